//! `Mesh::load_with_surfaces`: materials, textures, primitives and tangents of the textured
//! fixture (`tests/fixtures/textured.glb`, made by `examples/make_textured_asset.rs`), of OBJ
//! files, and of small hand-written glTF files, good and bad.

mod support;

use std::io::Cursor;
use std::path::{Path, PathBuf};

use cdrf_core::glam::{Vec3, Vec4};
use cdrf_core::mesh::{Mesh, MeshSurfaces, SurfacePrimitive, TextureWrap};

use support::{base64, chain};

fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/fixtures/textured.glb")
}

fn load_fixture() -> (Mesh, MeshSurfaces) {
    let (repaired, surfaces) = Mesh::load_with_surfaces(fixture()).unwrap();
    assert!(repaired.report.is_clean(), "{}", repaired.report);
    (repaired.mesh, surfaces)
}

/// Big sphere: 64 segments × 32 rings, one triangle per segment in each pole row.
const BIG_TRIANGLES: u32 = 64 * 32 * 2 - 2 * 64;
/// Small sphere: 32 × 16.
const SMALL_TRIANGLES: u32 = 32 * 16 * 2 - 2 * 32;

#[test]
fn fixture_has_two_primitives_with_their_materials_and_textures() {
    let (mesh, surfaces) = load_fixture();
    assert!(surfaces.warnings.is_empty(), "{:?}", surfaces.warnings);
    assert_eq!(
        surfaces.primitives,
        vec![
            SurfacePrimitive {
                triangles: 0..BIG_TRIANGLES,
                material: 0
            },
            SurfacePrimitive {
                triangles: BIG_TRIANGLES..BIG_TRIANGLES + SMALL_TRIANGLES,
                material: 1
            },
        ]
    );
    assert_eq!(mesh.triangles.len() as u32, BIG_TRIANGLES + SMALL_TRIANGLES);

    let [checker, tinted] = surfaces.materials.as_slice() else {
        panic!("{} materials", surfaces.materials.len());
    };
    assert_eq!(checker.name.as_deref(), Some("checker"));
    assert_eq!(checker.source_index, Some(0));
    assert_eq!(checker.base_color_factor, [1.0; 4]);
    assert_eq!(checker.roughness_factor, 0.6);
    assert!(checker.metallic_roughness_texture.is_none());
    let base = checker.base_color_texture.as_ref().unwrap();
    assert_eq!((base.width, base.height, base.rgba8.len()), (64, 64, 4096));
    assert_eq!(base.wrap, [TextureWrap::Repeat, TextureWrap::ClampToEdge]);
    // 8 × 8 px squares, top-left white (the measured material), then light orange (sRGB).
    assert_eq!(base.pixel(0, 0), Some([255, 255, 255, 255]));
    assert_eq!(base.pixel(8, 0), Some([255, 200, 150, 255]));
    assert_eq!(base.pixel(8, 8), Some([255, 255, 255, 255]));
    assert_eq!(base.pixel(63, 48), Some([255, 200, 150, 255]));
    assert_eq!(base.pixel(64, 0), None);
    let normal = checker.normal_texture.as_ref().unwrap();
    assert_eq!((normal.image.width, normal.image.height), (128, 128));
    assert_eq!(normal.scale, 1.0);
    // Every texel decodes to a unit-ish normal leaning at most ~45° from +Z (the bumps' largest
    // slope is 0.88); many lean (not a flat map).
    let mut leaning = 0;
    for p in &normal.image.rgba8 {
        let n = Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32) / 127.5 - 1.0;
        assert!((n.length() - 1.0).abs() < 0.02 && n.z > 0.7, "{n}");
        if n.z < 0.95 {
            leaning += 1;
        }
    }
    assert!(leaning > 1000, "{leaning} texels lean");

    assert_eq!(tinted.name.as_deref(), Some("tinted"));
    assert_eq!(tinted.base_color_factor, [0.8, 0.9, 1.0, 1.0]);
    assert_eq!(tinted.roughness_factor, 0.3);
    assert!(tinted.base_color_texture.is_none() && tinted.normal_texture.is_none());
}

