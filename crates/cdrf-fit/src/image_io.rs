//! Loading photographs as linear radiance.
//!
//! [`load_linear_image`] decodes one file into a [`LinearImage`]: linear RGB radiance per pixel,
//! multiplied by an exposure factor, plus a flag per pixel saying whether the camera clipped it.
//! It decodes one image at a time and converts the decoder's buffer in a single pass.
//!
//! # Formats and default colour spaces
//! The format is recognised from the file's first bytes (the extension only decides which
//! error to give when the content is not recognised).
//!
//! | format | samples | default colour space | saturated when |
//! |---|---|---|---|
//! | OpenEXR (`.exr`) | half / float / uint | linear | never |
//! | TIFF (`.tif`, `.tiff`) | 32-bit float | linear | never |
//! | TIFF, PNG (`.png`) | 16-bit | **linear** | a channel is 65535 |
//! | TIFF, PNG | 8-bit | sRGB | a channel is 255 |
//! | JPEG (`.jpg`, `.jpeg`) | 8-bit | sRGB | a channel is ≥ 250 ([`JPEG_SATURATION_CODE`]) |
//! | DNG (`.dng`, by extension; feature `raw`) | the sensor's | linear (developed: `crate::camera_raw`) | a sample reaches the white level |
//!
//! Integer files that hold a sensor's codes as they are take [`SensorLevels`] ([`Decoding`]):
//! black and white level, values below black kept negative.
//!
//! 16-bit files default to **linear** because that is how measurement photographs are made: a
//! raw converter writing 16 bits for analysis (`dcraw -4`, `darktable`/RawTherapee with a
//! linear output profile) writes linear values, while a gamma-encoded export is almost always
//! 8-bit. A 16-bit file that *is* sRGB-encoded (a photo editor's export) must say
//! `color_space = "srgb"` in the manifest; the tool cannot tell from the pixels.
//!
//! sRGB decoding is the exact piecewise IEC 61966-2-1 curve: `c / 12.92` for `c ≤ 0.04045`,
//! `((c + 0.055) / 1.055)^2.4` above (applied sign-symmetrically to float samples, which may be
//! negative or above 1). Primaries are taken as given: an EXR's `chromaticities` attribute is not
//! applied.
//!
//! # Channels
//! - Grey images give `R = G = B`.
//! - Alpha is ignored: colour is used as stored, not divided by alpha (a photograph has none;
//!   a renderer's alpha is coverage, and its colour is already what the camera saw).
//! - OpenEXR: the first layer with `R`, `G` and `B` channels is read (luminance-only `Y` files are
//!   not supported); pixels are placed in the display window (outside the data window: 0).
//!   Data and display windows are checked from the headers before anything is allocated: at most
//!   65536 px a side and 16384² pixels ([`cdrf_core::input_file`]); a file must be a regular
//!   file of at most 1 GiB.
//!
//! # Saturation
//! A pixel is saturated if any colour channel of its *stored integer code* is at the top of the
//! format's range (before the colour-space decode and the exposure). JPEG's lossy compression
//! spreads a clipped region over codes 250…255, so JPEG uses a lower threshold. A 16-bit file
//! holding 12- or 14-bit values that were not scaled to the full range never reaches 65535:
//! such clipping cannot be seen here. Float images are never flagged.
//!
//! # Non-finite values
//! A NaN or infinite sample (float images only) is an error ([`ImageError::NonFinite`]) that says
//! how many there are and where the first one is: the fitter must not average them silently.

use std::fs::File;
use std::io::{self, BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use glam::Vec3;
use image::{DynamicImage, ImageFormat};

/// JPEG code value at or above which a channel counts as clipped (see the module docs).
pub const JPEG_SATURATION_CODE: u8 = 250;

/// A raw-like integer file's code levels: `linear = (code − black) / (white − black)`, and a
/// channel at or above `white` is clipped. For 8/16-bit linear files that hold a sensor's codes
/// as they are (a 14-bit raw with a black level in a 16-bit PNG, say).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SensorLevels {
    /// Code of no light (the sensor's offset).
    pub black: u16,
    /// Code at which the sensor clips (> `black`).
    pub white: u16,
}

