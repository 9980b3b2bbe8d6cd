//! Material presets without photographs: a CDRF table and a Gaussian CDRF from a named medium
//! or from scattering coefficients, the two files `cdrf-fit` writes and the renderer reads.
//!
//! Two models make the table:
//! - **Simulated spheres** (the default, [`Preset::simulate`]): [`crate::simulation`] renders
//!   the spheres a technical artist would have photographed (Monte Carlo light transport in
//!   the medium, radii 5 … 50 mm) and the unchanged fit turns them into a table
//!   ([`simulated`]). The result is a full measured table: view correction, transmission and
//!   diffusion profile, so every render mode works with it. It costs up to a minute; a
//!   [`cache::PresetCache`] makes asking again free.
//! - **The dipole** ([`Preset::build_lut`], `--model dipole`): the radial diffusion profile
//!   pre-integrated over the ring through the normal and the light (Penner & Borshukov 2011;
//!   [`PreintegratedCdrf`]), for the dipole of Jensen et al. (2001) or d'Eon & Luebke's
//!   sum-of-Gaussians skin. Instant, for comparison: it has no view correction, no non-local
//!   data, and on the wax spheres it is 8–13 % off on the lit side and carries a sixth of the
//!   light past the terminator (docs/presets.md).
//!
//! `cdrf-preset NAME --out DIR` writes the result as [`MEASURED_LUT`] and [`GAUSSIAN`]
//! ([`write_preset`]). The media are [`crate::media::MEDIA`].
//!
//! ```
//! use cdrf_core::lut::Filter;
//! use cdrf_fit::preset::{Preset, PresetSettings};
//!
//! let marble = Preset::named("marble")?; // names are case-insensitive
//! let lut = marble.build_lut(&PresetSettings { curvature_count: 5, theta_count: 19, ..Default::default() })?;
//! // The dipole's table: a flat surface lit head-on reflects the medium's albedo R_d (π·L/E).
//! let flat = lut.sample(0.0, 0.0, Filter::Bilinear);
//! assert!((f64::from(flat.x) - marble.dipole_cdrf()?.albedo()[0]).abs() < 1e-6);
//! # Ok::<(), cdrf_fit::preset::PresetError>(())
//! ```
//!
//! # The dipole's albedo
//! Ring pre-integration divides by the ring integral of the profile: every curve it gives has
//! unit mass, and a flat surface lit at θ gives exactly `cos θ`, a *white* material. The dipole
//! table therefore is
//!
//! ```text
//! f(κ, θ) = R_d · D(θ, 1/κ)      per RGB channel, π·L/E,
//! ```
//!
//! with `R_d` the total diffuse reflectance of the profile ([`DipoleCdrf::albedo`]: for the dipole
//! [`DipoleProfile::total_diffuse_reflectance`], for d'Eon's skin the sum of the Gaussians'
//! weights, normalised to 1: their skin is white, its colour comes from a diffuse texture).
//! Fresnel transmission is left out: the table is the diffuse term only, as a cross-polarised
//! photograph sees it. Its view correction is 1 and it has no non-local data.
//!
//! # The dipole's axes
//! Curvature κ from 0 (flat: row 0 is exactly `R_d · cos⁺θ`) to
//! [`PresetSettings::max_curvature_per_mm`] (default 1 mm⁻¹) in 257 rows by default; θ over
//! 0 … 180° in 361 columns (0.5°). The simulated table's axes are the fit's: the spheres'
//! curvatures, clamped beyond them, like every measured table.

pub mod cache;
pub mod simulated;

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
use crate::media::{self, MEDIA};
use crate::simulation::{ScatteringMedium, SimulationError};

use cache::PresetCache;
use simulated::{SimulatedFitError, SimulatedSettings, SimulatedSphereReport};

pub use crate::outputs::{GAUSSIAN, MEASURED_LUT};

/// d'Eon & Luebke's six-Gaussian skin, the one preset that is a profile and not a medium
/// (dipole model only).
pub const DEON_SKIN: &str = "dEonSkin";

