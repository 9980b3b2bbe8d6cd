//! Residual highlights: what imperfect cross-polarisation leaves of the surface's reflection.
//!
//! A highlight sits where the normal is near the half vector h = normalize(l + v), and fades
//! with the angle α between them. Subsurface light does not know h: at one θ, pixels of every α
//! have the same radiance up to the (smooth) view correction. So on the lit side each pixel is
//! compared with the median of its 1° θ bin, the relative excesses are binned by α (1° bins),
//! and the bins from α = 0 outward whose median excess stands clear of the far field
//! (α = 20…50°) by more than four standard errors and 1 % are the highlight. Every pixel within
//! that α, plus one bin, is dropped — the lobe's tails with its core, never only the brightest
//! pixels, which would leave a bias the size of the tails.

use crate::curves::{median, robust_spread};
use crate::sphere::Sample;

/// Lit-side pixels only: a highlight needs the light on the surface.
const MAX_THETA_DEG: f32 = 85.0;
/// Bins of α looked at.
const ALPHA_BINS: usize = 60;
/// The far field the excess is measured against, degrees.
const FAR_FIELD_DEG: std::ops::Range<f32> = 20.0..50.0;

/// Drops the samples in a residual highlight; `half_angle_deg(sample)` is the angle between its
/// normal and the half vector, degrees. Returns how many were dropped.
pub fn reject_highlights(
    samples: &mut Vec<Sample>,
    half_angle_deg: impl Fn(&Sample) -> f32,
) -> usize {
    let luminance = |s: &Sample| s.radiance.element_sum();
    let theta_bin = |s: &Sample| (s.theta_rad.to_degrees().max(0.0) as usize).min(179);
    let mut by_theta: Vec<Vec<f32>> = vec![Vec::new(); 180];
    for s in samples.iter() {
        if s.theta_rad.to_degrees() < MAX_THETA_DEG {
            by_theta[theta_bin(s)].push(luminance(s));
        }
    }
    let theta_median: Vec<Option<f32>> = by_theta.iter_mut().map(|v| median(v)).collect();

    let mut by_alpha: Vec<Vec<f32>> = vec![Vec::new(); ALPHA_BINS];
    let mut far: Vec<f32> = Vec::new();
    for s in samples.iter() {
        if s.theta_rad.to_degrees() >= MAX_THETA_DEG {
            continue;
        }
        let Some(reference) = theta_median[theta_bin(s)].filter(|m| *m > 0.0) else {
            continue;
        };
        let excess = luminance(s) / reference - 1.0;
        let alpha = half_angle_deg(s);
        if FAR_FIELD_DEG.contains(&alpha) {
            far.push(excess);
        }
        if let Some(bin) = by_alpha.get_mut(alpha.max(0.0) as usize) {
            bin.push(excess);
        }
    }
    let Some(baseline) = median(&mut far) else {
        return 0;
    };
    let mut extent = None;
    for (k, bin) in by_alpha.iter_mut().enumerate() {
        if bin.len() < 5 {
            if extent.is_none() {
                continue;
            }
            break;
        }
        let m = median(bin).unwrap_or(0.0);
        let mut deviations: Vec<f32> = bin.iter().map(|v| (v - m).abs()).collect();
        let spread = robust_spread(&mut deviations).unwrap_or(0.0);
        let standard_error = 1.25 * spread / (bin.len() as f32).sqrt();
        if m - baseline > (4.0 * standard_error).max(0.01) {
            extent = Some(k);
        } else {
            break;
        }
    }
    let Some(extent) = extent else {
        return 0;
    };
    let limit = (extent + 2) as f32;
    let before = samples.len();
    samples.retain(|s| s.theta_rad.to_degrees() >= MAX_THETA_DEG || half_angle_deg(s) >= limit);
    before - samples.len()
}
