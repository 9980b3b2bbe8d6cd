//! The data set manifest: `DIR/cdrf-dataset.toml` says how the photographs in `DIR` were taken.
//!
//! [`Dataset::load`] parses the manifest (unknown keys are errors, so a misspelt key cannot be
//! silently ignored), then validates it into typed values, then checks that every image exists.
//!
//! # Example
//! ```toml
//! [camera]
//! projection = "orthographic"
//!
//! [light]
//! to_light = [-1.0, 0.0, 0.0]
//! irradiance = [1.0, 1.0, 1.0]
//!
//! [[sphere]]
//! image = "sphere_r15.exr"
//! radius_mm = 15.0
//!
//! [[sphere]]
//! image = "IMG_0042.tif"
//! radius_mm = 20.0
//! center_px = [1012.5, 768.0]
//! radius_px = 402.0
//! color_space = "srgb"
//! exposure = 2.0
//! ```
//!
//! # Keys
//! Camera space is right-handed: +x image right, +y image up, +z toward the camera.
//!
//! | key | required | meaning |
//! |---|---|---|
//! | `[camera]` `projection` | yes | `"orthographic"` (telecentric lens, or a long lens far away) or `"perspective"` |
//! | `[camera]` `vertical_fov_deg` | with `"perspective"` only | full vertical field of view in degrees, in (0, 180); principal point at the image centre |
//! | `[light]` `to_light` | one of the two | direction *toward* a directional (distant) light in camera space, `[x, y, z]`; normalised on load, must not be zero |
//! | `[light]` `position_mm` | one of the two | a lamp's position in camera space, mm (pinhole at the origin); the direction and the irradiance `intensity / d²` are then per pixel. Needs `projection = "perspective"` |
//! | `[light]` `irradiance` | no | directional light: irradiance per RGB channel on a surface facing it; radiance is divided by it. Each in [1e-30, 1e30] |
//! | `[light]` `intensity` | no | lamp: a surface facing it at d mm receives `intensity / d²` (per channel, in the photographs' units). Each in [1e-30, 1e30] |
//! | `[calibration]` | no | a matte (Lambertian) reference sphere under the same light that measures its strength; takes `albedo = [r, g, b]` (each in (0, 1]) and every `[[sphere]]` key; excludes `irradiance` / `intensity`. Without either, the table is *relative* (irradiance 1, or 1 at the first sphere's centre for a lamp) and the report says so |
//! | `[[sphere]]` | at least one | one table per photograph of one sphere |
//! | `image` | yes | file name relative to the folder, inside it (an absolute path or a `..` that leaves the folder is an error); OpenEXR, PNG, JPEG or TIFF; several entries may share one |
//! | `radius_mm` | yes | the sphere's radius in millimetres, > 0; radii must differ (curvature is 1 / radius) |
//! | `center_px` | no | exactly two numbers: centre of the sphere's disk in continuous pixel coordinates `[column, row]`, `(0, 0)` = top-left corner of the top-left pixel; detected from the image if absent. In a photograph of several spheres the detected circles are matched to the entries that give no centre by size (largest disk, largest radius_mm), which holds when the spheres stand at similar distances; give centres otherwise |
//! | `radius_px` | no | radius of the disk in pixels, > 0; detected if absent |
//! | `color_space` | no | `"linear"` or `"srgb"`; default: linear for OpenEXR, float TIFF and 16-bit PNG/TIFF, sRGB for 8-bit PNG/JPEG/TIFF (see [`crate::image_io`]) |
//! | `exposure` | no, default `1` | factor the decoded linear values are multiplied by (e.g. `2` for an image shot one stop darker than the others), > 0 |
//! | `black_level`, `white_level` | no | a raw-like linear integer file's codes: `linear = (code − black) / (white − black)`, codes ≥ `white_level` are clipped; `white_level` is required with them, `black_level` defaults to 0 |
//! | `mask` | no | an image of the photograph's size; pixels where it is 0 are not used (a stand or a cup in front of the sphere) |
//! | `ambient_image` | no | the *flagged frame*: the same shot, nothing moved, with an opaque card between the lamp and this sphere so that only the light the room (and lit neighbours) bounce onto it remains; decoded like `image` and subtracted pixel by pixel from this sphere's pixels (the silhouette is still found in `image`). Entries sharing a photograph each name their own |
//!
//! Several entries (spheres and the calibration) may name the same image: a photograph of
//! several spheres. They must then decode it alike (`color_space`, `exposure`, levels). Spheres
//! keep the manifest's order. One sphere is accepted here; what can be fitted from one is the
//! fitter's business.

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use serde::Deserialize;

