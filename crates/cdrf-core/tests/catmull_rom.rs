//! Catmull-Rom splines with non-uniform knots: interpolation, linear exactness, overshoot.

use cdrf_core::catmull_rom::{CatmullRom, Ends, SplineError, Tangents, evaluate_uniform};
use glam::Vec3;

/// The measured spheres' curvatures: radii 50, 45, …, 15 mm are uniform in r, not in κ.
fn sphere_curvatures_per_mm() -> Vec<f32> {
    [50.0_f32, 45.0, 40.0, 35.0, 30.0, 25.0, 20.0, 15.0]
        .iter()
        .map(|r| 1.0 / r)
        .collect()
}

fn assert_close(what: &str, found: f32, expected: f32, eps: f32) {
    let difference = (found - expected).abs();
    assert!(
        difference <= eps,
        "{what}: found {found}, expected {expected}, |difference| {difference} > eps {eps}"
    );
}

#[test]
fn passes_through_every_knot() {
    let knots = sphere_curvatures_per_mm();
    let values: Vec<f32> = knots.iter().map(|k| (k * 97.0).sin() + 2.0).collect();
    for tangents in [Tangents::CatmullRom, Tangents::Monotone] {
        let spline = CatmullRom::with_tangents(&knots, &values, tangents).unwrap();
        for (k, v) in knots.iter().zip(&values) {
            assert_close(
                &format!("{tangents:?} at κ = {k}"),
                spline.evaluate(*k),
                *v,
                1e-6,
            );
        }
    }
}

#[test]
fn reproduces_linear_data_exactly_on_non_uniform_knots() {
    let knots = sphere_curvatures_per_mm();
    let line = |x: f32| 3.0 - 40.0 * x;
    let values: Vec<f32> = knots.iter().map(|&k| line(k)).collect();
    for tangents in [Tangents::CatmullRom, Tangents::Monotone] {
        let spline = CatmullRom::with_tangents(&knots, &values, tangents).unwrap();
        let (first, last) = (knots[0], knots[knots.len() - 1]);
        let mut worst = 0.0_f32;
        for step in 0..=1000 {
            let x = first + (last - first) * step as f32 / 1000.0;
            worst = worst.max((spline.evaluate(x) - line(x)).abs());
        }
        println!("{tangents:?}: worst deviation from a line over 1001 points: {worst:e}");
        assert!(
            worst < 2e-6,
            "{tangents:?}: deviates from linear data by {worst}"
        );
    }
}

#[test]
fn interpolates_rgb_values() {
    let knots = [0.0_f32, 1.0, 3.0];
    let values = [
        Vec3::ZERO,
        Vec3::new(1.0, 2.0, 3.0),
        Vec3::new(3.0, 6.0, 9.0),
    ];
    let spline = CatmullRom::new(&knots, &values).unwrap();
    // Linear data in every channel: exact everywhere.
    let v = spline.evaluate(2.0);
    assert!(
        (v - Vec3::new(2.0, 4.0, 6.0)).abs().max_element() < 1e-6,
        "{v}"
    );
}

#[test]
fn clamps_outside_the_knots() {
    let spline = CatmullRom::new(&[1.0_f32, 2.0, 4.0], &[5.0_f32, 7.0, 6.0]).unwrap();
    assert_eq!(spline.evaluate(-3.0), 5.0);
    assert_eq!(spline.evaluate(100.0), 6.0);
    assert_eq!(spline.evaluate(f32::NAN), 5.0);
}

/// Worst excursion of the spline outside `[lo, hi]`, sampled densely.
fn overshoot(spline: &CatmullRom<f32>, lo: f32, hi: f32) -> f32 {
    let knots = spline.knots();
    let (first, last) = (knots[0], knots[knots.len() - 1]);
    (0..=20_000)
        .map(|step| spline.evaluate(first + (last - first) * step as f32 / 20_000.0))
        .map(|y| (y - hi).max(lo - y).max(0.0))
        .fold(0.0, f32::max)
}

