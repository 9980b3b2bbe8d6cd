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

/// `--exposure` and the scene's `[camera] exposure` multiply the radiance; and without an
/// `XDG_RUNTIME_DIR` the command says nothing about one (it makes its own).
#[test]
fn render_exposure_multiplies_the_radiance_and_needs_no_runtime_dir() {
    let dir = tempfile::tempdir().unwrap();
    let scene = small_bunny_scene(dir.path());
    let scene = scene.to_str().unwrap();
    let render = |scene: &str, out: &str, extra: &[&str]| {
        let output = Command::new(BINARY)
            .args(["render", "--scene", scene, "--out", out])
            .args(extra)
            .current_dir(dir.path())
            .env_remove("XDG_RUNTIME_DIR")
            .output()
            .unwrap();
        let stderr = text(&output.stderr);
        assert!(output.status.success(), "{stderr}");
        assert!(!stderr.contains("XDG_RUNTIME_DIR"), "{stderr}");
        cdrf_core::image_file::RgbaImage::read_exr(dir.path().join(out)).unwrap()
    };
    let one = render(scene, "one.exr", &[]);
    let two = render(scene, "two.exr", &["--exposure", "2"]);
    let text = std::fs::read_to_string(scene).unwrap();
    let keyed = dir.path().join("keyed.toml");
    std::fs::write(
        &keyed,
        text.replace("height = 256", "height = 256\nexposure = 2.0"),
    )
    .unwrap();
    let from_key = render(keyed.to_str().unwrap(), "keyed.exr", &[]);
    assert_eq!(from_key.pixels, two.pixels);
    let (mut lit, mut worst) = (0, 0.0f32);
    for (a, b) in one.pixels.iter().zip(&two.pixels) {
        assert_eq!(a[3], b[3], "coverage must not change");
        for c in 0..3 {
            if a[c] > 1e-3 {
                lit += 1;
                worst = worst.max((b[c] / a[c] - 2.0).abs());
            }
        }
    }
    println!("{lit} lit channels, worst |ratio − 2| {worst}");
    assert!(
        lit > 1000 && worst < 2e-3,
        "{lit} lit channels, worst {worst}"
    );
    let output = viewer(
        dir.path(),
        &[
            "render",
            "--scene",
            scene,
            "--out",
            "x.png",
            "--exposure",
            "0",
        ],
    );
    assert_fails(&output, 1, &["--exposure 0"]);
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
    // The opening view (one model with every term) shows wax on both sides of its middle, and
    // the surface (not sRGB) got sRGB-encoded colours: the view's background is sRGB ≈ 29, not
    // linear ≈ 3.
    let (left, right) = (
        bright_pixels(&image, 280..610),
        bright_pixels(&image, 610..940),
    );
    println!("bright pixels: left half of the view {left}, right half {right}");
    assert!(left > 5_000 && right > 5_000);
    let background = image.pixels[(700 * image.width + 300) as usize];
    assert!(
        (25..=33).contains(&background[0]),
        "background {background:?}"
    );
}

// ---- Hardening (issue 18, part A): no panic, no hang, no file touched that must not be, no
// half-written run. Each failure exits 1 (2 for a flag clap rejects) with a message naming
// the file, flag or size.

/// `cdrf-viewer ARGS` in `dir` with extra environment variables.
fn viewer_with_env(dir: &Path, args: &[&str], env: &[(&str, &str)]) -> Output {
    let runtime = dir.join("xdg-runtime");
    std::fs::create_dir_all(&runtime).unwrap();
    Command::new(BINARY)
        .args(args)
        .current_dir(dir)
        .env("XDG_RUNTIME_DIR", &runtime)
        .envs(env.iter().copied())
        .output()
        .unwrap_or_else(|error| panic!("running {BINARY}: {error}"))
}

/// The command failed with exit code `code`, without a panic, and stderr holds every needle.
#[track_caller]
fn assert_fails(output: &Output, code: i32, needles: &[&str]) -> String {
    let stderr = text(&output.stderr);
    println!("{stderr}");
    assert_eq!(output.status.code(), Some(code), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    for needle in needles {
        assert!(stderr.contains(needle), "stderr lacks {needle:?}: {stderr}");
    }
    stderr
}

/// Files under `dir` (recursively), relative, excluding the runtime folder.
fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut found = Vec::new();
    let mut stack = vec![dir.to_owned()];
    while let Some(folder) = stack.pop() {
        for entry in std::fs::read_dir(&folder).unwrap() {
            let path = entry.unwrap().path();
            if path.ends_with("xdg-runtime") {
                continue;
            }
            if path.is_dir() {
                stack.push(path);
            } else {
                found.push(path.strip_prefix(dir).unwrap().to_owned());
            }
        }
    }
    found.sort();
    found
}

