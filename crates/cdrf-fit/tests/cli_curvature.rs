//! Runs the built `cdrf-curvature` binary in a temporary directory (ripgrep's `TestCommand`
//! style): outputs, units, and clear failures that leave nothing behind.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use cdrf_core::mesh::Mesh;

fn bunny() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/bunny/bunny.obj")
}

/// A temporary working directory and the binary run inside it.
struct TestCommand {
    dir: tempfile::TempDir,
}

impl TestCommand {
    fn new() -> Self {
        Self {
            dir: tempfile::tempdir().expect("temporary directory"),
        }
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    fn write(&self, name: &str, contents: impl AsRef<[u8]>) -> PathBuf {
        let path = self.path(name);
        std::fs::write(&path, contents).expect("write test input");
        path
    }

    fn run(&self, args: &[&str]) -> Output {
        Command::new(env!("CARGO_BIN_EXE_cdrf-curvature"))
            .current_dir(self.dir.path())
            .args(args)
            .output()
            .expect("run cdrf-curvature")
    }

    /// Runs and expects success; returns stdout.
    fn ok(&self, args: &[&str]) -> String {
        let output = self.run(args);
        assert!(
            output.status.success(),
            "{args:?} failed with {}:\n{}",
            output.status,
            String::from_utf8_lossy(&output.stderr)
        );
        String::from_utf8(output.stdout).expect("UTF-8 stdout")
    }

    /// Runs and expects failure with `code`; returns stderr.
    fn fails(&self, args: &[&str], code: i32) -> String {
        let output = self.run(args);
        assert_eq!(
            output.status.code(),
            Some(code),
            "{args:?}: stdout {}\nstderr {}",
            String::from_utf8_lossy(&output.stdout),
            String::from_utf8_lossy(&output.stderr)
        );
        String::from_utf8(output.stderr).expect("UTF-8 stderr")
    }

    fn files(&self) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(self.dir.path())
            .expect("list directory")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }
}

/// Parses the CSV: header and rows of (x, y, z, curvature_per_mm).
fn read_csv(path: &Path) -> (String, Vec<[f32; 4]>) {
    let text = std::fs::read_to_string(path).expect("read CSV");
    let mut lines = text.lines();
    let header = lines.next().expect("header").to_owned();
    let rows = lines
        .map(|line| {
            let values: Vec<f32> = line
                .split(',')
                .map(|v| v.parse().expect("number"))
                .collect();
            values.try_into().expect("4 columns")
        })
        .collect();
    (header, rows)
}

#[test]
fn glb_output_carries_curvature() {
    let cmd = TestCommand::new();
    let bunny = bunny();
    let stdout = cmd.ok(&[
        bunny.to_str().unwrap(),
        "--mm-per-unit",
        "10",
        "--out",
        "bunny.glb",
    ]);
    println!("{stdout}");
    assert!(stdout.contains("1839 vertices, 3674 triangles"), "{stdout}");
    assert!(stdout.contains("no repairs -> bunny.glb"), "{stdout}");
    assert_eq!(cmd.files(), ["bunny.glb"]);

    let bytes = std::fs::read(cmd.path("bunny.glb")).unwrap();
    let gltf = gltf::Gltf::from_slice(&bytes).unwrap();
    let blob = gltf.blob.clone().unwrap();
    let primitive = gltf.meshes().next().unwrap().primitives().next().unwrap();
    let accessor = primitive
        .get(&gltf::Semantic::Extras("CURVATURE".into()))
        .expect("_CURVATURE");
    let curvature: Vec<f32> = gltf::accessor::Iter::<f32>::new(accessor, |_| Some(&blob[..]))
        .unwrap()
        .collect();
    assert_eq!(curvature.len(), 1839);
    // The bunny, 97 mm tall: typical κ of a few hundredths per mm, mostly convex.
    let positive = curvature.iter().filter(|&&k| k > 0.0).count();
    assert!(positive > 1839 * 6 / 10, "{positive}");
    assert!(curvature.iter().all(|k| k.is_finite() && k.abs() < 1.0));
    assert_eq!(
        Mesh::load(cmd.path("bunny.glb"))
            .unwrap()
            .mesh
            .positions
            .len(),
        1839
    );
}

#[test]
fn csv_rows_are_welded_vertices_in_file_units() {
    let cmd = TestCommand::new();
    // A cube with per-face UVs: 24 render vertices, 8 welded.
    let mut obj = String::new();
    for z in [0, 1] {
        for y in [0, 1] {
            for x in [0, 1] {
                obj.push_str(&format!("v {x} {y} {z}\n"));
            }
        }
    }
    obj.push_str("vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n");
    for face in [
        [1, 3, 4, 2],
        [5, 6, 8, 7],
        [1, 2, 6, 5],
        [3, 7, 8, 4],
        [1, 5, 7, 3],
        [2, 4, 8, 6],
    ] {
        obj.push_str(&format!(
            "f {}/1 {}/2 {}/3 {}/4\n",
            face[0], face[1], face[2], face[3]
        ));
    }
    cmd.write("cube.obj", obj);
    let stdout = cmd.ok(&["cube.obj", "--mm-per-unit", "1", "--out", "cube.csv"]);
    assert!(
        stdout.contains("8 welded vertices, 12 triangles"),
        "{stdout}"
    );
    let (header, rows) = read_csv(&cmd.path("cube.csv"));
    assert_eq!(header, "x,y,z,curvature_per_mm");
    assert_eq!(rows.len(), 8);
    for [x, y, z, k] in &rows {
        assert!([x, y, z].iter().all(|c| **c == 0.0 || **c == 1.0));
        // A cube's corners: convex, positive.
        assert!(*k > 0.0, "{k}");
    }
}