/// How to turn a file's stored values into linear radiance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Decoding {
    /// The transfer curve; `None`: the format's default ([`ColorSpace::default_for`]).
    pub color_space: Option<ColorSpace>,
    /// Factor the linear values are multiplied by (> 0).
    pub exposure: f32,
    /// Raw-like code levels (integer files in the linear colour space only).
    pub levels: Option<SensorLevels>,
}

impl Default for Decoding {
    fn default() -> Self {
        Self {
            color_space: None,
            exposure: 1.0,
            levels: None,
        }
    }
}

/// How the stored values relate to linear radiance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ColorSpace {
    /// Values are proportional to radiance.
    Linear,
    /// Values are encoded with the sRGB transfer curve (most 8-bit images).
    Srgb,
}

impl ColorSpace {
    /// The colour space assumed for a file whose samples are stored as `sample_format` when the
    /// manifest does not say: linear for float and 16-bit samples, sRGB for 8-bit.
    pub fn default_for(sample_format: SampleFormat) -> Self {
        match sample_format {
            SampleFormat::U8 => Self::Srgb,
            SampleFormat::U16 | SampleFormat::Float | SampleFormat::Raw => Self::Linear,
        }
    }

    /// The name used in the manifest: `"linear"` or `"srgb"`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Linear => "linear",
            Self::Srgb => "srgb",
        }
    }
}

/// How a file stored its samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SampleFormat {
    /// 8-bit integers (PNG, JPEG, TIFF).
    U8,
    /// 16-bit integers (PNG, TIFF).
    U16,
    /// Floating point (OpenEXR half/float, 32-bit float TIFF).
    Float,
    /// A camera's raw sensor data (RAW, DNG), developed linearly.
    Raw,
}

/// A decoded image: linear RGB radiance, row-major, row 0 at the top.
///
/// Invariant: `pixels.len() == saturated.len() == width as usize * height as usize`.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Linear RGB per pixel, already multiplied by the exposure; index `y * width + x`.
    pub pixels: Vec<Vec3>,
    /// Whether the camera clipped the pixel (any channel at the format's maximum code);
    /// always `false` for float images.
    pub saturated: Vec<bool>,
    /// How the file stored its samples.
    pub sample_format: SampleFormat,
    /// The transfer curve that was decoded (the requested one, or the format's default).
    pub color_space: ColorSpace,
    /// How wide one of the file's codes is in these linear units.
    pub code_step: CodeStep,
}

/// How a file's integer codes round its values, in its decoded linear units (exposure included).
///
/// Rounding to codes shifts a value by up to half a step; a sensor noise of more than about
/// half a step dithers that away over many pixels, a noiseless image keeps it. JPEG's
/// compression shifts values by about as much again, noise or not. The fit counts both as
/// bias in its confidence band ([`crate::fit::NodeBand`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CodeStep {
    /// Float samples: no step worth counting.
    Float,
    /// Linear codes, every step `step` wide.
    Linear {
        /// The width of one code.
        step: f32,
        /// A lossy file (JPEG).
        lossy: bool,
    },
    /// sRGB-encoded codes `0..=max_code`, decoded and multiplied by `exposure`.
    Srgb {
        /// The largest code (255 for 8-bit files).
        max_code: f32,
        /// The factor the decoded values were multiplied by.
        exposure: f32,
        /// A lossy file (JPEG).
        lossy: bool,
    },
}

impl CodeStep {
    /// The width of the code step at `value`: the step above the code `value` decodes from (at
    /// the top code, the step below it).
    pub fn at(self, value: f32) -> f32 {
        match self {
            Self::Float => 0.0,
            Self::Linear { step, .. } => step,
            Self::Srgb {
                max_code, exposure, ..
            } => {
                let encoded = linear_to_srgb((value / exposure).clamp(0.0, 1.0));
                let code = (encoded * max_code).round().min(max_code - 1.0);
                exposure
                    * (srgb_to_linear((code + 1.0) / max_code) - srgb_to_linear(code / max_code))
            }
        }
    }

    /// [`Self::at`] per channel.
    pub fn at_rgb(self, value: Vec3) -> Vec3 {
        Vec3::new(self.at(value.x), self.at(value.y), self.at(value.z))
    }

    /// Whether the file was compressed lossily (JPEG).
    pub fn lossy(self) -> bool {
        match self {
            Self::Float => false,
            Self::Linear { lossy, .. } | Self::Srgb { lossy, .. } => lossy,
        }
    }

