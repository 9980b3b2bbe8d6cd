//! Render / reference by θ bin: how much of the reference's light a model reproduces at each
//! angle between normal and light, the table the non-local terms are measured by.
//!
//! For each bin of θ (from the same per-pixel cos θ as the regions) the ratio Σ render / Σ
//! reference of the mean of R, G and B over the bin's compared pixels that are not in a cast
//! shadow, and the same ratio over the cast-shadow pixels (facing the light, hidden from it by
//! the object). A ratio of sums over thousands of pixels: the references' per-pixel noise
//! (tens of per cent on the shadow side) averages out, and a nearly black pixel cannot dominate.
//! 1 is right; 0.5 means half the light is missing.

use cdrf_core::block_error::CAST_SHADOW_FRACTION;
use cdrf_core::image_file::RgbaImage;
use serde::Serialize;

use crate::models::ComparedModel;

/// Bin edges in degrees of θ: the bins `[e₀, e₁)`, `[e₁, e₂)`, …; the last includes 180°.
pub const THETA_BIN_EDGES_DEG: [f64; 9] = [0.0, 50.0, 70.0, 80.0, 90.0, 100.0, 110.0, 130.0, 180.0];

/// Number of θ bins.
pub const THETA_BINS: usize = THETA_BIN_EDGES_DEG.len() - 1;

/// A case's table: pixels per bin and every model's ratios.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ThetaTable {
    /// Compared pixels per θ bin (cast shadows left out).
    pub pixels: [usize; THETA_BINS],
    /// Compared pixels in a cast shadow.
    pub cast_shadow_pixels: usize,
    /// One row per model, in the case's order.
    pub models: Vec<ThetaRatios>,
}

impl ThetaTable {
    /// The row of `model`.
    pub fn ratios(&self, model: ComparedModel) -> Option<&ThetaRatios> {
        self.models.iter().find(|row| row.model == model)
    }
}

/// One model's row.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ThetaRatios {
    /// The model.
    pub model: ComparedModel,
    /// Σ render / Σ reference per θ bin; NaN (`null` in JSON) where a bin is empty or black.
    pub bins: [f64; THETA_BINS],
    /// The same over the cast-shadow pixels.
    pub cast_shadow: f64,
}

/// The table of one case: per pixel compared (`mask`), its `cos_theta` and whether the object
/// hides it from the light (`occluded`), every render (of `models`, in that order) against
/// `reference`.
pub(crate) fn table(
    models: &[ComparedModel],
    mask: &[bool],
    cos_theta: &[f32],
    occluded: &[f32],
    reference: &RgbaImage,
    renders: &[RgbaImage],
) -> ThetaTable {
    let bins: Vec<Option<usize>> = mask
        .iter()
        .zip(cos_theta)
        .zip(occluded)
        .map(|((&compared, &cos_theta), &occluded)| pixel_bin(compared, cos_theta, occluded))
        .collect();
    let (pixels, cast_shadow_pixels) = counts(&bins);
    ThetaTable {
        pixels,
        cast_shadow_pixels,
        models: models
            .iter()
            .copied()
            .zip(renders)
            .map(|(model, render)| ratios(model, render, reference, &bins))
            .collect(),
    }
}

/// Which bin a pixel counts in: `Some(THETA_BINS)` for a cast shadow, `None` if not compared.
fn pixel_bin(compared: bool, cos_theta: f32, occluded: f32) -> Option<usize> {
    if !compared || !cos_theta.is_finite() {
        return None;
    }
    if cos_theta > 0.0 && occluded > CAST_SHADOW_FRACTION {
        return Some(THETA_BINS);
    }
    let degrees = f64::from(cos_theta.clamp(-1.0, 1.0)).acos().to_degrees();
    let bin = THETA_BIN_EDGES_DEG[1..]
        .iter()
        .position(|&edge| degrees < edge)
        .unwrap_or(THETA_BINS - 1);
    Some(bin)
}