#[test]
fn mm_per_unit_scales_the_curvature() {
    let cmd = TestCommand::new();
    let bunny = bunny();
    let bunny = bunny.to_str().unwrap();
    cmd.ok(&[bunny, "--mm-per-unit", "1", "--out", "mm.csv"]);
    cmd.ok(&[bunny, "--mm-per-unit", "10", "--out", "cm.csv"]);
    let (_, mm) = read_csv(&cmd.path("mm.csv"));
    let (_, cm) = read_csv(&cmd.path("cm.csv"));
    assert_eq!(mm.len(), 1839);
    for (a, b) in mm.iter().zip(&cm) {
        assert_eq!(a[..3], b[..3], "positions stay in file units");
        assert!(
            (a[3] - 10.0 * b[3]).abs() <= 1e-5 * a[3].abs(),
            "{} vs {}",
            a[3],
            b[3]
        );
    }
}

#[test]
fn smoothing_reduces_the_spread() {
    let cmd = TestCommand::new();
    let bunny = bunny();
    let bunny = bunny.to_str().unwrap();
    cmd.ok(&[bunny, "--mm-per-unit", "10", "--out", "raw.csv"]);
    cmd.ok(&[
        bunny,
        "--mm-per-unit",
        "10",
        "--out",
        "smooth.csv",
        "--smoothing",
        "5",
    ]);
    let spread = |path: &Path| {
        let (_, rows) = read_csv(path);
        let mean = rows.iter().map(|r| r[3]).sum::<f32>() / rows.len() as f32;
        rows.iter().map(|r| (r[3] - mean).powi(2)).sum::<f32>() / rows.len() as f32
    };
    let (raw, smooth) = (
        spread(&cmd.path("raw.csv")),
        spread(&cmd.path("smooth.csv")),
    );
    // Measured: 0.00301 raw, 0.00140 smoothed.
    println!("bunny κ variance: raw {raw:.6}, 5 smoothing iterations {smooth:.6}");
    assert!(smooth < 0.6 * raw, "{smooth} vs {raw}");
}

#[test]
fn bad_meshes_fail_clearly_and_leave_nothing() {
    let cmd = TestCommand::new();
    cmd.write(
        "garbage.glb",
        b"glTF\x02\0\0\0\xff\xff\0\0 definitely not a GLB",
    );
    cmd.write("empty.obj", "");
    cmd.write("nan.obj", "v nan 0 0\nv 0 nan 0\nv 0 0 nan\nf 1 2 3\n");
    cmd.write("text.gltf", "hello");
    // An existing output must survive a failed run untouched.
    cmd.write("out.glb", "previous");
    for (input, expected) in [
        ("missing.obj", "missing.obj: cannot read"),
        ("garbage.glb", "garbage.glb"),
        ("empty.obj", "empty.obj: no usable mesh"),
        ("nan.obj", "3 non-finite vertices removed"),
        ("text.gltf", "text.gltf: invalid glTF"),
    ] {
        for out in ["out.glb", "new.csv"] {
            let stderr = cmd.fails(&[input, "--mm-per-unit", "1", "--out", out], 1);
            assert!(stderr.starts_with("error: "), "{stderr}");
            assert!(stderr.contains(expected), "{input}: {stderr}");
        }
    }
    assert_eq!(
        cmd.files(),
        [
            "empty.obj",
            "garbage.glb",
            "nan.obj",
            "out.glb",
            "text.gltf"
        ]
    );
    assert_eq!(std::fs::read(cmd.path("out.glb")).unwrap(), b"previous");
}

#[test]
fn bad_arguments_fail_clearly() {
    let cmd = TestCommand::new();
    let bunny = bunny();
    let bunny = bunny.to_str().unwrap();
    let stderr = cmd.fails(&[bunny, "--mm-per-unit", "1", "--out", "out.ply"], 1);
    assert!(
        stderr.contains("--out out.ply: unsupported output format (expected a .glb or .csv file)"),
        "{stderr}"
    );
    for scale in ["0", "-2", "inf", "NaN"] {
        let stderr = cmd.fails(&[bunny, "--mm-per-unit", scale, "--out", "out.glb"], 1);
        assert!(stderr.contains("must be a finite number > 0"), "{stderr}");
    }
    let stderr = cmd.fails(&[bunny, "--out", "out.glb"], 2);
    assert!(stderr.contains("--mm-per-unit"), "{stderr}");
    let stderr = cmd.fails(&[bunny, "--mm-per-unit", "ten", "--out", "out.glb"], 2);
    assert!(stderr.contains("invalid value 'ten'"), "{stderr}");
    // A directory that does not exist: error naming the path, exit 1.
    let stderr = cmd.fails(&[bunny, "--mm-per-unit", "1", "--out", "no/dir/out.csv"], 1);
    assert!(stderr.contains("no/dir/out.csv: cannot write"), "{stderr}");
    assert!(cmd.files().is_empty(), "{:?}", cmd.files());
}

