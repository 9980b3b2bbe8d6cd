//! Virtual photographs of spheres: Monte Carlo light transport in a homogeneous sphere under a
//! collimated light, seen by an orthographic camera, in exactly the set-up of the bundled
//! path-traced photographs (`data/README.md`): to-light `L = (−1, 0, 0)`, to-camera
//! `V = (0, 0, 1)`, irradiance 1 per channel, linear radiance per pixel.
//!
//! A preset without photographs ([`crate::preset`]) runs these images through the unchanged
//! fit, so it gets what a measured table has: the view correction, the transmission and the
//! diffusion profile.
//!
//! # The simulation
//! Photons enter the lit hemisphere uniformly over the beam's cross-section (flux `π r²` per
//! channel, Fresnel-transmitted when η ≠ 1), walk with free paths of density `σt·e^(−σt·s)`,
//! carry the single-scattering albedo as weight (Russian roulette ends faint ones without bias)
//! and scatter by the Henyey–Greenstein phase function. At the boundary they leave (η = 1) or
//! are reflected with the Fresnel probability, totally when internal reflection is total.
//!
//! The problem is symmetric about the light's axis, which is the image's x axis: a path rotated
//! about it is as likely as the path. Both estimators spend that symmetry:
//! - [`Estimator::ViewRays`] (η = 1, the default there): at every collision, for
//!   [`SimulationSettings::rotations`] rotations of the collision about the axis, the light
//!   scattered toward the camera, `w·p(cos)·e^(−σt·t)`, lands in the pixel the point projects
//!   to (next-event estimation; every collision counts).
//! - [`Estimator::ExitBand`] (any η): a photon that leaves with a direction within
//!   `|ω·L| < ε` of the plane perpendicular to the light is rotated about the axis until its
//!   direction is the camera's, and lands in the pixel of its exit point. The band has solid
//!   angle `4πε`; radiance is flux over pixel area and that solid angle. It handles Fresnel and
//!   internal reflection exactly, at the cost of using only the photons in the band.
//!
//! Two channels share one walk when their σt are equal (the wax of the bundled data); otherwise
//! every channel walks on its own. Work is split into fixed chunks, each with its own seeded
//! generator, and summed in a fixed order: the same settings give the same image, bit for bit,
//! on any number of threads. The chunks form [`SimulationSettings::batches`] independent batches
//! whose spread is the noise the simulation reports ([`SimulationNoise`]).

use std::f64::consts::PI;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use glam::{DVec3, Vec2, Vec3};
use rand_core::{RngCore, SeedableRng};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;
use serde::Serialize;

use crate::dataset::{Light, Projection};
use crate::image_io::{ColorSpace, LinearImage, SampleFormat};
use crate::sphere::{Circle, SphereView};

/// A homogeneous scattering medium, per RGB channel, in millimetres.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ScatteringMedium {
    /// Scattering coefficient σs, mm⁻¹ per channel (not the reduced σs′).
    pub sigma_s_per_mm: [f64; 3],
    /// Absorption coefficient σa, mm⁻¹ per channel.
    pub sigma_a_per_mm: [f64; 3],
    /// Henyey–Greenstein asymmetry g in (−1, 1); 0 is isotropic.
    pub g: f64,
    /// Relative index of refraction of the smooth boundary (medium over outside); 1 is
    /// index-matched (no Fresnel, no refraction).
    pub eta: f64,
}

/// Why a medium or settings cannot be simulated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SimulationError {
    /// A coefficient is negative, not finite, or all of a channel's are zero.
    #[error(
        "scattering medium: sigma_s and sigma_a must be finite and ≥ 0 with sigma_s + sigma_a in [1e-3, 1e3] mm⁻¹ per channel (got sigma_s {sigma_s:?}, sigma_a {sigma_a:?})"
    )]
    Coefficients {
        /// σs given.
        sigma_s: [f64; 3],
        /// σa given.
        sigma_a: [f64; 3],
    },
    /// g outside (−0.99, 0.99).
    #[error("scattering medium: the phase function's g must be in (−0.99, 0.99), got {0}")]
    Asymmetry(f64),
    /// η outside [1, 3].
    #[error(
        "scattering medium: the relative index eta must be in [1, 3] (1 = index-matched), got {0}"
    )]
    Eta(f64),
    /// A radius outside (0, 1000] mm.
    #[error("sphere radius must be in (0, 1000] mm, got {0}")]
    Radius(f32),
    /// Settings out of range.
    #[error("simulation settings: {0}")]
    Settings(&'static str),
}

