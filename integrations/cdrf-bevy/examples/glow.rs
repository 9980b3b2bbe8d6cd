//! Wax, skin and marble in Bevy: the trefoil knot in the wax table fitted from photographs
//! (`data/wax-fit/measured.exr`, loaded as an asset: edit it and it reloads), the Stanford bunny
//! in the built-in skin and marble tables, a point light circling them, a sky, and a Bevy
//! `StandardMaterial` floor they stand on. `N` turns the non-local terms (shadows,
//! transmission, the subsurface gather, inter-reflection) on and off; the window title says
//! which.
//!
//! `cargo run --release --example glow` in `integrations/cdrf-bevy`;
//! `… --example glow -- --screenshot glow.png` saves the 30th frame (the light still) and exits.

use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured, save_to_disk};
use cdrf_bevy::{CdrfPlugin, CdrfSettings};
use cdrf_core::light::NonLocal;
use common::{Shading, ShowcaseLight};

mod common;

fn main() {
    let mut args = std::env::args().skip(1);
    let screenshot = match (args.next().as_deref(), args.next()) {
        (None, _) => None,
        (Some("--screenshot"), Some(path)) => Some(path),
        _ => {
            eprintln!("usage: glow [--screenshot PATH.png]");
            std::process::exit(2);
        }
    };
    let mut app = App::new();
    app.add_plugins((
        DefaultPlugins
            .set(AssetPlugin {
                watch_for_changes_override: Some(true),
                ..common::asset_plugin()
            })
            .set(WindowPlugin {
                primary_window: Some(Window {
                    title: title(true),
                    ..default()
                }),
                ..default()
            }),
        CdrfPlugin::default(),
    ))
    .insert_resource(common::sky())
    .add_systems(Startup, setup)
    .add_systems(Update, toggle_non_local);
    match screenshot {
        Some(path) => app
            .insert_resource(ScreenshotTo(path))
            .add_systems(Update, screenshot_and_exit),
        None => app.add_systems(Update, circle_the_light),
    };
    app.run();
}

/// Where `--screenshot` saves the frame.
#[derive(Resource)]
struct ScreenshotTo(String);

fn screenshot_and_exit(mut commands: Commands, to: Res<ScreenshotTo>, mut frame: Local<u32>) {
    *frame += 1;
    if *frame == 30 {
        commands
            .spawn(Screenshot::primary_window())
            .observe(save_to_disk(to.0.clone()))
            .observe(
                |_: On<ScreenshotCaptured>, mut exit: MessageWriter<AppExit>| {
                    exit.write(AppExit::Success);
                },
            );
    }
}

fn title(non_local: bool) -> String {
    format!(
        "cdrf in Bevy: non-local terms {} (N toggles)",
        if non_local { "on" } else { "off" }
    )
}

fn setup(world: &mut World) {
    common::spawn_showcase(world, Shading::Cdrf);
    world.spawn((Camera3d::default(), common::camera_transform()));
}

fn circle_the_light(time: Res<Time>, mut lights: Query<&mut Transform, With<ShowcaseLight>>) {
    let angle = 0.4 * time.elapsed_secs();
    for mut transform in &mut lights {
        transform.translation = Vec3::new(0.25 * angle.cos(), 0.1, 0.25 * angle.sin());
    }
}

fn toggle_non_local(
    keys: Res<ButtonInput<KeyCode>>,
    mut settings: ResMut<CdrfSettings>,
    mut windows: Query<&mut Window>,
) {
    if !keys.just_pressed(KeyCode::KeyN) {
        return;
    }
    let on = settings.non_local == NonLocal::OFF;
    settings.non_local = if on { NonLocal::ALL } else { NonLocal::OFF };
    for mut window in &mut windows {
        window.title = title(on);
    }
}
