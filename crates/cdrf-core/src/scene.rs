//! The scene file: one mesh, an orthographic or perspective camera, lights (directional, point,
//! spot), a shading model and optionally an environment light, in TOML. Headless rendering, the
//! tests and the accuracy evaluation read it.
//!
//! Every key, with its unit and default, is in `docs/scene-file.md`; [`KEYS`] lists them (a
//! test holds that list against this parser and the document). A minimal scene:
//!
//! ```toml
//! [mesh]
//! path = "bunny.obj"            # OBJ or glTF/GLB, relative to this file
//! mm_per_unit = 10.0            # millimetres per mesh (= world) unit
//!
//! [camera]                      # orthographic: ortho_half_height; perspective: vertical_fov_deg
//! eye = [0.0, 0.0, 250.0]
//! target = [0.0, 0.0, 0.0]
//! up = [0.0, 1.0, 0.0]
//! ortho_half_height = 50.0      # world units
//! width = 512
//! height = 512
//!
//! [[light]]                     # directional by default
//! to_light = [-1.0, 0.0, 0.0]   # toward the light, world space
//! irradiance = [1.0, 1.0, 1.0]  # linear RGB, on a surface facing it
//!
//! [shading]
//! model = "measured"            # measured | gaussian | lambert | curvature
//! lut = "out/measured.exr"      # cdrf-fit's table
//! ```
//!
//! `shadows`, `transmission`, `interreflection` and `subsurface` under `[shading]` are the
//! non-local terms ([`NonLocal`], see [`crate::translucency`]); all off is the poster's local
//! model.
//!
//! # Units
//! World units are the mesh's units; one is `mm_per_unit` millimetres. The model transform's
//! `scale` makes the object physically larger, so its curvature in mm⁻¹ is the mesh's divided
//! by `scale`. Camera positions and `ortho_half_height` are in world units.
//!
//! # Camera
//! The conventions of the bundled data (`data/README.md`): right-handed, the camera looks from
//! `eye` to `target` with `up` projected to the image's +y; pixel (i, j), row 0 at the top, has
//! its centre at `(i + 0.5 − W/2)·s` along the image's right and `(H/2 − j − 0.5)·s` along its
//! up, `s = 2·ortho_half_height/H` (square pixels).

use std::path::{Path, PathBuf};

use glam::{Mat4, Vec3};
use serde::Deserialize;
use thiserror::Error;

use crate::curvature::{CurvatureError, CurvatureOptions, curvature_per_mm};
use crate::environment::{Environment, EnvironmentDesc, EnvironmentError, EnvironmentSource};
use crate::gaussian::GaussianCdrf;
use crate::gaussian_file::{GaussianFileError, read_gaussian};
use crate::light::{DirectionalLight, Light, NonLocal, PointLight, SpotLight};
use crate::lut::{CdrfLut, ViewCorrection};
use crate::lut_file::{LutFileError, read_lut};
use crate::mesh::{LoadError, Mesh, MeshSurfaces};
use crate::shading::ShadingModel;
use crate::specular::{DEFAULT_IOR, DEFAULT_ROUGHNESS_ALPHA, SpecularLayer};

/// A scene: what to render and how.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// The mesh and its placement.
    pub mesh: MeshSpec,
    /// The camera and image size.
    pub camera: Camera,
    /// The lights (at least one), in the file's order.
    pub lights: Vec<Light>,
    /// The shading model.
    pub shading: ShadingSpec,
    /// The non-local terms (`[shading] shadows`, `transmission`, `interreflection`,
    /// `subsurface`).
    pub non_local: NonLocal,
    /// The first-surface reflection (`[shading] specular`, `specular_roughness`, `ior`);
    /// `None`: off.
    pub specular: Option<SpecularLayer>,
    /// The environment light (`[environment]`; its map path resolved), loaded by
    /// [`Scene::load_environment`].
    pub environment: Option<EnvironmentDesc>,
}

/// The mesh of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshSpec {
    /// The mesh file, resolved against the scene file's folder.
    pub path: PathBuf,
    /// Millimetres per mesh unit.
    pub mm_per_unit: f32,
    /// Model → world.
    pub transform: ModelTransform,
    /// Rounds of smoothing of the per-vertex curvature
    /// ([`CurvatureOptions::with_smoothing_iterations`]); 0 = none.
    pub curvature_smoothing: u32,
    /// The length the curvature is filtered over, mm ([`CurvatureOptions::with_filter_length_mm`]):
    /// `None` = the material's [`Material::diffusion_length_mm`], 0 = no filter.
    pub curvature_filter_mm: Option<f32>,
}

/// Uniform scale, then rotations about x, y and z, then translation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModelTransform {
    /// Uniform scale (> 0).
    pub scale: f32,
    /// Rotation angles about x, y and z in degrees, applied in that order.
    pub rotate_deg: [f32; 3],
    /// Translation in world units.
    pub translate: [f32; 3],
}

impl Default for ModelTransform {
    fn default() -> Self {
        Self {
            scale: 1.0,
            rotate_deg: [0.0; 3],
            translate: [0.0; 3],
        }
    }
}

impl ModelTransform {
    /// `T · Rz · Ry · Rx · S`.
    pub fn world_from_model(&self) -> Mat4 {
        let [x, y, z] = self.rotate_deg.map(f32::to_radians);
        Mat4::from_translation(Vec3::from_array(self.translate))
            * Mat4::from_rotation_z(z)
            * Mat4::from_rotation_y(y)
            * Mat4::from_rotation_x(x)
            * Mat4::from_scale(Vec3::splat(self.scale))
    }
}

/// Camera projection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Parallel rays; the frame is `2·half_height` world units tall.
    Orthographic {
        /// Half the frame height, world units.
        half_height: f32,
    },
    /// A pinhole camera.
    Perspective {
        /// Full vertical field of view, degrees.
        vertical_fov_deg: f32,
    },
}

/// The camera and image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Projection.
    pub projection: Projection,
    /// Camera position, world units.
    pub eye: Vec3,
    /// The point at the image centre.
    pub target: Vec3,
    /// Up direction (projected to the image's +y).
    pub up: Vec3,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// MSAA samples per pixel (1 or 4).
    pub msaa_samples: u32,
    /// Multiplies the rendered radiance (1: physical output), in (0, [`MAX_EXPOSURE`]].
    pub exposure: f32,
}

impl Camera {
    /// Width over height.
    pub fn aspect(&self) -> f32 {
        self.width as f32 / self.height as f32
    }

    /// World → view (right-handed, camera looking down −z).
    pub fn view_from_world(&self) -> Mat4 {
        glam::camera::rh::view::look_at_mat4(self.eye, self.target, self.up)
    }

    /// View → clip in wgpu's conventions (depth 0 at `near`, 1 at `far`; y up); `near` and
    /// `far` are distances along the view direction in world units.
    pub fn clip_from_view(&self, near: f32, far: f32) -> Mat4 {
        match self.projection {
            Projection::Orthographic { half_height } => {
                let half_width = half_height * self.aspect();
                glam::camera::rh::proj::directx::orthographic(
                    -half_width,
                    half_width,
                    -half_height,
                    half_height,
                    near,
                    far,
                )
            }
            Projection::Perspective { vertical_fov_deg } => {
                glam::camera::rh::proj::directx::perspective(
                    vertical_fov_deg.to_radians(),
                    self.aspect(),
                    near,
                    far,
                )
            }
        }
    }
}

