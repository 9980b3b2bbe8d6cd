//! A folder of simulated presets, so that asking twice for the same medium costs nothing.
//!
//! An entry is keyed by everything that makes the tables: the tool's version, the preset's
//! name, the medium and every simulation and fit setting ([`key`]). Its folder is named by a
//! 64-bit FNV-1a hash of the key and holds `key.txt` (compared in full on every load, so a
//! hash collision is a miss, not a wrong table), `measured.exr` and `gaussian.toml`. Entries
//! are written into a staging folder and renamed into place: a reader never sees half of one.
//! Any problem reading an entry is a miss; the tables are then simulated again.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use cdrf_core::gaussian::GaussianCdrf;
use cdrf_core::gaussian_file::{GaussianParameters, read_gaussian, write_gaussian};
use cdrf_core::lut::CdrfLut;
use cdrf_core::lut_file::{read_lut, write_lut};

use super::simulated::SimulatedSettings;
use crate::outputs::{GAUSSIAN, MEASURED_LUT};
use crate::simulation::ScatteringMedium;

/// The environment variable that moves the cache (`cdrf-preset --cache DIR` wins over it).
pub const CACHE_DIR_VARIABLE: &str = "CDRF_CACHE_DIR";

const KEY_FILE: &str = "key.txt";

/// A cache folder.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PresetCache {
    dir: PathBuf,
}

impl PresetCache {
    /// A cache in `dir` (created on the first store).
    pub fn new(dir: impl Into<PathBuf>) -> Self {
        Self { dir: dir.into() }
    }

    /// The default cache: `$CDRF_CACHE_DIR`, else `$XDG_CACHE_HOME/cdrf/presets`, else
    /// `$HOME/.cache/cdrf/presets`; `None` when none of them is set.
    pub fn default_location() -> Option<Self> {
        let var = |name: &str| std::env::var_os(name).filter(|value| !value.is_empty());
        var(CACHE_DIR_VARIABLE)
            .map(PathBuf::from)
            .or_else(|| var("XDG_CACHE_HOME").map(|dir| Path::new(&dir).join("cdrf/presets")))
            .or_else(|| var("HOME").map(|home| Path::new(&home).join(".cache/cdrf/presets")))
            .map(Self::new)
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    fn entry(&self, key: &str) -> PathBuf {
        self.dir.join(format!("{:016x}", fnv1a(key.as_bytes())))
    }

    /// The tables stored under `key`, or `None` (missing, another key, or unreadable).
    pub fn load(&self, key: &str) -> Option<(CdrfLut, GaussianCdrf)> {
        let entry = self.entry(key);
        let stored = std::fs::read_to_string(entry.join(KEY_FILE)).ok()?;
        if stored != key {
            return None;
        }
        let lut = read_lut(entry.join(MEASURED_LUT)).ok()?;
        let gaussian = read_gaussian(entry.join(GAUSSIAN)).ok()?.model().ok()?;
        Some((lut, gaussian))
    }

    /// Stores the tables under `key`, replacing an entry of the same key (when another process
    /// stores the same key at the same time, one of the two entries stays).
    ///
    /// # Errors
    /// When the folder cannot be created or a file written.
    pub fn store(&self, key: &str, lut: &CdrfLut, gaussian: &GaussianCdrf) -> std::io::Result<()> {
        let entry = self.entry(key);
        // Unique per call: two stores at once (threads or processes) never share a folder.
        static STORES: AtomicU64 = AtomicU64::new(0);
        let staging = self.dir.join(format!(
            ".partial-{}-{}",
            std::process::id(),
            STORES.fetch_add(1, Ordering::Relaxed)
        ));
        std::fs::create_dir_all(&staging)?;
        let written = (|| {
            write_lut(lut, staging.join(MEASURED_LUT)).map_err(std::io::Error::other)?;
            let parameters = GaussianParameters {
                sigma_mm: gaussian.sigma_mm(),
                scale: gaussian.scale(),
                view_correction_from: Some(MEASURED_LUT.into()),
            };
            write_gaussian(&parameters, staging.join(GAUSSIAN)).map_err(std::io::Error::other)?;
            std::fs::write(staging.join(KEY_FILE), key)?;
            if entry.exists() {
                std::fs::remove_dir_all(&entry)?;
            }
            std::fs::rename(&staging, &entry)
        })();
        if written.is_err() {
            let _ = std::fs::remove_dir_all(&staging);
        }
        written
    }
}

/// Everything that makes a simulated preset's tables, as text.
pub fn key(name: &str, medium: &ScatteringMedium, settings: &SimulatedSettings) -> String {
    format!(
        "cdrf-preset {}\npreset {name}\nmedium {medium:?}\nsimulated {settings:?}\n",
        env!("CARGO_PKG_VERSION")
    )
}

/// 64-bit FNV-1a: stable across platforms and Rust versions (std's hasher is neither).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |hash, &byte| {
        (hash ^ u64::from(byte)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a_has_its_published_values() {
        assert_eq!(fnv1a(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(b"a"), 0xaf63_dc4c_8601_ec8c);
    }
}