impl ScatteringMedium {
    /// A checked medium.
    ///
    /// # Errors
    /// When a coefficient is negative or not finite, a channel's extinction is outside
    /// [1e-3, 1e3] mm⁻¹, `g` outside (−0.99, 0.99) or `eta` outside [1, 3].
    pub fn new(
        sigma_s_per_mm: [f64; 3],
        sigma_a_per_mm: [f64; 3],
        g: f64,
        eta: f64,
    ) -> Result<Self, SimulationError> {
        let ok = (0..3).all(|c| {
            let (s, a) = (sigma_s_per_mm[c], sigma_a_per_mm[c]);
            s.is_finite() && a.is_finite() && s >= 0.0 && a >= 0.0 && (1e-3..=1e3).contains(&(s + a))
        });
        if !ok {
            return Err(SimulationError::Coefficients {
                sigma_s: sigma_s_per_mm,
                sigma_a: sigma_a_per_mm,
            });
        }
        if !(g.is_finite() && g.abs() < 0.99) {
            return Err(SimulationError::Asymmetry(g));
        }
        if !(eta.is_finite() && (1.0..=3.0).contains(&eta)) {
            return Err(SimulationError::Eta(eta));
        }
        Ok(Self {
            sigma_s_per_mm,
            sigma_a_per_mm,
            g,
            eta,
        })
    }

    /// Extinction σt = σs + σa, mm⁻¹ per channel.
    pub fn sigma_t_per_mm(&self) -> [f64; 3] {
        std::array::from_fn(|c| self.sigma_s_per_mm[c] + self.sigma_a_per_mm[c])
    }

    /// Single-scattering albedo σs / σt per channel.
    pub fn albedo(&self) -> [f64; 3] {
        let t = self.sigma_t_per_mm();
        std::array::from_fn(|c| self.sigma_s_per_mm[c] / t[c])
    }

    /// Diffusion length 1/σtr = 1/√(3·σa·σt′) per channel, mm (σt′ = σs·(1 − g) + σa);
    /// infinite without absorption.
    pub fn diffusion_length_mm(&self) -> [f64; 3] {
        std::array::from_fn(|c| {
            let reduced = self.sigma_s_per_mm[c] * (1.0 - self.g) + self.sigma_a_per_mm[c];
            1.0 / (3.0 * self.sigma_a_per_mm[c] * reduced).sqrt()
        })
    }
}

/// Which estimator turns photon paths into pixels (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Estimator {
    /// Next-event estimation toward the camera from every collision; index-matched only.
    ViewRays,
    /// Photons leaving within a band of directions around the camera's; any η.
    ExitBand,
}

/// How much and how the simulation traces.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SimulationSettings {
    /// Photons per sphere and walk (a chromatic medium walks three times).
    pub photons: u64,
    /// Independent batches (≥ 2): their spread is the reported noise.
    pub batches: u32,
    /// Chunks per batch, each with its own generator (the unit of parallel work).
    pub chunks_per_batch: u32,
    /// Seed of every generator.
    pub seed: u64,
    /// Width and height of the virtual photograph, pixels.
    pub image_size_px: u32,
    /// The sphere's radius in the photograph, pixels (centred).
    pub sphere_radius_px: f32,
    /// Rotations about the light axis per collision ([`Estimator::ViewRays`]).
    pub rotations: u32,
    /// Rays per collision ([`Estimator::ExitBand`]).
    pub rays: u32,
    /// Half-width ε of the band `|ω·L| < ε` ([`Estimator::ExitBand`]).
    pub band_half_width: f64,
    /// The estimator; `None` picks [`Estimator::ViewRays`] at η = 1 and
    /// [`Estimator::ExitBand`] otherwise.
    pub estimator: Option<Estimator>,
}

impl Default for SimulationSettings {
    fn default() -> Self {
        Self {
            photons: 400_000,
            batches: 8,
            chunks_per_batch: 8,
            seed: 1,
            image_size_px: 512,
            sphere_radius_px: 230.0,
            rotations: 16,
            rays: 16,
            band_half_width: 0.04,
            estimator: None,
        }
    }
}

