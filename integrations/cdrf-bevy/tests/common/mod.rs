//! A headless Bevy app on the software Vulkan device (lavapipe), rendering into a float image
//! that a screenshot reads back.

use std::sync::{Arc, Mutex};

use bevy::app::PluginsState;
use bevy::light::GlobalAmbientLight;
use bevy::prelude::*;
use bevy::render::RenderPlugin;
use bevy::render::render_resource::TextureFormat;
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
use bevy::window::ExitCondition;
use bevy::winit::WinitPlugin;
use cdrf_bevy::{CdrfPlugin, CdrfSettings};

/// An app without a window or ambient light, with the plugin.
pub fn headless_app(settings: CdrfSettings) -> App {
    let mut app = App::new();
    app.add_plugins((
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
            .disable::<WinitPlugin>(),
        CdrfPlugin { settings },
    ))
    .insert_resource(GlobalAmbientLight::NONE);
    app
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
pub fn capture(mut app: App, target: Handle<Image>) -> Image {
    while app.plugins_state() == PluginsState::Adding {
        bevy::tasks::tick_global_task_pools_on_main_thread();
    }
    app.finish();
    app.cleanup();
    for _ in 0..3 {
        app.update();
    }
    let captured: Arc<Mutex<Option<Image>>> = Arc::default();
    let sink = captured.clone();
    app.world_mut().spawn(Screenshot::image(target)).observe(
        move |event: On<ScreenshotCaptured>| {
            *sink.lock().expect("not poisoned") = Some(event.image.clone());
        },
    );
    for _ in 0..20 {
        app.update();
        if let Some(image) = captured.lock().expect("not poisoned").take() {
            return image;
        }
    }
    panic!("no screenshot after 20 frames");
}

/// Linear RGB of a captured pixel.
pub fn linear_rgb(image: &Image, x: u32, y: u32) -> [f32; 3] {
    let c = image
        .get_color_at(x, y)
        .expect("a pixel of a float image")
        .to_linear();
    [c.red, c.green, c.blue]
}
