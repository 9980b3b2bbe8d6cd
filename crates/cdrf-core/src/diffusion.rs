//! The diffusion profile measured from the spheres: how far light travels under the surface.
//!
//! A radial diffusion profile `R(d)` (mm⁻²) says how much of a unit of light that entered the
//! surface at one point leaves it at distance `d`. To the diffusion approximation a lit object's
//! exitance at `p` is the light entering every lit point `q` weighted by `R(|p − q|)`, so its
//! radiance is, in the table's convention π·L/E (a white Lambertian surface is `cos⁺θ`),
//!
//! ```text
//! f(p) = ∫ h(μ_q) · R(|p − q|) dA_q,     h(μ) = max(μ, 0)^p,   μ_q = n_q · l,
//! ```
//!
//! over the lit surface. `h` is the light entering at `q`: `p = 1` is the irradiance `E·μ`;
//! a smaller power stands for Fresnel transmission and the shallower entry of grazing light.
//!
//! # The form: a sum of exponentials
//! `R(d) = Σₖ wₖ · exp(−d/ℓₖ) / (2π·ℓₖ·d)` per RGB channel, with lengths `ℓₖ` and weights
//! `wₖ ≥ 0`. Each term integrates to 1 over the plane, so `wₖ` is the share of the light that
//! leaves through that term and `Σₖ wₖ` the diffuse albedo. It is linear in the weights, so a
//! non-negative least-squares fit over a fixed set of lengths finds its global optimum, it is
//! positive by construction, and it holds the common analytic forms: Burley's normalized
//! diffusion is two terms (ℓ and 3ℓ), a dipole's far field one.
//!
//! # On a sphere
//! [`sphere_term_responses`] integrates each term over the lit part of a sphere of radius r
//! around the point at angle θ from the light (chord distances, the profile's own geometry): with
//! `d = 2r·sin(α/2)` for the point at arc angle α, `dA = d·dd·dβ` exactly, so
//!
//! ```text
//! f(θ; r) = Σₖ wₖ ∫₀^2r exp(−d/ℓₖ)/(2πℓₖ) · H(α(d), θ) dd,   H = ∫₀^2π h(cos θ cos α + sin θ sin α cos β) dβ.
//! ```
//!
//! `H` is integrated over the lit arc only (closed form for p = 1), `d` over 16-point
//! Gauss–Legendre panels that double from a quarter of the shortest length and split where the
//! lit arc starts, ends or closes. The rule is fixed, so the result is smooth in θ, r and p, as a
//! fitter needs; it agrees with a brute-force surface quadrature to ~1e-6 (tested).
//!
//! # Against the light's travel
//! Light entering a lit point moves on along the light's travel before it diffuses, so less of
//! it comes back to a point lying *upstream* of where it entered (nearer the light along the
//! light's direction) than the isotropic profile says. The far field a renderer gathers
//! ([`FarField`]) weighs each source by `1 − UPSTREAM_LOSS · max(−c, 0)`, c the cosine between
//! the light's travel and the direction from the source to the point (c > 0: the point lies
//! downstream). On a sphere's shadow side every lit point lies upstream of the point (c > 0),
//! and on a plane lit head-on every point is level with it (c = 0): neither changes; light
//! running back up a lit slope or a fold does. The profile itself, fitted to the spheres'
//! f, stays isotropic: the loss only moves light between the gathered far field and the
//! table's near field (`f − F_sphere`), so a sphere keeps its table. The near field's own
//! penumbra weighs its surface points the same way ([`NEAR_FIELD_UPSTREAM_LOSS`]): a shadow's
//! edge is sharper where the lit surface lies downstream of it.
//!
//! ```
//! use cdrf_core::diffusion::{DiffusionProfile, ProfileTerm};
//!
//! let profile = DiffusionProfile::new(
//!     vec![
//!         ProfileTerm { length_mm: 1.0, weight: [0.3, 0.4, 0.5] },
//!         ProfileTerm { length_mm: 8.0, weight: [0.6, 0.4, 0.2] },
//!     ],
//!     1.0,
//! )?;
//! // A large sphere facing the light is nearly flat: the albedo.
//! let f = profile.sphere_reflectance(1.0 / 2000.0, 0.0);
//! assert!((f[0] - 0.9).abs() < 0.01);
//! // Past the terminator of a small sphere, light still comes out, red most.
//! let f = profile.sphere_reflectance(1.0 / 15.0, 110f64.to_radians());
//! assert!(f[0] > f[2] && f[2] > 0.0);
//! # Ok::<(), cdrf_core::diffusion::DiffusionProfileError>(())
//! ```

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use thiserror::Error;

use crate::gaussian::quadrature::{GAUSS_LEGENDRE_16, for_each_node};

/// Most terms a profile may have (the LUT file stores one attribute pair per term).
pub const MAX_PROFILE_TERMS: usize = 16;

/// Largest entry cosine power accepted.
pub const MAX_ENTRY_COSINE_POWER: f32 = 4.0;

/// How much of a source's far field a point lying straight upstream of it loses (see
/// [Against the light's travel](self#against-the-lights-travel)): the weight is
/// `1 − UPSTREAM_LOSS · max(−c, 0)`. Fitted to the knot, the torus and the thick bodies
/// lit from the side and from behind (docs/research/thick-bodies.md, tenth pass).
pub const UPSTREAM_LOSS: f32 = 1.0;

/// The same loss for the near field a renderer keeps from the table (`f − F_sphere`, which
/// reaches about the cut ℓ_c): each surface point around a point counts
/// `1 − NEAR_FIELD_UPSTREAM_LOSS · max(−c, 0)` in the point's visibility, c as above (c < 0:
/// it lies downstream of the point). Larger than [`UPSTREAM_LOSS`]: the light's run along
/// the light before it diffuses (about a mean free path) is a larger share of the near
/// field's reach than of the far field's. The visibility weighs lit and shadowed points
/// alike, so where nothing is shadowed (a sphere) it stays 1. Fitted to the side-lit bodies'
/// cast shadows (docs/research/thick-bodies.md, fifteenth pass).
pub const NEAR_FIELD_UPSTREAM_LOSS: f32 = 2.0;

