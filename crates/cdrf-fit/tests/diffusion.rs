//! The diffusion profile fit on synthetic truth: spheres shaded by a known profile R(d) (not on
//! the fit's basis lengths) are fitted back, and the profile and its entry power recovered.

use cdrf_core::diffusion::{DiffusionProfile, ProfileTerm};
use cdrf_fit::diffusion::{DiffusionFitError, DiffusionSettings, fit_diffusion};
use cdrf_fit::transmission::SphereCurve;
use glam::Vec3;

/// Burley-like two-term profiles per channel (ℓ and 3ℓ), lengths between the basis lengths.
fn truth() -> DiffusionProfile {
    DiffusionProfile::new(
        vec![
            ProfileTerm {
                length_mm: 0.7,
                weight: [0.10, 0.25, 0.45],
            },
            ProfileTerm {
                length_mm: 2.1,
                weight: [0.20, 0.40, 0.35],
            },
            ProfileTerm {
                length_mm: 5.3,
                weight: [0.30, 0.20, 0.05],
            },
            ProfileTerm {
                length_mm: 15.9,
                weight: [0.35, 0.08, 0.0],
            },
        ],
        0.7,
    )
    .unwrap()
}

const NODES: usize = 181;
const RADII_MM: [f64; 8] = [15.0, 20.0, 25.0, 30.0, 35.0, 40.0, 45.0, 50.0];

fn curves(profile: &DiffusionProfile) -> Vec<Vec<Vec3>> {
    RADII_MM
        .iter()
        .map(|&r| {
            (0..NODES)
                .map(|i| {
                    let theta = std::f64::consts::PI * i as f64 / (NODES - 1) as f64;
                    let f = profile.sphere_reflectance(1.0 / r, theta);
                    Vec3::new(f[0] as f32, f[1] as f32, f[2] as f32)
                })
                .collect()
        })
        .collect()
}

#[test]
fn spheres_shaded_by_a_known_profile_give_it_back() {
    let truth = truth();
    let curves = curves(&truth);
    let samples = vec![50.0; NODES];
    let noise = vec![Vec3::splat(0.05); NODES];
    let spheres: Vec<SphereCurve<'_>> = RADII_MM
        .iter()
        .zip(&curves)
        .map(|(&r, values)| SphereCurve {
            curvature_per_mm: (1.0 / r) as f32,
            values,
            samples: &samples,
            noise: &noise,
        })
        .collect();
    let fit = fit_diffusion(&spheres, &DiffusionSettings::default()).unwrap();
    let profile = &fit.profile;
    println!(
        "power {} (truth {}), relative RMS {:?}, powers tried {:?}",
        profile.entry_cosine_power(),
        truth.entry_cosine_power(),
        fit.relative_rms,
        fit.powers_tried
    );
    assert!((profile.entry_cosine_power() - truth.entry_cosine_power()).abs() < 0.026);
    // The spheres are reproduced (the fit's basis lengths differ from the truth's).
    for sphere in &fit.spheres {
        println!(
            "r = {} mm: rel RMS {:?}, lit {:?}, shadow {:?}",
            sphere.radius_mm, sphere.relative_rms, sphere.lit_ratio, sphere.shadow_ratio
        );
        for c in 0..3 {
            assert!(sphere.relative_rms[c] < 0.03, "{sphere:?}");
            assert!((sphere.shadow_ratio[c] - 1.0).abs() < 0.03, "{sphere:?}");
        }
    }
    // The albedo and the profile itself, as the light leaving per mm of distance 2π·d·R(d),
    // wherever it carries at least 1 % of its peak (d = 0.5 … 40 mm).
    for (fitted, want) in profile.albedo().iter().zip(truth.albedo()) {
        assert!(
            (fitted / want - 1.0).abs() < 0.03,
            "albedo {fitted} vs {want}"
        );
    }
    for c in 0..3 {
        let peak = truth.ring_density_per_mm(0.0)[c];
        for i in 0..=80 {
            let d = 0.5 * 1.1f64.powi(i);
            if d > 40.0 {
                break;
            }
            let want = truth.ring_density_per_mm(d)[c];
            if want < 0.01 * peak {
                continue;
            }
            let got = profile.ring_density_per_mm(d)[c];
            assert!(
                (got / want - 1.0).abs() < 0.15,
                "channel {c}, d = {d:.2} mm: 2πdR = {got:.5} vs {want:.5}"
            );
        }
    }
}

#[test]
fn too_few_nodes_is_an_error_naming_the_channel() {
    let values = vec![Vec3::new(0.5, 0.5, 0.0); 5];
    let samples = vec![10.0; 5];
    let noise = vec![Vec3::splat(0.05); 5];
    let spheres = [SphereCurve {
        curvature_per_mm: 1.0 / 20.0,
        values: &values,
        samples: &samples,
        noise: &noise,
    }];
    let settings = DiffusionSettings {
        theta_stride: 1,
        ..DiffusionSettings::default()
    };
    match fit_diffusion(&spheres, &settings) {
        Err(DiffusionFitError::TooFewNodes { channel, .. }) => assert_eq!(channel, "red"),
        other => panic!("{other:?}"),
    }
    let settings = DiffusionSettings {
        lengths_mm: vec![2.0, 1.0],
        ..DiffusionSettings::default()
    };
    assert!(matches!(
        fit_diffusion(&spheres, &settings),
        Err(DiffusionFitError::Settings(_))
    ));
}
