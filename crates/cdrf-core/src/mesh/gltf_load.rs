//! glTF 2.0 / GLB loading.
//!
//! The `gltf` crate parses and validates the JSON; buffers and accessors are read here, with
//! every offset, stride and length checked, so a malformed file is an error and never a panic
//! (the crate's own readers assume well-formed accessors). [`load`] never decodes an image;
//! [`load_with_surfaces`] also reads materials, textures (`gltf_material`) and tangents.

use std::path::Path;

use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;

use super::{LoadError, MeshData, SurfaceMaterial};

/// The deepest node hierarchy accepted (deeper usually means a cycle).
const MAX_NODE_DEPTH: usize = 256;
/// The most node instances visited (guards against shared-subtree explosions).
const MAX_NODE_INSTANCES: usize = 1 << 20;
/// The most vertices (and, separately, triangle corners / 3) after instancing: 2²⁴.
pub const MAX_MESH_VERTICES: usize = 1 << 24;

/// What [`load_with_surfaces`] reads beside the mesh data, indexed like the unchecked data.
#[derive(Debug, Default)]
pub(super) struct GltfSurfaces {
    /// One tag per triangle of the data: the primitive instance it came from.
    pub(super) primitive_of_triangle: Vec<u32>,
    /// Per primitive instance, its index into `materials`.
    pub(super) material_of_primitive: Vec<usize>,
    /// The materials the primitives use, in order of first use.
    pub(super) materials: Vec<SurfaceMaterial>,
    /// `TANGENT` per vertex of the data (world space, handedness flipped under mirroring), when
    /// every primitive has it.
    pub(super) tangents: Option<Vec<Vec4>>,
    /// What was ignored.
    pub(super) warnings: Vec<String>,
}

/// Reads the default scene's triangle primitives into unchecked [`MeshData`].
pub(super) fn load(path: &Path) -> Result<MeshData, LoadError> {
    read(path, false).map(|(data, _)| data)
}

/// [`load`], also reading the primitives' materials (decoding their images) and tangents.
pub(super) fn load_with_surfaces(path: &Path) -> Result<(MeshData, GltfSurfaces), LoadError> {
    read(path, true)
}

