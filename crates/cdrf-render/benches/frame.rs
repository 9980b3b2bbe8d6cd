//! Frame cost of each shading model, in one run: the bunny and a ≥ 1M-triangle torus at
//! 1024 × 1024 (4× MSAA, depth), N timed frames per model after a warm-up, rounds interleaved
//! so drift in machine load hits every model alike. Prints ms/frame (the fastest round, whose
//! mean is least disturbed by other load; the median beside it) and
//! the ratios the product promises: measured ≤ 1.15 × Lambert and ≤ 1.02 × Gaussian, and the
//! non-local terms (shadow pass included) ≤ 1.5 × the poster's measured model. "no penumbra"
//! (one shadow-map read per light: the table without its translucency terms) separates the
//! shadow pass's cost from the penumbra's. "point + spot + sky + spec." is an engine's lighting
//! (a point light and a spot three half-heights away, a uniform sky, the specular layer) against
//! the poster's one directional light.
//!
//! ```text
//! cargo bench -p cdrf-render --bench frame                 # software adapter (lavapipe)
//! cargo bench -p cdrf-render --bench frame -- --gpu        # whatever adapter wgpu prefers
//! cargo bench -p cdrf-render --bench frame -- --frames 50 --rounds 5 [--bunny-only]
//! cargo bench -p cdrf-render --bench frame -- --only measured --only "measured + all (256 patches)"
//! ```

use std::error::Error;
use std::path::PathBuf;

use cdrf_core::environment::EnvironmentDesc;
use cdrf_core::gaussian_file::read_gaussian;
use cdrf_core::glam::Vec3;
use cdrf_core::scene::{
    Camera, Material, MeshSpec, ModelTransform, Projection, Scene, SceneAssets, ShadingSpec,
};
use cdrf_core::{CurvatureOptions, Mesh, curvature_per_mm, read_lut};
use cdrf_render::headless::{AdapterPreference, HeadlessDevice, RenderSettings, render_scene};
use cdrf_render::{DirectionalLight, NonLocal, PointLight, SpecularLayer, SpotLight};
use cdrf_render::{GaussianEvaluation, LutFiltering, Options};

const SIZE: u32 = 1024;

struct Variant {
    name: &'static str,
    material: Material,
    options: Options,
    non_local: NonLocal,
    /// An engine's lighting instead of the poster's one directional light: a point light, a
    /// spot, a uniform sky and the specular layer.
    engine_lights: bool,
}

