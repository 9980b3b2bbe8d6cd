//! Curvature throughput on a ≥ 1M-vertex mesh, parallel vs one thread, and accuracy against the
//! analytic torus; the time to cut that mesh into the inter-reflection's patches; the cost of
//! filtering curvature over 5 mm on a 10 000- and a 163 842-vertex mesh.
//! `cargo bench -p cdrf-core --bench curvature`; `… -- torus` or `… -- filter` runs one part.
//!
//! With `CDRF_BENCH_EXPORT=DIR` it also writes, for the big torus and the analytic test shapes,
//! `NAME.obj`, `NAME.truth.txt` (analytic mean curvature per vertex), `NAME.cdrf.txt` (this
//! estimator's values) and `cdrf_timings.json`, the input of `scripts/compare_libigl.py`.

#[path = "../tests/common/mod.rs"]
mod common;

use std::io::Write;
use std::path::Path;
use std::time::{Duration, Instant};

use cdrf_core::curvature::{
    CurvatureOptions, curvature_per_mm, mean_curvature_per_mm, mean_curvature_per_mm_welded,
};
use cdrf_core::mesh::Mesh;
use cdrf_core::patches::SurfacePatches;
use common::{ellipsoid_mean_curvature, irregular_ellipsoid, relative_error, torus_mean_curvature};
use glam::Vec3;

/// Best of `runs` wall-clock times (the least disturbed by the rest of the machine).
fn best_time<T>(runs: usize, mut f: impl FnMut() -> T) -> (Duration, T) {
    let mut best = Duration::MAX;
    let mut out = None;
    for _ in 0..runs {
        let start = Instant::now();
        let value = f();
        best = best.min(start.elapsed());
        out = Some(value);
    }
    (best, out.expect("runs > 0"))
}

fn main() {
    // Arguments not starting with `--` (cargo passes `--bench`) name the parts to run.
    let parts: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let run = |part: &str| parts.is_empty() || parts.iter().any(|p| p == part);
    if run("torus") {
        torus();
    }
    if run("filter") {
        filter();
    }
}

/// Filtering curvature over 5 mm (`CurvatureOptions::filter_length_mm`): the time it adds to
/// the estimate, for the mean curvature alone and with the anisotropy (whose six tensor
/// components are filtered too). The large mesh is timed once per setting.
fn filter() {
    let threads = rayon::current_num_threads();
    let radii = Vec3::new(60.0, 40.0, 20.0);
    let length_mm = 5.0;
    let plain = CurvatureOptions::default();
    let filtered = plain.with_filter_length_mm(length_mm);
    for (name, mesh, runs) in [
        (
            "3:2:1 ellipsoid (60 mm), hull of 10 000 random points",
            irregular_ellipsoid(radii, 10_000, 1),
            5,
        ),
        (
            "3:2:1 ellipsoid (60 mm), icosphere subdivided 7 times",
            Mesh::ellipsoid(radii, 7),
            1,
        ),
    ] {
        let edge_sum: f32 = mesh
            .triangles
            .iter()
            .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
            .map(|(a, b)| (mesh.positions[a as usize] - mesh.positions[b as usize]).length())
            .sum();
        let mean_edge = edge_sum / (3 * mesh.triangles.len()) as f32;
        println!(
            "{name}: {} vertices, mean edge {mean_edge:.2} mm, filter {length_mm} mm \
             ({:.1} edges), {threads} threads",
            mesh.positions.len(),
            length_mm / mean_edge
        );
        let mean = |options| {
            best_time(runs, || {
                mean_curvature_per_mm_welded(&mesh.positions, &mesh.triangles, options)
                    .expect("valid mesh")
            })
            .0
        };
        let full = |options| {
            best_time(runs, || {
                curvature_per_mm(&mesh, options).expect("valid mesh")
            })
            .0
        };
        let (mean_plain, mean_filtered) = (mean(&plain), mean(&filtered));
        let (full_plain, full_filtered) = (full(&plain), full(&filtered));
        println!(
            "  mean curvature: estimate {:7.3} s, filtered {:7.3} s: the filter adds {:7.3} s",
            mean_plain.as_secs_f64(),
            mean_filtered.as_secs_f64(),
            mean_filtered.as_secs_f64() - mean_plain.as_secs_f64()
        );
        println!(
            "  with anisotropy: estimate {:7.3} s, filtered {:7.3} s: the filter adds {:7.3} s",
            full_plain.as_secs_f64(),
            full_filtered.as_secs_f64(),
            full_filtered.as_secs_f64() - full_plain.as_secs_f64()
        );
    }
}

