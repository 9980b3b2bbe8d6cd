//! The φ correction: fitting `L(θ, φ; κ) ≈ f(θ; κ) · g(φ) [· c(θ, φ)]` to every pixel.
//!
//! # Model
//! On a sphere lit at 90° to the view, θ (normal–light) and φ (normal–view) are correlated, so
//! a curve of radiance against θ alone mixes in the view dependence (the poster's Fig. 2, raw).
//! We fit, jointly over all spheres k:
//! - `f_k(θ)`: one curve per sphere, piecewise linear on the table's θ nodes (0.5° by default);
//! - `g(φ)`: one view correction **shared by all radii**, piecewise linear on φ nodes over
//!   [0, 90°], normalised to `g(0) = 1` — the poster's form, which keeps the table
//!   interpolable across radii;
//! - optionally `c_k(θ, φ)`: a smooth multiplicative correction on a coarse bilinear grid (10°),
//!   **one per sphere**, smooth where the data says nothing ([`ViewModel::ThetaPhi`]);
//!   the table interpolates it across curvature like f (LUT format 5's curvature layers). It is
//!   needed because the exitant radiance of a diffusing medium is `Φ/4π + 3/(4π)·F·ω`: the net
//!   flux F points into the surface on the lit side and along it near the terminator, so grazing
//!   views are relatively brighter on the lit side and darker on the shadow side — no single
//!   g(φ) can do both, and small spheres need another c than large ones. What one shared g and
//!   one shared c cost on the bundled spheres: `docs/research/fit-notes.md`.
//!
//! Only the product is measured. With c fitted, the split is fixed at the end (`fix_ring_gauge`):
//! f(θ) is what an ideal photograph (orthographic, light at 90° to the view) shows averaged
//! over its ring at θ, so every capture geometry gives the same f to the profile and
//! transmission fits. Without c, g(0) = 1 fixes it, as in the poster.
//!
//! # Fit
//! Alternating weighted least squares, **per pixel**: each sample enters with its exact θ and φ
//! through the hat functions of the nodes around it (no binning: within a 5° bin the lit side
//! changes by several percent, which a binned fit would mistake for a φ effect). Weights are
//! inverse variances: the relative noise of each sphere's 10° θ band is re-estimated from the
//! residuals (a robust median of absolute deviations) and a sample's weight is
//! `1 / (noise · model)²`, at the model of the last reweighting (for the view factors, at the
//! model as it is when they are fitted where it has more than doubled since). Samples off their
//! model by more than 6 noise units (glints, dust) are dropped as outliers. Nodes with no
//! samples (θ near 0° and 180° lie on the silhouette) are filled by a light first-difference
//! penalty: flat toward the ends, as f's even symmetry about 0 and π requires, and linear
//! across gaps.

use cdrf_core::linear::{SingularColumn, solve_gaussian, solve_tridiagonal};
use glam::Vec3;
use rayon::prelude::*;

use crate::sphere::Sample;

/// Which view correction to fit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ViewModel {
    /// The poster's g(φ), shared by all radii.
    Phi,
    /// g(φ) times a smooth θ-dependent correction c(θ, φ) per sphere.
    #[default]
    ThetaPhi,
}

/// Resolution and model of the fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurveSettings {
    /// θ nodes over [0, π] (the table's columns).
    pub theta_count: usize,
    /// φ nodes of g over [0, π/2].
    pub phi_count: usize,
    /// Which view correction.
    pub view_model: ViewModel,
}

impl Default for CurveSettings {
    fn default() -> Self {
        Self {
            theta_count: 361,
            phi_count: 19,
            view_model: ViewModel::default(),
        }
    }
}

/// θ rows and φ columns of the coarse θ-dependent correction c(θ, φ) (10° apart).
pub const CORRECTION_THETA_COUNT: usize = 19;
/// See [`CORRECTION_THETA_COUNT`].
pub const CORRECTION_PHI_COUNT: usize = 10;

/// The samples of one sphere.
#[derive(Clone, Debug)]
pub struct SphereSamples {
    /// κ = 1/r, mm⁻¹.
    pub curvature_per_mm: f32,
    /// Width of its image, pixels (to locate [`Sample::pixel`]).
    pub image_width: u32,
    /// Its usable pixels.
    pub samples: Vec<Sample>,
}