#[test]
fn fixture_primitives_cover_each_triangle_once_with_the_right_geometry() {
    let (mesh, surfaces) = load_fixture();
    let mut next = 0;
    for (k, primitive) in surfaces.primitives.iter().enumerate() {
        assert_eq!(primitive.triangles.start, next, "primitive {k}");
        assert!(primitive.triangles.end > primitive.triangles.start);
        next = primitive.triangles.end;
        // Primitive 0 is the r = 30 mm sphere at the origin, 1 the r = 15 mm one at x = 55 mm.
        let (centre, radius) = [(Vec3::ZERO, 30.0), (Vec3::new(55.0, 0.0, 0.0), 15.0)][k];
        for t in &mesh.triangles[primitive.triangles.start as usize..next as usize] {
            for &v in t {
                let r = (mesh.positions[v as usize] - centre).length();
                assert!((r - radius).abs() < 1e-4, "primitive {k}: r = {r}");
            }
        }
    }
    assert_eq!(next as usize, mesh.triangles.len());
}

#[test]
fn fixture_tangents_are_unit_orthogonal_and_follow_the_uvs() {
    let (mesh, surfaces) = load_fixture();
    let tangents = surfaces.tangents.as_ref().expect("MikkTSpace tangents");
    assert_eq!(tangents.len(), mesh.positions.len());
    let mut checked = 0;
    for primitive in &surfaces.primitives {
        let (centre, radius) = if primitive.material == 0 {
            (Vec3::ZERO, 30.0)
        } else {
            (Vec3::new(55.0, 0.0, 0.0), 15.0)
        };
        let range = primitive.triangles.start as usize..primitive.triangles.end as usize;
        let mut vertices: Vec<u32> = mesh.triangles[range].iter().flatten().copied().collect();
        vertices.sort_unstable();
        vertices.dedup();
        for v in vertices {
            let (t, n) = (tangents[v as usize], mesh.normals[v as usize]);
            let xyz = t.truncate();
            assert!(
                (xyz.length() - 1.0).abs() < 1e-4,
                "vertex {v}: |t| = {}",
                xyz.length()
            );
            assert!(xyz.dot(n).abs() < 1e-3, "vertex {v}: t·n = {}", xyz.dot(n));
            // The sphere's parametrisation keeps orientation everywhere.
            assert_eq!(t.w, 1.0, "vertex {v}");
            let p = mesh.positions[v as usize] - centre;
            if p.y.abs() < 0.9 * radius {
                // dP/du ∝ (z, 0, −x); the bitangent points up the image, −dP/dv ∝ −dP/dθ.
                let du = Vec3::new(p.z, 0.0, -p.x).normalize();
                let theta = (p.y / radius).clamp(-1.0, 1.0).acos();
                let phi = p.x.atan2(p.z);
                let minus_dv = -Vec3::new(
                    theta.cos() * phi.sin(),
                    -theta.sin(),
                    theta.cos() * phi.cos(),
                );
                let bitangent = n.cross(xyz) * t.w;
                assert!(xyz.dot(du) > 0.99, "vertex {v}: t = {xyz}, dP/du ∝ {du}");
                assert!(
                    bitangent.dot(minus_dv) > 0.99,
                    "vertex {v}: b = {bitangent}"
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 1500, "{checked} vertices checked");
}

#[test]
fn plain_load_of_the_fixture_gives_the_same_mesh() {
    let (mesh, _) = load_fixture();
    let plain = Mesh::load(fixture()).unwrap().mesh;
    // As sets of positions and of triangles (by their corners' positions) …
    let key = |p: Vec3| p.to_array().map(f32::to_bits);
    let positions = |m: &Mesh| {
        let mut keys: Vec<_> = m.positions.iter().map(|&p| key(p)).collect();
        keys.sort_unstable();
        keys
    };
    let triangles = |m: &Mesh| {
        let mut keys: Vec<_> = m
            .triangles
            .iter()
            .map(|t| t.map(|i| key(m.positions[i as usize])))
            .collect();
        keys.sort_unstable();
        keys
    };
    assert_eq!(positions(&plain), positions(&mesh));
    assert_eq!(triangles(&plain), triangles(&mesh));
    // … and in fact identical, in the same order.
    assert_eq!(plain, mesh);
    // Seams and poles weld: two closed spheres.
    let welded = mesh.weld();
    assert_eq!(welded.positions.len(), (64 * 31 + 2) + (32 * 15 + 2));
}

#[test]
fn obj_gives_one_primitive_and_no_tangents() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("tetra.obj");
    std::fs::write(
        &path,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvt 1 0\nvt 0 1\n\
         f 1/1 3/3 2/2\nf 1/1 2/2 4/3\nf 1/1 4/3 3/3\nf 2/1 3/2 4/3\n",
    )
    .unwrap();
    let (repaired, surfaces) = Mesh::load_with_surfaces(&path).unwrap();
    assert_eq!(repaired.mesh, Mesh::load(&path).unwrap().mesh);
    assert_eq!(
        surfaces.primitives,
        vec![SurfacePrimitive {
            triangles: 0..4,
            material: 0
        }]
    );
    assert_eq!(surfaces.materials.len(), 1);
    assert_eq!(surfaces.materials[0].source_index, None);
    assert_eq!(surfaces.materials[0].base_color_factor, [1.0; 4]);
    assert!(surfaces.tangents.is_none());
}

// ---- hand-written glTF files ----

fn png(width: u32, height: u32, rgb: &[u8]) -> Vec<u8> {
    let mut bytes = Vec::new();
    image::write_buffer_with_format(
        &mut Cursor::new(&mut bytes),
        rgb,
        width,
        height,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .unwrap();
    bytes
}

/// CRC-32 (ISO-HDLC, PNG's) of `bytes`.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

/// A valid 1 × 1 PNG whose IHDR (with a correct CRC) claims `width × height` pixels.
fn png_claiming(width: u32, height: u32) -> Vec<u8> {
    let mut bytes = png(1, 1, &[1, 2, 3]);
    assert_eq!(&bytes[12..16], b"IHDR");
    bytes[16..20].copy_from_slice(&width.to_be_bytes());
    bytes[20..24].copy_from_slice(&height.to_be_bytes());
    let crc = crc32(&bytes[12..29]);
    bytes[29..33].copy_from_slice(&crc.to_be_bytes());
    bytes
}

/// Four vertices of the unit square in the xy plane (facing +z) with UVs, and tangents
/// `(2, 0, 0.5, −1)` (not unit, not orthogonal to +z: the loader must fix them).
fn square_buffer() -> Vec<u8> {
    let positions = [
        [0.0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let uvs = [[0.0f32, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
    let mut bytes: Vec<u8> = positions
        .iter()
        .flatten()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    bytes.extend(uvs.iter().flatten().flat_map(|f| f.to_le_bytes()));
    bytes.extend(
        (0..4)
            .flat_map(|_| [2.0f32, 0.0, 0.5, -1.0])
            .flat_map(f32::to_le_bytes),
    );
    // Indices (u16): triangles 0 1 2 | 0 2 3 | 0 0 1 (degenerate) | 1 1 2 (degenerate).
    bytes.extend(
        [0u16, 1, 2, 0, 2, 3, 0, 0, 1, 1, 1, 2]
            .iter()
            .flat_map(|i| i.to_le_bytes()),
    );
    bytes
}

/// A glTF of the square as primitives (one per index range `(first, count)` of the index
/// buffer, with the given material and TANGENT or not), with `materials`, `textures`,
/// `images` and `samplers` JSON arrays as given, and the node's `scale`.
fn square_gltf(
    primitives: &[(usize, usize, Option<usize>, bool)],
    materials: &str,
    textures: &str,
    images: &str,
    scale: [f32; 3],
) -> String {
    let buffer = square_buffer();
    let primitives: Vec<String> = primitives
        .iter()
        .map(|&(first, count, material, tangent)| {
            let material = material.map_or(String::new(), |m| format!(r#", "material": {m}"#));
            let tangent = if tangent { r#", "TANGENT": 2"# } else { "" };
            format!(
                r#"{{"attributes": {{"POSITION": 0, "TEXCOORD_0": 1{tangent}}},
                     "indices": {}{material}}}"#,
                3 + primitives_accessor(first, count)
            )
        })
        .collect();
    // One index accessor per primitive, after the three attribute accessors.
    let index_accessors: Vec<String> = PRIMITIVE_RANGES
        .iter()
        .map(|&(first, count)| {
            format!(
                r#"{{"bufferView": 3, "byteOffset": {}, "componentType": 5123, "count": {count},
                     "type": "SCALAR"}}"#,
                2 * first
            )
        })
        .collect();
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"mesh": 0, "scale": {scale:?}}}],
  "meshes": [{{"primitives": [{}]}}],
  "materials": {materials},
  "textures": {textures},
  "images": {images},
  "samplers": [{{"wrapS": 33071}}],
  "buffers": [{{"byteLength": {}, "uri": "data:application/octet-stream;base64,{}"}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 48}},
    {{"buffer": 0, "byteOffset": 48, "byteLength": 32}},
    {{"buffer": 0, "byteOffset": 80, "byteLength": 64}},
    {{"buffer": 0, "byteOffset": 144, "byteLength": 24}}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
      "min": [0, 0, 0], "max": [1, 1, 0]}},
    {{"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"}},
    {{"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC4"}},
    {}
  ]
}}"#,
        primitives.join(", "),
        buffer.len(),
        base64(&buffer),
        index_accessors.join(",\n    ")
    )
}

