//! The LUT type: axes, filtering, clamping, view correction.

use std::f32::consts::{FRAC_PI_2, PI};

use cdrf_core::lut::{
    Cdrf, CdrfLut, CurvatureAxis, Filter, Lambert, LutError, TexelCoverage, ViewCorrection,
    theta_rad_at,
};
use glam::Vec3;

/// A smooth synthetic CDRF that depends on both axes and, like every CDRF, is even in θ about
/// 0 and π (f(θ) = f(−θ) = f(2π − θ)).
struct Smooth;

impl Cdrf for Smooth {
    fn reflectance(&self, curvature_per_mm: f32, theta_rad: f32) -> [f32; 3] {
        let k = 10.0 * curvature_per_mm;
        let value = (1.2 + theta_rad.cos()) * (1.0 + k) + 0.3 * k * (2.0 * theta_rad).cos();
        [value, 0.9 * value, 0.8 * value]
    }
}

fn wax_axis(count: usize) -> CurvatureAxis {
    CurvatureAxis::from_radii_mm(50.0, 15.0, count)
}

#[test]
fn lambert_table_is_cos_plus_at_every_curvature() {
    let lut = CdrfLut::tabulate(&Lambert { albedo: [1.0; 3] }, wax_axis(8), 181).unwrap();
    let mut worst = 0.0_f32;
    for step in 0..=360 {
        let theta = PI * step as f32 / 360.0;
        for curvature in [0.0, 0.02, 0.031, 0.0667, 0.5] {
            for filter in [Filter::Bilinear, Filter::CatmullRom] {
                let f = lut.sample(curvature, theta, filter);
                worst = worst.max((f - Vec3::splat(theta.cos().max(0.0))).abs().max_element());
            }
        }
    }
    println!("white Lambert table, 181 θ columns: worst |f − cos⁺θ| = {worst:e}");
    // Bilinear error of cos on a 1° grid is ≤ h²/8 ≈ 3.8e-5; the kink at 90° costs up to h/4.
    assert!(worst < 5e-3, "worst {worst}");
}

#[test]
fn sampling_hits_the_stored_values_at_the_nodes() {
    let axis = wax_axis(6);
    let lut = CdrfLut::tabulate(&Smooth, axis, 33).unwrap();
    for row in 0..axis.count {
        for column in 0..33 {
            let (curvature, theta) = (axis.curvature_per_mm(row), theta_rad_at(column, 33));
            let stored = lut.row(row)[column];
            for filter in [Filter::Bilinear, Filter::CatmullRom] {
                let found = lut.sample(curvature, theta, filter);
                assert!(
                    (found - stored).abs().max_element() < 1e-5,
                    "{filter:?} at row {row} column {column}: {found} vs stored {stored}"
                );
            }
        }
    }
}

#[test]
fn catmull_rom_filter_is_more_accurate_than_bilinear_on_smooth_data() {
    let axis = wax_axis(8);
    let lut = CdrfLut::tabulate(&Smooth, axis, 46).unwrap();
    let (mut bilinear, mut cubic) = (0.0_f32, 0.0_f32);
    for i in 0..200 {
        for j in 0..200 {
            let curvature =
                axis.min_per_mm + (axis.max_per_mm - axis.min_per_mm) * i as f32 / 199.0;
            let theta = PI * j as f32 / 199.0;
            let truth = Vec3::from_array(Smooth.reflectance(curvature, theta));
            bilinear = bilinear.max(
                (lut.sample(curvature, theta, Filter::Bilinear) - truth)
                    .abs()
                    .max_element(),
            );
            cubic = cubic.max(
                (lut.sample(curvature, theta, Filter::CatmullRom) - truth)
                    .abs()
                    .max_element(),
            );
        }
    }
    println!("46 θ columns × 8 κ rows: worst error bilinear {bilinear:e}, Catmull-Rom {cubic:e}");
    assert!(
        cubic < bilinear / 3.0,
        "Catmull-Rom {cubic} vs bilinear {bilinear}"
    );
}

#[test]
fn curvature_outside_the_axis_is_clamped_to_the_end_rows() {
    let axis = wax_axis(8);
    let lut = CdrfLut::tabulate(&Smooth, axis, 91).unwrap();
    for theta in [0.0, 1.0, FRAC_PI_2, 2.5, PI] {
        for filter in [Filter::Bilinear, Filter::CatmullRom] {
            let flattest = lut.sample(axis.min_per_mm, theta, filter);
            let most_curved = lut.sample(axis.max_per_mm, theta, filter);
            // Flat, concave and barely curved points read the flattest row...
            for curvature in [0.0, -0.3, 0.5 * axis.min_per_mm, f32::NAN] {
                assert_eq!(
                    lut.sample(curvature, theta, filter),
                    flattest,
                    "κ = {curvature}"
                );
            }
            // ...and anything sharper than the smallest sphere reads the last row.
            for curvature in [0.1, 10.0, f32::INFINITY] {
                assert_eq!(
                    lut.sample(curvature, theta, filter),
                    most_curved,
                    "κ = {curvature}"
                );
            }
        }
    }
}

