//! The frame's uniforms (group 0): camera, lights, exposure and environment, checked and laid
//! out as the shaders read them; one copy per view of the frame ([`ViewBuffer`]).

use cdrf_core::environment::sh_basis_factors;
use cdrf_core::glam::Vec3;
use cdrf_core::light::Light;

use crate::constants::{
    ENVIRONMENT_SH_ORDER, GPU_LIGHT_DIRECTIONAL, GPU_LIGHT_POINT, GPU_LIGHT_SPOT, MAX_LIGHTS,
};
use crate::error::PrepareError;
use crate::frame::{FrameDesc, MAX_EXPOSURE, ToCamera, View};
use crate::gpu_types::{GpuFrame, GpuLight, uniform_size};

/// The frame's camera and lights, checked.
pub(crate) fn frame_uniforms(frame: &FrameDesc<'_>) -> Result<GpuFrame, PrepareError> {
    let needs_units =
        frame.non_local.any() || frame.directional_lights().count() < frame.lights.len();
    if needs_units && !(frame.mm_per_world_unit.is_finite() && frame.mm_per_world_unit > 0.0) {
        return Err(PrepareError::BadUnits {
            mm_per_world_unit: frame.mm_per_world_unit,
        });
    }
    if frame.lights.len() > MAX_LIGHTS {
        return Err(PrepareError::TooManyLights {
            count: frame.lights.len(),
        });
    }
    let mut uniforms = GpuFrame {
        light_count: frame.lights.len() as u32,
        mm_per_world_unit: frame.mm_per_world_unit,
        ..bytemuck::Zeroable::zeroed()
    };
    for (index, light) in frame.lights.iter().enumerate() {
        gpu_light(light).map_err(|problem| PrepareError::BadLight { index, problem })?;
    }
    for (slot, light) in uniforms
        .lights
        .iter_mut()
        .zip(frame.lights_in_shading_order())
    {
        *slot = gpu_light(light).expect("checked above");
    }
    set_view(&mut uniforms, &frame.view, frame.exposure)?;
    if let Some(sh) = frame.environment {
        if sh.coefficients.iter().flatten().any(|c| !c.is_finite()) {
            return Err(PrepareError::BadEnvironment);
        }
        let bands = (sh.order() + 1).min(ENVIRONMENT_SH_ORDER + 1);
        let factors = sh_basis_factors(bands - 1);
        for ((slot, c), factor) in uniforms
            .environment_sh
            .iter_mut()
            .zip(&sh.coefficients)
            .zip(&factors)
        {
            *slot = [c[0] * factor, c[1] * factor, c[2] * factor, 0.0];
        }
        uniforms.environment_bands = if sh.coefficients.is_empty() {
            0
        } else {
            bands as u32
        };
    }
    Ok(uniforms)
}

/// Puts a view (camera and exposure) into the frame's uniforms, or says what is wrong with it.
pub(crate) fn set_view(
    uniforms: &mut GpuFrame,
    view: &View,
    exposure: f32,
) -> Result<(), PrepareError> {
    let (to_camera, is_point) = match view.to_camera {
        ToCamera::Point(eye) => (eye, true),
        ToCamera::Direction(direction) => (direction.normalize_or_zero(), false),
    };
    if !view.clip_from_world.is_finite()
        || !to_camera.is_finite()
        || (!is_point && to_camera == Vec3::ZERO)
    {
        return Err(PrepareError::BadView);
    }
    if !(0.0..=MAX_EXPOSURE).contains(&exposure) {
        return Err(PrepareError::BadExposure { exposure });
    }
    uniforms.clip_from_world = view.clip_from_world;
    uniforms.to_camera = to_camera;
    uniforms.camera_is_point = u32::from(is_point);
    uniforms.exposure = exposure;
    Ok(())
}

/// The frame's uniforms once per view, each at a dynamic offset: view 0 is the
/// [`FrameDesc`]'s, further views copy it with their own camera and exposure. The passes
/// before the shading read view 0 (they do not depend on the camera).
pub(crate) struct ViewBuffer {
    layout: wgpu::BindGroupLayout,
    buffer: wgpu::Buffer,
    pub(crate) bind_group: wgpu::BindGroup,
    /// Bytes from one view to the next (the device's uniform offset alignment).
    stride: u64,
    /// The views of the last `prepare`, view 0 first.
    views: Vec<GpuFrame>,
}

impl ViewBuffer {
    pub(crate) fn new(device: &wgpu::Device, layout: wgpu::BindGroupLayout) -> Self {
        let alignment = u64::from(device.limits().min_uniform_buffer_offset_alignment);
        let stride = uniform_size::<GpuFrame>().get().next_multiple_of(alignment);
        let (buffer, bind_group) = Self::create(device, &layout, stride, 1);
        Self {
            layout,
            buffer,
            bind_group,
            stride,
            views: Vec::new(),
        }
    }

