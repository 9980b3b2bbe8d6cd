//! The files `cdrf-fit` writes. Their names are a contract other tools rely on:
//!
//! | file | content |
//! |---|---|
//! | `measured.exr` | the measured LUT ([`cdrf_core::lut_file`]), with its translucency (scattering length and transmission profile) when the transmission fit succeeded |
//! | `gaussian.toml` | the fitted Gaussian CDRF: `sigma_mm`, `scale` per RGB channel ([`GaussianParameters`]) |
//! | `report.json` | per-radius curves, sample counts, residuals, g(φ), errors, the transmission profile and its quality, timings ([`Report`]) |
//! | `radiance_vs_theta.svg` | radiance against θ per radius, raw (all φ) and φ-corrected: the poster's Fig. 2 |
//! | `view_correction.svg` | g(φ), and the θ-dependent correction at a few θ |
//! | `profile.svg` | the diffusion profile as the light leaving per mm of distance, 2π·d·R(d), per channel (log), with its entry power and how well it alone reproduces the spheres |
//! | `transmission.svg` | the shadow side divided by the entry cosine μ = \|cos θ\| against the chord d the light crossed, per sphere and channel (log), and the fitted A·exp(−d/ℓ) of T(d, μ) = A·μ·exp(−d/ℓ) per channel |
//! | `lut.png` | a picture of the table (θ across, κ down): in colour, and log₁₀ of green below |
//!
//! Every file is written atomically (temporary file, then rename).

use std::io::Write;
use std::path::{Path, PathBuf};

use cdrf_core::lut::theta_rad_at;
use glam::Vec3;
use serde::Serialize;

use crate::curves::{CORRECTION_PHI_COUNT, SphereSamples, ViewModel};
use crate::evaluate::SphereError;
use crate::fit::{
    Fit, ModelErrors, NOISY_BAND, NodeBand, SphereReport, Timings, confidence_95, noisy_ranges,
    room_dominated_ranges, theta_nodes_deg,
};
use crate::photographs::LightReport;
use crate::plot::{
    ColorScale, Colormap, LinePlot, LineStyle, Series, heatmap_png, rgb_png_srgb, upscale_nearest,
};
use crate::transmission::{
    ChordPoint, SphereCurve, TransmissionError, TransmissionFit, shadow_points,
};

/// The measured LUT.
pub const MEASURED_LUT: &str = "measured.exr";
/// The fitted Gaussian CDRF.
pub const GAUSSIAN: &str = "gaussian.toml";
/// The report.
pub const REPORT: &str = "report.json";
/// Radiance against θ per radius.
pub const RADIANCE_PLOT: &str = "radiance_vs_theta.svg";
/// The view correction.
pub const VIEW_PLOT: &str = "view_correction.svg";
/// The table as a picture.
pub const LUT_PICTURE: &str = "lut.png";
/// The transmission profile against the shadow sides.
pub const TRANSMISSION_PLOT: &str = "transmission.svg";
/// The diffusion profile.
pub const PROFILE_PLOT: &str = "profile.svg";

/// `gaussian.toml`: Kubo's Gaussian CDRF fitted to the same photographs (the format lives in
/// cdrf-core, which reads it for rendering).
pub use cdrf_core::gaussian_file::GaussianParameters;

/// Why writing outputs failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OutputError {
    /// The output folder could not be created or a file not written.
    #[error("{}: {error}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// What the OS said.
        error: std::io::Error,
    },
    /// The LUT could not be written.
    #[error(transparent)]
    Lut(#[from] cdrf_core::lut_file::LutFileError),
    /// The output folder is the input folder or inside it (the input folder is never written to).
    #[error("{}: the output folder must not be the data set folder or inside it", path.display())]
    IntoInput {
        /// The folder.
        path: PathBuf,
    },
    /// The output path is an existing file.
    #[error("{}: exists and is not a folder", path.display())]
    NotAFolder {
        /// The path.
        path: PathBuf,
    },
}

/// One sphere in the report.
#[derive(Clone, Debug, Serialize)]
pub struct ReportSphere {
    /// What happened while reading it.
    #[serde(flatten)]
    pub sphere: SphereReport,
    /// Errors of the models on it (8 × 8 px blocks; see `cdrf_fit::evaluate`).
    pub errors: ModelErrors,
    /// θ (degrees) of the curves below.
    pub theta_deg: Vec<f32>,
    /// Mean π·L/E of all samples in 1° θ bins, all φ mixed (NaN-free: empty bins are null).
    pub raw_curve: Vec<Option<[f32; 3]>>,
    /// The φ-corrected curve f(θ) on the table's θ nodes, filled and smoothed as it enters the
    /// table.
    pub corrected_curve: Vec<[f32; 3]>,
    /// Effective samples per θ node (0: filled, not measured).
    pub samples_per_node: Vec<f32>,
    /// Half-width of the 95 % confidence band of the curve at each θ node, relative to it, from
    /// the pixels' noise and the files' code steps (null: not measured). See
    /// [`crate::fit::confidence_95`].
    pub confidence_95: Vec<Option<f32>>,
    /// θ ranges (degrees) where that band is wider than ±10 %: too uncertain to trust.
    pub noisy_theta_deg: Vec<[f32; 2]>,
    /// θ ranges (degrees) where the flagged frame carried more than
    /// [`ROOM_DOMINATED`](crate::fit::ROOM_DOMINATED) times the light the curve keeps: what
    /// the flag left of the room's light is a bias there that the band does not count. See
    /// [`crate::fit::room_dominated_ranges`].
    pub room_dominated_theta_deg: Vec<[f32; 2]>,
    /// θ (degrees) from which `corrected_curve` is the diffusion profile's continuation, not
    /// the photograph (null: not continued — measured to 180°, or no profile). See
    /// [`crate::tails`].
    pub continued_from_theta_deg: Option<f32>,
}

