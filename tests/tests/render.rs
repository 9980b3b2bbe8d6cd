//! cdrf-render on a software adapter (lavapipe): golden images of every shading model on the
//! sphere, torus and bunny scenes, the scaled-mesh, MSAA and non-sRGB-target cases, and the
//! r = 35 mm sphere against its path-traced photograph.
//!
//! References live in `tests/golden/`; `UPDATE_SNAPSHOTS=1 cargo test -p cdrf-tests --test
//! render` writes missing or changed ones. A missing reference fails.

use cdrf_core::block_error::{self, BlockPixel, Region, RegionError};
use cdrf_core::glam::Vec3;
use cdrf_core::image_file::RgbaImage;
use cdrf_core::light::NonLocal;
use cdrf_core::scene::{Material, Scene, SceneAssets};
use cdrf_render::headless::{HeadlessDevice, RenderSettings, render_scene};
use cdrf_render::{Options, wgpu};
use cdrf_tests::golden::{Srgb8Image, Tolerance, assert_golden};
use cdrf_tests::{data_dir, render_predictable, software_device};

/// Renders of the same scene on lavapipe are byte-identical from run to run (TOOLCHAIN.md);
/// the tolerance only absorbs rounding differences between Mesa/LLVM versions. Set on
/// llvmpipe (LLVM 15.0.6, Mesa 22.3.6): any real change of shading, mapping or geometry moves
/// the mean FLIP above the threshold (rotating the light by 0.5° gives 0.009, by 1° 0.013).
const TOLERANCE: Tolerance = Tolerance {
    mean_flip: 0.005,
    max_flip_fraction_above_0_1: 0.002,
};

/// Golden images are 256 × 256 to keep the suite quick on a software rasteriser.
const GOLDEN_SIZE: u32 = 256;

fn load_scene(name: &str) -> Scene {
    let path = data_dir().join("scenes").join(name);
    Scene::load(&path).unwrap_or_else(|error| panic!("{error}"))
}

/// A bundled scene at golden-image size with the given MSAA sample count.
fn golden_scene(name: &str, msaa_samples: u32) -> Scene {
    let mut scene = load_scene(name);
    scene.camera.width = GOLDEN_SIZE;
    scene.camera.height = GOLDEN_SIZE;
    scene.camera.msaa_samples = msaa_samples;
    scene
}

fn assets(scene: &Scene) -> SceneAssets {
    scene
        .load_assets()
        .unwrap_or_else(|error| panic!("{error}"))
}

/// The Gaussian CDRF of the bundled fit, with the view correction it shares with the
/// measured table (`view_correction_from` in `data/wax-fit/gaussian.toml`).
fn bundled_gaussian() -> Material {
    let path = data_dir().join("wax-fit/gaussian.toml");
    let (model, view_correction) = cdrf_core::gaussian_file::read_gaussian(&path)
        .and_then(|parameters| parameters.load_model(&path))
        .unwrap_or_else(|error| panic!("{error}"));
    Material::Gaussian {
        model,
        view_correction,
    }
}

fn srgb8(image: &RgbaImage) -> Srgb8Image {
    Srgb8Image {
        width: image.width,
        height: image.height,
        pixels: image.to_srgb8(),
    }
}

/// The four shading models for one scene, at golden size without MSAA.
fn models(scene_file: &str, stem: &str) {
    let mut scene = load_scene(scene_file);
    scene.camera.width = GOLDEN_SIZE;
    scene.camera.height = GOLDEN_SIZE;
    scene.camera.msaa_samples = 1;
    let mut assets = assets(&scene);
    let measured = assets.material.clone();
    assert!(
        matches!(measured, Material::Measured(_)),
        "{scene_file}: the bundled scenes use the measured model"
    );
    let materials = [
        ("measured", measured.clone()),
        ("gaussian", bundled_gaussian()),
        ("lambert", Material::Lambert { albedo: [0.8; 3] }),
        (
            "curvature",
            Material::Curvature {
                range_per_mm: [-0.1, 0.1],
            },
        ),
    ];
    for (model, material) in materials {
        assets.material = material;
        let image = render_predictable(&scene, &assets);
        assert_golden(&format!("{stem}_{model}"), &srgb8(&image), TOLERANCE);
    }
}

#[test]
fn sphere_models() {
    models("sphere_r35.toml", "sphere");
}

#[test]
fn torus_models() {
    models("torus.toml", "torus");
}

#[test]
fn bunny_models() {
    models("bunny.toml", "bunny");
}

