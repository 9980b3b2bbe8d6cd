//! From per-sphere curves to the table: Catmull-Rom across curvature, the view correction grid,
//! coverage.

use cdrf_core::catmull_rom::{CatmullRom, SplineError};
use cdrf_core::lut::{CdrfLut, CurvatureAxis, LutError, TexelCoverage, ViewCorrection};
use glam::Vec3;

use crate::curves::{CurveFit, ViewModel};

/// Rows of the view-correction grid stored with a θ-dependent correction (5° apart).
pub const VIEW_THETA_ROWS: usize = 37;

/// Curvature layers of the view correction with a θ-dependent correction (uniform over the
/// table's curvature axis, at most its rows): each sphere's correction, linear in κ between
/// neighbouring spheres. 32 × 37 rows stay within the 2048 texels a GPU texture is guaranteed.
pub const VIEW_CURVATURE_LAYERS: usize = 32;

/// Why the table could not be built.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TableError {
    /// Two spheres have the same curvature, or a curvature is not finite.
    #[error("cannot interpolate across curvature: {0}")]
    Spline(SplineError),
    /// The fitted values do not form a valid table.
    #[error("fitted table is invalid: {0}")]
    Lut(LutError),
}

// The message holds the cause's, which `source()` therefore does not repeat.
impl From<SplineError> for TableError {
    fn from(error: SplineError) -> Self {
        Self::Spline(error)
    }
}

// The message holds the cause's, which `source()` therefore does not repeat.
impl From<LutError> for TableError {
    fn from(error: LutError) -> Self {
        Self::Lut(error)
    }
}

/// Builds the measured table from the fitted curves of spheres with curvatures
/// `curvature_per_mm`, as smoothed by [`smooth_curve`] (`smoothed`, same order as `fit.curves`).
///
/// With two or more spheres each θ column is a non-uniform Catmull-Rom spline through the
/// spheres' values at their curvatures, sampled at `curvature_count` rows uniformly spaced
/// between the flattest and the most curved sphere. With **one** sphere the table has a single
/// row: it is that sphere's curve at every curvature (no curvature dependence can be measured
/// from one radius).
///
/// # Errors
/// When two spheres share a curvature or the values are not a valid table.
pub fn build_table(
    fit: &CurveFit,
    smoothed: &[Vec<Vec3>],
    curvature_per_mm: &[f32],
    curvature_count: usize,
) -> Result<CdrfLut, TableError> {
    let theta_count = fit.settings.theta_count;
    let mut order: Vec<usize> = (0..curvature_per_mm.len()).collect();
    order.sort_by(|&a, &b| curvature_per_mm[a].total_cmp(&curvature_per_mm[b]));
    let knots: Vec<f32> = order.iter().map(|&k| curvature_per_mm[k]).collect();
    let (first, last) = (knots[0], knots[knots.len() - 1]);
    let axis = if knots.len() == 1 {
        CurvatureAxis {
            min_per_mm: first,
            max_per_mm: first,
            count: 1,
        }
    } else {
        CurvatureAxis {
            min_per_mm: first,
            max_per_mm: last,
            count: curvature_count.max(2),
        }
    };

    let mut radiance = vec![Vec3::ZERO; axis.count * theta_count];
    let mut coverage = vec![TexelCoverage::default(); axis.count * theta_count];
    for column in 0..theta_count {
        let values: Vec<Vec3> = order.iter().map(|&k| smoothed[k][column]).collect();
        let counts: Vec<f32> = order.iter().map(|&k| fit.node_samples[k][column]).collect();
        let noise: Vec<f32> = order
            .iter()
            .map(|&k| fit.node_noise[k][column].element_sum() / 3.0)
            .collect();
        let spline = (knots.len() > 1)
            .then(|| CatmullRom::new(&knots, &values))
            .transpose()?;
        for row in 0..axis.count {
            let curvature = axis.curvature_per_mm(row);
            let index = row * theta_count + column;
            radiance[index] = match &spline {
                Some(spline) => spline.evaluate(curvature).max(Vec3::ZERO),
                None => values[0],
            };
            // Coverage between two spheres: linear in κ between theirs.
            let upper = knots
                .partition_point(|&k| k < curvature)
                .min(knots.len() - 1);
            let lower = upper.saturating_sub(1);
            let t = if upper == lower || knots[upper] == knots[lower] {
                0.0
            } else {
                ((curvature - knots[lower]) / (knots[upper] - knots[lower])).clamp(0.0, 1.0)
            };
            coverage[index] = TexelCoverage {
                sample_count: counts[lower] * (1.0 - t) + counts[upper] * t,
                relative_spread: noise[lower] * (1.0 - t) + noise[upper] * t,
            };
        }
    }
    Ok(CdrfLut::new(axis, theta_count, radiance)?
        .with_coverage(coverage)?
        .with_view_correction(view_correction(fit, curvature_per_mm, axis)?))
}

/// Relative standard error a smoothed node aims for (1 %).
const TARGET_RELATIVE_ERROR: f32 = 0.01;
/// Widest smoothing half-window, nodes.
const MAX_HALF_WINDOW: usize = 12;

