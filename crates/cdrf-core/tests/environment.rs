//! Environment light through spherical harmonics against analytic truth and against brute-force
//! integration of the CDRF over the map's texels.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use cdrf_core::environment::{
    Environment, EnvironmentDesc, EnvironmentError, EquirectMap, RECOMMENDED_SH_ORDER, ZonalTable,
    lambert_zonal_coefficient, radiance_brute_force, radiance_sh, zonal_coefficients,
};
use cdrf_core::gaussian::GaussianCdrf;
use cdrf_core::glam::{Mat3, Vec3};
use cdrf_core::lut::Lambert;
use cdrf_core::{Cdrf, CdrfLut, CurvatureAxis, RgbaImage, read_lut};

fn measured_lut() -> CdrfLut {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/wax-fit/measured.exr");
    read_lut(&path).unwrap_or_else(|error| panic!("the bundled fit {}: {error}", path.display()))
}

/// Kubo's Gaussian CDRF as fitted to the wax spheres (`data/wax-fit/gaussian.toml`).
fn wax_gaussian() -> GaussianCdrf {
    GaussianCdrf::with_scale(
        [5.393_327_7, 5.129_224_3, 4.935_351],
        [0.851_312_94, 0.763_541_8, 0.666_886_15],
    )
    .unwrap()
}

/// A small table built here: Lambert-like at the flat row, glowing on the shadow side at the
/// curved one (the shape a measured wax table has), 91 columns.
fn small_lut() -> CdrfLut {
    let axis = CurvatureAxis::from_radii_mm(50.0, 10.0, 3);
    let columns = 91;
    let mut values = Vec::new();
    for row in 0..axis.count {
        let glow = 0.15 * row as f32;
        for column in 0..columns {
            let theta = column as f32 * std::f32::consts::PI / (columns - 1) as f32;
            let base = theta.cos().max(0.0) * (0.9 - 0.2 * glow) + glow * (0.5 + 0.5 * theta.cos());
            values.push(Vec3::new(base, 0.9 * base, 0.8 * base));
        }
    }
    CdrfLut::new(axis, columns, values).unwrap()
}

/// `count` unit normals spread evenly over the sphere (Fibonacci lattice).
fn normals(count: usize) -> Vec<Vec3> {
    let golden = PI * (3.0 - 5f64.sqrt());
    (0..count)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f64 + 0.5) / count as f64;
            let r = (1.0 - y * y).sqrt();
            let phi = golden * i as f64;
            Vec3::new((r * phi.cos()) as f32, y as f32, (r * phi.sin()) as f32)
        })
        .collect()
}

/// `2 ∫₀^π f(κ, θ) sin θ dθ` by composite Simpson on 20 000 intervals, in f64: what a uniform
/// sky of radiance 1 gives.
fn uniform_sky_truth(cdrf: &impl Cdrf, curvature_per_mm: f32) -> [f64; 3] {
    let n = 20_000;
    let h = PI / n as f64;
    let mut sum = [0.0f64; 3];
    for i in 0..=n {
        let theta = i as f64 * h;
        let w = if i == 0 || i == n {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        };
        let f = cdrf.reflectance(curvature_per_mm, theta as f32);
        for c in 0..3 {
            sum[c] += w * f64::from(f[c]) * theta.sin();
        }
    }
    sum.map(|s| 2.0 * s * h / 3.0)
}

fn assert_relative(value: [f32; 3], truth: [f64; 3], eps: f64, what: &str) {
    for c in 0..3 {
        let error = (f64::from(value[c]) - truth[c]).abs() / truth[c].abs().max(1e-12);
        assert!(
            error <= eps,
            "{what}, channel {c}: {} vs {} (relative error {error:.3e}, eps {eps:.1e})",
            value[c],
            truth[c]
        );
    }
}

