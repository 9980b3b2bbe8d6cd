//! Small dense linear solvers: the few systems the curvature estimator and the fitter solve
//! (5 × 5 normal equations, 3 × 3 Gauss–Newton steps, tridiagonal spline systems, a few dozen
//! unknowns of a least-squares fit).
//!
//! Each keeps its own arithmetic (operation order, thresholds, what a singular system gives),
//! so results are the same to the bit wherever it is used.

use std::ops::{Div, Mul, Sub};

/// Pivots smaller than this in magnitude make a column singular in [`solve_gaussian`].
pub const TINY_PIVOT: f64 = 1e-300;

/// Solves `A x = b` for a symmetric positive definite `A` given by its lower triangle
/// (Cholesky factorisation, then forward and back substitution); `None` if `A` is numerically
/// singular (a diagonal of the factor not above `1e-10 · A_ii`).
///
/// ```
/// use cdrf_core::linear::solve_cholesky;
///
/// let a = [[4.0, 0.0], [2.0, 3.0]]; // the lower triangle of [[4, 2], [2, 3]]
/// let x = solve_cholesky(&a, &[8.0, 7.0]).unwrap();
/// assert!((x[0] - 1.25).abs() < 1e-12 && (x[1] - 1.5).abs() < 1e-12);
/// ```
#[allow(clippy::needless_range_loop)] // index notation mirrors the textbook algorithm
pub fn solve_cholesky<const N: usize>(a: &[[f64; N]; N], b: &[f64; N]) -> Option<[f64; N]> {
    let mut l = [[0.0f64; N]; N];
    for i in 0..N {
        for j in 0..=i {
            let mut sum = a[i][j];
            for k in 0..j {
                sum -= l[i][k] * l[j][k];
            }
            if i == j {
                if sum <= 1e-10 * a[i][i] || sum <= 0.0 {
                    return None;
                }
                l[i][i] = sum.sqrt();
            } else {
                l[i][j] = sum / l[j][j];
            }
        }
    }
    let mut y = [0.0f64; N];
    for i in 0..N {
        let mut sum = b[i];
        for k in 0..i {
            sum -= l[i][k] * y[k];
        }
        y[i] = sum / l[i][i];
    }
    let mut x = [0.0f64; N];
    for i in (0..N).rev() {
        let mut sum = y[i];
        for k in i + 1..N {
            sum -= l[k][i] * x[k];
        }
        x[i] = sum / l[i][i];
    }
    Some(x)
}

/// Solves the 3 × 3 system `m x = b` by Cramer's rule; `None` if `|det m| < 1e-12`.
///
/// ```
/// use cdrf_core::linear::solve_3x3;
///
/// let x = solve_3x3([[2.0, 0.0, 0.0], [0.0, 4.0, 0.0], [1.0, 0.0, 1.0]], [2.0, 8.0, 4.0]);
/// assert_eq!(x, Some([1.0, 2.0, 3.0]));
/// ```
pub fn solve_3x3(m: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(m);
    if d.abs() < 1e-12 {
        return None;
    }
    let mut x = [0.0; 3];
    for (k, value) in x.iter_mut().enumerate() {
        let mut mk = m;
        for row in 0..3 {
            mk[row][k] = b[row];
        }
        *value = det(mk) / d;
    }
    Some(x)
}

