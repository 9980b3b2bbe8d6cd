//! Radial diffusion profiles `R(d)` for ring pre-integration.

use std::f64::consts::{FRAC_1_PI, TAU};

use super::{ParameterError, Range, check, check_rgb};

/// A radial diffusion profile `R(d)`: the light leaving a flat, semi-infinite slab at distance
/// `d` from where a unit of light entered, per RGB channel.
///
/// This is a trait, not an enum, because profiles are an open set (measured tables, quantized
/// diffusion, photon beam diffusion, Burley's normalized diffusion, …) and
/// [`PreintegratedCdrf`](super::PreintegratedCdrf) needs nothing from them but values and two
/// length hints; it is generic over the profile, so the hot loop is monomorphised.
/// The trait is object safe (`PreintegratedCdrf<Box<dyn RadialProfile + Send + Sync>>` works
/// through the `Box` impl).
///
/// Pre-integration divides by the ring integral of `R`, so the overall scale of `R` per channel
/// does not matter; it must be finite, ≥ 0 and positive near `d = 0`.
pub trait RadialProfile {
    /// `R(d)` per RGB channel at `distance_mm ≥ 0`, any consistent scale per channel.
    fn radial_reflectance(&self, distance_mm: f64) -> [f64; 3];

    /// The shortest distance over which `R` changes appreciably (e.g. the smallest standard
    /// deviation of a sum of Gaussians), in mm, > 0. Quadrature panels start at this width and
    /// double from there, so a value much too large loses accuracy and one much too small costs a
    /// few extra panels.
    fn feature_length_mm(&self) -> f64;

    /// A distance beyond which `R` is negligible (relative contribution below ~1e-10), in mm;
    /// `f64::INFINITY` when there is none.
    fn support_radius_mm(&self) -> f64;
}

impl<P: RadialProfile + ?Sized> RadialProfile for Box<P> {
    fn radial_reflectance(&self, distance_mm: f64) -> [f64; 3] {
        (**self).radial_reflectance(distance_mm)
    }
    fn feature_length_mm(&self) -> f64 {
        (**self).feature_length_mm()
    }
    fn support_radius_mm(&self) -> f64 {
        (**self).support_radius_mm()
    }
}

/// A Gaussian is negligible (`exp(−d²/2v) < 10⁻¹⁴`) beyond this many standard deviations.
const GAUSSIAN_SUPPORT_SIGMAS: f64 = 8.0;

/// A normalised 2D Gaussian per RGB channel, `R(d) = exp(−d²/2v) / (2πv)`.
///
/// Its ring weight is a von Mises kernel of concentration `r²/v`; it is the profile that matches
/// [`GaussianCdrf`](super::GaussianCdrf) with `sigma_mm = √v`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaussianProfile {
    variance_mm2: [f32; 3],
}

impl GaussianProfile {
    /// A Gaussian with variance `variance_mm2` (mm²) per RGB channel.
    ///
    /// # Errors
    /// [`ParameterError`] when a variance is zero, negative, NaN or infinite.
    pub fn new(variance_mm2: [f32; 3]) -> Result<Self, ParameterError> {
        check_rgb(variance_mm2, Range::Positive, "mm²", "variance_mm2")?;
        Ok(Self { variance_mm2 })
    }

    /// The variance per RGB channel, in mm².
    pub fn variance_mm2(&self) -> [f32; 3] {
        self.variance_mm2
    }
}

impl RadialProfile for GaussianProfile {
    fn radial_reflectance(&self, distance_mm: f64) -> [f64; 3] {
        let d2 = distance_mm * distance_mm;
        self.variance_mm2.map(|v| {
            let v = f64::from(v);
            (-0.5 * d2 / v).exp() / (TAU * v)
        })
    }

    fn feature_length_mm(&self) -> f64 {
        let v_min = self.variance_mm2.into_iter().fold(f32::INFINITY, f32::min);
        f64::from(v_min).sqrt()
    }

