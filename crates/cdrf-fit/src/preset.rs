//! Material presets without photographs: a CDRF table and a Gaussian CDRF from a named medium
//! or from scattering coefficients, the two files `cdrf-fit` writes and the renderer reads.
//!
//! A preset pre-integrates a radial diffusion profile over the ring through the normal and the
//! light (Penner & Borshukov 2011; [`PreintegratedCdrf`]), for the dipole of Jensen et al.
//! (2001) with a medium's reduced scattering σs′ and absorption σa, or for d'Eon & Luebke's
//! sum-of-Gaussians skin. `cdrf-preset NAME --out DIR` writes the result as
//! [`MEASURED_LUT`] and [`GAUSSIAN`] ([`write_preset`]).
//!
//! ```
//! use cdrf_core::lut::Filter;
//! use cdrf_fit::preset::{Preset, PresetSettings};
//!
//! let marble = Preset::named("marble")?; // names are case-insensitive
//! let lut = marble.build_lut(&PresetSettings { curvature_count: 5, theta_count: 19, ..Default::default() })?;
//! // A flat surface lit head-on reflects the medium's albedo R_d (π·L/E).
//! let flat = lut.sample(0.0, 0.0, Filter::Bilinear);
//! assert!((f64::from(flat.x) - marble.albedo()[0]).abs() < 1e-6);
//! # Ok::<(), cdrf_fit::preset::PresetError>(())
//! ```
//!
//! # Albedo
//! Ring pre-integration divides by the ring integral of the profile: every curve it gives has
//! unit mass, and a flat surface lit at θ gives exactly `cos θ`, a *white* material. A preset
//! must carry the medium's colour, so its table is
//!
//! ```text
//! f(κ, θ) = R_d · D(θ, 1/κ)      per RGB channel, π·L/E,
//! ```
//!
//! with `R_d` the total diffuse reflectance of the profile, the fraction of the light entering a
//! flat slab that leaves it again ([`Preset::albedo`]: for the dipole
//! [`DipoleProfile::total_diffuse_reflectance`], for d'Eon's skin the sum of the Gaussians'
//! weights, which d'Eon & Luebke normalise to 1: their skin is white, its colour comes from a
//! diffuse texture). A flat surface lit head-on then gives `R_d`, and a white Lambertian surface
//! would give 1. Fresnel transmission at entry and exit (Jensen's `F_t(η, ω)` factors) is left
//! out: the table is the diffuse term only, as a cross-polarised photograph sees it.
//!
//! # What a preset cannot know
//! - **The view correction** g(θ, φ): a measured table divides the dependence on the viewing
//!   angle φ out of its photographs. A preset has none, so g ≡ 1 (`ViewCorrection::identity`):
//!   radiance does not change with the view.
//! - **The measured near field**: the dipole (or the Gaussians) stands for the real
//!   medium's light transport, which differs most close to the point of entry and on the shadow
//!   side of small objects. The table has no coverage, translucency or diffusion profile; the
//!   renderer's non-local terms need a measured `measured.exr`.
//!
//! # Axes
//! Curvature κ from 0 (flat: row 0 is exactly `R_d · cos⁺θ`) to
//! [`PresetSettings::max_curvature_per_mm`] (default 1 mm⁻¹, spheres down to r = 1 mm; past it
//! the table clamps, like every LUT), uniform in κ with 257 rows by default (Δκ = 1/256 mm⁻¹, so
//! the wax spheres' 1/50 … 1/15 mm⁻¹ span a dozen rows); θ over 0 … 180° in 361 columns (0.5°),
//! the `cdrf-fit` default.

use std::fmt;
use std::path::{Path, PathBuf};

use cdrf_core::gaussian::{
    DipoleProfile, GaussianCdrf, ParameterError, PreintegratedCdrf, RadialProfile,
    SumOfGaussiansProfile, convolved_clamped_cosine,
};
use cdrf_core::gaussian_file::GaussianParameters;
use cdrf_core::lut::{Cdrf, CdrfLut, CurvatureAxis, LutError, ViewCorrection, theta_rad_at};
use cdrf_core::lut_file::{LutFileError, write_lut};
use rayon::prelude::*;

