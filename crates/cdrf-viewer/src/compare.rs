//! Measured CDRF vs Gaussian CDRF vs Lambert against path-traced references, in numbers and
//! pictures (the `compare` command).
//!
//! For each case (a scene file and the path-traced image of the same object, camera and light:
//! `data/compare.toml`) the object is rendered with the three models of one fit folder: the
//! measured LUT, the Gaussian CDRF fitted to the same photographs (both with the fit's view
//! correction), and Lambert with an albedo fitted to the same measurement
//! ([`CdrfLut::lambert_albedo`]), and with the non-local terms (cast shadows, transmission;
//! [`cdrf_core::translucency`]) added to the CDRFs ([`ModelName::ALL`]). Each render is compared
//! with the reference:
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

use std::fmt;
use std::path::{Path, PathBuf};

use cdrf_core::block_error::{self, Block, BlockPixel};
use cdrf_core::gaussian::GaussianCdrf;
use cdrf_core::glam::Vec3;
use cdrf_core::image_file::{RgbaImage, linear_to_srgb};
use cdrf_core::light::{DirectionalLight, Light, NonLocal, PointLight, SpotLight};
use cdrf_core::scene::{Material, Scene};
use cdrf_core::{CdrfLut, ViewCorrection};
use cdrf_render::Options;
use cdrf_render::headless::{HeadlessDevice, HeadlessError, RenderSettings, SceneRenderer};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::assets::{FIT_GAUSSIAN_FILE, FIT_LUT_FILE, LoadedGaussian, LoadedLut};

pub use cdrf_core::block_error::{BLOCK_PX, Region, TERMINATOR_COS};
pub use figure::{FIGURE_ROW_LABELS, FigureLayout, figure, figure_column_labels};
pub use theta_bins::{THETA_BIN_EDGES_DEG, THETA_BINS, ThetaRatios, ThetaTable};

mod figure;
mod theta_bins;

/// Pixels eroded from the render's silhouette before comparing.
pub const ERODE_PX: u32 = 2;
/// The regions of the tables, in table order.
pub const REGIONS: [Region; 5] = [
    Region::Whole,
    Region::Lit,
    Region::Terminator,
    Region::Shadow,
    Region::CastShadow,
];

/// Why a comparison could not run.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum CompareError {
    /// A file could not be read or parsed.
    #[error("{}: {message}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// A fit folder's file could not be loaded (the error names the file).
    #[error(transparent)]
    Asset(#[from] crate::assets::AssetError),
    /// The render or the reference is unusable for this comparison.
    #[error("case {case}: {message}")]
    Case {
        /// The case.
        case: String,
        /// What went wrong.
        message: String,
    },
    /// An output could not be staged or written (the error names it).
    #[error(transparent)]
    Output(#[from] crate::outputs::OutputError),
    /// Rendering failed.
    #[error("case {case}: rendering: {message}")]
    Render {
        /// The case.
        case: String,
        /// The renderer's error.
        message: String,
    },
}

/// One comparison: a scene and its path-traced image.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaseSpec {
    /// Short name (file names of the outputs).
    pub name: String,
    /// Scene file (mesh, camera, light; its shading is replaced by each model).
    pub scene: PathBuf,
    /// Path-traced reference, linear radiance OpenEXR, the scene camera's size.
    pub reference: PathBuf,
    /// What the reference shows (`reference_layer`; default the whole material).
    #[serde(default)]
    pub reference_layer: ReferenceLayer,
}

/// What a case's reference shows, and so which models it is compared with.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ReferenceLayer {
    /// The whole material: every model of [`ModelName::ALL`], with the scene's specular layer
    /// if it has one.
    #[default]
    Whole,
    /// The first-surface reflection alone (`knot-spec`): [`ModelName::SpecularLayer`] only; the
    /// scene must have `[shading] specular = true`.
    Specular,
}

