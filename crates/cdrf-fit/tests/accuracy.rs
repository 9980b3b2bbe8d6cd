//! Accuracy of the fit on the bundled path-traced wax spheres and on synthetic truth.
//!
//! Errors are measured on 8 × 8 pixel blocks (see `cdrf_fit::evaluate`): the data has ~7 %
//! relative noise per pixel on the lit side, so single pixels would measure the noise.

mod common;

use std::f32::consts::FRAC_PI_2;
use std::path::PathBuf;
use std::sync::OnceLock;

use cdrf_core::Cdrf;
use cdrf_core::gaussian::GaussianCdrf;
use cdrf_core::lut::Filter;
use cdrf_fit::curves::{CurveSettings, SphereSamples, ViewModel};
use cdrf_fit::dataset::Dataset;
use cdrf_fit::evaluate::sphere_error;
use cdrf_fit::fit::{Fit, Timings, fit_samples};
use cdrf_fit::{FitOptions, fit_dataset};
use common::{synthetic_sphere, synthetic_sphere_lit_from};
use glam::{Vec2, Vec3};

fn wax_dir() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/wax-spheres");
    assert!(
        dir.join("cdrf-dataset.toml").is_file(),
        "bundled data set missing at {}",
        dir.display()
    );
    dir
}

/// The full fit of the bundled data set, shared by the tests that only read it.
fn wax_fit() -> &'static Fit {
    static FIT: OnceLock<Fit> = OnceLock::new();
    FIT.get_or_init(|| {
        let dataset = Dataset::load(&wax_dir()).expect("bundled manifest loads");
        fit_dataset(&dataset, &FitOptions::default(), |_| {}).expect("bundled data set fits")
    })
}

#[test]
fn detection_finds_the_documented_circles() {
    // The data set's sidecars: every sphere is a disk of radius 230 px centred at (256, 256).
    // (r = 5 and 7.5 mm are given their circles in the manifest: their silhouettes are too soft
    // to detect to these bounds; see data/wax-spheres/cdrf-dataset.toml.)
    for sphere in wax_fit().spheres.iter().filter(|s| s.radius_mm >= 10.0) {
        let detected = sphere.detected.expect("detected");
        let offset = Vec2::from_array(detected.center_px) - Vec2::new(256.0, 256.0);
        println!(
            "{}: centre off by ({:.3}, {:.3}) px, radius off by {:.3} px, edge RMS {:.3} px",
            sphere.image,
            offset.x,
            offset.y,
            detected.radius_px - 230.0,
            detected.rms_residual_px
        );
        assert!(
            offset.length() < 0.4,
            "{}: centre off by {offset}",
            sphere.image
        );
        assert!(
            (detected.radius_px - 230.0).abs() < 0.4,
            "{}: radius {}",
            sphere.image,
            detected.radius_px
        );
    }
}

#[test]
fn self_consistency_within_three_percent_on_lit_and_terminator() {
    let fit = wax_fit();
    println!("radius  lit+terminator mean rel. error  (lit, terminator, shadow)");
    for (sphere, errors) in fit.spheres.iter().zip(&fit.errors) {
        let e = &errors.measured;
        println!(
            "{:>4} mm  {:.2} %  ({:.2} %, {:.2} %, {:.1} %)",
            sphere.radius_mm,
            100.0 * e.lit_and_terminator.mean_relative_error,
            100.0 * e.lit.mean_relative_error,
            100.0 * e.terminator.mean_relative_error,
            100.0 * e.shadow.mean_relative_error
        );
        assert!(
            e.lit_and_terminator.blocks > 500,
            "too few blocks: {}",
            e.lit_and_terminator.blocks
        );
        assert!(
            e.lit_and_terminator.mean_relative_error <= 0.03,
            "r = {} mm: {:.2} % > 3 %",
            sphere.radius_mm,
            100.0 * e.lit_and_terminator.mean_relative_error
        );
    }
}

#[test]
fn measured_error_is_at_most_half_the_gaussian_cdrf_error_at_every_radius() {
    let fit = wax_fit();
    println!(
        "Gaussian CDRF fitted to the same photos: sigma_mm {:?}, scale {:?}",
        fit.gaussian.model.sigma_mm(),
        fit.gaussian.model.scale()
    );
    println!("radius  relative RMS: measured  Gaussian  ratio");
    for (sphere, errors) in fit.spheres.iter().zip(&fit.errors) {
        let (measured, gaussian) = (
            errors.measured.whole.relative_rms,
            errors.gaussian.whole.relative_rms,
        );
        println!(
            "{:>4} mm  {:.2} %  {:.2} %  {:.3}",
            sphere.radius_mm,
            100.0 * measured,
            100.0 * gaussian,
            measured / gaussian
        );
        assert!(
            measured <= 0.5 * gaussian,
            "r = {} mm: {measured} vs {gaussian}",
            sphere.radius_mm
        );
    }
}