    /// The codes of an integer file with `max_code` codes in `color_space`.
    fn of_codes(max_code: f32, color_space: ColorSpace, exposure: f32, lossy: bool) -> Self {
        match color_space {
            ColorSpace::Linear => Self::Linear {
                step: exposure / max_code,
                lossy,
            },
            ColorSpace::Srgb => Self::Srgb {
                max_code,
                exposure,
                lossy,
            },
        }
    }
}

impl LinearImage {
    /// The radiance at column `x`, row `y` (row 0 at the top).
    ///
    /// # Panics
    /// If `x >= width` or `y >= height`.
    pub fn pixel(&self, x: u32, y: u32) -> Vec3 {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside a {} × {} image",
            self.width,
            self.height
        );
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// How many pixels are flagged as saturated.
    pub fn saturated_count(&self) -> usize {
        self.saturated.iter().filter(|&&s| s).count()
    }
}

/// Why an image could not be loaded. Every message starts with the file's path.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ImageError {
    /// The file does not exist.
    #[error("{}: no such file", path.display())]
    NotFound {
        /// The file.
        path: PathBuf,
    },
    /// The file exists but could not be read (permissions, a folder, an I/O error).
    #[error("{}: cannot read: {error}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        error: io::Error,
    },
    /// Not a format (or a variant of one) that this module decodes.
    #[error(
        "{}: unsupported image: {what}; supported: OpenEXR (.exr), PNG (.png), JPEG (.jpg, \
         .jpeg) and TIFF (.tif, .tiff), 8/16-bit or float, grey or RGB(A); camera RAW as DNG (.dng)",
        path.display()
    )]
    Unsupported {
        /// The file.
        path: PathBuf,
        /// What was found instead.
        what: String,
    },
    /// The file looks like a supported format but is corrupt, truncated or has no pixels.
    #[error("{}: cannot decode {format} (corrupt or truncated file?): {message}", path.display())]
    Decode {
        /// The file.
        path: PathBuf,
        /// The format the file claimed to be (`"PNG"`, `"OpenEXR"`, …).
        format: &'static str,
        /// The decoder's message.
        message: String,
    },
    /// The image is larger than the documented limits (checked before decoding; see
    /// [`cdrf_core::input_file`]: 65536 px a side, 16384² pixels).
    #[error("{}: {problem}", path.display())]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Which window or size, and the limit.
        problem: String,
    },
    /// Some pixels are NaN or infinite.
    #[error(
        "{}: {count} pixel(s) are NaN or infinite (first at column {first_x}, row {first_y}, \
         row 0 at the top); fix or mask them before fitting",
        path.display()
    )]
    NonFinite {
        /// The file.
        path: PathBuf,
        /// How many pixels have at least one non-finite channel.
        count: usize,
        /// Column of the first one in row-major order.
        first_x: u32,
        /// Row of the first one (row 0 at the top).
        first_y: u32,
    },
    /// Sensor levels were given for a file they cannot apply to.
    #[error("{}: black_level / white_level: {problem}", path.display())]
    Levels {
        /// The file.
        path: PathBuf,
        /// Why they do not apply.
        problem: String,
    },
    /// The exposure factor is not a finite number > 0.
    #[error("{}: exposure = {exposure}: must be a finite number > 0", path.display())]
    InvalidExposure {
        /// The file.
        path: PathBuf,
        /// The factor given.
        exposure: f32,
    },
}

/// Loads `path` as linear radiance, multiplied by `exposure`.
///
/// `color_space: None` uses the format's default ([`ColorSpace::default_for`]; see the module
/// docs for the table).
///
/// # Errors
/// [`ImageError`]: the file is missing or unreadable, not a supported format, corrupt,
/// truncated or empty, holds NaN or infinite values, or `exposure` is not a finite number > 0.
pub fn load_linear_image(
    path: &Path,
    color_space: Option<ColorSpace>,
    exposure: f32,
) -> Result<LinearImage, ImageError> {
    load_linear_image_with(
        path,
        &Decoding {
            color_space,
            exposure,
            levels: None,
        },
    )
}

