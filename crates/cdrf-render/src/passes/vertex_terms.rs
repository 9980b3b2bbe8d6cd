//! The vertex terms pass: a compute pass, after the light maps it reads, that writes each
//! vertex's non-local terms once per frame (`cs_vertex_terms`) into the terms buffer, which the
//! shading pass reads as its second vertex buffer; with the inter-reflection its stages follow
//! in the same pass ([`interreflection`](crate::passes::interreflection)).
//!
//! Draws that share a mesh, a material, the non-local terms and a transform share their terms:
//! the frame's draws are merged into *runs* by [`TermsKey`], each with its range of the buffer.

use std::collections::{HashMap, HashSet};

use cdrf_core::glam::Mat4;
use cdrf_core::light::NonLocal;

use crate::constants::{COMPUTE_WORKGROUP_SIZE, Model};
use crate::draw_buffer::draw_binding;
use crate::error::PrepareError;
use crate::gpu_types::{GpuPatch, GpuVertexTerms};
use crate::ids::{MaterialId, MeshId};
use crate::material::GpuMaterialEntry;
use crate::mesh::GpuMesh;
use crate::passes::interreflection::{self, Emitters, Step};
use crate::pipelines::{ComputePipelines, Pipelines, runs_vertex_terms};

/// Most workgroups in one row of a dispatch's grid.
const MAX_GROUPS_PER_ROW: u32 = 65_535;

/// A mesh where a draw puts it: the mesh and its transform's bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct PlacedMesh {
    pub(crate) mesh: MeshId,
    world_from_model_bits: [u32; 16],
}

impl PlacedMesh {
    pub(crate) fn new(mesh: MeshId, world_from_model: Mat4) -> Self {
        Self {
            mesh,
            world_from_model_bits: world_from_model.to_cols_array().map(f32::to_bits),
        }
    }
}

/// What a vertex's terms depend on: the placed mesh, the material and the non-local terms.
/// Draws with equal keys share one run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct TermsKey {
    pub(crate) placed: PlacedMesh,
    pub(crate) material: MaterialId,
    pub(crate) non_local: NonLocal,
}

/// A run's emitters in the frame's emitter buffers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct EmitterRange {
    pub(crate) first: u32,
    pub(crate) count: u32,
}

/// One run of the pass: a mesh's vertices under one transform, material and set of non-local
/// terms.
pub(crate) struct TermsRegion {
    key: TermsKey,
    model: Model,
    /// Its first draw's transforms in the draw buffer.
    draw_offset: u32,
    vertex_count: u32,
    /// Where its terms go in the terms buffer (bytes).
    pub(crate) range: std::ops::Range<u64>,
    /// With the inter-reflection, its mesh's patches as emitters (`None`: it sends out no light;
    /// another run of the same placed mesh does, or the mesh has no patches).
    pub(crate) emitters: Option<EmitterRange>,
}

/// The frame's runs, in the order of their first draws, and the buffer space they take.
pub(crate) struct TermsLayout {
    regions: Vec<TermsRegion>,
    index: HashMap<TermsKey, usize>,
    /// Placed meshes whose patches already send out light this frame (once each: another
    /// material on the same surface would send it twice).
    emitting: HashSet<PlacedMesh>,
    /// The end of the last run's terms, bytes.
    end: u64,
    emitter_count: u32,
    /// The device's storage offset alignment and the most vertices one binding holds terms for.
    alignment: u64,
    max_vertices: u64,
}

impl TermsLayout {
    pub(crate) fn new(limits: &wgpu::Limits) -> Self {
        Self {
            regions: Vec::new(),
            index: HashMap::new(),
            emitting: HashSet::new(),
            end: 0,
            emitter_count: 0,
            alignment: u64::from(limits.min_storage_buffer_offset_alignment),
            max_vertices: limits.max_storage_buffer_binding_size / GpuVertexTerms::STRIDE,
        }
    }

