//! Camera RAW and DNG photographs, decoded linearly (feature `raw`, on by default).
//!
//! The file is parsed by [rawler](https://github.com/dnglab/dnglab) — the maintained Rust raw
//! decoder of dnglab (DNG with lossless-JPEG or JPEG XL data, CR2/CR3, NEF, ARW, RAF, ORF, RW2,
//! PEF, …); rawloader, its older root, is smaller but reads fewer formats, and imagepipe adds a
//! display pipeline we do not want. rawler is LGPL-2.1: build with `--no-default-features` to
//! leave it out. What a measurement needs is then done here, all of it linear:
//! 1. **Levels**: each sample minus the black level of its position in the 2 × 2 pattern,
//!    divided by (white − black); a pixel with any sample at or above the white level is
//!    clipped (saturated).
//! 2. **No interpolation**: each 2 × 2 Bayer block becomes one RGB pixel (its red, the mean of
//!    its greens, its blue), so the image is half the sensor's size and no pixel mixes its
//!    neighbours' radiance — a demosaicking filter would blur the silhouette and the terminator.
//! 3. **White balance**: the file's as-shot coefficients, green = 1.
//! 4. **Colour**: camera RGB → linear sRGB (Rec. 709, D65) by the file's XYZ → camera matrix, with
//!    rows normalised so that white stays white after the white balance (dcraw's convention).
//!
//! The crop to the active area is applied. Only Bayer sensors (a 2 × 2 repeat of red, green and
//! blue) and linear (demosaicked) DNGs are read; X-Trans and other patterns are refused.
//!
//! The image size is checked against the input limits before the pixels are allocated (from
//! the raw image's TIFF directory, or a metadata-only decode for formats without one). A panic inside it (the
//! decoder has `todo!()`s for rare layouts) is caught and reported as a decode error.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;
use std::sync::Arc;

use glam::{Mat3, Vec3};
use rawler::RawImage;
use rawler::decoders::{RawDecodeParams, WellKnownIFD};
use rawler::rawimage::{RawImageData, RawPhotometricInterpretation};
use rawler::tags::TiffCommonTag;

use rawler::rawsource::RawSource;

use crate::image_io::{CodeStep, ColorSpace, ImageError, LinearImage, SampleFormat};

/// Linear sRGB (Rec. 709 primaries, D65) → CIE XYZ.
const SRGB_TO_XYZ: Mat3 = Mat3::from_cols(
    Vec3::new(0.412_456_4, 0.212_672_9, 0.019_333_9),
    Vec3::new(0.357_576_1, 0.715_152_2, 0.119_192),
    Vec3::new(0.180_437_5, 0.072_175, 0.950_304_1),
);

fn decode_error(path: &Path, message: impl Into<String>) -> ImageError {
    ImageError::Decode {
        path: path.to_path_buf(),
        format: "camera RAW",
        message: message.into(),
    }
}

/// Runs the decoder, turning a panic into an error.
fn guarded<T>(path: &Path, run: impl FnOnce() -> rawler::Result<T>) -> Result<T, ImageError> {
    match catch_unwind(AssertUnwindSafe(run)) {
        Ok(Ok(value)) => Ok(value),
        Ok(Err(error)) => Err(decode_error(path, error.to_string())),
        Err(_) => Err(decode_error(
            path,
            "the RAW decoder failed on this file (unsupported layout or corrupt data)",
        )),
    }
}

/// The largest number of TIFF directories a DNG may hold (previews, the raw image, EXIF, …).
const MAX_DIRECTORIES: usize = 64;
/// The most entries one directory may have.
const MAX_ENTRIES: usize = 4096;

