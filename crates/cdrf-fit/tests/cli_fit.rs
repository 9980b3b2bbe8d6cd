//! Runs the built `cdrf-fit` binary on small data sets in a temporary directory (ripgrep's
//! `TestCommand` style): every broken input fails with a message naming the file and the
//! problem, without a panic and without writing outputs; a good data set gives every output,
//! and the input folder is never touched.
//!
//! Each test copies two or three of the bundled spheres (not all eight) so that a fit takes well
//! under a second in a debug build.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus};
use std::time::SystemTime;

use cdrf_core::image_file::linear_to_srgb;
use cdrf_fit::image_io::load_linear_image;

/// The files `cdrf-fit` writes into OUTDIR, sorted.
const OUTPUTS: [&str; 8] = [
    "gaussian.toml",
    "lut.png",
    "measured.exr",
    "profile.svg",
    "radiance_vs_theta.svg",
    "report.json",
    "transmission.svg",
    "view_correction.svg",
];

const MANIFEST: &str = "cdrf-dataset.toml";

/// The camera and light of the bundled photographs.
const CAMERA_AND_LIGHT: &str = r#"[camera]
projection = "orthographic"

[light]
to_light = [-1.0, 0.0, 0.0]
irradiance = [1.0, 1.0, 1.0]
"#;

fn bundled(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../data/wax-spheres")
        .join(name)
}

/// The `[[sphere]]` table for `image` with `radius_mm` and optional extra lines.
fn sphere(image: &str, radius_mm: f32, extra: &str) -> String {
    format!("\n[[sphere]]\nimage = \"{image}\"\nradius_mm = {radius_mm:?}\n{extra}")
}

/// What a run printed.
struct Run {
    status: ExitStatus,
    stdout: String,
    stderr: String,
}

/// A temporary directory holding the data set folder `data/` (the input) and `out/` (OUTDIR,
/// not created here).
struct TestCommand {
    root: tempfile::TempDir,
}

impl TestCommand {
    fn new() -> Self {
        let root = tempfile::tempdir().expect("temporary directory");
        std::fs::create_dir(root.path().join("data")).expect("create data folder");
        Self { root }
    }

    /// The data set folder (absolute).
    fn data(&self) -> PathBuf {
        self.root.path().join("data")
    }

    /// OUTDIR (absolute).
    fn out(&self) -> PathBuf {
        self.root.path().join("out")
    }

    /// The manifest path as `cdrf-fit` prints it.
    fn manifest(&self) -> String {
        self.data().join(MANIFEST).display().to_string()
    }

    /// Copies the bundled `sphere_r{radius}.exr` into the data folder; returns its name.
    fn copy_sphere(&self, radius_mm: u32) -> String {
        let name = format!("sphere_r{radius_mm}.exr");
        std::fs::copy(bundled(&name), self.data().join(&name)).expect("copy bundled sphere");
        name
    }

    /// Writes `bytes` as `name` in the data folder.
    fn write(&self, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
        let path = self.data().join(name);
        std::fs::write(&path, bytes).expect("write test input");
        path
    }

    /// Writes the manifest: the bundled camera and light, then `spheres`.
    fn write_manifest(&self, spheres: &[String]) {
        self.write(MANIFEST, format!("{CAMERA_AND_LIGHT}{}", spheres.concat()));
    }

    /// Copies the bundled spheres of these radii and lists them in the manifest.
    fn with_spheres(radii_mm: &[u32]) -> Self {
        let cmd = Self::new();
        let spheres: Vec<String> = radii_mm
            .iter()
            .map(|&r| sphere(&cmd.copy_sphere(r), r as f32, ""))
            .collect();
        cmd.write_manifest(&spheres);
        cmd
    }

    /// Runs `cdrf-fit DATA --out OUT ARGS…` in the temporary directory.
    fn run(&self, args: &[&str]) -> Run {
        self.run_raw(
            [
                self.data().as_os_str(),
                "--out".as_ref(),
                self.out().as_os_str(),
            ]
            .into_iter()
            .chain(args.iter().map(|a| a.as_ref())),
        )
    }