/// Like [`load_linear_image`], with raw-like [`SensorLevels`] where `decoding` gives them.
///
/// # Errors
/// As [`load_linear_image`]; also [`ImageError::Levels`] when levels are given for a float
/// file, for an sRGB-encoded one, or exceed an 8-bit file's codes.
pub fn load_linear_image_with(path: &Path, decoding: &Decoding) -> Result<LinearImage, ImageError> {
    let Decoding {
        color_space,
        exposure,
        levels,
    } = *decoding;
    if !(exposure.is_finite() && exposure > 0.0) {
        return Err(ImageError::InvalidExposure {
            path: path.to_path_buf(),
            exposure,
        });
    }
    if is_camera_raw(path) {
        return load_camera_raw(path, color_space, exposure, levels);
    }
    let mut file =
        cdrf_core::input_file::open_regular(path, cdrf_core::input_file::MAX_INPUT_FILE_BYTES)
            .map_err(|error| read_error(path, error))?;
    let mut magic = [0_u8; 8];
    let magic_len = read_prefix(&mut file, &mut magic).map_err(|error| read_error(path, error))?;
    let magic = &magic[..magic_len];
    file.seek(SeekFrom::Start(0))
        .map_err(|error| read_error(path, error))?;
    let mut reader = BufReader::new(file);
    if matches!(detect(magic), Some(Detected::Exr)) {
        // The windows decide the allocation: check them from the headers first.
        cdrf_core::input_file::check_exr_windows(&mut reader).map_err(|error| match error {
            cdrf_core::input_file::ExrHeaderError::TooLarge(problem) => ImageError::TooLarge {
                path: path.to_path_buf(),
                problem,
            },
            cdrf_core::input_file::ExrHeaderError::Exr(error) => exr_error(path, error),
            _ => ImageError::Decode {
                path: path.to_path_buf(),
                format: "OpenEXR",
                message: error.to_string(),
            },
        })?;
        reader
            .seek(SeekFrom::Start(0))
            .map_err(|error| read_error(path, error))?;
    }

    let (image, format) = match detect(magic) {
        Some(Detected::Exr) => {
            if levels.is_some() {
                return Err(levels_error(
                    path,
                    "they apply to 8/16-bit integer files; this is float OpenEXR",
                ));
            }
            (decode_exr(path, reader, color_space, exposure)?, "OpenEXR")
        }
        Some(Detected::Image(format)) => (
            decode_with_image(path, reader, format, color_space, exposure, levels)?,
            format_name(format),
        ),
        None => return Err(unrecognised(path, magic)),
    };
    // Decoders reject these already; checked here so that nothing downstream divides by 0.
    if image.width == 0 || image.height == 0 {
        return Err(ImageError::Decode {
            path: path.to_path_buf(),
            format,
            message: format!("the image is empty ({} × {} px)", image.width, image.height),
        });
    }
    check_finite(path, &image)?;
    Ok(image)
}

/// Camera makers' own RAW formats: refused with a pointer to DNG (see `load_camera_raw`).
const VENDOR_RAW_EXTENSIONS: &[&str] = &[
    "cr2", "cr3", "crw", "nef", "nrw", "arw", "srf", "sr2", "raf", "orf", "rw2", "pef", "srw",
    "erf", "3fr", "iiq", "mos", "mef", "kdc", "dcr",
];

fn extension(path: &Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
}

/// DNG is TIFF inside, but its first image is usually a small preview: it is recognised by its
/// extension, like the vendor formats.
fn is_camera_raw(path: &Path) -> bool {
    extension(path).is_some_and(|e| e == "dng" || VENDOR_RAW_EXTENSIONS.contains(&e.as_str()))
}

fn load_camera_raw(
    path: &Path,
    color_space: Option<ColorSpace>,
    exposure: f32,
    levels: Option<SensorLevels>,
) -> Result<LinearImage, ImageError> {
    if levels.is_some() {
        return Err(levels_error(
            path,
            "a camera RAW file states its own levels; leave them out",
        ));
    }
    if color_space == Some(ColorSpace::Srgb) {
        return Err(ImageError::Unsupported {
            path: path.to_path_buf(),
            what: "color_space = \"srgb\" for a camera RAW file (it is decoded linearly)"
                .to_owned(),
        });
    }
    #[cfg(feature = "raw")]
    {
        let bytes =
            cdrf_core::input_file::read_regular(path, cdrf_core::input_file::MAX_INPUT_FILE_BYTES)
                .map_err(|error| read_error(path, error))?;
        crate::camera_raw::decode_raw(path, bytes, exposure)
    }
    #[cfg(not(feature = "raw"))]
    {
        let _ = exposure;
        Err(ImageError::Unsupported {
            path: path.to_path_buf(),
            what: "a camera RAW file, and this cdrf-fit was built without the `raw` feature"
                .to_owned(),
        })
    }
}