impl CaseSpec {
    /// The models this case is rendered with, in table order.
    pub fn models(&self) -> &'static [ModelName] {
        match self.reference_layer {
            ReferenceLayer::Whole => &ModelName::ALL,
            ReferenceLayer::Specular => &[ModelName::SpecularLayer],
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Manifest {
    case: Vec<CaseSpec>,
}

/// Reads a comparison manifest (`[[case]] name, scene, reference`; paths relative to it).
///
/// # Errors
/// [`CompareError::File`] naming the manifest.
pub fn read_manifest(path: &Path) -> Result<Vec<CaseSpec>, CompareError> {
    let file_error = |message: String| CompareError::File {
        path: path.to_owned(),
        message,
    };
    let text = std::fs::read_to_string(path).map_err(|e| file_error(e.to_string()))?;
    let manifest: Manifest = toml::from_str(&text).map_err(|e| file_error(e.to_string()))?;
    if manifest.case.is_empty() {
        return Err(file_error("no [[case]]".into()));
    }
    for case in &manifest.case {
        if let Err(problem) = check_case_name(&case.name) {
            return Err(file_error(format!("case {:?}: {problem}", case.name)));
        }
    }
    let base = path.parent().unwrap_or(Path::new("."));
    Ok(manifest
        .case
        .into_iter()
        .map(|case| CaseSpec {
            scene: base.join(&case.scene),
            reference: base.join(&case.reference),
            name: case.name,
            reference_layer: case.reference_layer,
        })
        .collect())
}

/// A case name becomes a file name (`<name>.png` in `--out`): 1 to 64 ASCII letters, digits,
/// `_`, `-` and `.`, not starting with `.` — so no `/`, `..` or absolute path can write
/// outside the output folder.
fn check_case_name(name: &str) -> Result<(), &'static str> {
    if name.is_empty() || name.len() > 64 {
        return Err("a case name must be 1 to 64 characters (it names the figure file)");
    }
    if name.starts_with('.')
        || !name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'))
    {
        return Err(
            "a case name may hold only ASCII letters, digits, '_', '-' and '.', and may not \
             start with '.' (it names the figure file in --out)",
        );
    }
    Ok(())
}

/// The three models of one fit.
#[derive(Clone, Debug)]
pub struct Models {
    /// The measured table (with its view correction).
    pub measured: CdrfLut,
    /// Kubo's Gaussian CDRF fitted to the same photographs.
    pub gaussian: GaussianCdrf,
    /// The view correction the Gaussian shares with the table.
    pub view_correction: ViewCorrection,
    /// Lambert's albedo per channel ([`CdrfLut::lambert_albedo`]).
    pub lambert_albedo: [f32; 3],
}

impl Models {
    /// The models of a cdrf-fit output folder (`measured.exr`, `gaussian.toml`).
    ///
    /// # Errors
    /// [`CompareError::File`] naming the file.
    pub fn from_fit_folder(folder: &Path) -> Result<Self, CompareError> {
        let lut = LoadedLut::load(&folder.join(FIT_LUT_FILE))?.lut;
        let gaussian_path = folder.join(FIT_GAUSSIAN_FILE);
        let gaussian = LoadedGaussian::load(&gaussian_path)?;
        let model = gaussian
            .model_with_sigma(gaussian.parameters.sigma_mm)
            .map_err(|e| CompareError::File {
                path: gaussian_path,
                message: e.to_string(),
            })?;
        Ok(Self {
            lambert_albedo: lut.lambert_albedo(),
            measured: lut,
            gaussian: model,
            view_correction: gaussian.view_correction,
        })
    }
}

/// A shading model compared: a CDRF (or Lambert) and the non-local terms added to it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ModelName {
    /// The measured LUT (the poster's model).
    Measured,
    /// The measured LUT with translucent visibility (cast shadows).
    MeasuredShadows,
    /// The measured LUT with transmission through thin parts.
    MeasuredTransmission,
    /// The measured LUT with both non-local terms.
    MeasuredShadowsTransmission,
    /// The measured LUT with cast shadows and the subsurface gather (in place of T(d, μ)).
    MeasuredShadowsSubsurface,
    /// The measured LUT with every non-local term: shadows, the subsurface gather and one
    /// inter-reflection.
    MeasuredAll,
    /// Kubo's Gaussian CDRF.
    Gaussian,
    /// Kubo's Gaussian CDRF with translucent visibility (penumbra = its σ).
    GaussianShadows,
    /// Lambert with the fitted albedo.
    Lambert,
    /// The scene's specular layer alone (a black material under it) with cast shadows: the
    /// model of a [`ReferenceLayer::Specular`] case; not in [`ModelName::ALL`].
    SpecularLayer,
}

impl ModelName {
    /// All of them, in table order.
    pub const ALL: [ModelName; 9] = [
        ModelName::Measured,
        ModelName::MeasuredShadows,
        ModelName::MeasuredTransmission,
        ModelName::MeasuredShadowsTransmission,
        ModelName::MeasuredShadowsSubsurface,
        ModelName::MeasuredAll,
        ModelName::Gaussian,
        ModelName::GaussianShadows,
        ModelName::Lambert,
    ];

    /// The non-local terms this model adds.
    pub fn non_local(self) -> NonLocal {
        let (shadows, transmission) = match self {
            ModelName::Measured | ModelName::Gaussian | ModelName::Lambert => (false, false),
            ModelName::MeasuredShadows | ModelName::GaussianShadows | ModelName::SpecularLayer => {
                (true, false)
            }
            ModelName::MeasuredTransmission => (false, true),
            ModelName::MeasuredShadowsTransmission
            | ModelName::MeasuredShadowsSubsurface
            | ModelName::MeasuredAll => (true, true),
        };
        NonLocal {
            shadows,
            transmission,
            interreflection: self == ModelName::MeasuredAll,
            subsurface: matches!(
                self,
                ModelName::MeasuredShadowsSubsurface | ModelName::MeasuredAll
            ),
        }
    }

    /// A short column heading.
    pub fn short_label(self) -> &'static str {
        match self {
            ModelName::Measured => "measured",
            ModelName::MeasuredShadows => "measured + shadows",
            ModelName::MeasuredTransmission => "measured + transmission",
            ModelName::MeasuredShadowsTransmission => "measured + shadows + transmission",
            ModelName::MeasuredShadowsSubsurface => "measured + shadows + subsurface",
            ModelName::MeasuredAll => "measured + shadows + subsurface + inter-reflection",
            ModelName::Gaussian => "Gaussian",
            ModelName::GaussianShadows => "Gaussian + shadows",
            ModelName::Lambert => "Lambert",
            ModelName::SpecularLayer => "specular layer alone + shadows",
        }
    }
}