    fn run_raw<'a>(&self, args: impl IntoIterator<Item = &'a std::ffi::OsStr>) -> Run {
        let output = Command::new(env!("CARGO_BIN_EXE_cdrf-fit"))
            .current_dir(self.root.path())
            .args(args)
            .output()
            .expect("run cdrf-fit");
        Run {
            status: output.status,
            stdout: String::from_utf8(output.stdout).expect("UTF-8 stdout"),
            stderr: String::from_utf8(output.stderr).expect("UTF-8 stderr"),
        }
    }

    /// Runs and expects success; returns what it printed.
    #[track_caller]
    fn ok(&self, args: &[&str]) -> Run {
        let run = self.run(args);
        assert!(
            run.status.success(),
            "{args:?} failed with {}:\n{}",
            run.status,
            run.stderr
        );
        assert_no_panic(&run.stderr);
        run
    }

    /// Runs and expects exit code 1 with an `error:` message holding every one of `needles`,
    /// no panic, and no file in OUTDIR. Returns stderr.
    #[track_caller]
    fn fails(&self, args: &[&str], needles: &[&str]) -> String {
        let run = self.run(args);
        assert_eq!(
            run.status.code(),
            Some(1),
            "{args:?} should have failed\nstdout: {}\nstderr: {}",
            run.stdout,
            run.stderr
        );
        assert_no_panic(&run.stderr);
        assert!(
            run.stderr.starts_with("error: "),
            "stderr does not start with `error: `:\n{}",
            run.stderr
        );
        assert_chain_without_repeats(&run.stderr);
        for needle in needles {
            assert!(
                run.stderr.contains(needle),
                "stderr lacks {needle:?}:\n{}",
                run.stderr
            );
        }
        let left = self.out_files();
        assert!(left.is_empty(), "a failed run left {left:?} in OUTDIR");
        run.stderr
    }

    /// Names in OUTDIR, sorted (none when it does not exist).
    fn out_files(&self) -> Vec<String> {
        list(&self.out())
    }
}

#[track_caller]
fn assert_no_panic(stderr: &str) {
    assert!(!stderr.contains("panicked"), "cdrf-fit panicked:\n{stderr}");
}

/// The message must not say anything twice in a row: an error whose message includes its
/// cause's and also returns it as `source()` prints `…: X: X` in the `: `-joined chain.
#[track_caller]
fn assert_chain_without_repeats(stderr: &str) {
    for line in stderr.lines() {
        let parts: Vec<&str> = line.split(": ").collect();
        for start in 0..parts.len() {
            for len in 1..=(parts.len() - start) / 2 {
                assert!(
                    parts[start..start + len] != parts[start + len..start + 2 * len],
                    "the error chain repeats {:?}:\n{stderr}",
                    parts[start..start + len].join(": ")
                );
            }
        }
    }
}

/// Names in `dir`, sorted (none when it does not exist).
fn list(dir: &Path) -> Vec<String> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut names: Vec<String> = entries
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// Every file in `dir` with its contents and modification time, plus the folder's own
/// modification time (which changes when a file is created or removed in it, even briefly).
type Snapshot = (SystemTime, BTreeMap<String, (Vec<u8>, SystemTime)>);

fn snapshot(dir: &Path) -> Snapshot {
    let files = list(dir)
        .into_iter()
        .map(|name| {
            let path = dir.join(&name);
            let modified = std::fs::metadata(&path)
                .and_then(|m| m.modified())
                .expect("mtime");
            let bytes = std::fs::read(&path).expect("read input file");
            (name, (bytes, modified))
        })
        .collect();
    let modified = std::fs::metadata(dir)
        .and_then(|m| m.modified())
        .expect("folder mtime");
    (modified, files)
}

#[track_caller]
fn assert_unchanged(before: &Snapshot, after: &Snapshot) {
    let names = |s: &Snapshot| s.1.keys().cloned().collect::<Vec<_>>();
    assert_eq!(names(before), names(after), "files in the input folder");
    for (name, (bytes, modified)) in &before.1 {
        let (bytes_after, modified_after) = &after.1[name];
        assert!(bytes == bytes_after, "{name} was rewritten");
        assert_eq!(modified, modified_after, "{name}'s mtime");
    }
    assert_eq!(
        before.0, after.0,
        "the input folder's mtime changed: something was created or removed in it"
    );
}

#[track_caller]
fn assert_close(actual: f32, expected: f32, eps: f32, what: &str) {
    let diff = (actual - expected).abs();
    assert!(
        diff <= eps,
        "{what}: got {actual}, expected {expected} (|diff| = {diff:e} > eps = {eps:e})"
    );
}

/// Writes a float RGB OpenEXR file.
fn write_exr(
    path: &Path,
    width: usize,
    height: usize,
    pixel: impl Sync + Fn(usize, usize) -> [f32; 3],
) {
    exr::prelude::write_rgb_file(path, width, height, |x, y| {
        let [r, g, b] = pixel(x, y);
        (r, g, b)
    })
    .expect("write test EXR");
}