/// The exact sRGB curves, decoding and encoding (cdrf-core's, re-exported for this module's
/// users).
pub use cdrf_core::image_file::{linear_to_srgb, srgb_to_linear};

fn read_error(path: &Path, error: io::Error) -> ImageError {
    if error.kind() == io::ErrorKind::NotFound {
        ImageError::NotFound {
            path: path.to_path_buf(),
        }
    } else {
        ImageError::Read {
            path: path.to_path_buf(),
            error,
        }
    }
}

/// Reads up to `buf.len()` bytes (fewer only at the end of the file).
fn read_prefix(file: &mut File, buf: &mut [u8]) -> io::Result<usize> {
    let mut filled = 0;
    while filled < buf.len() {
        match file.read(&mut buf[filled..]) {
            Ok(0) => break,
            Ok(n) => filled += n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(filled)
}

enum Detected {
    Exr,
    Image(ImageFormat),
}

fn detect(magic: &[u8]) -> Option<Detected> {
    if magic.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        Some(Detected::Exr)
    } else if magic.starts_with(b"\x89PNG\r\n\x1a\n") {
        Some(Detected::Image(ImageFormat::Png))
    } else if magic.starts_with(&[0xff, 0xd8, 0xff]) {
        Some(Detected::Image(ImageFormat::Jpeg))
    } else if magic.starts_with(b"II*\0") || magic.starts_with(b"MM\0*") {
        Some(Detected::Image(ImageFormat::Tiff))
    } else {
        None
    }
}

/// The error for content that is none of the supported formats.
fn unrecognised(path: &Path, magic: &[u8]) -> ImageError {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let claimed = match extension.as_deref() {
        Some("exr") => Some("OpenEXR"),
        Some("png") => Some("PNG"),
        Some("jpg" | "jpeg") => Some("JPEG"),
        Some("tif" | "tiff") => Some("TIFF"),
        _ => None,
    };
    let path = path.to_path_buf();
    match (claimed, image::guess_format(magic)) {
        (_, Ok(other)) => ImageError::Unsupported {
            path,
            what: format!("the file is {other:?}"),
        },
        (Some(format), Err(_)) => ImageError::Decode {
            path,
            format,
            message: if magic.len() < 8 {
                format!("the file is only {} bytes long", magic.len())
            } else {
                format!("the file does not start with the {format} signature")
            },
        },
        (None, Err(_)) => ImageError::Unsupported {
            path,
            what: match extension {
                Some(ext) => format!("unrecognised content with extension .{ext}"),
                None => "unrecognised content and no extension".to_owned(),
            },
        },
    }
}

/// Decodes OpenEXR with the `exr` crate straight into `Vec3`s (the `image` crate's decoder
/// goes through an extra interleaved byte buffer).
fn decode_exr(
    path: &Path,
    reader: BufReader<File>,
    color_space: Option<ColorSpace>,
    exposure: f32,
) -> Result<LinearImage, ImageError> {
    use exr::prelude::{ReadChannels, ReadLayers};

    struct Pixels {
        width: usize,
        data: Vec<Vec3>,
    }
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |size, _channels| Pixels {
                width: size.width(),
                data: vec![Vec3::ZERO; size.area()],
            },
            |pixels: &mut Pixels, position, (r, g, b, _a): (f32, f32, f32, f32)| {
                pixels.data[position.y() * pixels.width + position.x()] = Vec3::new(r, g, b);
            },
        )
        .first_valid_layer()
        .all_attributes()
        .pedantic()
        .from_buffered(reader)
        .map_err(|error| exr_error(path, error))?;

    let layer = image.layer_data;
    let display = image.attributes.display_window;
    let (width, height) = (display.size.width(), display.size.height());
    let mut data = layer.channel_data.pixels.data;
    let offset = layer.attributes.layer_position - display.position;
    if offset.x() != 0 || offset.y() != 0 || layer.size != display.size {
        data = place_in_window(
            &data,
            layer.size.width(),
            offset.x(),
            offset.y(),
            width,
            height,
        );
    }

    let color_space = color_space.unwrap_or(ColorSpace::default_for(SampleFormat::Float));
    for value in &mut data {
        *value = decode_float(*value, color_space) * exposure;
    }
    Ok(LinearImage {
        width: to_u32(width),
        height: to_u32(height),
        saturated: vec![false; data.len()],
        pixels: data,
        sample_format: SampleFormat::Float,
        code_step: CodeStep::Float,
        color_space,
    })
}