impl fmt::Display for ModelName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.short_label())
    }
}

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
    pub model: ModelName,
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
    /// The models compared, in the order of every per-model list here.
    pub models: Vec<ModelName>,
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
    pub fn metrics(&self, region: Region, model: ModelName) -> Option<Metrics> {
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

/// Renders `case` with the three `models` at `size` × `size` pixels (a divisor of the
/// reference's size: the reference is box-averaged down to it; `None` = the reference's size)
/// and compares each with the reference. `curvature_smoothing` overrides the scene's
/// `[mesh] curvature_smoothing`.
///
/// # Errors
/// [`CompareError`] naming the file or case.
pub fn run_case(
    device: &HeadlessDevice,
    case: &CaseSpec,
    models: &Models,
    size: Option<u32>,
    curvature_smoothing: Option<u32>,
) -> Result<CaseResult, CompareError> {
    let case_error = |message: String| CompareError::Case {
        case: case.name.clone(),
        message,
    };
    let mut scene = Scene::load(&case.scene).map_err(|e| CompareError::File {
        path: case.scene.clone(),
        message: e.to_string(),
    })?;
    let reference = RgbaImage::read_exr(&case.reference).map_err(|e| CompareError::File {
        path: case.reference.clone(),
        message: e.to_string(),
    })?;
    if let Some((index, pixel)) = reference
        .pixels
        .iter()
        .enumerate()
        .find(|(_, pixel)| !pixel.iter().all(|c| c.is_finite()))
    {
        let width = reference.width.max(1) as usize;
        return Err(CompareError::File {
            path: case.reference.clone(),
            message: format!(
                "pixel ({}, {}) is {pixel:?}: every reference pixel must be finite",
                index % width,
                index / width
            ),
        });
    }
    if (reference.width, reference.height) != (scene.camera.width, scene.camera.height) {
        return Err(case_error(format!(
            "the reference is {} × {} px but the scene's camera is {} × {}",
            reference.width, reference.height, scene.camera.width, scene.camera.height
        )));
    }
    let (width, height) = match size {
        None => (reference.width, reference.height),
        Some(size) => (size, size * reference.height / reference.width.max(1)),
    };
    if width == 0
        || height == 0
        || reference.width % width != 0
        || reference.height % height != 0
        || reference.width / width != reference.height / height
    {
        return Err(case_error(format!(
            "size {width} × {height} px: must divide the reference's {} × {} evenly",
            reference.width, reference.height
        )));
    }
    let reference = downsample(&reference, reference.width / width);
    scene.camera.width = width;
    scene.camera.height = height;
    scene.camera.msaa_samples = 4;
    if let Some(rounds) = curvature_smoothing {
        scene.mesh.curvature_smoothing = rounds;
    }
    let assets = scene.load_assets().map_err(|e| CompareError::File {
        path: case.scene.clone(),
        message: e.to_string(),
    })?;
    let Some(light) = scene.lights.first().copied() else {
        return Err(case_error("the scene has no light".into()));
    };
    if scene.lights.len() > 1 {
        return Err(case_error(
            "the scene has more than one light: θ regions need one".into(),
        ));
    }

    // One renderer for every model of the case: the mesh is uploaded and each pipeline built
    // once.
    let settings = RenderSettings {
        options: Options::PREDICTABLE,
        ..RenderSettings::default()
    };
    let render_error = |e: HeadlessError| CompareError::Render {
        case: case.name.clone(),
        message: e.to_string(),
    };
    let mut renderer =
        SceneRenderer::new(device, &scene, &assets, &settings).map_err(render_error)?;
    let mut add = |material: Material| renderer.add_material(&material).map_err(render_error);
    let measured = add(Material::Measured(models.measured.clone()))?;
    let gaussian = add(Material::Gaussian {
        model: models.gaussian,
        view_correction: models.view_correction.clone(),
    })?;
    let lambert = add(Material::Lambert {
        albedo: models.lambert_albedo,
    })?;
    let white = add(Material::Lambert { albedo: [1.0; 3] })?;
    let black = add(Material::Lambert { albedo: [0.0; 3] })?;
    if case.reference_layer == ReferenceLayer::Specular && scene.specular.is_none() {
        return Err(case_error(
            "reference_layer = \"specular\" needs a scene with [shading] specular = true".into(),
        ));
    }
    // cos θ is measured without the layer.
    renderer.set_specular(white, None).map_err(render_error)?;
    let mut render = |material, lights: &[Light], non_local| {
        renderer
            .render(material, lights, non_local)
            .map(|rendered| rendered.image)
            .map_err(render_error)
    };
    let models_compared = case.models();
    let mut renders = Vec::with_capacity(models_compared.len());
    for &model in models_compared {
        let material = match model {
            ModelName::Measured
            | ModelName::MeasuredShadows
            | ModelName::MeasuredTransmission
            | ModelName::MeasuredShadowsTransmission
            | ModelName::MeasuredShadowsSubsurface
            | ModelName::MeasuredAll => measured,
            ModelName::Gaussian | ModelName::GaussianShadows => gaussian,
            ModelName::Lambert => lambert,
            ModelName::SpecularLayer => black,
        };
        renders.push(render(material, &scene.lights, model.non_local())?);
    }

    let mask = block_error::covered_mask(&renders[0], ERODE_PX);
    if !mask.iter().any(|&m| m) {
        return Err(case_error("the object covers no pixel fully".into()));
    }
    let (occluded, cpu_cos_theta) = cast_shadow(&scene, &assets.mesh, &light, width, height);
    let cos_theta: Vec<f32> = match light {
        // cos θ per pixel as the renderer interpolates it: a white Lambertian surface lit from
        // the light and from the opposite side gives max(cos θ, 0)/π and max(−cos θ, 0)/π.
        Light::Directional(light) => {
            let unit = |to_light| {
                Light::Directional(DirectionalLight {
                    to_light,
                    irradiance: [1.0; 3],
                })
            };
            let toward = render(white, &[unit(light.to_light)], NonLocal::OFF)?;
            let away = render(white, &[unit(-light.to_light)], NonLocal::OFF)?;
            toward
                .pixels
                .iter()
                .zip(&away.pixels)
                .map(|(p, q)| {
                    let coverage = p[3].max(1e-6);
                    std::f32::consts::PI * (p[0] - q[0]) / coverage
                })
                .collect()
        }
        // A point or spot light has no opposite: cos θ of the CPU's surface point per pixel.
        _ => cpu_cos_theta,
    };
    let geometry = Geometry {
        mask: &mask,
        cos_theta: &cos_theta,
        occluded: &occluded,
    };
    let exposure = tone_exposure(&reference, &mask);
    let reference_tone = tone_map(&reference, exposure);
    let flips: Vec<Vec<f32>> = renders
        .iter()
        .map(|render| flip_map(&reference_tone, &tone_map(render, exposure), width, height))
        .collect();

    let render_blocks: Vec<Vec<Block>> = renders
        .iter()
        .map(|render| blocks(render, &reference, &geometry))
        .collect();
    let mut regions = Vec::new();
    for region in REGIONS {
        let mut models_row = Vec::new();
        let (mut blocks, mut pixels, mut reference_mean_radiance) = (0, 0, f64::NAN);
        for (index, &model) in models_compared.iter().enumerate() {
            let error = block_error::region_error(&render_blocks[index], region);
            let (flip, count) = region_flip(&flips[index], &geometry, region);
            blocks = error.blocks;
            pixels = count;
            reference_mean_radiance = error.reference_mean_radiance;
            models_row.push(ModelMetrics {
                model,
                metrics: Metrics {
                    relative_rmse: error.relative_rmse,
                    mean_relative_error: error.mean_relative_error,
                    flip,
                },
            });
        }
        regions.push(RegionRow {
            region,
            blocks,
            pixels,
            reference_mean_radiance,
            models: models_row,
        });
    }
    let theta = theta_bins::table(
        models_compared,
        &mask,
        &cos_theta,
        &occluded,
        &reference,
        &renders,
    );
    Ok(CaseResult {
        name: case.name.clone(),
        width,
        height,
        exposure,
        lambert_albedo: models.lambert_albedo,
        models: models_compared.to_vec(),
        regions,
        theta,
        images: CaseImages {
            reference: Some(reference),
            renders,
            cos_theta,
            mask,
            occluded,
        },
    })
}

/// Box-averages `image` by `factor` in each direction.
fn downsample(image: &RgbaImage, factor: u32) -> RgbaImage {
    if factor <= 1 {
        return image.clone();
    }
    let (width, height) = (image.width / factor, image.height / factor);
    let mut out = RgbaImage::new(width, height);
    let scale = 1.0 / (factor * factor) as f32;
    for y in 0..height {
        for x in 0..width {
            let mut sum = [0.0f32; 4];
            for dy in 0..factor {
                for dx in 0..factor {
                    let p = image.pixel(x * factor + dx, y * factor + dy);
                    for c in 0..4 {
                        sum[c] += p[c];
                    }
                }
            }
            out.pixels[(y * width + x) as usize] = sum.map(|s| s * scale);
        }
    }
    out
}

fn luminance(p: [f32; 4]) -> f32 {
    0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]
}

