//! The Gaussian CDRF of Kubo et al. (2010): `cos⁺` blurred by a wrapped Gaussian of angular
//! standard deviation σ·κ.

use std::f64::consts::{FRAC_1_PI, FRAC_2_PI, FRAC_PI_2};

use super::quadrature::{GAUSS_LEGENDRE_16, integrate};
use super::{ParameterError, Range, check_rgb, clamped_cos, fold_theta};
use crate::Cdrf;

/// From this angular standard deviation (radians) up, [`convolved_clamped_cosine`] sums the
/// Fourier series (at most 14 harmonics here); below it, it integrates near the terminator.
/// `LOCAL_SUPPORT · FOURIER_MIN_SIGMA_RAD < π/2` keeps the local form to one lobe of `cos⁺`.
const FOURIER_MIN_SIGMA_RAD: f64 = 0.25;

/// The local form treats the Gaussian as zero beyond this many standard deviations (the mass
/// left out is 2·10⁻⁹).
const LOCAL_SUPPORT: f64 = 6.0;

/// Fourier terms smaller than this are dropped.
const FOURIER_TOLERANCE: f64 = 1e-13;

/// `1/√(2π)`.
const FRAC_1_SQRT_TAU: f64 = 0.398_942_280_401_432_7;

/// `(cos⁺ ⊛ g_s)(θ)`: the clamped cosine convolved on the circle with the wrapped Gaussian of
/// angular standard deviation `s = angular_sigma_rad`. This is the Gaussian CDRF with unit scale
/// and `s = σ·κ`; a fitter that fits σ per channel can call it directly.
///
/// The result depends on `s` only through `s²` (a negative `s` acts as `|s|`); `s = 0` gives
/// `cos⁺θ`, `s = ∞` gives `1/π`. Any θ is accepted (the function is even and 2π-periodic in θ).
/// Absolute error ≲ 1e-9.
///
/// # Method
/// For `s ≥ 0.25` the Fourier series is summed: with the wrapped Gaussian's coefficients
/// `e^(−n²s²/2)` and those of `cos⁺`,
///
/// ```text
/// f(θ) = 1/π + ½·e^(−s²/2)·cos θ + (2/π) Σₖ₌₁ (−1)^(k+1) e^(−2k²s²) cos(2kθ) / (4k² − 1).
/// ```
///
/// For smaller `s` the Gaussian (cut at 6s < π/2) meets at most the one terminator at
/// θ = π/2, and `f = e^(−s²/2)·cos θ − ∫_dark cos(θ − t)·g_s(t) dt` on the lit side
/// (`f = ∫_lit …` on the dark side), the remaining integral over part of one half of the
/// Gaussian taken with 16-point Gauss–Legendre.
pub fn convolved_clamped_cosine(theta_rad: f64, angular_sigma_rad: f64) -> f64 {
    let theta = fold_theta(theta_rad);
    let s = angular_sigma_rad.abs();
    if s == 0.0 {
        clamped_cos(theta)
    } else if s >= FOURIER_MIN_SIGMA_RAD {
        fourier(theta, s)
    } else {
        local(theta, s)
    }
}

/// The Fourier series (see [`convolved_clamped_cosine`]); `s ≥ FOURIER_MIN_SIGMA_RAD`, `θ` any.
fn fourier(theta: f64, s: f64) -> f64 {
    let q = s * s;
    let sum = FRAC_1_PI + 0.5 * (-0.5 * q).exp() * theta.cos();
    // cos(2kθ) by the Chebyshev recurrence; e^(−2k²q) by the ratio e^(−2q(2k+1)).
    let cos_2theta = (2.0 * theta).cos();
    let (mut cos_prev, mut cos_k) = (1.0, cos_2theta);
    let step = (-4.0 * q).exp();
    let mut ratio = (-6.0 * q).exp();
    let mut damping = (-2.0 * q).exp();
    let mut series = 0.0;
    let mut sign = 1.0;
    for k in 1..1000 {
        let k = f64::from(k);
        let magnitude = damping / (4.0 * k * k - 1.0);
        if magnitude < FOURIER_TOLERANCE {
            break;
        }
        series += sign * magnitude * cos_k;
        sign = -sign;
        (cos_prev, cos_k) = (cos_k, 2.0 * cos_2theta * cos_k - cos_prev);
        damping *= ratio;
        ratio *= step;
    }
    sum + FRAC_2_PI * series
}