/// The ratios of `render` to `reference` over the pixels `bins` assigns (see [`pixel_bin`]).
fn ratios(
    model: ComparedModel,
    render: &RgbaImage,
    reference: &RgbaImage,
    bins: &[Option<usize>],
) -> ThetaRatios {
    let mean = |p: [f32; 4]| (f64::from(p[0]) + f64::from(p[1]) + f64::from(p[2])) / 3.0;
    let mut sums = [(0.0f64, 0.0f64); THETA_BINS + 1];
    for ((bin, r), t) in bins.iter().zip(&render.pixels).zip(&reference.pixels) {
        if let Some(bin) = *bin {
            sums[bin].0 += mean(*r);
            sums[bin].1 += mean(*t);
        }
    }
    let ratio = |(r, t): (f64, f64)| if t > 0.0 { r / t } else { f64::NAN };
    ThetaRatios {
        model,
        bins: std::array::from_fn(|i| ratio(sums[i])),
        cast_shadow: ratio(sums[THETA_BINS]),
    }
}

/// Pixels per bin (the table's second row).
fn counts(bins: &[Option<usize>]) -> ([usize; THETA_BINS], usize) {
    let mut counts = [0usize; THETA_BINS + 1];
    for bin in bins.iter().flatten() {
        counts[*bin] += 1;
    }
    (std::array::from_fn(|i| counts[i]), counts[THETA_BINS])
}

/// The table as Markdown: one column per bin and the cast shadow, one row per model.
pub(crate) fn markdown(table: &ThetaTable) -> String {
    let mut text = String::from("| render / reference by θ |");
    for pair in THETA_BIN_EDGES_DEG.windows(2) {
        text.push_str(&format!(" {:.0}–{:.0}° |", pair[0], pair[1]));
    }
    text.push_str(" cast shadow |\n|---|");
    text.push_str(&"---|".repeat(THETA_BINS + 1));
    text.push_str("\n| pixels |");
    for count in table.pixels.iter().chain([&table.cast_shadow_pixels]) {
        text.push_str(&format!(" {count} |"));
    }
    text.push('\n');
    let cell = |value: f64| {
        if value.is_finite() {
            format!(" {value:.2} |")
        } else {
            " — |".to_owned()
        }
    };
    for row in &table.models {
        text.push_str(&format!("| {} |", row.model));
        for &value in row.bins.iter().chain([&row.cast_shadow]) {
            text.push_str(&cell(value));
        }
        text.push('\n');
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(values: &[f32]) -> RgbaImage {
        RgbaImage {
            width: values.len() as u32,
            height: 1,
            pixels: values.iter().map(|&v| [v, v, v, 1.0]).collect(),
        }
    }

    #[test]
    fn pixels_land_in_their_theta_bin_or_the_cast_shadow() {
        let cos = |deg: f64| deg.to_radians().cos() as f32;
        assert_eq!(pixel_bin(true, cos(10.0), 0.0), Some(0));
        assert_eq!(pixel_bin(true, cos(60.0), 0.0), Some(1));
        assert_eq!(pixel_bin(true, cos(95.0), 0.0), Some(4));
        assert_eq!(
            pixel_bin(true, cos(120.0), 1.0),
            Some(6),
            "facing away: not a cast shadow"
        );
        assert_eq!(
            pixel_bin(true, -1.0, 0.0),
            Some(THETA_BINS - 1),
            "θ = 180° is in the last bin"
        );
        assert_eq!(pixel_bin(true, cos(30.0), 1.0), Some(THETA_BINS));
        assert_eq!(pixel_bin(false, cos(30.0), 0.0), None);
        assert_eq!(pixel_bin(true, f32::NAN, 0.0), None);
    }

    #[test]
    fn ratios_are_ratios_of_sums_per_bin() {
        // Bin 0: render half the reference; bin 7: twice; the cast shadow: 1.5 ×; bin 3 empty.
        let bins = [Some(0), Some(0), Some(7), Some(THETA_BINS), None];
        let reference = image(&[1.0, 3.0, 0.5, 2.0, 100.0]);
        let render = image(&[0.5, 1.5, 1.0, 3.0, 0.0]);
        let row = ratios(ComparedModel::ALL[0], &render, &reference, &bins);
        assert_eq!(row.bins[0], 0.5);
        assert_eq!(row.bins[7], 2.0);
        assert_eq!(row.cast_shadow, 1.5);
        assert!(row.bins[3].is_nan());
        assert_eq!(counts(&bins), ([2, 0, 0, 0, 0, 0, 0, 1], 1));
    }
}