    fn create(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        stride: u64,
        capacity: u64,
    ) -> (wgpu::Buffer, wgpu::BindGroup) {
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cdrf frame uniforms"),
            size: stride * capacity,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cdrf frame"),
            layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &buffer,
                    offset: 0,
                    size: Some(uniform_size::<GpuFrame>()),
                }),
            }],
        });
        (buffer, bind_group)
    }

    /// Forgets the last frame's views (a `prepare` begins).
    pub(crate) fn clear(&mut self) {
        self.views.clear();
    }

    /// The frame's own view (view 0); drops the previous frame's other views.
    pub(crate) fn set_frame(&mut self, queue: &wgpu::Queue, uniforms: GpuFrame) {
        self.views.clear();
        self.views.push(uniforms);
        queue.write_buffer(&self.buffer, 0, bytemuck::bytes_of(&uniforms));
    }

    /// Adds a view of the frame set last; returns its index. A new buffer, when it needs
    /// more room, holds every view again (commands recorded earlier keep the old one).
    /// [`PrepareError::NotPrepared`] when no frame is set (none yet, or its `prepare` failed).
    pub(crate) fn add_view(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        view: &View,
        exposure: f32,
    ) -> Result<usize, PrepareError> {
        let mut uniforms = *self.views.first().ok_or(PrepareError::NotPrepared)?;
        set_view(&mut uniforms, view, exposure)?;
        let index = self.views.len();
        self.views.push(uniforms);
        let needed = self.views.len() as u64 * self.stride;
        if needed > self.buffer.size() {
            let capacity = (self.views.len() as u64).next_power_of_two();
            (self.buffer, self.bind_group) =
                Self::create(device, &self.layout, self.stride, capacity);
            for (i, view) in self.views.iter().enumerate() {
                queue.write_buffer(&self.buffer, self.offset_of(i), bytemuck::bytes_of(view));
            }
        } else {
            queue.write_buffer(
                &self.buffer,
                self.offset_of(index),
                bytemuck::bytes_of(&uniforms),
            );
        }
        Ok(index)
    }

    fn offset_of(&self, view: usize) -> u64 {
        view as u64 * self.stride
    }

    /// View `view`'s dynamic offset, if the last frame has it.
    pub(crate) fn offset(&self, view: usize) -> Option<u32> {
        (view < self.views.len()).then(|| self.offset_of(view) as u32)
    }
}

/// One light as the shader holds it, or what is wrong with it.
fn gpu_light(light: &Light) -> Result<GpuLight, &'static str> {
    let unit = |v: Vec3, what| {
        if v.is_finite() && v.length_squared() >= 1e-12 {
            Ok(v.normalize())
        } else {
            Err(what)
        }
    };
    let colour = |c: [f32; 3], what| {
        if c.iter().all(|e| e.is_finite() && *e >= 0.0) {
            Ok(Vec3::from_array(c))
        } else {
            Err(what)
        }
    };
    let position = |p: Vec3| {
        if p.is_finite() {
            Ok(p)
        } else {
            Err("position is not finite")
        }
    };
    Ok(match *light {
        Light::Directional(light) => GpuLight {
            to_light: unit(light.to_light, "direction is zero or not finite")?,
            kind: GPU_LIGHT_DIRECTIONAL,
            irradiance: colour(light.irradiance, "irradiance must be finite and ≥ 0")?,
            ..bytemuck::Zeroable::zeroed()
        },
        Light::Point(light) => GpuLight {
            position: position(light.position)?,
            kind: GPU_LIGHT_POINT,
            intensity: colour(light.intensity, "intensity must be finite and ≥ 0")?,
            ..bytemuck::Zeroable::zeroed()
        },
        Light::Spot(light) => {
            let (inner, outer) = (light.inner_angle_rad, light.outer_angle_rad);
            // (NaN fails every comparison.)
            if !(0.0 <= inner && inner < outer && outer <= std::f32::consts::FRAC_PI_2) {
                return Err("spot angles must satisfy 0 ≤ inner < outer ≤ π/2");
            }
            GpuLight {
                position: position(light.position)?,
                kind: GPU_LIGHT_SPOT,
                intensity: colour(light.intensity, "intensity must be finite and ≥ 0")?,
                spot_cos_outer: outer.cos(),
                spot_direction: unit(light.direction, "spot direction is zero or not finite")?,
                spot_cos_inner: inner.cos(),
                ..bytemuck::Zeroable::zeroed()
            }
        }
    })
}
