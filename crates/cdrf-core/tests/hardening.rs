//! Inputs that must end in a clear error (issue 18, part B): allocations sized by the input,
//! special files, paths that leave their folder, silently dropped array elements, unbounded
//! loops, non-finite results and unclear messages.

mod support;

use std::path::{Path, PathBuf};

use cdrf_core::curvature::{CurvatureOptions, MAX_SMOOTHING_ITERATIONS, mean_curvature_per_mm};
use cdrf_core::mesh::Mesh;
use cdrf_core::{RgbaImage, Scene, read_gaussian, read_lut};

use support::chain;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/hardening")
        .join(name)
}

/// The error and its sources, joined with ": ".
#[track_caller]
fn assert_contains(message: &str, needles: &[&str]) {
    for needle in needles {
        assert!(message.contains(needle), "{needle:?} missing in: {message}");
    }
}

// --- allocations sized by the input --------------------------------------------------------

#[test]
fn exr_windows_over_the_limit_are_refused_before_decoding() {
    for (name, window) in [
        ("exr_huge_datawindow.exr", "data window"),
        ("exr_huge_displaywindow.exr", "display window"),
        ("exr_display_30000.exr", "display window"),
    ] {
        let path = fixture(name);
        let message = chain(&RgbaImage::read_exr(&path).unwrap_err());
        assert_contains(&message, &[name, window, "limit"]);
    }
}

#[test]
fn special_files_are_refused_as_luts_and_buffers() {
    let message = chain(&read_lut("/dev/zero").unwrap_err());
    assert_contains(&message, &["/dev/zero", "not a regular file"]);
    let message = chain(&RgbaImage::read_exr("/dev/zero").unwrap_err());
    assert_contains(&message, &["/dev/zero", "not a regular file"]);
    let dir = tempfile::tempdir().unwrap();
    let toml = dir.path().join("gaussian.toml");
    std::fs::write(
        &toml,
        "sigma_mm = [1.0, 1.0, 1.0]\nscale = [1.0, 1.0, 1.0]\nview_correction_from = \"/dev/zero\"\n",
    )
    .unwrap();
    let parameters = read_gaussian(&toml).unwrap();
    let message = chain(&parameters.load_model(&toml).unwrap_err());
    assert_contains(
        &message,
        &["view_correction_from", "/dev/zero", "not a regular file"],
    );
}

/// A glTF of a `vertices`-vertex triangle list instanced 2^`levels` times through a binary tree
/// of nodes, its buffer in `mesh.bin` (or `uri`).
fn write_instanced_gltf(dir: &Path, vertices: usize, levels: usize, uri: &str) -> PathBuf {
    let mut bytes = Vec::new();
    for i in 0..vertices {
        let p = [i as f32, (i % 3) as f32, (i * i % 7) as f32];
        for c in p {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    std::fs::write(dir.join("mesh.bin"), &bytes).unwrap();
    // Node k has two children, both node k + 1; the last node holds the mesh.
    let mut nodes = Vec::new();
    for k in 0..levels {
        nodes.push(format!(r#"{{"children": [{0}, {0}]}}"#, k + 1));
    }
    nodes.push(r#"{"mesh": 0}"#.to_owned());
    let json = format!(
        r#"{{"asset": {{"version": "2.0"}},
 "buffers": [{{"byteLength": {len}, "uri": "{uri}"}}],
 "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": {len}}}],
 "accessors": [{{"bufferView": 0, "componentType": 5126, "count": {vertices}, "type": "VEC3",
   "min": [0, 0, 0], "max": [1, 1, 1]}}],
 "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
 "nodes": [{nodes}], "scenes": [{{"nodes": [0]}}], "scene": 0}}"#,
        len = bytes.len(),
        nodes = nodes.join(", ")
    );
    let path = dir.join("model.gltf");
    std::fs::write(&path, json).unwrap();
    path
}

#[test]
fn gltf_instancing_past_the_vertex_limit_is_refused_before_building() {
    let dir = tempfile::tempdir().unwrap();
    // 2^17 instances of 129 vertices: 16.9 M vertices, over the 2^24 limit; 262 KB on disk.
    let path = write_instanced_gltf(dir.path(), 129, 17, "mesh.bin");
    let message = chain(&Mesh::load(&path).unwrap_err());
    assert_contains(&message, &["model.gltf", "instanc", "16908288", "limit"]);
    // A few instances are fine.
    let small = write_instanced_gltf(dir.path(), 129, 2, "mesh.bin");
    assert_eq!(Mesh::load(&small).unwrap().mesh.triangles.len(), 4 * 43);
}

// --- paths that leave the file's folder -----------------------------------------------------

#[test]
fn gltf_buffer_uris_must_stay_in_the_folder() {
    let root = tempfile::tempdir().unwrap();
    let inner = root.path().join("model");
    std::fs::create_dir(&inner).unwrap();
    write_instanced_gltf(root.path(), 3, 0, "mesh.bin");
    let outside = root.path().join("mesh.bin").display().to_string();
    for (uri, expected) in [
        ("../mesh.bin", "leaves"),
        (outside.as_str(), "absolute"),
        ("/dev/zero", "absolute"),
    ] {
        let path = write_instanced_gltf(&inner, 3, 0, uri);
        let message = chain(&Mesh::load(&path).unwrap_err());
        assert_contains(&message, &["model.gltf", "buffer 0", expected]);
    }
    // A name inside the folder still works.
    let path = write_instanced_gltf(&inner, 3, 0, "./mesh.bin");
    assert!(Mesh::load(&path).is_ok());
}

