//! The diffusion profile `R(d)` fitted to all spheres at once (see [`cdrf_core::diffusion`]).
//!
//! # Model
//! Each sphere's measured curve f(θ; r) (π·L/E, view correction divided out) is, to the diffusion
//! approximation, the lit surface's entering light integrated against `R(|p − q|)`:
//! `f(θ; r) = Σₖ wₖ · Fₖ(θ; r, p)`, where `Fₖ` is the unit term `exp(−d/ℓₖ)/(2πℓₖd)` on that
//! sphere ([`sphere_term_responses`]) and p the power of the entry cosine.
//!
//! # Fit
//! - **Basis**: fixed lengths ℓₖ ([`DiffusionSettings::lengths_mm`], 0.25 … 32 mm, spaced
//!   about ×1.5), so the model is linear in the weights.
//! - **Weights**: per RGB channel, non-negative least squares (Lawson & Hanson) of the relative
//!   residual `(model − f)/max(f, floor)` over every sphere's θ nodes that have samples
//!   (every [`DiffusionSettings::theta_stride`]-th node), `floor` = [`RELATIVE_FLOOR`] of that
//!   sphere's peak in that channel: the lit side and the shadow side count alike, as they do in
//!   a picture.
//! - **Entry power**: p from a grid ([`DiffusionSettings::entry_cosine_powers`], 0.5 … 1.0); the
//!   one with the smallest summed relative RMS wins.
//!
//! Why this form: a sum of exponentials holds the shapes that diffusion theory and path tracing
//! give (a dipole's far field is one, Burley's normalized diffusion two), is positive by
//! construction, and its fit has one optimum. A non-parametric R would be as flexible but needs
//! a smoothness penalty to be stable where no sphere constrains it.
//!
//! # What it tells
//! The quality figures say, per sphere and channel, how well the profile *alone* reproduces the
//! measured curve: the relative RMS over the nodes used, and render / measurement summed over
//! the lit side (θ < 90°) and the shadow side (θ ≥ 90°). The measured table stays what the
//! renderer shows on a sphere; the profile is what it can say off the sphere.
//!
//! ```
//! use cdrf_core::diffusion::{DiffusionProfile, ProfileTerm};
//! use cdrf_fit::diffusion::{DiffusionSettings, fit_diffusion};
//! use cdrf_fit::transmission::SphereCurve;
//! use glam::Vec3;
//!
//! // Spheres shaded by a known profile are fitted back.
//! let truth = DiffusionProfile::new(
//!     vec![ProfileTerm { length_mm: 2.0, weight: [0.4; 3] }, ProfileTerm { length_mm: 12.0, weight: [0.5; 3] }],
//!     0.8,
//! )?;
//! let n = 61;
//! let radii = [15.0, 25.0, 50.0];
//! let curves: Vec<Vec<Vec3>> = radii.iter().map(|&r: &f64| (0..n).map(|i| {
//!     let theta = std::f64::consts::PI * i as f64 / (n - 1) as f64;
//!     let f = truth.sphere_reflectance(1.0 / r, theta);
//!     Vec3::new(f[0] as f32, f[1] as f32, f[2] as f32)
//! }).collect()).collect();
//! let (samples, noise) = (vec![100.0; n], vec![Vec3::splat(0.05); n]);
//! let spheres: Vec<SphereCurve> = radii.iter().zip(&curves).map(|(&r, values)| SphereCurve {
//!     curvature_per_mm: (1.0 / r) as f32, values, samples: &samples, noise: &noise,
//! }).collect();
//! let settings = DiffusionSettings { theta_stride: 2, ..DiffusionSettings::default() };
//! let fit = fit_diffusion(&spheres, &settings)?;
//! assert!((fit.profile.entry_cosine_power() - 0.8).abs() < 1e-3);
//! assert!(fit.relative_rms.iter().all(|&e| e < 0.01));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use cdrf_core::diffusion::{
    DiffusionProfile, DiffusionProfileError, ProfileTerm, sphere_term_responses,
};
use cdrf_core::linear::{SingularColumn, solve_gaussian};
use glam::Vec3;
use rayon::prelude::*;
use thiserror::Error;

use crate::curves::CurveFit;
use crate::transmission::SphereCurve;

/// Nodes below this share of their sphere's peak (per channel) weigh as if they were at it.
pub const RELATIVE_FLOOR: f64 = 2e-3;