use crate::gaussian_fit::best_log_sigma;

pub use crate::outputs::{GAUSSIAN, MEASURED_LUT};

/// A medium of Jensen et al. (2001), table 2: reduced scattering σs′ and absorption σa, mm⁻¹
/// per RGB channel, measured at η = [`JENSEN_2001_ETA`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Medium {
    /// The name as the paper (and pbrt's `SubsurfaceParameterTable`) spells it.
    pub name: &'static str,
    /// Reduced scattering coefficient σs′ = σs·(1 − g), mm⁻¹ per RGB channel.
    pub sigma_s_prime_per_mm: [f32; 3],
    /// Absorption coefficient σa, mm⁻¹ per RGB channel.
    pub sigma_a_per_mm: [f32; 3],
}

/// The relative index of refraction of every medium in [`JENSEN_2001`].
pub const JENSEN_2001_ETA: f32 = 1.3;

/// Jensen, Marschner, Levoy & Hanrahan, "A Practical Model for Subsurface Light Transport"
/// (SIGGRAPH 2001), table 2, as pbrt's `SubsurfaceParameterTable` holds it (Spectralon, which
/// does not absorb, is left out: its dipole has no decay length). The one table of media.
pub const JENSEN_2001: [Medium; 11] = [
    medium("Apple", [2.29, 2.39, 1.97], [0.0030, 0.0034, 0.046]),
    medium("Chicken1", [0.15, 0.21, 0.38], [0.015, 0.077, 0.19]),
    medium("Chicken2", [0.19, 0.25, 0.32], [0.018, 0.088, 0.20]),
    medium("Cream", [7.38, 5.47, 3.15], [0.0002, 0.0028, 0.0163]),
    medium("Ketchup", [0.18, 0.07, 0.03], [0.061, 0.97, 1.45]),
    medium("Marble", [2.19, 2.62, 3.00], [0.0021, 0.0041, 0.0071]),
    medium("Potato", [0.68, 0.70, 0.55], [0.0024, 0.0090, 0.12]),
    medium("Skimmilk", [0.70, 1.22, 1.90], [0.0014, 0.0025, 0.0142]),
    medium("Skin1", [0.74, 0.88, 1.01], [0.032, 0.17, 0.48]),
    medium("Skin2", [1.09, 1.59, 1.79], [0.013, 0.070, 0.145]),
    medium("Wholemilk", [2.55, 3.21, 3.77], [0.0011, 0.0024, 0.014]),
];

/// The name of d'Eon & Luebke's six-Gaussian skin ([`SumOfGaussiansProfile::skin`]).
pub const DEON_SKIN: &str = "dEonSkin";

const fn medium(
    name: &'static str,
    sigma_s_prime_per_mm: [f32; 3],
    sigma_a_per_mm: [f32; 3],
) -> Medium {
    Medium {
        name,
        sigma_s_prime_per_mm,
        sigma_a_per_mm,
    }
}

/// Every name [`Preset::named`] accepts, in the order `--list` prints them.
pub fn preset_names() -> Vec<&'static str> {
    JENSEN_2001
        .iter()
        .map(|medium| medium.name)
        .chain([DEON_SKIN])
        .collect()
}

/// Why a preset could not be made or written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PresetError {
    /// The name is not in the table.
    #[error("unknown medium {name:?}; valid names (case-insensitive): {}", preset_names().join(", "))]
    UnknownMedium {
        /// The name given.
        name: String,
    },
    /// A scattering coefficient or η is out of range.
    #[error("medium: {0}")]
    Parameter(ParameterError),
    /// A table setting is out of range.
    #[error("table: {0}")]
    Table(LutError),
    /// The fitted Gaussian CDRF is invalid (a σ or scale not finite).
    #[error("Gaussian CDRF fit: {0}")]
    Gaussian(ParameterError),
    /// The output path exists and is not a folder.
    #[error("{}: exists and is not a folder: --out takes a folder", path.display())]
    NotAFolder {
        /// The path given.
        path: PathBuf,
    },
    /// A folder or file could not be created, written or moved.
    #[error("{}: {error}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// What the OS said.
        error: std::io::Error,
    },
    /// The LUT file could not be written.
    #[error(transparent)]
    LutFile(LutFileError),
}

