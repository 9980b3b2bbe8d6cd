//! Why a comparison could not run.

use std::path::PathBuf;

use cdrf_core::gaussian_file::GaussianFileError;
use cdrf_core::lut_file::LutFileError;
use thiserror::Error;

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
    /// The fit's measured table could not be read (the error names the file).
    #[error(transparent)]
    Lut(#[from] LutFileError),
    /// The fit's Gaussian parameters could not be read (the error names the file).
    #[error(transparent)]
    Gaussian(#[from] GaussianFileError),
    /// The render or the reference is unusable for this comparison.
    #[error("case {case}: {message}")]
    Case {
        /// The case.
        case: String,
        /// What went wrong.
        message: String,
    },
    /// Rendering failed.
    #[error("case {case}: rendering: {message}")]
    Render {
        /// The case.
        case: String,
        /// The renderer's error.
        message: String,
    },
}