/// `report.json`.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// cdrf-fit's version.
    pub tool_version: &'static str,
    /// The data set folder.
    pub dataset: PathBuf,
    /// How the light was known: where it was, and whether its strength was given, calibrated
    /// or unknown (`"relative"`: the table's scale is arbitrary).
    pub light: Option<LightReport>,
    /// The view model of the table.
    pub view_model: ViewModel,
    /// The table's shape.
    pub table: TableSummary,
    /// Per sphere.
    pub spheres: Vec<ReportSphere>,
    /// g(φ) of the chosen model (φ in degrees, RGB); with `theta-phi` it is fitted together with
    /// c(θ, φ).
    pub g_phi: Vec<(f32, [f32; 3])>,
    /// The poster's g(φ), fitted alone (no θ-dependent correction).
    pub poster_g_phi: Vec<(f32, [f32; 3])>,
    /// The θ-dependent correction c_k(θ, φ) of each sphere (in `spheres` order; θ rows 10°
    /// apart, φ columns 10° apart), when fitted.
    pub theta_phi_correction: Option<Vec<Vec<Vec<[f32; 3]>>>>,
    /// Residuals of the two view models, summed over spheres.
    pub view_model_residuals: ViewResiduals,
    /// The fitted Gaussian CDRF.
    pub gaussian: GaussianSummary,
    /// The transmission profile and the table's translucency.
    pub transmission: TransmissionSummary,
    /// The diffusion profile fitted to all spheres.
    pub diffusion: DiffusionSummary,
    /// Where the time went, seconds.
    pub timings: Timings,
}

/// The table's shape.
#[derive(Clone, Debug, Serialize)]
pub struct TableSummary {
    /// κ of the first row, mm⁻¹.
    pub curvature_min_per_mm: f32,
    /// κ of the last row, mm⁻¹.
    pub curvature_max_per_mm: f32,
    /// Rows.
    pub curvature_count: usize,
    /// θ columns over [0, 180°].
    pub theta_count: usize,
}

/// The Gaussian fit in the report.
#[derive(Clone, Debug, Serialize)]
pub struct GaussianSummary {
    /// σ per channel, mm.
    pub sigma_mm: [f32; 3],
    /// Scale per channel.
    pub scale: [f32; 3],
    /// √(Σ residual² / Σ L²) over all samples, per channel.
    pub relative_rms: [f32; 3],
}

/// The transmission fit in the report (`cdrf_fit::transmission`). Per-channel values are
/// `[R, G, B]`.
#[derive(Clone, Debug, Serialize)]
pub struct TransmissionSummary {
    /// Smallest θ of the shadow-side nodes used, degrees.
    pub min_theta_deg: f32,
    /// Why the profile could not be fitted; then `measured.exr` has no translucency and the
    /// fields below are absent.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// The fit, when it succeeded.
    #[serde(flatten)]
    pub fitted: Option<FittedTransmission>,
}

/// A successful transmission fit in the report.
#[derive(Clone, Debug, Serialize)]
pub struct FittedTransmission {
    /// A of T(d, μ) = A·μ^p·exp(−d/ℓ) per channel, π·L/E.
    pub amplitude: [f32; 3],
    /// Decay length ℓ per channel, mm.
    pub length_mm: [f32; 3],
    /// p: 1, the light entering scales with the entry cosine μ.
    pub entry_cosine_power: f32,
    /// The table's scattering length (Kubo's σ) per channel, mm.
    pub scattering_length_mm: [f32; 3],
    /// Nodes fitted per channel.
    pub points: [usize; 3],
    /// Shortest and longest chord per channel, mm.
    pub chord_range_mm: [[f32; 2]; 3],
    /// Weighted relative RMS error of T(d, μ) against the nodes per channel, relative to
    /// T(d, μ) (linear space).
    pub relative_rms: [f32; 3],
    /// Per sphere (input order): weighted mean of f / T(d, μ) over its nodes per channel
    /// (null: no nodes). 1 everywhere when the glow is one function of (d, μ) across radii.
    pub spheres: Vec<TransmissionSphere>,
}