/// The fitted curves and view correction.
#[derive(Clone, Debug)]
pub struct CurveFit {
    /// The settings used.
    pub settings: CurveSettings,
    /// f_k(θ) on the θ nodes, per sphere (input order), π·L/E.
    pub curves: Vec<Vec<Vec3>>,
    /// Effective number of samples per θ node per sphere (sum of hat weights; 0 = filled).
    pub node_samples: Vec<Vec<f32>>,
    /// Relative noise per θ node per sphere (robust, from residuals).
    pub node_noise: Vec<Vec<Vec3>>,
    /// Per θ node per sphere, sums over the node's samples with their hat weights (0 where
    /// filled), π·L/E: the model, floored at [`MODEL_FLOOR`] of the peak like the weights, so
    /// that the two sums below divide by it into relative values and pool as sums over nodes.
    pub node_model_sum: Vec<Vec<Vec3>>,
    /// The files' code bias bounds ([`code_bias_bound`]), summed like `node_model_sum`.
    pub node_code_bias_sum: Vec<Vec<Vec3>>,
    /// The flagged frame's light, summed like `node_model_sum` (0 without a flagged frame;
    /// see [`crate::fit::ROOM_DOMINATED`]).
    pub node_ambient_sum: Vec<Vec<Vec3>>,
    /// The poster's g(φ) on the φ nodes, g(0) = 1.
    pub g_phi: Vec<Vec3>,
    /// c_k(θ, φ) per sphere (input order) on the coarse grid (row-major, θ rows), when fitted.
    pub correction: Option<Vec<Vec<Vec3>>>,
    /// Samples dropped as outliers, per sphere.
    pub outliers: Vec<usize>,
}

impl CurveFit {
    /// The full view factor g(φ)·c_k(θ, φ) of sphere `k` at a sample's angles.
    pub fn view_factor(&self, sphere: usize, theta_rad: f32, phi_rad: f32) -> Vec3 {
        let basis = Basis::new(theta_rad, phi_rad, &self.settings);
        self.view_factor_at(sphere, &basis)
    }

    /// f_k(θ)·g(φ)·c_k(θ, φ) at a sample's basis.
    fn model_at(&self, sphere: usize, basis: &Basis) -> Vec3 {
        hat(&self.curves[sphere], basis.theta) * self.view_factor_at(sphere, basis)
    }

    fn view_factor_at(&self, sphere: usize, basis: &Basis) -> Vec3 {
        let g = hat(&self.g_phi, basis.phi);
        match &self.correction {
            None => g,
            Some(c) => g * basis.coarse.evaluate(&c[sphere]),
        }
    }

    /// The model radiance f_k(θ)·g(φ)·c_k(θ, φ) of sphere `k`, π·L/E.
    pub fn model(&self, sphere: usize, theta_rad: f32, phi_rad: f32) -> Vec3 {
        let basis = Basis::new(theta_rad, phi_rad, &self.settings);
        hat(&self.curves[sphere], basis.theta) * self.view_factor_at(sphere, &basis)
    }
}

/// A node index and the weight of the next node: value = v[i]·(1 − t) + v[i + 1]·t.
type Hat = (u32, f32);

fn hat_coordinate(value: f32, extent: f32, count: usize) -> Hat {
    let u = (value / extent * (count - 1) as f32).clamp(0.0, (count - 1) as f32);
    let i = (u as usize).min(count - 2);
    (i as u32, u - i as f32)
}

fn hat(values: &[Vec3], (i, t): Hat) -> Vec3 {
    let i = i as usize;
    values[i] * (1.0 - t) + values[i + 1] * t
}

/// A curve given on uniform θ nodes over [0, π] (at least two), read linearly at `theta_rad`.
pub(crate) fn on_theta_nodes(values: &[Vec3], theta_rad: f32) -> Vec3 {
    hat(
        values,
        hat_coordinate(theta_rad, std::f32::consts::PI, values.len()),
    )
}

/// The median of `values` (the upper of the middle two for an even count; reorders them);
/// `None` when empty.
pub(crate) fn median(values: &mut [f32]) -> Option<f32> {
    if values.is_empty() {
        return None;
    }
    let middle = values.len() / 2;
    let (_, m, _) = values.select_nth_unstable_by(middle, f32::total_cmp);
    Some(*m)
}

/// A robust spread of absolute deviations: 1.4826 × their median, σ for Gaussian ones (`None`
/// when empty; reorders them).
pub(crate) fn robust_spread(absolute_deviations: &mut [f32]) -> Option<f32> {
    median(absolute_deviations).map(|m| 1.4826 * m)
}

