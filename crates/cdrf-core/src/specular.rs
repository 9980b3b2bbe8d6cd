//! The optional first-surface reflection of a translucent material: a rough dielectric boundary
//! (microfacet Beckmann distribution, Smith shadowing, exact dielectric Fresnel), and what that
//! boundary does to the subsurface light under it.
//!
//! cdrf-fit's photographs are cross-polarised (the data sets' boundary is index-matched), so a
//! measured table holds no specular reflection and no boundary. With the layer on, a renderer
//! shades
//!
//! ```text
//! L = E · f_spec(n, l, v) · cos θ  +  t · L_subsurface,
//! f_spec = F(v·h) · D(h) · G₁(l) · G₁(v) / (4 cos θ cos φ),
//! t = (1 − F̄)² · R_d(α', A(η)) / R_d(α', 1)        (per RGB channel)
//! ```
//!
//! with θ, φ the angles of the light and the camera to the normal and h the half vector. `D` is
//! Beckmann's distribution of roughness α, `G₁` Smith's shadowing for it in Walter et al.'s
//! (2007) rational form (within 0.35 % of the exact one; Mitsuba uses the same), `F` the
//! unpolarised Fresnel reflectance of a dielectric of relative index η. This is the BRDF of
//! Mitsuba's `roughdielectric` reflection lobe, the `knot-spec` reference.
//!
//! **How the subsurface term conserves energy** (`t`, [`SpecularLayer::subsurface_transmission`]):
//! light crosses the boundary twice, once in and once out, and each time the share `F̄` (the
//! cosine-weighted hemispherical average of F, [`mean_fresnel`]) is reflected instead — on a
//! sphere lit from one side exactly the light the specular lobe does not take, on average.
//! Inside, the boundary reflects part of the diffuse light back (Jensen et al. 2001's
//! `A = (1 + F_dr)/(1 − F_dr)`), which a material with an index-matched boundary never does:
//! the dipole's total diffuse reflectance `R_d(α', A)` over its index-matched value gives that
//! loss, with the reduced albedo α' inverted from the material's own index-matched `R_d` (the
//! measured table's flattest row integrated over θ: a CDRF keeps `∫ f dθ` along the great circle). The shares are constants per
//! channel, not functions of θ and φ: the light a point sends out entered over the surface
//! around it at every angle, which the path-traced wax knot inside this boundary confirms (its
//! subsurface light over the index-matched knot's is flat in θ, 0.73–0.78 on the lit side for
//! red, where `1 − F(cos θ)` would fall from 0.96 to 0.36).

use glam::Vec3;
use thiserror::Error;

use crate::gaussian::profile::{diffuse_fresnel_reflectance, dipole_total_reflectance};

/// Beckmann roughness α of the layer when a scene does not say (the `knot-spec` reference's).
pub const DEFAULT_ROUGHNESS_ALPHA: f32 = 0.3;
/// Relative index of refraction of the layer when a scene does not say (wax, skin: ~1.4–1.45).
pub const DEFAULT_IOR: f32 = 1.45;

/// The layer's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpecularLayer {
    roughness_alpha: f32,
    ior: f32,
}

/// A specular parameter out of range.
#[derive(Clone, Copy, Debug, Error, PartialEq)]
pub enum SpecularError {
    /// α must lie in [0.01, 1].
    #[error("specular_roughness = {0}: the Beckmann α must lie in [0.01, 1]")]
    Roughness(f32),
    /// η must lie in (1, 3].
    #[error("ior = {0}: the relative index of refraction must lie in (1, 3]")]
    Ior(f32),
}

impl Default for SpecularLayer {
    fn default() -> Self {
        Self {
            roughness_alpha: DEFAULT_ROUGHNESS_ALPHA,
            ior: DEFAULT_IOR,
        }
    }
}

