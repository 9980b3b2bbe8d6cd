//! The CDRF look-up table: radiance over curvature κ × light angle θ, with a view correction.
//!
//! # Radiance convention
//! Every value in a [`CdrfLut`] is **π·L/E** per RGB channel: the outgoing radiance `L` divided by
//! the irradiance `E` the light delivers to a surface facing it, times π. A white Lambertian
//! surface therefore has the table `max(cos θ, 0)` at every curvature, and a renderer turns the
//! table back into radiance with `L = E/π · f(κ, θ) · g(θ, φ)` summed over lights.
//!
//! # Axes
//! - **Curvature** κ in mm⁻¹ (κ = 1/r for a sphere of radius r mm): `curvature_count` rows,
//!   uniformly spaced from `curvature_min_per_mm` (row 0) to `curvature_max_per_mm` (last row),
//!   the end rows exactly on the range's ends. Outside the range the table is **clamped** to its
//!   first or last row: measured data says nothing about curvatures it was not measured at, and
//!   extrapolating a Catmull-Rom curve past the flattest or the most curved sphere amplifies
//!   noise and can go negative. A concave point (κ < 0) therefore shades like the flattest row.
//! - **Light angle** θ, uniform in **θ** (not cos θ) over `[0, π]` with `theta_count` columns,
//!   column `j` at θ = j·π/(theta_count − 1). Uniform θ spends the same resolution on the lit
//!   side, the terminator and the shadow side. A cos θ axis would crowd its samples around the
//!   terminator and starve both ends, and the far shadow side (θ → 180°, where small spheres
//!   glow from light travelling through them) is exactly where a measured table differs most
//!   from the Gaussian model. It also matches how the measurement bins its samples.
//!
//! # View correction g(θ, φ)
//! The poster divides the φ dependence (φ = angle between normal and view) out of the
//! measurement and re-applies it when rendering: `f(κ, θ) · g(φ)`, with g(0) = 1. The table keeps
//! g as a small grid over φ ∈ [0, π/2] × θ ∈ [0, π] ([`ViewCorrection`]); with one θ column it is
//! the poster's g(φ), with more it is a correction that also depends on θ, and cdrf-fit then
//! scales f so that it is the ideal photograph's mean over each θ ring instead of g(0) = 1.
//!
//! # Coverage
//! A table fitted from photographs can carry, per texel, how many samples it came from and how
//! much they spread ([`TexelCoverage`]); texels with zero samples were filled by interpolation.

use std::collections::BTreeMap;
use std::f32::consts::{FRAC_PI_2, PI};

use glam::Vec3;
use rayon::prelude::*;
use thiserror::Error;

use crate::catmull_rom::{self, Ends};
use crate::diffusion::DiffusionProfile;
use crate::translucency::Translucency;

/// A curvature-dependent reflectance function f(κ, θ).
///
/// Values are in the LUT's radiance convention, **π·L/E** per RGB channel: a white Lambertian
/// surface gives `max(cos θ, 0)`. `curvature_per_mm` is the mean curvature κ = 1/r in mm⁻¹ and
/// `theta_rad` the angle between the surface normal and the direction to the light, in
/// `[0, π]`.
pub trait Cdrf {
    /// f(κ, θ) per RGB channel, π·L/E.
    fn reflectance(&self, curvature_per_mm: f32, theta_rad: f32) -> [f32; 3];
}

/// The Lambertian reference: `albedo · max(cos θ, 0)` at every curvature.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lambert {
    /// Diffuse reflectance per RGB channel.
    pub albedo: [f32; 3],
}

impl Cdrf for Lambert {
    fn reflectance(&self, _curvature_per_mm: f32, theta_rad: f32) -> [f32; 3] {
        let cos = theta_rad.cos().max(0.0);
        self.albedo.map(|a| a * cos)
    }
}

/// The curvature axis of a table: `count` rows uniformly spaced over
/// `[min_per_mm, max_per_mm]`, both ends included.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurvatureAxis {
    /// Curvature of row 0, mm⁻¹.
    pub min_per_mm: f32,
    /// Curvature of the last row, mm⁻¹.
    pub max_per_mm: f32,
    /// Number of rows; 1 makes the table independent of curvature.
    pub count: usize,
}

impl CurvatureAxis {
    /// The axis covering spheres from `largest_radius_mm` down to `smallest_radius_mm`.
    pub fn from_radii_mm(largest_radius_mm: f32, smallest_radius_mm: f32, count: usize) -> Self {
        Self {
            min_per_mm: 1.0 / largest_radius_mm,
            max_per_mm: 1.0 / smallest_radius_mm,
            count,
        }
    }

