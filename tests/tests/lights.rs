//! Point and spot lights (issue 19) on a software adapter: a Lambertian sphere under each
//! against the analytic radiance (albedo/π · intensity/d² · cone · cos⁺θ at the surface point
//! each pixel sees), the non-local terms staying with the directional lights whatever the order
//! of the frame's lights, and golden images of the wax sphere under a point and a spot light.

use cdrf_core::glam::Vec3;
use cdrf_core::image_file::RgbaImage;
use cdrf_core::light::{DirectionalLight, Light, NonLocal, PointLight, SpotLight};
use cdrf_core::scene::{Material, Scene};
use cdrf_tests::golden::{Srgb8Image, Tolerance, assert_golden};
use cdrf_tests::{data_dir, render_predictable, sphere_points, sphere_scene};

const TOLERANCE: Tolerance = Tolerance {
    mean_flip: 0.005,
    max_flip_fraction_above_0_1: 0.002,
};

/// Mean and largest relative error of a white Lambertian sphere under `light` against
/// 1/π · E · cos⁺θ (pixels brighter than a tenth of the brightest), and how much the analytic
/// irradiance varies over them (largest / smallest).
fn lambert_sphere_error(light: Light) -> (f64, f64, f64) {
    let (mut scene, mut assets) = sphere_scene(256);
    scene.lights = vec![light];
    assets.material = Material::Lambert { albedo: [1.0; 3] };
    let image = render_predictable(&scene, &assets);
    let truth: Vec<Option<(f32, f32)>> = sphere_points(&scene)
        .into_iter()
        .map(|hit| {
            hit.map(|(p, n)| {
                let at = light.incidence(p, 1.0);
                let e = at.irradiance[0];
                (e * n.dot(at.to_light).max(0.0) / std::f32::consts::PI, e)
            })
        })
        .collect();
    let peak = truth.iter().flatten().map(|t| t.0).fold(0.0f32, f32::max);
    assert!(peak > 0.0);
    let (mut sum, mut count, mut worst) = (0.0f64, 0usize, 0.0f64);
    let (mut e_min, mut e_max) = (f32::INFINITY, 0.0f32);
    for (pixel, truth) in image.pixels.iter().zip(&truth) {
        let Some((radiance, e)) = *truth else {
            continue;
        };
        if radiance < 0.1 * peak {
            continue;
        }
        let error = f64::from((pixel[0] - radiance).abs() / radiance);
        sum += error;
        count += 1;
        worst = worst.max(error);
        e_min = e_min.min(e);
        e_max = e_max.max(e);
    }
    assert!(count > 5000, "{count} pixels");
    (sum / count as f64, worst, f64::from(e_max / e_min))
}

#[test]
fn lambert_sphere_under_a_point_light_matches_the_inverse_square_law() {
    // 70 mm from the centre, up and to the left: the lit pixels are 35–70 mm from it.
    let light = Light::Point(PointLight {
        position: Vec3::new(-50.0, 30.0, 40.0),
        intensity: [2500.0; 3],
    });
    let (mean, worst, spread) = lambert_sphere_error(light);
    println!(
        "point light: mean relative error {:.3} %, largest {:.2} %; irradiance varies {spread:.2} ×",
        mean * 100.0,
        worst * 100.0
    );
    // The test can fail: the irradiance varies 2 × or more over the pixels it checks, so a
    // missing or wrong falloff (or units) is tens of per cent.
    assert!(spread > 2.0, "{spread}");
    assert!(mean < 0.005, "{mean}");
    assert!(worst < 0.03, "{worst}");
}

#[test]
fn lambert_sphere_under_a_spot_light_matches_its_cone() {
    // Aimed past the sphere's centre so the cone's edge crosses the lit side.
    let light = Light::Spot(SpotLight {
        position: Vec3::new(-30.0, 0.0, 80.0),
        direction: Vec3::new(0.55, 0.25, -1.0).normalize(),
        intensity: [5000.0; 3],
        inner_angle_rad: 8f32.to_radians(),
        outer_angle_rad: 20f32.to_radians(),
    });
    let (mean, worst, spread) = lambert_sphere_error(light);
    println!(
        "spot light: mean relative error {:.3} %, largest {:.2} %; irradiance varies {spread:.2} ×",
        mean * 100.0,
        worst * 100.0
    );
    assert!(spread > 3.0, "{spread}");
    assert!(mean < 0.01, "{mean}");
    assert!(worst < 0.06, "{worst}");
}

