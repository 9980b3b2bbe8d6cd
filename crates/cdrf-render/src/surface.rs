//! Surfaces: what an asset paints on the measured material — a base colour tint, a
//! tangent-space normal map and the specular layer's roughness, with their textures (bind
//! group 2 of the shading pass, beside the draw's transforms).
//!
//! A surface is independent of the material (the scattering medium): the same wax table can be
//! drawn with several glTF materials' textures, one draw per primitive
//! ([`Draw::with_surface`](crate::Draw::with_surface)).
//!
//! # How each part enters the shading
//! - **Base colour** (linear `factor` × the sRGB-decoded texture) multiplies the subsurface
//!   light once, where it leaves the surface — local table, non-local terms and environment
//!   alike; white is the measured material. The specular layer is not tinted (a dielectric's
//!   first-surface reflection is the light's colour). Alpha is ignored: cdrf draws opaque
//!   objects.
//! - **Normal map**: the per-pixel normal is `normalize(T·x + B·y + N·z)` with
//!   `(x, y, z) = (2·rgb − 1)·(scale, scale, 1)`, `B = cross(N, T)·w` (glTF's convention; the
//!   mesh's tangents, [`MeshDesc::with_tangents`](crate::MeshDesc::with_tangents)). It changes
//!   θ and φ of the local model and the specular lobe per pixel; the per-vertex terms (shadows,
//!   gathers, environment) and the curvature keep the geometric normal, since they vary over
//!   millimetres, not over a texture's bumps. A draw whose mesh has no tangents ignores it.
//! - **Roughness** (glTF's perceptual roughness `r` = factor × the texture's G channel) sets
//!   the specular layer's Beckmann α = r² per pixel when the surface has one
//!   ([`SurfaceDesc::roughness`]); without one the material's
//!   [`SpecularLayer::roughness_alpha`](cdrf_core::specular::SpecularLayer) holds. Whether
//!   there is a specular layer at all stays the material's choice.
//!
//! Textures are uploaded with a full mip chain (box-filtered on the CPU: base colour in linear
//! light, normals renormalised) and sampled trilinearly with each texture's own wrap modes.

use cdrf_core::glam::Vec3;
use cdrf_core::image_file::{linear_to_srgb, srgb_to_linear};
use cdrf_core::mesh::surface::{SurfaceMaterial, TextureImage, TextureWrap};
use wgpu::util::DeviceExt;

use crate::error::SurfaceError;

/// The specular roughness a surface paints (glTF's metallic-roughness convention).
#[derive(Clone, Copy, Debug)]
pub struct SurfaceRoughness<'a> {
    /// Perceptual roughness r in 0..=1 (Beckmann α = r²), multiplied by the texture's G.
    pub factor: f32,
    /// A linear texture whose G channel multiplies `factor` (glTF's metallic-roughness
    /// texture; B, metalness, is not used).
    pub texture: Option<&'a TextureImage>,
}

/// A surface to upload: its factors and textures, borrowed from the host. See the [module
/// docs](self) for how each part enters the shading.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceDesc<'a> {
    /// Linear RGB tint of the subsurface light, each ≥ 0 (white: the material itself).
    pub base_color_factor: [f32; 3],
    /// An sRGB-encoded texture multiplying `base_color_factor` (alpha ignored).
    pub base_color_texture: Option<&'a TextureImage>,
    /// A linear, tangent-space normal texture.
    pub normal_texture: Option<&'a TextureImage>,
    /// Multiplies the normal texture's x and y (glTF's `normalTexture.scale`).
    pub normal_scale: f32,
    /// The specular roughness (`None`: the material's).
    pub roughness: Option<SurfaceRoughness<'a>>,
}

impl Default for SurfaceDesc<'_> {
    /// White, no textures, the material's roughness: the look of a draw without a surface.
    fn default() -> Self {
        Self {
            base_color_factor: [1.0; 3],
            base_color_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            roughness: None,
        }
    }
}

