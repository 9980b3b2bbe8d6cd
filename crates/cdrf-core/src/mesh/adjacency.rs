//! Vertex → incident-face adjacency in compressed-sparse-row form, so per-vertex passes can
//! *gather* from their faces in parallel instead of faces *scattering* into vertices (no races,
//! no atomics in the hot loops, deterministic sums).

use std::sync::atomic::{AtomicU32, Ordering};

use rayon::prelude::*;

/// Incident faces of every vertex: `faces[offsets[v]..offsets[v + 1]]`, in increasing face order.
#[derive(Clone, Debug)]
pub(crate) struct VertexFaces {
    offsets: Vec<usize>,
    faces: Vec<u32>,
}

impl VertexFaces {
    /// Builds the adjacency. Indices `>= vertex_count` are ignored (callers validate first).
    pub(crate) fn new(vertex_count: usize, triangles: &[[u32; 3]]) -> Self {
        // Count incident faces per vertex (parallel, relaxed atomics: only the totals matter).
        let counts: Vec<AtomicU32> = (0..vertex_count).map(|_| AtomicU32::new(0)).collect();
        triangles.par_iter().for_each(|t| {
            for &i in t {
                if let Some(c) = counts.get(i as usize) {
                    c.fetch_add(1, Ordering::Relaxed);
                }
            }
        });
        let mut offsets = Vec::with_capacity(vertex_count + 1);
        let mut total = 0usize;
        offsets.push(0);
        for c in &counts {
            total += c.load(Ordering::Relaxed) as usize;
            offsets.push(total);
        }
        // Fill: each face claims a slot per corner through a per-vertex cursor.
        let cursors = counts;
        cursors
            .par_iter()
            .for_each(|c| c.store(0, Ordering::Relaxed));
        let slots: Vec<AtomicU32> = (0..total).map(|_| AtomicU32::new(0)).collect();
        triangles.par_iter().enumerate().for_each(|(f, t)| {
            for &i in t {
                let v = i as usize;
                if v < vertex_count {
                    let k = cursors[v].fetch_add(1, Ordering::Relaxed) as usize;
                    slots[offsets[v] + k].store(f as u32, Ordering::Relaxed);
                }
            }
        });
        let mut faces: Vec<u32> = slots.into_iter().map(AtomicU32::into_inner).collect();
        // The claim order above is a race; sort each (short) list so sums are deterministic.
        let mut rest: &mut [u32] = &mut faces;
        let mut lists = Vec::with_capacity(vertex_count);
        for w in offsets.windows(2) {
            let (head, tail) = rest.split_at_mut(w[1] - w[0]);
            lists.push(head);
            rest = tail;
        }
        lists.par_iter_mut().for_each(|l| l.sort_unstable());
        Self { offsets, faces }
    }

    /// The faces incident to vertex `v`, in increasing order.
    pub(crate) fn faces_of(&self, v: usize) -> &[u32] {
        &self.faces[self.offsets[v]..self.offsets[v + 1]]
    }
}