/// One term `w · exp(−d/ℓ) / (2π·ℓ·d)` of a [`DiffusionProfile`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProfileTerm {
    /// ℓ, mm.
    pub length_mm: f32,
    /// w per RGB channel: the share of entering light that leaves through this term.
    pub weight: [f32; 3],
}

/// A radial diffusion profile as a sum of exponentials, with the power of the entry cosine (see
/// the [module docs](self)).
#[derive(Clone, Debug, PartialEq)]
pub struct DiffusionProfile {
    terms: Vec<ProfileTerm>,
    entry_cosine_power: f32,
}

/// Why a diffusion profile is invalid.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum DiffusionProfileError {
    /// No terms, or more than [`MAX_PROFILE_TERMS`].
    #[error("a diffusion profile has {count} terms: must have 1 to {MAX_PROFILE_TERMS}")]
    TermCount {
        /// The count given.
        count: usize,
    },
    /// A length that is not finite and positive, or not longer than the one before it.
    #[error(
        "diffusion profile term {index}: length {length_mm} mm must be finite, positive and longer than the term before"
    )]
    Length {
        /// Which term (0-based).
        index: usize,
        /// The offending length, mm.
        length_mm: f32,
    },
    /// A weight that is negative or not finite.
    #[error("diffusion profile term {index}: weight {weight:?} must be finite and ≥ 0")]
    Weight {
        /// Which term (0-based).
        index: usize,
        /// The offending weights.
        weight: [f32; 3],
    },
    /// An entry cosine power outside [0, [`MAX_ENTRY_COSINE_POWER`]].
    #[error(
        "diffusion profile entry cosine power {power} must be finite, in [0, {MAX_ENTRY_COSINE_POWER}]"
    )]
    EntryCosinePower {
        /// The offending power.
        power: f32,
    },
}

impl DiffusionProfile {
    /// A profile from its terms (lengths strictly increasing) and entry cosine power.
    ///
    /// # Errors
    /// When a value is out of range (see [`DiffusionProfileError`]).
    pub fn new(
        terms: Vec<ProfileTerm>,
        entry_cosine_power: f32,
    ) -> Result<Self, DiffusionProfileError> {
        if terms.is_empty() || terms.len() > MAX_PROFILE_TERMS {
            return Err(DiffusionProfileError::TermCount { count: terms.len() });
        }
        let mut previous = 0.0;
        for (index, term) in terms.iter().enumerate() {
            if !(term.length_mm.is_finite() && term.length_mm > previous) {
                return Err(DiffusionProfileError::Length {
                    index,
                    length_mm: term.length_mm,
                });
            }
            previous = term.length_mm;
            if !term.weight.iter().all(|w| w.is_finite() && *w >= 0.0) {
                return Err(DiffusionProfileError::Weight {
                    index,
                    weight: term.weight,
                });
            }
        }
        if !(0.0..=MAX_ENTRY_COSINE_POWER).contains(&entry_cosine_power) {
            return Err(DiffusionProfileError::EntryCosinePower {
                power: entry_cosine_power,
            });
        }
        Ok(Self {
            terms,
            entry_cosine_power,
        })
    }

    /// The terms, shortest length first.
    pub fn terms(&self) -> &[ProfileTerm] {
        &self.terms
    }

    /// p of the entry factor `h(μ) = max(μ, 0)^p`.
    pub fn entry_cosine_power(&self) -> f32 {
        self.entry_cosine_power
    }

    /// The diffuse albedo per channel, `Σₖ wₖ`: what a flat surface lit head-on gives (π·L/E).
    pub fn albedo(&self) -> [f32; 3] {
        std::array::from_fn(|c| self.terms.iter().map(|t| t.weight[c]).sum())
    }

    /// The mean distance, mm, per channel, between where light enters and where it leaves:
    /// `Σₖ wₖ ℓₖ / Σₖ wₖ` (0 where every weight is 0). Over the plane each term
    /// `exp(−d/ℓ) / (2π·ℓ·d)` integrates to 1 and `d` weighted by it to `ℓ`
    /// (`∫₀^∞ d · exp(−d/ℓ)/ℓ dd = ℓ`), so its mean distance is ℓ. The scale at which the
    /// material sees its surface: a length to filter curvature over
    /// ([`crate::curvature::CurvatureOptions::filter_length_mm`]).
    pub fn mean_distance_mm(&self) -> [f32; 3] {
        std::array::from_fn(|c| {
            let (mut weighted, mut total) = (0.0f64, 0.0f64);
            for term in &self.terms {
                let w = f64::from(term.weight[c]);
                weighted += w * f64::from(term.length_mm);
                total += w;
            }
            if total > 0.0 {
                (weighted / total) as f32
            } else {
                0.0
            }
        })
    }

