//! Scratch: a table against photographs, per radius and region.
use cdrf_core::lut::Filter;
use cdrf_core::lut_file::read_lut;
use cdrf_fit::curves::SphereSamples;
use cdrf_fit::dataset::{Dataset, Light, Projection};
use cdrf_fit::evaluate::sphere_error;
use cdrf_fit::image_io::{ColorSpace, load_linear_image};
use cdrf_fit::sphere::{SphereView, detect_sphere, sample_sphere};
use glam::Vec3;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let lut = read_lut(&args[1]).unwrap();
    let dir = std::path::Path::new(&args[2]);
    let radii: Vec<f32> = args[3].split(',').map(|s| s.parse().unwrap()).collect();
    let light = Light {
        to_light: Vec3::new(-1.0, 0.0, 0.0),
        irradiance: Vec3::ONE,
    };
    for r in radii {
        let image = load_linear_image(
            &dir.join(format!("sphere_r{r}.exr")),
            Some(ColorSpace::Linear),
            1.0,
        )
        .unwrap();
        let (w, h) = (image.width as usize, image.height as usize);
        let det = detect_sphere(w, h, &image.pixels).unwrap();
        let view = SphereView::with_silhouette(
            det.circle,
            Projection::Orthographic,
            w,
            h,
            &det.edge_points,
        );
        let (samples, _) = sample_sphere(&view, &image, &light, 2.0);
        let s = SphereSamples {
            curvature_per_mm: 1.0 / r,
            image_width: image.width,
            samples,
        };
        let k = 1.0 / r;
        let e = sphere_error(&s, |t, p| lut.evaluate(k, t, p, Filter::Bilinear));
        let g1 = sphere_error(&s, |t, _p| lut.sample(k, t, Filter::Bilinear));
        println!(
            "r {r:>4}: lit {:5.2} % term {:5.2} % shadow {:5.2} %   (g=1: {:5.2} / {:5.2} / {:5.2})",
            100.0 * e.lit.mean_relative_error,
            100.0 * e.terminator.mean_relative_error,
            100.0 * e.shadow.mean_relative_error,
            100.0 * g1.lit.mean_relative_error,
            100.0 * g1.terminator.mean_relative_error,
            100.0 * g1.shadow.mean_relative_error
        );
    }
    let _ = Dataset::load;
}
