//! Checking and repairing unchecked [`MeshData`] into a valid [`Mesh`].

use std::fmt;

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use thiserror::Error;

use super::{Mesh, MeshData, RepairedMesh, Welded, smooth_normals};

/// What [`Mesh::from_data`] removed or computed. `Display` writes one line, `no repairs` when
/// nothing was wrong.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RepairReport {
    /// Vertices with a NaN or infinite coordinate (removed with their triangles).
    pub non_finite_vertices: usize,
    /// Triangles removed because a corner was a non-finite vertex.
    pub triangles_with_non_finite_vertex: usize,
    /// Triangles removed because an index was ≥ the vertex count.
    pub out_of_range_triangles: usize,
    /// Triangles removed because an index repeats or the area is zero
    /// (`|e₁ × e₂| ≤ 1e-12 · longest edge²`, computed in f64).
    pub degenerate_triangles: usize,
    /// Finite vertices that no remaining triangle uses (removed).
    pub unreferenced_vertices: usize,
    /// Supplied normals that were non-finite (or otherwise not normalisable, but not exactly
    /// zero, which means "missing") and were recomputed.
    pub invalid_normals: usize,
    /// UVs with a non-finite component, set to (0, 0).
    pub invalid_uvs: usize,
    /// The supplied normal array did not have one entry per vertex and was ignored.
    pub dropped_normals: bool,
    /// The supplied UV array did not have one entry per vertex and was dropped.
    pub dropped_uvs: bool,
    /// Vertices whose normal was computed (missing from the source, or invalid).
    pub computed_normals: usize,
}

impl RepairReport {
    /// Triangles removed for any reason.
    pub fn removed_triangles(&self) -> usize {
        self.triangles_with_non_finite_vertex
            + self.out_of_range_triangles
            + self.degenerate_triangles
    }

    /// Vertices removed for any reason.
    pub fn removed_vertices(&self) -> usize {
        self.non_finite_vertices + self.unreferenced_vertices
    }

    /// True when the data was valid as given (computing missing normals is not a repair).
    pub fn is_clean(&self) -> bool {
        self.removed_triangles() == 0
            && self.removed_vertices() == 0
            && self.invalid_normals == 0
            && self.invalid_uvs == 0
            && !self.dropped_normals
            && !self.dropped_uvs
    }
}

impl fmt::Display for RepairReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_clean() {
            return f.write_str("no repairs");
        }
        let mut parts = Vec::new();
        let mut count = |n: usize, what: &str| {
            if n > 0 {
                parts.push(format!("{n} {what}"));
            }
        };
        count(self.non_finite_vertices, "non-finite vertices removed");
        count(
            self.triangles_with_non_finite_vertex,
            "triangles on non-finite vertices removed",
        );
        count(
            self.out_of_range_triangles,
            "triangles with out-of-range indices removed",
        );
        count(self.degenerate_triangles, "degenerate triangles removed");
        count(self.unreferenced_vertices, "unreferenced vertices removed");
        count(self.invalid_normals, "invalid normals recomputed");
        count(self.invalid_uvs, "non-finite UVs zeroed");
        if self.dropped_normals {
            parts.push("normal array of the wrong length ignored".to_owned());
        }
        if self.dropped_uvs {
            parts.push("UV array of the wrong length dropped".to_owned());
        }
        f.write_str(&parts.join(", "))
    }
}

/// Why mesh data could not be turned into a [`Mesh`].
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum MeshError {
    /// Nothing valid remained after the repairs.
    #[error(
        "no usable triangles: {vertices} vertices and {triangles} triangles given, none valid ({report})"
    )]
    NoUsableTriangles {
        /// Vertices in the input.
        vertices: usize,
        /// Triangles in the input.
        triangles: usize,
        /// What was removed.
        report: RepairReport,
    },
}

/// Which input elements a repaired mesh kept, for carrying per-triangle and per-vertex data
/// of the input (primitive tags, tangents) through [`repair_mapped`].
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(super) struct RepairMap {
    /// For each output triangle, its index in the input (increasing: order is kept).
    pub(super) kept_triangles: Vec<u32>,
    /// For each output vertex, its index in the input (increasing: order is kept).
    pub(super) kept_vertices: Vec<u32>,
}

/// See [`Mesh::from_data`].
pub(super) fn repair(data: MeshData) -> Result<RepairedMesh, MeshError> {
    repair_mapped(data).map(|(mesh, _)| mesh)
}

