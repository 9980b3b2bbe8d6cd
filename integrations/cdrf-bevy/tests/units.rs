//! Units in the engine: a Bevy `PointLight` of P lumens at distance d lights the facing point
//! of a white diffuse sphere with E = P/(4π)/d² (Bevy's own shading of a `StandardMaterial`
//! gives E/π there), and a CDRF Lambert sphere under the same light, through the plugin's
//! conversion, gives that radiance too. (The four centre pixels look 0.2–0.3° off the axis:
//! both renders come out 0.5 % under E/π there.)

mod common;

use bevy::prelude::*;
use cdrf_bevy::CdrfSettings;
use std::f32::consts::PI;

const SIZE: u32 = 64;
const RADIUS_M: f32 = 0.03;
const LIGHT_M: f32 = 0.5;
const POWER_LM: f32 = 3.0;

/// The radiance at the image centre (the sphere's point facing camera and light), mean of
/// the four centre pixels, of a sphere shaded by Bevy (`cdrf: false`) or by the plugin.
fn centre_radiance(cdrf: bool) -> [f32; 3] {
    let mut app = common::headless_app(CdrfSettings::default());
    let target = common::float_target(&mut app, SIZE, SIZE);
    let world = app.world_mut();
    // A UV sphere turned so that its pole (one vertex, normal exactly +z) faces the camera.
    let sphere = world
        .resource_mut::<Assets<Mesh>>()
        .add(Sphere::new(RADIUS_M).mesh().uv(64, 32));
    let transform = Transform::from_rotation(Quat::from_rotation_x(PI / 2.0));
    common::spawn_white(world, sphere, cdrf, transform);
    world.spawn((
        PointLight {
            intensity: POWER_LM,
            range: 100.0,
            radius: 0.0,
            shadow_maps_enabled: false,
            ..default()
        },
        Transform::from_xyz(0.0, 0.0, LIGHT_M),
    ));
    world.spawn((
        common::measuring_camera(target.clone()),
        Transform::from_xyz(0.0, 0.0, 0.3).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    let image = common::capture(app, target);
    let mut sum = [0.0; 3];
    for (x, y) in [(31, 31), (32, 31), (31, 32), (32, 32)] {
        let p = common::linear_rgb(&image, x, y);
        for c in 0..3 {
            sum[c] += p[c] / 4.0;
        }
    }
    sum
}

#[test]
fn a_point_light_gives_the_same_irradiance_in_bevy_and_in_cdrf() {
    let distance_m = LIGHT_M - RADIUS_M;
    let irradiance = POWER_LM / (4.0 * PI) / (distance_m * distance_m);
    let expected = irradiance / PI;
    let bevy = centre_radiance(false);
    let cdrf = centre_radiance(true);
    println!(
        "E/π = {expected:.5}: Bevy's StandardMaterial {:.5}, the plugin's Lambert {:.5}",
        bevy[1], cdrf[1]
    );
    for c in 0..3 {
        assert!(
            (bevy[c] - cdrf[c]).abs() <= 0.002 * expected,
            "Bevy {} vs the plugin {}",
            bevy[c],
            cdrf[c]
        );
        assert!(
            (bevy[c] - expected).abs() <= 0.01 * expected,
            "Bevy's own shading: {} vs E/π = {expected}",
            bevy[c]
        );
        assert!(
            (cdrf[c] - expected).abs() <= 0.01 * expected,
            "the plugin's Lambert: {} vs E/π = {expected}",
            cdrf[c]
        );
    }
}