/// One sphere of [`FittedTransmission`].
#[derive(Clone, Debug, Serialize)]
pub struct TransmissionSphere {
    /// Radius, mm.
    pub radius_mm: f32,
    /// Nodes fitted per channel.
    pub points: [usize; 3],
    /// Weighted mean of f / T(d, μ) per channel.
    pub mean_ratio: [Option<f32>; 3],
}

impl TransmissionSummary {
    fn new(fit: &Fit) -> Self {
        match &fit.transmission {
            Ok(transmission) => Self {
                min_theta_deg: transmission.settings.min_theta_deg,
                error: None,
                fitted: Some(FittedTransmission::new(fit, transmission)),
            },
            Err(error) => Self {
                min_theta_deg: fit.transmission_settings.min_theta_deg,
                error: Some(error.to_string()),
                fitted: None,
            },
        }
    }
}

impl FittedTransmission {
    fn new(fit: &Fit, transmission: &TransmissionFit) -> Self {
        let channels = &transmission.channels;
        let spheres = (0..fit.samples.len())
            .map(|k| TransmissionSphere {
                radius_mm: radius_mm(fit, k),
                points: std::array::from_fn(|c| {
                    channels[c].points.iter().filter(|p| p.sphere == k).count()
                }),
                mean_ratio: std::array::from_fn(|c| {
                    channels[c].mean_ratio_per_sphere.get(k).copied().flatten()
                }),
            })
            .collect();
        Self {
            amplitude: transmission.profile.amplitude,
            length_mm: transmission.profile.length_mm,
            entry_cosine_power: transmission.profile.entry_cosine_power,
            scattering_length_mm: fit
                .lut
                .translucency()
                .map_or(fit.gaussian.model.sigma_mm(), |t| t.scattering_length_mm),
            points: std::array::from_fn(|c| channels[c].points.len()),
            chord_range_mm: std::array::from_fn(|c| {
                let (lo, hi) = channels[c].chord_range_mm;
                [lo, hi]
            }),
            relative_rms: std::array::from_fn(|c| channels[c].relative_rms),
            spheres,
        }
    }
}

/// The diffusion profile fit in the report (`cdrf_fit::diffusion`). Per-channel values are
/// `[R, G, B]`.
#[derive(Clone, Debug, Serialize)]
pub struct DiffusionSummary {
    /// Degrees of shadow side past θ = 110° that the sphere with the most has measured (before
    /// its cut, free of the room's light): below 10 the profile's long terms are a guess, and
    /// the CLI warns. See [`crate::fit::measured_deep_shadow_deg`].
    pub measured_deep_shadow_deg: f32,
    /// Why the profile could not be fitted; then `measured.exr` has no profile and the fields
    /// below are absent.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// The fit, when it succeeded.
    #[serde(flatten)]
    pub fitted: Option<FittedDiffusion>,
}

/// A successful profile fit in the report.
#[derive(Clone, Debug, Serialize)]
pub struct FittedDiffusion {
    /// p of the entry factor max(μ, 0)^p.
    pub entry_cosine_power: f32,
    /// The terms: ℓ (mm) and w per channel of w·exp(−d/ℓ)/(2πℓd).
    pub terms: Vec<DiffusionTerm>,
    /// Σ w per channel: the diffuse albedo.
    pub albedo: [f32; 3],
    /// Relative RMS of the profile alone against all spheres' θ nodes, per channel.
    pub relative_rms: [f32; 3],
    /// Per sphere: how well the profile alone reproduces its f(θ).
    pub spheres: Vec<DiffusionSphere>,
    /// Each entry power tried and the relative RMS summed over the channels.
    pub powers_tried: Vec<[f32; 2]>,
}

/// One term of [`FittedDiffusion`].
#[derive(Clone, Debug, Serialize)]
pub struct DiffusionTerm {
    /// ℓ, mm.
    pub length_mm: f32,
    /// w per channel.
    pub weight: [f32; 3],
}

/// One sphere of [`FittedDiffusion`].
#[derive(Clone, Debug, Serialize)]
pub struct DiffusionSphere {
    /// Radius, mm.
    pub radius_mm: f32,
    /// Relative RMS of the profile alone against this sphere's f(θ), per channel.
    pub relative_rms: [f32; 3],
    /// Σ profile / Σ measured over θ < 90°, per channel.
    pub lit_ratio: [f32; 3],
    /// Σ profile / Σ measured over θ ≥ 90°, per channel.
    pub shadow_ratio: [f32; 3],
}

