//! Curvature filtered over a length (`CurvatureOptions::filter_length_mm`): a sphere keeps its
//! curvature, a coarse random triangulation of an ellipsoid comes out as smooth as a fine regular
//! one and agrees with it, parts of a mesh apart on the surface do not mix however close they
//! are in space, and bad lengths are errors.
//!
//! Bounds are the measured values (printed; run with `--show-output`) with a margin.

mod common;

use cdrf_core::curvature::{
    Curvature, CurvatureError, CurvatureOptions, MAX_FILTER_LENGTH_EDGES, curvature_per_mm,
    mean_curvature_per_mm,
};
use cdrf_core::mesh::Mesh;
use common::irregular_ellipsoid;
use glam::Vec3;

/// Semi-axes of the test ellipsoid, mm: 2000 random points on it give 3.8 mm edges, a coarse
/// scan's.
const RADII: Vec3 = Vec3::new(60.0, 40.0, 20.0);

fn filtered(mesh: &Mesh, length_mm: f32) -> Curvature {
    let options = CurvatureOptions::default().with_filter_length_mm(length_mm);
    curvature_per_mm(mesh, &options).expect("valid mesh and length")
}

/// Each edge once, as (smaller index, larger index).
fn edges(mesh: &Mesh) -> Vec<(usize, usize)> {
    let mut edges: Vec<(usize, usize)> = mesh
        .triangles
        .iter()
        .flat_map(|t| {
            (0..3).map(move |k| {
                let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
                (a.min(b), a.max(b))
            })
        })
        .collect();
    edges.sort_unstable();
    edges.dedup();
    edges
}

/// How much κ jumps from vertex to vertex: the RMS over edges of `|κᵢ − κⱼ| / |pᵢ − pⱼ|`,
/// relative to the mean κ (mm⁻¹). Divided by the edge length, so meshes of different
/// resolution compare: on a smooth field it is the RMS slope, whatever the edges.
fn roughness_per_mm(mesh: &Mesh, values: &[f32]) -> f64 {
    let edges = edges(mesh);
    let mean = values.iter().map(|&v| f64::from(v)).sum::<f64>() / values.len() as f64;
    let sum: f64 = edges
        .iter()
        .map(|&(a, b)| {
            let length = (mesh.positions[a] - mesh.positions[b]).length();
            (f64::from(values[a] - values[b]) / f64::from(length)).powi(2)
        })
        .sum();
    (sum / edges.len() as f64).sqrt() / mean
}

/// The nearest vertex of `mesh` to `p` (brute force).
fn nearest(mesh: &Mesh, p: Vec3) -> usize {
    let mut best = (f32::INFINITY, 0);
    for (i, &q) in mesh.positions.iter().enumerate() {
        let d = (q - p).length_squared();
        if d < best.0 {
            best = (d, i);
        }
    }
    best.1
}

/// RMS and max of `(a[i] − b[map[i]]) / scale(b[map[i]])`.
fn compare_at(a: &[f64], b: &[f64], map: &[usize], scale: impl Fn(f64) -> f64) -> (f64, f64) {
    let d: Vec<f64> = map
        .iter()
        .enumerate()
        .map(|(i, &j)| (a[i] - b[j]) / scale(b[j]))
        .collect();
    let rms = (d.iter().map(|d| d * d).sum::<f64>() / d.len() as f64).sqrt();
    (rms, d.iter().fold(0.0f64, |m, d| m.max(d.abs())))
}

fn to_f64(values: &[f32]) -> Vec<f64> {
    values.iter().map(|&v| f64::from(v)).collect()
}

#[test]
fn a_sphere_keeps_its_curvature_at_any_length() {
    let (radius, mm_per_unit) = (25.0, 1.0);
    let sphere = Mesh::icosphere(radius, 4);
    let raw = mean_curvature_per_mm(&sphere, &CurvatureOptions::new(mm_per_unit)).unwrap();
    let (low, high) = raw
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(l, h), &k| {
            (l.min(k), h.max(k))
        });
    // The area-weighted mean (a third of each triangle to each corner) is what the filter keeps.
    let mut area = vec![0.0f64; sphere.positions.len()];
    for t in &sphere.triangles {
        let p = t.map(|i| sphere.positions[i as usize].as_dvec3());
        let third = (p[1] - p[0]).cross(p[2] - p[0]).length() / 6.0;
        for &i in t {
            area[i as usize] += third;
        }
    }
    let mean = |k: &[f32]| {
        k.iter()
            .zip(&area)
            .map(|(&k, a)| f64::from(k) * a)
            .sum::<f64>()
            / area.iter().sum::<f64>()
    };
    println!(
        "icosphere r = 25 mm, {} vertices: κ in [{low}, {high}] mm⁻¹ unfiltered",
        sphere.positions.len()
    );
    // Up to ~800 edges (1.9 mm): far past the whole sphere, whose every vertex then reads its
    // mean.
    for length_mm in [0.5, 5.0, 50.0, 500.0, 1500.0] {
        let k = filtered(&sphere, length_mm).mean_per_mm;
        let worst = k.iter().fold(0.0f64, |m, &k| {
            m.max((f64::from(k) * f64::from(radius) - 1.0).abs())
        });
        let drift = (mean(&k) - mean(&raw)).abs() / mean(&raw);
        println!("filter {length_mm} mm: largest |κ·r − 1| {worst:.2e}, mean moved {drift:.1e}");
        // A weighted mean of the input: nothing leaves its range (but for f32 rounding).
        let slack = 1e-6 * high;
        assert!(
            k.iter().all(|&k| k >= low - slack && k <= high + slack),
            "{length_mm} mm: a value left [{low}, {high}]"
        );
        assert!(drift < 1e-6, "{length_mm} mm: the mean moved by {drift:e}");
    }
}