/// The light through the bundled wax spheres: T(d) decays per channel over a length a little
/// longer than the material's diffusion length (10.5, 6.9, 4.7 mm: the chord is longer than
/// the way light takes from the nearest lit surface), red longest, and the table carries it.
#[test]
fn transmission_decays_over_about_the_diffusion_length() {
    let fit = wax_fit();
    let transmission = fit.transmission.as_ref().expect("bundled spheres transmit");
    let (amplitude, length_mm) = (
        transmission.profile.amplitude,
        transmission.profile.length_mm,
    );
    println!("transmission: A = {amplitude:?}, ℓ = {length_mm:?} mm");
    for (c, diffusion_mm) in [10.5_f32, 6.9, 4.7].into_iter().enumerate() {
        let channel = &transmission.channels[c];
        println!(
            "  channel {c}: {} points, d {:?} mm, relative RMS {:.3}, per-sphere f/T {:?}",
            channel.points.len(),
            channel.chord_range_mm,
            channel.relative_rms,
            channel.mean_ratio_per_sphere
        );
        // Measured with the twelve spheres of 5–50 mm: 9.1 / 6.2 / 4.4 mm (0.86–0.93 × the
        // diffusion length: the small spheres add short chords, where T falls faster than its
        // asymptote); with the eight of 15–50 mm it was 10.6 / 7.2 / 5.2 mm.
        assert!(
            (0.8 * diffusion_mm..1.5 * diffusion_mm).contains(&length_mm[c]),
            "ℓ[{c}] = {} mm, diffusion length {diffusion_mm} mm",
            length_mm[c]
        );
        // (A: 0.12 / 0.15 / 0.19 with the twelve spheres, 0.07 / 0.09 / 0.10 with the eight of
        // 15–50 mm: the shorter ℓ meets the same light at short chords with a larger A.)
        assert!(
            (0.01..0.25).contains(&amplitude[c]),
            "A[{c}] = {}",
            amplitude[c]
        );
    }
    assert!(length_mm[0] > length_mm[1] && length_mm[1] > length_mm[2]);
    let translucency = fit.lut.translucency().expect("table has translucency");
    assert_eq!(translucency.transmission, transmission.profile);
    assert_eq!(
        translucency.scattering_length_mm,
        fit.gaussian.model.sigma_mm()
    );
}

#[test]
fn theta_dependent_view_correction_lowers_the_residual() {
    let fit = wax_fit();
    for (sphere, errors) in fit.spheres.iter().zip(&fit.errors) {
        let (poster, chosen) = (
            errors
                .poster_view_fit
                .lit_and_terminator
                .mean_relative_error,
            errors
                .chosen_view_fit
                .lit_and_terminator
                .mean_relative_error,
        );
        println!(
            "{:>4} mm: g(φ) {:.2} %, g(φ)·c(θ, φ) {:.2} %",
            sphere.radius_mm,
            100.0 * poster,
            100.0 * chosen
        );
        assert!(
            chosen < poster,
            "r = {} mm: {chosen} ≥ {poster}",
            sphere.radius_mm
        );
    }
}

#[test]
fn leaving_one_radius_out_still_reproduces_it() {
    let full = wax_fit();
    let options = FitOptions::default();
    println!("radius  self-consistency  left out (lit+terminator mean rel. error)");
    // The end radii would need extrapolation past the measured curvatures (the table clamps), so
    // the interpolation is judged on the six interior ones.
    for left_out in 1..full.samples.len() - 1 {
        let kept: Vec<SphereSamples> = full
            .samples
            .iter()
            .enumerate()
            .filter(|(k, _)| *k != left_out)
            .map(|(_, s)| s.clone())
            .collect();
        let reports = full
            .spheres
            .iter()
            .enumerate()
            .filter(|(k, _)| *k != left_out)
            .map(|(_, s)| s.clone())
            .collect();
        let fit = fit_samples(kept, reports, &options, Timings::default()).unwrap();
        let sphere = &full.samples[left_out];
        let error = sphere_error(sphere, |theta, phi| {
            fit.lut
                .evaluate(sphere.curvature_per_mm, theta, phi, Filter::Bilinear)
        });
        let own = full.errors[left_out]
            .measured
            .lit_and_terminator
            .mean_relative_error;
        let out = error.lit_and_terminator.mean_relative_error;
        println!(
            "{:>4} mm  {:.2} %  {:.2} %",
            full.spheres[left_out].radius_mm,
            100.0 * own,
            100.0 * out
        );
        assert!(
            out <= 0.04,
            "r = {} mm left out: {:.2} %",
            full.spheres[left_out].radius_mm,
            100.0 * out
        );
    }
}

