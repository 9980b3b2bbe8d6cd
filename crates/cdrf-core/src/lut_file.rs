//! The LUT file: an OpenEXR any image tool can open.
//!
//! # Layout (format version 5)
//! A multi-part OpenEXR file, 32-bit float, lossless (ZIP) compression:
//!
//! | part (layer name) | size (width × height) | channels | content |
//! |---|---|---|---|
//! | `cdrf.lut` | θ columns × κ rows | `R`, `G`, `B` | f(κ, θ), π·L/E (see [`crate::lut`]) |
//! | | | `coverage.samples`, `coverage.spread` | only when the table has [`TexelCoverage`] |
//! | `cdrf.view` | φ columns × (θ rows × layers) | `R`, `G`, `B` | the view correction g(κ, θ, φ), one θ × φ grid per curvature layer, top to bottom |
//!
//! Row 0 of `cdrf.lut` (the top of the picture in an image viewer) is the smallest curvature,
//! column 0 is θ = 0 (facing the light). The `cdrf.lut` part carries these header attributes:
//!
//! | attribute | type | meaning |
//! |---|---|---|
//! | `cdrf.format` | text | always `cdrf-lut`: what marks the file as ours |
//! | `cdrf.version` | int | [`FORMAT_VERSION`]; newer files are refused with a clear error |
//! | `cdrf.curvature_min_per_mm`, `cdrf.curvature_max_per_mm` | float | κ of the first and last row, mm⁻¹ |
//! | `cdrf.curvature_axis` | text | `uniform kappa [min, max] mm^-1, rows at the ends` |
//! | `cdrf.theta_axis` | text | `uniform theta [0, pi] rad, columns at the ends` |
//! | `cdrf.view_axes` | text | `phi uniform [0, pi/2] columns x theta uniform [0, pi] rows` |
//! | `cdrf.radiance` | text | `pi*L/E (white Lambertian = max(cos theta, 0))` |
//! | `cdrf.provenance.KEY` | text | one per provenance entry (UTF-8) |
//! | `cdrf.scattering_length_mm` | v3f | version 2, optional: [`Translucency::scattering_length_mm`] (R, G, B) |
//! | `cdrf.transmission.amplitude`, `cdrf.transmission.length_mm` | v3f | version 2, optional: A and ℓ of T(d, μ) = A·μ^p·exp(−d/ℓ), [`TransmissionProfile`] |
//! | `cdrf.transmission.entry_cosine_power` | float | version 3, optional: p |
//! | `cdrf.diffusion.terms` | int | version 4, optional: the number n of terms of the [`DiffusionProfile`] (1 … 16) |
//! | `cdrf.diffusion.term_K.length_mm`, `cdrf.diffusion.term_K.weight` | float, v3f | version 4, with `terms`: ℓ and w (R, G, B) of term K = 0 … n − 1 |
//! | `cdrf.diffusion.entry_cosine_power` | float | version 4, with `terms`: p of the entry factor |
//! | `cdrf.view.curvature_layers` | int | version 5, optional: the view correction's layers n ≥ 2 (absent: one, the same at every curvature) |
//! | `cdrf.view.curvature_min_per_mm`, `cdrf.view.curvature_max_per_mm` | float | version 5, with `curvature_layers`: κ of the first and last layer (uniform between) |
//!
//! The translucency attributes come together or not at all, and so do the diffusion ones. Older
//! files still load: versions 1–4 have one view correction for every curvature; versions 1–3
//! have no diffusion profile ([`CdrfLut::diffusion_profile`] is
//! `None`); version 2 files have no p and mean T(d) alone (p = 0); version 1 files have no
//! translucency ([`CdrfLut::translucency`] is `None`).
//!
//! The axis and radiance texts are checked when reading, so a file written under another
//! convention is refused instead of misread.

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Encoding, FlatSamples, Image, ImageAttributes, Layer,
    LayerAttributes, ReadChannels, ReadLayers, Text, WritableImage,
};
use glam::Vec3;
use thiserror::Error;

use crate::diffusion::{DiffusionProfile, MAX_PROFILE_TERMS, ProfileTerm};
use crate::lut::{CdrfLut, CurvatureAxis, LutError, TexelCoverage, ViewCorrection};
use crate::translucency::{Translucency, TransmissionProfile};

/// The version this crate writes and the newest it reads.
pub const FORMAT_VERSION: i32 = 5;

