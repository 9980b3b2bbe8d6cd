//! The non-local terms' GPU side: an orthographic light camera per shadowed light fitted to the
//! frame's draws, the depth-only shadow pass that renders their maps, and the bind group
//! (group 3) through which the shading pipelines read them. What the shader does with the maps
//! is documented at the top of `shaders/cdrf.wgsl`.

use std::collections::HashMap;

use cdrf_core::glam::{Mat3, Mat4, Vec3};

use crate::frame::{Draw, FrameDesc};
use crate::gpu_types::{
    GpuShadowLight, GpuShadowPass, GpuShadows, GpuVertex, uniform_layout_entry, uniform_size,
};
use crate::mesh::{GpuMesh, MeshId};
use crate::shaders::{MAX_SHADOW_LIGHTS, shadow_shader_source};
use crate::target::Options;

/// The shadow maps' depth format.
const SHADOW_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// A draw of the frame for the shadow pass: its mesh and its transform's offset in the draw
/// buffer.
pub(crate) struct ShadowCaster<'a> {
    pub(crate) mesh: &'a GpuMesh,
    pub(crate) draw_offset: u32,
}

/// The shadow maps and what the shading pipelines read of them (bind group 3).
struct ShadowMaps {
    resolution: u32,
    /// One view per layer, to render into.
    layers: Vec<wgpu::TextureView>,
    bind_group: wgpu::BindGroup,
}

/// Everything the shadow pass owns.
pub(crate) struct NonLocalPass {
    /// Bind group 3's layout (uniforms and the map array).
    pub(crate) layout: wgpu::BindGroupLayout,
    uniforms: wgpu::Buffer,
    /// Bound when no shadow map exists yet (a 1 × 1 map).
    no_shadows: wgpu::BindGroup,
    maps: Option<ShadowMaps>,
    pass_buffer: wgpu::Buffer,
    pass_bind_group: wgpu::BindGroup,
    pass_stride: u64,
    pipeline: wgpu::RenderPipeline,
    /// Lights whose shadow map the last `prepare` rendered.
    shadowed_lights: usize,
}

