//! Several cameras: two 3D cameras with the same kind of target share one cdrf renderer (one
//! `prepare`, a view each) and must each give the pixels of an app with that camera alone.
//! A wax ellipsoid lit from the side and behind, every non-local term on; one camera in
//! front, one perspective camera to the side with another exposure.

mod common;

use bevy::asset::RenderAssetUsages;
use bevy::camera::{Exposure, ScalingMode};
use bevy::prelude::*;
use cdrf_bevy::{CdrfMaterial, CdrfMaterial3d, CdrfSettings};

const SIZE: u32 = 96;

/// The cameras: orthographic in front, perspective to the side with one stop more exposure.
fn camera(index: usize) -> (Projection, Transform, Exposure) {
    let exposure_1 = -(1.2f32).log2();
    match index {
        0 => (
            Projection::Orthographic(OrthographicProjection {
                scaling_mode: ScalingMode::Fixed {
                    width: 0.08,
                    height: 0.08,
                },
                ..OrthographicProjection::default_3d()
            }),
            Transform::from_xyz(0.0, 0.0, 0.3).looking_at(Vec3::ZERO, Vec3::Y),
            Exposure { ev100: exposure_1 },
        ),
        _ => (
            Projection::Perspective(PerspectiveProjection {
                fov: 0.5,
                ..default()
            }),
            Transform::from_xyz(0.25, 0.05, 0.0).looking_at(Vec3::ZERO, Vec3::Y),
            Exposure {
                ev100: exposure_1 - 1.0,
            },
        ),
    }
}

/// Renders the scene with the given cameras, each into its own float target.
fn render(cameras: &[usize]) -> Vec<Image> {
    let mut app = common::headless_app(CdrfSettings::default());
    let targets: Vec<_> = cameras
        .iter()
        .map(|_| common::float_target(&mut app, SIZE, SIZE))
        .collect();
    let world = app.world_mut();
    let mut body = cdrf_core::Mesh::icosphere(1.0, 4);
    for p in &mut body.positions {
        *p *= cdrf_core::glam::Vec3::new(0.03, 0.02, 0.018);
    }
    body.compute_normals();
    let body = world
        .resource_mut::<Assets<Mesh>>()
        .add(cdrf_bevy::mesh_from_cdrf(&body, RenderAssetUsages::all()));
    let wax = world
        .resource_mut::<Assets<CdrfMaterial>>()
        .add(CdrfMaterial::preset("wax").expect("built in"));
    world.spawn((Mesh3d(body), CdrfMaterial3d(wax)));
    world.spawn((
        DirectionalLight {
            illuminance: 1.0,
            ..default()
        },
        Transform::default().looking_to(Vec3::new(-0.7, -0.3, 0.6), Vec3::Y),
    ));
    for (order, (&index, target)) in cameras.iter().zip(&targets).enumerate() {
        let (projection, transform, exposure) = camera(index);
        world
            .spawn((
                common::measuring_camera(target.clone()),
                projection,
                transform,
            ))
            .insert((
                Camera {
                    order: order as isize,
                    clear_color: ClearColorConfig::Custom(Color::BLACK),
                    ..default()
                },
                exposure,
            ));
    }
    common::capture_all(app, &targets)
}

fn pixels(image: &Image) -> Vec<[f32; 3]> {
    (0..SIZE * SIZE)
        .map(|i| common::linear_rgb(image, i % SIZE, i / SIZE))
        .collect()
}

#[test]
fn two_cameras_share_a_renderer_and_each_sees_its_own_view() {
    let both = render(&[0, 1]);
    for (index, together) in both.iter().enumerate() {
        let alone = pixels(&render(&[index])[0]);
        let together = pixels(together);
        let lit = alone.iter().filter(|p| p[1] > 1e-4).count();
        let differing = alone
            .iter()
            .zip(&together)
            .filter(|(a, b)| a.iter().zip(b.iter()).any(|(a, b)| (a - b).abs() > 1e-6))
            .count();
        println!("camera {index}: {lit} px lit alone, {differing} px differ beside the other");
        assert!(lit > 500, "camera {index} sees the body ({lit} px)");
        assert_eq!(differing, 0, "camera {index}");
    }
}