/// Fit options with the poster's view correction g(φ) alone.
fn poster_view_options() -> FitOptions {
    FitOptions {
        curves: CurveSettings {
            view_model: ViewModel::Phi,
            ..CurveSettings::default()
        },
        ..FitOptions::default()
    }
}

/// The largest relative error of the fitted table against the `truth` at each of `radii` and
/// each whole degree of θ in `degrees`, per channel, where the truth is above 1 % of its scale.
fn worst_table_error(
    fit: &Fit,
    truth: &GaussianCdrf,
    radii: &[f32],
    degrees: std::ops::RangeInclusive<u32>,
) -> f32 {
    let mut worst = 0.0_f32;
    for &r in radii {
        for degree in degrees.clone() {
            let theta = (degree as f32).to_radians();
            let expected = Vec3::from_array(truth.reflectance(1.0 / r, theta));
            let found = fit.lut.sample(1.0 / r, theta, Filter::Bilinear);
            for c in 0..3 {
                if expected[c] > 1e-2 * truth.scale()[c] {
                    worst = worst.max((found[c] / expected[c] - 1.0).abs());
                }
            }
        }
    }
    worst
}

#[test]
fn synthetic_truth_is_fitted_back_within_half_a_percent() {
    let truth = GaussianCdrf::with_scale([9.0, 6.0, 4.0], [0.9, 0.85, 0.8]).unwrap();
    let g = |phi: f32| Vec3::new(1.0, 1.0, 1.0) + Vec3::new(0.10, 0.15, 0.20) * (1.0 - phi.cos());
    let radii = [15.0_f32, 20.0, 25.0, 30.0, 35.0, 40.0, 45.0, 50.0];
    let samples: Vec<SphereSamples> = radii
        .iter()
        .map(|&r| synthetic_sphere(&truth, g, r, |_| true))
        .collect();
    let reports = Vec::new();
    let options = poster_view_options();
    let fit = fit_samples(samples, reports, &options, Timings::default()).unwrap();

    // f at every sphere's curvature, over the θ the photographs cover, where it is not tiny.
    let worst_f = worst_table_error(&fit, &truth, &radii, 15..=165);
    let mut worst_g = 0.0_f32;
    let axis = fit.lut.curvature_axis();
    for degrees in 0..=80 {
        let phi = (degrees as f32).to_radians();
        // At every curvature: the correction is fitted per sphere and interpolated across κ.
        for kappa in [
            axis.min_per_mm,
            0.5 * (axis.min_per_mm + axis.max_per_mm),
            axis.max_per_mm,
        ] {
            let found = fit.lut.view_correction().sample(kappa, FRAC_PI_2, phi);
            worst_g = worst_g.max(((found / g(phi)) - Vec3::ONE).abs().max_element());
        }
    }
    println!(
        "synthetic truth: worst relative error of f {:.3} %, of g(φ) {:.3} %",
        100.0 * worst_f,
        100.0 * worst_g
    );
    assert!(worst_f <= 0.005, "f off by {:.3} %", 100.0 * worst_f);
    assert!(worst_g <= 0.005, "g off by {:.3} %", 100.0 * worst_g);
}