// ---------------------------------------------------------------------------------------------
// Failures

#[test]
fn empty_folder_says_the_manifest_is_missing() {
    let cmd = TestCommand::new();
    cmd.fails(
        &[],
        &[&cmd.manifest(), "not found", "the folder holds no images"],
    );
}

#[test]
fn folder_with_images_but_no_manifest() {
    let cmd = TestCommand::new();
    cmd.copy_sphere(15);
    cmd.copy_sphere(30);
    cmd.fails(
        &[],
        &[
            &cmd.manifest(),
            "not found",
            "2 image(s), e.g. sphere_r15.exr",
        ],
    );
}

#[test]
fn manifest_missing_a_key_or_with_an_unknown_key() {
    let cmd = TestCommand::new();
    let image = cmd.copy_sphere(15);
    cmd.write(
        MANIFEST,
        format!("{CAMERA_AND_LIGHT}\n[[sphere]]\nimage = \"{image}\"\n"),
    );
    cmd.fails(&[], &[&cmd.manifest(), "missing field `radius_mm`"]);

    cmd.write_manifest(&[sphere(&image, 15.0, "radius_pixels = 230.0\n")]);
    cmd.fails(&[], &[&cmd.manifest(), "unknown field `radius_pixels`"]);
}

#[test]
fn listed_image_that_does_not_exist() {
    let cmd = TestCommand::new();
    let image = cmd.copy_sphere(15);
    cmd.write_manifest(&[sphere(&image, 15.0, ""), sphere("sphere_r99.exr", 99.0, "")]);
    cmd.fails(
        &[],
        &[
            &cmd.manifest(),
            "sphere_r99.exr: no image file at",
            &cmd.data().join("sphere_r99.exr").display().to_string(),
        ],
    );
}

#[test]
fn corrupt_and_truncated_images() {
    let cmd = TestCommand::new();
    let good = cmd.copy_sphere(15);
    let garbage = cmd.write(
        "garbage.exr",
        b"this is not an OpenEXR file at all".repeat(100),
    );
    cmd.write_manifest(&[sphere(&good, 15.0, ""), sphere("garbage.exr", 30.0, "")]);
    cmd.fails(
        &[],
        &[
            &garbage.display().to_string(),
            "cannot decode OpenEXR",
            "does not start with the OpenEXR signature",
        ],
    );

    let bytes = std::fs::read(bundled("sphere_r30.exr")).expect("read bundled sphere");
    let truncated = cmd.write("truncated.exr", &bytes[..bytes.len() / 2]);
    cmd.write_manifest(&[sphere(&good, 15.0, ""), sphere("truncated.exr", 30.0, "")]);
    cmd.fails(
        &[],
        &[
            &truncated.display().to_string(),
            "cannot decode OpenEXR (corrupt or truncated file?)",
        ],
    );
}

#[test]
fn non_finite_pixels_are_reported_with_count_and_position() {
    let cmd = TestCommand::new();
    let good = cmd.copy_sphere(15);
    let path = cmd.data().join("nan.exr");
    write_exr(&path, 64, 64, |x, y| match (x, y) {
        (10, 5) => [f32::NAN, 0.1, 0.1],
        (20, 40) => [0.1, f32::NAN, f32::NAN],
        (3, 50) => [0.1, 0.1, f32::INFINITY],
        _ => [0.1; 3],
    });
    cmd.write_manifest(&[sphere(&good, 15.0, ""), sphere("nan.exr", 30.0, "")]);
    cmd.fails(
        &[],
        &[
            &path.display().to_string(),
            "3 pixel(s) are NaN or infinite (first at column 10, row 5",
        ],
    );
}

#[test]
fn black_image_has_no_sphere() {
    let cmd = TestCommand::new();
    let good = cmd.copy_sphere(15);
    write_exr(&cmd.data().join("black.exr"), 64, 64, |_, _| [0.0; 3]);
    cmd.write_manifest(&[sphere(&good, 15.0, ""), sphere("black.exr", 30.0, "")]);
    cmd.fails(&[], &["black.exr: the image is black: no sphere to detect"]);
}

