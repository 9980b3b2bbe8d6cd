//! `cdrf-viewer`: the window (no subcommand), `render` (a scene file to an image, no window)
//! and `screenshot` (the whole UI, offscreen).

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use cdrf_core::scene::Scene;
use cdrf_core::scene::ShadingSpec;
use cdrf_render::Options;
use cdrf_render::headless::{
    AdapterPreference, HeadlessDevice, RenderSettings, VULKAN_HINT, render_scene,
};
use cdrf_viewer::offscreen::OffscreenUi;
use cdrf_viewer::outputs::StagedOutputs;
use cdrf_viewer::{Compare, StartupFiles, ViewerApp};
use clap::{Args, Parser, Subcommand, ValueEnum};
use image::ImageEncoder;

/// Compare the measured and the Gaussian CDRF on a mesh. Without a subcommand: open the
/// window on the bundled bunny and wax fit.
#[derive(Parser)]
#[command(version, about)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    #[command(flatten)]
    start: StartArgs,
    /// Window mode only: after this many frames, save a screenshot (--screenshot-to) and
    /// exit, printing the mean frame interval (the app repaints continuously meanwhile).
    #[arg(long, value_name = "N")]
    exit_after_frames: Option<u32>,
    /// Window mode only: where --exit-after-frames saves the window's screenshot (PNG).
    #[arg(long, value_name = "PNG", requires = "exit_after_frames")]
    screenshot_to: Option<PathBuf>,
}

/// What the viewer opens with (window and screenshot).
#[derive(Args, Clone)]
struct StartArgs {
    /// A scene file whose mesh, scale, light, non-local terms, specular layer and sky to open
    /// (default: data/scenes/viewer.toml, the bunny with every term).
    #[arg(long, value_name = "SCENE.toml")]
    scene: Option<PathBuf>,
    /// A cdrf-fit output folder with measured.exr and gaussian.toml (default: data/wax-fit).
    #[arg(long, value_name = "DIR")]
    fit: Option<PathBuf>,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene file to an image without a window (float EXR or sRGB PNG).
    Render(RenderArgs),
    /// Render the whole UI offscreen (no display needed) to a PNG.
    Screenshot(ScreenshotArgs),
    /// Compare measured CDRF, Gaussian CDRF and Lambert with path-traced references: JSON,
    /// Markdown and a figure per case.
    Compare(CompareArgs),
}

#[derive(Args)]
struct CompareArgs {
    /// Cases: `[[case]] name, scene, reference` (default: data/compare.toml).
    #[arg(long, value_name = "TOML")]
    cases: Option<PathBuf>,
    /// cdrf-fit output folder with measured.exr and gaussian.toml (default: data/wax-fit); a
    /// case whose entry names its own `fit` (another medium) keeps that one.
    #[arg(long, value_name = "DIR")]
    fit: Option<PathBuf>,
    /// Output folder for compare.json, compare.md and one figure per case.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Also write the results page (Markdown: how it compares, each case's figure and table;
    /// e.g. docs/results.md), linking the figures in --out.
    #[arg(long, value_name = "FILE.md")]
    results: Option<PathBuf>,
    /// Compare at SIZE × SIZE pixels (must divide the references' size; default: theirs).
    #[arg(long, value_name = "PX")]
    size: Option<u32>,
    /// Only the named case (repeatable).
    #[arg(long = "case", value_name = "NAME")]
    only: Vec<String>,
    /// Override every scene's `[mesh] curvature_smoothing` (rounds of curvature smoothing,
    /// at most 1000).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32)
        .range(0..=i64::from(cdrf_core::curvature::MAX_SMOOTHING_ITERATIONS)))]
    curvature_smoothing: Option<u32>,
    /// Insist on a software adapter (lavapipe).
    #[arg(long)]
    software: bool,
}

/// The most frames `render --frames` times (a few minutes at most on a CPU adapter).
const MAX_TIMED_FRAMES: u32 = 10_000;

