//! The inter-reflection's GPU side: each mesh's patches (cut once, when the mesh is created)
//! and the frame's emitters, which the compute passes after the vertex terms fill, bounce and
//! gather (`cs_patch_emitters`, `cs_emitter_bounce`, `cs_vertex_interreflection`; what they
//! compute is documented at the top of `shaders/cdrf.wgsl`).

use cdrf_core::patches::SurfacePatches;
use wgpu::util::DeviceExt;

use crate::gpu_types::{GpuEmitter, GpuPatch, GpuPatchMember};
use crate::mesh::MeshDesc;

/// A mesh's patches on the GPU.
pub(crate) struct GpuPatches {
    pub(crate) patches: wgpu::Buffer,
    pub(crate) members: wgpu::Buffer,
    pub(crate) count: u32,
}

impl GpuPatches {
    /// Cuts the mesh into about `target_count` patches and uploads them; `None` when it has
    /// none (a mesh without area, or a count of 0).
    pub(crate) fn upload(
        device: &wgpu::Device,
        desc: &MeshDesc<'_>,
        target_count: u32,
    ) -> Option<Self> {
        let cut = SurfacePatches::build(
            desc.positions,
            desc.normals,
            desc.curvature_per_mm,
            desc.indices,
            target_count as usize,
        );
        if cut.patches.is_empty() {
            return None;
        }
        let patches: Vec<GpuPatch> = cut
            .patches
            .iter()
            .map(|patch| GpuPatch {
                centroid: patch.centroid,
                area: patch.area,
                normal: patch.normal,
                sagitta: patch.sagitta,
                curvature_per_mm: patch.curvature_per_mm,
                first_member: patch.first_member,
                member_count: patch.member_count,
                _pad0: 0,
            })
            .collect();
        let members: Vec<GpuPatchMember> = cut
            .members
            .iter()
            .map(|member| GpuPatchMember {
                vertex: member.vertex,
                weight: member.weight,
            })
            .collect();
        let storage = |label, contents: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        Some(Self {
            patches: storage("cdrf mesh patches", bytemuck::cast_slice(&patches)),
            members: storage("cdrf mesh patch members", bytemuck::cast_slice(&members)),
            count: patches.len() as u32,
        })
    }
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
}

fn create_emitter_buffer(device: &wgpu::Device, count: u32) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("cdrf emitters"),
        size: u64::from(count) * size_of::<GpuEmitter>() as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}
