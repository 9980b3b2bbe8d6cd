//! Loading a [`Mesh`] from a file: dispatch on the extension, one error type.

use std::path::{Path, PathBuf};

use thiserror::Error;

use super::{Mesh, MeshError, MeshSurfaces, RepairedMesh, surface};

/// Why a mesh file could not be loaded. Every message names the file; the underlying cause,
/// if any, is the error's [`source`](std::error::Error::source) (print the chain).
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum LoadError {
    /// The extension is not `.obj`, `.gltf` or `.glb`.
    #[error("{}: unsupported mesh format (expected .obj, .gltf or .glb)", path.display())]
    UnsupportedFormat {
        /// The file.
        path: PathBuf,
    },
    /// The file (or a buffer file it references) could not be read.
    #[error("{}: cannot read", path.display())]
    Io {
        /// The file that could not be read.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// An OBJ file holds bytes that are not UTF-8 text outside a comment (a binary file?).
    #[error("{}: not UTF-8 text at line {line} (a binary file, or another encoding?)", path.display())]
    NotText {
        /// The file.
        path: PathBuf,
        /// The first such line, 1-based.
        line: usize,
    },
    /// The OBJ parser rejected the file.
    #[error("{}: invalid OBJ", path.display())]
    Obj {
        /// The file.
        path: PathBuf,
        /// The parser's error.
        source: tobj::LoadError,
    },
    /// An OBJ face line names a vertex, texture coordinate or normal that does not exist, or
    /// mixes vertex formats (`1/1/1` beside `2//2`).
    #[error("{}: line {line}: {problem}", path.display())]
    ObjFace {
        /// The file.
        path: PathBuf,
        /// The 1-based line.
        line: usize,
        /// What is wrong.
        problem: String,
    },
    /// The glTF parser or validator rejected the file.
    #[error("{}: invalid glTF", path.display())]
    Gltf {
        /// The file.
        path: PathBuf,
        /// The parser's error.
        source: gltf::Error,
    },
    /// The glTF parsed but its mesh data cannot be used (bad buffer, unsupported accessor…).
    #[error("{}: {problem}", path.display())]
    GltfData {
        /// The file.
        path: PathBuf,
        /// What is wrong, naming the glTF object.
        problem: String,
    },
    /// The file parsed but no valid triangle remains (empty, all NaN, all degenerate…).
    #[error("{}: no usable mesh", path.display())]
    Unusable {
        /// The file.
        path: PathBuf,
        /// What was wrong with the data.
        source: MeshError,
    },
}

impl Mesh {
    /// Loads an OBJ (`.obj`) or glTF 2.0 (`.gltf`, `.glb`) file and repairs it
    /// ([`Mesh::from_data`]).
    ///
    /// - **OBJ**: every object and group, polygons triangulated, points and lines ignored;
    ///   materials are not read. `vt` is flipped to the glTF convention (`v' = 1 − v`).
    ///   Vertices come in order of first use by the faces (the parser's order), one per
    ///   distinct `v/vt/vn` combination; `v` lines no face uses never reach the mesh.
    /// - **glTF**: every triangle primitive (lists, strips and fans) of every node of the default
    ///   scene (the first scene if none is marked default; every mesh untransformed if there is
    ///   no scene), with the node's world transform applied (normals with its inverse-transpose;
    ///   mirroring transforms keep outward winding). `TEXCOORD_0` is kept only if every primitive
    ///   has it. Images are never decoded. Buffers may be the GLB chunk, `data:` base64 URIs or
    ///   files relative to the glTF file **inside its own folder**: an absolute URI or one whose
    ///   `..` leaves the folder is an error, so a model from elsewhere cannot make a tool read
    ///   other files.
    ///
    /// # Limits
    /// Every file read (the mesh, a buffer file) must be a regular file of at most
    /// [`crate::input_file::MAX_INPUT_FILE_BYTES`] (1 GiB); a glTF may expand through node
    /// instancing to at most 2²⁴ vertices and 2²⁴ triangles, counted before anything is built.
    ///
    /// # Errors
    /// [`LoadError`], naming the file: unknown extension, unreadable file, parse failure,
    /// unsupported glTF data, or nothing usable after repair.
    pub fn load(path: impl AsRef<Path>) -> Result<RepairedMesh, LoadError> {
        let path = path.as_ref();
        let data = match Format::of(path)? {
            Format::Obj => super::obj::load(path)?,
            Format::Gltf => super::gltf_load::load(path)?,
        };
        Self::from_data(data).map_err(|source| LoadError::Unusable {
            path: path.to_owned(),
            source,
        })
    }

    /// [`Mesh::load`] with what a renderer needs to draw the mesh textured: its materials, one
    /// primitive (draw) per glTF primitive instance, and tangents (see [`MeshSurfaces`] and
    /// [`super::surface`] for colour spaces and conventions).
    ///
    /// The mesh is the one [`Mesh::load`] returns (same vertices, same triangles in the same
    /// order: the glTF loader emits each primitive's triangles together and the repair keeps
    /// their order, dropping a triangle from its primitive's range; a primitive left without
    /// triangles is not listed).
    ///
    /// - **OBJ**: one primitive, the default material, no tangents (`mtl` files are not read).
    /// - **glTF**: the materials the primitives use, with their textures decoded (PNG and JPEG;
    ///   see [`MeshSurfaces::warnings`] for what is ignored); `TANGENT` when every primitive
    ///   has it (re-orthonormalised against the final normals), otherwise MikkTSpace tangents
    ///   when a material has a normal texture and the mesh has UVs.
    ///
    /// # Limits
    /// Those of [`Mesh::load`]; every image must be at most
    /// [`crate::input_file::MAX_IMAGE_SIDE_PX`] per side and
    /// [`crate::input_file::MAX_IMAGE_PIXELS`] in all, read from its header before decoding.
    ///
    /// # Errors
    /// Those of [`Mesh::load`], and [`LoadError::GltfData`] naming the file, the material and
    /// the image for an image that is missing, unreadable, of another format, corrupt or too
    /// large; [`LoadError::Gltf`] for a texture, image or sampler index out of range.
    pub fn load_with_surfaces(
        path: impl AsRef<Path>,
    ) -> Result<(RepairedMesh, MeshSurfaces), LoadError> {
        let path = path.as_ref();
        let unusable = |source| LoadError::Unusable {
            path: path.to_owned(),
            source,
        };
        match Format::of(path)? {
            Format::Obj => {
                let repaired = Self::from_data(super::obj::load(path)?).map_err(unusable)?;
                let surfaces = MeshSurfaces::single(&repaired.mesh);
                Ok((repaired, surfaces))
            }
            Format::Gltf => {
                let (data, gltf) = super::gltf_load::load_with_surfaces(path)?;
                let (mut repaired, map) = super::repair::repair_mapped(data).map_err(unusable)?;
                let tags: Vec<u32> = map
                    .kept_triangles
                    .iter()
                    .map(|&t| gltf.primitive_of_triangle[t as usize])
                    .collect();
                let primitives = surface::group_primitives(
                    &mut repaired.mesh,
                    &tags,
                    &gltf.material_of_primitive,
                );
                let mesh = &repaired.mesh;
                let tangents = match gltf.tangents {
                    Some(read) => {
                        let mut tangents: Vec<_> = map
                            .kept_vertices
                            .iter()
                            .map(|&v| read[v as usize])
                            .collect();
                        surface::orthonormalize_tangents(&mesh.normals, &mut tangents);
                        Some(tangents)
                    }
                    None if gltf.materials.iter().any(|m| m.normal_texture.is_some()) => {
                        surface::mikktspace_tangents(mesh)
                    }
                    None => None,
                };
                Ok((
                    repaired,
                    MeshSurfaces {
                        materials: gltf.materials,
                        primitives,
                        tangents,
                        warnings: gltf.warnings,
                    },
                ))
            }
        }
    }
}

/// The mesh file formats, by extension.
enum Format {
    Obj,
    Gltf,
}

impl Format {
    fn of(path: &Path) -> Result<Self, LoadError> {
        let extension = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match extension.as_deref() {
            Some("obj") => Ok(Self::Obj),
            Some("gltf" | "glb") => Ok(Self::Gltf),
            _ => Err(LoadError::UnsupportedFormat {
                path: path.to_owned(),
            }),
        }
    }
}
