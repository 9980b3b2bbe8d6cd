//! Wax, skin and marble in Bevy: the trefoil knot in the wax table fitted from photographs
//! (`data/wax-fit/measured.exr`, loaded as an asset: edit it and it reloads), the Stanford bunny
//! in the built-in skin and marble tables, a point light circling them, a sky, and a Bevy
//! `StandardMaterial` floor they stand on. `N` turns the non-local terms (shadows,
//! transmission, the subsurface gather, inter-reflection) on and off; the window title says
//! which.
//!
//! `cargo run --release --example glow` in `integrations/cdrf-bevy`;
//! `… --example glow -- --screenshot glow.png` saves the 30th frame (the light still) and exits.

use bevy::asset::RenderAssetUsages;
use bevy::light::GlobalAmbientLight;
use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured, save_to_disk};
use cdrf_bevy::{CdrfMaterial, CdrfMaterial3d, CdrfPlugin, CdrfSettings};
use cdrf_core::light::NonLocal;

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
    app
        .add_plugins((
            DefaultPlugins
                .set(AssetPlugin {
                    // The repository's data folder holds the tables and meshes.
                    file_path: concat!(env!("CARGO_MANIFEST_DIR"), "/../../data").into(),
                    watch_for_changes_override: Some(true),
                    ..default()
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
        .insert_resource(GlobalAmbientLight {
            color: Color::srgb(0.6, 0.7, 1.0),
            brightness: 150.0,
            ..default()
        })
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
            .observe(|_: On<ScreenshotCaptured>, mut exit: MessageWriter<AppExit>| {
                exit.write(AppExit::Success);
            });
    }
}

fn title(non_local: bool) -> String {
    format!(
        "cdrf in Bevy: non-local terms {} (N toggles)",
        if non_local { "on" } else { "off" }
    )
}

/// A mesh file of the repository's data folder as a Bevy mesh in metres.
fn load_mesh(path: &str, metres_per_unit: f32) -> Mesh {
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/").to_owned() + path;
    let mut mesh = cdrf_core::Mesh::load(&file)
        .unwrap_or_else(|error| panic!("{error}"))
        .mesh;
    for p in &mut mesh.positions {
        *p *= metres_per_unit;
    }
    cdrf_bevy::mesh_from_cdrf(&mesh, RenderAssetUsages::all())
}

#[derive(Component)]
struct Circling;

fn setup(
    mut commands: Commands,
    assets: Res<AssetServer>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut cdrf_materials: ResMut<Assets<CdrfMaterial>>,
    mut standard_materials: ResMut<Assets<StandardMaterial>>,
) {
    let knot = meshes.add(load_mesh("wax-knot/knot.obj", 0.001));
    let bunny = meshes.add(load_mesh("bunny/bunny.obj", 0.01));
    let wax = cdrf_materials.add(CdrfMaterial::from_lut(assets.load("wax-fit/measured.exr")));
    let skin = cdrf_materials.add(CdrfMaterial::preset("skin1").expect("a built-in table"));
    let marble = cdrf_materials.add(CdrfMaterial::preset("marble").expect("a built-in table"));

    commands.spawn((
        Mesh3d(knot),
        CdrfMaterial3d(wax),
        Transform::from_xyz(0.0, 0.06, 0.0),
    ));
    commands.spawn((
        Mesh3d(bunny.clone()),
        CdrfMaterial3d(skin),
        Transform::from_xyz(-0.13, -0.03, 0.0),
    ));
    commands.spawn((
        Mesh3d(bunny),
        CdrfMaterial3d(marble),
        Transform::from_xyz(0.13, -0.03, 0.0),
    ));
    commands.spawn((
        Mesh3d(meshes.add(Plane3d::default().mesh().size(0.6, 0.4))),
        MeshMaterial3d(standard_materials.add(StandardMaterial {
            base_color: Color::srgb(0.35, 0.33, 0.3),
            perceptual_roughness: 0.8,
            ..default()
        })),
        Transform::from_xyz(0.0, -0.035, 0.0),
    ));
    // About 2000 lux 0.25 m away.
    commands.spawn((
        PointLight {
            intensity: 2000.0 * 0.25 * 0.25 * 4.0 * std::f32::consts::PI,
            range: 5.0,
            ..default()
        },
        Transform::from_xyz(0.18, 0.1, 0.18),
        Circling,
    ));
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.0, 0.12, 0.45).looking_at(Vec3::new(0.0, 0.03, 0.0), Vec3::Y),
    ));
}

fn circle_the_light(time: Res<Time>, mut lights: Query<&mut Transform, With<Circling>>) {
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