#[test]
fn lambert_zonal_coefficients_match_the_closed_form() {
    let expected = [1.0, 2.0 / 3.0, 0.25, 0.0, -1.0 / 24.0];
    for (l, &e) in expected.iter().enumerate() {
        assert!((lambert_zonal_coefficient(l) - e).abs() < 1e-15, "l = {l}");
    }
    let albedo = [0.8, 0.5, 0.25];
    let numeric = zonal_coefficients(&Lambert { albedo }, 0.03, 8);
    let analytic = ZonalTable::lambert(albedo, 8);
    for l in 0..=8 {
        for c in 0..3 {
            let (a, b) = (numeric[l][c], analytic.row(0)[l][c]);
            assert!((a - b).abs() < 2e-7, "l = {l}, channel {c}: {a} vs {b}");
        }
    }
}

#[test]
fn lambert_under_a_uniform_sky_is_albedo_times_radiance() {
    let albedo = [0.8, 0.6, 0.3];
    let sky = [1.5, 0.7, 2.0];
    let truth: [f64; 3] = std::array::from_fn(|c| f64::from(albedo[c]) * f64::from(sky[c]));
    let lambert = Lambert { albedo };
    for (intensity, rotate_deg) in [(1.0, 0.0), (1.0, 73.0)] {
        let environment = Environment::load(
            &EnvironmentDesc::uniform(sky)
                .with_intensity(intensity)
                .with_rotation_deg(rotate_deg),
        )
        .unwrap();
        for order in 0..=4 {
            let sh = environment.project_sh(order);
            let analytic = ZonalTable::lambert(albedo, order);
            let numeric = zonal_coefficients(&lambert, 0.0, order);
            for n in normals(64) {
                let what = format!("order {order}, normal {n}");
                assert_relative(radiance_sh(&sh, analytic.row(0), n), truth, 3e-7, &what);
                assert_relative(radiance_sh(&sh, &numeric, n), truth, 1e-6, &what);
            }
        }
        for n in normals(64) {
            let brute = radiance_brute_force(&lambert, 0.0, n, &environment);
            assert_relative(brute, truth, 1e-6, &format!("brute force, normal {n}"));
        }
    }
}

#[test]
fn cdrf_under_a_uniform_sky_matches_integration_of_the_table() {
    let sky = [0.9, 1.1, 1.3];
    let environment = Environment::uniform(sky).unwrap();
    let sh = environment.project_sh(2);
    let check = |name: &str, cdrf: &dyn Fn(f32, f32) -> [f32; 3], zonal: &[[f32; 3]], kappa| {
        struct F<'a>(&'a dyn Fn(f32, f32) -> [f32; 3]);
        impl Cdrf for F<'_> {
            fn reflectance(&self, k: f32, t: f32) -> [f32; 3] {
                (self.0)(k, t)
            }
        }
        let integral = uniform_sky_truth(&F(cdrf), kappa);
        let truth: [f64; 3] = std::array::from_fn(|c| integral[c] * f64::from(sky[c]));
        for n in normals(16) {
            let what = format!("{name}, κ = {kappa} mm⁻¹, normal {n}");
            assert_relative(
                radiance_sh(&sh, zonal, n),
                truth,
                1e-5,
                &format!("SH: {what}"),
            );
        }
        truth
    };
    for lut in [small_lut(), measured_lut()] {
        let zonal = ZonalTable::from_lut(&lut, 2);
        for row in 0..lut.curvature_axis().count {
            let kappa = zonal.curvatures_per_mm[row];
            let truth = check(
                "table",
                &|k, t| lut.reflectance(k, t),
                zonal.row(row),
                kappa,
            );
            let brute = radiance_brute_force(&lut, kappa, Vec3::Y, &environment);
            assert_relative(
                brute,
                truth,
                1e-4,
                &format!("brute force, table, κ = {kappa}"),
            );
        }
    }
    let gaussian = wax_gaussian();
    let axis = CurvatureAxis::from_radii_mm(50.0, 5.0, 4);
    let zonal = ZonalTable::tabulate(&gaussian, axis, 2);
    for row in 0..axis.count {
        let kappa = zonal.curvatures_per_mm[row];
        let truth = check(
            "Gaussian",
            &|k, t| gaussian.reflectance(k, t),
            zonal.row(row),
            kappa,
        );
        let brute = radiance_brute_force(&gaussian, kappa, Vec3::X, &environment);
        assert_relative(
            brute,
            truth,
            1e-5,
            &format!("brute force, Gaussian, κ = {kappa}"),
        );
    }
}

