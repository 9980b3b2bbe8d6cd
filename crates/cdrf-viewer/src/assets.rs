//! What the viewer loads: meshes (with curvature), measured LUTs, Gaussian parameters,
//! cdrf-fit output folders and environment maps (an OpenEXR that is not a LUT). Every failure
//! is an [`AssetError`] naming the file.

use std::path::{Path, PathBuf};

use cdrf_core::environment::{EnvironmentDesc, EnvironmentError, EnvironmentSource, EquirectMap};
use cdrf_core::gaussian::GaussianCdrf;
use cdrf_core::gaussian_file::GaussianFileError;
use cdrf_core::glam::Vec3;
use cdrf_core::light::NonLocal;
use cdrf_core::lut_file::LutFileError;
use cdrf_core::mesh::MeshSurfaces;
use cdrf_core::scene::{Scene, SceneError};
use cdrf_core::specular::SpecularLayer;
use cdrf_core::{
    CdrfLut, CurvatureError, CurvatureOptions, GaussianParameters, LoadError, Mesh, ViewCorrection,
    curvature_per_mm, read_gaussian, read_lut,
};
use thiserror::Error;

/// The LUT a cdrf-fit output folder holds.
pub const FIT_LUT_FILE: &str = "measured.exr";
/// The Gaussian parameters a cdrf-fit output folder holds.
pub const FIT_GAUSSIAN_FILE: &str = "gaussian.toml";

/// Why something could not be loaded.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum AssetError {
    /// The mesh file could not be read or used.
    #[error(transparent)]
    Mesh(#[from] LoadError),
    /// Curvature could not be estimated on the mesh.
    #[error("{}: curvature: {error}", path.display())]
    Curvature {
        /// The mesh file.
        path: PathBuf,
        /// Why.
        error: CurvatureError,
    },
    /// The LUT file could not be read.
    #[error(transparent)]
    Lut(#[from] LutFileError),
    /// An OpenEXR that is not a cdrf LUT, and not a usable environment map either.
    #[error("{}: not a cdrf LUT ({lut}), and not an environment map: {environment}", path.display())]
    NeitherLutNorEnvironment {
        /// The file.
        path: PathBuf,
        /// Why it is not a LUT.
        lut: Box<LutFileError>,
        /// Why it is not an environment map.
        environment: Box<EnvironmentError>,
    },
    /// The Gaussian parameters could not be read.
    #[error(transparent)]
    Gaussian(#[from] GaussianFileError),
    /// The scene file could not be read.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A folder without `measured.exr` or `gaussian.toml`.
    #[error(
        "{}: not a cdrf-fit output folder (it has neither {FIT_LUT_FILE} nor {FIT_GAUSSIAN_FILE})",
        path.display()
    )]
    NotAFitFolder {
        /// The folder.
        path: PathBuf,
    },
    /// A file whose extension names nothing the viewer loads.
    #[error(
        "{}: unknown file type (meshes: .obj .gltf .glb; LUTs: .exr; Gaussian CDRF: .toml; or a cdrf-fit output folder)",
        path.display()
    )]
    UnknownKind {
        /// The file.
        path: PathBuf,
    },
}

/// A mesh with its curvature per model unit and its bounds.
#[derive(Clone, Debug)]
pub struct LoadedMesh {
    /// Where it came from.
    pub path: PathBuf,
    /// The repaired mesh, in model units.
    pub mesh: Mesh,
    /// Signed mean curvature per vertex, per model unit (divide by mm per unit for mm⁻¹).
    pub curvature_per_unit: Vec<f32>,
    /// The curvature's anisotropy per vertex, per model unit (cdrf-core's
    /// `Curvature::anisotropy_per_mm` at 1 mm per unit).
    pub curvature_anisotropy_per_unit: Vec<Vec3>,
    /// Rounds of smoothing the curvature had.
    pub curvature_smoothing: u32,
    /// The length the curvature is filtered over, model units (0: none; see
    /// [`LoadedMesh::filter_curvature`]).
    pub curvature_filter_units: f32,
    /// Centre of the bounding box, model units.
    pub center: Vec3,
    /// Radius of the bounding sphere around `center`, model units.
    pub radius: f32,
    /// Size of the bounding box, model units.
    pub extent: Vec3,
    /// Its materials (textures), primitives and tangents: one draw per primitive.
    pub surfaces: MeshSurfaces,
}