    fn support_radius_mm(&self) -> f64 {
        let v_max = self.variance_mm2.into_iter().fold(0.0, f32::max);
        GAUSSIAN_SUPPORT_SIGMAS * f64::from(v_max).sqrt()
    }
}

/// One term of a [`SumOfGaussiansProfile`]: `weights · exp(−d²/2v) / (2πv)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaussianTerm {
    /// The variance v, shared by the three channels, in mm² (> 0).
    pub variance_mm2: f32,
    /// The weight per RGB channel (≥ 0).
    pub weights: [f32; 3],
}

/// A weighted sum of normalised 2D Gaussians, `R(d) = Σᵢ wᵢ · exp(−d²/2vᵢ) / (2πvᵢ)`, with
/// variances shared by the channels and weights per channel (d'Eon et al. 2007).
///
/// When the weights of a channel sum to 1 the profile integrates to 1 over the plane in that
/// channel.
#[derive(Clone, Debug, PartialEq)]
pub struct SumOfGaussiansProfile {
    terms: Vec<GaussianTerm>,
    /// Per term: `−1/2v` and `wᵢ/(2πv)` per channel, precomputed for the quadrature loop.
    coefficients: Vec<(f64, [f64; 3])>,
}

impl SumOfGaussiansProfile {
    /// A profile from its terms.
    ///
    /// # Errors
    /// [`ParameterError`] when a variance is not finite and > 0, a weight is not finite and
    /// ≥ 0, or the weights of a channel sum to 0 (including an empty list).
    pub fn new(terms: Vec<GaussianTerm>) -> Result<Self, ParameterError> {
        for (i, term) in terms.iter().enumerate() {
            check(term.variance_mm2, Range::Positive, "mm²", || {
                format!("terms[{i}].variance_mm2")
            })?;
            check_rgb(
                term.weights,
                Range::NonNegative,
                "",
                &format!("terms[{i}].weights"),
            )?;
        }
        for channel in 0..3 {
            if terms.iter().all(|term| term.weights[channel] == 0.0) {
                return Err(ParameterError::ZeroTotalWeight { channel });
            }
        }
        let coefficients = terms
            .iter()
            .map(|term| {
                let v = f64::from(term.variance_mm2);
                (-0.5 / v, term.weights.map(|w| f64::from(w) / (TAU * v)))
            })
            .collect();
        Ok(Self {
            terms,
            coefficients,
        })
    }

    /// The six-Gaussian fit of measured skin by d'Eon & Luebke (GPU Gems 3, ch. 14, after
    /// d'Eon, Luebke & Enderton 2007): variances 0.0064, 0.0484, 0.187, 0.567, 1.99 and
    /// 7.41 mm². The weights of each channel sum to 1.
    pub fn skin() -> Self {
        const SKIN: [(f32, [f32; 3]); 6] = [
            (0.0064, [0.233, 0.455, 0.649]),
            (0.0484, [0.100, 0.336, 0.344]),
            (0.187, [0.118, 0.198, 0.0]),
            (0.567, [0.113, 0.007, 0.007]),
            (1.99, [0.358, 0.004, 0.0]),
            (7.41, [0.078, 0.0, 0.0]),
        ];
        let terms = SKIN
            .iter()
            .map(|&(variance_mm2, weights)| GaussianTerm {
                variance_mm2,
                weights,
            })
            .collect();
        Self::new(terms).expect("the skin preset is valid")
    }

    /// The terms, as given.
    pub fn terms(&self) -> &[GaussianTerm] {
        &self.terms
    }

    /// The sum of the weights per RGB channel (the integral of `R` over the plane).
    pub fn total_weights(&self) -> [f32; 3] {
        std::array::from_fn(|c| self.terms.iter().map(|term| term.weights[c]).sum())
    }
}