/// Every preset name: the media of [`MEDIA`] and [`DEON_SKIN`].
pub fn preset_names() -> Vec<&'static str> {
    MEDIA
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
    /// The medium cannot be simulated (coefficients, g or η out of the simulator's range).
    #[error("{name}: {error}")]
    NotSimulable {
        /// The preset.
        name: String,
        /// Why.
        error: SimulationError,
    },
    /// d'Eon's skin is a profile, not a medium: only the dipole model makes it.
    #[error("{0} is a sum of Gaussians, not a scattering medium: use --model dipole")]
    NoMedium(String),
    /// Simulating or fitting the spheres failed.
    #[error(transparent)]
    Simulated(#[from] SimulatedFitError),
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

/// A named or custom material: its scattering medium (for the simulated spheres) and its
/// profile pre-integrated and scaled by its albedo `R_d` (the dipole model; see the
/// [module docs](self)). Implements [`Cdrf`] in the LUT convention π·L/E by the dipole.
#[derive(Clone, Debug, PartialEq)]
pub struct Preset {
    name: String,
    description: String,
    medium: Result<ScatteringMedium, SimulationError>,
    dipole: Result<DipoleCdrf, ParameterError>,
}

/// The dipole model of a preset: its profile pre-integrated over the ring, scaled by its
/// albedo `R_d` (see the [module docs](self)). Implements [`Cdrf`] in the LUT convention π·L/E.
#[derive(Clone, Debug, PartialEq)]
pub struct DipoleCdrf {
    cdrf: PreintegratedCdrf<PresetProfile>,
    albedo: [f64; 3],
}

impl Preset {
    /// A named medium from [`MEDIA`] (with its own η) or [`DEON_SKIN`], matched without
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
                medium: Err(SimulationError::Settings("not a medium")),
                dipole: Ok(DipoleCdrf {
                    cdrf: PreintegratedCdrf::new(PresetProfile::SumOfGaussians(profile)),
                    albedo,
                }),
            });
        }
        let named = media::find(name).ok_or_else(|| PresetError::UnknownMedium {
            name: name.to_owned(),
        })?;
        let medium = ScatteringMedium::new(
            named.sigma_s_per_mm,
            named.sigma_a_per_mm,
            named.g,
            named.eta,
        )
        .map_err(|error| PresetError::NotSimulable {
            name: named.name.to_owned(),
            error,
        })?;
        let mut preset = Self::from_medium(medium)?;
        preset.name = named.name.to_owned();
        preset.description = format!(
            "{} \"{}\": {}",
            named.source, named.name, preset.description
        );
        Ok(preset)
    }

    /// The same medium with another relative index of refraction (`--eta` on a named medium).
    ///
    /// # Errors
    /// When the new η is out of the simulator's or the dipole's range.
    pub fn with_eta(&self, eta: f64) -> Result<Self, PresetError> {
        let Ok(medium) = self.medium else {
            return Err(PresetError::NoMedium(self.name.clone()));
        };
        let changed =
            ScatteringMedium::new(medium.sigma_s_per_mm, medium.sigma_a_per_mm, medium.g, eta)
                .map_err(|error| PresetError::NotSimulable {
                    name: self.name.clone(),
                    error,
                })?;
        let mut preset = Self::from_medium(changed)?;
        preset.name.clone_from(&self.name);
        preset.description = self.description.replace(
            &format!("eta = {}", medium.eta),
            &format!("eta = {eta} (published: {})", medium.eta),
        );
        Ok(preset)
    }

    /// Any medium: scattering σs, absorption σa (mm⁻¹), Henyey–Greenstein g and relative index
    /// η. Its dipole uses the reduced scattering σs′ = σs·(1 − g).
    ///
    /// # Errors
    /// Never for a checked medium; the dipole's own range is checked when its table is built
    /// ([`Preset::dipole_cdrf`]).
    pub fn from_medium(medium: ScatteringMedium) -> Result<Self, PresetError> {
        let reduced: [f32; 3] =
            std::array::from_fn(|c| (medium.sigma_s_per_mm[c] * (1.0 - medium.g)) as f32);
        let absorption = medium.sigma_a_per_mm.map(|a| a as f32);
        Ok(Self {
            name: "custom".to_owned(),
            description: format!(
                "sigma_s_per_mm = {}, sigma_a_per_mm = {}, g = {}, eta = {}",
                Rgb(medium.sigma_s_per_mm.map(|v| v as f32)),
                Rgb(absorption),
                medium.g,
                medium.eta
            ),
            medium: Ok(medium),
            dipole: DipoleCdrf::new(reduced, absorption, medium.eta as f32),
        })
    }

    /// Any medium by Jensen et al.'s dipole: reduced scattering σs′ (> 0) and absorption σa
    /// (≥ 0), mm⁻¹ per RGB channel, and the relative index of refraction η (medium over
    /// outside; 1 for an index-matched boundary). Simulated, it is isotropic with σs = σs′.
    ///
    /// # Errors
    /// [`PresetError::Parameter`] when a coefficient is negative, zero (σs′), NaN or infinite,
    /// or η is below about 0.75 or so large that the dipole's boundary term breaks down.
    pub fn dipole(
        sigma_s_prime_per_mm: [f32; 3],
        sigma_a_per_mm: [f32; 3],
        eta: f32,
    ) -> Result<Self, PresetError> {
        let dipole = DipoleCdrf::new(sigma_s_prime_per_mm, sigma_a_per_mm, eta)
            .map_err(PresetError::Parameter)?;
        Ok(Self {
            name: "custom".to_owned(),
            description: format!(
                "dipole (Jensen et al. 2001), sigma_s_prime_per_mm = {}, sigma_a_per_mm = {}, eta = {eta}",
                Rgb(sigma_s_prime_per_mm),
                Rgb(sigma_a_per_mm)
            ),
            medium: ScatteringMedium::new(
                sigma_s_prime_per_mm.map(f64::from),
                sigma_a_per_mm.map(f64::from),
                0.0,
                f64::from(eta),
            ),
            dipole: Ok(dipole),
        })
    }

    /// `lut` with the provenance every preset table carries: the tool, `source`, the preset's
    /// name and its medium.
    fn identified(&self, lut: CdrfLut, source: &str) -> CdrfLut {
        lut.with_provenance("tool", format!("cdrf-preset {}", env!("CARGO_PKG_VERSION")))
            .with_provenance("source", source)
            .with_provenance("preset", self.name.clone())
            .with_provenance("medium", self.description.clone())
    }

    /// The dipole model (or d'Eon's Gaussians), pre-integrated.
    ///
    /// # Errors
    /// [`PresetError::Parameter`] when the medium is outside the dipole's range (e.g. a channel
    /// that does not scatter, σs′ = 0).
    pub fn dipole_cdrf(&self) -> Result<&DipoleCdrf, PresetError> {
        self.dipole
            .as_ref()
            .map_err(|error| PresetError::Parameter(error.clone()))
    }

    /// The scattering medium the spheres are simulated in.
    ///
    /// # Errors
    /// [`PresetError::NoMedium`] for d'Eon's skin; [`PresetError::NotSimulable`] when the
    /// coefficients are out of the simulator's range.
    pub fn medium(&self) -> Result<&ScatteringMedium, PresetError> {
        match &self.medium {
            Ok(medium) => Ok(medium),
            Err(_) if self.name == DEON_SKIN => Err(PresetError::NoMedium(self.name.clone())),
            Err(error) => Err(PresetError::NotSimulable {
                name: self.name.clone(),
                error: error.clone(),
            }),
        }
    }

    /// The tables from simulated spheres ([`simulated::fit_simulated`]), through `cache` when
    /// given (a hit costs nothing). `progress` gets the photons traced so far, out of
    /// [`simulated::total_photons`]; a cache hit calls it with the total.
    ///
    /// # Errors
    /// When the preset has no medium, the simulation or the fit fails.
    pub fn simulate(
        &self,
        settings: &SimulatedSettings,
        cache: Option<&PresetCache>,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<PresetTables, PresetError> {
        let medium = self.medium()?;
        let key = cache::key(&self.name, medium, settings);
        if let Some(hit) = cache.and_then(|cache| cache.load(&key)) {
            progress(simulated::total_photons(medium, settings));
            return Ok(PresetTables {
                lut: hit.0,
                gaussian: hit.1,
                spheres: Vec::new(),
                cached: true,
            });
        }
        let fitted = simulated::fit_simulated(medium, settings, progress)?;
        let noise = fitted
            .spheres
            .iter()
            .map(|s| {
                format!(
                    "r = {} mm: {} photons, {} (worst channel)",
                    s.radius_mm, s.photons, s.noise
                )
            })
            .collect::<Vec<_>>()
            .join("; ");
        let sim = &settings.simulation;
        let lut = self
            .identified(
                fitted.fit.lut,
                "preset: simulated spheres (Monte Carlo), no photographs",
            )
            .with_provenance(
                "simulation",
                format!(
                    "radii_mm = {:?}, photons = {} per sphere (shared by the walks), seed = {}, image {} px with the sphere {} px in radius, batches = {}, estimator = {:?}",
                    settings.radii_mm,
                    sim.photons,
                    sim.seed,
                    sim.image_size_px,
                    sim.sphere_radius_px,
                    sim.batches,
                    fitted.spheres.first().map(|s| s.estimator),
                ),
            )
            .with_provenance("simulation_noise", noise)
            .with_provenance("cache_key", key.clone());
        let gaussian = fitted.fit.gaussian.model;
        if let Some(cache) = cache {
            // A cache that cannot be written costs the next run time, nothing else.
            let _ = cache.store(&key, &lut, &gaussian);
        }
        Ok(PresetTables {
            lut,
            gaussian,
            spheres: fitted.spheres,
            cached: false,
        })
    }

    /// The name (`custom` for [`Preset::dipole`] and [`Preset::from_medium`]).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Where the medium comes from and its parameters, as the LUT's provenance says it.
    pub fn description(&self) -> &str {
        &self.description
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
        let dipole = self.dipole_cdrf()?;
        let albedo = dipole.albedo;
        let table = CdrfLut::tabulate(dipole, axis, settings.theta_count)
            .map_err(PresetError::Table)?
            .with_view_correction(ViewCorrection::identity());
        let lut = self
            .identified(table, "preset (no photographs)")
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

impl DipoleCdrf {
    fn new(
        sigma_s_prime_per_mm: [f32; 3],
        sigma_a_per_mm: [f32; 3],
        eta: f32,
    ) -> Result<Self, ParameterError> {
        let profile = DipoleProfile::new(sigma_a_per_mm, sigma_s_prime_per_mm, eta)?;
        Ok(Self {
            albedo: profile.total_diffuse_reflectance(),
            cdrf: PreintegratedCdrf::new(PresetProfile::Dipole(profile)),
        })
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
}

impl Cdrf for DipoleCdrf {
    fn reflectance(&self, curvature_per_mm: f32, theta_rad: f32) -> [f32; 3] {
        self.reflectance_f64(f64::from(curvature_per_mm), f64::from(theta_rad))
            .map(|v| v as f32)
    }
}

/// Which model makes a preset's table.
#[derive(Clone, Debug, PartialEq)]
pub enum PresetModel {
    /// Simulated spheres through the fit (the default).
    Simulated(SimulatedSettings),
    /// The dipole (or d'Eon's Gaussians) pre-integrated over the ring.
    Dipole(PresetSettings),
}

impl Default for PresetModel {
    fn default() -> Self {
        Self::Simulated(SimulatedSettings::default())
    }
}

/// A preset's two tables and, when simulated, what each sphere's simulation reached.
#[derive(Clone, Debug)]
pub struct PresetTables {
    /// The CDRF table.
    pub lut: CdrfLut,
    /// Kubo's Gaussian CDRF (fitted to the spheres, or to the dipole's table).
    pub gaussian: GaussianCdrf,
    /// Per simulated sphere; empty for the dipole and for a cache hit.
    pub spheres: Vec<SimulatedSphereReport>,
    /// Whether the tables came from the cache.
    pub cached: bool,
}

impl Preset {
    /// The tables by `model`; see [`Preset::simulate`] for `cache` and `progress`.
    ///
    /// # Errors
    /// As [`Preset::simulate`] or [`Preset::build_tables`].
    pub fn tables(
        &self,
        model: &PresetModel,
        cache: Option<&PresetCache>,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<PresetTables, PresetError> {
        match model {
            PresetModel::Simulated(settings) => self.simulate(settings, cache, progress),
            PresetModel::Dipole(settings) => {
                let (lut, gaussian) = self.build_tables(settings)?;
                Ok(PresetTables {
                    lut,
                    gaussian,
                    spheres: Vec::new(),
                    cached: false,
                })
            }
        }
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
    /// The tables written and how they were made.
    pub tables: PresetTables,
}

/// Makes `preset`'s tables by `model` (see [`Preset::tables`]) and writes them into `out_dir`
/// (created if missing) as [`MEASURED_LUT`] and [`GAUSSIAN`] (whose `view_correction_from`
/// names the table, as `cdrf-fit`'s does).
///
/// Everything is computed before anything is written; both files are written into a staging
/// folder `out_dir/.cdrf-partial-*` and then renamed into place, so a failure leaves no partial
/// file (and removes `out_dir` again when this call created it and it is empty).
///
/// # Errors
/// [`PresetError::NotAFolder`] when `out_dir` is an existing file, the errors of
/// [`Preset::tables`], [`PresetError::Io`] / [`PresetError::LutFile`] when writing fails.
pub fn write_preset(
    preset: &Preset,
    model: &PresetModel,
    cache: Option<&PresetCache>,
    out_dir: &Path,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<WrittenPreset, PresetError> {
    if out_dir.exists() && !out_dir.is_dir() {
        return Err(PresetError::NotAFolder {
            path: out_dir.to_path_buf(),
        });
    }
    let tables = preset.tables(model, cache, progress)?;
    let parameters = GaussianParameters {
        sigma_mm: tables.gaussian.sigma_mm(),
        scale: tables.gaussian.scale(),
        view_correction_from: Some(MEASURED_LUT.into()),
    };
    let how = match model {
        PresetModel::Simulated(_) => "fitted by cdrf-preset to simulated spheres",
        PresetModel::Dipole(_) => "fitted by cdrf-preset to the dipole table (g = 1)",
    };
    let toml = format!(
        "# Kubo's Gaussian CDRF {how}; medium: {}; no photographs.\n{}",
        preset.description().replace('\n', " "),
        parameters.to_toml_string()
    );

    let created = !out_dir.exists();
    let result = stage_and_move(&tables.lut, toml.as_bytes(), out_dir);
    if result.is_err() && created {
        // Only removes an empty folder: never anything that was there before.
        let _ = std::fs::remove_dir(out_dir);
    }
    Ok(WrittenPreset {
        files: result?,
        tables,
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
