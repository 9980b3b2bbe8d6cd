//! Rendered images: linear radiance with coverage, as OpenEXR (exact) and sRGB PNG (preview).

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use exr::prelude::{ReadChannels, ReadLayers, SpecificChannels, WritableImage};
use thiserror::Error;

use crate::atomic;

/// An image of linear radiance per RGB channel with alpha = pixel coverage (0 outside the
/// object, 1 fully inside, fractional on an anti-aliased silhouette), row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct RgbaImage {
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// `pixels[row · width + column]`: R, G, B radiance and coverage.
    pub pixels: Vec<[f32; 4]>,
}

/// Why an image could not be read or written.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ImageFileError {
    /// The file system refused, or the encoder failed.
    #[error("{}: {error}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What happened.
        error: std::io::Error,
    },
    /// The file is not a readable RGB(A) OpenEXR.
    #[error("{}: not a readable RGB(A) OpenEXR image: {error}", path.display())]
    Exr {
        /// The file.
        path: PathBuf,
        /// What the decoder said.
        error: exr::error::Error,
    },
    /// The image is larger than [`crate::input_file::MAX_IMAGE_PIXELS`] or
    /// [`crate::input_file::MAX_IMAGE_SIDE_PX`] allow (checked from the headers, before decoding).
    #[error("{}: {problem}", path.display())]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Which window and which limit.
        problem: String,
    },
    /// The image has a zero side or a pixel count that does not match its size.
    #[error("{}: {width} × {height} image with {pixels} pixels", path.display())]
    Shape {
        /// The file.
        path: PathBuf,
        /// Columns.
        width: u32,
        /// Rows.
        height: u32,
        /// Pixels held.
        pixels: usize,
    },
}

impl RgbaImage {
    /// A transparent black image.
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            pixels: vec![[0.0; 4]; width as usize * height as usize],
        }
    }

    /// The pixel at `column`, `row` (row 0 at the top).
    ///
    /// # Panics
    /// If the position is outside the image.
    pub fn pixel(&self, column: u32, row: u32) -> [f32; 4] {
        assert!(column < self.width && row < self.height);
        self.pixels[(row * self.width + column) as usize]
    }

    /// Writes a 32-bit float RGBA OpenEXR (alpha = coverage), atomically.
    ///
    /// # Errors
    /// [`ImageFileError`] naming `path`.
    pub fn write_exr(&self, path: impl AsRef<Path>) -> Result<(), ImageFileError> {
        let path = path.as_ref();
        self.check_shape(path)?;
        let width = self.width as usize;
        let channels = SpecificChannels::rgba(|position: exr::math::Vec2<usize>| {
            let [r, g, b, a] = self.pixels[position.y() * width + position.x()];
            (r, g, b, a)
        });
        let image = exr::image::Image::from_channels((width, self.height as usize), channels);
        atomic::write_file(path, |file| {
            let mut writer = BufWriter::new(file);
            image
                .write()
                .to_buffered(&mut writer)
                .map_err(std::io::Error::other)?;
            writer.flush()
        })
        .map_err(|error| ImageFileError::Io {
            path: path.to_owned(),
            error,
        })
    }

    /// Reads the first RGB(A) layer of an OpenEXR file as f32; a missing alpha channel reads
    /// as 1 (fully covered).
    ///
    /// # Errors
    /// [`ImageFileError::Exr`] for an unreadable or non-RGB file;
    /// [`ImageFileError::Io`] for a missing or special file or one over
    /// [`crate::input_file::MAX_INPUT_FILE_BYTES`]; [`ImageFileError::TooLarge`] for a data or
    /// display window over the image limits.
    pub fn read_exr(path: impl AsRef<Path>) -> Result<Self, ImageFileError> {
        let path = path.as_ref();
        let io_error = |error| ImageFileError::Io {
            path: path.to_owned(),
            error,
        };
        let file = crate::input_file::open_regular(path, crate::input_file::MAX_INPUT_FILE_BYTES)
            .map_err(io_error)?;
        let mut reader = std::io::BufReader::new(file);
        crate::input_file::check_exr_windows(&mut reader).map_err(|error| match error {
            crate::input_file::ExrHeaderError::Exr(error) => ImageFileError::Exr {
                path: path.to_owned(),
                error,
            },
            crate::input_file::ExrHeaderError::TooLarge(problem) => ImageFileError::TooLarge {
                path: path.to_owned(),
                problem,
            },
        })?;
        std::io::Seek::rewind(&mut reader).map_err(io_error)?;
        let image = exr::prelude::read()
            .no_deep_data()
            .largest_resolution_level()
            .rgba_channels(
                |resolution, _| {
                    let (width, height) = (resolution.width(), resolution.height());
                    (width, vec![[0.0f32; 4]; width * height])
                },
                |(width, pixels), position, (r, g, b, a): (f32, f32, f32, f32)| {
                    pixels[position.y() * *width + position.x()] = [r, g, b, a];
                },
            )
            .first_valid_layer()
            .all_attributes()
            .from_buffered(reader)
            .map_err(|error| ImageFileError::Exr {
                path: path.to_owned(),
                error,
            })?;
        let size = image.layer_data.size;
        let (_, pixels) = image.layer_data.channel_data.pixels;
        let result = Self {
            width: size.width() as u32,
            height: size.height() as u32,
            pixels,
        };
        result.check_shape(path)?;
        Ok(result)
    }

    /// 8-bit sRGB RGBA: linear RGB clamped to [0, 1] and encoded with the sRGB curve
    /// ([`linear_to_srgb`]), alpha = coverage · 255. The colour is radiance over black (not
    /// divided by coverage), as the path-traced previews are.
    pub fn to_srgb8(&self) -> Vec<[u8; 4]> {
        let byte = |x: f32| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
        self.pixels
            .iter()
            .map(|&[r, g, b, a]| {
                [
                    byte(linear_to_srgb(r)),
                    byte(linear_to_srgb(g)),
                    byte(linear_to_srgb(b)),
                    byte(a),
                ]
            })
            .collect()
    }

    /// Writes an 8-bit sRGB PNG preview: the colours of [`RgbaImage::to_srgb8`], opaque (the
    /// radiance is already over black, as in the path-traced previews; a straight alpha would
    /// darken silhouettes twice), atomically.
    ///
    /// # Errors
    /// [`ImageFileError`] naming `path`.
    pub fn write_png_srgb(&self, path: impl AsRef<Path>) -> Result<(), ImageFileError> {
        let path = path.as_ref();
        self.check_shape(path)?;
        let bytes: Vec<u8> = self
            .to_srgb8()
            .into_iter()
            .flat_map(|[r, g, b, _]| [r, g, b])
            .collect();
        atomic::write_file(path, |file| {
            let mut writer = BufWriter::new(file);
            image::write_buffer_with_format(
                &mut writer,
                &bytes,
                self.width,
                self.height,
                image::ExtendedColorType::Rgb8,
                image::ImageFormat::Png,
            )
            .map_err(std::io::Error::other)?;
            writer.flush()
        })
        .map_err(|error| ImageFileError::Io {
            path: path.to_owned(),
            error,
        })
    }

    fn check_shape(&self, path: &Path) -> Result<(), ImageFileError> {
        if self.width == 0
            || self.height == 0
            || self.pixels.len() != self.width as usize * self.height as usize
        {
            return Err(ImageFileError::Shape {
                path: path.to_owned(),
                width: self.width,
                height: self.height,
                pixels: self.pixels.len(),
            });
        }
        Ok(())
    }
}