/// The same physical sphere described two ways — a unit mesh at 35 mm per unit seen by a
/// camera in mesh units, and a unit mesh scaled ×35 by the model transform seen by a camera in
/// mm — renders the same: curvature follows the transform's scale.
#[test]
fn scaled_mesh_matches_mm_per_unit() {
    let by_transform = golden_scene("sphere_r35.toml", 1);
    assert_eq!(by_transform.mesh.transform.scale, 35.0);
    let mut by_units = by_transform.clone();
    by_units.mesh.transform.scale = 1.0;
    by_units.mesh.mm_per_unit = 35.0;
    by_units.camera.eye /= 35.0;
    by_units.camera.target /= 35.0;
    if let cdrf_core::scene::Projection::Orthographic { half_height } =
        &mut by_units.camera.projection
    {
        *half_height /= 35.0;
    }
    let a = render_predictable(&by_transform, &assets(&by_transform));
    let b = render_predictable(&by_units, &assets(&by_units));
    let worst = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..4).map(move |c| (p[c] - q[c]).abs()))
        .fold(0.0f32, f32::max);
    println!("scale 35 vs mm_per_unit 35: largest difference {worst:e}");
    assert!(worst < 2e-3, "largest difference {worst}");
    assert_golden("sphere_scaled", &srgb8(&a), TOLERANCE);

    // A sphere drawn twice as large is less curved: it must not render like the small one.
    let mut doubled = by_transform.clone();
    doubled.mesh.transform.scale = 70.0;
    if let cdrf_core::scene::Projection::Orthographic { half_height } =
        &mut doubled.camera.projection
    {
        *half_height *= 2.0;
    }
    let c = render_predictable(&doubled, &assets(&doubled));
    let shadow_side = |image: &RgbaImage| {
        // Mean red radiance over the right (shadow) half of the disk.
        let mut sum = 0.0;
        for (index, pixel) in image.pixels.iter().enumerate() {
            let column = index as u32 % image.width;
            if column > image.width / 2 + image.width / 8 {
                sum += pixel[0];
            }
        }
        sum
    };
    println!(
        "shadow-side red radiance: r = 35 mm {:.3}, r = 70 mm {:.3}",
        shadow_side(&a),
        shadow_side(&c)
    );
    assert!(
        shadow_side(&c) < 0.8 * shadow_side(&a),
        "a larger sphere must glow less on its shadow side"
    );
}

/// 4× MSAA: the silhouette is anti-aliased (alpha = coverage) and the interior matches the
/// single-sampled render.
#[test]
fn msaa_sphere() {
    let mut scene = golden_scene("sphere_r35.toml", 4);
    let assets = assets(&scene);
    let msaa = render_predictable(&scene, &assets);
    scene.camera.msaa_samples = 1;
    let single = render_predictable(&scene, &assets);
    let partial = msaa
        .pixels
        .iter()
        .filter(|p| p[3] > 0.01 && p[3] < 0.99)
        .count();
    let single_partial = single
        .pixels
        .iter()
        .filter(|p| p[3] > 0.01 && p[3] < 0.99)
        .count();
    println!("pixels with partial coverage: 4× MSAA {partial}, 1 sample {single_partial}");
    assert_eq!(single_partial, 0);
    // The silhouette of a 115 px circle crosses ~720 pixels; most get partial coverage.
    assert!(partial > 400, "{partial} partially covered pixels");
    // Away from the silhouette (3 × 3 neighbourhood fully covered) every sample of a pixel
    // is shaded once at the pixel centre, as without MSAA.
    let width = msaa.width as usize;
    let interior = |index: usize| {
        let (column, row) = (index % width, index / width);
        (column.saturating_sub(1)..=(column + 1).min(width - 1)).all(|c| {
            (row.saturating_sub(1)..=(row + 1).min(msaa.height as usize - 1))
                .all(|r| msaa.pixels[r * width + c][3] >= 1.0)
        })
    };
    let differences: Vec<f32> = msaa
        .pixels
        .iter()
        .zip(&single.pixels)
        .enumerate()
        .filter(|(index, _)| interior(*index))
        .map(|(_, (p, q))| (p[0] - q[0]).abs())
        .collect();
    let largest = differences.iter().cloned().fold(0.0f32, f32::max);
    let mean = differences.iter().sum::<f32>() / differences.len() as f32;
    println!(
        "interior difference MSAA vs single sample: mean {mean:e}, largest {largest:e} over {} pixels",
        differences.len()
    );
    // Interior pixels are shaded once per triangle; where a triangle covers only some samples
    // (along interior triangle edges), centroid interpolation shades it at those samples'
    // centroid instead of the pixel centre, a fraction of a pixel away.
    assert!(mean < 2e-4, "mean {mean}");
    assert!(largest < 1e-2, "largest {largest}");
    assert_golden("sphere_msaa", &srgb8(&msaa), TOLERANCE);
}

/// A `Rgba8Unorm` target (not sRGB): the renderer encodes sRGB in the shader, so the bytes
/// match the float render encoded on the CPU.
#[test]
fn non_srgb_target() {
    let scene = golden_scene("bunny.toml", 1);
    let assets = assets(&scene);
    let float = render_predictable(&scene, &assets);
    let unorm = render_unorm(&scene, &assets);
    let expected = float.to_srgb8();
    let worst = expected
        .iter()
        .zip(&unorm.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| (i32::from(p[c]) - i32::from(q[c])).abs()))
        .max()
        .unwrap();
    println!("Rgba8Unorm target vs CPU-encoded float render: largest difference {worst}/255");
    assert!(worst <= 1, "largest difference {worst}/255");
    assert_golden("bunny_unorm_target", &unorm, TOLERANCE);
}

/// Renders into a host-owned `Rgba8Unorm` texture through the public pass API.
fn render_unorm(scene: &Scene, assets: &SceneAssets) -> Srgb8Image {
    use cdrf_render::{Draw, FrameDesc, MaterialDesc, MeshDesc, Renderer, TargetDesc, View};
    let HeadlessDevice { device, queue, .. } = software_device();
    let (width, height) = (scene.camera.width, scene.camera.height);
    let format = wgpu::TextureFormat::Rgba8Unorm;
    let depth_format = wgpu::TextureFormat::Depth32Float;
    let target = TargetDesc::new(format).with_depth(depth_format);
    let mut renderer = Renderer::new(device, &target, Options::PREDICTABLE);
    let mesh = renderer
        .create_mesh(
            device,
            &MeshDesc::from_mesh(&assets.mesh, &assets.curvature_per_mm)
                .with_curvature_anisotropy(&assets.curvature_anisotropy_per_mm),
        )
        .unwrap();
    let Material::Measured(lut) = &assets.material else {
        panic!("measured scene expected")
    };
    let material = renderer
        .create_material(device, queue, &MaterialDesc::Measured { lut })
        .unwrap();
    let draws = [Draw::new(
        mesh,
        material,
        scene.mesh.transform.world_from_model(),
    )];
    renderer
        .prepare(
            device,
            queue,
            &FrameDesc {
                view: View::from_camera(&scene.camera, 1.0, 100.0),
                lights: &scene.lights,
                exposure: 1.0,
                draws: &draws,
                non_local: NonLocal::OFF,
                mm_per_world_unit: 1.0,
                environment: None,
            },
        )
        .unwrap();
    record_and_read_back(&renderer, format, Some(depth_format), width, height)
}

