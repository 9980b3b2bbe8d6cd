//! Light through the material: the transmission profile `T(d, μ) = A·μ·exp(−d/ℓ)` measured
//! from the shadow side of the spheres (see [`cdrf_core::translucency`]).
//!
//! # Model
//! A sphere of radius r lit from the side receives light at a shadow-side point (θ > 90°) that
//! entered the lit side and crossed the chord `d = 2·r·|cos θ| = −2·cos θ / κ` of material
//! ([`cdrf_core::translucency::local_chord_mm`]). The chord is symmetric: the light entered at
//! the cosine `μ = |cos θ|` to the surface, so the irradiance entering is `E·μ`
//! ([`cdrf_core::translucency::local_entry_cosine`]). If the glow there is light transmitted
//! through the material, the measured curve `f_k(θ)` (π·L/E, view correction divided out) is
//! the same function of (d, μ) for every radius: `f_k(θ) = T(d, μ) = μ·A·exp(−d/ℓ)`. Near the
//! terminator light diffusing sideways from the lit surface dominates instead, so only nodes
//! with θ ≥ [`TransmissionSettings::min_theta_deg`] (110° by default) are used.
//!
//! # Fit
//! Per RGB channel, over the points (d, f/μ) — each θ node of each sphere with samples
//! (`node_samples > 0`) and a value of at least [`MODEL_FLOOR`] (10⁻⁴) of that sphere's peak
//! in that channel (below it the curve fit floors its model and does not resolve the value:
//! on exact synthetic data such nodes are off by tens of percent):
//! 1. a start from the weighted least-squares line through `(d, ln(f/μ))`: `ln A − d/ℓ`;
//! 2. the fit proper, in linear space with a constant relative noise: Gauss-Newton on
//!    `Σ w·(f/T − 1 − ln(f/T))` (the deviance of a Gamma model, log link), whose minimum is
//!    where the weighted relative residuals `f/T − 1` average 0 and show no trend with d.
//!
//! Deep in the shadow a path-traced (or photographed) node is the mean of pixels that are
//! mostly near zero with rare bright ones: unbiased in linear space but skewed, so a fit of
//! ln f alone is pulled down by the nodes that came out low (the log of a noisy mean is biased
//! low); the linear-space fit is not.
//!
//! The weight of a node is the inverse variance of its relative value: `w = n / s²`, with n the
//! node's effective sample count and s the relative noise per pixel of its θ band
//! ([`crate::curves`] estimates both; s is floored at 10⁻³). Noisy nodes count for less and the
//! bright, well-sampled nodes nearer 110° pin the fit.
//!
//! The quality figures are in linear space and relative to the **model**: the weighted
//! relative RMS error `√(Σ w·((f − T)/T)² / Σ w)` — the residual the fit minimises (a
//! relative error to the data instead is unbounded where a node came out near zero, and then
//! measures the path tracer's noise, not the model) — and per sphere the weighted mean ratio
//! `f / T` of its points: 1 on every sphere when the glow is one function of (d, μ) across
//! radii.
//!
//! The entry cosine μ is what makes the glow one function across radii: at one chord a large
//! sphere's point lies nearer the terminator, where the light enters at a grazing angle (the
//! figures on the bundled spheres: `docs/research/fit-notes.md`).
//!
//! The scattering length of [`cdrf_core::Translucency`] is not fitted here: it is Kubo's σ
//! ([`crate::gaussian_fit`]), the width of the terminator in mm.
//!
//! ```
//! use cdrf_fit::transmission::{SphereCurve, TransmissionSettings, fit_transmission};
//! use glam::Vec3;
//!
//! // Two spheres (r = 20 and 40 mm) whose shadow side is exactly μ·0.2·exp(−d / 8 mm).
//! let n = 181;
//! let make = |radius_mm: f32| -> Vec<Vec3> {
//!     (0..n)
//!         .map(|a| {
//!             let theta = std::f32::consts::PI * a as f32 / (n - 1) as f32;
//!             let (d, mu) = ((-2.0 * radius_mm * theta.cos()).max(0.0), theta.cos().abs());
//!             Vec3::splat(mu * 0.2 * (-d / 8.0).exp())
//!         })
//!         .collect()
//! };
//! let (small, large) = (make(20.0), make(40.0));
//! let samples = vec![100.0; n];
//! let noise = vec![Vec3::splat(0.05); n];
//! let curves = [
//!     SphereCurve { curvature_per_mm: 1.0 / 20.0, values: &small, samples: &samples, noise: &noise },
//!     SphereCurve { curvature_per_mm: 1.0 / 40.0, values: &large, samples: &samples, noise: &noise },
//! ];
//! let fit = fit_transmission(&curves, &TransmissionSettings::default())?;
//! assert!((fit.profile.length_mm[1] - 8.0).abs() < 1e-2);
//! assert!((fit.profile.amplitude[1] - 0.2).abs() < 1e-3);
//! # Ok::<(), cdrf_fit::transmission::TransmissionError>(())
//! ```