const LUT_LAYER: &str = "cdrf.lut";
const VIEW_LAYER: &str = "cdrf.view";
const FORMAT_NAME: &str = "cdrf-lut";
const ATTR_FORMAT: &str = "cdrf.format";
const ATTR_VERSION: &str = "cdrf.version";
const ATTR_CURVATURE_MIN: &str = "cdrf.curvature_min_per_mm";
const ATTR_CURVATURE_MAX: &str = "cdrf.curvature_max_per_mm";
const ATTR_CURVATURE_AXIS: &str = "cdrf.curvature_axis";
const ATTR_THETA_AXIS: &str = "cdrf.theta_axis";
const ATTR_VIEW_AXES: &str = "cdrf.view_axes";
const ATTR_RADIANCE: &str = "cdrf.radiance";
const ATTR_PROVENANCE_PREFIX: &str = "cdrf.provenance.";
const ATTR_SCATTERING_LENGTH: &str = "cdrf.scattering_length_mm";
const ATTR_TRANSMISSION_AMPLITUDE: &str = "cdrf.transmission.amplitude";
const ATTR_TRANSMISSION_LENGTH: &str = "cdrf.transmission.length_mm";
const ATTR_TRANSMISSION_ENTRY_POWER: &str = "cdrf.transmission.entry_cosine_power";
const ATTR_DIFFUSION_TERMS: &str = "cdrf.diffusion.terms";
const ATTR_DIFFUSION_ENTRY_POWER: &str = "cdrf.diffusion.entry_cosine_power";
const ATTR_VIEW_LAYERS: &str = "cdrf.view.curvature_layers";
const ATTR_VIEW_CURVATURE_MIN: &str = "cdrf.view.curvature_min_per_mm";
const ATTR_VIEW_CURVATURE_MAX: &str = "cdrf.view.curvature_max_per_mm";
/// The first version whose view correction may depend on curvature.
const VIEW_LAYERS_SINCE_VERSION: i32 = 5;
/// The first version with a diffusion profile.
const DIFFUSION_SINCE_VERSION: i32 = 4;
/// The first version whose transmission profile has an entry cosine power.
const ENTRY_POWER_SINCE_VERSION: i32 = 3;
const CURVATURE_AXIS: &str = "uniform kappa [min, max] mm^-1, rows at the ends";
const THETA_AXIS: &str = "uniform theta [0, pi] rad, columns at the ends";
const VIEW_AXES: &str = "phi uniform [0, pi/2] columns x theta uniform [0, pi] rows";
const RADIANCE: &str = "pi*L/E (white Lambertian = max(cos theta, 0))";
const COVERAGE_SAMPLES: &str = "coverage.samples";
const COVERAGE_SPREAD: &str = "coverage.spread";

/// Why a LUT file could not be read or written.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum LutFileError {
    /// The file system refused (missing file, permissions, full disk).
    #[error("{}: {error}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        error: std::io::Error,
    },
    /// The file is not a readable OpenEXR image (truncated, corrupt, another format).
    #[error("{}: not a readable OpenEXR file: {error}", path.display())]
    Exr {
        /// The file.
        path: PathBuf,
        /// What the decoder said.
        error: exr::error::Error,
    },
    /// An OpenEXR file, but not a cdrf LUT, or one written under other conventions.
    #[error("{}: not a cdrf LUT: {reason}", path.display())]
    NotACdrfLut {
        /// The file.
        path: PathBuf,
        /// What is missing or different.
        reason: String,
    },
    /// A cdrf LUT from a newer version of cdrf.
    #[error(
        "{}: cdrf LUT format version {found}; this build reads up to {FORMAT_VERSION}",
        path.display()
    )]
    UnsupportedVersion {
        /// The file.
        path: PathBuf,
        /// The version in the file.
        found: i32,
    },
    /// The table in the file is malformed (wrong shape, negative or non-finite values).
    #[error("{}: {error}", path.display())]
    InvalidTable {
        /// The file.
        path: PathBuf,
        /// What is wrong with the table.
        error: LutError,
    },
}