/// The terminator correction (see [`convolved_clamped_cosine`]); `0 < s < FOURIER_MIN_SIGMA_RAD`,
/// `θ ∈ [0, π]`.
fn local(theta: f64, s: f64) -> f64 {
    // The kernel offset t = s·u is lit iff t > θ − π/2.
    let u_terminator = (theta - FRAC_PI_2) / s;
    let (sin_theta, cos_theta) = theta.sin_cos();
    // ∫_a^T cos(θ ∓ s·u)·φ(u) du over part of one half of the standard normal.
    let half_tail = |a: f64, sign: f64| {
        integrate(&GAUSS_LEGENDRE_16, a, LOCAL_SUPPORT, |u| {
            let (sin_su, cos_su) = (s * u).sin_cos();
            (cos_theta * cos_su + sign * sin_theta * sin_su) * (-0.5 * u * u).exp()
        }) * FRAC_1_SQRT_TAU
    };
    if u_terminator <= 0.0 {
        // Lit side: everything minus the dark tail u < u_terminator (mirrored to v = −u > −u_t).
        let full = (-0.5 * s * s).exp() * cos_theta;
        if u_terminator <= -LOCAL_SUPPORT {
            full
        } else {
            full - half_tail(-u_terminator, -1.0)
        }
    } else if u_terminator >= LOCAL_SUPPORT {
        0.0
    } else {
        // Dark side: only the lit tail u > u_terminator.
        half_tail(u_terminator, 1.0)
    }
}

/// The Gaussian CDRF of Kubo et al. (2010): per RGB channel,
/// `f(θ, κ) = scale · (cos⁺ ⊛ g_(σκ))(θ)`, the clamped cosine blurred along the great circle by a
/// wrapped Gaussian whose angular standard deviation is `σ·κ` radians (σ in mm, κ in mm⁻¹).
///
/// κ ≤ 0 (flat or concave) gives `scale · cos⁺θ`. See the [module docs](super) for the wrapping,
/// what is conserved and the accuracy; [`convolved_clamped_cosine`] is the per-channel kernel.
///
/// ```
/// use cdrf_core::Cdrf;
/// use cdrf_core::gaussian::GaussianCdrf;
///
/// let wax = GaussianCdrf::with_scale([6.0, 4.0, 3.0], [0.9, 0.8, 0.7])?;
/// assert_eq!(wax.reflectance(0.0, 0.0), [0.9, 0.8, 0.7]); // flat: scale · cos 0
/// # Ok::<(), cdrf_core::gaussian::ParameterError>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaussianCdrf {
    sigma_mm: [f32; 3],
    scale: [f32; 3],
}

impl GaussianCdrf {
    /// A Gaussian CDRF with spatial standard deviation `sigma_mm` per RGB channel and scale 1.
    ///
    /// # Errors
    /// [`ParameterError`] when a σ is negative, NaN or infinite.
    pub fn new(sigma_mm: [f32; 3]) -> Result<Self, ParameterError> {
        Self::with_scale(sigma_mm, [1.0; 3])
    }

    /// A Gaussian CDRF with spatial standard deviation `sigma_mm` and an albedo-like `scale` per
    /// RGB channel.
    ///
    /// # Errors
    /// [`ParameterError`] when a σ or scale is negative, NaN or infinite.
    pub fn with_scale(sigma_mm: [f32; 3], scale: [f32; 3]) -> Result<Self, ParameterError> {
        check_rgb(sigma_mm, Range::NonNegative, "mm", "sigma_mm")?;
        check_rgb(scale, Range::NonNegative, "", "scale")?;
        Ok(Self { sigma_mm, scale })
    }

    /// The spatial standard deviation σ per RGB channel, in mm.
    pub fn sigma_mm(&self) -> [f32; 3] {
        self.sigma_mm
    }

    /// The scale per RGB channel.
    pub fn scale(&self) -> [f32; 3] {
        self.scale
    }

    /// [`Cdrf::reflectance`] in `f64`, without rounding to `f32`.
    pub fn reflectance_f64(&self, curvature_per_mm: f64, theta_rad: f64) -> [f64; 3] {
        std::array::from_fn(|c| {
            let scale = f64::from(self.scale[c]);
            let sigma_mm = f64::from(self.sigma_mm[c]);
            // A NaN κ is flat too; σ = 0 is excluded so that κ = ∞ gives cos⁺ rather than 0·∞.
            if curvature_per_mm.is_nan() || curvature_per_mm <= 0.0 || sigma_mm == 0.0 {
                scale * clamped_cos(theta_rad)
            } else {
                scale * convolved_clamped_cosine(theta_rad, sigma_mm * curvature_per_mm)
            }
        })
    }
}

impl Cdrf for GaussianCdrf {
    fn reflectance(&self, curvature_per_mm: f32, theta_rad: f32) -> [f32; 3] {
        self.reflectance_f64(f64::from(curvature_per_mm), f64::from(theta_rad))
            .map(|v| v as f32)
    }
}