use cdrf_core::lut::theta_rad_at;
use cdrf_core::translucency::{
    TranslucencyError, TransmissionProfile, local_chord_mm, local_entry_cosine,
};
use glam::Vec3;

use crate::curves::{CurveFit, MODEL_FLOOR};

/// Which nodes enter the fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransmissionSettings {
    /// Smallest θ used, degrees (> 90°). Nearer the terminator light diffusing sideways from
    /// the lit surface dominates the light through the chord.
    pub min_theta_deg: f32,
}

impl Default for TransmissionSettings {
    fn default() -> Self {
        Self {
            min_theta_deg: DEFAULT_MIN_THETA_DEG,
        }
    }
}

/// The default [`TransmissionSettings::min_theta_deg`], degrees.
pub const DEFAULT_MIN_THETA_DEG: f32 = 110.0;

/// Fewest points per channel the fit needs.
pub const MIN_POINTS: usize = 3;

/// Floor of the relative noise per pixel used in the weights.
const MIN_RELATIVE_NOISE: f32 = 1e-3;

/// One sphere's fitted curve on θ nodes uniformly spaced over [0, π] (see
/// [`CurveFit::curves`]).
#[derive(Clone, Copy, Debug)]
pub struct SphereCurve<'a> {
    /// κ = 1/r, mm⁻¹.
    pub curvature_per_mm: f32,
    /// f(θ) per node, π·L/E, view correction divided out.
    pub values: &'a [Vec3],
    /// Effective samples per node (0: no data, the node is filled).
    pub samples: &'a [f32],
    /// Relative noise per pixel per node.
    pub noise: &'a [Vec3],
}

impl<'a> SphereCurve<'a> {
    /// Sphere `sphere` of a curve fit, whose curvature is `curvature_per_mm`.
    ///
    /// # Panics
    /// When `sphere` is not a sphere of `fit`.
    pub fn from_fit(fit: &'a CurveFit, sphere: usize, curvature_per_mm: f32) -> Self {
        Self {
            curvature_per_mm,
            values: &fit.curves[sphere],
            samples: &fit.node_samples[sphere],
            noise: &fit.node_noise[sphere],
        }
    }

    /// Every sphere of a curve fit, sphere k with curvature `curvature_per_mm[k]` (as many as
    /// both have).
    ///
    /// # Panics
    /// When `fit` has fewer sample or noise rows than curves.
    pub fn all_from_fit(fit: &'a CurveFit, curvature_per_mm: &[f32]) -> Vec<Self> {
        curvature_per_mm
            .iter()
            .take(fit.curves.len())
            .enumerate()
            .map(|(k, &curvature)| Self::from_fit(fit, k, curvature))
            .collect()
    }
}

impl ChordPoint {
    /// f / μ: the value with the entry cosine of the model `T(d, μ) = A·μ·exp(−d/ℓ)` divided out.
    pub fn value_per_entry_cosine(&self) -> f64 {
        f64::from(self.value) / f64::from(self.entry_cosine)
    }
}

/// One node used by the fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChordPoint {
    /// Index of its sphere in the input.
    pub sphere: usize,
    /// θ of the node, radians.
    pub theta_rad: f32,
    /// The chord the light crossed, mm.
    pub chord_mm: f32,
    /// Cosine between the light and the surface where it entered the chord: `|cos θ|`.
    pub entry_cosine: f32,
    /// f(θ), π·L/E.
    pub value: f32,
    /// Weight in the fit (inverse variance of ln f).
    pub weight: f32,
}

