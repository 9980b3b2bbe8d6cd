//! The whole fit: a data set in, a measured table, a fitted Gaussian CDRF and their errors out.

use std::time::Instant;

use cdrf_core::lut::{CdrfLut, Filter};
use cdrf_core::translucency::Translucency;
use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::curves::{CurveFits, CurveSettings, SphereSamples, fit_curves};
use crate::dataset::{Dataset, SphereEntry};
use crate::diffusion::{
    DiffusionFit, DiffusionFitError, DiffusionSettings, fit_diffusion_curve_fit,
};
use crate::evaluate::{SphereError, sphere_error};
use crate::gaussian_fit::{GaussianFit, fit_gaussian};
use crate::image_io::{ImageError, LinearImage, load_linear_image};
use crate::sphere::{
    Circle, Detection, DetectionError, DroppedPixels, SphereView, detect_sphere, sample_sphere,
};
use crate::table::{TableError, build_table, smooth_curve};
use crate::transmission::{
    TransmissionError, TransmissionFit, TransmissionSettings, fit_curve_fit,
};

/// Settings of a fit. `Default` is what `cdrf-fit` uses.
#[derive(Clone, Debug, PartialEq)]
pub struct FitOptions {
    /// θ resolution, φ resolution and view model of the curve fit.
    pub curves: CurveSettings,
    /// Rows of the table along curvature.
    pub curvature_count: usize,
    /// Pixels closer than this to the silhouette are not used.
    pub edge_margin_px: f32,
    /// How far a manifest's `center_px` / `radius_px` may be from the detected circle.
    pub manifest_tolerance_px: f32,
    /// Fewest usable pixels a sphere must have.
    pub min_samples: usize,
    /// Which shadow-side nodes the transmission profile is fitted to.
    pub transmission: TransmissionSettings,
    /// The basis and entry powers of the diffusion profile fit.
    pub diffusion: DiffusionSettings,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            curves: CurveSettings::default(),
            curvature_count: 64,
            edge_margin_px: 2.0,
            manifest_tolerance_px: 3.0,
            min_samples: 2000,
            transmission: TransmissionSettings::default(),
            diffusion: DiffusionSettings::default(),
        }
    }
}

/// Why a fit failed. Every message names the image (or the manifest) it is about.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FitError {
    /// An image could not be read.
    #[error(transparent)]
    Image(#[from] ImageError),
    /// No sphere was found in an image.
    #[error("{image}: {error}")]
    Detection {
        /// The image.
        image: String,
        /// Why.
        error: DetectionError,
    },
    /// The manifest's circle and the detected one disagree.
    #[error(
        "{image}: the manifest says centre ({:.1}, {:.1}) px, radius {:.1} px, but the sphere in the image is at ({:.1}, {:.1}) px, radius {:.1} px (tolerance {tolerance_px} px): check center_px / radius_px",
        manifest.center_px.x, manifest.center_px.y, manifest.radius_px,
        detected.center_px.x, detected.center_px.y, detected.radius_px
    )]
    ManifestMismatch {
        /// The image.
        image: String,
        /// What the manifest says (missing values filled from the detection).
        manifest: Circle,
        /// What was detected.
        detected: Circle,
        /// The allowed difference.
        tolerance_px: f32,
    },
    /// Too few usable pixels.
    #[error(
        "{image}: only {usable} usable pixels on the sphere (need {needed}); {} saturated, {} invalid, {} at the silhouette",
        dropped.saturated, dropped.invalid, dropped.near_silhouette
    )]
    TooFewSamples {
        /// The image.
        image: String,
        /// Usable pixels.
        usable: usize,
        /// Required.
        needed: usize,
        /// What was dropped.
        dropped: DroppedPixels,
    },
    /// The table could not be built.
    #[error(transparent)]
    Table(#[from] TableError),
    /// The Gaussian fit produced invalid parameters.
    #[error("Gaussian CDRF fit failed: {0}")]
    Gaussian(cdrf_core::gaussian::ParameterError),
}

// The message holds the cause's, which `source()` therefore does not repeat.
impl From<cdrf_core::gaussian::ParameterError> for FitError {
    fn from(error: cdrf_core::gaussian::ParameterError) -> Self {
        Self::Gaussian(error)
    }
}

