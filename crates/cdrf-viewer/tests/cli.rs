//! The `cdrf-viewer` binary, run as a user would (in a temporary folder): the headless
//! `render` command against a golden image, its JSON and errors, the offscreen `screenshot`,
//! the message without a display, and the real window under `xvfb-run`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use cdrf_tests::data_dir;
use cdrf_tests::golden::{Srgb8Image, Tolerance, assert_golden};

const BINARY: &str = env!("CARGO_BIN_EXE_cdrf-viewer");

/// Set on llvmpipe (LLVM 15.0.6, Mesa 22.3.6), where renders are byte-identical from run to
/// run; as the renderer's golden images (tests/tests/render.rs): rotating the light by 0.5°
/// already gives a mean FLIP of 0.009.
const RENDER_TOLERANCE: Tolerance = Tolerance {
    mean_flip: 0.005,
    max_flip_fraction_above_0_1: 0.002,
};

fn viewer(dir: &Path, args: &[&str]) -> Output {
    let runtime = dir.join("xdg-runtime");
    std::fs::create_dir_all(&runtime).unwrap();
    Command::new(BINARY)
        .args(args)
        .current_dir(dir)
        .env("XDG_RUNTIME_DIR", &runtime)
        .output()
        .unwrap_or_else(|error| panic!("running {BINARY}: {error}"))
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// The bundled bunny scene at 256 × 256 with absolute paths, written into `dir`.
fn small_bunny_scene(dir: &Path) -> PathBuf {
    let data = data_dir().canonicalize().unwrap();
    let scene = format!(
        r#"
[mesh]
path = "{mesh}"
mm_per_unit = 10.0

[camera]
projection = "orthographic"
eye = [0.0, 4.83, 30.0]
target = [0.0, 4.83, 0.0]
up = [0.0, 1.0, 0.0]
ortho_half_height = 5.5
width = 256
height = 256

[[light]]
to_light = [-1.0, 0.0, 0.0]
irradiance = [1.0, 1.0, 1.0]

[shading]
model = "measured"
lut = "{lut}"
"#,
        mesh = data.join("bunny/bunny.obj").display(),
        lut = data.join("wax-fit/measured.exr").display(),
    );
    let path = dir.join("bunny.toml");
    std::fs::write(&path, scene).unwrap();
    path
}

fn read_png(path: &Path) -> Srgb8Image {
    Srgb8Image::from_png(path).unwrap_or_else(|error| panic!("{}: {error}", path.display()))
}

#[test]
fn render_writes_the_golden_bunny_and_reports_json() {
    let dir = tempfile::tempdir().unwrap();
    let scene = small_bunny_scene(dir.path());
    let output = viewer(
        dir.path(),
        &[
            "render",
            "--scene",
            scene.to_str().unwrap(),
            "--out",
            "out/bunny.exr",
            "--frames",
            "3",
            "--json",
        ],
    );
    assert!(output.status.success(), "{}", text(&output.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&output.stdout)
        .unwrap_or_else(|error| panic!("stdout is not JSON ({error}): {}", text(&output.stdout)));
    println!("{summary}");
    assert_eq!(summary["width"], 256);
    assert_eq!(summary["height"], 256);
    assert_eq!(summary["frames"], 3);
    assert!(summary["ms_per_frame"].as_f64().is_some_and(|ms| ms > 0.0));
    assert_eq!(summary["outputs"][0], "out/bunny.exr");
    assert_eq!(summary["outputs"][1], "out/bunny.png");
    assert!(dir.path().join("out/bunny.exr").is_file());
    // The command renders what cdrf-render renders (Options::default: hardware filtering).
    assert_golden(
        "viewer_cli_render_bunny",
        &read_png(&dir.path().join("out/bunny.png")),
        RENDER_TOLERANCE,
    );
}

#[test]
fn render_errors_name_the_file_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("bad.toml"),
        "[mesh]\npath = \"missing.obj\"\n",
    )
    .unwrap();
    let output = viewer(
        dir.path(),
        &["render", "--scene", "bad.toml", "--out", "out.png"],
    );
    let stderr = text(&output.stderr);
    println!("{stderr}");
    assert!(!output.status.success());
    assert!(stderr.starts_with("error: "), "{stderr}");
    assert!(stderr.contains("bad.toml"), "{stderr}");
    assert!(!dir.path().join("out.png").exists());

    let scene = small_bunny_scene(dir.path());
    let output = viewer(
        dir.path(),
        &[
            "render",
            "--scene",
            scene.to_str().unwrap(),
            "--out",
            "out.jpg",
        ],
    );
    let stderr = text(&output.stderr);
    assert!(!output.status.success());
    assert!(
        stderr.contains("out.jpg: --out must end in .exr or .png"),
        "{stderr}"
    );
}