/// f and the view correction g·c are only measured as a product; the fit fixes the split so
/// that f(θ) is the ideal photograph's mean over its ring at θ (orthographic, light at 90°: the
/// poster's raw curve), whatever the correction is. Truth with a θ-dependent view factor, as a
/// diffusing medium has (grazing views brighter on the lit side, darker on the shadow side).
#[test]
fn f_is_the_ideal_photographs_mean_over_each_theta_ring() {
    let truth = GaussianCdrf::with_scale([9.0, 6.0, 4.0], [0.9, 0.85, 0.8]).unwrap();
    let view = |theta: f32, phi: f32| 1.0 + 0.15 * (1.0 - phi.cos()) * theta.cos();
    let radii = [15.0_f32, 25.0, 35.0, 50.0];
    let samples: Vec<SphereSamples> = radii
        .iter()
        .map(|&r| {
            let mut sphere = synthetic_sphere(&truth, |_| Vec3::ONE, r, |_| true);
            for sample in &mut sphere.samples {
                sample.radiance *= view(sample.theta_rad, sample.phi_rad);
            }
            sphere
        })
        .collect();
    let fit = fit_samples(
        samples,
        Vec::new(),
        &FitOptions::default(),
        Timings::default(),
    )
    .unwrap();
    let curves = &fit.curves.chosen;
    assert!(
        curves.correction.is_some(),
        "the θ-dependent correction was fitted"
    );
    let mut worst = 0.0_f32;
    for (k, &r) in radii.iter().enumerate() {
        for degree in (20..=160).step_by(5) {
            let theta = (degree as f32).to_radians();
            // The ring at θ: pixels uniform in y across it, φ = acos √(sin²θ − y²).
            let steps = 400;
            let ring_mean = (0..steps)
                .map(|i| {
                    let y = ((i as f32 + 0.5) / steps as f32 * 2.0 - 1.0) * theta.sin();
                    view(theta, (theta.sin().powi(2) - y * y).max(0.0).sqrt().acos())
                })
                .sum::<f32>()
                / steps as f32;
            let expected = Vec3::from_array(truth.reflectance(1.0 / r, theta)) * ring_mean;
            let node = degree as usize * (curves.settings.theta_count - 1) / 180;
            let found = curves.curves[k][node];
            for c in 0..3 {
                if expected[c] > 1e-2 * truth.scale()[c] {
                    worst = worst.max((found[c] / expected[c] - 1.0).abs());
                }
            }
        }
    }
    println!(
        "f against the ideal ring means: worst {:.2} %",
        100.0 * worst
    );
    assert!(
        worst <= 0.005,
        "f off the ring means by {:.2} %",
        100.0 * worst
    );
}

/// Spheres photographed with the camera 60° from the light see the light under the surface
/// flow away from them (`cdrf_core::azimuth`); the fit divides that out, so the table is the
/// one a camera at 90° gives. The "photographs" here carry the renderer's own factor
/// (ℓ = FLUX_LENGTH_MM: the truth's light travels millimetres), several per cent at the
/// terminator; fitted back within 1 % where f is not tiny.
#[test]
fn a_camera_off_ninety_degrees_gives_the_same_table() {
    let truth = GaussianCdrf::with_scale([9.0, 6.0, 4.0], [0.9, 0.85, 0.8]).unwrap();
    let g = |_: f32| Vec3::ONE;
    let radii = [10.0_f32, 20.0, 30.0, 50.0];
    let to_light = Vec3::new(-(60f32.to_radians().sin()), 0.0, 60f32.to_radians().cos());
    let columns = 361;
    let samples: Vec<SphereSamples> = radii
        .iter()
        .map(|&r| {
            let kappa = 1.0 / r;
            let curve: Vec<Vec3> = (0..columns)
                .map(|j| {
                    let theta = std::f32::consts::PI * j as f32 / (columns - 1) as f32;
                    Vec3::from_array(truth.reflectance(kappa, theta))
                })
                .collect();
            let flow = cdrf_core::azimuth::flow_mm_per_rad(
                &curve,
                Vec3::splat(cdrf_core::azimuth::FLUX_LENGTH_MM),
            );
            let mut sphere = synthetic_sphere_lit_from(&truth, g, r, to_light, |_| true);
            for sample in &mut sphere.samples {
                let j = (sample.theta_rad / std::f32::consts::PI * (columns - 1) as f32).round();
                sample.radiance *= cdrf_core::azimuth::factor(
                    kappa,
                    flow[j as usize],
                    sample.theta_rad,
                    sample.view_dot_light,
                );
            }
            sphere
        })
        .collect();
    let options = poster_view_options();
    let fit = fit_samples(samples, Vec::new(), &options, Timings::default()).unwrap();
    let worst = worst_table_error(&fit, &truth, &radii, 20..=110);
    println!(
        "camera 60° from the light: worst relative error of f {:.2} %",
        100.0 * worst
    );
    assert!(worst <= 0.01, "f off by {:.2} %", 100.0 * worst);
}

#[test]
fn one_sphere_gives_a_curvature_independent_table() {
    let truth = GaussianCdrf::new([6.0, 6.0, 6.0]).unwrap();
    let sphere = synthetic_sphere(&truth, |_| Vec3::ONE, 25.0, |_| true);
    let options = poster_view_options();
    let fit = fit_samples(vec![sphere], Vec::new(), &options, Timings::default()).unwrap();
    assert_eq!(fit.lut.curvature_axis().count, 1);
    let at = |k: f32| fit.lut.sample(k, 1.7, Filter::Bilinear);
    assert_eq!(at(0.01), at(0.2));
}
