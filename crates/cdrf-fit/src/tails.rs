//! The shadow side a photograph could not measure, continued by the diffusion profile.
//!
//! Past some θ a sphere's curve is no longer measured: its pixels are too few (the silhouette,
//! a lamp near the camera), or what is left after subtracting the flagged frame is mostly that
//! frame's noise and the room's light. A flat fill or a noisy average there is what a renderer
//! then shows on every shadow side of that curvature.
//!
//! So from the first shadow-side node (θ ≥ 90°) whose 95 % band, pooled over ±1°, is wider
//! than [`CONTINUE_BAND`] — or that has no measured node within 1°, or lies past the last
//! measured node — the table holds the diffusion profile's sphere `F_k(θ)` instead, scaled per
//! channel to the smoothed curve's ratio to it over the [`MATCH_DEG`] of shadow side before
//! that node: the fall-off diffusion predicts, at the level the photograph measured. The
//! profile itself is fitted to the whole curve. What the continuation cannot know is how f/F
//! drifts past the cut (on the ideal photographs by up to ±40 % between 100° and 130° on the
//! largest spheres), which is why the band must be that wide before it takes over. Measured
//! and tuned: docs/research/captures.md.

use cdrf_core::diffusion::DiffusionProfile;
use glam::Vec3;

use cdrf_core::lut::theta_rad_at;

use crate::curves::CurveFit;
use crate::fit::{confidence_95, one_degree_nodes, pooled_band, theta_nodes_deg};

/// The 95 % band (relative half-width) past which the table continues with the profile.
pub const CONTINUE_BAND: f32 = 0.4;

/// The span before the cut over which the curve's level is matched, degrees: wide enough to
/// average the noise that widened the band, narrow enough that f/F does not drift much.
pub const MATCH_DEG: f32 = 20.0;

/// Per sphere, the first θ node from which the table holds the profile's continuation;
/// `None` where the curve is measured to 180°. Only the shadow side (θ ≥ 90°) is cut.
pub fn cuts(fit: &CurveFit) -> Vec<Option<usize>> {
    (0..fit.curves.len())
        .map(|k| {
            let band = confidence_95(fit, k);
            let n = band.len();
            let half = one_degree_nodes(&theta_nodes_deg(n));
            // Past the last measured node the curve is the fit's fill, never a measurement.
            let unmeasured_from = fit.node_samples[k]
                .iter()
                .rposition(|&samples| samples > 0.0)
                .map_or(0, |last| last + 1);
            (n / 2..n).find(|&i| {
                // NaN (a node whose model is 0) counts as too wide.
                i >= unmeasured_from
                    || pooled_band(&band, i, half)
                        .is_none_or(|b| b.half_width().is_nan() || b.half_width() > CONTINUE_BAND)
            })
        })
        .collect()
}

/// Replaces each curve (f on θ nodes over [0, π], sphere `k` at `curvature_per_mm[k]`) from its
/// cut on by `profile`'s sphere, scaled per channel to the curve's ratio to it over the
/// [`MATCH_DEG`] of shadow side before the cut — over the one or two nodes before it where
/// the cut is the first shadow-side node — and by 1 where those hold no light.
pub fn continue_curves(
    curves: &mut [Vec<Vec3>],
    curvature_per_mm: &[f32],
    cuts: &[Option<usize>],
    profile: &DiffusionProfile,
) {
    for ((curve, &curvature), &cut) in curves.iter_mut().zip(curvature_per_mm).zip(cuts) {
        let n = curve.len();
        let Some(cut) = cut.map(|cut| cut.min(n)) else {
            continue;
        };
        let model = |i: usize| {
            profile.sphere_reflectance(f64::from(curvature), f64::from(theta_rad_at(i, n)))
        };
        let span = (MATCH_DEG * (n.saturating_sub(1)) as f32 / 180.0).round() as usize;
        let mut from = cut.saturating_sub(span).max(n / 2);
        if from == cut {
            from = cut.saturating_sub(span.clamp(1, 2));
        }
        let (mut measured, mut predicted) = ([0.0_f64; 3], [0.0_f64; 3]);
        for i in from..cut {
            let f = model(i);
            for c in 0..3 {
                measured[c] += f64::from(curve[i][c]);
                predicted[c] += f[c];
            }
        }
        let scale: [f64; 3] = std::array::from_fn(|c| {
            if measured[c] > 0.0 && predicted[c] > 0.0 {
                measured[c] / predicted[c]
            } else {
                1.0
            }
        });
        for (i, value) in curve.iter_mut().enumerate().skip(cut) {
            let f = model(i);
            *value = Vec3::from_array(std::array::from_fn(|c| (scale[c] * f[c]) as f32));
        }
    }
}