#[test]
fn zonal_tables_interpolate_like_the_table_and_agree_across_builders() {
    let lut = measured_lut();
    let order = 4;
    let exact = ZonalTable::from_lut(&lut, order);
    let generic = ZonalTable::tabulate(&lut, lut.curvature_axis(), order);
    let axis = lut.curvature_axis();
    let scale = exact.row(0)[0][0];
    for row in 0..axis.count {
        for l in 0..=order {
            for c in 0..3 {
                let (a, b) = (exact.row(row)[l][c], generic.row(row)[l][c]);
                assert!(
                    (a - b).abs() < 1e-4 * scale,
                    "row {row}, l = {l}: {a} vs {b}"
                );
            }
        }
    }
    // Between rows and past the ends, as the bilinear table.
    let (first, last) = (axis.min_per_mm, axis.max_per_mm);
    for kappa in [
        0.0,
        first,
        0.3 * first + 0.7 * last,
        0.5 * (first + last),
        last,
        1.0,
    ] {
        let sampled = exact.sample(kappa);
        let direct = zonal_coefficients(&lut, kappa, order);
        for l in 0..=order {
            for c in 0..3 {
                let (a, b) = (sampled[l][c], direct[l][c]);
                assert!(
                    (a - b).abs() < 1e-4 * scale,
                    "κ = {kappa}, l = {l}: {a} vs {b}"
                );
            }
        }
    }
}

/// The sky of the accuracy test: a vertical gradient (blue above, dim warm ground) and a sun
/// disc of 4° radius at 35° elevation toward (+x, −z), 300× brighter than the zenith.
fn sun_and_sky(direction: Vec3) -> [f32; 3] {
    let sun = Vec3::new(1.0, 35_f32.to_radians().tan() * 2f32.sqrt(), -1.0).normalize();
    if direction.dot(sun) > 4_f32.to_radians().cos() {
        return [300.0, 285.0, 255.0];
    }
    if direction.y >= 0.0 {
        let t = 0.3 + 0.7 * direction.y;
        [0.5 * t, 0.7 * t, 1.0 * t]
    } else {
        [0.08, 0.07, 0.06]
    }
}

/// Writes an equirectangular `width × height` EXR of `radiance(direction)` (the module's
/// convention, written out here independently).
fn write_map(path: &Path, width: u32, height: u32, radiance: impl Fn(Vec3) -> [f32; 3]) {
    let mut image = RgbaImage::new(width, height);
    for row in 0..height {
        for column in 0..width {
            let u = (f64::from(column) + 0.5) / f64::from(width);
            let v = (f64::from(row) + 0.5) / f64::from(height);
            let (sin_v, cos_v) = (PI * v).sin_cos();
            let (sin_u, cos_u) = (2.0 * PI * u).sin_cos();
            let d = Vec3::new(
                (sin_v * sin_u) as f32,
                cos_v as f32,
                (-sin_v * cos_u) as f32,
            );
            let [r, g, b] = radiance(d);
            image.pixels[(row * width + column) as usize] = [r, g, b, 1.0];
        }
    }
    image.write_exr(path).unwrap();
}

/// Errors of SH against brute force over a set of normals: mean and max of the relative error
/// (largest over RGB) per normal, and the largest absolute error as a fraction of the brightest
/// normal's radiance (per channel).
#[derive(Clone, Copy, Debug)]
struct Errors {
    mean: f64,
    max: f64,
    of_peak: f64,
}

fn errors(sh: &[[f32; 3]], brute: &[[f32; 3]]) -> Errors {
    let per_normal: Vec<f64> = sh
        .iter()
        .zip(brute)
        .map(|(s, b)| {
            (0..3)
                .map(|c| (f64::from(s[c]) - f64::from(b[c])).abs() / f64::from(b[c]))
                .fold(0.0, f64::max)
        })
        .collect();
    let of_peak = (0..3)
        .map(|c| {
            let peak = brute.iter().map(|b| f64::from(b[c])).fold(0.0, f64::max);
            let worst = sh
                .iter()
                .zip(brute)
                .map(|(s, b)| (f64::from(s[c]) - f64::from(b[c])).abs())
                .fold(0.0, f64::max);
            worst / peak
        })
        .fold(0.0, f64::max);
    Errors {
        mean: per_normal.iter().sum::<f64>() / per_normal.len() as f64,
        max: per_normal.iter().copied().fold(0.0, f64::max),
        of_peak,
    }
}