    /// Curvature of row `row`, mm⁻¹.
    pub fn curvature_per_mm(&self, row: usize) -> f32 {
        if self.count <= 1 {
            return self.min_per_mm;
        }
        let t = row as f32 / (self.count - 1) as f32;
        self.min_per_mm + t * (self.max_per_mm - self.min_per_mm)
    }

    /// Continuous row coordinate of `curvature_per_mm`, clamped to `[0, count − 1]`.
    pub fn row_coordinate(&self, curvature_per_mm: f32) -> f32 {
        if self.count <= 1 || self.max_per_mm <= self.min_per_mm || curvature_per_mm.is_nan() {
            return 0.0;
        }
        let t = (curvature_per_mm - self.min_per_mm) / (self.max_per_mm - self.min_per_mm);
        (t * (self.count - 1) as f32).clamp(0.0, (self.count - 1) as f32)
    }

    /// One row at κ = 0: whatever is on it is the same at every curvature.
    pub fn single() -> Self {
        Self {
            min_per_mm: 0.0,
            max_per_mm: 0.0,
            count: 1,
        }
    }

    fn validate(&self) -> Result<(), LutError> {
        let ok = self.count >= 1
            && self.min_per_mm.is_finite()
            && self.max_per_mm.is_finite()
            && self.min_per_mm >= 0.0
            && (self.max_per_mm > self.min_per_mm
                || (self.count == 1 && self.max_per_mm == self.min_per_mm));
        if ok {
            Ok(())
        } else {
            Err(LutError::BadCurvatureAxis(*self))
        }
    }
}

/// θ of column `column` of a uniform θ axis with `count` columns over `[0, π]`.
pub fn theta_rad_at(column: usize, count: usize) -> f32 {
    if count <= 1 {
        return 0.0;
    }
    column as f32 * PI / (count - 1) as f32
}

/// How a table is filtered between its samples.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Filter {
    /// Bilinear: what a GPU's linear texture filter does.
    #[default]
    Bilinear,
    /// Bicubic Catmull-Rom (see [`catmull_rom::evaluate_uniform`]); negative results are
    /// clamped to 0. Along θ the ends are mirrored (f is even in θ about 0 and π, so its slope
    /// there is 0); along κ they are one-sided like the fitted spline's.
    CatmullRom,
}

/// The view correction g(κ, θ, φ): grids over φ ∈ [0, π/2] (columns) × θ ∈ [0, π] (rows), one
/// per layer of a curvature axis, sampled bilinearly within a layer and linearly between
/// layers, clamped at the edges (φ > π/2 reads the φ = π/2 column, κ beyond the axis its end
/// layer).
///
/// With one layer it is the same at every curvature (the poster's form, and every table before
/// LUT format version 5); with one row it is the poster's g(φ); with one column and one row a
/// constant.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewCorrection {
    phi_count: usize,
    theta_count: usize,
    curvature_axis: CurvatureAxis,
    values: Vec<Vec3>,
}

impl ViewCorrection {
    /// g ≡ 1: no view dependence (a Lambertian surface).
    pub fn identity() -> Self {
        Self {
            phi_count: 1,
            theta_count: 1,
            curvature_axis: CurvatureAxis::single(),
            values: vec![Vec3::ONE],
        }
    }

    /// The poster's form g(φ): `values[i]` at φ = i·(π/2)/(n − 1).
    ///
    /// # Errors
    /// When `values` is empty or holds a negative or non-finite value.
    pub fn from_phi(values: Vec<Vec3>) -> Result<Self, LutError> {
        Self::new(values.len(), 1, values)
    }

    /// A θ-dependent correction, the same at every curvature: `values[row · phi_count + column]`
    /// at φ = column·(π/2)/(phi_count − 1), θ = row·π/(theta_count − 1).
    ///
    /// # Errors
    /// When the shape does not match `values.len()`, a count is 0, or a value is negative or
    /// non-finite.
    pub fn new(phi_count: usize, theta_count: usize, values: Vec<Vec3>) -> Result<Self, LutError> {
        Self::with_curvature_layers(phi_count, theta_count, CurvatureAxis::single(), values)
    }

