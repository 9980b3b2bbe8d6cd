//! A headless Bevy app on the software Vulkan device (lavapipe), rendering into a float image
//! that a screenshot reads back. The frame benchmark shares the plugins and the start-up.
#![allow(dead_code)] // each user takes what it needs

use std::sync::{Arc, Mutex};

use bevy::app::{PluginGroupBuilder, PluginsState};
use bevy::camera::{Exposure, Hdr, RenderTarget};
use bevy::core_pipeline::tonemapping::{DebandDither, Tonemapping};
use bevy::light::GlobalAmbientLight;
use bevy::prelude::*;
use bevy::render::RenderPlugin;
use bevy::render::render_resource::TextureFormat;
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
use bevy::window::ExitCondition;
use bevy::winit::WinitPlugin;
use cdrf_bevy::{CdrfMaterial, CdrfMaterial3d, CdrfPlugin, CdrfSettings};
use cdrf_core::RgbaImage;
use cdrf_core::block_error::{BlockPixel, Region, RegionError, blocks, covered_mask, region_error};

/// Bevy's default plugins without a window, compiling pipelines as they are asked for.
pub fn headless_plugins() -> PluginGroupBuilder {
    DefaultPlugins
        .set(WindowPlugin {
            primary_window: None,
            exit_condition: ExitCondition::DontExit,
            ..default()
        })
        .set(RenderPlugin {
            synchronous_pipeline_compilation: true,
            ..default()
        })
        .disable::<WinitPlugin>()
}

/// An app without a window or ambient light, with the plugin.
pub fn headless_app(settings: CdrfSettings) -> App {
    let mut app = App::new();
    app.add_plugins((headless_plugins(), CdrfPlugin { settings }))
        .insert_resource(GlobalAmbientLight::NONE);
    app
}

/// Finishes the plugins' set-up (what `App::run` does before its first update), once.
pub fn finish_plugins(app: &mut App) {
    if app.plugins_state() == PluginsState::Cleaned {
        return;
    }
    while app.plugins_state() == PluginsState::Adding {
        bevy::tasks::tick_global_task_pools_on_main_thread();
    }
    app.finish();
    app.cleanup();
}

/// A camera that measures: into `target`, black background, Bevy's HDR main texture
/// (`Rgba16Float`; without it the pass writes 8-bit sRGB), no tonemapping or dithering, no
/// MSAA, exposure 1 (= 1 / (1.2 · 2^ev100)). Add its projection and place.
pub fn measuring_camera(target: Handle<Image>) -> impl Bundle {
    (
        Camera3d::default(),
        Camera {
            clear_color: ClearColorConfig::Custom(Color::BLACK),
            ..default()
        },
        RenderTarget::Image(target.into()),
        Hdr,
        Tonemapping::None,
        DebandDither::Disabled,
        Msaa::Off,
        Exposure {
            ev100: -(1.2f32).log2(),
        },
    )
}

/// A float render target (`Rgba32Float`) of the given size.
pub fn float_target(app: &mut App, width: u32, height: u32) -> Handle<Image> {
    app.world_mut()
        .resource_mut::<Assets<Image>>()
        .add(Image::new_target_texture(
            width,
            height,
            TextureFormat::Rgba32Float,
            None,
        ))
}

/// Runs the app a few frames, then captures `target`.
pub fn capture(app: App, target: Handle<Image>) -> Image {
    capture_all(app, &[target]).remove(0)
}

/// Runs the app a few frames, then captures each of `targets` (of one frame).
pub fn capture_all(mut app: App, targets: &[Handle<Image>]) -> Vec<Image> {
    finish_plugins(&mut app);
    for _ in 0..3 {
        app.update();
    }
    let captured: Arc<Mutex<Vec<Option<Image>>>> = Arc::new(Mutex::new(vec![None; targets.len()]));
    for (index, target) in targets.iter().enumerate() {
        let sink = captured.clone();
        app.world_mut()
            .spawn(Screenshot::image(target.clone()))
            .observe(move |event: On<ScreenshotCaptured>| {
                sink.lock().expect("not poisoned")[index] = Some(event.image.clone());
            });
    }
    for _ in 0..20 {
        app.update();
        let mut captured = captured.lock().expect("not poisoned");
        if captured.iter().all(Option::is_some) {
            return captured.drain(..).flatten().collect();
        }
    }
    panic!("no screenshot of every target after 20 frames");
}

/// Linear RGB of a captured pixel.
pub fn linear_rgb(image: &Image, x: u32, y: u32) -> [f32; 3] {
    let c = image
        .get_color_at(x, y)
        .expect("a pixel of a float image")
        .to_linear();
    [c.red, c.green, c.blue]
}

/// The block error (8 × 8 blocks of the reference's silhouette, mean relative error) of a
/// Bevy capture against cdrf-render's image of the same scene; both are written as sRGB PNGs
/// (`NAME-bevy.png`, `NAME-cdrf-render.png`) to the tests' temporary folder for a look at 1:1.
pub fn block_error_against(name: &str, bevy: &Image, reference: &RgbaImage) -> RegionError {
    assert_eq!(
        (bevy.width(), bevy.height()),
        (reference.width, reference.height)
    );
    let width = reference.width;
    let mut through_bevy = RgbaImage::new(width, reference.height);
    for y in 0..reference.height {
        for x in 0..width {
            let [r, g, b] = linear_rgb(bevy, x, y);
            through_bevy.pixels[(y * width + x) as usize] = [r, g, b, 1.0];
        }
    }
    let out = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
    through_bevy
        .write_png_srgb(out.join(format!("{name}-bevy.png")))
        .expect("written");
    reference
        .write_png_srgb(out.join(format!("{name}-cdrf-render.png")))
        .expect("written");
    let mask = covered_mask(reference, 1);
    let pixels = blocks(width, reference.height, |x, y| {
        let i = (y * width + x) as usize;
        mask[i].then(|| {
            let (r, b) = (reference.pixels[i], through_bevy.pixels[i]);
            BlockPixel {
                model: cdrf_core::glam::Vec3::new(b[0], b[1], b[2]),
                reference: cdrf_core::glam::Vec3::new(r[0], r[1], r[2]),
                // The whole silhouette is one region here.
                cos_theta: 1.0,
                occluded: 0.0,
            }
        })
    });
    region_error(&pixels, Region::Lit)
}

/// Spawns `mesh` in white: the plugin's Lambert (`cdrf`) or Bevy's own diffuse
/// `StandardMaterial` (white, roughness 1, reflectance 0: no specular), for comparing the two.
pub fn spawn_white(world: &mut World, mesh: Handle<Mesh>, cdrf: bool, transform: Transform) {
    if cdrf {
        let white = world
            .resource_mut::<Assets<CdrfMaterial>>()
            .add(CdrfMaterial::lambert([1.0; 3]));
        world.spawn((Mesh3d(mesh), CdrfMaterial3d(white), transform));
    } else {
        let white = world
            .resource_mut::<Assets<StandardMaterial>>()
            .add(StandardMaterial {
                base_color: Color::WHITE,
                perceptual_roughness: 1.0,
                reflectance: 0.0,
                ..default()
            });
        world.spawn((Mesh3d(mesh), MeshMaterial3d(white), transform));
    }
}
