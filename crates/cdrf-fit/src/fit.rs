//! The whole fit: a data set in, a measured table, a fitted Gaussian CDRF and their errors out.

use std::time::Instant;

use cdrf_core::lut::{CdrfLut, Filter, theta_rad_at};
use cdrf_core::translucency::Translucency;
use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::curves::{
    self, CurveFit, CurveFits, CurveSettings, SphereSamples, ViewModel, fit_curves, median,
};
use crate::dataset::Dataset;
use crate::diffusion::{
    DiffusionFit, DiffusionFitError, DiffusionSettings, fit_diffusion_curve_fit,
};
use crate::evaluate::{SphereError, sphere_error};
use crate::gaussian_fit::{GaussianFit, fit_gaussian};
use crate::image_io::ImageError;
use crate::photographs::LightReport;
use crate::photographs::sample_dataset;
use crate::sphere::{Circle, DetectionError, DroppedPixels};
use crate::table::{TableError, build_table, smooth_curve};
use crate::tails;
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
    /// A mask or a flagged frame is not the size of its photograph. The message reads
    /// `IMAGE: KEY FILE is W×H px but the photograph is W×H px`.
    #[error("{image}: {key} {} is {}×{} px but the photograph is {}×{} px", file.display(), file_size[0], file_size[1], image_size[0], image_size[1])]
    CompanionSize {
        /// The photograph.
        image: String,
        /// The manifest key that names the file: `mask` or `ambient_image`.
        key: &'static str,
        /// The file.
        file: std::path::PathBuf,
        /// Its size.
        file_size: [u32; 2],
        /// The photograph's size.
        image_size: [u32; 2],
    },
    /// The reference sphere could not calibrate the light.
    #[error("{image}: calibration: {problem}")]
    Calibration {
        /// The reference sphere's photograph.
        image: String,
        /// Why.
        problem: String,
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
    /// The sphere's centre in camera space, mm (perspective photographs only).
    pub center_mm: Option<[f32; 3]>,
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
    /// How the light was known (`None` for samples that did not come from a data set).
    pub light: Option<LightReport>,
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
    /// Per sphere, the θ (degrees) from which its table curve is the diffusion profile's
    /// continuation, not the photograph ([`crate::tails`]); `None`: not continued (measured to
    /// 180°, or no diffusion profile could be fitted).
    pub continued_from_theta_deg: Vec<Option<f32>>,
    /// The samples, per sphere (input order); where a camera was not at 90° to the light, as a
    /// camera there would have seen them (the view's azimuth divided out).
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

/// Fits a data set: samples every photograph (at most two decoded images in memory at a time),
/// calibrates the light where the manifest has a reference sphere, fits the curves and view
/// correction, builds the table, fits the Gaussian CDRF and the transmission profile (attached
/// to the table as its translucency when it succeeds; see [`Fit::transmission`]), and measures
/// both models on every sphere.
///
/// # Errors
/// When an image or mask cannot be read, shows no sphere (or not where the manifest says), has
/// too few usable pixels, the calibration sphere gives no usable light, or the table cannot be
/// built (e.g. two spheres with the same radius).
pub fn fit_dataset(
    dataset: &Dataset,
    options: &FitOptions,
    mut progress: impl FnMut(Progress),
) -> Result<Fit, FitError> {
    let started = Instant::now();
    let sampled = sample_dataset(dataset, options, &mut progress)?;
    progress(Progress::Fitting);
    let fit = fit_samples(sampled.samples, sampled.spheres, options, sampled.timings)?;
    Ok(Fit {
        light: Some(sampled.light),
        timings: Timings {
            total_s: started.elapsed().as_secs_f64(),
            ..fit.timings
        },
        ..fit
    })
}

/// Refits after dividing the view's azimuth out: each pass reads the flow from the last fit.
const AZIMUTH_PASSES: usize = 2;

/// The view model the photographs can separate from f: the θ-dependent correction c(θ, φ)
/// needs θ and φ to vary independently across the disk, as with the camera at 90° to the
/// light. With the lamp more than about 15° from 90° to the camera, either side (median |v·l|
/// above 0.25), they move together, c absorbs part of f, and the fit takes the poster's g(φ)
/// alone, whatever the settings asked for (on the several-sphere capture, lamp 53–62° from the
/// camera, c(θ, φ) swung the blue lit side of the 10 mm sphere by 10 % for a 0.4 px change of
/// its circle).
fn identifiable(settings: CurveSettings, samples: &[SphereSamples]) -> CurveSettings {
    let mut cosines: Vec<f32> = samples
        .iter()
        .flat_map(|sphere| sphere.samples.iter().map(|s| s.view_dot_light.abs()))
        .collect();
    if median(&mut cosines).is_some_and(|m| m > 0.25) {
        CurveSettings {
            view_model: ViewModel::Phi,
            ..settings
        }
    } else {
        settings
    }
}

/// Whether any photograph's camera is more than about 1° from 90° to the light.
fn seen_off_right_angle(samples: &[SphereSamples]) -> bool {
    samples
        .iter()
        .flat_map(|sphere| &sphere.samples)
        .any(|sample| sample.view_dot_light.abs() > 0.02)
}

/// The samples as a camera at 90° to the light would have seen them, which is what a table
/// holds and the renderer's view azimuth starts from (`cdrf_core::azimuth`): each divided by
/// the factor at its own θ and view, with ℓ·(−∂ ln f/∂θ) (`flows`, per sphere on the curves' θ
/// nodes) from the curves fitted so far.
fn divide_view_azimuth(photographed: &[SphereSamples], flows: &[Vec<Vec3>]) -> Vec<SphereSamples> {
    photographed
        .iter()
        .zip(flows)
        .map(|(sphere, flow)| {
            let mut out = sphere.clone();
            for sample in &mut out.samples {
                let factor = cdrf_core::azimuth::factor(
                    sphere.curvature_per_mm,
                    curves::on_theta_nodes(flow, sample.theta_rad),
                    sample.theta_rad,
                    sample.view_dot_light,
                );
                sample.divide(factor);
            }
            out
        })
        .collect()
}

/// The fit from already sampled spheres (what [`fit_dataset`] does after reading images).
///
/// # Errors
/// When the table cannot be built or the Gaussian fit fails. A transmission profile that cannot
/// be fitted is no error: [`Fit::transmission`] says why and the table has no translucency.
pub fn fit_samples(
    mut samples: Vec<SphereSamples>,
    mut spheres: Vec<SphereReport>,
    options: &FitOptions,
    mut timings: Timings,
) -> Result<Fit, FitError> {
    let started = Instant::now();
    let curvatures: Vec<f32> = samples.iter().map(|s| s.curvature_per_mm).collect();
    let settings = identifiable(options.curves, &samples);
    let mut curves = fit_curves(&samples, settings);
    if seen_off_right_angle(&samples) {
        let photographed = samples.clone();
        for _ in 0..AZIMUTH_PASSES {
            // ℓ from the profile of the curves so far (0 for an opaque material).
            let length = cdrf_core::azimuth::flux_length_mm(
                fit_diffusion_curve_fit(&curves.chosen, &curvatures, &options.diffusion)
                    .ok()
                    .map(|fit| fit.profile.mean_distance_mm()),
            );
            let flows: Vec<Vec<Vec3>> = (0..samples.len())
                .map(|k| {
                    cdrf_core::azimuth::flow_mm_per_rad(&smooth_curve(&curves.chosen, k), length)
                })
                .collect();
            samples = divide_view_azimuth(&photographed, &flows);
            curves = fit_curves(&samples, settings);
        }
    }
    timings.curves_s = started.elapsed().as_secs_f64();
    for (report, outliers) in spheres.iter_mut().zip(&curves.chosen.outliers) {
        report.outliers = *outliers;
    }

    // The profile first: the table continues with it where the photographs could not measure.
    let started = Instant::now();
    let diffusion = fit_diffusion_curve_fit(&curves.chosen, &curvatures, &options.diffusion);
    timings.diffusion_s = started.elapsed().as_secs_f64();

    let started = Instant::now();
    let mut table_curves: Vec<Vec<Vec3>> = (0..samples.len())
        .map(|k| smooth_curve(&curves.chosen, k))
        .collect();
    let continued_from = match &diffusion {
        Ok(diffusion) => {
            let cuts = tails::cuts(&curves.chosen);
            tails::continue_curves(&mut table_curves, &curvatures, &cuts, &diffusion.profile);
            cuts
        }
        Err(_) => vec![None; samples.len()],
    };
    let continued_from_theta_deg = continued_from
        .iter()
        .map(|cut| cut.map(|i| theta_rad_at(i, settings.theta_count).to_degrees()))
        .collect();
    let lut = build_table(
        &tails::coverage_fit(&curves.chosen, &continued_from),
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

    let lut = match &diffusion {
        Ok(fit) => lut.with_diffusion_profile(fit.profile.clone()),
        Err(_) => lut,
    };

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
        light: None,
        lut,
        gaussian,
        transmission,
        transmission_settings: options.transmission,
        diffusion,
        diffusion_settings: options.diffusion.clone(),
        curves,
        table_curves,
        continued_from_theta_deg,
        samples,
        spheres,
        errors,
        timings,
    })
}