#[test]
fn theta_is_clamped_to_zero_to_pi() {
    let lut = CdrfLut::tabulate(&Smooth, wax_axis(4), 19).unwrap();
    assert_eq!(
        lut.sample(0.03, -0.5, Filter::Bilinear),
        lut.sample(0.03, 0.0, Filter::Bilinear)
    );
    assert_eq!(
        lut.sample(0.03, 4.0, Filter::CatmullRom),
        lut.sample(0.03, PI, Filter::CatmullRom)
    );
}

#[test]
fn catmull_rom_never_returns_negative_radiance() {
    // A sharp terminator: 1 then 0 — the cubic undershoots, the table clamps at 0.
    let lut = CdrfLut::new(
        wax_axis(2),
        5,
        [1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0]
            .map(Vec3::splat)
            .to_vec(),
    )
    .unwrap();
    for step in 0..=100 {
        let f = lut.sample(0.04, PI * step as f32 / 100.0, Filter::CatmullRom);
        assert!(f.min_element() >= 0.0, "{f}");
    }
}

#[test]
fn view_correction_multiplies_and_interpolates() {
    // Poster form g(φ): 1 facing the camera, 1.5 at grazing view.
    let g = ViewCorrection::from_phi(vec![Vec3::ONE, Vec3::splat(1.25), Vec3::splat(1.5)]).unwrap();
    let lut = CdrfLut::tabulate(&Lambert { albedo: [1.0; 3] }, wax_axis(2), 181)
        .unwrap()
        .with_view_correction(g);
    let theta = 0.3_f32;
    let f = theta.cos();
    for (phi, factor) in [
        (0.0, 1.0),
        (FRAC_PI_2 / 4.0, 1.125),
        (FRAC_PI_2, 1.5),
        (3.0, 1.5),
    ] {
        let value = lut.evaluate(0.03, theta, phi, Filter::Bilinear).x;
        assert!(
            (value - f * factor).abs() < 1e-4,
            "φ = {phi}: {value} vs {}",
            f * factor
        );
    }
    // θ-dependent form: rows over θ ∈ [0, π].
    let g = ViewCorrection::new(
        2,
        2,
        vec![Vec3::ONE, Vec3::splat(2.0), Vec3::ONE, Vec3::splat(0.5)],
    )
    .unwrap();
    assert!((g.sample(0.05, 0.0, FRAC_PI_2).x - 2.0).abs() < 1e-6);
    assert!((g.sample(0.05, PI, FRAC_PI_2).x - 0.5).abs() < 1e-6);
    assert!((g.sample(0.05, FRAC_PI_2, FRAC_PI_2).x - 1.25).abs() < 1e-6);
    assert_eq!(ViewCorrection::identity().sample(0.05, 1.0, 1.0), Vec3::ONE);
}

#[test]
fn single_row_table_ignores_curvature() {
    let axis = CurvatureAxis {
        min_per_mm: 0.04,
        max_per_mm: 0.04,
        count: 1,
    };
    let lut = CdrfLut::tabulate(&Smooth, axis, 10).unwrap();
    for filter in [Filter::Bilinear, Filter::CatmullRom] {
        assert_eq!(lut.sample(0.0, 1.0, filter), lut.sample(1.0, 1.0, filter));
    }
}

#[test]
fn malformed_tables_are_errors_not_panics() {
    let axis = wax_axis(2);
    assert_eq!(
        CdrfLut::new(axis, 3, vec![Vec3::ONE; 5]).unwrap_err(),
        LutError::ShapeMismatch {
            what: "radiance",
            expected: 6,
            found: 5
        }
    );
    assert_eq!(
        CdrfLut::new(axis, 1, vec![Vec3::ONE; 2]).unwrap_err(),
        LutError::TooFewThetaColumns(1)
    );
    let bad_axis = CurvatureAxis {
        min_per_mm: 0.05,
        max_per_mm: 0.02,
        count: 4,
    };
    assert!(matches!(
        CdrfLut::new(bad_axis, 2, vec![Vec3::ONE; 8]),
        Err(LutError::BadCurvatureAxis(_))
    ));
    let mut values = vec![Vec3::ONE; 6];
    values[4].y = f32::NAN;
    let error = CdrfLut::new(axis, 3, values).unwrap_err();
    assert_eq!(
        error.to_string(),
        "radiance: value 4 is NaN: must be finite and ≥ 0"
    );
    let lut = CdrfLut::new(axis, 3, vec![Vec3::ONE; 6]).unwrap();
    assert!(matches!(
        lut.clone().with_coverage(vec![TexelCoverage::default(); 2]),
        Err(LutError::ShapeMismatch {
            what: "coverage",
            ..
        })
    ));
    assert!(matches!(
        ViewCorrection::from_phi(vec![Vec3::splat(-1.0)]),
        Err(LutError::BadValue {
            what: "view correction",
            ..
        })
    ));
}

