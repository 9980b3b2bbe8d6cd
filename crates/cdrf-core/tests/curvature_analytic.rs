//! Mean curvature against analytic shapes built here (sphere, torus, ellipsoid, height fields),
//! plus units, signs, smoothing, seams, boundaries and bad input.
//!
//! Error bounds are the measured values (printed; run with `--show-output`) with a margin.

mod common;

use cdrf_core::curvature::{
    CurvatureError, CurvatureOptions, mean_curvature_per_mm, mean_curvature_per_mm_welded,
};
use cdrf_core::mesh::Mesh;
use common::{RelativeError, ellipsoid_mean_curvature, relative_error, torus_mean_curvature};
use glam::Vec3;

fn curvature(mesh: &Mesh) -> Vec<f32> {
    mean_curvature_per_mm(mesh, &CurvatureOptions::default()).expect("valid mesh")
}

fn assert_error_below(what: &str, error: RelativeError, rms: f64, max: f64) {
    println!("{what}: {error}");
    assert!(
        error.rms < rms && error.max < max,
        "{what}: {error}, bounds RMS {} %, max {} %",
        100.0 * rms,
        100.0 * max
    );
}

fn torus_error(major: f32, minor: f32, nu: u32, nv: u32) -> RelativeError {
    let mesh = Mesh::torus(major, minor, nu, nv);
    let truth: Vec<f64> = mesh
        .positions
        .iter()
        .map(|&p| torus_mean_curvature(major.into(), minor.into(), p))
        .collect();
    relative_error(&curvature(&mesh), &truth)
}

#[test]
fn sphere_is_one_over_radius() {
    // Measured: s3 r 1: RMS 0.0153 %, max 0.0304 %; s5 r 25: RMS 0.0017 %, max 0.0065 %.
    for (subdivisions, radius, rms, max) in [(3, 1.0f32, 5e-4, 1e-3), (5, 25.0, 1e-4, 2e-4)] {
        let mesh = Mesh::icosphere(radius, subdivisions);
        let truth = vec![1.0 / f64::from(radius); mesh.positions.len()];
        assert_error_below(
            &format!(
                "icosphere r = {radius} mm, {} vertices",
                mesh.positions.len()
            ),
            relative_error(&curvature(&mesh), &truth),
            rms,
            max,
        );
    }
}

#[test]
fn torus_matches_analytic_and_converges() {
    // Measured: 64 × 32: RMS 0.41 %, max 1.00 %; 256 × 128: RMS 0.026 %, max 0.079 %.
    let coarse = torus_error(3.0, 1.0, 64, 32);
    let fine = torus_error(3.0, 1.0, 256, 128);
    assert_error_below("torus R 3 a 1, 64 x 32", coarse, 6e-3, 1.5e-2);
    assert_error_below("torus R 3 a 1, 256 x 128", fine, 5e-4, 1.5e-3);
    // Second-order convergence: 4× finer, ≥ 10× smaller error (measured 16×).
    assert!(fine.rms < coarse.rms / 10.0, "{fine} vs {coarse}");
}

#[test]
fn ellipsoid_formula_is_one_over_radius_on_a_sphere() {
    let radii = Vec3::splat(2.0);
    for p in [Vec3::X, Vec3::new(1.0, 2.0, -0.5), Vec3::NEG_Z] {
        let h = ellipsoid_mean_curvature(radii, p.normalize() * 2.0);
        assert!((h - 0.5).abs() < 1e-6, "{p}: {h}");
    }
    // At the tip (a, 0, 0) of a 3:2:1 ellipsoid the principal curvatures are a/b², a/c².
    let h = ellipsoid_mean_curvature(Vec3::new(3.0, 2.0, 1.0), Vec3::new(3.0, 0.0, 0.0));
    assert!((h - 0.5 * (3.0 / 4.0 + 3.0)).abs() < 1e-9, "{h}");
}

#[test]
fn ellipsoid_matches_analytic() {
    // Measured: s4: RMS 1.06 %, max 3.58 %; s5: RMS 0.29 %, max 1.01 %.
    let radii = Vec3::new(3.0, 2.0, 1.0);
    for (subdivisions, rms, max) in [(4, 1.5e-2, 5e-2), (5, 4.5e-3, 1.5e-2)] {
        let mesh = Mesh::ellipsoid(radii, subdivisions);
        let truth: Vec<f64> = mesh
            .positions
            .iter()
            .map(|&p| ellipsoid_mean_curvature(radii, p))
            .collect();
        assert_error_below(
            &format!("ellipsoid 3:2:1, {} vertices", mesh.positions.len()),
            relative_error(&curvature(&mesh), &truth),
            rms,
            max,
        );
    }
}