    /// A correction that depends on curvature: one `theta_count × phi_count` grid per layer of
    /// `curvature_axis`, `values[(layer · theta_count + row) · phi_count + column]`.
    ///
    /// # Errors
    /// As [`ViewCorrection::new`], and [`LutError::BadCurvatureAxis`].
    pub fn with_curvature_layers(
        phi_count: usize,
        theta_count: usize,
        curvature_axis: CurvatureAxis,
        values: Vec<Vec3>,
    ) -> Result<Self, LutError> {
        curvature_axis.validate()?;
        let expected = phi_count * theta_count * curvature_axis.count;
        if phi_count == 0 || theta_count == 0 || expected != values.len() {
            return Err(LutError::ShapeMismatch {
                what: "view correction",
                expected,
                found: values.len(),
            });
        }
        check_values("view correction", &values)?;
        Ok(Self {
            phi_count,
            theta_count,
            curvature_axis,
            values,
        })
    }

    /// Columns along φ ∈ [0, π/2].
    pub fn phi_count(&self) -> usize {
        self.phi_count
    }

    /// Rows along θ ∈ [0, π] in each layer; 1 for the poster's g(φ).
    pub fn theta_count(&self) -> usize {
        self.theta_count
    }

    /// The layers' curvatures (one layer: the same at every curvature).
    pub fn curvature_axis(&self) -> CurvatureAxis {
        self.curvature_axis
    }

    /// The grids, layer after layer, each row-major (`(layer · theta_count + row) · phi_count +
    /// column`).
    pub fn values(&self) -> &[Vec3] {
        &self.values
    }

    /// g(κ, θ, φ): bilinear within the two layers around κ, linear between them.
    pub fn sample(&self, curvature_per_mm: f32, theta_rad: f32, phi_rad: f32) -> Vec3 {
        let u = axis_coordinate(phi_rad, FRAC_PI_2, self.phi_count);
        let v = axis_coordinate(theta_rad, PI, self.theta_count);
        let layer_size = self.phi_count * self.theta_count;
        let at = |layer: usize| {
            let grid = &self.values[layer * layer_size..(layer + 1) * layer_size];
            bilinear(grid, self.phi_count, self.theta_count, u, v)
        };
        let w = self.curvature_axis.row_coordinate(curvature_per_mm);
        let below = (w as usize).min(self.curvature_axis.count - 1);
        let above = (below + 1).min(self.curvature_axis.count - 1);
        at(below).lerp(at(above), w - below as f32)
    }
}

/// Per-texel provenance of a fitted table.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TexelCoverage {
    /// How many measured samples fell into this texel (0: filled by interpolation).
    pub sample_count: f32,
    /// Relative spread of those samples (standard deviation / mean, mean over RGB).
    pub relative_spread: f32,
}

/// Why a table could not be built.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum LutError {
    /// The curvature axis is empty, not finite, negative or decreasing.
    #[error(
        "curvature axis {}..{} mm⁻¹ with {} rows: need finite 0 ≤ min < max (or min = max with one row)",
        .0.min_per_mm, .0.max_per_mm, .0.count
    )]
    BadCurvatureAxis(CurvatureAxis),
    /// The θ axis has fewer than two columns.
    #[error("{0} θ column(s): a table needs at least 2 over [0, π]")]
    TooFewThetaColumns(usize),
    /// A data array does not match the table's shape.
    #[error("{what}: expected {expected} values, found {found}")]
    ShapeMismatch {
        /// Which array.
        what: &'static str,
        /// Values the shape needs.
        expected: usize,
        /// Values given.
        found: usize,
    },
    /// A value is negative, NaN or infinite.
    #[error("{what}: value {index} is {value}: must be finite and ≥ 0")]
    BadValue {
        /// Which array.
        what: &'static str,
        /// Position of the value.
        index: usize,
        /// The offending channel value.
        value: f32,
    },
}

/// The CDRF table f(κ, θ) with its view correction g(θ, φ). See the [module docs](self) for the
/// conventions.
///
/// ```
/// use cdrf_core::lut::{CdrfLut, CurvatureAxis, Filter, Lambert};
/// let axis = CurvatureAxis::from_radii_mm(50.0, 15.0, 8);
/// let lut = CdrfLut::tabulate(&Lambert { albedo: [0.8; 3] }, axis, 181)?;
/// let f = lut.sample(1.0 / 35.0, 60_f32.to_radians(), Filter::Bilinear);
/// assert!((f.x - 0.4).abs() < 1e-4); // 0.8 · cos 60°
/// # Ok::<(), cdrf_core::lut::LutError>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct CdrfLut {
    curvature_axis: CurvatureAxis,
    theta_count: usize,
    radiance: Vec<Vec3>,
    view_correction: ViewCorrection,
    coverage: Option<Vec<TexelCoverage>>,
    translucency: Option<Translucency>,
    diffusion_profile: Option<DiffusionProfile>,
    provenance: BTreeMap<String, String>,
}

