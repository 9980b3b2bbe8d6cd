//! The subsurface pyramid: per face of a shadowed light, the light entering the lit surface as
//! the light sees it (level 0, rendered by the light-map pass with `fs_subsurface_map`) and
//! each further level the 2 × 2 sums of the one below, which the subsurface gather reads
//! coarser with distance. Two textures: Φ·position and Φ; and the spread Φ·|position − mean|²
//! summed, which the gather reads the kernel across (a texel's light is not all at its mean).

use crate::shaders::subsurface_reduce_shader_source;

/// The pyramid's formats: Φ·position (mm × Φ's unit) and Φ (mm² for a directional light, sr
/// for a point or spot), and the spread (mm² × Φ's unit); f32 all.
pub(crate) const SUBSURFACE_FORMATS: [wgpu::TextureFormat; 2] = [
    wgpu::TextureFormat::Rgba32Float,
    wgpu::TextureFormat::R32Float,
];
/// The pyramid's coarsest level, texels per side (the gather reads it whole).
const SUBSURFACE_COARSEST: u32 = 8;
/// Texels of level 0 across the cut ℓ_c (the kernel rises over ℓ_c; a sum over texels this
/// fine is smooth).
const SUBSURFACE_TEXELS_PER_CUT: f32 = 1.5;
/// The depth format of level 0's pass.
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// The reduction of one level into the next: a full-screen triangle per level.
pub(crate) struct SubsurfaceReduce {
    /// Its bind group's layout: the finer level's two textures, read texel by texel.
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::RenderPipeline,
}

impl SubsurfaceReduce {
    pub(crate) fn new(device: &wgpu::Device) -> Self {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cdrf subsurface reduce layout"),
            entries: &[0, 1].map(|binding| wgpu::BindGroupLayoutEntry {
                binding,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            }),
        });
        let pipeline = create_reduce_pipeline(device, &layout);
        Self { layout, pipeline }
    }
}

/// The pyramid's textures: every face's levels, and what reading and writing them takes.
pub(crate) struct SubsurfacePyramid {
    /// Texels per side of level 0.
    pub(crate) resolution: u32,
    /// Levels, down to [`SUBSURFACE_COARSEST`] (0: a blank pyramid the gather never reads).
    pub(crate) levels: u32,
    /// All layers and levels of each texture ([`SUBSURFACE_FORMATS`]), for the shading
    /// pipelines.
    pub(crate) arrays: [wgpu::TextureView; 2],
    /// Per face (layer), per level, a view of each texture (render targets and the next
    /// level's source).
    level_views: Vec<Vec<[wgpu::TextureView; 2]>>,
    /// Per face, the reduction's bind group of levels 1… (reading the level below).
    reduce_groups: Vec<Vec<wgpu::BindGroup>>,
    /// Level 0's depth buffer (not sampled).
    pub(crate) depth: wgpu::TextureView,
}