/// [`robust_spread`] of each band's and channel's absolute deviations, where there are at least
/// `min_count` of them.
fn band_spreads(deviations: &mut [[Vec<f32>; 3]], min_count: usize) -> Vec<[Option<f32>; 3]> {
    deviations
        .iter_mut()
        .map(|channels| {
            channels.each_mut().map(|values| {
                (values.len() >= min_count)
                    .then(|| robust_spread(values))
                    .flatten()
            })
        })
        .collect()
}

/// The floor under a curve's model values (per channel): MODEL_FLOOR of its peak, at least
/// 10⁻¹²; below it a ratio to the model measures the floor, not the curve.
fn model_floor(curve: &[Vec3]) -> Vec3 {
    let peak = curve.iter().fold(Vec3::ZERO, |m, v| m.max(*v));
    (peak * MODEL_FLOOR).max(Vec3::splat(1e-12))
}

/// Bilinear coordinates on the coarse correction grid.
#[derive(Clone, Copy, Debug)]
struct Coarse {
    theta: Hat,
    phi: Hat,
}

impl Coarse {
    fn nodes(&self) -> [(usize, f32); 4] {
        let ((a, ta), (b, tb)) = (self.theta, self.phi);
        let (a, b) = (a as usize, b as usize);
        let at = |a: usize, b: usize| a * CORRECTION_PHI_COUNT + b;
        [
            (at(a, b), (1.0 - ta) * (1.0 - tb)),
            (at(a, b + 1), (1.0 - ta) * tb),
            (at(a + 1, b), ta * (1.0 - tb)),
            (at(a + 1, b + 1), ta * tb),
        ]
    }

    fn evaluate(&self, grid: &[Vec3]) -> Vec3 {
        self.nodes().iter().map(|&(i, w)| grid[i] * w).sum()
    }
}

#[derive(Clone, Copy, Debug)]
struct Basis {
    theta: Hat,
    phi: Hat,
    coarse: Coarse,
}

impl Basis {
    fn new(theta_rad: f32, phi_rad: f32, settings: &CurveSettings) -> Self {
        use std::f32::consts::{FRAC_PI_2, PI};
        Self {
            theta: hat_coordinate(theta_rad, PI, settings.theta_count),
            phi: hat_coordinate(phi_rad, FRAC_PI_2, settings.phi_count),
            coarse: Coarse {
                theta: hat_coordinate(theta_rad, PI, CORRECTION_THETA_COUNT),
                phi: hat_coordinate(phi_rad, FRAC_PI_2, CORRECTION_PHI_COUNT),
            },
        }
    }
}

/// A sample prepared for the fit.
#[derive(Clone, Copy, Debug)]
struct Point {
    basis: Basis,
    radiance: Vec3,
    /// Inverse-variance weight per channel; 0 for an outlier.
    weight: Vec3,
    /// Its band's relative noise at the last reweighting (0 before the first).
    relative_noise: Vec3,
    /// The model (floored) its weight was computed at.
    weighted_model: Vec3,
    /// Per channel: dropped as an outlier (stays dropped).
    outlier: glam::BVec3,
    /// 10° θ band, for the noise estimate.
    band: u8,
    /// See [`Sample::code_step`].
    code_step: Vec3,
    /// See [`Sample::lossy`].
    lossy: bool,
    /// See [`Sample::ambient`].
    ambient: Vec3,
}

impl Point {
    /// The weight for the view factors, which are fitted after f, at the model as it is then
    /// (floored like the weights): where the model has more than doubled since the last
    /// reweighting (f at a sparse shadow-side node that lost most of its samples as outliers),
    /// the stale weight 1/(noise·model)² would let its few samples outweigh the lit side's
    /// thousands at their φ. Elsewhere the weight is kept as it was.
    fn weight_now(&self, model: Vec3) -> Vec3 {
        let sigma = self.relative_noise * model;
        let stale =
            model.cmpgt(self.weighted_model * MODEL_GROWTH) & self.relative_noise.cmpgt(Vec3::ZERO);
        Vec3::select(
            stale & !self.outlier,
            Vec3::ONE / (sigma * sigma),
            self.weight,
        )
    }
}

/// How much a sample's model may grow between reweightings before its weight is recomputed
/// for the view factors ([`Point::weight_now`]).
const MODEL_GROWTH: f32 = 2.0;

const BANDS: usize = 18;

/// Fraction of a sphere's peak (per channel) below which the fit floors its model when
/// weighting samples and estimating noise: values below `MODEL_FLOOR · peak` are not resolved
/// (their weights, and their band's noise, are those of the floor).
pub const MODEL_FLOOR: f32 = 1e-4;

