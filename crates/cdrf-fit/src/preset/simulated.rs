//! A preset from simulated photographs: [`crate::simulation`] renders the spheres a technical
//! artist would have photographed, and the unchanged fit ([`crate::fit::fit_samples`]) turns
//! them into a table. The images are sampled exactly as photographs are ([`sample_sphere`] on
//! the same [`crate::sphere::SphereView`]), so the table has everything a measured one has:
//! the view correction, the transmission `T(d, μ)` and the diffusion profile `R(d)`.

use std::sync::atomic::{AtomicU64, Ordering};

use serde::Serialize;

use crate::curves::SphereSamples;
use crate::fit::{Fit, FitError, FitOptions, SphereReport, Timings, fit_samples};
use crate::simulation::{
    Estimator, ScatteringMedium, SimulationError, SimulationNoise, SimulationSettings,
    photons_traced, simulate_sphere, simulated_light,
};
use crate::sphere::sample_sphere;

/// The radii of the bundled wax photographs (`data/wax-spheres`), mm: a preset's default
/// sphere set, so that its table spans the curvatures the bundled fit's does.
pub const BUNDLED_RADII_MM: [f32; 12] = [
    5.0, 7.5, 10.0, 12.5, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0, 45.0, 50.0,
];

/// What to simulate and how to fit it.
#[derive(Clone, Debug, PartialEq)]
pub struct SimulatedSettings {
    /// Sphere radii, mm (at least two, all different).
    pub radii_mm: Vec<f32>,
    /// Photons, seed and image of every sphere.
    pub simulation: SimulationSettings,
    /// The fit's settings, as `cdrf-fit` uses them by default.
    pub fit: FitOptions,
}

impl Default for SimulatedSettings {
    fn default() -> Self {
        Self {
            radii_mm: BUNDLED_RADII_MM.to_vec(),
            simulation: SimulationSettings::default(),
            fit: FitOptions::default(),
        }
    }
}

/// What the simulation of one sphere reached.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SimulatedSphereReport {
    /// Radius, mm.
    pub radius_mm: f32,
    /// The estimator used.
    pub estimator: Estimator,
    /// Photons traced (all walks).
    pub photons: u64,
    /// Relative standard error of the mean radiance per region.
    pub noise: SimulationNoise,
    /// Wall time, seconds.
    pub seconds: f64,
}

/// The fit of simulated spheres and what their simulation reached.
#[derive(Clone, Debug)]
pub struct SimulatedFit {
    /// The fit, as of photographs.
    pub fit: Fit,
    /// Per sphere, in the order of [`SimulatedSettings::radii_mm`].
    pub spheres: Vec<SimulatedSphereReport>,
}

/// Why a simulated preset failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SimulatedFitError {
    /// The medium or the settings cannot be simulated.
    #[error(transparent)]
    Simulation(#[from] SimulationError),
    /// Fewer than two radii, or two equal.
    #[error("simulated spheres: give at least two different radii (got {0:?})")]
    Radii(Vec<f32>),
    /// The fit failed.
    #[error("fitting the simulated spheres: {0}")]
    Fit(#[from] FitError),
}

/// The views more grazing than this (φ, degrees) are left out of the fit of a medium with a
/// refracting boundary: there the Fresnel transmittance falls to nothing (η = 1.3: 12 % is
/// reflected at 70°, 55 % at 85°) and the view correction would divide by it.
pub const MAX_VIEW_ANGLE_WITH_FRESNEL_DEG: f32 = 70.0;

/// The silhouette margin in pixels: the fit's, and for η ≠ 1 at least what leaves views past
/// [`MAX_VIEW_ANGLE_WITH_FRESNEL_DEG`] out.
fn edge_margin_px(
    medium: &ScatteringMedium,
    sphere: &crate::simulation::SimulatedSphere,
    settings: &SimulatedSettings,
) -> f32 {
    let margin = settings.fit.edge_margin_px;
    if medium.eta == 1.0 {
        return margin;
    }
    let grazing =
        sphere.circle.radius_px * (1.0 - MAX_VIEW_ANGLE_WITH_FRESNEL_DEG.to_radians().sin());
    margin.max(grazing)
}

/// Photons all spheres of `settings` trace for `medium` (the progress bar's length).
pub fn total_photons(medium: &ScatteringMedium, settings: &SimulatedSettings) -> u64 {
    photons_traced(medium, &settings.simulation) * settings.radii_mm.len() as u64
}

/// Simulates every sphere of `settings` and fits them. `progress` gets the photons traced so
/// far, out of [`total_photons`].
///
/// # Errors
/// When the settings are out of range, the radii are fewer than two or repeat, or the fit
/// fails.
pub fn fit_simulated(
    medium: &ScatteringMedium,
    settings: &SimulatedSettings,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<SimulatedFit, SimulatedFitError> {
    let radii = &settings.radii_mm;
    let distinct = radii
        .iter()
        .enumerate()
        .all(|(i, a)| radii[..i].iter().all(|b| a != b));
    if radii.len() < 2 || !distinct {
        return Err(SimulatedFitError::Radii(radii.clone()));
    }
    let done = AtomicU64::new(0);
    let light = simulated_light();
    let mut samples = Vec::with_capacity(radii.len());
    let mut reports = Vec::with_capacity(radii.len());
    let mut spheres = Vec::with_capacity(radii.len());
    for &radius_mm in radii {
        let before = done.load(Ordering::Relaxed);
        let sphere = simulate_sphere(medium, radius_mm, &settings.simulation, &|traced| {
            progress(before + traced);
        })?;
        done.fetch_add(sphere.photons, Ordering::Relaxed);
        let view = sphere.view();
        let (sphere_samples, dropped) = sample_sphere(
            &view,
            &sphere.image,
            &light,
            edge_margin_px(medium, &sphere, settings),
            None,
            false,
            None,
        );
        let name = format!("simulated sphere r = {radius_mm} mm");
        if sphere_samples.len() < settings.fit.min_samples {
            return Err(FitError::TooFewSamples {
                image: name,
                usable: sphere_samples.len(),
                needed: settings.fit.min_samples,
                dropped,
            }
            .into());
        }
        reports.push(SphereReport {
            image: name,
            radius_mm,
            curvature_per_mm: 1.0 / radius_mm,
            size_px: [sphere.image.width, sphere.image.height],
            detected: None,
            used_center_px: sphere.circle.center_px.to_array(),
            center_mm: None,
            used_radius_px: sphere.circle.radius_px,
            samples: sphere_samples.len(),
            dropped,
            outliers: 0,
            decode_s: 0.0,
            sampling_s: 0.0,
        });
        samples.push(SphereSamples {
            curvature_per_mm: 1.0 / radius_mm,
            image_width: sphere.image.width,
            samples: sphere_samples,
        });
        spheres.push(SimulatedSphereReport {
            radius_mm,
            estimator: sphere.estimator,
            photons: sphere.photons,
            noise: sphere.noise,
            seconds: sphere.seconds,
        });
    }
    let fit = fit_samples(samples, reports, &settings.fit, Timings::default())?;
    Ok(SimulatedFit { fit, spheres })
}
