//! Sphere detection and the pixel → normal mapping, on synthetic photographs with known truth.

use cdrf_fit::dataset::Projection;
use cdrf_fit::image_io::{CodeStep, ColorSpace, LinearImage, SampleFormat};
use cdrf_fit::sphere::{Illumination, SphereView, detect_sphere, sample_sphere};
use glam::{Vec2, Vec3};

fn image(width: u32, height: u32, pixels: Vec<Vec3>) -> LinearImage {
    LinearImage {
        width,
        height,
        saturated: vec![false; pixels.len()],
        pixels,
        sample_format: SampleFormat::Float,
        color_space: ColorSpace::Linear,
        code_step: CodeStep::Float,
    }
}

/// A Lambertian sphere lit from `to_light`, seen through a pinhole camera at the origin looking
/// down −z (vertical field of view `fov_deg`), ray traced at pixel centres. Returns the image and
/// the true normal per pixel.
fn perspective_sphere(
    width: u32,
    height: u32,
    fov_deg: f32,
    center: Vec3,
    radius: f32,
    to_light: Vec3,
) -> (LinearImage, Vec<Option<Vec3>>) {
    let focal = (height as f32 / 2.0) / (fov_deg.to_radians() / 2.0).tan();
    // The normal seen through image point (x, y), continuous pixel coordinates.
    let normal_at = |x: f32, y: f32| {
        let ray = Vec3::new(x - width as f32 / 2.0, height as f32 / 2.0 - y, -focal).normalize();
        let along = ray.dot(center);
        let discriminant = along * along - (center.length_squared() - radius * radius);
        (discriminant > 0.0).then(|| (ray * (along - discriminant.sqrt()) - center) / radius)
    };
    let mut pixels = Vec::new();
    let mut normals = Vec::new();
    // Box pixel filter (4 × 4 supersampling), like a camera or the path tracer.
    let n = 4;
    for row in 0..height {
        for column in 0..width {
            let mut sum = 0.0;
            for sy in 0..n {
                for sx in 0..n {
                    let x = column as f32 + (sx as f32 + 0.5) / n as f32;
                    let y = row as f32 + (sy as f32 + 0.5) / n as f32;
                    if let Some(normal) = normal_at(x, y) {
                        sum += normal.dot(to_light).max(0.0) * 0.8 / std::f32::consts::PI;
                    }
                }
            }
            pixels.push(Vec3::splat(sum / (n * n) as f32));
            normals.push(normal_at(column as f32 + 0.5, row as f32 + 0.5));
        }
    }
    (image(width, height, pixels), normals)
}

/// Mean and worst θ error (degrees) of the sampled pixels of a ray-traced perspective sphere.
fn perspective_theta_error(center: Vec3, radius: f32) -> (usize, f32, f32) {
    // Lit at about 90° to the view, as the measurement is set up (so the radiance is flat near
    // the lit limb, which the sub-pixel edge assumes).
    let to_light = Vec3::new(-1.0, 0.3, 0.0).normalize();
    let (photo, truth) = perspective_sphere(480, 360, 40.0, center, radius, to_light);
    let detection = detect_sphere(480, 360, &photo.pixels).expect("sphere found");
    let view = SphereView::with_silhouette(
        detection.circle,
        Projection::Perspective {
            vertical_fov_deg: 40.0,
        },
        480,
        360,
        &detection.edge_points,
    );
    let light = Illumination::directional(to_light, Vec3::ONE);
    let (samples, _) = sample_sphere(&view, &photo, &light, 2.0, None, false, None);
    let (mut sum, mut worst) = (0.0_f32, 0.0_f32);
    for s in &samples {
        let normal = truth[s.pixel as usize].expect("sampled pixels are on the sphere");
        let theta = normal.dot(to_light).clamp(-1.0, 1.0).acos();
        let error = (s.theta_rad - theta).abs().to_degrees();
        sum += error;
        worst = worst.max(error);
        // Radiance round-trips to π·L/E = 0.8·cos⁺θ (away from the kink at the terminator,
        // which the box filter rounds).
        if theta.cos().abs() > 0.05 {
            assert!((s.radiance.x - 0.8 * theta.cos().max(0.0)).abs() < 2e-3);
        }
    }
    (samples.len(), sum / samples.len() as f32, worst)
}

#[test]
fn perspective_normals_match_the_ray_traced_sphere() {
    // Near the optical axis, and about 20° off it (where the silhouette is an ellipse).
    for (center, radius) in [
        (Vec3::new(25.0, 10.0, -160.0), 30.0),
        (Vec3::new(45.0, 20.0, -200.0), 30.0),
    ] {
        let (count, mean, worst) = perspective_theta_error(center, radius);
        println!(
            "perspective, sphere at {center}: {count} samples, θ error mean {mean:.3}°, worst {worst:.3}°"
        );
        assert!(count > 10_000);
        // Measured: 0.13° / 0.7° on the axis, 0.24° / 1.25° 14° off it (the sub-pixel edge is
        // searched along radii of the fitted circle, not normal to the elliptical silhouette).
        assert!(mean < 0.3, "mean θ error {mean}°");
        assert!(worst < 1.5, "worst θ error {worst}°");
    }
}

#[test]
fn an_infinite_pixel_at_the_edge_does_not_break_detection() {
    let to_light = Vec3::new(-1.0, 0.0, 0.0);
    let (mut photo, _) =
        perspective_sphere(200, 200, 30.0, Vec3::new(0.0, 0.0, -200.0), 40.0, to_light);
    // A firefly just inside the lit limb.
    let row = 100;
    let column = (0..200)
        .find(|&c| photo.pixels[row * 200 + c].x > 0.0)
        .expect("lit limb")
        + 2;
    photo.pixels[row * 200 + column] = Vec3::splat(f32::INFINITY);
    let detection = detect_sphere(200, 200, &photo.pixels).expect("sphere found");
    assert!(detection.circle.center_px.is_finite() && detection.circle.radius_px.is_finite());
}

#[test]
fn orthographic_detection_is_sub_pixel_with_a_dark_shadow_side() {
    // A half-lit sphere: only the left half of the silhouette is visible.
    let (width, height) = (300_u32, 260_u32);
    let center = Vec2::new(141.3, 127.8);
    let radius = 97.4;
    let mut pixels = vec![Vec3::ZERO; (width * height) as usize];
    // Box-filtered by 8 × 8 supersampling, like the path tracer's box pixel filter.
    let n = 8;
    for row in 0..height {
        for column in 0..width {
            let mut sum = 0.0;
            for sy in 0..n {
                for sx in 0..n {
                    let p = Vec2::new(
                        column as f32 + (sx as f32 + 0.5) / n as f32,
                        row as f32 + (sy as f32 + 0.5) / n as f32,
                    );
                    let d = (p - center) / radius;
                    if d.length_squared() < 1.0 {
                        sum += (-d.x).max(0.0); // cos θ for a light from the left
                    }
                }
            }
            pixels[(row * width + column) as usize] = Vec3::splat(sum / (n * n) as f32);
        }
    }
    let detection = detect_sphere(width as usize, height as usize, &pixels).expect("sphere found");
    let offset = detection.circle.center_px - center;
    let radius_error = detection.circle.radius_px - radius;
    println!("half-lit sphere: centre off by {offset}, radius off by {radius_error:.3} px");
    assert!(offset.length() < 0.3, "centre off by {offset}");
    assert!(radius_error.abs() < 0.3, "radius off by {radius_error}");
}

#[test]
fn a_black_image_has_no_sphere() {
    assert!(detect_sphere(64, 64, &vec![Vec3::ZERO; 64 * 64]).is_err());
}
