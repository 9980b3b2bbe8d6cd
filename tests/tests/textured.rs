//! Textured glTF assets (issue 19) on a software adapter, with the test asset
//! `tests/fixtures/textured.glb` (made by `cargo run -p cdrf-core --example make_textured_asset`)
//! and its scene `tests/fixtures/textured.toml`: the base colour tints the subsurface light by
//! exactly its linear value (the texture decoded from sRGB), a flat normal map changes nothing
//! and the bump map does, the surface's roughness sets the specular lobe, bad draws are refused
//! with what is wrong, and a golden image of the whole asset.

use std::path::PathBuf;

use cdrf_core::glam::{Mat4, Vec3};
use cdrf_core::image_file::{RgbaImage, srgb_to_linear};
use cdrf_core::mesh::surface::{SurfaceMaterial, TextureImage};
use cdrf_core::scene::{Scene, SceneAssets};
use cdrf_render::{
    DirectionalLight, Draw, FrameDesc, MaterialDesc, MeshDesc, NonLocal, Options, PrepareError,
    Renderer, SurfaceDesc, TargetDesc, ToCamera, View, wgpu,
};
use cdrf_tests::golden::{Srgb8Image, Tolerance, assert_golden};
use cdrf_tests::{render_predictable, software_device};

/// Set on lavapipe (LLVM 15, 256 bits): identical images measure 0 / 0.
const TOLERANCE: Tolerance = Tolerance {
    mean_flip: 0.005,
    max_flip_fraction_above_0_1: 0.002,
};

/// The first image column that sees only the small sphere (centred at x = 55 mm, r = 15 mm;
/// the large one ends near column 220 of 384).
const SMALL_SPHERE_FIRST_COLUMN: u32 = 245;

fn fixture(name: &str) -> PathBuf {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name);
    assert!(path.is_file(), "test fixture {} is missing", path.display());
    path
}

/// The textured scene and its assets (two primitives, two materials, MikkTSpace tangents).
fn textured() -> (Scene, SceneAssets) {
    let scene = Scene::load(fixture("textured.toml")).unwrap_or_else(|e| panic!("{e}"));
    let assets = scene.load_assets().unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(assets.surfaces.primitives.len(), 2);
    assert_eq!(assets.surfaces.materials.len(), 2);
    assert!(
        assets.surfaces.tangents.is_some(),
        "a normal map brings tangents"
    );
    (scene, assets)
}

fn srgb8(image: &RgbaImage) -> Srgb8Image {
    Srgb8Image {
        width: image.width,
        height: image.height,
        pixels: image.to_srgb8(),
    }
}

/// Per-pixel, per-channel ratio `a / b` where `b` is lit (every channel above 0.02) and both
/// cover the pixel fully, with the pixel's column.
fn ratios(a: &RgbaImage, b: &RgbaImage) -> Vec<(u32, [f32; 3])> {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .enumerate()
        .filter(|(_, (p, q))| p[3] >= 1.0 && q[3] >= 1.0 && q[..3].iter().all(|&c| c > 0.02))
        .map(|(i, (p, q))| (i as u32 % a.width, [p[0] / q[0], p[1] / q[1], p[2] / q[2]]))
        .collect()
}

