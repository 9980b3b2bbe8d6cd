//! The shading pipelines, built on demand and cached per target, shading model and
//! non-local terms.

use std::collections::HashMap;

use cdrf_core::light::NonLocal;

use crate::error::PrepareError;
use crate::gpu_data::block_on;
use crate::gpu_types::GpuVertex;
use crate::shaders::{Model, shading_shader_source};
use crate::target::{LutFiltering, Options, TargetDesc};

/// The pipeline variants' key: target, shading model, non-local terms.
type PipelineKey = (TargetDesc, Model, NonLocal);

/// The shading shader, its layout and the pipelines built from them.
pub(crate) struct Pipelines {
    shader: wgpu::ShaderModule,
    layout: wgpu::PipelineLayout,
    cache: HashMap<PipelineKey, wgpu::RenderPipeline>,
}

impl Pipelines {
    /// `bind_group_layouts`: groups 0–3 (frame, material, draw, shadows).
    pub(crate) fn new(
        device: &wgpu::Device,
        bind_group_layouts: [&wgpu::BindGroupLayout; 4],
    ) -> Self {
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("cdrf shader"),
            source: wgpu::ShaderSource::Wgsl(shading_shader_source().into()),
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("cdrf pipeline layout"),
            bind_group_layouts: &bind_group_layouts.map(Some),
            immediate_size: 0,
        });
        Self {
            shader,
            layout,
            cache: HashMap::new(),
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

    /// Builds the pipeline of a variant unless cached. wgpu reports a target the device cannot
    /// use through an error scope, returned here instead of reaching the host's
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
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let flag = |on: bool| f64::from(u8::from(on));
        let constants = [
            ("MODEL", model as u32 as f64),
            (
                "MANUAL_FILTERING",
                flag(options.lut_filtering == LutFiltering::Manual),
            ),
            ("ENCODE_SRGB", flag(target.encodes_srgb_in_shader())),
            ("SHADOWS", flag(non_local.shadows)),
            ("TRANSMISSION", flag(non_local.transmission)),
        ];
        let compilation_options = wgpu::PipelineCompilationOptions {
            constants: &constants,
            ..Default::default()
        };
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("cdrf pipeline"),
            layout: Some(&self.layout),
            vertex: wgpu::VertexState {
                module: &self.shader,
                entry_point: Some("vs_main"),
                compilation_options: compilation_options.clone(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: GpuVertex::STRIDE,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &GpuVertex::ATTRIBUTES,
                })],
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
                module: &self.shader,
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
        if let Some(error) = block_on(scope.pop()) {
            return Err(PrepareError::Pipeline {
                target,
                message: error.to_string(),
            });
        }
        self.cache.insert(key, pipeline);
        Ok(())
    }
}
