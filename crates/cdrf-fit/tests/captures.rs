//! Real-capture conditions on synthetic photographs with known truth: a lamp at a finite
//! distance, a perspective camera, several spheres and a matte reference in one raw-like
//! photograph against a grey wall, a residual highlight, a mask. The spheres are Lambertian
//! (f(θ) = ρ·cos⁺θ exactly), so every number the fit returns has an exact answer.

use std::path::Path;

use cdrf_fit::dataset::Dataset;
use cdrf_fit::fit::{Fit, FitOptions, fit_dataset};
use glam::Vec3;

const FOV_DEG: f32 = 20.0;
const WIDTH: u32 = 960;
const HEIGHT: u32 = 480;
const LAMP_MM: Vec3 = Vec3::new(-700.0, 300.0, -100.0);
const INTENSITY: f32 = 2.0e5;
const WALL: f32 = 0.01;
const ALBEDO: f32 = 0.6;
const REFERENCE_ALBEDO: f32 = 0.5;
/// Radiance → sensor code above the black level.
const GAIN: f32 = 2.0e5;
const BLACK: u16 = 512;
const WHITE: u16 = 16383;

struct Ball {
    center_mm: Vec3,
    radius_mm: f32,
    albedo: f32,
}

fn balls() -> Vec<Ball> {
    let ball = |x: f32, radius_mm: f32, albedo: f32| Ball {
        center_mm: Vec3::new(x, 10.0, -600.0),
        radius_mm,
        albedo,
    };
    vec![
        ball(-150.0, 10.0, ALBEDO),
        ball(-95.0, 20.0, ALBEDO),
        ball(-20.0, 25.0, REFERENCE_ALBEDO),
        ball(70.0, 30.0, ALBEDO),
    ]
}

/// Radiance seen through image point (x, y): the nearest ball (Lambertian under the lamp, plus
/// `highlight` × a Beckmann lobe of α = 0.1 on the wax stand-ins), else the wall. Also whether a
/// dark bar across the r = 30 ball's lower third hides it there (`occluder`).
fn radiance_at(x: f32, y: f32, highlight: f32, occluder: bool) -> f32 {
    radiance_with_stray(x, y, highlight, occluder, Stray::None)
}

/// Light the room bounces onto the balls: irradiance rising toward +y (a lit ceiling, say).
#[derive(Clone, Copy, PartialEq)]
enum Stray {
    None,
    /// The lamp and the bounce light.
    Added,
    /// The flagged frame: the bounce light alone (the wall is still lit).
    Only,
}

fn radiance_with_stray(x: f32, y: f32, highlight: f32, occluder: bool, stray: Stray) -> f32 {
    let focal = (HEIGHT as f32 / 2.0) / (FOV_DEG.to_radians() / 2.0).tan();
    let ray = Vec3::new(x - WIDTH as f32 / 2.0, HEIGHT as f32 / 2.0 - y, -focal).normalize();
    let mut best: Option<(f32, &Ball)> = None;
    let all = balls();
    for ball in &all {
        let along = ray.dot(ball.center_mm);
        let discriminant =
            along * along - (ball.center_mm.length_squared() - ball.radius_mm * ball.radius_mm);
        if discriminant > 0.0 {
            let t = along - discriminant.sqrt();
            if best.is_none_or(|(b, _)| t < b) {
                best = Some((t, ball));
            }
        }
    }
    let Some((t, ball)) = best else {
        return WALL;
    };
    let hit = ray * t;
    if occluder && ball.radius_mm == 30.0 && hit.y < ball.center_mm.y - 12.0 {
        return 0.002;
    }
    let normal = (hit - ball.center_mm) / ball.radius_mm;
    let bounce = ball.albedo * 0.02 * (1.0 + normal.y) / std::f32::consts::PI;
    match stray {
        Stray::None => {}
        Stray::Added => {
            return radiance_with_stray(x, y, highlight, occluder, Stray::None) + bounce;
        }
        Stray::Only => return bounce,
    }
    let to_lamp = LAMP_MM - hit;
    let irradiance = INTENSITY / to_lamp.length_squared();
    let l = to_lamp.normalize();
    let cos = normal.dot(l).max(0.0);
    let mut value = ball.albedo * irradiance * cos / std::f32::consts::PI;
    if ball.albedo == ALBEDO && cos > 0.0 {
        let v = -ray;
        let h = (l + v).normalize();
        let cos_h = normal.dot(h).max(1e-4);
        let alpha2 = 0.01;
        let tan2 = (1.0 - cos_h * cos_h) / (cos_h * cos_h);
        let d = (-tan2 / alpha2).exp() / (std::f32::consts::PI * alpha2 * cos_h.powi(4));
        let cos_v = normal.dot(v).max(1e-3);
        value += highlight * 0.05 * d / (4.0 * cos_v) * irradiance;
    }
    value
}