    /// How the near field (`R − R_far` of [`FarField`] with cut `cut_mm`, which the measured
    /// table keeps) spreads light around a point: the share per channel that lands in each of
    /// `taps` rings of a disc of radius `disc_mm` — ring k from `disc·√((k − ½)/taps)` to
    /// `disc·√((k + ½)/taps)` (ring 0 the central disc, half the others' area), the ring of a
    /// Vogel spiral's tap k — normalised to sum 1 over the rings. A term of length ℓ ≤ ℓ_c
    /// stays whole, `w·exp(−d/ℓ)/(2πℓd)`; a longer one keeps `w·(ℓ_c/ℓ)·exp(−d/ℓ_c)/(2πℓ_c·d)`;
    /// either puts `w'·(exp(−a/ℓ') − exp(−b/ℓ'))` between radii a and b. These are the weights
    /// of a penumbra that spreads as the table's own light does: a channel that diffuses a
    /// short way sees only the lit surface close to the point. A channel the profile gives no
    /// light (or a disc that is no length) gets a Gaussian of standard deviation `disc/2`.
    pub fn near_field_ring_shares(&self, cut_mm: f64, disc_mm: f64, taps: usize) -> Vec<[f32; 3]> {
        let rings = taps.max(1) as f64;
        let edge = |k: f64| disc_mm * (k.max(0.0) / rings).sqrt();
        let mut shares: Vec<[f64; 3]> = (0..taps)
            .map(|k| {
                let (a, b) = (edge(k as f64 - 0.5), edge(k as f64 + 0.5));
                let mut share = [0.0; 3];
                for term in &self.terms {
                    let length = f64::from(term.length_mm);
                    let (kept, scale) = if cut_mm > 0.0 && length > cut_mm {
                        (cut_mm, cut_mm / length)
                    } else {
                        (length, 1.0)
                    };
                    let ring = (-a / kept).exp() - (-b / kept).exp();
                    for (c, w) in share.iter_mut().zip(term.weight) {
                        *c += f64::from(w) * scale * ring;
                    }
                }
                share
            })
            .collect();
        for c in 0..3 {
            let total: f64 = shares.iter().map(|s| s[c]).sum();
            let usable = total.is_finite() && total > 0.0 && disc_mm.is_finite() && disc_mm > 0.0;
            for (k, share) in shares.iter_mut().enumerate() {
                share[c] = if usable {
                    share[c] / total
                } else {
                    (-2.0 * k as f64 / rings).exp()
                };
            }
        }
        shares.into_iter().map(|s| s.map(|v| v as f32)).collect()
    }

    /// `R(d)` per channel, mm⁻² (infinite at d = 0, as every term is).
    pub fn radial_reflectance_per_mm2(&self, distance_mm: f64) -> [f64; 3] {
        let d = distance_mm.max(0.0);
        let ring = self.ring_density_per_mm(d);
        std::array::from_fn(|c| ring[c] / (TAU * d))
    }

    /// `2π·d·R(d)` per channel, mm⁻¹: the share of the light that leaves on the ring at distance
    /// `d`, per mm of distance (finite everywhere; integrates to the albedo over d ≥ 0).
    pub fn ring_density_per_mm(&self, distance_mm: f64) -> [f64; 3] {
        let d = distance_mm.max(0.0);
        let mut out = [0.0; 3];
        for term in &self.terms {
            let ell = f64::from(term.length_mm);
            let e = (-d / ell).exp() / ell;
            for (o, w) in out.iter_mut().zip(term.weight) {
                *o += f64::from(w) * e;
            }
        }
        out
    }

    /// The profile alone on a sphere: `f(θ; r)` of the [module docs](self) per channel, π·L/E, at
    /// curvature κ = 1/r (mm⁻¹, > 0; κ ≤ 0 or NaN is treated as a sphere of 10⁶ mm) and light
    /// angle θ (radians, folded into [0, π]).
    pub fn sphere_reflectance(&self, curvature_per_mm: f64, theta_rad: f64) -> [f64; 3] {
        let lengths: Vec<f64> = self.terms.iter().map(|t| f64::from(t.length_mm)).collect();
        let mut responses = vec![0.0; lengths.len()];
        let radius_mm = if curvature_per_mm > 0.0 {
            curvature_per_mm.recip().min(1e6)
        } else {
            1e6
        };
        sphere_term_responses(
            &lengths,
            radius_mm,
            theta_rad,
            f64::from(self.entry_cosine_power),
            &mut responses,
        );
        std::array::from_fn(|c| {
            self.terms
                .iter()
                .zip(&responses)
                .map(|(t, r)| f64::from(t.weight[c]) * r)
                .sum()
        })
    }
}

/// The part of a [`DiffusionProfile`] that reaches beyond a cut length `ℓ_c`: what a renderer
/// gathers over a sampled lit surface while the measured table keeps the near field.
///
/// Every term longer than the cut keeps its far part, the term minus the same `1/d` shape with
/// length `ℓ_c`; terms no longer than the cut are dropped (the near field):
///
/// ```text
/// R_far(d) = Σ_{ℓₖ > ℓ_c} wₖ · (exp(−d/ℓₖ) − exp(−d/ℓ_c)) / (2π·ℓₖ·d)
/// ```
///
/// `R_far` is finite at d = 0 (`wₖ·(1/ℓ_c − 1/ℓₖ)/(2πℓₖ)`), rises over about `ℓ_c` and then
/// falls as the term itself, so a sum over surface samples a fraction of `ℓ_c` apart is smooth;
/// and it is a difference of terms of the profile's own form, so its integral over a sphere
/// ([`FarField::sphere_reflectance`]) is exact in the same quadrature. Its weight per channel
/// (the light it carries on a flat surface) is `Σ wₖ·(1 − ℓ_c/ℓₖ)`. On a sphere each source
/// is weighed by the [upstream loss](self#against-the-lights-travel) ([`UPSTREAM_LOSS`]), as
/// the renderer's gather weighs it.
///
/// ```
/// use cdrf_core::diffusion::{DiffusionProfile, FarField, ProfileTerm};
///
/// let profile = DiffusionProfile::new(
///     vec![
///         ProfileTerm { length_mm: 1.0, weight: [0.3, 0.4, 0.5] },
///         ProfileTerm { length_mm: 8.0, weight: [0.6, 0.4, 0.2] },
///     ],
///     1.0,
/// )?;
/// let far = FarField::new(&profile, 2.0);
/// // Only the 8 mm term reaches beyond 2 mm, with three quarters of its light.
/// let flat = far.sphere_reflectance(1e-6, 0.0, &mut Vec::new());
/// assert!((flat[0] - 0.6 * 0.75).abs() < 1e-3);
/// # Ok::<(), cdrf_core::diffusion::DiffusionProfileError>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct FarField {
    cut_mm: f64,
    /// The kept terms' lengths, then the cut (the lengths `sphere_responses` integrates).
    lengths_mm: Vec<f64>,
    /// The kept terms' weights.
    weights: Vec<[f64; 3]>,
    entry_cosine_power: f64,
}