/// The index ranges `(first index, count)` that primitives may use: both good triangles, the
/// first good one and the first degenerate one, both degenerate ones, the second good one.
const PRIMITIVE_RANGES: [(usize, usize); 4] = [(0, 6), (3, 6), (6, 6), (3, 3)];

fn primitives_accessor(first: usize, count: usize) -> usize {
    PRIMITIVE_RANGES
        .iter()
        .position(|&r| r == (first, count))
        .expect("a listed range")
}

const TEXTURED_MATERIAL: &str = r#"[{"name": "m", "pbrMetallicRoughness":
    {"baseColorTexture": {"index": 0}, "roughnessFactor": 0.25}}]"#;

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

fn image_data_uri(png: &[u8]) -> String {
    format!(r#"[{{"uri": "data:image/png;base64,{}"}}]"#, base64(png))
}

#[test]
fn repair_keeps_primitive_ranges_and_tangents_consistent() {
    let dir = tempfile::tempdir().unwrap();
    let image = image_data_uri(&png(2, 2, &[9; 12]));
    // Primitive 0: good + degenerate; 1: only degenerate (dropped); 2: good, default material.
    let text = square_gltf(
        &[
            (3, 6, Some(0), true),
            (6, 6, Some(0), true),
            (3, 3, None, true),
        ],
        TEXTURED_MATERIAL,
        r#"[{"source": 0, "sampler": 0}]"#,
        &image,
        [1.0, 1.0, 1.0],
    );
    let path = write(dir.path(), "square.gltf", &text);
    let (repaired, surfaces) = Mesh::load_with_surfaces(&path).unwrap();
    assert_eq!(repaired.report.degenerate_triangles, 3);
    assert_eq!(repaired.mesh.triangles.len(), 2);
    assert_eq!(repaired.mesh, Mesh::load(&path).unwrap().mesh);
    assert_eq!(
        surfaces.primitives,
        vec![
            SurfacePrimitive {
                triangles: 0..1,
                material: 0
            },
            SurfacePrimitive {
                triangles: 1..2,
                material: 1
            },
        ]
    );
    assert_eq!(surfaces.materials[0].roughness_factor, 0.25);
    let texture = surfaces.materials[0].base_color_texture.as_ref().unwrap();
    assert_eq!(texture.pixel(1, 1), Some([9, 9, 9, 255]));
    assert_eq!(
        texture.wrap,
        [TextureWrap::ClampToEdge, TextureWrap::Repeat]
    );
    assert_eq!(surfaces.materials[1].source_index, None);
    // TANGENT read, carried through the vertex compaction, made unit and orthogonal to +z,
    // handedness kept.
    let tangents = surfaces.tangents.unwrap();
    assert_eq!(tangents.len(), repaired.mesh.positions.len());
    for t in &tangents {
        assert!((*t - Vec4::new(1.0, 0.0, 0.0, -1.0)).length() < 1e-6, "{t}");
    }

    // Mirrored by the node: winding and handedness flip.
    let text = square_gltf(
        &[(0, 6, Some(0), true)],
        TEXTURED_MATERIAL,
        r#"[{"source": 0}]"#,
        &image,
        [-1.0, 1.0, 1.0],
    );
    let path = write(dir.path(), "mirrored.gltf", &text);
    let (repaired, surfaces) = Mesh::load_with_surfaces(&path).unwrap();
    for (t, n) in surfaces
        .tangents
        .unwrap()
        .iter()
        .zip(&repaired.mesh.normals)
    {
        assert!((*n - Vec3::Z).length() < 1e-6, "{n}");
        assert!((*t - Vec4::new(-1.0, 0.0, 0.0, 1.0)).length() < 1e-6, "{t}");
    }
}

#[test]
fn tangents_are_computed_only_for_normal_maps_and_missing_when_a_primitive_lacks_them() {
    let dir = tempfile::tempdir().unwrap();
    let image = image_data_uri(&png(1, 1, &[128, 128, 255]));
    // One primitive without TANGENT: nothing is read; no normal texture: nothing computed.
    let text = square_gltf(
        &[(0, 6, Some(0), false)],
        TEXTURED_MATERIAL,
        r#"[{"source": 0}]"#,
        &image,
        [1.0; 3],
    );
    let (_, surfaces) = Mesh::load_with_surfaces(write(dir.path(), "plain.gltf", &text)).unwrap();
    assert!(surfaces.tangents.is_none());
    // With a normal texture: MikkTSpace, +u = +x, bitangent up the image = +y, w = +1.
    let normal_material = r#"[{"normalTexture": {"index": 0, "scale": 0.5}}]"#;
    let text = square_gltf(
        &[(0, 6, Some(0), false)],
        normal_material,
        r#"[{"source": 0}]"#,
        &image,
        [1.0; 3],
    );
    let (_, surfaces) = Mesh::load_with_surfaces(write(dir.path(), "normal.gltf", &text)).unwrap();
    assert_eq!(
        surfaces.materials[0].normal_texture.as_ref().unwrap().scale,
        0.5
    );
    for t in surfaces.tangents.unwrap() {
        assert!((t - Vec4::new(1.0, 0.0, 0.0, 1.0)).length() < 1e-5, "{t}");
    }
}

#[test]
fn textures_on_other_sets_are_ignored_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let material = r#"[{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "texCoord": 1},
        "metallicRoughnessTexture": {"index": 0}}}]"#;
    let text = square_gltf(
        &[(0, 6, Some(0), false)],
        material,
        r#"[{"source": 0}]"#,
        &image_data_uri(&png(1, 1, &[0, 77, 0])),
        [1.0; 3],
    );
    let (_, surfaces) = Mesh::load_with_surfaces(write(dir.path(), "set1.gltf", &text)).unwrap();
    let material = &surfaces.materials[0];
    assert!(material.base_color_texture.is_none());
    let roughness = material.metallic_roughness_texture.as_ref().unwrap();
    assert_eq!(roughness.pixel(0, 0).unwrap()[1], 77);
    assert_eq!(surfaces.warnings.len(), 1, "{:?}", surfaces.warnings);
    assert!(
        surfaces.warnings[0].contains("TEXCOORD_1"),
        "{:?}",
        surfaces.warnings
    );
}

