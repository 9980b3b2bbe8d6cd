//! The cases of a comparison: a manifest of scenes and their path-traced references.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::CompareError;
use crate::models::ComparedModel;

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
    /// The cdrf-fit output folder (`measured.exr`, `gaussian.toml`) of this case's material
    /// (`fit`; default: the run's): a case of another medium than the run's fit.
    #[serde(default)]
    pub fit: Option<PathBuf>,
}

/// What a case's reference shows, and so which models it is compared with.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ReferenceLayer {
    /// The whole material: every model of [`ComparedModel::ALL`], with the scene's specular
    /// layer if it has one.
    #[default]
    Whole,
    /// The first-surface reflection alone (`knot-spec`): [`ComparedModel::SPECULAR_LAYER`]
    /// only; the scene must have `[shading] specular = true`.
    Specular,
}

impl CaseSpec {
    /// The models this case is rendered with, in table order.
    pub fn models(&self) -> &'static [ComparedModel] {
        match self.reference_layer {
            ReferenceLayer::Whole => &ComparedModel::ALL,
            ReferenceLayer::Specular => &[ComparedModel::SPECULAR_LAYER],
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
            fit: case.fit.map(|fit| base.join(fit)),
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