/// Records `renderer` into a fresh pass on a host-owned `width × height` 8-bit `format` target
/// (with a depth attachment when given; cleared to transparent black) and reads it back.
fn record_and_read_back(
    renderer: &cdrf_render::Renderer,
    format: wgpu::TextureFormat,
    depth_format: Option<wgpu::TextureFormat>,
    width: u32,
    height: u32,
) -> Srgb8Image {
    let HeadlessDevice { device, queue, .. } = software_device();
    let texture = |format, usage| {
        device.create_texture(&wgpu::TextureDescriptor {
            label: Some("test target"),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        })
    };
    let color = texture(
        format,
        wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
    );
    let color_view = color.create_view(&Default::default());
    let depth_view = depth_format.map(|depth_format| {
        texture(depth_format, wgpu::TextureUsages::RENDER_ATTACHMENT)
            .create_view(&Default::default())
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("test pass"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &color_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: depth_view.as_ref().map(|view| {
                wgpu::RenderPassDepthStencilAttachment {
                    view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }
            }),
            ..Default::default()
        });
        renderer.render(&mut pass);
    }
    let readback = cdrf_render::readback::TextureReadback::record(device, &mut encoder, &color)
        .expect("readable format");
    queue.submit([encoder.finish()]);
    let pixels = readback
        .read(device)
        .expect("read back")
        .chunks_exact(4)
        .map(|p| [p[0], p[1], p[2], p[3]])
        .collect();
    Srgb8Image {
        width,
        height,
        pixels,
    }
}

/// The block errors ([`cdrf_core::block_error`], the metric of cdrf-fit and `compare`) of a
/// render of the r = 35 mm sphere (`sphere_r35.toml`: orthographic, 230 px to the radius, light
/// from the image's left) against its path-traced image in `region`, over the pixels the render
/// covers fully with the silhouette eroded by `erode_px`. cos θ is the analytic sphere's:
/// −x / r at the pixel centre (x from the image centre, rightwards).
fn sphere_block_error(
    render: &RgbaImage,
    reference: &RgbaImage,
    erode_px: u32,
    region: Region,
) -> RegionError {
    assert_eq!(
        (render.width, render.height),
        (reference.width, reference.height)
    );
    let radius_px = 230.0;
    let mask = block_error::covered_mask(render, erode_px);
    let rgb = |p: [f32; 4]| Vec3::new(p[0], p[1], p[2]);
    let blocks = block_error::blocks(render.width, render.height, |i, j| {
        let index = (j * render.width + i) as usize;
        let x = i as f32 + 0.5 - render.width as f32 / 2.0;
        mask[index].then(|| BlockPixel {
            model: rgb(render.pixels[index]),
            reference: rgb(reference.pixels[index]),
            cos_theta: (-x / radius_px).clamp(-1.0, 1.0),
            occluded: 0.0,
        })
    });
    block_error::region_error(&blocks, region)
}

fn read_reference(relative: &str) -> RgbaImage {
    let path = data_dir().join(relative);
    RgbaImage::read_exr(&path).unwrap_or_else(|error| panic!("{}: {error}", path.display()))
}

/// The opaque Lambertian control sphere: our render of the same scene must match the
/// path-traced image (0.8/π·cos⁺θ) — pixel mapping, light direction and units all at once.
#[test]
fn lambert_control_matches_path_traced() {
    let mut scene = load_scene("sphere_r35.toml");
    scene.camera.msaa_samples = 4;
    let mut assets = assets(&scene);
    assets.material = Material::Lambert { albedo: [0.8; 3] };
    let image = render_predictable(&scene, &assets);
    let reference = read_reference("lambert-control/sphere_r35.exr");
    let lit = sphere_block_error(&image, &reference, 1, Region::Lit);
    let (lit_error, blocks) = (lit.mean_relative_error, lit.blocks);
    println!(
        "Lambert control, lit side: mean relative error {:.3} % over {blocks} blocks",
        lit_error * 100.0
    );
    // The lit side is cos θ ≥ 0.26 (cdrf_core::block_error): 836 blocks, 0.039 % (before, the
    // blocks left of x = −20 px with a mean of per-block ratios: 1056 blocks, 0.041 %).
    assert!(blocks > 500);
    assert!(lit_error < 0.005, "Lambert control error {lit_error}");
    // Silhouette: the coverage-weighted centroid and area of the disk agree to a small
    // fraction of a pixel (the reference is black outside the disk and > 0 on its lit half).
    let centroid = |image: &RgbaImage, weight: &dyn Fn(&[f32; 4]) -> f32| {
        let (mut sx, mut sy, mut sw) = (0.0f64, 0.0f64, 0.0f64);
        for (index, pixel) in image.pixels.iter().enumerate() {
            let w = f64::from(weight(pixel));
            sx += w * (index as u32 % image.width) as f64;
            sy += w * (index as u32 / image.width) as f64;
            sw += w;
        }
        (sx / sw, sy / sw, sw)
    };
    let ours = centroid(&image, &|p| p[0]);
    let theirs = centroid(&reference, &|p| p[0]);
    println!(
        "radiance-weighted centroid: ours ({:.3}, {:.3}), path-traced ({:.3}, {:.3}); total {:.2} vs {:.2}",
        ours.0, ours.1, theirs.0, theirs.1, ours.2, theirs.2
    );
    // The mesh is an inscribed icosphere: its silhouette lies up to 0.14 px inside the circle,
    // and the sliver it misses on the left is the brightest part of the disk (θ = 0 there),
    // which moves our centroid ~0.1 px right and lowers the total ~0.2 %. A mapping error of
    // half a pixel would show as 0.5 px here and as ~0.4 % in the lit-side error above.
    assert!((ours.0 - theirs.0).abs() < 0.25 && (ours.1 - theirs.1).abs() < 0.05);
    assert!((ours.2 / theirs.2 - 1.0).abs() < 0.005);
}