/// What happened to one sphere.
#[derive(Clone, Debug, Serialize)]
pub struct SphereReport {
    /// Image file name.
    pub image: String,
    /// Radius, mm.
    pub radius_mm: f32,
    /// κ = 1/r, mm⁻¹.
    pub curvature_per_mm: f32,
    /// Image size, pixels.
    pub size_px: [u32; 2],
    /// The detected circle, when detection succeeded.
    pub detected: Option<DetectedCircle>,
    /// The circle used (the manifest's when given, else the detected one).
    pub used_center_px: [f32; 2],
    /// Radius of the circle used, pixels.
    pub used_radius_px: f32,
    /// Usable pixels.
    pub samples: usize,
    /// Pixels dropped before the fit.
    pub dropped: DroppedPixels,
    /// Samples dropped as outliers by the fit.
    pub outliers: usize,
    /// Seconds spent decoding the image.
    pub decode_s: f64,
    /// Seconds spent detecting and sampling the sphere.
    pub sampling_s: f64,
}

/// A detected circle for the report.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct DetectedCircle {
    /// Centre, pixels.
    pub center_px: [f32; 2],
    /// Radius, pixels.
    pub radius_px: f32,
    /// Boundary points used.
    pub edge_points: usize,
    /// Their RMS distance from the circle, pixels.
    pub rms_residual_px: f32,
}

/// Per-sphere errors of the models.
#[derive(Clone, Debug, Serialize)]
pub struct ModelErrors {
    /// The measured table with its view correction, as a renderer uses it (bilinear).
    pub measured: SphereError,
    /// The fitted Gaussian CDRF with the same view correction.
    pub gaussian: SphereError,
    /// The curve fit with the poster's g(φ) only (before tabulation).
    pub poster_view_fit: SphereError,
    /// The curve fit with the chosen view model (before tabulation).
    pub chosen_view_fit: SphereError,
}

/// Wall time per stage, seconds.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Timings {
    /// Decoding images (summed over images; overlapped with sampling).
    pub decode_s: f64,
    /// Detecting spheres and sampling pixels (summed over images; overlapped with decoding).
    pub sampling_s: f64,
    /// Fitting curves and view correction.
    pub curves_s: f64,
    /// Building the table.
    pub table_s: f64,
    /// Fitting the Gaussian CDRF.
    pub gaussian_s: f64,
    /// Fitting the transmission profile.
    pub transmission_s: f64,
    /// Fitting the diffusion profile.
    pub diffusion_s: f64,
    /// Measuring errors.
    pub evaluation_s: f64,
    /// Everything.
    pub total_s: f64,
}

/// The result of a fit.
#[derive(Clone, Debug)]
pub struct Fit {
    /// The measured table (with view correction and coverage).
    pub lut: CdrfLut,
    /// The Gaussian CDRF fitted to the same samples.
    pub gaussian: GaussianFit,
    /// The transmission profile fitted to the shadow sides, or why it could not be. When it
    /// was, `lut` carries it with Kubo's σ as the scattering length
    /// ([`CdrfLut::translucency`]); when not, the table has no translucency and the fit
    /// goes on (a data set of large or nearly opaque spheres still gives a table).
    pub transmission: Result<TransmissionFit, TransmissionError>,
    /// The settings the transmission fit ran with (also when it failed).
    pub transmission_settings: TransmissionSettings,
    /// The diffusion profile fitted to all spheres' curves, or why it could not be. When it
    /// was, `lut` carries the profile ([`CdrfLut::diffusion_profile`]).
    pub diffusion: Result<DiffusionFit, DiffusionFitError>,
    /// The settings the profile fit ran with (also when it failed).
    pub diffusion_settings: DiffusionSettings,
    /// The fitted curves (chosen model and the poster's).
    pub curves: CurveFits,
    /// The chosen fit's curves as they entered the table (filled and smoothed along θ), per
    /// sphere.
    pub table_curves: Vec<Vec<Vec3>>,
    /// The samples, per sphere (input order).
    pub samples: Vec<SphereSamples>,
    /// What happened to each sphere.
    pub spheres: Vec<SphereReport>,
    /// Errors of each model on each sphere.
    pub errors: Vec<ModelErrors>,
    /// Where the time went.
    pub timings: Timings,
}

/// Progress of a fit, for a progress bar.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Progress {
    /// Sphere `index` of `count` was read and sampled.
    SphereSampled {
        /// 0-based.
        index: usize,
        /// Spheres in all.
        count: usize,
    },
    /// All spheres are sampled; the fit itself runs.
    Fitting,
}

/// A decoded image and how long decoding took.
type Decoded = (Result<LinearImage, ImageError>, f64);

fn decode(entry: &SphereEntry) -> Decoded {
    let started = Instant::now();
    let image = load_linear_image(&entry.image, entry.color_space, entry.exposure);
    (image, started.elapsed().as_secs_f64())
}

