//! The whole fit: a data set in, a measured table, a fitted Gaussian CDRF and their errors out.

use std::time::Instant;

use cdrf_core::lut::{CdrfLut, Filter};
use cdrf_core::translucency::Translucency;
use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::circles::detect_spheres;
use crate::curves::{CurveFit, CurveFits, CurveSettings, SphereSamples, fit_curves};
use crate::dataset::{Calibration, Dataset, Light, LightSource, LightStrength, SphereEntry};
use crate::diffusion::{
    DiffusionFit, DiffusionFitError, DiffusionSettings, fit_diffusion_curve_fit,
};
use crate::evaluate::{SphereError, sphere_error};
use crate::gaussian_fit::{GaussianFit, fit_gaussian};
use crate::highlight::reject_highlights;
use crate::image_io::{ColorSpace, Decoding, ImageError, LinearImage, load_linear_image_with};
use crate::sphere::{
    Circle, Detection, DetectionError, DroppedPixels, Illumination, Sample, SphereView,
    detect_sphere, sample_sphere,
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
    /// A mask image is not the size of its photograph.
    #[error("{image}: mask {} is {}×{} px but the photograph is {}×{} px", mask.display(), mask_size[0], mask_size[1], image_size[0], image_size[1])]
    MaskSize {
        /// The photograph.
        image: String,
        /// The mask file.
        mask: std::path::PathBuf,
        /// The mask's size.
        mask_size: [u32; 2],
        /// The photograph's size.
        image_size: [u32; 2],
    },
    /// A flagged frame is not the size of its photograph.
    #[error("{image}: ambient_image {} is {}×{} px but the photograph is {}×{} px", ambient.display(), ambient_size[0], ambient_size[1], image_size[0], image_size[1])]
    AmbientSize {
        /// The photograph.
        image: String,
        /// The flagged frame.
        ambient: std::path::PathBuf,
        /// Its size.
        ambient_size: [u32; 2],
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

/// Who is in a photograph: a `[[sphere]]` (by index) or the `[calibration]` sphere.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Member {
    Sphere(usize),
    Calibration,
}

/// One photograph and the entries that name it (decoded once).
struct Photo<'a> {
    first: &'a SphereEntry,
    members: Vec<(Member, &'a SphereEntry)>,
}

fn photos(dataset: &Dataset) -> Vec<Photo<'_>> {
    let entries = dataset
        .spheres
        .iter()
        .enumerate()
        .map(|(k, e)| (Member::Sphere(k), e))
        .chain(
            dataset
                .calibration
                .as_ref()
                .map(|c| (Member::Calibration, &c.sphere)),
        );
    let mut photos: Vec<Photo<'_>> = Vec::new();
    for (member, entry) in entries {
        match photos.iter_mut().find(|p| p.first.image == entry.image) {
            Some(photo) => photo.members.push((member, entry)),
            None => photos.push(Photo {
                first: entry,
                members: vec![(member, entry)],
            }),
        }
    }
    photos
}

fn decode(entry: &SphereEntry) -> Decoded {
    let started = Instant::now();
    let image = load_linear_image_with(&entry.image, &entry.decoding());
    (image, started.elapsed().as_secs_f64())
}