impl SubsurfacePyramid {
    /// `resolution`: a power of two (1: a blank pyramid with no level the gather reads);
    /// `layers`: one per face of the shadowed lights.
    pub(crate) fn new(
        device: &wgpu::Device,
        reduce: &SubsurfaceReduce,
        resolution: u32,
        layers: u32,
    ) -> Self {
        let levels = if resolution >= SUBSURFACE_COARSEST {
            (resolution / SUBSURFACE_COARSEST).ilog2() + 1
        } else {
            0
        };
        let textures = SUBSURFACE_FORMATS.map(|format| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some("cdrf subsurface pyramid"),
                size: wgpu::Extent3d {
                    width: resolution,
                    height: resolution,
                    depth_or_array_layers: layers,
                },
                mip_level_count: levels.max(1),
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            })
        });
        let arrays = textures.each_ref().map(|texture| {
            texture.create_view(&wgpu::TextureViewDescriptor {
                label: Some("cdrf subsurface pyramid"),
                dimension: Some(wgpu::TextureViewDimension::D2Array),
                ..Default::default()
            })
        });
        let level_views: Vec<Vec<[wgpu::TextureView; 2]>> = (0..layers)
            .map(|layer| {
                (0..levels)
                    .map(|level| {
                        textures.each_ref().map(|texture| {
                            texture.create_view(&wgpu::TextureViewDescriptor {
                                label: Some("cdrf subsurface level"),
                                dimension: Some(wgpu::TextureViewDimension::D2),
                                base_mip_level: level,
                                mip_level_count: Some(1),
                                base_array_layer: layer,
                                array_layer_count: Some(1),
                                ..Default::default()
                            })
                        })
                    })
                    .collect()
            })
            .collect();
        let reduce_groups = level_views
            .iter()
            .map(|views| {
                views
                    .iter()
                    .take(views.len().saturating_sub(1))
                    .map(|finer| {
                        device.create_bind_group(&wgpu::BindGroupDescriptor {
                            label: Some("cdrf subsurface reduce"),
                            layout: &reduce.layout,
                            entries: &[
                                wgpu::BindGroupEntry {
                                    binding: 0,
                                    resource: wgpu::BindingResource::TextureView(&finer[0]),
                                },
                                wgpu::BindGroupEntry {
                                    binding: 1,
                                    resource: wgpu::BindingResource::TextureView(&finer[1]),
                                },
                            ],
                        })
                    })
                    .collect()
            })
            .collect();
        let depth = device
            .create_texture(&wgpu::TextureDescriptor {
                label: Some("cdrf subsurface depth"),
                size: wgpu::Extent3d {
                    width: resolution,
                    height: resolution,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: DEPTH_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                view_formats: &[],
            })
            .create_view(&Default::default());
        Self {
            resolution,
            levels,
            arrays,
            level_views,
            reduce_groups,
            depth,
        }
    }

    /// Level 0 of face (layer) `face` as render targets cleared to zero flux (no surface), or
    /// `None` in a blank pyramid.
    pub(crate) fn level0_targets(
        &self,
        face: usize,
    ) -> Option<[Option<wgpu::RenderPassColorAttachment<'_>>; 2]> {
        self.level_views
            .get(face)
            .and_then(|views| views.first())
            .map(|views| views.each_ref().map(cleared_target))
    }

    /// Reduces face `face`'s level 0 level by level (after the light-map pass rendered it).
    pub(crate) fn record_reduction(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        reduce: &SubsurfaceReduce,
        face: usize,
    ) {
        let (Some(views), Some(groups)) =
            (self.level_views.get(face), self.reduce_groups.get(face))
        else {
            return;
        };
        for (coarser, group) in views.iter().skip(1).zip(groups) {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("cdrf subsurface reduce"),
                color_attachments: &coarser.each_ref().map(cleared_target),
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&reduce.pipeline);
            pass.set_bind_group(0, group, &[]);
            pass.draw(0..3, 0..1);
        }
    }
}

/// Level 0's side for a map `side_mm` wide: the power of two that makes the cut span
/// [`SUBSURFACE_TEXELS_PER_CUT`] texels, from [`SUBSURFACE_COARSEST`] up to the largest power
/// of two not above `max_resolution`.
pub(crate) fn subsurface_resolution(side_mm: f32, cut_mm: f32, max_resolution: u32) -> u32 {
    let cap = if max_resolution >= SUBSURFACE_COARSEST {
        1 << max_resolution.ilog2()
    } else {
        SUBSURFACE_COARSEST
    };
    let wanted = side_mm * SUBSURFACE_TEXELS_PER_CUT / cut_mm.max(1e-3);
    if !(wanted.is_finite() && wanted > 0.0) {
        return cap;
    }
    (wanted.ceil().min(cap as f32) as u32)
        .next_power_of_two()
        .clamp(SUBSURFACE_COARSEST, cap)
}

/// A colour attachment cleared to zero and stored.
fn cleared_target(view: &wgpu::TextureView) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
            store: wgpu::StoreOp::Store,
        },
    })
}

/// The reduction pipeline (`vs_fullscreen` / `fs_reduce`).
fn create_reduce_pipeline(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
) -> wgpu::RenderPipeline {
    let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("cdrf subsurface reduce shader"),
        source: wgpu::ShaderSource::Wgsl(subsurface_reduce_shader_source().into()),
    });
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("cdrf subsurface reduce layout"),
        bind_group_layouts: &[Some(layout)],
        immediate_size: 0,
    });
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("cdrf subsurface reduce"),
        layout: Some(&layout),
        vertex: wgpu::VertexState {
            module: &shader,
            entry_point: Some("vs_fullscreen"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: Default::default(),
        depth_stencil: None,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &shader,
            entry_point: Some("fs_reduce"),
            compilation_options: Default::default(),
            targets: &SUBSURFACE_FORMATS.map(|format| {
                Some(wgpu::ColorTargetState {
                    format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })
            }),
        }),
        multiview_mask: None,
        cache: None,
    })
}
