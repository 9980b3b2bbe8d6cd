//! The shading pipelines, built on demand and cached per target, shading model and
//! non-local terms, the compute passes' (the vertex terms and, with the inter-reflection, its
//! emitters, bounces and gather; per shading model and non-local terms) and the subsurface map
//! pass's, from the shader modules of [`crate::shaders`] (one per pass).

use std::collections::HashMap;

use cdrf_core::light::NonLocal;

use crate::constants::{COMPUTE_WORKGROUP_SIZE, Model};
use crate::error::PrepareError;
use crate::gpu_types::{GpuDraw, GpuVertex, GpuVertexTerms, uniform_layout_entry};
use crate::passes::interreflection::InterreflectionPipelines;
use crate::passes::subsurface_pyramid::SUBSURFACE_FORMATS;
use crate::shaders::{INTERREFLECTION, LIGHT_VIEW, SHADING, Shader, VERTEX_TERMS};
use crate::target::{LutFiltering, Options, TargetDesc};

/// The pipeline variants' key: target, shading model, non-local terms.
type PipelineKey = (TargetDesc, Model, NonLocal);

/// Whether a shading pipeline reads per-vertex non-local terms, which the vertex terms pass
/// (`cs_vertex_terms`) writes: the translucent models' visibility, transmission and gather,
/// and every model's inter-reflection but the curvature view's (Lambert's other terms are
/// per pixel).
pub(crate) fn uses_vertex_terms(model: Model, non_local: NonLocal) -> bool {
    model != Model::Curvature
        && (non_local.interreflection || (model != Model::Lambert && non_local.light_maps()))
}

/// Whether a device with these limits runs the vertex terms pass: compute shaders of
/// [`COMPUTE_WORKGROUP_SIZE`] invocations a group reading the mesh's vertices and writing the
/// terms, and the inter-reflection's patches and emitters (six storage buffers).
pub(crate) fn runs_vertex_terms(limits: &wgpu::Limits) -> bool {
    limits.max_storage_buffers_per_shader_stage >= 6
        && limits.max_compute_workgroup_size_x >= COMPUTE_WORKGROUP_SIZE
        && limits.max_compute_invocations_per_workgroup >= COMPUTE_WORKGROUP_SIZE
}

/// The shader modules, their layouts and the pipelines built from them.
pub(crate) struct Pipelines {
    /// The shading pass's module (`vs_main`, `vs_main_terms`, `fs_main`).
    shading: wgpu::ShaderModule,
    /// The light-view pass's module (`vs_light_view`, `fs_subsurface_map`).
    light_view: wgpu::ShaderModule,
    /// The first module that failed to compile: the diagnostic at its part's file and line,
    /// returned by every pipeline built after.
    shader_error: Option<String>,
    /// The shading and light-view passes' layout.
    layout: wgpu::PipelineLayout,
    /// What the compute passes are built from; `None` on a device without compute shaders or
    /// storage buffers.
    compute: Option<ComputeShaders>,
    cache: HashMap<PipelineKey, wgpu::RenderPipeline>,
    compute_cache: HashMap<(Model, NonLocal), ComputePipelines>,
    subsurface_map: Option<wgpu::RenderPipeline>,
}

/// The compute passes' layouts and modules.
struct ComputeShaders {
    /// Their group 2 (the draw's transforms with a dynamic offset, the mesh's vertices, the
    /// terms they write, the mesh's patches and the frame's emitters).
    group_layout: wgpu::BindGroupLayout,
    layout: wgpu::PipelineLayout,
    /// `cs_vertex_terms`'s module.
    vertex_terms: wgpu::ShaderModule,
    /// The inter-reflection's module.
    interreflection: wgpu::ShaderModule,
}

/// The compute passes' pipelines of a shading model and its non-local terms.
pub(crate) struct ComputePipelines {
    /// `cs_vertex_terms`: each vertex's non-local terms of the direct light.
    pub(crate) vertex_terms: wgpu::ComputePipeline,
    /// With the inter-reflection, its stages.
    pub(crate) interreflection: Option<InterreflectionPipelines>,
}