/// Writes `lut` to `path` atomically: a temporary file beside it, renamed over `path` only once
/// complete, so a failed write never leaves a partial or clobbered file.
///
/// # Errors
/// When the directory is not writable or encoding fails.
pub fn write_lut(lut: &CdrfLut, path: impl AsRef<Path>) -> Result<(), LutFileError> {
    let path = path.as_ref();
    let image = Image::from_layers(
        ImageAttributes::with_size((lut.theta_count(), lut.curvature_axis().count)),
        vec![lut_layer(lut), view_layer(lut.view_correction())],
    );
    crate::atomic::write_file(path, |file| {
        let mut writer = BufWriter::new(file);
        image
            .write()
            .to_buffered(&mut writer)
            .map_err(std::io::Error::other)?;
        writer.flush()
    })
    .map_err(|error| LutFileError::Io {
        path: path.to_path_buf(),
        error,
    })
}

/// Reads a LUT written by [`write_lut`] (or any tool that follows the layout above).
///
/// # Errors
/// When the file cannot be read, is not OpenEXR, is not a cdrf LUT, is from a newer format
/// version, or holds a malformed table.
pub fn read_lut(path: impl AsRef<Path>) -> Result<CdrfLut, LutFileError> {
    let path = path.as_ref();
    let bytes = crate::input_file::read_regular(path, crate::input_file::MAX_INPUT_FILE_BYTES)
        .map_err(|error| LutFileError::Io {
            path: path.to_path_buf(),
            error,
        })?;
    read_lut_bytes(bytes.as_slice(), path)
}