impl DiffusionSummary {
    fn new(fit: &Fit) -> Self {
        let measured_deep_shadow_deg = crate::fit::measured_deep_shadow_deg(&fit.curves.chosen);
        match &fit.diffusion {
            Ok(diffusion) => Self {
                measured_deep_shadow_deg,
                error: None,
                fitted: Some(FittedDiffusion {
                    entry_cosine_power: diffusion.profile.entry_cosine_power(),
                    terms: diffusion
                        .profile
                        .terms()
                        .iter()
                        .map(|t| DiffusionTerm {
                            length_mm: t.length_mm,
                            weight: t.weight,
                        })
                        .collect(),
                    albedo: diffusion.profile.albedo(),
                    relative_rms: diffusion.relative_rms,
                    spheres: diffusion
                        .spheres
                        .iter()
                        .map(|s| DiffusionSphere {
                            radius_mm: (s.radius_mm * 100.0).round() / 100.0,
                            relative_rms: s.relative_rms,
                            lit_ratio: s.lit_ratio,
                            shadow_ratio: s.shadow_ratio,
                        })
                        .collect(),
                    powers_tried: diffusion
                        .powers_tried
                        .iter()
                        .map(|&(p, e)| [p, e])
                        .collect(),
                }),
            },
            Err(error) => Self {
                measured_deep_shadow_deg,
                error: Some(error.to_string()),
                fitted: None,
            },
        }
    }
}

/// Residuals of the curve fit, lit and terminator blocks of all spheres.
#[derive(Clone, Debug, Serialize)]
pub struct ViewResiduals {
    /// The poster's g(φ): mean relative error per sphere.
    pub phi: Vec<f32>,
    /// With the θ-dependent correction (same as `phi` when not fitted).
    pub theta_phi: Vec<f32>,
}

fn lit_and_terminator(error: &SphereError) -> f32 {
    error.lit_and_terminator.mean_relative_error
}

impl Report {
    /// The report of a fit of the data set in `dataset`.
    pub fn new(fit: &Fit, dataset: &Path) -> Self {
        let settings = fit.curves.chosen.settings;
        let theta_deg = theta_nodes_deg(settings.theta_count);
        let bands: Vec<_> = (0..fit.spheres.len())
            .map(|k| confidence_95(&fit.curves.chosen, k))
            .collect();
        let spheres = fit
            .spheres
            .iter()
            .zip(&fit.errors)
            .enumerate()
            .map(|(k, (sphere, errors))| ReportSphere {
                sphere: sphere.clone(),
                errors: errors.clone(),
                theta_deg: theta_deg.clone(),
                raw_curve: raw_curve(&fit.samples[k])
                    .iter()
                    .map(|v| v.map(|v| v.to_array()))
                    .collect(),
                corrected_curve: fit.table_curves[k].iter().map(|v| v.to_array()).collect(),
                samples_per_node: fit.curves.chosen.node_samples[k].clone(),
                confidence_95: bands[k]
                    .iter()
                    .map(|band| band.map(NodeBand::half_width))
                    .collect(),
                noisy_theta_deg: noisy_ranges(&bands[k], &theta_deg, NOISY_BAND),
                room_dominated_theta_deg: room_dominated_ranges(&fit.curves.chosen, k, &theta_deg),
                continued_from_theta_deg: fit.continued_from_theta_deg[k],
            })
            .collect();
        let phi_table = |values: &[Vec3]| -> Vec<(f32, [f32; 3])> {
            let last = (values.len() - 1) as f32;
            values
                .iter()
                .enumerate()
                .map(|(i, g)| (90.0 * i as f32 / last, g.to_array()))
                .collect()
        };
        let g_phi = phi_table(&fit.curves.chosen.g_phi);
        let poster_g_phi = phi_table(&fit.curves.poster.g_phi);
        let theta_phi_correction = fit.curves.chosen.correction.as_ref().map(|grids| {
            grids
                .iter()
                .map(|grid| {
                    grid.chunks(CORRECTION_PHI_COUNT)
                        .map(|row| row.iter().map(|v| v.to_array()).collect())
                        .collect()
                })
                .collect()
        });
        let axis = fit.lut.curvature_axis();
        Self {
            tool_version: env!("CARGO_PKG_VERSION"),
            dataset: dataset.to_path_buf(),
            light: fit.light.clone(),
            view_model: settings.view_model,
            table: TableSummary {
                curvature_min_per_mm: axis.min_per_mm,
                curvature_max_per_mm: axis.max_per_mm,
                curvature_count: axis.count,
                theta_count: fit.lut.theta_count(),
            },
            spheres,
            g_phi,
            poster_g_phi,
            theta_phi_correction,
            view_model_residuals: ViewResiduals {
                phi: fit
                    .errors
                    .iter()
                    .map(|e| lit_and_terminator(&e.poster_view_fit))
                    .collect(),
                theta_phi: fit
                    .errors
                    .iter()
                    .map(|e| lit_and_terminator(&e.chosen_view_fit))
                    .collect(),
            },
            gaussian: GaussianSummary {
                sigma_mm: fit.gaussian.model.sigma_mm(),
                scale: fit.gaussian.model.scale(),
                relative_rms: fit.gaussian.relative_rms,
            },
            transmission: TransmissionSummary::new(fit),
            diffusion: DiffusionSummary::new(fit),
            timings: fit.timings,
        }
    }
}