/// Checks a TIFF file's structure before rawler parses it: every directory and every entry's
/// data must lie inside the file (rawler allocates what an entry's count claims), every entry
/// of a known type, no directory reached twice, at most [`MAX_DIRECTORIES`] directories of at
/// most [`MAX_ENTRIES`] entries.
fn check_tiff_structure(bytes: &[u8]) -> Result<(), String> {
    let little = match bytes.get(..4) {
        Some(b"II*\0") => true,
        Some(b"MM\0*") => false,
        _ => return Err("not a DNG: no TIFF header".to_owned()),
    };
    let u16_at = |at: u64| -> Option<u64> {
        let at = usize::try_from(at).ok()?;
        let b: [u8; 2] = bytes.get(at..at.checked_add(2)?)?.try_into().ok()?;
        Some(u64::from(if little {
            u16::from_le_bytes(b)
        } else {
            u16::from_be_bytes(b)
        }))
    };
    let u32_at = |at: u64| -> Option<u64> {
        let at = usize::try_from(at).ok()?;
        let b: [u8; 4] = bytes.get(at..at.checked_add(4)?)?.try_into().ok()?;
        Some(u64::from(if little {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        }))
    };
    let length = bytes.len() as u64;
    let outside = |what: &str| format!("{what} lies outside the file (truncated or corrupt)");
    let mut pending = vec![u32_at(4).ok_or_else(|| outside("the first directory"))?];
    let mut visited: Vec<u64> = Vec::new();
    while let Some(offset) = pending.pop() {
        if offset == 0 {
            continue;
        }
        // rawler follows directory chains without remembering where it has been.
        if visited.contains(&offset) {
            return Err("the TIFF directories form a cycle".to_owned());
        }
        if visited.len() == MAX_DIRECTORIES {
            return Err(format!("more than {MAX_DIRECTORIES} TIFF directories"));
        }
        visited.push(offset);
        let count = u16_at(offset).ok_or_else(|| outside("a TIFF directory"))?;
        if count as usize > MAX_ENTRIES {
            return Err(format!(
                "a TIFF directory of {count} entries (at most {MAX_ENTRIES})"
            ));
        }
        pending.push(u32_at(offset + 2 + 12 * count).ok_or_else(|| outside("a TIFF directory"))?);
        for k in 0..count {
            let entry = offset + 2 + 12 * k;
            let (Some(tag), Some(kind), Some(n)) =
                (u16_at(entry), u16_at(entry + 2), u32_at(entry + 4))
            else {
                return Err(outside("a TIFF entry"));
            };
            let size: u64 = match kind {
                1 | 2 | 6 | 7 => 1,
                3 | 8 => 2,
                4 | 9 | 11 | 13 => 4,
                5 | 10 | 12 => 8,
                _ => return Err(format!("tag {tag} has an unknown TIFF type {kind}")),
            };
            let total = n * size;
            let data = if total > 4 {
                let start = u32_at(entry + 8).ok_or_else(|| outside("a TIFF entry"))?;
                if start + total > length {
                    return Err(format!("tag {tag}'s {n} values lie outside the file"));
                }
                start
            } else {
                entry + 8
            };
            // Sub-directories: SubIFDs, EXIF, GPS, interoperability.
            if matches!(tag, 330 | 34665 | 34853 | 40965) {
                if !matches!(kind, 4 | 13) {
                    return Err(format!("tag {tag} (a sub-directory) has TIFF type {kind}"));
                }
                for i in 0..n.min(MAX_DIRECTORIES as u64 + 1) {
                    pending.push(u32_at(data + 4 * i).ok_or_else(|| outside("a sub-directory"))?);
                }
            }
        }
    }
    Ok(())
}

/// Decodes a DNG file (the whole file in `bytes`) into linear sRGB radiance times `exposure`.
pub(crate) fn decode_raw(
    path: &Path,
    bytes: Vec<u8>,
    exposure: f32,
) -> Result<LinearImage, ImageError> {
    check_tiff_structure(&bytes).map_err(|message| decode_error(path, message))?;
    let source = RawSource::new_from_shared_vec(Arc::new(bytes));
    let params = RawDecodeParams::default();
    let decoder = guarded(path, || rawler::get_decoder(&source))?;
    // The size is checked before anything of that size is allocated: from the raw image's TIFF
    // directory where the format has one (DNG and most RAWs), else from a decode that reads the
    // metadata only.
    let raw_ifd = guarded(path, || decoder.ifd(WellKnownIFD::Raw))
        .ok()
        .flatten();
    let dimension = |tag: TiffCommonTag| {
        raw_ifd
            .as_ref()
            .and_then(|ifd| ifd.get_entry(tag))
            .and_then(|entry| entry.value.get_usize(0).ok().flatten())
    };
    let (width, height) = match (
        dimension(TiffCommonTag::ImageWidth),
        dimension(TiffCommonTag::ImageLength),
    ) {
        (Some(width), Some(height)) => (width, height),
        _ => {
            let shape = guarded(path, || decoder.raw_image(&source, &params, true))?;
            (shape.width, shape.height)
        }
    };
    cdrf_core::input_file::check_image_size("the raw image", width, height).map_err(|problem| {
        ImageError::TooLarge {
            path: path.to_path_buf(),
            problem,
        }
    })?;
    let raw = guarded(path, || decoder.raw_image(&source, &params, false))?;
    develop(path, &raw, exposure)
}