/// Decodes a CDRF table from the bytes of a `measured.exr` (e.g. one built into a binary);
/// `path` only names it in errors.
///
/// # Errors
/// As [`read_lut`], but never [`LutFileError::Io`].
pub fn read_lut_bytes(bytes: &[u8], path: &Path) -> Result<CdrfLut, LutFileError> {
    crate::input_file::check_exr_windows(bytes).map_err(|error| match error {
        crate::input_file::ExrHeaderError::Exr(error) => LutFileError::Exr {
            path: path.to_path_buf(),
            error,
        },
        crate::input_file::ExrHeaderError::TooLarge(reason) => LutFileError::NotACdrfLut {
            path: path.to_path_buf(),
            reason,
        },
    })?;
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .non_parallel()
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(|error| LutFileError::Exr {
            path: path.to_path_buf(),
            error,
        })?;
    let not_ours = |reason: String| LutFileError::NotACdrfLut {
        path: path.to_path_buf(),
        reason,
    };
    let find = |name: &str| {
        image.layer_data.iter().find(|layer| {
            layer
                .attributes
                .layer_name
                .as_ref()
                .is_some_and(|n| n == name)
        })
    };
    let lut_layer = find(LUT_LAYER).ok_or_else(|| not_ours(format!("no `{LUT_LAYER}` layer")))?;
    let attributes = &lut_layer.attributes.other;
    let text = |name: &str| match attributes.get(&Text::from(name)) {
        Some(AttributeValue::Text(text)) => {
            Ok(String::from_utf8_lossy(text.as_slice()).into_owned())
        }
        _ => Err(not_ours(format!("text attribute `{name}` missing"))),
    };
    let float = |name: &str| match attributes.get(&Text::from(name)) {
        Some(AttributeValue::F32(value)) => Ok(*value),
        _ => Err(not_ours(format!("float attribute `{name}` missing"))),
    };
    if text(ATTR_FORMAT)? != FORMAT_NAME {
        return Err(not_ours(format!("`{ATTR_FORMAT}` is not `{FORMAT_NAME}`")));
    }
    let version = match attributes.get(&Text::from(ATTR_VERSION)) {
        Some(AttributeValue::I32(version)) if *version > FORMAT_VERSION => {
            return Err(LutFileError::UnsupportedVersion {
                path: path.to_path_buf(),
                found: *version,
            });
        }
        Some(AttributeValue::I32(version)) if *version >= 1 => *version,
        _ => {
            return Err(not_ours(format!(
                "int attribute `{ATTR_VERSION}` missing or < 1"
            )));
        }
    };
    for (name, expected) in [
        (ATTR_CURVATURE_AXIS, CURVATURE_AXIS),
        (ATTR_THETA_AXIS, THETA_AXIS),
        (ATTR_VIEW_AXES, VIEW_AXES),
        (ATTR_RADIANCE, RADIANCE),
    ] {
        let found = text(name)?;
        if found != expected {
            return Err(not_ours(format!(
                "`{name}` is `{found}`, expected `{expected}`"
            )));
        }
    }

    let (theta_count, curvature_count) = (lut_layer.size.width(), lut_layer.size.height());
    let axis = CurvatureAxis {
        min_per_mm: float(ATTR_CURVATURE_MIN)?,
        max_per_mm: float(ATTR_CURVATURE_MAX)?,
        count: curvature_count,
    };
    let channels = &lut_layer.channel_data.list;
    let channel = |name: &str| channels.iter().find(|c| c.name == *name);
    let rgb = |layer_name: &str, list: &[AnyChannel<FlatSamples>]| {
        let get = |name: &str| {
            list.iter()
                .find(|c| c.name == *name)
                .map(|c| c.sample_data.values_as_f32().collect::<Vec<f32>>())
                .ok_or_else(|| not_ours(format!("layer `{layer_name}` has no channel `{name}`")))
        };
        let (r, g, b) = (get("R")?, get("G")?, get("B")?);
        Ok::<Vec<Vec3>, LutFileError>(
            r.iter()
                .zip(&g)
                .zip(&b)
                .map(|((&r, &g), &b)| Vec3::new(r, g, b))
                .collect(),
        )
    };
    let invalid = |error: LutError| LutFileError::InvalidTable {
        path: path.to_path_buf(),
        error,
    };
    let mut lut = CdrfLut::new(axis, theta_count, rgb(LUT_LAYER, channels)?).map_err(invalid)?;

    match (channel(COVERAGE_SAMPLES), channel(COVERAGE_SPREAD)) {
        (Some(samples), Some(spread)) => {
            let coverage = samples
                .sample_data
                .values_as_f32()
                .zip(spread.sample_data.values_as_f32())
                .map(|(sample_count, relative_spread)| TexelCoverage {
                    sample_count,
                    relative_spread,
                })
                .collect();
            lut = lut.with_coverage(coverage).map_err(invalid)?;
        }
        (None, None) => {}
        _ => {
            return Err(not_ours(format!(
                "`{COVERAGE_SAMPLES}` and `{COVERAGE_SPREAD}` must come together"
            )));
        }
    }

    let view = find(VIEW_LAYER).ok_or_else(|| not_ours(format!("no `{VIEW_LAYER}` layer")))?;
    // Versions before 5 have one layer: the same correction at every curvature.
    let view_axis = match attributes.get(&Text::from(ATTR_VIEW_LAYERS)) {
        None => CurvatureAxis::single(),
        Some(AttributeValue::I32(layers)) if version >= VIEW_LAYERS_SINCE_VERSION => {
            let layers = usize::try_from(*layers)
                .ok()
                .filter(|&layers| layers >= 1 && layers <= view.size.height())
                .ok_or_else(|| {
                    not_ours(format!(
                        "`{ATTR_VIEW_LAYERS}` {layers}: must be 1 … the view layer's {} rows",
                        view.size.height()
                    ))
                })?;
            CurvatureAxis {
                min_per_mm: float(ATTR_VIEW_CURVATURE_MIN)?,
                max_per_mm: float(ATTR_VIEW_CURVATURE_MAX)?,
                count: layers,
            }
        }
        Some(_) => {
            return Err(not_ours(format!(
                "`{ATTR_VIEW_LAYERS}` is not an int, or the file's version {version} is before {VIEW_LAYERS_SINCE_VERSION}"
            )));
        }
    };
    if !view.size.height().is_multiple_of(view_axis.count) {
        return Err(not_ours(format!(
            "`{VIEW_LAYER}` has {} rows: not a multiple of its {} curvature layers",
            view.size.height(),
            view_axis.count
        )));
    }
    let view_correction = ViewCorrection::with_curvature_layers(
        view.size.width(),
        view.size.height() / view_axis.count,
        view_axis,
        rgb(VIEW_LAYER, &view.channel_data.list)?,
    )
    .map_err(invalid)?;
    lut = lut.with_view_correction(view_correction);

    let vector = |name: &str| match attributes.get(&Text::from(name)) {
        Some(AttributeValue::FloatVec3((x, y, z))) => Ok(Some([*x, *y, *z])),
        None => Ok(None),
        Some(_) => Err(not_ours(format!("`{name}` is not a float vector (v3f)"))),
    };
    // Version 2 files have no power: their T(d) does not depend on the entry angle.
    let entry_cosine_power = if version >= ENTRY_POWER_SINCE_VERSION {
        match attributes.get(&Text::from(ATTR_TRANSMISSION_ENTRY_POWER)) {
            Some(AttributeValue::F32(power)) => Some(*power),
            None => None,
            Some(_) => {
                return Err(not_ours(format!(
                    "`{ATTR_TRANSMISSION_ENTRY_POWER}` is not a float"
                )));
            }
        }
    } else {
        Some(0.0)
    };
    match (
        vector(ATTR_SCATTERING_LENGTH)?,
        vector(ATTR_TRANSMISSION_AMPLITUDE)?,
        vector(ATTR_TRANSMISSION_LENGTH)?,
        entry_cosine_power,
    ) {
        (Some(scattering_length_mm), Some(amplitude), Some(length_mm), Some(power)) => {
            let translucency =
                TransmissionProfile::with_entry_cosine_power(amplitude, length_mm, power)
                    .and_then(|t| Translucency::new(scattering_length_mm, t))
                    .map_err(|error| not_ours(format!("translucency: {error}")))?;
            lut = lut.with_translucency(translucency);
        }
        (None, None, None, _) if version < ENTRY_POWER_SINCE_VERSION => {}
        (None, None, None, None) => {}
        _ => {
            return Err(not_ours(format!(
                "`{ATTR_SCATTERING_LENGTH}`, `{ATTR_TRANSMISSION_AMPLITUDE}`, \
                 `{ATTR_TRANSMISSION_LENGTH}` and `{ATTR_TRANSMISSION_ENTRY_POWER}` must come \
                 together"
            )));
        }
    }

    if version >= DIFFUSION_SINCE_VERSION
        && let Some(profile) = read_diffusion_profile(attributes).map_err(not_ours)?
    {
        lut = lut.with_diffusion_profile(profile);
    }

    let mut provenance: Vec<(String, String)> = attributes
        .iter()
        .filter_map(|(name, value)| {
            let key = name
                .to_string()
                .strip_prefix(ATTR_PROVENANCE_PREFIX)?
                .to_owned();
            match value {
                AttributeValue::Text(text) => {
                    Some((key, String::from_utf8_lossy(text.as_slice()).into_owned()))
                }
                _ => None,
            }
        })
        .collect();
    provenance.sort();
    for (key, value) in provenance {
        lut = lut.with_provenance(key, value);
    }
    Ok(lut)
}

