//! What a renderer draws a loaded mesh with besides its geometry: materials (base colour, normal
//! and roughness textures), the primitives that use them (one draw each) and vertex tangents.
//!
//! [`Mesh::load_with_surfaces`](super::Mesh::load_with_surfaces) returns these beside the
//! [`RepairedMesh`](super::RepairedMesh); [`Mesh::load`](super::Mesh::load) reads none of it
//! (no image is decoded there).
//!
//! # Colour spaces and conventions (glTF 2.0)
//! - `base_color_factor` is **linear**; the base colour texture is **sRGB-encoded** 8-bit
//!   (decode it, e.g. with an `Rgba8UnormSrgb` texture, before multiplying). In cdrf the base
//!   colour is a *tint* of the measured response: white (`[1, 1, 1, 1]` and no texture) is the
//!   measured material itself.
//! - The normal texture is **linear**, tangent space: `n = normalize((2·rgb − 1) · (scale, scale,
//!   1))` in the frame (tangent, bitangent, normal), +X along +u, +Y *up in the image* (along
//!   −v, glTF's `v` points down).
//! - The metallic-roughness texture is **linear**; roughness is its G channel, multiplied by
//!   `roughness_factor` (perceptual roughness, as glTF defines it).
//! - Tangents: `xyz` is a unit vector orthogonal to the vertex normal, `w = ±1`, and the
//!   bitangent is `cross(normal, tangent.xyz) · w` (glTF's `TANGENT`).
//! - Only `TEXCOORD_0` is supported: a texture on another set is ignored with a warning
//!   ([`MeshSurfaces::warnings`]), as is every texture when the mesh has no UVs.
//!   `KHR_texture_transform` and the other material extensions are ignored (with a warning
//!   when the file lists them as used); samplers' filters are ignored, their wrap modes kept.

use std::ops::Range;

use glam::{Vec3, Vec4};

use super::Mesh;

/// A decoded texture image: 8 bits per channel, RGBA, rows top to bottom (glTF's UV origin is
/// the image's top-left corner).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TextureImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width × height` pixels, row-major from the top-left. Grey, grey-alpha and RGB images
    /// are expanded (alpha 255); 16-bit images are reduced to 8 bits.
    pub rgba8: Vec<[u8; 4]>,
    /// How the glTF texture's sampler wraps `u` and `v` (`wrapS`, `wrapT`).
    pub wrap: [TextureWrap; 2],
}

impl TextureImage {
    /// The pixel at column `x`, row `y` (0 = top), or `None` outside the image.
    pub fn pixel(&self, x: u32, y: u32) -> Option<[u8; 4]> {
        (x < self.width && y < self.height)
            .then(|| self.rgba8[y as usize * self.width as usize + x as usize])
    }
}

/// A sampler's wrap mode along one texture axis.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum TextureWrap {
    /// The texture repeats (glTF's default).
    #[default]
    Repeat,
    /// Coordinates are clamped to the edge texels.
    ClampToEdge,
    /// The texture repeats, mirrored every other time.
    MirroredRepeat,
}

/// A tangent-space normal texture and its strength.
#[derive(Clone, Debug, PartialEq)]
pub struct NormalTexture {
    /// The image (linear, tangent-space normals in RGB).
    pub image: TextureImage,
    /// glTF's `normalTexture.scale`: multiplies the X and Y of the decoded normal.
    pub scale: f32,
}

/// One material of a loaded mesh (glTF's metallic-roughness material, the parts cdrf uses).
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceMaterial {
    /// The glTF material's name.
    pub name: Option<String>,
    /// The glTF material's index in the file; `None` for the default material (primitives
    /// without a material, OBJ files).
    pub source_index: Option<usize>,
    /// Linear RGBA multiplier of the measured response (and of the texture); white = the
    /// measured material.
    pub base_color_factor: [f32; 4],
    /// sRGB-encoded base colour, multiplied by `base_color_factor` (on `TEXCOORD_0`).
    pub base_color_texture: Option<TextureImage>,
    /// Tangent-space normal map (on `TEXCOORD_0`).
    pub normal_texture: Option<NormalTexture>,
    /// Perceptual roughness of the specular layer, multiplied by the texture's G channel.
    pub roughness_factor: f32,
    /// Linear texture whose G channel is roughness (B, metalness, is not used by cdrf).
    pub metallic_roughness_texture: Option<TextureImage>,
}

impl Default for SurfaceMaterial {
    /// glTF's default material: white, roughness 1, no textures.
    fn default() -> Self {
        Self {
            name: None,
            source_index: None,
            base_color_factor: [1.0; 4],
            base_color_texture: None,
            normal_texture: None,
            roughness_factor: 1.0,
            metallic_roughness_texture: None,
        }
    }
}

