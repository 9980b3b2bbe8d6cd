//! The frame's uniforms (group 0): camera, lights, exposure and environment, checked and laid
//! out as the shaders read them.

use cdrf_core::environment::sh_basis_factors;
use cdrf_core::glam::Vec3;
use cdrf_core::light::Light;

use crate::constants::{
    ENVIRONMENT_SH_ORDER, GPU_LIGHT_DIRECTIONAL, GPU_LIGHT_POINT, GPU_LIGHT_SPOT, MAX_LIGHTS,
};
use crate::error::PrepareError;
use crate::frame::{FrameDesc, MAX_EXPOSURE, ToCamera};
use crate::gpu_types::{GpuFrame, GpuLight};

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
        clip_from_world: frame.view.clip_from_world,
        exposure: frame.exposure,
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
    let (to_camera, is_point) = match frame.view.to_camera {
        ToCamera::Point(eye) => (eye, true),
        ToCamera::Direction(direction) => (direction.normalize_or_zero(), false),
    };
    if !frame.view.clip_from_world.is_finite()
        || !to_camera.is_finite()
        || (!is_point && to_camera == Vec3::ZERO)
    {
        return Err(PrepareError::BadView);
    }
    if !(0.0..=MAX_EXPOSURE).contains(&frame.exposure) {
        return Err(PrepareError::BadExposure {
            exposure: frame.exposure,
        });
    }
    uniforms.to_camera = to_camera;
    uniforms.camera_is_point = u32::from(is_point);
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
