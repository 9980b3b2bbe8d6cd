//! Mesh loading (OBJ, glTF, GLB), repair, welding and GLB export with `_CURVATURE`.

mod support;

use std::path::{Path, PathBuf};

use cdrf_core::curvature::{CurvatureOptions, mean_curvature_per_mm};
use cdrf_core::mesh::{
    CURVATURE_ATTRIBUTE, ExportError, LoadError, Mesh, MeshData, MeshError, RepairReport,
    glb_bytes_with_curvature, write_glb_with_curvature,
};
use glam::{Vec2, Vec3};

use support::{base64, chain};

fn bunny_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/bunny/bunny.obj")
}

/// The error and its sources, joined with ": " (as `anyhow`'s `{:#}` prints them).
fn approx_eq(a: Vec3, b: Vec3, eps: f32) {
    assert!(
        (a - b).abs().max_element() <= eps,
        "{a} vs {b} (eps {eps}, difference {})",
        a - b
    );
}

/// Signed volume of a closed mesh: positive when the winding is outward.
fn signed_volume(mesh: &Mesh) -> f32 {
    mesh.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

// ---------------------------------------------------------------- repair

#[test]
fn repair_removes_and_counts_every_problem() {
    let positions = vec![
        Vec3::new(0.0, 0.0, 0.0),           // 0
        Vec3::new(1.0, 0.0, 0.0),           // 1
        Vec3::new(0.0, 1.0, 0.0),           // 2
        Vec3::new(1.0, 1.0, 0.0),           // 3
        Vec3::new(f32::NAN, 0.0, 0.0),      // 4 non-finite
        Vec3::new(2.0, 0.0, 0.0),           // 5 collinear with 0, 1
        Vec3::new(9.0, 9.0, 9.0),           // 6 unreferenced
        Vec3::new(0.0, f32::INFINITY, 0.0), // 7 non-finite, unreferenced
    ];
    let triangles = vec![
        [0, 1, 2],  // good
        [1, 3, 2],  // good
        [0, 1, 4],  // non-finite vertex
        [0, 1, 5],  // zero area (collinear)
        [2, 2, 3],  // repeated index
        [0, 1, 42], // out of range
    ];
    let mut normals = vec![Vec3::Z; positions.len()];
    normals[1] = Vec3::new(f32::NAN, 0.0, 0.0); // invalid
    normals[2] = Vec3::ZERO; // missing
    let repaired = Mesh::from_data(MeshData {
        positions,
        normals: Some(normals),
        uvs: Some(vec![Vec2::ZERO; 3]), // wrong length
        triangles,
    })
    .unwrap();
    let expected = RepairReport {
        non_finite_vertices: 2,
        triangles_with_non_finite_vertex: 1,
        out_of_range_triangles: 1,
        degenerate_triangles: 2,
        unreferenced_vertices: 2, // 5 (its only triangle was degenerate) and 6
        invalid_normals: 1,
        invalid_uvs: 0,
        dropped_normals: false,
        dropped_uvs: true,
        computed_normals: 2,
    };
    assert_eq!(repaired.report, expected);
    assert_eq!(repaired.report.removed_triangles(), 4);
    assert!(!repaired.report.is_clean());
    assert_eq!(
        repaired.report.to_string(),
        "2 non-finite vertices removed, 1 triangles on non-finite vertices removed, \
         1 triangles with out-of-range indices removed, 2 degenerate triangles removed, \
         2 unreferenced vertices removed, 1 invalid normals recomputed, \
         UV array of the wrong length dropped"
    );
    let mesh = repaired.mesh;
    assert_eq!(mesh.positions.len(), 4);
    assert_eq!(mesh.triangles, vec![[0, 1, 2], [1, 3, 2]]);
    assert!(mesh.uvs.is_none());
    for n in &mesh.normals {
        approx_eq(*n, Vec3::Z, 1e-6);
    }
}

#[test]
fn clean_data_reports_no_repairs() {
    let sphere = Mesh::icosphere(1.0, 1);
    let repaired =
        Mesh::from_triangles(sphere.positions.clone(), sphere.triangles.clone()).unwrap();
    assert!(repaired.report.is_clean());
    assert_eq!(repaired.report.to_string(), "no repairs");
    assert_eq!(repaired.report.computed_normals, 42);
    // Computed (angle-weighted) normals of an icosphere are close to the exact ones.
    for (a, b) in repaired.mesh.normals.iter().zip(&sphere.normals) {
        approx_eq(*a, *b, 0.01);
    }
}

#[test]
fn nothing_usable_is_an_error() {
    let all_nan = MeshData {
        positions: vec![Vec3::NAN; 3],
        triangles: vec![[0, 1, 2]],
        ..Default::default()
    };
    let error = Mesh::from_data(all_nan).unwrap_err();
    let MeshError::NoUsableTriangles { report, .. } = &error else {
        panic!("{error}")
    };
    assert_eq!(report.non_finite_vertices, 3);
    assert!(
        error
            .to_string()
            .starts_with("no usable triangles: 3 vertices and 1 triangles given"),
        "{error}"
    );
    assert!(Mesh::from_data(MeshData::default()).is_err());
}

// ---------------------------------------------------------------- welding and normals

#[test]
fn uv_seam_is_welded_and_normals_stay_smooth() {
    // A torus whose u = 0 seam is split (duplicate vertices with different UVs), as an
    // exporter writes it.
    let (nu, nv) = (24u32, 12u32);
    let mut positions = Vec::new();
    let mut uvs = Vec::new();
    for i in 0..=nu {
        for j in 0..nv {
            let source = Mesh::torus(3.0, 1.0, nu, nv).positions[((i % nu) * nv + j) as usize];
            positions.push(source);
            uvs.push(Vec2::new(i as f32 / nu as f32, j as f32 / nv as f32));
        }
    }
    let mut triangles = Vec::new();
    for i in 0..nu {
        for j in 0..nv {
            let index = |i: u32, j: u32| i * nv + j % nv;
            let (a, b, c, d) = (
                index(i, j),
                index(i + 1, j),
                index(i + 1, j + 1),
                index(i, j + 1),
            );
            triangles.extend([[a, b, c], [a, c, d]]);
        }
    }
    let mesh = Mesh::from_data(MeshData {
        positions,
        normals: None,
        uvs: Some(uvs),
        triangles,
    })
    .unwrap()
    .mesh;
    assert_eq!(mesh.positions.len(), ((nu + 1) * nv) as usize);
    let welded = mesh.weld();
    assert_eq!(welded.vertex_count(), (nu * nv) as usize);
    for j in 0..nv as usize {
        let (first, last) = (j, (nu * nv) as usize + j);
        assert_eq!(
            welded.vertex_to_welded[first],
            welded.vertex_to_welded[last]
        );
        // Smooth across the seam: both copies get the same normal.
        assert_eq!(mesh.normals[first], mesh.normals[last]);
    }
    // Every welded edge is shared by exactly two triangles: the seam is closed.
    assert_closed(&welded.triangles);
}

fn assert_closed(triangles: &[[u32; 3]]) {
    let mut edges = std::collections::HashMap::new();
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    let open = edges.values().filter(|&&n| n != 2).count();
    assert_eq!(
        open,
        0,
        "{open} of {} edges are not shared by two triangles",
        edges.len()
    );
}

#[test]
fn two_sided_sheet_keeps_each_sides_normal() {
    // The same quad twice, the copy wound the other way: welded, the normals cancel, so each
    // side falls back to its own faces.
    let quad = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
    let positions = [quad, quad].concat();
    let triangles = vec![[0, 1, 2], [0, 2, 3], [4, 6, 5], [4, 7, 6]];
    let mesh = Mesh::from_triangles(positions, triangles).unwrap().mesh;
    assert_eq!(mesh.weld().vertex_count(), 4);
    for (i, n) in mesh.normals.iter().enumerate() {
        approx_eq(*n, if i < 4 { Vec3::Z } else { Vec3::NEG_Z }, 1e-6);
    }
}

#[test]
fn welding_treats_negative_zero_as_zero() {
    let positions = vec![
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(-0.0, 0.0, -0.0),
        Vec3::X,
    ];
    let welded = cdrf_core::mesh::Welded::from_triangles(&positions, &[[0, 2, 1]]);
    assert_eq!(welded.vertex_to_welded, vec![0, 0, 1]);
    assert_eq!(welded.triangles, vec![[0, 1, 0]]);
    assert_eq!(welded.to_mesh_vertices(&[7, 8]), vec![7, 7, 8]);
}

// ---------------------------------------------------------------- OBJ

#[test]
fn bunny_loads_closed_and_outward() {
    let loaded = Mesh::load(bunny_path()).unwrap();
    assert!(loaded.report.is_clean(), "{}", loaded.report);
    let mesh = loaded.mesh;
    assert_eq!(mesh.positions.len(), 1839);
    assert_eq!(mesh.triangles.len(), 3674);
    assert_eq!(loaded.report.computed_normals, 1839);
    assert_closed(&mesh.weld().triangles);
    assert!(signed_volume(&mesh) > 0.0, "{}", signed_volume(&mesh));
    // 9.66 units tall, one unit = 10 mm: curvature mostly positive, typical |κ| ~ 1/(a few cm).
    let k = mean_curvature_per_mm(&mesh, &CurvatureOptions::new(10.0)).unwrap();
    let mut sorted = k.clone();
    sorted.sort_by(f32::total_cmp);
    let median = sorted[sorted.len() / 2];
    let positive = k.iter().filter(|&&k| k > 0.0).count() as f32 / k.len() as f32;
    println!(
        "bunny: κ median {median:.4} /mm, 5 % {:.4}, 95 % {:.4}, {:.0} % positive",
        sorted[sorted.len() / 20],
        sorted[sorted.len() * 19 / 20],
        100.0 * positive
    );
    assert!((0.01..0.2).contains(&median), "{median}");
    assert!(positive > 0.6, "{positive}");
}

#[test]
fn obj_with_quads_uvs_and_nan() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("quad.obj");
    std::fs::write(
        &path,
        "mtllib missing.mtl\n\
         v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv nan 0 0\n\
         vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
         f 1/1 2/2 3/3 4/4\n\
         f 1/1 2/2 5/1\n",
    )
    .unwrap();
    let loaded = Mesh::load(&path).unwrap();
    assert_eq!(loaded.report.non_finite_vertices, 1);
    assert_eq!(loaded.report.triangles_with_non_finite_vertex, 1);
    let mesh = loaded.mesh;
    assert_eq!(mesh.triangles.len(), 2);
    assert_eq!(mesh.positions.len(), 4);
    // OBJ v = 0 is the image bottom: glTF v = 1.
    let uvs = mesh.uvs.as_ref().unwrap();
    let origin = mesh
        .positions
        .iter()
        .position(|&p| p == Vec3::ZERO)
        .unwrap();
    assert_eq!(uvs[origin], Vec2::new(0.0, 1.0));
    for n in &mesh.normals {
        approx_eq(*n, Vec3::Z, 1e-6);
    }
}

