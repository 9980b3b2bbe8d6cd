//! Half-float texture data and a blocking wait for wgpu's futures (no `unsafe`, no extra
//! dependencies).

use std::future::Future;
use std::pin::pin;
use std::sync::Arc;
use std::task::{Context, Poll, Wake, Waker};
use std::thread::{self, Thread};

use cdrf_core::glam::Vec3;

/// IEEE 754 binary16 bits of `value`, rounded to nearest even; overflow gives ±∞, NaN stays NaN.
pub(crate) fn f32_to_f16_bits(value: f32) -> u16 {
    let bits = value.to_bits();
    let sign = ((bits >> 16) & 0x8000) as u16;
    let exponent = ((bits >> 23) & 0xff) as i32;
    let mantissa = bits & 0x007f_ffff;
    if exponent == 0xff {
        // Inf or NaN (keep a quiet NaN bit).
        return sign | 0x7c00 | if mantissa != 0 { 0x0200 } else { 0 };
    }
    let half_exponent = exponent - 127 + 15;
    if half_exponent >= 0x1f {
        return sign | 0x7c00;
    }
    if half_exponent <= 0 {
        // Subnormal half (or zero): shift the implicit-1 mantissa into place, rounding to even.
        if half_exponent < -10 {
            return sign;
        }
        let full = mantissa | 0x0080_0000;
        let shift = (14 - half_exponent) as u32;
        let half_mantissa = full >> shift;
        let remainder = full & ((1 << shift) - 1);
        let halfway = 1 << (shift - 1);
        let round_up = remainder > halfway || (remainder == halfway && half_mantissa & 1 == 1);
        return sign | (half_mantissa + u32::from(round_up)) as u16;
    }
    let half = ((half_exponent as u32) << 10) | (mantissa >> 13);
    let remainder = mantissa & 0x1fff;
    let round_up = remainder > 0x1000 || (remainder == 0x1000 && half & 1 == 1);
    // A carry out of the mantissa correctly bumps the exponent (up to ∞).
    sign | (half + u32::from(round_up)) as u16
}

/// The f32 value of IEEE 754 binary16 bits (exact).
pub(crate) fn f16_bits_to_f32(bits: u16) -> f32 {
    let sign = if bits & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exponent = i32::from((bits >> 10) & 0x1f);
    let mantissa = f32::from(bits & 0x03ff);
    match exponent {
        0 => sign * mantissa * 2f32.powi(-24),
        0x1f if mantissa == 0.0 => sign * f32::INFINITY,
        0x1f => f32::NAN,
        _ => sign * (1.0 + mantissa / 1024.0) * 2f32.powi(exponent - 15),
    }
}

/// RGB values as `Rgba16Float` texels (alpha 1), in native byte order.
pub(crate) fn rgba16f_texels(values: &[Vec3]) -> Vec<u8> {
    let mut bytes = Vec::with_capacity(values.len() * 8);
    for value in values {
        for channel in [value.x, value.y, value.z, 1.0] {
            bytes.extend_from_slice(&f32_to_f16_bits(channel).to_ne_bytes());
        }
    }
    bytes
}

/// Runs a future to completion on this thread (wgpu's adapter and device requests resolve
/// at once on native backends; this just drives them without an async runtime).
pub(crate) fn block_on<F: Future>(future: F) -> F::Output {
    struct ThreadWaker(Thread);
    impl Wake for ThreadWaker {
        fn wake(self: Arc<Self>) {
            self.0.unpark();
        }
    }
    let waker = Waker::from(Arc::new(ThreadWaker(thread::current())));
    let mut context = Context::from_waker(&waker);
    let mut future = pin!(future);
    loop {
        match future.as_mut().poll(&mut context) {
            Poll::Ready(output) => return output,
            Poll::Pending => thread::park(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_floats_round_trip_and_round_to_nearest_even() {
        for value in [0.0f32, 1.0, -2.5, 0.333_333, 65504.0, 6.1e-5, 5.96e-8, 1e-3] {
            let back = f16_bits_to_f32(f32_to_f16_bits(value));
            let relative = ((back - value) / value.abs().max(6.1e-5)).abs();
            println!("{value} → {back} (relative error {relative:e})");
            assert!(relative <= 2f32.powi(-11), "{value} → {back}");
        }
        // Exactly halfway between 1 and the next half (1 + 2⁻¹⁰): rounds to even (1).
        assert_eq!(f32_to_f16_bits(1.0 + 2f32.powi(-11)), 0x3c00);
        assert_eq!(f32_to_f16_bits(1.0 + 3.0 * 2f32.powi(-11)), 0x3c02);
        assert_eq!(f32_to_f16_bits(1e6), 0x7c00);
        assert_eq!(f32_to_f16_bits(-1e6), 0xfc00);
        assert!(f16_bits_to_f32(f32_to_f16_bits(f32::NAN)).is_nan());
        // Every half-float converts to f32 and back to itself.
        for bits in 0..=u16::MAX {
            let value = f16_bits_to_f32(bits);
            if !value.is_nan() {
                assert_eq!(f32_to_f16_bits(value), bits, "bits {bits:#06x} = {value}");
            }
        }
    }
}