#[test]
fn curvature_is_per_millimetre() {
    // The same torus modelled in centimetres: R = 3 cm = 30 mm, κ in mm⁻¹ is a tenth.
    let mesh = Mesh::torus(3.0, 1.0, 48, 24);
    let per_unit = curvature(&mesh);
    let in_cm = mean_curvature_per_mm(&mesh, &CurvatureOptions::new(10.0)).unwrap();
    for (&u, &cm) in per_unit.iter().zip(&in_cm) {
        assert!((cm - u / 10.0).abs() <= 1e-6 * u.abs(), "{cm} vs {u}/10");
    }
    // …and equal to the same torus modelled in millimetres.
    let mut in_mm = mesh.clone();
    in_mm.positions.iter_mut().for_each(|p| *p *= 10.0);
    let mm = curvature(&in_mm);
    for (&a, &b) in mm.iter().zip(&in_cm) {
        assert!((a - b).abs() <= 1e-4 * b.abs(), "{a} vs {b}");
    }
    // The torus in mm: κ(outer equator) = (R + 2a)/(2a(R + a)) = 50/(2·10·40) mm⁻¹.
    assert!((mm[0] - 0.0625).abs() < 0.0625 * 0.01, "{}", mm[0]);
}

#[test]
fn inside_out_sphere_is_negative() {
    let mut mesh = Mesh::icosphere(2.0, 3);
    mesh.triangles.iter_mut().for_each(|t| t.swap(1, 2));
    let k = curvature(&mesh);
    let truth = vec![-0.5; k.len()];
    assert_error_below(
        "inside-out icosphere r 2",
        relative_error(&k, &truth),
        1e-3,
        2e-3,
    );
}

#[test]
fn torus_saddle_region_is_negative() {
    // R = 1.5, a = 1: H < 0 where cos v < −0.75, the inner saddle region.
    let (major, minor) = (1.5f32, 1.0f32);
    let mesh = Mesh::torus(major, minor, 96, 96);
    let k = curvature(&mesh);
    let mut negative = 0;
    let mut worst = 0.0f64;
    for (&p, &estimate) in mesh.positions.iter().zip(&k) {
        let truth = torus_mean_curvature(major.into(), minor.into(), p);
        worst = worst.max((f64::from(estimate) - truth).abs());
        if truth < -0.02 {
            negative += 1;
            assert!(estimate < 0.0, "{p}: {estimate} vs {truth}");
        }
    }
    // Measured: 2016 such vertices, worst absolute error 0.0022 mm⁻¹ (|H| ≤ 0.7 here).
    println!("torus R 1.5 a 1: {negative} vertices with H < -0.02, worst |error| {worst:.5}");
    assert!(negative > 500, "{negative}");
    assert!(worst < 0.005, "{worst}");
}

/// The height field `z = (α x² + β y²)/2` over [−1, 1]² on an `n × n` grid, normals up (+z).
fn height_field(alpha: f32, beta: f32, n: u32) -> Mesh {
    let mut positions = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let x = -1.0 + 2.0 * i as f32 / (n - 1) as f32;
            let y = -1.0 + 2.0 * j as f32 / (n - 1) as f32;
            positions.push(Vec3::new(x, y, 0.5 * (alpha * x * x + beta * y * y)));
        }
    }
    let mut triangles = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = j * n + i;
            // Alternate the diagonal so the mesh has no preferred direction.
            if (i + j) % 2 == 0 {
                triangles.extend([[a, a + 1, a + n + 1], [a, a + n + 1, a + n]]);
            } else {
                triangles.extend([[a, a + 1, a + n], [a + 1, a + n + 1, a + n]]);
            }
        }
    }
    Mesh::from_triangles(positions, triangles).unwrap().mesh
}

/// Mean curvature of `z = (α x² + β y²)/2` with the upward normal, in this crate's sign
/// convention (surface bending towards the normal is negative).
fn height_field_mean_curvature(alpha: f64, beta: f64, p: Vec3) -> f64 {
    let (x, y) = (f64::from(p.x), f64::from(p.y));
    let (fx, fy) = (alpha * x, beta * y);
    let up = ((1.0 + fy * fy) * alpha + (1.0 + fx * fx) * beta)
        / (2.0 * (1.0 + fx * fx + fy * fy).powf(1.5));
    -up
}