#[test]
fn obj_errors_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.obj");
    let error = Mesh::load(&missing).unwrap_err();
    assert!(matches!(error, LoadError::Io { .. }), "{error}");
    assert!(error.to_string().contains("missing.obj"), "{error}");

    let empty = dir.path().join("empty.obj");
    std::fs::write(&empty, "").unwrap();
    let error = Mesh::load(&empty).unwrap_err();
    assert!(matches!(error, LoadError::Unusable { .. }), "{error}");
    assert!(
        chain(&error).contains("empty.obj: no usable mesh: no usable triangles: 0 vertices"),
        "{}",
        chain(&error)
    );

    let bad_index = dir.path().join("bad_index.obj");
    std::fs::write(&bad_index, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n").unwrap();
    let error = Mesh::load(&bad_index).unwrap_err();
    assert!(error.to_string().contains("bad_index.obj"), "{error}");

    println!("{}", chain(&error));
    let garbage = dir.path().join("garbage.obj");
    std::fs::write(
        &garbage,
        [0xff_u8, 0xfe, 0x00, 0x13, 0x37, b'\n', b'f', b' ', b'x'],
    )
    .unwrap();
    let error = Mesh::load(&garbage).unwrap_err();
    println!("{}", chain(&error));
    assert!(error.to_string().contains("garbage.obj"), "{error}");

    let all_nan = dir.path().join("nan.obj");
    std::fs::write(&all_nan, "v nan 0 0\nv 1 nan 0\nv 0 1 inf\nf 1 2 3\n").unwrap();
    let error = Mesh::load(&all_nan).unwrap_err();
    assert!(
        chain(&error).contains("3 non-finite vertices removed"),
        "{}",
        chain(&error)
    );

    let unsupported = dir.path().join("mesh.ply");
    std::fs::write(&unsupported, "ply\n").unwrap();
    let error = Mesh::load(&unsupported).unwrap_err();
    assert!(
        matches!(error, LoadError::UnsupportedFormat { .. }),
        "{error}"
    );
}

