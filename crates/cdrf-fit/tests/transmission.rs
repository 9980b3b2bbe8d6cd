//! The transmission profile T(d, μ) = A·μ·exp(−d/ℓ) fitted to the spheres' shadow sides: synthetic
//! truth is recovered (exactly, with noise, and end to end through the whole fit), and data
//! without a usable shadow side gives a typed error — and a table without translucency, not a
//! failed fit.

mod common;

use cdrf_core::Cdrf;
use cdrf_core::translucency::{TransmissionProfile, local_chord_mm, local_entry_cosine};
use cdrf_fit::FitOptions;
use cdrf_fit::curves::{CurveSettings, SphereSamples, ViewModel};
use cdrf_fit::fit::{Timings, fit_samples};
use cdrf_fit::transmission::{
    DEFAULT_MIN_THETA_DEG, SphereCurve, TransmissionError, TransmissionSettings, fit_transmission,
};
use common::synthetic_sphere;
use glam::Vec3;

const AMPLITUDE: [f32; 3] = [0.25, 0.18, 0.12];
const LENGTH_MM: [f32; 3] = [12.0, 8.0, 5.5];
const RADII_MM: [f32; 8] = [15.0, 20.0, 25.0, 30.0, 35.0, 40.0, 45.0, 50.0];
const NODES: usize = 361;

fn truth() -> TransmissionProfile {
    TransmissionProfile::new(AMPLITUDE, LENGTH_MM).unwrap()
}

fn theta_at(a: usize) -> f32 {
    std::f32::consts::PI * a as f32 / (NODES - 1) as f32
}

/// Per-sphere inputs of the fit, owned.
struct Curve {
    curvature_per_mm: f32,
    values: Vec<Vec3>,
    samples: Vec<f32>,
    noise: Vec<Vec3>,
}

impl Curve {
    fn view(&self) -> SphereCurve<'_> {
        SphereCurve {
            curvature_per_mm: self.curvature_per_mm,
            values: &self.values,
            samples: &self.samples,
            noise: &self.noise,
        }
    }
}

/// T(d, μ) of the sphere of radius `radius_mm` at θ: its chord and entry cosine.
fn sphere_truth(radius_mm: f32, theta_rad: f32) -> Vec3 {
    let (curvature_per_mm, cos_theta) = (1.0 / radius_mm, theta_rad.cos());
    truth().evaluate(
        local_chord_mm(curvature_per_mm, cos_theta),
        local_entry_cosine(curvature_per_mm, cos_theta),
    )
}

/// A sphere's curve: lit side `0.8·cos θ + A`, between the terminator and the fit's θ
/// minimum 3·T(d, μ) (sideways diffusion, which the fit must leave out), beyond it exactly
/// T(d, μ);
/// samples as on a photograph (few near the silhouette, none in the last 8°), noise growing
/// into the shadow. `factor(sphere, node)` multiplies each value (noise).
fn curve(radius_mm: f32, factor: impl Fn(usize) -> f32) -> Curve {
    let values = (0..NODES)
        .map(|a| {
            let theta = theta_at(a);
            let value = if theta.to_degrees() <= 90.0 {
                Vec3::splat(0.8 * theta.cos()) + sphere_truth(radius_mm, theta)
            } else if theta.to_degrees() < DEFAULT_MIN_THETA_DEG {
                3.0 * sphere_truth(radius_mm, theta)
            } else {
                sphere_truth(radius_mm, theta)
            };
            value * factor(a)
        })
        .collect();
    let samples = (0..NODES)
        .map(|a| {
            if theta_at(a).to_degrees() > 172.25 {
                0.0
            } else {
                800.0 * theta_at(a).sin() + 1.0
            }
        })
        .collect();
    let noise = (0..NODES)
        .map(|a| Vec3::splat(0.1 + 0.9 * (theta_at(a).to_degrees() / 180.0)))
        .collect();
    Curve {
        curvature_per_mm: 1.0 / radius_mm,
        values,
        samples,
        noise,
    }
}

/// A seeded linear congruential generator: uniform numbers in (0, 1).
struct Lcg(u64);

impl Lcg {
    fn uniform(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 40) as f32 + 0.5) / (1u64 << 24) as f32
    }

    /// A standard normal number (Box-Muller).
    fn normal(&mut self) -> f32 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f32::consts::TAU * v).cos()
    }
}

fn assert_recovered(found: &TransmissionProfile, tolerance: f32, what: &str) {
    for c in 0..3 {
        for (name, value, expected) in [
            ("A", found.amplitude[c], AMPLITUDE[c]),
            ("ℓ", found.length_mm[c], LENGTH_MM[c]),
        ] {
            let error = (value / expected - 1.0).abs();
            println!(
                "{what}: {name}[{c}] = {value:.5} (truth {expected}, off {:.3} %)",
                100.0 * error
            );
            assert!(
                error <= tolerance,
                "{what}: {name}[{c}] = {value}, truth {expected}: off by {:.3} % > {:.1} %",
                100.0 * error,
                100.0 * tolerance
            );
        }
    }
}

