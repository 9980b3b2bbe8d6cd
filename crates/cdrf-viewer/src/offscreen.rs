//! The whole UI rendered without a window: the `screenshot` command, README images and the
//! UI frame benchmark.

use std::time::{Duration, Instant};

use cdrf_render::readback::TextureReadback;
use egui_wgpu::wgpu;
use thiserror::Error;

use crate::app::ViewerApp;

/// Why the offscreen UI could not be rendered.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum OffscreenError {
    /// No adapter or device (the message says which package gives a software one).
    #[error(
        "no GPU adapter for offscreen rendering ({0}). {hint}",
        hint = cdrf_render::headless::VULKAN_HINT
    )]
    NoDevice(String),
    /// A size of zero or beyond the device's limit.
    #[error("size {width} × {height} px: each side must be 1..={max} on this device")]
    BadSize {
        /// Requested width, pixels.
        width: u32,
        /// Requested height, pixels.
        height: u32,
        /// The device's largest texture side.
        max: u32,
    },
    /// The GPU failed while rendering or reading back.
    #[error("GPU: {0}")]
    Gpu(String),
}

/// An egui context and a wgpu device with no window.
pub struct OffscreenUi {
    render_state: egui_wgpu::RenderState,
    ctx: egui::Context,
    size_points: egui::Vec2,
    pixels_per_point: f32,
    start: Instant,
}

impl OffscreenUi {
    /// A UI of `size_points` at `pixels_per_point` on a new device (any adapter wgpu
    /// prefers; lavapipe where there is no GPU).
    ///
    /// # Errors
    /// [`OffscreenError::NoDevice`], [`OffscreenError::BadSize`].
    pub fn new(size_points: [u32; 2], pixels_per_point: f32) -> Result<Self, OffscreenError> {
        let setup = crate::gpu::wgpu_setup();
        let instance = pollster::block_on(setup.new_instance());
        let config = egui_wgpu::WgpuConfiguration {
            wgpu_setup: setup,
            ..Default::default()
        };
        let render_state = pollster::block_on(egui_wgpu::RenderState::create(
            &config,
            &instance,
            None,
            egui_wgpu::RendererOptions::PREDICTABLE,
        ))
        .map_err(|error| OffscreenError::NoDevice(error.to_string()))?;
        let [width, height] = size_points.map(|s| (s as f32 * pixels_per_point).round() as u32);
        let max = render_state.device.limits().max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max || height > max || pixels_per_point <= 0.0 {
            return Err(OffscreenError::BadSize { width, height, max });
        }
        Ok(Self {
            render_state,
            ctx: egui::Context::default(),
            size_points: egui::vec2(size_points[0] as f32, size_points[1] as f32),
            pixels_per_point,
            start: Instant::now(),
        })
    }

    /// The device and egui renderer (to create a [`ViewerApp`] on).
    pub fn render_state(&self) -> &egui_wgpu::RenderState {
        &self.render_state
    }

    /// Runs `frames` UI frames (at least one; later frames let the layout settle) and renders
    /// the last into an sRGB RGBA8 image of the size in pixels. `dt` is the simulated time
    /// per frame.
    ///
    /// # Errors
    /// [`OffscreenError::Gpu`].
    pub fn render(
        &mut self,
        app: &mut ViewerApp,
        frames: u32,
        dt: Duration,
    ) -> Result<image::RgbaImage, OffscreenError> {
        let mut output = None;
        for _ in 0..frames.max(1) {
            let input = egui::RawInput {
                screen_rect: Some(egui::Rect::from_min_size(
                    egui::Pos2::ZERO,
                    self.size_points,
                )),
                time: Some(self.start.elapsed().as_secs_f64()),
                predicted_dt: dt.as_secs_f32(),
                viewports: std::iter::once((
                    egui::ViewportId::ROOT,
                    egui::ViewportInfo {
                        native_pixels_per_point: Some(self.pixels_per_point),
                        ..Default::default()
                    },
                ))
                .collect(),
                ..Default::default()
            };
            let mut full = self.ctx.run_ui(input, |ui| app.show(ui));
            self.upload_textures(&mut full.textures_delta);
            // Textures freed by an earlier frame are no longer drawn: free them now.
            if let Some(mut earlier) = output.replace(full) {
                self.free_textures(&mut earlier.textures_delta);
            }
        }
        let mut output = output.expect("at least one frame ran");
        let image = self.draw(&output);
        self.free_textures(&mut output.textures_delta);
        image
    }

    fn upload_textures(&self, delta: &mut egui::TexturesDelta) {
        let mut renderer = self.render_state.renderer.write();
        for (id, images) in delta.set.drain() {
            for image in images {
                renderer.update_texture(
                    &self.render_state.device,
                    &self.render_state.queue,
                    id,
                    &image,
                );
            }
        }
    }

    fn free_textures(&self, delta: &mut egui::TexturesDelta) {
        let mut renderer = self.render_state.renderer.write();
        for id in delta.free.drain() {
            renderer.free_texture(&id);
        }
    }

    fn draw(&self, output: &egui::FullOutput) -> Result<image::RgbaImage, OffscreenError> {
        let (device, queue) = (&self.render_state.device, &self.render_state.queue);
        let pixels_per_point = self.ctx.pixels_per_point();
        let size = self.size_points * pixels_per_point;
        let (width, height) = (size.x.round() as u32, size.y.round() as u32);
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [width, height],
            pixels_per_point,
        };
        let primitives = self.ctx.tessellate(output.shapes.clone(), pixels_per_point);
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("cdrf-viewer offscreen UI"),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: self.render_state.target_format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = texture.create_view(&Default::default());
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut encoder = device.create_command_encoder(&Default::default());
        let mut renderer = self.render_state.renderer.write();
        let user_commands =
            renderer.update_buffers(device, queue, &mut encoder, &primitives, &screen);
        {
            let mut pass = encoder
                .begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("cdrf-viewer offscreen UI"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: &view,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                            store: wgpu::StoreOp::Store,
                        },
                    })],
                    ..Default::default()
                })
                .forget_lifetime();
            renderer.render(&mut pass, &primitives, &screen);
        }
        drop(renderer);

        let readback = TextureReadback::record(device, &mut encoder, &texture)
            .map_err(|error| OffscreenError::Gpu(error.to_string()))?;
        queue.submit(user_commands.into_iter().chain([encoder.finish()]));
        let data = readback
            .read(device)
            .map_err(|error| OffscreenError::Gpu(error.to_string()))?;
        if let Some(error) = pollster::block_on(scope.pop()) {
            return Err(OffscreenError::Gpu(error.to_string()));
        }
        let bgra = matches!(
            self.render_state.target_format,
            wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb
        );
        let mut pixels = Vec::with_capacity((width * height * 4) as usize);
        for texel in data.chunks_exact(4) {
            let [r, g, b, _] = [texel[0], texel[1], texel[2], texel[3]];
            let (r, b) = if bgra { (b, r) } else { (r, b) };
            // The UI is opaque; egui leaves alpha as its blending left it.
            pixels.extend_from_slice(&[r, g, b, 255]);
        }
        image::RgbaImage::from_raw(width, height, pixels)
            .ok_or_else(|| OffscreenError::Gpu("readback size mismatch".into()))
    }
}
