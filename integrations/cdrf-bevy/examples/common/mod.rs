//! The showcase scene the `glow` example and the frame benchmark share: the wax knot, a skin
//! and a marble bunny, a floor of Bevy's `StandardMaterial`, a point light. Bevy units are
//! metres.

use bevy::asset::RenderAssetUsages;
use bevy::light::GlobalAmbientLight;
use bevy::prelude::*;
use cdrf_bevy::{CdrfMaterial, CdrfMaterial3d};

/// How the three objects are shaded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(dead_code)] // the example uses one
pub enum Shading {
    /// The plugin's measured tables.
    Cdrf,
    /// Bevy's `StandardMaterial` in the tables' mean colours (the benchmark's baseline).
    Standard,
}

/// A marker on the point light.
#[derive(Component)]
pub struct ShowcaseLight;

/// The asset server reads the repository's data folder (tables and meshes), watching it for
/// changes where the file watcher is built in.
pub fn asset_plugin() -> AssetPlugin {
    AssetPlugin {
        file_path: concat!(env!("CARGO_MANIFEST_DIR"), "/../../data").into(),
        ..default()
    }
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

/// Spawns the objects, the floor and the light.
pub fn spawn_showcase(world: &mut World, shading: Shading) {
    let knot = load_mesh("wax-knot/knot.obj", 0.001);
    let bunny = load_mesh("bunny/bunny.obj", 0.01);
    let (knot, bunny) = {
        let mut meshes = world.resource_mut::<Assets<Mesh>>();
        (meshes.add(knot), meshes.add(bunny))
    };
    let objects = [
        (
            knot,
            "wax-fit/measured.exr",
            Vec3::new(0.0, 0.06, 0.0),
            Color::srgb(0.8, 0.78, 0.72),
        ),
        (
            bunny.clone(),
            "skin1",
            Vec3::new(-0.13, -0.03, 0.0),
            Color::srgb(0.7, 0.5, 0.4),
        ),
        (
            bunny,
            "marble",
            Vec3::new(0.13, -0.03, 0.0),
            Color::srgb(0.85, 0.85, 0.85),
        ),
    ];
    for (mesh, table, position, color) in objects {
        let transform = Transform::from_translation(position);
        match shading {
            Shading::Cdrf => {
                let material = match table.strip_suffix(".exr") {
                    // A file: an asset (hot-reloaded where the file watcher is on).
                    Some(_) => {
                        let table = world.resource::<AssetServer>().load(table);
                        CdrfMaterial::from_lut(table)
                    }
                    None => CdrfMaterial::preset(table).expect("a built-in table"),
                };
                let material = world.resource_mut::<Assets<CdrfMaterial>>().add(material);
                world.spawn((Mesh3d(mesh), CdrfMaterial3d(material), transform));
            }
            Shading::Standard => {
                let material = world
                    .resource_mut::<Assets<StandardMaterial>>()
                    .add(StandardMaterial::from_color(color));
                world.spawn((Mesh3d(mesh), MeshMaterial3d(material), transform));
            }
        }
    }
    let floor = world
        .resource_mut::<Assets<Mesh>>()
        .add(Plane3d::default().mesh().size(0.6, 0.4));
    let floor_material = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial {
            base_color: Color::srgb(0.35, 0.33, 0.3),
            perceptual_roughness: 0.8,
            ..default()
        });
    world.spawn((
        Mesh3d(floor),
        MeshMaterial3d(floor_material),
        Transform::from_xyz(0.0, -0.035, 0.0),
    ));
    // About 1500 lux 0.25 m away.
    world.spawn((
        PointLight {
            intensity: 1500.0 * 0.25 * 0.25 * 4.0 * std::f32::consts::PI,
            range: 5.0,
            ..default()
        },
        Transform::from_xyz(0.18, 0.1, 0.18),
        ShowcaseLight,
    ));
}

/// The sky: a uniform blue-white ambient light (cdrf lights with it as a uniform sky).
#[allow(dead_code)] // the benchmark leaves it out
pub fn sky() -> GlobalAmbientLight {
    GlobalAmbientLight {
        color: Color::srgb(0.6, 0.7, 1.0),
        brightness: 150.0,
        ..default()
    }
}

/// The camera's place.
pub fn camera_transform() -> Transform {
    Transform::from_xyz(0.0, 0.12, 0.45).looking_at(Vec3::new(0.0, 0.03, 0.0), Vec3::Y)
}
