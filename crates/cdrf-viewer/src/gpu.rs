//! The 3D view inside egui: a paint callback that drives [`cdrf_render::Renderer`].
//!
//! The renderer and everything it uploaded live in egui-wgpu's `CallbackResources` as one
//! [`ViewerGpu`]. Each frame the app adds one [`ViewCallback`] for the 3D area. Its `prepare`
//! renders the mesh twice — slot A and slot B, the two models being compared, same camera and
//! lights — into offscreen targets (Rgba16Float, 4× MSAA, depth) with egui's encoder; its
//! `paint` draws one triangle in egui's pass that lays the slots out (alone, side by side,
//! split, or their difference: `shaders/viewer_composite.wgsl`). Rendering offscreen keeps the
//! depth buffer and MSAA independent of the host's pass, and makes the difference view a
//! texture lookup.

use std::ops::Range;

use cdrf_core::environment::ShCoefficients;
use cdrf_core::glam::{Mat4, Vec2};
use cdrf_core::light::{Light, NonLocal};
use cdrf_render::{
    Draw, FrameDesc, MaterialId, MeshId, OffscreenTarget, Options, Renderer, SurfaceId, TargetDesc,
    View,
};
use egui_wgpu::{CallbackResources, CallbackTrait, ScreenDescriptor, wgpu};

/// The composite shader.
pub const COMPOSITE_SHADER: &str = include_str!("../shaders/viewer_composite.wgsl");

/// Colour format of the offscreen slots: linear radiance in half floats.
pub const SLOT_COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// MSAA samples of the offscreen slots.
pub const SLOT_SAMPLES: u32 = 4;
/// Depth format of the offscreen slots.
pub const SLOT_DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// How the two slots fill the 3D view.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// Slot A alone (the curvature view).
    Single,
    /// A on the left half, B on the right half, each with the half's aspect.
    SideBySide,
    /// A left of a vertical line, B right of it, over one view.
    Split,
    /// The signed luminance difference A − B.
    Difference,
}

impl Layout {
    /// Which slots the layout shows.
    pub fn slot_count(self) -> usize {
        match self {
            Layout::Single => 1,
            _ => 2,
        }
    }

    /// The size of one slot for a view of `view` (points or pixels): half the width side by
    /// side, the whole view otherwise.
    pub fn slot_size(self, view: Vec2) -> Vec2 {
        match self {
            Layout::SideBySide => Vec2::new((view.x / 2.0).floor(), view.y),
            _ => view,
        }
    }

    fn shader_index(self) -> f32 {
        match self {
            Layout::Single => 0.0,
            Layout::SideBySide => 1.0,
            Layout::Split => 2.0,
            Layout::Difference => 3.0,
        }
    }
}

/// Slot size in pixels for a view of `size_points` at `pixels_per_point` (each side ≥ 1).
pub fn slot_size_pixels(layout: Layout, size_points: Vec2, pixels_per_point: f32) -> [u32; 2] {
    let view = (size_points * pixels_per_point).round().max(Vec2::ONE);
    let slot = layout.slot_size(view).max(Vec2::ONE);
    [slot.x as u32, slot.y as u32]
}

/// The viewer's GPU state, kept in egui-wgpu's `CallbackResources`.
pub struct ViewerGpu {
    /// The CDRF renderer (offscreen target: [`SLOT_COLOR_FORMAT`], [`SLOT_SAMPLES`],
    /// [`SLOT_DEPTH_FORMAT`]). The app uploads meshes and materials to it directly.
    pub renderer: Renderer,
    pipeline: wgpu::RenderPipeline,
    bind_group_layout: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    slots: Option<Slots>,
    /// The last error of a frame's `prepare` (shown by the app), `None` after a good frame.
    pub last_error: Option<String>,
}

struct Slots {
    size: [u32; 2],
    targets: [OffscreenTarget; 2],
    bind_group: wgpu::BindGroup,
}

const PARAMS_SIZE: u64 = 48;

