//! Bevy's `EnvironmentMapLight` as cdrf's sky. Bevy lights a diffuse surface with its
//! *diffuse* cubemap D, read at the normal: D(n) = E(n)/π, the environment's radiance convolved
//! with the cosine. Projected to spherical harmonics D_lm = a_l · L_lm (a_l: Lambert's zonal
//! coefficients 1, 2/3, 1/4), so the environment cdrf convolves with each table is
//! L_lm = D_lm / a_l for bands 0–2 (the diffuse map holds nothing finer).
//!
//! Directions as Bevy samples: a world direction N reads the cubemap at
//! c = R⁻¹·N with z negated (bevy_pbr's `environment_map.wesl`: cubemaps are left-handed), R
//! the light's `rotation`; the faces in wgpu's order and orientation.

use bevy::image::Image;
use bevy::math::Quat;
use bevy::render::render_resource::{TextureDataOrder, TextureFormat};
use cdrf_core::environment::{ShCoefficients, lambert_zonal_coefficient, sh_basis, sh_index};
use cdrf_core::glam;

/// The bands a diffuse map carries.
const ORDER: usize = 2;

/// Why an environment map cannot light the CDRF meshes.
#[derive(Debug, thiserror::Error, PartialEq)]
pub(crate) enum EnvironmentMapError {
    #[error("its diffuse map is not a square cubemap of 6 layers ({width} × {height} × {layers})")]
    NotCube {
        width: u32,
        height: u32,
        layers: u32,
    },
    #[error("its diffuse map is {0:?}; the plugin reads Rgba16Float, Rgba32Float and Rgb9e5Ufloat")]
    Format(TextureFormat),
    #[error("its diffuse map has no pixels in the main world (RenderAssetUsages::RENDER_WORLD)")]
    NoData,
    #[error("its diffuse map holds {found} bytes, fewer than its size needs ({needed})")]
    Short { found: usize, needed: usize },
}

/// The direction (not unit) of texel (x, y) of cubemap face `face`, in wgpu's convention.
fn face_direction(face: usize, u: f32, v: f32) -> glam::Vec3 {
    match face {
        0 => glam::Vec3::new(1.0, -v, -u),
        1 => glam::Vec3::new(-1.0, -v, u),
        2 => glam::Vec3::new(u, 1.0, v),
        3 => glam::Vec3::new(u, -1.0, -v),
        4 => glam::Vec3::new(u, -v, 1.0),
        _ => glam::Vec3::new(-u, -v, -1.0),
    }
}

/// One texel of a cubemap's level 0, face by face, row by row.
struct CubeTexel {
    face: usize,
    /// Its place in the face, `row × side + column`.
    index: usize,
    /// The world direction it holds before the light's rotation: Bevy's z-negated lookup.
    unrotated: glam::Vec3,
    /// Its solid angle, sr.
    solid_angle: f32,
}

fn cube_texels(side: usize) -> impl Iterator<Item = CubeTexel> {
    let texel = 2.0 / side as f32;
    (0..6).flat_map(move |face| {
        (0..side * side).map(move |index| {
            let u = ((index % side) as f32 + 0.5) * texel - 1.0;
            let v = ((index / side) as f32 + 0.5) * texel - 1.0;
            let c = face_direction(face, u, v);
            CubeTexel {
                face,
                index,
                unrotated: glam::Vec3::new(c.x, c.y, -c.z).normalize(),
                solid_angle: texel * texel / c.length_squared().powf(1.5),
            }
        })
    })
}

/// A texel's linear RGB.
fn decode(format: TextureFormat, bytes: &[u8]) -> [f32; 3] {
    let word = |i: usize| [bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]];
    match format {
        TextureFormat::Rgba32Float => std::array::from_fn(|c| f32::from_le_bytes(word(4 * c))),
        TextureFormat::Rgba16Float => std::array::from_fn(|c| {
            half::f16::from_le_bytes([bytes[2 * c], bytes[2 * c + 1]]).to_f32()
        }),
        // Rgb9e5Ufloat: three 9-bit mantissas and a shared 5-bit exponent (bias 15).
        _ => {
            let bits = u32::from_le_bytes(word(0));
            let scale = 2f32.powi((bits >> 27) as i32 - 15 - 9);
            std::array::from_fn(|c| ((bits >> (9 * c)) & 0x1ff) as f32 * scale)
        }
    }
}

/// The environment of a diffuse cubemap (Bevy's `EnvironmentMapLight::diffuse_map`) turned by
/// `rotation`, before the light's intensity: SH of order 2.
pub(crate) fn diffuse_map_sh(
    image: &Image,
    rotation: Quat,
) -> Result<ShCoefficients, EnvironmentMapError> {
    let size = image.texture_descriptor.size;
    let (width, height, layers) = (size.width, size.height, size.depth_or_array_layers);
    if width != height || layers != 6 || width == 0 {
        return Err(EnvironmentMapError::NotCube {
            width,
            height,
            layers,
        });
    }
    let format = image.texture_descriptor.format;
    let texel_bytes = match format {
        TextureFormat::Rgba32Float => 16,
        TextureFormat::Rgba16Float => 8,
        TextureFormat::Rgb9e5Ufloat => 4,
        other => return Err(EnvironmentMapError::Format(other)),
    };
    let data = image.data.as_deref().ok_or(EnvironmentMapError::NoData)?;
    let level_bytes = |mip: u32| {
        let side = (width >> mip).max(1) as usize;
        side * side * texel_bytes
    };
    // Layer-major data holds each face's whole mip chain before the next face.
    let face_stride = match image.data_order {
        TextureDataOrder::LayerMajor => (0..image.texture_descriptor.mip_level_count)
            .map(level_bytes)
            .sum(),
        TextureDataOrder::MipMajor => level_bytes(0),
    };
    let needed = 5 * face_stride + level_bytes(0);
    if data.len() < needed {
        return Err(EnvironmentMapError::Short {
            found: data.len(),
            needed,
        });
    }

    let rotation = glam::Quat::from_array(rotation.to_array());
    let count = (ORDER + 1) * (ORDER + 1);
    let mut sums = vec![[0.0f64; 3]; count];
    for texel in cube_texels(width as usize) {
        let world = rotation * texel.unrotated;
        let offset = texel.face * face_stride + texel.index * texel_bytes;
        let value = decode(format, &data[offset..offset + texel_bytes]);
        for (sum, basis) in sums.iter_mut().zip(sh_basis(world, ORDER)) {
            for channel in 0..3 {
                sum[channel] += f64::from(value[channel]) * f64::from(basis * texel.solid_angle);
            }
        }
    }
    for l in 0..=ORDER {
        let a = lambert_zonal_coefficient(l);
        for m in -(l as i32)..=l as i32 {
            let sum = &mut sums[sh_index(l, m)];
            *sum = sum.map(|s| s / a);
        }
    }
    Ok(ShCoefficients {
        coefficients: sums.iter().map(|s| s.map(|v| v as f32)).collect(),
    })
}