/// The r = 35 mm wax sphere rendered with the measured LUT fitted from the wax photographs
/// (the bundled fit) against its path-traced image: mean relative error of 8 × 8 blocks
/// ([`cdrf_core::block_error`], the numbers `cdrf-viewer compare` gives for this sphere) on the
/// lit side (cos θ ≥ 0.26) and over the whole eroded disk. The Gaussian CDRF fitted to the same
/// photographs is printed beside it.
#[test]
fn measured_sphere_matches_path_traced() {
    let mut scene = load_scene("sphere_r35.toml");
    scene.camera.msaa_samples = 4;
    let mut assets = assets(&scene);
    let reference = read_reference("wax-spheres/sphere_r35.exr");
    assert!(
        matches!(assets.material, Material::Measured(_)),
        "sphere_r35.toml uses the measured model"
    );
    let gaussian = bundled_gaussian();
    let measured_image = render_predictable(&scene, &assets);
    assets.material = gaussian;
    let gaussian_image = render_predictable(&scene, &assets);
    let error = |image, region| sphere_block_error(image, &reference, 2, region);
    let (measured_lit, lit_blocks) = {
        let lit = error(&measured_image, Region::Lit);
        (lit.mean_relative_error, lit.blocks)
    };
    let gaussian_lit = error(&gaussian_image, Region::Lit).mean_relative_error;
    let (measured_all, all_blocks) = {
        let whole = error(&measured_image, Region::Whole);
        (whole.mean_relative_error, whole.blocks)
    };
    let gaussian_all = error(&gaussian_image, Region::Whole).mean_relative_error;
    println!(
        "r = 35 mm wax sphere vs path-traced, mean relative error of 8×8 blocks:\n\
         lit ({lit_blocks} blocks): measured {:.2} %, Gaussian {:.2} %\n\
         whole disk ({all_blocks} blocks): measured {:.2} %, Gaussian {:.2} %",
        measured_lit * 100.0,
        gaussian_lit * 100.0,
        measured_all * 100.0,
        gaussian_all * 100.0
    );
    // The fit reproduces this photograph to ~0.7 % (lit and terminator blocks, cdrf-fit's
    // report); the render adds half-float tables, tessellation and MSAA edges. 0.64 % when the
    // metric became cdrf_core::block_error (before, with a mean of per-block ratios over
    // x < −0.05 r: 0.77 %); the bound is the one set then.
    assert!(measured_lit < 0.015, "measured lit error {measured_lit}");
    // The whole disk includes the shadow side, where the photograph's noise is tens of per
    // cent per pixel. The bound was set at 7.5 % with a mean of per-block ratios, which those
    // nearly black, noisy blocks ruled; cdrf_core::block_error's ratio of sums weighs each
    // block by its radiance, so the whole disk now reads 0.75 % (Gaussian 61 % → 8.2 %). The
    // bound is kept as it was.
    assert!(
        measured_all < 0.10,
        "measured whole-disk error {measured_all}"
    );
    assert!(
        measured_all < 0.5 * gaussian_all,
        "the measured table must beat the Gaussian CDRF clearly"
    );
}

/// The shader's table lookup against cdrf-core's on the CPU: on the r = 35 mm sphere every
/// interior pixel must equal `E/π · f(1/35, θ) · g(θ, φ)` with θ, φ from the analytic normal —
/// checks the LUT and view-correction texture mapping, the curvature units through the model
/// transform, and the radiance convention at once.
#[test]
fn measured_shader_matches_the_cpu_table() {
    let mut scene = load_scene("sphere_r35.toml");
    scene.camera.msaa_samples = 1;
    let assets = assets(&scene);
    let Material::Measured(lut) = &assets.material else {
        panic!("measured scene expected")
    };
    for lut_filtering in [
        cdrf_render::LutFiltering::Manual,
        cdrf_render::LutFiltering::Hardware,
    ] {
        let settings = RenderSettings {
            options: Options {
                lut_filtering,
                ..Options::PREDICTABLE
            },
            ..RenderSettings::default()
        };
        let image = render_scene(software_device(), &scene, &assets, &settings)
            .unwrap_or_else(|error| panic!("{error}"))
            .image;
        compare_with_cpu_table(&image, lut, &format!("{lut_filtering:?} filtering"));
    }
}