/// The exposure that puts the reference's 99th-percentile luminance (over the mask) at 0.9.
fn tone_exposure(reference: &RgbaImage, mask: &[bool]) -> f32 {
    let mut values: Vec<f32> = reference
        .pixels
        .iter()
        .zip(mask)
        .filter(|(_, m)| **m)
        .map(|(p, _)| luminance(*p))
        .collect();
    values.sort_by(f32::total_cmp);
    let high = values
        .get(values.len() * 99 / 100)
        .copied()
        .unwrap_or(1.0)
        .max(1e-6);
    0.9 / high
}

/// Exposed, clamped, sRGB-encoded RGB bytes (what FLIP and the figure see).
fn tone_map(image: &RgbaImage, exposure: f32) -> Vec<u8> {
    image
        .pixels
        .iter()
        .flat_map(|p| {
            [0, 1, 2]
                .map(|c| (linear_to_srgb((p[c] * exposure).clamp(0.0, 1.0)) * 255.0).round() as u8)
        })
        .collect()
}

fn flip_map(reference: &[u8], test: &[u8], width: u32, height: u32) -> Vec<f32> {
    let to_flip = |rgb: &[u8]| nv_flip::FlipImageRgb8::with_data(width, height, rgb);
    nv_flip::flip(
        to_flip(reference),
        to_flip(test),
        nv_flip::DEFAULT_PIXELS_PER_DEGREE,
    )
    .to_vec()
}

fn region_flip(flip: &[f32], geometry: &Geometry<'_>, region: Region) -> (f64, usize) {
    let (mut sum, mut count) = (0.0f64, 0usize);
    for (i, &error) in flip.iter().enumerate() {
        if geometry.mask[i] && region.contains(geometry.cos_theta[i], geometry.occluded[i]) {
            sum += f64::from(error);
            count += 1;
        }
    }
    (
        if count > 0 {
            sum / count as f64
        } else {
            f64::NAN
        },
        count,
    )
}