/// [`repair`], also saying which input triangles and vertices survived, in order.
pub(super) fn repair_mapped(data: MeshData) -> Result<(RepairedMesh, RepairMap), MeshError> {
    let MeshData {
        positions,
        normals,
        uvs,
        triangles,
    } = data;
    let mut report = RepairReport::default();
    let vertex_count = positions.len();
    let finite: Vec<bool> = positions.par_iter().map(|p| p.is_finite()).collect();
    report.non_finite_vertices = finite.iter().filter(|&&ok| !ok).count();

    #[derive(Clone, Copy, PartialEq)]
    enum Verdict {
        Keep,
        OutOfRange,
        NonFinite,
        Degenerate,
    }
    let verdicts: Vec<Verdict> = triangles
        .par_iter()
        .map(|t| {
            if t.iter().any(|&i| i as usize >= vertex_count) {
                return Verdict::OutOfRange;
            }
            if t.iter().any(|&i| !finite[i as usize]) {
                return Verdict::NonFinite;
            }
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                return Verdict::Degenerate;
            }
            let [p0, p1, p2] = t.map(|i| positions[i as usize].as_dvec3());
            let (e1, e2, e3) = (p1 - p0, p2 - p0, p2 - p1);
            let longest_sq = e1
                .length_squared()
                .max(e2.length_squared())
                .max(e3.length_squared());
            if e1.cross(e2).length() <= 1e-12 * longest_sq {
                Verdict::Degenerate
            } else {
                Verdict::Keep
            }
        })
        .collect();
    for v in &verdicts {
        match v {
            Verdict::Keep => {}
            Verdict::OutOfRange => report.out_of_range_triangles += 1,
            Verdict::NonFinite => report.triangles_with_non_finite_vertex += 1,
            Verdict::Degenerate => report.degenerate_triangles += 1,
        }
    }
    let kept_triangles: Vec<u32> = (0..triangles.len() as u32)
        .filter(|&t| verdicts[t as usize] == Verdict::Keep)
        .collect();
    let kept: Vec<[u32; 3]> = kept_triangles
        .iter()
        .map(|&t| triangles[t as usize])
        .collect();
    if kept.is_empty() {
        report.unreferenced_vertices = vertex_count - report.non_finite_vertices;
        return Err(MeshError::NoUsableTriangles {
            vertices: vertex_count,
            triangles: triangles.len(),
            report,
        });
    }

    // Compact: keep referenced vertices in their original order.
    let mut referenced = vec![false; vertex_count];
    for t in &kept {
        for &i in t {
            referenced[i as usize] = true;
        }
    }
    let mut new_index = vec![u32::MAX; vertex_count];
    let mut old_of_new = Vec::new();
    for (i, &r) in referenced.iter().enumerate() {
        if r {
            new_index[i] = old_of_new.len() as u32;
            old_of_new.push(i);
        } else if finite[i] {
            report.unreferenced_vertices += 1;
        }
    }
    let positions: Vec<Vec3> = old_of_new.iter().map(|&i| positions[i]).collect();
    let triangles: Vec<[u32; 3]> = kept
        .par_iter()
        .map(|t| t.map(|i| new_index[i as usize]))
        .collect();

    let uvs = match uvs {
        Some(uvs) if uvs.len() == vertex_count => Some(
            old_of_new
                .iter()
                .map(|&i| {
                    let uv = uvs[i];
                    if uv.is_finite() {
                        uv
                    } else {
                        report.invalid_uvs += 1;
                        Vec2::ZERO
                    }
                })
                .collect(),
        ),
        Some(_) => {
            report.dropped_uvs = true;
            None
        }
        None => None,
    };

    // Normals: keep valid supplied ones (normalised), compute the rest.
    let supplied: Option<Vec<Option<Vec3>>> = match normals {
        Some(normals) if normals.len() == vertex_count => Some(
            old_of_new
                .iter()
                .map(|&i| {
                    let n = normals[i];
                    let unit = n.normalize_or_zero();
                    if unit != Vec3::ZERO {
                        Some(unit)
                    } else {
                        // Zero marks "missing" (a loader's placeholder), anything else that
                        // cannot be normalised (NaN, Inf, denormal) is invalid.
                        if n != Vec3::ZERO {
                            report.invalid_normals += 1;
                        }
                        None
                    }
                })
                .collect(),
        ),
        Some(_) => {
            report.dropped_normals = true;
            None
        }
        None => None,
    };
    let normals = match supplied {
        Some(supplied) if supplied.iter().all(Option::is_some) => {
            supplied.into_iter().flatten().collect()
        }
        supplied => {
            let welded = Welded::from_triangles(&positions, &triangles);
            let computed = smooth_normals(&positions, &triangles, &welded);
            match supplied {
                Some(supplied) => supplied
                    .into_iter()
                    .zip(computed)
                    .map(|(s, c)| {
                        s.unwrap_or_else(|| {
                            report.computed_normals += 1;
                            c
                        })
                    })
                    .collect(),
                None => {
                    report.computed_normals = computed.len();
                    computed
                }
            }
        }
    };

    let map = RepairMap {
        kept_triangles,
        kept_vertices: old_of_new.iter().map(|&i| i as u32).collect(),
    };
    Ok((
        RepairedMesh {
            mesh: Mesh {
                positions,
                normals,
                uvs,
                triangles,
            },
            report,
        },
        map,
    ))
}
