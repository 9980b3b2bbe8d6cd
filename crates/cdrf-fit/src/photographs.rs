//! From photographs to samples: what [`crate::fit::fit_dataset`] does before it fits.
//!
//! The entries of a data set are grouped by photograph (several spheres, and the calibration
//! sphere, may share one), each photograph is decoded once — the next one while this one is
//! sampled — its spheres found and matched to the entries, and each sphere's pixels, less its
//! own flagged frame, turned into samples (masks, highlights). Radiance is sampled for a
//! light of strength 1 and divided by the strength at the end: the manifest's, the one the
//! matte reference sphere measures, or (unknown) a relative one.

use std::time::Instant;

use glam::Vec3;
use serde::Serialize;

use crate::circles::detect_spheres;
use crate::curves::SphereSamples;
use crate::dataset::{Calibration, Dataset, Light, LightSource, LightStrength, SphereEntry};
use crate::fit::{DetectedCircle, FitError, FitOptions, Progress, SphereReport, Timings};
use crate::highlight::reject_highlights;
use crate::image_io::{ColorSpace, Decoding, ImageError, LinearImage, load_linear_image_with};
use crate::sphere::{
    Circle, Detection, DetectionError, FlaggedFrame, Illumination, Sample, SphereView,
    detect_sphere, sample_sphere,
};

/// Every sphere of a data set sampled, and how the light was known.
pub struct SampledDataset {
    /// The spheres' samples, π·L/E (manifest order).
    pub samples: Vec<SphereSamples>,
    /// What happened to each.
    pub spheres: Vec<SphereReport>,
    /// How the light was known.
    pub light: LightReport,
    /// Decoding and sampling times.
    pub timings: Timings,
}

/// Samples every sphere of `dataset` (see the module docs).
///
/// # Errors
/// When an image, a mask or a flagged frame cannot be read or does not match its photograph,
/// a photograph shows no sphere (or not where the manifest says, or more than it names), a
/// sphere has too few usable pixels, or the calibration sphere gives no usable light.
pub fn sample_dataset(
    dataset: &Dataset,
    options: &FitOptions,
    progress: &mut impl FnMut(Progress),
) -> Result<SampledDataset, FitError> {
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
                sample.divide(strength);
            }
        }
    }
    Ok(SampledDataset {
        samples,
        spheres,
        light: LightReport::new(&dataset.light, strength, calibration),
        timings,
    })
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

/// A file the entry's manifest key names beside its photograph (a mask, a flagged frame),
/// decoded with `decoding` and checked to be the photograph's size.
fn load_companion(
    entry: &SphereEntry,
    key: &'static str,
    path: &std::path::Path,
    decoding: &Decoding,
    image_size: [u32; 2],
) -> Result<LinearImage, FitError> {
    let file = load_linear_image_with(path, decoding)?;
    if [file.width, file.height] != image_size {
        return Err(FitError::CompanionSize {
            image: entry.image_name.clone(),
            key,
            file: path.to_path_buf(),
            file_size: [file.width, file.height],
            image_size,
        });
    }
    Ok(file)
}

/// `image` minus the entry's flagged frame (decoded alike; a pixel clipped in either is
/// clipped), and the flagged frame as sampling needs it.
fn subtract_flagged(
    image: &LinearImage,
    entry: &SphereEntry,
    path: &std::path::Path,
) -> Result<(LinearImage, FlaggedFrame), FitError> {
    let size = [image.width, image.height];
    let ambient = load_companion(entry, "ambient_image", path, &entry.decoding(), size)?;
    let mut out = image.clone();
    let mut steps = Vec::with_capacity(out.pixels.len());
    for (pixel, light) in out.pixels.iter_mut().zip(&ambient.pixels) {
        steps.push(image.code_step.at_rgb(*pixel) + ambient.code_step.at_rgb(*light));
        *pixel -= *light;
    }
    for (clipped, light_clipped) in out.saturated.iter_mut().zip(&ambient.saturated) {
        *clipped |= *light_clipped;
    }
    let lossy = image.code_step.lossy() || ambient.code_step.lossy();
    Ok((
        out,
        FlaggedFrame {
            light: ambient.pixels,
            code_steps: steps,
            lossy,
        },
    ))
}

/// A mask image as one flag per pixel (non-zero = use), checked against the photograph's size.
fn load_mask(
    entry: &SphereEntry,
    path: &std::path::Path,
    size: [u32; 2],
) -> Result<Vec<bool>, FitError> {
    let linear = Decoding {
        color_space: Some(ColorSpace::Linear),
        ..Decoding::default()
    };
    let mask = load_companion(entry, "mask", path, &linear, size)?;
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
    let image = image?;
    let started = Instant::now();
    let (width, height) = (image.width as usize, image.height as usize);
    let circles = circles(photo, &image, options)?;
    let light = Illumination {
        source: dataset.light.source,
        strength: match dataset.light.strength {
            LightStrength::Given(strength) => strength,
            LightStrength::Calibrated | LightStrength::Relative => Vec3::ONE,
        },
    };
    // Noise around a black level or a subtracted frame goes below zero; clipping it would bias
    // the dark side's mean.
    let allow_negative = photo.first.levels.is_some();
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
        // Its flagged frame: what the room (and, in a photograph of several, the lit
        // neighbours) send the sphere without the lamp's direct light, removed before sampling.
        let flagged = match &entry.ambient {
            Some(path) => Some(subtract_flagged(&image, entry, path)?),
            None => None,
        };
        let (mut samples, mut dropped) = sample_sphere(
            &view,
            flagged.as_ref().map_or(&image, |(net, _)| net),
            &light,
            options.edge_margin_px,
            mask.as_deref(),
            allow_negative || entry.ambient.is_some(),
            flagged.as_ref().map(|(_, frame)| frame),
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