impl SpecularLayer {
    /// A layer of Beckmann roughness `roughness_alpha` ∈ [0.01, 1] and relative index of
    /// refraction `ior` ∈ (1, 3].
    ///
    /// # Errors
    /// [`SpecularError`] naming the parameter out of range (or NaN).
    pub fn new(roughness_alpha: f32, ior: f32) -> Result<Self, SpecularError> {
        if !(0.01..=1.0).contains(&roughness_alpha) {
            return Err(SpecularError::Roughness(roughness_alpha));
        }
        if !(ior > 1.0 && ior <= 3.0) {
            return Err(SpecularError::Ior(ior));
        }
        Ok(Self {
            roughness_alpha,
            ior,
        })
    }

    /// Beckmann α.
    pub fn roughness_alpha(&self) -> f32 {
        self.roughness_alpha
    }

    /// Relative index of refraction η.
    pub fn ior(&self) -> f32 {
        self.ior
    }

    /// The reflected radiance per unit irradiance on a surface facing the light,
    /// `f_spec · cos θ` (sr⁻¹), for unit vectors: the normal, toward the light, toward the
    /// camera. Zero when either lies below the surface.
    pub fn radiance_per_irradiance(&self, normal: Vec3, to_light: Vec3, to_camera: Vec3) -> f32 {
        let cos_theta = normal.dot(to_light);
        let cos_phi = normal.dot(to_camera);
        if cos_theta <= 0.0 || cos_phi <= 0.0 {
            return 0.0;
        }
        let half = (to_light + to_camera).normalize_or_zero();
        let cos_half = normal.dot(half);
        if cos_half <= 0.0 {
            return 0.0;
        }
        let alpha = self.roughness_alpha;
        let d = beckmann_distribution(cos_half, alpha);
        let g = smith_g1(cos_theta, alpha) * smith_g1(cos_phi, alpha);
        let f = dielectric_fresnel(to_camera.dot(half), self.ior);
        f * d * g / (4.0 * cos_phi)
    }

    /// The share `t` of the subsurface light that the boundary lets through, per channel, for
    /// a material whose index-matched total diffuse reflectance is `matched_albedo` (see the
    /// module docs). In (0, 1).
    pub fn subsurface_transmission(&self, matched_albedo: [f32; 3]) -> [f32; 3] {
        let through = 1.0 - f64::from(mean_fresnel(self.ior));
        let a = internal_reflection_parameter(f64::from(self.ior));
        matched_albedo.map(|albedo| {
            let albedo = f64::from(albedo).clamp(1e-4, MAX_MATCHED_ALBEDO);
            let reduced_albedo = reduced_albedo_from_matched(albedo);
            let trapped = dipole_total_reflectance(reduced_albedo, a) / albedo;
            (through * through * trapped) as f32
        })
    }
}

/// The largest index-matched `R_d` a dipole reaches (α' → 1): `R_d(1, 1) = 1`; the inversion
/// clamps just below.
const MAX_MATCHED_ALBEDO: f64 = 0.9999;

/// Beckmann's microfacet distribution `D(h) = exp(−tan²θ_h/α²) / (π α² cos⁴θ_h)` for the
/// cosine of the half vector to the normal.
pub fn beckmann_distribution(cos_half: f32, alpha: f32) -> f32 {
    if cos_half <= 0.0 {
        return 0.0;
    }
    let c2 = cos_half * cos_half;
    let tan2 = (1.0 - c2).max(0.0) / c2;
    let a2 = alpha * alpha;
    (-tan2 / a2).exp() / (std::f32::consts::PI * a2 * c2 * c2)
}

/// Smith's shadowing–masking of one direction for Beckmann roughness α, in Walter et al.'s
/// (2007) rational approximation, from the direction's cosine to the normal.
pub fn smith_g1(cosine: f32, alpha: f32) -> f32 {
    if cosine <= 0.0 {
        return 0.0;
    }
    let tan = (1.0 - cosine * cosine).max(0.0).sqrt() / cosine;
    if tan == 0.0 {
        return 1.0;
    }
    let a = 1.0 / (alpha * tan);
    if a >= 1.6 {
        return 1.0;
    }
    (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)
}