/// Detects and samples one decoded sphere, keeping nothing of the image but its samples.
fn sample_entry(
    dataset: &Dataset,
    entry: &SphereEntry,
    options: &FitOptions,
    (image, decode_s): Decoded,
) -> Result<(SphereSamples, SphereReport), FitError> {
    let image = image?;
    let started = Instant::now();
    let (width, height) = (image.width as usize, image.height as usize);
    let detection = detect_sphere(width, height, &image.pixels);
    let circle = match (&detection, entry.center_px, entry.radius_px) {
        (Ok(found), center, radius) => {
            let manifest = Circle {
                center_px: center.unwrap_or(found.circle.center_px),
                radius_px: radius.unwrap_or(found.circle.radius_px),
            };
            let off = (manifest.center_px - found.circle.center_px).length()
                + (manifest.radius_px - found.circle.radius_px).abs();
            if off.is_nan() || off > options.manifest_tolerance_px {
                return Err(FitError::ManifestMismatch {
                    image: entry.image_name.clone(),
                    manifest,
                    detected: found.circle,
                    tolerance_px: options.manifest_tolerance_px,
                });
            }
            manifest
        }
        // A manifest that gives the whole circle stands on its own.
        (Err(_), Some(center_px), Some(radius_px)) => Circle {
            center_px,
            radius_px,
        },
        (Err(error), _, _) => {
            return Err(FitError::Detection {
                image: entry.image_name.clone(),
                error: error.clone(),
            });
        }
    };
    // Silhouette points only when the circle used is the detected one.
    let silhouette = match (&detection, entry.center_px, entry.radius_px) {
        (Ok(found), None, None) => found.edge_points.as_slice(),
        _ => &[],
    };
    let view =
        SphereView::with_silhouette(circle, dataset.camera.projection, width, height, silhouette);
    let (samples, dropped) = sample_sphere(&view, &image, &dataset.light, options.edge_margin_px);
    if samples.len() < options.min_samples {
        return Err(FitError::TooFewSamples {
            image: entry.image_name.clone(),
            usable: samples.len(),
            needed: options.min_samples,
            dropped,
        });
    }
    let sampling_s = started.elapsed().as_secs_f64();
    let detected = detection.ok().map(|d: Detection| DetectedCircle {
        center_px: d.circle.center_px.to_array(),
        radius_px: d.circle.radius_px,
        edge_points: d.edge_points.len(),
        rms_residual_px: d.rms_residual_px,
    });
    let report = SphereReport {
        image: entry.image_name.clone(),
        radius_mm: entry.radius_mm,
        curvature_per_mm: 1.0 / entry.radius_mm,
        size_px: [image.width, image.height],
        detected,
        used_center_px: circle.center_px.to_array(),
        used_radius_px: circle.radius_px,
        samples: samples.len(),
        dropped,
        outliers: 0,
        decode_s,
        sampling_s,
    };
    Ok((
        SphereSamples {
            curvature_per_mm: 1.0 / entry.radius_mm,
            image_width: image.width,
            samples,
        },
        report,
    ))
}

/// Fits a data set: samples every sphere (at most two decoded images in memory at a time), fits the curves and
/// view correction, builds the table, fits the Gaussian CDRF and the transmission profile
/// (attached to the table as its translucency when it succeeds; see [`Fit::transmission`]),
/// and measures both models on every sphere.
///
/// # Errors
/// When an image cannot be read, shows no sphere (or not where the manifest says), has too few
/// usable pixels, or the table cannot be built (e.g. two spheres with the same radius).
pub fn fit_dataset(
    dataset: &Dataset,
    options: &FitOptions,
    mut progress: impl FnMut(Progress),
) -> Result<Fit, FitError> {
    let started = Instant::now();
    let mut timings = Timings::default();
    let mut samples = Vec::with_capacity(dataset.spheres.len());
    let mut spheres = Vec::with_capacity(dataset.spheres.len());
    // Decode the next image while sampling this one: two images in memory at most.
    let entries = &dataset.spheres;
    let mut next = entries.first().map(decode);
    for (index, entry) in entries.iter().enumerate() {
        let Some(decoded) = next.take() else { break };
        let (sampled, following) = rayon::join(
            || sample_entry(dataset, entry, options, decoded),
            || entries.get(index + 1).map(decode),
        );
        next = following;
        let (sphere_samples, report) = sampled?;
        timings.decode_s += report.decode_s;
        timings.sampling_s += report.sampling_s;
        samples.push(sphere_samples);
        spheres.push(report);
        progress(Progress::SphereSampled {
            index,
            count: entries.len(),
        });
    }
    progress(Progress::Fitting);
    let fit = fit_samples(samples, spheres, options, timings)?;
    Ok(Fit {
        timings: Timings {
            total_s: started.elapsed().as_secs_f64(),
            ..fit.timings
        },
        ..fit
    })
}