#[test]
fn bowl_and_saddle_signs_with_boundaries() {
    // Bowl (bending towards its upward normal, concave): negative. The saddle α = 1, β = −0.5
    // bends towards the normal on average: negative; its mirror image positive. Boundary
    // vertices (one-sided fits) are not compared, only checked to be finite.
    for (alpha, beta) in [(1.0f32, 1.0f32), (1.0, -0.5), (-1.0, 0.5)] {
        let n = 41;
        let mesh = height_field(alpha, beta, n);
        let k = curvature(&mesh);
        assert!(k.iter().all(|k| k.is_finite()));
        let interior: Vec<usize> = (0..mesh.positions.len())
            .filter(|&i| {
                let (x, y) = ((i as u32) % n, (i as u32) / n);
                x > 1 && y > 1 && x < n - 2 && y < n - 2
            })
            .collect();
        let estimate: Vec<f32> = interior.iter().map(|&i| k[i]).collect();
        let truth: Vec<f64> = interior
            .iter()
            .map(|&i| height_field_mean_curvature(alpha.into(), beta.into(), mesh.positions[i]))
            .collect();
        for (&e, &t) in estimate.iter().zip(&truth) {
            assert_eq!(e < 0.0, t < 0.0, "sign: {e} vs {t}");
        }
        let error = relative_error(&estimate, &truth);
        // Measured (interior): bowl RMS 0.12 %, max 0.32 %; saddles RMS 0.26 %, max 0.70 %.
        assert_error_below(
            &format!("height field α {alpha} β {beta}, interior"),
            error,
            5e-3,
            1.5e-2,
        );
        let centre = (n / 2 * n + n / 2) as usize;
        println!(
            "  centre: {} (analytic {})",
            k[centre],
            -(alpha + beta) / 2.0
        );
    }
}

#[test]
fn smoothing_keeps_constants_and_reduces_noise() {
    let sphere = Mesh::icosphere(1.0, 4);
    let smoothed = mean_curvature_per_mm(
        &sphere,
        &CurvatureOptions::default().with_smoothing_iterations(3),
    )
    .unwrap();
    let truth = vec![1.0; smoothed.len()];
    assert_error_below(
        "icosphere s4, 3 smoothing iterations",
        relative_error(&smoothed, &truth),
        2e-4,
        5e-4,
    );

    // Radial jitter of ±0.5 % (deterministic LCG).
    let mut noisy = sphere.clone();
    let mut state = 0x2545_f491_u32;
    for p in &mut noisy.positions {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        let u = (state >> 8) as f32 / (1u32 << 24) as f32;
        *p *= 1.0 + 0.01 * (u - 0.5);
    }
    let std_dev = |k: &[f32]| {
        let mean = k.iter().map(|&k| f64::from(k)).sum::<f64>() / k.len() as f64;
        (k.iter()
            .map(|&k| (f64::from(k) - mean).powi(2))
            .sum::<f64>()
            / k.len() as f64)
            .sqrt()
    };
    let raw = std_dev(&curvature(&noisy));
    let smooth = std_dev(
        &mean_curvature_per_mm(
            &noisy,
            &CurvatureOptions::default().with_smoothing_iterations(3),
        )
        .unwrap(),
    );
    // Measured: 0.209 raw, 0.047 smoothed.
    println!("noisy icosphere: κ std dev {raw:.4} raw, {smooth:.4} after 3 iterations");
    assert!(smooth < 0.35 * raw, "{smooth} vs {raw}");
}

#[test]
fn seams_are_welded_before_estimating() {
    // Split every corner into its own vertex (a fully faceted render mesh): the estimate must
    // equal the welded torus's, vertex by vertex.
    let torus = Mesh::torus(3.0, 1.0, 32, 16);
    let welded_k = curvature(&torus);
    let mut split = Mesh::default();
    for t in &torus.triangles {
        let base = split.positions.len() as u32;
        for &i in t {
            split.positions.push(torus.positions[i as usize]);
            split.normals.push(torus.normals[i as usize]);
        }
        split.triangles.push([base, base + 1, base + 2]);
    }
    let split_k = curvature(&split);
    for (t, &[a, b, c]) in torus.triangles.iter().zip(&split.triangles) {
        for (&original, copy) in t.iter().zip([a, b, c]) {
            assert_eq!(split_k[copy as usize], welded_k[original as usize]);
        }
    }
    // Without welding every vertex sees one flat face: zero curvature.
    let unwelded =
        mean_curvature_per_mm_welded(&split.positions, &split.triangles, &Default::default())
            .unwrap();
    assert!(unwelded.iter().all(|&k| k == 0.0));
}

