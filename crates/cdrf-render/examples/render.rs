//! Renders a scene file without a window and optionally times it.
//!
//! ```text
//! cargo run --release -p cdrf-render --example render -- \
//!     --scene data/scenes/bunny.toml --out out/bunny.exr [--frames 100] [--json] [--software]
//! ```
//!
//! `--out X.exr` writes linear float RGBA (alpha = coverage) and an sRGB preview `X.png` beside
//! it; `--out X.png` writes only the preview. `--frames N` renders N more frames after a
//! warm-up and reports the mean time per frame; `--json` prints one JSON object on stdout
//! (`adapter`, `width`, `height`, `frames`, `ms_per_frame`, `outputs`). `--software` insists
//! on a software adapter (lavapipe). The viewer's `render` command does the same.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, bail};
use cdrf_core::scene::Scene;
use cdrf_render::Options;
use cdrf_render::headless::{AdapterPreference, HeadlessDevice, RenderSettings, render_scene};

struct Args {
    scene: PathBuf,
    out: PathBuf,
    frames: u32,
    json: bool,
    preference: AdapterPreference,
}

fn parse_args() -> anyhow::Result<Args> {
    let (mut scene, mut out, mut frames, mut json) = (None, None, 0, false);
    let mut preference = AdapterPreference::Any;
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        let mut value = |name: &str| args.next().with_context(|| format!("{name} needs a value"));
        match arg.as_str() {
            "--scene" => scene = Some(PathBuf::from(value("--scene")?)),
            "--out" => out = Some(PathBuf::from(value("--out")?)),
            "--frames" => {
                let text = value("--frames")?;
                frames = text
                    .parse()
                    .with_context(|| format!("--frames {text}: not a whole number"))?;
            }
            "--json" => json = true,
            "--software" => preference = AdapterPreference::Software,
            other => bail!("unknown argument {other} (see the example's docs)"),
        }
    }
    let out = out.context("--out OUT.exr|OUT.png is required")?;
    match out.extension().and_then(|e| e.to_str()) {
        Some("exr" | "png") => {}
        _ => bail!("{}: --out must end in .exr or .png", out.display()),
    }
    Ok(Args {
        scene: scene.context("--scene SCENE.toml is required")?,
        out,
        frames,
        json,
        preference,
    })
}

fn run() -> anyhow::Result<()> {
    let args = parse_args()?;
    let scene = Scene::load(&args.scene)?;
    let assets = scene.load_assets()?;
    let device = HeadlessDevice::new(args.preference)?;
    let settings = RenderSettings {
        options: Options::default(),
        timed_frames: args.frames,
        ..RenderSettings::default()
    };
    let rendered = render_scene(&device, &scene, &assets, &settings)?;
    let mut outputs: Vec<&Path> = Vec::new();
    let png = args.out.with_extension("png");
    if args.out.extension().is_some_and(|e| e == "exr") {
        rendered
            .image
            .write_exr(&args.out)
            .with_context(|| format!("writing {}", args.out.display()))?;
        outputs.push(&args.out);
    }
    rendered
        .image
        .write_png_srgb(&png)
        .with_context(|| format!("writing {}", png.display()))?;
    outputs.push(&png);

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

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {error:#}");
            ExitCode::FAILURE
        }
    }
}
