//! Per-vertex values filtered over a length on the welded surface: one backward-Euler heat
//! step `(M + t·L) x = M·κ`, `t = length²`, solved by conjugate gradients with a Jacobi
//! preconditioner (see "Filtering to a length" in the [module docs](super)).
//!
//! `M` is the lumped (barycentric: a third of each incident triangle) vertex area, `L` the
//! cotangent Laplacian with every edge's weight `½(cot α + cot β)` clamped at ≥ 0. With
//! non-negative weights `M + t·L` is a symmetric M-matrix: positive definite wherever `M > 0`,
//! its inverse is non-negative and `L·1 = 0`, so each filtered value is a weighted mean of the
//! input (a constant stays that constant, nothing leaves the input's range).

use glam::{DMat3, DVec3, Vec3};
use rayon::prelude::*;

use super::{CurvatureError, corner_of};
use crate::mesh::VertexFaces;

/// The longest filter accepted, in mean edge lengths of the mesh. The solve takes tens of
/// iterations per edge of filter length (fewer once the length nears the object's size), and
/// the areas get lost beside the Laplacian in f64 as the ratio grows without bound; a filter
/// this long in edges averages over far more than the mesh's own detail and usually means a
/// wrong `mm_per_unit`.
pub const MAX_FILTER_LENGTH_EDGES: f32 = 1000.0;

/// The solve stops when `‖M·κ − (M + t·L) x‖₂ ≤ RELATIVE_TOLERANCE · ‖M·κ‖₂` per component.
/// Since `M + t·L ≥ M`, the error left, relative to the values' RMS, is at most this times the
/// ratio of the largest to the smallest vertex area.
const RELATIVE_TOLERANCE: f64 = 1e-8;

/// The iteration cap: this many per mean edge length of filter, plus [`EXTRA_ITERATIONS`], at
/// most [`MAX_ITERATIONS`]. Measured: 22 to 70 iterations at 1 mm and 62 to 220 at 5 mm on
/// meshes of 0.75 to 3.8 mm edges (regular and random), 444 at 5 mm on 0.4 mm edges, saturating
/// at 250 to 700 once the length nears the object's size. The cap is far above, a guard against
/// a pathological mesh, which then keeps the iterate reached (a partly filtered field).
const ITERATIONS_PER_EDGE: f64 = 100.0;
const EXTRA_ITERATIONS: f64 = 1000.0;
const MAX_ITERATIONS: f64 = 5000.0;

/// Rows per partial sum in the dot products: the sums are added in this fixed chunk order,
/// so the result does not depend on the thread count.
const CHUNK: usize = 4096;

/// `M + t·L` of one welded mesh for one filter length, ready to solve.
pub(super) struct SurfaceFilter {
    /// Row `i`'s neighbours are `neighbours[offsets[i]..offsets[i + 1]]`, increasing.
    offsets: Vec<usize>,
    neighbours: Vec<u32>,
    /// `t·w_ij` (model units²) for those neighbours, all > 0.
    couplings: Vec<f64>,
    /// `M_i`, model units².
    area: Vec<f64>,
    /// `M_i + Σ_j t·w_ij`; 0 for a vertex without area (on no triangle of non-zero area: it
    /// has no coupling either), which keeps its value.
    diagonal: Vec<f64>,
    max_iterations: usize,
}

/// What a solve reached.
pub(super) struct Filtered<const K: usize> {
    pub(super) values: Vec<[f64; K]>,
    /// Iterations run (0 when the input already solves the system, as a constant does).
    #[cfg_attr(not(test), allow(dead_code))]
    pub(super) iterations: usize,
    /// Whether every component met the tolerance before the iteration cap.
    #[cfg_attr(not(test), allow(dead_code))]
    pub(super) converged: bool,
}