/// The circle of each member of a photograph: detected (matched to the entries by position
/// where the manifest gives one, else by size) and checked against the manifest's.
fn circles(
    photo: &Photo<'_>,
    image: &LinearImage,
    options: &FitOptions,
) -> Result<Vec<(Circle, Option<Detection>)>, FitError> {
    let (width, height) = (image.width as usize, image.height as usize);
    let count = photo.members.len();
    // One sphere on black: the threshold detector (exact on the bundled photographs); a
    // cluttered background or several spheres: the edge detector.
    let detections = if count == 1 {
        detect_sphere(width, height, &image.pixels)
            .map(|d| vec![d])
            .or_else(|_| detect_spheres(width, height, &image.pixels, 1))
    } else {
        detect_spheres(width, height, &image.pixels, count)
    };
    let mut detections: Vec<Option<Detection>> = match detections {
        Ok(found) => found.into_iter().map(Some).collect(),
        Err(error) => {
            // A manifest that gives every circle stands on its own.
            if photo
                .members
                .iter()
                .all(|(_, e)| e.center_px.is_some() && e.radius_px.is_some())
            {
                vec![None; count]
            } else {
                return Err(FitError::Detection {
                    image: photo.first.image_name.clone(),
                    error: if count > 1 {
                        DetectionError::TooFewSpheres {
                            wanted: count,
                            error: Box::new(error),
                        }
                    } else {
                        error
                    },
                });
            }
        }
    };
    let unplaced = photo
        .members
        .iter()
        .filter(|(_, e)| e.center_px.is_none())
        .count();
    if detections.len() > count && unplaced > 0 {
        return Err(FitError::Detection {
            image: photo.first.image_name.clone(),
            error: DetectionError::TooManySpheres { named: count },
        });
    }
    // Members with a manifest centre take the nearest circle; the others, by size.
    let mut assigned: Vec<Option<Detection>> = vec![None; count];
    for (slot, (_, entry)) in photo.members.iter().enumerate() {
        if let Some(center) = entry.center_px {
            let nearest = detections
                .iter()
                .enumerate()
                .filter_map(|(i, d)| {
                    d.as_ref()
                        .map(|d| (i, (d.circle.center_px - center).length()))
                })
                .min_by(|a, b| a.1.total_cmp(&b.1));
            if let Some((i, _)) = nearest {
                assigned[slot] = detections[i].take();
            }
        }
    }
    let mut free: Vec<Detection> = detections.into_iter().flatten().collect();
    free.sort_by(|a, b| a.circle.radius_px.total_cmp(&b.circle.radius_px));
    let mut by_size: Vec<usize> = (0..count)
        .filter(|&slot| photo.members[slot].1.center_px.is_none())
        .collect();
    by_size.sort_by(|&a, &b| {
        photo.members[a]
            .1
            .radius_mm
            .total_cmp(&photo.members[b].1.radius_mm)
    });
    for (slot, detection) in by_size.into_iter().zip(free) {
        assigned[slot] = Some(detection);
    }
    photo
        .members
        .iter()
        .zip(assigned)
        .map(|((_, entry), detection)| {
            let circle = match (&detection, entry.center_px, entry.radius_px) {
                (Some(found), center, radius) => {
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
                (None, Some(center_px), Some(radius_px)) => Circle {
                    center_px,
                    radius_px,
                },
                (None, _, _) => {
                    return Err(FitError::Detection {
                        image: entry.image_name.clone(),
                        error: DetectionError::NoCircle {
                            inliers: 0,
                            boundary: 0,
                        },
                    });
                }
            };
            Ok((circle, detection))
        })
        .collect()
}

/// A mask image as one flag per pixel (non-zero = use), checked against the photograph's size.
fn load_mask(
    entry: &SphereEntry,
    path: &std::path::Path,
    size: [u32; 2],
) -> Result<Vec<bool>, FitError> {
    let mask = load_linear_image_with(
        path,
        &Decoding {
            color_space: Some(ColorSpace::Linear),
            ..Decoding::default()
        },
    )?;
    if [mask.width, mask.height] != size {
        return Err(FitError::MaskSize {
            image: entry.image_name.clone(),
            mask: path.to_path_buf(),
            mask_size: [mask.width, mask.height],
            image_size: size,
        });
    }
    Ok(mask.pixels.iter().map(|p| p.max_element() > 0.5).collect())
}

/// A sampled member of a photograph.
struct Sampled {
    member: Member,
    samples: SphereSamples,
    report: SphereReport,
}

/// Detects and samples every member of one decoded photograph, keeping nothing of the image but
/// the samples. Radiance is relative to a light of strength 1 unless the manifest gives it.
fn sample_photo(
    dataset: &Dataset,
    photo: &Photo<'_>,
    options: &FitOptions,
    (image, decode_s): Decoded,
) -> Result<Vec<Sampled>, FitError> {
    let mut image = image?;
    let started = Instant::now();
    let (width, height) = (image.width as usize, image.height as usize);
    let circles = circles(photo, &image, options)?;
    // The flagged frame: what the room alone sends the spheres, removed before sampling.
    if let Some(path) = &photo.first.ambient {
        let ambient = load_linear_image_with(path, &photo.first.decoding())?;
        if [ambient.width, ambient.height] != [image.width, image.height] {
            return Err(FitError::AmbientSize {
                image: photo.first.image_name.clone(),
                ambient: path.clone(),
                ambient_size: [ambient.width, ambient.height],
                image_size: [image.width, image.height],
            });
        }
        for (pixel, light) in image.pixels.iter_mut().zip(&ambient.pixels) {
            *pixel -= *light;
        }
        for (clipped, light_clipped) in image.saturated.iter_mut().zip(&ambient.saturated) {
            *clipped |= *light_clipped;
        }
    }
    let light = Illumination {
        source: dataset.light.source,
        strength: match dataset.light.strength {
            LightStrength::Given(strength) => strength,
            LightStrength::Calibrated | LightStrength::Relative => Vec3::ONE,
        },
    };
    // Noise around a black level or a subtracted frame goes below zero; clipping it would bias
    // the dark side's mean.
    let allow_negative = photo.first.levels.is_some() || photo.first.ambient.is_some();
    let mut out = Vec::with_capacity(photo.members.len());
    for (&(member, entry), (circle, detection)) in photo.members.iter().zip(circles) {
        // Silhouette points only when the circle used is the detected one.
        let silhouette = match (&detection, entry.center_px, entry.radius_px) {
            (Some(found), None, None) => found.edge_points.as_slice(),
            _ => &[],
        };
        let view = SphereView::with_silhouette(
            circle,
            dataset.camera.projection,
            width,
            height,
            silhouette,
        )
        .with_radius_mm(entry.radius_mm);
        let mask = match &entry.mask {
            Some(path) => Some(load_mask(entry, path, [image.width, image.height])?),
            None => None,
        };
        let (mut samples, mut dropped) = sample_sphere(
            &view,
            &image,
            &light,
            options.edge_margin_px,
            mask.as_deref(),
            allow_negative,
        );
        if member != Member::Calibration {
            dropped.highlight = reject_highlights(&mut samples, |sample| {
                let (column, row) = (sample.pixel as usize % width, sample.pixel as usize / width);
                view.point(column, row).map_or(90.0, |point| {
                    let (to_light, _) = light.at(point.position_mm);
                    let half = (to_light + point.to_camera).normalize_or_zero();
                    point.normal.dot(half).clamp(-1.0, 1.0).acos().to_degrees()
                })
            });
        }
        if samples.len() < options.min_samples {
            return Err(FitError::TooFewSamples {
                image: entry.image_name.clone(),
                usable: samples.len(),
                needed: options.min_samples,
                dropped,
            });
        }
        let detected = detection.map(|d: Detection| DetectedCircle {
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
            center_mm: view.center_mm().map(|c| c.to_array()),
            samples: samples.len(),
            dropped,
            outliers: 0,
            decode_s: decode_s / photo.members.len() as f64,
            sampling_s: 0.0,
        };
        out.push(Sampled {
            member,
            samples: SphereSamples {
                curvature_per_mm: 1.0 / entry.radius_mm,
                image_width: image.width,
                samples,
            },
            report,
        });
    }
    let sampling_s = started.elapsed().as_secs_f64() / out.len().max(1) as f64;
    for sampled in &mut out {
        sampled.report.sampling_s = sampling_s;
    }
    Ok(out)
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
    let mut timings = Timings::default();
    let mut sampled: Vec<Sampled> = Vec::with_capacity(dataset.spheres.len() + 1);
    // Decode the next photograph while sampling this one: two images in memory at most.
    let photos = photos(dataset);
    let mut next = photos.first().map(|p| decode(p.first));
    for (index, photo) in photos.iter().enumerate() {
        let Some(decoded) = next.take() else { break };
        let (result, following) = rayon::join(
            || sample_photo(dataset, photo, options, decoded),
            || photos.get(index + 1).map(|p| decode(p.first)),
        );
        next = following;
        for one in result? {
            timings.decode_s += one.report.decode_s;
            timings.sampling_s += one.report.sampling_s;
            if let Member::Sphere(k) = one.member {
                progress(Progress::SphereSampled {
                    index: k,
                    count: dataset.spheres.len(),
                });
            }
            sampled.push(one);
        }
    }
    let calibration = match (&dataset.light.strength, &dataset.calibration) {
        (LightStrength::Calibrated, Some(reference)) => {
            let samples = sampled
                .iter()
                .find(|s| s.member == Member::Calibration)
                .map(|s| &s.samples.samples[..])
                .unwrap_or_default();
            Some(calibrate(samples, reference)?)
        }
        _ => None,
    };
    // Radiance was sampled for a light of strength 1: divide by the measured strength, or for a
    // relative lamp by its irradiance at the first sphere's centre.
    let strength = match (&calibration, dataset.light.source) {
        (Some(c), _) => Vec3::from_array(c.strength),
        (None, LightSource::Lamp { position_mm })
            if dataset.light.strength == LightStrength::Relative =>
        {
            let first = sampled
                .iter()
                .find(|s| s.member == Member::Sphere(0))
                .and_then(|s| s.report.center_mm)
                .map_or(Vec3::ZERO, Vec3::from_array);
            Vec3::splat((position_mm - first).length_squared().max(1e-12))
        }
        _ => Vec3::ONE,
    };
    sampled.retain(|s| s.member != Member::Calibration);
    sampled.sort_by_key(|s| match s.member {
        Member::Sphere(k) => k,
        Member::Calibration => usize::MAX,
    });
    let (mut samples, spheres): (Vec<SphereSamples>, Vec<SphereReport>) =
        sampled.into_iter().map(|s| (s.samples, s.report)).unzip();
    if strength != Vec3::ONE {
        for sphere in &mut samples {
            for sample in &mut sphere.samples {
                sample.radiance /= strength;
            }
        }
    }
    progress(Progress::Fitting);
    let fit = fit_samples(samples, spheres, options, timings)?;
    Ok(Fit {
        light: Some(LightReport::new(&dataset.light, strength, calibration)),
        timings: Timings {
            total_s: started.elapsed().as_secs_f64(),
            ..fit.timings
        },
        ..fit
    })
}

/// The light's strength from the matte reference sphere: π·L/E₁ = ρ·cos θ·S for a Lambertian
/// surface, with E₁ the irradiance of a light of strength 1; S is the median of
/// π·L/(E₁·ρ·cos θ) over the pixels with cos θ ≥ 0.3 (the median ignores a highlight or a
/// speck of dust).
fn calibrate(samples: &[Sample], reference: &Calibration) -> Result<CalibrationReport, FitError> {
    let mut ratios: [Vec<f32>; 3] = Default::default();
    for sample in samples {
        let cos = sample.theta_rad.cos();
        if cos < 0.3 {
            continue;
        }
        let ratio = sample.radiance / (reference.albedo * cos);
        for (channel, values) in ratios.iter_mut().enumerate() {
            values.push(ratio[channel]);
        }
    }
    let used = ratios[0].len();
    if used < 100 {
        return Err(FitError::Calibration {
            image: reference.sphere.image_name.clone(),
            problem: format!(
                "only {used} pixels of the reference sphere face the light (cos θ ≥ 0.3); need 100"
            ),
        });
    }
    let mut strength = [0.0_f32; 3];
    let mut spread = [0.0_f32; 3];
    for (channel, values) in ratios.iter_mut().enumerate() {
        values.sort_by(f32::total_cmp);
        let at = |q: f32| values[((values.len() - 1) as f32 * q) as usize];
        strength[channel] = at(0.5);
        spread[channel] = (at(0.75) - at(0.25)) / (2.0 * at(0.5).max(f32::MIN_POSITIVE));
    }
    if !strength.iter().all(|s| s.is_finite() && *s > 0.0) {
        return Err(FitError::Calibration {
            image: reference.sphere.image_name.clone(),
            problem: format!(
                "the reference sphere gives a light of strength {strength:?}: is it lit, and is the albedo right?"
            ),
        });
    }
    Ok(CalibrationReport {
        image: reference.sphere.image_name.clone(),
        albedo: reference.albedo.to_array(),
        pixels: used,
        strength,
        relative_spread: spread,
    })
}

/// How the light was known, for the report.
#[derive(Clone, Debug, Serialize)]
pub struct LightReport {
    /// `"directional"` or `"lamp"`.
    pub source: &'static str,
    /// The lamp's position, camera space, mm.
    pub position_mm: Option<[f32; 3]>,
    /// The direction toward a directional light.
    pub to_light: Option<[f32; 3]>,
    /// `"given"` (the manifest's irradiance / intensity), `"calibrated"` (the reference
    /// sphere) or `"relative"` (unknown: the table's scale is arbitrary).
    pub strength_from: &'static str,
    /// The strength the radiance was divided by: irradiance (directional) or intensity (lamp,
    /// irradiance·mm²), in the photographs' units.
    pub strength: [f32; 3],
    /// The calibration, when there was one.
    pub calibration: Option<CalibrationReport>,
}

impl LightReport {
    fn new(light: &Light, divided_by: Vec3, calibration: Option<CalibrationReport>) -> Self {
        let (source, position_mm, to_light) = match light.source {
            LightSource::Directional { to_light } => {
                ("directional", None, Some(to_light.to_array()))
            }
            LightSource::Lamp { position_mm } => ("lamp", Some(position_mm.to_array()), None),
        };
        let (strength_from, strength) = match light.strength {
            LightStrength::Given(value) => ("given", value.to_array()),
            LightStrength::Calibrated => ("calibrated", divided_by.to_array()),
            LightStrength::Relative => ("relative", divided_by.to_array()),
        };
        Self {
            source,
            position_mm,
            to_light,
            strength_from,
            strength,
            calibration,
        }
    }
}

/// What the reference sphere measured.
#[derive(Clone, Debug, Serialize)]
pub struct CalibrationReport {
    /// Its image.
    pub image: String,
    /// Its albedo (the manifest's).
    pub albedo: [f32; 3],
    /// Pixels used.
    pub pixels: usize,
    /// The measured strength per channel.
    pub strength: [f32; 3],
    /// Half the interquartile range of the per-pixel estimates, relative to the median: how
    /// Lambertian the reference looked (a few % is normal).
    pub relative_spread: [f32; 3],
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
        light: None,
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

/// The band [`noisy_ranges`] warns above: ±10 %.
pub const NOISY_BAND: f32 = 0.1;

/// Half-width of the 95 % confidence band of sphere `k`'s curve f(θ) at each θ node, relative
/// to it: 1.96 · σ / √n, with σ the node's relative per-pixel noise (robust, from the fit's
/// residuals) and n its effective pixel count — what a bootstrap over the pixels gives when
/// their noise is independent. `None` where the node was filled, not measured.
pub fn confidence_95(fit: &CurveFit, k: usize) -> Vec<Option<f32>> {
    fit.node_samples[k]
        .iter()
        .zip(&fit.node_noise[k])
        .map(|(&n, noise)| (n >= 1.0).then(|| 1.96 * noise.max_element() / n.sqrt()))
        .collect()
}

/// The θ ranges (degrees, from the node angles `theta_deg`) where the band, pooled over ±1°
/// (the table's curves are smoothed over about that), is wider than `limit`; ranges less than
/// 5° apart are merged.
pub fn noisy_ranges(band: &[Option<f32>], theta_deg: &[f32], limit: f32) -> Vec<[f32; 2]> {
    let step = theta_deg.get(1).map_or(1.0, |t| t - theta_deg[0]).max(1e-3);
    let half = (1.0 / step).round().max(0.0) as usize;
    let pooled = |i: usize| {
        // Pool inverse variances: 1/b² adds up like a pixel count.
        let window = &band[i.saturating_sub(half)..(i + half + 1).min(band.len())];
        let information: f32 = window
            .iter()
            .flatten()
            .map(|b| 1.0 / (b * b).max(1e-12))
            .sum();
        (information > 0.0).then(|| information.sqrt().recip())
    };
    let mut ranges: Vec<[f32; 2]> = Vec::new();
    for (i, &theta) in theta_deg.iter().enumerate() {
        if band[i].is_none() || !pooled(i).is_some_and(|b| b > limit) {
            continue;
        }
        match ranges.last_mut() {
            Some(last) if theta - last[1] < 5.0 => last[1] = theta,
            _ => ranges.push([theta, theta]),
        }
    }
    ranges
}
