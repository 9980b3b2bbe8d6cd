//! `gaussian.toml`: the parameters of a Gaussian CDRF, as cdrf-fit writes them.
//!
//! ```toml
//! sigma_mm = [5.39, 5.13, 4.94]          # σ per RGB channel, mm (angular width σ·κ)
//! scale = [0.85, 0.76, 0.67]             # overall factor per channel (π·L/E convention)
//! view_correction_from = "measured.exr"  # optional: LUT file whose g(θ, φ) the model shares
//! ```
//!
//! Radiance: `L = E/π · scale · (cos⁺ ⊛ Gaussian of angular width σ·κ)(θ) · g(θ, φ)`. The path in
//! `view_correction_from` is relative to the TOML file; without it g ≡ 1.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::gaussian::{GaussianCdrf, ParameterError};
use crate::lut::ViewCorrection;
use crate::lut_file::{LutFileError, read_lut};

/// The contents of a `gaussian.toml`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GaussianParameters {
    /// Standard deviation of the scattering Gaussian per RGB channel, mm.
    #[serde(deserialize_with = "sigma_mm")]
    pub sigma_mm: [f32; 3],
    /// Overall factor per channel (the material's albedo under the LUT convention π·L/E).
    #[serde(deserialize_with = "scale")]
    pub scale: [f32; 3],
    /// A LUT file (relative to the TOML file) whose view correction g(θ, φ) the model uses.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub view_correction_from: Option<PathBuf>,
}

crate::exact_array_fields!(sigma_mm: 3, scale: 3);

/// Why a `gaussian.toml` could not be read, used or written.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum GaussianFileError {
    /// The file system refused.
    #[error("{}: {error}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        error: std::io::Error,
    },
    /// The TOML is malformed, has unknown keys or misses one.
    #[error("{}: {message}", path.display())]
    Syntax {
        /// The file.
        path: PathBuf,
        /// What the parser said (with line and column).
        message: String,
    },
    /// A parameter is out of range.
    #[error("{}: {error}", path.display())]
    Parameter {
        /// The file.
        path: PathBuf,
        /// Which parameter and why.
        error: ParameterError,
    },
    /// The LUT named by `view_correction_from` could not be read.
    #[error("{}: view_correction_from: {error}", path.display())]
    ViewCorrection {
        /// The TOML file.
        path: PathBuf,
        /// The LUT file's error (names that file).
        error: LutFileError,
    },
}

impl GaussianParameters {
    /// The model these parameters describe.
    ///
    /// # Errors
    /// [`ParameterError`] when a σ or scale is negative or not finite.
    pub fn model(&self) -> Result<GaussianCdrf, ParameterError> {
        GaussianCdrf::with_scale(self.sigma_mm, self.scale)
    }

    /// The model and its view correction, reading `view_correction_from` relative to
    /// `toml_path`'s folder (g ≡ 1 without it).
    ///
    /// # Errors
    /// [`GaussianFileError::Parameter`] or [`GaussianFileError::ViewCorrection`].
    pub fn load_model(
        &self,
        toml_path: &Path,
    ) -> Result<(GaussianCdrf, ViewCorrection), GaussianFileError> {
        let model = self.model().map_err(|error| GaussianFileError::Parameter {
            path: toml_path.to_owned(),
            error,
        })?;
        let view_correction = match &self.view_correction_from {
            None => ViewCorrection::identity(),
            Some(relative) => {
                let folder = toml_path.parent().unwrap_or(Path::new("."));
                read_lut(folder.join(relative))
                    .map_err(|error| GaussianFileError::ViewCorrection {
                        path: toml_path.to_owned(),
                        error,
                    })?
                    .view_correction()
                    .clone()
            }
        };
        Ok((model, view_correction))
    }

    /// The file's text: a comment header explaining the model, then the keys.
    pub fn to_toml_string(&self) -> String {
        // The same keys with the path as (lossy) UTF-8, so serialising cannot fail: TOML
        // strings are UTF-8, and numbers and strings always serialise.
        #[derive(Serialize)]
        struct Keys {
            sigma_mm: [f32; 3],
            scale: [f32; 3],
            #[serde(skip_serializing_if = "Option::is_none")]
            view_correction_from: Option<String>,
        }
        let keys = toml::to_string(&Keys {
            sigma_mm: self.sigma_mm,
            scale: self.scale,
            view_correction_from: self
                .view_correction_from
                .as_ref()
                .map(|path| path.to_string_lossy().into_owned()),
        })
        .expect("numbers and UTF-8 strings always serialise to TOML");
        format!(
            "# Kubo et al. 2010 Gaussian CDRF.\n\
             # Radiance: L = E/pi * scale * (cos+ convolved with a Gaussian of angular width sigma_mm * curvature) * g,\n\
             # g = the view correction stored in the LUT file view_correction_from (relative to this file; none: g = 1).\n\
             {keys}"
        )
    }
}

