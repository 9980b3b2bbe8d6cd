//! The comparison with path-traced references (`cdrf-viewer compare`) on a small case: the
//! r = 35 mm wax sphere at 128 × 128 pixels (the 512 × 512 reference box-averaged 4 × 4), where
//! the measured CDRF must beat both the Gaussian CDRF and Lambert in every region and metric.

use std::process::Command;

use cdrf_render::headless::{AdapterPreference, HeadlessDevice};
use cdrf_tests::data_dir;
use cdrf_viewer::compare::{CaseSpec, ModelName, Models, Region, read_manifest, run_case};

fn sphere_case() -> CaseSpec {
    let cases = read_manifest(&data_dir().join("compare.toml")).unwrap_or_else(|e| panic!("{e}"));
    cases
        .into_iter()
        .find(|case| case.name == "sphere_r35")
        .expect("data/compare.toml has the sphere_r35 case")
}

#[test]
fn measured_beats_gaussian_and_lambert_on_the_sphere() {
    let device = HeadlessDevice::new(AdapterPreference::Software).unwrap_or_else(|e| panic!("{e}"));
    let models =
        Models::from_fit_folder(&data_dir().join("wax-fit")).unwrap_or_else(|e| panic!("{e}"));
    let result = run_case(&device, &sphere_case(), &models, Some(128), None)
        .unwrap_or_else(|e| panic!("{e}"));
    println!(
        "{}",
        cdrf_viewer::compare::markdown(std::slice::from_ref(&result))
    );
    // A sphere is convex: nothing on it is in a cast shadow.
    let cast = result
        .regions
        .iter()
        .find(|r| r.region == Region::CastShadow)
        .unwrap();
    assert_eq!((cast.blocks, cast.pixels), (0, 0));
    for region in [
        Region::Whole,
        Region::Lit,
        Region::Terminator,
        Region::Shadow,
    ] {
        let row = result.regions.iter().find(|r| r.region == region).unwrap();
        assert!(row.blocks >= 10, "{region}: only {} blocks", row.blocks);
        let measured = result.metrics(region, ModelName::Measured).unwrap();
        for other in [ModelName::Gaussian, ModelName::Lambert] {
            let other_metrics = result.metrics(region, other).unwrap();
            assert!(
                measured.relative_rmse < other_metrics.relative_rmse
                    && measured.mean_relative_error < other_metrics.mean_relative_error
                    && measured.flip < other_metrics.flip,
                "{region}: measured {measured:?} vs {other} {other_metrics:?}"
            );
        }
    }
    // On the lit side, where the reference's noise averages out, the table is within 2 %.
    let lit = result.metrics(Region::Lit, ModelName::Measured).unwrap();
    assert!(lit.relative_rmse < 0.02, "{lit:?}");
}

#[test]
fn lambert_albedo_is_fitted_to_the_measurement() {
    let models =
        Models::from_fit_folder(&data_dir().join("wax-fit")).unwrap_or_else(|e| panic!("{e}"));
    let albedo = models.measured.lambert_albedo();
    println!("Lambert albedo fitted to the measured table: {albedo:?}");
    // Wax scatters light back almost without loss (single-scattering albedo ≥ 0.985): its
    // diffuse albedo is high, red above green above blue.
    assert!(albedo[0] > albedo[1] && albedo[1] > albedo[2], "{albedo:?}");
    assert!(albedo.iter().all(|a| (0.5..1.0).contains(a)), "{albedo:?}");
}

#[test]
fn compare_command_writes_json_markdown_and_a_figure() {
    let dir = tempfile::tempdir().unwrap();
    let runtime = dir.path().join("xdg-runtime");
    std::fs::create_dir_all(&runtime).unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_cdrf-viewer"))
        .args([
            "compare",
            "--case",
            "sphere_r35",
            "--size",
            "128",
            "--out",
            "out",
        ])
        .current_dir(dir.path())
        .env("XDG_RUNTIME_DIR", &runtime)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(stdout.contains("| lit side |"), "{stdout}");
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("out/compare.json")).unwrap())
            .unwrap();
    assert_eq!(json[0]["name"], "sphere_r35");
    assert_eq!(json[0]["regions"][1]["region"], "lit");
    assert_eq!(json[0]["regions"][1]["models"][0]["model"], "measured");
    assert!(
        json[0]["regions"][1]["models"][0]["relative_rmse"]
            .as_f64()
            .is_some()
    );
    let figure = image::open(dir.path().join("out/sphere_r35.png")).unwrap();
    assert_eq!((figure.width(), figure.height()), (4 * 128, 2 * 128));
    assert!(dir.path().join("out/compare.md").is_file());

    let output = Command::new(env!("CARGO_BIN_EXE_cdrf-viewer"))
        .args(["compare", "--case", "teapot", "--out", "out2"])
        .current_dir(dir.path())
        .env("XDG_RUNTIME_DIR", &runtime)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(stderr.contains("no case named teapot"), "{stderr}");
    assert!(!dir.path().join("out2").exists());
}