/// A run of triangles drawn with one material: one glTF primitive instance (one draw).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SurfacePrimitive {
    /// The triangles, a contiguous range of [`Mesh::triangles`].
    pub triangles: Range<u32>,
    /// Index into [`MeshSurfaces::materials`].
    pub material: usize,
}

/// Materials, primitives and tangents of a loaded mesh (see the [module docs](self)).
///
/// Invariants: `primitives` are non-empty, in order, and cover `0..mesh.triangles.len()`
/// exactly once; every `material` index is in range; `tangents`, when present, has one entry
/// per vertex of the mesh.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshSurfaces {
    /// The materials the primitives use, in order of first use.
    pub materials: Vec<SurfaceMaterial>,
    /// The draws, in triangle order.
    pub primitives: Vec<SurfacePrimitive>,
    /// Unit tangents with handedness in `w`, one per vertex: the file's `TANGENT` when every
    /// primitive has one, else computed with MikkTSpace when a material has a normal texture
    /// and the mesh has UVs, else `None`.
    pub tangents: Option<Vec<Vec4>>,
    /// What was ignored (textures on `TEXCOORD_1`, extensions), one sentence each.
    pub warnings: Vec<String>,
}

impl MeshSurfaces {
    /// One primitive over all of `mesh`'s triangles with the default material, no tangents
    /// (what an OBJ file gives).
    pub fn single(mesh: &Mesh) -> Self {
        Self {
            materials: vec![SurfaceMaterial::default()],
            primitives: vec![SurfacePrimitive {
                triangles: 0..mesh.triangles.len() as u32,
                material: 0,
            }],
            tangents: None,
            warnings: Vec::new(),
        }
    }
}

/// Groups `mesh`'s triangles by `primitive_of_triangle` (one tag per triangle; triangles of a
/// tag keep their order, tags in increasing order) and returns the ranges, skipping tags with
/// no triangle. `material_of_primitive` maps a tag to its material. Already grouped input (the
/// loaders' case) is left in place.
pub(super) fn group_primitives(
    mesh: &mut Mesh,
    primitive_of_triangle: &[u32],
    material_of_primitive: &[usize],
) -> Vec<SurfacePrimitive> {
    debug_assert_eq!(primitive_of_triangle.len(), mesh.triangles.len());
    let mut tags = primitive_of_triangle.to_vec();
    if !tags.is_sorted() {
        let mut order: Vec<u32> = (0..tags.len() as u32).collect();
        order.sort_by_key(|&t| tags[t as usize]); // stable
        mesh.triangles = order.iter().map(|&t| mesh.triangles[t as usize]).collect();
        tags = order.iter().map(|&t| tags[t as usize]).collect();
    }
    let mut primitives: Vec<SurfacePrimitive> = Vec::new();
    let mut start = 0usize;
    for end in 1..=tags.len() {
        if end == tags.len() || tags[end] != tags[start] {
            primitives.push(SurfacePrimitive {
                triangles: start as u32..end as u32,
                material: material_of_primitive[tags[start] as usize],
            });
            start = end;
        }
    }
    primitives
}

/// Makes every tangent unit length and orthogonal to its vertex normal (Gram–Schmidt), with
/// `w = ±1`; a tangent that is missing, non-finite or parallel to the normal is replaced by
/// some unit vector orthogonal to it (`w = 1`). Returns how many were replaced.
pub(super) fn orthonormalize_tangents(normals: &[Vec3], tangents: &mut [Vec4]) -> usize {
    let mut replaced = 0;
    for (n, t) in normals.iter().zip(tangents.iter_mut()) {
        let xyz = t.truncate();
        let projected = (xyz - *n * n.dot(xyz)).normalize_or_zero();
        let w = if t.w < 0.0 { -1.0 } else { 1.0 };
        *t = if projected != Vec3::ZERO && t.is_finite() {
            projected.extend(w)
        } else {
            replaced += 1;
            n.any_orthonormal_vector().extend(1.0)
        };
    }
    replaced
}

