// Numeric constants and the angle from its cosine, for every shading-side pass.
// How the shaders are composed: docs/shading.md.

const PI: f32 = 3.14159265358979;
const FRAC_1_PI: f32 = 0.318309886183791;
const FRAC_2_PI: f32 = 0.636619772367581;
const FRAC_PI_2: f32 = 1.5707963267949;
const FRAC_1_SQRT_TAU: f32 = 0.398942280401433;

// Angle in [0, π] from its cosine: Abramowitz & Stegun 4.4.45, |error| ≤ 6.8e-5 rad (0.004°,
// a hundredth of a LUT column), cheaper than acos on software rasterisers.
fn angle(cosine: f32) -> f32 {
    let x = clamp(cosine, -1.0, 1.0);
    let a = abs(x);
    let r = sqrt(1.0 - a) * (1.5707288 + a * (-0.2121144 + a * (0.0742610 - 0.0187293 * a)));
    return select(r, PI - r, x < 0.0);
}