/// The fit with the requested view model, and the poster's g(φ)-only fit it started from (the
/// same when the poster's model was requested), so both residuals can be reported.
#[derive(Clone, Debug)]
pub struct CurveFits {
    /// The requested model.
    pub chosen: CurveFit,
    /// The poster's model, g(φ) only.
    pub poster: CurveFit,
}

/// Fits curves and view correction to the spheres' samples.
///
/// # Panics
/// If `settings` has fewer than 2 θ or φ nodes.
pub fn fit_curves(spheres: &[SphereSamples], settings: CurveSettings) -> CurveFits {
    assert!(settings.theta_count >= 2 && settings.phi_count >= 2);
    let mut points: Vec<Vec<Point>> = spheres
        .par_iter()
        .map(|sphere| {
            sphere
                .samples
                .iter()
                .map(|s| Point {
                    basis: Basis::new(s.theta_rad, s.phi_rad, &settings),
                    radiance: s.radiance,
                    weight: Vec3::ONE,
                    relative_noise: Vec3::ZERO,
                    weighted_model: Vec3::ZERO,
                    outlier: glam::BVec3::FALSE,
                    band: ((s.theta_rad.to_degrees() / 10.0) as usize).min(BANDS - 1) as u8,
                    code_step: s.code_step,
                    lossy: s.lossy,
                    ambient: s.ambient,
                })
                .collect()
        })
        .collect();

    let mut fit = CurveFit {
        settings,
        curves: vec![vec![Vec3::ZERO; settings.theta_count]; spheres.len()],
        node_samples: vec![vec![0.0; settings.theta_count]; spheres.len()],
        node_noise: vec![vec![Vec3::ZERO; settings.theta_count]; spheres.len()],
        node_model_sum: vec![vec![Vec3::ZERO; settings.theta_count]; spheres.len()],
        node_code_bias_sum: vec![vec![Vec3::ZERO; settings.theta_count]; spheres.len()],
        node_ambient_sum: vec![vec![Vec3::ZERO; settings.theta_count]; spheres.len()],
        g_phi: vec![Vec3::ONE; settings.phi_count],
        correction: None,
        outliers: vec![0; spheres.len()],
    };

    // Unweighted start, then inverse-variance weights, outlier rejection, and the θ-dependent
    // correction last (it only refines what the poster's model leaves).
    let mut noise = vec![[Vec3::ONE; BANDS]; spheres.len()];
    // (re-estimate weights first, and drop outliers while doing so)
    let stages = [(false, false), (true, false), (true, true), (true, false)];
    for (reweight, reject) in stages {
        if reweight {
            reweight_points(&fit, &mut points, &mut noise, reject);
        }
        fit_f(&mut fit, &points);
        fit_g(&mut fit, &points);
    }
    let poster = finish(
        CurveFit {
            settings: CurveSettings {
                view_model: ViewModel::Phi,
                ..settings
            },
            ..fit.clone()
        },
        &points,
        &noise,
    );
    if settings.view_model == ViewModel::Phi {
        return CurveFits {
            chosen: poster.clone(),
            poster,
        };
    }
    fit.correction = Some(vec![
        vec![
            Vec3::ONE;
            CORRECTION_THETA_COUNT * CORRECTION_PHI_COUNT
        ];
        spheres.len()
    ]);
    for round in 0..2 {
        fit_correction(&mut fit, &points);
        fit_f(&mut fit, &points);
        fit_g(&mut fit, &points);
        if round == 0 {
            reweight_points(&fit, &mut points, &mut noise, false);
        }
    }
    fix_ring_gauge(&mut fit);
    fit_f(&mut fit, &points);
    CurveFits {
        chosen: finish(fit, &points, &noise),
        poster,
    }
}

