//! A golden image of the `glow` example: its scene (the wax knot in the fitted table, a skin
//! and a marble bunny, a `StandardMaterial` floor, the point light where `--screenshot` leaves
//! it, the sky) through a camera like the example's (Bevy's default tonemapping and dithering,
//! an sRGB target) at 640 × 360, every non-local term on, compared with
//! `tests/golden/glow.png` by FLIP as the root workspace's goldens are. A missing reference
//! fails; `UPDATE_SNAPSHOTS=1` writes it.

#[path = "../examples/common/mod.rs"]
mod showcase;

mod common;

use bevy::camera::RenderTarget;
use bevy::prelude::*;
use bevy::render::render_resource::TextureFormat;
use cdrf_bevy::{CdrfPlugin, CdrfTable};
use cdrf_tests::golden::{Srgb8Image, Tolerance, assert_golden_in, update_requested};

const WIDTH: u32 = 640;
const HEIGHT: u32 = 360;

/// As the root workspace's goldens: lavapipe renders are deterministic; a real change of the
/// shading or the scene moves the mean FLIP above this.
const TOLERANCE: Tolerance = Tolerance {
    mean_flip: 0.005,
    max_flip_fraction_above_0_1: 0.002,
};

#[test]
fn the_glow_example_matches_its_golden_image() {
    let mut app = App::new();
    app.add_plugins((
        common::headless_plugins().set(showcase::asset_plugin()),
        CdrfPlugin::default(),
    ))
    .insert_resource(showcase::sky());
    let target = app
        .world_mut()
        .resource_mut::<Assets<Image>>()
        .add(Image::new_target_texture(
            WIDTH,
            HEIGHT,
            TextureFormat::Rgba8UnormSrgb,
            None,
        ));
    showcase::spawn_showcase(app.world_mut(), showcase::Shading::Cdrf);
    app.world_mut().spawn((
        Camera3d::default(),
        RenderTarget::Image(target.clone().into()),
        showcase::camera_transform(),
    ));
    // The knot's table is a file the asset server loads: wait for it.
    common::finish_plugins(&mut app);
    let mut frames = 0;
    while app.world().resource::<Assets<CdrfTable>>().is_empty() {
        assert!(frames < 600, "data/wax-fit/measured.exr did not load");
        app.update();
        std::thread::sleep(std::time::Duration::from_millis(10));
        frames += 1;
    }
    let image = common::capture(app, target)
        .try_into_dynamic()
        .expect("an 8-bit image")
        .to_rgba8();
    let pixels = image.pixels().map(|p| p.0).collect();
    let frame = Srgb8Image::new(WIDTH, HEIGHT, pixels);
    let golden = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/golden");
    assert_golden_in(
        std::path::Path::new(golden),
        "glow",
        &frame,
        TOLERANCE,
        update_requested(),
    );
}