    /// The run of draw `index` (its key's, made if new, with the draw's transforms at
    /// `draw_offset`): its terms' range and emitters.
    ///
    /// # Errors
    /// [`PrepareError::TooManyVertices`] when the mesh has more vertices than one storage
    /// binding holds terms for.
    pub(crate) fn place(
        &mut self,
        index: usize,
        key: TermsKey,
        model: Model,
        mesh: &GpuMesh,
        draw_offset: u32,
    ) -> Result<&TermsRegion, PrepareError> {
        if let Some(&region) = self.index.get(&key) {
            return Ok(&self.regions[region]);
        }
        if u64::from(mesh.vertex_count) > self.max_vertices {
            return Err(PrepareError::TooManyVertices {
                index,
                vertices: mesh.vertex_count,
                max_vertices: self.max_vertices,
            });
        }
        let start = self.end.next_multiple_of(self.alignment);
        self.end = start + u64::from(mesh.vertex_count) * GpuVertexTerms::STRIDE;
        let emitters = match &mesh.patches {
            Some(patches) if key.non_local.interreflection && self.emitting.insert(key.placed) => {
                let first = self.emitter_count;
                self.emitter_count += patches.count;
                Some(EmitterRange {
                    first,
                    count: patches.count,
                })
            }
            _ => None,
        };
        self.index.insert(key, self.regions.len());
        self.regions.push(TermsRegion {
            key,
            model,
            draw_offset,
            vertex_count: mesh.vertex_count,
            range: start..self.end,
            emitters,
        });
        Ok(self.regions.last().expect("pushed above"))
    }

    pub(crate) fn is_empty(&self) -> bool {
        self.regions.is_empty()
    }
}

/// What the pass binds besides its own buffers.
pub(crate) struct TermsInputs<'a> {
    /// Group 0: the frame's camera and lights.
    pub(crate) frame: &'a wgpu::BindGroup,
    /// Group 3: the light maps.
    pub(crate) light_maps: &'a wgpu::BindGroup,
    /// The draw buffer (each run reads its first draw's transforms).
    pub(crate) draws: &'a wgpu::Buffer,
    pub(crate) meshes: &'a HashMap<MeshId, GpuMesh>,
    pub(crate) materials: &'a HashMap<MaterialId, GpuMaterialEntry>,
    pub(crate) pipelines: &'a Pipelines,
    /// Bounces of the inter-reflection ([`Options::interreflection_bounces`](crate::Options)).
    pub(crate) bounces: u32,
}

/// The pass's buffers.
pub(crate) struct VertexTermsPass {
    /// The terms of the last frame's runs, `capacity` bytes (grown as needed).
    pub(crate) buffer: wgpu::Buffer,
    capacity: u64,
    /// Bound in the place of a mesh's patches when it has none.
    no_patches: wgpu::Buffer,
    emitters: Emitters,
}

impl VertexTermsPass {
    pub(crate) fn new(device: &wgpu::Device) -> Self {
        let capacity = GpuVertexTerms::STRIDE;
        Self {
            buffer: create_terms_buffer(device, capacity),
            capacity,
            no_patches: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("cdrf no patches"),
                size: size_of::<GpuPatch>() as u64,
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            }),
            emitters: Emitters::new(device),
        }
    }

    /// Makes room for the layout's terms and emitters (a larger terms buffer is a new one).
    pub(crate) fn reserve(&mut self, device: &wgpu::Device, layout: &TermsLayout) {
        if layout.end > self.capacity {
            self.capacity = layout.end.next_power_of_two();
            self.buffer = create_terms_buffer(device, self.capacity);
        }
        self.emitters.reserve(device, layout.emitter_count);
    }

    /// Records the pass: each run's vertex terms, then the inter-reflection's stages.
    pub(crate) fn record(
        &self,
        device: &wgpu::Device,
        layout: &TermsLayout,
        inputs: &TermsInputs<'_>,
    ) -> wgpu::CommandBuffer {
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("cdrf vertex terms"),
        });
        let emitter_count = layout.emitter_count;
        if emitter_count == 0 {
            self.emitters.record_clear(&mut encoder);
        }
        let runs: Vec<Run<'_>> = layout
            .regions
            .iter()
            .filter_map(|region| self.run(device, region, emitter_count, inputs))
            .collect();
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("cdrf vertex terms"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, inputs.frame, &[0]); // view 0: the passes see no camera
        pass.set_bind_group(3, inputs.light_maps, &[]);
        dispatch(&mut pass, &runs, Kernel::VertexTerms, 1);
        for stage in interreflection::stages(emitter_count, inputs.bounces) {
            dispatch(
                &mut pass,
                &runs,
                Kernel::Interreflection(stage.step),
                stage.source,
            );
        }
        drop(pass);
        encoder.finish()
    }

    /// A region's pipelines, material and group 2 reading emitter buffer 0 or 1 (and writing
    /// the other); `None` when its mesh, material or pipelines are gone.
    fn run<'a>(
        &self,
        device: &wgpu::Device,
        region: &'a TermsRegion,
        emitter_count: u32,
        inputs: &TermsInputs<'a>,
    ) -> Option<Run<'a>> {
        let key = region.key;
        let mesh = inputs.meshes.get(&key.placed.mesh)?;
        let material = inputs.materials.get(&key.material)?;
        let pipelines = inputs.pipelines.compute(region.model, key.non_local)?;
        let layout = inputs.pipelines.terms_layout()?;
        let (patches, members) = match &mesh.patches {
            Some(patches) => (&patches.patches, &patches.members),
            None => (&self.no_patches, &self.no_patches),
        };
        let bind_group = |source: usize| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("cdrf vertex terms"),
                layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::Buffer(draw_binding(inputs.draws)),
                    },
                    wgpu::BindGroupEntry {
                        binding: 7,
                        resource: mesh.vertices.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 8,
                        resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: &self.buffer,
                            offset: region.range.start,
                            size: wgpu::BufferSize::new(region.range.end - region.range.start),
                        }),
                    },
                    wgpu::BindGroupEntry {
                        binding: 9,
                        resource: patches.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 10,
                        resource: members.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 11,
                        resource: self.emitters.binding(source, emitter_count),
                    },
                    wgpu::BindGroupEntry {
                        binding: 12,
                        resource: self.emitters.binding(1 - source, emitter_count),
                    },
                ],
            })
        };
        Some(Run {
            region,
            material: &material.bind_group,
            pipelines,
            bind_groups: [bind_group(0), bind_group(1)],
        })
    }
}

