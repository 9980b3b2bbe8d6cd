//! cdrf-eval: the measured CDRF, the Gaussian CDRF and Lambert against path-traced references,
//! in numbers and pictures (what `cdrf-viewer compare` runs).
//!
//! ```no_run
//! use std::path::Path;
//!
//! use cdrf_eval::{Models, markdown, read_manifest, run_case};
//! use cdrf_render::headless::{AdapterPreference, HeadlessDevice};
//!
//! let cases = read_manifest(Path::new("data/compare.toml"))?;
//! let fit = Path::new("data/wax-fit");
//! let models = Models::from_files(&fit.join("measured.exr"), &fit.join("gaussian.toml"))?;
//! let device = HeadlessDevice::new(AdapterPreference::Software)?;
//! // The first case at 128 × 128 pixels (the reference box-averaged down to it).
//! let result = run_case(&device, &cases[0], &models, Some(128), None)?;
//! println!("{}", markdown(&[result]));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! For each case (a scene file and the path-traced image of the same object, camera and light:
//! `data/compare.toml`) the object is rendered with the three models of one fit: the measured
//! LUT, the Gaussian CDRF fitted to the same photographs (both with the fit's view correction),
//! and Lambert with an albedo fitted to the same measurement ([`CdrfLut::lambert_albedo`]), and
//! with the non-local terms (cast shadows, transmission, the subsurface gather, the
//! inter-reflection; [`cdrf_core::translucency`]) added to the CDRFs ([`ComparedModel::ALL`]).
//! Each render is compared with the reference:
//!
//! - **Pixels compared**: those the render covers fully (4× MSAA coverage = 1) with every
//!   neighbour within [`ERODE_PX`] pixels covered too — the silhouette eroded by 2 px, so edge
//!   pixels (partial coverage, sub-pixel silhouette differences) never count.
//! - **Regions** ([`Region`]) by θ, the angle between normal and light, from two extra Lambert
//!   renders (light and opposite light: cos θ = L₊ − L₋ per pixel, as the renderer interpolates
//!   normals): lit side cos θ ≥ 0.26 (θ ≤ 75°), terminator band |cos θ| < 0.26, shadow side
//!   cos θ ≤ −0.26; and the *cast shadow*: points facing the light (cos θ > 0) that another part
//!   of the object hides from it ([`cast_shadow`], a CPU shadow map), taken out of the lit side
//!   and the terminator band — light that no local model can know is missing.
//! - **Radiance errors**: cdrf's one block metric, [`cdrf_core::block_error`] — 8 × 8-pixel
//!   blocks (the references' per-pixel noise is 7 % lit to tens of per cent in shadow; a block
//!   averages 64 pixels) that lie wholly in the compared pixels, assigned to a region by their
//!   mean cos θ and cast-shadow fraction: *relative RMSE* = √(Σ|R − T|²) / √(Σ T²) and *mean
//!   relative error* = Σ|R − T| / Σ T, both over blocks and channels (T the reference, R the
//!   render). Ratios of sums, not means of ratios: a block in a cast shadow (T ≈ 0) weighs by
//!   its radiance instead of dividing by nearly zero.
//! - **Render / reference by θ** ([`ThetaTable`]): Σ render / Σ reference per bin of θ
//!   ([`THETA_BIN_EDGES_DEG`]) outside cast shadows and over the cast shadow — how much of the
//!   reference's light a model reproduces past the terminator, where the block errors of a dim
//!   region say little.
//! - **FLIP** (NVIDIA FLIP, 67 px/°) between the tone-mapped images (both × the exposure that
//!   puts the reference's 99th-percentile luminance at 0.9, clamped, sRGB), averaged over the
//!   compared pixels of each region.
//!
//! The modules: `case` (the manifest), `models` (the fit's models, [`ComparedModel`]), `run`
//! ([`run_case`]), `result` (what a case measures), `cast_shadow` (the CPU shadow map), `tone`
//! (exposure and FLIP), `theta_bins`, `figure` and `report` (Markdown, the results page and
//! the files of a run).

#[cfg(doc)]
use cdrf_core::CdrfLut;

pub use case::{CaseSpec, ReferenceLayer, read_manifest};
pub use cast_shadow::cast_shadow;
pub use cdrf_core::block_error::{BLOCK_PX, Region, TERMINATOR_COS};
pub use error::CompareError;
pub use figure::{FIGURE_ROW_LABELS, FigureLayout, figure, figure_column_labels};
pub use models::{ComparedModel, Models};
pub use report::{Provenance, markdown, output_files, output_paths, results_page};
pub use result::{CaseImages, CaseResult, Metrics, ModelMetrics, REGIONS, RegionRow};
pub use run::{ERODE_PX, run_case};
pub use theta_bins::{THETA_BIN_EDGES_DEG, THETA_BINS, ThetaRatios, ThetaTable};

mod case;
mod cast_shadow;
mod error;
mod figure;
mod models;
mod report;
mod result;
mod run;
mod theta_bins;
mod tone;