fn lut_layer(lut: &CdrfLut) -> Layer<AnyChannels<FlatSamples>> {
    let mut channels = rgb_channels(lut.radiance());
    if let Some(coverage) = lut.coverage() {
        channels.push(AnyChannel::new(
            COVERAGE_SAMPLES,
            FlatSamples::F32(coverage.iter().map(|c| c.sample_count).collect()),
        ));
        channels.push(AnyChannel::new(
            COVERAGE_SPREAD,
            FlatSamples::F32(coverage.iter().map(|c| c.relative_spread).collect()),
        ));
    }
    let axis = lut.curvature_axis();
    let mut attributes = LayerAttributes::named(LUT_LAYER);
    let other = &mut attributes.other;
    let mut put_text = |name: &str, value: &str| {
        other.insert(
            Text::from(name),
            AttributeValue::Text(Text::from_slice_unchecked(value.as_bytes())),
        );
    };
    put_text(ATTR_FORMAT, FORMAT_NAME);
    put_text(ATTR_CURVATURE_AXIS, CURVATURE_AXIS);
    put_text(ATTR_THETA_AXIS, THETA_AXIS);
    put_text(ATTR_VIEW_AXES, VIEW_AXES);
    put_text(ATTR_RADIANCE, RADIANCE);
    for (key, value) in lut.provenance() {
        put_text(&format!("{ATTR_PROVENANCE_PREFIX}{key}"), value);
    }
    other.insert(
        Text::from(ATTR_VERSION),
        AttributeValue::I32(FORMAT_VERSION),
    );
    other.insert(
        Text::from(ATTR_CURVATURE_MIN),
        AttributeValue::F32(axis.min_per_mm),
    );
    other.insert(
        Text::from(ATTR_CURVATURE_MAX),
        AttributeValue::F32(axis.max_per_mm),
    );
    if let Some(translucency) = lut.translucency() {
        let vector = |[x, y, z]: [f32; 3]| AttributeValue::FloatVec3((x, y, z));
        other.insert(
            Text::from(ATTR_SCATTERING_LENGTH),
            vector(translucency.scattering_length_mm),
        );
        other.insert(
            Text::from(ATTR_TRANSMISSION_AMPLITUDE),
            vector(translucency.transmission.amplitude),
        );
        other.insert(
            Text::from(ATTR_TRANSMISSION_LENGTH),
            vector(translucency.transmission.length_mm),
        );
        other.insert(
            Text::from(ATTR_TRANSMISSION_ENTRY_POWER),
            AttributeValue::F32(translucency.transmission.entry_cosine_power),
        );
    }
    let view_axis = lut.view_correction().curvature_axis();
    if view_axis.count > 1 {
        other.insert(
            Text::from(ATTR_VIEW_LAYERS),
            AttributeValue::I32(view_axis.count as i32),
        );
        other.insert(
            Text::from(ATTR_VIEW_CURVATURE_MIN),
            AttributeValue::F32(view_axis.min_per_mm),
        );
        other.insert(
            Text::from(ATTR_VIEW_CURVATURE_MAX),
            AttributeValue::F32(view_axis.max_per_mm),
        );
    }
    if let Some(profile) = lut.diffusion_profile() {
        other.insert(
            Text::from(ATTR_DIFFUSION_TERMS),
            AttributeValue::I32(profile.terms().len() as i32),
        );
        for (k, term) in profile.terms().iter().enumerate() {
            let [x, y, z] = term.weight;
            other.insert(
                Text::from(diffusion_term_attribute(k, "length_mm").as_str()),
                AttributeValue::F32(term.length_mm),
            );
            other.insert(
                Text::from(diffusion_term_attribute(k, "weight").as_str()),
                AttributeValue::FloatVec3((x, y, z)),
            );
        }
        other.insert(
            Text::from(ATTR_DIFFUSION_ENTRY_POWER),
            AttributeValue::F32(profile.entry_cosine_power()),
        );
    }
    Layer::new(
        (lut.theta_count(), axis.count),
        attributes,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels.into()),
    )
}

