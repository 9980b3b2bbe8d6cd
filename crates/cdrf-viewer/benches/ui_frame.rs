//! Frame times of the viewer at 1280 × 720 on whatever adapter wgpu picks (lavapipe without a
//! GPU), in one run so the figures compare:
//!
//! 1. the whole UI offscreen (egui + both 3D slots + composite + readback, one frame at a
//!    time) for each view: side by side, split, difference, curvature;
//! 2. the bunny alone, full frame, through the headless renderer, per shading model
//!    (throughput: frames submitted back to back).
//!
//! `cargo bench -p cdrf-viewer --bench ui_frame [-- --frames N]`

use std::time::{Duration, Instant};

use cdrf_core::scene::{Material, Scene};
use cdrf_render::Options;
use cdrf_render::headless::{AdapterPreference, HeadlessDevice, RenderSettings, render_scene};
use cdrf_viewer::offscreen::OffscreenUi;
use cdrf_viewer::{Compare, StartupFiles, ViewerApp};

/// Puts the app into one view.
type SetView = fn(&mut ViewerApp);

const WIDTH: u32 = 1280;
const HEIGHT: u32 = 720;

fn frames_arg() -> u32 {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == "--frames")
        .and_then(|i| args.get(i + 1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(20)
}

fn main() {
    let frames = frames_arg();
    let files = StartupFiles::bundled().unwrap_or_else(|error| panic!("{error}"));

    let mut offscreen = OffscreenUi::new([WIDTH, HEIGHT], 1.0).unwrap_or_else(|e| panic!("{e}"));
    let info = offscreen.render_state().adapter.get_info();
    println!(
        "adapter: {} ({:?}), {frames} frames per case",
        info.name, info.backend
    );
    let mut app = ViewerApp::new(offscreen.render_state(), &files);
    let dt = Duration::from_millis(16);
    println!(
        "\nwhole UI, {WIDTH} × {HEIGHT}, one frame at a time (UI + 3D + composite + readback):"
    );
    let views: [(&str, SetView); 4] = [
        ("side by side", |app| {
            app.settings_mut().compare = Compare::SideBySide
        }),
        ("split", |app| app.settings_mut().compare = Compare::Split),
        ("difference", |app| {
            app.settings_mut().compare = Compare::Difference
        }),
        ("curvature", |app| app.settings_mut().curvature_view = true),
    ];
    for (name, set) in views {
        set(&mut app);
        offscreen
            .render(&mut app, 3, dt)
            .unwrap_or_else(|e| panic!("{e}"));
        let start = Instant::now();
        for _ in 0..frames {
            offscreen
                .render(&mut app, 1, dt)
                .unwrap_or_else(|e| panic!("{e}"));
        }
        let ms = start.elapsed().as_secs_f64() * 1e3 / f64::from(frames);
        println!("  {name:<13} {ms:7.1} ms per frame ({:.0} fps)", 1e3 / ms);
    }

    println!("\nbunny alone, {WIDTH} × {HEIGHT}, 4× MSAA, headless renderer (throughput):");
    let device = HeadlessDevice::new(AdapterPreference::Any).unwrap_or_else(|e| panic!("{e}"));
    let data = cdrf_viewer::assets::bundled_data_dir();
    let mut scene = Scene::load(data.join("scenes/bunny.toml")).unwrap_or_else(|e| panic!("{e}"));
    scene.camera.width = WIDTH;
    scene.camera.height = HEIGHT;
    let mut assets = scene.load_assets().unwrap_or_else(|e| panic!("{e}"));
    let gaussian_path = data.join("wax-fit/gaussian.toml");
    let (model, view_correction) = cdrf_core::read_gaussian(&gaussian_path)
        .and_then(|p| p.load_model(&gaussian_path))
        .unwrap_or_else(|e| panic!("{e}"));
    let measured = assets.material.clone();
    let materials = [
        ("Lambert", Material::Lambert { albedo: [0.8; 3] }),
        ("measured", measured),
        (
            "Gaussian",
            Material::Gaussian {
                model,
                view_correction,
            },
        ),
    ];
    let settings = RenderSettings {
        options: Options::default(),
        timed_frames: frames,
        warm_up_frames: 3,
    };
    let mut times = Vec::new();
    for (name, material) in materials {
        assets.material = material;
        let rendered =
            render_scene(&device, &scene, &assets, &settings).unwrap_or_else(|e| panic!("{e}"));
        let ms = rendered.ms_per_frame.unwrap_or(f64::NAN);
        println!("  {name:<13} {ms:7.1} ms per frame");
        times.push(ms);
    }
    println!(
        "  measured / Lambert {:.2}, measured / Gaussian {:.2}",
        times[1] / times[0],
        times[1] / times[2]
    );
}