#[derive(Args)]
struct RenderArgs {
    /// Scene file (every key: docs/scene-file.md).
    #[arg(long = "scene", value_name = "SCENE.toml")]
    render_scene: PathBuf,
    /// Output: .exr (linear float RGBA, alpha = coverage, plus an sRGB preview .png beside
    /// it) or .png (sRGB only).
    #[arg(long, value_name = "OUT.exr|OUT.png")]
    out: PathBuf,
    /// Render and time this many more frames after a warm-up; report ms per frame
    /// (at most 10000).
    #[arg(long, default_value_t = 0, value_name = "N",
          value_parser = clap::value_parser!(u32).range(0..=i64::from(MAX_TIMED_FRAMES)))]
    frames: u32,
    /// Multiply the radiance by this (overrides the scene's `[camera] exposure`, default 1).
    #[arg(long, value_name = "FACTOR")]
    exposure: Option<f32>,
    /// Print one JSON object on stdout: adapter, width, height, frames, ms_per_frame, outputs.
    #[arg(long)]
    json: bool,
    /// Insist on a software adapter (lavapipe).
    #[arg(long)]
    software: bool,
}

#[derive(Args, Clone)]
struct ScreenshotArgs {
    /// Output PNG.
    #[arg(long, value_name = "OUT.png")]
    out: PathBuf,
    /// UI size in points, WIDTHxHEIGHT.
    #[arg(long, default_value = "1280x720", value_parser = parse_size)]
    size: (u32, u32),
    /// Pixels per point (2 for a HiDPI image).
    #[arg(long, default_value_t = 1.0)]
    scale: f32,
    /// How the models share the view (one: the left model alone, as the viewer opens).
    #[arg(long, value_enum, default_value_t = ViewArg::One)]
    view: ViewArg,
    #[command(flatten)]
    start: StartArgs,
}

#[derive(Clone, Copy, ValueEnum)]
enum ViewArg {
    One,
    SideBySide,
    Split,
    Difference,
    Curvature,
}

fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let (w, h) = text
        .split_once(['x', 'X', '×'])
        .ok_or_else(|| format!("{text}: expected WIDTHxHEIGHT, e.g. 1280x720"))?;
    let parse = |s: &str| {
        s.trim()
            .parse::<u32>()
            .ok()
            .filter(|v| *v > 0)
            .ok_or_else(|| format!("{text}: width and height must be whole numbers > 0"))
    };
    Ok((parse(w)?, parse(h)?))
}

fn startup_files(args: &StartArgs) -> anyhow::Result<StartupFiles> {
    let data = cdrf_viewer::assets::bundled_data_dir();
    let scene = args
        .scene
        .clone()
        .unwrap_or_else(|| data.join(cdrf_viewer::assets::BUNDLED_SCENE));
    let fit = args.fit.clone().unwrap_or_else(|| data.join("wax-fit"));
    StartupFiles::from_scene(&scene, &fit).context(
        "the viewer's start-up files (set CDRF_DATA to the repository's data folder, or pass --scene and --fit)",
    )
}

