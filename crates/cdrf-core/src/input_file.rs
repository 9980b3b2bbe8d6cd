//! Reading input files within documented limits, so that no input makes a tool read forever,
//! allocate without bound or follow a path out of its folder.
//!
//! | what | limit |
//! |---|---|
//! | any file a tool reads (mesh, glTF buffer, LUT, image, view correction) | a regular file (not a device, FIFO or folder) of at most [`MAX_INPUT_FILE_BYTES`] (1 GiB) |
//! | a TOML file (scene, manifest, `gaussian.toml`) | at most [`MAX_TEXT_FILE_BYTES`] (16 MiB) |
//! | an image (OpenEXR data and display windows, decoded photos) | at most [`MAX_IMAGE_SIDE_PX`] (65536) per side and [`MAX_IMAGE_PIXELS`] (2²⁸ = 16384²) in all |
//! | a path inside a file (glTF buffer/image `uri`, manifest `image`) | relative, inside the file's own folder: no absolute path, no `..` that leaves it |

use std::fs::File;
use std::io::{self, Read};
use std::path::{Component, Path, PathBuf};

/// The largest file any cdrf reader accepts, in bytes (1 GiB).
pub const MAX_INPUT_FILE_BYTES: u64 = 1 << 30;
/// The largest TOML file (scene, manifest, `gaussian.toml`) accepted, in bytes (16 MiB).
pub const MAX_TEXT_FILE_BYTES: u64 = 16 << 20;
/// The longest image side accepted, in pixels.
pub const MAX_IMAGE_SIDE_PX: usize = 1 << 16;
/// The most pixels an image may have (16384²).
pub const MAX_IMAGE_PIXELS: usize = 1 << 28;

/// Opens `path` for reading if it is a regular file of at most `max_bytes`.
///
/// # Errors
/// The OS error, or an [`io::ErrorKind::InvalidInput`] error saying that the file is not a
/// regular file or is larger than `max_bytes`.
pub fn open_regular(path: &Path, max_bytes: u64) -> io::Result<File> {
    let file = File::open(path)?;
    let metadata = file.metadata()?;
    if !metadata.is_file() {
        let what = if metadata.is_dir() {
            "a folder"
        } else {
            "not a regular file (a device, FIFO or socket)"
        };
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("is {what}; only regular files are read"),
        ));
    }
    if metadata.len() > max_bytes {
        return Err(too_large(metadata.len(), max_bytes));
    }
    Ok(file)
}

/// Reads `path` whole if it is a regular file of at most `max_bytes` (see [`open_regular`]);
/// a file that grows while it is read is cut off at the limit and refused.
///
/// # Errors
/// As [`open_regular`], or the read error.
pub fn read_regular(path: &Path, max_bytes: u64) -> io::Result<Vec<u8>> {
    let file = open_regular(path, max_bytes)?;
    let mut bytes = Vec::new();
    file.take(max_bytes + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max_bytes {
        return Err(too_large(bytes.len() as u64, max_bytes));
    }
    Ok(bytes)
}

/// [`read_regular`] with [`MAX_TEXT_FILE_BYTES`], as UTF-8 text.
///
/// # Errors
/// As [`read_regular`], or [`io::ErrorKind::InvalidData`] for text that is not UTF-8.
pub fn read_text(path: &Path) -> io::Result<String> {
    let bytes = read_regular(path, MAX_TEXT_FILE_BYTES)?;
    String::from_utf8(bytes).map_err(|error| {
        io::Error::new(
            io::ErrorKind::InvalidData,
            format!("not UTF-8 text (byte {})", error.utf8_error().valid_up_to()),
        )
    })
}

fn too_large(bytes: u64, max_bytes: u64) -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidInput,
        format!("is {bytes} bytes or more; the limit is {max_bytes} bytes"),
    )
}

/// Checks an image's size against [`MAX_IMAGE_SIDE_PX`] and [`MAX_IMAGE_PIXELS`]; `what` names
/// it in the message (`"data window"`).
///
/// # Errors
/// A message saying which limit the size breaks.
pub fn check_image_size(what: &str, width: usize, height: usize) -> Result<(), String> {
    if width > MAX_IMAGE_SIDE_PX || height > MAX_IMAGE_SIDE_PX {
        return Err(format!(
            "{what} of {width} × {height} px: a side is over the limit of {MAX_IMAGE_SIDE_PX} px"
        ));
    }
    if width.saturating_mul(height) > MAX_IMAGE_PIXELS {
        return Err(format!(
            "{what} of {width} × {height} px is over the limit of {MAX_IMAGE_PIXELS} pixels"
        ));
    }
    Ok(())
}

/// Reads an OpenEXR file's headers (never its pixels) and checks every layer's data window
/// and the display window against the image limits ([`check_image_size`]).
///
/// # Errors
/// The decoder's error for unreadable headers, or the limit that a window breaks.
pub fn check_exr_windows(reader: impl Read) -> Result<(), ExrHeaderError> {
    let meta = exr::meta::MetaData::read_from_buffered(io::BufReader::new(reader), false)
        .map_err(ExrHeaderError::Exr)?;
    for (index, header) in meta.headers.iter().enumerate() {
        let size = header.layer_size;
        check_image_size(
            &format!("layer {index} data window"),
            size.width(),
            size.height(),
        )
        .map_err(ExrHeaderError::TooLarge)?;
        let display = header.shared_attributes.display_window.size;
        check_image_size("display window", display.width(), display.height())
            .map_err(ExrHeaderError::TooLarge)?;
    }
    Ok(())
}