fn read(path: &Path, with_surfaces: bool) -> Result<(MeshData, GltfSurfaces), LoadError> {
    let data_error = |problem: String| LoadError::GltfData {
        path: path.to_owned(),
        problem,
    };
    let bytes = crate::input_file::read_regular(path, crate::input_file::MAX_INPUT_FILE_BYTES)
        .map_err(|source| LoadError::Io {
            path: path.to_owned(),
            source,
        })?;
    check_glb_header(&bytes).map_err(data_error)?;
    let gltf_error = |source| LoadError::Gltf {
        path: path.to_owned(),
        source,
    };
    let gltf::Gltf { document, blob } =
        gltf::Gltf::from_slice_without_validation(&bytes).map_err(gltf_error)?;
    drop(bytes);
    let root = document.into_json();
    // gltf-json 1.4.1's validator indexes the POSITION accessor before checking that it exists
    // (a panic on malformed files): check that first, then validate.
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            for accessor in primitive.attributes.values() {
                if accessor.value() >= root.accessors.len() {
                    return Err(data_error(format!(
                        "mesh {m} primitive {p} refers to accessor {}, but there are {}",
                        accessor.value(),
                        root.accessors.len()
                    )));
                }
            }
        }
    }
    let document = gltf::Document::from_json(root).map_err(gltf_error)?;
    let base = path.parent().unwrap_or(Path::new("."));
    let buffers = load_buffers(&document, blob, base, path)?;

    // (mesh, world transform) instances.
    let mut instances: Vec<(gltf::Mesh<'_>, Mat4)> = Vec::new();
    match document
        .default_scene()
        .or_else(|| document.scenes().next())
    {
        Some(scene) => {
            // Depth-first, in document order (children pushed in reverse).
            let mut stack: Vec<(gltf::Node<'_>, Mat4, usize)> =
                scene.nodes().map(|n| (n, Mat4::IDENTITY, 0)).collect();
            stack.reverse();
            let mut visited = 0usize;
            while let Some((node, parent, depth)) = stack.pop() {
                visited += 1;
                if depth > MAX_NODE_DEPTH || visited > MAX_NODE_INSTANCES {
                    return Err(data_error(format!(
                        "node hierarchy deeper than {MAX_NODE_DEPTH} levels or with more than \
                         {MAX_NODE_INSTANCES} node instances (a cycle?)"
                    )));
                }
                let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
                if let Some(mesh) = node.mesh() {
                    instances.push((mesh, world));
                }
                let first_child = stack.len();
                stack.extend(node.children().map(|c| (c, world, depth + 1)));
                stack[first_child..].reverse();
            }
        }
        None => instances.extend(document.meshes().map(|m| (m, Mat4::IDENTITY))),
    }

    // Count what instancing expands to before building anything.
    let (mut vertices, mut corners) = (0usize, 0usize);
    for (mesh, _) in &instances {
        for primitive in mesh.primitives() {
            if let Some(accessor) = primitive.get(&gltf::Semantic::Positions) {
                vertices = vertices.saturating_add(accessor.count());
                corners = corners.saturating_add(
                    primitive
                        .indices()
                        .map_or(accessor.count(), |indices| indices.count()),
                );
            }
        }
    }
    if vertices > MAX_MESH_VERTICES || corners / 3 > MAX_MESH_VERTICES {
        return Err(data_error(format!(
            "{} mesh instances expand to {vertices} vertices and {} triangles; the limit is \
             {MAX_MESH_VERTICES} of each (after node instancing)",
            instances.len(),
            corners / 3
        )));
    }

    let mut data = MeshData::default();
    let mut normals: Vec<Vec3> = Vec::new();
    let mut any_normals = false;
    let mut uvs: Vec<Vec2> = Vec::new();
    let mut all_uvs = true;
    let mut tangents: Vec<Vec4> = Vec::new();
    let mut all_tangents = with_surfaces;
    let mut surfaces = GltfSurfaces::default();
    // glTF material index (None: the default material) of each entry of `surfaces.materials`.
    let mut material_sources: Vec<Option<usize>> = Vec::new();
    for (mesh, world) in &instances {
        let normal_matrix = Mat3::from_mat4(*world).inverse().transpose();
        let mirrored = world.determinant() < 0.0;
        for primitive in mesh.primitives() {
            let label = format!("mesh {} primitive {}", mesh.index(), primitive.index());
            if !matches!(
                primitive.mode(),
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                continue;
            }
            let Some(position_accessor) = primitive.get(&gltf::Semantic::Positions) else {
                return Err(data_error(format!("{label} has no POSITION attribute")));
            };
            let positions = read_floats(&position_accessor, &buffers, Dimensions::Vec3, false)
                .map_err(|e| data_error(format!("{label} POSITION: {e}")))?;
            let count = positions.len() / 3;
            let base = data.positions.len();
            if u32::try_from(base + count).is_err() {
                return Err(data_error(format!(
                    "more than {} vertices in total",
                    u32::MAX
                )));
            }
            data.positions.extend(
                positions
                    .chunks_exact(3)
                    .map(|p| world.transform_point3(Vec3::new(p[0], p[1], p[2]))),
            );

            match primitive.get(&gltf::Semantic::Normals) {
                Some(accessor) => {
                    let n = read_floats(&accessor, &buffers, Dimensions::Vec3, false)
                        .map_err(|e| data_error(format!("{label} NORMAL: {e}")))?;
                    if n.len() != 3 * count {
                        return Err(data_error(format!(
                            "{label}: NORMAL has {} entries, POSITION {count}",
                            n.len() / 3
                        )));
                    }
                    any_normals = true;
                    normals.extend(n.chunks_exact(3).map(|n| {
                        (normal_matrix * Vec3::new(n[0], n[1], n[2])).normalize_or_zero()
                    }));
                }
                // Zero marks "missing": the repair step computes it.
                None => normals.extend(std::iter::repeat_n(Vec3::ZERO, count)),
            }

            match primitive.get(&gltf::Semantic::TexCoords(0)) {
                Some(accessor) if all_uvs => {
                    let t = read_floats(&accessor, &buffers, Dimensions::Vec2, true)
                        .map_err(|e| data_error(format!("{label} TEXCOORD_0: {e}")))?;
                    if t.len() != 2 * count {
                        return Err(data_error(format!(
                            "{label}: TEXCOORD_0 has {} entries, POSITION {count}",
                            t.len() / 2
                        )));
                    }
                    uvs.extend(t.chunks_exact(2).map(|t| Vec2::new(t[0], t[1])));
                }
                Some(_) => {}
                None => all_uvs = false,
            }

            match primitive.get(&gltf::Semantic::Tangents) {
                Some(accessor) if all_tangents => {
                    let t = read_floats(&accessor, &buffers, Dimensions::Vec4, false)
                        .map_err(|e| data_error(format!("{label} TANGENT: {e}")))?;
                    if t.len() != 4 * count {
                        return Err(data_error(format!(
                            "{label}: TANGENT has {} entries, POSITION {count}",
                            t.len() / 4
                        )));
                    }
                    let handedness = if mirrored { -1.0 } else { 1.0 };
                    tangents.extend(t.chunks_exact(4).map(|t| {
                        world
                            .transform_vector3(Vec3::new(t[0], t[1], t[2]))
                            .extend(t[3] * handedness)
                    }));
                }
                Some(_) => {}
                None => all_tangents = false,
            }

            let source = primitive.material().index();
            let material = match material_sources.iter().position(|&m| m == source) {
                Some(m) => m,
                None => {
                    material_sources.push(source);
                    material_sources.len() - 1
                }
            };
            let tag = surfaces.material_of_primitive.len() as u32;
            surfaces.material_of_primitive.push(material);
            let triangles_before = data.triangles.len();

            let indices: Vec<u32> = match primitive.indices() {
                Some(accessor) => read_indices(&accessor, &buffers)
                    .map_err(|e| data_error(format!("{label} indices: {e}")))?,
                None => (0..count as u32).collect(),
            };
            // Offset into the shared arrays; anything out of this primitive's range stays out
            // of range for the repair step to count.
            let offset = |i: u32| {
                if (i as usize) < count {
                    (base + i as usize) as u32
                } else {
                    u32::MAX
                }
            };
            let mut push = |t: [u32; 3]| {
                let t = t.map(offset);
                data.triangles
                    .push(if mirrored { [t[0], t[2], t[1]] } else { t });
            };
            match primitive.mode() {
                Mode::TriangleStrip => {
                    for (k, w) in indices.windows(3).enumerate() {
                        push(if k % 2 == 0 {
                            [w[0], w[1], w[2]]
                        } else {
                            [w[1], w[0], w[2]]
                        });
                    }
                }
                Mode::TriangleFan => {
                    for w in indices.get(1..).unwrap_or_default().windows(2) {
                        push([indices[0], w[0], w[1]]);
                    }
                }
                _ => indices
                    .chunks_exact(3)
                    .for_each(|t| push([t[0], t[1], t[2]])),
            }
            let added = data.triangles.len() - triangles_before;
            surfaces
                .primitive_of_triangle
                .extend(std::iter::repeat_n(tag, added));
        }
    }
    data.normals = any_normals.then_some(normals);
    data.uvs = (all_uvs && !uvs.is_empty()).then_some(uvs);
    if with_surfaces {
        surfaces.tangents = (all_tangents && !tangents.is_empty()).then_some(tangents);
        let mut reader = super::gltf_material::MaterialReader::new(
            &document,
            &buffers,
            base,
            path,
            data.uvs.is_some(),
        );
        surfaces.materials = material_sources
            .iter()
            .map(|&source| reader.read(source))
            .collect::<Result<_, _>>()?;
        surfaces.warnings = reader.into_warnings();
    }
    Ok((data, surfaces))
}

/// Rejects GLB headers the `gltf` crate would mis-handle (a declared length below the header
/// size underflows there).
fn check_glb_header(bytes: &[u8]) -> Result<(), String> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    let declared = bytes
        .get(8..12)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize);
    match declared {
        Some(length) if (20..=bytes.len()).contains(&length) => Ok(()),
        Some(length) => Err(format!(
            "GLB header declares {length} bytes but the file has {} (truncated or corrupt)",
            bytes.len()
        )),
        None => Err(format!(
            "GLB file of {} bytes is too short for its header",
            bytes.len()
        )),
    }
}