impl<'a> SurfaceDesc<'a> {
    /// The surface of a loaded glTF material
    /// ([`Mesh::load_with_surfaces`](cdrf_core::Mesh::load_with_surfaces)). A material of the
    /// file (`source_index` set) paints its roughness as glTF defines it (factor 1 when the
    /// file gives none); the default material (OBJ files, primitives without a material)
    /// leaves the cdrf material's.
    pub fn from_material(material: &'a SurfaceMaterial) -> Self {
        let [r, g, b, _] = material.base_color_factor;
        Self {
            base_color_factor: [r, g, b],
            base_color_texture: material.base_color_texture.as_ref(),
            normal_texture: material.normal_texture.as_ref().map(|n| &n.image),
            normal_scale: material
                .normal_texture
                .as_ref()
                .map_or(1.0, |normal| normal.scale),
            roughness: (material.source_index.is_some()
                || material.metallic_roughness_texture.is_some())
            .then_some(SurfaceRoughness {
                factor: material.roughness_factor,
                texture: material.metallic_roughness_texture.as_ref(),
            }),
        }
    }

    fn validate(&self, max_side: u32) -> Result<(), SurfaceError> {
        if !self
            .base_color_factor
            .iter()
            .all(|c| c.is_finite() && *c >= 0.0)
        {
            return Err(SurfaceError::Parameter {
                what: "base colour factor",
                value: self.base_color_factor.to_vec(),
                requirement: "each channel finite and ≥ 0",
            });
        }
        if !self.normal_scale.is_finite() {
            return Err(SurfaceError::Parameter {
                what: "normal scale",
                value: vec![self.normal_scale],
                requirement: "finite",
            });
        }
        if let Some(roughness) = self.roughness
            && !(0.0..=1.0).contains(&roughness.factor)
        {
            return Err(SurfaceError::Parameter {
                what: "roughness factor",
                value: vec![roughness.factor],
                requirement: "in 0..=1",
            });
        }
        for (what, texture) in self.textures() {
            if let Some(texture) = texture {
                check_texture(what, texture, max_side)?;
            }
        }
        Ok(())
    }

    fn textures(&self) -> [(&'static str, Option<&'a TextureImage>); 3] {
        [
            ("base colour texture", self.base_color_texture),
            ("normal texture", self.normal_texture),
            (
                "roughness texture",
                self.roughness.and_then(|roughness| roughness.texture),
            ),
        ]
    }
}

fn check_texture(what: &'static str, texture: &TextureImage, max: u32) -> Result<(), SurfaceError> {
    let (width, height) = (texture.width, texture.height);
    if width == 0 || height == 0 || width > max || height > max {
        return Err(SurfaceError::TextureSize {
            what,
            width,
            height,
            max,
        });
    }
    let expected = width as usize * height as usize;
    if texture.rgba8.len() != expected {
        return Err(SurfaceError::TextureData {
            what,
            found: texture.rgba8.len(),
            expected,
        });
    }
    Ok(())
}

/// What a draw with this surface writes into its `Draw` uniform.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SurfaceParameters {
    pub(crate) base_color_factor: Vec3,
    pub(crate) normal_scale: f32,
    pub(crate) roughness_factor: f32,
    /// [`SURFACE_NORMAL_MAP`] | [`SURFACE_ROUGHNESS`].
    pub(crate) flags: u32,
}

/// `Draw.surface_flags`: the surface has a normal map.
pub(crate) const SURFACE_NORMAL_MAP: u32 = 1;
/// `Draw.surface_flags`: the surface sets the specular roughness.
pub(crate) const SURFACE_ROUGHNESS: u32 = 2;

/// A surface's textures on the GPU and its bind group (which also holds the draw buffer, so it
/// is rebuilt when that grows).
pub(crate) struct GpuSurface {
    pub(crate) parameters: SurfaceParameters,
    views: [wgpu::TextureView; 3],
    samplers: [wgpu::Sampler; 3],
    pub(crate) bind_group: wgpu::BindGroup,
}

