//! How well a model reproduces a sphere photograph.
//!
//! Single pixels are too noisy to compare (the path-traced data has ~7 % relative noise per
//! pixel on the lit side, tens of percent in shadow), so errors are measured on **8 × 8 pixel
//! blocks**: the data and the model are averaged over each block whose 64 pixels were all
//! usable samples, and a block belongs to the region of its mean cos θ:
//! lit (cos θ > 0.1), terminator (|cos θ| ≤ 0.1) or shadow (cos θ < −0.1).
//!
//! Per region two numbers: the **mean relative error** `mean(|m − d| / d)` over blocks, and the
//! **relative RMS error** `√(Σ (m − d)² / Σ d²)` over blocks; both over all three channels.

use glam::Vec3;
use serde::Serialize;

use crate::curves::SphereSamples;

/// Block size, pixels.
pub const BLOCK_PX: u32 = 8;

/// Errors of one region.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct RegionError {
    /// Blocks in the region.
    pub blocks: usize,
    /// Mean of |model − data| / data over blocks and channels (where data > 0).
    pub mean_relative_error: f32,
    /// √(Σ (model − data)² / Σ data²) over blocks and channels.
    pub relative_rms: f32,
}

/// Errors of one sphere, per region.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct SphereError {
    /// cos θ > 0.1.
    pub lit: RegionError,
    /// |cos θ| ≤ 0.1.
    pub terminator: RegionError,
    /// cos θ < −0.1.
    pub shadow: RegionError,
    /// Lit and terminator together (the regions the self-consistency target is stated on).
    pub lit_and_terminator: RegionError,
    /// Every block.
    pub whole: RegionError,
}

#[derive(Default)]
struct Accumulator {
    blocks: usize,
    relative_terms: usize,
    relative_sum: f64,
    squared_error: f64,
    squared_data: f64,
}

impl Accumulator {
    fn add(&mut self, model: Vec3, data: Vec3) {
        self.blocks += 1;
        for c in 0..3 {
            let (m, d) = (model[c] as f64, data[c] as f64);
            if d > 0.0 {
                self.relative_sum += (m - d).abs() / d;
                self.relative_terms += 1;
            }
            self.squared_error += (m - d) * (m - d);
            self.squared_data += d * d;
        }
    }

    fn result(&self) -> RegionError {
        RegionError {
            blocks: self.blocks,
            mean_relative_error: if self.relative_terms > 0 {
                (self.relative_sum / self.relative_terms as f64) as f32
            } else {
                0.0
            },
            relative_rms: if self.squared_data > 0.0 {
                (self.squared_error / self.squared_data).sqrt() as f32
            } else {
                0.0
            },
        }
    }
}

/// Compares `model(θ, φ)` (π·L/E) with a sphere's samples, block-averaged.
pub fn sphere_error(sphere: &SphereSamples, model: impl Fn(f32, f32) -> Vec3) -> SphereError {
    // Per block: (pixels, Σ data, Σ model, Σ cos θ).
    let blocks_across = sphere.image_width.div_ceil(BLOCK_PX) as usize;
    let block_of = |pixel: u32| {
        let (x, y) = (pixel % sphere.image_width, pixel / sphere.image_width);
        (y / BLOCK_PX) as usize * blocks_across + (x / BLOCK_PX) as usize
    };
    let block_count = sphere
        .samples
        .iter()
        .map(|s| block_of(s.pixel) + 1)
        .max()
        .unwrap_or(0);
    let mut blocks = vec![(0_u32, Vec3::ZERO, Vec3::ZERO, 0.0_f32); block_count];
    for s in &sphere.samples {
        let entry = &mut blocks[block_of(s.pixel)];
        entry.0 += 1;
        entry.1 += s.radiance;
        entry.2 += model(s.theta_rad, s.phi_rad);
        entry.3 += s.theta_rad.cos();
    }
    let (mut lit, mut terminator, mut shadow, mut both, mut whole) = Default::default();
    for (count, data, model, cos_sum) in blocks {
        if count < BLOCK_PX * BLOCK_PX {
            continue;
        }
        let n = count as f32;
        let (data, model, cos) = (data / n, model / n, cos_sum / n);
        let region: &mut Accumulator = if cos > 0.1 {
            &mut lit
        } else if cos >= -0.1 {
            &mut terminator
        } else {
            &mut shadow
        };
        region.add(model, data);
        if cos >= -0.1 {
            Accumulator::add(&mut both, model, data);
        }
        Accumulator::add(&mut whole, model, data);
    }
    SphereError {
        lit: lit.result(),
        terminator: terminator.result(),
        shadow: shadow.result(),
        lit_and_terminator: both.result(),
        whole: whole.result(),
    }
}