/// Fills and smooths one sphere's curve along θ for the table.
///
/// Each node is replaced by a weighted straight-line fit of **log f** over the smallest window
/// of neighbours whose samples together pin f down to 1 % (a node's
/// precision is samples / relative noise²). On the lit side one node already does, so nothing
/// changes there; on the noisy shadow side the window widens. Fitting lines in log f follows
/// the shadow side's exponential fall-off without flattening it. Nodes without data (θ near
/// 0° and 180°, on the silhouette) keep the curve fit's fill: flat toward the ends, as f's even
/// symmetry about 0 and π requires (see [`crate::curves`]); on the shadow side the fit then
/// replaces what was not measured by the diffusion profile's fall-off ([`crate::tails`]).
pub fn smooth_curve(fit: &CurveFit, sphere: usize) -> Vec<Vec3> {
    let curve = &fit.curves[sphere];
    let counts = &fit.node_samples[sphere];
    let noise = &fit.node_noise[sphere];
    let n = curve.len();
    let measured: Vec<bool> = (0..n).map(|a| counts[a] > 0.0).collect();
    let needed = 1.0 / (TARGET_RELATIVE_ERROR * TARGET_RELATIVE_ERROR);
    let peak = curve.iter().fold(Vec3::ZERO, |m, v| m.max(*v));
    let mut out = curve.clone();
    for a in (0..n).filter(|&a| measured[a]) {
        let mut value = curve[a];
        for c in 0..3 {
            // Samples / relative noise², 0 for an empty node.
            let precision = |b: usize| {
                if measured[b] {
                    counts[b] / (noise[b][c] * noise[b][c]).max(1e-8)
                } else {
                    0.0
                }
            };
            let mut half = 0;
            let mut total = precision(a);
            while total < needed && half < MAX_HALF_WINDOW {
                half += 1;
                total += a.checked_sub(half).map_or(0.0, precision);
                total += if a + half < n {
                    precision(a + half)
                } else {
                    0.0
                };
            }
            if half == 0 {
                continue;
            }
            // Weighted least-squares line through (b − a, ln f_b), evaluated at 0.
            let floor = peak[c] * 1e-7 + 1e-12;
            let (mut sw, mut sx, mut sxx, mut sy, mut sxy) = (0.0_f64, 0.0, 0.0, 0.0, 0.0);
            for b in a.saturating_sub(half)..=(a + half).min(n - 1) {
                let w = precision(b) as f64;
                let x = b as f64 - a as f64;
                let y = (curve[b][c].max(floor) as f64).ln();
                sw += w;
                sx += w * x;
                sxx += w * x * x;
                sy += w * y;
                sxy += w * x * y;
            }
            let det = sw * sxx - sx * sx;
            let intercept = if det.abs() > 1e-9 * sw * sw {
                (sy * sxx - sxy * sx) / det
            } else {
                sy / sw
            };
            value[c] = intercept.exp() as f32;
        }
        out[a] = value;
    }
    out
}

/// The fit's view factor as the table's [`ViewCorrection`] grid: g(φ) alone, or g(φ)·c(κ, θ, φ)
/// on [`VIEW_CURVATURE_LAYERS`] layers over the table's curvature `axis`, each sphere's c_k
/// (curvatures `curvature_per_mm`, the fit's order) linear in κ between neighbouring spheres and
/// held beyond the ends.
///
/// # Errors
/// When the fitted values are not a valid grid (negative or non-finite).
pub fn view_correction(
    fit: &CurveFit,
    curvature_per_mm: &[f32],
    axis: CurvatureAxis,
) -> Result<ViewCorrection, LutError> {
    if fit.settings.view_model == ViewModel::Phi || fit.correction.is_none() {
        return ViewCorrection::from_phi(fit.g_phi.clone());
    }
    let layers = if axis.count > 1 {
        CurvatureAxis {
            count: VIEW_CURVATURE_LAYERS.min(axis.count),
            ..axis
        }
    } else {
        axis
    };
    let mut order: Vec<usize> = (0..curvature_per_mm.len()).collect();
    order.sort_by(|&a, &b| curvature_per_mm[a].total_cmp(&curvature_per_mm[b]));
    let phi_count = fit.settings.phi_count;
    let values = (0..layers.count)
        .flat_map(|layer| {
            let curvature = layers.curvature_per_mm(layer);
            // The two spheres around this curvature and the weight of the upper one.
            let upper = order
                .partition_point(|&k| curvature_per_mm[k] < curvature)
                .min(order.len() - 1);
            let lower = upper.saturating_sub(1);
            let (k0, k1) = (order[lower], order[upper]);
            let span = curvature_per_mm[k1] - curvature_per_mm[k0];
            let t = if span > 0.0 {
                ((curvature - curvature_per_mm[k0]) / span).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (0..VIEW_THETA_ROWS).flat_map(move |row| {
                let theta = std::f32::consts::PI * row as f32 / (VIEW_THETA_ROWS - 1) as f32;
                (0..phi_count).map(move |column| {
                    let phi = std::f32::consts::FRAC_PI_2 * column as f32 / (phi_count - 1) as f32;
                    fit.view_factor(k0, theta, phi)
                        .lerp(fit.view_factor(k1, theta, phi), t)
                })
            })
        })
        .collect();
    ViewCorrection::with_curvature_layers(phi_count, VIEW_THETA_ROWS, layers, values)
}