/// Levels, 2 × 2 blocks, white balance and colour (see the module docs).
fn develop(path: &Path, raw: &RawImage, exposure: f32) -> Result<LinearImage, ImageError> {
    let samples: Vec<f32> = match &raw.data {
        RawImageData::Integer(data) => data.iter().map(|&v| f32::from(v)).collect(),
        RawImageData::Float(data) => data.clone(),
    };
    let (width, height, cpp) = (raw.width, raw.height, raw.cpp);
    if width == 0 || height == 0 || cpp == 0 || samples.len() < width * height * cpp {
        return Err(decode_error(path, "the raw image has no pixels"));
    }
    let (x0, y0, crop_w, crop_h) = match raw.crop_area.or(raw.active_area) {
        Some(r) if r.p.x + r.d.w <= width && r.p.y + r.d.h <= height => {
            (r.p.x, r.p.y, r.d.w, r.d.h)
        }
        _ => (0, 0, width, height),
    };
    // Per position in the 2 × 2 pattern (one value: all four), read without rawler's
    // accessors, which index an empty list.
    let blacks: Vec<f32> = raw.blacklevel.levels.iter().map(|r| r.as_f32()).collect();
    let black: [f32; 4] = match blacks.as_slice() {
        [a, b, c, d] => [*a, *b, *c, *d],
        [a, ..] => [*a; 4],
        [] => [0.0; 4],
    };
    let white = raw
        .whitelevel
        .0
        .iter()
        .map(|&w| w as f32)
        .fold(f32::INFINITY, f32::min);
    if !(white.is_finite() && black.iter().all(|b| b.is_finite() && *b < white)) {
        return Err(decode_error(
            path,
            format!("black levels {black:?} and white level {white} make no range"),
        ));
    }
    let level = |value: f32, position: usize| {
        let b = black[position];
        ((value - b) / (white - b).max(1e-6), value >= white)
    };
    let (camera, saturated, out_w, out_h) = match &raw.photometric {
        RawPhotometricInterpretation::Cfa(config) => {
            let color = |row: usize, col: usize| config.cfa.color_at(row, col);
            // A 2 × 2 Bayer block: one red, two greens, one blue, repeating.
            let mut counts = [0; 3];
            for (dy, dx) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                match color(y0 + dy, x0 + dx) {
                    c @ 0..=2 => counts[c] += 1,
                    _ => counts = [9; 3],
                }
            }
            let repeats = (0..4).all(|dy| {
                (0..4).all(|dx| color(y0 + dy, x0 + dx) == color(y0 + dy % 2, x0 + dx % 2))
            });
            if counts != [1, 2, 1] || !repeats {
                return Err(ImageError::Unsupported {
                    path: path.to_path_buf(),
                    what: format!(
                        "colour filter pattern {} (only 2 × 2 Bayer patterns of red, green and blue are read)",
                        config.cfa.name
                    ),
                });
            }
            let (out_w, out_h) = (crop_w / 2, crop_h / 2);
            let mut pixels = Vec::with_capacity(out_w * out_h);
            let mut clipped = Vec::with_capacity(out_w * out_h);
            for by in 0..out_h {
                for bx in 0..out_w {
                    let mut sum = Vec3::ZERO;
                    let mut any_clipped = false;
                    for (dy, dx) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                        let (row, col) = (y0 + 2 * by + dy, x0 + 2 * bx + dx);
                        let position = ((row - y0) % 2) * 2 + (col - x0) % 2;
                        let (value, clip) = level(samples[row * width + col], position);
                        any_clipped |= clip;
                        sum[color(row, col)] += value;
                    }
                    pixels.push(Vec3::new(sum.x, sum.y / 2.0, sum.z));
                    clipped.push(any_clipped);
                }
            }
            (pixels, clipped, out_w, out_h)
        }
        RawPhotometricInterpretation::LinearRaw if cpp >= 3 => {
            let mut pixels = Vec::with_capacity(crop_w * crop_h);
            let mut clipped = Vec::with_capacity(crop_w * crop_h);
            for row in y0..y0 + crop_h {
                for col in x0..x0 + crop_w {
                    let at = (row * width + col) * cpp;
                    let mut rgb = Vec3::ZERO;
                    let mut any_clipped = false;
                    for c in 0..3 {
                        let (value, clip) = level(samples[at + c], c);
                        rgb[c] = value;
                        any_clipped |= clip;
                    }
                    pixels.push(rgb);
                    clipped.push(any_clipped);
                }
            }
            (pixels, clipped, crop_w, crop_h)
        }
        other => {
            return Err(ImageError::Unsupported {
                path: path.to_path_buf(),
                what: format!("raw photometric interpretation {other:?}"),
            });
        }
    };
    if out_w == 0 || out_h == 0 {
        return Err(decode_error(path, "the raw image's active area is empty"));
    }
    let to_srgb = camera_to_srgb(raw);
    let pixels = camera
        .into_iter()
        .map(|rgb| to_srgb * rgb * exposure)
        .collect();
    Ok(LinearImage {
        width: u32::try_from(out_w).unwrap_or(u32::MAX),
        height: u32::try_from(out_h).unwrap_or(u32::MAX),
        pixels,
        saturated,
        sample_format: SampleFormat::Raw,
        color_space: ColorSpace::Linear,
        // One raw code over the narrowest range. White balance and the colour matrix scale it
        // per channel by up to their rows' absolute sums (a few); a raw file's own noise, over
        // a code, dithers its rounding away in any case.
        code_step: CodeStep::Linear {
            step: exposure
                / (white - black.iter().copied().fold(f32::NEG_INFINITY, f32::max)).max(1e-6),
            lossy: false,
        },
    })
}

