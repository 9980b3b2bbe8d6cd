//! The light maps: a light camera per shadowed light fitted to the frame's draws (orthographic
//! for a directional light; for a point or spot light a perspective face aimed at the draws, or
//! a cube of six when the light is among them), the depth-only shadow pass that renders each
//! face's map, the subsurface pyramid's level 0 rendered from each face, and bind group 3,
//! through which the shading and compute pipelines read them. What the shaders do with the maps
//! is documented at the top of `shaders/cdrf.wgsl`.

use std::collections::HashMap;

use cdrf_core::glam::{Mat3, Mat4, Vec3};

use crate::constants::{
    GPU_SHADOW_ORTHOGRAPHIC, GPU_SHADOW_PERSPECTIVE, MAX_SHADOW_FACES, MAX_SHADOW_LIGHTS,
};
use crate::frame::{Draw, FrameDesc};
use crate::gpu_types::{
    GpuShadowLight, GpuShadowPass, GpuShadows, GpuVertex, SHADING_STAGES, uniform_layout_entry,
    uniform_size,
};
use crate::ids::MeshId;
use crate::mesh::GpuMesh;
use crate::passes::light_maps::light_camera::LightCamera;
use crate::passes::subsurface_pyramid::{
    SubsurfacePyramid, SubsurfaceReduce, subsurface_resolution,
};
use crate::shaders::shadow_shader_source;
use crate::target::Options;

mod light_camera;

/// The shadow maps' depth format.
const SHADOW_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// A draw of the frame as the light maps render it: its mesh and triangles, its transforms'
/// offset in the draw buffer and its material's bind group.
pub(crate) struct ShadowCaster<'a> {
    pub(crate) mesh: &'a GpuMesh,
    /// The draw's indices in the mesh's index buffer.
    pub(crate) indices: std::ops::Range<u32>,
    pub(crate) draw_offset: u32,
    pub(crate) material: &'a wgpu::BindGroup,
}

/// What the light maps bind besides their own: the frame's group 0 and the draws' group 2, and
/// the subsurface map's pipeline (`None`: no subsurface gather this frame).
pub(crate) struct LightViewBindings<'a> {
    pub(crate) frame: &'a wgpu::BindGroup,
    pub(crate) draws: &'a wgpu::BindGroup,
    pub(crate) subsurface_pipeline: Option<&'a wgpu::RenderPipeline>,
}

/// The depth-only pass that renders each face's shadow map.
struct ShadowPass {
    /// Per face, its clip transform (a dynamic offset of `stride` bytes a face).
    buffer: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    stride: u64,
    /// Orthographic faces: depth only.
    orthographic: wgpu::RenderPipeline,
    /// Perspective faces: the distance from the light as depth.
    perspective: wgpu::RenderPipeline,
}

impl ShadowPass {
    /// `draw_layout`: the shading pass's draw bind group layout (group 2), the shadow pass's
    /// group 1.
    fn new(device: &wgpu::Device, draw_layout: &wgpu::BindGroupLayout) -> Self {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cdrf shadow pass layout"),
            entries: &[uniform_layout_entry::<GpuShadowPass>(
                0,
                wgpu::ShaderStages::VERTEX_FRAGMENT,
                true,
            )],
        });
        let alignment = u64::from(device.limits().min_uniform_buffer_offset_alignment);
        let size = uniform_size::<GpuShadowPass>();
        let stride = size.get().next_multiple_of(alignment);
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cdrf shadow pass uniforms"),
            size: stride * (MAX_SHADOW_LIGHTS * MAX_SHADOW_FACES) as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cdrf shadow pass"),
            layout: &layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &buffer,
                    offset: 0,
                    size: Some(size),
                }),
            }],
        });
        Self {
            orthographic: create_shadow_pipeline(device, &[&layout, draw_layout], false),
            perspective: create_shadow_pipeline(device, &[&layout, draw_layout], true),
            buffer,
            bind_group,
            stride,
        }
    }

    /// Renders the casters into each face's layer of the map array.
    fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        layers: &[wgpu::TextureView],
        faces: &[LightFace],
        casters: &[ShadowCaster<'_>],
        draws: &wgpu::BindGroup,
    ) {
        for (index, (layer, face)) in layers.iter().zip(faces).enumerate() {
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
            pass.set_pipeline(if face.perspective {
                &self.perspective
            } else {
                &self.orthographic
            });
            let offset = (index as u64 * self.stride) as u32;
            pass.set_bind_group(0, &self.bind_group, &[offset]);
            for caster in casters {
                pass.set_bind_group(1, draws, &[caster.draw_offset]);
                pass.set_vertex_buffer(0, caster.mesh.vertices.slice(..));
                pass.set_index_buffer(caster.mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(caster.indices.clone(), 0, 0..1);
            }
        }
    }
}

