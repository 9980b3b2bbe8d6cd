//! Triangle meshes: one [`Mesh`] type loaded from OBJ or glTF 2.0 / GLB, checked and repaired,
//! welded for topology, and written back as GLB with a per-vertex curvature attribute.
//! [`Mesh::load_with_surfaces`] also returns the file's materials, textures, primitives and
//! tangents ([`surface`]).
//!
//! ```
//! use cdrf_core::mesh::Mesh;
//!
//! // A unit icosphere (vertices exactly on the sphere, outward normals).
//! let sphere = Mesh::icosphere(1.0, 2);
//! assert_eq!(sphere.positions.len(), 162);
//! assert_eq!(sphere.triangles.len(), 320);
//! // Topology view: here nothing to weld, every corner already shares its vertex.
//! let welded = sphere.weld();
//! assert_eq!(welded.positions.len(), 162);
//! ```
//!
//! # Vertices, seams and welding
//! A [`Mesh`] is a *render* mesh: a vertex is a unique (position, normal, uv) combination, so a
//! point on a UV seam or a hard edge appears as several vertices with the same position. Anything
//! that needs the surface's connectivity (vertex normals, curvature) works on the
//! [`Welded`] view instead, where vertices with **bit-identical positions** (after turning
//! `-0.0` into `0.0`) are merged. Exact equality is deliberate: exporters that split vertices
//! at seams copy the position, so exact matching finds every seam without merging distinct
//! nearby points of a fine mesh (no tolerance to tune).
//!
//! # Repairs
//! Meshes from files are checked before use ([`Mesh::from_data`]): vertices with NaN/Inf
//! coordinates, triangles with an out-of-range index, degenerate triangles (a repeated index or
//! zero area) and unreferenced vertices are removed and counted in a [`RepairReport`] instead of
//! panicking later; normals that are missing, non-finite or zero are computed. Only when no
//! triangle survives is it an error ([`MeshError::NoUsableTriangles`]).
//!
//! # Conventions
//! Positions are in the file's units (see `mm_per_unit` in [`crate::curvature`]); triangles wind
//! counter-clockwise seen from outside, so face normals `(p1 − p0) × (p2 − p0)` point outward;
//! normals are unit length; UVs follow glTF (origin at the image's top-left, `v` down), the OBJ
//! loader flips `v`.

mod adjacency;
mod export;
mod gltf_load;
mod gltf_material;
mod load;
mod obj;
mod repair;
mod shapes;
pub mod surface;
mod weld;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

pub(crate) use adjacency::VertexFaces;
pub use export::{
    CURVATURE_ATTRIBUTE, ExportError, glb_bytes_with_curvature, write_glb_with_curvature,
};
pub use load::LoadError;
pub use repair::{MeshError, RepairReport};
pub use surface::{
    MeshSurfaces, NormalTexture, SurfaceMaterial, SurfacePrimitive, TextureImage, TextureWrap,
};
pub use weld::Welded;

/// An indexed triangle mesh, ready to render: one normal (and optionally one UV) per vertex.
///
/// Invariants after [`Mesh::from_data`] or [`Mesh::load`]: every position is finite, every
/// triangle has three distinct in-range indices and non-zero area, every vertex is referenced,
/// `normals` has one unit vector per vertex and `uvs`, when present, one entry per vertex. The
/// fields are public (plain data, like glam's types); functions that rely on an invariant check
/// it and return an error rather than panic.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions, in the file's units.
    pub positions: Vec<Vec3>,
    /// Unit vertex normals, one per vertex.
    pub normals: Vec<Vec3>,
    /// Texture coordinates (glTF convention: `v` points down), one per vertex, if the source had
    /// them.
    pub uvs: Option<Vec<Vec2>>,
    /// Triangles as indices into the vertex arrays, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
}

/// Unchecked mesh data, as a loader or a generator produces it: the input of
/// [`Mesh::from_data`].
///
/// Anything may be wrong with it: NaN positions, out-of-range indices, attribute arrays of the
/// wrong length (they are dropped and reported).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshData {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Vertex normals, if known. An exactly zero entry means "missing here" and is computed;
    /// a non-finite one is invalid: computed and counted in the report.
    pub normals: Option<Vec<Vec3>>,
    /// Texture coordinates (glTF convention), if known.
    pub uvs: Option<Vec<Vec2>>,
    /// Triangles; indices may be out of range.
    pub triangles: Vec<[u32; 3]>,
}

