//! How well a model reproduces a sphere photograph.
//!
//! The metric is the one every cdrf comparison uses, [`cdrf_core::block_error`]: the data and
//! the model averaged over each 8 × 8-pixel block whose 64 pixels were all usable samples, the
//! blocks split into regions by their mean cos θ (lit side cos θ ≥ 0.26, terminator band
//! |cos θ| < 0.26, shadow side cos θ ≤ −0.26: [`cdrf_core::block_error::TERMINATOR_COS`]), and
//! per region the mean relative error Σ|m − d| / Σ d and the relative RMSE √(Σ(m − d)²) / √(Σ d²)
//! over the region's blocks and all three channels.
//!
//! [`RegionError`] is how `report.json` spells a region's errors (field names are a contract:
//! `relative_rms` is the relative RMSE).

use cdrf_core::block_error::{self, BlockPixel, Region};
use glam::Vec3;
use serde::Serialize;

use crate::curves::SphereSamples;

/// Block size, pixels.
pub const BLOCK_PX: u32 = block_error::BLOCK_PX;

/// Errors of one region, as `report.json` writes them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct RegionError {
    /// Blocks in the region.
    pub blocks: usize,
    /// Σ|model − data| / Σ data over blocks and channels
    /// ([`block_error::RegionError::mean_relative_error`]); 0 without blocks.
    pub mean_relative_error: f32,
    /// The relative RMSE √(Σ (model − data)²) / √(Σ data²) over blocks and channels
    /// ([`block_error::RegionError::relative_rmse`]; the name is `report.json`'s); 0 without
    /// blocks.
    pub relative_rms: f32,
}

impl From<block_error::RegionError> for RegionError {
    fn from(error: block_error::RegionError) -> Self {
        let or_zero = |value: f64| if value.is_finite() { value as f32 } else { 0.0 };
        Self {
            blocks: error.blocks,
            mean_relative_error: or_zero(error.mean_relative_error),
            relative_rms: or_zero(error.relative_rmse),
        }
    }
}

/// Errors of one sphere, per region ([`Region`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct SphereError {
    /// [`Region::Lit`]: cos θ ≥ 0.26.
    pub lit: RegionError,
    /// [`Region::Terminator`]: |cos θ| < 0.26.
    pub terminator: RegionError,
    /// [`Region::Shadow`]: cos θ ≤ −0.26.
    pub shadow: RegionError,
    /// [`Region::LitAndTerminator`]: cos θ > −0.26 (the regions the self-consistency target is
    /// stated on).
    pub lit_and_terminator: RegionError,
    /// Every block.
    pub whole: RegionError,
}

/// Compares `model(θ, φ)` (π·L/E) with a sphere's samples, block-averaged.
pub fn sphere_error(sphere: &SphereSamples, model: impl Fn(f32, f32) -> Vec3) -> SphereError {
    let width = sphere.image_width.max(1);
    let height = sphere
        .samples
        .iter()
        .map(|s| s.pixel / width + 1)
        .max()
        .unwrap_or(0);
    // Pixel → sample, for the pixels that have one.
    let mut sample_at = vec![None; width as usize * height as usize];
    for (index, s) in sphere.samples.iter().enumerate() {
        sample_at[s.pixel as usize] = Some(index);
    }
    let blocks = block_error::blocks(width, height, |x, y| {
        let s = &sphere.samples[sample_at[(y * width + x) as usize]?];
        Some(BlockPixel {
            model: model(s.theta_rad, s.phi_rad),
            reference: s.radiance,
            cos_theta: s.theta_rad.cos(),
            occluded: 0.0,
        })
    });
    let region = |region| block_error::region_error(&blocks, region).into();
    SphereError {
        lit: region(Region::Lit),
        terminator: region(Region::Terminator),
        shadow: region(Region::Shadow),
        lit_and_terminator: region(Region::LitAndTerminator),
        whole: region(Region::Whole),
    }
}
