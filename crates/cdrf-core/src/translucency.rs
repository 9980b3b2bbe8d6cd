//! What a CDRF cannot see: light blocked by, or travelling through, *other* parts of an object.
//!
//! A CDRF is local: at each point it knows the curvature κ and the light angle θ, so it answers
//! as if the point lay on its **osculating sphere** (radius 1/κ). On that sphere light reaching a
//! shadow-side point has crossed the chord `2·cos(θ − π)/κ` of material ([`local_chord_mm`]); the
//! measured table already holds that glow. A renderer with a shadow map knows the real distance
//! `d` light travels from the first surface it meets to the point, and corrects the CDRF where
//! the object differs from the osculating sphere (see `docs/shading.md`):
//! - **translucent visibility**: where an occluder lies nearer the light than the osculating
//!   sphere explains (a cast shadow), the CDRF term is attenuated. The edge is not sharp: light
//!   diffuses under it, so the test is averaged over a Gaussian footprint whose width is the
//!   material's [`Translucency::scattering_length_mm`];
//! - **transmission**: light that entered the first surface at the cosine μ to it and crossed
//!   `d` mm of material arrives as `E/π · T(d, μ) · g`, with the profile
//!   `T(d, μ) = A·μ^p·exp(−d/ℓ)` ([`TransmissionProfile`]; p = 1: the irradiance entering is
//!   `E·μ`); it replaces the CDRF where the point is in a cast shadow and adds
//!   `T(d, μ) − T(d_local, μ)` where the object is thinner than the osculating sphere (ears,
//!   fins, slabs lit from behind).
//!
//! Both terms are measured from the same sphere photographs as the table (cdrf-fit): the
//! scattering length is the width of the terminator (Kubo's σ, a length in mm), and T(d, μ) is
//! the shadow-side glow of the spheres against the chord each point's light crossed and the
//! cosine at which it entered. Values follow
//! the table's radiance convention, π·L/E.

use glam::Vec3;
use thiserror::Error;

/// Light through `thickness_mm` of material that entered it at the cosine μ to the surface:
/// `T(d, μ) = amplitude · μ^entry_cosine_power · exp(−d / length_mm)` per RGB channel, π·L/E
/// (radiance `L = E/π · T(d, μ) · g(θ, φ)`).
///
/// cdrf-fit writes `entry_cosine_power` = 1 (the irradiance entering the first surface is
/// `E·μ`; on the wax spheres this makes the glow one function of d across radii); tables of LUT
/// format version 2 carry T(d) alone, power 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransmissionProfile {
    /// T at d = 0 and μ = 1 per channel, π·L/E.
    pub amplitude: [f32; 3],
    /// Decay length ℓ per channel, mm.
    pub length_mm: [f32; 3],
    /// p in μ^p: 1 or 0 (T independent of the entry angle).
    pub entry_cosine_power: f32,
}

impl TransmissionProfile {
    /// A validated profile, `T(d, μ) = A·μ·exp(−d/ℓ)` (power 1).
    ///
    /// # Errors
    /// When an amplitude is negative or not finite, or a length is not finite and > 0.
    pub fn new(amplitude: [f32; 3], length_mm: [f32; 3]) -> Result<Self, TranslucencyError> {
        Self::with_entry_cosine_power(amplitude, length_mm, 1.0)
    }

    /// A validated profile `T(d, μ) = A·μ^p·exp(−d/ℓ)`.
    ///
    /// # Errors
    /// As [`Self::new`], and when p is not finite and ≥ 0.
    pub fn with_entry_cosine_power(
        amplitude: [f32; 3],
        length_mm: [f32; 3],
        entry_cosine_power: f32,
    ) -> Result<Self, TranslucencyError> {
        let profile = Self {
            amplitude,
            length_mm,
            entry_cosine_power,
        };
        profile.validate()?;
        Ok(profile)
    }

    /// T(d, μ) per channel, π·L/E. Negative thicknesses count as 0, μ is clamped to [0, 1].
    pub fn evaluate(&self, thickness_mm: f32, entry_cosine: f32) -> Vec3 {
        let d = thickness_mm.max(0.0);
        let entry = if self.entry_cosine_power == 0.0 {
            1.0
        } else {
            entry_cosine.clamp(0.0, 1.0).powf(self.entry_cosine_power)
        };
        Vec3::from_array(std::array::from_fn(|c| {
            self.amplitude[c] * entry * (-d / self.length_mm[c]).exp()
        }))
    }