#[test]
fn fully_saturated_sphere_has_no_usable_pixels() {
    let cmd = TestCommand::new();
    let good = cmd.copy_sphere(15);
    // A white disk (code 255: clipped) of radius 230 px on black: every sphere pixel saturated.
    let disk = image::RgbImage::from_fn(512, 512, |x, y| {
        let (dx, dy) = (x as f32 + 0.5 - 256.0, y as f32 + 0.5 - 256.0);
        if dx * dx + dy * dy <= 230.0 * 230.0 {
            image::Rgb([255; 3])
        } else {
            image::Rgb([0; 3])
        }
    });
    disk.save(cmd.data().join("saturated.png"))
        .expect("write test PNG");
    cmd.write_manifest(&[sphere("saturated.png", 30.0, ""), sphere(&good, 15.0, "")]);
    let stderr = cmd.fails(&[], &["saturated.png: only 0 usable pixels", "saturated"]);
    // Nearly the whole disk (π · 228² ≈ 163 000 px inside the edge margin) counted as saturated.
    let saturated: usize = stderr
        .split("; ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no saturated count in:\n{stderr}"));
    assert!(saturated > 150_000, "{saturated} saturated:\n{stderr}");
}

#[test]
fn manifest_circle_that_does_not_match_the_image() {
    let cmd = TestCommand::new();
    let image = cmd.copy_sphere(15);
    let other = cmd.copy_sphere(30);
    cmd.write_manifest(&[
        sphere(&image, 15.0, "center_px = [300.0, 256.0]\n"),
        sphere(&other, 30.0, ""),
    ]);
    cmd.fails(
        &[],
        &[
            "sphere_r15.exr: the manifest says centre (300.0, 256.0) px",
            "but the sphere in the image is at (256.",
            "check center_px / radius_px",
        ],
    );
}

#[test]
fn radius_mm_must_be_positive() {
    let cmd = TestCommand::new();
    let image = cmd.copy_sphere(15);
    let other = cmd.copy_sphere(30);
    for (radius, shown) in [(0.0, "radius_mm = 0:"), (-5.0, "radius_mm = -5:")] {
        cmd.write_manifest(&[sphere(&other, 30.0, ""), sphere(&image, radius, "")]);
        cmd.fails(
            &[],
            &[
                &cmd.manifest(),
                "sphere_r15.exr",
                shown,
                "must be a finite number > 0",
            ],
        );
    }
}

#[test]
fn duplicate_radii() {
    let cmd = TestCommand::new();
    let first = cmd.copy_sphere(15);
    let second = cmd.copy_sphere(30);
    cmd.write_manifest(&[sphere(&first, 30.0, ""), sphere(&second, 30.0, "")]);
    cmd.fails(
        &[],
        &[
            &cmd.manifest(),
            "sphere_r15.exr and sphere_r30.exr both have radius_mm = 30",
            "each sphere needs a different radius",
        ],
    );
}

#[test]
fn output_folder_must_not_be_the_input_folder() {
    let cmd = TestCommand::with_spheres(&[15, 50]);
    let before = snapshot(&cmd.data());
    // The same folder, given as is and through `..`, and a new folder inside it.
    let data = cmd.data();
    let alias = data.join("..").join("data");
    let inside = data.join("fit-output");
    for out in [&data, &alias, &inside] {
        let run = cmd.run_raw([data.as_os_str(), "--out".as_ref(), out.as_os_str()]);
        assert_eq!(
            run.status.code(),
            Some(1),
            "--out {}:\n{}",
            out.display(),
            run.stderr
        );
        assert_no_panic(&run.stderr);
        assert!(
            run.stderr
                .contains("the output folder must not be the data set folder")
                && run.stderr.contains(&out.display().to_string()),
            "--out {}:\n{}",
            out.display(),
            run.stderr
        );
        assert_unchanged(&before, &snapshot(&data));
    }
}

#[test]
fn output_path_that_is_a_file() {
    let cmd = TestCommand::with_spheres(&[15, 50]);
    std::fs::write(cmd.out(), b"not a folder").expect("write OUTDIR as a file");
    cmd.fails(&[], &[&cmd.out().display().to_string()]);
    assert_eq!(std::fs::read(cmd.out()).unwrap(), b"not a folder");
}

// ---------------------------------------------------------------------------------------------
// Successes

#[test]
fn successful_run_leaves_the_input_folder_untouched() {
    let cmd = TestCommand::with_spheres(&[15, 50]);
    let before = snapshot(&cmd.data());
    cmd.ok(&["--quiet", "--view-model", "phi"]);
    assert_unchanged(&before, &snapshot(&cmd.data()));
    assert_eq!(cmd.out_files(), OUTPUTS);
}