/// The draw layout's texture bindings: base colour (sRGB), normal, roughness at 1–3, their
/// samplers at 4–6.
pub(crate) fn texture_layout_entries() -> [wgpu::BindGroupLayoutEntry; 6] {
    let texture = |binding| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: true },
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    };
    let sampler = |binding| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
        count: None,
    };
    [
        texture(1),
        texture(2),
        texture(3),
        sampler(4),
        sampler(5),
        sampler(6),
    ]
}

impl GpuSurface {
    pub(crate) fn upload(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        desc: &SurfaceDesc<'_>,
        layout: &wgpu::BindGroupLayout,
        draws: &wgpu::BufferBinding<'_>,
    ) -> Result<Self, SurfaceError> {
        desc.validate(device.limits().max_texture_dimension_2d)?;
        let white = TextureImage {
            width: 1,
            height: 1,
            rgba8: vec![[255; 4]],
            wrap: [TextureWrap::Repeat; 2],
        };
        let flat = TextureImage {
            rgba8: vec![[128, 128, 255, 255]],
            ..white.clone()
        };
        let kinds = [
            TextureKind::Colour,
            TextureKind::Normal,
            TextureKind::Linear,
        ];
        let defaults = [&white, &flat, &white];
        let mut views = Vec::with_capacity(3);
        let mut samplers = Vec::with_capacity(3);
        for (((what, texture), kind), default) in
            desc.textures().into_iter().zip(kinds).zip(defaults)
        {
            let image = texture.unwrap_or(default);
            views.push(upload_texture(device, queue, what, image, kind));
            samplers.push(device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("cdrf surface sampler"),
                address_mode_u: address_mode(image.wrap[0]),
                address_mode_v: address_mode(image.wrap[1]),
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                mipmap_filter: wgpu::MipmapFilterMode::Linear,
                ..Default::default()
            }));
        }
        let views: [wgpu::TextureView; 3] = views.try_into().expect("three textures");
        let samplers: [wgpu::Sampler; 3] = samplers.try_into().expect("three samplers");
        let mut flags = 0;
        if desc.normal_texture.is_some() {
            flags |= SURFACE_NORMAL_MAP;
        }
        if desc.roughness.is_some() {
            flags |= SURFACE_ROUGHNESS;
        }
        let parameters = SurfaceParameters {
            base_color_factor: Vec3::from_array(desc.base_color_factor),
            normal_scale: desc.normal_scale,
            roughness_factor: desc.roughness.map_or(1.0, |r| r.factor),
            flags,
        };
        let bind_group = bind_group(device, layout, draws, &views, &samplers);
        Ok(Self {
            parameters,
            views,
            samplers,
            bind_group,
        })
    }

    /// Rebinds the textures with a new draw buffer.
    pub(crate) fn rebind(
        &mut self,
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        draws: &wgpu::BufferBinding<'_>,
    ) {
        self.bind_group = bind_group(device, layout, draws, &self.views, &self.samplers);
    }
}

fn bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    draws: &wgpu::BufferBinding<'_>,
    views: &[wgpu::TextureView; 3],
    samplers: &[wgpu::Sampler; 3],
) -> wgpu::BindGroup {
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("cdrf draw surface"),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(draws.clone()),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::TextureView(&views[0]),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: wgpu::BindingResource::TextureView(&views[1]),
            },
            wgpu::BindGroupEntry {
                binding: 3,
                resource: wgpu::BindingResource::TextureView(&views[2]),
            },
            wgpu::BindGroupEntry {
                binding: 4,
                resource: wgpu::BindingResource::Sampler(&samplers[0]),
            },
            wgpu::BindGroupEntry {
                binding: 5,
                resource: wgpu::BindingResource::Sampler(&samplers[1]),
            },
            wgpu::BindGroupEntry {
                binding: 6,
                resource: wgpu::BindingResource::Sampler(&samplers[2]),
            },
        ],
    })
}