impl RadialProfile for SumOfGaussiansProfile {
    fn radial_reflectance(&self, distance_mm: f64) -> [f64; 3] {
        let d2 = distance_mm * distance_mm;
        let mut sum = [0.0; 3];
        for &(minus_half_inverse_variance, weights) in &self.coefficients {
            let g = (minus_half_inverse_variance * d2).exp();
            for (s, w) in sum.iter_mut().zip(weights) {
                *s += w * g;
            }
        }
        sum
    }

    fn feature_length_mm(&self) -> f64 {
        let v_min = self
            .terms
            .iter()
            .map(|t| t.variance_mm2)
            .fold(f32::INFINITY, f32::min);
        f64::from(v_min).sqrt()
    }

    fn support_radius_mm(&self) -> f64 {
        let v_max = self
            .terms
            .iter()
            .map(|t| t.variance_mm2)
            .fold(0.0, f32::max);
        GAUSSIAN_SUPPORT_SIGMAS * f64::from(v_max).sqrt()
    }
}

/// Egan's fit of the diffuse Fresnel reflectance of a boundary of relative index η,
/// `F_dr = −1.440/η² + 0.710/η + 0.668 + 0.0636 η` (Jensen et al. 2001).
pub(crate) fn diffuse_fresnel_reflectance(eta: f64) -> f64 {
    -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta
}

/// The dipole's total diffuse reflectance from the reduced albedo α' and the internal
/// reflection parameter `A = (1 + F_dr)/(1 − F_dr)`:
/// `R_d = α'/2 · (1 + e^(−4/3·A·√(3(1 − α')))) · e^(−√(3(1 − α')))`
/// ([`DipoleProfile::total_diffuse_reflectance`] per channel).
pub(crate) fn dipole_total_reflectance(reduced_albedo: f64, a: f64) -> f64 {
    let s = (3.0 * (1.0 - reduced_albedo)).max(0.0).sqrt();
    0.5 * reduced_albedo * (1.0 + (-4.0 / 3.0 * a * s).exp()) * (-s).exp()
}

/// The dipole is negligible (`e^(−σ_tr·d) < 10⁻¹³`) beyond this many `1/σ_tr`.
const DIPOLE_SUPPORT_LENGTHS: f64 = 30.0;

/// The classic dipole diffusion profile of Jensen et al. (2001), per RGB channel:
///
/// ```text
/// R_d(d) = α'/4π · [ z_r (σ_tr d_r + 1) e^(−σ_tr d_r) / d_r³
///                  + z_v (σ_tr d_v + 1) e^(−σ_tr d_v) / d_v³ ]
/// σ_t' = σ_a + σ_s',  α' = σ_s'/σ_t',  σ_tr = √(3 σ_a σ_t'),  D = 1/(3σ_t'),
/// z_r = 1/σ_t',  z_v = z_r + 4AD,  A = (1 + F_dr)/(1 − F_dr),
/// F_dr = −1.440/η² + 0.710/η + 0.668 + 0.0636 η,  d_r = √(d² + z_r²),  d_v = √(d² + z_v²).
/// ```
///
/// Positive and strictly decreasing in `d`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DipoleProfile {
    sigma_a_per_mm: [f32; 3],
    sigma_s_prime_per_mm: [f32; 3],
    eta: f32,
    channels: [DipoleChannel; 3],
}

/// Derived per-channel constants of a [`DipoleProfile`].
#[derive(Clone, Copy, Debug, PartialEq)]
struct DipoleChannel {
    /// α'/4π.
    prefactor: f64,
    /// σ_tr in mm⁻¹.
    sigma_tr: f64,
    /// Depth of the real source, mm.
    z_r: f64,
    /// Height of the virtual source, mm.
    z_v: f64,
}