#[test]
fn exact_shadow_sides_give_the_profile_back() {
    let curves: Vec<Curve> = RADII_MM.iter().map(|&r| curve(r, |_| 1.0)).collect();
    let views: Vec<SphereCurve<'_>> = curves.iter().map(Curve::view).collect();
    let fit = fit_transmission(&views, &TransmissionSettings::default()).unwrap();
    assert_recovered(&fit.profile, 1e-3, "exact");
    for (c, channel) in fit.channels.iter().enumerate() {
        // 110° … 172° on 0.5° nodes, every sphere, down to 10⁻⁴ of the peak (0.8 + A).
        let floor = 1e-4 * (0.8 + AMPLITUDE[c]);
        let expected = RADII_MM
            .iter()
            .flat_map(|&r| (220..=344).filter(move |&a| sphere_truth(r, theta_at(a))[c] >= floor))
            .count();
        assert_eq!(channel.points.len(), expected, "channel {c}");
        // Blue, the shortest ℓ, keeps the fewest: 379 of the 1 000 nodes.
        assert!(expected > 350, "{expected}");
        assert!(
            channel
                .points
                .iter()
                .all(|p| p.theta_rad.to_degrees() >= 110.0 - 1e-3)
        );
        let (near, far) = channel.chord_range_mm;
        assert!(
            (near - 2.0 * 15.0 * 20.0_f32.to_radians().sin()).abs() < 0.05,
            "{near}"
        );
        // T(d, μ) = floor at μ = 1 bounds the chord; the r = 50 mm sphere's last nodes above the
        // floor come within a few mm of it.
        let longest = -LENGTH_MM[c] * (floor / AMPLITUDE[c]).ln();
        assert!(
            far <= longest && far > longest - 8.0,
            "{far} (T = floor at {longest} mm)"
        );
        assert!(channel.relative_rms < 1e-3, "{}", channel.relative_rms);
        assert_eq!(channel.mean_ratio_per_sphere.len(), 8);
        // Every sphere with a node above the floor has points (all but r = 50 mm in blue).
        for (ratio, &r) in channel.mean_ratio_per_sphere.iter().zip(&RADII_MM) {
            let has_points = (220..=344).any(|a| sphere_truth(r, theta_at(a))[c] >= floor);
            assert_eq!(ratio.is_some(), has_points, "r = {r} mm, channel {c}");
            if let Some(ratio) = ratio {
                assert!((ratio - 1.0).abs() < 1e-3, "{ratio}");
            }
        }
        let with_points = channel.mean_ratio_per_sphere.iter().flatten().count();
        assert!(with_points >= 7, "{with_points} spheres with points");
    }
}

#[test]
fn noisy_shadow_sides_give_the_profile_within_a_few_percent() {
    let mut random = Lcg(0x5eed);
    // 15 % multiplicative noise per node, mean one.
    let sigma = 0.15_f32;
    let curves: Vec<Curve> = RADII_MM
        .iter()
        .map(|&r| {
            let factors: Vec<f32> = (0..NODES)
                .map(|_| (sigma * random.normal() - 0.5 * sigma * sigma).exp())
                .collect();
            curve(r, |a| factors[a])
        })
        .collect();
    let views: Vec<SphereCurve<'_>> = curves.iter().map(Curve::view).collect();
    let fit = fit_transmission(&views, &TransmissionSettings::default()).unwrap();
    assert_recovered(&fit.profile, 0.03, "noisy");
    for channel in &fit.channels {
        // The noise, and no more.
        assert!(
            (0.10..0.20).contains(&channel.relative_rms),
            "{}",
            channel.relative_rms
        );
    }
}

#[test]
fn lit_side_only_or_too_few_points_is_a_typed_error() {
    let mut lit_only = curve(30.0, |_| 1.0);
    for a in 0..NODES {
        if theta_at(a).to_degrees() > 90.0 {
            lit_only.samples[a] = 0.0;
        }
    }
    let error = fit_transmission(&[lit_only.view()], &TransmissionSettings::default()).unwrap_err();
    assert!(
        matches!(error, TransmissionError::TooFewPoints { points: 0, .. }),
        "{error:?}"
    );
    let message = error.to_string();
    assert!(message.contains("θ ≥ 110°"), "{message}");

    // Two measured shadow-side nodes.
    let mut two = curve(30.0, |_| 1.0);
    for a in 0..NODES {
        if a != 300 && a != 310 {
            two.samples[a] = 0.0;
        }
    }
    let error = fit_transmission(&[two.view()], &TransmissionSettings::default()).unwrap_err();
    assert!(
        matches!(
            error,
            TransmissionError::TooFewPoints {
                points: 2,
                needed: 3,
                ..
            }
        ),
        "{error:?}"
    );

    // No sphere at all.
    assert!(matches!(
        fit_transmission(&[], &TransmissionSettings::default()),
        Err(TransmissionError::TooFewPoints { points: 0, .. })
    ));
}

