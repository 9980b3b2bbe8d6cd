//! Shared helpers for the workspace integration tests in `tests/tests/`.

use std::path::PathBuf;
use std::sync::OnceLock;

use cdrf_core::glam::Vec3;
use cdrf_core::image_file::RgbaImage;
use cdrf_core::scene::{Projection, Scene, SceneAssets};
use cdrf_core::{Curvature, CurvatureOptions, Mesh, curvature_per_mm};
use cdrf_render::headless::{
    AdapterPreference, HEADLESS_COLOR_FORMAT, HEADLESS_DEPTH_FORMAT, HeadlessDevice,
    RenderSettings, render_scene,
};
use cdrf_render::offscreen::OffscreenTarget;
use cdrf_render::readback::TextureReadback;
use cdrf_render::{Options, TargetDesc, wgpu};

pub mod golden;

/// The repository's bundled data folder (`data/`), checked to exist: a missing fixture folder is
/// a failure, never a silently skipped test.
///
/// # Panics
/// If the folder is missing.
pub fn data_dir() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data");
    assert!(
        dir.is_dir(),
        "bundled data folder {} is missing: the repository checkout is incomplete",
        dir.display()
    );
    dir
}

/// The software adapter (lavapipe) the golden-image tests render on, created once per test
/// binary; prints its description.
///
/// # Panics
/// If no software adapter is available.
pub fn software_device() -> &'static HeadlessDevice {
    static DEVICE: OnceLock<HeadlessDevice> = OnceLock::new();
    DEVICE.get_or_init(|| {
        let device = HeadlessDevice::new(AdapterPreference::Software)
            .unwrap_or_else(|error| panic!("{error}"));
        println!("adapter: {}", device.adapter_description());
        device
    })
}

/// Renders `scene` with its loaded `assets` on [`software_device`] with
/// [`Options::PREDICTABLE`] (the same on every adapter up to rounding).
///
/// # Panics
/// If rendering fails.
pub fn render_predictable(scene: &Scene, assets: &SceneAssets) -> RgbaImage {
    let settings = RenderSettings {
        options: Options::PREDICTABLE,
        ..RenderSettings::default()
    };
    render_scene(software_device(), scene, assets, &settings)
        .unwrap_or_else(|error| panic!("{error}"))
        .image
}

/// The radius of the sphere of `data/scenes/sphere_r35.toml`, mm (world units).
pub const SPHERE_RADIUS_MM: f32 = 35.0;

/// The bundled scene `data/scenes/<name>.toml` at `size` × `size` px (its own MSAA), with its
/// assets loaded.
///
/// # Panics
/// If the scene or its assets cannot be loaded.
pub fn bundled_scene(name: &str, size: u32) -> (Scene, SceneAssets) {
    let path = data_dir().join(format!("scenes/{name}.toml"));
    let mut scene = Scene::load(&path).unwrap_or_else(|error| panic!("{error}"));
    scene.camera.width = size;
    scene.camera.height = size;
    let assets = scene
        .load_assets()
        .unwrap_or_else(|error| panic!("{error}"));
    (scene, assets)
}

/// The r = 35 mm sphere scene (`data/scenes/sphere_r35.toml`: world units are mm, an
/// orthographic camera along −z) at `size` × `size` px, no MSAA, with its assets loaded.
///
/// # Panics
/// If the scene or its assets cannot be loaded.
pub fn sphere_scene(size: u32) -> (Scene, SceneAssets) {
    let (mut scene, assets) = bundled_scene("sphere_r35", size);
    scene.camera.msaa_samples = 1;
    (scene, assets)
}

/// Per pixel of [`sphere_scene`] at least 2 px inside the disk: the point it sees on the ideal
/// sphere of radius [`SPHERE_RADIUS_MM`] about the origin, and that point's normal.
///
/// # Panics
/// If the scene's camera is not orthographic.
pub fn sphere_points(scene: &Scene) -> Vec<Option<(Vec3, Vec3)>> {
    let Projection::Orthographic { half_height } = scene.camera.projection else {
        panic!("the sphere scene is orthographic");
    };
    let (width, height) = (scene.camera.width, scene.camera.height);
    let mm_per_px = 2.0 * half_height / height as f32;
    let inner = SPHERE_RADIUS_MM - 2.0 * mm_per_px;
    (0..width * height)
        .map(|index| {
            let x = ((index % width) as f32 + 0.5 - width as f32 / 2.0) * mm_per_px;
            let y = (height as f32 / 2.0 - (index / width) as f32 - 0.5) * mm_per_px;
            let r2 = x * x + y * y;
            (r2 < inner * inner).then(|| {
                let p = Vec3::new(x, y, (SPHERE_RADIUS_MM * SPHERE_RADIUS_MM - r2).sqrt());
                (p, p / SPHERE_RADIUS_MM)
            })
        })
        .collect()
}

/// Meshes moved by their offsets as one, with their curvature (mm⁻¹, mesh units mm): the scene
/// format draws one mesh; a second object is just more triangles.
///
/// # Panics
/// If a part's curvature cannot be estimated.
pub fn merged(parts: &[(Mesh, Vec3)]) -> (Mesh, Curvature) {
    let mut mesh = Mesh {
        positions: Vec::new(),
        normals: Vec::new(),
        uvs: None,
        triangles: Vec::new(),
    };
    let mut curvature = Curvature::default();
    for (part, offset) in parts {
        let base = mesh.positions.len() as u32;
        let part_curvature = curvature_per_mm(part, &CurvatureOptions::new(1.0))
            .unwrap_or_else(|error| panic!("{error}"));
        curvature.mean_per_mm.extend(part_curvature.mean_per_mm);
        curvature
            .anisotropy_per_mm
            .extend(part_curvature.anisotropy_per_mm);
        mesh.positions
            .extend(part.positions.iter().map(|p| *p + *offset));
        mesh.normals.extend(&part.normals);
        mesh.triangles
            .extend(part.triangles.iter().map(|t| t.map(|i| i + base)));
    }
    (mesh, curvature)
}

/// The headless target (`Rgba16Float`, 4× MSAA, depth) for tests that drive a
/// [`cdrf_render::Renderer`] themselves.
pub fn headless_target() -> TargetDesc {
    TargetDesc::new(HEADLESS_COLOR_FORMAT)
        .with_sample_count(4)
        .with_depth(HEADLESS_DEPTH_FORMAT)
}

/// Submits `commands` (a `prepare`'s), then a pass into `target` cleared to transparent in
/// which `record` draws, and reads the image back (linear RGBA, row 0 at the top) on
/// [`software_device`].
///
/// # Panics
/// If the read-back fails.
pub fn draw_and_read(
    target: &OffscreenTarget,
    mut commands: Vec<wgpu::CommandBuffer>,
    record: impl FnOnce(&mut wgpu::RenderPass<'_>),
) -> RgbaImage {
    let device = software_device();
    let mut encoder = device
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
    record(&mut target.begin_pass(&mut encoder, wgpu::Color::TRANSPARENT));
    let readback = TextureReadback::record(&device.device, &mut encoder, target.resolved())
        .unwrap_or_else(|error| panic!("{error}"));
    commands.push(encoder.finish());
    device.queue.submit(commands);
    readback
        .read_rgba16f(&device.device)
        .unwrap_or_else(|error| panic!("{error}"))
}
