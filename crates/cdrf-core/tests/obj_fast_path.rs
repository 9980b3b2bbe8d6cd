//! OBJ files of `v` and `f` lines only are read by cdrf's own parallel reader; everything else
//! by tobj. The two must agree exactly: each file here is loaded as it is (fast path) and with
//! an `o` line added at the top (which sends it through tobj without changing the geometry).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use cdrf_core::mesh::Mesh;

fn both_ways(name: &str, text: &str) -> (Mesh, Mesh) {
    let dir = std::env::temp_dir().join(format!("cdrf-obj-fast-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let plain = dir.join("plain.obj");
    let through_tobj = dir.join("tobj.obj");
    std::fs::write(&plain, text).unwrap();
    std::fs::write(&through_tobj, format!("o object\n{text}")).unwrap();
    let load = |path: &PathBuf| {
        let loaded = Mesh::load(path).unwrap_or_else(|e| panic!("{name}: {e}"));
        (loaded.mesh, loaded.report)
    };
    let (fast, fast_report) = load(&plain);
    let (slow, slow_report) = load(&through_tobj);
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(fast_report, slow_report, "{name}: repair reports differ");
    (fast, slow)
}

fn assert_same(name: &str, text: &str) {
    let (fast, slow) = both_ways(name, text);
    assert_eq!(
        fast.positions.len(),
        slow.positions.len(),
        "{name}: vertex count"
    );
    assert_eq!(fast.triangles, slow.triangles, "{name}: triangles");
    assert_eq!(fast.positions, slow.positions, "{name}: positions");
    assert_eq!(fast.normals, slow.normals, "{name}: normals");
    assert_eq!(fast.uvs, slow.uvs, "{name}: uvs");
}

fn repo_file(path: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(path);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn bundled_meshes_load_the_same_both_ways() {
    assert_same("bunny", &repo_file("data/bunny/bunny.obj"));
    assert_same("torus", &repo_file("data/wax-torus/torus.obj"));
}

#[test]
fn polygons_relative_indices_and_unused_vertices_load_the_same_both_ways() {
    // Quads and a pentagon (fanned), relative indices, a vertex no face uses, vertices declared
    // after the faces that use them, point and line faces (ignored), comments and CRLF lines.
    let text = "# a comment\r\n#no space\r\nv 0 0 0\r\nv 1 0 0\r\nv 1 1 0\r\nv 0 1 0\r\n\
                v 9 9 9\r\n\r\nf 1 2 3 4\r\nf -4 -2 -1\r\nf 1 2\r\nf 3\r\nf 2 6 7 8 3\r\n\
                v 2 0 0\r\nv 2 1 0.5\r\nv 1.5 1.5 1\r\n";
    assert_same("polygons", text);
}

#[test]
fn a_large_grid_spanning_many_chunks_loads_the_same_both_ways() {
    // ~6 MB: several of the reader's 1 MB chunks, so relative indices cross chunk borders.
    let n = 300u32;
    let mut text = String::new();
    for j in 0..n {
        for i in 0..n {
            let (x, y) = (i as f32 / 7.0, j as f32 / 11.0);
            writeln!(text, "v {x} {y} {}", (x * y).sin()).unwrap();
        }
        if j > 0 {
            // The quads of the row below, half of them by relative index.
            for i in 0..n - 1 {
                let a = (j - 1) * n + i + 1;
                if i % 2 == 0 {
                    writeln!(text, "f {a} {} {} {}", a + 1, a + n + 1, a + n).unwrap();
                } else {
                    let so_far = i64::from((j + 1) * n);
                    let rel = |v: u32| i64::from(v) - so_far - 1;
                    writeln!(
                        text,
                        "f {} {} {} {}",
                        rel(a),
                        rel(a + 1),
                        rel(a + n + 1),
                        rel(a + n)
                    )
                    .unwrap();
                }
            }
        }
    }
    assert!(text.len() > 4 << 20, "{} bytes", text.len());
    let (fast, _) = both_ways("grid", &text);
    assert_eq!(fast.triangles.len(), 2 * ((n - 1) * (n - 1)) as usize);
    assert_same("grid", &text);
}

#[test]
fn files_the_fast_reader_does_not_take_still_load() {
    // A `w` coordinate, normals and UVs, an empty face, bad indices: tobj's business or the
    // pre-check's (and their errors).
    let cases = [
        ("w", "v 0 0 0 1\nv 1 0 0 1\nv 0 1 0 1\nf 1 2 3\n", true),
        (
            "vn-vt",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1\n",
            true,
        ),
        (
            "empty-face",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf\n",
            false,
        ),
        // The most negative index (its negation overflowed in the pre-check once) and zero.
        (
            "i64-min",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -9223372036854775808\n",
            false,
        ),
        ("zero", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", false),
    ];
    for (name, text, loads) in cases {
        let dir =
            std::env::temp_dir().join(format!("cdrf-obj-other-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("m.obj");
        std::fs::write(&path, text).unwrap();
        let result = Mesh::load(&path);
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(result.is_ok(), loads, "{name}: {:?}", result.err());
        if let Ok(loaded) = result {
            assert_eq!(loaded.mesh.triangles.len(), 1, "{name}");
        }
    }
}