/// Pixels of the 3D view's middle band that are brighter than the background.
fn bright_pixels(image: &Srgb8Image, x_range: std::ops::Range<u32>) -> usize {
    let mut count = 0;
    for y in image.height / 4..image.height * 3 / 4 {
        for x in x_range.clone() {
            let [r, g, b, _] = image.pixels[(y * image.width + x) as usize];
            if u32::from(r) + u32::from(g) + u32::from(b) > 3 * 60 {
                count += 1;
            }
        }
    }
    count
}

#[test]
fn screenshot_renders_the_whole_ui_offscreen() {
    let dir = tempfile::tempdir().unwrap();
    let output = viewer(
        dir.path(),
        &[
            "screenshot",
            "--out",
            "ui.png",
            "--size",
            "960x600",
            "--view",
            "split",
        ],
    );
    assert!(output.status.success(), "{}", text(&output.stderr));
    let image = read_png(&dir.path().join("ui.png"));
    assert_eq!((image.width, image.height), (960, 600));
    let wax = bright_pixels(&image, 280..620);
    println!("bright pixels in the 3D view: {wax}");
    assert!(wax > 5_000, "the bunny is drawn");

    let output = viewer(dir.path(), &["screenshot", "--out", "ui.jpg"]);
    assert!(!output.status.success());
    assert!(text(&output.stderr).contains("ui.jpg: --out must end in .png"));
}

#[test]
fn without_a_display_the_window_explains_the_headless_commands() {
    let dir = tempfile::tempdir().unwrap();
    let output = Command::new(BINARY)
        .current_dir(dir.path())
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    let stderr = text(&output.stderr);
    println!("{stderr}");
    assert!(!output.status.success());
    assert!(stderr.contains("no display"), "{stderr}");
    assert!(stderr.contains("cdrf-viewer render --scene"), "{stderr}");
    assert!(stderr.contains("cdrf-viewer screenshot"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

/// The real window (eframe, winit, the wgpu surface — here `Bgra8Unorm`, not sRGB) under a
/// virtual X server: it opens on the bundled data, runs 30 frames, saves its own screenshot
/// and exits. `scripts/test.sh` installs xvfb; without `xvfb-run` this test fails.
#[test]
fn window_under_xvfb_takes_a_screenshot() {
    let dir = tempfile::tempdir().unwrap();
    let runtime = dir.path().join("xdg-runtime");
    std::fs::create_dir_all(&runtime).unwrap();
    let output = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1280x800x24", BINARY])
        .args(["--exit-after-frames", "30", "--screenshot-to", "window.png"])
        .current_dir(dir.path())
        .env("XDG_RUNTIME_DIR", &runtime)
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap_or_else(|error| {
            panic!("running xvfb-run: {error} (install it: apt-get install xvfb xauth; scripts/test.sh does)")
        });
    let (stdout, stderr) = (text(&output.stdout), text(&output.stderr));
    println!("{stdout}{stderr}");
    assert!(output.status.success(), "{stderr}");
    assert!(stdout.contains("ms per frame"), "{stdout}");
    let image = read_png(&dir.path().join("window.png"));
    assert_eq!((image.width, image.height), (1280, 720));
    // Both halves of the side-by-side view show wax, and the surface (not sRGB) got
    // sRGB-encoded colours: the view's background is sRGB ≈ 29, not linear ≈ 3.
    let (left, right) = (
        bright_pixels(&image, 280..600),
        bright_pixels(&image, 620..940),
    );
    println!("bright pixels: measured half {left}, Gaussian half {right}");
    assert!(left > 5_000 && right > 5_000);
    let background = image.pixels[(700 * image.width + 300) as usize];
    assert!(
        (25..=33).contains(&background[0]),
        "background {background:?}"
    );
}

#[test]
fn compare_curvature_smoothing_is_bounded_at_parse_time() {
    let dir = tempfile::tempdir().unwrap();
    let output = viewer(
        dir.path(),
        &[
            "compare",
            "--cases",
            "cases.toml",
            "--out",
            "out",
            "--curvature-smoothing",
            "4294967295",
        ],
    );
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("--curvature-smoothing") && stderr.contains("1000"),
        "{stderr}"
    );
}