/// Fills in the per-node sample counts, noise, systematic bounds and outlier counts.
fn finish(mut fit: CurveFit, points: &[Vec<Point>], noise: &[[Vec3; BANDS]]) -> CurveFit {
    let theta_count = fit.settings.theta_count;
    for (k, sphere_points) in points.iter().enumerate() {
        fit.outliers[k] = sphere_points.iter().filter(|p| p.outlier.any()).count();
        let mut counts = vec![0.0_f32; theta_count];
        let model_at = |p: &Point| fit.model_at(k, &p.basis);
        let floor = model_floor(&fit.curves[k]);
        // Absolute noise per band (what dithers the codes; the relative noise is floored).
        let mut deviations: Vec<[Vec<f32>; 3]> = vec![Default::default(); BANDS];
        for p in sphere_points.iter().filter(|p| !p.outlier.any()) {
            let residual = (p.radiance - model_at(p)).abs();
            for c in 0..3 {
                deviations[p.band as usize][c].push(residual[c]);
            }
        }
        let sigma: Vec<Vec3> = band_spreads(&mut deviations, 1)
            .into_iter()
            .map(|spread| Vec3::from_array(spread.map(|s| s.unwrap_or(0.0))))
            .collect();
        let mut bound = vec![Vec3::ZERO; theta_count];
        let mut ambient = vec![Vec3::ZERO; theta_count];
        let mut model = vec![Vec3::ZERO; theta_count];
        for p in sphere_points {
            let (a, t) = p.basis.theta;
            let a = a as usize;
            counts[a] += 1.0 - t;
            counts[a + 1] += t;
            let m = model_at(p).abs().max(floor);
            let b = code_bias_bound(p.code_step, sigma[p.band as usize], p.lossy);
            for (node, w) in [(a, 1.0 - t), (a + 1, t)] {
                bound[node] += w * b;
                ambient[node] += w * p.ambient;
                model[node] += w * m;
            }
        }
        fit.node_model_sum[k] = model;
        fit.node_code_bias_sum[k] = bound;
        fit.node_ambient_sum[k] = ambient;
        fit.node_samples[k] = counts;
        fit.node_noise[k] = (0..theta_count)
            .map(|a| {
                let theta_deg = 180.0 * a as f32 / (theta_count - 1) as f32;
                let band = ((theta_deg / 10.0) as usize).min(BANDS - 1);
                noise[k][band]
            })
            .collect();
    }
    fit
}

/// How far a file's codes can have moved a value, per channel, no matter how many pixels are
/// averaged: rounding's half step, which a noise of σ before rounding dithers away as
/// `exp(−2π²(σ/step)²)` (the first harmonic of the rounding error under Gaussian noise), and
/// for a lossy file half a step more for its compression — an allowance, not a derived bound,
/// that noise does not remove. `sigma` is the spread measured after rounding (robust, same
/// units), which holds rounding's own (0.37 step for a median-based spread of a uniform error):
/// that is taken out first, so a noiseless file keeps the whole half step.
pub fn code_bias_bound(step: Vec3, sigma: Vec3, lossy: bool) -> Vec3 {
    const ROUNDING_SPREAD_STEPS: f32 = 0.3707;
    let dithered = |step: f32, sigma: f32| {
        if step > 0.0 {
            let s2 = ((sigma / step).powi(2) - ROUNDING_SPREAD_STEPS.powi(2)).max(0.0);
            let s = s2.sqrt();
            0.5 * step * (-2.0 * std::f32::consts::PI.powi(2) * s * s).exp()
        } else {
            0.0
        }
    };
    let rounding = Vec3::new(
        dithered(step.x, sigma.x),
        dithered(step.y, sigma.y),
        dithered(step.z, sigma.z),
    );
    if lossy {
        rounding + 0.5 * step
    } else {
        rounding
    }
}

/// Re-estimates each band's relative noise from the residuals and sets inverse-variance
/// weights (optionally dropping outliers).
fn reweight_points(
    fit: &CurveFit,
    points: &mut [Vec<Point>],
    noise: &mut [[Vec3; BANDS]],
    reject: bool,
) {
    points
        .par_iter_mut()
        .zip(noise.par_iter_mut())
        .enumerate()
        .for_each(|(k, (sphere_points, noise))| {
            let floor = model_floor(&fit.curves[k]);
            let model = |p: &Point| fit.model_at(k, &p.basis).max(floor);
            // Relative deviations per band and channel, only where the model is above its floor
            // (below it the ratio measures the floor, not the noise).
            let mut deviations: Vec<[Vec<f32>; 3]> = vec![Default::default(); BANDS];
            // Every 4th sample is plenty for a median (thousands per band).
            for p in sphere_points.iter().step_by(4) {
                let m = fit.model_at(k, &p.basis);
                for c in 0..3 {
                    if m[c] > floor[c] {
                        deviations[p.band as usize][c].push((p.radiance[c] / m[c] - 1.0).abs());
                    }
                }
            }
            for (band, spread) in band_spreads(&mut deviations, 16).into_iter().enumerate() {
                for (c, spread) in spread.into_iter().enumerate() {
                    if let Some(spread) = spread {
                        noise[band][c] = spread.max(2e-3);
                    }
                }
            }
            for p in sphere_points.iter_mut() {
                let m = model(p);
                let sigma = noise[p.band as usize] * m;
                if reject {
                    p.outlier |= (p.radiance - m).abs().cmpgt(sigma * 6.0);
                }
                let weight = Vec3::ONE / (sigma * sigma);
                p.weight = Vec3::select(p.outlier, Vec3::ZERO, weight);
                p.relative_noise = noise[p.band as usize];
                p.weighted_model = m;
            }
        });
}

