//! Ring pre-integration of a radial diffusion profile (Penner & Borshukov 2011).

use std::f64::consts::{FRAC_1_PI, FRAC_PI_2, PI};

use super::profile::RadialProfile;
use super::quadrature::{GAUSS_LEGENDRE_8, for_each_node};
use super::{clamped_cos, fold_theta};
use crate::Cdrf;

/// Kernels narrower than this (radians, whole support) are not resolved: the result is `cos⁺θ`,
/// which is then within this distance of the exact value.
const UNRESOLVED_WIDTH_RAD: f64 = 1e-9;

/// Panels start no smaller than `2⁻⁴⁰` of the largest distance on the ring, bounding the panel
/// count at any curvature.
const MAX_DOUBLINGS: i32 = 40;

/// Panels wider than this (radians) are split evenly: the kernel is smooth there but, near the
/// far side of a small sphere, not smooth enough for one 8-point rule over up to π.
const MAX_PANEL_RAD: f64 = std::f64::consts::FRAC_PI_4;

/// Upper bound on panel edges: 0, ≤ 41 geometric edges, the end, 4 kinks.
const MAX_EDGES: usize = 48;

/// Penner & Borshukov's pre-integrated skin shading for any [`RadialProfile`] `R(d)`: per RGB
/// channel, with `r = 1/κ` mm,
///
/// ```text
/// D(θ, r) = ∫₋π^π cos⁺(θ + x) R(2r·sin(x/2)) dx  /  ∫₋π^π R(2r·sin(x/2)) dx.
/// ```
///
/// κ ≤ 0 (flat or concave) gives `cos⁺θ`, κ = +∞ gives `1/π`.
///
/// # Quadrature
/// With the kernel even, the numerator is `∫₀^π R(2r sin(z/2))·[cos⁺(θ + z) + cos⁺(θ − z)] dz`.
/// Both integrals run over the same 8-point Gauss–Legendre panels in `z`: edges at chord
/// distances `ℓ, 2ℓ, 4ℓ, …` from the profile's [feature length](RadialProfile::feature_length_mm)
/// `ℓ` up to its support (or the far side of the sphere), plus every kink of `cos⁺(θ ± z)`, and
/// no panel wider than π/4. Each panel sees a smooth integrand whatever the ratio of kernel width
/// to π (tested from 0.0016 rad, skin at r = 50 mm, to kernels wider than the circle). The rule
/// is fixed, so the result is smooth in θ, κ and the profile's parameters. A kernel narrower than
/// 1e-9 rad in all is not resolved and gives `cos⁺θ`.
///
/// ```
/// use cdrf_core::Cdrf;
/// use cdrf_core::gaussian::{DipoleProfile, PreintegratedCdrf};
///
/// let marble = PreintegratedCdrf::new(DipoleProfile::marble());
/// let f = marble.reflectance(1.0 / 20.0, 100f32.to_radians());
/// assert!(f.iter().all(|&v| v > 0.0)); // light wraps past the terminator
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct PreintegratedCdrf<P> {
    profile: P,
}

impl<P: RadialProfile> PreintegratedCdrf<P> {
    /// Pre-integration of `profile`.
    pub fn new(profile: P) -> Self {
        Self { profile }
    }

    /// The profile.
    pub fn profile(&self) -> &P {
        &self.profile
    }

    /// Gives the profile back.
    pub fn into_profile(self) -> P {
        self.profile
    }

    /// [`Cdrf::reflectance`] in `f64`, without rounding to `f32`.
    pub fn reflectance_f64(&self, curvature_per_mm: f64, theta_rad: f64) -> [f64; 3] {
        let theta = fold_theta(theta_rad);
        // A NaN κ is flat too.
        if curvature_per_mm.is_nan() || curvature_per_mm <= 0.0 {
            return [clamped_cos(theta); 3];
        }
        if curvature_per_mm == f64::INFINITY {
            return [FRAC_1_PI; 3];
        }
        let radius_mm = curvature_per_mm.recip();
        if radius_mm == f64::INFINITY {
            // A subnormal κ: flat for every profile.
            return [clamped_cos(theta); 3];
        }
        let diameter_mm = 2.0 * radius_mm;
        // Ring angle of the chord distance d (the far side of the sphere from d ≥ 2r on).
        let angle = |d: f64| {
            if d >= diameter_mm {
                PI
            } else {
                2.0 * (d / diameter_mm).asin()
            }
        };
        // `min` ignores a NaN support, which then covers the whole ring.
        let d_end = self.profile.support_radius_mm().min(diameter_mm);
        let z_end = angle(d_end);
        if z_end <= UNRESOLVED_WIDTH_RAD {
            return [clamped_cos(theta); 3];
        }

        let mut edges = [0.0; MAX_EDGES];
        let mut count = 1; // edges[0] = 0
        // `max` ignores a NaN feature length.
        let mut d = self
            .profile
            .feature_length_mm()
            .max(d_end * 2f64.powi(-MAX_DOUBLINGS));
        while d < d_end && count < MAX_EDGES - 5 {
            edges[count] = angle(d);
            count += 1;
            d *= 2.0;
        }
        edges[count] = z_end;
        count += 1;
        // Kinks of cos⁺(θ + z) and cos⁺(θ − z) for z ∈ [0, π].
        for kink in [
            FRAC_PI_2 - theta,
            theta - FRAC_PI_2,
            theta + FRAC_PI_2,
            3.0 * FRAC_PI_2 - theta,
        ] {
            if kink > 0.0 && kink < z_end {
                edges[count] = kink;
                count += 1;
            }
        }
        let edges = &mut edges[..count];
        edges.sort_unstable_by(f64::total_cmp);

        let mut numerator = [0.0; 3];
        let mut denominator = [0.0; 3];
        let mut add_panel = |a: f64, b: f64| {
            for_each_node(&GAUSS_LEGENDRE_8, a, b, |z, w| {
                let kernel = self
                    .profile
                    .radial_reflectance(diameter_mm * (0.5 * z).sin());
                let lambert = clamped_cos(theta + z) + clamped_cos(theta - z);
                for c in 0..3 {
                    numerator[c] += w * kernel[c] * lambert;
                    denominator[c] += w * kernel[c];
                }
            });
        };
        for panel in edges.windows(2) {
            let (start, end) = (panel[0], panel[1]);
            if end <= start {
                continue;
            }
            let pieces = ((end - start) / MAX_PANEL_RAD).ceil() as usize;
            let width = (end - start) / pieces as f64;
            for piece in 0..pieces - 1 {
                add_panel(
                    start + width * piece as f64,
                    start + width * (piece + 1) as f64,
                );
            }
            add_panel(start + width * (pieces - 1) as f64, end);
        }
        // Both integrals cover only half the ring; the factor 2 cancels, and the numerator's
        // two cos⁺ terms already stand for ±z.
        std::array::from_fn(|c| 0.5 * numerator[c] / denominator[c])
    }
}

impl<P: RadialProfile> Cdrf for PreintegratedCdrf<P> {
    fn reflectance(&self, curvature_per_mm: f32, theta_rad: f32) -> [f32; 3] {
        self.reflectance_f64(f64::from(curvature_per_mm), f64::from(theta_rad))
            .map(|v| v as f32)
    }
}