/// Without the specular layer and the normal map, the textured render is the bare one times the
/// base colour: (0.8, 0.9, 1.0) on the small sphere; on the checker, either 1 (white squares) or
/// the light orange (255, 200, 150) decoded from sRGB — (1, 0.578, 0.305), not the raw
/// (1, 0.784, 0.588) — with only the filtered square edges between.
#[test]
fn base_colour_tints_the_subsurface_light_by_its_linear_value() {
    let (mut scene, mut assets) = textured();
    scene.specular = None;
    assets.surfaces.materials[0].normal_texture = None;
    let tinted = render_predictable(&scene, &assets);
    let mut bare_assets = assets.clone();
    for material in &mut bare_assets.surfaces.materials {
        *material = SurfaceMaterial::default();
    }
    let bare = render_predictable(&scene, &bare_assets);

    let all = ratios(&tinted, &bare);
    let small: Vec<[f32; 3]> = all
        .iter()
        .filter(|(column, _)| *column >= SMALL_SPHERE_FIRST_COLUMN)
        .map(|(_, r)| *r)
        .collect();
    assert!(
        small.len() > 2000,
        "{} pixels on the small sphere",
        small.len()
    );
    let tint = [0.8, 0.9, 1.0];
    let worst = small
        .iter()
        .flat_map(|r| (0..3).map(move |c| (r[c] / tint[c] - 1.0).abs()))
        .fold(0.0f32, f32::max);
    println!(
        "small sphere: {} pixels, worst tint error {worst:.2e}",
        small.len()
    );
    assert!(worst < 0.01, "worst tint error {worst}");

    let orange = [
        1.0,
        srgb_to_linear(200.0 / 255.0),
        srgb_to_linear(150.0 / 255.0),
    ];
    let near =
        |r: &[f32; 3], target: &[f32; 3]| (0..3).all(|c| (r[c] / target[c] - 1.0).abs() < 0.02);
    let checker: Vec<[f32; 3]> = all
        .iter()
        .filter(|(column, _)| *column < 200)
        .map(|(_, r)| *r)
        .collect();
    let white = checker.iter().filter(|r| near(r, &[1.0; 3])).count();
    let oranges = checker.iter().filter(|r| near(r, &orange)).count();
    let n = checker.len() as f32;
    println!(
        "checker: {} pixels, {:.1} % white, {:.1} % orange (linear {orange:?})",
        checker.len(),
        100.0 * white as f32 / n,
        100.0 * oranges as f32 / n
    );
    assert!(white as f32 > 0.25 * n && oranges as f32 > 0.25 * n);
    // Squares are ~20 px across in this view and their filtered edges 2–3 px: about a quarter
    // of the pixels lie on an edge, every one of them between the two colours.
    assert!(
        (white + oranges) as f32 > 0.7 * n,
        "most pixels lie inside a square"
    );
    let between = checker
        .iter()
        .all(|r| (0..3).all(|c| r[c] > 0.98 * orange[c] && r[c] < 1.02));
    assert!(between, "every checker pixel is white, orange or between");
}

/// A flat normal map (every texel (128, 128, 255)) leaves the image as it is without one; the
/// asset's bump map changes it.
#[test]
fn a_flat_normal_map_changes_nothing_and_the_bump_map_does() {
    let (mut scene, assets) = textured();
    scene.specular = None;
    let bumped = render_predictable(&scene, &assets);
    let mut flat_assets = assets.clone();
    let normal = flat_assets.surfaces.materials[0]
        .normal_texture
        .as_mut()
        .expect("the checker material has a normal map");
    normal.image = TextureImage {
        width: 4,
        height: 4,
        rgba8: vec![[128, 128, 255, 255]; 16],
        ..normal.image.clone()
    };
    let flat = render_predictable(&scene, &flat_assets);
    let mut none_assets = assets.clone();
    none_assets.surfaces.materials[0].normal_texture = None;
    let none = render_predictable(&scene, &none_assets);

    let mean_difference = |a: &RgbaImage, b: &RgbaImage| {
        let sum: f64 = a
            .pixels
            .iter()
            .zip(&b.pixels)
            .map(|(p, q)| (0..3).map(|c| f64::from((p[c] - q[c]).abs())).sum::<f64>())
            .sum();
        sum / (3.0 * a.pixels.len() as f64)
    };
    let mean: f64 = none
        .pixels
        .iter()
        .map(|p| f64::from(p[0] + p[1] + p[2]) / 3.0)
        .sum::<f64>()
        / none.pixels.len() as f64;
    // (128 encodes 0.0039, not 0: the flat map tilts normals by 0.3°.)
    let flat_vs_none = mean_difference(&flat, &none) / mean;
    let bumped_vs_none = mean_difference(&bumped, &none) / mean;
    println!(
        "mean |difference| / mean radiance: flat {flat_vs_none:.2e}, bumps {bumped_vs_none:.3}"
    );
    assert!(flat_vs_none < 0.005, "{flat_vs_none}");
    assert!(bumped_vs_none > 0.05, "{bumped_vs_none}");
}