    fn validate(&self) -> Result<(), TranslucencyError> {
        let p = self.entry_cosine_power;
        if !(p.is_finite() && p >= 0.0) {
            return Err(TranslucencyError::BadValue {
                what: "transmission entry cosine power",
                value: p,
            });
        }
        for c in 0..3 {
            let (a, l) = (self.amplitude[c], self.length_mm[c]);
            if !(a.is_finite() && a >= 0.0) {
                return Err(TranslucencyError::BadValue {
                    what: "transmission amplitude",
                    value: a,
                });
            }
            if !(l.is_finite() && l > 0.0) {
                return Err(TranslucencyError::BadValue {
                    what: "transmission length (mm)",
                    value: l,
                });
            }
        }
        Ok(())
    }
}

/// The non-local terms of a translucent material, stored with its measured table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Translucency {
    /// How far light spreads sideways under the surface, per RGB channel, mm: the standard
    /// deviation of the Gaussian footprint that softens a cast shadow's edge.
    pub scattering_length_mm: [f32; 3],
    /// Light through material.
    pub transmission: TransmissionProfile,
}

impl Translucency {
    /// Validated terms.
    ///
    /// # Errors
    /// When a length is not finite and > 0 or the profile is invalid.
    pub fn new(
        scattering_length_mm: [f32; 3],
        transmission: TransmissionProfile,
    ) -> Result<Self, TranslucencyError> {
        for value in scattering_length_mm {
            if !(value.is_finite() && value > 0.0) {
                return Err(TranslucencyError::BadValue {
                    what: "scattering length (mm)",
                    value,
                });
            }
        }
        transmission.validate()?;
        Ok(Self {
            scattering_length_mm,
            transmission,
        })
    }
}

/// The material light has crossed to reach a point of the osculating sphere (radius 1/κ) whose
/// normal makes the angle θ with the light, mm: `−2·cos θ / κ` on the shadow side, 0 on the lit
/// side. Flat or concave points (κ ≤ 0) facing away from the light lie under a half-space of
/// material: infinite.
pub fn local_chord_mm(curvature_per_mm: f32, cos_theta: f32) -> f32 {
    if cos_theta >= 0.0 {
        0.0
    } else if curvature_per_mm <= 0.0 {
        f32::INFINITY
    } else {
        -2.0 * cos_theta / curvature_per_mm
    }
}

/// The cosine between the light and the surface where the light enters the osculating sphere
/// (radius 1/κ) on its way to a point at the angle θ: the chord is symmetric, so `|cos θ|` on
/// the shadow side; 1 on the lit side (the point itself) and for flat or concave points.
pub fn local_entry_cosine(curvature_per_mm: f32, cos_theta: f32) -> f32 {
    if cos_theta >= 0.0 || curvature_per_mm <= 0.0 {
        1.0
    } else {
        -cos_theta.max(-1.0)
    }
}

/// The Gaussian weight per channel of each of `TAPS` penumbra taps around a point: tap k lies
/// at radius `r_k = 2·σ_max·√(k / TAPS)` on the surface (a Vogel spiral, equal area per tap)
/// and weighs `exp(−r_k² / (2σ²))` with each channel's scattering length σ; a renderer
/// averages the taps' visibility with these weights. With no scattering length (σ_max ≤ 0)
/// every tap weighs 1.
pub fn penumbra_tap_weights<const TAPS: usize>(scattering_length_mm: Vec3) -> [Vec3; TAPS] {
    let sigma_max = scattering_length_mm.max_element();
    std::array::from_fn(|k| {
        if sigma_max <= 0.0 {
            Vec3::ONE
        } else {
            let radius_squared = 4.0 * sigma_max * sigma_max * k as f32 / TAPS as f32;
            Vec3::from_array(
                scattering_length_mm
                    .to_array()
                    .map(|sigma| (-0.5 * radius_squared / (sigma * sigma).max(1e-12)).exp()),
            )
        }
    })
}