const ORDERS: [usize; 4] = [1, 2, 3, 4];

/// SH (orders 1–4) against brute force on a 256 × 128 map of `radiance` over 96 normals, for
/// Lambert, the wax Gaussian at r = 50 … 5 mm and the bundled measured table at r = 50, 35,
/// 15 mm; prints the table and returns it.
fn measure_map(title: &str, radiance: impl Fn(Vec3) -> [f32; 3]) -> Vec<(String, Vec<Errors>)> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sky.exr");
    write_map(&path, 256, 128, radiance);
    let environment = Environment::load(&EnvironmentDesc::map(&path)).unwrap();
    let sh: Vec<_> = ORDERS.iter().map(|&o| environment.project_sh(o)).collect();
    let normals = normals(96);

    let gaussian = wax_gaussian();
    let lut = measured_lut();
    let lambert = Lambert { albedo: [1.0; 3] };
    let mut rows: Vec<(String, Vec<Errors>)> = Vec::new();
    let mut measure = |name: String, cdrf: &dyn Fn(Vec3) -> [f32; 3], zonal: &[[f32; 3]]| {
        let brute: Vec<[f32; 3]> = normals.iter().map(|&n| cdrf(n)).collect();
        let per_order = ORDERS
            .iter()
            .zip(&sh)
            .map(|(&order, sh)| {
                let ours: Vec<_> = normals
                    .iter()
                    .map(|&n| radiance_sh(sh, &zonal[..=order], n))
                    .collect();
                errors(&ours, &brute)
            })
            .collect();
        rows.push((name, per_order));
    };
    measure(
        "Lambert".into(),
        &|n| radiance_brute_force(&lambert, 0.0, n, &environment),
        ZonalTable::lambert([1.0; 3], 4).row(0),
    );
    for radius_mm in [50.0f32, 35.0, 25.0, 15.0, 10.0, 5.0] {
        let kappa = 1.0 / radius_mm;
        measure(
            format!("Gaussian r = {radius_mm} mm"),
            &|n| radiance_brute_force(&gaussian, kappa, n, &environment),
            &zonal_coefficients(&gaussian, kappa, 4),
        );
    }
    let zonal = ZonalTable::from_lut(&lut, 4);
    for radius_mm in [50.0f32, 35.0, 15.0] {
        let kappa = 1.0 / radius_mm;
        measure(
            format!("measured r = {radius_mm} mm"),
            &|n| radiance_brute_force(&lut, kappa, n, &environment),
            &zonal.sample(kappa),
        );
    }

    println!(
        "SH against brute force, {title}, 256 × 128 map, 96 normals: relative error per normal \
         mean / max, and max error / brightest normal"
    );
    println!(
        "{:<20} | {:^25} | {:^25} | {:^25} | {:^25}",
        "model", "order 1", "order 2", "order 3", "order 4"
    );
    for (name, per_order) in &rows {
        let cells: Vec<String> = per_order
            .iter()
            .map(|e| {
                format!(
                    "{:5.2}% /{:6.2}% /{:5.2}%",
                    100.0 * e.mean,
                    100.0 * e.max,
                    100.0 * e.of_peak
                )
            })
            .collect();
        println!("{name:<20} | {}", cells.join(" | "));
    }
    rows
}

fn at(rows: &[(String, Vec<Errors>)], name: &str, order: usize) -> Errors {
    let index = ORDERS.iter().position(|&o| o == order).unwrap();
    rows.iter().find(|(n, _)| n == name).unwrap().1[index]
}

/// A sky without a sun: the gradient of [`sun_and_sky`].
fn sky_only(direction: Vec3) -> [f32; 3] {
    if direction.y >= 0.0 {
        let t = 0.3 + 0.7 * direction.y;
        [0.5 * t, 0.7 * t, 1.0 * t]
    } else {
        [0.08, 0.07, 0.06]
    }
}