/// Mean π·L/E of a sphere's samples in 1° bins of θ (0°…180°), all φ mixed: the raw curve of
/// the poster's Fig. 2. `None` for empty bins.
fn raw_curve(sphere: &SphereSamples) -> Vec<Option<Vec3>> {
    let mut sums = vec![(Vec3::ZERO, 0_u32); 181];
    for s in &sphere.samples {
        let bin = (s.theta_rad.to_degrees().round() as usize).min(180);
        sums[bin].0 += s.radiance;
        sums[bin].1 += 1;
    }
    sums.iter()
        .map(|(sum, n)| (*n > 0).then(|| *sum / *n as f32))
        .collect()
}

fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    cdrf_core::atomic::write_file(path, |file| file.write_all(bytes)).map_err(|error| {
        OutputError::Io {
            path: path.to_path_buf(),
            error,
        }
    })
}

/// Checks, before any work, that `out_dir` can take the outputs: it is not the data set folder
/// or inside it (the input folder is never written to), and it is not an existing file.
///
/// # Errors
/// [`OutputError::IntoInput`] or [`OutputError::NotAFolder`].
pub fn check_output_dir(dataset_dir: &Path, out_dir: &Path) -> Result<(), OutputError> {
    if out_dir.exists() && !out_dir.is_dir() {
        return Err(OutputError::NotAFolder {
            path: out_dir.to_path_buf(),
        });
    }
    // Resolve the deepest existing ancestor (the folder may not exist yet), then the rest.
    let absolute = std::path::absolute(out_dir).unwrap_or_else(|_| out_dir.to_path_buf());
    let mut existing = absolute.as_path();
    let mut rest = Vec::new();
    while !existing.exists() {
        match (existing.parent(), existing.file_name()) {
            (Some(parent), Some(name)) => {
                rest.push(name.to_os_string());
                existing = parent;
            }
            _ => break,
        }
    }
    let mut resolved = existing
        .canonicalize()
        .unwrap_or_else(|_| existing.to_path_buf());
    resolved.extend(rest.iter().rev());
    let input = dataset_dir
        .canonicalize()
        .unwrap_or_else(|_| dataset_dir.to_path_buf());
    if resolved.starts_with(&input) {
        return Err(OutputError::IntoInput {
            path: out_dir.to_path_buf(),
        });
    }
    Ok(())
}

/// Writes every output of `fit` into `out_dir` (created if missing). Returns the files written
/// and the report.
///
/// The set is written whole into a staging folder `out_dir/.cdrf-partial-*` and only then moved
/// in, file by file (renames within one folder), while an exclusive lock on `out_dir` is held:
/// a second fit into the same folder waits, so two runs never mix their files, and a run killed
/// while writing leaves the previous set as it was (its staging folder is removed by the next
/// run, as are other stale `.cdrf-partial-*` files).
///
/// # Errors
/// When `out_dir` is the data set folder, or a file cannot be written.
pub fn write_outputs(
    fit: &Fit,
    dataset_dir: &Path,
    out_dir: &Path,
) -> Result<(Vec<PathBuf>, Report), OutputError> {
    check_output_dir(dataset_dir, out_dir)?;
    let io_error = |path: &Path| {
        let path = path.to_path_buf();
        move |error| OutputError::Io { path, error }
    };
    std::fs::create_dir_all(out_dir).map_err(io_error(out_dir))?;
    // One run at a time per folder: a second fit into the same OUTDIR waits here (the lock is
    // released when `lock` is dropped, also when the process is killed).
    let lock = std::fs::File::open(out_dir).map_err(io_error(out_dir))?;
    lock.lock().map_err(io_error(out_dir))?;
    remove_stale_partials(out_dir)?;
    // Every file is written into a fresh staging folder first and moved in only when all are
    // complete, so a kill during the (slow) writing leaves the old set untouched.
    let staging = out_dir.join(format!(
        ".cdrf-partial-{}-{}",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos())
    ));
    std::fs::create_dir(&staging).map_err(io_error(&staging))?;
    let result = write_set(fit, dataset_dir, &staging);
    let moved = result.and_then(|(names, report)| {
        let mut written = Vec::with_capacity(names.len());
        for name in names {
            let target = out_dir.join(&name);
            std::fs::rename(staging.join(&name), &target).map_err(io_error(&target))?;
            written.push(target);
        }
        Ok((written, report))
    });
    let _ = std::fs::remove_dir_all(&staging);
    drop(lock);
    moved
}

/// Removes `.cdrf-partial-*` files and folders that killed runs left in `out_dir` (called with
/// the folder's lock held, so no live fit's staging folder is among them).
fn remove_stale_partials(out_dir: &Path) -> Result<(), OutputError> {
    let entries = std::fs::read_dir(out_dir).map_err(|error| OutputError::Io {
        path: out_dir.to_path_buf(),
        error,
    })?;
    for entry in entries.flatten() {
        if !entry
            .file_name()
            .to_string_lossy()
            .starts_with(".cdrf-partial-")
        {
            continue;
        }
        let path = entry.path();
        let removed = if entry.file_type().is_ok_and(|t| t.is_dir()) {
            std::fs::remove_dir_all(&path)
        } else {
            std::fs::remove_file(&path)
        };
        removed.map_err(|error| OutputError::Io { path, error })?;
    }
    Ok(())
}

