//! Meshes on the GPU: what the host hands over and what the renderer keeps.

use cdrf_core::Mesh;
use cdrf_core::glam::{Vec2, Vec3, Vec4};
use cdrf_core::patches::SurfacePatches;
use wgpu::util::DeviceExt;

use crate::error::MeshUploadError;
use crate::gpu_types::{GpuPatch, GpuPatchMember, GpuVertex};
use crate::pipelines::runs_vertex_terms;

/// A mesh to upload, as slices of the host's own vertex data: triangles with per-vertex
/// normals and mean curvature, and for textured drawing UVs and tangents.
/// [`MeshDesc::from_mesh`] builds one from a [`cdrf_core::Mesh`].
#[derive(Clone, Copy, Debug)]
pub struct MeshDesc<'a> {
    /// Vertex positions, model units.
    pub positions: &'a [Vec3],
    /// Unit normals, one per position.
    pub normals: &'a [Vec3],
    /// Signed mean curvature per vertex in mm⁻¹, of the mesh as it is in model units (e.g.
    /// `cdrf_core::mean_curvature_per_mm` with the mesh's mm-per-unit). A draw's model
    /// transform rescales it: an object drawn twice as large has half the curvature.
    pub curvature_per_mm: &'a [f32],
    /// The curvature's anisotropy per vertex in mm⁻¹, model frame
    /// ([`cdrf_core::Curvature::anisotropy_per_mm`]): the table is then read at the curvature
    /// along each light's direction (for the first four lights). `None`: the mean curvature in
    /// every direction.
    pub curvature_anisotropy_per_mm: Option<&'a [Vec3]>,
    /// Triangles: three indices into the vertices each, counter-clockwise seen from outside.
    pub indices: &'a [u32],
    /// Texture coordinates, one per position (glTF's `TEXCOORD_0`: `v` down the image); `None`:
    /// textures read their top-left texel.
    pub uvs: Option<&'a [Vec2]>,
    /// Unit tangents along +u with the bitangent's sign in `w` (glTF's `TANGENT`), one per
    /// position; `None`: normal maps are ignored on this mesh.
    pub tangents: Option<&'a [Vec4]>,
    /// Whether [`Renderer::update_mesh`](crate::Renderer::update_mesh) may move its vertices
    /// (skinning, morph targets): the renderer then keeps a copy of the vertices (64 bytes
    /// each) to interleave the new ones with the attributes that stay.
    pub deforming: bool,
}

impl<'a> MeshDesc<'a> {
    /// The slices of a [`cdrf_core::Mesh`] (with its UVs, if any) and its per-vertex
    /// curvature; no tangents.
    pub fn from_mesh(mesh: &'a Mesh, curvature_per_mm: &'a [f32]) -> Self {
        Self {
            positions: &mesh.positions,
            normals: &mesh.normals,
            curvature_per_mm,
            curvature_anisotropy_per_mm: None,
            indices: mesh.triangles.as_flattened(),
            uvs: mesh.uvs.as_deref(),
            tangents: None,
            deforming: false,
        }
    }

    /// A mesh whose vertices move: see [`MeshDesc::deforming`](#structfield.deforming).
    pub fn deforming(self) -> Self {
        Self {
            deforming: true,
            ..self
        }
    }

    /// With the curvature's anisotropy (e.g. [`cdrf_core::Curvature::anisotropy_per_mm`]; an
    /// empty slice: none).
    pub fn with_curvature_anisotropy(self, anisotropy_per_mm: &'a [Vec3]) -> Self {
        Self {
            curvature_anisotropy_per_mm: (!anisotropy_per_mm.is_empty())
                .then_some(anisotropy_per_mm),
            ..self
        }
    }

    /// With tangents (e.g. [`MeshSurfaces::tangents`](cdrf_core::mesh::MeshSurfaces::tangents)).
    pub fn with_tangents(self, tangents: Option<&'a [Vec4]>) -> Self {
        Self { tangents, ..self }
    }

    fn validate(&self) -> Result<(), MeshUploadError> {
        let vertices = self.positions.len();
        if self.indices.is_empty() {
            return Err(MeshUploadError::Empty);
        }
        if !self.indices.len().is_multiple_of(3) {
            return Err(MeshUploadError::IndexCount {
                count: self.indices.len(),
            });
        }
        check_counts(
            vertices,
            [
                ("normals", Some(self.normals.len())),
                ("curvature values", Some(self.curvature_per_mm.len())),
                (
                    "curvature anisotropies",
                    self.curvature_anisotropy_per_mm.map(<[_]>::len),
                ),
                ("UVs", self.uvs.map(<[_]>::len)),
                ("tangents", self.tangents.map(<[_]>::len)),
            ],
        )?;
        if let Some((position, &index)) = self
            .indices
            .iter()
            .enumerate()
            .find(|(_, i)| **i as usize >= vertices)
        {
            return Err(MeshUploadError::IndexOutOfRange {
                position,
                index,
                vertices,
            });
        }
        if let Some((vertex, &value)) = self
            .curvature_per_mm
            .iter()
            .enumerate()
            .find(|(_, k)| !k.is_finite())
        {
            return Err(MeshUploadError::NonFiniteCurvature { vertex, value });
        }
        if self
            .curvature_anisotropy_per_mm
            .is_some_and(|a| a.iter().any(|a| !a.is_finite()))
        {
            return Err(MeshUploadError::NonFinite {
                what: "curvature anisotropy",
            });
        }
        let uvs_finite = self
            .uvs
            .is_none_or(|uvs| uvs.iter().all(|uv| uv.is_finite()));
        let tangents_finite = self
            .tangents
            .is_none_or(|tangents| tangents.iter().all(|t| t.is_finite()));
        if !uvs_finite || !tangents_finite {
            return Err(MeshUploadError::NonFinite {
                what: if uvs_finite { "tangent" } else { "UV" },
            });
        }
        Ok(())
    }
}