/// The profile behind a preset.
#[derive(Clone, Debug, PartialEq)]
pub enum PresetProfile {
    /// Jensen et al.'s dipole.
    Dipole(DipoleProfile),
    /// d'Eon & Luebke's sum of Gaussians.
    SumOfGaussians(SumOfGaussiansProfile),
}

impl RadialProfile for PresetProfile {
    fn radial_reflectance(&self, distance_mm: f64) -> [f64; 3] {
        match self {
            Self::Dipole(p) => p.radial_reflectance(distance_mm),
            Self::SumOfGaussians(p) => p.radial_reflectance(distance_mm),
        }
    }
    fn feature_length_mm(&self) -> f64 {
        match self {
            Self::Dipole(p) => p.feature_length_mm(),
            Self::SumOfGaussians(p) => p.feature_length_mm(),
        }
    }
    fn support_radius_mm(&self) -> f64 {
        match self {
            Self::Dipole(p) => p.support_radius_mm(),
            Self::SumOfGaussians(p) => p.support_radius_mm(),
        }
    }
}

/// A medium ready to tabulate: its profile pre-integrated, scaled by its albedo `R_d` (see the
/// [module docs](self)). Implements [`Cdrf`] in the LUT convention π·L/E.
#[derive(Clone, Debug, PartialEq)]
pub struct Preset {
    name: String,
    description: String,
    cdrf: PreintegratedCdrf<PresetProfile>,
    albedo: [f64; 3],
}

impl Preset {
    /// A named medium: one of [`JENSEN_2001`] (η = 1.3) or [`DEON_SKIN`], matched without
    /// regard to case.
    ///
    /// # Errors
    /// [`PresetError::UnknownMedium`], listing the valid names.
    pub fn named(name: &str) -> Result<Self, PresetError> {
        if name.eq_ignore_ascii_case(DEON_SKIN) {
            let profile = SumOfGaussiansProfile::skin();
            let albedo = profile.total_weights().map(f64::from);
            return Ok(Self {
                name: DEON_SKIN.to_owned(),
                description: "d'Eon & Luebke (GPU Gems 3, ch. 14) six-Gaussian skin profile, \
                              weights normalised to white"
                    .to_owned(),
                cdrf: PreintegratedCdrf::new(PresetProfile::SumOfGaussians(profile)),
                albedo,
            });
        }
        let medium = JENSEN_2001
            .iter()
            .find(|medium| medium.name.eq_ignore_ascii_case(name))
            .ok_or_else(|| PresetError::UnknownMedium {
                name: name.to_owned(),
            })?;
        let mut preset = Self::dipole(
            medium.sigma_s_prime_per_mm,
            medium.sigma_a_per_mm,
            JENSEN_2001_ETA,
        )?;
        preset.name = medium.name.to_owned();
        preset.description = format!(
            "Jensen et al. 2001 table 2 \"{}\": {}",
            medium.name, preset.description
        );
        Ok(preset)
    }