/// The error's whole chain, one string.
fn load_error(dir: &Path, name: &str, textures: &str, images: &str) -> String {
    let text = square_gltf(
        &[(0, 6, Some(0), false)],
        TEXTURED_MATERIAL,
        textures,
        images,
        [1.0; 3],
    );
    let path = write(dir, name, &text);
    let error = Mesh::load_with_surfaces(&path).unwrap_err();
    let message = chain(&error);
    assert!(message.contains(name), "{message}");
    message
}

#[test]
fn a_missing_image_file_is_an_error_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let message = load_error(
        dir.path(),
        "missing.gltf",
        r#"[{"source": 0}]"#,
        r#"[{"uri": "no%20such.png"}]"#,
    );
    assert!(
        message.contains("no such.png") && message.contains("cannot read"),
        "{message}"
    );
    // Plain loading never touches images.
    assert!(Mesh::load(dir.path().join("missing.gltf")).is_ok());
    // A file next to the glTF is read; one outside its folder is refused.
    std::fs::write(dir.path().join("no such.png"), png(3, 2, &[0; 18])).unwrap();
    let (_, surfaces) = Mesh::load_with_surfaces(dir.path().join("missing.gltf")).unwrap();
    let texture = surfaces.materials[0].base_color_texture.as_ref().unwrap();
    assert_eq!((texture.width, texture.height), (3, 2));
    let message = load_error(
        dir.path(),
        "outside.gltf",
        r#"[{"source": 0}]"#,
        r#"[{"uri": "../x.png"}]"#,
    );
    assert!(
        message.contains("leaves the file's own folder"),
        "{message}"
    );
}

