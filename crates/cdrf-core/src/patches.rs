//! A mesh's surface cut into small, nearly flat patches: the emitters and receivers of the
//! renderer's inter-reflection.
//!
//! Light that leaves one part of a translucent object through the air and enters another — from
//! its lit side, and from the glow of its shadow side, bounce after bounce — is gathered between
//! patches rather than between vertices (the cost is vertices × patches instead of vertices²).
//! A patch is a group of nearby vertices whose normals agree: its area (the sum of its vertices'
//! shares of their triangles), its area-weighted centroid and normal, its mean curvature and its
//! *sagitta*, how far its vertices rise above the plane through its centroid (a curved patch's
//! centroid lies below its surface; a point must lie farther in front of the patch than that to
//! see it as an emitter, or a convex surface would light itself).
//!
//! The cut is deterministic: farthest-point seeds (in space), then a few rounds of assigning
//! each vertex to the nearest seed by distance *and* normal (so the two sides of a thin part
//! never share a patch) and moving each seed to its patch's centroid.
//!
//! ```
//! use cdrf_core::patches::SurfacePatches;
//! use cdrf_core::glam::Vec3;
//!
//! // A unit square of two triangles, cut into (at most) one patch.
//! let positions = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
//! let normals = [Vec3::Z; 4];
//! let curvature = [0.0; 4];
//! let patches = SurfacePatches::build(&positions, &normals, &curvature, &[0, 1, 2, 0, 2, 3], 1);
//! assert_eq!(patches.patches.len(), 1);
//! assert!((patches.patches[0].area - 1.0).abs() < 1e-6);
//! assert_eq!(patches.patches[0].normal, Vec3::Z);
//! ```

use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// How strongly normals that disagree push a vertex away from a seed, in squared patch
/// spacings per unit of (1 − cos angle): opposite normals weigh as 2·√(2·WEIGHT) ≈ 4
/// spacings of distance, so the two faces of a part thinner than that stay apart.
const NORMAL_WEIGHT: f64 = 4.0;
/// Rounds of assignment and re-centring after the farthest-point seeds.
const LLOYD_ROUNDS: usize = 3;

/// One patch (model units, as the mesh's positions).
#[derive(Clone, Debug, PartialEq)]
pub struct SurfacePatch {
    /// Area-weighted centroid of its vertices.
    pub centroid: Vec3,
    /// Area-weighted mean normal, unit length.
    pub normal: Vec3,
    /// Its area: the sum of its vertices' shares (a third of each triangle they touch).
    pub area: f32,
    /// How far its farthest vertex lies in front of the plane through the centroid.
    pub sagitta: f32,
    /// Area-weighted mean curvature of its vertices (as given, mm⁻¹).
    pub curvature_per_mm: f32,
    /// Its vertices: `members[first_member .. first_member + member_count]`.
    pub first_member: u32,
    /// How many vertices it has (at least one).
    pub member_count: u32,
}

/// One vertex of a patch and its share of the patch's area (the shares of a patch sum to 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchMember {
    /// Index into the mesh's vertices.
    pub vertex: u32,
    /// Its area over the patch's.
    pub weight: f32,
}

/// The patches of one mesh (see the module documentation).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SurfacePatches {
    /// The patches, none empty.
    pub patches: Vec<SurfacePatch>,
    /// Every vertex with area, grouped by patch.
    pub members: Vec<PatchMember>,
}

