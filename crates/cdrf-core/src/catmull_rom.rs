//! Catmull-Rom interpolation through points with non-uniform knots.
//!
//! The measured spheres are uniform in radius (15, 20, …, 50 mm) and therefore **not** uniform in
//! curvature κ = 1/r, the axis the table is built on. A uniform Catmull-Rom spline would treat the
//! knots as equally spaced and bend the curve; this module uses the non-uniform (Barry–Goldman)
//! form instead.
//!
//! # The curve
//! The spline is a piecewise cubic Hermite curve through every point `(xᵢ, yᵢ)`. Its tangent at an
//! interior knot is the slope of the parabola through the knot and its two neighbours,
//!
//! ```text
//! mᵢ = (dᵢ₋₁·hᵢ + dᵢ·hᵢ₋₁) / (hᵢ₋₁ + hᵢ),   hᵢ = xᵢ₊₁ − xᵢ,   dᵢ = (yᵢ₊₁ − yᵢ) / hᵢ,
//! ```
//!
//! which is exactly the tangent of the Barry–Goldman non-uniform Catmull-Rom spline with the knots
//! as its parameter (for uniform knots it reduces to the classic `(yᵢ₊₁ − yᵢ₋₁) / 2h`). At the two
//! end knots the tangent is the slope of the end segment. Consequences, each tested:
//! - the curve passes through every point;
//! - data on a straight line is reproduced exactly, between and at the knots;
//! - outside `[x₀, xₙ₋₁]` the curve is **clamped** to the end values (no extrapolation).
//!
//! # Overshoot
//! Like every Catmull-Rom spline, [`Tangents::CatmullRom`] can overshoot near a sudden change. For
//! a single step of height `Δ` (flat, then a jump over one interval of width `h_step`, then flat),
//! the curve leaves the data range by at most
//!
//! ```text
//! (4/27) · ρ² / (1 + ρ) · Δ,   ρ = h_flat / h_step,
//! ```
//!
//! where `h_flat` is the width of the flat interval next to the jump: 7.4 % of the step for uniform
//! knots. [`Tangents::Monotone`] limits the tangents (Fritsch–Carlson) so the curve never leaves
//! the range of its neighbouring points and is monotone wherever the data is; it keeps the other
//! two properties.

use std::ops::{Add, Mul, Sub};

use thiserror::Error;

/// A value a spline can interpolate: `f32`, [`glam::Vec3`] (RGB), and anything else with
/// vector-space arithmetic.
pub trait SplineValue:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<f32, Output = Self>
{
    /// Applies `f` to every component (used by the monotone tangent limiter).
    fn map_components(self, f: impl Fn(f32) -> f32) -> Self;
    /// Combines two values component by component.
    fn zip_components(self, other: Self, f: impl Fn(f32, f32) -> f32) -> Self;
}

impl SplineValue for f32 {
    fn map_components(self, f: impl Fn(f32) -> f32) -> Self {
        f(self)
    }
    fn zip_components(self, other: Self, f: impl Fn(f32, f32) -> f32) -> Self {
        f(self, other)
    }
}

impl SplineValue for glam::Vec3 {
    fn map_components(self, f: impl Fn(f32) -> f32) -> Self {
        glam::Vec3::new(f(self.x), f(self.y), f(self.z))
    }
    fn zip_components(self, other: Self, f: impl Fn(f32, f32) -> f32) -> Self {
        glam::Vec3::new(f(self.x, other.x), f(self.y, other.y), f(self.z, other.z))
    }
}

/// How the tangents at the knots are chosen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Tangents {
    /// Non-uniform Catmull-Rom (Barry–Goldman): smooth, may overshoot as documented above.
    #[default]
    CatmullRom,
    /// Catmull-Rom tangents limited per component (Fritsch–Carlson): no overshoot.
    Monotone,
}

