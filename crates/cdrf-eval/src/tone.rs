//! What FLIP and the figures see: the images exposed, clamped and sRGB-encoded.

use cdrf_core::image_file::{RgbaImage, linear_to_srgb};

/// Rec. 709 luminance of a linear RGB pixel.
fn luminance(p: [f32; 4]) -> f32 {
    0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]
}

/// The exposure that puts the reference's 99th-percentile luminance (over the mask) at 0.9.
pub(crate) fn tone_exposure(reference: &RgbaImage, mask: &[bool]) -> f32 {
    let mut values: Vec<f32> = reference
        .pixels
        .iter()
        .zip(mask)
        .filter(|(_, m)| **m)
        .map(|(p, _)| luminance(*p))
        .collect();
    values.sort_by(f32::total_cmp);
    let high = values
        .get(values.len() * 99 / 100)
        .copied()
        .unwrap_or(1.0)
        .max(1e-6);
    0.9 / high
}

/// Exposed, clamped, sRGB-encoded RGB bytes (what FLIP and the figure see).
pub(crate) fn tone_map(image: &RgbaImage, exposure: f32) -> Vec<u8> {
    image
        .pixels
        .iter()
        .flat_map(|p| {
            [0, 1, 2]
                .map(|c| (linear_to_srgb((p[c] * exposure).clamp(0.0, 1.0)) * 255.0).round() as u8)
        })
        .collect()
}

/// NVIDIA FLIP per pixel between two tone-mapped images (67 px/°).
pub(crate) fn flip_map(reference: &[u8], test: &[u8], width: u32, height: u32) -> Vec<f32> {
    let to_flip = |rgb: &[u8]| nv_flip::FlipImageRgb8::with_data(width, height, rgb);
    nv_flip::flip(
        to_flip(reference),
        to_flip(test),
        nv_flip::DEFAULT_PIXELS_PER_DEGREE,
    )
    .to_vec()
}