/// The case the filter is for: a coarse irregular mesh (the convex hull of 2000 random points,
/// like a scan) against a fine regular one (40 962 vertices) of the same ellipsoid.
#[test]
fn a_coarse_random_mesh_filtered_is_as_smooth_as_a_fine_one_and_agrees_with_it() {
    let length_mm = 5.0;
    let fine = Mesh::ellipsoid(RADII, 6);
    let (fine_raw, fine_filtered) = (filtered(&fine, 0.0), filtered(&fine, length_mm));
    let fine_roughness = roughness_per_mm(&fine, &fine_raw.mean_per_mm);
    let fine_filtered_roughness = roughness_per_mm(&fine, &fine_filtered.mean_per_mm);
    println!(
        "fine: {} vertices, roughness {fine_roughness:.4} mm⁻¹ unfiltered, \
         {fine_filtered_roughness:.4} filtered over {length_mm} mm",
        fine.positions.len()
    );
    // The filter removes noise, not the surface: the fine mesh keeps most of its (real) slope.
    // Measured 0.56.
    assert!(fine_filtered_roughness > 0.4 * fine_roughness);

    // Measured over seeds 1 … 8: roughness unfiltered 0.077 … 0.129, filtered 0.029 … 0.030
    // (0.53 … 0.56 of the fine mesh's unfiltered, 0.96 … 0.99 of its filtered); against the
    // fine mesh's filtered values at the nearest vertex, RMS 1.73 … 1.77 %, max 5.4 … 6.5 %
    // (unfiltered against unfiltered: RMS 4.1 … 5.6 %, max 20 … 154 %); anisotropy length
    // RMS 5.1 … 5.7 % of the mean (unfiltered 12.6 … 19.4 %).
    for seed in [3, 4] {
        let coarse = irregular_ellipsoid(RADII, 2000, seed);
        let (raw, smooth) = (filtered(&coarse, 0.0), filtered(&coarse, length_mm));
        let raw_roughness = roughness_per_mm(&coarse, &raw.mean_per_mm);
        let roughness = roughness_per_mm(&coarse, &smooth.mean_per_mm);
        let map: Vec<usize> = coarse
            .positions
            .iter()
            .map(|&p| nearest(&fine, p))
            .collect();
        let relative = |k: f64| k;
        let (raw_rms, raw_max) = compare_at(
            &to_f64(&raw.mean_per_mm),
            &to_f64(&fine_raw.mean_per_mm),
            &map,
            relative,
        );
        let (rms, max) = compare_at(
            &to_f64(&smooth.mean_per_mm),
            &to_f64(&fine_filtered.mean_per_mm),
            &map,
            relative,
        );
        let lengths = |a: &[Vec3]| a.iter().map(|a| f64::from(a.length())).collect::<Vec<_>>();
        let anisotropy_error = |coarse: &Curvature, fine: &Curvature| {
            let fine = lengths(&fine.anisotropy_per_mm);
            let mean = fine.iter().sum::<f64>() / fine.len() as f64;
            compare_at(&lengths(&coarse.anisotropy_per_mm), &fine, &map, |_| mean).0
        };
        let (raw_anisotropy, anisotropy) = (
            anisotropy_error(&raw, &fine_raw),
            anisotropy_error(&smooth, &fine_filtered),
        );
        println!(
            "seed {seed}: roughness {raw_roughness:.4} → {roughness:.4} mm⁻¹; against the fine \
             mesh at the nearest vertex RMS {:.2} % max {:.1} % → RMS {:.2} % max {:.1} %; \
             anisotropy RMS {:.1} % → {:.1} %",
            100.0 * raw_rms,
            100.0 * raw_max,
            100.0 * rms,
            100.0 * max,
            100.0 * raw_anisotropy,
            100.0 * anisotropy
        );
        assert!(roughness < 0.7 * fine_roughness, "seed {seed}");
        assert!(roughness < 1.15 * fine_filtered_roughness, "seed {seed}");
        assert!(roughness < 0.5 * raw_roughness, "seed {seed}");
        assert!(rms < 0.025 && max < 0.1, "seed {seed}");
        assert!(anisotropy < 0.08, "seed {seed}");
    }
}