/// Writes the photograph as a raw-like 16-bit PNG (codes with a black level; box filter, 3 × 3
/// samples a pixel), the manifest and, for `mask`, the r = 30 ball's mask.
fn write_capture(dir: &Path, highlight: f32, calibrated: bool, mask: bool, centers: bool) {
    write_capture_with(dir, highlight, calibrated, mask, centers, false);
}

/// Writes one frame as raw-like 16-bit codes.
fn write_frame(path: &Path, radiance: impl Fn(f32, f32) -> f32) {
    let n = 3;
    let mut codes = Vec::with_capacity((WIDTH * HEIGHT * 3) as usize);
    for row in 0..HEIGHT {
        for column in 0..WIDTH {
            let mut sum = 0.0;
            for sy in 0..n {
                for sx in 0..n {
                    sum += radiance(
                        column as f32 + (sx as f32 + 0.5) / n as f32,
                        row as f32 + (sy as f32 + 0.5) / n as f32,
                    );
                }
            }
            let code = (f32::from(BLACK) + sum / (n * n) as f32 * GAIN)
                .round()
                .min(f32::from(WHITE)) as u16;
            codes.extend([code; 3]);
        }
    }
    image::ImageBuffer::<image::Rgb<u16>, _>::from_raw(WIDTH, HEIGHT, codes)
        .unwrap()
        .save(path)
        .unwrap();
}

fn write_capture_with(
    dir: &Path,
    highlight: f32,
    calibrated: bool,
    mask: bool,
    centers: bool,
    stray: bool,
) {
    let n = 3;
    let mut codes = Vec::with_capacity((WIDTH * HEIGHT * 3) as usize);
    let mut mask_pixels = Vec::with_capacity((WIDTH * HEIGHT) as usize);
    for row in 0..HEIGHT {
        for column in 0..WIDTH {
            let mut sum = 0.0;
            let mut hidden = false;
            for sy in 0..n {
                for sx in 0..n {
                    let x = column as f32 + (sx as f32 + 0.5) / n as f32;
                    let y = row as f32 + (sy as f32 + 0.5) / n as f32;
                    let mode = if stray { Stray::Added } else { Stray::None };
                    sum += radiance_with_stray(x, y, highlight, mask, mode);
                    hidden |= radiance_at(x, y, 0.0, true) != radiance_at(x, y, 0.0, false);
                }
            }
            let code = (f32::from(BLACK) + sum / (n * n) as f32 * GAIN)
                .round()
                .min(f32::from(WHITE)) as u16;
            codes.extend([code; 3]);
            mask_pixels.push(if hidden { 0_u8 } else { 255 });
        }
    }
    image::ImageBuffer::<image::Rgb<u16>, _>::from_raw(WIDTH, HEIGHT, codes)
        .unwrap()
        .save(dir.join("row.png"))
        .unwrap();
    image::GrayImage::from_raw(WIDTH, HEIGHT, mask_pixels)
        .unwrap()
        .save(dir.join("mask.png"))
        .unwrap();
    let mut levels = format!("black_level = {BLACK}\nwhite_level = {WHITE}\n");
    if stray {
        write_frame(&dir.join("row_flag.png"), |x, y| {
            radiance_with_stray(x, y, 0.0, mask, Stray::Only)
        });
        levels += "ambient_image = \"row_flag.png\"\n";
    }
    let mut manifest = format!(
        "[camera]\nprojection = \"perspective\"\nvertical_fov_deg = {FOV_DEG}\n\
         [light]\nposition_mm = [{}, {}, {}]\n",
        LAMP_MM.x, LAMP_MM.y, LAMP_MM.z
    );
    if calibrated {
        manifest += &format!(
            "[calibration]\nimage = \"row.png\"\nradius_mm = 25\nalbedo = [{a}, {a}, {a}]\n{levels}",
            a = REFERENCE_ALBEDO
        );
    }
    for radius in [10, 20, 30] {
        manifest += &format!("[[sphere]]\nimage = \"row.png\"\nradius_mm = {radius}\n{levels}");
        if centers {
            let ball = balls()
                .into_iter()
                .find(|b| b.radius_mm == radius as f32)
                .unwrap();
            let focal = (HEIGHT as f32 / 2.0) / (FOV_DEG.to_radians() / 2.0).tan();
            let c = ball.center_mm;
            let column = WIDTH as f32 / 2.0 + focal * c.x / -c.z;
            let row = HEIGHT as f32 / 2.0 - focal * c.y / -c.z;
            manifest += &format!("center_px = [{column}, {row}]\n");
        }
        if mask && radius == 30 {
            manifest += "mask = \"mask.png\"\n";
        }
    }
    std::fs::write(dir.join("cdrf-dataset.toml"), manifest).unwrap();
}