impl SurfacePatches {
    /// Cuts a triangle mesh into about `target_count` patches (fewer when it has fewer
    /// vertices with area; none for an empty mesh or `target_count` 0). Positions and normals
    /// per vertex, `curvature_per_mm` per vertex (averaged per patch), `indices` three per
    /// triangle; indices out of range and degenerate triangles are skipped.
    pub fn build(
        positions: &[Vec3],
        normals: &[Vec3],
        curvature_per_mm: &[f32],
        indices: &[u32],
        target_count: usize,
    ) -> SurfacePatches {
        let areas = vertex_areas(positions, indices);
        let vertices: Vec<usize> = (0..positions.len())
            .filter(|&v| areas[v] > 0.0 && v < normals.len() && v < curvature_per_mm.len())
            .collect();
        let count = target_count.min(vertices.len());
        if count == 0 {
            return SurfacePatches::default();
        }
        let position = |v: usize| positions[v].as_dvec3();
        let normal = |v: usize| normals[v].as_dvec3().normalize_or_zero();
        let total_area: f64 = vertices.iter().map(|&v| areas[v]).sum();
        // The spacing of `count` square patches of the whole area.
        let spacing2 = total_area / count as f64;

        // Farthest-point seeds, from the first vertex with area.
        let mut seeds: Vec<(DVec3, DVec3)> = Vec::with_capacity(count);
        let mut nearest2 = vec![f64::INFINITY; vertices.len()];
        let mut next = 0;
        for _ in 0..count {
            let v = vertices[next];
            let seed = position(v);
            seeds.push((seed, normal(v)));
            nearest2
                .par_iter_mut()
                .zip(&vertices)
                .for_each(|(d2, &u)| *d2 = d2.min(position(u).distance_squared(seed)));
            next = farthest(&nearest2);
        }

        let mut assignment = vec![0usize; vertices.len()];
        for _ in 0..LLOYD_ROUNDS {
            assignment
                .par_iter_mut()
                .zip(&vertices)
                .for_each(|(patch, &v)| {
                    let (p, n) = (position(v), normal(v));
                    let cost = |(s, m): &(DVec3, DVec3)| {
                        p.distance_squared(*s) + NORMAL_WEIGHT * spacing2 * (1.0 - n.dot(*m))
                    };
                    *patch = (0..seeds.len())
                        .min_by(|&a, &b| cost(&seeds[a]).total_cmp(&cost(&seeds[b])))
                        .expect("at least one seed");
                });
            let mut sums = vec![(DVec3::ZERO, DVec3::ZERO, 0.0f64); seeds.len()];
            for (&patch, &v) in assignment.iter().zip(&vertices) {
                let sum = &mut sums[patch];
                sum.0 += areas[v] * position(v);
                sum.1 += areas[v] * normal(v);
                sum.2 += areas[v];
            }
            for (seed, (p, n, a)) in seeds.iter_mut().zip(sums) {
                if a > 0.0 {
                    *seed = (p / a, n.try_normalize().unwrap_or(seed.1));
                }
            }
        }

        // Group the vertices by patch (stable: by vertex index within a patch).
        let mut order: Vec<usize> = (0..vertices.len()).collect();
        order.sort_by_key(|&i| (assignment[i], vertices[i]));
        let mut patches = Vec::new();
        let mut members = Vec::with_capacity(vertices.len());
        let mut start = 0;
        while start < order.len() {
            let patch = assignment[order[start]];
            let end = start
                + order[start..]
                    .iter()
                    .take_while(|&&i| assignment[i] == patch)
                    .count();
            let group: Vec<usize> = order[start..end].iter().map(|&i| vertices[i]).collect();
            let area: f64 = group.iter().map(|&v| areas[v]).sum();
            let centroid = group.iter().map(|&v| areas[v] * position(v)).sum::<DVec3>() / area;
            let summed_normal = group.iter().map(|&v| areas[v] * normal(v)).sum::<DVec3>();
            let normal = summed_normal.try_normalize().unwrap_or(seeds[patch].1);
            let sagitta = group
                .iter()
                .map(|&v| normal.dot(position(v) - centroid))
                .fold(0.0f64, f64::max);
            let curvature = group
                .iter()
                .map(|&v| areas[v] * f64::from(curvature_per_mm[v]))
                .sum::<f64>()
                / area;
            patches.push(SurfacePatch {
                centroid: centroid.as_vec3(),
                normal: normal.as_vec3(),
                area: area as f32,
                sagitta: sagitta as f32,
                curvature_per_mm: curvature as f32,
                first_member: members.len() as u32,
                member_count: group.len() as u32,
            });
            members.extend(group.iter().map(|&v| PatchMember {
                vertex: v as u32,
                weight: (areas[v] / area) as f32,
            }));
            start = end;
        }
        SurfacePatches { patches, members }
    }
}

/// Each vertex's share of the area of the triangles it belongs to (a third of each).
fn vertex_areas(positions: &[Vec3], indices: &[u32]) -> Vec<f64> {
    let mut areas = vec![0.0f64; positions.len()];
    for triangle in indices.chunks_exact(3) {
        let [a, b, c] = [triangle[0], triangle[1], triangle[2]].map(|i| i as usize);
        if a.max(b).max(c) >= positions.len() {
            continue;
        }
        let [pa, pb, pc] = [a, b, c].map(|i| positions[i].as_dvec3());
        let third = 0.5 * (pb - pa).cross(pc - pa).length() / 3.0;
        if !third.is_finite() {
            continue;
        }
        for i in [a, b, c] {
            areas[i] += third;
        }
    }
    areas
}