/// Why [`check_exr_windows`] refused a file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExrHeaderError {
    /// The headers could not be read.
    #[error(transparent)]
    Exr(exr::error::Error),
    /// A window is larger than the image limits.
    #[error("{0}")]
    TooLarge(String),
}

/// Resolves `relative` (a path written inside a file whose folder is `base`) to a path inside
/// `base`: absolute paths, drive prefixes and `..` components that climb out of `base` are
/// refused. Symbolic links are not followed here (a link inside the folder is the folder
/// owner's choice).
///
/// # Errors
/// A message saying why the path is refused.
pub fn resolve_inside(base: &Path, relative: &str) -> Result<PathBuf, String> {
    let path = Path::new(relative);
    let mut depth = 0usize;
    for component in path.components() {
        match component {
            Component::Prefix(_) | Component::RootDir => {
                return Err(format!(
                    "{relative:?} is an absolute path; only paths relative to the file's own \
                     folder are followed"
                ));
            }
            Component::CurDir => {}
            Component::ParentDir => {
                depth = depth.checked_sub(1).ok_or_else(|| {
                    format!(
                        "{relative:?} leaves the file's own folder (`..`); only paths inside \
                         it are followed"
                    )
                })?;
            }
            Component::Normal(_) => depth += 1,
        }
    }
    if relative.is_empty() {
        return Err("empty path".to_owned());
    }
    Ok(base.join(path))
}

/// Deserializes a TOML array of exactly `N` numbers into `[f32; N]`; any other length is an
/// error naming `key` and the expected length (serde's own arrays drop extra elements).
///
/// # Errors
/// The deserializer's error, or an invalid-length error.
pub fn exact_array<'de, D, const N: usize>(
    deserializer: D,
    key: &'static str,
) -> Result<[f32; N], D::Error>
where
    D: serde::Deserializer<'de>,
{
    struct Visitor<const N: usize>(&'static str);
    impl<'de, const N: usize> serde::de::Visitor<'de> for Visitor<N> {
        type Value = [f32; N];
        fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            write!(f, "`{}` as an array of exactly {N} numbers", self.0)
        }
        fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<[f32; N], A::Error> {
            let mut values = [0.0; N];
            let mut count = 0usize;
            while let Some(value) = seq.next_element::<f32>()? {
                if let Some(slot) = values.get_mut(count) {
                    *slot = value;
                }
                count += 1;
            }
            if count != N {
                return Err(serde::de::Error::invalid_length(count, &self));
            }
            Ok(values)
        }
    }
    deserializer.deserialize_seq(Visitor::<N>(key))
}

/// Serde `deserialize_with` functions for fixed-length keys (see [`exact_array`]).
#[doc(hidden)]
#[macro_export]
macro_rules! exact_array_fields {
    ($($name:ident: $n:literal),* $(,)?) => {
        $(
            fn $name<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[f32; $n], D::Error> {
                $crate::input_file::exact_array::<D, $n>(d, stringify!($name))
            }
        )*
        /// The same as `Option`s.
        #[allow(dead_code)]
        mod optional {
            $(
                pub(super) fn $name<'de, D: serde::Deserializer<'de>>(
                    d: D,
                ) -> Result<Option<[f32; $n]>, D::Error> {
                    super::$name(d).map(Some)
                }
            )*
        }
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn special_and_large_files_are_refused() {
        let error = read_regular(Path::new("/dev/zero"), 1024).unwrap_err();
        assert_eq!(error.kind(), io::ErrorKind::InvalidInput);
        assert!(error.to_string().contains("not a regular file"), "{error}");
        let dir = tempfile::tempdir().unwrap();
        let error = read_regular(dir.path(), 1024).unwrap_err();
        assert!(error.to_string().contains("folder"), "{error}");
        let path = dir.path().join("big");
        std::fs::write(&path, [0u8; 100]).unwrap();
        let error = read_regular(&path, 99).unwrap_err();
        assert!(error.to_string().contains("limit is 99 bytes"), "{error}");
        assert_eq!(read_regular(&path, 100).unwrap().len(), 100);
    }

    #[test]
    fn paths_stay_inside_the_folder() {
        let base = Path::new("/models");
        assert_eq!(
            resolve_inside(base, "a/../b.bin").unwrap(),
            base.join("a/../b.bin")
        );
        assert!(resolve_inside(base, "/dev/zero").is_err());
        assert!(resolve_inside(base, "../x.bin").is_err());
        assert!(resolve_inside(base, "a/../../x.bin").is_err());
        assert!(resolve_inside(base, "").is_err());
    }

    #[test]
    fn image_limits() {
        assert!(check_image_size("x", 16384, 16384).is_ok());
        assert!(check_image_size("x", 16385, 16384).is_err());
        assert!(check_image_size("x", 100_000, 1).is_err());
    }
}