impl SimulationSettings {
    fn check(&self) -> Result<(), SimulationError> {
        let problem = if self.batches < 2 {
            Some("batches must be at least 2 (their spread is the noise)")
        } else if self.chunks_per_batch == 0 || self.rotations == 0 || self.rays == 0 {
            Some("chunks_per_batch, rotations and rays must be at least 1")
        } else if self.photons < u64::from(self.batches * self.chunks_per_batch) {
            Some("photons must be at least batches × chunks_per_batch")
        } else if self.photons > 1 << 40 {
            Some("photons must be at most 2^40")
        } else if !(16..=4096).contains(&self.image_size_px) {
            Some("image_size_px must be in 16 … 4096")
        } else if !(self.sphere_radius_px >= 4.0
            && self.sphere_radius_px <= self.image_size_px as f32 / 2.0)
        {
            Some("sphere_radius_px must be in 4 … image_size_px / 2")
        } else if !(self.band_half_width > 0.0 && self.band_half_width <= 0.5) {
            Some("band_half_width must be in (0, 0.5]")
        } else {
            None
        };
        problem.map_or(Ok(()), |p| Err(SimulationError::Settings(p)))
    }
}

/// Relative standard error of the mean radiance per region of the sphere, per RGB channel,
/// from the spread of the batches. Regions as the checks bin them: lit `cos θ ≥ 0.26`,
/// terminator `|cos θ| < 0.26`, shadow `cos θ ≤ −0.26`, and the band θ ∈ [145°, 155°].
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct SimulationNoise {
    /// Lit side.
    pub lit: [f32; 3],
    /// Around the terminator.
    pub terminator: [f32; 3],
    /// Shadow side.
    pub shadow: [f32; 3],
    /// θ = 150° ± 5°.
    pub theta_150: [f32; 3],
}

/// A simulated photograph of one sphere.
#[derive(Clone, Debug)]
pub struct SimulatedSphere {
    /// The sphere's radius, mm.
    pub radius_mm: f32,
    /// Linear radiance per pixel, irradiance 1 (mirror-averaged about the horizontal axis).
    pub image: LinearImage,
    /// Where the sphere is in the image.
    pub circle: Circle,
    /// The estimator used.
    pub estimator: Estimator,
    /// The noise reached.
    pub noise: SimulationNoise,
    /// Photons traced (all walks).
    pub photons: u64,
    /// Wall time, seconds.
    pub seconds: f64,
}

impl SimulatedSphere {
    /// How the fit sees this photograph: orthographic, the circle, the image size.
    pub fn view(&self) -> SphereView {
        SphereView::new(
            self.circle,
            Projection::Orthographic,
            self.image.width as usize,
            self.image.height as usize,
        )
    }
}

/// The light of every simulated photograph: from the image's left, irradiance 1.
pub fn simulated_light() -> Light {
    Light {
        to_light: Vec3::new(-1.0, 0.0, 0.0),
        irradiance: Vec3::ONE,
    }
}