/// The shading model and its data files.
#[derive(Clone, Debug, PartialEq)]
pub enum ShadingSpec {
    /// A measured LUT.
    Measured {
        /// The LUT file (resolved).
        lut: PathBuf,
    },
    /// Kubo's Gaussian CDRF.
    Gaussian {
        /// The `gaussian.toml` (resolved).
        parameters: PathBuf,
    },
    /// Lambert.
    Lambert {
        /// Albedo per channel.
        albedo: [f32; 3],
    },
    /// The curvature view.
    Curvature {
        /// κ at the colour map's ends, mm⁻¹ (`None`: ±max |κ| of the drawn mesh).
        range_per_mm: Option<[f32; 2]>,
    },
}

impl ShadingSpec {
    /// The model this is.
    pub fn model(&self) -> ShadingModel {
        match self {
            ShadingSpec::Measured { .. } => ShadingModel::Measured,
            ShadingSpec::Gaussian { .. } => ShadingModel::Gaussian,
            ShadingSpec::Lambert { .. } => ShadingModel::Lambert,
            ShadingSpec::Curvature { .. } => ShadingModel::Curvature,
        }
    }
}

/// A shading model with its data loaded.
#[derive(Clone, Debug, PartialEq)]
pub enum Material {
    /// A measured LUT with its view correction.
    Measured(CdrfLut),
    /// Kubo's Gaussian CDRF and the view correction it shares.
    Gaussian {
        /// The model.
        model: GaussianCdrf,
        /// g(θ, φ).
        view_correction: ViewCorrection,
    },
    /// Lambert.
    Lambert {
        /// Albedo per channel.
        albedo: [f32; 3],
    },
    /// The curvature view.
    Curvature {
        /// κ at the colour map's ends, mm⁻¹.
        range_per_mm: [f32; 2],
    },
}

impl Material {
    /// How far the material's light travels under the surface, mm (the measured table's
    /// [`CdrfLut::diffusion_length_mm`], the Gaussian's largest σ); `None` for Lambert and the
    /// curvature view. A scene filters its mesh's curvature over it unless `[mesh]
    /// curvature_filter_mm` says otherwise.
    pub fn diffusion_length_mm(&self) -> Option<f32> {
        match self {
            Material::Measured(lut) => lut.diffusion_length_mm(),
            Material::Gaussian { model, .. } => {
                Some(model.sigma_mm().into_iter().fold(0.0f32, f32::max)).filter(|s| *s > 0.0)
            }
            Material::Lambert { .. } | Material::Curvature { .. } => None,
        }
    }

    /// The model this is.
    pub fn model(&self) -> ShadingModel {
        match self {
            Material::Measured(_) => ShadingModel::Measured,
            Material::Gaussian { .. } => ShadingModel::Gaussian,
            Material::Lambert { .. } => ShadingModel::Lambert,
            Material::Curvature { .. } => ShadingModel::Curvature,
        }
    }
}

/// A scene's files, loaded.
#[derive(Clone, Debug)]
pub struct SceneAssets {
    /// The mesh in its own units.
    pub mesh: Mesh,
    /// Per-vertex mean curvature, mm⁻¹, of the mesh at `mm_per_unit` (before the model
    /// transform's scale).
    pub curvature_per_mm: Vec<f32>,
    /// Per-vertex anisotropy of the curvature, mm⁻¹, in the mesh's own frame (see
    /// [`crate::curvature::Curvature`]); empty: none (the mean curvature in every direction).
    pub curvature_anisotropy_per_mm: Vec<Vec3>,
    /// The shading model with its data.
    pub material: Material,
    /// The mesh's glTF materials, primitives and tangents, to draw it textured (empty
    /// primitives: one untextured draw of the whole mesh).
    pub surfaces: MeshSurfaces,
}

/// Why a scene could not be loaded.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum SceneError {
    /// The scene file could not be read.
    #[error("{}: {error}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        error: std::io::Error,
    },
    /// Malformed TOML, an unknown key or a missing one.
    #[error("{}: {message}", path.display())]
    Syntax {
        /// The scene file.
        path: PathBuf,
        /// The parser's message.
        message: String,
    },
    /// A value is out of range or a key does not fit the chosen model.
    #[error("{}: {key}: {problem}", path.display())]
    Invalid {
        /// The scene file.
        path: PathBuf,
        /// The key, e.g. `[camera] width`.
        key: &'static str,
        /// What is wrong.
        problem: String,
    },
    /// The mesh could not be loaded. The message includes the loader's cause (which
    /// [`LoadError`] keeps as its `source`), so printing this error alone says why.
    #[error("[mesh] path: {error}{}", causes(error))]
    Mesh {
        /// The mesh loader's error (names the mesh file).
        error: LoadError,
    },
    /// Curvature could not be estimated.
    #[error("{}: curvature: {error}", mesh.display())]
    Curvature {
        /// The mesh file.
        mesh: PathBuf,
        /// Why.
        error: CurvatureError,
    },
    /// The LUT could not be read.
    #[error("[shading] lut: {error}")]
    Lut {
        /// The LUT reader's error (names the LUT file).
        error: LutFileError,
    },
    /// `[shading] subsurface = true` with a table that has no diffusion profile (a dipole preset, or
    /// a LUT file before format version 4).
    #[error(
        "[shading] subsurface: {} has no diffusion profile, which the subsurface gather needs \
         (a preset, or a table from before LUT format 4): use a table cdrf-fit wrote, or turn \
         subsurface off",
        lut.display()
    )]
    NoDiffusionProfile {
        /// The LUT file.
        lut: PathBuf,
    },
    /// The Gaussian parameters could not be read.
    #[error("[shading] gaussian: {error}")]
    Gaussian {
        /// The parameter file's error (names that file).
        error: GaussianFileError,
    },
    /// The environment map could not be read or is not usable.
    #[error("[environment]: {error}")]
    Environment {
        /// The environment's error (names the map file).
        error: EnvironmentError,
    },
}