    /// Any medium by Jensen et al.'s dipole: reduced scattering σs′ (> 0) and absorption σa
    /// (≥ 0), mm⁻¹ per RGB channel, and the relative index of refraction η (medium over
    /// outside; 1 for an index-matched boundary).
    ///
    /// # Errors
    /// [`PresetError::Parameter`] when a coefficient is negative, zero (σs′), NaN or infinite,
    /// or η is below about 0.75 or so large that the dipole's boundary term breaks down.
    pub fn dipole(
        sigma_s_prime_per_mm: [f32; 3],
        sigma_a_per_mm: [f32; 3],
        eta: f32,
    ) -> Result<Self, PresetError> {
        let profile = DipoleProfile::new(sigma_a_per_mm, sigma_s_prime_per_mm, eta)
            .map_err(PresetError::Parameter)?;
        let albedo = profile.total_diffuse_reflectance();
        Ok(Self {
            name: "custom".to_owned(),
            description: format!(
                "dipole (Jensen et al. 2001), sigma_s_prime_per_mm = {}, sigma_a_per_mm = {}, eta = {eta}",
                Rgb(sigma_s_prime_per_mm),
                Rgb(sigma_a_per_mm)
            ),
            cdrf: PreintegratedCdrf::new(PresetProfile::Dipole(profile)),
            albedo,
        })
    }

    /// The name (`custom` for [`Preset::dipole`]).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Where the medium comes from and its parameters, as the LUT's provenance says it.
    pub fn description(&self) -> &str {
        &self.description
    }

    /// The profile.
    pub fn profile(&self) -> &PresetProfile {
        self.cdrf.profile()
    }

    /// The total diffuse reflectance `R_d` per RGB channel: the table's value for a flat
    /// surface lit head-on (see the [module docs](self)).
    pub fn albedo(&self) -> [f64; 3] {
        self.albedo
    }

    /// `R_d · D(θ, 1/κ)` in `f64`, π·L/E.
    pub fn reflectance_f64(&self, curvature_per_mm: f64, theta_rad: f64) -> [f64; 3] {
        let d = self.cdrf.reflectance_f64(curvature_per_mm, theta_rad);
        std::array::from_fn(|c| self.albedo[c] * d[c])
    }

    /// The table on `settings`' axes and Kubo's Gaussian CDRF fitted to it
    /// ([`fit_gaussian_to_lut`]): what `cdrf-preset` writes and the viewer's material picker
    /// shows.
    ///
    /// # Errors
    /// As [`Preset::build_lut`] and [`fit_gaussian_to_lut`].
    pub fn build_tables(
        &self,
        settings: &PresetSettings,
    ) -> Result<(CdrfLut, GaussianCdrf), PresetError> {
        let lut = self.build_lut(settings)?;
        let gaussian = fit_gaussian_to_lut(&lut)?;
        Ok((lut, gaussian))
    }

    /// The table on `settings`' axes, with g ≡ 1 and provenance naming the preset and medium.
    ///
    /// # Errors
    /// [`PresetError::Table`] when the axes are invalid (fewer than 2 rows or θ columns, a
    /// maximum curvature that is not finite and > 0).
    pub fn build_lut(&self, settings: &PresetSettings) -> Result<CdrfLut, PresetError> {
        let axis = CurvatureAxis {
            min_per_mm: 0.0,
            max_per_mm: settings.max_curvature_per_mm,
            count: settings.curvature_count,
        };
        if settings.curvature_count < 2 {
            return Err(PresetError::Table(LutError::BadCurvatureAxis(axis)));
        }
        let albedo = self.albedo;
        let lut = CdrfLut::tabulate(self, axis, settings.theta_count)
            .map_err(PresetError::Table)?
            .with_view_correction(ViewCorrection::identity())
            .with_provenance("tool", format!("cdrf-preset {}", env!("CARGO_PKG_VERSION")))
            .with_provenance("source", "preset (no photographs)")
            .with_provenance("preset", self.name.clone())
            .with_provenance("medium", self.description.clone())
            .with_provenance(
                "albedo",
                format!(
                    "R_d = [{:.6}, {:.6}, {:.6}]: the table is R_d times the unit-mass ring pre-integration (Penner & Borshukov 2011)",
                    albedo[0], albedo[1], albedo[2]
                ),
            )
            .with_provenance(
                "view_correction",
                "none (g = 1): a preset has no photographs to measure it from",
            );
        Ok(lut)
    }
}