use crate::image_io::{ColorSpace, Decoding, SensorLevels};

/// The manifest's file name inside a data set folder.
pub const MANIFEST_FILE_NAME: &str = "cdrf-dataset.toml";

/// How the camera projects the scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Projection {
    /// Parallel projection along −z; the view vector is `(0, 0, 1)` everywhere.
    Orthographic,
    /// Pinhole camera with its principal point at the image centre.
    Perspective {
        /// Full vertical field of view in degrees, in (0, 180).
        vertical_fov_deg: f32,
    },
}

/// The `[camera]` table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// The projection.
    pub projection: Projection,
}

/// Where the light comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LightSource {
    /// A collimated light (the sun, or a lamp far away): the same direction everywhere.
    Directional {
        /// Unit vector toward the light, in camera space (+x right, +y up, +z toward the camera).
        to_light: Vec3,
    },
    /// A lamp at a finite distance: direction and irradiance change across the sphere.
    Lamp {
        /// The lamp's position in camera space, mm (the camera's pinhole at the origin).
        position_mm: Vec3,
    },
}

/// How strong the light is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LightStrength {
    /// Given per RGB channel (each > 0): the irradiance on a surface facing a directional light,
    /// or a lamp's intensity (a surface facing it at d mm receives `intensity / d²`).
    Given(Vec3),
    /// Measured from the `[calibration]` sphere.
    Calibrated,
    /// Unknown: the table is relative (a directional light's irradiance is taken as 1; a lamp's
    /// irradiance as 1 at the first sphere's centre).
    Relative,
}

/// The `[light]` table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Light {
    /// Where the light comes from.
    pub source: LightSource,
    /// How strong it is.
    pub strength: LightStrength,
}

impl Light {
    /// The direction toward a directional light (`None` for a lamp).
    pub fn to_light(&self) -> Option<Vec3> {
        match self.source {
            LightSource::Directional { to_light } => Some(to_light),
            LightSource::Lamp { .. } => None,
        }
    }

    /// The strength the manifest gives (`None` when calibrated or unknown).
    pub fn given_strength(&self) -> Option<Vec3> {
        match self.strength {
            LightStrength::Given(value) => Some(value),
            LightStrength::Calibrated | LightStrength::Relative => None,
        }
    }
}

/// The `[calibration]` table: a matte (Lambertian) reference sphere of known albedo under the
/// same light, in a photograph of its own or in one of the spheres' photographs.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    /// Its photograph and radius (as a `[[sphere]]` entry).
    pub sphere: SphereEntry,
    /// Its diffuse albedo per RGB channel, in (0, 1].
    pub albedo: Vec3,
}