fn render(args: &RenderArgs) -> anyhow::Result<()> {
    match args.out.extension().and_then(|e| e.to_str()) {
        Some("exr" | "png") => {}
        _ => bail!("{}: --out must end in .exr or .png", args.out.display()),
    }
    let mut scene = Scene::load(&args.render_scene)?;
    if let Some(exposure) = args.exposure {
        if let Some(problem) = cdrf_core::scene::exposure_problem(exposure) {
            bail!("--exposure {problem}");
        }
        scene.camera.exposure = exposure;
    }
    // Every output is checked (not an input, folder writable) and staged before the render.
    let png = args.out.with_extension("png");
    let mut output_paths = Vec::new();
    if args.out.extension().is_some_and(|e| e == "exr") {
        output_paths.push(args.out.clone());
    }
    output_paths.push(png.clone());
    let mut inputs = vec![args.render_scene.clone(), scene.mesh.path.clone()];
    match &scene.shading {
        ShadingSpec::Measured { lut } => inputs.push(lut.clone()),
        ShadingSpec::Gaussian { parameters } => inputs.push(parameters.clone()),
        _ => {}
    }
    let staged = StagedOutputs::new(&output_paths, &inputs)?;
    let assets = scene
        .load_assets()
        .with_context(|| format!("{}", args.render_scene.display()))?;
    let preference = if args.software {
        AdapterPreference::Software
    } else {
        AdapterPreference::Any
    };
    let device = HeadlessDevice::new(preference)?;
    let settings = RenderSettings {
        options: Options::default(),
        timed_frames: args.frames,
        ..RenderSettings::default()
    };
    let rendered = render_scene(&device, &scene, &assets, &settings)?;
    if args.out.extension().is_some_and(|e| e == "exr") {
        rendered
            .image
            .write_exr(staged.temporary_path(&args.out))
            .with_context(|| format!("writing {}", args.out.display()))?;
    }
    rendered
        .image
        .write_png_srgb(staged.temporary_path(&png))
        .with_context(|| format!("writing {}", png.display()))?;
    let outputs = staged.commit()?;

    if args.json {
        let outputs: Vec<String> = outputs.iter().map(|p| p.display().to_string()).collect();
        let summary = serde_json::json!({
            "adapter": device.adapter_description(),
            "width": rendered.image.width,
            "height": rendered.image.height,
            "frames": rendered.timed_frames,
            "ms_per_frame": rendered.ms_per_frame,
            "outputs": outputs,
        });
        println!("{summary}");
    } else {
        eprintln!("adapter: {}", device.adapter_description());
        for output in outputs {
            eprintln!("wrote {}", output.display());
        }
        if let Some(ms) = rendered.ms_per_frame {
            eprintln!("{ms:.3} ms per frame over {} frames", rendered.timed_frames);
        }
    }
    Ok(())
}

/// Creates the folder `path` is to be written in.
fn create_parent(path: &Path) -> anyhow::Result<()> {
    match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => std::fs::create_dir_all(parent)
            .with_context(|| format!("creating the folder {}", parent.display())),
        _ => Ok(()),
    }
}

/// Writes `image` as PNG through a temporary file renamed over `path`.
fn write_png(image: &image::RgbaImage, path: &Path) -> anyhow::Result<()> {
    cdrf_core::atomic::write_file(path, |file| {
        image::codecs::png::PngEncoder::new(std::io::BufWriter::new(file))
            .write_image(
                image.as_raw(),
                image.width(),
                image.height(),
                image::ExtendedColorType::Rgba8,
            )
            .map_err(std::io::Error::other)
    })
    .with_context(|| format!("writing {}", path.display()))
}

fn apply_view(app: &mut ViewerApp, view: ViewArg) {
    let settings = app.settings_mut();
    match view {
        ViewArg::One => settings.compare = Compare::Single,
        ViewArg::SideBySide => settings.compare = Compare::SideBySide,
        ViewArg::Split => settings.compare = Compare::Split,
        ViewArg::Difference => settings.compare = Compare::Difference,
        ViewArg::Curvature => settings.curvature_view = true,
    }
}

fn screenshot(args: &ScreenshotArgs) -> anyhow::Result<()> {
    if args.out.extension().is_none_or(|e| e != "png") {
        bail!("{}: --out must end in .png", args.out.display());
    }
    if !(args.scale.is_finite() && args.scale > 0.0) {
        bail!("--scale {}: must be > 0", args.scale);
    }
    let files = startup_files(&args.start)?;
    let mut offscreen = OffscreenUi::new([args.size.0, args.size.1], args.scale)?;
    let mut app = ViewerApp::new(offscreen.render_state(), &files);
    // A screenshot of the start-up files' error is not what was asked for.
    if let Some(error) = app.error() {
        bail!("the viewer's start-up files: {error}");
    }
    // Offscreen frames are not display frames: their intervals and build times mean nothing.
    app.settings_mut().show_timings = false;
    apply_view(&mut app, args.view);
    let image = offscreen.render(&mut app, 4, Duration::from_millis(16))?;
    if let Some(error) = app.error() {
        eprintln!("note: the UI shows an error: {error}");
    }
    write_png(&image, &args.out)?;
    eprintln!(
        "wrote {} ({} × {} px)",
        args.out.display(),
        image.width(),
        image.height()
    );
    Ok(())
}

