//! The view's azimuth: what a table measured with the camera at 90° to the light misses when
//! the camera is elsewhere (docs/shading.md, "The view's azimuth").
//!
//! Light under the surface flows away from the light; a view along the flow sees more of it.
//! The diffusion approximation's flux term, L ∝ φ − ℓ·∇φ·ω, gives per channel the factor h(x),
//! x = ℓ·a·(−v·l)/sin θ, with a = κ·(−∂ ln f/∂θ) how fast f falls along the surface, v·l the
//! cosine between the view and the light (0 in the photographs: h = 1 there) and ℓ the
//! transport mean free path ([`flux_length_mm`]). The renderer multiplies the table by it
//! (cdrf-render's `tables.wgsl` reads these constants); cdrf-fit divides photographs taken at
//! another angle by it. Measured in docs/research/thick-bodies.md and captures.md.

use std::f32::consts::PI;

use glam::Vec3;

/// ℓ, mm, of a translucent material: the transport mean free path of the wax and of Skin1's red
/// (1 mm); on the r = 20 mm wax sphere lit from behind the fitted value is 0.85–1.07 mm at the
/// terminator.
pub const FLUX_LENGTH_MM: f32 = 1.0;
/// A diffusion profile whose mean distance is no longer than this is the surface's own: light
/// that does not travel under the surface does not flow (a Lambertian sphere's fitted profile
/// sits on cdrf-fit's shortest term, 0.25 mm).
pub const SURFACE_LENGTH_MM: f32 = 0.25;
/// On the shadow side light that crossed the body flows too: for a view along the flow ℓ grows
/// to ℓ·(1 + SHADOW_FLUX_GAIN·|cos θ|) (set on the r = 20 mm wax sphere lit from behind).
pub const SHADOW_FLUX_GAIN: f32 = 2.4;
/// The floor of sin θ in x on the lit side (cos θ > 0): within 20° of θ = 0 the azimuth is
/// ill-defined, and the photographs saw those points only at grazing angles.
pub const LIT_MIN_SINE: f32 = 0.35;
/// The floor of sin θ in x on the shadow side: only a guard of the division, since near the
/// anti-light pole the flow falls as sin θ ([`POLE_FROM_RAD`]), so x keeps its value there.
pub const SHADOW_MIN_SINE: f32 = 1e-3;
/// A view against the flow (x < 0) loses less than a view along it gains: h = 1/(1 − 0.8·x)
/// there. Set on the path-traced captures with the lamp 53–83° from the camera
/// (docs/research/captures.md); 1/(1 − x) left their terminators 2–6 % too bright once divided.
pub const AGAINST_FLOW_SCALE: f32 = 0.8;
/// The exponent's cap (a factor of e² ≈ 7.4).
pub const EXPONENT_LIMIT: f32 = 2.0;
/// Half the θ span of [`falloff_per_rad`]'s differences, radians (5°).
pub const SLOPE_HALF_WIDTH_RAD: f32 = 5.0 * PI / 180.0;
/// From this θ (radians, 130°) ln f is averaged before its slope is taken, over a window
/// growing to ±2 × [`SLOPE_HALF_WIDTH_RAD`] at [`POLE_FROM_RAD`]: a photograph's deep shadow
/// side is a few pixels a node, and its wiggles, times the shadow side's growth and e^x, drew
/// rings on a body lit from behind.
pub const SHADOW_SMOOTHING_FROM_RAD: f32 = 130.0 * PI / 180.0;
/// Within 20° of the anti-light pole (from 160°) the flow is the even continuation of its value
/// here, ln f ≈ a + b·(π − θ)²/2 (a sphere's f is symmetric about the pole), so it falls as
/// sin θ and x keeps its value: the photographs barely measure this cap and the table holds
/// the diffusion profile's continuation there (cdrf-fit's tails), whose join with the last
/// measured nodes is no slope to read.
pub const POLE_FROM_RAD: f32 = 160.0 * PI / 180.0;

/// ℓ per channel, mm, for a material whose diffusion profile's mean distance is
/// `mean_distance_mm` (`DiffusionProfile::mean_distance_mm`): [`FLUX_LENGTH_MM`], less by what
/// the profile falls short of [`SURFACE_LENGTH_MM`] + ℓ, 0 for an opaque surface. `None` (a
/// table that does not say how far its light travels) is taken as translucent.
pub fn flux_length_mm(mean_distance_mm: Option<[f32; 3]>) -> Vec3 {
    mean_distance_mm.map_or(Vec3::splat(FLUX_LENGTH_MM), |d| {
        (Vec3::from_array(d) - Vec3::splat(SURFACE_LENGTH_MM))
            .clamp(Vec3::ZERO, Vec3::splat(FLUX_LENGTH_MM))
    })
}