/// The bytes of every buffer: the GLB chunk, a `data:` URI or a file next to the glTF file.
pub(super) fn load_buffers(
    document: &gltf::Document,
    mut blob: Option<Vec<u8>>,
    base: &Path,
    path: &Path,
) -> Result<Vec<Vec<u8>>, LoadError> {
    let data_error = |problem: String| LoadError::GltfData {
        path: path.to_owned(),
        problem,
    };
    let mut buffers = Vec::new();
    for buffer in document.buffers() {
        let index = buffer.index();
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                data_error(format!(
                    "buffer {index} refers to the GLB binary chunk, which is missing"
                ))
            })?,
            gltf::buffer::Source::Uri(uri) => uri_bytes(uri, base).map_err(|e| match e {
                UriError::Invalid(problem) => data_error(format!("buffer {index}: {problem}")),
                UriError::Read { file, source } => LoadError::Io { path: file, source },
            })?,
        };
        if data.len() < buffer.length() {
            return Err(data_error(format!(
                "buffer {index} declares {} bytes but has {}",
                buffer.length(),
                data.len()
            )));
        }
        buffers.push(data);
    }
    Ok(buffers)
}

/// Why a glTF `uri` gave no bytes.
pub(super) enum UriError {
    /// Not a base64 `data:` URI nor a relative path inside the folder.
    Invalid(String),
    /// The file it names could not be read.
    Read {
        /// The file.
        file: std::path::PathBuf,
        /// What the OS said.
        source: std::io::Error,
    },
}