/// `": cause: its cause …"` for every error in `error`'s source chain (empty without one).
fn causes(error: &dyn std::error::Error) -> String {
    let mut text = String::new();
    let mut next = error.source();
    while let Some(cause) = next {
        text.push_str(": ");
        text.push_str(&cause.to_string());
        next = cause.source();
    }
    text
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    mesh: RawMesh,
    camera: RawCamera,
    #[serde(default)]
    light: Vec<RawLight>,
    shading: RawShading,
    environment: Option<RawEnvironment>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEnvironment {
    #[serde(default, deserialize_with = "optional::uniform")]
    uniform: Option<[f32; 3]>,
    map: Option<PathBuf>,
    intensity: Option<f32>,
    rotate_deg: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMesh {
    path: PathBuf,
    #[serde(default = "one")]
    mm_per_unit: f32,
    #[serde(default = "one")]
    scale: f32,
    #[serde(default, deserialize_with = "rotate_deg")]
    rotate_deg: [f32; 3],
    #[serde(default, deserialize_with = "translate")]
    translate: [f32; 3],
    #[serde(default)]
    curvature_smoothing: u32,
    #[serde(default)]
    curvature_filter_mm: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCamera {
    projection: Option<String>,
    #[serde(deserialize_with = "eye")]
    eye: [f32; 3],
    #[serde(deserialize_with = "target")]
    target: [f32; 3],
    #[serde(deserialize_with = "up")]
    up: [f32; 3],
    ortho_half_height: Option<f32>,
    vertical_fov_deg: Option<f32>,
    width: u32,
    height: u32,
    #[serde(default = "four")]
    msaa_samples: u32,
    exposure: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLight {
    #[serde(rename = "type")]
    kind: Option<String>,
    #[serde(default, deserialize_with = "optional::to_light")]
    to_light: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "optional::irradiance")]
    irradiance: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "optional::position")]
    position: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "optional::intensity")]
    intensity: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "optional::direction")]
    direction: Option<[f32; 3]>,
    inner_angle_deg: Option<f32>,
    outer_angle_deg: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawShading {
    model: String,
    lut: Option<PathBuf>,
    gaussian: Option<PathBuf>,
    #[serde(default, deserialize_with = "optional::albedo")]
    albedo: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "optional::curvature_range_per_mm")]
    curvature_range_per_mm: Option<[f32; 2]>,
    #[serde(default)]
    shadows: bool,
    #[serde(default)]
    transmission: bool,
    #[serde(default)]
    interreflection: bool,
    #[serde(default)]
    subsurface: bool,
    #[serde(default)]
    specular: bool,
    specular_roughness: Option<f32>,
    ior: Option<f32>,
}

crate::exact_array_fields!(
    rotate_deg: 3,
    translate: 3,
    eye: 3,
    target: 3,
    up: 3,
    to_light: 3,
    irradiance: 3,
    position: 3,
    intensity: 3,
    direction: 3,
    albedo: 3,
    curvature_range_per_mm: 2,
    uniform: 3,
);

fn one() -> f32 {
    1.0
}

fn four() -> u32 {
    4
}

/// Largest image side accepted.
pub const MAX_IMAGE_SIDE: u32 = 16384;

/// The largest `[camera] exposure`: beyond it every lit pixel saturates, which is a mistake, not
/// a setting.
pub const MAX_EXPOSURE: f32 = 1.0e6;

/// Why `exposure` cannot be an exposure (it must be > 0 and at most [`MAX_EXPOSURE`]), or
/// `None`: the one check of the scene file's key and the render command's flag.
pub fn exposure_problem(exposure: f32) -> Option<String> {
    (!(exposure > 0.0 && exposure <= MAX_EXPOSURE))
        .then(|| format!("{exposure}: must be > 0 and at most {MAX_EXPOSURE}"))
}

/// Every key the parser accepts, as `[table] key` (`[[light]]` for the light tables); a test
/// holds it against the parser, and `docs/scene-file.md` documents each one.
pub const KEYS: &[&str] = &[
    "[mesh] path",
    "[mesh] mm_per_unit",
    "[mesh] scale",
    "[mesh] rotate_deg",
    "[mesh] translate",
    "[mesh] curvature_smoothing",
    "[mesh] curvature_filter_mm",
    "[camera] projection",
    "[camera] eye",
    "[camera] target",
    "[camera] up",
    "[camera] ortho_half_height",
    "[camera] vertical_fov_deg",
    "[camera] width",
    "[camera] height",
    "[camera] msaa_samples",
    "[camera] exposure",
    "[[light]] type",
    "[[light]] to_light",
    "[[light]] irradiance",
    "[[light]] position",
    "[[light]] intensity",
    "[[light]] direction",
    "[[light]] inner_angle_deg",
    "[[light]] outer_angle_deg",
    "[shading] model",
    "[shading] lut",
    "[shading] gaussian",
    "[shading] albedo",
    "[shading] curvature_range_per_mm",
    "[shading] shadows",
    "[shading] transmission",
    "[shading] interreflection",
    "[shading] subsurface",
    "[shading] specular",
    "[shading] specular_roughness",
    "[shading] ior",
    "[environment] uniform",
    "[environment] map",
    "[environment] intensity",
    "[environment] rotate_deg",
];