#[test]
fn three_spheres_give_every_output() {
    let cmd = TestCommand::with_spheres(&[15, 30, 50]);
    let run = cmd.ok(&[]);
    assert!(
        run.stdout.is_empty(),
        "stdout without --json:\n{}",
        run.stdout
    );
    assert!(
        run.stderr.contains("fitted 3 spheres (r = 15, 30, 50)"),
        "{}",
        run.stderr
    );

    // Exactly the seven outputs: no temporary or partial file left behind.
    assert_eq!(cmd.out_files(), OUTPUTS);
    for name in OUTPUTS {
        let len = std::fs::metadata(cmd.out().join(name))
            .expect("output")
            .len();
        assert!(len > 0, "{name} is empty");
        assert!(
            run.stderr
                .contains(&format!("wrote {}", cmd.out().join(name).display())),
            "{name} not reported:\n{}",
            run.stderr
        );
    }

    let lut = cdrf_core::read_lut(cmd.out().join("measured.exr")).expect("read measured.exr");
    let axis = lut.curvature_axis();
    assert_close(
        axis.min_per_mm,
        1.0 / 50.0,
        1e-6,
        "curvature of the first row",
    );
    assert_close(
        axis.max_per_mm,
        1.0 / 15.0,
        1e-6,
        "curvature of the last row",
    );
    assert_eq!(axis.count, 64, "default --curvature-count");
    assert_eq!(lut.theta_count(), 361, "default --theta-count");

    // gaussian.toml is cdrf-core's format: it reads back, and its view correction is the one
    // in measured.exr next to it.
    let gaussian_path = cmd.out().join("gaussian.toml");
    let gaussian = cdrf_core::gaussian_file::read_gaussian(&gaussian_path)
        .unwrap_or_else(|error| panic!("{error}"));
    for (key, values) in [("sigma_mm", gaussian.sigma_mm), ("scale", gaussian.scale)] {
        assert!(
            values.iter().all(|v| v.is_finite() && *v > 0.0),
            "{key}: {values:?}"
        );
    }
    assert_eq!(
        gaussian.view_correction_from.as_deref(),
        Some(Path::new("measured.exr"))
    );
    let (model, view_correction) = gaussian
        .load_model(&gaussian_path)
        .unwrap_or_else(|error| panic!("{error}"));
    assert_eq!(model.sigma_mm(), gaussian.sigma_mm);
    assert_eq!(&view_correction, lut.view_correction());

    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(cmd.out().join("report.json")).unwrap())
            .expect("report.json is JSON");
    let spheres = report["spheres"].as_array().expect("spheres");
    let images: Vec<&str> = spheres
        .iter()
        .map(|s| s["image"].as_str().unwrap())
        .collect();
    assert_eq!(
        images,
        ["sphere_r15.exr", "sphere_r30.exr", "sphere_r50.exr"]
    );
    assert_eq!(report["table"]["curvature_count"], 64);

    // The transmission profile: in the report, and in measured.exr with Kubo's σ as the
    // scattering length.
    let section = &report["transmission"];
    assert_eq!(section["min_theta_deg"], 110.0, "{section}");
    assert!(section.get("error").is_none(), "{section}");
    let per_channel = |key: &str| -> Vec<f64> {
        section[key]
            .as_array()
            .unwrap_or_else(|| panic!("no {key} in {section}"))
            .iter()
            .map(|v| v.as_f64().expect("number"))
            .collect()
    };
    for key in [
        "amplitude",
        "length_mm",
        "scattering_length_mm",
        "relative_rms",
    ] {
        let values = per_channel(key);
        assert_eq!(values.len(), 3, "{key}: {values:?}");
        assert!(
            values.iter().all(|v| v.is_finite() && *v > 0.0),
            "{key}: {values:?}"
        );
    }
    assert!(per_channel("points").iter().all(|&n| n >= 3.0), "{section}");
    assert_eq!(section["chord_range_mm"].as_array().map(Vec::len), Some(3));
    let ratio_spheres = section["spheres"].as_array().expect("spheres");
    assert_eq!(ratio_spheres.len(), 3);
    assert_eq!(ratio_spheres[0]["radius_mm"], 15.0);
    assert_eq!(
        ratio_spheres[0]["mean_ratio"].as_array().map(Vec::len),
        Some(3)
    );
    let translucency = lut
        .translucency()
        .expect("measured.exr carries translucency");
    for c in 0..3 {
        assert_close(
            translucency.scattering_length_mm[c],
            gaussian.sigma_mm[c],
            1e-5 * gaussian.sigma_mm[c],
            "scattering length in measured.exr and σ in gaussian.toml",
        );
        assert_close(
            translucency.transmission.amplitude[c],
            per_channel("amplitude")[c] as f32,
            1e-6,
            "amplitude in measured.exr and report.json",
        );
        assert_close(
            translucency.transmission.length_mm[c],
            per_channel("length_mm")[c] as f32,
            1e-4,
            "length in measured.exr and report.json",
        );
    }
    assert_eq!(translucency.transmission.entry_cosine_power, 1.0);
    assert_eq!(section["entry_cosine_power"], 1.0);
    let svg = std::fs::read_to_string(cmd.out().join("transmission.svg")).expect("plot");
    assert!(
        svg.starts_with("<svg") && svg.contains("T(d, 1) G"),
        "transmission.svg"
    );
    assert!(
        run.stderr.contains("transmission T(d, mu)"),
        "{}",
        run.stderr
    );

    // The diffusion profile: in measured.exr exactly as report.json gives it, plotted, printed.
    let section = &report["diffusion"];
    assert!(section.get("error").is_none(), "{section}");
    let profile = lut
        .diffusion_profile()
        .expect("measured.exr carries the diffusion profile");
    let terms = section["terms"].as_array().expect("terms");
    assert_eq!(terms.len(), profile.terms().len());
    for (term, json) in profile.terms().iter().zip(terms) {
        // serde_json prints an f32 as its shortest round-tripping decimal.
        assert_eq!(term.length_mm, json["length_mm"].as_f64().unwrap() as f32);
        for c in 0..3 {
            assert_eq!(term.weight[c], json["weight"][c].as_f64().unwrap() as f32);
        }
    }
    assert_eq!(
        profile.entry_cosine_power(),
        section["entry_cosine_power"].as_f64().unwrap() as f32
    );
    // A translucent material: a diffuse albedo well inside (0, 1), and the profile alone close
    // to the spheres it was fitted to.
    for (c, albedo) in profile.albedo().into_iter().enumerate() {
        assert!(albedo > 0.2 && albedo < 1.0, "albedo {c}: {albedo}");
        let rms = section["relative_rms"][c].as_f64().unwrap();
        assert!(rms > 0.0 && rms < 0.3, "relative RMS {c}: {rms}");
    }
    assert_eq!(section["spheres"].as_array().map(Vec::len), Some(3));
    // Photographs of lone spheres in a dark room measure the deep shadow side: no warning.
    let deep_deg = section["measured_deep_shadow_deg"].as_f64().unwrap();
    assert!(
        deep_deg >= f64::from(cdrf_fit::fit::DEEP_SHADOW_MIN_DEG),
        "deep shadow side measured over {deep_deg}°"
    );
    assert!(
        !run.stderr.contains("no sphere's shadow side is measured"),
        "{}",
        run.stderr
    );
    let svg = std::fs::read_to_string(cmd.out().join("profile.svg")).expect("plot");
    assert!(
        svg.starts_with("<svg") && svg.contains("albedo"),
        "profile.svg"
    );
    assert!(
        run.stderr.contains("diffusion profile R(d)"),
        "{}",
        run.stderr
    );
}