/// Why a spline could not be built.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum SplineError {
    /// Knots and values differ in length.
    #[error("{knots} knots but {values} values: a spline needs one value per knot")]
    LengthMismatch {
        /// Number of knots given.
        knots: usize,
        /// Number of values given.
        values: usize,
    },
    /// Fewer than two points.
    #[error("{0} point(s): a spline needs at least 2")]
    TooFewPoints(usize),
    /// A knot is NaN or infinite.
    #[error("knot {index} is {value}: knots must be finite")]
    NonFiniteKnot {
        /// Position of the knot in the input.
        index: usize,
        /// Its value.
        value: f32,
    },
    /// Knots are not strictly increasing.
    #[error(
        "knot {index} ({value}) is not greater than the one before ({previous}): knots must increase strictly"
    )]
    KnotsNotIncreasing {
        /// Position of the offending knot.
        index: usize,
        /// Its value.
        value: f32,
        /// The knot before it.
        previous: f32,
    },
}

/// A Catmull-Rom spline through `(knot, value)` points with strictly increasing knots.
///
/// ```
/// use cdrf_core::catmull_rom::CatmullRom;
/// // Curvatures of spheres with radii 50, 40, 30, 20 mm, and some value measured on each.
/// let curvature_per_mm = [1.0 / 50.0, 1.0 / 40.0, 1.0 / 30.0, 1.0 / 20.0];
/// let spline = CatmullRom::new(&curvature_per_mm, &[0.10_f32, 0.13, 0.18, 0.27])?;
/// assert_eq!(spline.evaluate(1.0 / 40.0), 0.13); // passes through its points
/// assert_eq!(spline.evaluate(0.0), 0.10); // clamped outside the knots
/// # Ok::<(), cdrf_core::catmull_rom::SplineError>(())
/// ```
#[derive(Clone, Debug)]
pub struct CatmullRom<T> {
    knots: Vec<f32>,
    values: Vec<T>,
    tangents: Vec<T>,
}

impl<T: SplineValue> CatmullRom<T> {
    /// A spline with [`Tangents::CatmullRom`].
    ///
    /// # Errors
    /// When knots and values differ in length, there are fewer than two points, or the knots are
    /// not finite and strictly increasing.
    pub fn new(knots: &[f32], values: &[T]) -> Result<Self, SplineError> {
        Self::with_tangents(knots, values, Tangents::CatmullRom)
    }

    /// A spline with the given tangent rule.
    ///
    /// # Errors
    /// As [`CatmullRom::new`].
    pub fn with_tangents(
        knots: &[f32],
        values: &[T],
        tangents: Tangents,
    ) -> Result<Self, SplineError> {
        if knots.len() != values.len() {
            return Err(SplineError::LengthMismatch {
                knots: knots.len(),
                values: values.len(),
            });
        }
        if knots.len() < 2 {
            return Err(SplineError::TooFewPoints(knots.len()));
        }
        for (index, &value) in knots.iter().enumerate() {
            if !value.is_finite() {
                return Err(SplineError::NonFiniteKnot { index, value });
            }
            if index > 0 && value <= knots[index - 1] {
                return Err(SplineError::KnotsNotIncreasing {
                    index,
                    value,
                    previous: knots[index - 1],
                });
            }
        }
        let tangents = knot_tangents(knots, values, tangents);
        Ok(Self {
            knots: knots.to_vec(),
            values: values.to_vec(),
            tangents,
        })
    }

    /// The knots, strictly increasing.
    pub fn knots(&self) -> &[f32] {
        &self.knots
    }

    /// The value at `x`; the end values outside the knots.
    pub fn evaluate(&self, x: f32) -> T {
        let last = self.knots.len() - 1;
        if x.is_nan() || x <= self.knots[0] {
            return self.values[0];
        }
        if x >= self.knots[last] {
            return self.values[last];
        }
        // First knot greater than x; x lies in [knots[i], knots[i + 1]).
        let i = self.knots.partition_point(|&k| k <= x) - 1;
        let h = self.knots[i + 1] - self.knots[i];
        hermite(
            self.values[i],
            self.values[i + 1],
            self.tangents[i] * h,
            self.tangents[i + 1] * h,
            (x - self.knots[i]) / h,
        )
    }
}

