//! A run's output files, checked before the work and written together: each output is staged
//! in a temporary file (`.cdrf-partial-*`) in its own folder when the run starts — so a
//! folder that cannot be written, an output that is a folder, or an output that is one of
//! the run's inputs fails before anything is rendered — and all are renamed into place only
//! after every one was written. On failure (or drop) the temporary files are removed, and a
//! reader never sees a new file beside an old one of the same run (short of a crash between
//! two renames).

use std::fs::File;
use std::io;
use std::path::{Path, PathBuf};

use thiserror::Error;

/// Why a run's outputs could not be staged or written.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum OutputError {
    /// An output is one of the run's inputs (the same file by canonical path).
    #[error("{}: the output is one of the inputs ({}); choose another name", output.display(), input.display())]
    IsInput {
        /// The output as given.
        output: PathBuf,
        /// The input it would replace.
        input: PathBuf,
    },
    /// The same output is named twice.
    #[error("{}: named twice among the outputs", path.display())]
    Duplicate {
        /// The output.
        path: PathBuf,
    },
    /// An output exists and is a folder.
    #[error("{}: is a folder, not a file", path.display())]
    IsFolder {
        /// The output.
        path: PathBuf,
    },
    /// An output's folder could not be created, or a file could not be staged, written or
    /// renamed into place.
    #[error("{}: {error}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// What failed.
        error: io::Error,
    },
}

/// The canonical form of `path`, which need not exist yet (its folder must): the folder
/// canonicalized, joined with the file name.
fn canonical_output(path: &Path) -> Result<PathBuf, OutputError> {
    let io_error = |error| OutputError::Io {
        path: path.to_owned(),
        error,
    };
    let name = path.file_name().ok_or_else(|| {
        io_error(io::Error::new(
            io::ErrorKind::InvalidInput,
            "not a file name",
        ))
    })?;
    let folder = folder_of(path);
    let folder = folder.canonicalize().map_err(|error| OutputError::Io {
        path: folder.to_owned(),
        error,
    })?;
    Ok(folder.join(name))
}

fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    }
}

/// The outputs of one run, staged.
#[derive(Debug)]
pub struct StagedOutputs {
    files: Vec<(PathBuf, tempfile::NamedTempFile)>,
}

impl StagedOutputs {
    /// Checks `outputs` against each other and `inputs` (canonical paths; inputs that do not
    /// exist are ignored), creates their folders and a temporary file for each.
    ///
    /// # Errors
    /// [`OutputError`] naming the first unusable output.
    pub fn new(outputs: &[PathBuf], inputs: &[PathBuf]) -> Result<Self, OutputError> {
        let inputs: Vec<(PathBuf, &PathBuf)> = inputs
            .iter()
            .filter_map(|input| input.canonicalize().ok().map(|c| (c, input)))
            .collect();
        let mut canonical_outputs: Vec<PathBuf> = Vec::new();
        let mut files = Vec::new();
        for output in outputs {
            let folder = folder_of(output);
            std::fs::create_dir_all(folder).map_err(|error| OutputError::Io {
                path: folder.to_owned(),
                error,
            })?;
            if output.is_dir() {
                return Err(OutputError::IsFolder {
                    path: output.clone(),
                });
            }
            let canonical = canonical_output(output)?;
            if let Some((_, input)) = inputs.iter().find(|(c, _)| *c == canonical) {
                return Err(OutputError::IsInput {
                    output: output.clone(),
                    input: (*input).clone(),
                });
            }
            if canonical_outputs.contains(&canonical) {
                return Err(OutputError::Duplicate {
                    path: output.clone(),
                });
            }
            canonical_outputs.push(canonical);
            let mut builder = tempfile::Builder::new();
            builder.prefix(".cdrf-partial-");
            #[cfg(unix)]
            {
                use std::os::unix::fs::PermissionsExt;
                builder.permissions(std::fs::Permissions::from_mode(0o666));
            }
            let temporary = builder
                .tempfile_in(folder)
                .map_err(|error| OutputError::Io {
                    path: output.clone(),
                    error,
                })?;
            files.push((output.clone(), temporary));
        }
        Ok(Self { files })
    }

    /// The outputs, in the order given.
    pub fn paths(&self) -> Vec<PathBuf> {
        self.files.iter().map(|(path, _)| path.clone()).collect()
    }

    /// The temporary file that becomes `output`, for writers that take a path (it may be
    /// replaced by a rename).
    ///
    /// # Panics
    /// If `output` is not one of the staged outputs (a programming error).
    pub fn temporary_path(&self, output: &Path) -> &Path {
        self.files
            .iter()
            .find(|(path, _)| path == output)
            .map(|(_, temporary)| temporary.path())
            .unwrap_or_else(|| panic!("{} was not staged", output.display()))
    }

    /// Writes `output`'s temporary file with `write`.
    ///
    /// # Errors
    /// [`OutputError::Io`] naming `output`.
    pub fn write(
        &self,
        output: &Path,
        write: impl FnOnce(&mut File) -> io::Result<()>,
    ) -> Result<(), OutputError> {
        let io_error = |error| OutputError::Io {
            path: output.to_owned(),
            error,
        };
        let mut file = File::create(self.temporary_path(output)).map_err(io_error)?;
        write(&mut file).map_err(io_error)?;
        file.sync_all().map_err(io_error)
    }

    /// Renames every temporary file into place.
    ///
    /// # Errors
    /// [`OutputError::Io`] naming the output that could not be renamed (the remaining
    /// temporary files are removed).
    pub fn commit(self) -> Result<Vec<PathBuf>, OutputError> {
        let mut written = Vec::new();
        for (path, temporary) in self.files {
            temporary.persist(&path).map_err(|error| OutputError::Io {
                path: path.clone(),
                error: error.error,
            })?;
            written.push(path);
        }
        Ok(written)
    }
}
