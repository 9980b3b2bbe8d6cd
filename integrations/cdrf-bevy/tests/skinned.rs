//! Skinned meshes from a glTF file: `tests/fixtures/skinned_tube.glb` (a tube 80 × 14 mm,
//! two joints `root` and `bend`) loaded by Bevy's glTF loader, `bend` turned 60° about the
//! first joint away from the camera, shaded by Bevy (its `StandardMaterial`: Bevy's GPU
//! skinning) and by the plugin (a `CdrfOverride` in Lambert: its CPU skinning into
//! cdrf-render's deforming mesh). The two must cover the same pixels and shade them alike; the
//! tube unbent covers others.
//!
//! The light comes from the camera, so Bevy's diffuse is Lambert's: Burley's retro-reflection
//! factor is 1 where L = V at perceptual roughness 0.5 (the file's), and the test sets the
//! `StandardMaterial`'s reflectance to 0, leaving no specular. The turn tilts the tube's right
//! half away from the light: normals skinned wrong would shade it as if it faced the camera.

mod common;

use bevy::camera::ScalingMode;
use bevy::gltf::GltfAssetLabel;
use bevy::prelude::*;
use bevy::world_serialization::WorldAssetRoot;
use cdrf_bevy::{CdrfMaterial, CdrfOverride, CdrfSettings};
use cdrf_core::light::NonLocal;

const SIZE: u32 = 128;
/// The second joint's turn, degrees.
const TURN_DEG: f32 = 60.0;

/// Renders the tube, `bend` turned by `turn_deg`, with Bevy's shading (`cdrf: false`) or the
/// plugin's; linear RGB per pixel.
fn render(cdrf: bool, turn_deg: f32) -> Vec<[f32; 3]> {
    let mut app = App::new();
    app.add_plugins((
        common::headless_plugins().set(AssetPlugin {
            file_path: concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/fixtures").into(),
            ..default()
        }),
        cdrf_bevy::CdrfPlugin {
            settings: CdrfSettings {
                non_local: NonLocal::OFF,
                ..default()
            },
        },
    ))
    .insert_resource(GlobalAmbientLight::NONE);
    let target = common::float_target(&mut app, SIZE, SIZE);
    let world = app.world_mut();
    let scene = world
        .resource::<AssetServer>()
        .load(GltfAssetLabel::Scene(0).from_asset("skinned_tube.glb"));
    let root = world.spawn(WorldAssetRoot(scene)).id();
    if cdrf {
        let white = world
            .resource_mut::<Assets<CdrfMaterial>>()
            .add(CdrfMaterial::lambert([1.0; 3]));
        world.entity_mut(root).insert(CdrfOverride(white));
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
    // The file loads and the scene spawns over some frames: then turn the joint.
    common::finish_plugins(&mut app);
    let mut frames = 0;
    let bend = loop {
        app.update();
        let world = app.world_mut();
        let bend = world
            .query::<(Entity, &Name)>()
            .iter(world)
            .find_map(|(entity, name)| (name.as_str() == "bend").then_some(entity));
        let handed_over = world
            .query::<&cdrf_bevy::CdrfMaterial3d>()
            .iter(world)
            .count();
        if let Some(bend) = bend
            && (handed_over == 1) == cdrf
        {
            break bend;
        }
        assert!(frames < 600, "the glTF scene did not spawn");
        std::thread::sleep(std::time::Duration::from_millis(10));
        frames += 1;
    };
    let world = app.world_mut();
    world.get_mut::<Transform>(bend).expect("a joint").rotation =
        Quat::from_rotation_y(turn_deg.to_radians());
    for (_, material) in world.resource_mut::<Assets<StandardMaterial>>().iter_mut() {
        material.reflectance = 0.0;
    }
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