/// One `[[sphere]]` entry: a photograph of one sphere.
#[derive(Debug, Clone, PartialEq)]
pub struct SphereEntry {
    /// The image file, joined to the data set folder (absolute when the folder path is).
    pub image: PathBuf,
    /// The image name as written in the manifest (for messages).
    pub image_name: String,
    /// The sphere's radius in millimetres (> 0).
    pub radius_mm: f32,
    /// Centre of the sphere's disk in continuous pixel coordinates (column, row), if given.
    pub center_px: Option<Vec2>,
    /// Radius of the disk in pixels (> 0), if given.
    pub radius_px: Option<f32>,
    /// The image's colour space, if given (otherwise the format's default).
    pub color_space: Option<ColorSpace>,
    /// Factor applied to the decoded linear values (> 0; default 1).
    pub exposure: f32,
    /// Raw-like code levels, if given.
    pub levels: Option<SensorLevels>,
    /// A mask image (same size; non-zero = use the pixel), if given.
    pub mask: Option<PathBuf>,
    /// The flagged frame (the same shot with the lamp's direct light blocked from the sphere),
    /// subtracted pixel by pixel, if given.
    pub ambient: Option<PathBuf>,
}

impl SphereEntry {
    /// How its image is decoded.
    pub fn decoding(&self) -> Decoding {
        Decoding {
            color_space: self.color_space,
            exposure: self.exposure,
            levels: self.levels,
        }
    }
}

/// A validated data set: the folder's manifest with every image checked to exist.
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    /// The data set folder (absolute).
    pub dir: PathBuf,
    /// The manifest file (`dir/cdrf-dataset.toml`).
    pub manifest: PathBuf,
    /// The camera.
    pub camera: Camera,
    /// The light.
    pub light: Light,
    /// The matte reference sphere, if any.
    pub calibration: Option<Calibration>,
    /// The spheres, in manifest order (at least one).
    pub spheres: Vec<SphereEntry>,
}

