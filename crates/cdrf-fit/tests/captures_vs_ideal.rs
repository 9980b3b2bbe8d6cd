//! The realistic captures of `data/captures/` (a lamp at 1 m, a perspective lens, a stand, a
//! table, a grey wall, sensor noise, a residual highlight, RAW-like codes, JPEG, four spheres in
//! one photograph; made by `scripts/captures/make_captures.py`) against the bundled fit of the
//! ideal photographs of the same wax (`data/wax-fit/measured.exr`).
//!
//! Both tables are read as a renderer reads them, over the ideal photographs' own pixels (an
//! orthographic view, the light at 90°), at each captured sphere's curvature; the sums over a θ
//! region are compared and printed against issue 38's bounds: lit side (θ < 80°) within 2 %,
//! terminator (80–110°) within 4 %, shadow side (110–150°) within 15 % or inside the fit's own
//! 95 % band.
//!
//! Where they hold and where not (docs/captures.md has the table): the fit divides out the view's
//! azimuth (the lamp is 83° from the camera, 53–62° in the several-sphere photograph) and finds
//! each silhouette against the wall to a tenth of a pixel, so every lit side and terminator of
//! the single-sphere sets is within 2 % / 4 %; the 8-bit JPEG's shadow sides up to 30 mm are
//! inside the band, which counts the files' code steps; where a shadow side's band passes ±40 %
//! the table continues with the diffusion profile (`cdrf_fit::tails`), which holds the
//! several-sphere photograph's 10 mm sphere within 15 %. Not yet: the shadow side of the 50 mm
//! sphere (room light the flagged frame cannot remove), the several-sphere photograph's other
//! shadow sides (few samples per pixel), its 50 and 20 mm terminators (+4.5 % blue, −4.1 %
//! green) and its 10 mm lit side (+2.0 % blue); the fit warns of the shadow sides (the flagged
//! frame carried more than three times the lamp's light there), and this test fails a shadow
//! side that misses both the bound and the band unwarned, and the several-sphere photograph
//! alone measures no deep shadow side (past 110°) to set the profile's long terms, which the
//! fit must also say (`measured_deep_shadow_deg`). What this test holds every capture to is
//! what the fit reaches today, so that it cannot get worse unnoticed: see [`held_to`].

use std::path::{Path, PathBuf};

use cdrf_core::lut::{CdrfLut, Filter};
use cdrf_fit::dataset::Dataset;
use cdrf_fit::fit::{
    DEEP_SHADOW_MIN_DEG, Fit, FitOptions, NodeBand, confidence_95, fit_dataset,
    measured_deep_shadow_deg, room_dominated_ranges,
};
use glam::Vec3;

fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data")
}

const REGIONS: [(&str, f32, f32, f32); 3] = [
    ("lit", 0.0, 80.0, 0.02),
    ("terminator", 80.0, 110.0, 0.04),
    ("shadow", 110.0, 150.0, 0.15),
];

/// Sum of `lut` over the ideal photograph's pixels whose θ is in `[from, to)` degrees.
fn region_sum(lut: &CdrfLut, curvature_per_mm: f32, from: f32, to: f32) -> Vec3 {
    let n = 256;
    let mut sum = Vec3::ZERO;
    for j in 0..n {
        for i in 0..n {
            let (x, y) = (
                (i as f32 + 0.5) / n as f32 * 2.0 - 1.0,
                (j as f32 + 0.5) / n as f32 * 2.0 - 1.0,
            );
            let rho2 = x * x + y * y;
            if rho2 >= 0.98 {
                continue;
            }
            let normal = Vec3::new(x, y, (1.0 - rho2).sqrt());
            let theta = normal.dot(Vec3::NEG_X).clamp(-1.0, 1.0).acos();
            let phi = normal.z.clamp(-1.0, 1.0).acos();
            if (from..to).contains(&theta.to_degrees()) {
                sum += lut.evaluate(curvature_per_mm, theta, phi, Filter::Bilinear);
            }
        }
    }
    sum
}

/// The fit's 95 % band for sphere `k` pooled over the θ nodes of a region (relative).
fn region_band(fit: &Fit, k: usize, from: f32, to: f32) -> f32 {
    let band = confidence_95(&fit.curves.chosen, k);
    let count = band.len();
    let in_region = band
        .iter()
        .enumerate()
        .filter(|(i, _)| (from..to).contains(&(*i as f32 / (count - 1) as f32 * 180.0)))
        .filter_map(|(_, b)| *b);
    // A region with no measured node has no band: nothing is inside it.
    NodeBand::pool(in_region).map_or(f32::NAN, NodeBand::half_width)
}

/// Whether the fit warned that the room dominated sphere `k` somewhere in `[from, to)` degrees.
fn room_dominated(fit: &Fit, k: usize, from: f32, to: f32) -> bool {
    let count = fit.curves.chosen.settings.theta_count;
    let theta_deg: Vec<f32> = (0..count)
        .map(|i| i as f32 / (count - 1) as f32 * 180.0)
        .collect();
    room_dominated_ranges(&fit.curves.chosen, k, &theta_deg)
        .iter()
        .any(|[a, b]| *a < to && *b >= from)
}