/// Order 4 beats order 2 for every model (order 3 adds nothing to the even kernels).
fn assert_order_4_beats_order_2(rows: &[(String, Vec<Errors>)]) {
    for (name, _) in rows {
        let (e2, e4) = (at(rows, name, 2), at(rows, name, 4));
        assert!(
            e4.mean <= e2.mean + 1e-4 && e4.of_peak <= e2.of_peak + 1e-4,
            "{name}: order 4 {e4:?} vs order 2 {e2:?}"
        );
    }
}

#[test]
fn sh_matches_brute_force_on_a_sky_gradient() {
    let rows = measure_map("sky gradient", sky_only);
    assert_order_4_beats_order_2(&rows);
    // Measured: order 4 at most 0.07 % mean, 0.99 % max, 0.17 % of the peak; order 2 at most
    // 0.74 % mean, 4.98 % max, 1.33 % of the peak.
    for (name, _) in &rows {
        let e = at(&rows, name, RECOMMENDED_SH_ORDER);
        assert!(
            e.mean < 0.002 && e.max < 0.015 && e.of_peak < 0.003,
            "{name}, order {RECOMMENDED_SH_ORDER}: {e:?}"
        );
        let e = at(&rows, name, 2);
        assert!(
            e.mean < 0.01 && e.max < 0.06 && e.of_peak < 0.02,
            "{name}, order 2: {e:?}"
        );
    }
}

#[test]
fn sh_matches_brute_force_on_a_sun_and_sky_map() {
    let rows = measure_map("sun (4°, 300×) and sky", sun_and_sky);
    assert_order_4_beats_order_2(&rows);
    // Measured: order 4 at most 8.5 % mean, 43.6 % max (the dark side, lit by the sky alone,
    // against the sun's ringing), 3.65 % of the peak; the smooth kernels of small spheres far
    // less (Gaussian r = 10 mm: 0.03 % / 0.19 %).
    for (name, _) in &rows {
        let e = at(&rows, name, RECOMMENDED_SH_ORDER);
        assert!(
            e.mean < 0.10 && e.max < 0.50 && e.of_peak < 0.045,
            "{name}, order {RECOMMENDED_SH_ORDER}: {e:?}"
        );
    }
    let e = at(&rows, "Gaussian r = 10 mm", RECOMMENDED_SH_ORDER);
    assert!(e.mean < 0.001 && e.max < 0.005, "Gaussian r = 10 mm: {e:?}");
}

#[test]
fn uniform_map_projects_like_the_analytic_sky() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("grey.exr");
    write_map(&path, 64, 32, |_| [0.5, 1.0, 2.0]);
    let from_map = Environment::load(&EnvironmentDesc::map(&path).with_rotation_deg(20.0))
        .unwrap()
        .project_sh(4);
    let analytic = Environment::uniform([0.5, 1.0, 2.0]).unwrap().project_sh(4);
    for (i, (a, b)) in from_map
        .coefficients
        .iter()
        .zip(&analytic.coefficients)
        .enumerate()
    {
        for c in 0..3 {
            // Texel centres integrate Y_20 with an O(texel²) error (the same in the brute force).
            assert!(
                (a[c] - b[c]).abs() < 1e-2,
                "L[{i}][{c}]: {} vs {}",
                a[c],
                b[c]
            );
        }
    }
    assert!((from_map.coefficients[0][1] - (4.0 * std::f32::consts::PI).sqrt()).abs() < 1e-5);
}