/// Adds the first-difference penalty that fills empty nodes and steadies sparse ones: its
/// strength follows the local data (1e-3 of the nearest non-empty diagonal).
fn add_smoothness(diagonal: &mut [Vec3], upper: &mut [Vec3]) {
    let n = diagonal.len();
    let mut scale: Vec<Vec3> = diagonal.to_vec();
    // Spread the nearest non-empty diagonal into empty nodes, per channel, both directions.
    let mut last = Vec3::ZERO;
    for value in scale.iter_mut() {
        last = Vec3::select(value.cmpgt(Vec3::ZERO), *value, last);
        *value = last;
    }
    last = Vec3::ZERO;
    for value in scale.iter_mut().rev() {
        last = Vec3::select(value.cmpgt(Vec3::ZERO), *value, last);
        *value = Vec3::select(value.cmpgt(Vec3::ZERO), *value, last);
    }
    for i in 0..n - 1 {
        let lambda = (scale[i].min(scale[i + 1]) * 1e-3).max(Vec3::splat(1e-30));
        diagonal[i] += lambda;
        diagonal[i + 1] += lambda;
        upper[i] -= lambda;
    }
}

fn fit_f(fit: &mut CurveFit, points: &[Vec<Point>]) {
    let n = fit.settings.theta_count;
    let curves: Vec<Vec<Vec3>> = points
        .par_iter()
        .enumerate()
        .map(|(k, sphere_points)| {
            let (mut diagonal, mut upper, mut rhs) = (
                vec![Vec3::ZERO; n],
                vec![Vec3::ZERO; n],
                vec![Vec3::ZERO; n],
            );
            for p in sphere_points {
                let view = fit.view_factor_at(k, &p.basis);
                let (a, t) = p.basis.theta;
                let a = a as usize;
                let (b0, b1) = (1.0 - t, t);
                let wv = p.weight * view;
                let wvv = wv * view;
                diagonal[a] += wvv * (b0 * b0);
                diagonal[a + 1] += wvv * (b1 * b1);
                upper[a] += wvv * (b0 * b1);
                rhs[a] += wv * p.radiance * b0;
                rhs[a + 1] += wv * p.radiance * b1;
            }
            add_smoothness(&mut diagonal, &mut upper);
            solve_tridiagonal(&mut diagonal, &upper, &mut rhs)
                .into_iter()
                .map(|v| v.max(Vec3::ZERO))
                .collect()
        })
        .collect();
    fit.curves = curves;
}

fn fit_g(fit: &mut CurveFit, points: &[Vec<Point>]) {
    let n = fit.settings.phi_count;
    let zero = || {
        (
            vec![Vec3::ZERO; n],
            vec![Vec3::ZERO; n],
            vec![Vec3::ZERO; n],
        )
    };
    let (mut diagonal, mut upper, mut rhs) = points
        .par_iter()
        .enumerate()
        .map(|(k, sphere_points)| {
            let (mut diagonal, mut upper, mut rhs) = zero();
            let floor = model_floor(&fit.curves[k]);
            for p in sphere_points {
                let mut f = hat(&fit.curves[k], p.basis.theta);
                if let Some(c) = &fit.correction {
                    f *= p.basis.coarse.evaluate(&c[k]);
                }
                let (b, t) = p.basis.phi;
                let b = b as usize;
                let (b0, b1) = (1.0 - t, t);
                let weight = p.weight_now(fit.model_at(k, &p.basis).max(floor));
                let wf = weight * f;
                let wff = wf * f;
                diagonal[b] += wff * (b0 * b0);
                diagonal[b + 1] += wff * (b1 * b1);
                upper[b] += wff * (b0 * b1);
                rhs[b] += wf * p.radiance * b0;
                rhs[b + 1] += wf * p.radiance * b1;
            }
            (diagonal, upper, rhs)
        })
        .reduce(zero, |mut a, b| {
            for i in 0..n {
                a.0[i] += b.0[i];
                a.1[i] += b.1[i];
                a.2[i] += b.2[i];
            }
            a
        });
    add_smoothness(&mut diagonal, &mut upper);
    let g = solve_tridiagonal(&mut diagonal, &upper, &mut rhs);
    let g0 = g[0];
    if g0.min_element() > 0.0 && g0.is_finite() {
        fit.g_phi = g.iter().map(|v| (*v / g0).max(Vec3::ZERO)).collect();
        for curve in &mut fit.curves {
            for value in curve.iter_mut() {
                *value *= g0;
            }
        }
    }
}

