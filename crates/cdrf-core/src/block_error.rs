//! The one error metric of a model against a reference image: **8 × 8-pixel blocks**, per region.
//!
//! Every comparison in cdrf uses it: `cdrf-fit`'s evaluation of the fitted models against the
//! sphere photographs, `cdrf-viewer compare` against path-traced references, and the render
//! tests. Single pixels are too noisy to compare (path-traced references have ~7 % relative
//! noise per pixel on the lit side and tens of per cent in shadow), so:
//!
//! 1. **Blocks**: the image is cut into [`BLOCK_PX`] × [`BLOCK_PX`] blocks aligned with pixel
//!    (0, 0); a block counts only if *all* its pixels are compared (the caller's mask, e.g. the
//!    render's silhouette eroded by [`covered_mask`], or the pixels a photograph yields samples
//!    for). Per block: the mean model radiance M, the mean reference radiance T (RGB), and the
//!    mean of the caller's per-pixel cos θ and cast-shadow fraction ([`blocks`]).
//! 2. **Regions** by the block's mean cos θ (θ between normal and light) and mean occlusion
//!    ([`Region::contains`]): lit side cos θ ≥ [`TERMINATOR_COS`] (θ ≤ 75°), terminator band
//!    |cos θ| < [`TERMINATOR_COS`], shadow side cos θ ≤ −[`TERMINATOR_COS`], and the cast
//!    shadow: facing the light (cos θ > 0) but more than [`CAST_SHADOW_FRACTION`] of it hidden
//!    from the light by another part of the object — taken out of the lit side and terminator
//!    band. One set of thresholds for every caller.
//! 3. **Errors per region** ([`region_error`]), over the region's blocks b and channels c:
//!    - *relative RMSE* = √(Σ (M − T)²) / √(Σ T²),
//!    - *mean relative error* = Σ |M − T| / Σ T.
//!
//!    Ratios of sums, not means of per-block ratios: a block whose reference is nearly black
//!    (deep shadow, a cast shadow) weighs by its radiance instead of dividing by nearly zero, so
//!    a region's number is not ruled by its darkest, noisiest blocks.
//!
//! ```
//! use cdrf_core::block_error::{BlockPixel, Region, blocks, region_error};
//! use cdrf_core::glam::Vec3;
//!
//! // A 16 × 16 image, left half lit (cos θ = 1), right half in shadow; the model is 2 % too
//! // bright everywhere.
//! let pixels = blocks(16, 16, |x, _y| {
//!     let lit = x < 8;
//!     let reference = if lit { Vec3::splat(0.5) } else { Vec3::splat(0.01) };
//!     Some(BlockPixel {
//!         model: reference * 1.02,
//!         reference,
//!         cos_theta: if lit { 1.0 } else { -1.0 },
//!         occluded: 0.0,
//!     })
//! });
//! assert_eq!(pixels.len(), 4);
//! let lit = region_error(&pixels, Region::Lit);
//! assert_eq!(lit.blocks, 2);
//! assert!((lit.mean_relative_error - 0.02).abs() < 1e-6);
//! assert!((lit.relative_rmse - 0.02).abs() < 1e-6);
//! assert_eq!(region_error(&pixels, Region::CastShadow).blocks, 0);
//! ```

use std::fmt;

use glam::Vec3;
use serde::Serialize;

use crate::image_file::RgbaImage;

/// Side of the blocks, pixels.
pub const BLOCK_PX: u32 = 8;
/// |cos θ| below which a block (or pixel) is in the terminator band: θ within 75°…105°.
pub const TERMINATOR_COS: f32 = 0.26;
/// The fraction of a block hidden from the light above which a block facing the light is in
/// the cast shadow.
pub const CAST_SHADOW_FRACTION: f32 = 0.5;
/// Coverage from which a pixel counts as fully covered by the render (4× MSAA gives 0, ¼, ½, ¾
/// or 1).
pub const FULL_COVERAGE: f32 = 0.999;

/// A region of the object, by the angle θ between normal and light and by cast shadows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Region {
    /// Every compared block.
    Whole,
    /// cos θ ≥ [`TERMINATOR_COS`], not in a cast shadow.
    Lit,
    /// |cos θ| < [`TERMINATOR_COS`], not in a cast shadow.
    Terminator,
    /// cos θ ≤ −[`TERMINATOR_COS`].
    Shadow,
    /// Facing the light (cos θ > 0) but hidden from it by another part of the object (more than
    /// [`CAST_SHADOW_FRACTION`] of the block): light no local model (no CDRF) knows is missing.
    CastShadow,
    /// [`Region::Lit`] and [`Region::Terminator`] together: cos θ > −[`TERMINATOR_COS`], not in a
    /// cast shadow (the regions `cdrf-fit`'s self-consistency target is stated on).
    #[serde(rename = "lit_and_terminator")]
    LitAndTerminator,
}

