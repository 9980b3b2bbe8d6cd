//! Shared helpers for the workspace integration tests in `tests/tests/`.

use std::path::PathBuf;

pub mod golden;

/// The repository's bundled data folder (`data/`), checked to exist: a missing fixture folder is
/// a failure, never a silently skipped test.
///
/// # Panics
/// If the folder is missing.
pub fn data_dir() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data");
    assert!(
        dir.is_dir(),
        "bundled data folder {} is missing: the repository checkout is incomplete",
        dir.display()
    );
    dir
}
