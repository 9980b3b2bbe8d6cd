//! Writing files so that readers never see a partial one.

use std::fs::File;
use std::io;
use std::path::Path;

/// Creates `path` through a temporary file in the same directory that is renamed over `path`
/// only after `write` succeeded and the data reached the disk. On any error the temporary file
/// is removed and an existing `path` is left untouched.
///
/// # Errors
/// Whatever creating, writing, syncing or renaming the file returns, or `write`'s own error.
pub fn write_file(path: &Path, write: impl FnOnce(&mut File) -> io::Result<()>) -> io::Result<()> {
    let directory = match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    };
    // Dropped (and deleted) on every early return.
    let mut temporary = tempfile::NamedTempFile::new_in(directory)?;
    write(temporary.as_file_mut())?;
    temporary.as_file().sync_all()?;
    temporary.persist(path).map_err(|error| error.error)?;
    Ok(())
}