/// The fit from already sampled spheres (what [`fit_dataset`] does after reading images).
///
/// # Errors
/// When the table cannot be built or the Gaussian fit fails. A transmission profile that cannot
/// be fitted is no error: [`Fit::transmission`] says why and the table has no translucency.
pub fn fit_samples(
    samples: Vec<SphereSamples>,
    mut spheres: Vec<SphereReport>,
    options: &FitOptions,
    mut timings: Timings,
) -> Result<Fit, FitError> {
    let started = Instant::now();
    let curves = fit_curves(&samples, options.curves);
    timings.curves_s = started.elapsed().as_secs_f64();
    for (report, outliers) in spheres.iter_mut().zip(&curves.chosen.outliers) {
        report.outliers = *outliers;
    }

    let started = Instant::now();
    let curvatures: Vec<f32> = samples.iter().map(|s| s.curvature_per_mm).collect();
    let table_curves: Vec<Vec<Vec3>> = (0..samples.len())
        .map(|k| smooth_curve(&curves.chosen, k))
        .collect();
    let lut = build_table(
        &curves.chosen,
        &table_curves,
        &curvatures,
        options.curvature_count,
    )?;
    timings.table_s = started.elapsed().as_secs_f64();

    let started = Instant::now();
    let gaussian = fit_gaussian(&samples, &curves.chosen)?;
    timings.gaussian_s = started.elapsed().as_secs_f64();

    let started = Instant::now();
    let transmission = fit_curve_fit(&curves.chosen, &curvatures, &options.transmission).and_then(
        |transmission| {
            let translucency = Translucency::new(gaussian.model.sigma_mm(), transmission.profile)?;
            Ok((transmission, translucency))
        },
    );
    let (lut, transmission) = match transmission {
        Ok((transmission, translucency)) => (lut.with_translucency(translucency), Ok(transmission)),
        Err(error) => (lut, Err(error)),
    };
    timings.transmission_s = started.elapsed().as_secs_f64();

    let started = Instant::now();
    let diffusion = fit_diffusion_curve_fit(&curves.chosen, &curvatures, &options.diffusion);
    let lut = match &diffusion {
        Ok(fit) => lut.with_diffusion_profile(fit.profile.clone()),
        Err(_) => lut,
    };
    timings.diffusion_s = started.elapsed().as_secs_f64();

    let started = Instant::now();
    let errors = samples
        .par_iter()
        .enumerate()
        .map(|(k, sphere)| {
            let curvature = sphere.curvature_per_mm;
            let view = |theta: f32, phi: f32| lut.view_correction().sample(curvature, theta, phi);
            ModelErrors {
                measured: sphere_error(sphere, |theta, phi| {
                    lut.evaluate(curvature, theta, phi, Filter::Bilinear)
                }),
                gaussian: {
                    // The Gaussian at this sphere's curvature on a fine θ grid (0.1°), read
                    // linearly: far below the data's noise, and 100× cheaper than the kernel.
                    let curve: Vec<Vec3> = (0..=1800)
                        .map(|i| {
                            let theta = std::f32::consts::PI * i as f32 / 1800.0;
                            Vec3::from_array(cdrf_core::Cdrf::reflectance(
                                &gaussian.model,
                                curvature,
                                theta,
                            ))
                        })
                        .collect();
                    sphere_error(sphere, |theta, phi| {
                        let u = (theta / std::f32::consts::PI * 1800.0).clamp(0.0, 1800.0);
                        let i = (u as usize).min(1799);
                        curve[i].lerp(curve[i + 1], u - i as f32) * view(theta, phi)
                    })
                },
                poster_view_fit: sphere_error(sphere, |theta, phi| {
                    curves.poster.model(k, theta, phi)
                }),
                chosen_view_fit: sphere_error(sphere, |theta, phi| {
                    curves.chosen.model(k, theta, phi)
                }),
            }
        })
        .collect();
    timings.evaluation_s = started.elapsed().as_secs_f64();
    timings.total_s += timings.curves_s
        + timings.table_s
        + timings.gaussian_s
        + timings.transmission_s
        + timings.diffusion_s
        + timings.evaluation_s;

    Ok(Fit {
        lut,
        gaussian,
        transmission,
        transmission_settings: options.transmission,
        diffusion,
        diffusion_settings: options.diffusion.clone(),
        curves,
        table_curves,
        samples,
        spheres,
        errors,
        timings,
    })
}