/// Without a Vulkan driver wgpu would fall back to OpenGL, where the shaders do not compile
/// (a panic, exit 101): every GPU command refuses it up front and names the packages.
#[test]
fn without_vulkan_every_gpu_command_names_the_vulkan_packages() {
    let dir = tempfile::tempdir().unwrap();
    let scene = small_bunny_scene(dir.path());
    let no_vulkan = [("VK_ICD_FILENAMES", "/nonexistent")];
    let hint = "mesa-vulkan-drivers libvulkan1";
    for args in [
        vec![
            "render",
            "--scene",
            scene.to_str().unwrap(),
            "--out",
            "a.png",
        ],
        vec![
            "render",
            "--scene",
            scene.to_str().unwrap(),
            "--out",
            "b.png",
            "--software",
        ],
        vec!["screenshot", "--out", "c.png"],
        vec![
            "compare",
            "--case",
            "sphere_r35",
            "--size",
            "128",
            "--out",
            "d",
        ],
    ] {
        let output = viewer_with_env(dir.path(), &args, &no_vulkan);
        assert_fails(&output, 1, &[hint]);
    }
    // The window, under a virtual X server.
    let runtime = dir.path().join("xdg-runtime");
    let output = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1280x800x24", BINARY])
        .args(["--exit-after-frames", "3"])
        .current_dir(dir.path())
        .env("XDG_RUNTIME_DIR", &runtime)
        .env("VK_ICD_FILENAMES", "/nonexistent")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap_or_else(|error| panic!("running xvfb-run: {error}"));
    assert_fails(&output, 1, &[hint]);
    assert_eq!(files_under(dir.path()), vec![PathBuf::from("bunny.toml")]);
}

/// `small_bunny_scene` at another size.
fn bunny_scene_of_size(dir: &Path, width: u32, height: u32) -> PathBuf {
    let path = small_bunny_scene(dir);
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("width = 256", &format!("width = {width}"))
        .replace("height = 256", &format!("height = {height}"));
    let sized = dir.join(format!("bunny_{width}x{height}.toml"));
    std::fs::write(&sized, text).unwrap();
    std::fs::remove_file(path).unwrap();
    sized
}

/// 6000² failed to map its read-back buffer and 16384² ran out of memory creating the target
/// (wgpu's uncaptured-error handler panicked): the scene check allows only what the device
/// can render and read back, and names the size.
#[test]
fn render_rejects_sizes_the_device_cannot_render_or_read_back() {
    let dir = tempfile::tempdir().unwrap();
    for (width, height) in [(6000, 6000), (16384, 16384), (5800, 5800)] {
        let scene = bunny_scene_of_size(dir.path(), width, height);
        let output = viewer(
            dir.path(),
            &[
                "render",
                "--scene",
                scene.to_str().unwrap(),
                "--out",
                "out.exr",
                "--software",
            ],
        );
        assert_fails(&output, 1, &[&format!("{width} × {height}")]);
        assert!(!dir.path().join("out.exr").exists());
        assert!(!dir.path().join("out.png").exists());
    }
}

/// `--frames 4294967295` rendered for hours: the flag is bounded at parse time.
#[test]
fn render_frames_is_bounded_when_parsed() {
    let dir = tempfile::tempdir().unwrap();
    let output = viewer(
        dir.path(),
        &[
            "render",
            "--scene",
            "missing.toml",
            "--out",
            "o.png",
            "--frames",
            "4294967295",
        ],
    );
    assert_fails(&output, 2, &["--frames", "10000"]);
}