impl FarField {
    /// The far field of `profile` beyond `cut_mm` (mm, > 0; a cut that is not finite and
    /// positive keeps nothing).
    pub fn new(profile: &DiffusionProfile, cut_mm: f64) -> Self {
        let valid = cut_mm.is_finite() && cut_mm > 0.0;
        let (mut lengths_mm, weights): (Vec<f64>, Vec<[f64; 3]>) = profile
            .terms()
            .iter()
            .filter(|t| valid && f64::from(t.length_mm) > cut_mm)
            .map(|t| (f64::from(t.length_mm), t.weight.map(f64::from)))
            .unzip();
        if !lengths_mm.is_empty() {
            lengths_mm.push(cut_mm);
        }
        Self {
            cut_mm,
            lengths_mm,
            weights,
            entry_cosine_power: f64::from(profile.entry_cosine_power()),
        }
    }

    /// The longest kept term with any weight, mm (0 when empty): R_far falls as exp(−d/ℓ) of
    /// it far out.
    pub fn longest_mm(&self) -> f64 {
        self.lengths_mm
            .iter()
            .zip(&self.weights)
            .filter(|(_, w)| w.iter().any(|w| *w > 0.0))
            .map(|(l, _)| *l)
            .fold(0.0, f64::max)
    }

    /// ℓ_c, mm.
    pub fn cut_mm(&self) -> f64 {
        self.cut_mm
    }

    /// Whether no term reaches beyond the cut (the far field is zero).
    pub fn is_empty(&self) -> bool {
        self.weights.is_empty()
    }

    /// p of the entry factor `h(μ) = max(μ, 0)^p` (the profile's).
    pub fn entry_cosine_power(&self) -> f64 {
        self.entry_cosine_power
    }

    /// `R_far(d)` per channel, mm⁻² (finite at d = 0).
    pub fn reflectance_per_mm2(&self, distance_mm: f64) -> [f64; 3] {
        let d = distance_mm.max(0.0);
        let cut = self.cut_mm;
        let mut out = [0.0; 3];
        for (&ell, weight) in self.lengths_mm.iter().zip(&self.weights) {
            // (exp(−d/ℓ) − exp(−d/ℓ_c)) / d, without cancellation near 0.
            let shape = if d > 1e-9 * cut {
                ((-d / ell).exp_m1() - (-d / cut).exp_m1()) / d
            } else {
                1.0 / cut - 1.0 / ell
            };
            for (o, w) in out.iter_mut().zip(weight) {
                *o += w * shape / (TAU * ell);
            }
        }
        out
    }

    /// The far field on a sphere, as [`DiffusionProfile::sphere_reflectance`] for the whole
    /// profile but with each source weighed by the upstream loss ([`UPSTREAM_LOSS`]): π·L/E
    /// per channel at curvature κ (mm⁻¹) and light angle θ (radians).
    /// `scratch` is reused between calls (a table of thousands of entries needs no allocation
    /// per entry).
    pub fn sphere_reflectance(
        &self,
        curvature_per_mm: f64,
        theta_rad: f64,
        scratch: &mut Vec<f64>,
    ) -> [f64; 3] {
        if self.is_empty() {
            return [0.0; 3];
        }
        let radius_mm = if curvature_per_mm > 0.0 {
            curvature_per_mm.recip().min(1e6)
        } else {
            1e6
        };
        scratch.clear();
        scratch.resize(self.lengths_mm.len(), 0.0);
        sphere_responses(
            &self.lengths_mm,
            radius_mm,
            theta_rad,
            self.entry_cosine_power,
            f64::from(UPSTREAM_LOSS),
            scratch,
        );
        let cut_response = scratch[self.weights.len()];
        let mut out = [0.0; 3];
        for ((&ell, weight), &response) in self.lengths_mm.iter().zip(&self.weights).zip(&**scratch)
        {
            let far = response - self.cut_mm / ell * cut_response;
            for (o, w) in out.iter_mut().zip(weight) {
                *o += w * far;
            }
        }
        out
    }
}

/// Each unit-weight term `exp(−d/ℓₖ)/(2π·ℓₖ·d)` of `lengths_mm` integrated over the lit part of
/// a sphere of radius `radius_mm` at the point θ = `theta_rad` from the light, with the entry
/// factor `max(μ, 0)^entry_cosine_power` (see the [module docs](self)): `out[k]` is term k's
/// π·L/E. What a fitter needs as its design matrix.
///
/// # Panics
/// When `out` and `lengths_mm` differ in length.
pub fn sphere_term_responses(
    lengths_mm: &[f64],
    radius_mm: f64,
    theta_rad: f64,
    entry_cosine_power: f64,
    out: &mut [f64],
) {
    sphere_responses(
        lengths_mm,
        radius_mm,
        theta_rad,
        entry_cosine_power,
        0.0,
        out,
    );
}