/// Fits each sphere's c_k(θ, φ) (dense normal equations on the coarse grid, ridge toward 1 and
/// a smoothness penalty between neighbours, both scaled to that sphere's data).
fn fit_correction(fit: &mut CurveFit, points: &[Vec<Point>]) {
    const N: usize = CORRECTION_THETA_COUNT * CORRECTION_PHI_COUNT;
    let previous = fit.correction.take().unwrap_or_default();
    let corrections: Vec<Vec<Vec3>> = points
        .par_iter()
        .enumerate()
        .map(|(k, sphere_points)| {
            let (mut matrix, mut rhs) = (vec![[Vec3::ZERO; N]; N], vec![Vec3::ZERO; N]);
            let floor = model_floor(&fit.curves[k]);
            // c lives on a 10° grid: every other sample still gives it thousands per node.
            for p in sphere_points.iter().step_by(2) {
                let g = hat(&fit.g_phi, p.basis.phi);
                let fg = hat(&fit.curves[k], p.basis.theta) * g;
                let c = previous
                    .get(k)
                    .map_or(Vec3::ONE, |c| p.basis.coarse.evaluate(c));
                let wfg = p.weight_now((fg * c).max(floor)) * fg;
                let nodes = p.basis.coarse.nodes();
                for &(i, wi) in &nodes {
                    rhs[i] += wfg * p.radiance * wi;
                    for &(j, wj) in &nodes {
                        matrix[i][j] += wfg * fg * (wi * wj);
                    }
                }
            }
            let mean_diagonal = (0..N).map(|i| matrix[i][i]).sum::<Vec3>() / N as f32;
            let ridge = mean_diagonal * 1e-3;
            let smooth = mean_diagonal * 1e-2;
            for i in 0..N {
                matrix[i][i] += ridge;
                rhs[i] += ridge;
                let (row, column) = (i / CORRECTION_PHI_COUNT, i % CORRECTION_PHI_COUNT);
                let mut neighbours = Vec::with_capacity(2);
                if column + 1 < CORRECTION_PHI_COUNT {
                    neighbours.push(i + 1);
                }
                if row + 1 < CORRECTION_THETA_COUNT {
                    neighbours.push(i + CORRECTION_PHI_COUNT);
                }
                for j in neighbours {
                    matrix[i][i] += smooth;
                    matrix[j][j] += smooth;
                    matrix[i][j] -= smooth;
                    matrix[j][i] -= smooth;
                }
            }
            match solve_dense(matrix, rhs) {
                Some(solution) => solution
                    .into_iter()
                    .map(|v| v.max(Vec3::splat(0.05)))
                    .collect(),
                None => previous
                    .get(k)
                    .cloned()
                    .unwrap_or_else(|| vec![Vec3::ONE; N]),
            }
        })
        .collect();
    fit.correction = Some(corrections);
}

/// Only the product f·g·c is measured, and f can trade any function of θ with c. This scales
/// each row of c so that g·c averages 1 over the ring an ideal photograph (orthographic, light
/// at 90° to the view) shows at that θ: f(θ) is then that photograph's ring mean — the poster's
/// raw curve — whatever geometry the photographs had, so the fits that read f (profile,
/// transmission) get the same curve from any capture. The 0° and 180° rows take the rings at
/// 10° and 170°. A channel whose mean is not positive is left as it is. The caller refits f.
fn fix_ring_gauge(fit: &mut CurveFit) {
    use std::f32::consts::{FRAC_PI_2, PI};
    const STEPS: usize = 90;
    let g_phi = fit.g_phi.clone();
    let Some(corrections) = fit.correction.as_mut() else {
        return;
    };
    let edge = PI / (CORRECTION_THETA_COUNT - 1) as f32;
    for grid in corrections {
        for (row, c_row) in grid.chunks_exact_mut(CORRECTION_PHI_COUNT).enumerate() {
            let theta = (row as f32 * edge).clamp(edge, PI - edge);
            let mean = (0..STEPS)
                .map(|step| {
                    // Pixels are uniform across the ring's chord: y, then φ = acos √(sin²θ − y²).
                    let y = ((step as f32 + 0.5) / STEPS as f32 * 2.0 - 1.0) * theta.sin();
                    let phi = (theta.sin().powi(2) - y * y)
                        .max(0.0)
                        .sqrt()
                        .min(1.0)
                        .acos();
                    let g = hat(&g_phi, hat_coordinate(phi, FRAC_PI_2, g_phi.len()));
                    g * hat(c_row, hat_coordinate(phi, FRAC_PI_2, CORRECTION_PHI_COUNT))
                })
                .sum::<Vec3>()
                / STEPS as f32;
            let scale = Vec3::select(mean.cmpgt(Vec3::splat(1e-3)), mean.recip(), Vec3::ONE);
            for value in c_row {
                *value *= scale;
            }
        }
    }
}