impl DipoleProfile {
    /// A dipole from the absorption coefficient `sigma_a_per_mm` (≥ 0), the reduced scattering
    /// coefficient `sigma_s_prime_per_mm` (> 0), both mm⁻¹ per RGB channel, and the relative
    /// index of refraction `eta` (medium over outside).
    ///
    /// # Errors
    /// [`ParameterError`] when a coefficient is out of range, NaN or infinite, or η is not
    /// finite and positive or gives `F_dr ∉ (−1, 1)` (η below about 0.75).
    pub fn new(
        sigma_a_per_mm: [f32; 3],
        sigma_s_prime_per_mm: [f32; 3],
        eta: f32,
    ) -> Result<Self, ParameterError> {
        check_rgb(sigma_a_per_mm, Range::NonNegative, "mm⁻¹", "sigma_a_per_mm")?;
        check_rgb(
            sigma_s_prime_per_mm,
            Range::Positive,
            "mm⁻¹",
            "sigma_s_prime_per_mm",
        )?;
        check(eta, Range::Positive, "", || "eta".to_owned())?;
        let f_dr = diffuse_fresnel_reflectance(f64::from(eta));
        if !(f_dr > -1.0 && f_dr < 1.0) {
            return Err(ParameterError::EtaOutOfRange { eta, f_dr });
        }
        let a = (1.0 + f_dr) / (1.0 - f_dr);
        let channels = std::array::from_fn(|c| {
            let sigma_a = f64::from(sigma_a_per_mm[c]);
            let sigma_s_prime = f64::from(sigma_s_prime_per_mm[c]);
            let sigma_t_prime = sigma_a + sigma_s_prime;
            let diffusion = 1.0 / (3.0 * sigma_t_prime);
            let z_r = 1.0 / sigma_t_prime;
            DipoleChannel {
                prefactor: sigma_s_prime / sigma_t_prime * 0.25 * FRAC_1_PI,
                sigma_tr: (3.0 * sigma_a * sigma_t_prime).sqrt(),
                z_r,
                z_v: z_r + 4.0 * a * diffusion,
            }
        });
        Ok(Self {
            sigma_a_per_mm,
            sigma_s_prime_per_mm,
            eta,
            channels,
        })
    }

    /// Jensen et al. (2001), table 2, "Skin1": σ_s' = (0.74, 0.88, 1.01) mm⁻¹,
    /// σ_a = (0.032, 0.17, 0.48) mm⁻¹, η = 1.3.
    pub fn skin1() -> Self {
        Self::new([0.032, 0.17, 0.48], [0.74, 0.88, 1.01], 1.3).expect("the preset is valid")
    }

    /// Jensen et al. (2001), table 2, "Marble": σ_s' = (2.19, 2.62, 3.00) mm⁻¹,
    /// σ_a = (0.0021, 0.0041, 0.0071) mm⁻¹, η = 1.3.
    pub fn marble() -> Self {
        Self::new([0.0021, 0.0041, 0.0071], [2.19, 2.62, 3.00], 1.3).expect("the preset is valid")
    }

    /// The absorption coefficient σ_a per RGB channel, in mm⁻¹.
    pub fn sigma_a_per_mm(&self) -> [f32; 3] {
        self.sigma_a_per_mm
    }

    /// The reduced scattering coefficient σ_s' per RGB channel, in mm⁻¹.
    pub fn sigma_s_prime_per_mm(&self) -> [f32; 3] {
        self.sigma_s_prime_per_mm
    }

    /// The relative index of refraction η.
    pub fn eta(&self) -> f32 {
        self.eta
    }

    /// The total diffuse reflectance per RGB channel: the profile integrated over the plane,
    /// `R_d = ∫₀^∞ R_d(d) 2πd dd`, in closed form (Jensen et al. 2001, eq. 8 integrated):
    ///
    /// ```text
    /// R_d = α'/2 · (e^(−σ_tr z_r) + e^(−σ_tr z_v))
    ///     = α'/2 · (1 + e^(−(4/3)·A·√(3(1 − α')))) · e^(−√(3(1 − α'))).
    /// ```
    ///
    /// This is the albedo of a flat, semi-infinite slab of the medium under the dipole model:
    /// the fraction of the light entering it that leaves it again, in (0, 1).
    /// [`PreintegratedCdrf`](super::PreintegratedCdrf) divides the overall scale out, so a
    /// table of the medium's reflectance multiplies by this.
    ///
    /// ```
    /// use cdrf_core::gaussian::DipoleProfile;
    ///
    /// let r_d = DipoleProfile::skin1().total_diffuse_reflectance();
    /// assert!(r_d[0] > r_d[1] && r_d[1] > r_d[2]); // skin is red
    /// ```
    pub fn total_diffuse_reflectance(&self) -> [f64; 3] {
        self.channels.map(|ch| {
            // prefactor = α'/4π; each pole integrates to 2π·e^(−σ_tr z).
            ch.prefactor * TAU * ((-ch.sigma_tr * ch.z_r).exp() + (-ch.sigma_tr * ch.z_v).exp())
        })
    }
}