// ---------------------------------------------------------------- glTF

fn floats(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|f| f.to_le_bytes()).collect()
}

/// A glTF with one buffer: a quad in the xy plane (4 positions, 4 normals tilted in x, six
/// u16 indices) and a second, normal-less triangle primitive; a parent node scaling x by 2
/// and a child translating by (0, 0, 5) that holds the mesh.
fn write_gltf(dir: &Path, name: &str, buffer_uri: &str, buffer: &[u8]) -> PathBuf {
    let json = format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [
    {{"scale": [2, 1, 1], "children": [1]}},
    {{"translation": [0, 0, 5], "mesh": 0}}
  ],
  "meshes": [{{"primitives": [
    {{"attributes": {{"POSITION": 0, "NORMAL": 1, "_EXTRA": 1}}, "indices": 2}},
    {{"attributes": {{"POSITION": 3}}}},
    {{"attributes": {{"POSITION": 0}}, "mode": 1}}
  ]}}],
  "buffers": [{{"byteLength": {len}, "uri": "{buffer_uri}"}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 48}},
    {{"buffer": 0, "byteOffset": 48, "byteLength": 48}},
    {{"buffer": 0, "byteOffset": 96, "byteLength": 12}},
    {{"buffer": 0, "byteOffset": 108, "byteLength": 36}}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}},
    {{"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"}},
    {{"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}},
    {{"bufferView": 3, "componentType": 5126, "count": 3, "type": "VEC3", "min": [3,0,0], "max": [4,1,0]}}
  ]
}}"#,
        len = buffer.len()
    );
    let path = dir.join(name);
    std::fs::write(&path, json).unwrap();
    path
}