/// Where each pixel is: compared or not, cos θ, in a cast shadow or not.
struct Geometry<'a> {
    mask: &'a [bool],
    cos_theta: &'a [f32],
    occluded: &'a [f32],
}

/// The 8 × 8 blocks of `render` against `reference` wholly inside the compared pixels
/// ([`block_error::blocks`]).
fn blocks(render: &RgbaImage, reference: &RgbaImage, geometry: &Geometry<'_>) -> Vec<Block> {
    let rgb = |p: [f32; 4]| Vec3::new(p[0], p[1], p[2]);
    block_error::blocks(render.width, render.height, |x, y| {
        let i = (y * render.width + x) as usize;
        geometry.mask[i].then(|| BlockPixel {
            model: rgb(render.pixels[i]),
            reference: rgb(reference.pixels[i]),
            cos_theta: geometry.cos_theta[i],
            occluded: geometry.occluded[i],
        })
    })
}

/// One case's Markdown table: per region, each model's relative RMSE, mean relative error and
/// FLIP; the best model of each region and metric in bold.
fn case_table(result: &CaseResult) -> String {
    let mut text = String::new();
    text.push_str("| region | blocks | mean reference radiance |");
    for model in &result.models {
        text.push_str(&format!(" {model} |"));
    }
    text.push_str("\n|---|---|---|");
    text.push_str(&"---|".repeat(result.models.len()));
    text.push('\n');
    for row in &result.regions {
        let best = |metric: fn(&Metrics) -> f64| {
            row.models
                .iter()
                .map(|entry| metric(&entry.metrics))
                .filter(|v| v.is_finite())
                .fold(f64::INFINITY, f64::min)
        };
        let best_rmse = best(|m| m.relative_rmse);
        let best_mre = best(|m| m.mean_relative_error);
        let best_flip = best(|m| m.flip);
        let cell = |value: f64, best: f64, percent: bool| {
            let text = if !value.is_finite() {
                "—".to_owned()
            } else if percent {
                format!("{:.1} %", value * 100.0)
            } else {
                format!("{value:.3}")
            };
            if value == best {
                format!("**{text}**")
            } else {
                text
            }
        };
        let radiance = if row.reference_mean_radiance.is_finite() {
            format!("{:.4}", row.reference_mean_radiance)
        } else {
            "—".to_owned()
        };
        text.push_str(&format!("| {} | {} | {radiance} |", row.region, row.blocks));
        for entry in &row.models {
            let m = &entry.metrics;
            text.push_str(&format!(
                " {} / {} / {} |",
                cell(m.relative_rmse, best_rmse, true),
                cell(m.mean_relative_error, best_mre, true),
                cell(m.flip, best_flip, false)
            ));
        }
        text.push('\n');
    }
    text
}

/// What a case is: its name, size and Lambert albedo (a table's caption).
fn case_caption(result: &CaseResult) -> String {
    format!(
        "{} × {} px; Lambert albedo {:.3} {:.3} {:.3}",
        result.width,
        result.height,
        result.lambert_albedo[0],
        result.lambert_albedo[1],
        result.lambert_albedo[2]
    )
}

const TABLE_KEY: &str = "Each cell: relative RMSE / mean relative error (8 × 8-pixel blocks, linear \
                         radiance) / mean FLIP (tone-mapped). Lower is better; the best of each \
                         region in bold.\n";

const THETA_KEY: &str = "Render / reference by θ: Σ render / Σ reference (mean of R, G, B) over the \
                         compared pixels of each θ bin outside cast shadows, and over the \
                         cast-shadow pixels; 1 is right, 0.5 means half the light is missing.\n";

/// A case's two tables (regions, then θ bins), each followed by a blank line.
fn case_tables(result: &CaseResult) -> String {
    format!(
        "{}\n{}\n",
        case_table(result),
        theta_bins::markdown(&result.theta)
    )
}

/// The results as Markdown tables: per case and region, each model's relative RMSE, mean
/// relative error and FLIP; the best model of each region and metric in bold.
pub fn markdown(results: &[CaseResult]) -> String {
    let mut text = String::new();
    for result in results {
        text.push_str(&format!(
            "**{}** ({})\n\n",
            result.name,
            case_caption(result)
        ));
        text.push_str(&case_tables(result));
    }
    text.push_str(TABLE_KEY);
    text.push('\n');
    text.push_str(THETA_KEY);
    text
}

/// How a results page was made: the command line, the adapter, the fit.
#[derive(Clone, Debug, Default)]
pub struct Provenance {
    /// The command line that wrote the page (`cdrf-viewer compare …`).
    pub command: String,
    /// The GPU adapter the renders ran on (the numbers depend on it slightly).
    pub adapter: String,
    /// The fit folder whose models were compared.
    pub fit: String,
}

