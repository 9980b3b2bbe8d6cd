//! The subsurface gather's tables: what a renderer needs, per material, to add the light that
//! entered the surface far from a point and reached it through the medium, by the far field of
//! the measured table's diffusion profile ([`FarField`]).
//!
//! The renderer gathers `R_far(d)` over the lit surface (the [kernel](SubsurfaceTables::kernel))
//! and takes out of it [`F_sphere(κ, θ)`](SubsurfaceTables::sphere), the far field on the
//! point's osculating sphere — what the table already holds of the gathered light. On the shadow side the measured spheres glow more (or less)
//! than the profile's far field says; the **shadow gain** `s(κ, θ)` carries that ratio.
//!
//! ```
//! use cdrf_core::diffusion::{DiffusionProfile, FarField, ProfileTerm};
//! use cdrf_core::subsurface::SubsurfaceTables;
//! use cdrf_core::{CdrfLut, CurvatureAxis};
//! use cdrf_core::glam::Vec3;
//!
//! let profile = DiffusionProfile::new(
//!     vec![ProfileTerm { length_mm: 6.0, weight: [0.6, 0.4, 0.2] }],
//!     1.0,
//! )?;
//! let axis = CurvatureAxis::from_radii_mm(50.0, 10.0, 4);
//! let lut = CdrfLut::new(axis, 91, vec![Vec3::splat(0.5); 4 * 91])?;
//! let tables = SubsurfaceTables::new(&FarField::new(&profile, 1.0), &lut, 32);
//! assert_eq!(tables.sphere.len(), 4 * 91);
//! assert!(tables.kernel[0].x > tables.kernel[31].x);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use glam::Vec3;
use rayon::prelude::*;

use crate::diffusion::FarField;
use crate::lut::{CdrfLut, CurvatureAxis, theta_rad_at};

/// The confinement gain on the gather's light on the shadow side of a body thinner along the
/// light than the circle of the point's local shape predicts ([`confinement_gain`]): at most
/// 1 + this. Fitted to the blob, the capsule and Skin1's blob lit from behind, the side-lit
/// capsule, the torus and knot view 2 (docs/research/thick-bodies.md).
pub const CONFINEMENT_GAIN: f32 = 0.85;
/// The body's thickness in these many transmission lengths ℓ_T brings the gain to 1 − e⁻¹ of
/// its whole.
pub const CONFINEMENT_THICKNESS_LENGTHS: f32 = 2.0;
/// How much thinner than the chord (mm) a body must be before it counts as confining.
pub const CONFINEMENT_TOLERANCE_MM: f32 = 1.0;
/// n · the light's ray (−cos θ) from which the gain is whole: θ ≈ 115° (near the terminator the
/// light runs along the surface).
pub const CONFINEMENT_FULL_FROM: f32 = 0.42;

/// The gain on the gathered light G at a point on the shadow side of a body thinner along the
/// light than the circle of its local shape — wider than it is thick, as a thick body lit from
/// behind or a tube's far side: the spheres the profile was fitted to lose light through their
/// curved sides that such a body keeps. 1 on a sphere, whose chord is the circle's; it grows
/// with how much thinner the body is (on the scale of the transmission length ℓ_T) and with
/// the thickness itself (light that crossed a body a few ℓ_T thick), to at most
/// 1 + [`CONFINEMENT_GAIN`], faded in from the terminator to [`CONFINEMENT_FULL_FROM`]. Where
/// the curvature is ≤ 0 the chord is unbounded (thinner than any circle).
///
/// `thickness_mm`: the body along the light at the point; `along`: n · the light's ray (> 0 on
/// the shadow side); `curvature_per_mm`: the local shape's; `transmission_length_mm`: ℓ_T (one
/// channel's). 1 where any of them is not positive or not a number. The renderer's
/// `gather.wgsl` mirrors this.
///
/// ```
/// use cdrf_core::subsurface::{confinement_gain, CONFINEMENT_GAIN};
/// // A sphere of r = 20 mm, 130° from the light: its chord there is its thickness.
/// let along = 130f32.to_radians().cos().abs();
/// assert_eq!(confinement_gain(2.0 * 20.0 * along, along, 1.0 / 20.0, 9.0), 1.0);
/// // A 40 mm slab lit from straight behind confines almost the whole gain.
/// let slab = confinement_gain(40.0, 1.0, 0.0, 9.0);
/// assert!(slab > 1.0 + 0.85 * CONFINEMENT_GAIN && slab <= 1.0 + CONFINEMENT_GAIN);
/// ```
pub fn confinement_gain(
    thickness_mm: f32,
    along: f32,
    curvature_per_mm: f32,
    transmission_length_mm: f32,
) -> f32 {
    if !(thickness_mm > 0.0 && along > 0.0 && transmission_length_mm > 0.0) {
        return 1.0;
    }
    // The limit of a vanishing curvature, so the gain is continuous where it changes sign.
    let chord_mm = 2.0 * along / curvature_per_mm.max(1e-6);
    let thinner_mm = (chord_mm - thickness_mm - CONFINEMENT_TOLERANCE_MM).clamp(0.0, thickness_mm);
    let length_mm = transmission_length_mm;
    let thick = 1.0 - (-thickness_mm / (CONFINEMENT_THICKNESS_LENGTHS * length_mm)).exp();
    let t = (along / CONFINEMENT_FULL_FROM).clamp(0.0, 1.0);
    let deep = t * t * (3.0 - 2.0 * t);
    1.0 + CONFINEMENT_GAIN * deep * thick * (1.0 - (-thinner_mm / length_mm).exp())
}