#[test]
fn json_summary_on_stdout_and_quiet_stderr() {
    let cmd = TestCommand::with_spheres(&[15, 50]);
    let run = cmd.ok(&["--json", "--quiet", "--theta-count", "91"]);
    assert!(run.stderr.is_empty(), "--quiet printed:\n{}", run.stderr);
    let summary: serde_json::Value =
        serde_json::from_str(&run.stdout).expect("stdout is one JSON document");
    for key in [
        "outputs",
        "spheres",
        "gaussian",
        "transmission",
        "diffusion",
        "timings",
    ] {
        assert!(summary.get(key).is_some(), "no {key:?} in {summary}");
    }
    assert_eq!(summary["spheres"], 2);
    let outputs: Vec<PathBuf> = summary["outputs"]
        .as_array()
        .expect("outputs")
        .iter()
        .map(|p| PathBuf::from(p.as_str().expect("path")))
        .collect();
    assert_eq!(outputs.len(), OUTPUTS.len(), "{outputs:?}");
    assert!(outputs.iter().all(|p| p.is_file()), "{outputs:?}");
    assert_eq!(
        summary["gaussian"]["sigma_mm"].as_array().map(Vec::len),
        Some(3)
    );
    assert!(
        summary["timings"]["total_s"]
            .as_f64()
            .is_some_and(|t| t > 0.0)
    );
    let lut = cdrf_core::read_lut(cmd.out().join("measured.exr")).expect("read measured.exr");
    assert_eq!(lut.theta_count(), 91, "--theta-count");
}

