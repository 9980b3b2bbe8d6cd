//! `CdrfLut::flow_mm_per_rad`: ℓ·(−∂ ln f / ∂θ), the rate the view's azimuth term reads. These
//! tables carry no diffusion profile, so ℓ is `FLUX_LENGTH_MM` in every channel.

use std::f32::consts::PI;

use cdrf_core::azimuth::FLUX_LENGTH_MM;
use cdrf_core::glam::Vec3;
use cdrf_core::{CdrfLut, CurvatureAxis};

const COLUMNS: usize = 181;

fn table(f: impl Fn(f32) -> Vec3) -> CdrfLut {
    table_of(COLUMNS, f)
}

fn table_of(columns: usize, f: impl Fn(f32) -> Vec3) -> CdrfLut {
    let axis = CurvatureAxis::from_radii_mm(50.0, 5.0, 4);
    let radiance = (0..axis.count * columns)
        .map(|i| f(PI * (i % columns) as f32 / (columns - 1) as f32))
        .collect();
    CdrfLut::new(axis, columns, radiance).unwrap()
}

/// f = exp(−θ/w) per channel: ln f is linear, so the rate is ℓ/w at every θ up to the
/// anti-light pole's cap (from 160°), where it falls as sin θ from that value, to 0 at π (the
/// widths keep f above the floor of 10⁻⁴ of its largest value up to θ = π).
#[test]
fn an_exponential_falls_at_one_over_its_width() {
    let widths = Vec3::new(0.9, 0.6, 0.4);
    let expected = FLUX_LENGTH_MM / widths;
    // The table's grid and the coarsest the fit writes (10° a column).
    for columns in [COLUMNS, 19] {
        let lut = table_of(columns, |theta| (-Vec3::splat(theta) / widths).exp());
        let falloff = lut.flow_mm_per_rad();
        assert_eq!(falloff.len(), lut.curvature_axis().count * columns);
        for (i, rate) in falloff.iter().enumerate() {
            let theta = 180.0 * (i % columns) as f32 / (columns - 1) as f32;
            let cap = if theta > 160.0 {
                theta.to_radians().sin() / 160f32.to_radians().sin()
            } else {
                1.0
            };
            let error = ((*rate - expected * cap) / expected).abs().max_element();
            assert!(
                error < 1e-3,
                "{columns} columns, texel {i}: {rate} against {}",
                expected * cap
            );
        }
    }
}

/// One node of the deep shadow side 30 % low (a photograph's few pixels there) barely moves
/// the rate from 140° to 160°: the shadow side is averaged before its slope is taken (without
/// it, +2 rad⁻¹ on a rate of 1.7 either side of the node).
#[test]
fn a_wiggle_deep_on_the_shadow_side_does_not_spike_the_rate() {
    let width = 0.6;
    let dip = 155.0_f32.to_radians();
    let lut = table(|theta| {
        let f = (-theta / width).exp();
        Vec3::splat(if (theta - dip).abs() < 1e-3 {
            0.7 * f
        } else {
            f
        })
    });
    let expected = FLUX_LENGTH_MM / width;
    let falloff = lut.flow_mm_per_rad();
    for (column, rate) in falloff[..COLUMNS].iter().enumerate().skip(140).take(21) {
        let error = ((rate.x - expected) / expected).abs();
        assert!(error < 0.1, "column {column}: {rate} against {expected}");
    }
}

/// A table rising with θ has no flow away from the light: 0, never negative; zeros in the
/// table (an unlit far side) give finite rates.
#[test]
fn the_rate_is_never_negative_and_always_finite() {
    let rising = table(|theta| Vec3::splat(1.0 + theta));
    assert!(rising.flow_mm_per_rad().iter().all(|r| *r == Vec3::ZERO));
    let dark = table(|theta| Vec3::splat(theta.cos().max(0.0)));
    let rates = dark.flow_mm_per_rad();
    assert!(
        rates
            .iter()
            .all(|r| r.is_finite() && r.min_element() >= 0.0)
    );
    // Past the terminator f is 0 on both sides of the difference: no flow there.
    assert_eq!(rates[COLUMNS - 1], Vec3::ZERO);
}