fn try_fit(
    highlight: f32,
    calibrated: bool,
    mask: bool,
    centers: bool,
) -> Result<Fit, cdrf_fit::fit::FitError> {
    let dir = tempfile::tempdir().unwrap();
    write_capture(dir.path(), highlight, calibrated, mask, centers);
    let dataset = Dataset::load(dir.path()).unwrap_or_else(|e| panic!("{e}"));
    let options = FitOptions {
        min_samples: 500,
        ..FitOptions::default()
    };
    fit_dataset(&dataset, &options, |_| {})
}

fn fit(highlight: f32, calibrated: bool, mask: bool) -> Fit {
    try_fit(highlight, calibrated, mask, false).unwrap_or_else(|e| panic!("{e}"))
}

/// Largest relative error of each sphere's curve against ρ·cos θ over θ = 10…75°.
fn worst_lit_error(fit: &Fit) -> Vec<f32> {
    let count = fit.table_curves[0].len();
    (0..fit.table_curves.len())
        .map(|k| {
            (0..count)
                .map(|i| {
                    (
                        i as f32 / (count - 1) as f32 * 180.0,
                        fit.table_curves[k][i],
                    )
                })
                .filter(|(theta, _)| (10.0..=75.0).contains(theta))
                .map(|(theta, value)| {
                    let truth = ALBEDO * theta.to_radians().cos();
                    ((value.x - truth) / truth).abs()
                })
                .fold(0.0, f32::max)
        })
        .collect()
}

#[test]
fn a_row_of_spheres_under_a_lamp_calibrated_by_a_matte_sphere() {
    let fit = fit(0.0, true, false);
    // Each sphere found in the shared photograph and placed in mm.
    for (report, ball) in fit
        .spheres
        .iter()
        .zip(balls().iter().filter(|b| b.albedo == ALBEDO))
    {
        let center = Vec3::from_array(report.center_mm.expect("perspective"));
        let off = (center - ball.center_mm).length();
        println!("r = {}: centre off by {off:.3} mm", ball.radius_mm);
        assert!(
            off < 0.01 * ball.center_mm.length(),
            "r = {}: {off} mm",
            ball.radius_mm
        );
        assert_eq!(report.dropped.highlight, 0, "no highlight in this photo");
    }
    // The lamp's strength in the file's units, measured by the matte sphere.
    let light = fit.light.as_ref().expect("a data set fit");
    assert_eq!(light.strength_from, "calibrated");
    let truth = INTENSITY * GAIN / f32::from(WHITE - BLACK);
    let measured = light.strength[0];
    println!("intensity {measured:.4e}, truth {truth:.4e}");
    assert!(
        (measured / truth - 1.0).abs() < 0.01,
        "{measured} vs {truth}"
    );
    // The curves are the albedo's cosine: direction and 1/d² per pixel are right.
    let worst = worst_lit_error(&fit);
    println!("worst lit-side error per sphere: {worst:?}");
    assert!(worst.iter().all(|w| *w < 0.02), "{worst:?}");
}

#[test]
fn without_a_reference_the_table_is_relative_and_says_so() {
    // The matte sphere is still in the photograph but not named: sizes alone cannot say which
    // circle is which entry, so the fit asks for centres.
    let error = try_fit(0.0, false, false, false).expect_err("ambiguous");
    assert!(error.to_string().contains("center_px"), "{error}");
    let fit = try_fit(0.0, false, false, true).unwrap_or_else(|e| panic!("{e}"));
    let light = fit.light.as_ref().expect("a data set fit");
    assert_eq!(light.strength_from, "relative");
    // Relative to the irradiance at the first sphere's centre: the shape is still exact.
    let first = balls()[0].center_mm;
    let scale = INTENSITY * GAIN / f32::from(WHITE - BLACK) / (LAMP_MM - first).length_squared();
    let theta = 1.0_f32; // radians
    let count = fit.table_curves[1].len();
    let i = (theta.to_degrees() / 180.0 * (count - 1) as f32).round() as usize;
    let value = fit.table_curves[1][i].x;
    let truth = ALBEDO * scale * (i as f32 / (count - 1) as f32 * std::f32::consts::PI).cos();
    assert!((value / truth - 1.0).abs() < 0.02, "{value} vs {truth}");
}