/// The unpolarised Fresnel reflectance of light arriving from outside at cosine `cos_incident`
/// on a dielectric of relative index `eta` > 1.
pub fn dielectric_fresnel(cos_incident: f32, eta: f32) -> f32 {
    let c = cos_incident.clamp(0.0, 1.0);
    let sin2_transmitted = (1.0 - c * c) / (eta * eta);
    let ct = (1.0 - sin2_transmitted).max(0.0).sqrt();
    let rs = (c - eta * ct) / (c + eta * ct);
    let rp = (eta * c - ct) / (eta * c + ct);
    0.5 * (rs * rs + rp * rp)
}

/// `F̄ = 2 ∫₀¹ F(μ) μ dμ`: the share of diffuse (cosine-distributed) light from outside that a
/// smooth dielectric boundary reflects (η = 1.45: 0.084).
pub fn mean_fresnel(eta: f32) -> f32 {
    // Gauss–Legendre would do with fewer; the integrand has a kink-free but steep rise at
    // grazing incidence, and 2048 midpoints put the error below 1e-6.
    const STEPS: usize = 2048;
    let sum: f64 = (0..STEPS)
        .map(|i| {
            let mu = (i as f64 + 0.5) / STEPS as f64;
            f64::from(dielectric_fresnel(mu as f32, eta)) * mu
        })
        .sum();
    (2.0 * sum / STEPS as f64) as f32
}

/// Jensen et al.'s (2001) internal reflection parameter `A = (1 + F_dr)/(1 − F_dr)` (the
/// dipole profile's own).
fn internal_reflection_parameter(eta: f64) -> f64 {
    let f_dr = diffuse_fresnel_reflectance(eta);
    (1.0 + f_dr) / (1.0 - f_dr)
}