/// −∂ ln f / ∂θ, per radian, of one curve f on `values.len()` uniform θ nodes over [0, π] (at
/// least two), at least 0: central differences over ±5° (one-sided at the ends), f floored at
/// 10⁻⁴ of its largest value (a fitted curve's small wiggles and zeros would otherwise show);
/// from [`SHADOW_SMOOTHING_FROM_RAD`] on ln f is averaged over a widening window first, and from
/// [`POLE_FROM_RAD`] on the rate there falls as sin θ, to 0 at π.
pub fn falloff_per_rad(values: &[Vec3]) -> Vec<Vec3> {
    let columns = values.len();
    if columns < 2 {
        return vec![Vec3::ZERO; columns];
    }
    let last = columns - 1;
    let step = PI / last as f32;
    let reach = ((SLOPE_HALF_WIDTH_RAD / step).round() as usize).max(1);
    let floor = values.iter().fold(Vec3::ZERO, |m, v| m.max(*v)) * 1e-4;
    let ln = |j: usize| {
        values[j]
            .max(floor)
            .max(Vec3::splat(f32::MIN_POSITIVE))
            .ln()
    };
    let smoothing = (POLE_FROM_RAD - SHADOW_SMOOTHING_FROM_RAD).max(f32::EPSILON);
    let smoothed: Vec<Vec3> = (0..columns)
        .map(|j| {
            let theta = j as f32 * step;
            let share = ((theta - SHADOW_SMOOTHING_FROM_RAD) / smoothing).clamp(0.0, 1.0);
            // Narrowed evenly at the ends, so that the window stays centred on the node.
            let half = ((share * (2 * reach) as f32).round() as usize)
                .min(j)
                .min(last - j);
            (j - half..=j + half).map(ln).sum::<Vec3>() / (2 * half + 1) as f32
        })
        .collect();
    let rate = |j: usize| {
        let (a, b) = (j.saturating_sub(reach), (j + reach).min(last));
        let slope = (smoothed[b] - smoothed[a]) / ((b - a) as f32 * step);
        (-slope).max(Vec3::ZERO)
    };
    // At least one node past it, so that the rate at π is 0 on any grid.
    let pole = ((POLE_FROM_RAD / step).round() as usize).min(last - 1);
    let at_pole = rate(pole) / (pole as f32 * step).sin().max(f32::EPSILON);
    (0..columns)
        .map(|j| {
            if j > pole {
                at_pole * (j as f32 * step).sin().max(0.0)
            } else {
                rate(j)
            }
        })
        .collect()
}

/// ℓ·(−∂ ln f / ∂θ), mm per radian, of one curve (as [`falloff_per_rad`]) for a material of
/// transport mean free path `length_mm` per channel ([`flux_length_mm`]): what [`factor`] reads.
pub fn flow_mm_per_rad(values: &[Vec3], length_mm: Vec3) -> Vec<Vec3> {
    falloff_per_rad(values)
        .into_iter()
        .map(|rate| rate * length_mm)
        .collect()
}

/// h(x) per channel at a point of curvature `curvature_per_mm` (mm⁻¹; none below 0) where the
/// table's flow is `flow_mm_per_rad` (ℓ·(−∂ ln f/∂θ): [`flux_length_mm`] times
/// [`falloff_per_rad`]), at `theta_rad` from the light, seen from a view whose cosine to the
/// light is `view_dot_light`. Mirrors `view_azimuth` in cdrf-render's tables.wgsl.
pub fn factor(
    curvature_per_mm: f32,
    flow_mm_per_rad: Vec3,
    theta_rad: f32,
    view_dot_light: f32,
) -> Vec3 {
    let sine_floor = if theta_rad.cos() > 0.0 {
        LIT_MIN_SINE
    } else {
        SHADOW_MIN_SINE
    };
    let across = -view_dot_light / theta_rad.sin().max(sine_floor);
    let along_flow = if across >= 0.0 { 1.0 } else { 0.0 };
    let shadow = (-theta_rad.cos()).max(0.0) * along_flow;
    let growth = 1.0 + SHADOW_FLUX_GAIN * shadow;
    let x = (growth * curvature_per_mm.max(0.0) * flow_mm_per_rad * across)
        .min(Vec3::splat(EXPONENT_LIMIT));
    Vec3::select(
        x.cmpge(Vec3::ZERO),
        x.exp(),
        Vec3::ONE / (Vec3::ONE - AGAINST_FLOW_SCALE * x),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At 90° between the view and the light nothing changes; behind brightens, beside the
    /// camera darkens, and a plane (κ = 0) has no flow.
    #[test]
    fn one_at_ninety_degrees_and_on_a_plane() {
        let falloff = Vec3::new(8.0, 10.0, 12.0) * FLUX_LENGTH_MM;
        let theta = 95f32.to_radians();
        assert_eq!(factor(0.05, falloff, theta, 0.0), Vec3::ONE);
        assert_eq!(factor(0.0, falloff, theta, -0.8), Vec3::ONE);
        let behind = factor(0.05, falloff, theta, -0.8);
        let front = factor(0.05, falloff, theta, 0.8);
        assert!(
            behind.min_element() > 1.3 && front.max_element() < 0.8,
            "{behind} {front}"
        );
        // Capped.
        let far = factor(1.0, Vec3::splat(100.0), theta, -1.0);
        assert!(
            (far - Vec3::splat(EXPONENT_LIMIT.exp()))
                .abs()
                .max_element()
                < 1e-4
        );
    }

    /// A translucent profile flows at ℓ, an opaque one (a Lambertian fit's) not at all, and a
    /// table that does not say is taken as translucent.
    #[test]
    fn an_opaque_surface_has_no_flow() {
        let length = flux_length_mm(Some([3.2, 1.1, SURFACE_LENGTH_MM]));
        assert_eq!(length.x, FLUX_LENGTH_MM);
        assert!((length.y - (1.1 - SURFACE_LENGTH_MM)).abs() < 1e-6);
        assert_eq!(length.z, 0.0);
        assert_eq!(flux_length_mm(None), Vec3::splat(FLUX_LENGTH_MM));
        assert_eq!(
            factor(0.1, length * 0.0, 95f32.to_radians(), 0.8),
            Vec3::ONE
        );
    }
}
