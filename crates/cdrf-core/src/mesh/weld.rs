//! Welding: merge vertices with bit-identical positions into one topology vertex.

use glam::Vec3;
use rayon::prelude::*;

/// The topology view of a mesh: vertices with bit-identical positions merged.
///
/// Welded vertices keep the order of their first occurrence in the mesh, so a mesh without
/// duplicates welds to itself.
#[derive(Clone, Debug, PartialEq)]
pub struct Welded {
    /// One position per welded vertex.
    pub positions: Vec<Vec3>,
    /// The mesh's triangles with indices into `positions`.
    pub triangles: Vec<[u32; 3]>,
    /// For every mesh vertex, its welded vertex.
    pub vertex_to_welded: Vec<u32>,
}

impl Welded {
    /// Welds `positions`; `triangles` are mapped through (indices out of range stay as they are,
    /// so callers that need valid indices check them first).
    ///
    /// Positions are compared by their bits after `-0.0 → 0.0`; sorting the keys (in parallel)
    /// rather than hashing keeps this fast and deterministic for millions of vertices.
    pub fn from_triangles(positions: &[Vec3], triangles: &[[u32; 3]]) -> Self {
        let key = |p: Vec3| (p + Vec3::ZERO).to_array().map(f32::to_bits);
        let mut order: Vec<u32> = (0..positions.len() as u32).collect();
        order.par_sort_unstable_by_key(|&i| (key(positions[i as usize]), i));
        // Representative of each group: its smallest original index (first in sorted order,
        // since ties sort by index).
        let mut representative = vec![0u32; positions.len()];
        let mut start = 0;
        while start < order.len() {
            let k = key(positions[order[start] as usize]);
            let mut end = start + 1;
            while end < order.len() && key(positions[order[end] as usize]) == k {
                end += 1;
            }
            let rep = order[start];
            for &i in &order[start..end] {
                representative[i as usize] = rep;
            }
            start = end;
        }
        // Number the representatives in original order.
        let mut welded_index = vec![u32::MAX; positions.len()];
        let mut welded_positions = Vec::new();
        for (i, &p) in positions.iter().enumerate() {
            if representative[i] as usize == i {
                welded_index[i] = welded_positions.len() as u32;
                welded_positions.push(p);
            }
        }
        let vertex_to_welded: Vec<u32> = representative
            .par_iter()
            .map(|&r| welded_index[r as usize])
            .collect();
        let triangles = triangles
            .par_iter()
            .map(|t| t.map(|i| vertex_to_welded.get(i as usize).copied().unwrap_or(i)))
            .collect();
        Self {
            positions: welded_positions,
            triangles,
            vertex_to_welded,
        }
    }

    /// Number of welded vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Spreads one value per welded vertex back to one value per mesh vertex.
    ///
    /// # Panics
    /// If `welded_values` has fewer entries than there are welded vertices.
    pub fn to_mesh_vertices<T: Copy + Send + Sync>(&self, welded_values: &[T]) -> Vec<T> {
        assert!(
            welded_values.len() >= self.positions.len(),
            "{} values for {} welded vertices",
            welded_values.len(),
            self.positions.len()
        );
        self.vertex_to_welded
            .par_iter()
            .map(|&w| welded_values[w as usize])
            .collect()
    }
}