#[test]
fn overshoot_on_a_step_stays_within_the_documented_bound() {
    let knots = sphere_curvatures_per_mm();
    // A unit step between every pair of neighbouring knots in turn.
    for jump in 0..knots.len() - 1 {
        let values: Vec<f32> = (0..knots.len())
            .map(|i| if i <= jump { 0.0 } else { 1.0 })
            .collect();
        let spline = CatmullRom::new(&knots, &values).unwrap();
        let found = overshoot(&spline, 0.0, 1.0);
        // Documented bound: (4/27)·ρ²/(1+ρ) with ρ = flat interval / step interval, on the
        // flat side before and after the jump.
        let h = |i: usize| knots[i + 1] - knots[i];
        let bound = |rho: f32| 4.0 / 27.0 * rho * rho / (1.0 + rho);
        let before = if jump > 0 {
            bound(h(jump - 1) / h(jump))
        } else {
            0.0
        };
        let after = if jump + 2 < knots.len() {
            bound(h(jump + 1) / h(jump))
        } else {
            0.0
        };
        let documented = before.max(after);
        println!(
            "step between knots {jump} and {}: overshoot {found:.4}, documented bound {documented:.4}",
            jump + 1
        );
        assert!(
            found <= documented + 1e-4,
            "overshoot {found} exceeds documented {documented}"
        );
        assert!(
            found > 0.0 || documented == 0.0,
            "the bound should be attained"
        );

        let monotone = CatmullRom::with_tangents(&knots, &values, Tangents::Monotone).unwrap();
        let found = overshoot(&monotone, 0.0, 1.0);
        assert!(found < 1e-6, "monotone tangents overshoot by {found}");
    }
    // Uniform knots: the classic 2/27 ≈ 7.4 %.
    let uniform = CatmullRom::new(&[0.0_f32, 1.0, 2.0, 3.0], &[0.0_f32, 0.0, 1.0, 1.0]).unwrap();
    assert_close(
        "uniform overshoot",
        overshoot(&uniform, 0.0, 1.0),
        2.0 / 27.0,
        1e-4,
    );
}

#[test]
fn uniform_evaluation_is_the_same_spline() {
    let values = [0.2_f32, 0.9, 0.4, 0.45, 1.3, 0.0];
    let knots: Vec<f32> = (0..values.len()).map(|i| i as f32).collect();
    let spline = CatmullRom::new(&knots, &values).unwrap();
    for step in 0..=500 {
        let u = step as f32 / 100.0;
        assert_close(
            &format!("u = {u}"),
            evaluate_uniform(&values, u, Ends::OneSided),
            spline.evaluate(u),
            1e-5,
        );
    }
}

#[test]
fn mirrored_ends_have_zero_slope() {
    let values = [1.0_f32, 0.8, 0.3, 0.1];
    let slope_at = |u: f32| {
        (evaluate_uniform(&values, u + 1e-3, Ends::Mirrored)
            - evaluate_uniform(&values, u, Ends::Mirrored))
            / 1e-3
    };
    assert!(
        slope_at(0.0).abs() < 2e-3,
        "slope at the first knot {}",
        slope_at(0.0)
    );
    assert!(
        slope_at(3.0 - 1e-3).abs() < 2e-3,
        "slope at the last knot {}",
        slope_at(3.0 - 1e-3)
    );
    assert_close(
        "interior still interpolates",
        evaluate_uniform(&values, 2.0, Ends::Mirrored),
        0.3,
        1e-6,
    );
}

#[test]
fn bad_knots_are_errors() {
    assert_eq!(
        CatmullRom::new(&[1.0_f32], &[1.0_f32]).unwrap_err(),
        SplineError::TooFewPoints(1)
    );
    assert!(matches!(
        CatmullRom::new(&[1.0_f32, 1.0], &[1.0_f32, 2.0]),
        Err(SplineError::KnotsNotIncreasing { index: 1, .. })
    ));
    assert!(matches!(
        CatmullRom::new(&[0.0_f32, f32::NAN], &[1.0_f32, 2.0]),
        Err(SplineError::NonFiniteKnot { index: 1, .. })
    ));
    let error = CatmullRom::new(&[0.0_f32, 1.0], &[1.0_f32]).unwrap_err();
    assert_eq!(
        error.to_string(),
        "2 knots but 1 values: a spline needs one value per knot"
    );
}
