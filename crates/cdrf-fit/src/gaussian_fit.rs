//! Fitting Kubo's Gaussian CDRF to the same samples, so both models can be compared fairly.
//!
//! Per channel, σ (mm) and a scale are chosen to minimise the plain squared error over every
//! usable pixel of the photographs (the measured fit's outliers included: they are a handful),
//! `Σᵢ (scale · K(θᵢ; σκᵢ) · gᵢ − Lᵢ)²`, with the view correction g·c of the measured model's
//! curve fit (the table stores the same on a 5° grid). Unweighted least squares on π·L/E is exactly the
//! image-space error the comparison reports, so this is the Gaussian's best shot at it.
//!
//! For a given σ the optimal scale is linear and closed-form, and the error reduces to
//! `c − (Kᵀr)² / KᵀMK`, where K holds the kernel on the θ nodes and `M`, `r` are the
//! (tridiagonal) normal equations of the samples on the nodes' hat functions, accumulated once.
//! σ is then found by a log-spaced scan and golden-section refinement.

use cdrf_core::gaussian::{GaussianCdrf, ParameterError, convolved_clamped_cosine};
use rayon::prelude::*;

use crate::curves::{CurveFit, SphereSamples};

/// The fitted Gaussian CDRF and how well it fits.
#[derive(Clone, Debug)]
pub struct GaussianFit {
    /// The model (σ per channel in mm, scale per channel).
    pub model: GaussianCdrf,
    /// Relative RMS error over all samples per channel: √(Σ residual² / Σ L²).
    pub relative_rms: [f32; 3],
}

/// Normal equations of one sphere and channel on the θ nodes (unweighted).
struct Normal {
    curvature_per_mm: f64,
    diagonal: Vec<f64>,
    upper: Vec<f64>,
    rhs: Vec<f64>,
}

/// Smallest and largest σ considered, mm.
pub(crate) const SIGMA_RANGE_MM: (f64, f64) = (0.01, 100.0);