/// Why a data set could not be loaded. Every message names the folder or the manifest.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DatasetError {
    /// The folder does not exist.
    #[error("{}: no such folder", dir.display())]
    FolderMissing {
        /// The folder given.
        dir: PathBuf,
    },
    /// The path exists but is not a folder.
    #[error("{}: not a folder (give the folder that holds {MANIFEST_FILE_NAME} and the images)", dir.display())]
    NotAFolder {
        /// The path given.
        dir: PathBuf,
    },
    /// The folder has no manifest.
    #[error(
        "{}: not found ({}); every data set folder needs a {MANIFEST_FILE_NAME} listing its \
         images, camera and light; see the `cdrf-fit` section of README.md, or \
         data/wax-spheres/{MANIFEST_FILE_NAME} for an example",
        manifest.display(),
        match (images_found, example_image) {
            (0, _) => "the folder holds no images".to_owned(),
            (n, Some(name)) => format!("the folder holds {n} image(s), e.g. {name}"),
            (n, None) => format!("the folder holds {n} image(s)"),
        }
    )]
    ManifestMissing {
        /// The manifest path expected.
        manifest: PathBuf,
        /// How many image files (by extension) the folder holds.
        images_found: usize,
        /// One of them.
        example_image: Option<String>,
    },
    /// The manifest or the folder could not be read.
    #[error("{}: cannot read: {error}", path.display())]
    Read {
        /// The file or folder.
        path: PathBuf,
        /// What the operating system said.
        error: std::io::Error,
    },
    /// TOML syntax error, missing key, unknown key or a value of the wrong type.
    #[error("{}:{line}:{column}: {message}", manifest.display())]
    Parse {
        /// The manifest.
        manifest: PathBuf,
        /// 1-based line of the problem (or of the table it concerns).
        line: usize,
        /// 1-based column (in characters).
        column: usize,
        /// The TOML parser's message.
        message: String,
    },
    /// `projection = "perspective"` without `vertical_fov_deg`.
    #[error("{}: [camera] projection = \"perspective\" needs vertical_fov_deg (the full vertical field of view in degrees)", manifest.display())]
    MissingFieldOfView {
        /// The manifest.
        manifest: PathBuf,
    },
    /// `vertical_fov_deg` given with an orthographic camera.
    #[error("{}: [camera] vertical_fov_deg = {vertical_fov_deg} is only meaningful with projection = \"perspective\"", manifest.display())]
    UnexpectedFieldOfView {
        /// The manifest.
        manifest: PathBuf,
        /// The value given.
        vertical_fov_deg: f32,
    },
    /// The field of view is outside (0, 180) degrees.
    #[error("{}: [camera] vertical_fov_deg = {vertical_fov_deg}: must be in (0, 180)", manifest.display())]
    InvalidFieldOfView {
        /// The manifest.
        manifest: PathBuf,
        /// The value given.
        vertical_fov_deg: f32,
    },
    /// The light direction is zero or not finite.
    #[error("{}: [light] to_light = {to_light:?}: must be a finite, non-zero direction", manifest.display())]
    InvalidLightDirection {
        /// The manifest.
        manifest: PathBuf,
        /// The value given.
        to_light: [f32; 3],
    },
    /// An irradiance channel is not a finite number > 0.
    #[error("{}: [light] irradiance = {irradiance:?}: every channel must be a number in [{MIN_IRRADIANCE:e}, {MAX_IRRADIANCE:e}] (radiance is divided by it)", manifest.display())]
    InvalidIrradiance {
        /// The manifest.
        manifest: PathBuf,
        /// The value given.
        irradiance: [f32; 3],
    },
    /// The manifest lists no `[[sphere]]`.
    #[error("{}: no [[sphere]] entries: list at least one image with its radius_mm", manifest.display())]
    NoSpheres {
        /// The manifest.
        manifest: PathBuf,
    },
    /// A sphere's `radius_mm` is not a finite number > 0.
    #[error("{}: {image}: radius_mm = {radius_mm}: must be a finite number > 0", manifest.display())]
    InvalidRadius {
        /// The manifest.
        manifest: PathBuf,
        /// The sphere's image name.
        image: String,
        /// The value given.
        radius_mm: f32,
    },
    /// A sphere's `radius_px` is not a finite number > 0.
    #[error("{}: {image}: radius_px = {radius_px}: must be a finite number > 0", manifest.display())]
    InvalidRadiusPx {
        /// The manifest.
        manifest: PathBuf,
        /// The sphere's image name.
        image: String,
        /// The value given.
        radius_px: f32,
    },
    /// A sphere's `center_px` is not finite.
    #[error("{}: {image}: center_px = {center_px:?}: must be finite", manifest.display())]
    InvalidCenterPx {
        /// The manifest.
        manifest: PathBuf,
        /// The sphere's image name.
        image: String,
        /// The value given.
        center_px: [f32; 2],
    },
    /// A sphere's `exposure` is not a finite number > 0.
    #[error("{}: {image}: exposure = {exposure}: must be a finite number > 0", manifest.display())]
    InvalidExposure {
        /// The manifest.
        manifest: PathBuf,
        /// The sphere's image name.
        image: String,
        /// The value given.
        exposure: f32,
    },
    /// Two spheres have the same radius (the table interpolates across curvature = 1 / radius).
    #[error("{}: {first} and {second} both have radius_mm = {radius_mm}: each sphere needs a different radius", manifest.display())]
    DuplicateRadius {
        /// The manifest.
        manifest: PathBuf,
        /// The radius.
        radius_mm: f32,
        /// The first sphere's image name.
        first: String,
        /// The second sphere's image name.
        second: String,
    },
    /// Entries that share an image decode it differently.
    #[error("{}: {image} is named by several entries with different {key}: entries that share a photograph must decode it alike", manifest.display())]
    SharedImageMismatch {
        /// The manifest.
        manifest: PathBuf,
        /// The image name.
        image: String,
        /// Which key differs.
        key: &'static str,
    },
    /// The `[light]` table names no source, or both.
    #[error("{}: [light] {problem}", manifest.display())]
    LightSource {
        /// The manifest.
        manifest: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// `[calibration]` is given together with a known strength, or its albedo is out of range.
    #[error("{}: [calibration] {problem}", manifest.display())]
    Calibration {
        /// The manifest.
        manifest: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// `black_level` / `white_level` are inconsistent.
    #[error("{}: {image}: black_level / white_level: {problem}", manifest.display())]
    Levels {
        /// The manifest.
        manifest: PathBuf,
        /// The entry's image name.
        image: String,
        /// What is wrong.
        problem: String,
    },
    /// An `image` is an absolute path or leaves the data set folder through `..`.
    #[error("{}: image = {image:?}: {problem}", manifest.display())]
    ImageOutsideFolder {
        /// The manifest.
        manifest: PathBuf,
        /// The image name as written.
        image: String,
        /// Why it is refused.
        problem: String,
    },
    /// An image file does not exist (or is not a file).
    #[error("{}: {image}: no image file at {}", manifest.display(), path.display())]
    ImageMissing {
        /// The manifest.
        manifest: PathBuf,
        /// The image name as written.
        image: String,
        /// Where it was looked for.
        path: PathBuf,
    },
}

/// The smallest irradiance channel accepted (radiance is divided by it: below this the table
/// overflows f32).
pub const MIN_IRRADIANCE: f32 = 1e-30;
/// The largest irradiance channel accepted.
pub const MAX_IRRADIANCE: f32 = 1e30;

/// File extensions counted as images when the manifest is missing.
const IMAGE_EXTENSIONS: &[&str] = &["exr", "png", "jpg", "jpeg", "tif", "tiff"];

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawManifest {
    camera: RawCamera,
    light: RawLight,
    calibration: Option<RawCalibration>,
    #[serde(default)]
    sphere: Vec<RawSphere>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCamera {
    projection: RawProjection,
    vertical_fov_deg: Option<f32>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum RawProjection {
    Orthographic,
    Perspective,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLight {
    #[serde(default, deserialize_with = "optional::to_light")]
    to_light: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "optional::position_mm")]
    position_mm: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "optional::irradiance")]
    irradiance: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "optional::intensity")]
    intensity: Option<[f32; 3]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSphere {
    image: String,
    radius_mm: f32,
    #[serde(default, deserialize_with = "optional::center_px")]
    center_px: Option<[f32; 2]>,
    radius_px: Option<f32>,
    color_space: Option<RawColorSpace>,
    exposure: Option<f32>,
    black_level: Option<u16>,
    white_level: Option<u16>,
    mask: Option<String>,
    ambient_image: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCalibration {
    image: String,
    radius_mm: f32,
    #[serde(deserialize_with = "albedo")]
    albedo: [f32; 3],
    #[serde(default, deserialize_with = "optional::center_px")]
    center_px: Option<[f32; 2]>,
    radius_px: Option<f32>,
    color_space: Option<RawColorSpace>,
    exposure: Option<f32>,
    black_level: Option<u16>,
    white_level: Option<u16>,
    mask: Option<String>,
    ambient_image: Option<String>,
}

cdrf_core::exact_array_fields!(
    to_light: 3,
    position_mm: 3,
    irradiance: 3,
    intensity: 3,
    albedo: 3,
    center_px: 2
);

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum RawColorSpace {
    Linear,
    Srgb,
}

impl Dataset {
    /// Loads and validates `dir/cdrf-dataset.toml`.
    ///
    /// # Errors
    /// [`DatasetError`]: the folder or the manifest is missing or unreadable, the TOML is
    /// malformed (syntax, missing or unknown key, wrong type), a value is out of range, two
    /// spheres share a radius or an image, there is no sphere, or an image file is missing.
    pub fn load(dir: &Path) -> Result<Self, DatasetError> {
        let dir = std::path::absolute(dir).map_err(|error| DatasetError::Read {
            path: dir.to_path_buf(),
            error,
        })?;
        match std::fs::metadata(&dir) {
            Ok(meta) if meta.is_dir() => {}
            Ok(_) => return Err(DatasetError::NotAFolder { dir }),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Err(DatasetError::FolderMissing { dir });
            }
            Err(error) => return Err(DatasetError::Read { path: dir, error }),
        }
        let manifest = dir.join(MANIFEST_FILE_NAME);
        let text = match cdrf_core::input_file::read_text(&manifest) {
            Ok(text) => text,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                let (images_found, example_image) = count_images(&dir)?;
                return Err(DatasetError::ManifestMissing {
                    manifest,
                    images_found,
                    example_image,
                });
            }
            Err(error) => {
                return Err(DatasetError::Read {
                    path: manifest,
                    error,
                });
            }
        };
        let raw: RawManifest = toml::from_str(&text).map_err(|e| {
            let (line, column) = line_column(&text, e.span().map_or(0, |s| s.start));
            DatasetError::Parse {
                manifest: manifest.clone(),
                line,
                column,
                message: e.message().trim_end().to_owned(),
            }
        })?;
        let dataset = validate(raw, dir, manifest)?;
        let entries = dataset
            .spheres
            .iter()
            .chain(dataset.calibration.as_ref().map(|c| &c.sphere));
        for sphere in entries {
            let files = std::iter::once(&sphere.image)
                .chain(sphere.mask.as_ref())
                .chain(sphere.ambient.as_ref());
            for path in files {
                if !path.is_file() {
                    return Err(DatasetError::ImageMissing {
                        manifest: dataset.manifest.clone(),
                        image: sphere.image_name.clone(),
                        path: path.clone(),
                    });
                }
            }
        }
        Ok(dataset)
    }
}