#[test]
fn a_huge_image_header_is_refused_before_decoding() {
    let dir = tempfile::tempdir().unwrap();
    let huge = png_claiming(100_000, 100_000);
    // The patched header is well-formed: the decoder reads the claimed size.
    let dimensions = image::ImageReader::with_format(Cursor::new(&huge), image::ImageFormat::Png)
        .into_dimensions()
        .unwrap();
    assert_eq!(dimensions, (100_000, 100_000));
    let message = load_error(
        dir.path(),
        "huge.gltf",
        r#"[{"source": 0}]"#,
        &image_data_uri(&huge),
    );
    assert!(
        message.contains("100000 × 100000") && message.contains("limit"),
        "{message}"
    );
    // Within the side limit but over the pixel limit (2²⁸): refused too.
    let message = load_error(
        dir.path(),
        "many.gltf",
        r#"[{"source": 0}]"#,
        &image_data_uri(&png_claiming(65_536, 65_536)),
    );
    assert!(message.contains("pixels"), "{message}");
    // A corrupt image (truncated) is an error, not a panic.
    let good = png(4, 4, &[7; 48]);
    let message = load_error(
        dir.path(),
        "corrupt.gltf",
        r#"[{"source": 0}]"#,
        &image_data_uri(&good[..good.len() - 20]),
    );
    assert!(message.contains("invalid PNG"), "{message}");
}

#[test]
fn texture_image_and_sampler_indices_out_of_range_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let image = image_data_uri(&png(1, 1, &[1, 2, 3]));
    // The material's texture index 0 with no texture.
    let message = load_error(dir.path(), "no_texture.gltf", "[]", &image);
    assert!(
        message.contains("baseColorTexture.index: Index out of bounds"),
        "{message}"
    );
    // The texture's image and sampler out of range, or no image.
    let message = load_error(dir.path(), "no_image.gltf", r#"[{"source": 3}]"#, &image);
    assert!(message.contains("source: Index out of bounds"), "{message}");
    let message = load_error(
        dir.path(),
        "no_sampler.gltf",
        r#"[{"source": 0, "sampler": 2}]"#,
        &image,
    );
    assert!(
        message.contains("sampler: Index out of bounds"),
        "{message}"
    );
    let message = load_error(dir.path(), "no_source.gltf", r#"[{"sampler": 0}]"#, &image);
    assert!(message.contains("source: Missing data"), "{message}");
}