/// One face of a shadowed light's map (a layer of the map arrays): the light's index and the
/// face's, and whether it is perspective.
#[derive(Clone, Copy)]
struct LightFace {
    light: usize,
    face: usize,
    perspective: bool,
}

impl LightFace {
    /// The light-view pass's instance index (`vs_light_view`).
    fn instance(self) -> u32 {
        (self.light * MAX_SHADOW_FACES + self.face) as u32
    }
}

/// The shadow maps, the subsurface pyramid and what the shading pipelines read of them (bind
/// group 3).
struct MapTextures {
    resolution: u32,
    /// One view per layer, to render into.
    layers: Vec<wgpu::TextureView>,
    subsurface: SubsurfacePyramid,
    bind_group: wgpu::BindGroup,
    /// Group 3 for the light-view pass itself: the same uniforms with a blank pyramid (a map
    /// cannot be read and written in one pass).
    light_view_bind_group: wgpu::BindGroup,
}

impl MapTextures {
    /// The shadow maps (one depth layer per face, `resolution` texels per side), the
    /// subsurface pyramid and bind group 3 reading them. `sizes`: texels per side of the
    /// shadow maps and of the pyramid's level 0, and the maps' layers.
    fn new(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        reduce: &SubsurfaceReduce,
        uniforms: &wgpu::Buffer,
        sizes: [u32; 3],
    ) -> Self {
        let [resolution, subsurface_resolution, layer_count] = sizes;
        let subsurface = SubsurfacePyramid::new(device, reduce, subsurface_resolution, layer_count);
        let blank_pyramid = SubsurfacePyramid::new(device, reduce, 1, 1);
        let (shadow_array, layers) = layered_texture(
            device,
            "cdrf shadow maps",
            SHADOW_FORMAT,
            resolution,
            layer_count,
        );
        let group = |pyramid: &[wgpu::TextureView; 2]| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("cdrf shadows"),
                layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: uniforms.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(&shadow_array),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: wgpu::BindingResource::TextureView(&pyramid[0]),
                    },
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: wgpu::BindingResource::TextureView(&pyramid[1]),
                    },
                ],
            })
        };
        let bind_group = group(&subsurface.arrays);
        let light_view_bind_group = group(&blank_pyramid.arrays);
        Self {
            resolution,
            layers,
            subsurface,
            bind_group,
            light_view_bind_group,
        }
    }

    fn sizes(&self) -> [u32; 3] {
        [
            self.resolution,
            self.subsurface.resolution,
            self.layers.len() as u32,
        ]
    }
}

/// Everything the light maps own.
pub(crate) struct LightMaps {
    /// Bind group 3's layout (uniforms, the shadow map array and the subsurface pyramids).
    pub(crate) layout: wgpu::BindGroupLayout,
    uniforms: wgpu::Buffer,
    /// Bound when no map exists yet (1 × 1 maps).
    blank: MapTextures,
    maps: Option<MapTextures>,
    shadow_pass: ShadowPass,
    reduce: SubsurfaceReduce,
    /// Lights whose maps the last `prepare` rendered.
    shadowed_lights: usize,
}