fn address_mode(wrap: TextureWrap) -> wgpu::AddressMode {
    match wrap {
        TextureWrap::Repeat => wgpu::AddressMode::Repeat,
        TextureWrap::ClampToEdge => wgpu::AddressMode::ClampToEdge,
        TextureWrap::MirroredRepeat => wgpu::AddressMode::MirrorRepeat,
    }
}

/// How a texture's texels are encoded, for its format and its mip filter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum TextureKind {
    /// sRGB-encoded colour: averaged in linear light.
    Colour,
    /// Tangent-space normals: averaged and renormalised.
    Normal,
    /// Linear data: averaged.
    Linear,
}

fn upload_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    what: &'static str,
    image: &TextureImage,
    kind: TextureKind,
) -> wgpu::TextureView {
    let levels = mip_chain(image, kind);
    let format = match kind {
        TextureKind::Colour => wgpu::TextureFormat::Rgba8UnormSrgb,
        TextureKind::Normal | TextureKind::Linear => wgpu::TextureFormat::Rgba8Unorm,
    };
    let texture = device.create_texture_with_data(
        queue,
        &wgpu::TextureDescriptor {
            label: Some(what),
            size: wgpu::Extent3d {
                width: image.width,
                height: image.height,
                depth_or_array_layers: 1,
            },
            mip_level_count: levels.len() as u32,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        },
        wgpu::util::TextureDataOrder::LayerMajor,
        bytemuck::cast_slice(&levels.concat()),
    );
    texture.create_view(&Default::default())
}