impl Cdrf for Preset {
    fn reflectance(&self, curvature_per_mm: f32, theta_rad: f32) -> [f32; 3] {
        self.reflectance_f64(f64::from(curvature_per_mm), f64::from(theta_rad))
            .map(|v| v as f32)
    }
}

/// The axes of a preset's table. `Default` is what `cdrf-preset` uses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PresetSettings {
    /// Curvature of the last row, mm⁻¹ (row 0 is κ = 0, flat).
    pub max_curvature_per_mm: f32,
    /// Rows, uniform in κ, at least 2.
    pub curvature_count: usize,
    /// Columns over θ ∈ [0, π], at least 2.
    pub theta_count: usize,
}

impl Default for PresetSettings {
    fn default() -> Self {
        Self {
            max_curvature_per_mm: 1.0,
            curvature_count: 257,
            theta_count: 361,
        }
    }
}

/// The Gaussian fit uses at most this many rows and columns of the table (every k-th).
const FIT_MAX_ROWS: usize = 65;
/// See [`FIT_MAX_ROWS`].
const FIT_MAX_COLUMNS: usize = 181;

/// Kubo's Gaussian CDRF fitted to a table, per channel: σ (mm) and scale minimising the plain
/// squared error `Σ (scale · K(θ; σκ) − f(κ, θ))²` over the table's rows and θ columns (at most
/// 65 × 181 of them, evenly strided; every curvature alike). For a σ the best scale is closed
/// form; σ is found by a log-spaced scan over 0.01 … 100 mm and golden-section refinement.
/// (`cdrf-fit`'s own fit works on photograph samples and their view correction, which a preset
/// does not have.)
///
/// # Errors
/// [`PresetError::Gaussian`] when the table holds nothing to fit (σ or scale not finite).
pub fn fit_gaussian_to_lut(lut: &CdrfLut) -> Result<GaussianCdrf, PresetError> {
    let axis = lut.curvature_axis();
    let row_stride = axis.count.div_ceil(FIT_MAX_ROWS).max(1);
    let column_stride = lut.theta_count().div_ceil(FIT_MAX_COLUMNS).max(1);
    // (κ, θ, f) of every texel used.
    let texels: Vec<(f64, f64, [f64; 3])> = (0..axis.count)
        .step_by(row_stride)
        .flat_map(|row| {
            (0..lut.theta_count())
                .step_by(column_stride)
                .map(move |column| (row, column))
        })
        .map(|(row, column)| {
            let value = lut.row(row)[column];
            (
                f64::from(axis.curvature_per_mm(row)),
                f64::from(theta_rad_at(column, lut.theta_count())),
                value.to_array().map(f64::from),
            )
        })
        .collect();
    let per_channel: Vec<(f64, f64)> = (0..3_usize)
        .into_par_iter()
        .map(|c| {
            // (Σ K·f, Σ K²) for a σ.
            let moments = |sigma: f64| {
                texels
                    .iter()
                    .fold((0.0, 0.0), |(kf, kk), &(kappa, theta, f)| {
                        let k = convolved_clamped_cosine(theta, sigma * kappa);
                        (kf + k * f[c], kk + k * k)
                    })
            };
            let explained = |log_sigma: f64| {
                let (kf, kk) = moments(log_sigma.exp());
                if kk > 0.0 { kf * kf / kk } else { 0.0 }
            };
            let sigma = best_log_sigma(&explained, 40, 40).exp();
            let (kf, kk) = moments(sigma);
            (sigma, if kk > 0.0 { kf / kk } else { f64::NAN })
        })
        .collect();
    GaussianCdrf::with_scale(
        [0, 1, 2].map(|c| per_channel[c].0 as f32),
        [0, 1, 2].map(|c| per_channel[c].1 as f32),
    )
    .map_err(PresetError::Gaussian)
}

/// What [`write_preset`] wrote.
#[derive(Clone, Debug)]
pub struct WrittenPreset {
    /// The files, `out_dir/measured.exr` and `out_dir/gaussian.toml`.
    pub files: Vec<PathBuf>,
    /// The Gaussian CDRF written to `gaussian.toml`.
    pub gaussian: GaussianCdrf,
}