/// [`sphere_term_responses`] with each source weighed by `1 − upstream_loss · max(−c, 0)`
/// ([`UPSTREAM_LOSS`]; 0: isotropic).
fn sphere_responses(
    lengths_mm: &[f64],
    radius_mm: f64,
    theta_rad: f64,
    entry_cosine_power: f64,
    upstream_loss: f64,
    out: &mut [f64],
) {
    assert_eq!(lengths_mm.len(), out.len(), "one output per length");
    out.fill(0.0);
    let theta = crate::gaussian::fold_theta(theta_rad);
    let diameter_mm = 2.0 * radius_mm;
    let chord = |alpha: f64| diameter_mm * (0.5 * alpha.clamp(0.0, PI)).sin();
    // The lit part of the ring at arc angle α: α in (θ − π/2, θ + π/2).
    let d_start = chord(theta - FRAC_PI_2);
    let d_end = chord(theta + FRAC_PI_2);
    if d_end.partial_cmp(&d_start) != Some(std::cmp::Ordering::Greater) || lengths_mm.is_empty() {
        return;
    }
    let shortest = lengths_mm.iter().copied().fold(f64::INFINITY, f64::min);
    let mut edges: Vec<f64> = vec![d_start, d_end];
    // Geometric edges from both ends of the lit range where a short kernel varies fastest.
    for origin in [0.0, d_start] {
        let mut step = 0.25 * shortest;
        while origin + step < d_end {
            edges.push(origin + step);
            step *= 2.0;
        }
    }
    // Where the ring stops being fully lit.
    edges.push(chord(FRAC_PI_2 - theta));
    // No panel wider than r/4 (H changes over the sphere's own scale).
    let widest = 0.25 * radius_mm;
    edges.retain(|d| *d >= d_start && *d <= d_end);
    edges.sort_by(f64::total_cmp);
    edges.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * diameter_mm);
    let (cos_t, sin_t) = (theta.cos(), theta.sin());
    let power = entry_cosine_power;
    for pair in edges.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        let pieces = ((b - a) / widest).ceil().max(1.0);
        let width = (b - a) / pieces;
        for i in 0..pieces as usize {
            let lo = a + width * i as f64;
            for_each_node(&GAUSS_LEGENDRE_16, lo, lo + width, |d, w| {
                let alpha = 2.0 * (d / diameter_mm).min(1.0).asin();
                let mut lit = lit_arc_integral(cos_t * alpha.cos(), sin_t * alpha.sin(), power);
                if upstream_loss > 0.0 {
                    lit -= upstream_arc_loss(cos_t, sin_t, alpha, power, upstream_loss);
                }
                if lit <= 0.0 {
                    return;
                }
                for (o, &ell) in out.iter_mut().zip(lengths_mm) {
                    *o += w * lit * (-d / ell).exp() / (TAU * ell);
                }
            });
        }
    }
}

/// What the upstream loss takes from [`lit_arc_integral`] on the ring at arc angle α around the
/// point at θ (`cos_t`, `sin_t`): `∫₀^2π max(μ, 0)^p · min(loss · max(−c, 0), 1) dβ` with
/// `μ = cos θ cos α + sin θ sin α cos β` and `c = sin θ cos(α/2) cos β − cos θ sin(α/2)`, the
/// cosine between the light's travel and the chord from the ring's point to the point
/// (`(μ_q − μ_p)·r / d` with `d = 2r sin(α/2)`). c falls as β grows, so the loss lies on one
/// arc `(β_c, β₀)`, integrated by 16-point Gauss–Legendre after `β = β₀ − (β₀ − β_c)·u²`
/// (smooth where the lit arc ends).
fn upstream_arc_loss(cos_t: f64, sin_t: f64, alpha: f64, p: f64, loss: f64) -> f64 {
    let a = cos_t * alpha.cos();
    let b = (sin_t * alpha.sin()).max(0.0);
    let Some(beta0) = lit_arc_half_width(a, b) else {
        return 0.0;
    };
    let (half_sin, half_cos) = (0.5 * alpha).sin_cos();
    let slope = sin_t * half_cos;
    let offset = cos_t * half_sin;
    // c < 0 where slope · cos β < offset.
    let from = if offset >= slope {
        0.0
    } else if offset <= -slope {
        return 0.0;
    } else {
        (offset / slope).acos()
    };
    if from >= beta0 {
        return 0.0;
    }
    let span = beta0 - from;
    let mut sum = 0.0;
    for_each_node(&GAUSS_LEGENDRE_16, 0.0, 1.0, |u, w| {
        let beta = beta0 - span * u * u;
        let mu = (a + b * beta.cos()).max(0.0);
        let against = (offset - slope * beta.cos()).max(0.0);
        sum += w * mu.powf(p) * (loss * against).min(1.0) * 2.0 * span * u;
    });
    2.0 * sum
}

/// Half-width β₀ of the arc where `a + b·cos β > 0` (`b ≥ 0`): π when the whole ring is lit,
/// `None` when none of it is.
fn lit_arc_half_width(a: f64, b: f64) -> Option<f64> {
    if a + b <= 0.0 {
        None
    } else if a >= b {
        Some(PI)
    } else {
        Some((-a / b).clamp(-1.0, 1.0).acos())
    }
}

/// `∫₀^2π max(a + b·cos β, 0)^p dβ` for `b ≥ 0`: over the lit arc only, closed form for p = 1,
/// else 16-point Gauss–Legendre after `β = β₀(1 − u²)`, which makes the integrand smooth at the
/// arc's end `β₀` (where it vanishes like `(β₀ − β)^p`).
fn lit_arc_integral(a: f64, b: f64, p: f64) -> f64 {
    let b = b.max(0.0);
    let Some(beta0) = lit_arc_half_width(a, b) else {
        return 0.0;
    };
    if p == 1.0 {
        return 2.0 * (a * beta0 + b * beta0.sin());
    }
    let mut sum = 0.0;
    for_each_node(&GAUSS_LEGENDRE_16, 0.0, 1.0, |u, w| {
        let beta = beta0 * (1.0 - u * u);
        let mu = (a + b * beta.cos()).max(0.0);
        sum += w * mu.powf(p) * 2.0 * beta0 * u;
    });
    2.0 * sum
}

#[cfg(test)]
mod tests {
    use super::*;

    fn profile() -> DiffusionProfile {
        DiffusionProfile::new(
            vec![
                ProfileTerm {
                    length_mm: 0.5,
                    weight: [0.2, 0.3, 0.4],
                },
                ProfileTerm {
                    length_mm: 3.0,
                    weight: [0.3, 0.3, 0.2],
                },
                ProfileTerm {
                    length_mm: 12.0,
                    weight: [0.4, 0.2, 0.05],
                },
            ],
            0.8,
        )
        .unwrap()
    }