fn diffusion_term_attribute(term: usize, what: &str) -> String {
    format!("cdrf.diffusion.term_{term}.{what}")
}

/// The diffusion profile of a version 4 `cdrf.lut` header, `None` when it has none; the error
/// says which attribute is missing or wrong.
fn read_diffusion_profile(
    attributes: &std::collections::HashMap<Text, AttributeValue>,
) -> Result<Option<DiffusionProfile>, String> {
    let get = |name: &str| attributes.get(&Text::from(name));
    let count = match get(ATTR_DIFFUSION_TERMS) {
        None => {
            if get(ATTR_DIFFUSION_ENTRY_POWER).is_some() {
                return Err(format!(
                    "`{ATTR_DIFFUSION_ENTRY_POWER}` without `{ATTR_DIFFUSION_TERMS}`"
                ));
            }
            return Ok(None);
        }
        Some(AttributeValue::I32(n)) if (1..=MAX_PROFILE_TERMS as i32).contains(n) => *n as usize,
        Some(_) => {
            return Err(format!(
                "`{ATTR_DIFFUSION_TERMS}` must be an int from 1 to {MAX_PROFILE_TERMS}"
            ));
        }
    };
    let float = |name: &str| match get(name) {
        Some(AttributeValue::F32(v)) => Ok(*v),
        _ => Err(format!("float attribute `{name}` missing")),
    };
    let terms = (0..count)
        .map(|k| {
            let length_mm = float(&diffusion_term_attribute(k, "length_mm"))?;
            let name = diffusion_term_attribute(k, "weight");
            match get(&name) {
                Some(AttributeValue::FloatVec3((x, y, z))) => Ok(ProfileTerm {
                    length_mm,
                    weight: [*x, *y, *z],
                }),
                _ => Err(format!("float vector (v3f) attribute `{name}` missing")),
            }
        })
        .collect::<Result<Vec<_>, String>>()?;
    let power = float(ATTR_DIFFUSION_ENTRY_POWER)?;
    DiffusionProfile::new(terms, power)
        .map(Some)
        .map_err(|error| format!("diffusion profile: {error}"))
}

fn view_layer(view: &ViewCorrection) -> Layer<AnyChannels<FlatSamples>> {
    Layer::new(
        (
            view.phi_count(),
            view.theta_count() * view.curvature_axis().count,
        ),
        LayerAttributes::named(VIEW_LAYER),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(rgb_channels(view.values()).into()),
    )
}

fn rgb_channels(values: &[Vec3]) -> Vec<AnyChannel<FlatSamples>> {
    ["R", "G", "B"]
        .into_iter()
        .enumerate()
        .map(|(c, name)| {
            AnyChannel::new(
                name,
                FlatSamples::F32(values.iter().map(|v| v[c]).collect()),
            )
        })
        .collect()
}