/// White balance then camera → linear sRGB, as one matrix.
fn camera_to_srgb(raw: &RawImage) -> Mat3 {
    let wb = Vec3::new(raw.wb_coeffs[0], raw.wb_coeffs[1], raw.wb_coeffs[2]);
    let wb = if wb.is_finite() && wb.min_element() > 0.0 {
        wb / wb.y
    } else {
        Vec3::ONE
    };
    let m = raw.xyz_to_cam;
    let xyz_to_cam = Mat3::from_cols(
        Vec3::new(m[0][0], m[1][0], m[2][0]),
        Vec3::new(m[0][1], m[1][1], m[2][1]),
        Vec3::new(m[0][2], m[1][2], m[2][2]),
    );
    let mut cam_from_srgb = xyz_to_cam * SRGB_TO_XYZ;
    // Rows normalised to sum 1: sRGB white is camera white once white-balanced.
    let rows = cam_from_srgb.transpose();
    let sums = Vec3::new(
        rows.x_axis.element_sum(),
        rows.y_axis.element_sum(),
        rows.z_axis.element_sum(),
    );
    let usable = sums.is_finite() && sums.abs().min_element() > 1e-6;
    if usable {
        cam_from_srgb = Mat3::from_cols(
            rows.x_axis / sums.x,
            rows.y_axis / sums.y,
            rows.z_axis / sums.z,
        )
        .transpose();
    }
    let srgb_from_cam = if usable && cam_from_srgb.determinant().abs() > 1e-9 {
        cam_from_srgb.inverse()
    } else {
        // No usable matrix: take the camera's RGB as it is.
        Mat3::IDENTITY
    };
    srgb_from_cam * Mat3::from_diagonal(wb)
}