#[test]
fn one_sphere_gives_a_single_curvature_row() {
    let cmd = TestCommand::with_spheres(&[30]);
    let run = cmd.ok(&[]);
    assert!(run.stderr.contains("one sphere"), "{}", run.stderr);
    assert_eq!(cmd.out_files(), OUTPUTS);
    let lut = cdrf_core::read_lut(cmd.out().join("measured.exr")).expect("read measured.exr");
    let axis = lut.curvature_axis();
    assert_eq!(axis.count, 1, "{axis:?}");
    assert_close(axis.min_per_mm, 1.0 / 30.0, 1e-6, "curvature of the row");
}

/// An 8-bit sRGB PNG, exposed ×3 and undone with `exposure = 1/3`, measures the same radiance
/// as the EXR it was made from: the sRGB decode and the exposure are applied, end to end.
#[test]
fn srgb_png_with_exposure_matches_its_exr() {
    const GAIN: f32 = 3.0;
    let cmd = TestCommand::new();
    let exr = load_linear_image(&bundled("sphere_r30.exr"), None, 1.0).expect("read r30");
    let (width, height) = (exr.width, exr.height);
    let png = image::RgbImage::from_fn(width, height, |x, y| {
        let p = exr.pixel(x, y) * GAIN;
        image::Rgb(
            p.to_array()
                .map(|c| (linear_to_srgb(c.clamp(0.0, 1.0)) * 255.0).round() as u8),
        )
    });
    png.save(cmd.data().join("sphere_r30.png"))
        .expect("write test PNG");
    let good = cmd.copy_sphere(15);
    cmd.write_manifest(&[
        sphere(&good, 15.0, ""),
        sphere(
            "sphere_r30.png",
            30.0,
            &format!("exposure = {:?}\n", 1.0 / GAIN),
        ),
    ]);
    cmd.ok(&["--quiet"]);

    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(cmd.out().join("report.json")).unwrap())
            .expect("report.json is JSON");
    let png_sphere = &report["spheres"][1];
    assert_eq!(png_sphere["image"], "sphere_r30.png");
    let saturated = png_sphere["dropped"]["saturated"]
        .as_u64()
        .expect("saturated");
    assert!(
        saturated < 100,
        "{saturated} saturated pixels: exposure too high"
    );

    // The expected raw curve: π·L (E = 1) of the EXR in 1° θ bins, on the bundled framing
    // (orthographic, disk of radius 230 px at (256, 256), light from the left).
    let mut sums = [(0.0_f64, 0_u32); 181];
    for y in 0..height {
        for x in 0..width {
            let nx = (x as f32 + 0.5 - 256.0) / 230.0;
            let ny = (y as f32 + 0.5 - 256.0) / 230.0;
            // Inside the 2 px edge margin, as cdrf-fit samples.
            if nx * nx + ny * ny > (228.0_f32 / 230.0).powi(2) {
                continue;
            }
            let theta_deg = (-nx).acos().to_degrees().round() as usize;
            sums[theta_deg].0 += f64::from(exr.pixel(x, y).y * std::f32::consts::PI);
            sums[theta_deg].1 += 1;
        }
    }
    // The lit side, where 8 bits at this exposure resolve better than 1 %.
    for theta_deg in (10..=70).step_by(10) {
        let (sum, count) = sums[theta_deg];
        let expected = (sum / f64::from(count)) as f32;
        let measured = png_sphere["raw_curve"][theta_deg][1]
            .as_f64()
            .unwrap_or_else(|| panic!("no raw curve at {theta_deg}°"))
            as f32;
        assert_close(
            measured,
            expected,
            0.02 * expected,
            &format!("π·L (green) at θ = {theta_deg}° from the PNG"),
        );
    }
}

#[test]
fn help_mentions_the_manifest() {
    let cmd = TestCommand::new();
    let run = cmd.run_raw(["--help".as_ref()]);
    assert!(run.status.success(), "{}", run.stderr);
    assert!(run.stdout.contains("cdrf-dataset.toml"), "{}", run.stdout);
    assert!(run.stdout.contains("--out"), "{}", run.stdout);
}

// ---------------------------------------------------------------------------------------------
// Hardening (issue 18, part B)

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

#[test]
fn exr_windows_over_the_limit_are_refused_before_decoding() {
    for (name, window) in [
        ("exr_huge_datawindow.exr", "data window"),
        ("exr_display_30000.exr", "display window"),
    ] {
        let cmd = TestCommand::new();
        let image = cmd.copy_sphere(15);
        std::fs::copy(fixture(name), cmd.data().join(name)).expect("copy fixture");
        cmd.write_manifest(&[sphere(&image, 15.0, ""), sphere(name, 30.0, "")]);
        cmd.fails(&[], &[name, window, "limit"]);
    }
}

