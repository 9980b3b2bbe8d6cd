//! A case's result: per region each model's errors, the θ table, and the images behind them.

use cdrf_core::block_error::Region;
use cdrf_core::image_file::RgbaImage;
use serde::Serialize;

use crate::models::ComparedModel;
use crate::theta_bins::ThetaTable;

/// The regions of the tables, in table order.
pub const REGIONS: [Region; 5] = [
    Region::Whole,
    Region::Lit,
    Region::Terminator,
    Region::Shadow,
    Region::CastShadow,
];

/// Errors of one model in one region.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Metrics {
    /// √(Σ|R − T|²) / √(Σ T²) over 8 × 8 blocks and channels.
    pub relative_rmse: f64,
    /// Σ|R − T| / Σ T over 8 × 8 blocks and channels.
    pub mean_relative_error: f64,
    /// Mean FLIP of the tone-mapped images over the region's pixels.
    pub flip: f64,
}

/// One region's row of the table.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RegionRow {
    /// The region.
    pub region: Region,
    /// 8 × 8 blocks compared.
    pub blocks: usize,
    /// Pixels compared (FLIP).
    pub pixels: usize,
    /// Mean reference radiance of the region's blocks (over channels), for scale: the relative
    /// errors of a nearly black region are large however small the absolute error.
    pub reference_mean_radiance: f64,
    /// Per model, in [`CaseResult::models`] order.
    pub models: Vec<ModelMetrics>,
}

/// One model's errors in one region.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ModelMetrics {
    /// The model.
    pub model: ComparedModel,
    /// Its errors.
    #[serde(flatten)]
    pub metrics: Metrics,
}

/// The result of one case.
#[derive(Clone, Debug, Serialize)]
pub struct CaseResult {
    /// The case's name.
    pub name: String,
    /// Image size compared, pixels.
    pub width: u32,
    /// Image size compared, pixels.
    pub height: u32,
    /// The tone-mapping exposure (FLIP and figure).
    pub exposure: f32,
    /// Lambert's albedo used.
    pub lambert_albedo: [f32; 3],
    /// The case's own fit folder (`fit` in the manifest), when not the run's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fit: Option<String>,
    /// The models compared, in the order of every per-model list here.
    pub models: Vec<ComparedModel>,
    /// One row per region.
    pub regions: Vec<RegionRow>,
    /// Render / reference per θ bin and in the cast shadow, per model ([`ThetaTable`]).
    pub theta: ThetaTable,
    /// Reference, renders per model, cos θ and the compared-pixel mask (for the figure).
    #[serde(skip)]
    pub images: CaseImages,
}

impl CaseResult {
    /// The metrics of `model` in `region`.
    pub fn metrics(&self, region: Region, model: ComparedModel) -> Option<Metrics> {
        self.regions
            .iter()
            .find(|row| row.region == region)?
            .models
            .iter()
            .find(|entry| entry.model == model)
            .map(|entry| entry.metrics)
    }
}

/// The images of one case.
#[derive(Clone, Debug, Default)]
pub struct CaseImages {
    /// The reference at the compared size.
    pub reference: Option<RgbaImage>,
    /// The renders, in [`CaseResult::models`] order.
    pub renders: Vec<RgbaImage>,
    /// Per-pixel cos θ.
    pub cos_theta: Vec<f32>,
    /// Per-pixel: compared or not.
    pub mask: Vec<bool>,
    /// Per-pixel: 1 where the surface point is hidden from the light by the object, else 0.
    pub occluded: Vec<f32>,
}
