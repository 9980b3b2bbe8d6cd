//! Fixed Gauss–Legendre rules (deterministic and smooth in their parameters, which least-squares
//! fitters need; an adaptive rule would make the model jump when its subdivision changes).

/// Positive half of the 8-point Gauss–Legendre rule on `[-1, 1]`: `(node, weight)`.
pub(crate) const GAUSS_LEGENDRE_8: [(f64, f64); 4] = [
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_4),
    (0.796_666_477_413_626_8, 0.222_381_034_453_374_45),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_18),
];

/// Positive half of the 16-point Gauss–Legendre rule on `[-1, 1]`: `(node, weight)`.
pub(crate) const GAUSS_LEGENDRE_16: [(f64, f64); 8] = [
    (0.095_012_509_837_637_44, 0.189_450_610_455_068_47),
    (0.281_603_550_779_258_9, 0.182_603_415_044_923_6),
    (0.458_016_777_657_227_37, 0.169_156_519_395_002_56),
    (0.617_876_244_402_643_8, 0.149_595_988_816_576_82),
    (0.755_404_408_355_003, 0.124_628_971_255_533_95),
    (0.865_631_202_387_831_8, 0.095_158_511_682_492_9),
    (0.944_575_023_073_232_6, 0.062_253_523_938_647_776),
    (0.989_400_934_991_649_9, 0.027_152_459_411_754_058),
];

/// Calls `visit(x, w)` for every node `x` of the symmetric rule `half` mapped onto `[a, b]`, with
/// `w` the node's weight already scaled by the interval, so `Σ w·f(x) ≈ ∫ₐᵇ f`.
#[inline]
pub(crate) fn for_each_node<const N: usize>(
    half: &[(f64, f64); N],
    a: f64,
    b: f64,
    mut visit: impl FnMut(f64, f64),
) {
    let mid = 0.5 * (a + b);
    let half_width = 0.5 * (b - a);
    for &(node, weight) in half {
        let w = weight * half_width;
        visit(mid - half_width * node, w);
        visit(mid + half_width * node, w);
    }
}

/// `∫ₐᵇ f` with the symmetric rule `half`.
#[inline]
pub(crate) fn integrate<const N: usize>(
    half: &[(f64, f64); N],
    a: f64,
    b: f64,
    mut f: impl FnMut(f64) -> f64,
) -> f64 {
    let mut sum = 0.0;
    for_each_node(half, a, b, |x, w| sum += w * f(x));
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An n-point rule integrates polynomials up to degree 2n − 1 exactly.
    #[test]
    fn rules_are_exact_for_their_degree() {
        for (name, degree, value) in [
            (
                "GL8",
                15,
                integrate(&GAUSS_LEGENDRE_8, -1.0, 2.0, |x| x.powi(15) + x.powi(14)),
            ),
            (
                "GL16",
                31,
                integrate(&GAUSS_LEGENDRE_16, -1.0, 2.0, |x| x.powi(31) + x.powi(30)),
            ),
        ] {
            let d = f64::from(degree);
            let want = (2f64.powf(d + 1.0) - 1.0) / (d + 1.0) + (2f64.powf(d) + 1.0) / d;
            let error = (value - want).abs() / want;
            println!(
                "{name}: ∫ x^{degree} + x^{} over [-1, 2] = {value}, want {want}, rel error {error:e}",
                degree - 1
            );
            assert!(error < 1e-13);
        }
    }
}