/// Counts image files in `dir` (by extension) and returns one name, sorted first.
fn count_images(dir: &Path) -> Result<(usize, Option<String>), DatasetError> {
    let entries = std::fs::read_dir(dir).map_err(|error| DatasetError::Read {
        path: dir.to_path_buf(),
        error,
    })?;
    let mut names: Vec<String> = entries
        .filter_map(Result::ok)
        .filter_map(|entry| entry.file_name().into_string().ok())
        .filter(|name| {
            Path::new(name)
                .extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| IMAGE_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()))
        })
        .collect();
    names.sort();
    Ok((names.len(), names.into_iter().next()))
}

/// 1-based line and column (in characters) of byte `offset` in `text`.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = text.get(..offset).unwrap_or(text);
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = before[line_start..].chars().count() + 1;
    (line, column)
}

fn positive(value: f32) -> bool {
    value.is_finite() && value > 0.0
}

fn validate(raw: RawManifest, dir: PathBuf, manifest: PathBuf) -> Result<Dataset, DatasetError> {
    let projection = match (raw.camera.projection, raw.camera.vertical_fov_deg) {
        (RawProjection::Orthographic, None) => Projection::Orthographic,
        (RawProjection::Orthographic, Some(vertical_fov_deg)) => {
            return Err(DatasetError::UnexpectedFieldOfView {
                manifest,
                vertical_fov_deg,
            });
        }
        (RawProjection::Perspective, None) => {
            return Err(DatasetError::MissingFieldOfView { manifest });
        }
        (RawProjection::Perspective, Some(vertical_fov_deg)) => {
            if !(vertical_fov_deg.is_finite() && vertical_fov_deg > 0.0 && vertical_fov_deg < 180.0)
            {
                return Err(DatasetError::InvalidFieldOfView {
                    manifest,
                    vertical_fov_deg,
                });
            }
            Projection::Perspective { vertical_fov_deg }
        }
    };

    let light = validate_light(&raw.light, projection, raw.calibration.is_some(), &manifest)?;

    if raw.sphere.is_empty() {
        return Err(DatasetError::NoSpheres { manifest });
    }
    let mut spheres: Vec<SphereEntry> = Vec::with_capacity(raw.sphere.len());
    for s in raw.sphere {
        let entry = validate_entry(s, &dir, &manifest)?;
        for earlier in &spheres {
            if earlier.radius_mm == entry.radius_mm {
                return Err(DatasetError::DuplicateRadius {
                    manifest,
                    radius_mm: entry.radius_mm,
                    first: earlier.image_name.clone(),
                    second: entry.image_name,
                });
            }
        }
        spheres.push(entry);
    }
    let calibration = match raw.calibration {
        None => None,
        Some(c) => {
            let albedo = Vec3::from_array(c.albedo);
            if !albedo.is_finite() || albedo.min_element() <= 0.0 || albedo.max_element() > 1.0 {
                return Err(DatasetError::Calibration {
                    manifest,
                    problem: format!("albedo = {:?}: every channel must be in (0, 1]", c.albedo),
                });
            }
            let sphere = validate_entry(
                RawSphere {
                    image: c.image,
                    radius_mm: c.radius_mm,
                    center_px: c.center_px,
                    radius_px: c.radius_px,
                    color_space: c.color_space,
                    exposure: c.exposure,
                    black_level: c.black_level,
                    white_level: c.white_level,
                    mask: c.mask,
                    ambient_image: c.ambient_image,
                },
                &dir,
                &manifest,
            )?;
            Some(Calibration { sphere, albedo })
        }
    };
    // Entries that share a photograph must decode it alike (it is decoded once).
    let all: Vec<&SphereEntry> = spheres
        .iter()
        .chain(calibration.as_ref().map(|c| &c.sphere))
        .collect();
    for (i, a) in all.iter().enumerate() {
        for b in &all[..i] {
            if a.image != b.image {
                continue;
            }
            let key = if a.color_space != b.color_space {
                "color_space"
            } else if a.exposure != b.exposure {
                "exposure"
            } else if a.levels != b.levels {
                "black_level / white_level"
            } else {
                continue;
            };
            return Err(DatasetError::SharedImageMismatch {
                manifest,
                image: a.image_name.clone(),
                key,
            });
        }
    }

    Ok(Dataset {
        dir,
        manifest,
        camera: Camera { projection },
        light,
        calibration,
        spheres,
    })
}