fn gltf_buffer() -> Vec<u8> {
    let s = 0.5f32.sqrt();
    let mut bytes = floats(&[0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.]);
    bytes.extend(floats(&[s, 0., s, s, 0., s, s, 0., s, s, 0., s]));
    bytes.extend([0u16, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
    bytes.extend(floats(&[3., 0., 0., 4., 0., 0., 3., 1., 0.]));
    bytes
}

fn check_gltf_quad(mesh: &Mesh, report: &RepairReport) {
    assert_eq!(mesh.positions.len(), 7);
    assert_eq!(mesh.triangles.len(), 3);
    // World transform: scale x by 2, then (child) translate z by 5.
    approx_eq(mesh.positions[1], Vec3::new(2.0, 0.0, 5.0), 1e-6);
    approx_eq(mesh.positions[2], Vec3::new(2.0, 1.0, 5.0), 1e-6);
    approx_eq(mesh.positions[5], Vec3::new(8.0, 0.0, 5.0), 1e-6);
    // Normals through the inverse-transpose: (1, 0, 1)/√2 → (1/2, 0, 1) normalised.
    approx_eq(mesh.normals[0], Vec3::new(0.5, 0.0, 1.0).normalize(), 1e-6);
    // The normal-less primitive gets computed normals; the line primitive is skipped.
    approx_eq(mesh.normals[4], Vec3::Z, 1e-6);
    assert_eq!(report.computed_normals, 3);
    assert!(report.is_clean(), "{report}");
    assert!(mesh.uvs.is_none());
}

#[test]
fn gltf_with_data_uri_and_node_transforms() {
    let dir = tempfile::tempdir().unwrap();
    let buffer = gltf_buffer();
    let uri = format!("data:application/octet-stream;base64,{}", base64(&buffer));
    let path = write_gltf(dir.path(), "scene.gltf", &uri, &buffer);
    let loaded = Mesh::load(&path).unwrap();
    check_gltf_quad(&loaded.mesh, &loaded.report);
}

#[test]
fn gltf_with_external_buffer() {
    let dir = tempfile::tempdir().unwrap();
    let buffer = gltf_buffer();
    std::fs::write(dir.path().join("quad data.bin"), &buffer).unwrap();
    let path = write_gltf(dir.path(), "scene.gltf", "quad%20data.bin", &buffer);
    let loaded = Mesh::load(&path).unwrap();
    check_gltf_quad(&loaded.mesh, &loaded.report);

    // The buffer file missing: an I/O error naming that file.
    std::fs::remove_file(dir.path().join("quad data.bin")).unwrap();
    let error = Mesh::load(&path).unwrap_err();
    assert!(matches!(error, LoadError::Io { .. }), "{error}");
    assert!(error.to_string().contains("quad data.bin"), "{error}");
}

#[test]
fn gltf_errors_name_the_file_and_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let buffer = gltf_buffer();
    let uri = format!("data:application/octet-stream;base64,{}", base64(&buffer));

    // An accessor reaching past its buffer view.
    let path = write_gltf(dir.path(), "overrun.gltf", &uri, &buffer);
    let json = std::fs::read_to_string(&path).unwrap().replace(
        r#""count": 6, "type": "SCALAR""#,
        r#""count": 60, "type": "SCALAR""#,
    );
    std::fs::write(&path, json).unwrap();
    let error = Mesh::load(&path).unwrap_err();
    assert!(matches!(error, LoadError::GltfData { .. }), "{error}");
    let message = error.to_string();
    assert!(message.contains("overrun.gltf"), "{message}");
    assert!(
        message.contains("mesh 0 primitive 0 indices: accessor 2"),
        "{message}"
    );

    // A POSITION accessor that does not exist (gltf-json 1.4.1's validator would panic).
    let path = write_gltf(dir.path(), "no_accessor.gltf", &uri, &buffer);
    let json = std::fs::read_to_string(&path)
        .unwrap()
        .replace(r#""POSITION": 3"#, r#""POSITION": 30"#);
    std::fs::write(&path, json).unwrap();
    let error = Mesh::load(&path).unwrap_err();
    assert!(
        error.to_string().ends_with(
            "no_accessor.gltf: mesh 0 primitive 1 refers to accessor 30, but there are 4"
        ),
        "{error}"
    );

    // A short buffer.
    let path = write_gltf(
        dir.path(),
        "short.gltf",
        &uri,
        &[buffer.clone(), vec![0; 8]].concat(),
    );
    let error = Mesh::load(&path).unwrap_err();
    assert!(
        error
            .to_string()
            .contains("buffer 0 declares 152 bytes but has 144"),
        "{error}"
    );

    // Not JSON at all, and a GLB whose header lies about its length.
    let garbage = dir.path().join("garbage.gltf");
    std::fs::write(&garbage, "this is not glTF").unwrap();
    let error = Mesh::load(&garbage).unwrap_err();
    assert!(matches!(error, LoadError::Gltf { .. }), "{error}");
    assert!(
        error
            .to_string()
            .starts_with(&garbage.display().to_string()),
        "{error}"
    );
    let truncated = dir.path().join("truncated.glb");
    std::fs::write(&truncated, b"glTF\x02\0\0\0\x04\0\0\0").unwrap();
    let error = Mesh::load(&truncated).unwrap_err();
    assert!(
        error.to_string().contains("truncated or corrupt"),
        "{error}"
    );
    let tiny = dir.path().join("tiny.glb");
    std::fs::write(&tiny, b"glTF\x02").unwrap();
    assert!(Mesh::load(&tiny).is_err());
}

// ---------------------------------------------------------------- GLB export

#[test]
fn glb_round_trip_with_curvature() {
    let dir = tempfile::tempdir().unwrap();
    let mut mesh = Mesh::torus(3.0, 1.0, 24, 12);
    mesh.uvs = Some(
        (0..mesh.positions.len())
            .map(|i| Vec2::new(i as f32 / 288.0, 0.25))
            .collect(),
    );
    let curvature = mean_curvature_per_mm(&mesh, &CurvatureOptions::new(10.0)).unwrap();
    let path = dir.path().join("torus.glb");
    write_glb_with_curvature(&path, &mesh, &curvature).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(bytes.len() % 4, 0);
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        1,
        "no temporary file left behind"
    );

    // Read back with the gltf crate itself.
    let gltf = gltf::Gltf::from_slice(&bytes).unwrap();
    let blob = gltf.blob.clone().unwrap();
    let primitive = gltf.meshes().next().unwrap().primitives().next().unwrap();
    let semantic = gltf::Semantic::Extras(CURVATURE_ATTRIBUTE[1..].to_owned());
    let accessor = primitive.get(&semantic).expect("_CURVATURE attribute");
    assert_eq!(accessor.name(), Some("curvature_per_mm"));
    assert_eq!(accessor.dimensions(), gltf::accessor::Dimensions::Scalar);
    let read: Vec<f32> = gltf::accessor::Iter::<f32>::new(accessor, |_| Some(&blob[..]))
        .unwrap()
        .collect();
    assert_eq!(read, curvature);
    let positions = primitive.get(&gltf::Semantic::Positions).unwrap();
    assert_eq!(
        positions.min().unwrap(),
        gltf::json::Value::from(vec![-4.0, -4.0, -1.0])
    );
    assert_eq!(
        positions.max().unwrap(),
        gltf::json::Value::from(vec![4.0, 4.0, 1.0])
    );

    // And with our loader: the same mesh (normals renormalised, so within f32 rounding).
    let loaded = Mesh::load(&path).unwrap();
    assert!(loaded.report.is_clean(), "{}", loaded.report);
    assert_eq!(loaded.report.computed_normals, 0);
    assert!(loaded.mesh.positions == mesh.positions, "positions differ");
    assert!(loaded.mesh.triangles == mesh.triangles, "triangles differ");
    assert!(loaded.mesh.uvs == mesh.uvs, "uvs differ");
    for (a, b) in loaded.mesh.normals.iter().zip(&mesh.normals) {
        approx_eq(*a, *b, 1e-6);
    }
}

#[test]
fn glb_export_checks_lengths_and_never_leaves_partial_files() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = Mesh::icosphere(1.0, 1);
    let error = glb_bytes_with_curvature(&mesh, &[0.0; 3]).unwrap_err();
    assert_eq!(error.to_string(), "curvature has 3 entries for 42 vertices");

    let mut bad = mesh.clone();
    bad.triangles[0][1] = 100;
    let error = glb_bytes_with_curvature(&bad, &[0.0; 42]).unwrap_err();
    assert!(
        matches!(error, ExportError::IndexOutOfRange { index: 100, .. }),
        "{error}"
    );

    // A directory that does not exist: an error naming the path, nothing created.
    let path = dir.path().join("no/such/dir/out.glb");
    let error = write_glb_with_curvature(&path, &mesh, &[0.0; 42]).unwrap_err();
    assert!(matches!(error, ExportError::Io { .. }), "{error}");
    assert!(error.to_string().contains("out.glb"), "{error}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);

    // An existing file is replaced whole.
    let path = dir.path().join("out.glb");
    std::fs::write(&path, "old").unwrap();
    write_glb_with_curvature(&path, &mesh, &[0.5; 42]).unwrap();
    assert_eq!(
        std::fs::read(&path).unwrap(),
        glb_bytes_with_curvature(&mesh, &[0.5; 42]).unwrap()
    );
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}

#[test]
fn cuboid_faces_are_flat_outward_and_counter_clockwise() {
    let half = Vec3::new(30.0, 20.0, 2.0);
    let cuboid = Mesh::cuboid(half, 3);
    assert_eq!(
        (cuboid.positions.len(), cuboid.triangles.len()),
        (6 * 16, 12 * 9)
    );
    for [a, b, c] in &cuboid.triangles {
        let [a, b, c] = [*a, *b, *c].map(|i| cuboid.positions[i as usize]);
        let geometric = (b - a).cross(c - a).normalize();
        let centre = (a + b + c) / 3.0;
        assert!(
            geometric.dot(centre / half) > 0.5,
            "{geometric} at {centre}"
        );
        assert!(
            (a.abs() - half).abs().min_element() < 1e-5,
            "a vertex off the box: {a}"
        );
    }
    for (p, n) in cuboid.positions.iter().zip(&cuboid.normals) {
        assert!((p.dot(*n) - (half * n.abs()).element_sum()).abs() < 1e-5);
    }
}
