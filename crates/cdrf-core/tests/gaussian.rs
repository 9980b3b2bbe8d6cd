//! The Gaussian CDRF (Kubo) and ring pre-integration (Penner): limits, conservation, agreement
//! with independent references, monotonicity, parameter validation.

use std::f64::consts::{FRAC_1_PI, FRAC_PI_2, PI, TAU};
use std::time::Instant;

use cdrf_core::Cdrf;
use cdrf_core::gaussian::{
    DipoleProfile, GaussianCdrf, GaussianProfile, GaussianTerm, ParameterError, PreintegratedCdrf,
    RadialProfile, SumOfGaussiansProfile, convolved_clamped_cosine,
};

fn clamped_cos(theta: f64) -> f64 {
    theta.cos().max(0.0)
}

/// `n` evenly spaced angles covering `[0, π]`.
fn thetas(n: usize) -> impl Iterator<Item = f64> {
    (0..n).map(move |i| PI * i as f64 / (n - 1) as f64)
}

/// Asserts `|got − want| ≤ eps`, printing both, the difference and eps.
#[track_caller]
fn assert_close(what: &str, got: f64, want: f64, eps: f64) {
    let diff = (got - want).abs();
    assert!(
        diff <= eps,
        "{what}: got {got}, want {want}, |diff| {diff:e} > eps {eps:e}"
    );
}