impl Scene {
    /// Reads and validates a scene file; relative paths resolve against its folder.
    ///
    /// # Errors
    /// [`SceneError`] naming the file and the key.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, SceneError> {
        let path = path.as_ref();
        let text = crate::input_file::read_text(path).map_err(|error| SceneError::Io {
            path: path.to_owned(),
            error,
        })?;
        let base = path.parent().unwrap_or(Path::new("."));
        Self::from_toml_str(&text, base, path)
    }

    /// Parses scene TOML; relative paths resolve against `base_dir`; errors name `file`.
    ///
    /// # Errors
    /// [`SceneError`].
    pub fn from_toml_str(text: &str, base_dir: &Path, file: &Path) -> Result<Self, SceneError> {
        let raw: RawScene = toml::from_str(text).map_err(|error| SceneError::Syntax {
            path: file.to_owned(),
            message: error.to_string().trim_end().to_owned(),
        })?;
        let invalid = |key: &'static str, problem: String| SceneError::Invalid {
            path: file.to_owned(),
            key,
            problem,
        };
        let finite3 = |key: &'static str, v: [f32; 3]| {
            if v.iter().all(|x| x.is_finite()) {
                Ok(Vec3::from_array(v))
            } else {
                Err(invalid(key, format!("{v:?}: must be finite")))
            }
        };

        let m = raw.mesh;
        if !(m.mm_per_unit.is_finite() && m.mm_per_unit > 0.0) {
            return Err(invalid(
                "[mesh] mm_per_unit",
                format!("{}: must be > 0", m.mm_per_unit),
            ));
        }
        if !(m.scale.is_finite() && m.scale > 0.0) {
            return Err(invalid("[mesh] scale", format!("{}: must be > 0", m.scale)));
        }
        if m.curvature_smoothing > crate::curvature::MAX_SMOOTHING_ITERATIONS {
            return Err(invalid(
                "[mesh] curvature_smoothing",
                format!(
                    "{}: at most {} rounds",
                    m.curvature_smoothing,
                    crate::curvature::MAX_SMOOTHING_ITERATIONS
                ),
            ));
        }
        if let Some(length) = m.curvature_filter_mm
            && !(length.is_finite() && length >= 0.0)
        {
            return Err(invalid(
                "[mesh] curvature_filter_mm",
                format!("{length}: must be finite and ≥ 0 (0: no filter)"),
            ));
        }
        finite3("[mesh] rotate_deg", m.rotate_deg)?;
        finite3("[mesh] translate", m.translate)?;
        let mesh = MeshSpec {
            path: base_dir.join(&m.path),
            mm_per_unit: m.mm_per_unit,
            transform: ModelTransform {
                scale: m.scale,
                rotate_deg: m.rotate_deg,
                translate: m.translate,
            },
            curvature_smoothing: m.curvature_smoothing,
            curvature_filter_mm: m.curvature_filter_mm,
        };

        let c = raw.camera;
        // Without `projection`, the one projection key given says which.
        let projection_name = match (
            c.projection.as_deref(),
            c.ortho_half_height,
            c.vertical_fov_deg,
        ) {
            (Some(name), _, _) => name,
            (None, Some(_), None) => "orthographic",
            (None, None, Some(_)) => "perspective",
            (None, Some(_), Some(_)) => {
                return Err(invalid(
                    "[camera] projection",
                    "not given, and both ortho_half_height and vertical_fov_deg are: give \
                     projection = \"orthographic\" or \"perspective\", or only one of them"
                        .into(),
                ));
            }
            (None, None, None) => {
                return Err(invalid(
                    "[camera] projection",
                    "not given: give ortho_half_height (orthographic) or vertical_fov_deg \
                     (perspective)"
                        .into(),
                ));
            }
        };
        let projection = match projection_name {
            "orthographic" => {
                if c.vertical_fov_deg.is_some() {
                    return Err(invalid(
                        "[camera] vertical_fov_deg",
                        "only for projection = \"perspective\"".into(),
                    ));
                }
                let half_height = c.ortho_half_height.ok_or_else(|| {
                    invalid(
                        "[camera] ortho_half_height",
                        "required for an orthographic camera".into(),
                    )
                })?;
                if !(half_height.is_finite() && half_height > 0.0) {
                    return Err(invalid(
                        "[camera] ortho_half_height",
                        format!("{half_height}: must be > 0"),
                    ));
                }
                Projection::Orthographic { half_height }
            }
            "perspective" => {
                if c.ortho_half_height.is_some() {
                    return Err(invalid(
                        "[camera] ortho_half_height",
                        "only for projection = \"orthographic\"".into(),
                    ));
                }
                let fov = c.vertical_fov_deg.ok_or_else(|| {
                    invalid(
                        "[camera] vertical_fov_deg",
                        "required for a perspective camera".into(),
                    )
                })?;
                if !(fov > 0.0 && fov < 180.0) {
                    return Err(invalid(
                        "[camera] vertical_fov_deg",
                        format!("{fov}: must be in (0, 180)"),
                    ));
                }
                Projection::Perspective {
                    vertical_fov_deg: fov,
                }
            }
            other => {
                return Err(invalid(
                    "[camera] projection",
                    format!("\"{other}\": must be \"orthographic\" or \"perspective\""),
                ));
            }
        };
        let eye = finite3("[camera] eye", c.eye)?;
        let target = finite3("[camera] target", c.target)?;
        let up = finite3("[camera] up", c.up)?;
        let forward = target - eye;
        if forward.length() <= 1e-6 * eye.length().max(1.0) {
            return Err(invalid(
                "[camera] target",
                "must differ from eye".to_owned(),
            ));
        }
        if up.length() == 0.0 || forward.normalize().cross(up.normalize()).length() < 1e-4 {
            return Err(invalid(
                "[camera] up",
                format!(
                    "{:?}: must not be zero or parallel to the view direction",
                    c.up
                ),
            ));
        }
        for (key, side) in [("[camera] width", c.width), ("[camera] height", c.height)] {
            if !(1..=MAX_IMAGE_SIDE).contains(&side) {
                return Err(invalid(
                    key,
                    format!("{side}: must be 1..={MAX_IMAGE_SIDE}"),
                ));
            }
        }
        if !matches!(c.msaa_samples, 1 | 4) {
            return Err(invalid(
                "[camera] msaa_samples",
                format!("{}: must be 1 or 4", c.msaa_samples),
            ));
        }
        let exposure = c.exposure.unwrap_or(1.0);
        if let Some(problem) = exposure_problem(exposure) {
            return Err(invalid("[camera] exposure", problem));
        }
        let camera = Camera {
            projection,
            eye,
            target,
            up,
            width: c.width,
            height: c.height,
            msaa_samples: c.msaa_samples,
            exposure,
        };

        if raw.light.is_empty() {
            return Err(invalid(
                "[[light]]",
                "at least one light is required".into(),
            ));
        }
        let mut lights = Vec::with_capacity(raw.light.len());
        for light in raw.light {
            let kind = light.kind.as_deref().unwrap_or("directional");
            // Each key belongs to some kinds; a key of another kind is a mistake, not ignored.
            let keys: [(&'static str, bool, &[&str]); 7] = [
                (
                    "[[light]] to_light",
                    light.to_light.is_some(),
                    &["directional"],
                ),
                (
                    "[[light]] irradiance",
                    light.irradiance.is_some(),
                    &["directional"],
                ),
                (
                    "[[light]] position",
                    light.position.is_some(),
                    &["point", "spot"],
                ),
                (
                    "[[light]] intensity",
                    light.intensity.is_some(),
                    &["point", "spot"],
                ),
                ("[[light]] direction", light.direction.is_some(), &["spot"]),
                (
                    "[[light]] inner_angle_deg",
                    light.inner_angle_deg.is_some(),
                    &["spot"],
                ),
                (
                    "[[light]] outer_angle_deg",
                    light.outer_angle_deg.is_some(),
                    &["spot"],
                ),
            ];
            if !["directional", "point", "spot"].contains(&kind) {
                return Err(invalid(
                    "[[light]] type",
                    format!("\"{kind}\": must be \"directional\", \"point\" or \"spot\""),
                ));
            }
            for (key, present, kinds) in keys {
                if present && !kinds.contains(&kind) {
                    return Err(invalid(key, format!("not used by type = \"{kind}\"")));
                }
                if !present && kinds.contains(&kind) {
                    return Err(invalid(key, format!("required by type = \"{kind}\"")));
                }
            }
            let colour = |key: &'static str, value: Option<[f32; 3]>| {
                let value = value.unwrap_or_default();
                if value.iter().any(|e| !e.is_finite() || *e < 0.0) {
                    Err(invalid(key, format!("{value:?}: must be finite and ≥ 0")))
                } else {
                    Ok(value)
                }
            };
            let unit = |key: &'static str, value: Option<[f32; 3]>| {
                let v = finite3(key, value.unwrap_or_default())?;
                if v.length() < 1e-12 {
                    return Err(invalid(key, "must not be zero".into()));
                }
                Ok(v.normalize())
            };
            lights.push(match kind {
                "directional" => Light::Directional(DirectionalLight {
                    to_light: unit("[[light]] to_light", light.to_light)?,
                    irradiance: colour("[[light]] irradiance", light.irradiance)?,
                }),
                "point" => Light::Point(PointLight {
                    position: finite3("[[light]] position", light.position.unwrap_or_default())?,
                    intensity: colour("[[light]] intensity", light.intensity)?,
                }),
                _ => {
                    let inner = light.inner_angle_deg.unwrap_or_default();
                    let outer = light.outer_angle_deg.unwrap_or_default();
                    // (NaN fails every comparison.)
                    if !(0.0 <= inner && inner < outer && outer <= 90.0) {
                        return Err(invalid(
                            "[[light]] inner_angle_deg, outer_angle_deg",
                            format!("{inner}, {outer}: must satisfy 0 ≤ inner < outer ≤ 90"),
                        ));
                    }
                    Light::Spot(SpotLight {
                        position: finite3(
                            "[[light]] position",
                            light.position.unwrap_or_default(),
                        )?,
                        direction: unit("[[light]] direction", light.direction)?,
                        intensity: colour("[[light]] intensity", light.intensity)?,
                        inner_angle_rad: inner.to_radians(),
                        outer_angle_rad: outer.to_radians(),
                    })
                }
            });
        }

        let s = raw.shading;
        let unexpected = |key: &'static str, present: bool, model: &str| {
            if present {
                Err(invalid(key, format!("not used by model = \"{model}\"")))
            } else {
                Ok(())
            }
        };
        let Some(model) = ShadingModel::from_name(&s.model) else {
            let [rest @ .., last] = ShadingModel::ALL.map(ShadingModel::name);
            return Err(invalid(
                "[shading] model",
                format!("\"{}\": must be {} or {last}", s.model, rest.join(", ")),
            ));
        };
        let shading = match model {
            ShadingModel::Measured => {
                unexpected("[shading] gaussian", s.gaussian.is_some(), "measured")?;
                unexpected("[shading] albedo", s.albedo.is_some(), "measured")?;
                unexpected(
                    "[shading] curvature_range_per_mm",
                    s.curvature_range_per_mm.is_some(),
                    "measured",
                )?;
                let lut = s.lut.ok_or_else(|| {
                    invalid("[shading] lut", "required for model = \"measured\"".into())
                })?;
                ShadingSpec::Measured {
                    lut: base_dir.join(lut),
                }
            }
            ShadingModel::Gaussian => {
                unexpected("[shading] lut", s.lut.is_some(), "gaussian")?;
                unexpected("[shading] albedo", s.albedo.is_some(), "gaussian")?;
                unexpected(
                    "[shading] curvature_range_per_mm",
                    s.curvature_range_per_mm.is_some(),
                    "gaussian",
                )?;
                let parameters = s.gaussian.ok_or_else(|| {
                    invalid(
                        "[shading] gaussian",
                        "required for model = \"gaussian\"".into(),
                    )
                })?;
                ShadingSpec::Gaussian {
                    parameters: base_dir.join(parameters),
                }
            }
            ShadingModel::Lambert => {
                unexpected("[shading] lut", s.lut.is_some(), "lambert")?;
                unexpected("[shading] gaussian", s.gaussian.is_some(), "lambert")?;
                unexpected(
                    "[shading] curvature_range_per_mm",
                    s.curvature_range_per_mm.is_some(),
                    "lambert",
                )?;
                let albedo = s.albedo.unwrap_or([1.0; 3]);
                if albedo.iter().any(|a| !a.is_finite() || *a < 0.0) {
                    return Err(invalid(
                        "[shading] albedo",
                        format!("{albedo:?}: must be finite and ≥ 0"),
                    ));
                }
                ShadingSpec::Lambert { albedo }
            }
            ShadingModel::Curvature => {
                unexpected("[shading] lut", s.lut.is_some(), "curvature")?;
                unexpected("[shading] gaussian", s.gaussian.is_some(), "curvature")?;
                unexpected("[shading] albedo", s.albedo.is_some(), "curvature")?;
                if let Some([low, high]) = s.curvature_range_per_mm
                    && !(low.is_finite() && high.is_finite() && low < high)
                {
                    return Err(invalid(
                        "[shading] curvature_range_per_mm",
                        format!("[{low}, {high}]: must be finite with low < high"),
                    ));
                }
                ShadingSpec::Curvature {
                    range_per_mm: s.curvature_range_per_mm,
                }
            }
        };
        // Checked whether or not the layer is on, so a file that sets them is never silently
        // wrong.
        let layer = SpecularLayer::new(
            s.specular_roughness.unwrap_or(DEFAULT_ROUGHNESS_ALPHA),
            s.ior.unwrap_or(DEFAULT_IOR),
        )
        .map_err(|error| {
            let key = match error {
                crate::specular::SpecularError::Roughness(_) => "[shading] specular_roughness",
                crate::specular::SpecularError::Ior(_) => "[shading] ior",
            };
            invalid(key, error.to_string())
        })?;
        // The gather needs a table's diffusion profile; a table without one is refused when it
        // is loaded (`Scene::load_assets`).
        if s.subsurface && !matches!(shading, ShadingSpec::Measured { .. }) {
            return Err(invalid(
                "[shading] subsurface",
                format!(
                    "needs a measured table with a diffusion profile; model = \"{}\" has none",
                    s.model
                ),
            ));
        }
        if s.specular && matches!(shading, ShadingSpec::Curvature { .. }) {
            return Err(invalid(
                "[shading] specular",
                "not used by model = \"curvature\"".into(),
            ));
        }
        let environment = match raw.environment {
            None => None,
            Some(e) => {
                let source = match (e.uniform, e.map) {
                    (Some(radiance), None) => {
                        if radiance.iter().any(|e| !e.is_finite() || *e < 0.0) {
                            return Err(invalid(
                                "[environment] uniform",
                                format!("{radiance:?}: must be finite and ≥ 0"),
                            ));
                        }
                        EnvironmentSource::Uniform(radiance)
                    }
                    (None, Some(map)) => EnvironmentSource::Map(base_dir.join(map)),
                    _ => {
                        return Err(invalid(
                            "[environment] uniform, map",
                            "give exactly one of them".into(),
                        ));
                    }
                };
                let intensity = e.intensity.unwrap_or(1.0);
                if !(intensity.is_finite() && intensity >= 0.0) {
                    return Err(invalid(
                        "[environment] intensity",
                        format!("{intensity}: must be finite and ≥ 0"),
                    ));
                }
                let rotate_deg = e.rotate_deg.unwrap_or(0.0);
                if !rotate_deg.is_finite() {
                    return Err(invalid(
                        "[environment] rotate_deg",
                        format!("{rotate_deg}: must be finite"),
                    ));
                }
                Some(EnvironmentDesc {
                    source,
                    intensity,
                    rotate_deg,
                })
            }
        };
        Ok(Self {
            mesh,
            camera,
            lights,
            shading,
            environment,
            specular: s.specular.then_some(layer),
            non_local: NonLocal {
                shadows: s.shadows,
                transmission: s.transmission,
                interreflection: s.interreflection,
                subsurface: s.subsurface,
            },
        })
    }

    /// Loads the environment light's map, if any, and checks its parameters (`None`: the scene
    /// has none).
    ///
    /// # Errors
    /// [`SceneError::Environment`] naming the map file and the problem.
    pub fn load_environment(&self) -> Result<Option<Environment>, SceneError> {
        self.environment
            .as_ref()
            .map(|desc| Environment::load(desc).map_err(|error| SceneError::Environment { error }))
            .transpose()
    }

    /// Loads the mesh (computing its curvature; with its glTF materials and textures, see
    /// [`Mesh::load_with_surfaces`]) and the shading model's files.
    ///
    /// # Errors
    /// [`SceneError`] naming the key and the failing file.
    pub fn load_assets(&self) -> Result<SceneAssets, SceneError> {
        let (repaired, surfaces) = Mesh::load_with_surfaces(&self.mesh.path)
            .map_err(|error| SceneError::Mesh { error })?;
        let mesh = repaired.mesh;
        let mut material = match &self.shading {
            ShadingSpec::Measured { lut: path } => {
                let lut = read_lut(path).map_err(|error| SceneError::Lut { error })?;
                if self.non_local.subsurface && lut.diffusion_profile().is_none() {
                    return Err(SceneError::NoDiffusionProfile { lut: path.clone() });
                }
                Material::Measured(lut)
            }
            ShadingSpec::Gaussian { parameters } => {
                let gaussian_error = |error| SceneError::Gaussian { error };
                let (model, view_correction) = read_gaussian(parameters)
                    .and_then(|p| p.load_model(parameters))
                    .map_err(gaussian_error)?;
                Material::Gaussian {
                    model,
                    view_correction,
                }
            }
            ShadingSpec::Lambert { albedo } => Material::Lambert { albedo: *albedo },
            ShadingSpec::Curvature { .. } => Material::Curvature {
                range_per_mm: [-1.0, 1.0],
            },
        };
        // The key is in world mm; the estimate runs in the mesh's own (model) mm.
        let scale = self.mesh.transform.scale;
        let filter_mm = self.mesh.curvature_filter_mm.map_or_else(
            || {
                crate::curvature::material_filter_length_mm(
                    material.diffusion_length_mm(),
                    &mesh,
                    self.mesh.mm_per_unit,
                    scale,
                )
            },
            |world_mm| world_mm / scale,
        );
        let curvature = curvature_per_mm(
            &mesh,
            &CurvatureOptions::new(self.mesh.mm_per_unit)
                .with_smoothing_iterations(self.mesh.curvature_smoothing)
                .with_filter_length_mm(filter_mm),
        )
        .map_err(|error| SceneError::Curvature {
            mesh: self.mesh.path.clone(),
            error,
        })?;
        let curvature_per_mm = curvature.mean_per_mm;
        if let ShadingSpec::Curvature { range_per_mm } = &self.shading {
            let range_per_mm = range_per_mm.unwrap_or_else(|| {
                let largest = curvature_per_mm.iter().fold(0.0f32, |m, k| m.max(k.abs()))
                    / self.mesh.transform.scale;
                let largest = if largest > 0.0 { largest } else { 1.0 };
                [-largest, largest]
            });
            material = Material::Curvature { range_per_mm };
        }
        Ok(SceneAssets {
            mesh,
            curvature_per_mm,
            curvature_anisotropy_per_mm: curvature.anisotropy_per_mm,
            material,
            surfaces,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec4;

    const EXAMPLE: &str = r#"
[mesh]
path = "bunny.obj"
mm_per_unit = 10.0
scale = 2.0
rotate_deg = [90.0, 0.0, 0.0]
translate = [1.0, 2.0, 3.0]
[camera]
projection = "orthographic"
eye = [0.0, 0.0, 250.0]
target = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
ortho_half_height = 50.0
width = 512
height = 512
[[light]]
to_light = [-2.0, 0.0, 0.0]
irradiance = [1.0, 1.0, 1.0]
[[light]]
to_light = [0.0, 1.0, 0.0]
irradiance = [0.5, 0.5, 0.5]
[shading]
model = "measured"
lut = "out/measured.exr"
"#;

    fn parse(text: &str) -> Result<Scene, SceneError> {
        Scene::from_toml_str(text, Path::new("/scenes"), Path::new("/scenes/s.toml"))
    }

    #[test]
    fn example_parses() {
        let scene = parse(EXAMPLE).unwrap();
        assert_eq!(scene.mesh.path, Path::new("/scenes/bunny.obj"));
        assert_eq!(scene.mesh.mm_per_unit, 10.0);
        assert_eq!(scene.camera.msaa_samples, 4);
        assert_eq!(scene.lights.len(), 2);
        assert_eq!(
            scene.lights[0],
            Light::Directional(DirectionalLight {
                to_light: Vec3::NEG_X,
                irradiance: [1.0; 3]
            })
        );
        assert_eq!(
            scene.shading,
            ShadingSpec::Measured {
                lut: "/scenes/out/measured.exr".into()
            }
        );
        assert_eq!(scene.shading.model(), ShadingModel::Measured);
        // Scale, then rotate about x, then translate.
        let p = scene
            .mesh
            .transform
            .world_from_model()
            .transform_point3(Vec3::Y);
        assert!((p - Vec3::new(1.0, 2.0, 5.0)).length() < 1e-5, "{p}");
    }

    #[test]
    fn environment_keys_parse_with_the_issue_names() {
        assert_eq!(parse(EXAMPLE).unwrap().environment, None);
        let with = |table: &str| parse(&format!("{EXAMPLE}\n[environment]\n{table}"));
        assert_eq!(
            with("uniform = [0.1, 0.2, 0.3]").unwrap().environment,
            Some(EnvironmentDesc::uniform([0.1, 0.2, 0.3]))
        );
        assert_eq!(
            with("map = \"sky.exr\"\nintensity = 2.0\nrotate_deg = 90.0")
                .unwrap()
                .environment,
            Some(
                EnvironmentDesc::map("/scenes/sky.exr")
                    .with_intensity(2.0)
                    .with_rotation_deg(90.0)
            )
        );
        for (table, key) in [
            ("intensity = 1.0", "[environment] uniform, map"),
            (
                "uniform = [1.0, 1.0, 1.0]\nmap = \"sky.exr\"",
                "uniform, map",
            ),
            ("uniform = [1.0, -1.0, 1.0]", "[environment] uniform"),
            ("uniform = [1.0, 1.0]", "uniform"),
            (
                "uniform = [1.0, 1.0, 1.0]\nintensity = -1.0",
                "[environment] intensity",
            ),
            (
                "uniform = [1.0, 1.0, 1.0]\nrotate_deg = inf",
                "[environment] rotate_deg",
            ),
            ("uniform = [1.0, 1.0, 1.0]\nsun = 1", "sun"),
        ] {
            let message = with(table).unwrap_err().to_string();
            assert!(message.contains(key), "{table}: {message}");
        }
        // A missing map is the loader's error, naming the file.
        let scene = with("map = \"missing-sky.exr\"").unwrap();
        let message = scene.load_environment().unwrap_err().to_string();
        assert!(message.contains("missing-sky.exr"), "{message}");
    }

    #[test]
    fn specular_keys_parse_with_the_issue_names() {
        assert_eq!(parse(EXAMPLE).unwrap().specular, None);
        let with = |extra: &str| {
            parse(&EXAMPLE.replace(
                "lut = \"out/measured.exr\"",
                &format!("lut = \"out/measured.exr\"\n{extra}"),
            ))
        };
        assert_eq!(
            with("specular = true").unwrap().specular,
            Some(SpecularLayer::default())
        );
        assert_eq!(
            with("specular = true\nspecular_roughness = 0.2\nior = 1.3")
                .unwrap()
                .specular,
            Some(SpecularLayer::new(0.2, 1.3).unwrap())
        );
        // Off, but its parameters are still checked.
        assert_eq!(with("ior = 1.3").unwrap().specular, None);
        for (extra, key) in [
            (
                "specular = true\nspecular_roughness = 0.0",
                "specular_roughness",
            ),
            ("ior = 0.9", "[shading] ior"),
            ("specular = true\nior = nan", "[shading] ior"),
        ] {
            let message = with(extra).unwrap_err().to_string();
            assert!(message.contains(key), "{extra}: {message}");
        }
        let curvature = EXAMPLE
            .replace("model = \"measured\"", "model = \"curvature\"")
            .replace("lut = \"out/measured.exr\"", "specular = true");
        let message = parse(&curvature).unwrap_err().to_string();
        assert!(message.contains("[shading] specular"), "{message}");
    }

    #[test]
    fn non_local_keys_default_off() {
        assert_eq!(parse(EXAMPLE).unwrap().non_local, NonLocal::OFF);
        let text = EXAMPLE.replace(
            "lut = \"out/measured.exr\"",
            "lut = \"out/measured.exr\"\nshadows = true\ntransmission = true",
        );
        let scene = parse(&text).unwrap();
        assert_eq!(
            scene.non_local,
            NonLocal {
                shadows: true,
                transmission: true,
                ..NonLocal::OFF
            }
        );
        let text = EXAMPLE.replace(
            "lut = \"out/measured.exr\"",
            "lut = \"out/measured.exr\"\nsubsurface = true",
        );
        assert_eq!(
            parse(&text).unwrap().non_local,
            NonLocal {
                subsurface: true,
                ..NonLocal::OFF
            }
        );
        let text = EXAMPLE.replace(
            "lut = \"out/measured.exr\"",
            "lut = \"out/measured.exr\"\ninterreflection = true",
        );
        assert_eq!(
            parse(&text).unwrap().non_local,
            NonLocal {
                interreflection: true,
                ..NonLocal::OFF
            }
        );
        let text = EXAMPLE.replace(
            "lut = \"out/measured.exr\"",
            "lut = \"out/measured.exr\"\nshadows = \"yes\"",
        );
        let error = parse(&text).unwrap_err().to_string();
        assert!(error.contains("shadows"), "{error}");
    }

    #[test]
    fn point_and_spot_lights_parse_with_the_issue_keys() {
        let text = EXAMPLE.replace(
            "[[light]]\nto_light = [0.0, 1.0, 0.0]\nirradiance = [0.5, 0.5, 0.5]",
            r#"[[light]]
type = "point"
position = [1.0, 2.0, 3.0]
intensity = [100.0, 200.0, 300.0]
[[light]]
type = "spot"
position = [0.0, 0.0, 10.0]
intensity = [1.0, 1.0, 1.0]
direction = [0.0, 0.0, -2.0]
inner_angle_deg = 20.0
outer_angle_deg = 30.0"#,
        );
        let scene = parse(&text).unwrap();
        assert_eq!(scene.lights.len(), 3);
        assert_eq!(
            scene.lights[1],
            Light::Point(PointLight {
                position: Vec3::new(1.0, 2.0, 3.0),
                intensity: [100.0, 200.0, 300.0]
            })
        );
        let Light::Spot(spot) = scene.lights[2] else {
            panic!("{:?}", scene.lights[2]);
        };
        assert_eq!(spot.direction, Vec3::NEG_Z);
        assert!((spot.inner_angle_rad - 20f32.to_radians()).abs() < 1e-7);
        assert!((spot.outer_angle_rad - 30f32.to_radians()).abs() < 1e-7);

        // Wrong, missing and foreign keys name the key.
        let spot_text = |from: &str, to: &str| text.replace(from, to);
        for (from, to, key) in [
            ("type = \"point\"", "type = \"area\"", "[[light]] type"),
            (
                "outer_angle_deg = 30.0",
                "outer_angle_deg = 10.0",
                "outer_angle_deg",
            ),
            (
                "outer_angle_deg = 30.0",
                "outer_angle_deg = 95.0",
                "outer_angle_deg",
            ),
            ("outer_angle_deg = 30.0", "", "[[light]] outer_angle_deg"),
            (
                "intensity = [100.0, 200.0, 300.0]",
                "intensity = [100.0, 200.0, 300.0]\nto_light = [1.0, 0.0, 0.0]",
                "[[light]] to_light",
            ),
            (
                "intensity = [100.0, 200.0, 300.0]",
                "",
                "[[light]] intensity",
            ),
            (
                "intensity = [100.0, 200.0, 300.0]",
                "intensity = [-1.0, 0.0, 0.0]",
                "[[light]] intensity",
            ),
            (
                "direction = [0.0, 0.0, -2.0]",
                "direction = [0.0, 0.0, 0.0]",
                "[[light]] direction",
            ),
            (
                "position = [1.0, 2.0, 3.0]",
                "position = [1.0, 2.0, nan]",
                "[[light]] position",
            ),
        ] {
            let message = parse(&spot_text(from, to)).unwrap_err().to_string();
            assert!(message.contains(key), "{message} lacks {key}");
        }
    }

    #[test]
    fn errors_name_the_file_and_key() {
        let cases = [
            ("width = 512", "width = 0", "[camera] width"),
            ("msaa_samples", "msaa_samples", ""),
            (
                "ortho_half_height = 50.0",
                "ortho_half_height = -1.0",
                "[camera] ortho_half_height",
            ),
            (
                "projection = \"orthographic\"",
                "projection = \"fisheye\"",
                "[camera] projection",
            ),
            (
                "up = [0.0, 1.0, 0.0]",
                "up = [0.0, 0.0, 1.0]",
                "[camera] up",
            ),
            (
                "mm_per_unit = 10.0",
                "mm_per_unit = 0.0",
                "[mesh] mm_per_unit",
            ),
            ("scale = 2.0", "scale = -2.0", "[mesh] scale"),
            ("lut = \"out/measured.exr\"", "", "[shading] lut"),
            (
                "model = \"measured\"",
                "model = \"lambert\"",
                "[shading] lut",
            ),
            (
                "model = \"measured\"",
                "model = \"phong\"",
                "[shading] model",
            ),
            (
                "irradiance = [0.5, 0.5, 0.5]",
                "irradiance = [-0.5, 0.5, 0.5]",
                "[[light]] irradiance",
            ),
            (
                "to_light = [0.0, 1.0, 0.0]",
                "to_light = [0.0, 0.0, 0.0]",
                "[[light]] to_light",
            ),
            ("width = 512", "width = 512\ncolour = 1", "colour"),
        ];
        for (from, to, key) in cases {
            if from == "msaa_samples" {
                let text = EXAMPLE.replace("height = 512", "height = 512\nmsaa_samples = 3");
                let message = parse(&text).unwrap_err().to_string();
                assert!(message.contains("[camera] msaa_samples"), "{message}");
                continue;
            }
            let text = EXAMPLE.replace(from, to);
            let message = parse(&text).unwrap_err().to_string();
            println!("{message}");
            assert!(message.starts_with("/scenes/s.toml: "), "{message}");
            assert!(message.contains(key), "{message} lacks {key}");
        }
        let message = parse(&EXAMPLE.replace("model = \"measured\"", "model = \"phong\""))
            .unwrap_err()
            .to_string();
        assert!(
            message.ends_with("\"phong\": must be measured, gaussian, lambert or curvature"),
            "{message}"
        );
    }

    #[test]
    fn exposure_defaults_to_one_and_is_checked() {
        assert_eq!(parse(EXAMPLE).unwrap().camera.exposure, 1.0);
        let with = |value: &str| {
            parse(&EXAMPLE.replace("height = 512", &format!("height = 512\nexposure = {value}")))
        };
        assert_eq!(with("2.5").unwrap().camera.exposure, 2.5);
        for bad in ["0.0", "-1.0", "nan", "inf", "1e7"] {
            let message = with(bad).unwrap_err().to_string();
            assert!(message.contains("[camera] exposure"), "{bad}: {message}");
        }
    }

    #[test]
    fn projection_is_inferred_from_its_one_key() {
        let omitted = EXAMPLE.replace("projection = \"orthographic\"\n", "");
        assert_eq!(
            parse(&omitted).unwrap().camera.projection,
            Projection::Orthographic { half_height: 50.0 }
        );
        let perspective = omitted.replace("ortho_half_height = 50.0", "vertical_fov_deg = 30.0");
        assert_eq!(
            parse(&perspective).unwrap().camera.projection,
            Projection::Perspective {
                vertical_fov_deg: 30.0
            }
        );
        for text in [
            omitted.replace("ortho_half_height = 50.0", ""),
            omitted.replace(
                "ortho_half_height = 50.0",
                "ortho_half_height = 50.0\nvertical_fov_deg = 30.0",
            ),
        ] {
            let message = parse(&text).unwrap_err().to_string();
            assert!(
                message.starts_with("/scenes/s.toml: [camera] projection"),
                "{message}"
            );
        }
    }

    #[test]
    fn subsurface_needs_a_table_with_a_diffusion_profile() {
        let lambert = EXAMPLE
            .replace("model = \"measured\"", "model = \"lambert\"")
            .replace("lut = \"out/measured.exr\"", "subsurface = true");
        let message = parse(&lambert).unwrap_err().to_string();
        assert!(message.contains("[shading] subsurface"), "{message}");

        // A table without a profile (as a preset writes) is refused when it is loaded.
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("bunny.obj"),
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        )
        .unwrap();
        std::fs::create_dir(dir.path().join("out")).unwrap();
        let lut = CdrfLut::tabulate(
            &crate::lut::Lambert { albedo: [0.8; 3] },
            crate::lut::CurvatureAxis::from_radii_mm(50.0, 15.0, 2),
            19,
        )
        .unwrap();
        crate::lut_file::write_lut(&lut, dir.path().join("out/measured.exr")).unwrap();
        let scene_path = dir.path().join("s.toml");
        let text = EXAMPLE.replace(
            "lut = \"out/measured.exr\"",
            "lut = \"out/measured.exr\"\nsubsurface = true",
        );
        std::fs::write(&scene_path, &text).unwrap();
        let message = Scene::load(&scene_path)
            .unwrap()
            .load_assets()
            .unwrap_err()
            .to_string();
        assert!(message.starts_with("[shading] subsurface: "), "{message}");
        assert!(message.contains("measured.exr"), "{message}");
        // Without the gather the same table loads.
        std::fs::write(&scene_path, EXAMPLE).unwrap();
        Scene::load(&scene_path).unwrap().load_assets().unwrap();
    }

    /// [`KEYS`] is what the parser accepts: serde's "unknown field" error lists each table's
    /// fields.
    #[test]
    fn keys_are_the_parser_s_fields() {
        fn fields(text: &str) -> Vec<String> {
            let message = parse(text).unwrap_err().to_string();
            let listed = message
                .split_once("expected ")
                .unwrap_or_else(|| panic!("{message}"))
                .1;
            let listed = listed.strip_prefix("one of ").unwrap_or(listed);
            listed
                .lines()
                .next()
                .unwrap()
                .split(", ")
                .map(|field| field.trim().trim_matches('`').to_owned())
                .collect()
        }
        let mut parsed = Vec::new();
        for (table, anchor) in [
            ("[mesh]", "path = \"bunny.obj\""),
            ("[camera]", "width = 512"),
            ("[[light]]", "to_light = [-2.0, 0.0, 0.0]"),
            ("[shading]", "model = \"measured\""),
        ] {
            let text = EXAMPLE.replacen(anchor, &format!("{anchor}\nbogus_key = 1"), 1);
            parsed.extend(fields(&text).into_iter().map(|f| format!("{table} {f}")));
        }
        let environment = format!("{EXAMPLE}\n[environment]\nbogus_key = 1");
        parsed.extend(
            fields(&environment)
                .into_iter()
                .map(|f| format!("[environment] {f}")),
        );
        let top = format!("bogus_key = 1\n{EXAMPLE}");
        assert_eq!(
            fields(&top),
            ["mesh", "camera", "light", "shading", "environment"],
            "a new table: add its keys to KEYS"
        );
        let mut keys: Vec<String> = KEYS.iter().map(|k| k.to_string()).collect();
        keys.sort();
        parsed.sort();
        assert_eq!(keys, parsed);
    }

    /// The data set's pixel mapping: pixel (i, j)'s centre projects to that pixel's NDC centre.
    #[test]
    fn orthographic_pixel_centres_match_the_data_convention() {
        let camera = parse(EXAMPLE).unwrap().camera;
        let clip_from_world = camera.clip_from_view(1.0, 500.0) * camera.view_from_world();
        let mm_per_px = 100.0 / 512.0;
        for (i, j) in [(0, 0), (255, 256), (511, 3), (100, 511)] {
            let x = (i as f32 + 0.5 - 256.0) * mm_per_px;
            let y = (256.0 - j as f32 - 0.5) * mm_per_px;
            let clip = clip_from_world * Vec4::new(x, y, 10.0, 1.0);
            let ndc = clip.truncate() / clip.w;
            let expected = (
                (i as f32 + 0.5) / 256.0 - 1.0,
                1.0 - (j as f32 + 0.5) / 256.0,
            );
            assert!(
                (ndc.x - expected.0).abs() < 1e-5 && (ndc.y - expected.1).abs() < 1e-5,
                "pixel ({i}, {j}): ndc {ndc}, expected {expected:?}"
            );
            assert!((0.0..=1.0).contains(&ndc.z));
        }
    }

    #[test]
    fn perspective_camera_projects_the_target_to_the_centre() {
        let text = EXAMPLE
            .replace("ortho_half_height = 50.0", "vertical_fov_deg = 30.0")
            .replace("\"orthographic\"", "\"perspective\"");
        let camera = parse(&text).unwrap().camera;
        let clip_from_world = camera.clip_from_view(1.0, 500.0) * camera.view_from_world();
        let centre = clip_from_world * Vec4::new(0.0, 0.0, 0.0, 1.0);
        assert!((centre.x / centre.w).abs() < 1e-6 && (centre.y / centre.w).abs() < 1e-6);
        // A point at the top edge of the field of view maps to NDC y = 1.
        let top = 250.0 * 15f32.to_radians().tan();
        let edge = clip_from_world * Vec4::new(0.0, top, 0.0, 1.0);
        assert!((edge.y / edge.w - 1.0).abs() < 1e-4, "{}", edge.y / edge.w);
    }

    /// Asset errors say which key and which file failed, and why (the OS's reason included).
    #[test]
    fn asset_errors_name_the_key_the_file_and_the_cause() {
        let dir = tempfile::tempdir().unwrap();
        let scene_path = dir.path().join("s.toml");
        std::fs::write(&scene_path, EXAMPLE).unwrap();
        let scene = Scene::load(&scene_path).unwrap();
        let message = scene.load_assets().unwrap_err().to_string();
        println!("{message}");
        assert!(message.starts_with("[mesh] path: "), "{message}");
        assert!(message.contains("bunny.obj"), "{message}");
        let os_reason = std::io::Error::from(std::io::ErrorKind::NotFound).to_string();
        assert!(
            message.contains("os error") || message.contains(&os_reason),
            "the cause is missing: {message}"
        );

        std::fs::write(
            dir.path().join("bunny.obj"),
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        )
        .unwrap();
        let message = scene.load_assets().unwrap_err().to_string();
        println!("{message}");
        assert!(message.starts_with("[shading] lut: "), "{message}");
        assert!(message.contains("measured.exr"), "{message}");
    }
}