/// Writes the run's files into `out_dir` (the staging folder); returns their names.
fn write_set(
    fit: &Fit,
    dataset_dir: &Path,
    out_dir: &Path,
) -> Result<(Vec<String>, Report), OutputError> {
    let view_model = fit.curves.chosen.settings.view_model;
    let lut = fit
        .lut
        .clone()
        .with_provenance("tool", format!("cdrf-fit {}", env!("CARGO_PKG_VERSION")))
        .with_provenance("dataset", dataset_dir.display().to_string())
        .with_provenance("view_model", view_model_name(view_model));
    let lut_path = out_dir.join(MEASURED_LUT);
    cdrf_core::lut_file::write_lut(&lut, &lut_path)?;
    let mut written = vec![MEASURED_LUT.to_owned()];
    let mut put = |name: &str, bytes: &[u8]| -> Result<(), OutputError> {
        let path = out_dir.join(name);
        write_bytes(&path, bytes)?;
        written.push(name.to_owned());
        Ok(())
    };

    let gaussian = GaussianParameters {
        sigma_mm: fit.gaussian.model.sigma_mm(),
        scale: fit.gaussian.model.scale(),
        view_correction_from: Some(MEASURED_LUT.into()),
    };
    let toml = format!(
        "# Fitted by cdrf-fit to the same photographs as {MEASURED_LUT} (view model: {}).\n{}",
        view_model_name(view_model),
        gaussian.to_toml_string()
    );
    put(GAUSSIAN, toml.as_bytes())?;

    let report = Report::new(fit, dataset_dir);
    let json = serde_json::to_vec_pretty(&report).map_err(|e| OutputError::Io {
        path: out_dir.join(REPORT),
        error: e.into(),
    })?;
    put(REPORT, &json)?;
    put(RADIANCE_PLOT, radiance_plot(fit).as_bytes())?;
    put(VIEW_PLOT, view_plot(fit).as_bytes())?;
    put(TRANSMISSION_PLOT, transmission_plot(fit).as_bytes())?;
    put(PROFILE_PLOT, profile_plot(fit).as_bytes())?;

    let picture = lut_picture(fit);
    let mut png = Vec::new();
    picture
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .map_err(|e| OutputError::Io {
            path: out_dir.join(LUT_PICTURE),
            error: std::io::Error::other(e),
        })?;
    put(LUT_PICTURE, &png)?;
    Ok((written, report))
}

/// The manifest/CLI name of a view model.
pub fn view_model_name(model: ViewModel) -> &'static str {
    match model {
        ViewModel::Phi => "phi",
        ViewModel::ThetaPhi => "theta-phi",
    }
}

fn radius_color(fit: &Fit, k: usize) -> [u8; 3] {
    let radii: Vec<f32> = fit.spheres.iter().map(|s| s.radius_mm).collect();
    let (lo, hi) = radii
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), r| (a.min(*r), b.max(*r)));
    let t = if hi > lo {
        (radii[k] - lo) / (hi - lo)
    } else {
        0.5
    };
    Colormap::Viridis.color_at(0.9 * t)
}

/// The poster's Fig. 2 for every radius: green channel, raw (dots) and φ-corrected (lines),
/// log radiance so the shadow side shows.
fn radiance_plot(fit: &Fit) -> String {
    let settings = fit.curves.chosen.settings;
    let mut plot = LinePlot::new(
        "Radiance against θ per radius: raw (dots, all φ), φ-corrected f(θ) (lines) and its 95 % band (faint), green",
        "θ, angle between normal and light (degrees)",
        "π·L/E",
    )
    .with_log_y(true)
    .with_x_range(0.0, 180.0)
    .with_size_px(900, 560);
    for (k, sphere) in fit.spheres.iter().enumerate() {
        let color = radius_color(fit, k);
        let raw = raw_curve(&fit.samples[k])
            .iter()
            .enumerate()
            .filter_map(|(degrees, v)| v.map(|v| (degrees as f32, v.y)))
            .collect();
        let corrected = fit.table_curves[k]
            .iter()
            .enumerate()
            .map(|(a, v)| (theta_rad_at(a, settings.theta_count).to_degrees(), v.y))
            .collect();
        let band = confidence_95(&fit.curves.chosen, k);
        let edge = |sign: f32| -> Vec<(f32, f32)> {
            fit.table_curves[k]
                .iter()
                .zip(&band)
                .enumerate()
                .map(|(a, (v, b))| {
                    let theta = theta_rad_at(a, settings.theta_count).to_degrees();
                    // A band of ±100 % or more says "not measured": not drawn (its edge would
                    // stretch the log axis by decades).
                    let width = b.map(NodeBand::half_width).filter(|&w| w < 1.0);
                    (theta, width.map_or(f32::NAN, |w| v.y * (1.0 + sign * w)))
                })
                .collect()
        };
        plot = plot
            .with_series(Series::new("", color, raw).with_style(LineStyle::Markers))
            .with_series(Series::new(
                format!("r = {} mm", sphere.radius_mm),
                color,
                corrected,
            ))
            .with_series(Series::new("", color, edge(1.0)).with_style(LineStyle::Faint))
            .with_series(Series::new("", color, edge(-1.0)).with_style(LineStyle::Faint));
    }
    plot.to_svg()
}