/// Fits σ and scale per channel.
///
/// # Errors
/// Only if the fitted parameters are invalid (non-finite), which means the samples were.
pub fn fit_gaussian(
    spheres: &[SphereSamples],
    fit: &CurveFit,
) -> Result<GaussianFit, ParameterError> {
    let n = fit.settings.theta_count;
    let theta_nodes: Vec<f64> = (0..n)
        .map(|a| std::f64::consts::PI * a as f64 / (n - 1) as f64)
        .collect();
    // Per sphere: [channel] normal equations, and Σ L² per channel.
    let per_sphere: Vec<([Normal; 3], [f64; 3])> = spheres
        .par_iter()
        .enumerate()
        .map(|(k, sphere)| {
            let make = || Normal {
                curvature_per_mm: sphere.curvature_per_mm as f64,
                diagonal: vec![0.0; n],
                upper: vec![0.0; n],
                rhs: vec![0.0; n],
            };
            let mut normals = [make(), make(), make()];
            let mut energy = [0.0_f64; 3];
            for s in &sphere.samples {
                let g = fit.view_factor(k, s.theta_rad, s.phi_rad);
                let u = (s.theta_rad as f64 / std::f64::consts::PI * (n - 1) as f64)
                    .clamp(0.0, (n - 1) as f64);
                let a = (u as usize).min(n - 2);
                let t = u - a as f64;
                let (b0, b1) = (1.0 - t, t);
                for c in 0..3 {
                    let (gc, l) = (g[c] as f64, s.radiance[c] as f64);
                    let normal = &mut normals[c];
                    normal.diagonal[a] += gc * gc * b0 * b0;
                    normal.diagonal[a + 1] += gc * gc * b1 * b1;
                    normal.upper[a] += gc * gc * b0 * b1;
                    normal.rhs[a] += gc * l * b0;
                    normal.rhs[a + 1] += gc * l * b1;
                    energy[c] += l * l;
                }
            }
            (normals, energy)
        })
        .collect();

    // Channels are independent: fit them in parallel. Each gives (σ, scale, relative RMS).
    let per_channel: Vec<(f32, f32, f32)> = (0..3_usize)
        .into_par_iter()
        .map(|c| {
            let normals: Vec<&Normal> = per_sphere.iter().map(|(normals, _)| &normals[c]).collect();
            let energy: f64 = per_sphere.iter().map(|(_, e)| e[c]).sum();
            // For a σ: (Σ Kᵀr, Σ KᵀMK).
            let moments = |sigma: f64| -> (f64, f64) {
                normals
                    .iter()
                    .map(|normal| {
                        let kernel: Vec<f64> = theta_nodes
                            .iter()
                            .map(|&theta| {
                                convolved_clamped_cosine(theta, sigma * normal.curvature_per_mm)
                            })
                            .collect();
                        let mut k_r = 0.0;
                        let mut k_m_k = 0.0;
                        for a in 0..n {
                            k_r += kernel[a] * normal.rhs[a];
                            k_m_k += kernel[a] * kernel[a] * normal.diagonal[a];
                            if a + 1 < n {
                                k_m_k += 2.0 * kernel[a] * kernel[a + 1] * normal.upper[a];
                            }
                        }
                        (k_r, k_m_k)
                    })
                    .fold((0.0, 0.0), |acc, m| (acc.0 + m.0, acc.1 + m.1))
            };
            // The error is energy − (Kᵀr)²/KᵀMK: maximise the explained part.
            let explained = |log_sigma: f64| {
                let (k_r, k_m_k) = moments(log_sigma.exp());
                if k_m_k > 0.0 { k_r * k_r / k_m_k } else { 0.0 }
            };
            let sigma = best_log_sigma(&explained, 32, 30).exp();
            let (k_r, k_m_k) = moments(sigma);
            let fitted_scale = if k_m_k > 0.0 { k_r / k_m_k } else { 0.0 };
            let residual = (energy - fitted_scale * k_r).max(0.0);
            let relative_rms = if energy > 0.0 {
                (residual / energy).sqrt()
            } else {
                0.0
            };
            (sigma as f32, fitted_scale as f32, relative_rms as f32)
        })
        .collect();
    let sigma_mm = [0, 1, 2].map(|c| per_channel[c].0);
    let scale = [0, 1, 2].map(|c| per_channel[c].1);
    let relative_rms = [0, 1, 2].map(|c| per_channel[c].2);
    Ok(GaussianFit {
        model: GaussianCdrf::with_scale(sigma_mm, scale)?,
        relative_rms,
    })
}

/// The ln σ in [`SIGMA_RANGE_MM`] that maximises `explained` (a function of ln σ): the best of
/// `grid_steps + 1` log-spaced values, refined by `refine_iterations` golden-section steps within
/// one grid step of it. Kubo's fit to photographs and a preset's fit to its table both search so.
pub(crate) fn best_log_sigma(
    explained: &impl Fn(f64) -> f64,
    grid_steps: u32,
    refine_iterations: u32,
) -> f64 {
    let (lo, hi) = (SIGMA_RANGE_MM.0.ln(), SIGMA_RANGE_MM.1.ln());
    let steps = f64::from(grid_steps);
    let best = (0..=grid_steps)
        .map(|i| lo + (hi - lo) * f64::from(i) / steps)
        .map(|x| (x, explained(x)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(lo, |(x, _)| x);
    let step = (hi - lo) / steps;
    golden_section_max(
        explained,
        (best - step).max(lo),
        (best + step).min(hi),
        refine_iterations,
    )
}

fn golden_section_max(f: &impl Fn(f64) -> f64, mut a: f64, mut b: f64, iterations: u32) -> f64 {
    let ratio = (5.0_f64.sqrt() - 1.0) / 2.0;
    let mut c = b - ratio * (b - a);
    let mut d = a + ratio * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..iterations {
        if fc > fd {
            (b, d, fd) = (d, c, fc);
            c = b - ratio * (b - a);
            fc = f(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + ratio * (b - a);
            fd = f(d);
        }
    }
    (a + b) / 2.0
}