/// Builds `preset`'s table and Gaussian CDRF and writes them into `out_dir` (created if
/// missing) as [`MEASURED_LUT`] and [`GAUSSIAN`] (whose `view_correction_from` names the
/// table, as `cdrf-fit`'s does; its g is 1).
///
/// Everything is computed before anything is written; both files are written into a staging
/// folder `out_dir/.cdrf-partial-*` and then renamed into place, so a failure leaves no partial
/// file (and removes `out_dir` again when this call created it and it is empty).
///
/// # Errors
/// [`PresetError::NotAFolder`] when `out_dir` is an existing file, [`PresetError::Table`] for
/// bad settings, [`PresetError::Io`] / [`PresetError::LutFile`] when writing fails.
pub fn write_preset(
    preset: &Preset,
    settings: &PresetSettings,
    out_dir: &Path,
) -> Result<WrittenPreset, PresetError> {
    if out_dir.exists() && !out_dir.is_dir() {
        return Err(PresetError::NotAFolder {
            path: out_dir.to_path_buf(),
        });
    }
    let (lut, gaussian) = preset.build_tables(settings)?;
    let parameters = GaussianParameters {
        sigma_mm: gaussian.sigma_mm(),
        scale: gaussian.scale(),
        view_correction_from: Some(MEASURED_LUT.into()),
    };
    let toml = format!(
        "# Fitted by cdrf-preset to the preset table {MEASURED_LUT} (medium: {}; no photographs, g = 1).\n{}",
        preset.description().replace('\n', " "),
        parameters.to_toml_string()
    );

    let created = !out_dir.exists();
    let result = stage_and_move(&lut, toml.as_bytes(), out_dir);
    if result.is_err() && created {
        // Only removes an empty folder: never anything that was there before.
        let _ = std::fs::remove_dir(out_dir);
    }
    Ok(WrittenPreset {
        files: result?,
        gaussian,
    })
}

/// Writes both files into a staging folder inside `out_dir`, then renames them into place.
fn stage_and_move(lut: &CdrfLut, toml: &[u8], out_dir: &Path) -> Result<Vec<PathBuf>, PresetError> {
    let io_error = |path: &Path| {
        let path = path.to_path_buf();
        move |error| PresetError::Io { path, error }
    };
    std::fs::create_dir_all(out_dir).map_err(io_error(out_dir))?;
    let staging = out_dir.join(format!(
        ".cdrf-partial-preset-{}-{}",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos())
    ));
    std::fs::create_dir(&staging).map_err(io_error(&staging))?;
    let written = write_and_move(lut, toml, &staging, out_dir);
    let _ = std::fs::remove_dir_all(&staging);
    written
}

/// Writes both files into `staging`, then renames them into `out_dir`.
fn write_and_move(
    lut: &CdrfLut,
    toml: &[u8],
    staging: &Path,
    out_dir: &Path,
) -> Result<Vec<PathBuf>, PresetError> {
    let io_error = |path: &Path| {
        let path = path.to_path_buf();
        move |error| PresetError::Io { path, error }
    };
    write_lut(lut, staging.join(MEASURED_LUT)).map_err(PresetError::LutFile)?;
    let toml_path = staging.join(GAUSSIAN);
    cdrf_core::atomic::write_file(&toml_path, |file| std::io::Write::write_all(file, toml))
        .map_err(io_error(&toml_path))?;
    let mut files = Vec::with_capacity(2);
    for name in [MEASURED_LUT, GAUSSIAN] {
        let target = out_dir.join(name);
        std::fs::rename(staging.join(name), &target).map_err(io_error(&target))?;
        files.push(target);
    }
    Ok(files)
}

/// An RGB triple as `[a, b, c]`.
struct Rgb([f32; 3]);

impl fmt::Display for Rgb {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "[{}, {}, {}]", self.0[0], self.0[1], self.0[2])
    }
}