/// A deforming mesh's vertices this frame (e.g. after skinning), for
/// [`Renderer::update_mesh`](crate::Renderer::update_mesh): same count and order as at
/// creation, model units. The triangles, UVs and patches stay as created.
///
/// Curvature: `None` keeps the one the mesh was created with — the rest pose's, as FaceWorks
/// does; skinning mostly bends a body where it is already curved (docs/deforming.md measures
/// what that loses). `Some`: the host's own, e.g. recomputed on the posed mesh.
#[derive(Clone, Copy, Debug)]
pub struct MeshVertices<'a> {
    /// Vertex positions, model units.
    pub positions: &'a [Vec3],
    /// Unit normals.
    pub normals: &'a [Vec3],
    /// Tangents with the bitangent's sign in `w`; `None`: keep the created ones.
    pub tangents: Option<&'a [Vec4]>,
    /// Signed mean curvature, mm⁻¹; `None`: keep the created one.
    pub curvature_per_mm: Option<&'a [f32]>,
    /// The curvature's anisotropy, mm⁻¹, model frame; `None`: keep the created one.
    pub curvature_anisotropy_per_mm: Option<&'a [Vec3]>,
}

impl<'a> MeshVertices<'a> {
    /// New positions and normals; everything else as created.
    pub fn new(positions: &'a [Vec3], normals: &'a [Vec3]) -> Self {
        Self {
            positions,
            normals,
            tangents: None,
            curvature_per_mm: None,
            curvature_anisotropy_per_mm: None,
        }
    }

    fn validate(&self, vertices: usize) -> Result<(), MeshUploadError> {
        check_counts(
            vertices,
            [
                ("positions", Some(self.positions.len())),
                ("normals", Some(self.normals.len())),
                ("tangents", self.tangents.map(<[_]>::len)),
                ("curvature values", self.curvature_per_mm.map(<[_]>::len)),
                (
                    "curvature anisotropies",
                    self.curvature_anisotropy_per_mm.map(<[_]>::len),
                ),
            ],
        )?;
        let finite3 = |values: &[Vec3]| values.iter().all(|v| v.is_finite());
        for (what, finite) in [
            ("position", finite3(self.positions)),
            ("normal", finite3(self.normals)),
            (
                "tangent",
                self.tangents
                    .is_none_or(|t| t.iter().all(|t| t.is_finite())),
            ),
            (
                "curvature value",
                self.curvature_per_mm
                    .is_none_or(|k| k.iter().all(|k| k.is_finite())),
            ),
            (
                "curvature anisotropy",
                self.curvature_anisotropy_per_mm.is_none_or(finite3),
            ),
        ] {
            if !finite {
                return Err(MeshUploadError::NonFinite { what });
            }
        }
        Ok(())
    }
}