/// `render --out` the scene's own LUT (or the scene file) replaced the input.
#[test]
fn render_refuses_an_output_that_is_one_of_its_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let lut = dir.path().join("lut.exr");
    std::fs::copy(data_dir().join("wax-fit/measured.exr"), &lut).unwrap();
    let before = std::fs::read(&lut).unwrap();
    let scene = small_bunny_scene(dir.path());
    let text = std::fs::read_to_string(&scene).unwrap().replace(
        &data_dir()
            .canonicalize()
            .unwrap()
            .join("wax-fit/measured.exr")
            .display()
            .to_string(),
        "lut.exr",
    );
    std::fs::write(&scene, text).unwrap();
    // The same file by another spelling.
    for out in ["lut.exr", "./sub/../lut.exr"] {
        std::fs::create_dir_all(dir.path().join("sub")).unwrap();
        let output = viewer(
            dir.path(),
            &[
                "render",
                "--scene",
                "bunny.toml",
                "--out",
                out,
                "--software",
            ],
        );
        assert_fails(&output, 1, &["lut.exr", "input"]);
        assert_eq!(std::fs::read(&lut).unwrap(), before, "the LUT was replaced");
    }
    // A scene named .png is an input too.
    std::fs::copy(&scene, dir.path().join("scene.png")).unwrap();
    let output = viewer(
        dir.path(),
        &[
            "render",
            "--scene",
            "scene.png",
            "--out",
            "scene.exr",
            "--software",
        ],
    );
    assert_fails(&output, 1, &["scene.png", "input"]);
    assert!(!dir.path().join("scene.exr").exists());
}

/// `render --out x.exr` wrote x.exr and then failed on x.png: every output is checked before
/// the render, and the run's files appear together or not at all.
#[test]
fn render_writes_all_its_outputs_or_none() {
    let dir = tempfile::tempdir().unwrap();
    let scene = small_bunny_scene(dir.path());
    std::fs::create_dir_all(dir.path().join("out/x.png")).unwrap();
    let output = viewer(
        dir.path(),
        &[
            "render",
            "--scene",
            scene.to_str().unwrap(),
            "--out",
            "out/x.exr",
            "--software",
        ],
    );
    assert_fails(&output, 1, &["x.png"]);
    assert_eq!(files_under(dir.path()), vec![PathBuf::from("bunny.toml")]);
    // A parent that does not exist is created; one that is a file is an error naming it.
    std::fs::write(dir.path().join("file"), "").unwrap();
    let output = viewer(
        dir.path(),
        &[
            "render",
            "--scene",
            scene.to_str().unwrap(),
            "--out",
            "file/x.png",
        ],
    );
    assert_fails(&output, 1, &["file"]);
}

/// A manifest for `compare` in `dir` with one case (the bundled sphere) of this name and
/// reference.
fn sphere_manifest(dir: &Path, name: &str, reference: &Path) -> PathBuf {
    let data = data_dir().canonicalize().unwrap();
    let manifest = format!(
        "[[case]]\nname = {name:?}\nscene = {scene:?}\nreference = {reference:?}\n",
        scene = data.join("scenes/sphere_r35.toml").display().to_string(),
        reference = reference.display().to_string(),
    );
    let path = dir.join("cases.toml");
    std::fs::write(&path, manifest).unwrap();
    path
}