/// Gaussian elimination with partial pivoting, per channel (the unknowns kept in f32).
fn solve_dense<const N: usize>(matrix: Vec<[Vec3; N]>, rhs: Vec<Vec3>) -> Option<Vec<Vec3>> {
    let mut solution = vec![Vec3::ZERO; N];
    for channel in 0..3 {
        let rows = matrix
            .iter()
            .zip(&rhs)
            .map(|(row, b)| {
                row.iter()
                    .chain([b])
                    .map(|v| f64::from(v[channel]))
                    .collect()
            })
            .collect();
        let x: Vec<f32> = solve_gaussian(rows, SingularColumn::Fail)?;
        for (value, x) in solution.iter_mut().zip(x) {
            value[channel] = x;
        }
    }
    Some(solution)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(weight: Vec3, relative_noise: Vec3, weighted_model: Vec3) -> Point {
        Point {
            basis: Basis::new(0.5, 0.5, &CurveSettings::default()),
            radiance: Vec3::ONE,
            weight,
            relative_noise,
            weighted_model,
            outlier: glam::BVec3::new(false, false, true),
            band: 0,
            code_step: Vec3::ZERO,
            lossy: false,
            ambient: Vec3::ZERO,
        }
    }

    #[test]
    fn a_view_factor_weight_is_recomputed_only_where_the_model_more_than_doubled() {
        // Weighted at model 1 with noise 0.1: weight 100 (blue an outlier, weight 0).
        let p = point(Vec3::new(100.0, 100.0, 0.0), Vec3::splat(0.1), Vec3::ONE);
        // Red grew 1.5×: kept. Green grew 10×: 1/(0.1·10)² = 1. Blue stays an outlier.
        let w = p.weight_now(Vec3::new(1.5, 10.0, 10.0));
        assert_eq!(w.x, 100.0);
        assert!((w.y - 1.0).abs() < 1e-5, "{w}");
        assert_eq!(w.z, 0.0);
        // A shrunk model keeps its weight; so does every sample before the first reweighting.
        assert_eq!(p.weight_now(Vec3::splat(0.01)), p.weight);
        let start = point(Vec3::ONE, Vec3::ZERO, Vec3::ZERO);
        assert_eq!(start.weight_now(Vec3::splat(5.0)), Vec3::ONE);
    }

    #[test]
    fn code_bias_is_half_a_step_without_noise_and_dithered_away_with_it() {
        let step = Vec3::splat(0.01);
        // The spread measured after rounding, for a noise of `before` steps before it.
        let measured = |before: f32| step * (before * before + 0.3707_f32.powi(2)).sqrt();
        // Noiseless lossless codes: rounding's half step is all bias, whether or not its own
        // spread was measured.
        assert_eq!(code_bias_bound(step, Vec3::ZERO, false), step * 0.5);
        let noiseless = code_bias_bound(step, measured(0.0), false);
        assert!(
            (noiseless - step * 0.5).abs().max_element() < 1e-6,
            "{noiseless}"
        );
        // A noise of one step dithers rounding away (e^(−2π²) ≈ 3e-9).
        assert!(code_bias_bound(step, measured(1.0), false).max_element() < 1e-8);
        // A quarter step leaves e^(−π²/8) ≈ 0.29 of it.
        let quarter = code_bias_bound(step, measured(0.25), false).x / (0.5 * step.x);
        assert!((quarter - (-std::f32::consts::PI.powi(2) / 8.0).exp()).abs() < 1e-3);
        // JPEG's compression stays, noise or not.
        let jpeg = code_bias_bound(step, measured(1.0), true);
        assert!((jpeg - step * 0.5).abs().max_element() < 1e-8);
        assert_eq!(code_bias_bound(Vec3::ZERO, Vec3::ZERO, true), Vec3::ZERO);
    }
}