impl CdrfLut {
    /// A table from its values, row-major: `radiance[row · theta_count + column]` is f at the
    /// row's curvature and the column's θ. No view correction (g ≡ 1), no coverage.
    ///
    /// # Errors
    /// When the axes are invalid, the shape does not match, or a value is negative or
    /// non-finite.
    pub fn new(
        curvature_axis: CurvatureAxis,
        theta_count: usize,
        radiance: Vec<Vec3>,
    ) -> Result<Self, LutError> {
        curvature_axis.validate()?;
        if theta_count < 2 {
            return Err(LutError::TooFewThetaColumns(theta_count));
        }
        let expected = curvature_axis.count * theta_count;
        if radiance.len() != expected {
            return Err(LutError::ShapeMismatch {
                what: "radiance",
                expected,
                found: radiance.len(),
            });
        }
        check_values("radiance", &radiance)?;
        Ok(Self {
            curvature_axis,
            theta_count,
            radiance,
            view_correction: ViewCorrection::identity(),
            coverage: None,
            translucency: None,
            diffusion_profile: None,
            provenance: BTreeMap::new(),
        })
    }

    /// Tabulates any CDRF model on the given axes (in parallel).
    ///
    /// # Errors
    /// When the axes are invalid or the model returns a negative or non-finite value.
    pub fn tabulate(
        model: &(impl Cdrf + Sync),
        curvature_axis: CurvatureAxis,
        theta_count: usize,
    ) -> Result<Self, LutError> {
        curvature_axis.validate()?;
        if theta_count < 2 {
            return Err(LutError::TooFewThetaColumns(theta_count));
        }
        let radiance = (0..curvature_axis.count * theta_count)
            .into_par_iter()
            .map(|index| {
                let curvature = curvature_axis.curvature_per_mm(index / theta_count);
                let theta = theta_rad_at(index % theta_count, theta_count);
                Vec3::from_array(model.reflectance(curvature, theta))
            })
            .collect();
        Self::new(curvature_axis, theta_count, radiance)
    }

    /// Replaces the view correction.
    pub fn with_view_correction(mut self, view_correction: ViewCorrection) -> Self {
        self.view_correction = view_correction;
        self
    }

    /// Attaches per-texel coverage, same layout as the radiance.
    ///
    /// # Errors
    /// When the length does not match the table or a value is negative or non-finite.
    pub fn with_coverage(mut self, coverage: Vec<TexelCoverage>) -> Result<Self, LutError> {
        if coverage.len() != self.radiance.len() {
            return Err(LutError::ShapeMismatch {
                what: "coverage",
                expected: self.radiance.len(),
                found: coverage.len(),
            });
        }
        for (index, texel) in coverage.iter().enumerate() {
            for value in [texel.sample_count, texel.relative_spread] {
                if !(value.is_finite() && value >= 0.0) {
                    return Err(LutError::BadValue {
                        what: "coverage",
                        index,
                        value,
                    });
                }
            }
        }
        self.coverage = Some(coverage);
        Ok(self)
    }

    /// Attaches the material's non-local terms (scattering length, transmission profile),
    /// measured with the table. See [`crate::translucency`].
    pub fn with_translucency(mut self, translucency: Translucency) -> Self {
        self.translucency = Some(translucency);
        self
    }

    /// The material's non-local terms, when the table carries them (files of format version 2
    /// or later written by cdrf-fit do; version 1 files and tabulated models do not).
    pub fn translucency(&self) -> Option<&Translucency> {
        self.translucency.as_ref()
    }

    /// Attaches the diffusion profile fitted to the same spheres as the table. See
    /// [`crate::diffusion`].
    pub fn with_diffusion_profile(mut self, profile: DiffusionProfile) -> Self {
        self.diffusion_profile = Some(profile);
        self
    }

    /// The diffusion profile, when the table carries one (files of format version 4 or later
    /// written by cdrf-fit do).
    pub fn diffusion_profile(&self) -> Option<&DiffusionProfile> {
        self.diffusion_profile.as_ref()
    }