fn view_plot(fit: &Fit) -> String {
    let chosen = &fit.curves.chosen;
    let phi_deg = |i: usize, n: usize| 90.0 * i as f32 / (n - 1) as f32;
    let mut plot = LinePlot::new(
        "View correction: g(φ), and g(φ)·c(θ, φ) of one sphere at a few θ",
        "φ, angle between normal and view (degrees)",
        "factor",
    )
    .with_x_range(0.0, 90.0)
    .with_size_px(900, 560);
    for (c, (name, color)) in CHANNEL_COLORS.into_iter().enumerate() {
        let points = chosen
            .g_phi
            .iter()
            .enumerate()
            .map(|(i, g)| (phi_deg(i, chosen.g_phi.len()), g[c]))
            .collect();
        plot = plot.with_series(Series::new(format!("g(φ) {name}"), color, points));
    }
    // The correction is per sphere: shown for the middle one by curvature.
    let mut order: Vec<usize> = (0..fit.samples.len()).collect();
    order.sort_by(|&a, &b| {
        fit.samples[a]
            .curvature_per_mm
            .total_cmp(&fit.samples[b].curvature_per_mm)
    });
    if let (Some(_), Some(&sphere)) = (&chosen.correction, order.get(order.len() / 2)) {
        let radius_mm = 1.0 / fit.samples[sphere].curvature_per_mm;
        for (j, theta_deg) in [30.0_f32, 60.0, 80.0, 100.0, 120.0].into_iter().enumerate() {
            let points = (0..=45)
                .map(|i| {
                    let phi = (2.0 * i as f32).to_radians();
                    (
                        2.0 * i as f32,
                        chosen.view_factor(sphere, theta_deg.to_radians(), phi).y,
                    )
                })
                // Only where a sphere lit at 90° to the view has data: φ ≥ |90° − θ|.
                .filter(|(phi_deg, _)| *phi_deg >= (90.0 - theta_deg).abs())
                .collect();
            let color = Colormap::Inferno.color_at(0.15 + 0.17 * j as f32);
            plot = plot.with_series(
                Series::new(
                    format!("G, θ = {theta_deg}°, r = {radius_mm:.3} mm"),
                    color,
                    points,
                )
                .with_style(LineStyle::Dashed),
            );
        }
    }
    plot.to_svg()
}

/// Radius of sphere `k`, mm: the manifest's, or 1/κ of its samples (a fit without reports).
fn radius_mm(fit: &Fit, k: usize) -> f32 {
    fit.spheres
        .get(k)
        .map_or(1.0 / fit.samples[k].curvature_per_mm, |s| s.radius_mm)
}

/// Channel names and colours of the per-channel plots (Okabe & Ito vermillion, bluish green,
/// blue).
const CHANNEL_COLORS: [(&str, [u8; 3]); 3] = [
    ("R", [213, 94, 0]),
    ("G", [0, 158, 115]),
    ("B", [0, 114, 178]),
];