/// How a uniform-knot spline ([`evaluate_uniform`]) treats its first and last knot.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Ends {
    /// The end tangent is the end segment's slope, as in [`CatmullRom`].
    #[default]
    OneSided,
    /// The data is mirrored about the end knots, so the end tangents are 0: right for a
    /// function that is even about its ends, like f(θ) about θ = 0 and θ = π.
    Mirrored,
}

/// Evaluates the uniform-knot spline through `values` (knot `i` at `u = i`) at `u`, clamped to
/// `[0, values.len() − 1]`: the table's filter. With [`Ends::OneSided`] it is the same curve as
/// [`CatmullRom`] on knots `0, 1, 2, …`.
///
/// # Panics
/// If `values` is empty.
pub fn evaluate_uniform<T: SplineValue>(values: &[T], u: f32, ends: Ends) -> T {
    let last = values.len() - 1;
    if last == 0 || u.is_nan() || u <= 0.0 {
        return values[0];
    }
    if u >= last as f32 {
        return values[last];
    }
    let i = (u as usize).min(last - 1);
    let t = u - i as f32;
    let tangent = |k: usize| -> T {
        match (k == 0 || k == last, ends) {
            (false, _) => (values[k + 1] - values[k - 1]) * 0.5,
            (true, Ends::Mirrored) => values[k] * 0.0,
            (true, Ends::OneSided) if k == 0 => values[1] - values[0],
            (true, Ends::OneSided) => values[last] - values[last - 1],
        }
    };
    hermite(values[i], values[i + 1], tangent(i), tangent(i + 1), t)
}

/// Cubic Hermite segment from `p0` to `p1` with end derivatives `m0`, `m1` (per unit `t`).
fn hermite<T: SplineValue>(p0: T, p1: T, m0: T, m1: T, t: f32) -> T {
    let t2 = t * t;
    let t3 = t2 * t;
    p0 * (2.0 * t3 - 3.0 * t2 + 1.0)
        + m0 * (t3 - 2.0 * t2 + t)
        + p1 * (-2.0 * t3 + 3.0 * t2)
        + m1 * (t3 - t2)
}

fn knot_tangents<T: SplineValue>(knots: &[f32], values: &[T], rule: Tangents) -> Vec<T> {
    let n = knots.len();
    let secant = |i: usize| (values[i + 1] - values[i]) * (1.0 / (knots[i + 1] - knots[i]));
    (0..n)
        .map(|i| {
            if i == 0 {
                return secant(0);
            }
            if i == n - 1 {
                return secant(n - 2);
            }
            let (h0, h1) = (knots[i] - knots[i - 1], knots[i + 1] - knots[i]);
            let (d0, d1) = (secant(i - 1), secant(i));
            let m = (d0 * h1 + d1 * h0) * (1.0 / (h0 + h1));
            match rule {
                Tangents::CatmullRom => m,
                Tangents::Monotone => limit_monotone(m, d0, d1),
            }
        })
        .collect()
}

/// Fritsch–Carlson: zero at a local extremum, otherwise at most three times the smaller secant.
fn limit_monotone<T: SplineValue>(m: T, d0: T, d1: T) -> T {
    let bound = d0.zip_components(d1, |a, b| {
        if a * b <= 0.0 {
            0.0
        } else {
            3.0 * a.abs().min(b.abs())
        }
    });
    m.zip_components(bound, |m, bound| m.clamp(-bound, bound))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_matches_general_spline() {
        let values = [0.0_f32, 0.3, 1.5, 1.2, 4.0];
        let knots = [0.0_f32, 1.0, 2.0, 3.0, 4.0];
        let spline = CatmullRom::new(&knots, &values).unwrap();
        for step in 0..=80 {
            let u = step as f32 * 0.05;
            let (a, b) = (
                spline.evaluate(u),
                evaluate_uniform(&values, u, Ends::OneSided),
            );
            assert!((a - b).abs() < 1e-5, "u = {u}: general {a}, uniform {b}");
        }
    }
}