/// Solves a symmetric tridiagonal system by the Thomas algorithm, overwriting `diagonal` and
/// `rhs` with the eliminated system. `upper[i]` couples unknowns `i` and `i + 1`. `T` is a
/// scalar, or a vector type whose operations act per component (e.g. `Vec3`: one system per
/// channel).
///
/// # Panics
/// If `diagonal` is empty, or `upper` or `rhs` is shorter than needed.
///
/// ```
/// use cdrf_core::linear::solve_tridiagonal;
///
/// // [[2, 1, 0], [1, 2, 1], [0, 1, 2]] x = [4, 8, 8]
/// let x = solve_tridiagonal(&mut [2.0_f64, 2.0, 2.0], &[1.0, 1.0], &mut [4.0, 8.0, 8.0]);
/// for (x, expected) in x.iter().zip([1.0, 2.0, 3.0]) {
///     assert!((x - expected).abs() < 1e-12, "{x} vs {expected}");
/// }
/// ```
pub fn solve_tridiagonal<T>(diagonal: &mut [T], upper: &[T], rhs: &mut [T]) -> Vec<T>
where
    T: Copy + Sub<Output = T> + Mul<Output = T> + Div<Output = T>,
{
    let n = diagonal.len();
    for i in 1..n {
        let factor = upper[i - 1] / diagonal[i - 1];
        diagonal[i] = diagonal[i] - factor * upper[i - 1];
        rhs[i] = rhs[i] - factor * rhs[i - 1];
    }
    let mut x = rhs.to_vec();
    x[n - 1] = rhs[n - 1] / diagonal[n - 1];
    for i in (0..n - 1).rev() {
        x[i] = (rhs[i] - upper[i] * x[i + 1]) / diagonal[i];
    }
    x
}

/// What [`solve_gaussian`] does with a column whose largest remaining pivot is below
/// [`TINY_PIVOT`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SingularColumn {
    /// The system has no solution: `None`.
    Fail,
    /// The column is skipped and its unknown is 0 (a least-squares solver's choice for a
    /// column that adds nothing).
    Zero,
}

/// The precision [`solve_gaussian`] keeps the unknowns in: back substitution reads each
/// unknown as stored.
pub trait Unknown: Copy {
    /// `value` rounded to this type.
    fn from_f64(value: f64) -> Self;
    /// The value as f64 (exact).
    fn to_f64(self) -> f64;
}

impl Unknown for f64 {
    fn from_f64(value: f64) -> Self {
        value
    }
    fn to_f64(self) -> f64 {
        self
    }
}

impl Unknown for f32 {
    fn from_f64(value: f64) -> Self {
        value as f32
    }
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
}