/// Copies a data window (`data`, `data_width` wide, at `(dx, dy)` relative to the display
/// window) into a zero-filled `width` × `height` display window.
fn place_in_window(
    data: &[Vec3],
    data_width: usize,
    dx: i32,
    dy: i32,
    width: usize,
    height: usize,
) -> Vec<Vec3> {
    let mut out = vec![Vec3::ZERO; width * height];
    if data_width == 0 {
        return out;
    }
    for (row, line) in data.chunks_exact(data_width).enumerate() {
        let y = row as i64 + i64::from(dy);
        if y < 0 || y >= height as i64 {
            continue;
        }
        for (column, &value) in line.iter().enumerate() {
            let x = column as i64 + i64::from(dx);
            if x >= 0 && x < width as i64 {
                out[y as usize * width + x as usize] = value;
            }
        }
    }
    out
}

fn to_u32(n: usize) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}

fn exr_error(path: &Path, error: exr::error::Error) -> ImageError {
    let path = path.to_path_buf();
    match error {
        exr::error::Error::NotSupported(what) => ImageError::Unsupported {
            path,
            what: format!("OpenEXR feature not supported: {what}"),
        },
        exr::error::Error::Io(error) if error.kind() != io::ErrorKind::UnexpectedEof => {
            ImageError::Read { path, error }
        }
        other => ImageError::Decode {
            path,
            format: "OpenEXR",
            message: other.to_string(),
        },
    }
}

fn format_name(format: ImageFormat) -> &'static str {
    match format {
        ImageFormat::Png => "PNG",
        ImageFormat::Jpeg => "JPEG",
        ImageFormat::Tiff => "TIFF",
        _ => "image",
    }
}

fn image_error(path: &Path, format: ImageFormat, error: image::ImageError) -> ImageError {
    let path = path.to_path_buf();
    match error {
        image::ImageError::Unsupported(e) => ImageError::Unsupported {
            path,
            what: e.to_string(),
        },
        image::ImageError::IoError(error) if error.kind() != io::ErrorKind::UnexpectedEof => {
            ImageError::Read { path, error }
        }
        other => ImageError::Decode {
            path,
            format: format_name(format),
            message: other.to_string(),
        },
    }
}

fn levels_error(path: &Path, problem: &str) -> ImageError {
    ImageError::Levels {
        path: path.to_path_buf(),
        problem: problem.to_owned(),
    }
}