/// Fewest usable nodes per channel the fit needs.
pub const MIN_NODES: usize = 8;

/// What the profile fit runs with.
#[derive(Clone, Debug, PartialEq)]
pub struct DiffusionSettings {
    /// The basis lengths ℓₖ, mm, increasing (at most
    /// [`cdrf_core::diffusion::MAX_PROFILE_TERMS`]).
    pub lengths_mm: Vec<f32>,
    /// The entry cosine powers tried.
    pub entry_cosine_powers: Vec<f32>,
    /// Every how many θ nodes of a curve enter the fit (1: all).
    pub theta_stride: usize,
}

impl Default for DiffusionSettings {
    fn default() -> Self {
        Self {
            lengths_mm: vec![
                0.25, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0, 24.0, 32.0,
            ],
            entry_cosine_powers: (0..=10).map(|i| 0.5 + 0.05 * i as f32).collect(),
            theta_stride: 3,
        }
    }
}

/// How well the profile alone reproduces one sphere.
#[derive(Clone, Debug, PartialEq)]
pub struct SphereQuality {
    /// The sphere's radius, mm.
    pub radius_mm: f32,
    /// Relative RMS of (profile − measured) over the nodes used, per channel.
    pub relative_rms: [f32; 3],
    /// Σ profile / Σ measured over the nodes used with θ < 90°, per channel.
    pub lit_ratio: [f32; 3],
    /// Σ profile / Σ measured over the nodes used with θ ≥ 90°, per channel.
    pub shadow_ratio: [f32; 3],
}

/// The fitted profile and how well it fits.
#[derive(Clone, Debug, PartialEq)]
pub struct DiffusionFit {
    /// The profile (the chosen power, the fitted weights on the settings' lengths).
    pub profile: DiffusionProfile,
    /// The settings the fit ran with.
    pub settings: DiffusionSettings,
    /// Relative RMS over all spheres' nodes used, per channel.
    pub relative_rms: [f32; 3],
    /// Per sphere (input order; spheres with no usable curvature are left out).
    pub spheres: Vec<SphereQuality>,
    /// Each power tried and its relative RMS summed over the channels.
    pub powers_tried: Vec<(f32, f32)>,
}

/// Why the profile could not be fitted.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum DiffusionFitError {
    /// A sphere's values, samples and noise differ in length.
    #[error("sphere {sphere}: {values} values but {samples} sample counts")]
    Shape {
        /// Which sphere (0-based).
        sphere: usize,
        /// Values given.
        values: usize,
        /// Sample counts given.
        samples: usize,
    },
    /// Too few nodes with samples and a positive value.
    #[error("{channel}: {nodes} usable θ nodes over all spheres, the profile fit needs {needed}")]
    TooFewNodes {
        /// "red", "green" or "blue".
        channel: &'static str,
        /// Nodes found.
        nodes: usize,
        /// Nodes needed.
        needed: usize,
    },
    /// The settings are unusable (no powers, a zero stride, bad lengths).
    #[error("profile fit settings: {0}")]
    Settings(String),
    /// The fitted weights do not make a valid profile (not finite).
    #[error("fitted profile: {0}")]
    Profile(DiffusionProfileError),
}

// The message holds the cause's, which `source()` therefore does not repeat.
impl From<DiffusionProfileError> for DiffusionFitError {
    fn from(error: DiffusionProfileError) -> Self {
        Self::Profile(error)
    }
}

const CHANNELS: [&str; 3] = ["red", "green", "blue"];

/// One θ node of one sphere as the fit uses it.
struct Node {
    sphere: usize,
    radius_mm: f64,
    theta_rad: f64,
    shadow: bool,
    value: Vec3,
    /// 1 / max(value, floor) per channel; 0 where the channel is not used.
    weight: [f64; 3],
}

