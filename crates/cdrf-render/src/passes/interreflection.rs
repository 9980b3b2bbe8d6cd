//! The inter-reflection: after the vertex terms, compute passes average each patch's exitance
//! into the frame's emitters (`cs_patch_emitters`), pass light between the patches bounce
//! after bounce (`cs_emitter_bounce`) and gather it at every vertex
//! (`cs_vertex_interreflection`). A mesh's patches are cut and uploaded with the mesh
//! (`mesh::GpuPatches`); what the passes compute is documented at the top of
//! `shaders/cdrf.wgsl`.

use crate::gpu_types::GpuEmitter;

/// The inter-reflection's compute pipelines of one shading model and set of non-local terms.
pub(crate) struct InterreflectionPipelines {
    /// `cs_patch_emitters`: each patch's exitance, averaged from its vertices' terms.
    pub(crate) patch_emitters: wgpu::ComputePipeline,
    /// `cs_emitter_bounce`: the light each patch receives from the others, sent on.
    pub(crate) emitter_bounce: wgpu::ComputePipeline,
    /// `cs_vertex_interreflection`: every vertex's gather of the emitters, answered with its
    /// CDRF.
    pub(crate) vertex_gather: wgpu::ComputePipeline,
}

impl InterreflectionPipelines {
    /// The three pipelines, made by `compute(label, entry point)`.
    pub(crate) fn new(
        compute: impl Fn(&'static str, &'static str) -> wgpu::ComputePipeline,
    ) -> Self {
        Self {
            patch_emitters: compute("cdrf patch emitters pipeline", "cs_patch_emitters"),
            emitter_bounce: compute("cdrf emitter bounce pipeline", "cs_emitter_bounce"),
            vertex_gather: compute(
                "cdrf vertex interreflection pipeline",
                "cs_vertex_interreflection",
            ),
        }
    }
}

/// What one dispatch of the inter-reflection runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Step {
    /// [`InterreflectionPipelines::patch_emitters`], over a run's patches.
    PatchEmitters,
    /// [`InterreflectionPipelines::emitter_bounce`], over a run's patches.
    EmitterBounce,
    /// [`InterreflectionPipelines::vertex_gather`], over a run's vertices.
    VertexGather,
}

impl Step {
    pub(crate) fn pipeline(self, pipelines: &InterreflectionPipelines) -> &wgpu::ComputePipeline {
        match self {
            Self::PatchEmitters => &pipelines.patch_emitters,
            Self::EmitterBounce => &pipelines.emitter_bounce,
            Self::VertexGather => &pipelines.vertex_gather,
        }
    }

    /// Whether it runs over patches (else over vertices).
    pub(crate) fn over_patches(self) -> bool {
        self != Self::VertexGather
    }
}

/// A dispatch of the inter-reflection over every run: its step, and the emitter buffer it reads
/// (0 or 1; it writes the other).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Stage {
    pub(crate) step: Step,
    pub(crate) source: usize,
}

/// The inter-reflection's dispatches in order, after the vertex terms: with emitters, their own
/// light into buffer 0, each further bounce into the other buffer, then the gather of the last;
/// without, the gather alone (of a blank emitter in buffer 0).
pub(crate) fn stages(emitter_count: u32, bounces: u32) -> Vec<Stage> {
    if emitter_count == 0 {
        return vec![Stage {
            step: Step::VertexGather,
            source: 0,
        }];
    }
    let mut stages = vec![Stage {
        step: Step::PatchEmitters,
        source: 1,
    }];
    let mut source = 0;
    for _ in 1..bounces.max(1) {
        stages.push(Stage {
            step: Step::EmitterBounce,
            source,
        });
        source = 1 - source;
    }
    stages.push(Stage {
        step: Step::VertexGather,
        source,
    });
    stages
}

/// The frame's emitters: two buffers the bounces read from and write to in turn.
pub(crate) struct Emitters {
    pub(crate) buffers: [wgpu::Buffer; 2],
    capacity: u32,
}

impl Emitters {
    pub(crate) fn new(device: &wgpu::Device) -> Self {
        Self {
            buffers: std::array::from_fn(|_| create_emitter_buffer(device, 1)),
            capacity: 1,
        }
    }

    /// Makes room for `count` emitters (keeps the buffers when they have it).
    pub(crate) fn reserve(&mut self, device: &wgpu::Device, count: u32) {
        if count > self.capacity {
            self.capacity = count.next_power_of_two();
            self.buffers = std::array::from_fn(|_| create_emitter_buffer(device, self.capacity));
        }
    }

    /// Buffer `index`'s first `count` emitters (at least one slot: a binding is never empty).
    pub(crate) fn binding(&self, index: usize, count: u32) -> wgpu::BindingResource<'_> {
        wgpu::BindingResource::Buffer(wgpu::BufferBinding {
            buffer: &self.buffers[index],
            offset: 0,
            size: wgpu::BufferSize::new(u64::from(count.max(1)) * size_of::<GpuEmitter>() as u64),
        })
    }

    /// Records clearing the first emitter of both buffers: what the gather reads when the
    /// frame has none.
    pub(crate) fn record_clear(&self, encoder: &mut wgpu::CommandEncoder) {
        for buffer in &self.buffers {
            encoder.clear_buffer(buffer, 0, Some(size_of::<GpuEmitter>() as u64));
        }
    }
}

fn create_emitter_buffer(device: &wgpu::Device, count: u32) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("cdrf emitters"),
        size: u64::from(count) * size_of::<GpuEmitter>() as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounces_alternate_the_emitter_buffers_and_the_gather_reads_the_last() {
        let stage = |step, source| Stage { step, source };
        use Step::*;
        assert_eq!(stages(0, 3), [stage(VertexGather, 0)]);
        assert_eq!(
            stages(10, 1),
            [stage(PatchEmitters, 1), stage(VertexGather, 0)]
        );
        assert_eq!(
            stages(10, 3),
            [
                stage(PatchEmitters, 1),
                stage(EmitterBounce, 0),
                stage(EmitterBounce, 1),
                stage(VertexGather, 0),
            ]
        );
        // At least one bounce: the emitters' own light.
        assert_eq!(stages(10, 0), stages(10, 1));
    }
}