/// The `n`-point Gauss–Legendre rule on `[-1, 1]` by Newton's method (independent of the
/// library's tables).
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (1..=n)
        .map(|i| {
            let mut x = (PI * (i as f64 - 0.25) / (n as f64 + 0.5)).cos();
            let legendre = |x: f64| {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let k = k as f64;
                    (p0, p1) = (p1, ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k);
                }
                (p1, n as f64 * (x * p1 - p0) / (x * x - 1.0))
            };
            for _ in 0..100 {
                let (p, dp) = legendre(x);
                let dx = p / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            let (_, dp) = legendre(x);
            (x, 2.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

/// `∫ f` over the panels between consecutive sorted `edges`, each with `rule`, for an RGB `f`.
fn integrate_panels_rgb(
    rule: &[(f64, f64)],
    edges: &mut [f64],
    mut f: impl FnMut(f64) -> [f64; 3],
) -> [f64; 3] {
    edges.sort_by(f64::total_cmp);
    let mut sum = [0.0; 3];
    for panel in edges.windows(2) {
        let (mid, half) = (0.5 * (panel[0] + panel[1]), 0.5 * (panel[1] - panel[0]));
        for &(x, w) in rule {
            let value = f(mid + half * x);
            for c in 0..3 {
                sum[c] += w * half * value[c];
            }
        }
    }
    sum
}

/// `∫ f` over the panels between consecutive sorted `edges`, each with `rule`.
fn integrate_panels(rule: &[(f64, f64)], edges: &mut [f64], mut f: impl FnMut(f64) -> f64) -> f64 {
    integrate_panels_rgb(rule, edges, |x| [f(x), 0.0, 0.0])[0]
}

/// `∫₀^π f(θ) dθ` per channel on panels graded towards the terminator θ = π/2 (down to 1e-5
/// rad), where the blurred kink lives.
fn integrate_theta(f: impl FnMut(f64) -> [f64; 3]) -> [f64; 3] {
    let mut edges = vec![0.0, FRAC_PI_2, PI];
    let mut h = 1e-5;
    while h < FRAC_PI_2 {
        edges.extend([FRAC_PI_2 - h, FRAC_PI_2 + h]);
        h *= 1.5;
    }
    integrate_panels_rgb(&gauss_legendre(16), &mut edges, f)
}

/// The ring integral by brute force at each of `thetas`: uniform panels of width π/`panels` over
/// x ∈ [−π, π], plus edges at x = 0 and at the kinks of cos⁺(θ + x), straight from the definition.
fn ring_brute_force(
    profile: &impl RadialProfile,
    curvature_per_mm: f64,
    thetas: &[f64],
    panels: usize,
) -> Vec<[f64; 3]> {
    let r = 1.0 / curvature_per_mm;
    let uniform: Vec<f64> = (0..=2 * panels)
        .map(|i| -PI + PI * i as f64 / panels as f64)
        .collect();
    let rule = gauss_legendre(8);
    let kernel = |x: f64| profile.radial_reflectance((2.0 * r * (0.5 * x).sin()).abs());
    let denominator = integrate_panels_rgb(&rule, &mut uniform.clone(), kernel);
    thetas
        .iter()
        .map(|&theta| {
            let mut edges = uniform.clone();
            for kink in [FRAC_PI_2 - theta, -FRAC_PI_2 - theta] {
                edges.push(if kink < -PI { kink + TAU } else { kink });
            }
            let numerator = integrate_panels_rgb(&rule, &mut edges, |x| {
                kernel(x).map(|k| clamped_cos(theta + x) * k)
            });
            std::array::from_fn(|c| numerator[c] / denominator[c])
        })
        .collect()
}

/// Ring pre-integration of a single Gaussian in closed form: the ring weight
/// exp(−(r²/v)(1 − cos x)) is a von Mises kernel of concentration k = r²/v with Fourier
/// coefficients Aₙ = Iₙ(k)/I₀(k), so
/// D(θ) = 1/π + ½A₁ cos θ + (2/π) Σ (−1)^(k+1) A₂ₖ cos(2kθ)/(4k² − 1).
/// The Bessel ratios come from the backward recurrence Iₙ/Iₙ₋₁ = 1/(2n/k + Iₙ₊₁/Iₙ).
fn von_mises_ring(variance_mm2: f64, radius_mm: f64, thetas: &[f64]) -> Vec<f64> {
    let k = radius_mm * radius_mm / variance_mm2;
    let harmonics = (20.0 * k.sqrt()).ceil() as usize + 50;
    let start = (4.0 * k) as usize + harmonics + 1000;
    let mut ratio = 0.0;
    let mut ratios = vec![0.0; harmonics + 1];
    for n in (1..=start).rev() {
        ratio = 1.0 / (2.0 * n as f64 / k + ratio);
        if n <= harmonics {
            ratios[n] = ratio;
        }
    }
    let mut a = vec![1.0; harmonics + 1];
    for n in 1..=harmonics {
        a[n] = a[n - 1] * ratios[n];
    }
    thetas
        .iter()
        .map(|&theta| {
            let mut f = FRAC_1_PI + 0.5 * a[1] * theta.cos();
            for j in 1..harmonics / 2 {
                let j_f = j as f64;
                let sign = if j % 2 == 1 { 1.0 } else { -1.0 };
                f += 2.0 / PI * sign * a[2 * j] * (2.0 * j_f * theta).cos()
                    / (4.0 * j_f * j_f - 1.0);
            }
            f
        })
        .collect()
}

/// `(cos⁺ ⊛ g_s)(θ)` by brute force: the periodic cos⁺ against the unwrapped Gaussian on the
/// line (the same as the wrapped Gaussian on the circle), cut at 12s, panels ≤ s/4 wide split
/// at every kink.
fn kubo_brute_force(theta: f64, s: f64) -> f64 {
    let half_width = 12.0 * s;
    let panels = 96;
    let mut edges: Vec<f64> = (0..=panels)
        .map(|i| -half_width + 2.0 * half_width * i as f64 / panels as f64)
        .collect();
    // Kinks of cos⁺(θ − t): θ − t = ±π/2 + 2πm.
    for m in -20..=20 {
        for kink in [
            theta - FRAC_PI_2 - TAU * m as f64,
            theta + FRAC_PI_2 - TAU * m as f64,
        ] {
            if kink.abs() < half_width {
                edges.push(kink);
            }
        }
    }
    let norm = 1.0 / (s * TAU.sqrt());
    integrate_panels(&gauss_legendre(16), &mut edges, |t| {
        clamped_cos(theta - t) * norm * (-0.5 * (t / s).powi(2)).exp()
    })
}

fn single_gaussian() -> GaussianProfile {
    GaussianProfile::new([16.0, 4.0, 1.0]).unwrap()
}

/// A model's `reflectance_f64(curvature_per_mm, theta_rad)`.
type Model = Box<dyn Fn(f64, f64) -> [f64; 3]>;

/// Every model, named.
fn all_models() -> Vec<(&'static str, Model)> {
    let kubo = GaussianCdrf::with_scale([4.0, 2.0, 1.0], [1.0; 3]).unwrap();
    let gauss = PreintegratedCdrf::new(single_gaussian());
    let skin = PreintegratedCdrf::new(SumOfGaussiansProfile::skin());
    let skin1 = PreintegratedCdrf::new(DipoleProfile::skin1());
    let marble = PreintegratedCdrf::new(DipoleProfile::marble());
    vec![
        (
            "Kubo σ=(4,2,1) mm",
            Box::new(move |k, t| kubo.reflectance_f64(k, t)),
        ),
        (
            "ring Gaussian v=(16,4,1) mm²",
            Box::new(move |k, t| gauss.reflectance_f64(k, t)),
        ),
        (
            "ring skin 6-Gaussian",
            Box::new(move |k, t| skin.reflectance_f64(k, t)),
        ),
        (
            "ring dipole Skin1",
            Box::new(move |k, t| skin1.reflectance_f64(k, t)),
        ),
        (
            "ring dipole Marble",
            Box::new(move |k, t| marble.reflectance_f64(k, t)),
        ),
    ]
}

/// The largest |f − cos⁺θ| over θ and channels.
fn max_error_to_clamped_cosine(f: &dyn Fn(f64, f64) -> [f64; 3], curvature_per_mm: f64) -> f64 {
    thetas(721)
        .flat_map(|theta| f(curvature_per_mm, theta).map(|v| (v - clamped_cos(theta)).abs()))
        .fold(0.0, f64::max)
}

#[test]
fn flat_limit_gives_clamped_cosine() {
    for (name, f) in all_models() {
        for curvature in [0.0, -0.05, f64::NAN] {
            let error = max_error_to_clamped_cosine(&*f, curvature);
            println!("{name}: κ = {curvature} mm⁻¹: max |f − cos⁺θ| = {error:e}");
            assert_eq!(error, 0.0);
        }
        let mut previous = f64::INFINITY;
        for curvature in [1e-3, 1e-4, 1e-5, 1e-6, 1e-7] {
            let error = max_error_to_clamped_cosine(&*f, curvature);
            println!("{name}: κ = {curvature:e} mm⁻¹: max |f − cos⁺θ| = {error:e}");
            assert!(error < previous || error == 0.0, "error must shrink with κ");
            previous = error;
        }
        assert!(
            previous < 1e-5,
            "{name}: κ = 1e-7 mm⁻¹ is {previous:e} from cos⁺"
        );
    }
    // Through the f32 trait, too.
    let kubo = GaussianCdrf::with_scale([4.0; 3], [0.5; 3]).unwrap();
    assert_eq!(kubo.reflectance(0.0, 1.0), [(0.5 * 1f64.cos()) as f32; 3]);
}

#[test]
fn theta_symmetry_and_infinite_curvature() {
    for (name, f) in all_models() {
        for theta in [0.3, 1.5, 2.9] {
            for curvature in [0.01, 0.3] {
                let f0 = f(curvature, theta);
                for other in [-theta, theta + TAU, TAU - theta] {
                    let f1 = f(curvature, other);
                    for c in 0..3 {
                        assert_close(&format!("{name} f(θ={other})"), f1[c], f0[c], 1e-12);
                    }
                }
            }
        }
        let full_blur = f(f64::INFINITY, 0.7);
        println!("{name}: κ = ∞: f = {full_blur:?} (1/π = {FRAC_1_PI})");
        for v in full_blur {
            assert_close(name, v, FRAC_1_PI, 1e-12);
        }
    }
}

#[test]
fn kubo_matches_brute_force_convolution() {
    let mut worst: f64 = 0.0;
    for s in [
        1e-4, 1e-3, 0.01, 0.05, 0.2, 0.2499999, 0.25, 0.3, 0.7, 1.5, 3.0,
    ] {
        let mut worst_s: f64 = 0.0;
        for theta in thetas(181).chain([FRAC_PI_2 - 1e-3, FRAC_PI_2 + 3e-4, FRAC_PI_2 + 1.4]) {
            let got = convolved_clamped_cosine(theta, s);
            let want = kubo_brute_force(theta, s);
            worst_s = worst_s.max((got - want).abs());
        }
        println!("Kubo s = {s} rad: max |closed form − brute force| = {worst_s:e}");
        worst = worst.max(worst_s);
    }
    assert!(worst < 1e-8, "worst {worst:e}");
}

#[test]
fn kubo_is_continuous_where_the_method_switches() {
    let mut jump: f64 = 0.0;
    for theta in thetas(721) {
        let below = convolved_clamped_cosine(theta, 0.25 * (1.0 - f64::EPSILON));
        let at = convolved_clamped_cosine(theta, 0.25);
        jump = jump.max((below - at).abs());
    }
    println!("Kubo: max jump between the local and Fourier forms at s = 0.25 rad: {jump:e}");
    assert!(jump < 1e-9);
}

#[test]
fn circle_integral_is_conserved() {
    // ∫₋π^π f dθ = 2 ∫₀^π f dθ = 2·scale for every kernel width.
    let mut worst: f64 = 0.0;
    for s in [
        1e-4, 1e-3, 0.01, 0.1, 0.2499, 0.2501, 0.5, 1.0, 2.0, 5.0, 50.0,
    ] {
        let circle = 2.0 * integrate_theta(|theta| [convolved_clamped_cosine(theta, s); 3])[0];
        let sphere =
            TAU * integrate_theta(|theta| [convolved_clamped_cosine(theta, s) * theta.sin(); 3])[0];
        println!(
            "Kubo s = {s} rad: ∫ over circle = {circle:.10} (2), error {:e}; sphere flux 2π∫f sinθ = {sphere:.6} (π at s = 0, 4 at full blur)",
            (circle - 2.0).abs()
        );
        worst = worst.max((circle - 2.0).abs());
    }
    let kubo = GaussianCdrf::with_scale([4.0, 2.0, 1.0], [0.8, 0.5, 0.25]).unwrap();
    let circles = integrate_theta(|theta| kubo.reflectance_f64(0.1, theta));
    for (c, (circle, scale)) in circles.iter().zip(kubo.scale()).enumerate() {
        let circle = 2.0 * circle;
        let want = 2.0 * f64::from(scale);
        println!("Kubo with scale, channel {c}: ∫ = {circle:.10}, want {want}");
        worst = worst.max((circle - want).abs());
    }
    for (name, f) in all_models().into_iter().skip(1) {
        for curvature in [0.02, 0.1, 0.5, 3.0] {
            let circles = integrate_theta(|theta| f(curvature, theta));
            for (c, circle) in circles.iter().enumerate() {
                let circle = 2.0 * circle;
                println!("{name}: κ = {curvature} mm⁻¹, channel {c}: ∫ over circle = {circle:.10}");
                worst = worst.max((circle - 2.0).abs());
            }
        }
    }
    println!("worst |∫ over circle − 2·scale| = {worst:e}");
    assert!(worst < 1e-4);
}

#[test]
fn kubo_and_ring_agree_for_a_single_gaussian() {
    // Metric: max over θ of |Kubo − ring| relative to the peak of Kubo (its value at θ = 0).
    for (radius_mm, sigma_mm) in [(15.0, 4.0), (15.0, 1.0), (50.0, 4.0), (5.0, 4.0)] {
        let kubo = GaussianCdrf::new([sigma_mm; 3]).unwrap();
        let ring = PreintegratedCdrf::new(GaussianProfile::new([sigma_mm * sigma_mm; 3]).unwrap());
        let curvature = 1.0 / f64::from(radius_mm);
        let (mut max_diff, mut peak): (f64, f64) = (0.0, 0.0);
        for theta in thetas(1801) {
            let a = kubo.reflectance_f64(curvature, theta)[0];
            let b = ring.reflectance_f64(curvature, theta)[0];
            max_diff = max_diff.max((a - b).abs());
            peak = peak.max(a);
        }
        let relative = max_diff / peak;
        println!(
            "r = {radius_mm} mm, σ = {sigma_mm} mm (σκ = {:.4} rad): max |Kubo − ring| = {max_diff:.3e}, relative to peak {peak:.4}: {:.4} %",
            sigma_mm / radius_mm,
            100.0 * relative
        );
        if (radius_mm, sigma_mm) == (15.0, 4.0) {
            assert!(relative < 0.02);
        }
    }
}

#[test]
fn ring_single_gaussian_matches_von_mises_series() {
    let angles: Vec<f64> = thetas(91)
        .chain([FRAC_PI_2 - 1e-3, FRAC_PI_2 + 2e-3])
        .collect();
    let mut worst: f64 = 0.0;
    for (variance_mm2, radius_mm) in [
        (0.0064, 50.0),
        (0.0064, 5.0),
        (16.0, 15.0),
        (16.0, 2.0),
        (1.0, 0.3),
    ] {
        let ring = PreintegratedCdrf::new(GaussianProfile::new([variance_mm2 as f32; 3]).unwrap());
        let variance = f64::from(variance_mm2 as f32);
        let want = von_mises_ring(variance, radius_mm, &angles);
        let error = angles
            .iter()
            .zip(&want)
            .map(|(&theta, &w)| (ring.reflectance_f64(1.0 / radius_mm, theta)[0] - w).abs())
            .fold(0.0, f64::max);
        println!(
            "ring Gaussian v = {variance_mm2} mm², r = {radius_mm} mm (angular σ ≈ {:.2e} rad): max |quadrature − von Mises series| = {error:e}",
            variance.sqrt() / radius_mm
        );
        worst = worst.max(error);
    }
    assert!(worst < 1e-7, "worst {worst:e}");
}

#[test]
fn ring_matches_brute_force_quadrature() {
    let angles = [
        0.0,
        1.0,
        FRAC_PI_2 - 0.01,
        FRAC_PI_2,
        FRAC_PI_2 + 0.002,
        2.1,
        PI,
    ];
    let cases: Vec<(&str, Box<dyn RadialProfile>, f64, usize)> = vec![
        (
            "skin 6-Gaussian",
            Box::new(SumOfGaussiansProfile::skin()),
            50.0,
            2000,
        ),
        (
            "skin 6-Gaussian",
            Box::new(SumOfGaussiansProfile::skin()),
            3.0,
            1000,
        ),
        (
            "dipole Marble",
            Box::new(DipoleProfile::marble()),
            15.0,
            1000,
        ),
        ("dipole Skin1", Box::new(DipoleProfile::skin1()), 2.0, 1000),
        (
            "dipole Skin1",
            Box::new(DipoleProfile::skin1()),
            1.0 / 3.0,
            1000,
        ),
    ];
    let mut worst: f64 = 0.0;
    for (name, profile, radius_mm, panels) in cases {
        let ring = PreintegratedCdrf::new(profile);
        let want = ring_brute_force(ring.profile(), 1.0 / radius_mm, &angles, panels);
        let mut error: f64 = 0.0;
        for (&theta, want) in angles.iter().zip(&want) {
            let got = ring.reflectance_f64(1.0 / radius_mm, theta);
            for c in 0..3 {
                error = error.max((got[c] - want[c]).abs());
            }
        }
        println!("ring {name}, r = {radius_mm} mm: max |panels − brute force| = {error:e}");
        worst = worst.max(error);
    }
    assert!(worst < 1e-7, "worst {worst:e}");
}

#[test]
fn broadening_grows_with_curvature() {
    // At θ = 120°, 30° past the terminator, f is light wrapped around from the lit side.
    let theta = 120f64.to_radians();
    let curvatures = [0.0, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0];
    for (name, f) in all_models() {
        let values: Vec<[f64; 3]> = curvatures.iter().map(|&k| f(k, theta)).collect();
        println!("{name}: f(120°) red at κ = {curvatures:?} mm⁻¹:");
        println!(
            "    {:.5?}",
            values.iter().map(|v| v[0]).collect::<Vec<_>>()
        );
        for c in 0..3 {
            for pair in values.windows(2) {
                assert!(
                    pair[1][c] >= pair[0][c],
                    "{name} channel {c}: {:?} then {:?}",
                    pair[0],
                    pair[1]
                );
            }
            let last = values.last().unwrap()[c];
            assert!(
                last > values[0][c] && last < FRAC_1_PI + 1e-9,
                "{name}: f(120°, κ = 5) = {last}"
            );
        }
    }
}

#[test]
fn skin_profile_is_normalised() {
    let skin = SumOfGaussiansProfile::skin();
    let totals = skin.total_weights();
    println!("skin weights per channel sum to {totals:?}");
    // ∫ R(d) 2πd dd over the plane, on panels doubling from 0.01 mm to 64 mm.
    let mut edges = vec![0.0];
    let mut d = 0.01;
    while d < 64.0 {
        edges.push(d);
        d *= 2.0;
    }
    let rule = gauss_legendre(16);
    for (c, total) in totals.into_iter().enumerate() {
        assert_close("skin weight sum", f64::from(total), 1.0, 1e-6);
        let integral = integrate_panels(&rule, &mut edges, |d| {
            TAU * d * skin.radial_reflectance(d)[c]
        });
        println!("skin channel {c}: ∫ R 2πd dd = {integral:.9}");
        assert_close("skin ∫ R over the plane", integral, 1.0, 1e-6);
    }
    assert_eq!(skin.terms().len(), 6);
}

#[test]
fn dipole_is_positive_and_decreasing() {
    for (name, dipole) in [
        ("Skin1", DipoleProfile::skin1()),
        ("Marble", DipoleProfile::marble()),
    ] {
        let mut previous = [f64::INFINITY; 3];
        let mut d = 0.0;
        while d < 500.0 {
            let value = dipole.radial_reflectance(d);
            for c in 0..3 {
                assert!(
                    value[c] > 0.0 && value[c] < previous[c],
                    "{name} at {d} mm: {value:?} after {previous:?}"
                );
            }
            previous = value;
            d = if d == 0.0 { 1e-3 } else { d * 1.25 };
        }
        println!(
            "dipole {name}: R_d(0) = {:.4?}, R_d(1 mm) = {:.4?}, R_d(10 mm) = {:.3?} mm⁻²",
            dipole.radial_reflectance(0.0),
            dipole.radial_reflectance(1.0),
            dipole.radial_reflectance(10.0)
        );
    }
}

#[test]
fn bad_parameters_are_errors() {
    let cases: Vec<(&str, Result<(), ParameterError>)> = vec![
        ("negative σ", GaussianCdrf::new([1.0, -2.0, 1.0]).map(drop)),
        ("NaN σ", GaussianCdrf::new([f32::NAN, 1.0, 1.0]).map(drop)),
        (
            "infinite scale",
            GaussianCdrf::with_scale([1.0; 3], [1.0, 1.0, f32::INFINITY]).map(drop),
        ),
        (
            "negative scale",
            GaussianCdrf::with_scale([1.0; 3], [-0.5, 1.0, 1.0]).map(drop),
        ),
        (
            "zero variance",
            GaussianProfile::new([1.0, 0.0, 1.0]).map(drop),
        ),
        ("no terms", SumOfGaussiansProfile::new(vec![]).map(drop)),
        (
            "negative weight",
            SumOfGaussiansProfile::new(vec![GaussianTerm {
                variance_mm2: 1.0,
                weights: [1.0, -1.0, 1.0],
            }])
            .map(drop),
        ),
        (
            "blue weights all zero",
            SumOfGaussiansProfile::new(vec![GaussianTerm {
                variance_mm2: 1.0,
                weights: [1.0, 1.0, 0.0],
            }])
            .map(drop),
        ),
        (
            "zero σ_s'",
            DipoleProfile::new([0.1; 3], [1.0, 0.0, 1.0], 1.3).map(drop),
        ),
        (
            "negative σ_a",
            DipoleProfile::new([0.1, 0.1, -0.1], [1.0; 3], 1.3).map(drop),
        ),
        (
            "η = 0.5",
            DipoleProfile::new([0.1; 3], [1.0; 3], 0.5).map(drop),
        ),
        (
            "η = NaN",
            DipoleProfile::new([0.1; 3], [1.0; 3], f32::NAN).map(drop),
        ),
    ];
    for (what, result) in &cases {
        let error = result.as_ref().expect_err(what);
        println!("{what}: {error}");
    }
    let message = |i: usize| cases[i].1.as_ref().unwrap_err().to_string();
    assert_eq!(message(0), "sigma_mm[1] = -2 mm: must be >= 0");
    assert_eq!(message(1), "sigma_mm[0] = NaN mm: must be finite");
    assert_eq!(message(4), "variance_mm2[1] = 0 mm²: must be > 0");
    assert_eq!(message(6), "terms[0].weights[1] = -1: must be >= 0");
    assert!(matches!(
        cases[5].1,
        Err(ParameterError::ZeroTotalWeight { channel: 0 })
    ));
    assert!(matches!(
        cases[7].1,
        Err(ParameterError::ZeroTotalWeight { channel: 2 })
    ));
    assert_eq!(message(8), "sigma_s_prime_per_mm[1] = 0 mm⁻¹: must be > 0");
    assert!(matches!(
        cases[10].1,
        Err(ParameterError::EtaOutOfRange { .. })
    ));
    // Valid edge cases: σ = 0 is the plain Lambertian, σ_a = 0 a non-absorbing dipole.
    let lambert = GaussianCdrf::new([0.0; 3]).unwrap();
    assert_eq!(lambert.reflectance(f32::INFINITY, 0.5), [0.5f32.cos(); 3]);
    let clear = PreintegratedCdrf::new(DipoleProfile::new([0.0; 3], [1.0; 3], 1.3).unwrap());
    let f = clear.reflectance(0.1, 2.0);
    println!("non-absorbing dipole at κ = 0.1 mm⁻¹, θ = 2 rad: {f:?}");
    assert!(f.iter().all(|v| v.is_finite() && *v > 0.0));
}

#[test]
fn evaluation_is_cheap() {
    // No timing asserts (speed belongs in benchmarks); this prints rough costs per call.
    let build = if cfg!(debug_assertions) {
        "debug"
    } else {
        "release"
    };
    let kubo = GaussianCdrf::new([4.0, 2.0, 1.0]).unwrap();
    let skin = PreintegratedCdrf::new(SumOfGaussiansProfile::skin());
    let marble = PreintegratedCdrf::new(DipoleProfile::marble());
    let cases: [(&str, &dyn Cdrf, usize); 3] = [
        ("Kubo (3 channels)", &kubo, 20_000),
        ("ring skin", &skin, 2000),
        ("ring Marble", &marble, 2000),
    ];
    for (name, model, calls) in cases {
        let mut checksum = 0.0;
        let start = Instant::now();
        for i in 0..calls {
            let curvature = 0.01 + 0.5 * (i % 97) as f32 / 97.0;
            let theta = std::f32::consts::PI * (i % 101) as f32 / 100.0;
            checksum += model.reflectance(curvature, theta)[1];
        }
        let per_call = start.elapsed().as_secs_f64() / calls as f64;
        println!(
            "{name}: {:.2} µs per call ({build} build, {calls} calls, checksum {checksum:.3})",
            per_call * 1e6
        );
        assert!(checksum.is_finite());
    }
    // The three paths of the Kubo kernel, one channel.
    let calls = 20_000;
    for (path, s, theta_from, theta_to) in [
        ("Fourier series, s = 0.5 rad", 0.5, 0.0, PI),
        (
            "terminator quadrature, s = 0.1 rad",
            0.1,
            FRAC_PI_2 - 0.5,
            FRAC_PI_2 + 0.5,
        ),
        (
            "closed form away from the terminator, s = 0.01 rad",
            0.01,
            0.0,
            1.4,
        ),
    ] {
        let mut checksum = 0.0;
        let start = Instant::now();
        for i in 0..calls {
            let theta = theta_from + (theta_to - theta_from) * (i % 101) as f64 / 100.0;
            checksum += convolved_clamped_cosine(theta, s);
        }
        let per_call = start.elapsed().as_secs_f64() / f64::from(calls);
        println!(
            "Kubo kernel, {path}: {:.3} µs per channel ({build} build, checksum {checksum:.3})",
            per_call * 1e6
        );
    }
}