/// The kernel reaches this many of the far field's longest length: beyond it `R_far` is below
/// e⁻¹² of its start.
pub const REACH_LENGTHS: f64 = 12.0;

/// The shadow gain is read from this light angle on, where the table's near field has died
/// out (the profile's own near part is below 3 % of its far field past 100°); toward the lit
/// side it holds its value there.
pub const GAIN_FROM_THETA_DEG: f32 = 100.0;

/// Bounds on the shadow gain: where `F_sphere` and the table both fade (deep shadow of a large
/// sphere) their ratio is the table's noise. (The renderer applies its square root, so
/// 0.5–2.)
pub const GAIN_RANGE: [f32; 2] = [0.25, 4.0];

/// A material's subsurface gather tables. `sphere` and `gain` lie on the measured table's axes:
/// `columns` θ columns ([`theta_rad_at`]) per row, `rows` κ rows, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct SubsurfaceTables {
    /// `R_far` per channel, mm⁻², at `d = reach · (i / (samples − 1))²` (a square-root grid:
    /// fine where `R_far` changes fastest).
    pub kernel: Vec<Vec3>,
    /// Where the kernel ends, mm: [`REACH_LENGTHS`] times the longest kept length (or the cut).
    pub reach_mm: f32,
    /// `F_sphere(κ, θ)` ([`sphere_far_field`]): what the gather replaces.
    pub sphere: Vec<Vec3>,
    /// The shadow gain `s(κ, θ)` ([`shadow_gain`]).
    pub gain: Vec<Vec3>,
    /// θ columns of `sphere` and `gain`.
    pub columns: usize,
    /// κ rows of `sphere` and `gain`.
    pub rows: usize,
}

impl SubsurfaceTables {
    /// The tables of `lut` (the measured table) and the far field of its diffusion profile,
    /// with `kernel_samples` samples of `R_far`.
    pub fn new(far: &FarField, lut: &CdrfLut, kernel_samples: usize) -> Self {
        let (reach_mm, kernel) = far_field_kernel(far, kernel_samples);
        let axis = lut.curvature_axis();
        let columns = lut.theta_count();
        let sphere = sphere_far_field(far, axis, columns);
        Self {
            kernel,
            reach_mm: reach_mm as f32,
            gain: shadow_gain(lut, &sphere, columns),
            sphere,
            columns,
            rows: axis.count,
        }
    }
}

/// `R_far(d)` per channel at `d = reach · (i / (samples − 1))²`, i = 0 … samples − 1, and the
/// reach in mm ([`REACH_LENGTHS`] times the longest kept length, at least the cut).
pub fn far_field_kernel(far: &FarField, samples: usize) -> (f64, Vec<Vec3>) {
    let reach_mm = REACH_LENGTHS * far.longest_mm().max(far.cut_mm());
    let last = (samples.max(2) - 1) as f64;
    let kernel = (0..samples)
        .map(|i| {
            let u = i as f64 / last;
            let r = far.reflectance_per_mm2(reach_mm * u * u);
            Vec3::new(r[0] as f32, r[1] as f32, r[2] as f32)
        })
        .collect();
    (reach_mm, kernel)
}