/// The small sphere's glTF roughness 0.3 (Beckmann α = 0.09) makes a highlight several times
/// brighter than the scene's α = 0.3, which a surface without roughness keeps.
#[test]
fn the_surface_roughness_sets_the_specular_lobe() {
    let (scene, assets) = textured();
    let brightest = |image: &RgbaImage| {
        image
            .pixels
            .iter()
            .enumerate()
            .filter(|(i, _)| *i as u32 % image.width >= SMALL_SPHERE_FIRST_COLUMN)
            .map(|(_, p)| p[0] + p[1] + p[2])
            .fold(0.0f32, f32::max)
    };
    let glossy = brightest(&render_predictable(&scene, &assets));
    let mut default_assets = assets.clone();
    let tint = default_assets.surfaces.materials[1].base_color_factor;
    default_assets.surfaces.materials[1] = SurfaceMaterial {
        base_color_factor: tint,
        ..SurfaceMaterial::default()
    };
    let broad = brightest(&render_predictable(&scene, &default_assets));
    println!("brightest pixel of the small sphere: α = 0.09 {glossy:.3}, α = 0.3 {broad:.3}");
    assert!(glossy > 2.0 * broad, "{glossy} vs {broad}");
}

/// Draws with a triangle range outside their mesh, or naming a removed surface, are refused
/// by `prepare` with the draw and the problem.
#[test]
fn bad_draws_are_refused_with_what_is_wrong() {
    let host = software_device();
    let (device, queue) = (&host.device, &host.queue);
    let mut renderer = Renderer::new(
        device,
        &TargetDesc::new(wgpu::TextureFormat::Rgba16Float),
        Options::default(),
    );
    let sphere = cdrf_core::Mesh::icosphere(20.0, 2);
    let triangles = sphere.triangles.len() as u32;
    let curvature = vec![0.05; sphere.positions.len()];
    let mesh = renderer
        .create_mesh(device, &MeshDesc::from_mesh(&sphere, &curvature))
        .unwrap();
    let material = renderer
        .create_material(device, queue, &MaterialDesc::Lambert { albedo: [0.8; 3] })
        .unwrap();
    let surface = renderer
        .create_surface(device, queue, &SurfaceDesc::default())
        .unwrap();
    let lights = [DirectionalLight {
        to_light: Vec3::Z,
        irradiance: [1.0; 3],
    }
    .into()];
    let frame_with = |renderer: &mut Renderer, draw: Draw| {
        let draws = [draw];
        let frame = FrameDesc {
            view: View {
                clip_from_world: Mat4::IDENTITY,
                to_camera: ToCamera::Direction(Vec3::Z),
            },
            lights: &lights,
            exposure: 1.0,
            draws: &draws,
            non_local: NonLocal::OFF,
            mm_per_world_unit: 1.0,
            environment: None,
        };
        renderer.prepare(device, queue, &frame).map(|_| ())
    };
    let whole = Draw::new(mesh, material, Mat4::IDENTITY);
    frame_with(
        &mut renderer,
        whole
            .clone()
            .with_triangles(0..triangles)
            .with_surface(surface),
    )
    .unwrap();
    let error = frame_with(
        &mut renderer,
        whole.clone().with_triangles(10..triangles + 1),
    )
    .unwrap_err();
    assert!(matches!(error, PrepareError::BadTriangles { index: 0, .. }));
    assert!(
        error
            .to_string()
            .contains(&format!("but the mesh has {triangles}")),
        "{error}"
    );
    assert!(matches!(
        frame_with(&mut renderer, whole.clone().with_triangles(5..5)),
        Err(PrepareError::BadTriangles { .. })
    ));
    renderer.remove_surface(surface);
    let error = frame_with(&mut renderer, whole.with_surface(surface)).unwrap_err();
    assert!(
        matches!(error, PrepareError::UnknownSurface { index: 0, .. }),
        "{error}"
    );
}

/// The whole asset: checker tint, bumps, two roughnesses, one draw per primitive.
#[test]
fn textured_asset_golden() {
    let (scene, assets) = textured();
    let image = render_predictable(&scene, &assets);
    assert_golden("textured_glb", &srgb8(&image), TOLERANCE);
}
