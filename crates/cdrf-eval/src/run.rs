//! Rendering a case with each model and measuring it against the reference.

use cdrf_core::ShadingModel;
use cdrf_core::block_error::{self, Block, BlockPixel, Region};
use cdrf_core::glam::Vec3;
use cdrf_core::image_file::RgbaImage;
use cdrf_core::light::{DirectionalLight, Light, NonLocal};
use cdrf_core::scene::{Material, Scene};
use cdrf_render::Options;
use cdrf_render::headless::{HeadlessDevice, HeadlessError, RenderSettings, SceneRenderer};

use crate::case::{CaseSpec, ReferenceLayer};
use crate::cast_shadow::cast_shadow;
use crate::error::CompareError;
use crate::models::{ComparedModel, Models};
use crate::result::{CaseImages, CaseResult, Metrics, ModelMetrics, REGIONS, RegionRow};
use crate::theta_bins;
use crate::tone::{flip_map, tone_exposure, tone_map};

/// Pixels eroded from the render's silhouette before comparing.
pub const ERODE_PX: u32 = 2;

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
    // The references are radiance: a render scaled by an exposure would not be.
    if scene.camera.exposure != 1.0 {
        return Err(case_error(format!(
            "the scene's [camera] exposure is {}: compared renders must be radiance (exposure 1)",
            scene.camera.exposure
        )));
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
            ComparedModel::Shaded { model, .. } => match model {
                ShadingModel::Measured => measured,
                ShadingModel::Gaussian => gaussian,
                ShadingModel::Lambert => lambert,
                ShadingModel::Curvature => {
                    return Err(case_error(
                        "the curvature view is no radiance to compare".into(),
                    ));
                }
            },
            ComparedModel::SpecularLayer { .. } => black,
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
        fit: case
            .fit
            .as_ref()
            .and_then(|fit| fit.file_name())
            .map(|name| name.to_string_lossy().into_owned()),
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
pub(crate) struct Geometry<'a> {
    pub(crate) mask: &'a [bool],
    pub(crate) cos_theta: &'a [f32],
    pub(crate) occluded: &'a [f32],
}

/// The 8 × 8 blocks of `render` against `reference` wholly inside the compared pixels
/// ([`block_error::blocks`]).
pub(crate) fn blocks(
    render: &RgbaImage,
    reference: &RgbaImage,
    geometry: &Geometry<'_>,
) -> Vec<Block> {
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