/// `F_sphere(κ, θ)`, the far field on the osculating sphere ([`FarField::sphere_reflectance`]),
/// on a table's axes: `axis.count` rows of `columns` θ columns ([`theta_rad_at`]), row-major.
/// Rows are computed in parallel; each value is the same as a call of its own.
pub fn sphere_far_field(far: &FarField, axis: CurvatureAxis, columns: usize) -> Vec<Vec3> {
    let mut sphere = vec![Vec3::ZERO; columns * axis.count];
    if columns == 0 {
        return sphere;
    }
    sphere
        .par_chunks_mut(columns)
        .enumerate()
        .for_each_init(Vec::new, |scratch, (row, values)| {
            let kappa = f64::from(axis.curvature_per_mm(row));
            for (column, value) in values.iter_mut().enumerate() {
                let theta = f64::from(theta_rad_at(column, columns));
                let f = far.sphere_reflectance(kappa, theta, scratch);
                *value = Vec3::new(f[0] as f32, f[1] as f32, f[2] as f32);
            }
        });
    sphere
}

/// The shadow gain `s(κ, θ) = f(κ, θ′) / F_sphere(κ, θ′)` per channel, `θ′ = max(θ, 100°)`
/// ([`GAIN_FROM_THETA_DEG`]), bounded to [`GAIN_RANGE`], and 1 where `F_sphere` vanishes: how
/// much more (or less) the measured sphere glows in its shadow than the profile's far field
/// says. `sphere` is `F_sphere` on the table's axes (`columns` per row).
pub fn shadow_gain(lut: &CdrfLut, sphere: &[Vec3], columns: usize) -> Vec<Vec3> {
    let from = (0..columns)
        .find(|&c| theta_rad_at(c, columns) >= GAIN_FROM_THETA_DEG.to_radians())
        .unwrap_or(columns.saturating_sub(1));
    let [low, high] = GAIN_RANGE;
    let mut gain = Vec::with_capacity(sphere.len());
    for (row, far_row) in sphere.chunks(columns.max(1)).enumerate() {
        let measured = lut.row(row);
        for column in 0..columns {
            let at = column.max(from);
            let (f, far) = (measured[at], far_row[at]);
            gain.push(Vec3::from_array(std::array::from_fn(|c| {
                if far[c] > 1e-6 {
                    (f[c] / far[c]).clamp(low, high)
                } else {
                    1.0
                }
            })));
        }
    }
    gain
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diffusion::{DiffusionProfile, ProfileTerm};

    fn profile() -> DiffusionProfile {
        DiffusionProfile::new(
            vec![
                ProfileTerm {
                    length_mm: 0.5,
                    weight: [0.2, 0.3, 0.4],
                },
                ProfileTerm {
                    length_mm: 8.0,
                    weight: [0.6, 0.4, 0.2],
                },
            ],
            1.0,
        )
        .unwrap()
    }

    /// The gain is the table over F_sphere per channel on the shadow side, held at its 100°
    /// value toward the lit side, bounded, and 1 where F_sphere vanishes.
    #[test]
    fn the_shadow_gain_is_the_shadow_side_ratio() {
        let columns = 181; // 1° per column
        let axis = CurvatureAxis {
            min_per_mm: 0.02,
            max_per_mm: 0.06,
            count: 2,
        };
        let mut radiance = Vec::new();
        let mut sphere = Vec::new();
        for row in 0..2 {
            for column in 0..columns {
                let far = if row == 1 && column >= 150 {
                    Vec3::ZERO
                } else {
                    Vec3::new(0.1, 0.2, 0.01) * (1.0 + column as f32 / 100.0)
                };
                // Red 1.5 × F, green 0.9 × F, blue 10 × F (bounded to 4).
                radiance.push(far * Vec3::new(1.5 + 0.001 * column as f32, 0.9, 10.0));
                sphere.push(far);
            }
        }
        let lut = CdrfLut::new(axis, columns, radiance).unwrap();
        let gain = shadow_gain(&lut, &sphere, columns);
        assert_eq!(gain.len(), sphere.len());
        let at = |row: usize, column: usize| gain[row * columns + column];
        let close = |a: Vec3, b: Vec3| (a - b).abs().max_element() < 1e-5;
        // Past 100° the ratio of its own column; before, the 100° column's.
        assert!(
            close(at(0, 120), Vec3::new(1.62, 0.9, 4.0)),
            "{}",
            at(0, 120)
        );
        assert!(close(at(0, 30), Vec3::new(1.6, 0.9, 4.0)), "{}", at(0, 30));
        assert!(close(at(0, 100), at(0, 0)));
        // No far field: no gain.
        assert!(close(at(1, 160), Vec3::ONE), "{}", at(1, 160));
    }

    /// The parallel table holds, value for value, what `FarField::sphere_reflectance` gives.
    #[test]
    fn the_sphere_table_is_the_far_field_on_each_rows_sphere() {
        let far = FarField::new(&profile(), 1.0);
        let axis = CurvatureAxis::from_radii_mm(100.0, 5.0, 7);
        let columns = 37;
        let table = sphere_far_field(&far, axis, columns);
        assert_eq!(table.len(), 7 * columns);
        for row in 0..axis.count {
            for column in 0..columns {
                let f = far.sphere_reflectance(
                    f64::from(axis.curvature_per_mm(row)),
                    f64::from(theta_rad_at(column, columns)),
                    &mut Vec::new(),
                );
                let expected = Vec3::new(f[0] as f32, f[1] as f32, f[2] as f32);
                assert_eq!(
                    table[row * columns + column],
                    expected,
                    "row {row} column {column}"
                );
            }
        }
        // The pole of the 100 mm row, facing the light: per term (entry power 1) the source at
        // chord d has μ = 1 − d²/(2r²) and c = −d/(2r), so ∫ e^(−d/ℓ)/ℓ · μ · (1 − c·loss) dd
        // = 1 − ℓ²/r² − loss·ℓ/(2r) (to O((ℓ/r)³)); the far field is the 8 mm term less ℓ_c/ℓ
        // of the 1 mm cut's.
        let facing = table[0];
        let (r, ell, cut) = (100.0, 8.0, 1.0);
        let loss = f64::from(crate::diffusion::UPSTREAM_LOSS);
        let term = |l: f64| 1.0 - l * l / (r * r) - loss * l / (2.0 * r);
        for (channel, weight) in [0.6, 0.4, 0.2].into_iter().enumerate() {
            let expected = (weight * (term(ell) - cut / ell * term(cut))) as f32;
            assert!(
                (facing[channel] - expected).abs() < 2e-3,
                "{facing} vs {expected}"
            );
        }
    }

    /// A constant profile of one term: the kernel starts at R_far(0) = w (1/ℓ_c − 1/ℓ)/(2πℓ),
    /// falls, and ends at the reach; the tables lie on the table's axes.
    #[test]
    fn the_kernel_and_the_tables_of_a_one_term_profile() {
        let profile = DiffusionProfile::new(
            vec![ProfileTerm {
                length_mm: 4.0,
                weight: [0.5; 3],
            }],
            1.0,
        )
        .unwrap();
        let far = FarField::new(&profile, 1.0);
        let (reach_mm, kernel) = far_field_kernel(&far, 16);
        assert_eq!(reach_mm, 48.0);
        let start = 0.5 * (1.0 - 1.0 / 4.0) / (std::f64::consts::TAU * 4.0);
        assert!(
            (f64::from(kernel[0].x) - start).abs() < 1e-7,
            "{}",
            kernel[0]
        );
        assert!(kernel.windows(2).all(|pair| pair[1].x < pair[0].x));
        assert!(kernel[15].x < 1e-5 * kernel[0].x);

        let axis = CurvatureAxis::from_radii_mm(40.0, 10.0, 3);
        let lut = CdrfLut::new(axis, 19, vec![Vec3::splat(0.7); 3 * 19]).unwrap();
        let tables = SubsurfaceTables::new(&far, &lut, 16);
        assert_eq!((tables.columns, tables.rows), (19, 3));
        assert_eq!((tables.sphere.len(), tables.gain.len()), (3 * 19, 3 * 19));
    }
}
