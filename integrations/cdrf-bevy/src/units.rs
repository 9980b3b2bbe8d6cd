//! Bevy's photometric light units → cdrf's radiometric ones.
//!
//! Bevy shades in linear HDR values where a `DirectionalLight` of `illuminance` lux and linear
//! colour `c` lights a surface facing it with irradiance `c · illuminance`, and a white
//! Lambertian surface returns radiance `E/π` (then the camera's exposure scales it). cdrf
//! renders `L = E/π · f(κ, θ)`, so the numbers carry over unchanged:
//!
//! | Bevy | cdrf |
//! |---|---|
//! | `DirectionalLight { illuminance: lux, color }` | `DirectionalLight { irradiance: color · lux }` |
//! | `PointLight { intensity: lumens, color }` | `PointLight { intensity: color · lumens/(4π) · mm_per_unit² }` |
//! | `SpotLight { intensity: lumens, color, inner/outer_angle }` | the same intensity on the axis, the same angles |
//! | `GlobalAmbientLight { brightness: cd/m², color }` | a uniform sky of radiance `color · brightness` |
//! | world units (metres) | `mm_per_unit` (1000) mm each |
//!
//! Bevy divides a point or spot light's lumens by 4π to candela (both kinds alike); cdrf's
//! intensity is irradiance × mm², so E = I / d_mm² equals Bevy's cd / d_units². Bevy's range
//! window (the falloff to zero at `range`) and its light radius are not modelled: inside the
//! range cdrf follows the inverse square exactly.

use std::f32::consts::PI;

/// Irradiance per RGB channel of a directional light of `illuminance_lux` and linear colour.
pub fn directional_irradiance(linear_color: [f32; 3], illuminance_lux: f32) -> [f32; 3] {
    linear_color.map(|c| c * illuminance_lux)
}

/// cdrf's intensity (irradiance × mm²) of a point or spot light of `power_lm` lumens and linear
/// colour, in a world of `mm_per_unit` millimetres per unit.
pub fn point_intensity(linear_color: [f32; 3], power_lm: f32, mm_per_unit: f32) -> [f32; 3] {
    let candela = power_lm / (4.0 * PI);
    linear_color.map(|c| c * candela * mm_per_unit * mm_per_unit)
}

/// The radiance of the uniform sky that stands for Bevy's ambient light of `brightness` cd/m².
pub fn ambient_radiance(linear_color: [f32; 3], brightness: f32) -> [f32; 3] {
    linear_color.map(|c| c * brightness)
}

#[cfg(test)]
mod tests {
    use super::*;
    use cdrf_core::glam::Vec3;
    use cdrf_core::light::{Light, PointLight};

    /// A Bevy point light of P lumens 2 m away lights a surface facing it with P/(4π)/2² lux;
    /// cdrf's point light of the converted intensity gives that irradiance.
    #[test]
    fn a_point_light_gives_bevys_irradiance_at_a_distance() {
        let (power_lm, distance_units, mm_per_unit) = (800.0, 2.0, 1000.0);
        let color = [1.0, 0.5, 0.25];
        let bevy_lux = power_lm / (4.0 * PI) / (distance_units * distance_units);
        let light = Light::Point(PointLight {
            position: Vec3::new(0.0, distance_units, 0.0),
            intensity: point_intensity(color, power_lm, mm_per_unit),
        });
        let incidence = light.incidence(Vec3::ZERO, mm_per_unit);
        for channel in 0..3 {
            let expected = color[channel] * bevy_lux;
            let got = incidence.irradiance[channel];
            assert!(
                (got - expected).abs() <= 1e-5 * expected,
                "channel {channel}: {got} vs Bevy's {expected}"
            );
        }
        assert!((incidence.to_light - Vec3::Y).length() < 1e-6);
    }

    #[test]
    fn a_directional_light_keeps_its_lux_as_irradiance() {
        assert_eq!(
            directional_irradiance([1.0, 0.5, 0.0], 10_000.0),
            [10_000.0, 5_000.0, 0.0]
        );
    }

    #[test]
    fn ambient_brightness_is_the_skys_radiance() {
        assert_eq!(ambient_radiance([0.5, 1.0, 1.0], 80.0), [40.0, 80.0, 80.0]);
    }
}