/// The index of the largest value (the first of equals).
fn farthest(values: &[f64]) -> usize {
    let mut best = 0;
    for (i, &value) in values.iter().enumerate() {
        if value > values[best] {
            best = i;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Mesh;

    fn sphere_patches(target: usize) -> (Mesh, SurfacePatches, Vec<u32>) {
        let mesh = Mesh::icosphere(1.0, 4);
        let curvature = vec![1.0; mesh.positions.len()];
        let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
        let patches =
            SurfacePatches::build(&mesh.positions, &mesh.normals, &curvature, &indices, target);
        (mesh, patches, indices)
    }

    #[test]
    fn patches_cover_the_area_once() {
        let (mesh, patches, indices) = sphere_patches(64);
        assert_eq!(patches.patches.len(), 64);
        let total: f64 = vertex_areas(&mesh.positions, &indices).iter().sum();
        let patch_total: f64 = patches.patches.iter().map(|p| f64::from(p.area)).sum();
        assert!(
            (patch_total - total).abs() < 1e-4 * total,
            "{patch_total} vs {total}"
        );
        let mut seen = vec![false; mesh.positions.len()];
        for patch in &patches.patches {
            let members =
                &patches.members[patch.first_member as usize..][..patch.member_count as usize];
            let weights: f32 = members.iter().map(|m| m.weight).sum();
            assert!((weights - 1.0).abs() < 1e-4, "{weights}");
            for member in members {
                assert!(
                    !seen[member.vertex as usize],
                    "vertex {} twice",
                    member.vertex
                );
                seen[member.vertex as usize] = true;
            }
        }
    }

    #[test]
    fn patches_are_compact_and_similar_in_size() {
        // On a unit sphere each of 64 patches covers about 4π/64: a cap of angular radius
        // about 14°, so no member lies much farther than that from its centroid's direction.
        let (mesh, patches, _) = sphere_patches(64);
        let mean = 4.0 * std::f32::consts::PI / 64.0;
        for patch in &patches.patches {
            assert!(
                patch.area > 0.4 * mean && patch.area < 2.0 * mean,
                "{}",
                patch.area
            );
            assert!((patch.curvature_per_mm - 1.0).abs() < 1e-5);
            assert!(patch.normal.dot(patch.centroid.normalize()) > 0.999);
            let members =
                &patches.members[patch.first_member as usize..][..patch.member_count as usize];
            for member in members {
                let p = mesh.positions[member.vertex as usize];
                assert!(p.normalize().dot(patch.normal) > 30_f32.to_radians().cos());
            }
            // A cap's centroid lies below its surface: its vertices rise above its plane.
            assert!(
                patch.sagitta > 0.0 && patch.sagitta < 0.1,
                "{}",
                patch.sagitta
            );
        }
    }

    #[test]
    fn the_two_faces_of_a_thin_slab_never_share_a_patch() {
        // Two parallel squares 0.05 apart, facing away from each other, 20 × 20 vertices each.
        let mut positions = Vec::new();
        let mut normals = Vec::new();
        let mut indices = Vec::new();
        for (z, n) in [(0.0f32, -1.0f32), (0.05, 1.0)] {
            let base = positions.len() as u32;
            for j in 0..20 {
                for i in 0..20 {
                    positions.push(Vec3::new(i as f32 / 19.0, j as f32 / 19.0, z));
                    normals.push(Vec3::new(0.0, 0.0, n));
                }
            }
            for j in 0..19u32 {
                for i in 0..19u32 {
                    let a = base + j * 20 + i;
                    indices.extend([a, a + 1, a + 21, a, a + 21, a + 20]);
                }
            }
        }
        let curvature = vec![0.0; positions.len()];
        let patches = SurfacePatches::build(&positions, &normals, &curvature, &indices, 16);
        for patch in &patches.patches {
            let members =
                &patches.members[patch.first_member as usize..][..patch.member_count as usize];
            let face = |m: &PatchMember| normals[m.vertex as usize].z;
            assert!(members.iter().all(|m| face(m) == face(&members[0])));
            assert!(patch.normal.z.abs() > 0.999);
        }
    }

    #[test]
    fn empty_and_degenerate_input_gives_no_patches() {
        assert!(
            SurfacePatches::build(&[], &[], &[], &[], 16)
                .patches
                .is_empty()
        );
        let positions = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let normals = [Vec3::Z; 3];
        let curvature = [0.0; 3];
        // Out-of-range and degenerate triangles give no area.
        for indices in [[0, 1, 7], [0, 0, 1]] {
            assert!(
                SurfacePatches::build(&positions, &normals, &curvature, &indices, 4)
                    .patches
                    .is_empty()
            );
        }
        assert!(
            SurfacePatches::build(&positions, &normals, &curvature, &[0, 1, 2], 0)
                .patches
                .is_empty()
        );
        // More patches asked for than vertices: one per vertex.
        let patches = SurfacePatches::build(&positions, &normals, &curvature, &[0, 1, 2], 10);
        assert_eq!(patches.patches.len(), 3);
    }
}