impl NonLocalPass {
    /// `draw_layout`: the shading pass's draw bind group layout (group 2), reused as the shadow
    /// pass's group 1.
    pub(crate) fn new(device: &wgpu::Device, draw_layout: &wgpu::BindGroupLayout) -> Self {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cdrf shadows layout"),
            entries: &[
                uniform_layout_entry::<GpuShadows>(0, wgpu::ShaderStages::VERTEX_FRAGMENT, false),
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    // Read per vertex (translucent materials) and per pixel (Lambert).
                    visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Depth,
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                    count: None,
                },
            ],
        });
        let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cdrf shadow uniforms"),
            size: uniform_size::<GpuShadows>().get(),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let (_, no_shadows) = create_shadow_maps(device, &layout, &uniforms, 1);
        let pass_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cdrf shadow pass layout"),
            entries: &[uniform_layout_entry::<GpuShadowPass>(
                0,
                wgpu::ShaderStages::VERTEX,
                true,
            )],
        });
        let alignment = u64::from(device.limits().min_uniform_buffer_offset_alignment);
        let pass_size = uniform_size::<GpuShadowPass>();
        let pass_stride = pass_size.get().next_multiple_of(alignment);
        let pass_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cdrf shadow pass uniforms"),
            size: pass_stride * MAX_SHADOW_LIGHTS as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let pass_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cdrf shadow pass"),
            layout: &pass_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &pass_buffer,
                    offset: 0,
                    size: Some(pass_size),
                }),
            }],
        });
        let pipeline = create_shadow_pipeline(device, &[&pass_layout, draw_layout]);
        Self {
            layout,
            uniforms,
            no_shadows,
            maps: None,
            pass_buffer,
            pass_bind_group,
            pass_stride,
            pipeline,
            shadowed_lights: 0,
        }
    }

    /// Bind group 3 for the shading pass: the maps the last `prepare` rendered, or a blank one.
    pub(crate) fn bind_group(&self) -> &wgpu::BindGroup {
        match &self.maps {
            Some(maps) if self.shadowed_lights > 0 => &maps.bind_group,
            _ => &self.no_shadows,
        }
    }

    /// Forgets the maps of the last frame (a frame without non-local terms, or a failed one).
    pub(crate) fn clear(&mut self) {
        self.shadowed_lights = 0;
    }

    /// Fits an orthographic light camera to the bounding sphere of the draws for each of the
    /// first [`MAX_SHADOW_LIGHTS`] lights, uploads the transforms and records the depth pass.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        options: &Options,
        frame: &FrameDesc<'_>,
        meshes: &HashMap<MeshId, GpuMesh>,
        casters: &[ShadowCaster<'_>],
        draw_bind_group: &wgpu::BindGroup,
    ) -> wgpu::CommandBuffer {
        let resolution = options
            .shadow_map_resolution
            .clamp(1, device.limits().max_texture_dimension_2d);
        if self.maps.as_ref().map(|m| m.resolution) != Some(resolution) {
            let (layers, bind_group) =
                create_shadow_maps(device, &self.layout, &self.uniforms, resolution);
            self.maps = Some(ShadowMaps {
                resolution,
                layers,
                bind_group,
            });
        }
        let (centre, radius) = scene_bounds(frame.draws, meshes);
        let lights = frame.lights.len().min(MAX_SHADOW_LIGHTS);
        let mut shadows = GpuShadows {
            mm_per_world_unit: frame.mm_per_world_unit,
            depth_bias_mm: options.shadow_bias_mm.max(0.0),
            resolution,
            light_count: lights as u32,
            ..bytemuck::Zeroable::zeroed()
        };
        let mut passes = vec![0u8; (self.pass_stride * MAX_SHADOW_LIGHTS as u64) as usize];
        for (index, light) in frame.lights.iter().take(lights).enumerate() {
            let camera = LightCamera::fit(light.to_light, centre, radius);
            shadows.lights[index] = GpuShadowLight {
                light_from_world: camera.light_from_world,
                half_extent: camera.half_extent,
                depth_range: camera.depth_range(),
                _pad0: [0.0; 2],
            };
            let pass = GpuShadowPass {
                clip_from_world: camera.clip_from_world(),
            };
            let start = index * self.pass_stride as usize;
            passes[start..start + size_of::<GpuShadowPass>()]
                .copy_from_slice(bytemuck::bytes_of(&pass));
        }
        queue.write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&shadows));
        queue.write_buffer(&self.pass_buffer, 0, &passes);

        let maps = self.maps.as_ref().expect("created above");
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("cdrf shadow pass"),
        });
        for (index, layer) in maps.layers.iter().take(lights).enumerate() {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("cdrf shadow map"),
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: layer,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.pipeline);
            let offset = (index as u64 * self.pass_stride) as u32;
            pass.set_bind_group(0, &self.pass_bind_group, &[offset]);
            for caster in casters {
                pass.set_bind_group(1, draw_bind_group, &[caster.draw_offset]);
                pass.set_vertex_buffer(0, caster.mesh.vertices.slice(..));
                pass.set_index_buffer(caster.mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..caster.mesh.index_count, 0, 0..1);
            }
        }
        self.shadowed_lights = lights;
        encoder.finish()
    }
}

/// An orthographic camera looking along a directional light, fitted to a bounding sphere.
struct LightCamera {
    /// World → light space: x, y across the light, z along it from the map's light-side plane.
    light_from_world: Mat4,
    /// Half the map's side, world units.
    half_extent: f32,
}

impl LightCamera {
    fn fit(to_light: Vec3, centre: Vec3, radius: f32) -> Self {
        let forward = -to_light.normalize();
        let helper = if forward.y.abs() < 0.9 {
            Vec3::Y
        } else {
            Vec3::X
        };
        let x = helper.cross(forward).normalize();
        let y = forward.cross(x);
        // A margin so the sphere's rim is not on the map's edge or its far plane.
        let half_extent = radius * 1.02;
        let rotation = Mat4::from_mat3(Mat3::from_cols(x, y, forward).transpose());
        let light_from_world = Mat4::from_translation(Vec3::new(0.0, 0.0, half_extent))
            * rotation
            * Mat4::from_translation(-centre);
        Self {
            light_from_world,
            half_extent,
        }
    }

