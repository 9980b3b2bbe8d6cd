//! Loading a [`Mesh`] from a file: dispatch on the extension, one error type.

use std::path::{Path, PathBuf};

use thiserror::Error;

use super::{Mesh, MeshError, RepairedMesh};

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
        let extension = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let data = match extension.as_deref() {
            Some("obj") => super::obj::load(path)?,
            Some("gltf" | "glb") => super::gltf_load::load(path)?,
            _ => {
                return Err(LoadError::UnsupportedFormat {
                    path: path.to_owned(),
                });
            }
        };
        Self::from_data(data).map_err(|source| LoadError::Unusable {
            path: path.to_owned(),
            source,
        })
    }
}
