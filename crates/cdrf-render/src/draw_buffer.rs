//! The draw buffer: each draw's transforms and surface factors ([`GpuDraw`]), one per draw at a
//! dynamic offset, read by the shading pass (group 2) and the passes before it.

use cdrf_core::glam::{Mat3, Mat4};

use crate::gpu_types::{GpuDraw, uniform_size};
use crate::surface::SurfaceParameters;

/// The buffer and the room it has.
pub(crate) struct DrawBuffer {
    pub(crate) buffer: wgpu::Buffer,
    /// Bytes from one draw to the next (the device's uniform offset alignment).
    pub(crate) stride: u64,
    /// Draws it holds.
    capacity: u64,
}

impl DrawBuffer {
    pub(crate) fn new(device: &wgpu::Device) -> Self {
        let alignment = u64::from(device.limits().min_uniform_buffer_offset_alignment);
        let stride = uniform_size::<GpuDraw>().get().next_multiple_of(alignment);
        let capacity = 16;
        Self {
            buffer: create_draw_buffer(device, stride, capacity),
            stride,
            capacity,
        }
    }

    /// A zeroed staging area for `draws` draws, each at its offset.
    pub(crate) fn staging(&self, draws: usize) -> Vec<u8> {
        vec![0u8; draws * self.stride as usize]
    }

    /// Draw `index`'s offset in the buffer, bytes.
    pub(crate) fn offset(&self, index: usize) -> u32 {
        (index * self.stride as usize) as u32
    }

    /// Makes room for `draws` draws; returns whether the buffer is a new one (whose bind
    /// groups must be made again).
    pub(crate) fn reserve(&mut self, device: &wgpu::Device, draws: u64) -> bool {
        if draws <= self.capacity {
            return false;
        }
        self.capacity = draws.next_power_of_two();
        self.buffer = create_draw_buffer(device, self.stride, self.capacity);
        true
    }
}

/// Writes a draw's uniforms at its offset in `staging`.
pub(crate) fn stage_draw(staging: &mut [u8], offset: u32, uniforms: &GpuDraw) {
    let offset = offset as usize;
    staging[offset..offset + size_of::<GpuDraw>()].copy_from_slice(bytemuck::bytes_of(uniforms));
}

/// One draw's window of the draw buffer (moved by the dynamic offset).
pub(crate) fn draw_binding(buffer: &wgpu::Buffer) -> wgpu::BufferBinding<'_> {
    wgpu::BufferBinding {
        buffer,
        offset: 0,
        size: Some(uniform_size::<GpuDraw>()),
    }
}

/// A draw's uniforms, or `None` for a transform that is singular, mirroring (it would flip the
/// winding and cull the wrong faces) or not finite.
pub(crate) fn draw_uniforms(
    world_from_model: Mat4,
    surface: &SurfaceParameters,
) -> Option<GpuDraw> {
    let linear = Mat3::from_mat4(world_from_model);
    let determinant = linear.determinant();
    if !world_from_model.is_finite() || determinant < 1e-30 {
        return None;
    }
    Some(GpuDraw {
        world_from_model,
        normal_from_model: Mat4::from_mat3(linear.inverse().transpose()),
        base_color_factor: surface.base_color_factor,
        curvature_scale: 1.0 / determinant.cbrt(),
        normal_scale: surface.normal_scale,
        roughness_factor: surface.roughness_factor,
        surface_flags: surface.flags,
        emitter_first: 0,
    })
}

fn create_draw_buffer(device: &wgpu::Device, stride: u64, capacity: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("cdrf draw uniforms"),
        size: stride * capacity,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}