    /// How far the material's light travels under the surface, mm: the longest channel's mean
    /// distance of the diffusion profile ([`DiffusionProfile::mean_distance_mm`]), else of the
    /// translucency's scattering length; `None` when the table has neither. The length a
    /// renderer filters the mesh's curvature over (see [`crate::curvature`]).
    pub fn diffusion_length_mm(&self) -> Option<f32> {
        let longest = |lengths: [f32; 3]| lengths.into_iter().fold(0.0f32, f32::max);
        self.diffusion_profile
            .as_ref()
            .map(|profile| longest(profile.mean_distance_mm()))
            .or_else(|| {
                self.translucency
                    .as_ref()
                    .map(|t| longest(t.scattering_length_mm))
            })
            .filter(|length| *length > 0.0)
    }

    /// Records where the table came from (tool, input folder, date, …). Stored in the file.
    pub fn with_provenance(mut self, key: impl Into<String>, value: impl Into<String>) -> Self {
        self.provenance.insert(key.into(), value.into());
        self
    }

    /// The curvature axis (rows).
    pub fn curvature_axis(&self) -> CurvatureAxis {
        self.curvature_axis
    }

    /// Number of θ columns over `[0, π]`.
    pub fn theta_count(&self) -> usize {
        self.theta_count
    }

    /// All values, row-major (`row · theta_count + column`), π·L/E.
    pub fn radiance(&self) -> &[Vec3] {
        &self.radiance
    }

    /// One row: f(κ_row, θ) over the θ axis.
    ///
    /// # Panics
    /// If `row` ≥ the number of rows.
    pub fn row(&self, row: usize) -> &[Vec3] {
        &self.radiance[row * self.theta_count..(row + 1) * self.theta_count]
    }

    /// The transport mean free path ℓ per channel, mm, that the view's azimuth uses for this
    /// material ([`crate::azimuth::flux_length_mm`] of the diffusion profile).
    pub fn flux_length_mm(&self) -> Vec3 {
        crate::azimuth::flux_length_mm(
            self.diffusion_profile
                .as_ref()
                .map(DiffusionProfile::mean_distance_mm),
        )
    }

    /// ℓ·(−∂ ln f / ∂θ) per texel (row-major as [`radiance`](Self::radiance)), mm per radian:
    /// [`flux_length_mm`](Self::flux_length_mm) times how fast f falls with θ, at least 0
    /// (per row, [`crate::azimuth::flow_mm_per_rad`]); times κ, how far f falls along the surface
    /// per ℓ. The light under the surface flows away from the light, and a view along the flow
    /// sees more of it (the view's azimuth, which the table's spheres, lit at 90° to the camera,
    /// never varied).
    pub fn flow_mm_per_rad(&self) -> Vec<Vec3> {
        let length = self.flux_length_mm();
        (0..self.curvature_axis.count)
            .flat_map(|row| crate::azimuth::flow_mm_per_rad(self.row(row), length))
            .collect()
    }

    /// The view correction g(θ, φ).
    pub fn view_correction(&self) -> &ViewCorrection {
        &self.view_correction
    }

    /// Per-texel coverage, when the table was fitted.
    pub fn coverage(&self) -> Option<&[TexelCoverage]> {
        self.coverage.as_deref()
    }

    /// Key/value provenance.
    pub fn provenance(&self) -> &BTreeMap<String, String> {
        &self.provenance
    }

    /// f(κ, θ), π·L/E. κ is clamped to the axis (see the [module docs](self)); θ to `[0, π]`.
    pub fn sample(&self, curvature_per_mm: f32, theta_rad: f32, filter: Filter) -> Vec3 {
        let v = self.curvature_axis.row_coordinate(curvature_per_mm);
        let u = axis_coordinate(theta_rad, PI, self.theta_count);
        let rows = self.curvature_axis.count;
        match filter {
            Filter::Bilinear => bilinear(&self.radiance, self.theta_count, rows, u, v),
            Filter::CatmullRom => {
                let row = (v as usize).min(rows.saturating_sub(2));
                let first = row.saturating_sub(1);
                let last = (row + 2).min(rows - 1);
                let mut along_theta = [Vec3::ZERO; 4];
                for (slot, r) in along_theta.iter_mut().zip(first..=last) {
                    *slot = catmull_rom::evaluate_uniform(self.row(r), u, Ends::Mirrored);
                }
                let along_theta = &along_theta[..=last - first];
                // The window holds the rows the segment around v needs (and the axis ends where
                // they are the ends), so the spline over it equals the one over the whole axis.
                catmull_rom::evaluate_uniform(along_theta, v - first as f32, Ends::OneSided)
                    .max(Vec3::ZERO)
            }
        }
    }