#[test]
fn rotation_and_intensity_act_as_documented() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sky.exr");
    write_map(&path, 128, 64, sun_and_sky);
    let gaussian = wax_gaussian();
    let kappa = 1.0 / 15.0;
    let zonal = zonal_coefficients(&gaussian, kappa, 3);
    let plain = Environment::load(&EnvironmentDesc::map(&path)).unwrap();
    let plain_sh = plain.project_sh(3);
    for rotate_deg in [90.0f32, 30.0] {
        let turned = Environment::load(
            &EnvironmentDesc::map(&path)
                .with_rotation_deg(rotate_deg)
                .with_intensity(2.5),
        )
        .unwrap();
        let turned_sh = turned.project_sh(3);
        let back = Mat3::from_rotation_y(-rotate_deg.to_radians());
        for n in normals(24) {
            let expected: [f64; 3] =
                radiance_sh(&plain_sh, &zonal, back * n).map(|v| 2.5 * f64::from(v));
            let what = format!("SH, rotate {rotate_deg}°, normal {n}");
            assert_relative(radiance_sh(&turned_sh, &zonal, n), expected, 1e-4, &what);
            let expected = radiance_brute_force(&gaussian, kappa, back * n, &plain)
                .map(|v| 2.5 * f64::from(v));
            let what = format!("brute force, rotate {rotate_deg}°, normal {n}");
            let brute = radiance_brute_force(&gaussian, kappa, n, &turned);
            assert_relative(brute, expected, 1e-4, &what);
        }
    }
    // The sun is toward (+x, −z); turned by +90° about +y (+z toward +x) it is toward (−x, −z).
    let sun = Vec3::new(1.0, 35_f32.to_radians().tan() * 2f32.sqrt(), -1.0).normalize();
    let turned = Environment::load(&EnvironmentDesc::map(&path).with_rotation_deg(90.0)).unwrap();
    let moved = Vec3::new(-sun.x, sun.y, sun.z);
    assert_eq!(plain.radiance(sun)[0], 300.0);
    assert_eq!(turned.radiance(moved)[0], 300.0);
    assert!(turned.radiance(sun)[0] < 1.0);
    // And a surface facing the moved sun is the brighter one.
    let sh = turned.project_sh(2);
    let zonal = zonal_coefficients(&gaussian, kappa, 2);
    assert!(radiance_sh(&sh, &zonal, moved)[0] > 3.0 * radiance_sh(&sh, &zonal, -moved)[0]);
}

fn load_error(path: &Path) -> String {
    let error = Environment::load(&EnvironmentDesc::map(path)).unwrap_err();
    let message = error.to_string();
    assert!(
        message.contains(&path.file_name().unwrap().to_string_lossy().into_owned()),
        "{message}"
    );
    message
}

#[test]
fn bad_maps_and_parameters_are_errors_naming_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let missing: PathBuf = dir.path().join("missing.exr");
    load_error(&missing);
    let text = dir.path().join("text.exr");
    std::fs::write(&text, b"not an image").unwrap();
    assert!(load_error(&text).contains("OpenEXR"));
    let empty = dir.path().join("empty.exr");
    std::fs::write(&empty, b"").unwrap();
    load_error(&empty);
    assert!(load_error(dir.path()).contains("folder"));
    for (name, value) in [
        ("nan.exr", f32::NAN),
        ("negative.exr", -1.0),
        ("infinite.exr", f32::INFINITY),
    ] {
        let path = dir.path().join(name);
        write_map(&path, 8, 4, |d| {
            if d.y > 0.9 {
                [1.0, value, 1.0]
            } else {
                [1.0; 3]
            }
        });
        let error = Environment::load(&EnvironmentDesc::map(&path)).unwrap_err();
        assert!(matches!(error, EnvironmentError::Map { .. }), "{error:?}");
        let message = load_error(&path);
        assert!(
            message.contains("row 0") && message.contains("≥ 0"),
            "{message}"
        );
    }
    assert!(EquirectMap::new(0, 4, vec![]).is_err());
    assert!(EquirectMap::new(2, 2, vec![[0.0; 3]; 3]).is_err());
    for desc in [
        EnvironmentDesc::uniform([1.0, -0.1, 1.0]),
        EnvironmentDesc::uniform([1.0, f32::NAN, 1.0]),
        EnvironmentDesc::uniform([1.0; 3]).with_intensity(-1.0),
        EnvironmentDesc::uniform([1.0; 3]).with_intensity(f32::INFINITY),
        EnvironmentDesc::uniform([1.0; 3]).with_rotation_deg(f32::NAN),
    ] {
        let error = Environment::load(&desc).unwrap_err();
        assert!(
            matches!(error, EnvironmentError::Parameter { .. }),
            "{desc:?}: {error:?}"
        );
    }
}
