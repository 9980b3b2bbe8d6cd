//! GLB export with a per-vertex `_CURVATURE` attribute.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use gltf::json;
use json::validation::Checked::Valid;
use json::validation::USize64;
use thiserror::Error;

use super::Mesh;

/// The custom attribute name for the signed mean curvature in mm⁻¹ (glTF requires custom
/// attribute names to start with `_`). Its accessor is also named `curvature_per_mm`.
pub const CURVATURE_ATTRIBUTE: &str = "_CURVATURE";

/// Why a mesh could not be exported; the underlying cause, if any, is the error's
/// [`source`](std::error::Error::source).
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ExportError {
    /// An attribute array does not have one entry per vertex.
    #[error("{attribute} has {found} entries for {vertices} vertices")]
    AttributeLength {
        /// `"normals"`, `"uvs"` or `"curvature"`.
        attribute: &'static str,
        /// Entries in the array.
        found: usize,
        /// Vertices in the mesh.
        vertices: usize,
    },
    /// A triangle refers to a vertex that does not exist.
    #[error("triangle {triangle} refers to vertex {index}, but the mesh has {vertices} vertices")]
    IndexOutOfRange {
        /// The triangle.
        triangle: usize,
        /// The offending index.
        index: u32,
        /// Vertices in the mesh.
        vertices: usize,
    },
    /// The GLB would exceed the format's 4 GiB limit.
    #[error("the GLB would be {bytes} bytes, over the format's 4 GiB limit")]
    TooLarge {
        /// The size it would have.
        bytes: u64,
    },
    /// The glTF JSON could not be encoded.
    #[error("cannot encode the glTF JSON")]
    Json(#[source] json::Error),
    /// The GLB container could not be assembled.
    #[error("cannot assemble the GLB")]
    Glb(#[source] gltf::Error),
    /// Writing the file failed (nothing was left at the destination).
    #[error("{}: cannot write", path.display())]
    Io {
        /// The destination.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
}

/// Writes `mesh` as a GLB file with `POSITION` (with min/max), `NORMAL`, `TEXCOORD_0` (when
/// present), [`CURVATURE_ATTRIBUTE`] (scalar float, one per vertex) and `u32` indices.
///
/// The file is written atomically: to a temporary file in the same directory, synced, then
/// renamed over `path`. On error nothing is left behind and an existing file is untouched.
///
/// # Errors
/// See [`glb_bytes_with_curvature`]; [`ExportError::Io`] if the file cannot be written.
pub fn write_glb_with_curvature(
    path: impl AsRef<Path>,
    mesh: &Mesh,
    curvature_per_mm: &[f32],
) -> Result<(), ExportError> {
    let path = path.as_ref();
    let bytes = glb_bytes_with_curvature(mesh, curvature_per_mm)?;
    let io_error = |source| ExportError::Io {
        path: path.to_owned(),
        source,
    };
    crate::atomic::write_file(path, |file| file.write_all(&bytes)).map_err(io_error)
}

/// The GLB bytes that [`write_glb_with_curvature`] writes.
///
/// # Errors
/// [`ExportError::AttributeLength`] if `normals`, `uvs` or `curvature_per_mm` do not have one
/// entry per vertex, [`ExportError::IndexOutOfRange`] for a bad triangle,
/// [`ExportError::TooLarge`] past 4 GiB.
pub fn glb_bytes_with_curvature(
    mesh: &Mesh,
    curvature_per_mm: &[f32],
) -> Result<Vec<u8>, ExportError> {
    let vertices = mesh.positions.len();
    let check = |attribute, found| {
        if found == vertices {
            Ok(())
        } else {
            Err(ExportError::AttributeLength {
                attribute,
                found,
                vertices,
            })
        }
    };
    check("normals", mesh.normals.len())?;
    if let Some(uvs) = &mesh.uvs {
        check("uvs", uvs.len())?;
    }
    check("curvature", curvature_per_mm.len())?;
    for (triangle, t) in mesh.triangles.iter().enumerate() {
        if let Some(&index) = t.iter().find(|&&i| i as usize >= vertices) {
            return Err(ExportError::IndexOutOfRange {
                triangle,
                index,
                vertices,
            });
        }
    }

    let mut builder = Builder::new();
    let (mut min, mut max) = (glam::Vec3::INFINITY, glam::Vec3::NEG_INFINITY);
    for &p in &mesh.positions {
        min = min.min(p);
        max = max.max(p);
    }
    let mut attributes = BTreeMap::new();
    let positions = builder.float_accessor(
        mesh.positions.iter().flat_map(|p| p.to_array()),
        json::accessor::Type::Vec3,
        None,
    );
    builder.root.accessors[positions.value()].min =
        Some(json::Value::from(min.to_array().to_vec()));
    builder.root.accessors[positions.value()].max =
        Some(json::Value::from(max.to_array().to_vec()));
    attributes.insert(Valid(json::mesh::Semantic::Positions), positions);
    let normals = builder.float_accessor(
        mesh.normals.iter().flat_map(|n| n.to_array()),
        json::accessor::Type::Vec3,
        None,
    );
    attributes.insert(Valid(json::mesh::Semantic::Normals), normals);
    if let Some(uvs) = &mesh.uvs {
        let uvs = builder.float_accessor(
            uvs.iter().flat_map(|t| t.to_array()),
            json::accessor::Type::Vec2,
            None,
        );
        attributes.insert(Valid(json::mesh::Semantic::TexCoords(0)), uvs);
    }
    let curvature = builder.float_accessor(
        curvature_per_mm.iter().copied(),
        json::accessor::Type::Scalar,
        Some("curvature_per_mm"),
    );
    attributes.insert(
        Valid(json::mesh::Semantic::Extras(
            CURVATURE_ATTRIBUTE.trim_start_matches('_').to_owned(),
        )),
        curvature,
    );
    let indices = builder.index_accessor(mesh.triangles.iter().flatten().copied());
    let Builder {
        mut root,
        bin,
        buffer,
    } = builder;
    root.buffers[buffer.value()].byte_length = USize64::from(bin.len());

    let mesh_index = root.push(json::Mesh {
        extensions: None,
        extras: Default::default(),
        name: Some("cdrf".to_owned()),
        primitives: vec![json::mesh::Primitive {
            attributes,
            extensions: None,
            extras: Default::default(),
            indices: Some(indices),
            material: None,
            mode: Valid(json::mesh::Mode::Triangles),
            targets: None,
        }],
        weights: None,
    });
    let node = root.push(json::Node {
        mesh: Some(mesh_index),
        ..Default::default()
    });
    let scene = root.push(json::Scene {
        extensions: None,
        extras: Default::default(),
        name: None,
        nodes: vec![node],
    });
    root.scene = Some(scene);

    let json_bytes = root.to_vec().map_err(ExportError::Json)?;
    let total = 12 + 8 + json_bytes.len().next_multiple_of(4) + 8 + bin.len().next_multiple_of(4);
    if u32::try_from(total).is_err() {
        return Err(ExportError::TooLarge {
            bytes: total as u64,
        });
    }
    let glb = gltf::binary::Glb {
        header: gltf::binary::Header {
            magic: *b"glTF",
            version: 2,
            length: total as u32,
        },
        json: Cow::Owned(json_bytes),
        bin: Some(Cow::Owned(bin)),
    };
    glb.to_vec().map_err(ExportError::Glb)
}

/// Accumulates the binary chunk and the JSON objects that describe it.
struct Builder {
    root: json::Root,
    bin: Vec<u8>,
    buffer: json::Index<json::Buffer>,
}

impl Builder {
    fn new() -> Self {
        let mut root = json::Root::default();
        root.asset.generator = Some(format!("cdrf-core {}", env!("CARGO_PKG_VERSION")));
        let buffer = root.push(json::Buffer {
            byte_length: USize64(0), // set once everything is appended
            extensions: None,
            extras: Default::default(),
            name: None,
            uri: None,
        });
        Self {
            root,
            bin: Vec::new(),
            buffer,
        }
    }

    /// Appends 4-byte values as one tightly packed buffer view (so every view stays 4-byte
    /// aligned) and returns the view.
    fn view(
        &mut self,
        words: impl Iterator<Item = [u8; 4]>,
        target: json::buffer::Target,
    ) -> json::Index<json::buffer::View> {
        let offset = self.bin.len();
        words.for_each(|w| self.bin.extend_from_slice(&w));
        self.root.push(json::buffer::View {
            buffer: self.buffer,
            byte_length: USize64::from(self.bin.len() - offset),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: None,
            extensions: None,
            extras: Default::default(),
            name: None,
            target: Some(Valid(target)),
        })
    }

    fn accessor(
        &mut self,
        view: json::Index<json::buffer::View>,
        count: usize,
        component_type: json::accessor::ComponentType,
        type_: json::accessor::Type,
        name: Option<&str>,
    ) -> json::Index<json::Accessor> {
        self.root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64::from(count),
            component_type: Valid(json::accessor::GenericComponentType(component_type)),
            extensions: None,
            extras: Default::default(),
            type_: Valid(type_),
            min: None,
            max: None,
            name: name.map(str::to_owned),
            normalized: false,
            sparse: None,
        })
    }

    fn float_accessor(
        &mut self,
        floats: impl Iterator<Item = f32>,
        type_: json::accessor::Type,
        name: Option<&str>,
    ) -> json::Index<json::Accessor> {
        let start = self.bin.len();
        let view = self.view(
            floats.map(f32::to_le_bytes),
            json::buffer::Target::ArrayBuffer,
        );
        let count = (self.bin.len() - start) / (4 * type_.multiplicity());
        self.accessor(view, count, json::accessor::ComponentType::F32, type_, name)
    }

    fn index_accessor(
        &mut self,
        indices: impl Iterator<Item = u32>,
    ) -> json::Index<json::Accessor> {
        let start = self.bin.len();
        let view = self.view(
            indices.map(u32::to_le_bytes),
            json::buffer::Target::ElementArrayBuffer,
        );
        let count = (self.bin.len() - start) / 4;
        self.accessor(
            view,
            count,
            json::accessor::ComponentType::U32,
            json::accessor::Type::Scalar,
            None,
        )
    }
}