    /// One 2 mm term that gives green no light.
    fn dark_green_profile() -> DiffusionProfile {
        DiffusionProfile::new(
            vec![ProfileTerm {
                length_mm: 2.0,
                weight: [0.5, 0.0, 0.25],
            }],
            1.0,
        )
        .unwrap()
    }

    #[test]
    fn mean_distance_is_the_profiles_own() {
        // ∫ d·2πd·R(d) dd / ∫ 2πd·R(d) dd with the ring density, by a midpoint rule in
        // u = ln d (d from 1e-6 to 1000 mm: the tails beyond hold < 1e-30 of the light).
        let profile = profile();
        let (mut moment, mut total) = ([0.0f64; 3], [0.0f64; 3]);
        let (low, high, steps) = (1e-6f64.ln(), 1000f64.ln(), 200_000);
        let du = (high - low) / f64::from(steps);
        for i in 0..steps {
            let d = (low + (f64::from(i) + 0.5) * du).exp();
            let ring = profile.ring_density_per_mm(d);
            for c in 0..3 {
                total[c] += ring[c] * d * du;
                moment[c] += ring[c] * d * d * du;
            }
        }
        let mean = profile.mean_distance_mm();
        for c in 0..3 {
            let numeric = moment[c] / total[c];
            assert!(
                (f64::from(mean[c]) - numeric).abs() < 1e-5 * numeric,
                "channel {c}: {} vs numeric {numeric}",
                mean[c]
            );
            assert!((total[c] - f64::from(profile.albedo()[c])).abs() < 1e-6);
        }
        // Red reaches farthest in this profile; a channel with no light has no distance.
        assert!(mean[0] > mean[1] && mean[1] > mean[2], "{mean:?}");
        let dark = dark_green_profile();
        assert_eq!(dark.mean_distance_mm(), [2.0, 0.0, 2.0]);
    }

    #[test]
    fn near_field_ring_shares_are_the_near_fields_light_per_ring() {
        // The near field R − R_far integrated over each ring by a midpoint rule in u = ln d
        // (ring 0 from 1e-9 mm), normalised over the disc, against the closed form.
        let profile = profile();
        let (cut, disc, taps) = (1.0, 2.0, 64);
        let far = FarField::new(&profile, cut);
        let shares = profile.near_field_ring_shares(cut, disc, taps);
        assert_eq!(shares.len(), taps);
        let edge = |k: f64| disc * (k.max(0.0) / taps as f64).sqrt();
        let mut numeric = vec![[0.0f64; 3]; taps];
        for (k, ring) in numeric.iter_mut().enumerate() {
            let (a, b) = (edge(k as f64 - 0.5).max(1e-9), edge(k as f64 + 0.5));
            let steps = 4000;
            let du = (b.ln() - a.ln()) / f64::from(steps);
            for i in 0..steps {
                let d = (a.ln() + (f64::from(i) + 0.5) * du).exp();
                let (whole, outer) = (
                    profile.radial_reflectance_per_mm2(d),
                    far.reflectance_per_mm2(d),
                );
                for c in 0..3 {
                    ring[c] += (whole[c] - outer[c]) * TAU * d * d * du;
                }
            }
        }
        for c in 0..3 {
            let total: f64 = numeric.iter().map(|r| r[c]).sum();
            for (k, (share, ring)) in shares.iter().zip(&numeric).enumerate() {
                let expected = ring[c] / total;
                assert!(
                    (f64::from(share[c]) - expected).abs() < 1e-4 * expected.max(1e-3),
                    "channel {c}, ring {k}: {} vs numeric {expected}",
                    share[c]
                );
            }
            let sum: f32 = shares.iter().map(|s| s[c]).sum();
            assert!((sum - 1.0).abs() < 1e-5, "channel {c} sums to {sum}");
        }
        // Blue's near field is the shortest: more of it lands in the inner half of the taps.
        let inner = |c: usize| shares[..taps / 2].iter().map(|s| s[c]).sum::<f32>();
        assert!(
            inner(2) > inner(1) && inner(1) > inner(0),
            "{:?}",
            [inner(0), inner(1), inner(2)]
        );
        // A channel without light, and a disc that is no length, fall back to a Gaussian.
        let dark = dark_green_profile();
        for shares in [
            dark.near_field_ring_shares(1.0, 2.0, 8),
            profile.near_field_ring_shares(1.0, 0.0, 8),
        ] {
            for (k, share) in shares.iter().enumerate() {
                let gaussian = (-2.0 * k as f32 / 8.0).exp();
                assert!(share[1].is_finite() && (share[1] - gaussian).abs() < 1e-6);
            }
        }
    }

    /// A plain midpoint rule over the sphere's surface in (α, β), with R(d)·r²·sin α: an
    /// independent check of the panels, the lit-arc integral and the change of variables.
    fn brute_force(profile: &DiffusionProfile, radius_mm: f64, theta: f64) -> [f64; 3] {
        brute_force_kernel(
            |d| profile.radial_reflectance_per_mm2(d),
            f64::from(profile.entry_cosine_power()),
            radius_mm,
            theta,
        )
    }

    /// [`brute_force`] for any kernel `R(d)` and entry power `p`.
    fn brute_force_kernel(
        kernel: impl Fn(f64) -> [f64; 3],
        p: f64,
        radius_mm: f64,
        theta: f64,
    ) -> [f64; 3] {
        brute_force_weighted(kernel, p, 0.0, radius_mm, theta)
    }

