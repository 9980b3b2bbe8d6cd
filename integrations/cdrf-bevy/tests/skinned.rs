//! Skinned meshes: a tube (80 × 14 mm) with two joints, the second turned 60° about the first
//! away from the camera, shaded by Bevy (`StandardMaterial`: its own GPU skinning) and by the
//! plugin (a CDRF Lambert material: its CPU skinning into cdrf-render's deforming mesh). The two
//! must cover the same pixels and shade them alike; the tube unbent covers others.
//!
//! The light comes from the camera, so Bevy's diffuse is Lambert's: Burley's retro-reflection
//! factor is 1 where L = V at perceptual roughness 0.5, and reflectance 0 leaves no specular.
//! The turn tilts the tube's right half away from the light: normals skinned wrong would shade
//! it as if it faced the camera.

mod common;

use bevy::camera::ScalingMode;
use bevy::camera::visibility::NoFrustumCulling;
use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
use bevy::prelude::*;
use cdrf_bevy::{CdrfMaterial, CdrfMaterial3d, CdrfSettings, mesh_from_cdrf};
use cdrf_core::light::NonLocal;

const SIZE: u32 = 128;
/// The tube's semi-axes, m.
const SEMI_M: [f32; 3] = [0.04, 0.007, 0.007];
/// The second joint's turn, degrees.
const TURN_DEG: f32 = 60.0;

/// The tube along x with joint 0 on its left half and joint 1 on its right, blended over the
/// middle 20 mm.
fn skinned_tube() -> Mesh {
    let mut tube = cdrf_core::Mesh::icosphere(1.0, 4);
    let semi = cdrf_core::glam::Vec3::from_array(SEMI_M);
    for (p, n) in tube.positions.iter_mut().zip(&mut tube.normals) {
        let u = *p;
        *p = u * semi;
        *n = (u / semi).normalize();
    }
    let weights: Vec<[f32; 4]> = tube
        .positions
        .iter()
        .map(|p| {
            let t = ((p.x + 0.01) / 0.02).clamp(0.0, 1.0);
            let right = t * t * (3.0 - 2.0 * t);
            [1.0 - right, right, 0.0, 0.0]
        })
        .collect();
    let joints = vec![[0u16, 1, 0, 0]; weights.len()];
    mesh_from_cdrf(&tube, bevy::asset::RenderAssetUsages::default())
        .with_inserted_attribute(
            Mesh::ATTRIBUTE_JOINT_INDEX,
            bevy::mesh::VertexAttributeValues::Uint16x4(joints),
        )
        .with_inserted_attribute(Mesh::ATTRIBUTE_JOINT_WEIGHT, weights)
}

/// Renders the tube, bent by `turn_deg`, with Bevy's shading (`cdrf: false`) or the
/// plugin's; linear RGB per pixel.
fn render(cdrf: bool, turn_deg: f32) -> Vec<[f32; 3]> {
    let mut app = common::headless_app(CdrfSettings {
        non_local: NonLocal::OFF,
        ..default()
    });
    let target = common::float_target(&mut app, SIZE, SIZE);
    let world = app.world_mut();
    let mesh = world.resource_mut::<Assets<Mesh>>().add(skinned_tube());
    let inverse_bindposes = world
        .resource_mut::<Assets<SkinnedMeshInverseBindposes>>()
        .add(SkinnedMeshInverseBindposes::from(vec![Mat4::IDENTITY; 2]));
    let root = world.spawn(Transform::IDENTITY).id();
    let bend = world
        .spawn((
            Transform::from_rotation(Quat::from_rotation_y(turn_deg.to_radians())),
            ChildOf(root),
        ))
        .id();
    let skin = SkinnedMesh {
        inverse_bindposes,
        joints: vec![root, bend],
    };
    let tube = world.spawn((Mesh3d(mesh), skin, NoFrustumCulling)).id();
    if cdrf {
        let white = world
            .resource_mut::<Assets<CdrfMaterial>>()
            .add(CdrfMaterial::lambert([1.0; 3]));
        world.entity_mut(tube).insert(CdrfMaterial3d(white));
    } else {
        let white = world
            .resource_mut::<Assets<StandardMaterial>>()
            .add(StandardMaterial {
                base_color: Color::WHITE,
                perceptual_roughness: 0.5,
                reflectance: 0.0,
                ..default()
            });
        world.entity_mut(tube).insert(MeshMaterial3d(white));
    }
    world.spawn((
        DirectionalLight {
            illuminance: 1.0,
            shadow_maps_enabled: false,
            ..default()
        },
        Transform::from_xyz(0.0, 0.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    world.spawn((
        common::measuring_camera(target.clone()),
        Projection::Orthographic(OrthographicProjection {
            scaling_mode: ScalingMode::Fixed {
                width: 0.1,
                height: 0.1,
            },
            ..OrthographicProjection::default_3d()
        }),
        Transform::from_xyz(0.0, 0.0, 0.5).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    let image = common::capture(app, target);
    (0..SIZE * SIZE)
        .map(|i| common::linear_rgb(&image, i % SIZE, i / SIZE))
        .collect()
}

fn lit(pixel: &[f32; 3]) -> bool {
    pixel[1] > 1e-4
}

/// Pixels lit in one image only.
fn mismatched(a: &[[f32; 3]], b: &[[f32; 3]]) -> usize {
    a.iter().zip(b).filter(|(a, b)| lit(a) != lit(b)).count()
}

/// Mean |a − b| / mean a over the pixels lit in both (green).
fn relative_difference(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let (mut difference, mut total) = (0.0f64, 0.0f64);
    for (a, b) in a.iter().zip(b) {
        if lit(a) && lit(b) {
            difference += f64::from((a[1] - b[1]).abs());
            total += f64::from(a[1]);
        }
    }
    difference / total
}

#[test]
fn a_skinned_mesh_bends_in_the_plugin_as_in_bevy() {
    let bevy = render(false, TURN_DEG);
    let cdrf = render(true, TURN_DEG);
    let bevy_unbent = render(false, 0.0);
    let cdrf_unbent = render(true, 0.0);
    let covered = bevy.iter().filter(|p| lit(p)).count();
    let mismatched_bent = mismatched(&bevy, &cdrf);
    let moved = mismatched(&cdrf, &cdrf_unbent);
    let bent = relative_difference(&bevy, &cdrf);
    let turned = relative_difference(&cdrf_unbent, &cdrf);
    let unbent = relative_difference(&bevy_unbent, &cdrf_unbent);
    println!(
        "skinned tube: {covered} px lit in Bevy, {mismatched_bent} px lit in one only, {moved} px \
         moved by the bend, shading {:.1} % changed by it; Bevy vs the plugin: {:.3} % bent, \
         {:.3} % unbent",
        100.0 * turned,
        100.0 * bent,
        100.0 * unbent
    );
    assert!(moved > 200, "the bend must move the tube ({moved} px)");
    assert!(turned > 0.1, "the bend must turn the normals ({turned})");
    assert!(
        mismatched_bent * 100 <= covered,
        "coverage: {mismatched_bent} of {covered} px differ"
    );
    for (name, difference) in [("bent", bent), ("unbent", unbent)] {
        assert!(
            difference < 0.005,
            "{name}: shading differs by {:.3} %",
            100.0 * difference
        );
    }
}