impl ViewerGpu {
    /// Builds the renderer and the composite pipeline for egui's pass (`target_format`, one
    /// sample, no depth: eframe's and egui_kittest's defaults).
    pub fn new(device: &wgpu::Device, target_format: wgpu::TextureFormat) -> Self {
        let slot_target = TargetDesc::new(SLOT_COLOR_FORMAT)
            .with_sample_count(SLOT_SAMPLES)
            .with_depth(SLOT_DEPTH_FORMAT);
        // The view's projection maps near to 0 and far to 1.
        let options = Options {
            depth_compare: wgpu::CompareFunction::Less,
            ..Options::default()
        };
        let renderer = Renderer::new(device, &slot_target, options);

        let texture_entry = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: false },
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            },
            count: None,
        };
        let bind_group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cdrf-viewer composite"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: wgpu::BufferSize::new(PARAMS_SIZE),
                    },
                    count: None,
                },
                texture_entry(1),
                texture_entry(2),
            ],
        });
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("cdrf-viewer composite"),
            source: wgpu::ShaderSource::Wgsl(COMPOSITE_SHADER.into()),
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("cdrf-viewer composite"),
            bind_group_layouts: &[Some(&bind_group_layout)],
            immediate_size: 0,
        });
        let encode_srgb = TargetDesc::new(target_format).encodes_srgb_in_shader();
        let constants = [("ENCODE_SRGB", if encode_srgb { 1.0 } else { 0.0 })];
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("cdrf-viewer composite"),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fs_main"),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: &constants,
                    ..Default::default()
                },
                targets: &[Some(wgpu::ColorTargetState {
                    format: target_format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            multiview_mask: None,
            cache: None,
        });
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cdrf-viewer composite parameters"),
            size: PARAMS_SIZE,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            renderer,
            pipeline,
            bind_group_layout,
            params,
            slots: None,
            last_error: None,
        }
    }

    /// Creates a [`ViewerGpu`] for `render_state` and stores it in its callback resources
    /// (replacing an earlier one).
    pub fn install(render_state: &egui_wgpu::RenderState) {
        let gpu = Self::new(&render_state.device, render_state.target_format);
        render_state.renderer.write().callback_resources.insert(gpu);
    }

    fn ensure_slots(&mut self, device: &wgpu::Device, size: [u32; 2]) {
        let max_side = device.limits().max_texture_dimension_2d;
        let size = size.map(|side| side.clamp(1, max_side));
        if self.slots.as_ref().is_some_and(|slots| slots.size == size) {
            return;
        }
        let target = *self.renderer.target();
        let targets = [0, 1].map(|_| OffscreenTarget::new(device, &target, size[0], size[1]));
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cdrf-viewer composite"),
            layout: &self.bind_group_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: self.params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(targets[0].resolved_view()),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(targets[1].resolved_view()),
                },
            ],
        });
        self.slots = Some(Slots {
            size,
            targets,
            bind_group,
        });
    }
}

/// One frame of the 3D view: what to render into the slots and how to lay them out.
#[derive(Clone, Debug)]
pub struct ViewCallback {
    /// Camera (built for the slot's aspect).
    pub view: View,
    /// Lights, in world space (mm).
    pub lights: Vec<Light>,
    /// Exposure multiplier.
    pub exposure: f32,
    /// The mesh, or `None` to show only the background.
    pub mesh: Option<MeshId>,
    /// The mesh's draws: each primitive's triangles and surface (`None`: untextured); empty:
    /// the whole mesh, untextured.
    pub primitives: Vec<(Range<u32>, Option<SurfaceId>)>,
    /// Model → world (mm): the mesh's mm per unit and placement.
    pub world_from_model: Mat4,
    /// Materials of slots A and B (B is ignored by [`Layout::Single`]).
    pub materials: [Option<MaterialId>; 2],
    /// How the slots are shown.
    pub layout: Layout,
    /// Split position as a fraction of the view width ([`Layout::Split`]).
    pub split: f32,
    /// Radiance difference shown at full colour ([`Layout::Difference`]).
    pub difference_range: f32,
    /// Size of the 3D view in points.
    pub size_points: Vec2,
    /// Background, linear RGB.
    pub background: [f32; 3],
    /// Cast shadows and transmission (world units are mm here).
    pub non_local: NonLocal,
    /// The environment light's SH (`None`: none).
    pub environment: Option<ShCoefficients>,
}