/// A checked mesh together with what was repaired to make it valid.
#[derive(Clone, Debug, PartialEq)]
pub struct RepairedMesh {
    /// The valid mesh.
    pub mesh: Mesh,
    /// What was removed or computed.
    pub report: RepairReport,
}

impl Mesh {
    /// Checks and repairs `data` into a valid mesh (see the [module docs](self#repairs)).
    ///
    /// # Errors
    /// [`MeshError::NoUsableTriangles`] when no valid triangle remains.
    pub fn from_data(data: MeshData) -> Result<RepairedMesh, MeshError> {
        repair::repair(data)
    }

    /// [`Mesh::from_data`] for bare positions and triangles: normals are computed, no UVs.
    ///
    /// # Errors
    /// [`MeshError::NoUsableTriangles`] when no valid triangle remains.
    pub fn from_triangles(
        positions: Vec<Vec3>,
        triangles: Vec<[u32; 3]>,
    ) -> Result<RepairedMesh, MeshError> {
        Self::from_data(MeshData {
            positions,
            normals: None,
            uvs: None,
            triangles,
        })
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// The topology view: vertices with bit-identical positions merged (see the
    /// [module docs](self#vertices-seams-and-welding)).
    pub fn weld(&self) -> Welded {
        Welded::from_triangles(&self.positions, &self.triangles)
    }

    /// Replaces every normal by the angle-weighted average of the incident face normals over the
    /// welded topology (so seams stay smooth).
    pub fn compute_normals(&mut self) {
        let welded = self.weld();
        self.normals = smooth_normals(&self.positions, &self.triangles, &welded);
    }
}

/// Angle-weighted vertex normals (Thürmer & Wüthrich 1998) over the welded topology, mapped back
/// to the mesh vertices. Vertices where the welded normals cancel (a two-sided sheet welded onto
/// itself) fall back to the unwelded topology, then to the first incident face's normal; a
/// vertex with no non-degenerate incident face gets `+z`, so the result is always unit length.
pub(crate) fn smooth_normals(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    welded: &Welded,
) -> Vec<Vec3> {
    let welded_normals = angle_weighted_normals(&welded.positions, &welded.triangles);
    let normals = welded.to_mesh_vertices(&welded_normals);
    if !normals.contains(&Vec3::ZERO) {
        return normals;
    }
    let unwelded = VertexFaces::new(positions.len(), triangles);
    normals
        .into_par_iter()
        .enumerate()
        .map(|(v, n)| {
            if n != Vec3::ZERO {
                return n;
            }
            let faces = unwelded.faces_of(v);
            let own = vertex_normal(v, faces, positions, triangles).normalize_or_zero();
            if own != Vec3::ZERO {
                return own;
            }
            faces
                .iter()
                .map(|&f| face_normal(positions, triangles[f as usize]).normalize_or_zero())
                .find(|n| *n != Vec3::ZERO)
                .unwrap_or(Vec3::Z)
        })
        .collect()
}

/// Angle-weighted unit normals per vertex of `triangles`; zero where nothing contributes.
fn angle_weighted_normals(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let adjacency = VertexFaces::new(positions.len(), triangles);
    (0..positions.len())
        .into_par_iter()
        .map(|v| vertex_normal(v, adjacency.faces_of(v), positions, triangles).normalize_or_zero())
        .collect()
}

/// Σ over `faces` of (corner angle at `v`) × (unit face normal), unnormalised.
fn vertex_normal(v: usize, faces: &[u32], positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec3 {
    let mut sum = glam::DVec3::ZERO;
    for &f in faces {
        let t = triangles[f as usize];
        let Some(corner) = t.iter().position(|&i| i as usize == v) else {
            continue;
        };
        let p = positions[v].as_dvec3();
        let a = positions[t[(corner + 1) % 3] as usize].as_dvec3() - p;
        let b = positions[t[(corner + 2) % 3] as usize].as_dvec3() - p;
        let n = a.cross(b);
        let len = n.length();
        if len > 0.0 && a != glam::DVec3::ZERO && b != glam::DVec3::ZERO {
            sum += n / len * a.angle_between(b);
        }
    }
    sum.as_vec3()
}

/// Unnormalised face normal `(p1 − p0) × (p2 − p0)`.
fn face_normal(positions: &[Vec3], t: [u32; 3]) -> Vec3 {
    let [p0, p1, p2] = t.map(|i| positions[i as usize]);
    (p1 - p0).cross(p2 - p0)
}
