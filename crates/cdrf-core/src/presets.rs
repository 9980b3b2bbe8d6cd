//! Materials that need no file: tables `cdrf-preset` made from simulated spheres of a medium
//! (Monte Carlo light transport, fitted as photographs are), built into the crate so that a
//! crates.io user without the repository's `data/` folder starts from the measured look.
//!
//! Each is a full table (view correction, transmission, diffusion profile: every render mode
//! works) and its Kubo Gaussian. They are decoded on first use and kept. `scripts/make_presets.sh`
//! makes them again; the table's provenance says how (medium, simulator settings, noise).
//!
//! ```
//! let wax = cdrf_core::presets::lut("wax")?; // case-insensitive
//! assert!(wax.translucency().is_some() && wax.diffusion_profile().is_some());
//! # Ok::<(), cdrf_core::presets::PresetError>(())
//! ```

use std::path::Path;
use std::sync::OnceLock;

use crate::gaussian::GaussianCdrf;
use crate::gaussian_file::{GaussianFileError, parse_gaussian};
use crate::lut::CdrfLut;
use crate::lut_file::{LutFileError, read_lut_bytes};

/// A built-in material.
#[derive(Debug)]
pub struct BuiltInPreset {
    /// The name (matched case-insensitively).
    pub name: &'static str,
    /// The medium, in a line.
    pub description: &'static str,
    lut: &'static [u8],
    gaussian: &'static str,
}

macro_rules! preset {
    ($name:literal, $file:literal, $description:literal) => {
        BuiltInPreset {
            name: $name,
            description: $description,
            lut: include_bytes!(concat!("../presets/", $file, ".exr")),
            gaussian: include_str!(concat!("../presets/", $file, ".gaussian.toml")),
        }
    };
}

/// Every built-in material.
pub const PRESETS: [BuiltInPreset; 4] = [
    preset!(
        "wax",
        "wax",
        "the bundled photographs' paraffin-like wax: σt = 1 mm⁻¹, albedo 0.997 / 0.993 / 0.985, isotropic, index-matched"
    ),
    preset!("skin1", "skin1", "Jensen et al. 2001 Skin1, index-matched"),
    preset!(
        "marble",
        "marble",
        "Jensen et al. 2001 Marble, index-matched"
    ),
    preset!(
        "wholemilk",
        "wholemilk",
        "Jensen et al. 2001 Wholemilk, index-matched"
    ),
];

/// Why a built-in material could not be had.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PresetError {
    /// No built-in material has that name.
    #[error("no built-in material {name:?}; built in: {}", names().collect::<Vec<_>>().join(", "))]
    Unknown {
        /// The name asked for.
        name: String,
    },
    /// The built-in table does not decode (a broken build).
    #[error("built-in material: {0}")]
    Lut(#[from] LutFileError),
    /// The built-in Gaussian does not parse (a broken build).
    #[error("built-in material: {0}")]
    Gaussian(#[from] GaussianFileError),
}

/// The built-in materials' names.
pub fn names() -> impl Iterator<Item = &'static str> {
    PRESETS.iter().map(|preset| preset.name)
}

fn index(name: &str) -> Result<usize, PresetError> {
    PRESETS
        .iter()
        .position(|preset| preset.name.eq_ignore_ascii_case(name))
        .ok_or_else(|| PresetError::Unknown {
            name: name.to_owned(),
        })
}

/// The table of the built-in material `name`, decoded on first use.
///
/// # Errors
/// [`PresetError::Unknown`], listing the names.
pub fn lut(name: &str) -> Result<&'static CdrfLut, PresetError> {
    static DECODED: [OnceLock<CdrfLut>; PRESETS.len()] = [const { OnceLock::new() }; PRESETS.len()];
    let position = index(name)?;
    let cell: &'static OnceLock<CdrfLut> = &DECODED[position];
    if let Some(lut) = cell.get() {
        return Ok(lut);
    }
    let preset = &PRESETS[position];
    let lut = read_lut_bytes(
        preset.lut,
        Path::new(&format!("built-in {}.exr", preset.name)),
    )?;
    Ok(cell.get_or_init(|| lut))
}

/// The Kubo Gaussian fitted to the same simulated spheres; its view correction is the table's.
///
/// # Errors
/// [`PresetError::Unknown`], listing the names.
pub fn gaussian(name: &str) -> Result<GaussianCdrf, PresetError> {
    let preset = &PRESETS[index(name)?];
    let path = format!("built-in {}.gaussian.toml", preset.name);
    let parameters = parse_gaussian(preset.gaussian, Path::new(&path))?;
    parameters.model().map_err(|error| {
        PresetError::Gaussian(GaussianFileError::Parameter {
            path: path.into(),
            error,
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lut::Filter;

    #[test]
    fn every_built_in_material_decodes_whole() {
        for name in names() {
            let lut = lut(name).unwrap();
            assert!(lut.translucency().is_some(), "{name}: no transmission");
            assert!(
                lut.diffusion_profile().is_some(),
                "{name}: no diffusion profile"
            );
            assert!(
                lut.provenance()
                    .get("source")
                    .is_some_and(|s| s.contains("simulated")),
                "{name}: {:?}",
                lut.provenance()
            );
            // Lit head-on, a flat-ish surface reflects its albedo: below 1, above 0.
            let head_on = lut.sample(lut.curvature_axis().min_per_mm, 0.0, Filter::Bilinear);
            assert!(
                head_on.min_element() > 0.0 && head_on.max_element() < 1.0,
                "{name}: {head_on}"
            );
            gaussian(name).unwrap();
        }
        // Decoded once: the same table again.
        assert!(std::ptr::eq(lut("wax").unwrap(), lut("WAX").unwrap()));
    }

    #[test]
    fn unknown_names_list_the_built_in_ones() {
        let message = lut("unobtainium").unwrap_err().to_string();
        assert!(
            message.contains("wax") && message.contains("skin1"),
            "{message}"
        );
    }
}