/// The band [`noisy_ranges`] warns above: ±10 %.
pub const NOISY_BAND: f32 = 0.1;

/// A θ node's 95 % confidence band, relative to the curve: a noise part that shrinks as
/// pixels add up, and a systematic part that does not.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeBand {
    /// 1.96 · σ / √n, with σ the node's relative per-pixel noise (robust, from the fit's
    /// residuals) and n its effective pixel count — what a bootstrap over the pixels gives when
    /// their noise is independent.
    pub noise: f32,
    /// What the files' codes can have shifted the curve by, relative
    /// ([`crate::curves::code_bias_bound`]): where the sensor's noise is smaller than a code
    /// (a noiseless or an 8-bit file's dark end) rounding, and JPEG's compression anywhere,
    /// bias every pixel alike.
    pub systematic: f32,
}

impl NodeBand {
    /// The band's half-width, relative: noise and systematic parts added.
    pub fn half_width(self) -> f32 {
        self.noise + self.systematic
    }

    /// The band of an average over `bands`: the noise parts pool like independent
    /// measurements (inverse variances add), the systematic parts average with the same weights.
    pub fn pool(bands: impl IntoIterator<Item = NodeBand>) -> Option<NodeBand> {
        let (mut information, mut systematic) = (0.0_f32, 0.0_f32);
        for band in bands {
            let weight = 1.0 / (band.noise * band.noise).max(1e-12);
            information += weight;
            systematic += weight * band.systematic;
        }
        (information > 0.0).then(|| NodeBand {
            noise: information.sqrt().recip(),
            systematic: systematic / information,
        })
    }
}