fn main() -> Result<(), Box<dyn Error>> {
    let mut frames = 20;
    let mut rounds = 3;
    let mut preference = AdapterPreference::Software;
    let mut bunny_only = false;
    // Variants to run (by name; every one when empty): a ratio is printed where both ran.
    let mut only: Vec<String> = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--gpu" => preference = AdapterPreference::Any,
            "--frames" => frames = args.next().ok_or("--frames needs a number")?.parse()?,
            "--rounds" => rounds = args.next().ok_or("--rounds needs a number")?.parse()?,
            "--bunny-only" => bunny_only = true,
            "--only" => only.push(args.next().ok_or("--only needs a variant's name")?),
            "--bench" => {}
            other => return Err(format!("unknown argument {other}").into()),
        }
    }
    let device = HeadlessDevice::new(preference)?;
    println!("adapter: {}", device.adapter_description());
    println!("{SIZE}×{SIZE}, 4× MSAA, {frames} timed frames per model and round, {rounds} rounds");

    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data");
    let lut = read_lut(root.join("wax-fit/measured.exr"))?;
    let gaussian_path = root.join("wax-fit/gaussian.toml");
    let (gaussian, view_correction) = read_gaussian(&gaussian_path)?.load_model(&gaussian_path)?;
    if lut.translucency().is_none() {
        return Err("the bundled measured.exr carries no translucency terms: refit it".into());
    }
    // The same table without its scattering length and T(d): hard shadows, one read per light.
    let opaque_lut = cdrf_core::CdrfLut::new(
        lut.curvature_axis(),
        lut.theta_count(),
        lut.radiance().to_vec(),
    )?
    .with_view_correction(lut.view_correction().clone());
    let variants = || {
        let fast = Options::default();
        let shadows = NonLocal {
            shadows: true,
            ..NonLocal::OFF
        };
        let both = NonLocal {
            shadows: true,
            transmission: true,
            ..NonLocal::OFF
        };
        vec![
            Variant {
                name: "lambert",
                material: Material::Lambert { albedo: [0.8; 3] },
                options: fast,
                non_local: NonLocal::OFF,
                engine_lights: false,
            },
            Variant {
                name: "measured",
                material: Material::Measured(lut.clone()),
                options: fast,
                non_local: NonLocal::OFF,
                engine_lights: false,
            },
            Variant {
                name: "measured (manual filtering)",
                material: Material::Measured(lut.clone()),
                options: Options {
                    lut_filtering: LutFiltering::Manual,
                    ..fast
                },
                non_local: NonLocal::OFF,
                engine_lights: false,
            },
            Variant {
                name: "gaussian (LUT)",
                material: Material::Gaussian {
                    model: gaussian,
                    view_correction: view_correction.clone(),
                },
                options: fast,
                non_local: NonLocal::OFF,
                engine_lights: false,
            },
            Variant {
                name: "gaussian (analytic)",
                material: Material::Gaussian {
                    model: gaussian,
                    view_correction: view_correction.clone(),
                },
                options: Options {
                    gaussian: GaussianEvaluation::Analytic,
                    ..fast
                },
                non_local: NonLocal::OFF,
                engine_lights: false,
            },
            Variant {
                name: "measured + shadows",
                material: Material::Measured(lut.clone()),
                options: fast,
                non_local: shadows,
                engine_lights: false,
            },
            Variant {
                name: "measured + shadows + transm.",
                material: Material::Measured(lut.clone()),
                options: fast,
                non_local: both,
                engine_lights: false,
            },
            Variant {
                name: "measured + shadows + subsurface",
                material: Material::Measured(lut.clone()),
                options: fast,
                non_local: NonLocal {
                    shadows: true,
                    subsurface: true,
                    ..NonLocal::OFF
                },
                engine_lights: false,
            },
            Variant {
                name: "measured + all (256 patches)",
                material: Material::Measured(lut.clone()),
                options: fast,
                non_local: NonLocal::ALL,
                engine_lights: false,
            },
            Variant {
                name: "measured + all (512 patches)",
                material: Material::Measured(lut.clone()),
                options: Options {
                    interreflection_patches: 512,
                    ..fast
                },
                non_local: NonLocal::ALL,
                engine_lights: false,
            },
            Variant {
                name: "measured + shadows, no penumbra",
                material: Material::Measured(opaque_lut.clone()),
                options: fast,
                non_local: shadows,
                engine_lights: false,
            },
            Variant {
                name: "measured, point + spot + sky + spec.",
                material: Material::Measured(lut.clone()),
                options: fast,
                non_local: NonLocal::OFF,
                engine_lights: true,
            },
            Variant {
                name: "measured + all, point + spot + sky + spec.",
                material: Material::Measured(lut.clone()),
                options: fast,
                non_local: NonLocal::ALL,
                engine_lights: true,
            },
        ]
    };

    let names: Vec<&str> = variants().iter().map(|v| v.name).collect();
    if let Some(unknown) = only.iter().find(|name| !names.contains(&name.as_str())) {
        return Err(format!("no variant is named {unknown:?}; they are {names:?}").into());
    }

    let bunny = Mesh::load(root.join("bunny/bunny.obj"))?.mesh;
    let mut meshes = vec![("bunny", bunny, 10.0)];
    if !bunny_only {
        meshes.push(("torus 1M", Mesh::torus(30.0, 14.0, 1024, 512), 1.0));
    }
    for (label, mesh, mm_per_unit) in meshes {
        let curvature = curvature_per_mm(&mesh, &CurvatureOptions::new(mm_per_unit))?;
        let (low, high) = bounds(&mesh);
        let centre = 0.5 * (low + high);
        let half_height = 0.55 * (high - low).max_element();
        println!(
            "\n{label}: {} vertices, {} triangles",
            mesh.vertex_count(),
            mesh.triangle_count()
        );
        let scene = |shading| Scene {
            mesh: MeshSpec {
                path: PathBuf::from(label),
                mm_per_unit,
                transform: ModelTransform::default(),
                curvature_smoothing: 0,
                curvature_filter_mm: None,
            },
            camera: Camera {
                projection: Projection::Orthographic { half_height },
                eye: centre + Vec3::new(0.0, 0.0, 4.0 * half_height),
                target: centre,
                up: Vec3::Y,
                width: SIZE,
                height: SIZE,
                msaa_samples: 4,
                exposure: 1.0,
            },
            lights: vec![
                DirectionalLight {
                    to_light: Vec3::new(-1.0, 0.3, 0.5).normalize(),
                    irradiance: [1.0; 3],
                }
                .into(),
            ],
            shading,
            non_local: NonLocal::OFF,
            specular: None,
            environment: None,
        };
        let variants: Vec<Variant> = variants()
            .into_iter()
            .filter(|v| only.is_empty() || only.iter().any(|name| name == v.name))
            .collect();
        let mut times = vec![Vec::new(); variants.len()];
        let mut assets = SceneAssets {
            mesh,
            curvature_per_mm: curvature.mean_per_mm,
            curvature_anisotropy_per_mm: curvature.anisotropy_per_mm,
            material: Material::Lambert { albedo: [1.0; 3] },
            surfaces: Default::default(),
        };
        for _ in 0..rounds {
            for (variant, times) in variants.iter().zip(&mut times) {
                assets.material = variant.material.clone();
                let settings = RenderSettings {
                    options: variant.options,
                    timed_frames: frames,
                    warm_up_frames: 2,
                };
                // The shading spec is not read by render_scene (the assets carry the material).
                let mut scene = scene(ShadingSpec::Lambert { albedo: [1.0; 3] });
                scene.non_local = variant.non_local;
                if variant.engine_lights {
                    let radius_mm = half_height * mm_per_unit;
                    let lamp = |offset: Vec3| centre + offset * (3.0 * half_height);
                    let intensity = [(3.0 * radius_mm).powi(2); 3];
                    scene.lights = vec![
                        PointLight {
                            position: lamp(Vec3::new(-1.0, 0.3, 0.5)),
                            intensity,
                        }
                        .into(),
                        SpotLight {
                            position: lamp(Vec3::new(0.8, 0.6, 0.6)),
                            direction: -Vec3::new(0.8, 0.6, 0.6).normalize(),
                            intensity,
                            inner_angle_rad: 15f32.to_radians(),
                            outer_angle_rad: 25f32.to_radians(),
                        }
                        .into(),
                    ];
                    scene.environment = Some(EnvironmentDesc::uniform([0.2; 3]));
                    scene.specular = Some(SpecularLayer::default());
                }
                let rendered = render_scene(&device, &scene, &assets, &settings)?;
                times.push(rendered.ms_per_frame.ok_or("no timing")?);
            }
        }
        // The fastest round: lavapipe's frame times carry scheduling noise that only adds.
        let fastest: Vec<f64> = times
            .iter()
            .map(|t| t.iter().cloned().fold(f64::INFINITY, f64::min))
            .collect();
        for (variant, (best, times)) in variants.iter().zip(fastest.iter().zip(&times)) {
            let spread = times.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
                - times.iter().cloned().fold(f64::INFINITY, f64::min);
            println!(
                "  {:<42} {best:8.2} ms/frame  (fastest round; median {:.2}, spread {spread:.2} ms)",
                variant.name,
                median_of(times)
            );
        }
        let ms = |name: &str| {
            variants
                .iter()
                .position(|v| v.name == name)
                .map(|i| fastest[i])
        };
        for (label, numerator, denominator, goal) in [
            (
                "measured / lambert",
                "measured",
                "lambert",
                " (goal ≤ 1.15)",
            ),
            (
                "measured / gaussian (LUT)",
                "measured",
                "gaussian (LUT)",
                " (goal ≤ 1.02)",
            ),
            (
                "gaussian analytic / LUT",
                "gaussian (analytic)",
                "gaussian (LUT)",
                "",
            ),
            (
                "manual / hardware filtering",
                "measured (manual filtering)",
                "measured",
                "",
            ),
            (
                "shadows / measured",
                "measured + shadows",
                "measured",
                " (goal ≤ 1.5)",
            ),
            (
                "shadows + transm. / measured",
                "measured + shadows + transm.",
                "measured",
                " (goal ≤ 1.5)",
            ),
            (
                "shadows + subsurface / measured",
                "measured + shadows + subsurface",
                "measured",
                " (goal ≤ 1.5)",
            ),
            (
                "all (256 patches) / measured",
                "measured + all (256 patches)",
                "measured",
                " (goal ≤ 1.5)",
            ),
            (
                "all (512 patches) / measured",
                "measured + all (512 patches)",
                "measured",
                "",
            ),
            (
                "point + spot + sky + spec. / measured",
                "measured, point + spot + sky + spec.",
                "measured",
                "",
            ),
            (
                "all, point + spot + sky + spec. / measured",
                "measured + all, point + spot + sky + spec.",
                "measured",
                "",
            ),
            (
                "no penumbra / measured",
                "measured + shadows, no penumbra",
                "measured",
                "",
            ),
        ] {
            if let (Some(numerator), Some(denominator)) = (ms(numerator), ms(denominator)) {
                println!("  ratio {label:<44} {:.3}{goal}", numerator / denominator);
            }
        }
    }
    Ok(())
}

fn bounds(mesh: &Mesh) -> (Vec3, Vec3) {
    mesh.positions.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(low, high), &p| (low.min(p), high.max(p)),
    )
}

fn median_of(values: &[f64]) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    sorted[sorted.len() / 2]
}