/// Solves `A x = b` given as augmented rows `[A | b]` (n rows of n + 1) by Gaussian elimination
/// with partial pivoting in f64, then back substitution into unknowns of type `U` (`f32`:
/// each unknown is rounded before the rows above read it). A column whose pivot is below
/// [`TINY_PIVOT`] is handled as `singular` says.
///
/// # Panics
/// If a row is shorter than n + 1.
///
/// ```
/// use cdrf_core::linear::{SingularColumn, solve_gaussian};
///
/// let rows = vec![vec![0.0, 2.0, 4.0], vec![1.0, 1.0, 3.0]];
/// let x: Vec<f64> = solve_gaussian(rows, SingularColumn::Fail).unwrap();
/// assert_eq!(x, vec![1.0, 2.0]);
/// ```
pub fn solve_gaussian<U: Unknown>(
    mut rows: Vec<Vec<f64>>,
    singular: SingularColumn,
) -> Option<Vec<U>> {
    let n = rows.len();
    for column in 0..n {
        let pivot = (column..n)
            .max_by(|&i, &j| rows[i][column].abs().total_cmp(&rows[j][column].abs()))
            .unwrap_or(column);
        if rows[pivot][column].abs() < TINY_PIVOT {
            match singular {
                SingularColumn::Fail => return None,
                SingularColumn::Zero => {
                    rows.swap(column, pivot);
                    continue;
                }
            }
        }
        rows.swap(column, pivot);
        let (done, below) = rows.split_at_mut(column + 1);
        let pivot_row = &done[column];
        for row in below {
            let factor = row[column] / pivot_row[column];
            for k in column..=n {
                row[k] -= factor * pivot_row[k];
            }
        }
    }
    let mut x = vec![U::from_f64(0.0); n];
    for r in (0..n).rev() {
        let sum: f64 = (r + 1..n).map(|c| rows[r][c] * x[c].to_f64()).sum();
        x[r] = if rows[r][r].abs() < TINY_PIVOT {
            U::from_f64(0.0)
        } else {
            U::from_f64((rows[r][n] - sum) / rows[r][r])
        };
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// A small deterministic generator for test matrices.
    fn numbers(seed: u64) -> impl FnMut() -> f64 {
        let mut state = seed;
        move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        }
    }

    fn residual(a: &[Vec<f64>], x: &[f64], b: &[f64]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(row, b)| (row.iter().zip(x).map(|(a, x)| a * x).sum::<f64>() - b).abs())
            .fold(0.0, f64::max)
    }

    #[test]
    fn every_solver_solves_a_well_conditioned_system() {
        let mut next = numbers(7);
        // Symmetric positive definite: MᵀM + I.
        let m: Vec<Vec<f64>> = (0..5).map(|_| (0..5).map(|_| next()).collect()).collect();
        let mut spd = [[0.0; 5]; 5];
        for i in 0..5 {
            for j in 0..5 {
                spd[i][j] = (0..5).map(|k| m[k][i] * m[k][j]).sum::<f64>() + f64::from(i == j);
            }
        }
        let b: [f64; 5] = std::array::from_fn(|_| next());
        let full: Vec<Vec<f64>> = spd.iter().map(|row| row.to_vec()).collect();
        let x = solve_cholesky(&spd, &b).unwrap();
        assert!(residual(&full, &x, &b) < 1e-12, "Cholesky: {x:?}");

        let rows = full
            .iter()
            .zip(&b)
            .map(|(row, b)| row.iter().copied().chain([*b]).collect())
            .collect();
        let x: Vec<f64> = solve_gaussian(rows, SingularColumn::Fail).unwrap();
        assert!(residual(&full, &x, &b) < 1e-12, "Gaussian: {x:?}");

        let m3 = [[3.0, 1.0, -1.0], [0.5, -2.0, 1.0], [1.0, 1.0, 4.0]];
        let x = solve_3x3(m3, [1.0, 2.0, 3.0]).unwrap();
        let full3: Vec<Vec<f64>> = m3.iter().map(|row| row.to_vec()).collect();
        assert!(
            residual(&full3, &x, &[1.0, 2.0, 3.0]) < 1e-12,
            "3 × 3: {x:?}"
        );
    }

    #[test]
    fn the_tridiagonal_solver_solves_each_channel() {
        let mut diagonal = vec![Vec3::splat(4.0); 6];
        let upper = vec![Vec3::new(1.0, -1.0, 0.5); 5];
        let truth: Vec<Vec3> = (0..6)
            .map(|i| Vec3::new(i as f32, 1.0 - i as f32, 0.25 * i as f32))
            .collect();
        let mut rhs: Vec<Vec3> = (0..6)
            .map(|i| {
                let mut v = diagonal[i] * truth[i];
                if i > 0 {
                    v += upper[i - 1] * truth[i - 1];
                }
                if i < 5 {
                    v += upper[i] * truth[i + 1];
                }
                v
            })
            .collect();
        let x = solve_tridiagonal(&mut diagonal, &upper, &mut rhs);
        for (x, t) in x.iter().zip(&truth) {
            assert!((*x - *t).abs().max_element() < 1e-5, "{x} vs {t}");
        }
    }

    #[test]
    fn singular_systems_fail_or_zero_their_columns() {
        assert_eq!(
            solve_3x3(
                [[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]],
                [1.0; 3]
            ),
            None
        );
        assert_eq!(solve_cholesky(&[[1.0, 0.0], [1.0, 1.0]], &[1.0, 1.0]), None);
        // The second unknown's column is zero.
        let rows = || vec![vec![2.0, 0.0, 4.0], vec![1.0, 0.0, 2.0]];
        assert_eq!(solve_gaussian::<f64>(rows(), SingularColumn::Fail), None);
        assert_eq!(
            solve_gaussian::<f64>(rows(), SingularColumn::Zero),
            Some(vec![2.0, 0.0])
        );
    }

    #[test]
    fn f32_unknowns_are_rounded_before_the_rows_above_read_them() {
        // x₁ = 1/3 is stored as f32; x₀ = 1 − x₁ reads the rounded value.
        let rows = vec![vec![1.0, 1.0, 1.0], vec![0.0, 3.0, 1.0]];
        let x: Vec<f32> = solve_gaussian(rows, SingularColumn::Fail).unwrap();
        assert_eq!(x[1], (1.0f64 / 3.0) as f32);
        assert_eq!(x[0], (1.0 - f64::from((1.0f64 / 3.0) as f32)) as f32);
    }
}