/// A results page (Markdown, meant to be committed as `docs/results.md`): what is compared and
/// how, then per case its figure (`figures`: the folder of the figures, relative to the
/// page) and its table. Everything in it is generated, so no number in it can drift from what
/// `compare` measures.
pub fn results_page(results: &[CaseResult], figures: &str, provenance: &Provenance) -> String {
    let mut text = String::new();
    text.push_str("# Results: measured vs Gaussian vs Lambert against path-traced references\n\n");
    text.push_str(&format!(
        "<!-- Generated by `{}`; do not edit by hand: run it again. -->\n\n",
        provenance.command
    ));
    text.push_str(&format!(
        "Generated by `{}` on {} with the models of `{}`: the measured CDRF (the table), Kubo's \
         Gaussian CDRF fitted to the same photographs (both with the fit's view correction) and \
         Lambert with the albedo fitted to the measured table, each also with the non-local \
         terms (cast shadows, transmission) where they apply.\n\n",
        provenance.command, provenance.adapter, provenance.fit
    ));
    text.push_str(&format!(
        "**How it compares** (`cdrf_viewer::compare`; the metric is `cdrf_core::block_error`, \
         the one cdrf-fit and the render tests use too):\n\
         - *Pixels*: those the render covers fully (4× MSAA coverage = 1) with all neighbours \
         within {ERODE_PX} px covered too.\n\
         - *Errors in linear radiance* on {BLOCK_PX} × {BLOCK_PX}-pixel blocks wholly inside \
         those pixels: relative RMSE √(Σ|R − T|²)/√(Σ T²) and mean relative error \
         Σ|R − T|/Σ T over the region's blocks and channels (T reference, R render; ratios of \
         sums). *FLIP* on tone-mapped images (the exposure puts the reference's 99th-percentile \
         luminance at 0.9, sRGB), averaged over the region's pixels.\n\
         - *Regions* by a block's mean cos θ (θ between normal and light): lit side \
         cos θ ≥ {TERMINATOR_COS}, terminator band |cos θ| < {TERMINATOR_COS}, shadow side \
         cos θ ≤ −{TERMINATOR_COS}, and the cast shadow: facing the light but hidden from it \
         by another part of the object, taken out of the lit side and the terminator band.\n\
         - *Render / reference by θ*: per bin of θ, Σ render / Σ reference of the pixels' mean \
         of R, G and B (cast-shadow pixels in their own column): how much of the light a model \
         reproduces at each angle.\n\n"
    ));
    for result in results {
        text.push_str(&format!("## {}\n\n", result.name));
        text.push_str(&format!(
            "![{}: the reference and each model; beneath: the regions and each model's signed \
             error per block]({}/{}.png)\n\n",
            result.name,
            figures.trim_end_matches('/'),
            result.name
        ));
        text.push_str(&format!("{}\n\n", case_caption(result)));
        text.push_str(&case_tables(result));
    }
    text.push_str(TABLE_KEY);
    text.push('\n');
    text.push_str(THETA_KEY);
    text
}

/// Writes `text` to `path` through a temporary file.
fn write_text(path: &Path, text: &str) -> Result<(), CompareError> {
    cdrf_core::atomic::write_file(path, |file| {
        std::io::Write::write_all(file, text.as_bytes())
    })
    .map_err(|e| CompareError::File {
        path: path.to_owned(),
        message: e.to_string(),
    })
}

/// The files a run of `cases` writes: `compare.json`, `compare.md` and `<case>.png` in
/// `folder`, then the results page if any.
pub fn output_paths<'a>(
    folder: &Path,
    case_names: impl IntoIterator<Item = &'a str>,
    results_page: Option<&Path>,
) -> Vec<PathBuf> {
    let mut paths = vec![folder.join("compare.json"), folder.join("compare.md")];
    paths.extend(
        case_names
            .into_iter()
            .map(|name| folder.join(format!("{name}.png"))),
    );
    paths.extend(results_page.map(Path::to_owned));
    paths
}

/// Writes `compare.json`, `compare.md` and `<case>.png` (the figures) into `folder` (all
/// staged first, renamed into place together: [`crate::outputs::StagedOutputs`]).
///
/// # Errors
/// [`CompareError::Output`] naming the file.
pub fn write_outputs(results: &[CaseResult], folder: &Path) -> Result<Vec<PathBuf>, CompareError> {
    let paths = output_paths(folder, results.iter().map(|r| r.name.as_str()), None);
    let staged = crate::outputs::StagedOutputs::new(&paths, &[])?;
    write_staged(results, folder, None, &staged)?;
    Ok(staged.commit()?)
}

/// Writes a run's files into `staged` (made from [`output_paths`] of the same `folder`,
/// cases and page); the caller commits.
///
/// # Errors
/// [`CompareError`] naming the file.
pub fn write_staged(
    results: &[CaseResult],
    folder: &Path,
    page: Option<(&Path, &Provenance)>,
    staged: &crate::outputs::StagedOutputs,
) -> Result<(), CompareError> {
    let file_error = |path: &Path, message: String| CompareError::File {
        path: path.to_owned(),
        message,
    };
    let json_path = folder.join("compare.json");
    let json =
        serde_json::to_string_pretty(results).map_err(|e| file_error(&json_path, e.to_string()))?;
    let text = |path: &Path, text: &str| {
        staged.write(path, |file| {
            std::io::Write::write_all(file, text.as_bytes())
        })
    };
    text(&json_path, &json)?;
    text(&folder.join("compare.md"), &markdown(results))?;
    for result in results {
        let path = folder.join(format!("{}.png", result.name));
        let figure = figure(result);
        staged.write(&path, |file| {
            use image::ImageEncoder;
            image::codecs::png::PngEncoder::new(std::io::BufWriter::new(file))
                .write_image(
                    figure.as_raw(),
                    figure.width(),
                    figure.height(),
                    image::ExtendedColorType::Rgb8,
                )
                .map_err(std::io::Error::other)
        })?;
    }
    if let Some((page, provenance)) = page {
        let page_folder = page.parent().filter(|p| !p.as_os_str().is_empty());
        let page_folder = page_folder.unwrap_or(Path::new("."));
        let canonical = |path: &Path| {
            path.canonicalize().map_err(|e| CompareError::File {
                path: path.to_owned(),
                message: e.to_string(),
            })
        };
        let figures = relative_path(&canonical(folder)?, &canonical(page_folder)?);
        text(page, &results_page(results, &figures, provenance))?;
    }
    Ok(())
}