/// `fit` with no samples counted from each sphere's cut on, so that the table's coverage
/// shows the continuation as filled, not measured.
pub fn coverage_fit(fit: &CurveFit, cuts: &[Option<usize>]) -> CurveFit {
    let mut out = fit.clone();
    for (samples, cut) in out.node_samples.iter_mut().zip(cuts) {
        if let Some(cut) = *cut {
            samples[cut..].fill(0.0);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::curves::{CurveSettings, ViewModel};
    use cdrf_core::diffusion::ProfileTerm;

    const N: usize = 361;

    fn profile() -> DiffusionProfile {
        let terms = vec![
            ProfileTerm {
                length_mm: 1.5,
                weight: [0.5, 0.4, 0.3],
            },
            ProfileTerm {
                length_mm: 8.0,
                weight: [0.4, 0.3, 0.2],
            },
        ];
        DiffusionProfile::new(terms, 0.8).unwrap()
    }

    fn theta_rad(i: usize) -> f64 {
        theta_rad_at(i, N).into()
    }

    /// One sphere's fit, `samples` pixels per node, relative noise `noise(i)` at node i.
    fn fit_with_noise(noise: impl Fn(usize) -> f32) -> CurveFit {
        let curve: Vec<Vec3> = (0..N).map(|_| Vec3::ONE).collect();
        CurveFit {
            settings: CurveSettings {
                theta_count: N,
                phi_count: 19,
                view_model: ViewModel::Phi,
            },
            curves: vec![curve.clone()],
            node_samples: vec![vec![100.0; N]],
            node_noise: vec![(0..N).map(|i| Vec3::splat(noise(i))).collect()],
            node_model_sum: vec![curve],
            node_code_bias_sum: vec![vec![Vec3::ZERO; N]],
            node_ambient_sum: vec![vec![Vec3::ZERO; N]],
            g_phi: vec![Vec3::ONE; 19],
            correction: None,
            outliers: vec![0],
        }
    }

    #[test]
    fn a_curve_measured_to_the_end_is_not_cut() {
        assert_eq!(cuts(&fit_with_noise(|_| 0.1)), vec![None]);
    }

    #[test]
    fn the_cut_is_where_the_band_passes_its_limit() {
        // Band 1.96·noise/√100: 0.04 before 120°, 1.0 from 120° on.
        let fit = fit_with_noise(|i| if i < 240 { 0.2 } else { 5.0 });
        // Pooled over ±1° (inverse variances), the band passes 0.4 once the window holds
        // only noisy nodes: 1° after 120°.
        assert_eq!(cuts(&fit), vec![Some(242)]);
    }

    /// From the first node past the last measured one: the fit's fill there (flat, or 0 where
    /// the last measured node came out 0 — the bundled table's 5 mm sphere at 172.5°) is no
    /// measurement, though a measured node lies within 1°. A gap inside the curve is kept.
    #[test]
    fn a_tail_without_samples_is_cut() {
        let mut fit = fit_with_noise(|_| 0.1);
        fit.node_samples[0][300..].fill(0.0);
        fit.node_samples[0][250] = 0.0;
        assert_eq!(cuts(&fit), vec![Some(300)]);
    }

    #[test]
    fn a_coarse_grid_matches_over_twenty_degrees_and_a_cut_at_ninety_over_the_nodes_before() {
        let profile = profile();
        let kappa = 1.0 / 20.0;
        // 19 nodes, 10° apart: the 20° before a cut at 120° are 2 nodes, both on the shadow
        // side; a cut at 90° matches over the two nodes before it.
        let n = 19;
        let at = |i: usize| profile.sphere_reflectance(kappa, theta_rad_at(i, n).into());
        for (cut, matched) in [(12, 10..12), (9, 7..9)] {
            let mut curve: Vec<Vec3> = (0..n).map(|i| Vec3::splat(2.0 * at(i)[0] as f32)).collect();
            curve[cut..].fill(Vec3::ZERO);
            // A level off by 1.5 outside the matched span must not show.
            for i in (0..n).filter(|i| !matched.contains(i) && *i < cut) {
                curve[i] *= 1.5;
            }
            let mut curves = vec![curve];
            continue_curves(&mut curves, &[kappa as f32], &[Some(cut)], &profile);
            for i in cut..n {
                let want = 2.0 * at(i)[0] as f32;
                let got = curves[0][i].x;
                assert!(
                    (got / want - 1.0).abs() < 1e-4,
                    "cut {cut}, node {i}: {got} vs {want}"
                );
            }
        }
        // A cut past the curve's end changes nothing and does not panic.
        let mut curves = vec![vec![Vec3::ONE; n]];
        continue_curves(&mut curves, &[kappa as f32], &[Some(40)], &profile);
        assert_eq!(curves[0], vec![Vec3::ONE; n]);
    }

    #[test]
    fn the_continuation_follows_the_profile_at_the_measured_level() {
        let profile = profile();
        let kappa = 1.0 / 20.0;
        let level = [1.3, 0.9, 0.6];
        let truth: Vec<Vec3> = (0..N)
            .map(|i| {
                let f = profile.sphere_reflectance(kappa, theta_rad(i));
                Vec3::from_array(std::array::from_fn(|c| (level[c] * f[c]) as f32))
            })
            .collect();
        // Garbage from 120° on (a flat fill of a noisy value).
        let mut curves = vec![truth.clone()];
        curves[0][240..].fill(Vec3::splat(0.05));
        continue_curves(&mut curves, &[kappa as f32], &[Some(240)], &profile);
        for (i, (got, want)) in curves[0].iter().zip(&truth).enumerate() {
            let off = ((*got - *want).abs() / want.max(Vec3::splat(1e-12))).max_element();
            assert!(off < 1e-4, "node {i}: {got} vs {want}");
        }
    }

    #[test]
    fn coverage_counts_no_samples_from_the_cut_on_and_no_cut_changes_nothing() {
        let fit = fit_with_noise(|_| 0.1);
        let mut curves = fit.curves.clone();
        continue_curves(&mut curves, &[0.05], &[None], &profile());
        assert_eq!(curves, fit.curves);
        assert_eq!(coverage_fit(&fit, &[None]).node_samples, fit.node_samples);
        let cut = coverage_fit(&fit, &[Some(300)]).node_samples;
        assert!(cut[0][..300].iter().all(|&n| n == 100.0));
        assert!(cut[0][300..].iter().all(|&n| n == 0.0));
    }
}
