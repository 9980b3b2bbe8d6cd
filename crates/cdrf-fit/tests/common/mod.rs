//! Helpers shared by the cdrf-fit integration tests.

use cdrf_core::Cdrf;
use cdrf_fit::curves::SphereSamples;
use cdrf_fit::dataset::Projection;
use cdrf_fit::sphere::{Circle, Sample, SphereView};
use glam::{Vec2, Vec3};

/// A sphere of radius `radius_mm` "photographed" like the bundled data set (orthographic, 512²,
/// radius 230 px, lit from the left, 2 px edge margin, pixel centres) from a known CDRF `model`
/// and view correction `g(φ)`, keeping the pixels with `keep(θ)`.
pub fn synthetic_sphere(
    model: &impl Cdrf,
    g: impl Fn(f32) -> Vec3,
    radius_mm: f32,
    keep: impl Fn(f32) -> bool,
) -> SphereSamples {
    synthetic_sphere_lit_from(model, g, radius_mm, Vec3::new(-1.0, 0.0, 0.0), keep)
}

/// [`synthetic_sphere`] lit from `to_light` (camera space, unit; the camera looks along −z).
pub fn synthetic_sphere_lit_from(
    model: &impl Cdrf,
    g: impl Fn(f32) -> Vec3,
    radius_mm: f32,
    to_light: Vec3,
    keep: impl Fn(f32) -> bool,
) -> SphereSamples {
    let view = SphereView::new(
        Circle {
            center_px: Vec2::splat(256.0),
            radius_px: 230.0,
        },
        Projection::Orthographic,
        512,
        512,
    );
    let mut samples = Vec::new();
    for row in 0..512 {
        for column in 0..512 {
            let Some(point) = view.point(column, row) else {
                continue;
            };
            if point.inside_by_px < 2.0 {
                continue;
            }
            let theta = point.normal.dot(to_light).clamp(-1.0, 1.0).acos();
            if !keep(theta) {
                continue;
            }
            let phi = point.normal.dot(point.to_camera).clamp(-1.0, 1.0).acos();
            samples.push(Sample {
                theta_rad: theta,
                phi_rad: phi,
                radiance: Vec3::from_array(model.reflectance(1.0 / radius_mm, theta)) * g(phi),
                view_dot_light: point.to_camera.dot(to_light),
                pixel: (row * 512 + column) as u32,
                code_step: Vec3::ZERO,
                lossy: false,
                ambient: Vec3::ZERO,
            });
        }
    }
    SphereSamples {
        curvature_per_mm: 1.0 / radius_mm,
        image_width: 512,
        samples,
    }
}