#[test]
fn a_shadow_side_that_brightens_with_the_chord_is_a_typed_error() {
    let mut rising = curve(30.0, |_| 1.0);
    // Faster than the entry cosine rises (0.34 → 0.99 over the shadow side): f/μ rises too.
    for a in 0..NODES {
        rising.values[a] = Vec3::splat(1e-3 * (0.05 * a as f32).exp());
    }
    let error = fit_transmission(&[rising.view()], &TransmissionSettings::default()).unwrap_err();
    assert!(
        matches!(error, TransmissionError::NoDecay { channel: "R", .. }),
        "{error:?}"
    );
    assert!(error.to_string().contains("does not get darker"), "{error}");
}

#[test]
fn inconsistent_inputs_are_a_typed_error() {
    let mut short = curve(30.0, |_| 1.0);
    short.noise.truncate(100);
    let error = fit_transmission(&[short.view()], &TransmissionSettings::default()).unwrap_err();
    assert!(
        matches!(
            error,
            TransmissionError::Shape {
                sphere: 0,
                values: 361,
                samples: 361,
                noise: 100
            }
        ),
        "{error:?}"
    );
}

#[test]
fn a_larger_theta_minimum_uses_fewer_points() {
    let curves: Vec<Curve> = RADII_MM.iter().map(|&r| curve(r, |_| 1.0)).collect();
    let views: Vec<SphereCurve<'_>> = curves.iter().map(Curve::view).collect();
    let settings = TransmissionSettings {
        min_theta_deg: 140.0,
    };
    let fit = fit_transmission(&views, &settings).unwrap();
    assert_eq!(fit.settings, settings);
    assert!(
        fit.channels
            .iter()
            .flat_map(|c| &c.points)
            .all(|p| p.theta_rad.to_degrees() >= 140.0 - 1e-3)
    );
    assert_recovered(&fit.profile, 1e-3, "θ ≥ 140°");
}

/// A CDRF whose lit side is Lambertian plus T(0, 1) and whose shadow side is exactly T(d, μ)
/// of the osculating sphere's chord.
struct TransmittingSphere;

impl Cdrf for TransmittingSphere {
    fn reflectance(&self, curvature_per_mm: f32, theta_rad: f32) -> [f32; 3] {
        (Vec3::splat(0.8 * theta_rad.cos().max(0.0))
            + sphere_truth(1.0 / curvature_per_mm, theta_rad))
        .to_array()
    }
}

fn phi_options() -> FitOptions {
    FitOptions {
        curves: CurveSettings {
            view_model: ViewModel::Phi,
            ..CurveSettings::default()
        },
        ..FitOptions::default()
    }
}

#[test]
fn the_whole_fit_recovers_the_profile_and_puts_it_in_the_table() {
    let samples: Vec<SphereSamples> = [15.0, 25.0, 35.0, 50.0]
        .iter()
        .map(|&r| synthetic_sphere(&TransmittingSphere, |_| Vec3::ONE, r, |_| true))
        .collect();
    let fit = fit_samples(samples, Vec::new(), &phi_options(), Timings::default()).unwrap();
    let transmission = fit.transmission.as_ref().expect("transmission fitted");
    assert_recovered(&transmission.profile, 0.02, "whole fit");
    let translucency = fit
        .lut
        .translucency()
        .expect("the table carries translucency");
    assert_eq!(translucency.transmission, transmission.profile);
    assert_eq!(
        translucency.scattering_length_mm,
        fit.gaussian.model.sigma_mm()
    );
}

#[test]
fn without_a_shadow_side_the_fit_goes_on_without_translucency() {
    let lit = |theta: f32| theta < 85.0_f32.to_radians();
    let samples: Vec<SphereSamples> = [20.0, 40.0]
        .iter()
        .map(|&r| synthetic_sphere(&TransmittingSphere, |_| Vec3::ONE, r, lit))
        .collect();
    let fit = fit_samples(samples, Vec::new(), &phi_options(), Timings::default()).unwrap();
    assert!(
        matches!(
            fit.transmission,
            Err(TransmissionError::TooFewPoints { .. })
        ),
        "{:?}",
        fit.transmission
    );
    assert!(fit.lut.translucency().is_none());

    // The outputs say so.
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    std::fs::create_dir(&data).unwrap();
    let out = dir.path().join("out");
    cdrf_fit::outputs::write_outputs(&fit, &data, &out).unwrap();
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    let section = &report["transmission"];
    assert_eq!(section["min_theta_deg"], 110.0);
    assert!(
        section["error"]
            .as_str()
            .is_some_and(|e| e.contains("shadow-side")),
        "{section}"
    );
    assert!(section.get("amplitude").is_none(), "{section}");
    let svg = std::fs::read_to_string(out.join("transmission.svg")).unwrap();
    assert!(svg.contains("not fitted"));
    let lut = cdrf_core::read_lut(out.join("measured.exr")).unwrap();
    assert!(lut.translucency().is_none());
}
