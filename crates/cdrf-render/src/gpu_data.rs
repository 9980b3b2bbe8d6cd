//! Tables as `Rgba16Float` texel data.

use cdrf_core::glam::Vec3;
use half::f16;

/// RGB values as `Rgba16Float` texels (alpha 1), in native byte order; each channel rounded to
/// the nearest half float (ties to even; overflow gives ±∞, NaN stays NaN).
pub(crate) fn rgba16f_texels(values: &[Vec3]) -> Vec<u8> {
    let mut bytes = Vec::with_capacity(values.len() * 8);
    for value in values {
        for channel in [value.x, value.y, value.z, 1.0] {
            bytes.extend_from_slice(&f16::from_f32(channel).to_bits().to_ne_bytes());
        }
    }
    bytes
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The conversion the texels rely on: round to nearest even, ±∞ on overflow, NaN kept,
    /// and every half float back to itself.
    #[test]
    fn half_floats_round_trip_and_round_to_nearest_even() {
        let bits = |value: f32| f16::from_f32(value).to_bits();
        let value = |bits: u16| f16::from_bits(bits).to_f32();
        for x in [0.0f32, 1.0, -2.5, 0.333_333, 65504.0, 6.1e-5, 5.96e-8, 1e-3] {
            let back = value(bits(x));
            let relative = ((back - x) / x.abs().max(6.1e-5)).abs();
            assert!(relative <= 2f32.powi(-11), "{x} → {back}");
        }
        // Exactly halfway between 1 and the next half (1 + 2⁻¹⁰): rounds to even (1).
        assert_eq!(bits(1.0 + 2f32.powi(-11)), 0x3c00);
        assert_eq!(bits(1.0 + 3.0 * 2f32.powi(-11)), 0x3c02);
        assert_eq!(bits(1e6), 0x7c00);
        assert_eq!(bits(-1e6), 0xfc00);
        assert!(value(bits(f32::NAN)).is_nan());
        for half in 0..=u16::MAX {
            let x = value(half);
            if !x.is_nan() {
                assert_eq!(bits(x), half, "bits {half:#06x} = {x}");
            }
        }
        // The texels: RGB then alpha 1 (0x3c00).
        let texel = rgba16f_texels(&[Vec3::new(1.0, 0.5, -2.0)]);
        let halves: Vec<u16> = texel
            .chunks_exact(2)
            .map(|b| u16::from_ne_bytes([b[0], b[1]]))
            .collect();
        assert_eq!(halves, [0x3c00, 0x3800, 0xc000, 0x3c00]);
    }
}
