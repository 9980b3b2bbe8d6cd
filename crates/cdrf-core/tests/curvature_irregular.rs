//! Mean curvature on irregular triangulations (the shape of scanned meshes): the convex hull of
//! random points on an ellipsoid, against the closed-form mean curvature.
//!
//! libigl's `principal_curvature` (a quadric fitted over a 5-ring) measured 2.0 % RMS relative
//! error on such a mesh (issue 18); we must do better.

mod common;

use cdrf_core::curvature::{CurvatureOptions, mean_curvature_per_mm};
use common::{ellipsoid_mean_curvature, irregular_ellipsoid, relative_error};
use glam::Vec3;

#[test]
fn irregular_ellipsoid_hull_beats_libigl() {
    let radii = Vec3::new(3.0, 2.0, 1.0);
    // Measured: 10 000 points RMS 1.88 %, 40 000 points 1.18 % (10 000 before the
    // irregular-ring blend and the 2-ring normal fit: 3.5 %). Max errors stay large (50–130 %)
    // at a few sliver vertices.
    for (count, seed) in [(10_000, 1), (40_000, 2)] {
        let mesh = irregular_ellipsoid(radii, count, seed);
        assert_eq!(mesh.triangles.len(), 2 * count - 4, "a closed genus-0 hull");
        let truth: Vec<f64> = mesh
            .positions
            .iter()
            .map(|&p| ellipsoid_mean_curvature(radii, p))
            .collect();
        let estimate =
            mean_curvature_per_mm(&mesh, &CurvatureOptions::default()).expect("valid mesh");
        let error = relative_error(&estimate, &truth);
        println!("irregular ellipsoid 3:2:1 hull of {count} random points: {error}");
        assert!(
            error.rms < 0.02,
            "{count} points: {error}; libigl: 2.0 % RMS"
        );
    }
}
