//! Analytic mean curvatures and error measures shared by the curvature tests and the benchmark
//! (`benches/curvature.rs` includes this file by path).

#![allow(dead_code)] // each including crate uses a different subset

use glam::Vec3;

/// Mean curvature of the torus `((R + a cos v) cos u, (R + a cos v) sin u, a sin v)` (axis z,
/// centred at the origin) at the surface point `p`, with outward normals:
/// `H = (R + 2a cos v) / (2a (R + a cos v))`, `v` measured from the outer equator.
pub fn torus_mean_curvature(major: f64, minor: f64, p: Vec3) -> f64 {
    let p = p.as_dvec3();
    let rho = (p.x * p.x + p.y * p.y).sqrt();
    let v = p.z.atan2(rho - major);
    (major + 2.0 * minor * v.cos()) / (2.0 * minor * (major + minor * v.cos()))
}

/// Mean curvature of the ellipsoid `x²/a² + y²/b² + z²/c² = 1` at the surface point `p`, outward
/// normals (positive): `H = (a² + b² + c² − |p|²) / (2 a²b²c² h³)`,
/// `h = √(x²/a⁴ + y²/b⁴ + z²/c⁴)`.
pub fn ellipsoid_mean_curvature(radii: Vec3, p: Vec3) -> f64 {
    let (r, p) = (radii.as_dvec3(), p.as_dvec3());
    let (a2, b2, c2) = (r.x * r.x, r.y * r.y, r.z * r.z);
    let h = (p.x * p.x / (a2 * a2) + p.y * p.y / (b2 * b2) + p.z * p.z / (c2 * c2)).sqrt();
    (a2 + b2 + c2 - p.length_squared()) / (2.0 * a2 * b2 * c2 * h * h * h)
}

/// RMS and maximum of the relative error `(estimate − truth) / truth`.
#[derive(Clone, Copy, Debug)]
pub struct RelativeError {
    pub rms: f64,
    pub max: f64,
}

impl std::fmt::Display for RelativeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "RMS relative error {:.4} %, max {:.4} %",
            100.0 * self.rms,
            100.0 * self.max
        )
    }
}

pub fn relative_error(estimate: &[f32], truth: &[f64]) -> RelativeError {
    assert_eq!(estimate.len(), truth.len());
    let mut sum = 0.0;
    let mut max = 0.0f64;
    for (&e, &t) in estimate.iter().zip(truth) {
        let r = (f64::from(e) - t) / t;
        sum += r * r;
        max = max.max(r.abs());
    }
    RelativeError {
        rms: (sum / truth.len() as f64).sqrt(),
        max,
    }
}