fn compare_with_cpu_table(image: &RgbaImage, lut: &cdrf_core::CdrfLut, label: &str) {
    let (mut worst, mut sum, mut count) = (0.0f32, 0.0f32, 0);
    let radius_px = 230.0;
    for j in (0..512).step_by(7) {
        for i in (0..512).step_by(7) {
            let x = (i as f32 + 0.5 - 256.0) / radius_px;
            let y = (256.0 - j as f32 - 0.5) / radius_px;
            let rho2 = x * x + y * y;
            if rho2 > 0.9 * 0.9 {
                continue;
            }
            let normal = Vec3::new(x, y, (1.0 - rho2).sqrt());
            let theta = (-normal.x).clamp(-1.0, 1.0).acos();
            let phi = normal.z.clamp(-1.0, 1.0).acos();
            let expected = lut.evaluate(1.0 / 35.0, theta, phi, cdrf_core::Filter::Bilinear)
                / std::f32::consts::PI;
            let pixel = image.pixel(i, j);
            // Where the table is tiny (deep shadow) compare against a floor.
            for c in 0..3 {
                let floor = 0.002;
                let error = (pixel[c] - expected[c]).abs() / expected[c].max(floor);
                worst = worst.max(error);
                sum += error;
                count += 1;
            }
        }
    }
    println!(
        "shader ({label}) vs CPU table over {count} samples: mean relative difference {:.4} %, worst {:.3} %",
        100.0 * sum / count as f32,
        100.0 * worst
    );
    // Half-float texels (2⁻¹¹), interpolated mesh normals (the icosphere's facets), f32
    // trigonometry and, with the sampler, 8-bit filter weights; a wrong texel centre or a
    // wrong curvature row gives several per cent.
    assert!(
        sum / (count as f32) < 0.003,
        "{label}: mean {}",
        sum / count as f32
    );
    assert!(worst < 0.02, "{label}: worst {worst}");
}

/// The analytic Gaussian CDRF in the shader agrees with the tabulated one.
#[test]
fn analytic_gaussian_matches_tabulated() {
    let scene = golden_scene("sphere_r35.toml", 1);
    let mut assets = assets(&scene);
    assets.material = bundled_gaussian();
    // r = 35 mm: σκ ≈ 0.15 (the terminator quadrature); r = 10 mm: σκ ≈ 0.5 (the Fourier series).
    for radius_mm in [35.0, 10.0] {
        let mut scene = scene.clone();
        scene.mesh.transform.scale = radius_mm;
        compare_gaussian_evaluations(&scene, &assets, radius_mm);
    }
}

fn compare_gaussian_evaluations(scene: &Scene, assets: &SceneAssets, radius_mm: f32) {
    let mut rendered = Vec::new();
    for gaussian in [
        cdrf_render::GaussianEvaluation::Lut,
        cdrf_render::GaussianEvaluation::Analytic,
    ] {
        let settings = RenderSettings {
            options: Options {
                gaussian,
                ..Options::PREDICTABLE
            },
            ..RenderSettings::default()
        };
        rendered.push(
            render_scene(software_device(), scene, assets, &settings)
                .unwrap()
                .image,
        );
    }
    let (mut worst, mut peak) = (0.0f32, 0.0f32);
    for (p, q) in rendered[0].pixels.iter().zip(&rendered[1].pixels) {
        for c in 0..3 {
            worst = worst.max((p[c] - q[c]).abs());
            peak = peak.max(p[c]);
        }
    }
    println!(
        "Gaussian CDRF, r = {radius_mm} mm, tabulated vs analytic in the shader: largest difference {worst:e} (peak {peak})"
    );
    assert!(peak > 0.1);
    assert!(
        worst < 2e-3 * peak,
        "r = {radius_mm} mm: largest difference {worst}"
    );
}

/// One directional light from the image's left, irradiance 1.
const ONE_LIGHT: [cdrf_core::light::Light; 1] = [cdrf_core::light::Light::Directional(
    cdrf_core::light::DirectionalLight {
        to_light: Vec3::NEG_X,
        irradiance: [1.0; 3],
    },
)];

/// A renderer for `format` holding a 20 mm icosphere and a Lambert material, and an
/// orthographic view of it from +z — the fixture of the pass-contract tests.
struct LambertSphere {
    renderer: cdrf_render::Renderer,
    mesh: cdrf_render::MeshId,
    material: cdrf_render::MaterialId,
    view: cdrf_render::View,
}

impl LambertSphere {
    fn new(format: wgpu::TextureFormat, subdivisions: u32) -> Self {
        let HeadlessDevice { device, queue, .. } = software_device();
        let mut renderer = cdrf_render::Renderer::new(
            device,
            &cdrf_render::TargetDesc::new(format),
            Options::PREDICTABLE,
        );
        let mesh = Self::upload_mesh(&mut renderer, subdivisions);
        let material = renderer
            .create_material(
                device,
                queue,
                &cdrf_render::MaterialDesc::Lambert { albedo: [0.8; 3] },
            )
            .unwrap();
        let view = cdrf_render::View {
            clip_from_world: glam::camera::rh::proj::directx::orthographic(
                -25.0, 25.0, -25.0, 25.0, 0.0, 100.0,
            ) * glam::camera::rh::view::look_at_mat4(
                Vec3::new(0.0, 0.0, 50.0),
                Vec3::ZERO,
                Vec3::Y,
            ),
            to_camera: cdrf_render::ToCamera::Direction(Vec3::Z),
        };
        Self {
            renderer,
            mesh,
            material,
            view,
        }
    }