/// Fits the profile to `spheres` (see the [module docs](self)).
///
/// # Errors
/// See [`DiffusionFitError`].
pub fn fit_diffusion(
    spheres: &[SphereCurve<'_>],
    settings: &DiffusionSettings,
) -> Result<DiffusionFit, DiffusionFitError> {
    if settings.entry_cosine_powers.is_empty() || settings.theta_stride == 0 {
        return Err(DiffusionFitError::Settings(
            "no entry cosine powers, or a θ stride of 0".into(),
        ));
    }
    // Checks the lengths (and the power range) up front.
    let check = |power: f32| {
        DiffusionProfile::new(
            settings
                .lengths_mm
                .iter()
                .map(|&length_mm| ProfileTerm {
                    length_mm,
                    weight: [0.0; 3],
                })
                .collect(),
            power,
        )
    };
    for &power in &settings.entry_cosine_powers {
        check(power).map_err(|e| DiffusionFitError::Settings(e.to_string()))?;
    }
    let nodes = usable_nodes(spheres, settings.theta_stride)?;
    for (c, channel) in CHANNELS.into_iter().enumerate() {
        let count = nodes.iter().filter(|n| n.weight[c] > 0.0).count();
        if count < MIN_NODES {
            return Err(DiffusionFitError::TooFewNodes {
                channel,
                nodes: count,
                needed: MIN_NODES,
            });
        }
    }
    let lengths: Vec<f64> = settings.lengths_mm.iter().map(|&l| f64::from(l)).collect();

    /// One entry power's fit.
    struct Candidate {
        power: f32,
        relative_rms: [f32; 3],
        design: Vec<Vec<f64>>,
        weights: [Vec<f64>; 3],
    }
    let mut best: Option<Candidate> = None;
    let mut powers_tried = Vec::new();
    for &power in &settings.entry_cosine_powers {
        let design = design_matrix(&nodes, &lengths, f64::from(power));
        let weights: [Vec<f64>; 3] = std::array::from_fn(|c| channel_weights(&nodes, &design, c));
        let rms: [f32; 3] =
            std::array::from_fn(|c| relative_rms(&nodes, &design, &weights[c], c, |_| true));
        let cost: f32 = rms.iter().sum();
        powers_tried.push((power, cost));
        if best
            .as_ref()
            .is_none_or(|b| cost < b.relative_rms.iter().sum())
        {
            best = Some(Candidate {
                power,
                relative_rms: rms,
                design,
                weights,
            });
        }
    }
    let Candidate {
        power,
        relative_rms: relative_rms_all,
        design,
        weights,
    } = best.expect("at least one power was tried");
    let terms = lengths
        .iter()
        .enumerate()
        .map(|(k, &length)| ProfileTerm {
            length_mm: length as f32,
            weight: std::array::from_fn(|c| weights[c][k] as f32),
        })
        .collect();
    let profile = DiffusionProfile::new(terms, power)?;

    let sphere_quality = spheres
        .iter()
        .enumerate()
        .filter(|(_, s)| s.curvature_per_mm.is_finite() && s.curvature_per_mm > 0.0)
        .map(|(k, s)| {
            let ratio = |c: usize, shadow: bool| {
                let (mut model, mut measured) = (0.0, 0.0);
                for (node, row) in nodes.iter().zip(&design) {
                    if node.sphere == k && node.shadow == shadow && node.weight[c] > 0.0 {
                        model += dot(row, &weights[c]);
                        measured += f64::from(node.value[c]);
                    }
                }
                if measured > 0.0 {
                    (model / measured) as f32
                } else {
                    f32::NAN
                }
            };
            SphereQuality {
                radius_mm: s.curvature_per_mm.recip(),
                relative_rms: std::array::from_fn(|c| {
                    relative_rms(&nodes, &design, &weights[c], c, |n| n.sphere == k)
                }),
                lit_ratio: std::array::from_fn(|c| ratio(c, false)),
                shadow_ratio: std::array::from_fn(|c| ratio(c, true)),
            }
        })
        .collect();
    Ok(DiffusionFit {
        profile,
        settings: settings.clone(),
        relative_rms: relative_rms_all,
        spheres: sphere_quality,
        powers_tried,
    })
}

/// The profile fit of `fit`'s curves, spheres with curvatures `curvature_per_mm` (same order).
///
/// # Errors
/// As [`fit_diffusion`]; [`DiffusionFitError::Shape`] also when the curvatures are not one per
/// sphere.
pub fn fit_diffusion_curve_fit(
    fit: &CurveFit,
    curvature_per_mm: &[f32],
    settings: &DiffusionSettings,
) -> Result<DiffusionFit, DiffusionFitError> {
    if curvature_per_mm.len() != fit.curves.len() || fit.node_samples.len() != fit.curves.len() {
        return Err(DiffusionFitError::Shape {
            sphere: curvature_per_mm.len().min(fit.curves.len()),
            values: fit.curves.len(),
            samples: fit.node_samples.len(),
        });
    }
    fit_diffusion(&SphereCurve::all_from_fit(fit, curvature_per_mm), settings)
}

/// The nodes the fit uses.
fn usable_nodes(
    spheres: &[SphereCurve<'_>],
    stride: usize,
) -> Result<Vec<Node>, DiffusionFitError> {
    let mut nodes = Vec::new();
    for (k, sphere) in spheres.iter().enumerate() {
        let n = sphere.values.len();
        if n < 2 || sphere.samples.len() != n {
            return Err(DiffusionFitError::Shape {
                sphere: k,
                values: n,
                samples: sphere.samples.len(),
            });
        }
        if !(sphere.curvature_per_mm.is_finite() && sphere.curvature_per_mm > 0.0) {
            continue;
        }
        let radius_mm = f64::from(sphere.curvature_per_mm.recip());
        let peak = sphere
            .values
            .iter()
            .filter(|v| v.is_finite())
            .fold(Vec3::ZERO, |a, v| a.max(*v));
        for i in (0..n).step_by(stride) {
            let value = sphere.values[i];
            if sphere.samples[i].is_nan() || sphere.samples[i] <= 0.0 || !value.is_finite() {
                continue;
            }
            let weight = std::array::from_fn(|c| {
                if value[c] > 0.0 && peak[c] > 0.0 {
                    1.0 / f64::from(value[c]).max(RELATIVE_FLOOR * f64::from(peak[c]))
                } else {
                    0.0
                }
            });
            let theta = std::f64::consts::PI * i as f64 / (n - 1) as f64;
            nodes.push(Node {
                sphere: k,
                radius_mm,
                theta_rad: theta,
                shadow: theta >= std::f64::consts::FRAC_PI_2 - 1e-9,
                value,
                weight,
            });
        }
    }
    Ok(nodes)
}

/// One row of unit-term responses per node.
fn design_matrix(nodes: &[Node], lengths: &[f64], power: f64) -> Vec<Vec<f64>> {
    nodes
        .par_iter()
        .map(|node| {
            let mut row = vec![0.0; lengths.len()];
            sphere_term_responses(lengths, node.radius_mm, node.theta_rad, power, &mut row);
            row
        })
        .collect()
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Non-negative weights of channel `c` minimising the weighted relative residual.
fn channel_weights(nodes: &[Node], design: &[Vec<f64>], c: usize) -> Vec<f64> {
    let rows: Vec<(Vec<f64>, f64)> = nodes
        .iter()
        .zip(design)
        .filter(|(n, _)| n.weight[c] > 0.0)
        .map(|(n, row)| {
            let w = n.weight[c];
            (
                row.iter().map(|a| a * w).collect(),
                f64::from(n.value[c]) * w,
            )
        })
        .collect();
    nnls(&rows, design.first().map_or(0, Vec::len))
}

/// Relative RMS of channel `c` over the used nodes that `keep` selects.
fn relative_rms(
    nodes: &[Node],
    design: &[Vec<f64>],
    weights: &[f64],
    c: usize,
    keep: impl Fn(&Node) -> bool,
) -> f32 {
    let (mut sum, mut count) = (0.0, 0usize);
    for (node, row) in nodes.iter().zip(design) {
        if node.weight[c] > 0.0 && keep(node) {
            let r = (dot(row, weights) - f64::from(node.value[c])) * node.weight[c];
            sum += r * r;
            count += 1;
        }
    }
    if count == 0 {
        f32::NAN
    } else {
        (sum / count as f64).sqrt() as f32
    }
}

/// Non-negative least squares `min ‖A x − b‖, x ≥ 0` for a few columns (Lawson & Hanson's active
/// set method on the normal equations, columns scaled to unit norm). `rows` are (row of A, b).
fn nnls(rows: &[(Vec<f64>, f64)], columns: usize) -> Vec<f64> {
    let k = columns;
    let mut gram = vec![vec![0.0; k]; k];
    let mut atb = vec![0.0; k];
    for (row, b) in rows {
        for i in 0..k {
            atb[i] += row[i] * b;
            for j in 0..k {
                gram[i][j] += row[i] * row[j];
            }
        }
    }
    // Unit columns: the basis spans lengths 100× apart, whose responses differ in scale.
    let scale: Vec<f64> = (0..k)
        .map(|i| {
            if gram[i][i] > 0.0 {
                gram[i][i].sqrt().recip()
            } else {
                0.0
            }
        })
        .collect();
    for i in 0..k {
        atb[i] *= scale[i];
        for j in 0..k {
            gram[i][j] *= scale[i] * scale[j];
        }
    }
    let tolerance = 1e-12 * atb.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
    let mut x = vec![0.0; k];
    let mut passive = vec![false; k];
    for _ in 0..3 * k + 3 {
        // The gradient of −½‖Ax − b‖² on the active (zero) set.
        let gradient: Vec<f64> = (0..k).map(|i| atb[i] - dot(&gram[i], &x)).collect();
        let Some(j) = (0..k)
            .filter(|&i| !passive[i] && scale[i] > 0.0 && gradient[i] > tolerance)
            .max_by(|&a, &b| gradient[a].total_cmp(&gradient[b]))
        else {
            break;
        };
        passive[j] = true;
        for _ in 0..3 * k + 3 {
            let z = solve_passive(&gram, &atb, &passive);
            if (0..k).all(|i| !passive[i] || z[i] > 0.0) {
                x = z;
                break;
            }
            // Step from x towards z until the first passive weight reaches 0.
            let alpha = (0..k)
                .filter(|&i| passive[i] && z[i] <= 0.0)
                .map(|i| x[i] / (x[i] - z[i]))
                .fold(1.0f64, f64::min);
            for i in 0..k {
                x[i] += alpha * (z[i] - x[i]);
                if passive[i] && x[i] <= 1e-15 {
                    passive[i] = false;
                    x[i] = 0.0;
                }
            }
        }
    }
    x.iter().zip(&scale).map(|(x, s)| x * s).collect()
}

/// The least-squares solution on the passive set (zero elsewhere): Gaussian elimination with
/// partial pivoting on the scaled normal equations, with a tiny ridge against collinear columns.
fn solve_passive(gram: &[Vec<f64>], atb: &[f64], passive: &[bool]) -> Vec<f64> {
    let index: Vec<usize> = (0..atb.len()).filter(|&i| passive[i]).collect();
    let rows = index
        .iter()
        .enumerate()
        .map(|(local, &i)| {
            let mut row: Vec<f64> = index.iter().map(|&j| gram[i][j]).collect();
            row[local] += 1e-10;
            row.push(atb[i]);
            row
        })
        .collect();
    let z_local: Vec<f64> =
        solve_gaussian(rows, SingularColumn::Zero).expect("a singular column gives 0, not None");
    let mut z = vec![0.0; atb.len()];
    for (local, &i) in index.iter().enumerate() {
        z[i] = z_local[local];
    }
    z
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nnls_solves_a_small_problem_with_an_active_bound() {
        // b = 2·a0 − 1·a1 exactly: the unconstrained solution has a negative weight, NNLS
        // zeroes it and fits the rest.
        let rows: Vec<(Vec<f64>, f64)> = (0..10)
            .map(|i| {
                let t = i as f64 / 9.0;
                (vec![1.0, t, t * t], 2.0 - t)
            })
            .collect();
        let x = nnls(&rows, 3);
        assert!(x.iter().all(|&v| v >= 0.0), "{x:?}");
        // b = 2 − t ≥ 0 on [0, 1]; best non-negative fit uses the constant only: x0 = mean(b).
        let mean = rows.iter().map(|r| r.1).sum::<f64>() / 10.0;
        assert!(
            (x[0] - mean).abs() < 1e-9 && x[1] == 0.0 && x[2] == 0.0,
            "{x:?}"
        );
        // And a feasible exact problem is solved exactly.
        let rows: Vec<(Vec<f64>, f64)> = (0..10)
            .map(|i| {
                let t = i as f64 / 9.0;
                (vec![1.0, t, t * t], 0.5 + 3.0 * t * t)
            })
            .collect();
        let x = nnls(&rows, 3);
        assert!((x[0] - 0.5).abs() < 1e-7 && x[1].abs() < 1e-7 && (x[2] - 3.0).abs() < 1e-7);
    }
}