fn compare(args: &CompareArgs) -> anyhow::Result<()> {
    use cdrf_eval::{
        Models, Provenance, markdown, output_files, output_paths, read_manifest, run_case,
    };
    use cdrf_viewer::assets::{FIT_GAUSSIAN_FILE, FIT_LUT_FILE};
    let data = cdrf_viewer::assets::bundled_data_dir();
    let cases_path = args
        .cases
        .clone()
        .unwrap_or_else(|| data.join("compare.toml"));
    let fit = args.fit.clone().unwrap_or_else(|| data.join("wax-fit"));
    let mut cases = read_manifest(&cases_path)?;
    if !args.only.is_empty() {
        for name in &args.only {
            if !cases.iter().any(|case| &case.name == name) {
                bail!("{}: no case named {name}", cases_path.display());
            }
        }
        cases.retain(|case| args.only.contains(&case.name));
    }
    let models = Models::from_files(&fit.join(FIT_LUT_FILE), &fit.join(FIT_GAUSSIAN_FILE))?;
    // Every output is checked and staged before the work.
    let output_paths = output_paths(
        &args.out,
        cases.iter().map(|case| case.name.as_str()),
        args.results.as_deref(),
    );
    let mut inputs = vec![
        cases_path.clone(),
        fit.join(FIT_LUT_FILE),
        fit.join(FIT_GAUSSIAN_FILE),
    ];
    for case in &cases {
        inputs.extend([case.scene.clone(), case.reference.clone()]);
    }
    // Cases of another medium bring their own fit (`fit` in the manifest).
    let mut case_models = Vec::with_capacity(cases.len());
    for case in &cases {
        case_models.push(match &case.fit {
            Some(fit) => {
                if let Some(asked) = &args.fit {
                    eprintln!(
                        "note: case {} keeps its own fit {} (named in {}), not --fit {}",
                        case.name,
                        fit.display(),
                        cases_path.display(),
                        asked.display()
                    );
                }
                inputs.extend([fit.join(FIT_LUT_FILE), fit.join(FIT_GAUSSIAN_FILE)]);
                Some(Models::from_files(
                    &fit.join(FIT_LUT_FILE),
                    &fit.join(FIT_GAUSSIAN_FILE),
                )?)
            }
            None => None,
        });
    }
    let staged = StagedOutputs::new(&output_paths, &inputs)?;
    let preference = if args.software {
        AdapterPreference::Software
    } else {
        AdapterPreference::Any
    };
    let device = HeadlessDevice::new(preference)?;
    eprintln!("adapter: {}", device.adapter_description());
    let mut results = Vec::new();
    for (case, own_models) in cases.iter().zip(&case_models) {
        eprintln!("case {}: rendering and comparing", case.name);
        results.push(run_case(
            &device,
            case,
            own_models.as_ref().unwrap_or(&models),
            args.size,
            args.curvature_smoothing,
        )?);
    }
    let provenance = args.results.as_ref().map(|_| Provenance {
        command: std::iter::once("cdrf-viewer".to_owned())
            .chain(std::env::args().skip(1))
            .collect::<Vec<_>>()
            .join(" "),
        adapter: device.adapter_description(),
        fit: args.fit.as_ref().map_or_else(
            || "data/wax-fit (the bundled fit)".to_owned(),
            |fit| fit.display().to_string(),
        ),
    });
    let page = args.results.as_deref().zip(provenance.as_ref());
    for (path, bytes) in output_files(&results, &args.out, page)? {
        staged.write(&path, |file| std::io::Write::write_all(file, &bytes))?;
    }
    let written = staged.commit()?;
    println!("{}", markdown(&results));
    for path in written {
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

/// The window, with the optional scripted screenshot-and-exit.
struct Window {
    app: ViewerApp,
    frames: u32,
    exit_after_frames: Option<u32>,
    screenshot_to: Option<PathBuf>,
    timing_started: Option<(Instant, u32)>,
    screenshot: Arc<Mutex<Option<Arc<egui::ColorImage>>>>,
    result: Arc<Mutex<Option<anyhow::Result<()>>>>,
}

impl eframe::App for Window {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        self.app.show(ui);
        let Some(exit_after) = self.exit_after_frames else {
            return;
        };
        self.frames += 1;
        // Frames after the first few (shader compilation, first uploads) are timed.
        if self.frames == exit_after / 2 {
            self.timing_started = Some((Instant::now(), self.frames));
        }
        let ctx = ui.ctx().clone();
        let screenshot = lock(&self.screenshot).take();
        if let Some(image) = screenshot {
            let outcome = self.save_screenshot(&image);
            *lock(&self.result) = Some(outcome);
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
        } else if self.frames == exit_after {
            if let Some((start, first)) = self.timing_started {
                let timed = self.frames - first;
                let ms = start.elapsed().as_secs_f64() * 1e3 / f64::from(timed.max(1));
                let size = ctx.content_rect().size() * ctx.pixels_per_point();
                println!(
                    "window {:.0} × {:.0} px: {ms:.1} ms per frame over {timed} frames",
                    size.x, size.y
                );
            }
            if self.screenshot_to.is_some() {
                let slot = self.screenshot.clone();
                ctx.request_screenshot(move |image| *lock(&slot) = Some(image));
            } else {
                *lock(&self.result) = Some(Ok(()));
                ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            }
        }
        ctx.request_repaint();
    }
}

fn lock<T>(mutex: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    mutex
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

impl Window {
    fn save_screenshot(&self, image: &egui::ColorImage) -> anyhow::Result<()> {
        let Some(path) = &self.screenshot_to else {
            return Ok(());
        };
        let [width, height] = image.size;
        let bytes: Vec<u8> = image.pixels.iter().flat_map(|c| c.to_array()).collect();
        let image = image::RgbaImage::from_raw(width as u32, height as u32, bytes)
            .context("screenshot size mismatch")?;
        create_parent(path)?;
        write_png(&image, path)?;
        eprintln!("wrote {} ({width} × {height} px)", path.display());
        Ok(())
    }
}

const NO_DISPLAY_HELP: &str = "\
no display: neither DISPLAY nor WAYLAND_DISPLAY is set, so the viewer cannot open a window.
Without a display, use the headless commands (from a checkout: cargo run --release -p cdrf-viewer -- ...):
  cdrf-viewer render --scene data/scenes/bunny.toml --out out/bunny.exr   # one model, float EXR
  cdrf-viewer screenshot --out out/viewer.png                             # the whole UI, offscreen
  cdrf-viewer compare --out out/compare                                   # the models vs path-traced references
or run the window under a virtual X server:
  xvfb-run -a -s \"-screen 0 1280x800x24\" cargo run --release -p cdrf-viewer";

fn window(cli: &Cli) -> anyhow::Result<()> {
    if cfg!(all(unix, not(target_os = "macos")))
        && std::env::var_os("DISPLAY").is_none()
        && std::env::var_os("WAYLAND_DISPLAY").is_none()
    {
        bail!(NO_DISPLAY_HELP);
    }
    let files = startup_files(&cli.start)?;
    let options = eframe::NativeOptions {
        wgpu_options: egui_wgpu::WgpuConfiguration {
            wgpu_setup: cdrf_viewer::gpu::wgpu_setup(),
            ..Default::default()
        },
        viewport: egui::ViewportBuilder::default()
            .with_title("cdrf viewer")
            .with_inner_size([1280.0, 720.0])
            .with_min_inner_size([640.0, 400.0])
            .with_drag_and_drop(true),
        ..Default::default()
    };
    let result = Arc::new(Mutex::new(None));
    let shared = result.clone();
    let (exit_after_frames, screenshot_to) = (cli.exit_after_frames, cli.screenshot_to.clone());
    eframe::run_native(
        "cdrf viewer",
        options,
        Box::new(move |cc| {
            let render_state = cc
                .wgpu_render_state
                .as_ref()
                .ok_or("eframe started without its wgpu renderer")?;
            let mut app = ViewerApp::new(render_state, &files);
            if exit_after_frames.is_some() {
                app.settings_mut().continuous = true;
            }
            Ok(Box::new(Window {
                app,
                frames: 0,
                exit_after_frames,
                screenshot_to,
                timing_started: None,
                screenshot: Arc::new(Mutex::new(None)),
                result: shared,
            }))
        }),
    )
    .map_err(|error| match error {
        eframe::Error::Wgpu(error) => anyhow::anyhow!("{error}\n\n{VULKAN_HINT}"),
        error => anyhow::anyhow!("{error}\n\n{NO_DISPLAY_HELP}"),
    })?;
    let outcome = lock(&result).take();
    match (outcome, cli.exit_after_frames) {
        (Some(outcome), _) => outcome,
        (None, Some(frames)) => bail!("the window closed before {frames} frames were shown"),
        (None, None) => Ok(()),
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    let top_level = [
        ("--scene", cli.start.scene.is_some()),
        ("--fit", cli.start.fit.is_some()),
        ("--exit-after-frames", cli.exit_after_frames.is_some()),
    ];
    let given: Vec<&str> = top_level
        .iter()
        .filter(|(_, given)| *given)
        .map(|(flag, _)| *flag)
        .collect();
    if !given.is_empty() && matches!(cli.command, Some(Command::Render(_) | Command::Compare(_))) {
        bail!(
            "{} before the subcommand: for the window and screenshot only (render takes \
             --scene after `render`, compare --fit after `compare`)",
            given.join(", ")
        );
    }
    match &cli.command {
        Some(Command::Render(args)) => render(args),
        Some(Command::Screenshot(args)) => {
            // `cdrf-viewer --scene S screenshot` means `screenshot --scene S`.
            if cli.exit_after_frames.is_some() {
                bail!("--exit-after-frames is for the window, not screenshot");
            }
            let mut args = args.clone();
            for (top, own, flag) in [
                (&cli.start.scene, &mut args.start.scene, "--scene"),
                (&cli.start.fit, &mut args.start.fit, "--fit"),
            ] {
                match (top, &own) {
                    (Some(_), Some(_)) => {
                        bail!("{flag} given both before and after `screenshot`: give it once")
                    }
                    (Some(top), None) => *own = Some(top.clone()),
                    _ => {}
                }
            }
            screenshot(&args)
        }
        Some(Command::Compare(args)) => compare(args),
        None => window(&cli),
    }
}

/// Gives the process a private, empty `XDG_RUNTIME_DIR` (mode 0700, in the temporary folder)
/// when it has none that is a folder: without one the Vulkan loader and the window system's
/// libraries print "XDG_RUNTIME_DIR is invalid or not set" every time they start. Returns the
/// folder's guard, which removes it when dropped.
///
/// # Safety
/// It changes the environment: no other thread may exist yet.
#[allow(unsafe_code)]
unsafe fn private_runtime_dir() -> Option<tempfile::TempDir> {
    if !cfg!(all(unix, not(target_os = "macos")))
        || std::env::var_os("XDG_RUNTIME_DIR").is_some_and(|dir| Path::new(&dir).is_dir())
    {
        return None;
    }
    let mut builder = tempfile::Builder::new();
    builder.prefix("cdrf-runtime-");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o700));
    }
    let dir = builder.tempdir().ok()?;
    // SAFETY: the caller guarantees that no other thread exists.
    unsafe { std::env::set_var("XDG_RUNTIME_DIR", dir.path()) };
    Some(dir)
}

fn main() -> ExitCode {
    // First, as clap exits the process on --help or a usage error (no folder to leave behind).
    let cli = Cli::parse();
    // SAFETY: no other thread exists yet: parsing the command line starts none.
    #[allow(unsafe_code)]
    let _runtime_dir = unsafe { private_runtime_dir() };
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {error:#}");
            ExitCode::FAILURE
        }
    }
}
