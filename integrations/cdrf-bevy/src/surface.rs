//! glTF scenes in a CDRF material: [`CdrfOverride`] on a scene's root hands every mesh below it
//! that Bevy's glTF loader gave a `StandardMaterial` to the plugin, painted with that
//! material's base colour, normal map and roughness as a cdrf-render surface
//! (`cdrf_render::surface`: the base colour tints the subsurface light, the normal map bends
//! the local model's normal, the roughness sets the specular layer's).

use bevy::image::{ImageAddressMode, ImageSampler};
use bevy::prelude::*;
use bevy::render::render_resource::TextureFormat;
use cdrf_core::mesh::surface::{TextureImage, TextureWrap};

use crate::assets::{CdrfMaterial, CdrfMaterial3d};

/// On a scene's root (e.g. beside a glTF `WorldAssetRoot`): every mesh below it with a
/// `StandardMaterial` is drawn by the plugin in this material instead, keeping the
/// `StandardMaterial`'s textures as its surface ([`CdrfSurface`]).
#[derive(Component, Clone, Debug)]
pub struct CdrfOverride(pub Handle<CdrfMaterial>);

/// What a CDRF mesh is painted with: the base colour (factor and texture), normal map and
/// perceptual roughness (factor and the metallic-roughness texture's G) of a
/// `StandardMaterial`. [`CdrfOverride`] adds it; add it yourself to paint any CDRF entity.
#[derive(Component, Clone, Debug)]
pub struct CdrfSurface(pub Handle<StandardMaterial>);

/// Hands the meshes under each [`CdrfOverride`] to the plugin as soon as the scene spawns them.
pub(crate) fn apply_overrides(
    mut commands: Commands,
    roots: Query<(Entity, &CdrfOverride)>,
    children: Query<&Children>,
    standard: Query<&MeshMaterial3d<StandardMaterial>, Without<CdrfMaterial3d>>,
) {
    for (root, CdrfOverride(material)) in &roots {
        for entity in children.iter_descendants(root) {
            if let Ok(MeshMaterial3d(surface)) = standard.get(entity) {
                commands
                    .entity(entity)
                    .remove::<MeshMaterial3d<StandardMaterial>>()
                    .insert((
                        CdrfMaterial3d(material.clone()),
                        CdrfSurface(surface.clone()),
                    ));
            }
        }
    }
}

/// A `StandardMaterial` as cdrf-render paints it (textures in the main world's copy).
#[derive(Debug)]
pub(crate) struct PreparedSurface {
    pub base_color_factor: [f32; 3],
    pub base_color_texture: Option<TextureImage>,
    pub normal_texture: Option<TextureImage>,
    pub roughness_factor: f32,
    pub roughness_texture: Option<TextureImage>,
}

impl PreparedSurface {
    pub(crate) fn desc(&self) -> cdrf_render::SurfaceDesc<'_> {
        cdrf_render::SurfaceDesc {
            base_color_factor: self.base_color_factor,
            base_color_texture: self.base_color_texture.as_ref(),
            normal_texture: self.normal_texture.as_ref(),
            normal_scale: 1.0,
            roughness: Some(cdrf_render::SurfaceRoughness {
                factor: self.roughness_factor,
                texture: self.roughness_texture.as_ref(),
            }),
        }
    }
}

/// Why a `StandardMaterial` cannot paint a CDRF mesh.
#[derive(Debug, thiserror::Error, PartialEq)]
pub(crate) enum SurfaceError {
    #[error(
        "its {which} texture is {format:?}; the plugin reads Rgba8UnormSrgb and Rgba8Unorm \
         textures"
    )]
    Format {
        which: &'static str,
        format: TextureFormat,
    },
    #[error("its {which} texture has no pixels in the main world")]
    NoData { which: &'static str },
}

/// The surface of `material`; `Ok(None)` while a texture loads.
pub(crate) fn prepare_surface(
    material: &StandardMaterial,
    images: &Assets<Image>,
) -> Result<Option<PreparedSurface>, SurfaceError> {
    let texture = |which,
                   handle: &Option<Handle<Image>>|
     -> Result<Option<Option<TextureImage>>, SurfaceError> {
        let Some(handle) = handle else {
            return Ok(Some(None));
        };
        let Some(image) = images.get(handle) else {
            return Ok(None); // still loading
        };
        texture_image(which, image).map(|t| Some(Some(t)))
    };
    let (Some(base), Some(normal), Some(roughness)) = (
        texture("base colour", &material.base_color_texture)?,
        texture("normal", &material.normal_map_texture)?,
        texture("metallic-roughness", &material.metallic_roughness_texture)?,
    ) else {
        return Ok(None);
    };
    let base_color = material.base_color.to_linear();
    Ok(Some(PreparedSurface {
        base_color_factor: [base_color.red, base_color.green, base_color.blue],
        base_color_texture: base,
        normal_texture: normal,
        roughness_factor: material.perceptual_roughness,
        roughness_texture: roughness,
    }))
}

/// A Bevy image (its first mip level) as cdrf's texture.
fn texture_image(which: &'static str, image: &Image) -> Result<TextureImage, SurfaceError> {
    let format = image.texture_descriptor.format;
    if !matches!(
        format,
        TextureFormat::Rgba8UnormSrgb | TextureFormat::Rgba8Unorm
    ) {
        return Err(SurfaceError::Format { which, format });
    }
    let (width, height) = (image.width(), image.height());
    let texels = width as usize * height as usize;
    let data = image
        .data
        .as_deref()
        .filter(|data| data.len() >= 4 * texels)
        .ok_or(SurfaceError::NoData { which })?;
    let wrap = |mode: ImageAddressMode| match mode {
        ImageAddressMode::Repeat => TextureWrap::Repeat,
        ImageAddressMode::MirrorRepeat => TextureWrap::MirroredRepeat,
        _ => TextureWrap::ClampToEdge,
    };
    let wrap = match &image.sampler {
        ImageSampler::Descriptor(sampler) => {
            [wrap(sampler.address_mode_u), wrap(sampler.address_mode_v)]
        }
        // Bevy's default sampler clamps.
        ImageSampler::Default => [TextureWrap::ClampToEdge; 2],
    };
    Ok(TextureImage {
        width,
        height,
        rgba8: data[..4 * texels]
            .chunks_exact(4)
            .map(|p| [p[0], p[1], p[2], p[3]])
            .collect(),
        wrap,
    })
}