/// The reduced albedo α' whose index-matched (`A = 1`) dipole reflects `matched_albedo` in
/// total: `R_d(α', 1)` grows monotonically from 0 to 1, so bisection.
fn reduced_albedo_from_matched(matched_albedo: f64) -> f64 {
    let (mut low, mut high) = (0.0_f64, 1.0_f64);
    for _ in 0..60 {
        let mid = 0.5 * (low + high);
        if dipole_total_reflectance(mid, 1.0) < matched_albedo {
            low = mid;
        } else {
            high = mid;
        }
    }
    0.5 * (low + high)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit(theta_deg: f32, azimuth_deg: f32) -> Vec3 {
        let (t, p) = (theta_deg.to_radians(), azimuth_deg.to_radians());
        Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
    }

    #[test]
    fn fresnel_has_its_closed_form_values() {
        // Normal incidence: ((η − 1)/(η + 1))²; grazing: 1; Brewster's angle: rp = 0.
        let eta = 1.45_f32;
        let normal = ((eta - 1.0) / (eta + 1.0)).powi(2);
        assert!((dielectric_fresnel(1.0, eta) - normal).abs() < 1e-6);
        assert!((dielectric_fresnel(0.0, eta) - 1.0).abs() < 1e-6);
        let brewster = eta.atan().cos();
        let sin2t = (1.0 - brewster * brewster) / (eta * eta);
        let ct = (1.0 - sin2t).sqrt();
        let rs = (brewster - eta * ct) / (brewster + eta * ct);
        assert!((dielectric_fresnel(brewster, eta) - 0.5 * rs * rs).abs() < 1e-6);
        // F̄ lies between normal incidence and grazing, and grows with η.
        let mean = mean_fresnel(eta);
        assert!(mean > normal && mean < 0.2, "{mean}");
        assert!(mean_fresnel(1.6) > mean);
    }

    #[test]
    fn beckmann_distribution_projects_to_unit_area() {
        // ∫ D(h) cos θ_h dω = 1 for every α.
        for alpha in [0.05_f32, 0.3, 0.8] {
            let steps = 4000;
            let mut sum = 0.0_f64;
            for i in 0..steps {
                let t = (i as f64 + 0.5) / steps as f64 * std::f64::consts::FRAC_PI_2;
                let d = beckmann_distribution(t.cos() as f32, alpha);
                sum += f64::from(d) * t.cos() * t.sin();
            }
            let area = sum * std::f64::consts::TAU * std::f64::consts::FRAC_PI_2 / steps as f64;
            assert!((area - 1.0).abs() < 2e-3, "α {alpha}: {area}");
        }
    }

    #[test]
    fn the_lobe_is_reciprocal_and_loses_energy_only_to_fresnel_and_shadowing() {
        let layer = SpecularLayer::default();
        let n = Vec3::Z;
        for (a, b) in [((30.0, 0.0), (50.0, 170.0)), ((10.0, 40.0), (75.0, 200.0))] {
            let (l, v) = (unit(a.0, a.1), unit(b.0, b.1));
            // f_spec = value / cos θ is symmetric in l and v.
            let f_lv = layer.radiance_per_irradiance(n, l, v) / n.dot(l);
            let f_vl = layer.radiance_per_irradiance(n, v, l) / n.dot(v);
            assert!(
                (f_lv - f_vl).abs() <= 1e-5 * f_lv.abs().max(1e-6),
                "{f_lv} {f_vl}"
            );
        }
        // Directional albedo at 30°, ∫ f_spec cos φ dω_v: about the Fresnel reflectance, less
        // what shadowing takes, more where off-specular half vectors raise F.
        let l = unit(30.0, 0.0);
        let (steps_t, steps_p) = (600, 240);
        let mut albedo = 0.0_f64;
        for i in 0..steps_t {
            let t = (i as f32 + 0.5) / steps_t as f32 * 90.0;
            for j in 0..steps_p {
                let p = (j as f32 + 0.5) / steps_p as f32 * 360.0;
                let v = unit(t, p);
                let f = layer.radiance_per_irradiance(n, l, v) / n.dot(l);
                albedo += f64::from(f * n.dot(v)) * f64::from(t.to_radians().sin());
            }
        }
        albedo *= (std::f64::consts::FRAC_PI_2 / steps_t as f64)
            * (std::f64::consts::TAU / steps_p as f64);
        let f30 = f64::from(dielectric_fresnel(30f32.to_radians().cos(), 1.45));
        assert!(
            albedo < 1.1 * f30 && albedo > 0.85 * f30,
            "{albedo} vs F {f30}"
        );
        // Below the surface: nothing.
        assert_eq!(
            layer.radiance_per_irradiance(n, unit(95.0, 0.0), Vec3::Z),
            0.0
        );
        assert_eq!(
            layer.radiance_per_irradiance(n, Vec3::Z, unit(91.0, 0.0)),
            0.0
        );
    }

    #[test]
    fn subsurface_transmission_is_the_dipole_boundary_loss() {
        let layer = SpecularLayer::default();
        // The inversion round-trips.
        for albedo in [0.1, 0.5, 0.85, 0.99] {
            let reduced = reduced_albedo_from_matched(albedo);
            assert!((dipole_total_reflectance(reduced, 1.0) - albedo).abs() < 1e-9);
        }
        // The wax data set: α' = (0.997, 0.993, 0.985), index-matched R_d from the dipole.
        let reduced = [0.997, 0.993, 0.985_f64];
        let matched = reduced.map(|a| dipole_total_reflectance(a, 1.0) as f32);
        let t = layer.subsurface_transmission(matched);
        let through = (1.0 - mean_fresnel(1.45)).powi(2);
        let a = internal_reflection_parameter(1.45);
        for c in 0..3 {
            let expected =
                through * (dipole_total_reflectance(reduced[c], a) / f64::from(matched[c])) as f32;
            assert!(
                (t[c] - expected).abs() < 1e-4,
                "{c}: {} vs {expected}",
                t[c]
            );
            assert!(t[c] > 0.0 && t[c] < through);
        }
        // More absorbing channels lose more to the trapped light: blue < red.
        assert!(t[2] < t[0]);
    }

    #[test]
    fn parameters_out_of_range_are_errors() {
        assert!(SpecularLayer::new(0.3, 1.45).is_ok());
        assert_eq!(
            SpecularLayer::new(0.0, 1.45),
            Err(SpecularError::Roughness(0.0))
        );
        assert!(SpecularLayer::new(f32::NAN, 1.45).is_err());
        assert_eq!(SpecularLayer::new(0.3, 1.0), Err(SpecularError::Ior(1.0)));
        assert!(SpecularLayer::new(0.3, f32::INFINITY).is_err());
    }
}