fn validate_light(
    raw: &RawLight,
    projection: Projection,
    calibrated: bool,
    manifest: &Path,
) -> Result<Light, DatasetError> {
    let light_error = |problem: &str| DatasetError::LightSource {
        manifest: manifest.to_path_buf(),
        problem: problem.to_owned(),
    };
    let (source, given) = match (raw.to_light, raw.position_mm) {
        (Some(_), Some(_)) => {
            return Err(light_error(
                "gives both to_light (a directional light) and position_mm (a lamp): keep one",
            ));
        }
        (None, None) => {
            return Err(light_error(
                "needs to_light (the direction toward a distant light) or position_mm (a lamp's position relative to the camera, mm)",
            ));
        }
        (Some(raw_to_light), None) => {
            if raw.intensity.is_some() {
                return Err(light_error(
                    "intensity is a lamp's (with position_mm); a directional light takes irradiance",
                ));
            }
            // Divide by the largest component first so that huge (finite) vectors normalise too.
            let to_light = Vec3::from_array(raw_to_light);
            let largest = to_light.abs().max_element();
            if !(to_light.is_finite() && largest > 0.0) {
                return Err(DatasetError::InvalidLightDirection {
                    manifest: manifest.to_path_buf(),
                    to_light: raw_to_light,
                });
            }
            let to_light = (to_light / largest).normalize();
            (LightSource::Directional { to_light }, raw.irradiance)
        }
        (None, Some(position_mm)) => {
            if raw.irradiance.is_some() {
                return Err(light_error(
                    "irradiance is a directional light's; a lamp (position_mm) takes intensity (a surface facing it at d mm receives intensity / d²)",
                ));
            }
            if !matches!(projection, Projection::Perspective { .. }) {
                return Err(light_error(
                    "a lamp (position_mm) needs [camera] projection = \"perspective\": an orthographic photograph does not say how far the sphere is from it",
                ));
            }
            let position_mm = Vec3::from_array(position_mm);
            if !position_mm.is_finite() {
                return Err(light_error(&format!(
                    "position_mm = {:?}: must be finite",
                    position_mm.to_array()
                )));
            }
            (LightSource::Lamp { position_mm }, raw.intensity)
        }
    };
    let strength = match (given, calibrated) {
        (Some(value), false) => {
            if !value
                .iter()
                .all(|&c| (MIN_IRRADIANCE..=MAX_IRRADIANCE).contains(&c))
            {
                return Err(DatasetError::InvalidIrradiance {
                    manifest: manifest.to_path_buf(),
                    irradiance: value,
                });
            }
            LightStrength::Given(Vec3::from_array(value))
        }
        (Some(_), true) => {
            return Err(DatasetError::Calibration {
                manifest: manifest.to_path_buf(),
                problem: "is given together with the light's irradiance / intensity: give one (the calibration measures it)".to_owned(),
            });
        }
        (None, true) => LightStrength::Calibrated,
        (None, false) => LightStrength::Relative,
    };
    Ok(Light { source, strength })
}

