//! What lies under the pointer: a ray cast against the mesh on the CPU, for the inspector's
//! (κ, θ) read-out and the LUT marker.

use cdrf_core::Mesh;
use cdrf_core::glam::Vec3;

/// The nearest surface point hit by a ray, in model space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// The triangle hit.
    pub triangle: usize,
    /// Barycentric weights of its three corners.
    pub barycentric: Vec3,
    /// Ray parameter of the hit (distance in model units for a unit direction).
    pub distance: f32,
}

impl Hit {
    /// A per-vertex value interpolated at the hit.
    pub fn interpolate<T>(&self, mesh: &Mesh, values: &[T]) -> T
    where
        T: Copy + std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>,
    {
        let [a, b, c] = mesh.triangles[self.triangle].map(|i| values[i as usize]);
        a * self.barycentric.x + b * self.barycentric.y + c * self.barycentric.z
    }
}

/// The nearest front-facing triangle hit by the ray (`origin`, `direction`) in model space,
/// Möller–Trumbore over every triangle (the bunny: ~10 µs; a million triangles: milliseconds,
/// only when the pointer moves).
pub fn pick(mesh: &Mesh, origin: Vec3, direction: Vec3) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    for (index, triangle) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = triangle.map(|i| mesh.positions[i as usize]);
        let (edge1, edge2) = (b - a, c - a);
        let p = direction.cross(edge2);
        let determinant = edge1.dot(p);
        // Back faces are culled when drawing, so they cannot be under the pointer either.
        if determinant <= f32::EPSILON * edge1.length() * edge2.length() {
            continue;
        }
        let inverse = 1.0 / determinant;
        let s = origin - a;
        let u = s.dot(p) * inverse;
        if !(0.0..=1.0).contains(&u) {
            continue;
        }
        let q = s.cross(edge1);
        let v = direction.dot(q) * inverse;
        if v < 0.0 || u + v > 1.0 {
            continue;
        }
        let distance = edge2.dot(q) * inverse;
        if distance > 0.0 && best.is_none_or(|hit| distance < hit.distance) {
            best = Some(Hit {
                triangle: index,
                barycentric: Vec3::new(1.0 - u - v, u, v),
                distance,
            });
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ray_hits_the_near_side_of_a_sphere_at_its_radius() {
        let sphere = Mesh::icosphere(10.0, 3);
        let hit = pick(&sphere, Vec3::new(0.5, 0.3, 50.0), Vec3::NEG_Z).expect("hit");
        let point = hit.interpolate(&sphere, &sphere.positions);
        assert!(point.z > 9.0, "near side: {point}");
        assert!((point.length() - 10.0).abs() < 0.1, "{point}");
        assert!((hit.distance - (50.0 - point.z)).abs() < 1e-3);
        let weights = hit.barycentric;
        assert!((weights.x + weights.y + weights.z - 1.0).abs() < 1e-5);
        assert!(pick(&sphere, Vec3::new(20.0, 0.0, 50.0), Vec3::NEG_Z).is_none());
        // From inside only back faces are crossed.
        assert!(pick(&sphere, Vec3::ZERO, Vec3::NEG_Z).is_none());
    }
}
