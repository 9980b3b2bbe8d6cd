//! The CDRF look-up table.

/// A curvature-dependent reflectance function f(κ, θ).
///
/// Values are in the LUT's radiance convention, **π·L/E** per RGB channel: a white Lambertian
/// surface gives `max(cos θ, 0)`. `curvature_per_mm` is the mean curvature κ = 1/r in mm⁻¹ and
/// `theta_rad` the angle between the surface normal and the direction to the light, in
/// `[0, π]`.
pub trait Cdrf {
    /// f(κ, θ) per RGB channel, π·L/E.
    fn reflectance(&self, curvature_per_mm: f32, theta_rad: f32) -> [f32; 3];
}

/// Placeholder until the table lands.
pub struct CdrfLut;
