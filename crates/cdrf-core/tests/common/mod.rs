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

/// An irregular triangulation of the ellipsoid with semi-axes `radii`, like a scanned mesh: the
/// convex hull of `count` random points (seeded xorshift, uniform on the unit sphere), scaled
/// to the ellipsoid (an affine map keeps a convex hull a convex hull, so this *is* the hull of
/// the scaled points). Triangles are the sphere's Delaunay triangles: random sizes, valences
/// 3 to ~10, slivers and obtuse corners, outward winding.
pub fn irregular_ellipsoid(radii: Vec3, count: usize, seed: u64) -> cdrf_core::mesh::Mesh {
    use glam::DVec3;
    assert!(count >= 4);
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut uniform = move || {
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        (state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    };
    let points: Vec<DVec3> = (0..count)
        .map(|_| {
            loop {
                let p = DVec3::new(uniform(), uniform(), uniform()) * 2.0 - 1.0;
                let l2 = p.length_squared();
                if l2 > 1e-6 && l2 <= 1.0 {
                    break p / l2.sqrt();
                }
            }
        })
        .collect();

    // Incremental hull. Every point on the sphere is a hull vertex, so each new point sees a
    // non-empty cap of faces: replace it by a fan from the point to the cap's boundary.
    let plane = |t: [u32; 3]| {
        let [a, b, c] = t.map(|i| points[i as usize]);
        let n = (b - a).cross(c - a);
        (n, n.dot(a))
    };
    let mut faces: Vec<([u32; 3], DVec3, f64)> = Vec::new();
    let add = |faces: &mut Vec<_>, t: [u32; 3]| {
        let (n, d) = plane(t);
        faces.push((t, n, d));
    };
    // Start: a tetrahedron on points 0..4, each face wound away from the centroid.
    let centroid = (points[0] + points[1] + points[2] + points[3]) / 4.0;
    for t in [[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0]] {
        let (n, d) = plane(t);
        add(
            &mut faces,
            if n.dot(centroid) > d {
                [t[0], t[2], t[1]]
            } else {
                t
            },
        );
    }
    let mut edges = std::collections::HashSet::new();
    for i in 4..count {
        let p = points[i];
        edges.clear();
        let mut k = 0;
        while k < faces.len() {
            let (t, n, d) = faces[k];
            if n.dot(p) - d > 1e-15 * n.length() {
                for e in 0..3 {
                    edges.insert((t[e], t[(e + 1) % 3]));
                }
                faces.swap_remove(k);
            } else {
                k += 1;
            }
        }
        assert!(!edges.is_empty(), "point {i} is inside the hull");
        for &(a, b) in &edges {
            if !edges.contains(&(b, a)) {
                add(&mut faces, [a, b, i as u32]);
            }
        }
    }
    let positions: Vec<Vec3> = points
        .iter()
        .map(|&p| (p * radii.as_dvec3()).as_vec3())
        .collect();
    let normals = points
        .iter()
        .map(|&p| (p / radii.as_dvec3()).normalize().as_vec3())
        .collect();
    cdrf_core::mesh::Mesh {
        positions,
        normals,
        uvs: None,
        triangles: faces.into_iter().map(|(t, _, _)| t).collect(),
    }
}