/// Decodes PNG, JPEG and TIFF with the `image` crate and converts its buffer in one pass.
fn decode_with_image(
    path: &Path,
    reader: BufReader<File>,
    format: ImageFormat,
    color_space: Option<ColorSpace>,
    exposure: f32,
    levels: Option<SensorLevels>,
) -> Result<LinearImage, ImageError> {
    let decoded = image::ImageReader::with_format(reader, format)
        .decode()
        .map_err(|error| image_error(path, format, error))?;
    let (width, height) = (decoded.width(), decoded.height());
    let lossy = format == ImageFormat::Jpeg;
    let max_u8 = if lossy { JPEG_SATURATION_CODE } else { u8::MAX };
    if let Some(levels) = levels {
        if color_space == Some(ColorSpace::Srgb) {
            return Err(levels_error(
                path,
                "they apply to linear files, not sRGB-encoded ones",
            ));
        }
        let (top, kind) = match &decoded {
            DynamicImage::ImageLuma8(_)
            | DynamicImage::ImageLumaA8(_)
            | DynamicImage::ImageRgb8(_)
            | DynamicImage::ImageRgba8(_) => (u16::from(u8::MAX), "8-bit"),
            DynamicImage::ImageRgb32F(_) | DynamicImage::ImageRgba32F(_) => {
                return Err(levels_error(
                    path,
                    "they apply to 8/16-bit integer files; this is float",
                ));
            }
            _ => (u16::MAX, "16-bit"),
        };
        if levels.white > top {
            return Err(levels_error(
                path,
                &format!(
                    "white_level = {} is above the {kind} file's largest code {top}",
                    levels.white
                ),
            ));
        }
        return Ok(convert_levels(&decoded, levels, exposure, lossy));
    }
    let (pixels, saturated, sample_format, color_space) = match &decoded {
        DynamicImage::ImageLuma8(b) => convert_u8(b.as_raw(), 1, color_space, exposure, max_u8),
        DynamicImage::ImageLumaA8(b) => convert_u8(b.as_raw(), 2, color_space, exposure, max_u8),
        DynamicImage::ImageRgb8(b) => convert_u8(b.as_raw(), 3, color_space, exposure, max_u8),
        DynamicImage::ImageRgba8(b) => convert_u8(b.as_raw(), 4, color_space, exposure, max_u8),
        DynamicImage::ImageLuma16(b) => convert_u16(b.as_raw(), 1, color_space, exposure),
        DynamicImage::ImageLumaA16(b) => convert_u16(b.as_raw(), 2, color_space, exposure),
        DynamicImage::ImageRgb16(b) => convert_u16(b.as_raw(), 3, color_space, exposure),
        DynamicImage::ImageRgba16(b) => convert_u16(b.as_raw(), 4, color_space, exposure),
        DynamicImage::ImageRgb32F(b) => convert_f32(b.as_raw(), 3, color_space, exposure),
        DynamicImage::ImageRgba32F(b) => convert_f32(b.as_raw(), 4, color_space, exposure),
        other => {
            return Err(ImageError::Unsupported {
                path: path.to_path_buf(),
                what: format!("pixel type {:?}", other.color()),
            });
        }
    };
    let code_step = match sample_format {
        SampleFormat::U8 => CodeStep::of_codes(255.0, color_space, exposure, lossy),
        SampleFormat::U16 => CodeStep::of_codes(65535.0, color_space, exposure, lossy),
        SampleFormat::Float | SampleFormat::Raw => CodeStep::Float,
    };
    Ok(LinearImage {
        width,
        height,
        pixels,
        saturated,
        sample_format,
        color_space,
        code_step,
    })
}

type Converted = (Vec<Vec3>, Vec<bool>, SampleFormat, ColorSpace);

/// An integer image with raw-like levels: `(code − black) / (white − black) · exposure` (negative
/// below black: noise around the offset must not be clipped, or the dark mean is biased).
fn convert_levels(
    decoded: &DynamicImage,
    levels: SensorLevels,
    exposure: f32,
    lossy: bool,
) -> LinearImage {
    let scale = exposure / f32::from(levels.white - levels.black);
    let black = f32::from(levels.black);
    let decode = |code: u16| (f32::from(code) - black) * scale;
    // Checked by the caller: an 8-bit file's white level fits in a byte.
    let white_u8 = u8::try_from(levels.white).unwrap_or(u8::MAX);
    let from_u8 = |raw: &[u8], channels: usize| {
        let (p, s) = convert_integer(raw, channels, white_u8, |c: u8| decode(c.into()));
        (p, s, SampleFormat::U8)
    };
    let from_u16 = |raw: &[u16], channels: usize| {
        let (p, s) = convert_integer(raw, channels, levels.white, decode);
        (p, s, SampleFormat::U16)
    };
    let (pixels, saturated, sample_format) = match decoded {
        DynamicImage::ImageLuma8(b) => from_u8(b.as_raw(), 1),
        DynamicImage::ImageLumaA8(b) => from_u8(b.as_raw(), 2),
        DynamicImage::ImageRgb8(b) => from_u8(b.as_raw(), 3),
        DynamicImage::ImageRgba8(b) => from_u8(b.as_raw(), 4),
        DynamicImage::ImageLuma16(b) => from_u16(b.as_raw(), 1),
        DynamicImage::ImageLumaA16(b) => from_u16(b.as_raw(), 2),
        DynamicImage::ImageRgb16(b) => from_u16(b.as_raw(), 3),
        other => from_u16(other.to_rgba16().as_raw(), 4),
    };
    LinearImage {
        width: decoded.width(),
        height: decoded.height(),
        pixels,
        saturated,
        sample_format,
        color_space: ColorSpace::Linear,
        code_step: CodeStep::Linear { step: scale, lossy },
    }
}