impl LoadedMesh {
    /// Re-estimates the curvature filtered over `length_units` model units (0: none; cdrf-core's
    /// `CurvatureOptions::with_filter_length_mm` at 1 mm per unit), keeping the smoothing.
    ///
    /// # Errors
    /// [`AssetError::Curvature`].
    pub fn filter_curvature(&mut self, length_units: f32) -> Result<(), AssetError> {
        let options = CurvatureOptions::new(1.0)
            .with_smoothing_iterations(self.curvature_smoothing)
            .with_filter_length_mm(length_units);
        let curvature =
            curvature_per_mm(&self.mesh, &options).map_err(|error| AssetError::Curvature {
                path: self.path.clone(),
                error,
            })?;
        self.curvature_per_unit = curvature.mean_per_mm;
        self.curvature_anisotropy_per_unit = curvature.anisotropy_per_mm;
        self.curvature_filter_units = length_units;
        Ok(())
    }

    /// Reads an OBJ or glTF file with its materials and textures and estimates its curvature
    /// (on the welded geometry: UV seams do not cut it), smoothed `curvature_smoothing` rounds.
    ///
    /// # Errors
    /// [`AssetError::Mesh`] or [`AssetError::Curvature`].
    pub fn load(path: &Path, curvature_smoothing: u32) -> Result<Self, AssetError> {
        let (repaired, surfaces) = Mesh::load_with_surfaces(path)?;
        Ok(Self {
            surfaces,
            ..Self::new(path, repaired.mesh, curvature_smoothing)?
        })
    }

    /// Estimates the curvature of `mesh` (read from `path`), smoothed `curvature_smoothing`
    /// rounds; one untextured primitive.
    ///
    /// # Errors
    /// [`AssetError::Curvature`].
    pub fn new(path: &Path, mesh: Mesh, curvature_smoothing: u32) -> Result<Self, AssetError> {
        let (min, max) = mesh.positions.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(min, max), &p| (min.min(p), max.max(p)),
        );
        let center = (min + max) * 0.5;
        let radius = mesh
            .positions
            .iter()
            .map(|p| p.distance(center))
            .fold(0.0f32, f32::max);
        let mut loaded = Self {
            path: path.to_owned(),
            curvature_per_unit: Vec::new(),
            curvature_anisotropy_per_unit: Vec::new(),
            curvature_smoothing,
            curvature_filter_units: 0.0,
            center,
            radius,
            extent: max - min,
            surfaces: MeshSurfaces::single(&mesh),
            mesh,
        };
        loaded.filter_curvature(0.0)?;
        Ok(loaded)
    }

    /// A starting scale for a newly loaded file: glTF is in metres by its specification
    /// (1000 mm per unit); OBJ has no unit, so the largest side is made about 100 mm (a
    /// hand-sized object like the photographed spheres), rounded to 1, 2 or 5 × 10ⁿ.
    pub fn suggested_mm_per_unit(&self) -> f32 {
        let is_gltf = self
            .path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"));
        let largest = self.extent.max_element();
        if is_gltf || !(largest > 0.0 && largest.is_finite()) {
            return if is_gltf { 1000.0 } else { 1.0 };
        }
        let raw = 100.0 / largest;
        let decade = 10f32.powf(raw.log10().floor());
        let mantissa = raw / decade;
        let nice = [1.0, 2.0, 5.0, 10.0]
            .into_iter()
            .min_by(|a: &f32, b: &f32| {
                (a.ln() - mantissa.ln())
                    .abs()
                    .total_cmp(&(b.ln() - mantissa.ln()).abs())
            })
            .unwrap_or(1.0);
        nice * decade
    }

    /// Curvature in mm⁻¹ at the given scale: (min, median, max).
    pub fn curvature_summary_per_mm(&self, mm_per_unit: f32) -> (f32, f32, f32) {
        let mut sorted: Vec<f32> = self
            .curvature_per_unit
            .iter()
            .map(|k| k / mm_per_unit)
            .filter(|k| k.is_finite())
            .collect();
        if sorted.is_empty() {
            return (0.0, 0.0, 0.0);
        }
        sorted.sort_by(f32::total_cmp);
        (
            sorted[0],
            sorted[sorted.len() / 2],
            sorted[sorted.len() - 1],
        )
    }

    /// The symmetric range the curvature view maps to its colours: ±(98th percentile of |κ|),
    /// mm⁻¹, so a few noisy vertices do not wash the colours out.
    pub fn curvature_view_range_per_mm(&self, mm_per_unit: f32) -> [f32; 2] {
        let mut magnitudes: Vec<f32> = self
            .curvature_per_unit
            .iter()
            .map(|k| (k / mm_per_unit).abs())
            .filter(|k| k.is_finite())
            .collect();
        magnitudes.sort_by(f32::total_cmp);
        let largest = magnitudes
            .get((magnitudes.len() * 98) / 100)
            .copied()
            .unwrap_or(0.0);
        let largest = if largest > 0.0 { largest } else { 1.0 };
        [-largest, largest]
    }
}

/// A measured LUT and its file.
#[derive(Clone, Debug)]
pub struct LoadedLut {
    /// Where it came from.
    pub path: PathBuf,
    /// The table.
    pub lut: CdrfLut,
}