fn torus() {
    let export = std::env::var_os("CDRF_BENCH_EXPORT").map(std::path::PathBuf::from);
    let options = CurvatureOptions::default();
    let one_thread = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a 1-thread pool");
    let threads = rayon::current_num_threads();

    let (major, minor) = (3.0f32, 1.0f32);
    let (build, mesh) = best_time(1, || Mesh::torus(major, minor, 1024, 1024));
    let vertices = mesh.positions.len();
    println!(
        "torus 1024 x 1024 (R = {major}, a = {minor}): {vertices} vertices, {} triangles (built in {:.2} s)",
        mesh.triangles.len(),
        build.as_secs_f64()
    );

    let rate = |d: Duration| vertices as f64 / d.as_secs_f64();
    let (parallel, curvature) = best_time(5, || {
        mean_curvature_per_mm_welded(&mesh.positions, &mesh.triangles, &options)
            .expect("valid mesh")
    });
    let (serial, serial_curvature) = best_time(3, || {
        one_thread.install(|| {
            mean_curvature_per_mm_welded(&mesh.positions, &mesh.triangles, &options)
                .expect("valid mesh")
        })
    });
    assert_eq!(
        curvature, serial_curvature,
        "results must not depend on the thread count"
    );
    let (with_weld, _) = best_time(3, || mean_curvature_per_mm(&mesh, &options).expect("valid"));
    let (smoothed, smoothed_curvature) = best_time(3, || {
        mean_curvature_per_mm_welded(
            &mesh.positions,
            &mesh.triangles,
            &options.with_smoothing_iterations(1),
        )
        .expect("valid mesh")
    });
    println!(
        "mean_curvature_per_mm_welded, {threads} threads: {:7.3} s  {:6.2} M vertices/s",
        parallel.as_secs_f64(),
        rate(parallel) / 1e6
    );
    println!(
        "mean_curvature_per_mm_welded, 1 thread:  {:7.3} s  {:6.2} M vertices/s  (parallel speed-up {:.2}x)",
        serial.as_secs_f64(),
        rate(serial) / 1e6,
        serial.as_secs_f64() / parallel.as_secs_f64()
    );
    println!(
        "mean_curvature_per_mm (weld + map back), {threads} threads: {:7.3} s  {:6.2} M vertices/s",
        with_weld.as_secs_f64(),
        rate(with_weld) / 1e6
    );
    println!(
        "with 1 smoothing iteration, {threads} threads: {:7.3} s  {:6.2} M vertices/s",
        smoothed.as_secs_f64(),
        rate(smoothed) / 1e6
    );
    let truth: Vec<f64> = mesh
        .positions
        .iter()
        .map(|&p| torus_mean_curvature(major.into(), minor.into(), p))
        .collect();
    println!(
        "error vs analytic torus: {}",
        relative_error(&curvature, &truth)
    );
    // At this resolution the f32 positions (spacing 0.006 at |p| ≈ 3) limit the raw estimate;
    // one smoothing round averages that rounding noise away.
    println!(
        "error vs analytic torus, 1 smoothing iteration: {}",
        relative_error(&smoothed_curvature, &truth)
    );

    // The renderer cuts each mesh into patches for the inter-reflection when it is created.
    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    for target in [256, 1024] {
        let (cut, patches) = best_time(3, || {
            SurfacePatches::build(&mesh.positions, &mesh.normals, &curvature, &indices, target)
        });
        println!(
            "SurfacePatches::build, {target} patches, {threads} threads: {:7.3} s  ({} patches)",
            cut.as_secs_f64(),
            patches.patches.len()
        );
    }

    if let Some(dir) = export {
        std::fs::create_dir_all(&dir).expect("export directory");
        let mut timings = Vec::new();
        timings.push(("torus_1024x1024".to_owned(), parallel, serial));
        write_case(&dir, "torus_1024x1024", &mesh, &truth, &curvature);
        let radii = Vec3::new(3.0, 2.0, 1.0);
        let torus = |p| torus_mean_curvature(3.0, 1.0, p);
        let ellipsoid = |p| ellipsoid_mean_curvature(radii, p);
        let cases = [
            case("sphere_s3", Mesh::icosphere(1.0, 3), |_| 1.0),
            case("sphere_s5", Mesh::icosphere(1.0, 5), |_| 1.0),
            case("torus_64x32", Mesh::torus(3.0, 1.0, 64, 32), torus),
            case("torus_256x128", Mesh::torus(3.0, 1.0, 256, 128), torus),
            case("ellipsoid_s4", Mesh::ellipsoid(radii, 4), ellipsoid),
            case("ellipsoid_s5", Mesh::ellipsoid(radii, 5), ellipsoid),
            case("ellipsoid_s7", Mesh::ellipsoid(radii, 7), ellipsoid),
            // Irregular, like a scanned mesh (tests/curvature_irregular.rs).
            case(
                "ellipsoid_hull_10k",
                irregular_ellipsoid(radii, 10_000, 1),
                ellipsoid,
            ),
            case(
                "ellipsoid_hull_40k",
                irregular_ellipsoid(radii, 40_000, 2),
                ellipsoid,
            ),
        ];
        for (name, mesh, truth) in cases {
            let (parallel, curvature) = best_time(5, || {
                mean_curvature_per_mm_welded(&mesh.positions, &mesh.triangles, &options)
                    .expect("valid mesh")
            });
            let (serial, _) = best_time(5, || {
                one_thread.install(|| {
                    mean_curvature_per_mm_welded(&mesh.positions, &mesh.triangles, &options)
                        .expect("valid mesh")
                })
            });
            println!(
                "{name}: {} vertices, {}",
                mesh.positions.len(),
                relative_error(&curvature, &truth)
            );
            write_case(&dir, &name, &mesh, &truth, &curvature);
            timings.push((name, parallel, serial));
        }
        let mut json = String::from("{\n");
        json.push_str(&format!("  \"threads\": {threads},\n  \"cases\": {{\n"));
        let entries: Vec<String> = timings
            .iter()
            .map(|(name, p, s)| {
                format!(
                    "    \"{name}\": {{\"seconds_parallel\": {}, \"seconds_one_thread\": {}}}",
                    p.as_secs_f64(),
                    s.as_secs_f64()
                )
            })
            .collect();
        json.push_str(&entries.join(",\n"));
        json.push_str("\n  }\n}\n");
        std::fs::write(dir.join("cdrf_timings.json"), json).expect("write timings");
        println!("exported to {}", dir.display());
    }
}

/// A named mesh with its analytic mean curvature per vertex.
fn case(name: &str, mesh: Mesh, analytic: impl Fn(Vec3) -> f64) -> (String, Mesh, Vec<f64>) {
    let truth = mesh.positions.iter().map(|&p| analytic(p)).collect();
    (name.to_owned(), mesh, truth)
}

fn write_case(dir: &Path, name: &str, mesh: &Mesh, truth: &[f64], curvature: &[f32]) {
    let file = |suffix: &str| {
        std::io::BufWriter::new(
            std::fs::File::create(dir.join(format!("{name}.{suffix}"))).expect("create file"),
        )
    };
    let mut obj = file("obj");
    // f32 Display is the shortest exact representation: the OBJ holds the very same mesh.
    for p in &mesh.positions {
        writeln!(obj, "v {} {} {}", p.x, p.y, p.z).expect("write");
    }
    for t in &mesh.triangles {
        writeln!(obj, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1).expect("write");
    }
    let mut truth_file = file("truth.txt");
    for t in truth {
        writeln!(truth_file, "{t}").expect("write");
    }
    let mut cdrf = file("cdrf.txt");
    for k in curvature {
        writeln!(cdrf, "{k}").expect("write");
    }
}