    /// The same with each source weighed by `1 − loss · max(−c, 0)`, c from the points' own
    /// positions: the point at θ in the x–z plane, the light along +z, the source at arc α and
    /// azimuth β (β = 0 toward the light).
    fn brute_force_weighted(
        kernel: impl Fn(f64) -> [f64; 3],
        p: f64,
        loss: f64,
        radius_mm: f64,
        theta: f64,
    ) -> [f64; 3] {
        let point = [theta.sin(), 0.0, theta.cos()];
        let toward_light = [-theta.cos(), 0.0, theta.sin()];
        let (n_alpha, n_beta) = (20_000, 720);
        let mut out = [0.0; 3];
        // α on a square-root grid: fine near α = 0, where the short terms live.
        for i in 0..n_alpha {
            let (u0, u1) = (i as f64 / n_alpha as f64, (i + 1) as f64 / n_alpha as f64);
            let (a0, a1) = (PI * u0 * u0, PI * u1 * u1);
            let alpha = 0.5 * (a0 + a1);
            let d = 2.0 * radius_mm * (0.5 * alpha).sin();
            let r = kernel(d);
            let area = radius_mm * radius_mm * alpha.sin() * (a1 - a0) * TAU / n_beta as f64;
            let mut h = 0.0;
            for j in 0..n_beta {
                let beta = TAU * (j as f64 + 0.5) / n_beta as f64;
                let mu = theta.cos() * alpha.cos() + theta.sin() * alpha.sin() * beta.cos();
                let mut weight = 1.0;
                if loss > 0.0 && d > 0.0 {
                    // (q − p)·l / |q − p| on the unit sphere, scaled by r / d.
                    let q: [f64; 3] = std::array::from_fn(|k| {
                        alpha.cos() * point[k] + alpha.sin() * beta.cos() * toward_light[k]
                    });
                    let c = (q[2] - point[2]) * radius_mm / d;
                    weight = 1.0 - (loss * (-c).max(0.0)).min(1.0);
                }
                h += weight * mu.max(0.0).powf(p);
            }
            for c in 0..3 {
                out[c] += r[c] * area * h;
            }
        }
        out
    }

    #[test]
    fn agrees_with_a_brute_force_surface_integral() {
        let profile = profile();
        for radius_mm in [15.0, 50.0] {
            for theta_deg in [0.0f64, 45.0, 85.0, 100.0, 140.0, 180.0] {
                let theta = theta_deg.to_radians();
                let fast = profile.sphere_reflectance(1.0 / radius_mm, theta);
                let slow = brute_force(&profile, radius_mm, theta);
                for c in 0..3 {
                    let scale = profile.sphere_reflectance(1.0 / radius_mm, 0.0)[c];
                    let error = (fast[c] - slow[c]).abs() / scale;
                    assert!(
                        error < 2e-4,
                        "r = {radius_mm}, θ = {theta_deg}°, channel {c}: {} vs {} (error {error:e} of the peak)",
                        fast[c],
                        slow[c]
                    );
                }
            }
        }
    }

    #[test]
    fn the_far_field_on_a_sphere_agrees_with_a_brute_force_surface_integral() {
        let profile = profile();
        let far = FarField::new(&profile, 2.0);
        let mut scratch = Vec::new();
        for radius_mm in [10.0, 40.0] {
            for theta_deg in [0.0f64, 60.0, 95.0, 130.0, 180.0] {
                let theta = theta_deg.to_radians();
                let fast = far.sphere_reflectance(1.0 / radius_mm, theta, &mut scratch);
                let slow = brute_force_weighted(
                    |d| far.reflectance_per_mm2(d),
                    far.entry_cosine_power(),
                    f64::from(UPSTREAM_LOSS),
                    radius_mm,
                    theta,
                );
                let peak = far.sphere_reflectance(1.0 / radius_mm, 0.0, &mut scratch);
                for c in 0..3 {
                    let error = (fast[c] - slow[c]).abs() / peak[c];
                    assert!(
                        error < 2e-4,
                        "r = {radius_mm}, θ = {theta_deg}°, channel {c}: {} vs {} (error {error:e})",
                        fast[c],
                        slow[c]
                    );
                }
            }
        }
    }

    /// The upstream loss changes nothing on a sphere's shadow side (every lit point lies
    /// upstream of the point) or on a plane lit head-on, takes light on a sphere's lit side
    /// (more with a larger loss), and agrees with a brute-force surface integral at any loss.
    #[test]
    fn the_upstream_loss_takes_light_only_from_points_upstream_of_their_sources() {
        let lengths = [2.0, 8.0];
        let (radius_mm, power) = (20.0, 0.85);
        let responses = |theta_deg: f64, loss: f64| {
            let mut out = [0.0; 2];
            sphere_responses(
                &lengths,
                radius_mm,
                theta_deg.to_radians(),
                power,
                loss,
                &mut out,
            );
            out
        };
        for theta_deg in [95.0, 120.0, 160.0] {
            assert_eq!(responses(theta_deg, 1.0), responses(theta_deg, 0.0));
        }
        let mut flat = [[0.0; 2]; 2];
        for (out, loss) in flat.iter_mut().zip([0.0, 1.0]) {
            sphere_responses(&lengths, 1e6, 0.0, power, loss, out);
        }
        // (A plane of radius 10⁶ mm: every source lies d/(2r) below the point, a loss of
        // about ℓ/(2r) = 4·10⁻⁶ of the 8 mm term.)
        for k in 0..2 {
            assert!(
                (flat[1][k] - flat[0][k]).abs() < 1e-5 * flat[0][k],
                "{flat:?}"
            );
        }
        for theta_deg in [0.0, 40.0, 80.0] {
            let [none, some, more] = [0.0, 1.0, 2.0].map(|loss| responses(theta_deg, loss));
            for k in 0..2 {
                assert!(more[k] < some[k] && some[k] < none[k], "θ = {theta_deg}°");
            }
        }
        // The brute force's grid and the loss's kinks (where c = 0 and where the loss reaches
        // 1, inside the quadrature's panels) hold the agreement to 10⁻³ of the peak, five times
        // the isotropic integral's.
        let peak = responses(0.0, 0.0);
        for loss in [1.0, 2.0] {
            for theta_deg in [30.0f64, 60.0, 85.0] {
                let fast = responses(theta_deg, loss);
                let kernel = |d: f64| {
                    let d = d.max(1e-12);
                    let [a, b] = lengths.map(|ell| (-d / ell).exp() / (TAU * ell * d));
                    [a, b, 0.0]
                };
                let slow =
                    brute_force_weighted(kernel, power, loss, radius_mm, theta_deg.to_radians());
                for k in 0..2 {
                    assert!(
                        (fast[k] - slow[k]).abs() < 1e-3 * peak[k],
                        "loss {loss}, θ = {theta_deg}°, ℓ = {}: {} vs {}",
                        lengths[k],
                        fast[k],
                        slow[k]
                    );
                }
            }
        }
    }