impl LoadedLut {
    /// Reads a LUT EXR written by cdrf-fit.
    ///
    /// # Errors
    /// [`AssetError::Lut`].
    pub fn load(path: &Path) -> Result<Self, AssetError> {
        Ok(Self {
            path: path.to_owned(),
            lut: read_lut(path)?,
        })
    }
}

/// An environment map and its file.
#[derive(Clone, Debug)]
pub struct LoadedEnvironment {
    /// Where it came from.
    pub path: PathBuf,
    /// The map.
    pub map: EquirectMap,
}

/// Gaussian CDRF parameters, their view correction, and their file.
#[derive(Clone, Debug)]
pub struct LoadedGaussian {
    /// Where it came from.
    pub path: PathBuf,
    /// The parameters as read (σ here is the fitted value the UI can reset to).
    pub parameters: GaussianParameters,
    /// The view correction g(θ, φ) named by `view_correction_from` (identity without one).
    pub view_correction: ViewCorrection,
}

impl LoadedGaussian {
    /// Reads a `gaussian.toml` and the view correction it names.
    ///
    /// # Errors
    /// [`AssetError::Gaussian`].
    pub fn load(path: &Path) -> Result<Self, AssetError> {
        let parameters = read_gaussian(path)?;
        let (_, view_correction) = parameters.load_model(path)?;
        Ok(Self {
            path: path.to_owned(),
            parameters,
            view_correction,
        })
    }

    /// The model with σ replaced by `sigma_mm`.
    ///
    /// # Errors
    /// When a σ is negative or not finite (the message names the channel).
    pub fn model_with_sigma(
        &self,
        sigma_mm: [f32; 3],
    ) -> Result<GaussianCdrf, cdrf_core::gaussian::ParameterError> {
        GaussianCdrf::with_scale(sigma_mm, self.parameters.scale)
    }
}

/// Anything the viewer can open.
#[derive(Debug)]
pub enum Asset {
    /// A mesh file.
    Mesh(LoadedMesh),
    /// A LUT file.
    Lut(LoadedLut),
    /// A `gaussian.toml`.
    Gaussian(LoadedGaussian),
    /// An equirectangular environment map (linear radiance).
    Environment(LoadedEnvironment),
    /// A cdrf-fit output folder: its LUT and/or Gaussian parameters.
    Fit {
        /// `measured.exr`, when present.
        lut: Option<LoadedLut>,
        /// `gaussian.toml`, when present.
        gaussian: Option<LoadedGaussian>,
    },
}

impl Asset {
    /// Loads `path` by what it is: a folder is a fit output; otherwise by extension (a mesh's
    /// curvature smoothed `curvature_smoothing` rounds).
    ///
    /// # Errors
    /// [`AssetError`] naming the file.
    pub fn load(path: &Path, curvature_smoothing: u32) -> Result<Self, AssetError> {
        if path.is_dir() {
            return load_fit_folder(path);
        }
        let extension = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match extension.as_deref() {
            Some("obj" | "gltf" | "glb") => {
                LoadedMesh::load(path, curvature_smoothing).map(Asset::Mesh)
            }
            // A LUT, or else an environment map.
            Some("exr") => match read_lut(path) {
                Ok(lut) => Ok(Asset::Lut(LoadedLut {
                    path: path.to_owned(),
                    lut,
                })),
                Err(lut @ LutFileError::NotACdrfLut { .. }) => match EquirectMap::read_exr(path) {
                    Ok(map) => Ok(Asset::Environment(LoadedEnvironment {
                        path: path.to_owned(),
                        map,
                    })),
                    Err(environment) => Err(AssetError::NeitherLutNorEnvironment {
                        path: path.to_owned(),
                        lut: Box::new(lut),
                        environment: Box::new(environment),
                    }),
                },
                Err(error) => Err(error.into()),
            },
            Some("toml") => LoadedGaussian::load(path).map(Asset::Gaussian),
            _ => Err(AssetError::UnknownKind {
                path: path.to_owned(),
            }),
        }
    }
}

/// Loads `measured.exr` and `gaussian.toml` from a cdrf-fit output folder (either may be
/// missing, not both).
///
/// # Errors
/// [`AssetError::NotAFitFolder`], or the error of a file that is there but bad.
pub fn load_fit_folder(folder: &Path) -> Result<Asset, AssetError> {
    let lut_path = folder.join(FIT_LUT_FILE);
    let gaussian_path = folder.join(FIT_GAUSSIAN_FILE);
    if !lut_path.exists() && !gaussian_path.exists() {
        return Err(AssetError::NotAFitFolder {
            path: folder.to_owned(),
        });
    }
    let lut = lut_path
        .exists()
        .then(|| LoadedLut::load(&lut_path))
        .transpose()?;
    let gaussian = gaussian_path
        .exists()
        .then(|| LoadedGaussian::load(&gaussian_path))
        .transpose()?;
    Ok(Asset::Fit { lut, gaussian })
}

