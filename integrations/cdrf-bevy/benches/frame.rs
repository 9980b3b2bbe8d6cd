//! Frame cost in Bevy: the showcase scene (wax knot, skin and marble bunnies, a floor, a point
//! light) rendered headless at 1280 × 720 with the plugin's measured tables — local model, and
//! every non-local term — against the same scene with Bevy's `StandardMaterial`, in one run.
//!
//! `cargo bench --bench frame [-- --frames N]` in `integrations/cdrf-bevy` (lavapipe here: its
//! numbers say how the costs compare, not what a GPU takes).

#[path = "../examples/common/mod.rs"]
mod common;
#[path = "../tests/common/mod.rs"]
mod headless;

use std::time::Instant;

use bevy::camera::{Hdr, RenderTarget};
use bevy::log::LogPlugin;
use bevy::prelude::*;
use bevy::render::render_resource::TextureFormat;
use bevy::render::renderer::RenderDevice;
use bevy::render::{RenderApp, render_resource::PollType};
use cdrf_bevy::{CdrfPlugin, CdrfSettings};
use cdrf_core::light::NonLocal;
use common::Shading;

const WARM_UP_FRAMES: u32 = 5;

/// Mean milliseconds per frame over `frames` frames after a warm-up; the GPU's queue is
/// drained before the clock starts and before it stops.
fn ms_per_frame(shading: Shading, non_local: NonLocal, frames: u32) -> f64 {
    let mut app = App::new();
    app.add_plugins((
        headless::headless_plugins()
            .set(common::asset_plugin())
            // One app after another: the first one's logger stays.
            .disable::<LogPlugin>(),
        CdrfPlugin {
            settings: CdrfSettings {
                non_local,
                ..default()
            },
        },
    ));
    let target = app
        .world_mut()
        .resource_mut::<Assets<Image>>()
        .add(Image::new_target_texture(
            1280,
            720,
            TextureFormat::Rgba8UnormSrgb,
            None,
        ));
    common::spawn_showcase(app.world_mut(), shading);
    app.world_mut().spawn((
        Camera3d::default(),
        RenderTarget::Image(target.into()),
        Hdr,
        common::camera_transform(),
    ));
    headless::finish_plugins(&mut app);
    let wait = |app: &mut App| {
        let device = app
            .sub_app(RenderApp)
            .world()
            .resource::<RenderDevice>()
            .wgpu_device()
            .clone();
        device
            .poll(PollType::wait_indefinitely())
            .expect("the device polls");
    };
    // The wax table is an asset: wait for it, or the knot is missing from the timed frames.
    let tables = usize::from(shading == Shading::Cdrf);
    for _ in 0..1000 {
        if app.world().resource::<Assets<cdrf_bevy::CdrfTable>>().len() >= tables {
            break;
        }
        app.update();
    }
    assert_eq!(
        app.world().resource::<Assets<cdrf_bevy::CdrfTable>>().len(),
        tables,
        "the wax table did not load"
    );
    for _ in 0..WARM_UP_FRAMES {
        app.update();
    }
    wait(&mut app);
    let start = Instant::now();
    for _ in 0..frames {
        app.update();
    }
    wait(&mut app);
    start.elapsed().as_secs_f64() * 1000.0 / f64::from(frames)
}

fn main() {
    let mut args = std::env::args().skip(1).filter(|a| a != "--bench");
    let frames = match (args.next().as_deref(), args.next()) {
        (None, _) => 20,
        (Some("--frames"), Some(n)) => n.parse().expect("--frames takes a count"),
        _ => {
            eprintln!("usage: frame [--frames N]");
            std::process::exit(2);
        }
    };
    let standard = ms_per_frame(Shading::Standard, NonLocal::OFF, frames);
    let local = ms_per_frame(Shading::Cdrf, NonLocal::OFF, frames);
    let all = ms_per_frame(Shading::Cdrf, NonLocal::ALL, frames);
    println!("showcase scene, 1280 x 720, {frames} frames each:");
    println!("  StandardMaterial            {standard:8.1} ms/frame   1.00x");
    println!(
        "  cdrf, local model           {local:8.1} ms/frame   {:.2}x",
        local / standard
    );
    println!(
        "  cdrf, every non-local term  {all:8.1} ms/frame   {:.2}x",
        all / standard
    );
}