/// Fits one capture set and checks every sphere's regions; returns the failures.
fn check(case: &str) -> Vec<String> {
    let ideal = cdrf_core::read_lut(data_dir().join("wax-fit/measured.exr"))
        .unwrap_or_else(|e| panic!("{e}"));
    let dataset =
        Dataset::load(&data_dir().join("captures").join(case)).unwrap_or_else(|e| panic!("{e}"));
    let fit = fit_dataset(&dataset, &FitOptions::default(), |_| {})
        .unwrap_or_else(|e| panic!("{case}: {e}"));
    let mut failures = Vec::new();
    // Only the several-sphere photograph leaves the profile's long terms unmeasured (its
    // spheres light each other's shadow sides), and the fit must say so.
    let deep_deg = measured_deep_shadow_deg(&fit.curves.chosen);
    println!("{case:>6}: shadow side past 110° measured over {deep_deg:.1}°");
    if (deep_deg < DEEP_SHADOW_MIN_DEG) != (case == "multi") {
        failures.push(format!(
            "{case}: {deep_deg:.1}° of deep shadow side measured (warns below {DEEP_SHADOW_MIN_DEG}°)"
        ));
    }
    for (k, sphere) in fit.spheres.iter().enumerate() {
        let kappa = 1.0 / sphere.radius_mm;
        let mut line = format!("{case:>6} r = {:>2} mm:", sphere.radius_mm);
        for (name, from, to, bound) in REGIONS {
            let ratio = region_sum(&fit.lut, kappa, from, to) / region_sum(&ideal, kappa, from, to);
            let band = region_band(&fit, k, from, to);
            let off = (ratio - Vec3::ONE).abs().max_element();
            line += &format!(
                "  {name} {:+.1}/{:+.1}/{:+.1} % (band {:.1} %)",
                100.0 * (ratio.x - 1.0),
                100.0 * (ratio.y - 1.0),
                100.0 * (ratio.z - 1.0),
                100.0 * band
            );
            let meets_issue = off <= bound || (name == "shadow" && off <= band);
            // Where a shadow side misses both, the fit must have said why: the room's light.
            let warned = name == "shadow" && room_dominated(&fit, k, from, to);
            line += match (meets_issue, warned) {
                (true, _) => " ok",
                (false, true) => " (over the issue's bound; warned: room light)",
                (false, false) => " (over the issue's bound)",
            };
            if name == "shadow" && !meets_issue && !warned {
                failures.push(format!(
                    "{case} r = {} mm shadow: {:.1} % off, outside the band, and not warned about",
                    sphere.radius_mm,
                    100.0 * off
                ));
            }
            if let Some((limit, or_band)) = held_to(case, sphere.radius_mm, name)
                && off > limit
                && !(or_band && off <= band)
            {
                failures.push(format!(
                    "{case} r = {} mm {name}: {:.1} % off (held to {:.0} %{})",
                    sphere.radius_mm,
                    100.0 * off,
                    100.0 * limit,
                    if or_band { " or the band" } else { "" }
                ));
            }
        }
        println!("{line}");
    }
    failures
}

/// The bound a region is held to today (largest channel), and whether being inside the fit's
/// band also passes; `None` where nothing is held.
/// - lit side: issue 38's 2 % on the single-sphere sets, 3 % in the several-sphere photograph;
/// - terminator: issue 38's 4 % on the single-sphere sets, 5 % in the several-sphere photograph
///   (its lamp 53–62° from the camera: what the view's azimuth model leaves; see the module
///   docs);
/// - shadow side: issue 38's 15 % for the RAW-like and the ideal-sensor sets up to r = 30 mm
///   and the several-sphere photograph's 10 mm sphere; 15 % or the band for JPEG up to 30 mm
///   (its 8-bit codes and compression, which the band counts); the 50 mm spheres (room light
///   the flag leaves) and the several-sphere photograph's others (rendered at few samples) are
///   printed only, and must be warned about where they miss.
fn held_to(case: &str, radius_mm: f32, region: &str) -> Option<(f32, bool)> {
    match region {
        "lit" if case == "multi" => Some((0.03, false)),
        "lit" => Some((0.02, false)),
        "terminator" if case == "multi" => Some((0.05, false)),
        "terminator" => Some((0.04, false)),
        "shadow" if matches!(case, "raw14" | "lamp") && radius_mm <= 30.0 => Some((0.15, false)),
        "shadow" if case == "multi" && radius_mm == 10.0 => Some((0.15, false)),
        "shadow" if case == "jpeg" && radius_mm <= 30.0 => Some((0.15, true)),
        _ => None,
    }
}

#[test]
fn captures_agree_with_the_ideal_photographs() {
    let failures: Vec<String> = ["lamp", "raw14", "jpeg", "multi"]
        .into_iter()
        .flat_map(check)
        .collect();
    assert!(failures.is_empty(), "{failures:#?}");
}