/// Reads and validates a `gaussian.toml`.
///
/// # Errors
/// [`GaussianFileError`] naming the file and the key.
pub fn read_gaussian(path: impl AsRef<Path>) -> Result<GaussianParameters, GaussianFileError> {
    let path = path.as_ref();
    let text = crate::input_file::read_text(path).map_err(|error| GaussianFileError::Io {
        path: path.to_owned(),
        error,
    })?;
    parse_gaussian(&text, path)
}

/// Parses and validates the text of a `gaussian.toml`; `path` only names it in errors.
///
/// # Errors
/// [`GaussianFileError::Syntax`] or [`GaussianFileError::Parameter`].
pub fn parse_gaussian(text: &str, path: &Path) -> Result<GaussianParameters, GaussianFileError> {
    let parameters: GaussianParameters =
        toml::from_str(text).map_err(|error| GaussianFileError::Syntax {
            path: path.to_owned(),
            message: error.to_string().trim_end().to_owned(),
        })?;
    parameters
        .model()
        .map_err(|error| GaussianFileError::Parameter {
            path: path.to_owned(),
            error,
        })?;
    Ok(parameters)
}

/// Writes a `gaussian.toml` atomically.
///
/// # Errors
/// [`GaussianFileError::Io`].
pub fn write_gaussian(
    parameters: &GaussianParameters,
    path: impl AsRef<Path>,
) -> Result<(), GaussianFileError> {
    let path = path.as_ref();
    crate::atomic::write_file(path, |file| {
        std::io::Write::write_all(file, parameters.to_toml_string().as_bytes())
    })
    .map_err(|error| GaussianFileError::Io {
        path: path.to_owned(),
        error,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lut::Lambert;
    use crate::{CdrfLut, CurvatureAxis, write_lut};
    use glam::Vec3;

    #[test]
    fn round_trip_and_shared_view_correction() {
        let dir = tempfile::tempdir().unwrap();
        let view = ViewCorrection::from_phi(vec![Vec3::ONE, Vec3::splat(0.9)]).unwrap();
        let lut = CdrfLut::tabulate(
            &Lambert { albedo: [1.0; 3] },
            CurvatureAxis::from_radii_mm(50.0, 15.0, 2),
            5,
        )
        .unwrap()
        .with_view_correction(view.clone());
        write_lut(&lut, dir.path().join("measured.exr")).unwrap();
        let parameters = GaussianParameters {
            sigma_mm: [5.0, 4.0, 3.0],
            scale: [0.9, 0.8, 0.7],
            view_correction_from: Some("measured.exr".into()),
        };
        let path = dir.path().join("gaussian.toml");
        write_gaussian(&parameters, &path).unwrap();
        let read = read_gaussian(&path).unwrap();
        assert_eq!(read, parameters);
        let (model, g) = read.load_model(&path).unwrap();
        assert_eq!(model.sigma_mm(), [5.0, 4.0, 3.0]);
        assert_eq!(g, view);
    }

    #[test]
    fn errors_name_file_and_key() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("g.toml");
        let check = |text: &str, wanted: &[&str]| {
            std::fs::write(&path, text).unwrap();
            let message = read_gaussian(&path)
                .and_then(|p| p.load_model(&path).map(|_| p))
                .unwrap_err()
                .to_string();
            println!("{message}");
            assert!(message.contains("g.toml"), "{message}");
            for w in wanted {
                assert!(message.contains(w), "{message} lacks {w}");
            }
        };
        check("sigma_mm = [1, 2, 3]\n", &["scale"]);
        check("sigma_mm = [1, -2, 3]\nscale = [1, 1, 1]\n", &["sigma"]);
        check(
            "sigma_mm = [1, 2, 3]\nscale = [1, 1, 1]\ncolour = 3\n",
            &["colour"],
        );
        check(
            "sigma_mm = [1, 2, 3]\nscale = [1, 1, 1]\nview_correction_from = \"nope.exr\"\n",
            &["view_correction_from", "nope.exr"],
        );
    }
}