/// The shadow side of every sphere against the chord the light crossed (markers coloured by
/// radius, all three channels), and the fitted T(d, 1) per channel (lines in the channel's
/// colour), log radiance. When the fit failed, the nodes it would have used and the reason.
fn transmission_plot(fit: &Fit) -> String {
    let (points, title) = match &fit.transmission {
        Ok(transmission) => (
            std::array::from_fn(|c| transmission.channels[c].points.clone()),
            format!(
                "Shadow side (θ ≥ {}°; R, G, B dots per radius) ÷ μ = |cos θ| against the chord d = 2r·|cos θ|; lines: A·exp(−d/ℓ)",
                transmission.settings.min_theta_deg
            ),
        ),
        Err(error) => {
            let settings = &fit.transmission_settings;
            let curvatures: Vec<f32> = fit.samples.iter().map(|s| s.curvature_per_mm).collect();
            let spheres = SphereCurve::all_from_fit(&fit.curves.chosen, &curvatures);
            (
                shadow_points(&spheres, settings),
                format!(
                    "Shadow side (θ ≥ {}°; R, G, B dots per radius) ÷ μ = |cos θ| against the chord d; T(d, μ) not fitted: {}",
                    settings.min_theta_deg,
                    match error {
                        TransmissionError::TooFewPoints { .. } => "too few points",
                        TransmissionError::NoDecay { .. } => "no decay",
                        _ => "see report.json",
                    }
                ),
            )
        }
    };
    let radii: Vec<f32> = fit
        .samples
        .iter()
        .map(|s| 1.0 / s.curvature_per_mm)
        .collect();
    let (lo, hi) = radii
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), r| (a.min(*r), b.max(*r)));
    let radius_color = |r: f32| {
        let t = if hi > lo { (r - lo) / (hi - lo) } else { 0.5 };
        Colormap::Viridis.color_at(0.9 * t)
    };
    let mut plot = LinePlot::new(
        title,
        "d, chord the light crossed (mm)",
        "π·L/E ÷ μ (view correction and entry cosine μ = |cos θ| divided out)",
    )
    .with_log_y(true)
    .with_size_px(900, 560);
    let sphere_points = |points: &[ChordPoint], k: usize| -> Vec<(f32, f32)> {
        points
            .iter()
            .filter(|p| p.sphere == k)
            .map(|p| (p.chord_mm, p.value_per_entry_cosine() as f32))
            .collect()
    };
    for (k, &radius_mm) in radii.iter().enumerate() {
        for (c, channel_points) in points.iter().enumerate() {
            // One legend entry per sphere (its colour), on the first channel.
            let label = if c == 0 {
                // To 0.01 mm: 1/κ of a 15 mm sphere reads 14.999999.
                format!("r = {} mm", (radius_mm * 100.0).round() / 100.0)
            } else {
                String::new()
            };
            plot = plot.with_series(
                Series::new(
                    label,
                    radius_color(radius_mm),
                    sphere_points(channel_points, k),
                )
                .with_style(LineStyle::Markers),
            );
        }
    }
    if let Ok(transmission) = &fit.transmission {
        let profile = &transmission.profile;
        for (c, (name, color)) in CHANNEL_COLORS.into_iter().enumerate() {
            let (start, end) = transmission.channels[c].chord_range_mm;
            let curve = (0..=200)
                .map(|i| {
                    let d = start + (end - start) * i as f32 / 200.0;
                    (d, profile.evaluate(d, 1.0)[c])
                })
                .collect();
            plot = plot.with_series(Series::new(
                format!(
                    "T(d, 1) {name}: A = {:.3}, ℓ = {:.2} mm",
                    profile.amplitude[c], profile.length_mm[c]
                ),
                color,
                curve,
            ));
        }
    }
    plot.to_svg()
}

/// The diffusion profile per channel as 2π·d·R(d) (the share of the light leaving per mm of
/// distance), log, 0–40 mm; the title gives the entry power and how well the profile alone
/// reproduces the spheres. When the fit failed, an empty plot titled with the reason.
fn profile_plot(fit: &Fit) -> String {
    let title = match &fit.diffusion {
        Ok(d) => format!(
            "Diffusion profile, entry factor μ^{:.2}; alone it fits the spheres to {:.1} / {:.1} / {:.1} % RMS",
            d.profile.entry_cosine_power(),
            100.0 * d.relative_rms[0],
            100.0 * d.relative_rms[1],
            100.0 * d.relative_rms[2]
        ),
        Err(error) => format!("Diffusion profile not fitted: {error}"),
    };
    let mut plot = LinePlot::new(
        title,
        "d, distance from where the light entered (mm)",
        "2π·d·R(d), share of the light leaving per mm of distance (mm⁻¹)",
    )
    .with_log_y(true)
    .with_x_range(0.0, 40.0)
    .with_size_px(900, 560);
    if let Ok(diffusion) = &fit.diffusion {
        let albedo = diffusion.profile.albedo();
        for (c, (name, color)) in CHANNEL_COLORS.into_iter().enumerate() {
            let curve = (0..=400)
                .map(|i| {
                    let d = 0.1 * i as f64;
                    (d as f32, diffusion.profile.ring_density_per_mm(d)[c] as f32)
                })
                .filter(|(_, v)| *v > 0.0)
                .collect();
            plot = plot.with_series(Series::new(
                format!("{name}: albedo Σw = {:.3}", albedo[c]),
                color,
                curve,
            ));
        }
    }
    plot.to_svg()
}

/// The table as a picture, θ across (0° left, 180° right), κ down (flattest at the top): above,
/// in colour (sRGB, exposure 1, as a white-lit surface would look); below, log₁₀ of the green
/// channel over six decades (inferno), so the shadow side shows.
fn lut_picture(fit: &Fit) -> image::RgbImage {
    let lut = &fit.lut;
    let (width, height) = (lut.theta_count(), lut.curvature_axis().count);
    let colour = upscale_nearest(&rgb_png_srgb(lut.radiance(), width, height, 1.0), 2, 4);
    let green: Vec<f32> = lut.radiance().iter().map(|v| v.y).collect();
    let peak = green.iter().copied().fold(0.0_f32, f32::max).max(1e-12);
    let scale = ColorScale::log()
        .with_colormap(Colormap::Inferno)
        .with_range(peak * 1e-6, peak);
    let log = upscale_nearest(&heatmap_png(&green, width, height, scale), 2, 4);
    let mut picture = image::RgbImage::new(colour.width(), colour.height() * 2 + 4);
    image::imageops::replace(&mut picture, &colour, 0, 0);
    image::imageops::replace(&mut picture, &log, 0, i64::from(colour.height()) + 4);
    picture
}