/// The fit of one channel and how well it fits.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelFit {
    /// The points used.
    pub points: Vec<ChordPoint>,
    /// Shortest and longest chord among them, mm.
    pub chord_range_mm: (f32, f32),
    /// Weighted relative RMS error of the model against the points, relative to the model
    /// (linear space; see the module docs).
    pub relative_rms: f32,
    /// Per input sphere, the weighted mean of f / T(d, μ) over its points (`None`: no points).
    pub mean_ratio_per_sphere: Vec<Option<f32>>,
}

/// The fitted transmission profile and its quality per channel.
#[derive(Clone, Debug, PartialEq)]
pub struct TransmissionFit {
    /// `T(d, μ) = A·μ·exp(−d/ℓ)` per channel.
    pub profile: TransmissionProfile,
    /// The settings used.
    pub settings: TransmissionSettings,
    /// Points and quality per channel (R, G, B).
    pub channels: [ChannelFit; 3],
}

/// Why the transmission profile could not be fitted.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum TransmissionError {
    /// A sphere's curve, sample counts and noise do not have one entry per θ node each.
    #[error(
        "sphere {sphere}: {values} curve values, {samples} sample counts and {noise} noise values: need one of each per θ node (at least 2)"
    )]
    Shape {
        /// Index of the sphere.
        sphere: usize,
        /// Curve values.
        values: usize,
        /// Sample counts.
        samples: usize,
        /// Noise values.
        noise: usize,
    },
    /// Too few measured shadow-side nodes with a positive value.
    #[error(
        "channel {channel}: only {points} measured shadow-side nodes with θ ≥ {min_theta_deg}° and a positive value (need {needed}, at two chords or more): the photographs show no light through the spheres"
    )]
    TooFewPoints {
        /// R, G or B.
        channel: &'static str,
        /// Points found.
        points: usize,
        /// Points needed.
        needed: usize,
        /// The θ minimum, degrees.
        min_theta_deg: f32,
    },
    /// ln f does not fall with the chord.
    #[error(
        "channel {channel}: the shadow side does not get darker through longer chords (slope of ln f {slope_per_mm} per mm): no transmission decay to fit"
    )]
    NoDecay {
        /// R, G or B.
        channel: &'static str,
        /// Fitted slope of ln f against d, mm⁻¹.
        slope_per_mm: f32,
    },
    /// The fitted profile is not valid (e.g. an amplitude that overflows).
    #[error("fitted transmission profile is invalid: {0}")]
    Profile(TranslucencyError),
}

// The message holds the cause's, which `source()` therefore does not repeat.
impl From<TranslucencyError> for TransmissionError {
    fn from(error: TranslucencyError) -> Self {
        Self::Profile(error)
    }
}

const CHANNELS: [&str; 3] = ["R", "G", "B"];