impl LightMaps {
    /// `draw_layout`: the shading pass's draw bind group layout (group 2), reused by the
    /// shadow pass.
    pub(crate) fn new(device: &wgpu::Device, draw_layout: &wgpu::BindGroupLayout) -> Self {
        // The subsurface pyramid's textures: gathered per vertex, by the vertex terms pass.
        let pyramid_entry = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: false },
                view_dimension: wgpu::TextureViewDimension::D2Array,
                multisampled: false,
            },
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cdrf shadows layout"),
            entries: &[
                uniform_layout_entry::<GpuShadows>(0, SHADING_STAGES, false),
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    // Read per vertex (translucent materials, by the vertex terms pass; the
                    // light-view passes' vertices) and per pixel (Lambert).
                    visibility: SHADING_STAGES,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Depth,
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                    count: None,
                },
                pyramid_entry(2),
                pyramid_entry(3),
            ],
        });
        let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cdrf shadow uniforms"),
            size: uniform_size::<GpuShadows>().get(),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let reduce = SubsurfaceReduce::new(device);
        let blank = MapTextures::new(device, &layout, &reduce, &uniforms, [1, 1, 1]);
        Self {
            shadow_pass: ShadowPass::new(device, draw_layout),
            layout,
            uniforms,
            blank,
            maps: None,
            reduce,
            shadowed_lights: 0,
        }
    }

    /// Bind group 3: the maps the last `prepare` rendered, or blank ones.
    pub(crate) fn bind_group(&self) -> &wgpu::BindGroup {
        match &self.maps {
            Some(maps) if self.shadowed_lights > 0 => &maps.bind_group,
            _ => &self.blank.bind_group,
        }
    }

    /// Forgets the maps of the last frame (a frame without light maps, or a failed one).
    pub(crate) fn clear(&mut self) {
        self.shadowed_lights = 0;
    }

    /// Fits a light camera to the bounding sphere of the draws for each of the first
    /// [`MAX_SHADOW_LIGHTS`] lights, uploads the transforms and records the shadow pass, then
    /// (with the subsurface gather on) the subsurface pyramid of every face.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        options: &Options,
        frame: &FrameDesc<'_>,
        meshes: &HashMap<MeshId, GpuMesh>,
        casters: &[ShadowCaster<'_>],
        bindings: LightViewBindings<'_>,
    ) -> wgpu::CommandBuffer {
        let max_side = device.limits().max_texture_dimension_2d;
        let resolution = options.shadow_map_resolution.clamp(1, max_side);
        let (centre, radius) = scene_bounds(frame.draws, meshes);
        let subsurface_resolution = if bindings.subsurface_pipeline.is_some() {
            subsurface_resolution(
                2.0 * LightCamera::half_extent_for(radius) * frame.mm_per_world_unit,
                options.subsurface_cut_mm,
                options.subsurface_max_resolution.min(max_side),
            )
        } else {
            1
        };
        // The first MAX_SHADOW_LIGHTS lights in shading order (directional first), each with
        // its camera and its faces' layers.
        let cameras: Vec<LightCamera> = frame
            .lights_in_shading_order()
            .take(MAX_SHADOW_LIGHTS)
            .map(|light| LightCamera::fit(light, centre, radius))
            .collect();
        let layer_count: usize = cameras.iter().map(|c| c.faces.len()).sum();
        let sizes = [resolution, subsurface_resolution, layer_count.max(1) as u32];
        if self.maps.as_ref().map(MapTextures::sizes) != Some(sizes) {
            self.maps = Some(MapTextures::new(
                device,
                &self.layout,
                &self.reduce,
                &self.uniforms,
                sizes,
            ));
        }
        let maps = self.maps.as_ref().expect("created above");
        let (shadows, faces) = self.upload_cameras(queue, options, frame, &cameras, maps);

        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("cdrf shadow pass"),
        });
        self.shadow_pass
            .record(&mut encoder, &maps.layers, &faces, casters, bindings.draws);
        if let Some(pipeline) = bindings.subsurface_pipeline {
            for (layer, face) in faces.iter().enumerate() {
                let Some(targets) = maps.subsurface.level0_targets(layer) else {
                    break;
                };
                record_light_view(
                    &mut encoder,
                    "cdrf subsurface map",
                    &targets,
                    &maps.subsurface.depth,
                    face.instance(),
                    casters,
                    &bindings,
                    &maps.light_view_bind_group,
                    pipeline,
                );
                maps.subsurface
                    .record_reduction(&mut encoder, &self.reduce, layer);
            }
        }
        self.shadowed_lights = shadows;
        encoder.finish()
    }

    /// Uploads the shadowed lights' uniforms (group 3) and each face's clip transform (the
    /// shadow pass's); returns how many lights are shadowed and every face in layer order.
    fn upload_cameras(
        &self,
        queue: &wgpu::Queue,
        options: &Options,
        frame: &FrameDesc<'_>,
        cameras: &[LightCamera],
        maps: &MapTextures,
    ) -> (usize, Vec<LightFace>) {
        let mut shadows = GpuShadows {
            mm_per_world_unit: frame.mm_per_world_unit,
            depth_bias_mm: options.shadow_bias_mm.max(0.0),
            resolution: maps.resolution,
            light_count: cameras.len() as u32,
            subsurface_resolution: maps.subsurface.resolution,
            subsurface_levels: maps.subsurface.levels,
            ..bytemuck::Zeroable::zeroed()
        };
        let stride = self.shadow_pass.stride;
        let mut passes =
            vec![0u8; (stride * (MAX_SHADOW_LIGHTS * MAX_SHADOW_FACES) as u64) as usize];
        let mut faces = Vec::with_capacity(maps.layers.len());
        for (index, camera) in cameras.iter().enumerate() {
            let mut light_from_world = [Mat4::IDENTITY; MAX_SHADOW_FACES];
            light_from_world[..camera.faces.len()].copy_from_slice(&camera.faces);
            shadows.lights[index] = GpuShadowLight {
                light_from_world,
                position: camera.position.unwrap_or(Vec3::ZERO),
                half_extent: camera.half_extent,
                depth_range: camera.depth_range,
                projection: if camera.position.is_some() {
                    GPU_SHADOW_PERSPECTIVE
                } else {
                    GPU_SHADOW_ORTHOGRAPHIC
                },
                face_count: camera.faces.len() as u32,
                first_layer: faces.len() as u32,
            };
            for face in 0..camera.faces.len() {
                let pass = GpuShadowPass {
                    clip_from_world: camera.clip_from_world(face),
                    light_position: camera.position.unwrap_or(Vec3::ZERO),
                    inverse_depth_range: 1.0 / camera.depth_range,
                };
                let start = faces.len() * stride as usize;
                passes[start..start + size_of::<GpuShadowPass>()]
                    .copy_from_slice(bytemuck::bytes_of(&pass));
                faces.push(LightFace {
                    light: index,
                    face,
                    perspective: camera.position.is_some(),
                });
            }
        }
        queue.write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&shadows));
        queue.write_buffer(&self.shadow_pass.buffer, 0, &passes);
        (cameras.len(), faces)
    }
}