/// `a + b` coefficient by coefficient (the shorter padded with zeros).
pub(crate) fn add_sh(a: &ShCoefficients, b: &ShCoefficients) -> ShCoefficients {
    let count = a.coefficients.len().max(b.coefficients.len());
    let at = |sh: &ShCoefficients, i: usize| sh.coefficients.get(i).copied().unwrap_or_default();
    ShCoefficients {
        coefficients: (0..count)
            .map(|i| {
                let (x, y) = (at(a, i), at(b, i));
                [x[0] + y[0], x[1] + y[1], x[2] + y[2]]
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::asset::RenderAssetUsages;
    use bevy::render::render_resource::{Extent3d, TextureDimension};
    use cdrf_core::environment::radiance_sh;

    /// A diffuse cubemap whose value at world direction N is `f(N)`.
    pub(crate) fn cubemap(side: u32, f: impl Fn(glam::Vec3) -> [f32; 3]) -> Image {
        let mut data = Vec::new();
        for texel in cube_texels(side as usize) {
            let value = f(texel.unrotated);
            for channel in [value[0], value[1], value[2], 1.0] {
                data.extend_from_slice(&channel.to_le_bytes());
            }
        }
        Image::new(
            Extent3d {
                width: side,
                height: side,
                depth_or_array_layers: 6,
            },
            TextureDimension::D2,
            data,
            TextureFormat::Rgba32Float,
            RenderAssetUsages::all(),
        )
    }

    /// A linear (band ≤ 1) diffuse map comes back: a white Lambertian surface lit by the
    /// projected environment returns the map's value at its normal.
    #[test]
    fn a_linear_diffuse_map_is_returned_at_each_normal() {
        let f = |n: glam::Vec3| [0.3 + 0.1 * n.y + 0.05 * n.x + 0.08 * n.z, 0.2, 0.1];
        let sh = diffuse_map_sh(&cubemap(32, f), Quat::IDENTITY).expect("a cubemap");
        let lambert: Vec<[f32; 3]> = (0..=ORDER)
            .map(|l| [lambert_zonal_coefficient(l) as f32; 3])
            .collect();
        for n in [
            glam::Vec3::X,
            glam::Vec3::NEG_Y,
            glam::Vec3::Z,
            glam::Vec3::new(1.0, 1.0, -1.0).normalize(),
        ] {
            let got = radiance_sh(&sh, &lambert, n);
            let want = f(n);
            for c in 0..3 {
                assert!((got[c] - want[c]).abs() < 1e-3, "{n}: {got:?} vs {want:?}");
            }
        }
    }

    #[test]
    fn a_turned_map_turns_its_light() {
        let f = |n: glam::Vec3| [0.5 + 0.4 * n.x, 0.5, 0.5];
        let turn = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
        let sh = diffuse_map_sh(&cubemap(16, f), turn).expect("a cubemap");
        let lambert = vec![[1.0; 3], [2.0 / 3.0; 3], [0.25; 3]];
        // The map's +x (bright) lands where the turn takes +x: −z.
        let bright = radiance_sh(&sh, &lambert, glam::Vec3::NEG_Z)[0];
        let dark = radiance_sh(&sh, &lambert, glam::Vec3::Z)[0];
        assert!(
            (bright - 0.9).abs() < 1e-3 && (dark - 0.1).abs() < 1e-3,
            "{bright} {dark}"
        );
    }

    #[test]
    fn maps_it_cannot_read_are_refused() {
        let mut image = cubemap(4, |_| [1.0; 3]);
        image.texture_descriptor.format = TextureFormat::Bc6hRgbUfloat;
        assert_eq!(
            diffuse_map_sh(&image, Quat::IDENTITY),
            Err(EnvironmentMapError::Format(TextureFormat::Bc6hRgbUfloat))
        );
        let mut image = cubemap(4, |_| [1.0; 3]);
        image.texture_descriptor.size.depth_or_array_layers = 1;
        assert!(matches!(
            diffuse_map_sh(&image, Quat::IDENTITY),
            Err(EnvironmentMapError::NotCube { layers: 1, .. })
        ));
        let mut image = cubemap(4, |_| [1.0; 3]);
        image.data.as_mut().expect("pixels").truncate(100);
        assert!(matches!(
            diffuse_map_sh(&image, Quat::IDENTITY),
            Err(EnvironmentMapError::Short { found: 100, .. })
        ));
    }
}
