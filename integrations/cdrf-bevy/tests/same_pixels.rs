//! The same model gives the same pixels whatever the host: the wax knot of
//! `data/scenes/knot.toml` rendered through Bevy (its camera, its directional light, the
//! plugin) against cdrf-render's headless render of the scene file (what `cdrf-viewer render`
//! writes), on the software Vulkan device (lavapipe).

mod common;

use std::path::{Path, PathBuf};

use bevy::asset::RenderAssetUsages;
use bevy::camera::ScalingMode;
use bevy::prelude::*;
use cdrf_bevy::{CdrfMaterial, CdrfMaterial3d, CdrfSettings};
use cdrf_core::light::{Light, NonLocal};
use cdrf_core::scene::{Projection as SceneProjection, Scene};
use cdrf_render::headless::{AdapterPreference, RenderSettings, render_scene_file};

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data")
}

/// Renders the knot scene through Bevy: the scene's mesh as a Bevy mesh (in mm, so
/// `mm_per_unit` = 1), its orthographic camera, its light as a `DirectionalLight` of
/// `irradiance` lux, exposure 1, no tonemapping, a float target.
fn render_through_bevy(scene: &Scene) -> Image {
    let assets = scene.load_assets().expect("the knot's assets load");
    let camera = &scene.camera;
    let (width, height) = (camera.width, camera.height);
    let SceneProjection::Orthographic { half_height } = camera.projection else {
        panic!("the knot's camera is orthographic");
    };
    let Light::Directional(light) = scene.lights[0] else {
        panic!("the knot is lit by a directional light");
    };
    let lut = match &assets.material {
        cdrf_core::scene::Material::Measured(lut) => lut.clone(),
        other => panic!("the knot is shaded with a measured table, not {other:?}"),
    };

    let mut app = common::headless_app(CdrfSettings {
        mm_per_unit: 1.0,
        non_local: NonLocal::OFF,
        ..default()
    });
    let target = common::float_target(&mut app, width, height);
    let bevy_mesh = cdrf_bevy::mesh_from_cdrf(&assets.mesh, RenderAssetUsages::all());

    let world = app.world_mut();
    let mesh_handle = world.resource_mut::<Assets<Mesh>>().add(bevy_mesh);
    let material = world
        .resource_mut::<Assets<CdrfMaterial>>()
        .add(CdrfMaterial::from_table(lut));
    let transform = scene.mesh.transform.world_from_model();
    world.spawn((
        Mesh3d(mesh_handle),
        CdrfMaterial3d(material),
        Transform::from_matrix(Mat4::from_cols_array(&transform.to_cols_array())),
    ));
    let v = |v: cdrf_core::glam::Vec3| Vec3::from_array(v.to_array());
    world.spawn((
        DirectionalLight {
            illuminance: 1.0,
            color: Color::linear_rgb(
                light.irradiance[0],
                light.irradiance[1],
                light.irradiance[2],
            ),
            ..default()
        },
        Transform::default().looking_to(-v(light.to_light), Vec3::Y),
    ));
    world.spawn((
        common::measuring_camera(target.clone()),
        Projection::Orthographic(OrthographicProjection {
            scaling_mode: ScalingMode::FixedVertical {
                viewport_height: 2.0 * half_height,
            },
            near: 0.0,
            far: 1000.0,
            ..OrthographicProjection::default_3d()
        }),
        Transform::from_translation(v(camera.eye)).looking_at(v(camera.target), v(camera.up)),
    ));

    common::capture(app, target)
}

#[test]
fn the_knot_through_bevy_matches_cdrf_renders_pixels() {
    let scene_path = data().join("scenes/knot.toml");
    let scene = Scene::load(&scene_path).expect("the knot scene loads");
    let reference = render_scene_file(
        &scene_path,
        AdapterPreference::Software,
        &RenderSettings::default(),
    )
    .expect("cdrf-render renders the knot")
    .image;
    let bevy = render_through_bevy(&scene);
    let error = common::block_error_against("knot", &bevy, &reference);
    println!(
        "knot, Bevy vs cdrf-render: {} blocks, mean relative error {:.4} %, relative RMSE {:.4} %",
        error.blocks,
        100.0 * error.mean_relative_error,
        100.0 * error.relative_rmse
    );
    assert!(error.blocks > 500, "{} blocks compared", error.blocks);
    assert!(
        error.mean_relative_error <= 0.01,
        "Bevy's knot is {:.2} % off cdrf-render's",
        100.0 * error.mean_relative_error
    );
}
