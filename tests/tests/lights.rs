//! Point and spot lights (issue 19) on a software adapter: a Lambertian sphere under each
//! against the analytic radiance (albedo/π · intensity/d² · cone · cos⁺θ at the surface point
//! each pixel sees), each light keeping its own non-local terms whatever the order of the
//! frame's lights, their cast shadows where the rays from the light say (perspective and cube
//! maps), and golden images of the wax sphere under a point and a spot light.

use cdrf_core::Mesh;
use cdrf_core::glam::Vec3;
use cdrf_core::image_file::RgbaImage;
use cdrf_core::light::{DirectionalLight, Light, NonLocal, PointLight, SpotLight};
use cdrf_core::mesh::MeshSurfaces;
use cdrf_core::scene::{Material, ModelTransform, Projection, Scene};
use cdrf_tests::golden::{Srgb8Image, Tolerance, assert_golden};
use cdrf_tests::{bundled_scene, merged, render_predictable, sphere_points, sphere_scene};

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

/// Radiance adds over lights, each with its own non-local terms: a point light and a directional
/// one with every term on render as the two apart, in either order, and every term acts on the
/// point light (its perspective maps): shadows and transmission, and the subsurface gather and
/// inter-reflection on top of them.
#[test]
fn each_light_keeps_its_own_non_local_terms_whatever_the_order() {
    let (mut scene, assets) = bundled_scene("torus", 128);
    scene.camera.msaa_samples = 1;
    scene.non_local = NonLocal::ALL;
    let Some(Light::Directional(sun)) = scene.lights.first().copied() else {
        panic!("the torus scene has a directional light");
    };
    let lamp = Light::Point(PointLight {
        position: Vec3::new(60.0, 40.0, 80.0),
        intensity: [8000.0; 3],
    });
    let render = |lights: Vec<Light>, non_local: NonLocal| {
        let mut scene = scene.clone();
        scene.lights = lights;
        scene.non_local = non_local;
        render_predictable(&scene, &assets)
    };
    let lamp_first = render(vec![lamp, Light::Directional(sun)], NonLocal::ALL);
    let sun_first = render(vec![Light::Directional(sun), lamp], NonLocal::ALL);
    let sun_alone = render(vec![Light::Directional(sun)], NonLocal::ALL);
    let lamp_alone = render(vec![lamp], NonLocal::ALL);
    let shadows_and_transmission = NonLocal {
        shadows: true,
        transmission: true,
        ..NonLocal::OFF
    };
    let lamp_shadowed = render(vec![lamp], shadows_and_transmission);
    let lamp_local = render(vec![lamp], NonLocal::OFF);
    let mut total = 0.0f64;
    let mut sums = [0.0f64; 4];
    for (((((a, b), s), l), ls), ll) in lamp_first
        .pixels
        .iter()
        .zip(&sun_first.pixels)
        .zip(&sun_alone.pixels)
        .zip(&lamp_alone.pixels)
        .zip(&lamp_shadowed.pixels)
        .zip(&lamp_local.pixels)
    {
        for c in 0..3 {
            total += f64::from(a[c]);
            sums[0] += f64::from((a[c] - b[c]).abs());
            sums[1] += f64::from((a[c] - s[c] - l[c]).abs());
            sums[2] += f64::from((l[c] - ls[c]).abs());
            sums[3] += f64::from((l[c] - ll[c]).abs());
        }
    }
    let [order, parts, gathers, terms] = sums.map(|d| d / total.max(1e-30));
    println!(
        "of the whole: order {:.4} %, sum of the parts {:.4} %, the lamp's gathers {:.4} %, \
         the lamp's shadows and transmission {:.2} %",
        100.0 * order,
        100.0 * parts,
        100.0 * gathers,
        100.0 * terms
    );
    assert!(total > 0.0);
    assert!(order < 1e-5, "{order}");
    assert!(parts < 1e-3, "{parts}");
    assert!(gathers > 0.005, "{gathers}");
    assert!(terms > 0.01, "{terms}");
}