/// Sphere `k`'s 95 % band at each θ node; `None` where the node was filled, not measured.
pub fn confidence_95(fit: &CurveFit, k: usize) -> Vec<Option<NodeBand>> {
    (0..fit.node_samples[k].len())
        .map(|a| {
            let n = fit.node_samples[k][a];
            (n >= 1.0).then(|| NodeBand {
                noise: 1.96 * fit.node_noise[k][a].max_element() / n.sqrt(),
                systematic: (fit.node_code_bias_sum[k][a] / fit.node_model_sum[k][a]).max_element(),
            })
        })
        .collect()
}

/// The flagged frame's light over the curve's (all channels, pooled over ±1°) above which
/// [`room_dominated_ranges`] warns. A flag also shades a ring of the room around the sphere's
/// own shadow, so it leaves part of the room's light, a bias no band counts; where the room
/// gave the sphere three times the lamp's light, a flag that left 5 % of it is 15 % off, the
/// shadow side's bound of issue 38 (docs/research/captures.md has the captures' figures).
pub const ROOM_DOMINATED: f32 = 3.0;

/// The θ ranges (degrees, from the node angles `theta_deg`) of sphere `k` where the flagged
/// frame carried more than [`ROOM_DOMINATED`] times the curve's light, pooled over ±1° and the
/// three channels; merged like [`noisy_ranges`].
pub fn room_dominated_ranges(fit: &CurveFit, k: usize, theta_deg: &[f32]) -> Vec<[f32; 2]> {
    let half = one_degree_nodes(theta_deg);
    merged_ranges(theta_deg, |i| room_dominated_node(fit, k, i, half))
}

/// Whether node `i` of sphere `k` was measured and its flagged frame carried more than
/// [`ROOM_DOMINATED`] times the curve's light, pooled over `half` nodes each side.
fn room_dominated_node(fit: &CurveFit, k: usize, i: usize, half: usize) -> bool {
    let (ambient, model) = (&fit.node_ambient_sum[k], &fit.node_model_sum[k]);
    let window = i.saturating_sub(half)..(i + half + 1).min(model.len());
    let light: f32 = ambient[window.clone()]
        .iter()
        .map(|v| v.element_sum())
        .sum();
    let curve: f32 = model[window].iter().map(|v| v.element_sum()).sum();
    fit.node_samples[k][i] >= 1.0 && light > ROOM_DOMINATED * curve
}

/// Where the shadow side sets the diffusion profile's long terms (how far light travels under
/// the surface, which the gather, the transmission and every continuation past a cut read):
/// from this θ, degrees, on a sphere lit from the side only light that crossed the body is left.
pub const DEEP_SHADOW_FROM_DEG: f32 = 110.0;

