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
    let name = path
        .file_name()
        .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "path names no file"))?;
    let temporary = directory.join(format!(
        ".{}.{}.partial",
        name.to_string_lossy(),
        std::process::id()
    ));
    let result = File::create(&temporary).and_then(|mut file| {
        write(&mut file)?;
        file.sync_all()?;
        drop(file);
        std::fs::rename(&temporary, path)
    });
    if result.is_err() {
        // Best effort: the temporary may not exist if creating it failed.
        let _ = std::fs::remove_file(&temporary);
    }
    result
}
