//! glTF materials and their texture images (PNG, JPEG), for
//! [`Mesh::load_with_surfaces`](super::Mesh::load_with_surfaces).
//!
//! An image's size is read from its header and checked against
//! [`crate::input_file::check_image_size`] before it is decoded, and the decoder runs with
//! allocation limits, so a file cannot make the loader allocate without bound. Images come from
//! a GLB's buffer views, `data:` base64 URIs or files relative to the glTF file inside its own
//! folder (as buffers do). Each image is decoded once however many textures use it.

use std::collections::HashMap;
use std::io::Cursor;
use std::path::Path;

use image::ImageFormat;

use super::gltf_load::{UriError, uri_bytes, view_bytes};
use super::{LoadError, NormalTexture, SurfaceMaterial, TextureImage, TextureWrap};

/// glTF extensions that change how textures or materials are read and that are ignored.
const IGNORED_EXTENSIONS: &[&str] = &[
    "KHR_texture_transform",
    "KHR_texture_basisu",
    "EXT_texture_webp",
    "KHR_materials_pbrSpecularGlossiness",
];

/// Reads materials of one document, caching decoded images.
pub(super) struct MaterialReader<'a> {
    document: &'a gltf::Document,
    buffers: &'a [Vec<u8>],
    base: &'a Path,
    path: &'a Path,
    has_uvs: bool,
    images: HashMap<usize, TextureImage>,
    warnings: Vec<String>,
}

impl<'a> MaterialReader<'a> {
    /// `base` is the glTF file's folder; `has_uvs` whether the mesh has `TEXCOORD_0` (textures
    /// are ignored, with a warning, when it has not).
    pub(super) fn new(
        document: &'a gltf::Document,
        buffers: &'a [Vec<u8>],
        base: &'a Path,
        path: &'a Path,
        has_uvs: bool,
    ) -> Self {
        let warnings = document
            .extensions_used()
            .filter(|e| IGNORED_EXTENSIONS.contains(e))
            .map(|e| format!("extension {e} is not supported and was ignored"))
            .collect();
        Self {
            document,
            buffers,
            base,
            path,
            has_uvs,
            images: HashMap::new(),
            warnings,
        }
    }

    /// What was ignored, one sentence each.
    pub(super) fn into_warnings(self) -> Vec<String> {
        self.warnings
    }

    fn error(&self, problem: String) -> LoadError {
        LoadError::GltfData {
            path: self.path.to_owned(),
            problem,
        }
    }

    /// The material with glTF index `source` (`None`: the default material).
    pub(super) fn read(&mut self, source: Option<usize>) -> Result<SurfaceMaterial, LoadError> {
        let Some(index) = source else {
            return Ok(SurfaceMaterial::default());
        };
        let material = self
            .document
            .materials()
            .nth(index)
            .ok_or_else(|| self.error(format!("material {index} does not exist")))?;
        let label = format!("material {index}");
        let pbr = material.pbr_metallic_roughness();
        let base_color_texture = match pbr.base_color_texture() {
            Some(info) => {
                self.texture(&label, "baseColorTexture", info.texture(), info.tex_coord())?
            }
            None => None,
        };
        let metallic_roughness_texture = match pbr.metallic_roughness_texture() {
            Some(info) => self.texture(
                &label,
                "metallicRoughnessTexture",
                info.texture(),
                info.tex_coord(),
            )?,
            None => None,
        };
        let normal_texture = match material.normal_texture() {
            Some(normal) => self
                .texture(
                    &label,
                    "normalTexture",
                    normal.texture(),
                    normal.tex_coord(),
                )?
                .map(|image| NormalTexture {
                    image,
                    scale: normal.scale(),
                }),
            None => None,
        };
        let finite = |x: f32, what: &str| {
            if x.is_finite() {
                Ok(x)
            } else {
                Err(self.error(format!("{label}: {what} {x} is not finite")))
            }
        };
        let factor = pbr.base_color_factor();
        for c in factor {
            finite(c, "baseColorFactor component")?;
        }
        Ok(SurfaceMaterial {
            name: material.name().map(str::to_owned),
            source_index: Some(index),
            base_color_factor: factor,
            base_color_texture,
            normal_texture,
            roughness_factor: finite(pbr.roughness_factor(), "roughnessFactor")?,
            metallic_roughness_texture,
        })
    }

    /// The decoded image of `texture`, with its sampler's wrap modes; `None` (and a warning)
    /// when it cannot be used: a set other than `TEXCOORD_0`, or a mesh without UVs.
    fn texture(
        &mut self,
        label: &str,
        slot: &str,
        texture: gltf::Texture<'_>,
        tex_coord: u32,
    ) -> Result<Option<TextureImage>, LoadError> {
        if tex_coord != 0 {
            self.warnings.push(format!(
                "{label} {slot} uses TEXCOORD_{tex_coord}; only TEXCOORD_0 is supported, the \
                 texture was ignored"
            ));
            return Ok(None);
        }
        if !self.has_uvs {
            self.warnings.push(format!(
                "{label} {slot} was ignored: the mesh has no TEXCOORD_0 on every primitive"
            ));
            return Ok(None);
        }
        let sampler = texture.sampler();
        let wrap = [sampler.wrap_s(), sampler.wrap_t()].map(|w| match w {
            gltf::texture::WrappingMode::ClampToEdge => TextureWrap::ClampToEdge,
            gltf::texture::WrappingMode::MirroredRepeat => TextureWrap::MirroredRepeat,
            gltf::texture::WrappingMode::Repeat => TextureWrap::Repeat,
        });
        let image = texture.source();
        let index = image.index();
        if !self.images.contains_key(&index) {
            let decoded = self.decode(&image).map_err(|problem| {
                self.error(format!(
                    "{label} {slot}: texture {} image {index}: {problem}",
                    texture.index()
                ))
            })?;
            self.images.insert(index, decoded);
        }
        let mut decoded = self.images[&index].clone();
        decoded.wrap = wrap;
        Ok(Some(decoded))
    }