    #[test]
    fn the_far_field_keeps_the_long_terms_beyond_the_cut() {
        let profile = profile();
        let far = FarField::new(&profile, 2.0);
        // Finite at 0, below the whole profile everywhere, and the 3 and 12 mm terms alone far
        // out (the 0.5 mm term is dropped).
        let at_zero = far.reflectance_per_mm2(0.0);
        let near_zero = far.reflectance_per_mm2(1e-4);
        for c in 0..3 {
            assert!(
                at_zero[c].is_finite() && (at_zero[c] - near_zero[c]).abs() < 1e-4 * at_zero[c]
            );
        }
        for d in [0.1, 1.0, 5.0, 20.0, 60.0] {
            let whole = profile.radial_reflectance_per_mm2(d);
            let part = far.reflectance_per_mm2(d);
            for c in 0..3 {
                assert!(
                    part[c] > 0.0 && part[c] < whole[c],
                    "d = {d}: {part:?} vs {whole:?}"
                );
            }
        }
        let d = 40.0;
        let tail = far.reflectance_per_mm2(d)[0];
        let long: f64 = [(3.0, 0.3), (12.0, 0.4)]
            .iter()
            .map(|&(ell, w): &(f64, f64)| w * (-d / ell).exp() / (TAU * ell * d))
            .sum();
        assert!((tail - long).abs() < 1e-6 * long, "{tail} vs {long}");
        // A flat surface lit head-on: Σ w·(1 − ℓ_c/ℓ) of the kept terms.
        let flat = far.sphere_reflectance(1e-6, 0.0, &mut Vec::new());
        let expected = 0.3 * (1.0 - 2.0 / 3.0) + 0.4 * (1.0 - 2.0 / 12.0);
        assert!(
            (flat[0] - expected).abs() < 1e-4,
            "{} vs {expected}",
            flat[0]
        );
        assert_eq!(far.longest_mm(), 12.0);
        // Nothing beyond the longest term, or for a cut that is no length.
        assert!(FarField::new(&profile, 12.0).is_empty());
        assert!(FarField::new(&profile, f64::NAN).is_empty());
        assert_eq!(
            FarField::new(&profile, 20.0).reflectance_per_mm2(1.0),
            [0.0; 3]
        );
    }

    #[test]
    fn a_flat_surface_lit_head_on_gives_the_albedo() {
        let profile = profile();
        let f = profile.sphere_reflectance(1e-6, 0.0);
        for (f, a) in f.iter().zip(profile.albedo()) {
            assert!((f - f64::from(a)).abs() < 1e-4, "{f} vs {a}");
        }
    }

    #[test]
    fn the_lit_arc_integral_matches_its_closed_form_and_a_fine_sum() {
        for (a, b) in [(0.5, 0.2), (0.2, 0.5), (-0.3, 0.5), (0.0, 1.0), (0.7, 0.7)] {
            for p in [0.5, 0.8, 1.0, 1.7] {
                let n = 200_000;
                let sum: f64 = (0..n)
                    .map(|j| {
                        let beta = TAU * (j as f64 + 0.5) / n as f64;
                        f64::max(a + b * beta.cos(), 0.0).powf(p)
                    })
                    .sum::<f64>()
                    * TAU
                    / n as f64;
                let value = lit_arc_integral(a, b, p);
                assert!(
                    (value - sum).abs() < 1e-5,
                    "a = {a}, b = {b}, p = {p}: {value} vs {sum}"
                );
            }
        }
        assert_eq!(lit_arc_integral(-0.5, 0.2, 0.8), 0.0);
    }

    #[test]
    fn light_wraps_further_on_smaller_spheres_and_is_smooth_in_p() {
        let profile = profile();
        let theta = 110f64.to_radians();
        let small = profile.sphere_reflectance(1.0 / 15.0, theta);
        let large = profile.sphere_reflectance(1.0 / 50.0, theta);
        assert!(small[0] > large[0]);
        // The quadrature is fixed: responses move smoothly with p.
        let lengths = [0.5, 4.0];
        let mut f = [[0.0; 2]; 3];
        for (i, p) in [0.79, 0.8, 0.81].into_iter().enumerate() {
            sphere_term_responses(&lengths, 20.0, 1.2, p, &mut f[i]);
        }
        for k in 0..2 {
            let second = f[0][k] - 2.0 * f[1][k] + f[2][k];
            assert!(second.abs() < 1e-3 * f[1][k], "{f:?}");
        }
    }

    #[test]
    fn rejects_bad_terms() {
        let term = |length_mm, w| ProfileTerm {
            length_mm,
            weight: [w; 3],
        };
        assert!(DiffusionProfile::new(vec![], 1.0).is_err());
        assert!(DiffusionProfile::new(vec![term(1.0, 0.1), term(1.0, 0.1)], 1.0).is_err());
        assert!(DiffusionProfile::new(vec![term(0.0, 0.1)], 1.0).is_err());
        assert!(DiffusionProfile::new(vec![term(f32::NAN, 0.1)], 1.0).is_err());
        assert!(DiffusionProfile::new(vec![term(1.0, -0.1)], 1.0).is_err());
        assert!(DiffusionProfile::new(vec![term(1.0, 0.1)], -1.0).is_err());
        assert!(DiffusionProfile::new(vec![term(1.0, 0.1)], f32::NAN).is_err());
        assert!(DiffusionProfile::new(vec![term(1.0, 0.1); 17], 1.0).is_err());
        assert!(DiffusionProfile::new(vec![term(1.0, 0.1)], 1.0).is_ok());
    }
}