/// The image and its mip levels down to 1 × 1, each half the one above (rounded down, at least
/// 1), every texel the mean of the 2 × 2 (or fewer, at an odd edge) it covers.
fn mip_chain(image: &TextureImage, kind: TextureKind) -> Vec<Vec<[u8; 4]>> {
    let decode = |texel: [u8; 4]| -> [f32; 4] {
        let unit = texel.map(|c| f32::from(c) / 255.0);
        match kind {
            TextureKind::Colour => [
                srgb_to_linear(unit[0]),
                srgb_to_linear(unit[1]),
                srgb_to_linear(unit[2]),
                unit[3],
            ],
            TextureKind::Normal => [
                2.0 * unit[0] - 1.0,
                2.0 * unit[1] - 1.0,
                2.0 * unit[2] - 1.0,
                unit[3],
            ],
            TextureKind::Linear => unit,
        }
    };
    let encode = |value: [f32; 4]| -> [u8; 4] {
        let unit = match kind {
            TextureKind::Colour => [
                linear_to_srgb(value[0]),
                linear_to_srgb(value[1]),
                linear_to_srgb(value[2]),
                value[3],
            ],
            TextureKind::Normal => {
                let n = Vec3::new(value[0], value[1], value[2]).normalize_or(Vec3::Z);
                [0.5 * n.x + 0.5, 0.5 * n.y + 0.5, 0.5 * n.z + 0.5, value[3]]
            }
            TextureKind::Linear => value,
        };
        unit.map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8)
    };
    let mut levels = vec![image.rgba8.clone()];
    let (mut width, mut height) = (image.width as usize, image.height as usize);
    let mut values: Vec<[f32; 4]> = image.rgba8.iter().map(|&t| decode(t)).collect();
    while width > 1 || height > 1 {
        let (next_width, next_height) = ((width / 2).max(1), (height / 2).max(1));
        let mut next = Vec::with_capacity(next_width * next_height);
        for y in 0..next_height {
            for x in 0..next_width {
                let mut sum = [0.0f32; 4];
                let mut count = 0.0;
                for sy in (2 * y)..(2 * y + 2).min(height) {
                    for sx in (2 * x)..(2 * x + 2).min(width) {
                        let value = values[sy * width + sx];
                        for (s, v) in sum.iter_mut().zip(value) {
                            *s += v;
                        }
                        count += 1.0;
                    }
                }
                next.push(sum.map(|s| s / count));
            }
        }
        levels.push(next.iter().map(|&v| encode(v)).collect());
        values = next;
        (width, height) = (next_width, next_height);
    }
    levels
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(width: u32, height: u32, rgba8: Vec<[u8; 4]>) -> TextureImage {
        TextureImage {
            width,
            height,
            rgba8,
            wrap: [TextureWrap::Repeat; 2],
        }
    }

    #[test]
    fn mip_chain_halves_down_to_one_texel_and_averages_colour_in_linear_light() {
        // Black and white columns: the linear mean is 0.5, sRGB-encoded 188, not 128.
        let texels = (0..6 * 3)
            .map(|i| if i % 2 == 0 { [0, 0, 0, 255] } else { [255; 4] })
            .collect();
        let levels = mip_chain(&image(6, 3, texels), TextureKind::Colour);
        let sizes: Vec<usize> = levels.iter().map(Vec::len).collect();
        assert_eq!(sizes, [18, 3, 1]);
        assert_eq!(levels[1][0], [188, 188, 188, 255]);
        let linear = mip_chain(
            &image(2, 1, vec![[0, 0, 0, 0], [255, 255, 255, 255]]),
            TextureKind::Linear,
        );
        assert_eq!(linear[1], [[128, 128, 128, 128]]);
    }

    #[test]
    fn mip_chain_renormalises_normals() {
        // Two normals tilted ±45° about y average to +z, unit length.
        let tilt = |x: f32| {
            let n = Vec3::new(x, 0.0, 1.0).normalize();
            [
                ((0.5 * n.x + 0.5) * 255.0).round() as u8,
                128,
                ((0.5 * n.z + 0.5) * 255.0).round() as u8,
                255,
            ]
        };
        let levels = mip_chain(
            &image(2, 1, vec![tilt(1.0), tilt(-1.0)]),
            TextureKind::Normal,
        );
        assert_eq!(levels[1], [[128, 128, 255, 255]]);
    }

    #[test]
    fn a_bad_surface_is_refused_with_what_is_wrong() {
        let short = image(4, 4, vec![[0; 4]; 15]);
        let desc = SurfaceDesc {
            base_color_texture: Some(&short),
            ..Default::default()
        };
        let error = desc.validate(8192).unwrap_err().to_string();
        assert!(
            error.contains("base colour texture") && error.contains("15"),
            "{error}"
        );
        let huge = image(16, 1, vec![[0; 4]; 16]);
        let desc = SurfaceDesc {
            normal_texture: Some(&huge),
            ..Default::default()
        };
        assert!(matches!(
            desc.validate(8),
            Err(SurfaceError::TextureSize { width: 16, .. })
        ));
        let desc = SurfaceDesc {
            base_color_factor: [1.0, f32::NAN, 0.0],
            ..Default::default()
        };
        assert!(matches!(
            desc.validate(8),
            Err(SurfaceError::Parameter { .. })
        ));
        let desc = SurfaceDesc {
            roughness: Some(SurfaceRoughness {
                factor: 1.5,
                texture: None,
            }),
            ..Default::default()
        };
        assert!(matches!(
            desc.validate(8),
            Err(SurfaceError::Parameter { .. })
        ));
    }

    #[test]
    fn a_gltf_material_paints_its_roughness_and_the_default_material_does_not() {
        let default = SurfaceMaterial::default();
        assert!(SurfaceDesc::from_material(&default).roughness.is_none());
        let authored = SurfaceMaterial {
            source_index: Some(0),
            roughness_factor: 0.6,
            base_color_factor: [0.5, 0.25, 1.0, 0.5],
            ..Default::default()
        };
        let desc = SurfaceDesc::from_material(&authored);
        assert_eq!(desc.roughness.map(|r| r.factor), Some(0.6));
        assert_eq!(desc.base_color_factor, [0.5, 0.25, 1.0]);
    }
}