#[test]
fn a_residual_highlight_is_left_out_not_averaged_in() {
    let fit = fit(1.0, true, false);
    for report in &fit.spheres {
        println!(
            "{} px of highlight left out (r = {})",
            report.dropped.highlight, report.radius_mm
        );
        assert!(report.dropped.highlight > 0, "r = {}", report.radius_mm);
    }
    let worst = worst_lit_error(&fit);
    println!("worst lit-side error per sphere with a highlight: {worst:?}");
    assert!(worst.iter().all(|w| *w < 0.02), "{worst:?}");
}

#[test]
fn a_mask_keeps_an_occluder_out_of_the_table() {
    let fit = fit(0.0, true, true);
    let big = &fit.spheres[2];
    assert_eq!(big.radius_mm, 30.0);
    assert!(big.dropped.masked > 1000, "{:?}", big.dropped);
    let worst = worst_lit_error(&fit);
    assert!(worst.iter().all(|w| *w < 0.02), "{worst:?}");

    // Without it the dark bar inside the disk is averaged into the r = 30 curve.
    let dir = tempfile::tempdir().unwrap();
    write_capture(dir.path(), 0.0, true, true, false);
    let manifest = dir.path().join("cdrf-dataset.toml");
    let text = std::fs::read_to_string(&manifest).unwrap();
    std::fs::write(&manifest, text.replace("mask = \"mask.png\"\n", "")).unwrap();
    let dataset = Dataset::load(dir.path()).unwrap_or_else(|e| panic!("{e}"));
    let options = FitOptions {
        min_samples: 500,
        ..FitOptions::default()
    };
    let unmasked = fit_dataset(&dataset, &options, |_| {}).unwrap_or_else(|e| panic!("{e}"));
    let worst = worst_lit_error(&unmasked);
    println!("without the mask: {worst:?}");
    assert!(worst[2] > 0.1, "{worst:?}");
}

/// Mean of each sphere's curve over θ = 100…150° (the truth is 0: a Lambertian shadow side).
fn shadow_mean(fit: &Fit) -> Vec<f32> {
    let count = fit.table_curves[0].len();
    (0..fit.table_curves.len())
        .map(|k| {
            let values: Vec<f32> = (0..count)
                .filter(|&i| (100.0..=150.0).contains(&(i as f32 / (count - 1) as f32 * 180.0)))
                .map(|i| fit.table_curves[k][i].x)
                .collect();
            values.iter().sum::<f32>() / values.len() as f32
        })
        .collect()
}

#[test]
fn a_flagged_frame_removes_the_rooms_bounce_light() {
    let run = |flagged: bool| {
        let dir = tempfile::tempdir().unwrap();
        write_capture_with(dir.path(), 0.0, true, false, false, true);
        if !flagged {
            let manifest = dir.path().join("cdrf-dataset.toml");
            let text = std::fs::read_to_string(&manifest).unwrap();
            std::fs::write(
                &manifest,
                text.replace("ambient_image = \"row_flag.png\"\n", ""),
            )
            .unwrap();
        }
        let dataset = Dataset::load(dir.path()).unwrap_or_else(|e| panic!("{e}"));
        let options = FitOptions {
            min_samples: 500,
            ..FitOptions::default()
        };
        fit_dataset(&dataset, &options, |_| {}).unwrap_or_else(|e| panic!("{e}"))
    };
    let with = run(true);
    let without = run(false);
    let (shadow_with, shadow_without) = (shadow_mean(&with), shadow_mean(&without));
    println!("shadow side with the flagged frame {shadow_with:?}, without {shadow_without:?}");
    // The bounce light is ~0.6·0.02·(1 + n_y)/π·π/E ≈ 0.01–0.04 of π·L/E here.
    assert!(
        shadow_without.iter().all(|v| *v > 0.01),
        "{shadow_without:?}"
    );
    assert!(
        shadow_with.iter().all(|v| v.abs() < 0.002),
        "{shadow_with:?}"
    );
    let worst = worst_lit_error(&with);
    assert!(worst.iter().all(|w| *w < 0.02), "{worst:?}");
}