    /// The Lambertian albedo closest to the table, per channel: least squares of
    /// `f(κ, θ) ≈ a·max(cos θ, 0)` over every row (each measured curvature alike) and θ
    /// weighted by sin θ (the solid angle each θ covers on a sphere). The table is the
    /// measurement of the spheres, so this is Lambert fitted to the same photographs: the fair
    /// Lambertian baseline.
    pub fn lambert_albedo(&self) -> [f32; 3] {
        let (mut numerator, mut denominator) = (Vec3::ZERO, 0.0f64);
        for row in 0..self.curvature_axis.count {
            for (column, value) in self.row(row).iter().enumerate() {
                let theta = theta_rad_at(column, self.theta_count);
                let c = theta.cos().max(0.0);
                let weight = theta.sin();
                numerator += *value * (c * weight);
                denominator += f64::from(c * c * weight);
            }
        }
        if denominator <= 0.0 {
            return [0.0; 3];
        }
        (numerator / denominator as f32).to_array()
    }

    /// The total diffuse reflectance of the flattest row, per channel: `∫₀^π f(κ_min, θ) dθ`
    /// (720 midpoint steps, bilinear reads). A CDRF blurs `cos⁺θ` along the great circle with
    /// a kernel of unit mass, which keeps `∫₋π^π f dθ = 2 · albedo` (see [`crate::gaussian`]),
    /// so this is the flat surface's albedo — which f(κ, 0) itself is not on a curved row: the
    /// light that enters beside the point arrives at a lower cosine.
    pub fn flat_albedo(&self) -> [f32; 3] {
        const STEPS: usize = 720;
        let kappa = self.curvature_axis.min_per_mm;
        let mut sum = [0.0_f64; 3];
        for i in 0..STEPS {
            let theta = (i as f32 + 0.5) / STEPS as f32 * PI;
            let f = self.reflectance(kappa, theta);
            for c in 0..3 {
                sum[c] += f64::from(f[c]);
            }
        }
        sum.map(|s| (s * std::f64::consts::PI / STEPS as f64) as f32)
    }

    /// Radiance factor with the view correction: f(κ, θ) · g(θ, φ), π·L/E.
    /// Multiply by E/π for radiance.
    pub fn evaluate(
        &self,
        curvature_per_mm: f32,
        theta_rad: f32,
        phi_rad: f32,
        filter: Filter,
    ) -> Vec3 {
        self.sample(curvature_per_mm, theta_rad, filter)
            * self
                .view_correction
                .sample(curvature_per_mm, theta_rad, phi_rad)
    }
}

impl Cdrf for CdrfLut {
    /// The table itself, bilinear, without the view correction.
    fn reflectance(&self, curvature_per_mm: f32, theta_rad: f32) -> [f32; 3] {
        self.sample(curvature_per_mm, theta_rad, Filter::Bilinear)
            .to_array()
    }
}

/// Continuous grid coordinate of `value` on a uniform axis over `[0, extent]` with `count`
/// nodes, clamped to `[0, count − 1]`.
fn axis_coordinate(value: f32, extent: f32, count: usize) -> f32 {
    if count <= 1 || value.is_nan() {
        return 0.0;
    }
    (value / extent * (count - 1) as f32).clamp(0.0, (count - 1) as f32)
}

/// Bilinear read of a row-major `width × height` grid at continuous node coordinates `(u, v)`.
fn bilinear(values: &[Vec3], width: usize, height: usize, u: f32, v: f32) -> Vec3 {
    let (x0, y0) = ((u as usize).min(width - 1), (v as usize).min(height - 1));
    let (x1, y1) = ((x0 + 1).min(width - 1), (y0 + 1).min(height - 1));
    let (tx, ty) = (u - x0 as f32, v - y0 as f32);
    let at = |x: usize, y: usize| values[y * width + x];
    let top = at(x0, y0).lerp(at(x1, y0), tx);
    let bottom = at(x0, y1).lerp(at(x1, y1), tx);
    top.lerp(bottom, ty)
}

fn check_values(what: &'static str, values: &[Vec3]) -> Result<(), LutError> {
    for (index, value) in values.iter().enumerate() {
        for channel in value.to_array() {
            if !(channel.is_finite() && channel >= 0.0) {
                return Err(LutError::BadValue {
                    what,
                    index,
                    value: channel,
                });
            }
        }
    }
    Ok(())
}