#[test]
fn lambert_albedo_recovers_a_lambertian_table_and_fits_a_glowing_one() {
    let axis = CurvatureAxis::from_radii_mm(50.0, 15.0, 8);
    let albedo = [0.8, 0.6, 0.3];
    let lambert = CdrfLut::tabulate(&Lambert { albedo }, axis, 181).unwrap();
    let fitted = lambert.lambert_albedo();
    for (a, b) in fitted.iter().zip(albedo) {
        assert!((a - b).abs() < 1e-5, "{fitted:?} vs {albedo:?}");
    }
    // A table with glow past the terminator (a Gaussian CDRF) still gives an albedo close to
    // its lit-side scale, and never a negative or non-finite one.
    let gaussian = cdrf_core::gaussian::GaussianCdrf::with_scale([5.0; 3], albedo).unwrap();
    let fitted = CdrfLut::tabulate(&gaussian, axis, 181)
        .unwrap()
        .lambert_albedo();
    println!("Lambert albedo of a Gaussian CDRF with scale {albedo:?}: {fitted:?}");
    for (a, b) in fitted.iter().zip(albedo) {
        assert!(
            a.is_finite() && (a - b).abs() < 0.1 * b,
            "{fitted:?} vs {albedo:?}"
        );
    }
}

/// ∫₀^π f(κ_min, θ) dθ: the albedo of a Lambertian table (∫₀^π cos⁺θ dθ = 1), and the scale of a
/// Gaussian CDRF, whose kernel of unit mass keeps the flat surface's total reflectance.
#[test]
fn flat_albedo_is_the_flattest_rows_integral() {
    let axis = CurvatureAxis::from_radii_mm(50.0, 15.0, 8);
    let albedo = [0.8, 0.6, 0.3];
    let lambert = CdrfLut::tabulate(&Lambert { albedo }, axis, 181).unwrap();
    let flat = lambert.flat_albedo();
    for (a, b) in flat.iter().zip(albedo) {
        assert!((a - b).abs() < 1e-4, "{flat:?} vs {albedo:?}");
    }
    let gaussian = cdrf_core::gaussian::GaussianCdrf::with_scale([5.0; 3], albedo).unwrap();
    let flat = CdrfLut::tabulate(&gaussian, axis, 361)
        .unwrap()
        .flat_albedo();
    println!("flat albedo of a Gaussian CDRF with scale {albedo:?}: {flat:?}");
    for (a, b) in flat.iter().zip(albedo) {
        assert!((a - b).abs() < 0.01 * b, "{flat:?} vs {albedo:?}");
    }
}

/// A view correction with curvature layers: each layer at its κ, linear between, the end layers
/// beyond the axis; a wrong shape or axis is refused.
#[test]
fn view_correction_layers_interpolate_in_curvature() {
    use cdrf_core::lut::CurvatureAxis;
    let layers = CurvatureAxis {
        min_per_mm: 0.02,
        max_per_mm: 0.06,
        count: 3,
    };
    // 2 φ columns × 2 θ rows per layer; layer l holds 1 + l everywhere.
    let values: Vec<Vec3> = (0..12).map(|i| Vec3::splat(1.0 + (i / 4) as f32)).collect();
    let g = ViewCorrection::with_curvature_layers(2, 2, layers, values).unwrap();
    for (kappa, expected) in [
        (0.0, 1.0),
        (0.02, 1.0),
        (0.03, 1.5),
        (0.04, 2.0),
        (0.055, 2.75),
        (1.0, 3.0),
    ] {
        let found = g.sample(kappa, 1.0, 0.5).x;
        assert!(
            (found - expected).abs() < 1e-5,
            "κ {kappa}: {found} vs {expected}"
        );
    }
    assert!(ViewCorrection::with_curvature_layers(2, 2, layers, vec![Vec3::ONE; 8]).is_err());
    let backwards = CurvatureAxis {
        min_per_mm: 0.06,
        max_per_mm: 0.02,
        count: 3,
    };
    assert!(ViewCorrection::with_curvature_layers(2, 2, backwards, vec![Vec3::ONE; 12]).is_err());
}
