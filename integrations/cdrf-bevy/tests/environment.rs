//! Bevy's `EnvironmentMapLight` lights CDRF meshes: a camera's diffuse cubemap holding a
//! smooth sky W(N) (brighter above, toward +x and toward +z), no other light. A white sphere
//! shaded by the plugin's Lambert must return W at each normal (a diffuse map holds E/π), and
//! Bevy's own `StandardMaterial` sphere under the same map must give the same values within
//! 1 % at each: the map is read in Bevy's orientation and scale. (The test writes the cubemap
//! in wgpu's face convention, as the plugin reads it; Bevy's render is what checks both.)

mod common;

use bevy::asset::RenderAssetUsages;
use bevy::light::EnvironmentMapLight;
use bevy::prelude::*;
use bevy::render::render_resource::{
    Extent3d, TextureDimension, TextureFormat, TextureViewDescriptor, TextureViewDimension,
};
use cdrf_bevy::CdrfSettings;

const SIZE: u32 = 64;
const RADIUS_M: f32 = 0.03;

/// The sky as Bevy's diffuse map holds it (E/π for a white surface facing N). Its gradients
/// are steep enough that a flipped axis fails the 0.5 % bound: 0.38 facing +z, 0.22 facing −z.
fn sky(n: Vec3) -> f32 {
    0.3 + 0.1 * n.y + 0.05 * n.x + 0.08 * n.z
}

/// A cubemap of `sky` in wgpu's face order and orientation; Bevy reads it at N with z
/// negated (its cubemaps are left-handed).
fn sky_cubemap(side: u32) -> Image {
    let mut data = Vec::new();
    for face in 0..6 {
        for y in 0..side {
            for x in 0..side {
                let u = (x as f32 + 0.5) / side as f32 * 2.0 - 1.0;
                let v = (y as f32 + 0.5) / side as f32 * 2.0 - 1.0;
                let c = match face {
                    0 => Vec3::new(1.0, -v, -u),
                    1 => Vec3::new(-1.0, -v, u),
                    2 => Vec3::new(u, 1.0, v),
                    3 => Vec3::new(u, -1.0, -v),
                    4 => Vec3::new(u, -v, 1.0),
                    _ => Vec3::new(-u, -v, -1.0),
                };
                let value = sky(Vec3::new(c.x, c.y, -c.z).normalize());
                for channel in [value, value, value, 1.0] {
                    data.extend_from_slice(&channel.to_le_bytes());
                }
            }
        }
    }
    let mut image = Image::new(
        Extent3d {
            width: side,
            height: side,
            depth_or_array_layers: 6,
        },
        TextureDimension::D2,
        data,
        TextureFormat::Rgba32Float,
        RenderAssetUsages::all(),
    );
    image.texture_view_descriptor = Some(TextureViewDescriptor {
        dimension: Some(TextureViewDimension::Cube),
        ..default()
    });
    image
}

/// Pixels of the sphere (column, row) and their normals.
fn samples() -> Vec<((u32, u32), Vec3)> {
    let centre = SIZE as f32 / 2.0;
    [(0.0, 0.0), (0.6, 0.0), (-0.6, 0.0), (0.0, 0.6), (0.0, -0.6)]
        .into_iter()
        .map(|(x, y): (f32, f32)| {
            // An orthographic view along −z of a frame 2.5 radii high.
            let column = (centre + x * SIZE as f32 / 2.5 - 0.5).round() as u32;
            let row = (centre - y * SIZE as f32 / 2.5 - 0.5).round() as u32;
            let px = |c: u32| (c as f32 + 0.5 - centre) / (SIZE as f32 / 2.5);
            let (nx, ny) = (px(column), -px(row));
            (
                (column, row),
                Vec3::new(nx, ny, (1.0 - nx * nx - ny * ny).sqrt()),
            )
        })
        .collect()
}

fn render(cdrf: bool) -> Vec<f32> {
    let mut app = common::headless_app(CdrfSettings::default());
    let target = common::float_target(&mut app, SIZE, SIZE);
    let world = app.world_mut();
    let map = world.resource_mut::<Assets<Image>>().add(sky_cubemap(16));
    let sphere = world
        .resource_mut::<Assets<Mesh>>()
        .add(Sphere::new(RADIUS_M).mesh().ico(5).expect("an icosphere"));
    common::spawn_white(world, sphere, cdrf, Transform::IDENTITY);
    world.spawn((
        common::measuring_camera(target.clone()),
        Projection::Orthographic(OrthographicProjection {
            scaling_mode: bevy::camera::ScalingMode::Fixed {
                width: 2.5 * RADIUS_M,
                height: 2.5 * RADIUS_M,
            },
            ..OrthographicProjection::default_3d()
        }),
        Transform::from_xyz(0.0, 0.0, 0.5).looking_at(Vec3::ZERO, Vec3::Y),
        EnvironmentMapLight {
            diffuse_map: map.clone(),
            specular_map: map,
            intensity: 1.0,
            ..default()
        },
    ));
    let image = common::capture(app, target);
    samples()
        .iter()
        .map(|((x, y), _)| common::linear_rgb(&image, *x, *y)[1])
        .collect()
}

#[test]
fn an_environment_map_lights_cdrf_meshes_as_it_lights_bevys() {
    let cdrf = render(true);
    let bevy = render(false);
    let mut ratios = Vec::new();
    for ((((column, row), normal), cdrf), bevy) in samples().iter().zip(&cdrf).zip(&bevy) {
        let expected = sky(*normal);
        println!(
            "px ({column}, {row}), normal {normal:.2}: sky {expected:.4}, plugin {cdrf:.4}, Bevy {bevy:.4}"
        );
        assert!(
            (cdrf - expected).abs() <= 0.005 * expected,
            "the plugin's Lambert {cdrf} vs the map's {expected} at {normal}"
        );
        ratios.push(bevy / cdrf);
    }
    let mean = ratios.iter().sum::<f32>() / ratios.len() as f32;
    println!("Bevy / plugin: {ratios:.4?} (mean {mean:.4})");
    for ratio in &ratios {
        assert!((ratio - 1.0).abs() < 0.01, "Bevy / plugin: {ratios:?}");
    }
}
