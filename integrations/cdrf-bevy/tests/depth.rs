//! Depth: CDRF meshes and Bevy's meshes share the camera's (reversed-Z) depth buffer. A red
//! unlit cube in front of a CDRF sphere hides part of it; a blue one behind it is hidden.

mod common;

use bevy::asset::RenderAssetUsages;
use bevy::prelude::*;
use cdrf_bevy::{CdrfMaterial, CdrfMaterial3d, CdrfSettings};

const SIZE: u32 = 128;

/// A 30 mm wax sphere at the origin lit from the camera, and optionally the two cubes.
fn render(with_cubes: bool) -> Vec<[f32; 3]> {
    let mut app = common::headless_app(CdrfSettings::default());
    let target = common::float_target(&mut app, SIZE, SIZE);
    let world = app.world_mut();
    let sphere = cdrf_bevy::mesh_from_cdrf(
        &cdrf_core::Mesh::icosphere(0.03, 4),
        RenderAssetUsages::all(),
    );
    let sphere = world.resource_mut::<Assets<Mesh>>().add(sphere);
    let wax = world
        .resource_mut::<Assets<CdrfMaterial>>()
        .add(CdrfMaterial::preset("wax").expect("built in"));
    world.spawn((Mesh3d(sphere), CdrfMaterial3d(wax)));
    if with_cubes {
        let cube = world
            .resource_mut::<Assets<Mesh>>()
            .add(Cuboid::new(0.02, 0.02, 0.02));
        for (color, position) in [
            (
                Color::linear_rgb(1.0, 0.0, 0.0),
                Vec3::new(-0.015, 0.0, 0.04),
            ),
            (
                Color::linear_rgb(0.0, 0.0, 1.0),
                Vec3::new(0.015, 0.0, -0.03),
            ),
        ] {
            let material = world
                .resource_mut::<Assets<StandardMaterial>>()
                .add(StandardMaterial {
                    base_color: color,
                    unlit: true,
                    ..default()
                });
            world.spawn((
                Mesh3d(cube.clone()),
                MeshMaterial3d(material),
                Transform::from_translation(position),
            ));
        }
    }
    world.spawn((
        DirectionalLight {
            illuminance: 1.0,
            ..default()
        },
        Transform::default().looking_to(Vec3::NEG_Z, Vec3::Y),
    ));
    world.spawn((
        common::measuring_camera(target.clone()),
        Transform::from_xyz(0.0, 0.0, 0.2).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    let image = common::capture(app, target);
    (0..SIZE * SIZE)
        .map(|i| common::linear_rgb(&image, i % SIZE, i / SIZE))
        .collect()
}

#[test]
fn bevy_meshes_and_cdrf_meshes_hide_each_other() {
    let alone = render(false);
    let with_cubes = render(true);
    // For a look at 1:1.
    let mut png = cdrf_core::RgbaImage::new(SIZE, SIZE);
    for (out, p) in png.pixels.iter_mut().zip(&with_cubes) {
        *out = [p[0], p[1], p[2], 1.0];
    }
    png.write_png_srgb(std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("depth.png"))
        .expect("written");
    let sphere_pixels = alone.iter().filter(|p| p[1] > 0.01).count();
    assert!(sphere_pixels > 1000, "the sphere covers {sphere_pixels} px");
    let (mut red_in_front, mut changed_not_red, mut blue) = (0, 0, 0);
    for (a, b) in alone.iter().zip(&with_cubes) {
        let is_red = b[0] > 0.5 && b[1] < 1e-3 && b[2] < 1e-3;
        if b[2] > 1e-3 && b[0] < 1e-3 {
            blue += 1;
        }
        let changed = (0..3).any(|c| (a[c] - b[c]).abs() > 1e-3 * a[c].max(1e-3));
        if changed && is_red {
            if a[1] > 0.01 {
                red_in_front += 1;
            }
        } else if changed {
            changed_not_red += 1;
        }
    }
    println!(
        "depth: {red_in_front} sphere px hidden by the cube in front, {blue} px of the cube behind visible, {changed_not_red} other px changed"
    );
    assert!(
        red_in_front > 100,
        "the cube in front hides {red_in_front} px of the sphere"
    );
    assert_eq!(blue, 0, "the cube behind the sphere shows through");
    assert_eq!(changed_not_red, 0, "pixels changed that no cube covers");
}