impl Pipelines {
    /// `bind_group_layouts`: groups 0–3 (frame, material, draw, shadows).
    pub(crate) fn new(
        device: &wgpu::Device,
        bind_group_layouts: [&wgpu::BindGroupLayout; 4],
    ) -> Self {
        let mut shader_error = None;
        let mut create = |shader: &Shader| {
            let (module, result) = shader.create_module(device);
            if let Err(error) = result {
                shader_error.get_or_insert(error);
            }
            module
        };
        let shading = create(&SHADING);
        let light_view = create(&LIGHT_VIEW);
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("cdrf pipeline layout"),
            bind_group_layouts: &bind_group_layouts.map(Some),
            immediate_size: 0,
        });
        let storage = |binding, read_only| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let compute = runs_vertex_terms(&device.limits()).then(|| {
            let group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("cdrf vertex terms layout"),
                entries: &[
                    uniform_layout_entry::<GpuDraw>(0, wgpu::ShaderStages::COMPUTE, true),
                    storage(7, true),
                    storage(8, false),
                    storage(9, true),
                    storage(10, true),
                    storage(11, true),
                    storage(12, false),
                ],
            });
            let [frame, material, _, shadows] = bind_group_layouts;
            let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("cdrf vertex terms pipeline layout"),
                bind_group_layouts: &[
                    Some(frame),
                    Some(material),
                    Some(&group_layout),
                    Some(shadows),
                ],
                immediate_size: 0,
            });
            ComputeShaders {
                group_layout,
                layout,
                vertex_terms: create(&VERTEX_TERMS),
                interreflection: create(&INTERREFLECTION),
            }
        });
        Self {
            shading,
            light_view,
            compute,
            shader_error,
            layout,
            compute_cache: HashMap::new(),
            cache: HashMap::new(),
            subsurface_map: None,
        }
    }

    /// The pipeline of a variant, if built.
    pub(crate) fn get(
        &self,
        target: TargetDesc,
        model: Model,
        non_local: NonLocal,
    ) -> Option<&wgpu::RenderPipeline> {
        self.cache.get(&(target, model, non_local))
    }

    /// Whether the device runs the vertex terms pass (compute shaders, storage buffers).
    pub(crate) fn has_vertex_terms(&self) -> bool {
        self.compute.is_some()
    }

    /// The compute passes' group 2 layout (bindings 0 and 7–12 of `vertex_terms_pass.wgsl` and
    /// `interreflection_pass.wgsl`), if the device runs them.
    pub(crate) fn terms_layout(&self) -> Option<&wgpu::BindGroupLayout> {
        self.compute.as_ref().map(|compute| &compute.group_layout)
    }

    /// The compute passes' pipelines of a shading model and its non-local terms, if built.
    pub(crate) fn compute(&self, model: Model, non_local: NonLocal) -> Option<&ComputePipelines> {
        self.compute_cache.get(&(model, non_local))
    }

    /// Builds the pipeline of a variant unless cached, and the vertex terms pass's pipeline
    /// it reads from if it [uses one](uses_vertex_terms). wgpu reports a target the device
    /// cannot use through an error scope, returned here instead of reaching the host's
    /// uncaptured-error handler.
    pub(crate) fn ensure(
        &mut self,
        device: &wgpu::Device,
        options: &Options,
        target: TargetDesc,
        model: Model,
        non_local: NonLocal,
    ) -> Result<(), PrepareError> {
        let key = (target, model, non_local);
        if self.cache.contains_key(&key) {
            return Ok(());
        }
        if let Some(message) = &self.shader_error {
            return Err(PrepareError::Pipeline {
                target,
                message: message.clone(),
            });
        }
        let terms = uses_vertex_terms(model, non_local);
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let constants = [
            ("MODEL", model as u32 as f64),
            (
                "MANUAL_FILTERING",
                flag(options.lut_filtering == LutFiltering::Manual),
            ),
            ("ENCODE_SRGB", flag(target.encodes_srgb_in_shader())),
            ("SHADOWS", flag(non_local.shadows)),
            ("TRANSMISSION", flag(non_local.transmission)),
            ("INTERREFLECTION", flag(non_local.interreflection)),
            ("SUBSURFACE", flag(non_local.subsurface)),
        ];
        let compilation_options = wgpu::PipelineCompilationOptions {
            constants: &constants,
            ..Default::default()
        };
        let vertices = Some(wgpu::VertexBufferLayout {
            array_stride: GpuVertex::STRIDE,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &GpuVertex::ATTRIBUTES,
        });
        let vertex_terms = Some(wgpu::VertexBufferLayout {
            array_stride: GpuVertexTerms::STRIDE,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &GpuVertexTerms::ATTRIBUTES,
        });
        let buffers = [vertices, vertex_terms];
        let terms_shaders = self
            .compute
            .as_ref()
            .filter(|_| terms && !self.compute_cache.contains_key(&(model, non_local)));
        let terms_pipeline = terms_shaders.map(|shaders| {
            let compute = |label, module, entry_point| {
                device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(label),
                    layout: Some(&shaders.layout),
                    module,
                    entry_point: Some(entry_point),
                    compilation_options: compilation_options.clone(),
                    cache: None,
                })
            };
            let interreflection = &shaders.interreflection;
            ComputePipelines {
                vertex_terms: compute(
                    "cdrf vertex terms pipeline",
                    &shaders.vertex_terms,
                    "cs_vertex_terms",
                ),
                interreflection: non_local.interreflection.then(|| {
                    InterreflectionPipelines::new(|label, entry_point| {
                        compute(label, interreflection, entry_point)
                    })
                }),
            }
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("cdrf pipeline"),
            layout: Some(&self.layout),
            vertex: wgpu::VertexState {
                module: &self.shading,
                entry_point: Some(if terms { "vs_main_terms" } else { "vs_main" }),
                compilation_options: compilation_options.clone(),
                buffers: if terms { &buffers } else { &buffers[..1] },
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                front_face: wgpu::FrontFace::Ccw,
                cull_mode: options.cull_back_faces.then_some(wgpu::Face::Back),
                ..Default::default()
            },
            depth_stencil: target.depth_format.map(|format| wgpu::DepthStencilState {
                format,
                depth_write_enabled: Some(true),
                depth_compare: Some(options.depth_compare),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: wgpu::MultisampleState {
                count: target.sample_count,
                ..Default::default()
            },
            fragment: Some(wgpu::FragmentState {
                module: &self.shading,
                entry_point: Some("fs_main"),
                compilation_options,
                targets: &[Some(wgpu::ColorTargetState {
                    format: target.color_format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        if let Some(error) = pollster::block_on(scope.pop()) {
            return Err(PrepareError::Pipeline {
                target,
                message: error.to_string(),
            });
        }
        self.cache.insert(key, pipeline);
        if let Some(terms_pipeline) = terms_pipeline {
            self.compute_cache
                .insert((model, non_local), terms_pipeline);
        }
        Ok(())
    }

    /// The subsurface map pass's pipeline, if built.
    pub(crate) fn subsurface_map(&self) -> Option<&wgpu::RenderPipeline> {
        self.subsurface_map.as_ref()
    }

    /// Builds the subsurface map pass's pipeline unless built: `fs_subsurface_map` into the
    /// pyramid's level 0 (one pipeline for every model: what a material lets in is in its
    /// uniforms).
    pub(crate) fn ensure_subsurface_map(
        &mut self,
        device: &wgpu::Device,
    ) -> Result<(), PrepareError> {
        if self.subsurface_map.is_none() {
            let targets = SUBSURFACE_FORMATS.map(|format| Some(color_target(format)));
            let pipeline = self.light_view_pipeline(
                device,
                "cdrf subsurface map pipeline",
                "fs_subsurface_map",
                &[],
                &targets,
            )?;
            self.subsurface_map = Some(pipeline);
        }
        Ok(())
    }

    /// A pipeline of the passes that render the draws as the light sees them (`vs_light_view`, the
    /// light is the instance index) into maps: no culling (the first surface whatever its
    /// winding, as the shadow pass), its own depth test, `fragment` into `targets`. wgpu's
    /// validation error, if any, is returned.
    fn light_view_pipeline(
        &self,
        device: &wgpu::Device,
        label: &'static str,
        fragment: &'static str,
        constants: &[(&str, f64)],
        targets: &[Option<wgpu::ColorTargetState>],
    ) -> Result<wgpu::RenderPipeline, PrepareError> {
        let target_desc = |targets: &[Option<wgpu::ColorTargetState>]| {
            let format = targets
                .iter()
                .flatten()
                .next()
                .map_or(SUBSURFACE_FORMATS[0], |t| t.format);
            TargetDesc::new(format)
        };
        if let Some(message) = &self.shader_error {
            return Err(PrepareError::Pipeline {
                target: target_desc(targets),
                message: message.clone(),
            });
        }
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let compilation_options = wgpu::PipelineCompilationOptions {
            constants,
            ..Default::default()
        };
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(label),
            layout: Some(&self.layout),
            vertex: wgpu::VertexState {
                module: &self.light_view,
                entry_point: Some("vs_light_view"),
                compilation_options: compilation_options.clone(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: GpuVertex::STRIDE,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &GpuVertex::ATTRIBUTES,
                })],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: wgpu::TextureFormat::Depth32Float,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &self.light_view,
                entry_point: Some(fragment),
                compilation_options,
                targets,
            }),
            multiview_mask: None,
            cache: None,
        });
        if let Some(error) = pollster::block_on(scope.pop()) {
            return Err(PrepareError::Pipeline {
                target: target_desc(targets),
                message: error.to_string(),
            });
        }
        Ok(pipeline)
    }
}

/// A colour target written whole, without blending.
fn color_target(format: wgpu::TextureFormat) -> wgpu::ColorTargetState {
    wgpu::ColorTargetState {
        format,
        blend: None,
        write_mask: wgpu::ColorWrites::ALL,
    }
}

/// A boolean pipeline constant.
fn flag(on: bool) -> f64 {
    f64::from(u8::from(on))
}