impl Region {
    /// Whether a block (or pixel) with mean `cos_theta` and `occluded` (the fraction of it hidden
    /// from the light, 0 or 1 for a pixel) belongs to the region.
    pub fn contains(self, cos_theta: f32, occluded: f32) -> bool {
        let cast = occluded > CAST_SHADOW_FRACTION && cos_theta > 0.0;
        match self {
            Region::Whole => true,
            Region::Lit => cos_theta >= TERMINATOR_COS && !cast,
            Region::Terminator => cos_theta.abs() < TERMINATOR_COS && !cast,
            Region::Shadow => cos_theta <= -TERMINATOR_COS,
            Region::CastShadow => cast,
            Region::LitAndTerminator => cos_theta > -TERMINATOR_COS && !cast,
        }
    }
}

impl fmt::Display for Region {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Region::Whole => "whole object",
            Region::Lit => "lit side",
            Region::Terminator => "terminator band",
            Region::Shadow => "shadow side",
            Region::CastShadow => "cast shadow",
            Region::LitAndTerminator => "lit side and terminator band",
        })
    }
}

/// What [`blocks`] needs of one compared pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BlockPixel {
    /// The model's (the render's) linear radiance, RGB.
    pub model: Vec3,
    /// The reference's linear radiance, RGB.
    pub reference: Vec3,
    /// cos θ, θ between the surface normal and the light.
    pub cos_theta: f32,
    /// 1 where the point is hidden from the light by another part of the object, else 0.
    pub occluded: f32,
}

/// One block wholly inside the compared pixels: the means of its [`BLOCK_PX`]² pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Block {
    /// Block column (its pixels are `column · BLOCK_PX ..` across).
    pub column: u32,
    /// Block row.
    pub row: u32,
    /// Mean model radiance.
    pub model: Vec3,
    /// Mean reference radiance.
    pub reference: Vec3,
    /// Mean cos θ.
    pub cos_theta: f32,
    /// Fraction of the block hidden from the light.
    pub occluded: f32,
}

impl Block {
    /// Whether the block is in `region` ([`Region::contains`] of its means).
    pub fn is_in(&self, region: Region) -> bool {
        region.contains(self.cos_theta, self.occluded)
    }

    /// (ΣM − ΣT) / ΣT over the channels: positive where the model is too bright (the figures'
    /// per-block colour). 0 where the reference is black.
    pub fn signed_relative_error(&self) -> f32 {
        let total = self.reference.element_sum();
        if total > 0.0 {
            (self.model - self.reference).element_sum() / total
        } else {
            0.0
        }
    }
}

/// The blocks of a `width` × `height` image wholly inside the compared pixels, row by row.
/// `pixel(x, y)` gives a compared pixel's values, `None` for a pixel not compared (a block
/// with one such pixel is skipped; its remaining pixels are not asked for). Blocks cut by the
/// right or bottom edge are never complete and never count.
pub fn blocks(
    width: u32,
    height: u32,
    mut pixel: impl FnMut(u32, u32) -> Option<BlockPixel>,
) -> Vec<Block> {
    let mut out = Vec::new();
    let count = (BLOCK_PX * BLOCK_PX) as f32;
    for row in 0..height / BLOCK_PX {
        'block: for column in 0..width / BLOCK_PX {
            let mut sum = BlockPixel::default();
            for y in row * BLOCK_PX..(row + 1) * BLOCK_PX {
                for x in column * BLOCK_PX..(column + 1) * BLOCK_PX {
                    let Some(p) = pixel(x, y) else {
                        continue 'block;
                    };
                    sum.model += p.model;
                    sum.reference += p.reference;
                    sum.cos_theta += p.cos_theta;
                    sum.occluded += p.occluded;
                }
            }
            out.push(Block {
                column,
                row,
                model: sum.model / count,
                reference: sum.reference / count,
                cos_theta: sum.cos_theta / count,
                occluded: sum.occluded / count,
            });
        }
    }
    out
}

/// The errors of one region (the module docs define them).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct RegionError {
    /// Blocks in the region.
    pub blocks: usize,
    /// √(Σ (M − T)²) / √(Σ T²) over the region's blocks and channels; NaN without blocks (or
    /// with a black reference).
    pub relative_rmse: f64,
    /// Σ |M − T| / Σ T over the region's blocks and channels; NaN without blocks (or with a
    /// black reference).
    pub mean_relative_error: f64,
    /// Mean reference radiance of the region's blocks over channels, for scale (the relative
    /// errors of a nearly black region are large however small the absolute error); NaN
    /// without blocks.
    pub reference_mean_radiance: f64,
}

/// The errors of the `blocks` in `region`.
pub fn region_error(blocks: &[Block], region: Region) -> RegionError {
    let (mut squared_error, mut squared_reference, mut absolute_error, mut total, mut count) =
        (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0usize);
    for block in blocks.iter().filter(|block| block.is_in(region)) {
        for c in 0..3 {
            let (m, t) = (f64::from(block.model[c]), f64::from(block.reference[c]));
            squared_error += (m - t) * (m - t);
            squared_reference += t * t;
            absolute_error += (m - t).abs();
            total += t;
        }
        count += 1;
    }
    let ratio = |numerator: f64, denominator: f64| {
        if denominator > 0.0 {
            numerator / denominator
        } else {
            f64::NAN
        }
    };
    RegionError {
        blocks: count,
        relative_rmse: ratio(squared_error, squared_reference).sqrt(),
        mean_relative_error: ratio(absolute_error, total),
        reference_mean_radiance: ratio(total, (3 * count) as f64),
    }
}

