//! Analytic test shapes with exact vertex positions and normals: icosphere, ellipsoid, torus,
//! cuboid.

use std::collections::HashMap;
use std::f32::consts::TAU;

use glam::Vec3;

use super::Mesh;

impl Mesh {
    /// A sphere of `radius` centred at the origin: an icosahedron subdivided `subdivisions`
    /// times (each step splits every triangle into four), vertices projected onto the sphere,
    /// exact outward normals. `10·4ⁿ + 2` vertices, `20·4ⁿ` triangles.
    pub fn icosphere(radius: f32, subdivisions: u32) -> Self {
        let (directions, triangles) = unit_icosphere(subdivisions);
        Self {
            positions: directions.iter().map(|&d| d * radius).collect(),
            normals: directions,
            uvs: None,
            triangles,
        }
    }

    /// An axis-aligned box centred at the origin with the given half extents: six flat faces,
    /// each a grid of `subdivisions × subdivisions` quads (two triangles each) with its own
    /// vertices, so every vertex normal is its face's: `6·(n + 1)²` vertices, `12·n²` triangles.
    /// Its faces are flat: curvature 0 everywhere but the edges.
    ///
    /// # Panics
    /// If `subdivisions` is 0.
    pub fn cuboid(half_extents: Vec3, subdivisions: u32) -> Self {
        assert!(subdivisions >= 1, "a cuboid needs at least 1 subdivision");
        let n = subdivisions;
        let mut positions = Vec::new();
        let mut normals = Vec::new();
        let mut triangles = Vec::new();
        for axis in 0..3 {
            for sign in [-1.0f32, 1.0] {
                let mut normal = Vec3::ZERO;
                normal[axis] = sign;
                // Two directions across the face, ordered so (u × v) = normal: CCW from outside.
                let mut u = Vec3::ZERO;
                u[(axis + 1) % 3] = 1.0;
                let mut v = Vec3::ZERO;
                v[(axis + 2) % 3] = sign;
                let base = positions.len() as u32;
                for j in 0..=n {
                    for i in 0..=n {
                        let a = 2.0 * i as f32 / n as f32 - 1.0;
                        let b = 2.0 * j as f32 / n as f32 - 1.0;
                        positions.push((normal + a * u + b * v) * half_extents);
                        normals.push(normal);
                    }
                }
                for j in 0..n {
                    for i in 0..n {
                        let corner = base + j * (n + 1) + i;
                        let above = corner + n + 1;
                        triangles.push([corner, corner + 1, above + 1]);
                        triangles.push([corner, above + 1, above]);
                    }
                }
            }
        }
        Self {
            positions,
            normals,
            uvs: None,
            triangles,
        }
    }

    /// The ellipsoid `x²/a² + y²/b² + z²/c² = 1` with `radii = (a, b, c)`: the unit icosphere
    /// scaled per axis, so every vertex lies exactly on the surface; exact outward normals.
    pub fn ellipsoid(radii: Vec3, subdivisions: u32) -> Self {
        let (directions, triangles) = unit_icosphere(subdivisions);
        let positions: Vec<Vec3> = directions.iter().map(|&d| d * radii).collect();
        let normals = positions
            .iter()
            .map(|&p| (p / (radii * radii)).normalize())
            .collect();
        Self {
            positions,
            normals,
            uvs: None,
            triangles,
        }
    }

    /// A torus around the z axis centred at the origin, `major_radius` from the axis to the
    /// tube's centre, tube radius `minor_radius`: vertex `(i, j)` (index `i·segments_v + j`) is
    /// `((R + a cos v) cos u, (R + a cos v) sin u, a sin v)` with `u = 2πi/segments_u`,
    /// `v = 2πj/segments_v`. Closed (no seam vertices), outward winding, exact normals.
    ///
    /// # Panics
    /// If a segment count is below 3.
    pub fn torus(major_radius: f32, minor_radius: f32, segments_u: u32, segments_v: u32) -> Self {
        assert!(
            segments_u >= 3 && segments_v >= 3,
            "a torus needs at least 3 × 3 segments, got {segments_u} × {segments_v}"
        );
        let (nu, nv) = (segments_u, segments_v);
        let mut positions = Vec::with_capacity((nu * nv) as usize);
        let mut normals = Vec::with_capacity((nu * nv) as usize);
        for i in 0..nu {
            let u = TAU * i as f32 / nu as f32;
            for j in 0..nv {
                let v = TAU * j as f32 / nv as f32;
                let ring = major_radius + minor_radius * v.cos();
                positions.push(Vec3::new(
                    ring * u.cos(),
                    ring * u.sin(),
                    minor_radius * v.sin(),
                ));
                normals.push(Vec3::new(v.cos() * u.cos(), v.cos() * u.sin(), v.sin()));
            }
        }
        let index = |i: u32, j: u32| (i % nu) * nv + (j % nv);
        let mut triangles = Vec::with_capacity(2 * (nu * nv) as usize);
        for i in 0..nu {
            for j in 0..nv {
                let (a, b, c, d) = (
                    index(i, j),
                    index(i + 1, j),
                    index(i + 1, j + 1),
                    index(i, j + 1),
                );
                triangles.push([a, b, c]);
                triangles.push([a, c, d]);
            }
        }
        Self {
            positions,
            normals,
            uvs: None,
            triangles,
        }
    }
}

/// Unit directions and outward triangles of a subdivided icosahedron.
fn unit_icosphere(subdivisions: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let phi = (1.0 + 5f32.sqrt()) / 2.0;
    let mut vertices: Vec<Vec3> = [
        (-1.0, phi, 0.0),
        (1.0, phi, 0.0),
        (-1.0, -phi, 0.0),
        (1.0, -phi, 0.0),
        (0.0, -1.0, phi),
        (0.0, 1.0, phi),
        (0.0, -1.0, -phi),
        (0.0, 1.0, -phi),
        (phi, 0.0, -1.0),
        (phi, 0.0, 1.0),
        (-phi, 0.0, -1.0),
        (-phi, 0.0, 1.0),
    ]
    .into_iter()
    .map(|(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::with_capacity(triangles.len() * 2);
        let mut midpoint = |a: u32, b: u32, vertices: &mut Vec<Vec3>| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let m = (vertices[a as usize] + vertices[b as usize]).normalize();
                vertices.push(m);
                vertices.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for &[a, b, c] in &triangles {
            let ab = midpoint(a, b, &mut vertices);
            let bc = midpoint(b, c, &mut vertices);
            let ca = midpoint(c, a, &mut vertices);
            next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    (vertices, triangles)
}