/// The bytes a buffer's or an image's `uri` names: a base64 `data:` URI, or a percent-encoded
/// path relative to `base` that stays inside it (read as any input file, within its limits).
pub(super) fn uri_bytes(uri: &str, base: &Path) -> Result<Vec<u8>, UriError> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, payload) = rest
            .split_once(";base64,")
            .ok_or_else(|| UriError::Invalid("data URI is not base64".to_owned()))?;
        decode_base64(payload).map_err(|e| UriError::Invalid(format!("data URI: {e}")))
    } else if uri.contains(':') {
        Err(UriError::Invalid(format!(
            "unsupported URI scheme in {uri:?} (only data: URIs and relative paths)"
        )))
    } else {
        let relative = percent_decode(uri)
            .ok_or_else(|| UriError::Invalid(format!("malformed URI {uri:?}")))?;
        let file = crate::input_file::resolve_inside(base, &relative).map_err(UriError::Invalid)?;
        crate::input_file::read_regular(&file, crate::input_file::MAX_INPUT_FILE_BYTES)
            .map_err(|source| UriError::Read { file, source })
    }
}

/// The bytes of a buffer view, checked against its buffer.
pub(super) fn view_bytes<'a>(
    view: &gltf::buffer::View<'_>,
    buffers: &'a [Vec<u8>],
) -> Result<&'a [u8], String> {
    let buffer = buffers
        .get(view.buffer().index())
        .ok_or_else(|| format!("buffer view {} has no buffer", view.index()))?;
    view.offset()
        .checked_add(view.length())
        .and_then(|end| buffer.get(view.offset()..end))
        .ok_or_else(|| {
            format!(
                "buffer view {} ({} bytes at {}) exceeds buffer {} ({} bytes)",
                view.index(),
                view.length(),
                view.offset(),
                view.buffer().index(),
                buffer.len()
            )
        })
}

/// Where an accessor's elements lie, checked against its buffer.
struct Layout<'a> {
    data: &'a [u8],
    stride: usize,
    count: usize,
    components: usize,
    component_size: usize,
}

impl Layout<'_> {
    fn component(&self, element: usize, component: usize) -> &[u8] {
        let start = element * self.stride + component * self.component_size;
        &self.data[start..start + self.component_size]
    }
}

fn layout<'a>(accessor: &gltf::Accessor<'_>, buffers: &'a [Vec<u8>]) -> Result<Layout<'a>, String> {
    let index = accessor.index();
    if accessor.sparse().is_some() {
        return Err(format!("accessor {index} is sparse (not supported)"));
    }
    let view = accessor
        .view()
        .ok_or_else(|| format!("accessor {index} has no buffer view"))?;
    let view_data = view_bytes(&view, buffers)?;
    let count = accessor.count();
    let element_size = accessor.size();
    let stride = view.stride().unwrap_or(element_size);
    if count == 0 {
        return Err(format!("accessor {index} is empty"));
    }
    if stride < element_size {
        return Err(format!(
            "accessor {index}: stride {stride} is smaller than its {element_size}-byte elements"
        ));
    }
    // count ≤ view length bounds the arithmetic below (every element takes ≥ 1 byte).
    let needed = (count <= view_data.len() && accessor.offset() <= view_data.len())
        .then(|| accessor.offset() + stride * (count - 1) + element_size);
    let data = needed
        .and_then(|end| view_data.get(accessor.offset()..end))
        .ok_or_else(|| {
            format!(
                "accessor {index} ({count} elements, stride {stride}, offset {}) exceeds buffer \
                 view {} ({} bytes)",
                accessor.offset(),
                view.index(),
                view_data.len()
            )
        })?;
    Ok(Layout {
        data,
        stride,
        count,
        components: accessor.dimensions().multiplicity(),
        component_size: accessor.data_type().size(),
    })
}