/// Writes the [`results_page`] to `page`, linking the figures `write_outputs` wrote into
/// `figures_folder` (relative to the page's folder when both are under one folder, else by
/// absolute path).
///
/// # Errors
/// [`CompareError::File`] naming the file.
pub fn write_results_page(
    results: &[CaseResult],
    page: &Path,
    figures_folder: &Path,
    provenance: &Provenance,
) -> Result<(), CompareError> {
    let page_folder = page.parent().filter(|p| !p.as_os_str().is_empty());
    let page_folder = page_folder.unwrap_or(Path::new("."));
    std::fs::create_dir_all(page_folder).map_err(|e| CompareError::File {
        path: page_folder.to_owned(),
        message: e.to_string(),
    })?;
    let canonical = |path: &Path| {
        path.canonicalize().map_err(|e| CompareError::File {
            path: path.to_owned(),
            message: e.to_string(),
        })
    };
    let figures = relative_path(&canonical(figures_folder)?, &canonical(page_folder)?);
    write_text(page, &results_page(results, &figures, provenance))
}

/// `target` relative to the folder `base` (both absolute), with `/` separators.
fn relative_path(target: &Path, base: &Path) -> String {
    let target: Vec<_> = target.components().collect();
    let base: Vec<_> = base.components().collect();
    let common = target.iter().zip(&base).take_while(|(a, b)| a == b).count();
    let mut parts: Vec<String> = vec!["..".to_owned(); base.len() - common];
    parts.extend(
        target[common..]
            .iter()
            .map(|c| c.as_os_str().to_string_lossy().into_owned()),
    );
    if parts.is_empty() {
        ".".to_owned()
    } else {
        parts.join("/")
    }
}