/// The exact sRGB decoding curve (IEC 61966-2-1) for an encoded value in [0, 1]; values outside
/// are mapped sign-symmetrically with the same formula.
pub fn srgb_to_linear(encoded: f32) -> f32 {
    let c = encoded.abs();
    let linear = if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    };
    linear.copysign(encoded)
}

/// The sRGB transfer function (IEC 61966-2-1) of a linear value in [0, 1] (clamped).
pub fn linear_to_srgb(linear: f32) -> f32 {
    let x = linear.clamp(0.0, 1.0);
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gradient() -> RgbaImage {
        let mut image = RgbaImage::new(7, 3);
        for (index, pixel) in image.pixels.iter_mut().enumerate() {
            let t = index as f32 / 20.0;
            *pixel = [t, 0.5 * t, 2.0 * t, (index % 3) as f32 / 2.0];
        }
        image
    }

    #[test]
    fn exr_round_trip_is_exact() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.exr");
        let image = gradient();
        image.write_exr(&path).unwrap();
        assert_eq!(RgbaImage::read_exr(&path).unwrap(), image);
    }

    #[test]
    fn png_preview_is_written_and_readable() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.png");
        let image = gradient();
        image.write_png_srgb(&path).unwrap();
        let decoded = image::open(&path).unwrap();
        assert_eq!(decoded.color(), image::ColorType::Rgb8);
        let decoded = decoded.to_rgb8();
        assert_eq!(decoded.dimensions(), (7, 3));
        let expected = image.to_srgb8();
        for (ours, theirs) in expected.iter().zip(decoded.pixels()) {
            assert_eq!(ours[..3], theirs.0);
        }
    }

    #[test]
    fn srgb_curve_ends_and_continuity() {
        assert_eq!(linear_to_srgb(0.0), 0.0);
        assert!((linear_to_srgb(1.0) - 1.0).abs() < 1e-6);
        assert!((linear_to_srgb(0.18) - 0.4613).abs() < 1e-3);
        let below = linear_to_srgb(0.003_130_8);
        let above = linear_to_srgb(0.003_130_9);
        assert!((above - below).abs() < 1e-5, "{below} vs {above}");
        assert_eq!(linear_to_srgb(-1.0), 0.0);
        assert_eq!(linear_to_srgb(7.0), linear_to_srgb(1.0));
    }

    #[test]
    fn bad_files_name_the_path() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("not.exr");
        std::fs::write(&path, b"hello").unwrap();
        let message = RgbaImage::read_exr(&path).unwrap_err().to_string();
        assert!(message.contains("not.exr"), "{message}");
        let empty = RgbaImage::new(0, 0);
        let message = empty
            .write_exr(dir.path().join("e.exr"))
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("e.exr") && message.contains("0 × 0"),
            "{message}"
        );
        assert!(!dir.path().join("e.exr").exists());
    }
}