/// Float attributes: `F32`, or (when `allow_normalized`) normalised `U8`/`U16`.
fn read_floats(
    accessor: &gltf::Accessor<'_>,
    buffers: &[Vec<u8>],
    dimensions: Dimensions,
    allow_normalized: bool,
) -> Result<Vec<f32>, String> {
    if accessor.dimensions() != dimensions {
        return Err(format!(
            "accessor {} is {:?}, expected {dimensions:?}",
            accessor.index(),
            accessor.dimensions()
        ));
    }
    let data_type = accessor.data_type();
    let normalized = allow_normalized && accessor.normalized();
    let convert: fn(&[u8]) -> f32 = match data_type {
        DataType::F32 => |b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        DataType::U8 if normalized => |b| f32::from(b[0]) / 255.0,
        DataType::U16 if normalized => |b| f32::from(u16::from_le_bytes([b[0], b[1]])) / 65535.0,
        other => {
            return Err(format!(
                "accessor {} has component type {other:?}{}; only F32 is supported here",
                accessor.index(),
                if accessor.normalized() {
                    " (normalized)"
                } else {
                    ""
                }
            ));
        }
    };
    let layout = layout(accessor, buffers)?;
    let mut out = Vec::with_capacity(layout.count * layout.components);
    for e in 0..layout.count {
        for c in 0..layout.components {
            out.push(convert(layout.component(e, c)));
        }
    }
    Ok(out)
}

/// Index accessors: scalar `U8`, `U16` or `U32`.
fn read_indices(accessor: &gltf::Accessor<'_>, buffers: &[Vec<u8>]) -> Result<Vec<u32>, String> {
    let convert: fn(&[u8]) -> u32 = match (accessor.dimensions(), accessor.data_type()) {
        (Dimensions::Scalar, DataType::U8) => |b| u32::from(b[0]),
        (Dimensions::Scalar, DataType::U16) => |b| u32::from(u16::from_le_bytes([b[0], b[1]])),
        (Dimensions::Scalar, DataType::U32) => |b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        (dimensions, data_type) => {
            return Err(format!(
                "accessor {} is {dimensions:?} {data_type:?}; indices must be scalar U8, U16 or U32",
                accessor.index()
            ));
        }
    };
    let layout = layout(accessor, buffers)?;
    Ok((0..layout.count)
        .map(|e| convert(layout.component(e, 0)))
        .collect())
}

/// Standard base64 (RFC 4648 alphabet, `=` padding optional).
pub(super) fn decode_base64(text: &str) -> Result<Vec<u8>, String> {
    let text = text.trim_end_matches('=');
    let mut out = Vec::with_capacity(text.len() * 3 / 4);
    let mut accumulator = 0u32;
    let mut bits = 0u32;
    for (position, byte) in text.bytes().enumerate() {
        let value = match byte {
            b'A'..=b'Z' => byte - b'A',
            b'a'..=b'z' => byte - b'a' + 26,
            b'0'..=b'9' => byte - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            _ => {
                return Err(format!(
                    "invalid base64 character {:?} at {position}",
                    byte as char
                ));
            }
        };
        accumulator = (accumulator << 6) | u32::from(value);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((accumulator >> bits) as u8);
            accumulator &= (1 << bits) - 1;
        }
    }
    Ok(out)
}

/// Decodes `%XX` escapes of a relative URI; `None` if malformed or not UTF-8.
pub(super) fn percent_decode(uri: &str) -> Option<String> {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = std::str::from_utf8(bytes.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_decodes_rfc4648_vectors() {
        for (text, expected) in [
            ("", ""),
            ("Zg==", "f"),
            ("Zm8=", "fo"),
            ("Zm9v", "foo"),
            ("Zm9vYg==", "foob"),
            ("Zm9vYmE=", "fooba"),
            ("Zm9vYmFy", "foobar"),
        ] {
            assert_eq!(
                decode_base64(text).as_deref(),
                Ok(expected.as_bytes()),
                "{text}"
            );
        }
        assert!(decode_base64("Zm9v!").is_err());
    }

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("a%20b.bin").as_deref(), Some("a b.bin"));
        assert_eq!(percent_decode("plain.bin").as_deref(), Some("plain.bin"));
        assert_eq!(percent_decode("bad%2"), None);
        assert_eq!(percent_decode("bad%FF"), None);
    }
}