/// Per pixel of the scene camera's `width` × `height` image: 1 where the visible surface point
/// is hidden from `light` by another part of `mesh` (model units, placed by the scene's
/// transform), else 0; and the cosine between that point's normal and its direction to the light
/// (0 where no surface). Two CPU depth maps: the camera's (which surface point each pixel sees)
/// and the light's (2048 cells across the object, keeping the point nearest the light:
/// orthographic along a directional light, a perspective map about a point or spot light's
/// position); a point is occluded when the light's map holds a point nearer the light than it
/// by more than a slope-scaled bias (2 + 2 tan θ cells).
pub fn cast_shadow(
    scene: &Scene,
    mesh: &cdrf_core::Mesh,
    light: &Light,
    width: u32,
    height: u32,
) -> (Vec<f32>, Vec<f32>) {
    let world_from_model = scene.mesh.transform.world_from_model();
    let positions: Vec<Vec3> = mesh
        .positions
        .iter()
        .map(|&p| world_from_model.transform_point3(p))
        .collect();
    let camera = &scene.camera;
    let forward = (camera.target - camera.eye).normalize();
    let depths = positions.iter().map(|p| (*p - camera.eye).dot(forward));
    let (near, far) = depths.fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), d| {
        (a.min(d), b.max(d))
    });
    let margin = 0.01 * (far - near).abs() + 1e-3;
    let near = match camera.projection {
        cdrf_core::scene::Projection::Orthographic { .. } => near - margin,
        cdrf_core::scene::Projection::Perspective { .. } => (near - margin).max(1e-3),
    };
    let clip_from_world = camera.clip_from_view(near, far + margin) * camera.view_from_world();

    // The camera's depth map: the nearest surface point per pixel centre.
    let screen: Vec<(Vec3, f32)> = positions
        .iter()
        .map(|&p| {
            let clip = clip_from_world * p.extend(1.0);
            let ndc = clip.truncate() / clip.w;
            let x = (ndc.x + 1.0) * 0.5 * width as f32;
            let y = (1.0 - ndc.y) * 0.5 * height as f32;
            (Vec3::new(x, y, ndc.z), clip.w)
        })
        .collect();
    let normal_from_model = cdrf_core::glam::Mat3::from_mat4(world_from_model)
        .inverse()
        .transpose();
    let normals: Vec<Vec3> = mesh
        .normals
        .iter()
        .map(|&n| (normal_from_model * n).normalize_or_zero())
        .collect();
    // Per pixel: depth, surface point, normal.
    let mut seen: Vec<Option<(f32, Vec3, Vec3)>> = vec![None; (width * height) as usize];
    for triangle in &mesh.triangles {
        let [a, b, c] = triangle.map(|i| i as usize);
        rasterize(
            [screen[a].0, screen[b].0, screen[c].0],
            width,
            height,
            |x, y, weights| {
                // Perspective-correct interpolation of the world position.
                let w =
                    Vec3::new(1.0 / screen[a].1, 1.0 / screen[b].1, 1.0 / screen[c].1) * weights;
                let w = w / w.element_sum();
                let depth = screen[a].0.z * weights.x
                    + screen[b].0.z * weights.y
                    + screen[c].0.z * weights.z;
                let point = positions[a] * w.x + positions[b] * w.y + positions[c] * w.z;
                let normal = normals[a] * w.x + normals[b] * w.y + normals[c] * w.z;
                let slot = &mut seen[(y * width + x) as usize];
                if slot.is_none_or(|(d, _, _)| depth < d) {
                    *slot = Some((depth, point, normal.normalize_or_zero()));
                }
            },
        );
    }

    // The light's depth map: (x, y, toward) per point, keeping the largest `toward` (nearest the
    // light) per cell. Directional: x, y across the light, toward = along it. Point and spot:
    // x, y the tangents about an axis from the light to the object, toward = −distance; a cell
    // there covers `cell · distance` of world.
    let source = match *light {
        Light::Directional(_) => None,
        Light::Point(PointLight { position, .. }) | Light::Spot(SpotLight { position, .. }) => {
            Some(position)
        }
    };
    let directional_light = match light {
        Light::Directional(light) => light.to_light.normalize(),
        _ => Vec3::Z,
    };
    let axis = match source {
        Some(position) => {
            let centre = positions.iter().copied().sum::<Vec3>() / positions.len().max(1) as f32;
            (centre - position).normalize_or(Vec3::NEG_Z)
        }
        None => directional_light,
    };
    let u = axis.any_orthonormal_vector();
    let v = axis.cross(u);
    let project = |p: Vec3| match source {
        None => Vec3::new(p.dot(u), p.dot(v), p.dot(directional_light)),
        Some(position) => {
            let r = p - position;
            let z = r.dot(axis).max(1e-6);
            Vec3::new(r.dot(u) / z, r.dot(v) / z, -r.length())
        }
    };
    let to_light_at = |p: Vec3| match source {
        None => directional_light,
        Some(position) => (position - p).normalize_or_zero(),
    };
    let world_per_unit = |p: Vec3| match source {
        None => 1.0,
        Some(position) => (p - position).length(),
    };
    let light_space: Vec<Vec3> = positions.iter().map(|&p| project(p)).collect();
    let (min, max) = light_space.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    const CELLS: u32 = 2048;
    let cell = ((max.x - min.x).max(max.y - min.y) / (CELLS - 2) as f32).max(1e-9);
    let to_cell = |p: Vec3| Vec3::new((p.x - min.x) / cell + 1.0, (p.y - min.y) / cell + 1.0, p.z);
    let mut nearest = vec![f32::NEG_INFINITY; (CELLS * CELLS) as usize];
    for triangle in &mesh.triangles {
        let corners = triangle.map(|i| to_cell(light_space[i as usize]));
        rasterize(corners, CELLS, CELLS, |x, y, weights| {
            let toward =
                corners[0].z * weights.x + corners[1].z * weights.y + corners[2].z * weights.z;
            let slot = &mut nearest[(y * CELLS + x) as usize];
            *slot = slot.max(toward);
        });
    }
    let mut cos_thetas = vec![0.0; seen.len()];
    let occluded = seen
        .iter()
        .zip(&mut cos_thetas)
        .map(|(hit, cos_out)| {
            let Some((_, point, normal)) = hit else {
                return 0.0;
            };
            // Slope-scaled: a surface at grazing light changes its distance to the light by
            // tan θ per unit across, so a cell holds points up to that much nearer.
            let cos_theta = normal.dot(to_light_at(*point)).clamp(-1.0, 1.0);
            *cos_out = cos_theta;
            let tan_theta = (1.0 - cos_theta * cos_theta).sqrt() / cos_theta.abs().max(0.02);
            let bias = cell * world_per_unit(*point) * (2.0 + 2.0 * tan_theta);
            let p = to_cell(project(*point));
            let (x, y) = (p.x.floor() as i64, p.y.floor() as i64);
            if x < 0 || y < 0 || x >= i64::from(CELLS) || y >= i64::from(CELLS) {
                return 0.0;
            }
            let occluder = nearest[(y as u32 * CELLS + x as u32) as usize];
            if occluder > p.z + bias { 1.0 } else { 0.0 }
        })
        .collect();
    (occluded, cos_thetas)
}

/// Calls `shade(x, y, barycentric weights)` for every pixel centre (x + 0.5, y + 0.5) of a
/// `width` × `height` grid inside the triangle `corners` (x, y in pixels; either winding).
fn rasterize(corners: [Vec3; 3], width: u32, height: u32, mut shade: impl FnMut(u32, u32, Vec3)) {
    let [a, b, c] = corners;
    let area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if area.abs() < 1e-12 || !area.is_finite() {
        return;
    }
    let lo_x = a.x.min(b.x).min(c.x).floor().max(0.0) as u32;
    let hi_x = (a.x.max(b.x).max(c.x).ceil().max(0.0) as u32).min(width);
    let lo_y = a.y.min(b.y).min(c.y).floor().max(0.0) as u32;
    let hi_y = (a.y.max(b.y).max(c.y).ceil().max(0.0) as u32).min(height);
    for y in lo_y..hi_y {
        for x in lo_x..hi_x {
            let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
            let w0 = ((b.x - px) * (c.y - py) - (b.y - py) * (c.x - px)) / area;
            let w1 = ((c.x - px) * (a.y - py) - (c.y - py) * (a.x - px)) / area;
            let w2 = 1.0 - w0 - w1;
            if w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0 {
                shade(x, y, Vec3::new(w0, w1, w2));
            }
        }
    }
}