    /// Uploads the 20 mm icosphere (curvature 1/20 mm⁻¹ everywhere).
    fn upload_mesh(renderer: &mut cdrf_render::Renderer, subdivisions: u32) -> cdrf_render::MeshId {
        let sphere = cdrf_core::Mesh::icosphere(20.0, subdivisions);
        let curvature = vec![1.0 / 20.0; sphere.positions.len()];
        renderer
            .create_mesh(
                &software_device().device,
                &cdrf_render::MeshDesc::from_mesh(&sphere, &curvature),
            )
            .unwrap()
    }
}

/// A device without compute shaders or storage buffers (WebGL 2's limits say 0 storage
/// buffers): the renderer is made and draws the local models, and a frame that asks for the
/// per-vertex non-local terms (which the vertex terms pass computes) is refused with a
/// clear error instead of a validation error.
#[test]
fn a_device_without_compute_refuses_the_vertex_terms_only() {
    use cdrf_render::{
        Draw, FrameDesc, MaterialDesc, MeshDesc, PrepareError, Renderer, TargetDesc,
    };
    fn block_on<F: Future>(future: F) -> F::Output {
        let mut future = std::pin::pin!(future);
        let mut context = std::task::Context::from_waker(std::task::Waker::noop());
        loop {
            if let std::task::Poll::Ready(value) = future.as_mut().poll(&mut context) {
                return value;
            }
            std::thread::yield_now();
        }
    }
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle());
    let adapter = block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN))
        .into_iter()
        .find(|adapter| adapter.get_info().device_type == wgpu::DeviceType::Cpu)
        .expect("lavapipe (see README)");
    let limits = wgpu::Limits {
        max_storage_buffers_per_shader_stage: 0,
        ..wgpu::Limits::default().using_resolution(adapter.limits())
    };
    let (device, queue) = block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        required_limits: limits,
        ..Default::default()
    }))
    .expect("a device with fewer limits than the adapter's");
    let target = TargetDesc::new(wgpu::TextureFormat::Rgba8UnormSrgb);
    let mut renderer = Renderer::new(&device, &target, Options::PREDICTABLE);
    let sphere = cdrf_core::Mesh::icosphere(20.0, 2);
    let curvature = vec![1.0 / 20.0; sphere.positions.len()];
    let mesh = renderer
        .create_mesh(&device, &MeshDesc::from_mesh(&sphere, &curvature))
        .unwrap();
    let material = renderer
        .create_material(&device, &queue, &MaterialDesc::Lambert { albedo: [0.8; 3] })
        .unwrap();
    let draws = [Draw::new(mesh, material, glam::Mat4::IDENTITY)];
    let view = LambertSphere::new(wgpu::TextureFormat::Rgba8UnormSrgb, 1).view;
    let frame = |non_local| FrameDesc {
        view,
        lights: &ONE_LIGHT,
        exposure: 1.0,
        draws: &draws,
        non_local,
        mm_per_world_unit: 1.0,
        environment: None,
    };
    renderer
        .prepare(&device, &queue, &frame(NonLocal::OFF))
        .unwrap();
    // Lambert's shadows are per pixel: no vertex terms.
    let shadows = NonLocal {
        shadows: true,
        ..NonLocal::OFF
    };
    renderer.prepare(&device, &queue, &frame(shadows)).unwrap();
    // Its inter-reflection is per vertex.
    let error = renderer
        .prepare(&device, &queue, &frame(NonLocal::ALL))
        .unwrap_err();
    println!("{error}");
    assert!(
        matches!(error, PrepareError::NoComputeShaders { index: 0 }),
        "{error}"
    );
}

/// The middleware contract: `render` before `prepare` draws nothing and does not panic; a
/// failed `prepare` draws nothing; a new target gets its own pipeline.
#[test]
fn render_before_prepare_and_after_errors_draws_nothing() {
    use cdrf_core::light::{DirectionalLight, Light};
    use cdrf_render::{Draw, FrameDesc, PrepareError, Renderer, TargetDesc};
    let HeadlessDevice { device, queue, .. } = software_device();
    let format = wgpu::TextureFormat::Rgba8UnormSrgb;
    let LambertSphere {
        mut renderer,
        mesh,
        material,
        view,
    } = LambertSphere::new(format, 2);
    let draw_into = |renderer: &Renderer, format| -> Vec<u8> {
        let image = record_and_read_back(renderer, format, None, 64, 64);
        image.pixels.into_iter().flatten().collect()
    };
    let lit_bytes = |bytes: &[u8]| bytes.iter().filter(|&&b| b != 0).count();

    assert_eq!(
        lit_bytes(&draw_into(&renderer, format)),
        0,
        "render before prepare drew"
    );

    let draws = [Draw::new(mesh, material, glam::Mat4::IDENTITY)];
    let frame = |lights: &'static [Light]| FrameDesc {
        view,
        lights,
        exposure: 1.0,
        draws: &draws,
        non_local: NonLocal::OFF,
        mm_per_world_unit: 1.0,
        environment: None,
    };
    renderer.prepare(device, queue, &frame(&ONE_LIGHT)).unwrap();
    let drawn = lit_bytes(&draw_into(&renderer, format));
    assert!(drawn > 1000, "{drawn} bytes drawn");

    // Too many lights: an error, and nothing drawn afterwards.
    static MANY: [Light; 17] = [Light::Directional(DirectionalLight {
        to_light: Vec3::NEG_X,
        irradiance: [1.0; 3],
    }); 17];
    let error = renderer.prepare(device, queue, &frame(&MANY)).unwrap_err();
    assert!(
        matches!(error, PrepareError::TooManyLights { count: 17 }),
        "{error}"
    );
    println!("prepare error: {error}");
    assert_eq!(lit_bytes(&draw_into(&renderer, format)), 0);

    // A removed mesh: an error naming the draw.
    renderer.remove_mesh(mesh);
    let error = renderer
        .prepare(device, queue, &frame(&ONE_LIGHT))
        .unwrap_err();
    println!("prepare error: {error}");
    assert!(matches!(error, PrepareError::UnknownMesh { index: 0, .. }));

    // Another target format: a pipeline of its own, same picture (sRGB encoding either way).
    let mesh = LambertSphere::upload_mesh(&mut renderer, 2);
    let draws = [Draw::new(mesh, material, glam::Mat4::IDENTITY)];
    let frame = FrameDesc {
        view,
        lights: &ONE_LIGHT,
        exposure: 1.0,
        draws: &draws,
        non_local: NonLocal::OFF,
        mm_per_world_unit: 1.0,
        environment: None,
    };
    renderer.prepare(device, queue, &frame).unwrap();
    let srgb = draw_into(&renderer, format);
    let unorm_format = wgpu::TextureFormat::Rgba8Unorm;
    renderer.set_target(&TargetDesc::new(unorm_format));
    assert_eq!(
        lit_bytes(&draw_into(&renderer, unorm_format)),
        0,
        "stale draws after set_target"
    );
    renderer.prepare(device, queue, &frame).unwrap();
    let unorm = draw_into(&renderer, unorm_format);
    let worst = srgb
        .iter()
        .zip(&unorm)
        .map(|(a, b)| a.abs_diff(*b))
        .max()
        .unwrap();
    println!("Rgba8UnormSrgb vs Rgba8Unorm target: largest byte difference {worst}");
    assert!(worst <= 1);
}