// --- silently dropped array elements --------------------------------------------------------

const SCENE: &str = r#"
[mesh]
path = "m.obj"
CURVATURE

[camera]
projection = "orthographic"
eye = [0.0, 0.0, 5.0]
target = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
ortho_half_height = 1.0
width = 64
height = 64

[[light]]
to_light = TO_LIGHT
irradiance = IRRADIANCE

[shading]
model = "lambert"
"#;

fn scene(to_light: &str, irradiance: &str, curvature: &str) -> Result<Scene, String> {
    let text = SCENE
        .replace("TO_LIGHT", to_light)
        .replace("IRRADIANCE", irradiance)
        .replace("CURVATURE", curvature);
    Scene::from_toml_str(&text, Path::new("/s"), Path::new("scene.toml"))
        .map_err(|error| chain(&error))
}

#[test]
fn scene_arrays_of_the_wrong_length_are_errors() {
    scene("[1.0, 0.0, 0.0]", "[1.0, 1.0, 1.0]", "").expect("the good scene loads");
    let message = scene("[1.0, 0.0, 0.0, 5.0]", "[1.0, 1.0, 1.0]", "").unwrap_err();
    assert_contains(&message, &["scene.toml", "to_light", "exactly 3", "4"]);
    let message = scene("[1.0, 0.0, 0.0]", "[1.0, 1.0, 1.0, 1.0]", "").unwrap_err();
    assert_contains(&message, &["scene.toml", "irradiance", "exactly 3"]);
    let message = scene("[1.0, 0.0]", "[1.0, 1.0, 1.0]", "").unwrap_err();
    assert_contains(&message, &["scene.toml", "to_light", "exactly 3", "2"]);
}

#[test]
fn gaussian_toml_with_a_fourth_sigma_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("gaussian.toml");
    std::fs::write(
        &path,
        "sigma_mm = [1.0, 2.0, 3.0, 4.0]\nscale = [1.0, 1.0, 1.0]\n",
    )
    .unwrap();
    let message = chain(&read_gaussian(&path).unwrap_err());
    assert_contains(&message, &["gaussian.toml", "sigma_mm", "exactly 3", "4"]);
}

// --- unbounded loops ------------------------------------------------------------------------

#[test]
fn curvature_smoothing_is_bounded() {
    let message = scene(
        "[1.0, 0.0, 0.0]",
        "[1.0, 1.0, 1.0]",
        "curvature_smoothing = 4294967295",
    )
    .unwrap_err();
    assert_contains(
        &message,
        &[
            "scene.toml",
            "curvature_smoothing",
            &MAX_SMOOTHING_ITERATIONS.to_string(),
        ],
    );
    let mesh = Mesh::icosphere(1.0, 1);
    let options = CurvatureOptions::new(1.0).with_smoothing_iterations(u32::MAX);
    let message = mean_curvature_per_mm(&mesh, &options)
        .unwrap_err()
        .to_string();
    assert_contains(
        &message,
        &["smoothing", &MAX_SMOOTHING_ITERATIONS.to_string()],
    );
    let options = CurvatureOptions::new(1.0).with_smoothing_iterations(MAX_SMOOTHING_ITERATIONS);
    assert!(mean_curvature_per_mm(&mesh, &options).is_ok());
}

// --- non-finite results ---------------------------------------------------------------------

#[test]
fn non_finite_curvature_is_an_error_that_says_where() {
    let mut mesh = Mesh::icosphere(1.0, 1);
    for p in &mut mesh.positions {
        *p *= 1e38;
    }
    let message = mean_curvature_per_mm(&mesh, &CurvatureOptions::new(1.0))
        .unwrap_err()
        .to_string();
    assert_contains(&message, &["vertex", "not finite"]);
    let mesh = Mesh::icosphere(1.0, 1);
    let message = mean_curvature_per_mm(&mesh, &CurvatureOptions::new(1e-45))
        .unwrap_err()
        .to_string();
    assert_contains(&message, &["vertex", "not finite", "mm_per_unit"]);
}

// --- messages -------------------------------------------------------------------------------

#[test]
fn obj_errors_say_what_is_wrong() {
    let dir = tempfile::tempdir().unwrap();
    // A Latin-1 comment is harmless: the file loads.
    let latin1 = dir.path().join("latin1.obj");
    let mut bytes = b"# caf\xe9\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".to_vec();
    std::fs::write(&latin1, &bytes).unwrap();
    assert_eq!(Mesh::load(&latin1).unwrap().mesh.triangles.len(), 1);
    // Binary data outside a comment names the line.
    bytes.extend_from_slice(b"v 1 \xff\x00 2\n");
    let binary = dir.path().join("binary.obj");
    std::fs::write(&binary, &bytes).unwrap();
    let message = chain(&Mesh::load(&binary).unwrap_err());
    assert_contains(&message, &["binary.obj", "line 6", "not UTF-8 text"]);
    // A folder says so.
    let folder = dir.path().join("folder.obj");
    std::fs::create_dir(&folder).unwrap();
    let message = chain(&Mesh::load(&folder).unwrap_err());
    assert_contains(&message, &["folder.obj", "folder"]);
}