/// `compare --fit DIR` silently rendered a case that names its own `fit` (another medium)
/// with that fit: the run now says so, per case.
#[test]
fn compare_says_when_a_case_keeps_its_own_fit() {
    let dir = tempfile::tempdir().unwrap();
    let data = data_dir().canonicalize().unwrap();
    let manifest = sphere_manifest(
        dir.path(),
        "sphere",
        &data.join("wax-spheres/sphere_r35.exr"),
    );
    let own = data.join("skin1-fit");
    let text = std::fs::read_to_string(&manifest).unwrap();
    std::fs::write(
        &manifest,
        format!("{text}fit = {:?}\n", own.display().to_string()),
    )
    .unwrap();
    // Stop before rendering: the output folder is a file.
    std::fs::write(dir.path().join("out"), b"").unwrap();
    let wax = data.join("wax-fit");
    let output = viewer(
        dir.path(),
        &[
            "compare",
            "--cases",
            "cases.toml",
            "--fit",
            wax.to_str().unwrap(),
            "--out",
            "out",
            "--software",
        ],
    );
    assert_fails(&output, 1, &["out"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("note: case sphere keeps its own fit") && stderr.contains("skin1-fit"),
        "{stderr}"
    );
}

/// Case names became figure paths: `../x` or `/abs` wrote outside `--out`.
#[test]
fn compare_rejects_case_names_that_are_not_plain_file_names() {
    let dir = tempfile::tempdir().unwrap();
    let work = dir.path().join("work");
    std::fs::create_dir_all(&work).unwrap();
    let reference = data_dir()
        .canonicalize()
        .unwrap()
        .join("wax-spheres/sphere_r35.exr");
    let absolute = dir.path().join("abs").display().to_string();
    for name in ["../escape", absolute.as_str(), "", ".hidden", "a/b"] {
        sphere_manifest(&work, name, &reference);
        let output = viewer(
            &work,
            &[
                "compare",
                "--cases",
                "cases.toml",
                "--size",
                "128",
                "--out",
                "out",
                "--software",
            ],
        );
        assert_fails(&output, 1, &["cases.toml", &format!("case {name:?}")]);
        assert_eq!(
            files_under(dir.path()),
            vec![PathBuf::from("work/cases.toml")]
        );
    }
}

/// `compare` wrote compare.json and compare.md, then failed on a figure.
#[test]
fn compare_writes_all_its_outputs_or_none() {
    let dir = tempfile::tempdir().unwrap();
    let reference = data_dir()
        .canonicalize()
        .unwrap()
        .join("wax-spheres/sphere_r35.exr");
    sphere_manifest(dir.path(), "sphere", &reference);
    std::fs::create_dir_all(dir.path().join("out/sphere.png")).unwrap();
    let output = viewer(
        dir.path(),
        &[
            "compare",
            "--cases",
            "cases.toml",
            "--size",
            "128",
            "--out",
            "out",
            "--software",
        ],
    );
    assert_fails(&output, 1, &["sphere.png"]);
    assert_eq!(files_under(dir.path()), vec![PathBuf::from("cases.toml")]);
}

/// One NaN pixel in the reference made every metric `null` in compare.json, exit 0.
#[test]
fn compare_rejects_a_non_finite_reference_pixel() {
    let dir = tempfile::tempdir().unwrap();
    let mut image =
        cdrf_core::image_file::RgbaImage::read_exr(data_dir().join("wax-spheres/sphere_r35.exr"))
            .unwrap();
    let (x, y) = (300, 200);
    image.pixels[(y * image.width + x) as usize][1] = f32::NAN;
    let reference = dir.path().join("nan.exr");
    image.write_exr(&reference).unwrap();
    sphere_manifest(dir.path(), "sphere", &reference);
    let output = viewer(
        dir.path(),
        &[
            "compare",
            "--cases",
            "cases.toml",
            "--size",
            "128",
            "--out",
            "out",
            "--software",
        ],
    );
    assert_fails(&output, 1, &["nan.exr", "pixel (300, 200)"]);
    assert_eq!(
        files_under(dir.path()),
        vec![PathBuf::from("cases.toml"), PathBuf::from("nan.exr")]
    );
}

/// `cdrf-viewer --scene BAD screenshot` ignored the flag; `screenshot --fit BAD` drew the
/// error into the UI and exited 0.
#[test]
fn screenshot_fails_on_start_up_files_it_cannot_use() {
    let dir = tempfile::tempdir().unwrap();
    let output = viewer(
        dir.path(),
        &["--scene", "bad.toml", "screenshot", "--out", "a.png"],
    );
    assert_fails(&output, 1, &["bad.toml"]);
    let output = viewer(
        dir.path(),
        &["--fit", "nofit", "screenshot", "--out", "a.png"],
    );
    assert_fails(&output, 1, &["nofit"]);
    let output = viewer(
        dir.path(),
        &["screenshot", "--fit", "nofit", "--out", "a.png"],
    );
    assert_fails(&output, 1, &["nofit"]);
    // Top-level flags belong to the window and screenshot only.
    let output = viewer(
        dir.path(),
        &[
            "--fit", "nofit", "render", "--scene", "s.toml", "--out", "a.png",
        ],
    );
    assert_fails(&output, 1, &["--fit"]);
    assert!(!dir.path().join("a.png").exists());
}

/// `--curvature-smoothing 4294967295` smoothed for hours: the flag is bounded at parse time.
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
    assert_fails(&output, 2, &["--curvature-smoothing", "1000"]);
}