/// Renders the casters with `pipeline` as a face of a shadowed light sees them
/// (`vs_light_view`, `instance` names the light and the face: [`LightFace::instance`]) into
/// `target`, with `depth` cleared as the depth buffer.
#[allow(clippy::too_many_arguments)]
fn record_light_view(
    encoder: &mut wgpu::CommandEncoder,
    label: &'static str,
    targets: &[Option<wgpu::RenderPassColorAttachment<'_>>],
    depth: &wgpu::TextureView,
    instance: u32,
    casters: &[ShadowCaster<'_>],
    bindings: &LightViewBindings<'_>,
    pass_bind_group: &wgpu::BindGroup,
    pipeline: &wgpu::RenderPipeline,
) {
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: targets,
        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
            view: depth,
            depth_ops: Some(wgpu::Operations {
                load: wgpu::LoadOp::Clear(1.0),
                store: wgpu::StoreOp::Discard,
            }),
            stencil_ops: None,
        }),
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, bindings.frame, &[0]); // view 0: the passes see no camera
    pass.set_bind_group(3, pass_bind_group, &[]);
    for caster in casters {
        pass.set_bind_group(1, caster.material, &[]);
        pass.set_bind_group(2, bindings.draws, &[caster.draw_offset]);
        pass.set_vertex_buffer(0, caster.mesh.vertices.slice(..));
        pass.set_index_buffer(caster.mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed(caster.indices.clone(), 0, instance..instance + 1);
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

/// A 2D texture array of `layers` layers `side` texels square, sampled by the shaders and
/// rendered into: its array view and one view per layer.
fn layered_texture(
    device: &wgpu::Device,
    label: &str,
    format: wgpu::TextureFormat,
    side: u32,
    layers: u32,
) -> (wgpu::TextureView, Vec<wgpu::TextureView>) {
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: side,
            height: side,
            depth_or_array_layers: layers,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        view_formats: &[],
    });
    let array = texture.create_view(&wgpu::TextureViewDescriptor {
        label: Some(label),
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    });
    let views = (0..layers)
        .map(|layer| {
            texture.create_view(&wgpu::TextureViewDescriptor {
                label: Some(label),
                dimension: Some(wgpu::TextureViewDimension::D2),
                base_array_layer: layer,
                array_layer_count: Some(1),
                ..Default::default()
            })
        })
        .collect();
    (array, views)
}

/// The depth-only pipeline of the shadow pass (no culling: the first surface whatever its
/// winding); `distance_as_depth`: the fragment shader writes the distance from the light.
fn create_shadow_pipeline(
    device: &wgpu::Device,
    layouts: &[&wgpu::BindGroupLayout],
    distance_as_depth: bool,
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
        fragment: distance_as_depth.then(|| wgpu::FragmentState {
            module: &shader,
            entry_point: Some("fs_shadow_distance"),
            compilation_options: Default::default(),
            targets: &[],
        }),
        multiview_mask: None,
        cache: None,
    })
}