fn convert_u8(
    raw: &[u8],
    channels: usize,
    color_space: Option<ColorSpace>,
    exposure: f32,
    saturation_code: u8,
) -> Converted {
    let color_space = color_space.unwrap_or(ColorSpace::default_for(SampleFormat::U8));
    // 256 codes: decode each once.
    let table: [f32; 256] =
        std::array::from_fn(|code| decode_code(code as f32 / 255.0, color_space, exposure));
    let (pixels, saturated) = convert_integer(raw, channels, saturation_code, |code| {
        table[usize::from(code)]
    });
    (pixels, saturated, SampleFormat::U8, color_space)
}

fn convert_u16(
    raw: &[u16],
    channels: usize,
    color_space: Option<ColorSpace>,
    exposure: f32,
) -> Converted {
    let color_space = color_space.unwrap_or(ColorSpace::default_for(SampleFormat::U16));
    let (pixels, saturated) = convert_integer(raw, channels, u16::MAX, |code| {
        decode_code(f32::from(code) / 65535.0, color_space, exposure)
    });
    (pixels, saturated, SampleFormat::U16, color_space)
}

/// Linear radiance of one normalised integer code (0..=1) in `color_space`, times `exposure`.
fn decode_code(encoded: f32, color_space: ColorSpace, exposure: f32) -> f32 {
    exposure
        * match color_space {
            ColorSpace::Linear => encoded,
            ColorSpace::Srgb => srgb_to_linear(encoded),
        }
}

/// Pixels of interleaved integer samples (grey when fewer than three channels) decoded by
/// `decode`, and whether any of a pixel's channels reaches `saturation_code`.
fn convert_integer<T: Copy + PartialOrd>(
    raw: &[T],
    channels: usize,
    saturation_code: T,
    decode: impl Fn(T) -> f32,
) -> (Vec<Vec3>, Vec<bool>) {
    let count = raw.len() / channels;
    let mut pixels = Vec::with_capacity(count);
    let mut saturated = Vec::with_capacity(count);
    for px in raw.chunks_exact(channels) {
        let rgb = if channels < 3 {
            [px[0]; 3]
        } else {
            [px[0], px[1], px[2]]
        };
        pixels.push(Vec3::new(decode(rgb[0]), decode(rgb[1]), decode(rgb[2])));
        saturated.push(rgb.iter().any(|&c| c >= saturation_code));
    }
    (pixels, saturated)
}

fn convert_f32(
    raw: &[f32],
    channels: usize,
    color_space: Option<ColorSpace>,
    exposure: f32,
) -> Converted {
    let color_space = color_space.unwrap_or(ColorSpace::default_for(SampleFormat::Float));
    let pixels: Vec<Vec3> = raw
        .chunks_exact(channels)
        .map(|px| decode_float(Vec3::new(px[0], px[1], px[2]), color_space) * exposure)
        .collect();
    let saturated = vec![false; pixels.len()];
    (pixels, saturated, SampleFormat::Float, color_space)
}

fn decode_float(value: Vec3, color_space: ColorSpace) -> Vec3 {
    match color_space {
        ColorSpace::Linear => value,
        ColorSpace::Srgb => Vec3::new(
            srgb_to_linear(value.x),
            srgb_to_linear(value.y),
            srgb_to_linear(value.z),
        ),
    }
}

fn check_finite(path: &Path, image: &LinearImage) -> Result<(), ImageError> {
    if image.sample_format != SampleFormat::Float {
        return Ok(());
    }
    let mut bad = image
        .pixels
        .iter()
        .enumerate()
        .filter(|(_, p)| !p.is_finite());
    let Some((first, _)) = bad.next() else {
        return Ok(());
    };
    let width = image.width as usize;
    Err(ImageError::NonFinite {
        path: path.to_path_buf(),
        count: 1 + bad.count(),
        first_x: to_u32(first % width),
        first_y: to_u32(first / width),
    })
}