/// MikkTSpace tangents of `mesh` (which must have UVs) in glTF's convention.
///
/// MikkTSpace is given `(u, 1 − v)` — the texture coordinates with `v` up, as in the tools
/// that bake normal maps (Blender computes them there and flips `v` on glTF export) — so that
/// its bitangent `cross(n, t) · w` points up in the image, +Y of glTF's normal textures. A
/// vertex shared by faces that MikkTSpace splits (mirrored UVs on one vertex) gets the
/// average of its faces' tangents and the majority's sign.
pub(super) fn mikktspace_tangents(mesh: &Mesh) -> Option<Vec<Vec4>> {
    let uvs = mesh.uvs.as_ref()?;
    struct Geometry<'a> {
        mesh: &'a Mesh,
        uvs: &'a [glam::Vec2],
        sums: Vec<Vec4>,
    }
    impl Geometry<'_> {
        fn vertex(&self, face: usize, vert: usize) -> usize {
            self.mesh.triangles[face][vert] as usize
        }
    }
    impl bevy_mikktspace::Geometry for Geometry<'_> {
        fn num_faces(&self) -> usize {
            self.mesh.triangles.len()
        }
        fn num_vertices_of_face(&self, _face: usize) -> usize {
            3
        }
        fn position(&self, face: usize, vert: usize) -> [f32; 3] {
            self.mesh.positions[self.vertex(face, vert)].to_array()
        }
        fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
            self.mesh.normals[self.vertex(face, vert)].to_array()
        }
        fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
            let uv = self.uvs[self.vertex(face, vert)];
            [uv.x, 1.0 - uv.y]
        }
        fn set_tangent(
            &mut self,
            tangent_space: Option<bevy_mikktspace::TangentSpace>,
            face: usize,
            vert: usize,
        ) {
            if let Some(space) = tangent_space {
                let v = self.vertex(face, vert);
                let [x, y, z, w] = space.tangent_encoded();
                self.sums[v] += Vec4::new(x, y, z, w);
            }
        }
    }
    let mut geometry = Geometry {
        mesh,
        uvs,
        sums: vec![Vec4::ZERO; mesh.positions.len()],
    };
    // Fails only for meshes without faces, which a repaired mesh never is.
    bevy_mikktspace::generate_tangents(&mut geometry).ok()?;
    let mut tangents = geometry.sums;
    orthonormalize_tangents(&mesh.normals, &mut tangents);
    Some(tangents)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;

    fn quad() -> Mesh {
        // Unit square in the xy plane facing +z, u along +x, v (down) along −y.
        Mesh {
            positions: vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
            ],
            normals: vec![Vec3::Z; 4],
            uvs: Some(vec![
                Vec2::new(0.0, 1.0),
                Vec2::new(1.0, 1.0),
                Vec2::new(1.0, 0.0),
                Vec2::new(0.0, 0.0),
            ]),
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    #[test]
    fn mikktspace_follows_gltf_uv_convention() {
        let tangents = mikktspace_tangents(&quad()).unwrap();
        for t in tangents {
            // Tangent along +u = +x; bitangent cross(z, x)·w = +y·w must point up the image
            // (−v = +y here), so w = +1.
            assert!((t - Vec4::new(1.0, 0.0, 0.0, 1.0)).length() < 1e-5, "{t}");
        }
        // Mirror u: the tangent flips and so must the handedness, keeping the bitangent +y.
        let mut mirrored = quad();
        for uv in mirrored.uvs.as_mut().unwrap() {
            uv.x = 1.0 - uv.x;
        }
        for t in mikktspace_tangents(&mirrored).unwrap() {
            assert!((t - Vec4::new(-1.0, 0.0, 0.0, -1.0)).length() < 1e-5, "{t}");
        }
    }

    #[test]
    fn grouping_reorders_only_when_needed() {
        let mut mesh = quad();
        mesh.triangles = vec![[0, 1, 2], [0, 2, 3], [1, 2, 3]];
        let primitives = group_primitives(&mut mesh, &[1, 0, 1], &[5, 7]);
        assert_eq!(mesh.triangles, vec![[0, 2, 3], [0, 1, 2], [1, 2, 3]]);
        assert_eq!(
            primitives,
            vec![
                SurfacePrimitive {
                    triangles: 0..1,
                    material: 5
                },
                SurfacePrimitive {
                    triangles: 1..3,
                    material: 7
                },
            ]
        );
        let before = mesh.triangles.clone();
        let primitives = group_primitives(&mut mesh, &[0, 0, 2], &[1, 2, 3]);
        assert_eq!(mesh.triangles, before);
        assert_eq!(primitives.len(), 2);
        assert_eq!(primitives[1].material, 3);
    }

    #[test]
    fn tangents_are_orthonormalized() {
        let normals = [Vec3::Z, Vec3::Z, Vec3::X];
        let mut tangents = [
            Vec4::new(2.0, 0.0, 1.0, -0.5),
            Vec4::new(0.0, 0.0, 3.0, 1.0),
            Vec4::new(f32::NAN, 0.0, 0.0, 1.0),
        ];
        assert_eq!(orthonormalize_tangents(&normals, &mut tangents), 2);
        assert_eq!(tangents[0], Vec4::new(1.0, 0.0, 0.0, -1.0));
        for (t, n) in tangents.iter().zip(normals) {
            assert!((t.truncate().length() - 1.0).abs() < 1e-6);
            assert!(t.truncate().dot(n).abs() < 1e-6);
            assert!(t.w.abs() == 1.0);
        }
    }
}