/// Per pixel of `render`: whether it and every pixel within `erode_px` of it (a square) are
/// fully covered ([`FULL_COVERAGE`]) — the render's silhouette eroded, so that edge pixels
/// (partial coverage, sub-pixel silhouette differences) are never compared.
pub fn covered_mask(render: &RgbaImage, erode_px: u32) -> Vec<bool> {
    let (w, h) = (i64::from(render.width), i64::from(render.height));
    let erode = i64::from(erode_px);
    let full = |x: i64, y: i64| {
        x >= 0
            && y >= 0
            && x < w
            && y < h
            && render
                .pixels
                .get((y * w + x) as usize)
                .is_some_and(|p| p[3] >= FULL_COVERAGE)
    };
    let mut mask = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            mask.push((-erode..=erode).all(|dy| (-erode..=erode).all(|dx| full(x + dx, y + dy))));
        }
    }
    mask
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pixel(model: f32, reference: f32, cos_theta: f32) -> Option<BlockPixel> {
        Some(BlockPixel {
            model: Vec3::splat(model),
            reference: Vec3::splat(reference),
            cos_theta,
            occluded: 0.0,
        })
    }

    #[test]
    fn a_block_with_one_pixel_outside_the_mask_is_skipped() {
        let found = blocks(17, 9, |x, y| {
            if (x, y) == (3, 3) {
                None
            } else {
                pixel(1.0, 1.0, 1.0)
            }
        });
        // 2 × 1 complete blocks fit in 17 × 9; the first has a hole.
        assert_eq!(found.len(), 1);
        assert_eq!((found[0].column, found[0].row), (1, 0));
    }

    #[test]
    fn errors_are_ratios_of_sums() {
        // Two lit blocks: one bright and 10 % too dark, one nearly black and 100 % too bright.
        let found = blocks(16, 8, |x, _| {
            if x < 8 {
                pixel(0.9, 1.0, 1.0)
            } else {
                pixel(0.02, 0.01, 1.0)
            }
        });
        let lit = region_error(&found, Region::Lit);
        assert_eq!(lit.blocks, 2);
        // Σ|M − T| / Σ T = (0.1 + 0.01) / 1.01, not (10 % + 100 %) / 2.
        let expected = 0.11 / 1.01;
        assert!((lit.mean_relative_error - expected).abs() < 1e-6, "{lit:?}");
        let expected_rmse = ((0.01f64 + 0.0001) / (1.0 + 0.0001)).sqrt();
        assert!((lit.relative_rmse - expected_rmse).abs() < 1e-6, "{lit:?}");
        assert!((lit.reference_mean_radiance - 0.505).abs() < 1e-6);
        assert!((found[0].signed_relative_error() + 0.1).abs() < 1e-6);
    }

    #[test]
    fn regions_split_at_the_named_thresholds() {
        let t = TERMINATOR_COS;
        assert!(Region::Lit.contains(t, 0.0) && !Region::Terminator.contains(t, 0.0));
        assert!(Region::Terminator.contains(t - 1e-3, 0.0));
        assert!(Region::Shadow.contains(-t, 0.0) && !Region::LitAndTerminator.contains(-t, 0.0));
        assert!(Region::LitAndTerminator.contains(-t + 1e-3, 0.0));
        // A cast shadow leaves the lit side and the terminator band, not the shadow side.
        assert!(Region::CastShadow.contains(0.5, 1.0) && !Region::Lit.contains(0.5, 1.0));
        assert!(!Region::CastShadow.contains(-0.5, 1.0) && Region::Shadow.contains(-0.5, 1.0));
        assert!(Region::Whole.contains(0.5, 1.0));
    }

    #[test]
    fn an_empty_region_has_no_numbers() {
        let error = region_error(&[], Region::Lit);
        assert_eq!(error.blocks, 0);
        assert!(error.relative_rmse.is_nan() && error.mean_relative_error.is_nan());
    }

    #[test]
    fn the_mask_erodes_the_silhouette() {
        let mut image = RgbaImage::new(7, 7);
        for (i, p) in image.pixels.iter_mut().enumerate() {
            let (x, y) = (i % 7, i / 7);
            if (1..6).contains(&x) && (1..6).contains(&y) {
                p[3] = 1.0;
            } else {
                p[3] = 0.75;
            }
        }
        let mask = covered_mask(&image, 2);
        let kept: Vec<usize> = (0..49).filter(|&i| mask[i]).collect();
        assert_eq!(kept, vec![3 * 7 + 3]);
        assert_eq!(covered_mask(&image, 0).iter().filter(|m| **m).count(), 25);
    }
}
