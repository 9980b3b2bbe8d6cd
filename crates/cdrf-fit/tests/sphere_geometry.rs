//! Sphere detection and the pixel → normal mapping, on synthetic photographs with known truth.

use cdrf_fit::dataset::{Light, Projection};
use cdrf_fit::image_io::{ColorSpace, LinearImage, SampleFormat};
use cdrf_fit::sphere::{SphereView, detect_sphere, sample_sphere};
use glam::{Vec2, Vec3};

fn image(width: u32, height: u32, pixels: Vec<Vec3>) -> LinearImage {
    LinearImage {
        width,
        height,
        saturated: vec![false; pixels.len()],
        pixels,
        sample_format: SampleFormat::Float,
        color_space: ColorSpace::Linear,
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
    let mut pixels = Vec::new();
    let mut normals = Vec::new();
    for row in 0..height {
        for column in 0..width {
            let ray = Vec3::new(
                column as f32 + 0.5 - width as f32 / 2.0,
                height as f32 / 2.0 - row as f32 - 0.5,
                -focal,
            )
            .normalize();
            let along = ray.dot(center);
            let discriminant = along * along - (center.length_squared() - radius * radius);
            if discriminant <= 0.0 {
                pixels.push(Vec3::ZERO);
                normals.push(None);
                continue;
            }
            let normal = (ray * (along - discriminant.sqrt()) - center) / radius;
            pixels.push(Vec3::splat(
                normal.dot(to_light).max(0.0) * 0.8 / std::f32::consts::PI,
            ));
            normals.push(Some(normal));
        }
    }
    (image(width, height, pixels), normals)
}

#[test]
fn perspective_normals_match_the_ray_traced_sphere() {
    let to_light = Vec3::new(-1.0, 0.3, 0.2).normalize();
    // Off the optical axis, so the silhouette is slightly elliptical.
    let (photo, truth) = perspective_sphere(
        480,
        360,
        40.0,
        Vec3::new(25.0, 10.0, -160.0),
        30.0,
        to_light,
    );
    let detection = detect_sphere(480, 360, &photo.pixels).expect("sphere found");
    let view = SphereView::new(
        detection.circle,
        Projection::Perspective {
            vertical_fov_deg: 40.0,
        },
        480,
        360,
    );
    let light = Light {
        to_light,
        irradiance: Vec3::ONE,
    };
    let (samples, _) = sample_sphere(&view, &photo, &light, 2.0);
    let (mut sum, mut worst) = (0.0_f32, 0.0_f32);
    for s in &samples {
        let normal = truth[s.pixel as usize].expect("sampled pixels are on the sphere");
        let theta = normal.dot(to_light).clamp(-1.0, 1.0).acos();
        let error = (s.theta_rad - theta).abs().to_degrees();
        sum += error;
        worst = worst.max(error);
        // Radiance round-trips to π·L/E = 0.8·cos⁺θ.
        assert!((s.radiance.x - 0.8 * theta.cos().max(0.0)).abs() < 1e-4);
    }
    let mean = sum / samples.len() as f32;
    println!(
        "perspective: {} samples, θ error mean {mean:.3}°, worst {worst:.3}°",
        samples.len()
    );
    assert!(samples.len() > 10_000);
    // The fitted circle only approximates the slightly elliptical silhouette of an off-axis
    // sphere, which costs a few tenths of a degree.
    assert!(mean < 0.5, "mean θ error {mean}°");
    assert!(worst < 4.0, "worst θ error {worst}°");
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