impl CallbackTrait for ViewCallback {
    fn prepare(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        screen_descriptor: &ScreenDescriptor,
        egui_encoder: &mut wgpu::CommandEncoder,
        callback_resources: &mut CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        let Some(gpu) = callback_resources.get_mut::<ViewerGpu>() else {
            return Vec::new();
        };
        let pixels_per_point = screen_descriptor.pixels_per_point;
        let view_pixels = (self.size_points * pixels_per_point).round().max(Vec2::ONE);
        let slot_size = slot_size_pixels(self.layout, self.size_points, pixels_per_point);
        gpu.ensure_slots(device, slot_size);

        // The mesh's draws (one per primitive) for each slot that has a mesh and a material; a
        // slot without stays empty.
        let mut draws = Vec::new();
        let mut slot_draws = [None, None];
        if let Some(mesh) = self.mesh {
            for (slot, material) in self.materials[..self.layout.slot_count()]
                .iter()
                .enumerate()
            {
                if let Some(material) = *material {
                    let first = draws.len();
                    let whole = Draw::new(mesh, material, self.world_from_model);
                    if self.primitives.is_empty() {
                        draws.push(whole.clone());
                    }
                    for (triangles, surface) in &self.primitives {
                        let draw = whole.clone().with_triangles(triangles.clone());
                        draws.push(match surface {
                            Some(surface) => draw.with_surface(*surface),
                            None => draw,
                        });
                    }
                    slot_draws[slot] = Some(first..draws.len());
                }
            }
        }
        let frame = FrameDesc {
            view: self.view,
            lights: &self.lights,
            exposure: self.exposure,
            draws: &draws,
            non_local: self.non_local,
            mm_per_world_unit: 1.0,
            environment: self.environment.as_ref(),
        };
        let prepared = gpu.renderer.prepare(device, queue, &frame);
        gpu.last_error = prepared.as_ref().err().map(ToString::to_string);
        let (prepared, shadow_commands) = match prepared {
            Ok(commands) => (Ok(()), commands),
            Err(error) => (Err(error), Vec::new()),
        };

        if let Some(slots) = &gpu.slots {
            for (target, slot_draws) in slots.targets.iter().zip(slot_draws) {
                let mut pass = target.begin_pass(egui_encoder, wgpu::Color::TRANSPARENT);
                if let (Ok(()), Some(slot_draws)) = (&prepared, slot_draws) {
                    gpu.renderer.render_draws(&mut pass, slot_draws);
                }
            }
        }

        let mut params = [0.0f32; 12];
        params[0] = self.layout.shader_index();
        params[1] = self.split;
        params[2] = self.difference_range;
        params[4] = view_pixels.x;
        params[5] = view_pixels.y;
        params[6] = slot_size[0] as f32;
        params[7] = slot_size[1] as f32;
        params[8..11].copy_from_slice(&self.background);
        let bytes: Vec<u8> = params.iter().flat_map(|v| v.to_le_bytes()).collect();
        queue.write_buffer(&gpu.params, 0, &bytes);
        // egui-wgpu submits these ahead of its own encoder, which holds the slots' passes.
        shadow_commands
    }

    fn paint(
        &self,
        _info: egui::PaintCallbackInfo,
        render_pass: &mut wgpu::RenderPass<'static>,
        callback_resources: &CallbackResources,
    ) {
        let Some(gpu) = callback_resources.get::<ViewerGpu>() else {
            return;
        };
        let Some(slots) = &gpu.slots else {
            return;
        };
        render_pass.set_pipeline(&gpu.pipeline);
        render_pass.set_bind_group(0, &slots.bind_group, &[]);
        render_pass.draw(0..3, 0..1);
    }
}

/// The wgpu setup of every device the viewer creates (window, offscreen UI, UI tests): the
/// backends cdrf renders on ([`cdrf_render::headless::SUPPORTED_BACKENDS`]; OpenGL refused,
/// where the shadow-map shaders do not compile), the rest egui-wgpu's defaults.
pub fn wgpu_setup() -> egui_wgpu::WgpuSetup {
    let mut create = egui_wgpu::WgpuSetupCreateNew::without_display_handle();
    create.instance_descriptor.backends = cdrf_render::headless::SUPPORTED_BACKENDS;
    egui_wgpu::WgpuSetup::CreateNew(create)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slots_are_half_the_view_side_by_side_in_physical_pixels() {
        let size = Vec2::new(401.0, 300.0);
        assert_eq!(slot_size_pixels(Layout::Split, size, 1.0), [401, 300]);
        assert_eq!(slot_size_pixels(Layout::SideBySide, size, 1.0), [200, 300]);
        // HiDPI: the slots match the physical pixels, not the points.
        assert_eq!(slot_size_pixels(Layout::SideBySide, size, 2.0), [401, 600]);
        assert_eq!(slot_size_pixels(Layout::Single, size, 1.5), [602, 450]);
        // A zero-sized view (minimised window) still gives a valid texture size.
        assert_eq!(slot_size_pixels(Layout::Split, Vec2::ZERO, 1.0), [1, 1]);
        assert_eq!(
            slot_size_pixels(Layout::SideBySide, Vec2::ZERO, 1.0),
            [1, 1]
        );
    }
}