/// The viewer's opening scene, relative to the data folder.
pub const BUNDLED_SCENE: &str = "scenes/viewer.toml";

/// The repository's `data/` folder (bundled meshes, the wax fit, scenes), or `CDRF_DATA`.
pub fn bundled_data_dir() -> PathBuf {
    match std::env::var_os("CDRF_DATA") {
        Some(dir) => PathBuf::from(dir),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data"),
    }
}

/// What the viewer opens with: a mesh at a scale, a light, the measured and Gaussian fits.
#[derive(Clone, Debug)]
pub struct StartupFiles {
    /// Mesh file.
    pub mesh: PathBuf,
    /// Its millimetres per unit.
    pub mm_per_unit: f32,
    /// Direction towards the light, world.
    pub to_light: Vec3,
    /// The light's irradiance (first channel of the scene's light).
    pub irradiance: f32,
    /// cdrf-fit output folder (`measured.exr`, `gaussian.toml`).
    pub fit_folder: PathBuf,
    /// The non-local terms to start with (the scene's `[shading] shadows`, `transmission`,
    /// `interreflection`, `subsurface`).
    pub non_local: NonLocal,
    /// The specular layer to start with (the scene's `[shading] specular`); `None`: off.
    pub specular: Option<SpecularLayer>,
    /// A uniform sky's radiance to start with (the scene's `[environment] uniform`, first
    /// channel, times its intensity; 0: none).
    pub sky_radiance: f32,
    /// Rounds of curvature smoothing for meshes the viewer loads (the scene's
    /// `[mesh] curvature_smoothing`).
    pub curvature_smoothing: u32,
}

impl StartupFiles {
    /// The bundled opening view (`data/scenes/viewer.toml`: the bunny with every non-local
    /// term, the specular layer and a sky) with the bundled wax fit (`data/wax-fit`).
    ///
    /// # Errors
    /// [`AssetError::Scene`] when the bundled scene is missing or bad.
    pub fn bundled() -> Result<Self, AssetError> {
        let data = bundled_data_dir();
        Self::from_scene(&data.join(BUNDLED_SCENE), &data.join("wax-fit"))
    }

    /// The mesh, scale, first light, non-local terms, specular layer, uniform sky and curvature
    /// smoothing of a scene file, with the fit in `fit_folder`.
    ///
    /// # Errors
    /// [`AssetError::Scene`].
    pub fn from_scene(scene_path: &Path, fit_folder: &Path) -> Result<Self, AssetError> {
        let scene = Scene::load(scene_path)?;
        // The viewer's light is directional: a point or spot light as it arrives at the world's
        // origin.
        let light = scene
            .lights
            .first()
            .map(|l| l.incidence(Vec3::ZERO, scene.mesh.mm_per_unit));
        Ok(Self {
            mesh: scene.mesh.path.clone(),
            mm_per_unit: scene.mesh.mm_per_unit * scene.mesh.transform.scale,
            to_light: light.map_or(Vec3::NEG_X, |l| l.to_light),
            irradiance: light.map_or(1.0, |l| l.irradiance[0]),
            fit_folder: fit_folder.to_owned(),
            non_local: scene.non_local,
            specular: scene.specular,
            sky_radiance: match &scene.environment {
                Some(EnvironmentDesc {
                    source: EnvironmentSource::Uniform(radiance),
                    intensity,
                    ..
                }) => radiance[0] * intensity,
                _ => 0.0,
            },
            curvature_smoothing: scene.mesh.curvature_smoothing,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suggested_scale_makes_an_obj_about_100_mm_and_a_gltf_metres() {
        let sphere = Mesh::icosphere(1.7, 1);
        let obj = LoadedMesh::new(Path::new("a.obj"), sphere.clone(), 0).unwrap();
        // 3.4 units across → 29.4 mm per unit → nearest of 20, 50: 20 (ln distance).
        assert_eq!(obj.suggested_mm_per_unit(), 20.0);
        let gltf = LoadedMesh::new(Path::new("a.glb"), sphere, 0).unwrap();
        assert_eq!(gltf.suggested_mm_per_unit(), 1000.0);
    }

    #[test]
    fn unknown_files_and_empty_folders_name_the_path() {
        let error = Asset::load(Path::new("notes.txt"), 0).unwrap_err();
        assert!(
            error
                .to_string()
                .starts_with("notes.txt: unknown file type")
        );
        let folder = std::env::temp_dir().join(format!("cdrf-viewer-empty-{}", std::process::id()));
        std::fs::create_dir_all(&folder).unwrap();
        let error = Asset::load(&folder, 0).unwrap_err();
        assert!(error.to_string().contains("not a cdrf-fit output folder"));
        std::fs::remove_dir_all(&folder).unwrap();
    }
}