/// The filter follows the surface: two bodies 0.5 mm apart in space, a flat ellipsoid and a
/// small sphere on top (κ 0.018 and 0.125 mm⁻¹ where they nearly touch), filtered over 10 mm
/// together come out as each does alone. A Euclidean average over 10 mm would pull the
/// ellipsoid's top toward the sphere's κ.
#[test]
fn parts_apart_on_the_surface_do_not_mix() {
    let length_mm = 10.0;
    let body = irregular_ellipsoid(Vec3::new(30.0, 20.0, 10.0), 1500, 1);
    let sphere_radius = 8.0;
    let mut ball = Mesh::icosphere(sphere_radius, 3);
    for p in &mut ball.positions {
        *p += Vec3::new(0.0, 0.0, 10.0 + 0.5 + sphere_radius);
    }
    let mut both = body.clone();
    let offset = both.positions.len() as u32;
    both.positions.extend(&ball.positions);
    both.normals.extend(&ball.normals);
    both.triangles
        .extend(ball.triangles.iter().map(|t| t.map(|i| i + offset)));

    let together = filtered(&both, length_mm).mean_per_mm;
    let (body_alone, ball_alone) = (
        filtered(&body, length_mm).mean_per_mm,
        filtered(&ball, length_mm).mean_per_mm,
    );
    let body_raw = filtered(&body, 0.0).mean_per_mm;
    let scale = body_alone.iter().map(|&k| f64::from(k)).sum::<f64>() / body_alone.len() as f64;
    let differs = |a: &[f32], b: &[f32]| {
        a.iter()
            .zip(b)
            .fold(0.0f64, |m, (&a, &b)| m.max(f64::from((a - b).abs())))
            / scale
    };
    let (body_mixed, ball_mixed) = (
        differs(&together[..offset as usize], &body_alone),
        differs(&together[offset as usize..], &ball_alone),
    );
    let filtered_change = differs(&body_alone, &body_raw);
    println!(
        "largest change from filtering alone vs together: body {body_mixed:.1e}, ball \
         {ball_mixed:.1e} (of the body's mean κ); the filter itself changes the body by {:.1} %",
        100.0 * filtered_change
    );
    assert!(filtered_change > 0.05, "the body is filtered");
    assert!(body_mixed < 1e-5 && ball_mixed < 1e-5);
    // The body's top (its vertex nearest the ball) stays the body's.
    let top = nearest(&body, Vec3::new(0.0, 0.0, 10.0));
    assert!(together[top] < 0.05, "{}", together[top]);
}

/// The length is in millimetres whatever the model's unit.
#[test]
fn the_length_is_in_millimetres() {
    let in_mm = irregular_ellipsoid(RADII, 2000, 5);
    let mut in_cm = in_mm.clone();
    for p in &mut in_cm.positions {
        *p /= 10.0;
    }
    let options = CurvatureOptions::default().with_filter_length_mm(5.0);
    let a = mean_curvature_per_mm(&in_mm, &options).unwrap();
    let b = mean_curvature_per_mm(
        &in_cm,
        &CurvatureOptions {
            mm_per_unit: 10.0,
            ..options
        },
    )
    .unwrap();
    let worst = a
        .iter()
        .zip(&b)
        .fold(0.0f32, |m, (&a, &b)| m.max((a - b).abs() / a));
    assert!(worst < 1e-4, "mm vs cm: {worst}");
}

#[test]
fn a_bad_filter_length_is_an_error() {
    let sphere = Mesh::icosphere(25.0, 3);
    for length_mm in [-1.0, f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let error = mean_curvature_per_mm(
            &sphere,
            &CurvatureOptions::default().with_filter_length_mm(length_mm),
        )
        .unwrap_err();
        assert!(
            matches!(error, CurvatureError::InvalidFilterLength { .. }),
            "{error}"
        );
        let message = error.to_string();
        assert!(
            message.contains("filter length") && message.contains(&length_mm.to_string()),
            "{message}"
        );
    }
    // The sphere's edges are ~4 mm: 10 m is ~2500 of them.
    let error = curvature_per_mm(
        &sphere,
        &CurvatureOptions::default().with_filter_length_mm(10_000.0),
    )
    .unwrap_err();
    let message = error.to_string();
    println!("{message}");
    assert!(
        matches!(error, CurvatureError::FilterTooLong { .. })
            && message.contains("10000 mm")
            && message.contains("mean edge length")
            && message.contains(&MAX_FILTER_LENGTH_EDGES.to_string())
            && message.contains("mm_per_unit"),
        "{message}"
    );
    // The same length is fine on a model whose unit makes it short.
    let options = CurvatureOptions::new(1000.0).with_filter_length_mm(10_000.0);
    assert!(mean_curvature_per_mm(&sphere, &options).is_ok());
}