/// Fits `T(d, μ) = A·μ·exp(−d/ℓ)` per channel to the shadow sides of `spheres` (see the module
/// docs). Spheres with a curvature that is not finite and > 0 contribute no points.
///
/// # Errors
/// [`TransmissionError::Shape`] for inconsistent inputs, [`TransmissionError::TooFewPoints`]
/// when a channel has fewer than [`MIN_POINTS`] usable nodes (or all at one chord),
/// [`TransmissionError::NoDecay`] when ln f does not fall with d, and
/// [`TransmissionError::Profile`] when the result is not finite.
pub fn fit_transmission(
    spheres: &[SphereCurve<'_>],
    settings: &TransmissionSettings,
) -> Result<TransmissionFit, TransmissionError> {
    for (k, sphere) in spheres.iter().enumerate() {
        let n = sphere.values.len();
        if n < 2 || sphere.samples.len() != n || sphere.noise.len() != n {
            return Err(TransmissionError::Shape {
                sphere: k,
                values: n,
                samples: sphere.samples.len(),
                noise: sphere.noise.len(),
            });
        }
    }
    let mut amplitude = [0.0_f32; 3];
    let mut length_mm = [0.0_f32; 3];
    let mut used = shadow_points(spheres, settings);
    for (c, channel) in CHANNELS.into_iter().enumerate() {
        let points = &used[c];
        let too_few = || TransmissionError::TooFewPoints {
            channel,
            points: points.len(),
            needed: MIN_POINTS,
            min_theta_deg: settings.min_theta_deg,
        };
        if points.len() < MIN_POINTS {
            return Err(too_few());
        }
        // Start: weighted least squares of ln f = a + b·d.
        let Some((mut a, mut b)) = weighted_line(points, |p| p.value_per_entry_cosine().ln())
        else {
            return Err(too_few());
        };
        // Then the relative-error fit in linear space (Gauss-Newton, step halving).
        let mut deviance = gamma_deviance(points, a, b);
        for _ in 0..MAX_ITERATIONS {
            let model = |p: &ChordPoint| (a + b * f64::from(p.chord_mm)).exp();
            let Some((da, db)) =
                weighted_line(points, |p| p.value_per_entry_cosine() / model(p) - 1.0)
            else {
                break;
            };
            let mut step = 1.0;
            let mut improved = false;
            while step > 1e-6 {
                let (na, nb) = (a + step * da, b + step * db);
                let next = gamma_deviance(points, na, nb);
                if next.is_finite() && next <= deviance {
                    (a, b, deviance) = (na, nb, next);
                    improved = true;
                    break;
                }
                step *= 0.5;
            }
            if !improved
                || (da * step).abs() + (db * step).abs() * (1.0 + mean_chord(points)) < 1e-10
            {
                break;
            }
        }
        // NaN counts as no decay.
        if b.is_nan() || b >= 0.0 {
            return Err(TransmissionError::NoDecay {
                channel,
                slope_per_mm: b as f32,
            });
        }
        amplitude[c] = a.exp() as f32;
        length_mm[c] = (-1.0 / b) as f32;
    }
    let profile = TransmissionProfile::new(amplitude, length_mm)?;
    let channels = std::array::from_fn(|c| {
        channel_quality(std::mem::take(&mut used[c]), &profile, c, spheres.len())
    });
    Ok(TransmissionFit {
        profile,
        settings: *settings,
        channels,
    })
}

/// The fit of the shadow sides of `fit`'s curves, spheres with curvatures `curvature_per_mm`
/// (same order).
///
/// # Errors
/// As [`fit_transmission`]; [`TransmissionError::Shape`] also when the curvatures are not one
/// per sphere.
pub fn fit_curve_fit(
    fit: &CurveFit,
    curvature_per_mm: &[f32],
    settings: &TransmissionSettings,
) -> Result<TransmissionFit, TransmissionError> {
    if curvature_per_mm.len() != fit.curves.len()
        || fit.node_samples.len() != fit.curves.len()
        || fit.node_noise.len() != fit.curves.len()
    {
        return Err(TransmissionError::Shape {
            sphere: curvature_per_mm.len().min(fit.curves.len()),
            values: fit.curves.len(),
            samples: fit.node_samples.len(),
            noise: fit.node_noise.len(),
        });
    }
    fit_transmission(&SphereCurve::all_from_fit(fit, curvature_per_mm), settings)
}

/// The shadow-side nodes the fit uses, per channel (R, G, B): θ ≥ `settings.min_theta_deg`,
/// samples > 0, a value ≥ [`MODEL_FLOOR`] × the sphere's peak (and > 0), a sphere with a curvature that is finite and > 0, and their
/// weights (see the module docs). Inputs of inconsistent lengths give what their common nodes
/// give.
pub fn shadow_points(
    spheres: &[SphereCurve<'_>],
    settings: &TransmissionSettings,
) -> [Vec<ChordPoint>; 3] {
    // A node exactly at the minimum counts, whatever the rounding of its θ.
    let min_theta_rad = settings.min_theta_deg.to_radians() - 1e-5;
    std::array::from_fn(|c| channel_points(spheres, c, min_theta_rad))
}

/// The usable shadow-side nodes of channel `c`.
fn channel_points(spheres: &[SphereCurve<'_>], c: usize, min_theta_rad: f32) -> Vec<ChordPoint> {
    let mut points = Vec::new();
    for (k, sphere) in spheres.iter().enumerate() {
        let curvature = sphere.curvature_per_mm;
        if !(curvature.is_finite() && curvature > 0.0) {
            continue;
        }
        let n = sphere.values.len();
        let nodes = n.min(sphere.samples.len()).min(sphere.noise.len());
        let peak = sphere.values.iter().map(|v| v[c]).fold(0.0_f32, f32::max);
        let floor = peak * MODEL_FLOOR;
        for a in 0..nodes {
            let theta = theta_rad_at(a, n);
            let (value, samples, noise) =
                (sphere.values[a][c], sphere.samples[a], sphere.noise[a][c]);
            let usable = theta >= min_theta_rad
                && samples > 0.0
                && value > 0.0
                && value >= floor
                && value.is_finite()
                && noise.is_finite();
            if !usable {
                continue;
            }
            let noise = noise.max(MIN_RELATIVE_NOISE);
            let weight = samples / (noise * noise);
            let chord_mm = local_chord_mm(curvature, theta.cos());
            if !(chord_mm.is_finite() && weight.is_finite()) {
                continue;
            }
            points.push(ChordPoint {
                sphere: k,
                theta_rad: theta,
                chord_mm,
                entry_cosine: local_entry_cosine(curvature, theta.cos()),
                value,
                weight,
            });
        }
    }
    points
}

/// Most Gauss-Newton steps of the linear-space fit.
const MAX_ITERATIONS: usize = 100;

/// Weighted least-squares line `y = intercept + slope · d` through the points; `None` when the
/// chords do not spread (or the weights are not positive).
fn weighted_line(points: &[ChordPoint], y: impl Fn(&ChordPoint) -> f64) -> Option<(f64, f64)> {
    let (mut sw, mut sd, mut sy) = (0.0_f64, 0.0_f64, 0.0_f64);
    for p in points {
        let w = f64::from(p.weight);
        sw += w;
        sd += w * f64::from(p.chord_mm);
        sy += w * y(p);
    }
    if sw.is_nan() || sw <= 0.0 {
        return None;
    }
    let (mean_d, mean_y) = (sd / sw, sy / sw);
    let (mut sdd, mut sdy) = (0.0_f64, 0.0_f64);
    for p in points {
        let w = f64::from(p.weight);
        let dd = f64::from(p.chord_mm) - mean_d;
        sdd += w * dd * dd;
        sdy += w * dd * (y(p) - mean_y);
    }
    let spread = sdd / sw;
    if spread.is_nan() || spread <= 1e-12 * (1.0 + mean_d * mean_d) {
        return None;
    }
    let slope = sdy / sdd;
    let line = (mean_y - slope * mean_d, slope);
    (line.0.is_finite() && line.1.is_finite()).then_some(line)
}

/// Weighted mean chord, mm.
fn mean_chord(points: &[ChordPoint]) -> f64 {
    let (sw, sd) = points.iter().fold((0.0_f64, 0.0_f64), |(sw, sd), p| {
        let w = f64::from(p.weight);
        (sw + w, sd + w * f64::from(p.chord_mm))
    });
    sd / sw
}

/// `Σ w·(f/T − 1 − ln(f/T))` for `T = μ·exp(a + b·d)`: the deviance of a constant relative
/// noise (a Gamma model), whose minimum solves `Σ w·(f/T − 1)·(1, d) = 0`.
fn gamma_deviance(points: &[ChordPoint], a: f64, b: f64) -> f64 {
    points
        .iter()
        .map(|p| {
            let ratio = p.value_per_entry_cosine() / (a + b * f64::from(p.chord_mm)).exp();
            f64::from(p.weight) * (ratio - 1.0 - ratio.ln())
        })
        .sum()
}

/// The quality figures of one channel.
fn channel_quality(
    points: Vec<ChordPoint>,
    profile: &TransmissionProfile,
    c: usize,
    sphere_count: usize,
) -> ChannelFit {
    let (amplitude, length_mm) = (
        f64::from(profile.amplitude[c]),
        f64::from(profile.length_mm[c]),
    );
    let model = |d: f32| amplitude * (-f64::from(d) / length_mm).exp();
    let (mut sw, mut se) = (0.0_f64, 0.0_f64);
    let mut per_sphere = vec![(0.0_f64, 0.0_f64); sphere_count];
    let mut range = (f32::INFINITY, f32::NEG_INFINITY);
    for p in &points {
        let (w, f, t) = (
            f64::from(p.weight),
            p.value_per_entry_cosine(),
            model(p.chord_mm),
        );
        if t > 0.0 {
            sw += w;
            se += w * ((f - t) / t).powi(2);
            per_sphere[p.sphere].0 += w * f / t;
            per_sphere[p.sphere].1 += w;
        }
        range = (range.0.min(p.chord_mm), range.1.max(p.chord_mm));
    }
    ChannelFit {
        relative_rms: if sw > 0.0 {
            (se / sw).sqrt() as f32
        } else {
            f32::INFINITY
        },
        chord_range_mm: range,
        mean_ratio_per_sphere: per_sphere
            .iter()
            .map(|&(sum, w)| (w > 0.0).then(|| (sum / w) as f32))
            .collect(),
        points,
    }
}