#[test]
fn counts_out_of_bounds_are_usage_errors_naming_the_flag() {
    let cmd = TestCommand::with_spheres(&[15, 50]);
    for (flag, value) in [
        ("--theta-count", "4294967295"),
        ("--theta-count", "18"),
        ("--curvature-count", "100000000"),
        ("--curvature-count", "1"),
    ] {
        let run = cmd.run(&[flag, value]);
        assert_eq!(run.status.code(), Some(2), "{flag} {value}: {}", run.stderr);
        assert!(
            run.stderr.contains(flag) && run.stderr.contains(value),
            "{flag} {value}: {}",
            run.stderr
        );
        assert!(cmd.out_files().is_empty());
    }
}

#[test]
fn arrays_of_the_wrong_length_are_errors() {
    let cmd = TestCommand::new();
    let image = cmd.copy_sphere(15);
    let other = cmd.copy_sphere(50);
    cmd.write_manifest(&[
        sphere(&image, 15.0, "center_px = [1.0, 2.0, 3.0]\n"),
        sphere(&other, 50.0, ""),
    ]);
    cmd.fails(&[], &[&cmd.manifest(), "center_px", "exactly 2", "3"]);
    cmd.write(
        MANIFEST,
        format!(
            "[camera]\nprojection = \"orthographic\"\n[light]\nto_light = [-1.0, 0.0, 0.0, 1.0]\n{}",
            sphere(&image, 15.0, "")
        ),
    );
    cmd.fails(&[], &[&cmd.manifest(), "to_light", "exactly 3", "4"]);
    cmd.write(
        MANIFEST,
        format!(
            "[camera]\nprojection = \"orthographic\"\n[light]\nto_light = [-1.0, 0.0, 0.0]\nirradiance = [1.0, 1.0, 1.0, 1.0]\n{}",
            sphere(&image, 15.0, "")
        ),
    );
    cmd.fails(&[], &[&cmd.manifest(), "irradiance", "exactly 3", "4"]);
}

#[test]
fn irradiance_outside_the_usable_range_is_named() {
    let cmd = TestCommand::new();
    let image = cmd.copy_sphere(15);
    let other = cmd.copy_sphere(50);
    cmd.write(
        MANIFEST,
        format!(
            "[camera]\nprojection = \"orthographic\"\n[light]\nto_light = [-1.0, 0.0, 0.0]\nirradiance = [1e-40, 1.0, 1.0]\n{}{}",
            sphere(&image, 15.0, ""),
            sphere(&other, 50.0, "")
        ),
    );
    let stderr = cmd.fails(&[], &[&cmd.manifest(), "irradiance", "1e-30"]);
    assert!(!stderr.contains("NaN"), "{stderr}");
}

#[test]
fn images_must_be_inside_the_data_set_folder() {
    let cmd = TestCommand::new();
    let image = cmd.copy_sphere(15);
    std::fs::copy(
        bundled("sphere_r50.exr"),
        cmd.root.path().join("outside.exr"),
    )
    .unwrap();
    let absolute = cmd.root.path().join("outside.exr").display().to_string();
    for (name, expected) in [
        ("../outside.exr", "leaves"),
        (absolute.as_str(), "absolute"),
    ] {
        cmd.write_manifest(&[sphere(&image, 15.0, ""), sphere(name, 50.0, "")]);
        cmd.fails(&[], &[&cmd.manifest(), "image", expected]);
    }
}

#[test]
fn stale_partial_files_are_cleaned_and_outputs_come_as_one_set() {
    let cmd = TestCommand::with_spheres(&[15, 50]);
    std::fs::create_dir(cmd.out()).unwrap();
    std::fs::write(cmd.out().join(".cdrf-partial-abc123"), b"killed run").unwrap();
    std::fs::write(cmd.out().join("keep.txt"), b"the user's").unwrap();
    cmd.ok(&[]);
    let mut expected: Vec<String> = OUTPUTS.iter().map(|s| s.to_string()).collect();
    expected.push("keep.txt".to_owned());
    expected.sort();
    assert_eq!(cmd.out_files(), expected);
    let siblings = list(cmd.root.path());
    assert!(
        siblings.iter().all(|n| !n.starts_with(".cdrf-")),
        "left beside OUTDIR: {siblings:?}"
    );
}
