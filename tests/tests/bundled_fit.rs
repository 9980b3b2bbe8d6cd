//! `data/wax-fit/` must be what cdrf-fit produces from `data/wax-spheres/` today: the render
//! tests, the benchmark and the viewer read it instead of fitting first.

use cdrf_core::gaussian_file::read_gaussian;
use cdrf_core::read_lut;
use cdrf_fit::dataset::Dataset;
use cdrf_fit::{FitOptions, fit_dataset};
use cdrf_tests::data_dir;

#[test]
fn bundled_fit_is_current() {
    let dataset = Dataset::load(&data_dir().join("wax-spheres")).unwrap_or_else(|e| panic!("{e}"));
    let fit =
        fit_dataset(&dataset, &FitOptions::default(), |_| {}).unwrap_or_else(|e| panic!("{e}"));
    let refresh = "refresh data/wax-fit as data/wax-fit/README.md says";
    let bundled =
        read_lut(data_dir().join("wax-fit/measured.exr")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        (bundled.curvature_axis(), bundled.theta_count()),
        (fit.lut.curvature_axis(), fit.lut.theta_count()),
        "table shape changed: {refresh}"
    );
    // The fit is deterministic up to floating-point summation order across threads.
    let peak = fit
        .lut
        .radiance()
        .iter()
        .map(|v| v.max_element())
        .fold(0.0f32, f32::max);
    let worst = bundled
        .radiance()
        .iter()
        .zip(fit.lut.radiance())
        .map(|(a, b)| (*a - *b).abs().max_element())
        .fold(0.0f32, f32::max);
    let view_worst = bundled
        .view_correction()
        .values()
        .iter()
        .zip(fit.lut.view_correction().values())
        .map(|(a, b)| (*a - *b).abs().max_element())
        .fold(0.0f32, f32::max);
    println!(
        "bundled vs fresh fit: largest LUT difference {worst:e} (peak {peak}), view correction {view_worst:e}"
    );
    assert!(worst <= 1e-4 * peak, "LUT differs by {worst}: {refresh}");
    assert!(
        view_worst <= 1e-4,
        "view correction differs by {view_worst}: {refresh}"
    );

    let gaussian =
        read_gaussian(data_dir().join("wax-fit/gaussian.toml")).unwrap_or_else(|e| panic!("{e}"));
    let fresh = &fit.gaussian.model;
    for c in 0..3 {
        let sigma = (gaussian.sigma_mm[c] - fresh.sigma_mm()[c]).abs() / fresh.sigma_mm()[c];
        let scale = (gaussian.scale[c] - fresh.scale()[c]).abs() / fresh.scale()[c];
        assert!(
            sigma < 1e-4 && scale < 1e-4,
            "Gaussian channel {c} differs: {refresh}"
        );
    }
    assert_eq!(
        gaussian.view_correction_from.as_deref(),
        Some(std::path::Path::new("measured.exr"))
    );

    // The material terms of the non-local modes travel with the table.
    let (Some(bundled_terms), Some(fresh_terms)) = (bundled.translucency(), fit.lut.translucency())
    else {
        panic!("the bundled or the fresh table has no translucency terms: {refresh}");
    };
    let pairs = [
        (
            bundled_terms.scattering_length_mm,
            fresh_terms.scattering_length_mm,
        ),
        (
            bundled_terms.transmission.amplitude,
            fresh_terms.transmission.amplitude,
        ),
        (
            bundled_terms.transmission.length_mm,
            fresh_terms.transmission.length_mm,
        ),
    ];
    for (a, b) in pairs {
        for c in 0..3 {
            assert!(
                (a[c] - b[c]).abs() <= 1e-4 * b[c].abs(),
                "translucency terms differ ({a:?} vs {b:?}): {refresh}"
            );
        }
    }
    assert_eq!(
        bundled_terms.transmission.entry_cosine_power, fresh_terms.transmission.entry_cosine_power,
        "entry cosine power differs (a version 2 table?): {refresh}"
    );
}