/// Below this many degrees of deep shadow side measured on any sphere
/// ([`measured_deep_shadow_deg`]), the profile's long terms are the fit's guess: the CLI warns.
pub const DEEP_SHADOW_MIN_DEG: f32 = 10.0;

/// The most degrees of shadow side past [`DEEP_SHADOW_FROM_DEG`] that one sphere of `fit` has
/// measured: nodes with samples, before the sphere's cut ([`tails::cuts`]: its band narrower
/// than the continuation's limit) and not dominated by the room's light. A photograph of
/// several lit spheres can have none: each sphere's neighbours light its shadow side.
pub fn measured_deep_shadow_deg(fit: &CurveFit) -> f32 {
    let theta_deg = theta_nodes_deg(fit.settings.theta_count);
    let half = one_degree_nodes(&theta_deg);
    let step = theta_deg.get(1).map_or(0.0, |t| t - theta_deg[0]);
    tails::cuts(fit)
        .iter()
        .enumerate()
        .map(|(k, cut)| {
            let end = cut.unwrap_or(theta_deg.len());
            let measured = (0..end)
                .filter(|&i| theta_deg[i] >= DEEP_SHADOW_FROM_DEG)
                .filter(|&i| fit.node_samples[k][i] >= 1.0)
                .filter(|&i| !room_dominated_node(fit, k, i, half))
                .count();
            measured as f32 * step
        })
        .fold(0.0, f32::max)
}

/// The θ ranges (degrees, from the node angles `theta_deg`) where the band, pooled over ±1°
/// (the table's curves are smoothed over about that), is wider than `limit`; ranges less than
/// 5° apart are merged.
pub fn noisy_ranges(band: &[Option<NodeBand>], theta_deg: &[f32], limit: f32) -> Vec<[f32; 2]> {
    let half = one_degree_nodes(theta_deg);
    merged_ranges(theta_deg, |i| {
        band[i].is_some() && pooled_band(band, i, half).is_some_and(|b| b.half_width() > limit)
    })
}

/// The band at node `i` pooled with the nodes within `half` of it; `None` where none of them
/// was measured.
pub(crate) fn pooled_band(band: &[Option<NodeBand>], i: usize, half: usize) -> Option<NodeBand> {
    let window = &band[i.saturating_sub(half)..(i + half + 1).min(band.len())];
    NodeBand::pool(window.iter().flatten().copied())
}

/// The angles, degrees, of `n` uniform θ nodes over [0°, 180°].
pub(crate) fn theta_nodes_deg(n: usize) -> Vec<f32> {
    (0..n).map(|i| theta_rad_at(i, n).to_degrees()).collect()
}

/// How many nodes of `theta_deg` make 1°.
pub(crate) fn one_degree_nodes(theta_deg: &[f32]) -> usize {
    let step = theta_deg.get(1).map_or(1.0, |t| t - theta_deg[0]).max(1e-3);
    (1.0 / step).round().max(0.0) as usize
}

/// The ranges of `theta_deg` where `selected(node)` holds, those less than 5° apart merged.
fn merged_ranges(theta_deg: &[f32], selected: impl Fn(usize) -> bool) -> Vec<[f32; 2]> {
    let mut ranges: Vec<[f32; 2]> = Vec::new();
    for (i, &theta) in theta_deg.iter().enumerate() {
        if !selected(i) {
            continue;
        }
        match ranges.last_mut() {
            Some(last) if theta - last[1] < 5.0 => last[1] = theta,
            _ => ranges.push([theta, theta]),
        }
    }
    ranges
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pooled_bands_shrink_the_noise_but_not_the_codes() {
        let band = NodeBand {
            noise: 0.2,
            systematic: 0.05,
        };
        let pooled = NodeBand::pool([band; 4]).unwrap();
        assert!((pooled.noise - 0.1).abs() < 1e-6, "{pooled:?}");
        assert!((pooled.systematic - 0.05).abs() < 1e-6, "{pooled:?}");
        assert!((pooled.half_width() - 0.15).abs() < 1e-6);
        assert_eq!(NodeBand::pool([]), None);
    }

    #[test]
    fn ranges_merge_across_gaps_under_five_degrees() {
        let theta_deg: Vec<f32> = (0..=360).map(|i| i as f32 * 0.5).collect();
        let ranges = merged_ranges(&theta_deg, |i| {
            let theta = theta_deg[i];
            (100.0..=110.0).contains(&theta) || (113.0..=120.0).contains(&theta) || theta == 150.0
        });
        assert_eq!(ranges, vec![[100.0, 120.0], [150.0, 150.0]]);
        assert_eq!(one_degree_nodes(&theta_deg), 2);
    }
}