    /// Depth that maps to 1, world units: the bounding sphere's diameter.
    fn depth_range(&self) -> f32 {
        2.0 * self.half_extent
    }

    /// Light space → the shadow pass's clip space (depth = z / depth range).
    fn clip_from_world(&self) -> Mat4 {
        Mat4::from_scale(Vec3::new(
            1.0 / self.half_extent,
            1.0 / self.half_extent,
            1.0 / self.depth_range(),
        )) * self.light_from_world
    }
}

/// A sphere around every draw's mesh in world space (radius > 0).
fn scene_bounds(draws: &[Draw], meshes: &HashMap<MeshId, GpuMesh>) -> (Vec3, f32) {
    let spheres: Vec<(Vec3, f32)> = draws
        .iter()
        .filter_map(|draw| {
            let (centre, radius) = meshes.get(&draw.mesh)?.bounds;
            let linear = Mat3::from_mat4(draw.world_from_model);
            let scale = linear
                .x_axis
                .length()
                .max(linear.y_axis.length())
                .max(linear.z_axis.length());
            Some((
                draw.world_from_model.transform_point3(centre),
                radius * scale,
            ))
        })
        .collect();
    let (min, max) = spheres.iter().fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(lo, hi), &(c, r)| (lo.min(c - r), hi.max(c + r)),
    );
    let centre = (min + max) * 0.5;
    let radius = spheres
        .iter()
        .map(|&(c, r)| c.distance(centre) + r)
        .fold(0.0, f32::max);
    (centre, radius.max(1e-6))
}

/// The shadow maps (one depth layer per shadowed light, `resolution` texels per side) and the
/// shading pipelines' bind group 3 reading them.
fn create_shadow_maps(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    uniforms: &wgpu::Buffer,
    resolution: u32,
) -> (Vec<wgpu::TextureView>, wgpu::BindGroup) {
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("cdrf shadow maps"),
        size: wgpu::Extent3d {
            width: resolution,
            height: resolution,
            depth_or_array_layers: MAX_SHADOW_LIGHTS as u32,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: SHADOW_FORMAT,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        view_formats: &[],
    });
    let array = texture.create_view(&wgpu::TextureViewDescriptor {
        label: Some("cdrf shadow maps (array)"),
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    });
    let layers = (0..MAX_SHADOW_LIGHTS as u32)
        .map(|layer| {
            texture.create_view(&wgpu::TextureViewDescriptor {
                label: Some("cdrf shadow map"),
                dimension: Some(wgpu::TextureViewDimension::D2),
                base_array_layer: layer,
                array_layer_count: Some(1),
                ..Default::default()
            })
        })
        .collect();
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("cdrf shadows"),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: uniforms.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::TextureView(&array),
            },
        ],
    });
    (layers, bind_group)
}

/// The depth-only pipeline of the shadow pass (no culling: the first surface whatever its
/// winding).
fn create_shadow_pipeline(
    device: &wgpu::Device,
    layouts: &[&wgpu::BindGroupLayout],
) -> wgpu::RenderPipeline {
    let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("cdrf shadow shader"),
        source: wgpu::ShaderSource::Wgsl(shadow_shader_source().into()),
    });
    let layouts: Vec<Option<&wgpu::BindGroupLayout>> = layouts.iter().copied().map(Some).collect();
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("cdrf shadow pipeline layout"),
        bind_group_layouts: &layouts,
        immediate_size: 0,
    });
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("cdrf shadow pipeline"),
        layout: Some(&layout),
        vertex: wgpu::VertexState {
            module: &shader,
            entry_point: Some("vs_shadow"),
            compilation_options: Default::default(),
            buffers: &[Some(wgpu::VertexBufferLayout {
                array_stride: GpuVertex::STRIDE,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &GpuVertex::ATTRIBUTES[..1],
            })],
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: SHADOW_FORMAT,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Less),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: None,
        multiview_mask: None,
        cache: None,
    })
}