/// A region ready to dispatch.
struct Run<'a> {
    region: &'a TermsRegion,
    material: &'a wgpu::BindGroup,
    pipelines: &'a ComputePipelines,
    /// Group 2 reading emitter buffer 0, and reading buffer 1.
    bind_groups: [wgpu::BindGroup; 2],
}

/// What a dispatch runs: the vertex terms, or a stage of the inter-reflection.
#[derive(Clone, Copy)]
enum Kernel {
    VertexTerms,
    Interreflection(Step),
}

impl Kernel {
    /// A run's pipeline for it (`None`: the run has no inter-reflection).
    fn pipeline(self, pipelines: &ComputePipelines) -> Option<&wgpu::ComputePipeline> {
        match self {
            Self::VertexTerms => Some(&pipelines.vertex_terms),
            Self::Interreflection(step) => pipelines
                .interreflection
                .as_ref()
                .map(|interreflection| step.pipeline(interreflection)),
        }
    }

    /// Its invocations over a region: one per vertex, or per patch of its emitters (`None`:
    /// it sends out no light).
    fn invocations(self, region: &TermsRegion) -> Option<u32> {
        match self {
            Self::Interreflection(step) if step.over_patches() => {
                region.emitters.map(|emitters| emitters.count)
            }
            _ => Some(region.vertex_count),
        }
    }
}

/// One stage over every run (those without its pipeline or invocations are skipped), reading
/// emitter buffer `source`.
fn dispatch(pass: &mut wgpu::ComputePass<'_>, runs: &[Run<'_>], kernel: Kernel, source: usize) {
    for run in runs {
        let (Some(pipeline), Some(count)) = (
            kernel.pipeline(run.pipelines),
            kernel.invocations(run.region),
        ) else {
            continue;
        };
        pass.set_pipeline(pipeline);
        pass.set_bind_group(1, run.material, &[]);
        pass.set_bind_group(2, &run.bind_groups[source], &[run.region.draw_offset]);
        // On a grid whose rows hold at most MAX_GROUPS_PER_ROW groups.
        let groups = count.div_ceil(COMPUTE_WORKGROUP_SIZE);
        let columns = groups.clamp(1, MAX_GROUPS_PER_ROW);
        pass.dispatch_workgroups(columns, groups.div_ceil(columns), 1);
    }
}

/// The terms buffer: written by the pass, read as a vertex buffer (a vertex buffer only, never
/// written, on a device that does not run the pass).
fn create_terms_buffer(device: &wgpu::Device, size: u64) -> wgpu::Buffer {
    let usage = if runs_vertex_terms(&device.limits()) {
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::VERTEX
    } else {
        wgpu::BufferUsages::VERTEX
    };
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("cdrf vertex terms"),
        size,
        usage,
        mapped_at_creation: false,
    })
}