/// Bad scene input gives an error naming the file and the problem, not a panic.
#[test]
fn bad_scene_files_are_reported() {
    let dir = tempfile::tempdir().unwrap();
    let scene_path = dir.path().join("bad.toml");
    let original = std::fs::read_to_string(data_dir().join("scenes/sphere_r35.toml")).unwrap();
    let sphere = data_dir().join("sphere/unit_sphere.obj");
    let fixed = original
        .replace("../sphere/unit_sphere.obj", &sphere.display().to_string())
        .replace("../wax-fit/measured.exr", "missing.exr");
    std::fs::write(&scene_path, &fixed).unwrap();
    let error = render_scene_file(&scene_path).unwrap_err();
    println!("{error}");
    assert!(
        error.contains("[shading] lut") && error.contains("missing.exr"),
        "{error}"
    );

    std::fs::write(&scene_path, fixed.replace("width = 512", "width = 0")).unwrap();
    let error = render_scene_file(&scene_path).unwrap_err();
    println!("{error}");
    assert!(
        error.contains("bad.toml") && error.contains("[camera] width"),
        "{error}"
    );
}

fn render_scene_file(path: &std::path::Path) -> Result<RgbaImage, String> {
    let scene = Scene::load(path).map_err(|e| e.to_string())?;
    let assets = scene.load_assets().map_err(|e| e.to_string())?;
    render_scene(
        software_device(),
        &scene,
        &assets,
        &RenderSettings::default(),
    )
    .map(|r| r.image)
    .map_err(|e| e.to_string())
}

/// A perspective camera: the sphere at the target lands centred, with the size the field of
/// view predicts (radius on screen = r / (d·tan(fov/2)) · H/2 for a sphere seen from d ≫ r,
/// here corrected for the exact tangent cone).
#[test]
fn perspective_camera_frames_the_sphere() {
    let mut scene = golden_scene("sphere_r35.toml", 4);
    scene.camera.projection = cdrf_core::scene::Projection::Perspective {
        vertical_fov_deg: 20.0,
    };
    let image = render_predictable(&scene, &assets(&scene));
    let (mut sum, mut sx, mut sy) = (0.0f64, 0.0f64, 0.0f64);
    for (index, pixel) in image.pixels.iter().enumerate() {
        let a = f64::from(pixel[3]);
        sum += a;
        sx += a * ((index as u32 % image.width) as f64 + 0.5);
        sy += a * ((index as u32 / image.width) as f64 + 0.5);
    }
    let (cx, cy) = (sx / sum, sy / sum);
    // Apparent angular radius of a sphere of radius r at distance d: asin(r/d).
    let (r, d) = (35.0f64, 450.0f64);
    let half = f64::from(GOLDEN_SIZE) / 2.0;
    let radius_px = (r / d).asin().tan() / 10f64.to_radians().tan() * half;
    let expected_area = std::f64::consts::PI * radius_px * radius_px;
    println!(
        "perspective: coverage centroid ({cx:.2}, {cy:.2}), area {sum:.0} px², expected {expected_area:.0}"
    );
    assert!((cx - half).abs() < 0.2 && (cy - half).abs() < 0.2);
    assert!(
        (sum / expected_area - 1.0).abs() < 0.02,
        "area {sum} vs {expected_area}"
    );
}