impl RadialProfile for DipoleProfile {
    fn radial_reflectance(&self, distance_mm: f64) -> [f64; 3] {
        let d2 = distance_mm * distance_mm;
        self.channels.map(|ch| {
            let pole = |z: f64| {
                let dist = (d2 + z * z).sqrt();
                z * (ch.sigma_tr * dist + 1.0) * (-ch.sigma_tr * dist).exp() / (dist * dist * dist)
            };
            ch.prefactor * (pole(ch.z_r) + pole(ch.z_v))
        })
    }

    fn feature_length_mm(&self) -> f64 {
        self.channels
            .iter()
            .map(|ch| ch.z_r)
            .fold(f64::INFINITY, f64::min)
    }

    fn support_radius_mm(&self) -> f64 {
        self.channels
            .iter()
            .map(|ch| ch.z_v + DIPOLE_SUPPORT_LENGTHS / ch.sigma_tr)
            .fold(0.0, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫₀^∞ R(d) 2πd dd by the substitution d = t/(1 − t) and a fine midpoint rule.
    fn integrate_over_plane(profile: &impl RadialProfile, channel: usize) -> f64 {
        let n = 400_000;
        (0..n)
            .map(|i| {
                let t = (i as f64 + 0.5) / n as f64;
                let d = t / (1.0 - t);
                let jacobian = 1.0 / ((1.0 - t) * (1.0 - t));
                profile.radial_reflectance(d)[channel] * TAU * d * jacobian / n as f64
            })
            .sum()
    }

    #[test]
    fn dipole_total_diffuse_reflectance_is_the_profile_integral_and_jensens_formula() {
        for (sigma_a, sigma_s_prime, eta) in [
            ([0.032, 0.17, 0.48], [0.74, 0.88, 1.01], 1.3),
            ([0.0021, 0.0041, 0.0071], [2.19, 2.62, 3.00], 1.3),
            ([0.003, 0.007, 0.015], [0.997, 0.993, 0.985], 1.0),
        ] {
            let dipole = DipoleProfile::new(sigma_a, sigma_s_prime, eta).unwrap();
            let r_d = dipole.total_diffuse_reflectance();
            let n = f64::from(eta);
            let f_dr = -1.440 / (n * n) + 0.710 / n + 0.668 + 0.0636 * n;
            let a = (1.0 + f_dr) / (1.0 - f_dr);
            for c in 0..3 {
                let alpha = f64::from(sigma_s_prime[c]) / f64::from(sigma_s_prime[c] + sigma_a[c]);
                let root = (3.0 * (1.0 - alpha)).sqrt();
                let jensen = 0.5 * alpha * (1.0 + (-4.0 / 3.0 * a * root).exp()) * (-root).exp();
                let integral = integrate_over_plane(&dipole, c);
                println!(
                    "channel {c}: R_d {} Jensen {jensen} integral {integral}",
                    r_d[c]
                );
                assert!(
                    (r_d[c] - jensen).abs() < 1e-4 * jensen,
                    "{} vs {jensen}",
                    r_d[c]
                );
                assert!(
                    (r_d[c] - integral).abs() < 2e-3 * integral,
                    "{} vs {integral}",
                    r_d[c]
                );
                assert!(r_d[c] > 0.0 && r_d[c] < 1.0);
            }
        }
    }
}