    /// Reads and decodes one image.
    fn decode(&self, image: &gltf::Image<'_>) -> Result<TextureImage, String> {
        let (bytes, mime_type) = match image.source() {
            gltf::image::Source::View { view, mime_type } => (
                std::borrow::Cow::Borrowed(view_bytes(&view, self.buffers)?),
                Some(mime_type),
            ),
            gltf::image::Source::Uri { uri, mime_type } => {
                let bytes = uri_bytes(uri, self.base).map_err(|e| match e {
                    UriError::Invalid(problem) => problem,
                    UriError::Read { file, source } => {
                        format!("cannot read {}: {source}", file.display())
                    }
                })?;
                (std::borrow::Cow::Owned(bytes), mime_type)
            }
        };
        decode_image(&bytes, mime_type)
    }
}

/// Decodes PNG or JPEG `bytes` to RGBA8 after checking the header's size against the image
/// limits. The format is the MIME type's, else guessed from the first bytes.
pub(super) fn decode_image(bytes: &[u8], mime_type: Option<&str>) -> Result<TextureImage, String> {
    let format = match mime_type {
        Some("image/png") => ImageFormat::Png,
        Some("image/jpeg") => ImageFormat::Jpeg,
        Some(other) => {
            return Err(format!(
                "MIME type {other:?} is not supported (image/png and image/jpeg are)"
            ));
        }
        None => match image::guess_format(bytes) {
            Ok(format @ (ImageFormat::Png | ImageFormat::Jpeg)) => format,
            Ok(other) => {
                return Err(format!(
                    "{other:?} images are not supported (PNG and JPEG are)"
                ));
            }
            Err(_) => return Err("not a PNG or JPEG image".to_owned()),
        },
    };
    let name = if format == ImageFormat::Png {
        "PNG"
    } else {
        "JPEG"
    };
    let decode_error = |e: image::ImageError| format!("invalid {name}: {e}");
    let (width, height) = image::ImageReader::with_format(Cursor::new(bytes), format)
        .into_dimensions()
        .map_err(decode_error)?;
    crate::input_file::check_image_size(name, width as usize, height as usize)?;
    if width == 0 || height == 0 {
        return Err(format!("{name} of {width} × {height} px is empty"));
    }
    let mut reader = image::ImageReader::with_format(Cursor::new(bytes), format);
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(width);
    limits.max_image_height = Some(height);
    // The largest buffer a decoder needs: 16-bit RGBA, plus the RGBA8 copy.
    limits.max_alloc = Some(u64::from(width) * u64::from(height) * 8 + (1 << 20));
    reader.limits(limits);
    let decoded = reader.decode().map_err(decode_error)?;
    if (decoded.width(), decoded.height()) != (width, height) {
        return Err(format!(
            "{name} header says {width} × {height} px but {} × {} were decoded",
            decoded.width(),
            decoded.height()
        ));
    }
    let rgba8 = decoded
        .into_rgba8()
        .into_raw()
        .chunks_exact(4)
        .map(|p| [p[0], p[1], p[2], p[3]])
        .collect();
    Ok(TextureImage {
        width,
        height,
        rgba8,
        wrap: [TextureWrap::Repeat; 2],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn png(width: u32, height: u32, pixels: &[u8], color: image::ExtendedColorType) -> Vec<u8> {
        let mut bytes = Vec::new();
        image::write_buffer_with_format(
            &mut Cursor::new(&mut bytes),
            pixels,
            width,
            height,
            color,
            ImageFormat::Png,
        )
        .unwrap();
        bytes
    }

    #[test]
    fn png_and_jpeg_decode_to_rgba8() {
        let bytes = png(
            2,
            1,
            &[10, 20, 30, 40, 50, 60],
            image::ExtendedColorType::Rgb8,
        );
        for mime in [Some("image/png"), None] {
            let image = decode_image(&bytes, mime).unwrap();
            assert_eq!((image.width, image.height), (2, 1));
            assert_eq!(image.rgba8, vec![[10, 20, 30, 255], [40, 50, 60, 255]]);
        }
        let mut jpeg = Vec::new();
        image::write_buffer_with_format(
            &mut Cursor::new(&mut jpeg),
            &[200u8; 8 * 8 * 3],
            8,
            8,
            image::ExtendedColorType::Rgb8,
            ImageFormat::Jpeg,
        )
        .unwrap();
        let image = decode_image(&jpeg, Some("image/jpeg")).unwrap();
        assert_eq!(image.rgba8.len(), 64);
        assert!(
            image
                .rgba8
                .iter()
                .all(|p| p[0].abs_diff(200) <= 2 && p[3] == 255)
        );
    }

    #[test]
    fn wrong_or_unsupported_formats_are_errors() {
        let bytes = png(1, 1, &[0, 0, 0], image::ExtendedColorType::Rgb8);
        let error = decode_image(&bytes, Some("image/jpeg")).unwrap_err();
        assert!(error.contains("invalid JPEG"), "{error}");
        let error = decode_image(&bytes, Some("image/webp")).unwrap_err();
        assert!(error.contains("not supported"), "{error}");
        let error = decode_image(b"GIF89a......", None).unwrap_err();
        assert!(error.contains("not supported"), "{error}");
        let error = decode_image(&bytes[..bytes.len() / 2], None).unwrap_err();
        assert!(error.contains("invalid PNG"), "{error}");
    }
}
