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
//!   internal reflection, at the cost of using only the photons in the band; it averages the
//!   radiance over the band's width (a bias of order ε²).
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

use crate::dataset::Projection;
use crate::image_io::{CodeStep, ColorSpace, LinearImage, SampleFormat};
use crate::sphere::{Circle, Illumination, SphereView};

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
            s.is_finite()
                && a.is_finite()
                && s >= 0.0
                && a >= 0.0
                && (1e-3..=1e3).contains(&(s + a))
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
    /// Rays from every collision to the boundary and through its internal reflections, kept
    /// when they leave within a band of directions around the camera's; any η.
    ExitBand,
    /// The photons' own exits within the band: the plainest estimator, exact by construction
    /// and slow (most photons leave outside the band); the others are tested against it.
    ExitPhotons,
}

/// How much and how the simulation traces.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SimulationSettings {
    /// Photons per sphere (a chromatic medium's three walks share them).
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
    /// Scattering events after which a path ends (the references' `max_depth`); `u32::MAX`
    /// for none.
    pub max_scatterings: u32,
    /// The estimator; `None` picks [`Estimator::ViewRays`] at η = 1 and
    /// [`Estimator::ExitBand`] otherwise.
    pub estimator: Option<Estimator>,
}

impl Default for SimulationSettings {
    fn default() -> Self {
        Self {
            photons: 300_000,
            batches: 8,
            chunks_per_batch: 8,
            seed: 1,
            image_size_px: 512,
            sphere_radius_px: 230.0,
            rotations: 4,
            rays: 4,
            band_half_width: 0.04,
            estimator: None,
            max_scatterings: u32::MAX,
        }
    }
}

