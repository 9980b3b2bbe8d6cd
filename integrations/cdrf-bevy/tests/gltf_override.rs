//! A glTF scene in a CDRF material: `tests/fixtures/textured.glb` (two spheres, a checker base
//! colour, a bump normal map, two roughnesses, MikkTSpace tangents) loaded by Bevy's glTF
//! loader as a `WorldAssetRoot` with a `CdrfOverride` of the bundled wax with its specular layer,
//! against cdrf-render's headless render of `tests/fixtures/textured.toml` (the same file,
//! camera, light, table and layer): the same pixels whatever the host, textures included.

mod common;

use std::path::{Path, PathBuf};

use bevy::gltf::GltfAssetLabel;
use bevy::prelude::*;
use bevy::world_serialization::WorldAssetRoot;

use cdrf_bevy::{CdrfMaterial, CdrfOverride, CdrfSettings, CdrfSurface};
use cdrf_core::light::{Light, NonLocal};
use cdrf_core::scene::{Projection as SceneProjection, Scene};
use cdrf_render::headless::{AdapterPreference, RenderSettings, render_scene_file};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/fixtures")
}

fn render_through_bevy(scene: &Scene) -> Image {
    let camera = &scene.camera;
    let SceneProjection::Perspective { vertical_fov_deg } = camera.projection else {
        panic!("the textured scene's camera is perspective");
    };
    let Light::Directional(light) = scene.lights[0] else {
        panic!("the textured scene is lit by a directional light");
    };
    let assets = scene.load_assets().expect("the scene's assets load");
    let cdrf_core::scene::Material::Measured(lut) = assets.material else {
        panic!("the textured scene is shaded with a measured table");
    };
    let layer = scene.specular.expect("the scene has a specular layer");

    let mut app = App::new();
    app.add_plugins((
        common::headless_plugins().set(AssetPlugin {
            file_path: fixtures().to_string_lossy().into_owned(),
            ..default()
        }),
        cdrf_bevy::CdrfPlugin {
            settings: CdrfSettings {
                mm_per_unit: 1.0,
                non_local: NonLocal::OFF,
                ..default()
            },
        },
    ))
    .insert_resource(GlobalAmbientLight::NONE);
    let target = common::float_target(&mut app, camera.width, camera.height);
    let world = app.world_mut();
    let wax = world
        .resource_mut::<Assets<CdrfMaterial>>()
        .add(CdrfMaterial::from_table(lut).with_specular(layer));
    let gltf = world
        .resource::<AssetServer>()
        .load(GltfAssetLabel::Scene(0).from_asset("textured.glb"));
    world.spawn((WorldAssetRoot(gltf), CdrfOverride(wax)));
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
        Projection::Perspective(PerspectiveProjection {
            fov: vertical_fov_deg.to_radians(),
            near: 1.0,
            ..default()
        }),
        Transform::from_translation(v(camera.eye)).looking_at(v(camera.target), v(camera.up)),
    ));
    // The file loads and the scene spawns over some frames: wait for both surfaces.
    common::finish_plugins(&mut app);
    let mut frames = 0;
    loop {
        app.update();
        let world = app.world_mut();
        let painted = world.query::<&CdrfSurface>().iter(world).count();
        if painted == 2 {
            break;
        }
        assert!(
            frames < 600,
            "the glTF scene did not spawn ({painted} surfaces)"
        );
        std::thread::sleep(std::time::Duration::from_millis(10));
        frames += 1;
    }
    common::capture(app, target)
}

#[test]
fn a_gltf_scene_in_a_cdrf_material_renders_as_cdrf_renders_it() {
    let scene_path = fixtures().join("textured.toml");
    let scene = Scene::load(&scene_path).expect("the textured scene loads");
    let reference = render_scene_file(
        &scene_path,
        AdapterPreference::Software,
        &RenderSettings::default(),
    )
    .expect("cdrf-render renders the scene")
    .image;
    let bevy = render_through_bevy(&scene);
    let error = common::block_error_against("textured", &bevy, &reference);
    println!(
        "textured glTF, Bevy vs cdrf-render: {} blocks, mean relative error {:.4} %, relative RMSE {:.4} %",
        error.blocks,
        100.0 * error.mean_relative_error,
        100.0 * error.relative_rmse
    );
    assert!(error.blocks > 300, "{} blocks compared", error.blocks);
    assert!(
        error.mean_relative_error <= 0.01,
        "Bevy's render is {:.2} % off cdrf-render's",
        100.0 * error.mean_relative_error
    );
}