impl SurfaceFilter {
    /// The system for filter length `length_mm` (finite, > 0) on the welded topology
    /// `positions` (model units) / `triangles`; `None` when the mesh has no triangle of
    /// non-zero area (nothing to filter over).
    ///
    /// # Errors
    /// [`CurvatureError::FilterTooLong`] beyond [`MAX_FILTER_LENGTH_EDGES`] mean edge lengths.
    pub(super) fn new(
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        adjacency: &VertexFaces,
        mm_per_unit: f32,
        length_mm: f32,
    ) -> Result<Option<Self>, CurvatureError> {
        // Everything is in model units (`t` too), which cannot overflow where mm² might; the
        // solution does not depend on the unit, as M and t·L scale alike.
        let mm = f64::from(mm_per_unit);
        let Some(mean_edge) = super::mean_edge_length_units(positions, triangles) else {
            return Ok(None);
        };
        let mean_edge_mm = mean_edge * mm;
        let edges = f64::from(length_mm) / mean_edge_mm;
        if edges > f64::from(MAX_FILTER_LENGTH_EDGES) {
            return Err(CurvatureError::FilterTooLong {
                length_mm,
                mean_edge_mm: mean_edge_mm as f32,
            });
        }
        // Per face: the cotangent at each corner and the area (zero for a degenerate face,
        // which then couples nothing).
        let faces: Vec<([f64; 3], f64)> = triangles
            .par_iter()
            .map(|&t| {
                let p = t.map(|i| positions[i as usize].as_dvec3());
                let double_area = (p[1] - p[0]).cross(p[2] - p[0]).length();
                let repeated = t[0] == t[1] || t[1] == t[2] || t[2] == t[0];
                if repeated || !(double_area > 0.0 && double_area.is_finite()) {
                    return ([0.0; 3], 0.0);
                }
                let cot = std::array::from_fn(|k| {
                    let (a, b) = (p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
                    a.dot(b) / double_area
                });
                (cot, 0.5 * double_area)
            })
            .collect();

        // Rows by gathering each vertex's faces (in increasing face order, so w_ij and w_ji
        // are the same sum in the same order: the matrix is exactly symmetric).
        let t = (f64::from(length_mm) / mm).powi(2);
        let rows: Vec<(Vec<(u32, f64)>, f64)> = (0..positions.len())
            .into_par_iter()
            .map(|v| {
                let mut row = Vec::new();
                let mut area = 0.0;
                for &f in adjacency.faces_of(v) {
                    let (cot, face_area) = faces[f as usize];
                    if face_area <= 0.0 {
                        continue;
                    }
                    let tri = triangles[f as usize];
                    let c = corner_of(tri, v);
                    let (a, b) = ((c + 1) % 3, (c + 2) % 3);
                    // Edge v–tri[a] is opposite corner b, edge v–tri[b] opposite corner a.
                    row.push((tri[a], 0.5 * cot[b]));
                    row.push((tri[b], 0.5 * cot[a]));
                    area += face_area / 3.0;
                }
                row.sort_by_key(|&(u, _)| u);
                let mut merged: Vec<(u32, f64)> = Vec::with_capacity(row.len());
                for (u, w) in row {
                    match merged.last_mut() {
                        Some(last) if last.0 == u => last.1 += w,
                        _ => merged.push((u, w)),
                    }
                }
                merged.retain(|&(_, w)| w > 0.0);
                for e in &mut merged {
                    e.1 *= t;
                }
                (merged, area)
            })
            .collect();

        let mut offsets = Vec::with_capacity(rows.len() + 1);
        offsets.push(0);
        let mut total = 0;
        for (row, _) in &rows {
            total += row.len();
            offsets.push(total);
        }
        let mut neighbours = Vec::with_capacity(total);
        let mut couplings = Vec::with_capacity(total);
        let mut areas = Vec::with_capacity(rows.len());
        let mut diagonal = Vec::with_capacity(rows.len());
        for (row, area) in rows {
            let sum: f64 = row.iter().map(|e| e.1).sum();
            diagonal.push(if area > 0.0 { area + sum } else { 0.0 });
            areas.push(area);
            for (u, c) in row {
                neighbours.push(u);
                couplings.push(c);
            }
        }
        let max_iterations =
            (ITERATIONS_PER_EDGE * edges + EXTRA_ITERATIONS).min(MAX_ITERATIONS) as usize;
        Ok(Some(Self {
            offsets,
            neighbours,
            couplings,
            area: areas,
            diagonal,
            max_iterations,
        }))
    }

    /// `(M + t·L) x` on the rows that are solved for; 0 on the others.
    fn apply<const K: usize>(&self, x: &[[f64; K]], out: &mut [[f64; K]]) {
        out.par_iter_mut().enumerate().for_each(|(i, o)| {
            let d = self.diagonal[i];
            if d <= 0.0 {
                *o = [0.0; K];
                return;
            }
            let mut y = x[i].map(|v| d * v);
            let range = self.offsets[i]..self.offsets[i + 1];
            for (&j, &c) in self.neighbours[range.clone()]
                .iter()
                .zip(&self.couplings[range])
            {
                let xj = x[j as usize];
                for k in 0..K {
                    y[k] -= c * xj[k];
                }
            }
            *o = y;
        });
    }

    /// Solves `(M + t·L) x = M·values` for `K` components at once (they share the matrix; each
    /// has its own step lengths and stops on its own), starting from `values`. Vertices without
    /// area keep their values.
    pub(super) fn solve<const K: usize>(&self, values: Vec<[f64; K]>) -> Filtered<K> {
        let n = values.len();
        let active = |i: usize| self.diagonal[i] > 0.0;
        let mut scratch = vec![[0.0; K]; n];
        self.apply(&values, &mut scratch);
        // r = M·κ − (M + t·L)·κ, the system's residual at the start.
        let mut r: Vec<[f64; K]> = (0..n)
            .into_par_iter()
            .map(|i| {
                if active(i) {
                    std::array::from_fn(|k| self.area[i] * values[i][k] - scratch[i][k])
                } else {
                    [0.0; K]
                }
            })
            .collect();
        let rhs: Vec<[f64; K]> = (0..n)
            .into_par_iter()
            .map(|i| values[i].map(|v| self.area[i] * v))
            .collect();
        let rhs_norm2 = dot(&rhs, &rhs);
        drop(rhs);
        let mut x = values;
        let tolerance2: [f64; K] =
            std::array::from_fn(|k| RELATIVE_TOLERANCE * RELATIVE_TOLERANCE * rhs_norm2[k]);
        let rr = dot(&r, &r);
        // A component is done when its residual is small enough, or not a number (nothing to gain).
        let met = |rr: f64, k: usize| rr <= tolerance2[k] || rr.is_nan();
        let mut done: [bool; K] = std::array::from_fn(|k| met(rr[k], k));

        let precondition = |r: &[[f64; K]], z: &mut [[f64; K]]| {
            z.par_iter_mut().enumerate().for_each(|(i, z)| {
                let d = self.diagonal[i];
                *z = if d > 0.0 {
                    r[i].map(|v| v / d)
                } else {
                    [0.0; K]
                };
            });
        };
        let mut z = vec![[0.0; K]; n];
        precondition(&r, &mut z);
        let mut p = z.clone();
        let mut rz = dot(&r, &z);
        let mut ap = scratch;
        let mut iterations = 0;
        while iterations < self.max_iterations && done.contains(&false) {
            iterations += 1;
            self.apply(&p, &mut ap);
            let pap = dot(&p, &ap);
            let alpha: [f64; K] = std::array::from_fn(|k| {
                let a = rz[k] / pap[k];
                if done[k] || !(pap[k] > 0.0 && a.is_finite()) {
                    0.0
                } else {
                    a
                }
            });
            for k in 0..K {
                done[k] |= alpha[k] == 0.0;
            }
            x.par_iter_mut()
                .zip(r.par_iter_mut())
                .zip(p.par_iter().zip(ap.par_iter()))
                .for_each(|((x, r), (p, ap))| {
                    for k in 0..K {
                        x[k] += alpha[k] * p[k];
                        r[k] -= alpha[k] * ap[k];
                    }
                });
            let rr = dot(&r, &r);
            for k in 0..K {
                done[k] |= met(rr[k], k);
            }
            precondition(&r, &mut z);
            let rz_next = dot(&r, &z);
            let beta: [f64; K] =
                std::array::from_fn(|k| if done[k] { 0.0 } else { rz_next[k] / rz[k] });
            rz = rz_next;
            p.par_iter_mut().zip(z.par_iter()).for_each(|(p, z)| {
                for k in 0..K {
                    p[k] = z[k] + beta[k] * p[k];
                }
            });
        }
        Filtered {
            values: x,
            iterations,
            converged: !done.contains(&false),
        }
    }

    /// Filters symmetric 3 × 3 tensors component by component.
    pub(super) fn solve_tensors(&self, tensors: &[DMat3]) -> Vec<DMat3> {
        let components: Vec<[f64; 6]> = tensors
            .par_iter()
            .map(|m| {
                let c = [
                    m.x_axis.x, m.y_axis.x, m.z_axis.x, m.y_axis.y, m.z_axis.y, m.z_axis.z,
                ];
                // A tensor that overflowed carries no direction; it must not spread NaN.
                if c.iter().all(|v| v.is_finite()) {
                    c
                } else {
                    [0.0; 6]
                }
            })
            .collect();
        self.solve(components)
            .values
            .into_par_iter()
            .map(|[xx, xy, xz, yy, yz, zz]| {
                DMat3::from_cols(
                    DVec3::new(xx, xy, xz),
                    DVec3::new(xy, yy, yz),
                    DVec3::new(xz, yz, zz),
                )
            })
            .collect()
    }
}

/// Σᵢ aᵢ·bᵢ per component, summed in fixed chunks in a fixed order (thread-count independent).
fn dot<const K: usize>(a: &[[f64; K]], b: &[[f64; K]]) -> [f64; K] {
    a.par_chunks(CHUNK)
        .zip(b.par_chunks(CHUNK))
        .map(|(a, b)| {
            let mut s = [0.0; K];
            for (a, b) in a.iter().zip(b) {
                for k in 0..K {
                    s[k] += a[k] * b[k];
                }
            }
            s
        })
        .collect::<Vec<_>>()
        .into_iter()
        .fold([0.0; K], |mut s, c| {
            for k in 0..K {
                s[k] += c[k];
            }
            s
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Mesh;

    /// A deterministic value in [−1, 1) per index.
    fn noise(i: usize, salt: u64) -> f64 {
        let mut x = (i as u64 ^ salt.rotate_left(32)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        x ^= x >> 29;
        x = x.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        x ^= x >> 32;
        (x >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }

    /// A 3:2:1 ellipsoid (30 mm) with every vertex moved by up to a third of an edge: irregular
    /// rings, obtuse corners, negative cotangent weights.
    fn jittered(subdivisions: u32) -> Mesh {
        let mut mesh = Mesh::ellipsoid(Vec3::new(30.0, 20.0, 10.0), subdivisions);
        let edge = 60.0 / 2f32.powi(subdivisions as i32 + 1);
        for (i, p) in mesh.positions.iter_mut().enumerate() {
            let d = Vec3::new(noise(i, 1) as f32, noise(i, 2) as f32, noise(i, 3) as f32);
            *p += d * (edge / 3.0);
        }
        mesh
    }

    fn filter(mesh: &Mesh, length_mm: f32) -> SurfaceFilter {
        let adjacency = VertexFaces::new(mesh.positions.len(), &mesh.triangles);
        SurfaceFilter::new(&mesh.positions, &mesh.triangles, &adjacency, 1.0, length_mm)
            .expect("length within bounds")
            .expect("a mesh with area")
    }

    #[test]
    fn a_constant_is_unchanged() {
        let mesh = jittered(3);
        let constant = [0.04, -2.0, 3.0, 0.5, 0.0, 7.0];
        for length_mm in [0.5, 5.0, 50.0, 500.0] {
            let solved = filter(&mesh, length_mm).solve(vec![constant; mesh.positions.len()]);
            assert!(solved.converged, "{length_mm} mm");
            for v in &solved.values {
                for k in 0..6 {
                    let error = (v[k] - constant[k]).abs();
                    assert!(error <= 1e-9 * constant[k].abs(), "{length_mm} mm: {v:?}");
                }
            }
        }
    }

    #[test]
    fn the_area_weighted_mean_is_kept_and_values_stay_in_range() {
        let mesh = jittered(3);
        let input: Vec<[f64; 1]> = (0..mesh.positions.len())
            .map(|i| [0.05 + 0.02 * noise(i, 7)])
            .collect();
        let (low, high) = (0.03 - 1e-12, 0.07 + 1e-12);
        let spread = |v: &[[f64; 1]]| {
            let mean = v.iter().map(|x| x[0]).sum::<f64>() / v.len() as f64;
            v.iter().map(|x| (x[0] - mean).powi(2)).sum::<f64>().sqrt()
        };
        let mut previous_spread = spread(&input);
        for length_mm in [0.5, 2.0, 8.0, 32.0] {
            let system = filter(&mesh, length_mm);
            let solved = system.solve(input.clone());
            assert!(solved.converged && solved.iterations > 0, "{length_mm} mm");
            // 1ᵀ(M + t·L) = 1ᵀM: the filter moves value around, it neither adds nor removes any.
            let weighted =
                |v: &[[f64; 1]]| -> f64 { v.iter().zip(&system.area).map(|(x, a)| x[0] * a).sum() };
            let (before, after) = (weighted(&input), weighted(&solved.values));
            assert!(
                (after - before).abs() <= 1e-9 * before,
                "{length_mm} mm: {before} → {after}"
            );
            assert!(
                solved.values.iter().all(|x| (low..=high).contains(&x[0])),
                "{length_mm} mm: a value left the input's range"
            );
            let s = spread(&solved.values);
            assert!(
                s < previous_spread,
                "{length_mm} mm: spread {s} ≥ {previous_spread}"
            );
            previous_spread = s;
        }
    }

    #[test]
    fn vertices_without_area_keep_their_values() {
        let mut mesh = jittered(2);
        let n = mesh.positions.len() as u32;
        // An isolated vertex and a degenerate (collinear) triangle of three more.
        mesh.positions.extend([
            Vec3::new(100.0, 0.0, 0.0),
            Vec3::new(0.0, 100.0, 0.0),
            Vec3::new(0.0, 101.0, 0.0),
            Vec3::new(0.0, 102.0, 0.0),
        ]);
        mesh.triangles.push([n + 1, n + 2, n + 3]);
        let input: Vec<[f64; 1]> = (0..mesh.positions.len())
            .map(|i| [1.0 + noise(i, 3)])
            .collect();
        let solved = filter(&mesh, 10.0).solve(input.clone());
        assert!(solved.converged);
        for i in n as usize..mesh.positions.len() {
            assert_eq!(solved.values[i], input[i], "vertex {i}");
        }
        assert_ne!(solved.values[0], input[0], "the rest is filtered");
    }

    #[test]
    fn the_result_does_not_depend_on_the_thread_count() {
        // More vertices than one chunk of the dot products.
        let mesh = jittered(5);
        assert!(mesh.positions.len() > 2 * CHUNK);
        let input: Vec<[f64; 1]> = (0..mesh.positions.len()).map(|i| [noise(i, 5)]).collect();
        let run = || filter(&mesh, 5.0).solve(input.clone()).values;
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("a 1-thread pool")
            .install(run);
        let three = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .expect("a 3-thread pool")
            .install(run);
        assert!(one == three, "1 and 3 threads differ");
    }
}