impl SimulationSettings {
    fn check(&self) -> Result<(), SimulationError> {
        let problem = if self.batches < 2 {
            Some("batches must be at least 2 (their spread is the noise)")
        } else if self.batches > 64 || self.chunks_per_batch > 256 {
            Some("batches must be at most 64 and chunks_per_batch at most 256")
        } else if self.chunks_per_batch == 0
            || !(1..=64).contains(&self.rotations)
            || !(1..=64).contains(&self.rays)
        {
            Some("chunks_per_batch must be at least 1, rotations and rays in 1 … 64")
        } else if self.photons < u64::from(self.batches) * u64::from(self.chunks_per_batch) {
            Some("photons must be at least batches × chunks_per_batch")
        } else if self.photons > 1 << 40 {
            Some("photons must be at most 2^40")
        } else if !(16..=4096).contains(&self.image_size_px)
            || !self.image_size_px.is_multiple_of(2)
        {
            Some("image_size_px must be even and in 16 … 4096")
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

impl SimulationNoise {
    /// The worst channel's relative standard error per region, per cent: lit, terminator,
    /// shadow, θ = 150°.
    pub fn worst_percent(&self) -> [f32; 4] {
        [self.lit, self.terminator, self.shadow, self.theta_150]
            .map(|region| 100.0 * region.into_iter().fold(0.0, f32::max))
    }
}

/// `lit 0.15 %, terminator 0.56 %, shadow 1.21 %, θ = 150° 3.17 %` (worst channel).
impl std::fmt::Display for SimulationNoise {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [lit, terminator, shadow, theta_150] = self.worst_percent();
        write!(
            f,
            "lit {lit:.2} %, terminator {terminator:.2} %, shadow {shadow:.2} %, θ = 150° {theta_150:.2} %"
        )
    }
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
    /// The share of the light falling on the sphere that leaves it again (reflected and
    /// transmitted, every direction), per channel: 1 − absorbed − reflected at entry.
    pub escaped_fraction: [f64; 3],
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
pub fn simulated_light() -> Illumination {
    Illumination::directional(Vec3::new(-1.0, 0.0, 0.0), Vec3::ONE)
}

/// Simulates the photograph of a sphere of `radius_mm` in `medium`. `progress` is called with
/// the photons traced so far (all walks together, [`photons_traced`] in the end).
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
    if estimator == Estimator::ViewRays && medium.eta != 1.0 {
        return Err(SimulationError::Settings(
            "the ViewRays estimator needs an index-matched boundary (eta = 1)",
        ));
    }
    let frame = Frame::new(radius_mm, settings);
    let groups = channel_groups(medium);
    let batches = settings.batches as usize;
    let chunks = settings.chunks_per_batch as usize;
    let done = AtomicU64::new(0);

    // Every walk traces its share of the photons, split into batches × chunks tasks with
    // their own generators. Tasks run a window at a time and are summed in task order, so
    // the image does not depend on the thread count.
    let per_walk = photons_traced(medium, settings) / groups.len() as u64;
    let flux = PI * f64::from(radius_mm).powi(2) / per_walk as f64;
    let walkers: Vec<Walk> = groups
        .iter()
        .map(|channels| Walk::new(medium, channels, f64::from(radius_mm), estimator, settings))
        .collect();
    let tasks: Vec<(usize, usize, u64)> = (0..batches)
        .flat_map(|batch| {
            (0..walkers.len()).flat_map(move |walk| {
                (0..chunks).map(move |chunk| (batch, walk, (batch * chunks + chunk) as u64))
            })
        })
        .collect();
    let mut batch_sums: Vec<Accumulator> =
        (0..batches).map(|_| Accumulator::new(frame.size)).collect();
    for window in tasks.chunks(TASK_WINDOW) {
        let images: Vec<Accumulator> = window
            .par_iter()
            .map(|&(_, walk, index)| {
                let count = chunk_photons(per_walk, batches * chunks, index);
                let stream = (walk as u64) << 32 | index;
                let mut rng = Pcg64Mcg::seed_from_u64(mix(settings.seed, stream));
                let mut image = Accumulator::new(frame.size);
                for traced in 0..count {
                    walkers[walk].trace(&mut rng, &frame, flux, &mut image);
                    if traced % 1024 == 1023 {
                        progress(done.fetch_add(1024, Ordering::Relaxed) + 1024);
                    }
                }
                done.fetch_add(count % 1024, Ordering::Relaxed);
                image
            })
            .collect();
        for (&(batch, _, _), image) in window.iter().zip(&images) {
            batch_sums[batch].add(image);
        }
    }
    let mut total = Accumulator::new(frame.size);
    let mut batch_means = Vec::with_capacity(batches);
    for batch in &batch_sums {
        // Each batch traced 1/batches of the photons: scale it to a full estimate.
        batch_means.push(frame.region_means(batch, batches as f64));
        total.add(batch);
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
        escaped_fraction: total
            .escaped
            .map(|e| e / (PI * f64::from(radius_mm).powi(2))),
        photons: per_walk * groups.len() as u64,
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// Tasks traced in parallel before their images are summed (bounds the memory: one half
/// image of `f64` RGB per task).
const TASK_WINDOW: usize = 16;

/// Photons one sphere traces: [`SimulationSettings::photons`] shared by the medium's walks
/// (each at least one per task).
pub fn photons_traced(medium: &ScatteringMedium, settings: &SimulationSettings) -> u64 {
    let walks = walks(medium) as u64;
    let tasks = u64::from(settings.batches) * u64::from(settings.chunks_per_batch);
    (settings.photons / walks).max(tasks) * walks
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
        (0..3).map(|c| std::array::from_fn(|k| k == c)).collect()
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

/// Radiance sums per pixel, RGB, of the top half of the image: the scene is mirror-symmetric
/// about the horizontal axis, so a point below it lands in its mirror pixel above.
struct Accumulator {
    size: usize,
    sums: Vec<[f64; 3]>,
    /// Flux that left the sphere, per channel.
    escaped: [f64; 3],
}

impl Accumulator {
    fn new(size: usize) -> Self {
        Self {
            size,
            sums: vec![[0.0; 3]; size * size / 2],
            escaped: [0.0; 3],
        }
    }

    fn add(&mut self, other: &Self) {
        for c in 0..3 {
            self.escaped[c] += other.escaped[c];
        }
        for (a, b) in self.sums.iter_mut().zip(&other.sums) {
            for c in 0..3 {
                a[c] += b[c];
            }
        }
    }

    /// The sums of pixel (column, row), folded into the top half.
    fn at(&self, column: usize, row: usize) -> [f64; 3] {
        let row = row.min(self.size - 1 - row);
        self.sums[row * self.size + column]
    }

    /// Adds `weight · factor` to the pixel under the image-plane point (x, y) mm.
    #[inline]
    fn splat(&mut self, frame: &Frame, x: f64, y: f64, weight: &[f64; 3], factor: f64) {
        let column = (x * frame.px_per_mm + frame.half_size).floor();
        let row = (frame.half_size - y.abs() * frame.px_per_mm).floor();
        if column >= 0.0
            && row >= 0.0
            && column < frame.size as f64
            && row < (frame.size / 2) as f64
        {
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
        for row in 0..self.size / 2 {
            for column in 0..self.size {
                let Some(cos) = self.cos_theta(column, row) else {
                    continue;
                };
                // A top-half pixel holds its own and its mirror's light.
                let value = image.at(column, row).map(|v| 0.5 * v);
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

    /// The accumulated sums as radiance, each pixel the mean of itself and its mirror.
    fn photograph(&self, image: &Accumulator) -> LinearImage {
        let n = self.size;
        let pixels = (0..n * n)
            .map(|index| {
                let value = image.at(index % n, index / n);
                Vec3::from_array(std::array::from_fn(|c| {
                    (0.5 * value[c] / self.pixel_area_mm2) as f32
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
            code_step: CodeStep::Float,
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
    split_rate_per_mm: f64,
    max_scatterings: u32,
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
            max_scatterings: settings.max_scatterings,
            band: settings.band_half_width,
            // The farthest-reaching channel of the walk (the smallest σtr), but never faster
            // than reaching the largest importance at the far side of the sphere.
            split_rate_per_mm: (0..3)
                .filter(|&c| channels[c])
                .map(|c| 1.0 / medium.diffusion_length_mm()[c])
                .fold(f64::INFINITY, f64::min)
                .min(MAX_IMPORTANCE.ln() / (2.0 * radius)),
        }
    }

    /// Traces one photon of flux `flux` per channel from entry to exit or absorption, with the
    /// copies the weight window splits off it.
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
        let start = weight.iter().copied().fold(0.0, f64::max);
        let mut photons = vec![Photon {
            position,
            direction,
            weight,
            scatterings: 0,
        }];
        while let Some(photon) = photons.pop() {
            self.walk(rng, photon, start, frame, image, &mut photons);
        }
    }

    /// The importance of a point: photons there weigh `start / importance` in the weight
    /// window. It grows by e per diffusion length of the walk's farthest-reaching channel
    /// along the light's direction (so that light that does reach the shadow side is sampled
    /// as densely as the lit side), and at most to [`MAX_IMPORTANCE`] at the far side.
    fn importance(&self, x: f64) -> f64 {
        ((x + self.radius) * self.split_rate_per_mm)
            .exp()
            .min(MAX_IMPORTANCE)
    }

    /// One photon's walk until it leaves, is absorbed or ended by roulette; copies split off
    /// go to `pending`.
    fn walk(
        &self,
        rng: &mut Pcg64Mcg,
        photon: Photon,
        start: f64,
        frame: &Frame,
        image: &mut Accumulator,
        pending: &mut Vec<Photon>,
    ) {
        let r = self.radius;
        let Photon {
            mut position,
            mut direction,
            mut weight,
            mut scatterings,
        } = photon;
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
                for c in 0..3 {
                    image.escaped[c] += weight[c];
                }
                if self.estimator == Estimator::ExitPhotons {
                    let out = refract_outward(direction, normal, cos_out, self.eta);
                    self.record_exit(
                        position,
                        out,
                        &weight,
                        1.0 / (4.0 * PI * self.band),
                        frame,
                        image,
                    );
                }
                // The other estimators counted escaping light at the collisions.
                return;
            }
            position += direction * free_path;
            if scatterings >= self.max_scatterings {
                return;
            }
            scatterings += 1;
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
                Estimator::ExitPhotons => {}
            }
            direction = sample_henyey_greenstein(rng, direction, self.g);
            // Weight window: split heavy photons, roulette light ones (both unbiased).
            let target = start / self.importance(position.x);
            let strongest = weight.iter().copied().fold(0.0, f64::max);
            if strongest > 2.0 * target {
                let copies = ((strongest / target) as usize).min(MAX_SPLIT);
                let share = 1.0 / copies as f64;
                for w in &mut weight {
                    *w *= share;
                }
                for _ in 1..copies {
                    pending.push(Photon {
                        position,
                        direction,
                        weight,
                        scatterings,
                    });
                }
            } else if strongest < 0.1 * target {
                let survival = strongest / (0.5 * target);
                if uniform(rng) < survival {
                    for w in &mut weight {
                        *w /= survival;
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
                // A chord keeps its angle to the surface at every bounce inside a sphere: a
                // ray past the critical angle never leaves.
                if reflect >= 1.0 {
                    break;
                }
                {
                    let out = refract_outward(heading, normal, cos_out, self.eta);
                    self.record_exit(
                        point,
                        out,
                        weight,
                        throughput * (1.0 - reflect),
                        frame,
                        image,
                    );
                }
                throughput *= reflect;
                if throughput < 1e-4 * share {
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

/// The weight window's largest importance (splits per photon, at most).
const MAX_IMPORTANCE: f64 = 256.0;

/// The most copies one split makes.
const MAX_SPLIT: usize = 8;

/// A photon in flight.
#[derive(Clone, Copy)]
struct Photon {
    position: DVec3,
    direction: DVec3,
    weight: [f64; 3],
    scatterings: u32,
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

/// The direction of a ray arriving from outside along `direction` after entering a boundary of
/// relative index `eta`; `normal` is the outward normal (facing the ray), `cos_in` = −direction·normal.
fn refract_inward(direction: DVec3, normal: DVec3, cos_in: f64, eta: f64) -> DVec3 {
    let ratio = 1.0 / eta;
    let cos_t = (1.0 - ratio * ratio * (1.0 - cos_in * cos_in))
        .max(0.0)
        .sqrt();
    (direction * ratio + normal * (ratio * cos_in - cos_t)).normalize()
}

/// The outside direction of a ray leaving along `direction` (cos `cos_out` with the outward
/// `normal`, inside the critical angle).
fn refract_outward(direction: DVec3, normal: DVec3, cos_out: f64, eta: f64) -> DVec3 {
    if eta == 1.0 {
        return direction;
    }
    let cos_t = (1.0 - eta * eta * (1.0 - cos_out * cos_out))
        .max(0.0)
        .sqrt();
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
        // A face whose outward normal is −z, hit by a ray travelling into it (+z).
        let outward = DVec3::new(0.0, 0.0, -1.0);
        let incoming = DVec3::new(0.6, 0.0, 0.8);
        let cos_in = -incoming.dot(outward);
        let inside = refract_inward(incoming, outward, cos_in, eta);
        let sin_in = (1.0 - cos_in * cos_in).sqrt();
        let sin_t = (1.0 - inside.z * inside.z).sqrt();
        assert!((sin_in - eta * sin_t).abs() < 1e-12);
        assert!(inside.z > 0.0 && inside.x > 0.0);
        // Leaving again through a parallel face (outward normal +z) restores the direction.
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

    /// Small and quick: a 64 px photograph of a sphere a few mean free paths across.
    fn quick(photons: u64, estimator: Estimator) -> SimulationSettings {
        SimulationSettings {
            photons,
            image_size_px: 64,
            sphere_radius_px: 28.0,
            estimator: Some(estimator),
            ..SimulationSettings::default()
        }
    }

    /// [`quick`] simulated, unwrapped.
    fn simulate_quick(
        medium: &ScatteringMedium,
        radius_mm: f32,
        photons: u64,
        estimator: Estimator,
    ) -> SimulatedSphere {
        simulate_sphere(medium, radius_mm, &quick(photons, estimator), &|_| {}).unwrap()
    }

    fn region_means(sphere: &SimulatedSphere) -> [[f64; 3]; 4] {
        let frame = Frame::new(
            sphere.radius_mm,
            &SimulationSettings {
                image_size_px: sphere.image.width,
                sphere_radius_px: sphere.circle.radius_px,
                ..SimulationSettings::default()
            },
        );
        let mut image = Accumulator::new(frame.size);
        for (index, pixel) in sphere.image.pixels.iter().enumerate() {
            let (row, column) = (index / frame.size, index % frame.size);
            if row < frame.size / 2 {
                image.sums[index] =
                    [0, 1, 2].map(|c| 2.0 * f64::from(pixel[c]) * frame.pixel_area_mm2);
            }
            let _ = column;
        }
        frame.region_means(&image, 1.0)
    }

    /// Two estimates of the lit and terminator means agree within `sigmas` of their combined
    /// standard errors.
    fn assert_agree(a: &SimulatedSphere, b: &SimulatedSphere, sigmas: f64, what: &str) {
        let (ma, mb) = (region_means(a), region_means(b));
        for (region, na, nb) in [
            (0, a.noise.lit, b.noise.lit),
            (1, a.noise.terminator, b.noise.terminator),
        ] {
            for c in 0..3 {
                let error =
                    (f64::from(na[c]) * ma[region][c]).hypot(f64::from(nb[c]) * mb[region][c]);
                let difference = (ma[region][c] - mb[region][c]).abs();
                assert!(
                    difference <= sigmas * error + 1e-12,
                    "{what}: region {region} channel {c}: {} vs {} (± {error})",
                    ma[region][c],
                    mb[region][c]
                );
            }
        }
    }

    fn chromatic_medium(eta: f64) -> ScatteringMedium {
        ScatteringMedium::new([0.95, 1.2, 1.5], [0.02, 0.05, 0.1], 0.3, eta).unwrap()
    }

    #[test]
    fn the_three_estimators_agree_index_matched() {
        let medium = chromatic_medium(1.0);
        let exits = simulate_quick(&medium, 4.0, 600_000, Estimator::ExitPhotons);
        for estimator in [Estimator::ViewRays, Estimator::ExitBand] {
            let other = simulate_quick(&medium, 4.0, 60_000, estimator);
            assert_agree(
                &exits,
                &other,
                4.0,
                &format!("{estimator:?} vs ExitPhotons"),
            );
        }
    }

    #[test]
    fn boundary_rays_follow_fresnel_and_internal_reflection() {
        // η = 1.4: the rays' Fresnel chains against the photons' own Fresnel walk.
        let medium = chromatic_medium(1.4);
        let exits = simulate_quick(&medium, 4.0, 600_000, Estimator::ExitPhotons);
        let rays = simulate_quick(&medium, 4.0, 60_000, Estimator::ExitBand);
        assert_agree(&exits, &rays, 4.0, "ExitBand vs ExitPhotons at eta 1.4");
        // The boundary changes the picture: index-matched is measurably different.
        let matched = simulate_quick(&chromatic_medium(1.0), 4.0, 60_000, Estimator::ExitBand);
        let (a, b) = (region_means(&rays)[0][0], region_means(&matched)[0][0]);
        assert!((a / b - 1.0).abs() > 0.05, "eta 1.4 {a} vs eta 1 {b}");
    }

    #[test]
    fn without_absorption_every_photon_that_enters_leaves() {
        for eta in [1.0, 1.5] {
            let medium = ScatteringMedium::new([2.0; 3], [0.0; 3], 0.5, eta).unwrap();
            // The walk's own tally of escaping light, whatever the estimator: the cheapest.
            let sphere = simulate_quick(&medium, 3.0, 20_000, Estimator::ExitPhotons);
            // What enters: the disk-averaged Fresnel transmittance 2∫(1 − F(μ)) μ dμ.
            let steps = 20_000;
            let entering: f64 = (0..steps)
                .map(|i| {
                    let mu = (i as f64 + 0.5) / steps as f64;
                    2.0 * (1.0 - fresnel_from_outside(mu, eta)) * mu / steps as f64
                })
                .sum();
            for c in 0..3 {
                let ratio = sphere.escaped_fraction[c] / entering;
                assert!((ratio - 1.0).abs() < 2e-3, "eta {eta}: {ratio}");
            }
        }
    }

    /// Chandrasekhar's H-function of isotropic scattering with albedo `a`, by iterating
    /// 1/H(μ) = √(1 − a) + (a/2) ∫₀¹ μ′ H(μ′) / (μ + μ′) dμ′ on a midpoint grid.
    fn chandrasekhar_h(a: f64, mu: f64) -> f64 {
        let n = 400;
        let nodes: Vec<f64> = (0..n).map(|i| (i as f64 + 0.5) / n as f64).collect();
        let mut h = vec![1.0; n];
        let integral = |h: &[f64], mu: f64| -> f64 {
            nodes
                .iter()
                .zip(h)
                .map(|(&m, &hm)| m * hm / (mu + m))
                .sum::<f64>()
                / n as f64
        };
        for _ in 0..200 {
            h = nodes
                .iter()
                .map(|&m| 1.0 / ((1.0 - a).sqrt() + 0.5 * a * integral(&h, m)))
                .collect();
        }
        1.0 / ((1.0 - a).sqrt() + 0.5 * a * integral(&h, mu))
    }

    #[test]
    fn a_large_sphere_reflects_what_a_half_space_does() {
        // Diffusion length ≈ 1.3 mm on a 300 mm sphere: locally a half-space. Its reflectance
        // for collimated light at μ0 is 1 − H(μ0)·√(1 − a) (Chandrasekhar, Radiative Transfer
        // §59), averaged over the disk the beam falls on (weight 2μ0).
        let a: f64 = 0.8;
        let medium = ScatteringMedium::new([a; 3], [1.0 - a; 3], 0.0, 1.0).unwrap();
        let sphere = simulate_quick(&medium, 300.0, 40_000, Estimator::ExitPhotons);
        let steps = 200;
        let expected: f64 = (0..steps)
            .map(|i| {
                let mu = (i as f64 + 0.5) / steps as f64;
                2.0 * mu * (1.0 - chandrasekhar_h(a, mu) * (1.0 - a).sqrt()) / steps as f64
            })
            .sum();
        for c in 0..3 {
            let ratio = sphere.escaped_fraction[c] / expected;
            assert!(
                (ratio - 1.0).abs() < 0.01,
                "{} vs {expected}",
                sphere.escaped_fraction[c]
            );
        }
        // The H-function's zeroth moment has a closed form: ∫H = 2/a·(1 − √(1 − a)).
        let moment: f64 = (0..steps)
            .map(|i| chandrasekhar_h(a, (i as f64 + 0.5) / steps as f64) / steps as f64)
            .sum();
        assert!(
            (moment - 2.0 / a * (1.0 - (1.0 - a).sqrt())).abs() < 1e-3,
            "{moment}"
        );
    }

    #[test]
    fn the_same_seed_gives_the_same_image() {
        let medium = chromatic_medium(1.0);
        let settings = quick(4_000, Estimator::ViewRays);
        let a = simulate_sphere(&medium, 4.0, &settings, &|_| {}).unwrap();
        let b = simulate_sphere(&medium, 4.0, &settings, &|_| {}).unwrap();
        assert_eq!(a.image.pixels, b.image.pixels);
        let other = SimulationSettings {
            seed: 2,
            ..settings
        };
        let c = simulate_sphere(&medium, 4.0, &other, &|_| {}).unwrap();
        assert_ne!(a.image.pixels, c.image.pixels);
    }

    #[test]
    fn bad_media_and_settings_are_typed_errors() {
        assert!(matches!(
            ScatteringMedium::new([-1.0; 3], [0.1; 3], 0.0, 1.0),
            Err(SimulationError::Coefficients { .. })
        ));
        assert!(matches!(
            ScatteringMedium::new([1.0; 3], [f64::NAN; 3], 0.0, 1.0),
            Err(SimulationError::Coefficients { .. })
        ));
        assert!(matches!(
            ScatteringMedium::new([1.0; 3], [0.1; 3], 1.0, 1.0),
            Err(SimulationError::Asymmetry(_))
        ));
        assert!(matches!(
            ScatteringMedium::new([1.0; 3], [0.1; 3], 0.0, 0.5),
            Err(SimulationError::Eta(_))
        ));
        let medium = chromatic_medium(1.0);
        // One batch (no noise estimate), an odd image size, too many batches.
        for bad in [
            SimulationSettings {
                batches: 1,
                ..SimulationSettings::default()
            },
            SimulationSettings {
                image_size_px: 63,
                ..SimulationSettings::default()
            },
            SimulationSettings {
                batches: 1000,
                ..SimulationSettings::default()
            },
        ] {
            assert!(matches!(
                simulate_sphere(&medium, 4.0, &bad, &|_| {}),
                Err(SimulationError::Settings(_))
            ));
        }
        assert!(matches!(
            simulate_sphere(&medium, 0.0, &SimulationSettings::default(), &|_| {}),
            Err(SimulationError::Radius(_))
        ));
        let refracting = chromatic_medium(1.3);
        let view_rays = quick(100, Estimator::ViewRays);
        assert!(matches!(
            simulate_sphere(&refracting, 4.0, &view_rays, &|_| {}),
            Err(SimulationError::Settings(_))
        ));
    }
}