/// Checks that each given per-vertex slice (`Some(length)`) has one value per vertex.
fn check_counts<const N: usize>(
    vertices: usize,
    counts: [(&'static str, Option<usize>); N],
) -> Result<(), MeshUploadError> {
    match counts
        .into_iter()
        .find_map(|(what, found)| found.filter(|&found| found != vertices).map(|f| (what, f)))
    {
        Some((what, found)) => Err(MeshUploadError::AttributeCount {
            what,
            found,
            vertices,
        }),
        None => Ok(()),
    }
}

/// A mesh's buffers and bounds.
pub(crate) struct GpuMesh {
    pub(crate) vertices: wgpu::Buffer,
    pub(crate) indices: wgpu::Buffer,
    pub(crate) vertex_count: u32,
    pub(crate) index_count: u32,
    /// Bounding sphere in model units: centre and radius.
    pub(crate) bounds: (Vec3, f32),
    /// Its patches for the inter-reflection (where the device runs the compute passes).
    pub(crate) patches: Option<GpuPatches>,
    /// A deforming mesh's vertices as last uploaded.
    pub(crate) deforming: Option<Vec<GpuVertex>>,
}

impl GpuMesh {
    /// `patch_count`: about how many patches to cut it into for the inter-reflection.
    pub(crate) fn upload(
        device: &wgpu::Device,
        desc: &MeshDesc<'_>,
        patch_count: u32,
    ) -> Result<Self, MeshUploadError> {
        desc.validate()?;
        let vertices: Vec<GpuVertex> = (0..desc.positions.len())
            .map(|i| GpuVertex {
                position: desc.positions[i],
                normal: desc.normals[i],
                curvature_per_mm: desc.curvature_per_mm[i],
                curvature_anisotropy_per_mm: desc
                    .curvature_anisotropy_per_mm
                    .map_or(Vec3::ZERO, |a| a[i]),
                uv: desc.uvs.map_or(Vec2::ZERO, |uvs| uvs[i]),
                tangent: desc
                    .tangents
                    .map_or([0.0; 4], |tangents| tangents[i].to_array()),
            })
            .collect();
        Ok(Self {
            vertices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("cdrf mesh vertices"),
                contents: bytemuck::cast_slice(&vertices),
                // Storage: the vertex terms pass reads them too, where the device runs it.
                usage: wgpu::BufferUsages::VERTEX
                    | if runs_vertex_terms(&device.limits()) {
                        wgpu::BufferUsages::STORAGE
                    } else {
                        wgpu::BufferUsages::empty()
                    }
                    | if desc.deforming {
                        wgpu::BufferUsages::COPY_DST
                    } else {
                        wgpu::BufferUsages::empty()
                    },
            }),
            indices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("cdrf mesh indices"),
                contents: bytemuck::cast_slice(desc.indices),
                usage: wgpu::BufferUsages::INDEX,
            }),
            vertex_count: vertices.len() as u32,
            index_count: desc.indices.len() as u32,
            bounds: bounding_sphere(desc.positions),
            patches: runs_vertex_terms(&device.limits())
                .then(|| GpuPatches::upload(device, desc, patch_count))
                .flatten(),
            deforming: desc.deforming.then_some(vertices),
        })
    }

    /// Writes a deforming mesh's new vertices (see [`MeshVertices`]).
    pub(crate) fn update(
        &mut self,
        queue: &wgpu::Queue,
        new: &MeshVertices<'_>,
    ) -> Result<(), MeshUploadError> {
        let vertices = self
            .deforming
            .as_mut()
            .ok_or(MeshUploadError::NotDeforming)?;
        new.validate(vertices.len())?;
        for (i, vertex) in vertices.iter_mut().enumerate() {
            vertex.position = new.positions[i];
            vertex.normal = new.normals[i];
            if let Some(tangents) = new.tangents {
                vertex.tangent = tangents[i].to_array();
            }
            if let Some(curvature) = new.curvature_per_mm {
                vertex.curvature_per_mm = curvature[i];
            }
            if let Some(anisotropy) = new.curvature_anisotropy_per_mm {
                vertex.curvature_anisotropy_per_mm = anisotropy[i];
            }
        }
        queue.write_buffer(&self.vertices, 0, bytemuck::cast_slice(vertices));
        self.bounds = bounding_sphere(new.positions);
        Ok(())
    }
}

/// A mesh's patches on the GPU: the inter-reflection's emitters and receivers, cut once when
/// the mesh is uploaded.
pub(crate) struct GpuPatches {
    pub(crate) patches: wgpu::Buffer,
    pub(crate) members: wgpu::Buffer,
    pub(crate) count: u32,
}

impl GpuPatches {
    /// Cuts the mesh into about `target_count` patches and uploads them; `None` when it has
    /// none (a mesh without area, or a count of 0).
    pub(crate) fn upload(
        device: &wgpu::Device,
        desc: &MeshDesc<'_>,
        target_count: u32,
    ) -> Option<Self> {
        let cut = SurfacePatches::build(
            desc.positions,
            desc.normals,
            desc.curvature_per_mm,
            desc.indices,
            target_count as usize,
        );
        if cut.patches.is_empty() {
            return None;
        }
        let patches: Vec<GpuPatch> = cut
            .patches
            .iter()
            .map(|patch| GpuPatch {
                area: patch.area,
                curvature_per_mm: patch.curvature_per_mm,
                first_member: patch.first_member,
                member_count: patch.member_count,
            })
            .collect();
        let members: Vec<GpuPatchMember> = cut
            .members
            .iter()
            .map(|member| GpuPatchMember {
                vertex: member.vertex,
                weight: member.weight,
            })
            .collect();
        let storage = |label, contents: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        Some(Self {
            patches: storage("cdrf mesh patches", bytemuck::cast_slice(&patches)),
            members: storage("cdrf mesh patch members", bytemuck::cast_slice(&members)),
            count: patches.len() as u32,
        })
    }
}

/// A bounding sphere of `positions` (the box's centre and the farthest point from it).
fn bounding_sphere(positions: &[Vec3]) -> (Vec3, f32) {
    let (min, max) = positions.iter().fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    let centre = (min + max) * 0.5;
    let radius = positions
        .iter()
        .map(|p| p.distance(centre))
        .fold(0.0, f32::max);
    (centre, radius)
}