/// Simulates the photograph of a sphere of `radius_mm` in `medium`. `progress` is called with
/// the photons traced so far (all walks together; the total is [`walks`] × `photons`).
///
/// # Errors
/// When the radius or the settings are out of range.
pub fn simulate_sphere(
    medium: &ScatteringMedium,
    radius_mm: f32,
    settings: &SimulationSettings,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<SimulatedSphere, SimulationError> {
    settings.check()?;
    if !(radius_mm > 0.0 && radius_mm <= 1000.0) {
        return Err(SimulationError::Radius(radius_mm));
    }
    let started = Instant::now();
    let estimator = settings.estimator.unwrap_or(if medium.eta == 1.0 {
        Estimator::ViewRays
    } else {
        Estimator::ExitBand
    });
    let frame = Frame::new(radius_mm, settings);
    let groups = channel_groups(medium);
    let batches = settings.batches as usize;
    let chunks = settings.chunks_per_batch as usize;
    let done = AtomicU64::new(0);

    let mut total = Accumulator::new(frame.size);
    let mut batch_means = Vec::with_capacity(batches);
    for batch in 0..batches {
        let mut batch_image = Accumulator::new(frame.size);
        for (group_index, channels) in groups.iter().enumerate() {
            let walk = Walk::new(medium, channels, f64::from(radius_mm), estimator, settings);
            let images: Vec<Accumulator> = (0..chunks)
                .into_par_iter()
                .map(|chunk| {
                    let index = (batch * chunks + chunk) as u64;
                    let count = chunk_photons(settings.photons, batches * chunks, index);
                    let stream = (group_index as u64) << 32 | index;
                    let mut rng = Pcg64Mcg::seed_from_u64(mix(settings.seed, stream));
                    let mut image = Accumulator::new(frame.size);
                    let flux = PI * f64::from(radius_mm).powi(2) / settings.photons as f64;
                    for traced in 0..count {
                        walk.trace(&mut rng, &frame, flux, &mut image);
                        if traced % 4096 == 4095 {
                            progress(done.fetch_add(4096, Ordering::Relaxed) + 4096);
                        }
                    }
                    done.fetch_add(count % 4096, Ordering::Relaxed);
                    image
                })
                .collect();
            for image in &images {
                batch_image.add(image);
            }
        }
        // Each batch traced 1/batches of the photons: scale it to a full estimate.
        batch_means.push(frame.region_means(&batch_image, batches as f64));
        total.add(&batch_image);
    }
    progress(done.load(Ordering::Relaxed));
    let means = frame.region_means(&total, 1.0);
    let noise = noise_of(&batch_means, &means);
    Ok(SimulatedSphere {
        radius_mm,
        image: frame.photograph(&total),
        circle: frame.circle(),
        estimator,
        noise,
        photons: settings.photons * groups.len() as u64,
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// How many walks a medium needs: one when its σt is the same in every channel, else three.
pub fn walks(medium: &ScatteringMedium) -> usize {
    channel_groups(medium).len()
}

fn channel_groups(medium: &ScatteringMedium) -> Vec<[bool; 3]> {
    let t = medium.sigma_t_per_mm();
    if t[0] == t[1] && t[1] == t[2] {
        vec![[true; 3]]
    } else {
        (0..3)
            .map(|c| std::array::from_fn(|k| k == c))
            .collect()
    }
}

/// Photons of chunk `index` of `chunks`: the remainder goes to the first chunks.
fn chunk_photons(photons: u64, chunks: usize, index: u64) -> u64 {
    let chunks = chunks as u64;
    photons / chunks + u64::from(index < photons % chunks)
}

/// SplitMix64 of the seed and the stream: well-separated generator seeds.
fn mix(seed: u64, stream: u64) -> u64 {
    let mut z = seed ^ stream.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

fn noise_of(batch_means: &[[[f64; 3]; 4]], means: &[[f64; 3]; 4]) -> SimulationNoise {
    let n = batch_means.len() as f64;
    let relative = |region: usize| -> [f32; 3] {
        std::array::from_fn(|c| {
            let mean = means[region][c];
            let variance = batch_means
                .iter()
                .map(|b| (b[region][c] - mean).powi(2))
                .sum::<f64>()
                / (n - 1.0);
            if mean > 0.0 {
                ((variance / n).sqrt() / mean) as f32
            } else {
                f32::INFINITY
            }
        })
    };
    SimulationNoise {
        lit: relative(0),
        terminator: relative(1),
        shadow: relative(2),
        theta_150: relative(3),
    }
}

/// Radiance sums per pixel, RGB.
struct Accumulator {
    size: usize,
    sums: Vec<[f64; 3]>,
}

impl Accumulator {
    fn new(size: usize) -> Self {
        Self {
            size,
            sums: vec![[0.0; 3]; size * size],
        }
    }

    fn add(&mut self, other: &Self) {
        for (a, b) in self.sums.iter_mut().zip(&other.sums) {
            for c in 0..3 {
                a[c] += b[c];
            }
        }
    }

    /// Adds `weight · factor` to the pixel under the image-plane point (x, y) mm.
    #[inline]
    fn splat(&mut self, frame: &Frame, x: f64, y: f64, weight: &[f64; 3], factor: f64) {
        let column = (x * frame.px_per_mm + frame.half_size).floor();
        let row = (frame.half_size - y * frame.px_per_mm).floor();
        if column >= 0.0 && row >= 0.0 && column < frame.size as f64 && row < frame.size as f64 {
            let pixel = &mut self.sums[row as usize * self.size + column as usize];
            for c in 0..3 {
                pixel[c] += weight[c] * factor;
            }
        }
    }
}

/// The photograph's geometry: image size, scale and the pixels' regions.
struct Frame {
    size: usize,
    half_size: f64,
    px_per_mm: f64,
    radius_mm: f64,
    radius_px: f32,
    /// Pixel area, mm².
    pixel_area_mm2: f64,
}

impl Frame {
    fn new(radius_mm: f32, settings: &SimulationSettings) -> Self {
        let px_per_mm = f64::from(settings.sphere_radius_px) / f64::from(radius_mm);
        Self {
            size: settings.image_size_px as usize,
            half_size: f64::from(settings.image_size_px) / 2.0,
            px_per_mm,
            radius_mm: f64::from(radius_mm),
            radius_px: settings.sphere_radius_px,
            pixel_area_mm2: 1.0 / (px_per_mm * px_per_mm),
        }
    }

    fn circle(&self) -> Circle {
        Circle {
            center_px: Vec2::splat(self.half_size as f32),
            radius_px: self.radius_px,
        }
    }

    /// cos θ of the pixel's centre when it lies on the sphere more than 2 px inside the rim.
    fn cos_theta(&self, column: usize, row: usize) -> Option<f64> {
        let x = (column as f64 + 0.5 - self.half_size) / self.px_per_mm;
        let y = (self.half_size - row as f64 - 0.5) / self.px_per_mm;
        let rho = (x * x + y * y).sqrt();
        (rho * self.px_per_mm < f64::from(self.radius_px) - 2.0).then(|| -x / self.radius_mm)
    }

    /// Mean radiance (sums / pixel area × `scale`) of the lit, terminator, shadow and θ = 150°
    /// regions.
    fn region_means(&self, image: &Accumulator, scale: f64) -> [[f64; 3]; 4] {
        let mut sums = [[0.0; 3]; 4];
        let mut counts = [0usize; 4];
        let theta_150 = ((145.0f64).to_radians().cos(), (155.0f64).to_radians().cos());
        for row in 0..self.size {
            for column in 0..self.size {
                let Some(cos) = self.cos_theta(column, row) else {
                    continue;
                };
                let value = image.sums[row * self.size + column];
                let mut regions = [false; 4];
                regions[if cos >= 0.26 {
                    0
                } else if cos > -0.26 {
                    1
                } else {
                    2
                }] = true;
                regions[3] = cos <= theta_150.0 && cos >= theta_150.1;
                for (region, inside) in regions.iter().enumerate() {
                    if *inside {
                        counts[region] += 1;
                        for c in 0..3 {
                            sums[region][c] += value[c];
                        }
                    }
                }
            }
        }
        std::array::from_fn(|region| {
            std::array::from_fn(|c| {
                sums[region][c] * scale / self.pixel_area_mm2 / counts[region].max(1) as f64
            })
        })
    }

    /// The accumulated sums as radiance, mirror-averaged about the horizontal axis (the scene
    /// is symmetric in y).
    fn photograph(&self, image: &Accumulator) -> LinearImage {
        let n = self.size;
        let pixels = (0..n * n)
            .map(|index| {
                let (row, column) = (index / n, index % n);
                let mirror = image.sums[(n - 1 - row) * n + column];
                let value = image.sums[index];
                Vec3::from_array(std::array::from_fn(|c| {
                    (0.5 * (value[c] + mirror[c]) / self.pixel_area_mm2) as f32
                }))
            })
            .collect();
        LinearImage {
            width: n as u32,
            height: n as u32,
            pixels,
            saturated: vec![false; n * n],
            sample_format: SampleFormat::Float,
            color_space: ColorSpace::Linear,
        }
    }
}

/// One walk's constants: the channels it carries and the medium seen by them.
struct Walk {
    channels: [bool; 3],
    sigma_t: f64,
    albedo: [f64; 3],
    g: f64,
    eta: f64,
    radius: f64,
    estimator: Estimator,
    rotations: u32,
    rays: u32,
    band: f64,
}

impl Walk {
    fn new(
        medium: &ScatteringMedium,
        channels: &[bool; 3],
        radius: f64,
        estimator: Estimator,
        settings: &SimulationSettings,
    ) -> Self {
        let first = channels.iter().position(|&on| on).unwrap_or(0);
        let albedo = medium.albedo();
        Self {
            channels: *channels,
            sigma_t: medium.sigma_t_per_mm()[first],
            albedo: std::array::from_fn(|c| if channels[c] { albedo[c] } else { 0.0 }),
            g: medium.g,
            eta: medium.eta,
            radius,
            estimator,
            rotations: settings.rotations,
            rays: settings.rays,
            band: settings.band_half_width,
        }
    }

    /// Traces one photon of flux `flux` per channel from entry to exit or absorption.
    fn trace(&self, rng: &mut Pcg64Mcg, frame: &Frame, flux: f64, image: &mut Accumulator) {
        let r = self.radius;
        // Entry: uniform over the beam's disk; by the symmetry, on the +y half-plane.
        let rho = r * uniform(rng).sqrt();
        let position = DVec3::new(-(r * r - rho * rho).max(0.0).sqrt(), rho, 0.0);
        let normal = position / r;
        let beam = DVec3::X;
        let mut weight: [f64; 3] =
            std::array::from_fn(|c| if self.channels[c] { flux } else { 0.0 });
        let mut direction = beam;
        if self.eta != 1.0 {
            let cos_in = -beam.dot(normal);
            let transmit = 1.0 - fresnel_from_outside(cos_in, self.eta);
            for w in &mut weight {
                *w *= transmit;
            }
            direction = refract_inward(beam, normal, cos_in, self.eta);
        }
        let mut position = position;
        let start = weight.iter().copied().fold(0.0, f64::max);
        loop {
            let free_path = -(1.0 - uniform(rng)).ln() / self.sigma_t;
            let to_boundary = distance_to_sphere(position, direction, r);
            if free_path >= to_boundary {
                position += direction * to_boundary;
                // Keep the point on the sphere despite rounding.
                position *= r / position.length();
                let normal = position / r;
                let cos_out = direction.dot(normal).clamp(0.0, 1.0);
                let reflect = if self.eta == 1.0 {
                    0.0
                } else {
                    fresnel_from_inside(cos_out, self.eta)
                };
                if reflect > 0.0 && uniform(rng) < reflect {
                    direction -= 2.0 * cos_out * normal;
                    continue;
                }
                // Escaping light reached the camera through the estimators already.
                return;
            }
            position += direction * free_path;
            for c in 0..3 {
                weight[c] *= self.albedo[c];
            }
            match self.estimator {
                Estimator::ViewRays => {
                    self.look_toward_camera(rng, position, direction, &weight, frame, image);
                }
                Estimator::ExitBand => {
                    self.rays_to_boundary(rng, position, direction, &weight, frame, image);
                }
            }
            direction = sample_henyey_greenstein(rng, direction, self.g);
            // Russian roulette below 1 % of the entering flux: survivors carry the rest.
            let strongest = weight.iter().copied().fold(0.0, f64::max);
            if strongest < 0.01 * start {
                if uniform(rng) < 0.2 {
                    for w in &mut weight {
                        *w /= 0.2;
                    }
                } else {
                    return;
                }
            }
        }
    }

    /// [`Estimator::ViewRays`]: the light a collision at `position` scatters toward the camera,
    /// for evenly spaced rotations about the light axis with a random offset.
    fn look_toward_camera(
        &self,
        rng: &mut Pcg64Mcg,
        position: DVec3,
        direction: DVec3,
        weight: &[f64; 3],
        frame: &Frame,
        image: &mut Accumulator,
    ) {
        let r2 = self.radius * self.radius;
        let step = 2.0 * PI / f64::from(self.rotations);
        let offset = uniform(rng) * step;
        let share = 1.0 / f64::from(self.rotations);
        for k in 0..self.rotations {
            let (sin, cos) = (offset + step * f64::from(k)).sin_cos();
            let y = cos * position.y - sin * position.z;
            let z = sin * position.y + cos * position.z;
            // Direction's component along the camera after the same rotation.
            let toward = sin * direction.y + cos * direction.z;
            let depth = (r2 - position.x * position.x - y * y).max(0.0).sqrt() - z;
            let factor = henyey_greenstein(toward, self.g) * (-self.sigma_t * depth).exp() * share;
            image.splat(frame, position.x, y, weight, factor);
        }
    }

    /// [`Estimator::ExitBand`]: [`SimulationSettings::rays`] directions from a collision, each
    /// followed to the boundary and through its internal reflections; what leaves within the
    /// band lands in the image.
    fn rays_to_boundary(
        &self,
        rng: &mut Pcg64Mcg,
        position: DVec3,
        direction: DVec3,
        weight: &[f64; 3],
        frame: &Frame,
        image: &mut Accumulator,
    ) {
        // Uniform directions (pdf 1/4π); the band's solid angle is 4πε.
        let share = 1.0 / (f64::from(self.rays) * self.band);
        for _ in 0..self.rays {
            let ray = uniform_direction(rng);
            let mut throughput = henyey_greenstein(direction.dot(ray), self.g) * share;
            let mut point = position;
            let mut heading = ray;
            for _ in 0..MAX_CHAIN {
                let length = distance_to_sphere(point, heading, self.radius);
                point += heading * length;
                point *= self.radius / point.length();
                throughput *= (-self.sigma_t * length).exp();
                let normal = point / self.radius;
                let cos_out = heading.dot(normal).clamp(0.0, 1.0);
                let reflect = fresnel_from_inside(cos_out, self.eta);
                if reflect < 1.0 {
                    let out = refract_outward(heading, normal, cos_out, self.eta);
                    self.record_exit(point, out, weight, throughput * (1.0 - reflect), frame, image);
                }
                throughput *= reflect;
                if throughput < 1e-6 * share {
                    break;
                }
                heading -= 2.0 * cos_out * normal;
            }
        }
    }

    /// Light leaving at `position` in direction `out` with `weight · factor` of flux per band
    /// solid angle: if `out` is in the band, rotated about the light axis until it is the
    /// camera's direction, and projected along it.
    fn record_exit(
        &self,
        position: DVec3,
        out: DVec3,
        weight: &[f64; 3],
        factor: f64,
        frame: &Frame,
        image: &mut Accumulator,
    ) {
        // L = −x: the band is |out.x| < ε.
        if out.x.abs() >= self.band {
            return;
        }
        // Rotate about x so that out's (y, z) part points along +z, then project along `out`
        // onto the image plane (the small tilt ε about y, exactly).
        let across = (out.y * out.y + out.z * out.z).sqrt();
        let (sin, cos) = (out.y / across, out.z / across);
        let y = cos * position.y - sin * position.z;
        let z = sin * position.y + cos * position.z;
        let x = across * position.x - out.x * z;
        image.splat(frame, x, y, weight, factor);
    }
}

/// Internal reflections followed per boundary ray (their weight falls as R^k).
const MAX_CHAIN: usize = 64;

/// A uniform direction on the unit sphere.
fn uniform_direction(rng: &mut Pcg64Mcg) -> DVec3 {
    let z = 1.0 - 2.0 * uniform(rng);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = (2.0 * PI * uniform(rng)).sin_cos();
    DVec3::new(r * c, r * s, z)
}

/// Uniform in [0, 1).
#[inline]
fn uniform(rng: &mut Pcg64Mcg) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Distance from `position` inside the sphere of radius `r` along unit `direction` to its
/// surface.
#[inline]
fn distance_to_sphere(position: DVec3, direction: DVec3, r: f64) -> f64 {
    let b = position.dot(direction);
    let c = position.length_squared() - r * r;
    -b + (b * b - c).max(0.0).sqrt()
}

/// Henyey–Greenstein phase function, sr⁻¹, at the cosine between the propagation directions
/// before and after.
#[inline]
fn henyey_greenstein(cos: f64, g: f64) -> f64 {
    let denominator = 1.0 + g * g - 2.0 * g * cos;
    (1.0 - g * g) / (4.0 * PI * denominator * denominator.sqrt())
}

/// A new propagation direction after scattering `direction` by Henyey–Greenstein.
fn sample_henyey_greenstein(rng: &mut Pcg64Mcg, direction: DVec3, g: f64) -> DVec3 {
    let u = uniform(rng);
    let cos = if g.abs() < 1e-6 {
        1.0 - 2.0 * u
    } else {
        let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
        ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
    };
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let azimuth = 2.0 * PI * uniform(rng);
    let (tangent, bitangent) = direction.any_orthonormal_pair();
    let (sa, ca) = azimuth.sin_cos();
    (direction * cos + (tangent * ca + bitangent * sa) * sin).normalize()
}

/// Unpolarised Fresnel reflectance for light arriving from outside at cosine `cos` on a
/// boundary of relative index `eta` ≥ 1.
fn fresnel_from_outside(cos: f64, eta: f64) -> f64 {
    let c = cos.clamp(0.0, 1.0);
    let ct = (1.0 - (1.0 - c * c) / (eta * eta)).max(0.0).sqrt();
    let rs = (c - eta * ct) / (c + eta * ct);
    let rp = (eta * c - ct) / (eta * c + ct);
    0.5 * (rs * rs + rp * rp)
}

/// Fresnel reflectance from inside at internal cosine `cos`: 1 past the critical angle, else
/// the outside value at the transmitted angle (reciprocity).
fn fresnel_from_inside(cos: f64, eta: f64) -> f64 {
    let sin2_out = eta * eta * (1.0 - cos * cos);
    if sin2_out >= 1.0 {
        return 1.0;
    }
    fresnel_from_outside((1.0 - sin2_out).sqrt(), eta)
}

/// The direction of a ray arriving from outside along `direction` (cos `cos_in` with the
/// inward normal) after entering a boundary of relative index `eta`.
fn refract_inward(direction: DVec3, normal: DVec3, cos_in: f64, eta: f64) -> DVec3 {
    let ratio = 1.0 / eta;
    let cos_t = (1.0 - ratio * ratio * (1.0 - cos_in * cos_in)).max(0.0).sqrt();
    (direction * ratio + normal * (ratio * cos_in - cos_t)).normalize()
}

/// The outside direction of a ray leaving along `direction` (cos `cos_out` with the outward
/// `normal`, inside the critical angle).
fn refract_outward(direction: DVec3, normal: DVec3, cos_out: f64, eta: f64) -> DVec3 {
    if eta == 1.0 {
        return direction;
    }
    let cos_t = (1.0 - eta * eta * (1.0 - cos_out * cos_out)).max(0.0).sqrt();
    (direction * eta + normal * (cos_t - eta * cos_out)).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresnel_has_its_closed_forms() {
        // Normal incidence: ((η − 1)/(η + 1))².
        let eta: f64 = 1.5;
        let normal = ((eta - 1.0) / (eta + 1.0)).powi(2);
        assert!((fresnel_from_outside(1.0, eta) - normal).abs() < 1e-12);
        assert!((fresnel_from_inside(1.0, eta) - normal).abs() < 1e-12);
        // Past the critical angle from inside: total.
        let critical_cos = (1.0 - 1.0 / (eta * eta)).sqrt();
        assert_eq!(fresnel_from_inside(critical_cos - 1e-3, eta), 1.0);
        assert!(fresnel_from_inside(critical_cos + 1e-3, eta) < 1.0);
        // Index-matched: nothing reflected.
        assert!(fresnel_from_outside(0.3, 1.0).abs() < 1e-15);
    }

    #[test]
    fn refraction_obeys_snell_and_reverses() {
        let eta = 1.3;
        let normal = DVec3::new(0.0, 0.0, -1.0); // inward normal is +z... outward −z
        let incoming = DVec3::new(0.6, 0.0, 0.8); // travelling into the medium (+z)
        let cos_in = incoming.dot(-normal);
        let inside = refract_inward(incoming, -normal, cos_in, eta);
        let sin_in = (1.0 - cos_in * cos_in).sqrt();
        let sin_t = (1.0 - inside.z * inside.z).sqrt();
        assert!((sin_in - eta * sin_t).abs() < 1e-12);
        // Leaving again through a parallel face restores the direction.
        let out = refract_outward(inside, DVec3::Z, inside.z, eta);
        assert!((out - incoming).length() < 1e-12);
    }

    #[test]
    fn henyey_greenstein_sampling_matches_its_density() {
        let mut rng = Pcg64Mcg::seed_from_u64(7);
        let g = 0.7;
        let n = 200_000;
        let mean_cos: f64 = (0..n)
            .map(|_| sample_henyey_greenstein(&mut rng, DVec3::Z, g).z)
            .sum::<f64>()
            / n as f64;
        // The mean cosine of Henyey–Greenstein is g.
        assert!((mean_cos - g).abs() < 0.005, "mean cosine {mean_cos}");
        // The density integrates to 1 over the sphere.
        let integral: f64 = (0..2000)
            .map(|i| {
                let cos = -1.0 + (i as f64 + 0.5) / 1000.0;
                henyey_greenstein(cos, g) * 2.0 * PI / 1000.0
            })
            .sum();
        assert!((integral - 1.0).abs() < 1e-3, "integral {integral}");
    }

    #[test]
    fn chunks_share_the_photons_exactly() {
        let total: u64 = (0..7).map(|i| chunk_photons(100, 7, i)).sum();
        assert_eq!(total, 100);
    }
}