/// Why translucency terms are invalid.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum TranslucencyError {
    /// A value out of range.
    #[error("{what} is {value}: must be finite and positive")]
    BadValue {
        /// Which value.
        what: &'static str,
        /// The offending value.
        value: f32,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chord_of_the_osculating_sphere() {
        // Opposite the light on a 20 mm sphere: the whole diameter.
        assert!((local_chord_mm(1.0 / 20.0, -1.0) - 40.0).abs() < 1e-4);
        assert_eq!(local_chord_mm(1.0 / 20.0, 0.3), 0.0);
        assert_eq!(local_chord_mm(0.0, -0.5), f32::INFINITY);
        assert_eq!(local_chord_mm(-0.1, -0.5), f32::INFINITY);
    }

    #[test]
    fn profile_decays_by_e_per_length() {
        let t = TransmissionProfile::new([0.2, 0.1, 0.05], [10.0, 5.0, 2.0]).unwrap();
        let at_0 = t.evaluate(0.0, 1.0);
        let at_10 = t.evaluate(10.0, 1.0);
        assert!((at_0.x - 0.2).abs() < 1e-6);
        assert!((at_10.x / at_0.x - (-1.0f32).exp()).abs() < 1e-5);
        assert!((at_10.y / at_0.y - (-2.0f32).exp()).abs() < 1e-5);
        assert_eq!(t.evaluate(-3.0, 1.0), at_0);
    }

    #[test]
    fn profile_scales_with_the_entry_cosine_to_its_power() {
        let t = TransmissionProfile::new([0.2, 0.1, 0.05], [10.0, 5.0, 2.0]).unwrap();
        assert!((t.evaluate(4.0, 0.25).x - 0.25 * t.evaluate(4.0, 1.0).x).abs() < 1e-7);
        assert_eq!(t.evaluate(4.0, -0.5), Vec3::ZERO);
        let v2 = TransmissionProfile::with_entry_cosine_power([0.2; 3], [10.0; 3], 0.0).unwrap();
        assert_eq!(v2.evaluate(4.0, 0.0), v2.evaluate(4.0, 1.0));
        assert!(TransmissionProfile::with_entry_cosine_power([0.2; 3], [10.0; 3], -1.0).is_err());
    }

    #[test]
    fn entry_cosine_of_the_osculating_sphere() {
        assert_eq!(local_entry_cosine(1.0 / 20.0, -0.3), 0.3);
        assert_eq!(local_entry_cosine(1.0 / 20.0, 0.3), 1.0);
        assert_eq!(local_entry_cosine(0.0, -0.3), 1.0);
    }

    #[test]
    fn penumbra_taps_weigh_a_gaussian_of_each_channels_width() {
        const TAPS: usize = 64;
        let weights = penumbra_tap_weights::<TAPS>(Vec3::new(2.0, 1.0, 0.0));
        // The widest channel reaches 2σ at the last tap: exp(−2k / TAPS).
        for (k, w) in weights.iter().enumerate() {
            let widest = (-2.0 * k as f32 / TAPS as f32).exp();
            assert!((w.x - widest).abs() < 1e-6, "tap {k}: {w}");
            // Half the width: (2σ/σ)² = 4 times the exponent.
            assert!((w.y - widest.powi(4)).abs() < 1e-6, "tap {k}: {w}");
        }
        assert_eq!(weights[0], Vec3::new(1.0, 1.0, 1.0));
        // A zero width keeps only the centre.
        assert!(weights[1..].iter().all(|w| w.z == 0.0));
        // Normalised, a channel's weights sum to 1 and fall with radius.
        let total: f32 = weights.iter().map(|w| w.x).sum();
        let normalised: Vec<f32> = weights.iter().map(|w| w.x / total).collect();
        assert!((normalised.iter().sum::<f32>() - 1.0).abs() < 1e-5);
        assert!(normalised.windows(2).all(|pair| pair[1] < pair[0]));
        // No scattering length: every tap alike.
        assert!(
            penumbra_tap_weights::<TAPS>(Vec3::ZERO)
                .iter()
                .all(|w| *w == Vec3::ONE)
        );
    }

    #[test]
    fn rejects_bad_values() {
        assert!(TransmissionProfile::new([-0.1, 0.0, 0.0], [1.0; 3]).is_err());
        assert!(TransmissionProfile::new([0.1; 3], [1.0, 0.0, 1.0]).is_err());
        let t = TransmissionProfile::new([0.1; 3], [1.0; 3]).unwrap();
        assert!(Translucency::new([1.0, f32::NAN, 1.0], t).is_err());
        assert!(Translucency::new([1.0; 3], t).is_ok());
    }
}