/// Radiance adds over lights: a point light listed before a directional one, with every
/// non-local term on, renders as the two apart — so the shadow maps, gather and bounce stay
/// with the directional light (the point light gets the local model), whatever the order.
#[test]
fn non_local_terms_follow_the_directional_light_whatever_the_order() {
    let path = data_dir().join("scenes/torus.toml");
    let mut scene = Scene::load(&path).unwrap_or_else(|error| panic!("{error}"));
    scene.camera.width = 128;
    scene.camera.height = 128;
    scene.camera.msaa_samples = 1;
    scene.non_local = NonLocal::ALL;
    let assets = scene
        .load_assets()
        .unwrap_or_else(|error| panic!("{error}"));
    let Some(Light::Directional(sun)) = scene.lights.first().copied() else {
        panic!("the torus scene has a directional light");
    };
    let lamp = Light::Point(PointLight {
        position: Vec3::new(60.0, 40.0, 80.0),
        intensity: [8000.0; 3],
    });
    let render = |lights: Vec<Light>| {
        let mut scene = scene.clone();
        scene.lights = lights;
        render_predictable(&scene, &assets)
    };
    let both = render(vec![lamp, Light::Directional(sun)]);
    let sun_alone = render(vec![Light::Directional(sun)]);
    let lamp_alone = render(vec![lamp]);
    let mut lamp_local_scene = scene.clone();
    lamp_local_scene.lights = vec![lamp];
    lamp_local_scene.non_local = NonLocal::OFF;
    let lamp_local = render_predictable(&lamp_local_scene, &assets);
    let (mut difference, mut total, mut lamp_difference) = (0.0f64, 0.0f64, 0.0f64);
    for (((b, s), l), ll) in both
        .pixels
        .iter()
        .zip(&sun_alone.pixels)
        .zip(&lamp_alone.pixels)
        .zip(&lamp_local.pixels)
    {
        for c in 0..3 {
            difference += f64::from((b[c] - s[c] - l[c]).abs());
            total += f64::from(b[c]);
            lamp_difference += f64::from((l[c] - ll[c]).abs());
        }
    }
    println!(
        "sum of the parts: {:.4} % of the whole; the lamp alone with and without the terms: {:.4} %",
        100.0 * difference / total,
        100.0 * lamp_difference / total
    );
    assert!(total > 0.0);
    assert!(difference / total < 1e-3, "{}", difference / total);
    assert!(
        lamp_difference / total < 1e-5,
        "{}",
        lamp_difference / total
    );
    // And the terms do act on the sun: without them its render differs.
    let mut local_scene = scene.clone();
    local_scene.non_local = NonLocal::OFF;
    let sun_local = render_predictable(&local_scene, &assets);
    let changed: f64 = sun_alone
        .pixels
        .iter()
        .zip(&sun_local.pixels)
        .map(|(a, b)| f64::from((a[0] - b[0]).abs()))
        .sum();
    assert!(changed > 0.05 * total / 3.0, "{changed}");
}

fn srgb8(image: &RgbaImage) -> Srgb8Image {
    Srgb8Image {
        width: image.width,
        height: image.height,
        pixels: image.to_srgb8(),
    }
}

/// The measured wax sphere under a point light and a spot light together (256 px).
#[test]
fn wax_sphere_under_point_and_spot_lights() {
    let (mut scene, assets) = sphere_scene(256);
    scene.lights = vec![
        Light::Point(PointLight {
            position: Vec3::new(-60.0, 20.0, 30.0),
            intensity: [3000.0, 2800.0, 2500.0],
        }),
        Light::Spot(SpotLight {
            position: Vec3::new(50.0, 50.0, 60.0),
            direction: Vec3::new(-0.6, -0.6, -0.8).normalize(),
            intensity: [3000.0, 3200.0, 4000.0],
            inner_angle_rad: 10f32.to_radians(),
            outer_angle_rad: 20f32.to_radians(),
        }),
        Light::Directional(DirectionalLight {
            to_light: Vec3::new(0.0, -1.0, 0.2).normalize(),
            irradiance: [0.1; 3],
        }),
    ];
    let image = render_predictable(&scene, &assets);
    assert_golden("sphere_point_spot", &srgb8(&image), TOLERANCE);
}