/// Validates one `[[sphere]]` (or the calibration's) entry, resolving its files in `dir`.
fn validate_entry(s: RawSphere, dir: &Path, manifest: &Path) -> Result<SphereEntry, DatasetError> {
    let manifest = manifest.to_path_buf();
    let image = s.image;
    if !positive(s.radius_mm) {
        return Err(DatasetError::InvalidRadius {
            manifest,
            image,
            radius_mm: s.radius_mm,
        });
    }
    if let Some(radius_px) = s.radius_px
        && !positive(radius_px)
    {
        return Err(DatasetError::InvalidRadiusPx {
            manifest,
            image,
            radius_px,
        });
    }
    if let Some(center_px) = s.center_px
        && !center_px.iter().all(|c| c.is_finite())
    {
        return Err(DatasetError::InvalidCenterPx {
            manifest,
            image,
            center_px,
        });
    }
    let exposure = s.exposure.unwrap_or(1.0);
    if !positive(exposure) {
        return Err(DatasetError::InvalidExposure {
            manifest,
            image,
            exposure,
        });
    }
    let color_space = s.color_space.map(|c| match c {
        RawColorSpace::Linear => ColorSpace::Linear,
        RawColorSpace::Srgb => ColorSpace::Srgb,
    });
    let levels = match (s.black_level, s.white_level) {
        (None, None) => None,
        (black, Some(white)) => {
            let black = black.unwrap_or(0);
            let problem = if black >= white {
                Some(format!(
                    "black_level = {black} must be below white_level = {white}"
                ))
            } else if color_space == Some(ColorSpace::Srgb) {
                Some(
                    "they describe linear sensor codes; this entry says color_space = \"srgb\""
                        .to_owned(),
                )
            } else {
                None
            };
            if let Some(problem) = problem {
                return Err(DatasetError::Levels {
                    manifest,
                    image,
                    problem,
                });
            }
            Some(SensorLevels { black, white })
        }
        (Some(_), None) => {
            return Err(DatasetError::Levels {
                manifest,
                image,
                problem: "black_level needs white_level (the code at which the sensor clips)"
                    .to_owned(),
            });
        }
    };
    let resolve = |name: &str| {
        cdrf_core::input_file::resolve_inside(dir, name).map_err(|problem| {
            DatasetError::ImageOutsideFolder {
                manifest: manifest.clone(),
                image: name.to_owned(),
                problem,
            }
        })
    };
    let path = resolve(&image)?;
    let mask = s.mask.as_deref().map(resolve).transpose()?;
    let ambient = s.ambient_image.as_deref().map(resolve).transpose()?;
    Ok(SphereEntry {
        image: path,
        image_name: image,
        radius_mm: s.radius_mm,
        center_px: s.center_px.map(Vec2::from_array),
        radius_px: s.radius_px,
        color_space,
        exposure,
        levels,
        mask,
        ambient,
    })
}