// ---------------------------------------------------------------------------------------------
// Hardening (issue 18, part B)

#[test]
fn smoothing_is_bounded_at_parse_time() {
    let cmd = TestCommand::new();
    let mesh = cmd.write("t.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let mesh = mesh.to_str().unwrap();
    let stderr = cmd.fails(
        &[
            mesh,
            "--mm-per-unit",
            "1",
            "--smoothing",
            "4294967295",
            "--out",
            "o.glb",
        ],
        2,
    );
    assert!(
        stderr.contains("--smoothing") && stderr.contains("1000"),
        "{stderr}"
    );
    assert_eq!(cmd.files(), ["t.obj"]);
}

#[test]
fn output_that_is_the_input_is_refused() {
    let cmd = TestCommand::new();
    std::fs::copy(bunny(), cmd.path("in.obj")).unwrap();
    let before = std::fs::read(cmd.path("in.obj")).unwrap();
    // Export the bunny as GLB, then try to overwrite it in place, also through another name.
    cmd.ok(&["in.obj", "--mm-per-unit", "10", "--out", "in.glb"]);
    let glb = std::fs::read(cmd.path("in.glb")).unwrap();
    for out in ["in.glb", "./in.glb"] {
        let stderr = cmd.fails(&["in.glb", "--mm-per-unit", "10", "--out", out], 1);
        assert!(stderr.contains("is the input"), "{stderr}");
    }
    assert_eq!(std::fs::read(cmd.path("in.glb")).unwrap(), glb);
    assert_eq!(std::fs::read(cmd.path("in.obj")).unwrap(), before);
}

#[test]
fn non_finite_curvature_is_an_error() {
    let cmd = TestCommand::new();
    cmd.write(
        "huge.obj",
        "v 0 0 0\nv 1e38 0 0\nv 0 1e38 0\nv 0 0 1e38\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
    );
    cmd.write(
        "t.obj",
        "v 0 0 1\nv 1 0 0\nv 0 1 0\nv 0 0 0\nf 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n",
    );
    for (mesh, scale) in [("huge.obj", "1"), ("t.obj", "1e-45")] {
        let stderr = cmd.fails(&[mesh, "--mm-per-unit", scale, "--out", "o.csv"], 1);
        assert!(
            stderr.contains("not finite") && stderr.contains("vertex"),
            "{stderr}"
        );
    }
    assert_eq!(cmd.files(), ["huge.obj", "t.obj"]);
}

#[test]
fn gltf_node_scale_that_overflows_is_an_error() {
    let cmd = TestCommand::new();
    // A tetrahedron (data: URI buffer) under a node scaled by 1e30.
    let mut buffer = Vec::new();
    for p in [
        [0.0f32, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0],
    ] {
        for c in p {
            buffer.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in [0u16, 1, 2, 0, 2, 3, 0, 3, 1, 1, 3, 2] {
        buffer.extend_from_slice(&i.to_le_bytes());
    }
    const B64: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut encoded = String::new();
    for chunk in buffer.chunks(3) {
        let n = chunk
            .iter()
            .enumerate()
            .fold(0u32, |n, (i, &b)| n | u32::from(b) << (16 - 8 * i));
        for k in 0..4 {
            encoded.push(if k <= chunk.len() {
                B64[(n >> (18 - 6 * k) & 63) as usize] as char
            } else {
                '='
            });
        }
    }
    cmd.write(
        "scaled.gltf",
        format!(
            r#"{{"asset": {{"version": "2.0"}},
 "buffers": [{{"byteLength": 72, "uri": "data:application/octet-stream;base64,{encoded}"}}],
 "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 48}},
                 {{"buffer": 0, "byteOffset": 48, "byteLength": 24}}],
 "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                 "min": [0, 0, 0], "max": [1, 1, 1]}},
               {{"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR"}}],
 "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1}}]}}],
 "nodes": [{{"mesh": 0, "scale": [1e30, 1e30, 1e30]}}], "scenes": [{{"nodes": [0]}}], "scene": 0}}"#
        ),
    );
    let stderr = cmd.fails(&["scaled.gltf", "--mm-per-unit", "1", "--out", "o.glb"], 1);
    assert!(
        stderr.contains("not finite") && stderr.contains("vertex 0"),
        "{stderr}"
    );
    assert_eq!(cmd.files(), ["scaled.gltf"]);
}