#[test]
fn isolated_and_degenerate_input_does_not_panic() {
    let mut positions = Mesh::icosphere(1.0, 1).positions;
    let mut triangles = Mesh::icosphere(1.0, 1).triangles;
    positions.push(Vec3::new(5.0, 5.0, 5.0)); // isolated
    let last = positions.len() as u32 - 1;
    triangles.push([0, 0, 1]); // repeated index
    triangles.push([0, 1, 1]);
    let k = mean_curvature_per_mm_welded(&positions, &triangles, &Default::default()).unwrap();
    assert_eq!(k.len(), positions.len());
    assert_eq!(k[last as usize], 0.0);
    assert!(k.iter().all(|k| k.is_finite()));
    // An empty surface is fine too.
    assert!(
        mean_curvature_per_mm_welded(&[], &[], &Default::default())
            .unwrap()
            .is_empty()
    );
}

#[test]
fn invalid_input_is_an_error() {
    let mesh = Mesh::icosphere(1.0, 1);
    for mm_per_unit in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        let error = mean_curvature_per_mm(&mesh, &CurvatureOptions::new(mm_per_unit)).unwrap_err();
        assert!(
            matches!(error, CurvatureError::InvalidScale { .. }),
            "{error}"
        );
        assert!(error.to_string().contains("mm_per_unit"), "{error}");
    }
    let mut bad = mesh.clone();
    bad.triangles[3] = [0, 1, 99];
    let error = mean_curvature_per_mm(&bad, &Default::default()).unwrap_err();
    assert_eq!(
        error.to_string(),
        "triangle 3 refers to vertex 99, but there are 42 vertices"
    );
    let mut bad = mesh;
    bad.positions[7].y = f32::NAN;
    let error = mean_curvature_per_mm(&bad, &Default::default()).unwrap_err();
    assert!(
        matches!(error, CurvatureError::NonFinitePosition { vertex: 7, .. }),
        "{error}"
    );
}

/// The curvature along a direction on a torus (R = 3, a = 1, axis z), against its principal
/// curvatures: 1/a around the tube, cos v / (R + a cos v) along the ring; and none on a sphere.
#[test]
fn directional_curvature_follows_the_principal_curvatures() {
    use cdrf_core::curvature::{curvature_per_mm, directional_curvature_per_mm};
    let (major, minor) = (3.0f64, 1.0f64);
    let mesh = Mesh::torus(major as f32, minor as f32, 128, 64);
    let curvature = curvature_per_mm(&mesh, &CurvatureOptions::default()).unwrap();
    assert_eq!(curvature.mean_per_mm, self::curvature(&mesh), "the same H");
    let (mut around_error, mut along_error, mut diagonal_error) = (0.0f64, 0.0f64, 0.0f64);
    for (v, &p) in mesh.positions.iter().enumerate() {
        let q = p.as_dvec3();
        let rho = (q.x * q.x + q.y * q.y).sqrt();
        let angle = q.z.atan2(rho - major);
        let ring = glam::DVec3::new(-q.y, q.x, 0.0) / rho;
        let centre = glam::DVec3::new(q.x, q.y, 0.0) * (major / rho);
        let normal = (q - centre).normalize();
        let around = normal.cross(ring);
        let k_ring = angle.cos() / (major + minor * angle.cos());
        let k_around = 1.0 / minor;
        let at = |d: glam::DVec3| {
            f64::from(directional_curvature_per_mm(
                curvature.mean_per_mm[v],
                curvature.anisotropy_per_mm[v],
                normal.as_vec3(),
                d.normalize().as_vec3(),
            ))
        };
        around_error = around_error.max((at(around) - k_around).abs() / k_around);
        along_error = along_error.max((at(ring) - k_ring).abs() / k_around);
        // Halfway between the principal directions: the mean of the two.
        let halfway = 0.5 * (k_ring + k_around);
        diagonal_error = diagonal_error.max((at(ring + around) - halfway).abs() / k_around);
    }
    println!(
        "torus 128 × 64: largest error around the tube {:.3} %, along the ring {:.3} %, \
         diagonal {:.3} % (of 1/a)",
        100.0 * around_error,
        100.0 * along_error,
        100.0 * diagonal_error
    );
    assert!(around_error < 0.01 && along_error < 0.01 && diagonal_error < 0.01);

    let sphere = Mesh::icosphere(2.0, 3);
    let on_sphere = curvature_per_mm(&sphere, &CurvatureOptions::default()).unwrap();
    let largest = on_sphere
        .anisotropy_per_mm
        .iter()
        .fold(0.0f32, |m, a| m.max(a.length()));
    println!("icosphere: largest anisotropy {largest:.2e} of H = 0.5");
    assert!(largest < 2e-3 * 0.5, "{largest}");
}