/// Input the device or the maths cannot use is an error from `prepare`, never a panic: a
/// mirroring transform, a zero camera direction, a negative exposure, and a target the device
/// cannot render to (an integer colour format, 3 MSAA samples).
#[test]
fn prepare_rejects_unusable_input() {
    use cdrf_render::{Draw, FrameDesc, PrepareError, TargetDesc, ToCamera, View};
    let HeadlessDevice { device, queue, .. } = software_device();
    let format = wgpu::TextureFormat::Rgba8UnormSrgb;
    let LambertSphere {
        mut renderer,
        mesh,
        material,
        view,
    } = LambertSphere::new(format, 1);
    let draw = |world_from_model| [Draw::new(mesh, material, world_from_model)];
    let ok = draw(glam::Mat4::IDENTITY);
    let frame = |view, exposure, draws| FrameDesc {
        view,
        lights: &ONE_LIGHT,
        exposure,
        draws,
        non_local: NonLocal::OFF,
        mm_per_world_unit: 1.0,
        environment: None,
    };
    renderer
        .prepare(device, queue, &frame(view, 1.0, &ok))
        .unwrap();

    let mirrored = draw(glam::Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)));
    let error = renderer
        .prepare(device, queue, &frame(view, 1.0, &mirrored))
        .unwrap_err();
    println!("{error}");
    assert!(matches!(error, PrepareError::BadTransform { index: 0 }));

    let nowhere = View {
        to_camera: ToCamera::Direction(Vec3::ZERO),
        ..view
    };
    let error = renderer
        .prepare(device, queue, &frame(nowhere, 1.0, &ok))
        .unwrap_err();
    println!("{error}");
    assert!(matches!(error, PrepareError::BadView));
    // An exposure that is negative, not finite or absurd (1e38 was accepted) is an error
    // naming it.
    for exposure in [
        -1.0,
        f32::NAN,
        f32::INFINITY,
        1e38,
        cdrf_render::MAX_EXPOSURE * 2.0,
    ] {
        let error = renderer
            .prepare(device, queue, &frame(view, exposure, &ok))
            .unwrap_err();
        println!("{error}");
        assert!(
            matches!(error, PrepareError::BadExposure { exposure: e } if e.to_bits() == exposure.to_bits()),
            "{error}"
        );
    }
    renderer
        .prepare(device, queue, &frame(view, cdrf_render::MAX_EXPOSURE, &ok))
        .unwrap();

    // The non-local terms need millimetres per world unit: zero or NaN is an error.
    for mm_per_world_unit in [0.0, f32::NAN] {
        let error = renderer
            .prepare(
                device,
                queue,
                &FrameDesc {
                    non_local: NonLocal {
                        shadows: true,
                        ..NonLocal::OFF
                    },
                    mm_per_world_unit,
                    environment: None,
                    ..frame(view, 1.0, &ok)
                },
            )
            .unwrap_err();
        println!("{error}");
        assert!(matches!(error, PrepareError::BadUnits { .. }), "{error}");
    }
    // Point and spot lights: unusable values name the light; a point light needs the units
    // for its 1/d² even without non-local terms.
    use cdrf_core::light::{Light, PointLight, SpotLight};
    let point = PointLight {
        position: Vec3::new(0.0, 0.0, 100.0),
        intensity: [1000.0; 3],
    };
    let spot = SpotLight {
        position: Vec3::new(0.0, 0.0, 100.0),
        direction: Vec3::NEG_Z,
        intensity: [1000.0; 3],
        inner_angle_rad: 0.1,
        outer_angle_rad: 0.2,
    };
    let bad_lights = [
        Light::Point(PointLight {
            position: Vec3::new(f32::NAN, 0.0, 0.0),
            ..point
        }),
        Light::Point(PointLight {
            intensity: [-1.0, 0.0, 0.0],
            ..point
        }),
        Light::Spot(SpotLight {
            direction: Vec3::ZERO,
            ..spot
        }),
        Light::Spot(SpotLight {
            outer_angle_rad: 0.05,
            ..spot
        }),
        Light::Spot(SpotLight {
            outer_angle_rad: 2.0,
            ..spot
        }),
    ];
    for bad in bad_lights {
        let lights = [ONE_LIGHT[0], bad];
        let error = renderer
            .prepare(
                device,
                queue,
                &FrameDesc {
                    lights: &lights,
                    ..frame(view, 1.0, &ok)
                },
            )
            .unwrap_err();
        println!("{error}");
        assert!(
            matches!(error, PrepareError::BadLight { index: 1, .. }),
            "{error}"
        );
    }
    let lights = [Light::Point(point), Light::Spot(spot)];
    let error = renderer
        .prepare(
            device,
            queue,
            &FrameDesc {
                lights: &lights,
                mm_per_world_unit: 0.0,
                environment: None,
                ..frame(view, 1.0, &ok)
            },
        )
        .unwrap_err();
    assert!(matches!(error, PrepareError::BadUnits { .. }), "{error}");
    renderer
        .prepare(
            device,
            queue,
            &FrameDesc {
                lights: &lights,
                ..frame(view, 1.0, &ok)
            },
        )
        .unwrap();
    // With them on, prepare returns the shadow pass to submit; with them off, nothing.
    let shadow_pass = renderer
        .prepare(
            device,
            queue,
            &FrameDesc {
                non_local: NonLocal {
                    shadows: true,
                    transmission: true,
                    ..NonLocal::OFF
                },
                ..frame(view, 1.0, &ok)
            },
        )
        .unwrap();
    assert_eq!(shadow_pass.len(), 1);
    queue.submit(shadow_pass);
    assert!(
        renderer
            .prepare(device, queue, &frame(view, 1.0, &ok))
            .unwrap()
            .is_empty()
    );

    for target in [
        TargetDesc::new(wgpu::TextureFormat::Rgba8Uint),
        TargetDesc::new(format).with_sample_count(3),
    ] {
        renderer.set_target(&target);
        let error = renderer
            .prepare(device, queue, &frame(view, 1.0, &ok))
            .unwrap_err();
        println!("{error}");
        assert!(matches!(error, PrepareError::Pipeline { .. }), "{error}");
    }
}