/// The nearest hit of a ray on a set of spheres: (distance, sphere index).
fn hit_spheres(origin: Vec3, direction: Vec3, spheres: &[(Vec3, f32)]) -> Option<(f32, usize)> {
    spheres
        .iter()
        .enumerate()
        .filter_map(|(index, &(centre, radius))| {
            let oc = origin - centre;
            let b = oc.dot(direction);
            let discriminant = b * b - (oc.length_squared() - radius * radius);
            if discriminant < 0.0 {
                return None;
            }
            let t = -b - discriminant.sqrt();
            (t > 1e-3).then_some((t, index))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
}

/// Per pixel of an orthographic view along −z: which sphere it sees (`None`: background) and,
/// for a Lambertian sphere under `light`, whether the point is lit from the front (cos θ > 0.2)
/// and whether the way to the light is blocked by another sphere, with the radiance it has
/// when unblocked.
fn shadow_truth(
    scene: &Scene,
    spheres: &[(Vec3, f32)],
    light: &Light,
) -> Vec<Option<(usize, bool, f32)>> {
    let Projection::Orthographic { half_height } = scene.camera.projection else {
        panic!("orthographic view");
    };
    let (width, height) = (scene.camera.width, scene.camera.height);
    let mm_per_px = 2.0 * half_height / height as f32;
    (0..width * height)
        .map(|index| {
            let x = ((index % width) as f32 + 0.5 - width as f32 / 2.0) * mm_per_px;
            let y = (height as f32 / 2.0 - (index / width) as f32 - 0.5) * mm_per_px;
            let origin = Vec3::new(x, y, 500.0);
            let (t, sphere) = hit_spheres(origin, Vec3::NEG_Z, spheres)?;
            let p = origin - Vec3::Z * t;
            let n = (p - spheres[sphere].0).normalize();
            let at = light.incidence(p, 1.0);
            let cos_theta = n.dot(at.to_light);
            if cos_theta < 0.2 {
                return Some((sphere, false, 0.0));
            }
            let lit = at.irradiance[0] * cos_theta / std::f32::consts::PI;
            let to_light = match light {
                Light::Directional(_) => f32::INFINITY,
                Light::Point(l) => l.position.distance(p),
                Light::Spot(l) => l.position.distance(p),
            };
            let blocked =
                hit_spheres(p + n * 0.01, at.to_light, spheres).is_some_and(|(t, _)| t < to_light);
            Some((sphere, blocked, lit))
        })
        .collect()
}

/// Cast shadows of point and spot lights fall where the rays from the light say: white
/// Lambertian spheres (hard shadows, read per pixel) — two receivers each with a small sphere
/// beside it — under a point light among them (a cube map of six faces), a point light beyond
/// them (one perspective face) and a spot light. Per pixel, the render is dark exactly where the
/// segment to the light meets another sphere, away from shadow edges (±1 px).
#[test]
fn point_and_spot_light_shadows_fall_where_the_rays_say() {
    let spheres = [
        (Vec3::new(50.0, 0.0, 0.0), 20.0),
        (Vec3::new(22.0, 4.0, 2.0), 7.0),
        (Vec3::new(-50.0, 0.0, 0.0), 20.0),
        (Vec3::new(-22.0, -4.0, -2.0), 7.0),
    ];
    let parts: Vec<(Mesh, Vec3)> = spheres
        .iter()
        .map(|&(centre, radius)| (Mesh::icosphere(radius, 5), centre))
        .collect();
    let (mesh, curvature) = merged(&parts);
    let (mut scene, mut assets) = sphere_scene(256);
    if let Projection::Orthographic { half_height } = &mut scene.camera.projection {
        *half_height = 75.0;
    }
    scene.non_local = NonLocal {
        shadows: true,
        ..NonLocal::OFF
    };
    // (The sphere scene draws its unit sphere 35 × larger; these spheres are in mm.)
    scene.mesh.transform = ModelTransform::default();
    assets.surfaces = MeshSurfaces::single(&mesh);
    assets.mesh = mesh;
    assets.curvature_per_mm = curvature.mean_per_mm;
    assets.curvature_anisotropy_per_mm = curvature.anisotropy_per_mm;
    assets.material = Material::Lambert { albedo: [1.0; 3] };
    let (width, height) = (scene.camera.width as i64, scene.camera.height as i64);
    let cases = [
        (
            "point light among the spheres (cube)",
            Light::Point(PointLight {
                position: Vec3::new(0.0, 0.0, 6.0),
                intensity: [2000.0; 3],
            }),
        ),
        (
            "point light beyond them (one face)",
            Light::Point(PointLight {
                position: Vec3::new(-150.0, 20.0, 40.0),
                intensity: [20000.0; 3],
            }),
        ),
        (
            "spot light",
            Light::Spot(SpotLight {
                position: Vec3::new(140.0, -20.0, 40.0),
                direction: Vec3::new(-1.0, 0.1, -0.25).normalize(),
                intensity: [20000.0; 3],
                inner_angle_rad: 35f32.to_radians(),
                outer_angle_rad: 45f32.to_radians(),
            }),
        ),
    ];
    for (name, light) in cases {
        scene.lights = vec![light];
        let image = render_predictable(&scene, &assets);
        let truth = shadow_truth(&scene, &spheres, &light);
        let (mut counted, mut shadowed, mut wrong) = (0, 0, 0);
        for row in 1..height - 1 {
            for column in 1..width - 1 {
                let index = (row * width + column) as usize;
                let Some((sphere, blocked, lit)) = truth[index] else {
                    continue;
                };
                if lit <= 0.0 {
                    continue;
                }
                // Away from silhouettes, terminators and shadow edges.
                let steady = [(-1, 0), (1, 0), (0, -1), (0, 1)].iter().all(|(dx, dy)| {
                    let neighbour = ((row + dy) * width + column + dx) as usize;
                    matches!(truth[neighbour], Some((s, b, l)) if s == sphere && b == blocked && l > 0.0)
                });
                if !steady {
                    continue;
                }
                counted += 1;
                let radiance = image.pixels[index][0];
                let dark = radiance < 0.5 * lit;
                shadowed += usize::from(blocked);
                wrong += usize::from(dark != blocked);
            }
        }
        let fraction = wrong as f64 / counted.max(1) as f64;
        println!(
            "{name}: {counted} lit-facing pixels, {shadowed} in cast shadow, {wrong} wrong \
             ({:.2} %)",
            100.0 * fraction
        );
        assert!(shadowed > 90, "{name}: {shadowed} cast-shadow pixels");
        assert!(counted > 1000, "{name}: {counted}");
        assert!(fraction < 0.01, "{name}: {fraction}");
    }
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
