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
    let mut builder = tempfile::Builder::new();
    builder.prefix(".cdrf-partial-");
    // Temporary files default to owner-only; the result should be an ordinary file (the umask
    // still applies).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    // Dropped (and deleted) on every early return.
    let mut temporary = builder.tempfile_in(directory)?;
    write(temporary.as_file_mut())?;
    temporary.as_file().sync_all()?;
    temporary.persist(path).map_err(|error| error.error)?;
    Ok(())
}
