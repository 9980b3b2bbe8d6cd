//! The viewer's UI on lavapipe through egui_kittest (its wgpu renderer, target `Rgba8Unorm`,
//! which is not sRGB: the 3D view's composite must encode): snapshots of the default layout,
//! split mode, the curvature view and an error after dropping a bad file, compared with FLIP
//! against `tests/golden/viewer_*.png` like the renderer's golden images; plus behaviour that
//! a snapshot cannot show (the pointer read-out, live σ edits, HiDPI, tiny windows).
//!
//! `UPDATE_SNAPSHOTS=1 cargo test -p cdrf-tests --test viewer` writes missing or changed
//! references. A missing reference fails.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use cdrf_core::image_file::linear_to_srgb;
use cdrf_core::light::NonLocal;
use cdrf_core::specular::{DEFAULT_IOR, DEFAULT_ROUGHNESS_ALPHA, SpecularLayer};
use cdrf_tests::data_dir;
use cdrf_tests::golden::{Srgb8Image, Tolerance, assert_golden};
use cdrf_viewer::app::BACKGROUND;
use cdrf_viewer::{Compare, LightKind, StartupFiles, ViewerApp};
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use egui_kittest::wgpu::{WgpuTestRenderer, create_render_state, default_wgpu_setup};

/// Snapshot size in points (and pixels): wide enough for both panels and a 3D view.
const SIZE: egui::Vec2 = egui::vec2(1024.0, 640.0);

/// Set on llvmpipe (LLVM 15.0.6, Mesa 22.3.6), where the snapshots are byte-identical from run
/// to run (timings are hidden). A changed label or a moved widget gives a mean FLIP of
/// 0.0005–0.002 over the whole UI but thousands of pixels above 0.1, so the second limit is
/// the strict one: at most 0.05 % of the pixels (≈ 330) may differ visibly.
const TOLERANCE: Tolerance = Tolerance {
    mean_flip: 0.002,
    max_flip_fraction_above_0_1: 0.0005,
};

/// The bunny scene (the poster's model alone, no sky) with the specular layer: what the
/// snapshots below compare models on.
fn startup_files() -> StartupFiles {
    let data = data_dir();
    let mut files =
        StartupFiles::from_scene(&data.join("scenes/bunny.toml"), &data.join("wax-fit"))
            .unwrap_or_else(|error| panic!("{error}"));
    files.specular = Some(SpecularLayer::new(DEFAULT_ROUGHNESS_ALPHA, DEFAULT_IOR).unwrap());
    files
}

/// The viewer on the bunny scene, side by side, in a kittest harness at `pixels_per_point`,
/// timings hidden.
fn harness_at(pixels_per_point: f32) -> Harness<'static, ViewerApp> {
    harness_with(&startup_files(), pixels_per_point, |settings| {
        settings.compare = Compare::SideBySide;
    })
}

/// The viewer on `files` in a kittest harness, timings hidden, after `adjust`.
fn harness_with(
    files: &StartupFiles,
    pixels_per_point: f32,
    adjust: impl FnOnce(&mut cdrf_viewer::app::Settings),
) -> Harness<'static, ViewerApp> {
    // kittest's setup (software adapters first) on the viewer's backends: no OpenGL, where
    // the viewer's shaders do not compile.
    let mut setup = default_wgpu_setup();
    if let egui_wgpu::WgpuSetup::CreateNew(create) = &mut setup {
        create.instance_descriptor.backends = cdrf_render::headless::SUPPORTED_BACKENDS;
    }
    let render_state = create_render_state(setup, egui_wgpu::RendererOptions::PREDICTABLE);
    let mut app = ViewerApp::new(&render_state, files);
    app.settings_mut().show_timings = false;
    adjust(app.settings_mut());
    assert_eq!(app.error(), None, "the bundled data loads");
    let mut harness = Harness::builder()
        .with_size(SIZE)
        .with_pixels_per_point(pixels_per_point)
        .renderer(WgpuTestRenderer::from_render_state(render_state))
        .build_ui_state(|ui, app: &mut ViewerApp| app.show(ui), app);
    harness.run_steps(3);
    harness
}

fn harness() -> Harness<'static, ViewerApp> {
    harness_at(1.0)
}

fn render(harness: &mut Harness<'_, ViewerApp>) -> Srgb8Image {
    let image = harness.render().unwrap_or_else(|error| panic!("{error}"));
    let (width, height) = image.dimensions();
    Srgb8Image::new(
        width,
        height,
        image.pixels().map(|p| p.0).collect::<Vec<[u8; 4]>>(),
    )
}

/// Left and right edges of the 3D view in points (inside the side panels and their margins).
const VIEW_X: [f32; 2] = [280.0, SIZE.x - 340.0];

/// Top of the 3D view's content in points, below the title bar and the models' labels.
const VIEW_TOP: f32 = 80.0;

/// Pixels of the 3D view (between the side panels, below the title bar and the labels) that
/// are not the background: their bounding box in pixels, or `None`.
fn object_bounds(image: &Srgb8Image, scale: f32) -> Option<[u32; 4]> {
    let right = image.width - ((SIZE.x - VIEW_X[1]) * scale) as u32;
    object_bounds_in(
        image,
        (VIEW_X[0] * scale) as u32..right,
        (VIEW_TOP * scale) as u32,
    )
}

/// [`object_bounds`] over the columns `x_range`, from row `top` down.
fn object_bounds_in(
    image: &Srgb8Image,
    x_range: std::ops::Range<u32>,
    top: u32,
) -> Option<[u32; 4]> {
    let mut bounds: Option<[u32; 4]> = None;
    for y in top..image.height {
        for x in x_range.clone() {
            let [r, g, b, _] = image.pixels[(y * image.width + x) as usize];
            // The background is sRGB ≈ (22, 22, 25); the wax is far brighter.
            if u32::from(r) + u32::from(g) + u32::from(b) > 3 * 60 {
                let b = bounds.get_or_insert([x, y, x, y]);
                *b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
            }
        }
    }
    bounds
}

/// What the viewer opens on: one view of the bundled wax with every non-local term, the
/// specular layer and a sky, on the bunny with its curvature smoothed.
#[test]
fn opening_view_is_the_renderer_at_its_best() {
    let files = StartupFiles::bundled().unwrap_or_else(|error| panic!("{error}"));
    let mut harness = harness_with(&files, 1.0, |_| {});
    let settings = harness.state().settings();
    assert_eq!(settings.compare, Compare::Single);
    assert_eq!(settings.non_local, NonLocal::ALL);
    assert!(settings.specular && settings.sky_radiance > 0.0);
    assert!(settings.curvature_smoothing > 0);
    let opening = render(&mut harness);
    assert!(object_bounds(&opening, 1.0).is_some(), "the bunny is drawn");
    assert_golden("viewer_opening", &opening, TOLERANCE);

    // The poster's model is one click away.
    harness.get_by_label("poster's model").click();
    harness.run_steps(2);
    assert_eq!(harness.state().settings().non_local, NonLocal::OFF);
    let poster = render(&mut harness);
    let changed = changed_pixels(&opening, &poster);
    println!("pixels the non-local terms change: {changed}");
    assert!(changed > 10_000, "{changed} pixels changed");
}

#[test]
fn side_by_side_shows_measured_beside_gaussian() {
    let mut harness = harness();
    let image = render(&mut harness);
    // The composite encodes sRGB on this non-sRGB target: the background (linear 0.012 → sRGB
    // 29; left linear it would be 3) comes out as the sRGB value.
    let corner = image.pixels[(600 * image.width + 300) as usize];
    let expected = BACKGROUND.map(|c| (linear_to_srgb(c) * 255.0).round() as i32);
    println!("3D view background pixel: {corner:?}, expected {expected:?}");
    for channel in 0..3 {
        assert!(
            (i32::from(corner[channel]) - expected[channel]).abs() <= 1,
            "background {corner:?}, expected {expected:?}"
        );
    }
    assert!(object_bounds(&image, 1.0).is_some(), "the bunny is drawn");
    assert_golden("viewer_side_by_side", &image, TOLERANCE);
}

#[test]
fn split_mode_from_its_button() {
    let mut harness = harness();
    harness.get_by_label("split").click();
    harness.run_steps(2);
    assert_eq!(harness.state().settings().compare, Compare::Split);
    assert_golden("viewer_split", &render(&mut harness), TOLERANCE);
}

#[test]
fn curvature_view_with_its_legend() {
    let mut harness = harness();
    harness.get_by_label("curvature view (/mm)").click();
    harness.run_steps(2);
    assert!(harness.state().settings().curvature_view);
    assert_golden("viewer_curvature", &render(&mut harness), TOLERANCE);
}

#[derive(Debug)]
struct Dropped(PathBuf);

impl egui::DroppedFile for Dropped {
    fn path(&self) -> &Path {
        &self.0
    }

    fn bytes(&self) -> Result<Vec<u8>, String> {
        std::fs::read(&self.0).map_err(|error| error.to_string())
    }
}

#[test]
fn dropping_a_bad_file_shows_the_error_and_keeps_the_data() {
    let mut harness = harness();
    // Relative to the test's working folder (`tests/`), so the message is the same on every
    // machine.
    let bad = PathBuf::from("fixtures/not-a-lut.exr");
    assert!(bad.is_file(), "fixture {} is missing", bad.display());
    harness
        .input_mut()
        .dropped_files
        .push(Arc::new(Dropped(bad)));
    harness.run_steps(2);
    let error = harness
        .state()
        .error()
        .expect("an error is shown")
        .to_owned();
    println!("error: {error}");
    assert!(error.starts_with("fixtures/not-a-lut.exr:"), "{error}");
    harness.get_by_label_contains("not-a-lut.exr");
    // The bundled LUT is still loaded: the measured half still draws the bunny.
    let image = render(&mut harness);
    assert!(object_bounds(&image, 1.0).is_some());
    assert_golden("viewer_error", &image, TOLERANCE);

    harness.get_by_label("dismiss").click();
    harness.run_steps(2);
    assert_eq!(harness.state().error(), None);
}

#[test]
fn pointer_over_the_bunny_reads_curvature_and_angles() {
    let mut harness = harness();
    let image = render(&mut harness);
    let middle = ((VIEW_X[0] + VIEW_X[1]) / 2.0) as u32;
    let [x0, y0, x1, y1] =
        object_bounds_in(&image, VIEW_X[0] as u32..middle, VIEW_TOP as u32).expect("bunny drawn");
    // Two thirds down the middle of the left (measured) bunny: its body.
    let pointer = egui::pos2((x0 + x1) as f32 / 2.0, (y0 + 2 * y1) as f32 / 3.0);
    harness.hover_at(pointer);
    harness.run_steps(2);
    println!("pointer {pointer:?} in bounds {:?}", [x0, y0, x1, y1]);
    let hover = harness
        .state()
        .hover()
        .expect("the pointer is over the bunny");
    println!("hover at {pointer:?}: {hover:?}");
    assert_eq!(hover.slot, 0);
    assert!(hover.curvature_per_mm.abs() < 0.5, "{hover:?}");
    // Seen from the front (φ < 90°); lit from the left, so θ is anywhere in [0, π].
    assert!(hover.phi_rad < std::f32::consts::FRAC_PI_2, "{hover:?}");
    assert!((0.0..=std::f32::consts::PI).contains(&hover.theta_rad));
    harness.get_by_label_contains("1/κ");

    harness.hover_at(egui::pos2(300.0, 600.0));
    harness.run_steps(1);
    assert_eq!(harness.state().hover(), None, "background has no surface");
}

#[test]
fn editing_sigma_rebuilds_the_gaussian_half_only() {
    let mut harness = harness();
    let before = render(&mut harness);
    let sigma = harness.state().settings().sigma_mm;
    harness.state_mut().settings_mut().sigma_mm = [sigma[0] * 0.2, sigma[1], sigma[2]];
    harness.run_steps(2);
    let after = render(&mut harness);
    let half_width = ((VIEW_X[0] + VIEW_X[1]) / 2.0) as u32;
    let changed = |x_range: std::ops::Range<u32>| {
        let mut count = 0;
        for y in VIEW_TOP as u32..before.height {
            for x in x_range.clone() {
                let i = (y * before.width + x) as usize;
                let (a, b) = (before.pixels[i], after.pixels[i]);
                if (0..3).any(|c| a[c].abs_diff(b[c]) > 4) {
                    count += 1;
                }
            }
        }
        count
    };
    let (left, right) = (
        changed(VIEW_X[0] as u32..half_width - 2),
        changed(half_width + 2..VIEW_X[1] as u32),
    );
    println!("pixels changed by σ_R × 0.2: measured half {left}, Gaussian half {right}");
    assert_eq!(left, 0, "the measured half does not depend on σ");
    assert!(right > 500, "the Gaussian half changes with σ");
}

#[test]
fn hidpi_renders_the_same_view_at_twice_the_pixels() {
    let mut low = harness_at(1.0);
    let mut high = harness_at(2.0);
    let (a, b) = (render(&mut low), render(&mut high));
    assert_eq!((b.width, b.height), (2 * a.width, 2 * a.height));
    let (one, two) = (
        object_bounds(&a, 1.0).expect("drawn at 1×"),
        object_bounds(&b, 2.0).expect("drawn at 2×"),
    );
    println!(
        "bunny bounds at 1×: {one:?}, at 2× (halved): {:?}",
        two.map(|v| v / 2)
    );
    for (p, q) in one.iter().zip(two) {
        assert!(p.abs_diff(q / 2) <= 2, "1× {one:?} vs 2× {two:?}");
    }
}

#[test]
fn a_window_narrower_than_its_panels_and_a_zero_sized_one_do_not_crash() {
    let mut harness = harness();
    // Narrower than the two panels: the 3D view gets no width at all.
    harness.set_size(egui::vec2(500.0, 300.0));
    harness.run_steps(2);
    let image = render(&mut harness);
    assert_eq!((image.width, image.height), (500, 300));
    // Minimised: egui runs with an empty screen; nothing is rendered.
    harness.set_size(egui::Vec2::ZERO);
    harness.run_steps(2);
    harness.set_size(SIZE);
    harness.run_steps(2);
    assert!(object_bounds(&render(&mut harness), 1.0).is_some());
}

#[test]
fn dropping_a_mesh_and_a_fit_folder_loads_them() {
    let mut harness = harness();
    let sphere = data_dir().join("sphere/unit_sphere.obj");
    harness
        .input_mut()
        .dropped_files
        .push(Arc::new(Dropped(sphere)));
    harness.run_steps(2);
    assert_eq!(harness.state().error(), None);
    // A unit sphere is 2 units across: 50 mm per unit makes it 100 mm (r = 50 mm).
    assert_eq!(harness.state().settings().mm_per_unit, 50.0);
    harness.get_by_label_contains("unit_sphere.obj: 50 mm per unit");
    harness.get_by_label("2562");

    harness
        .input_mut()
        .dropped_files
        .push(Arc::new(Dropped(data_dir().join("wax-fit"))));
    // The cross-polarised look: the layer's boundary would dim the terminator below the
    // bounds' threshold.
    harness.state_mut().settings_mut().specular = false;
    harness.run_steps(2);
    assert_eq!(harness.state().error(), None);
    let image = render(&mut harness);
    let middle = ((VIEW_X[0] + VIEW_X[1]) / 2.0) as u32;
    let [x0, y0, x1, y1] = object_bounds_in(&image, VIEW_X[0] as u32..middle, VIEW_TOP as u32)
        .expect("the sphere is drawn");
    println!("sphere bounds {:?}", [x0, y0, x1, y1]);
    // Lit from the left, the bright part is the left half of the disk: half as wide as tall
    // (a perspective camera framing the sphere keeps it round).
    let (width, height) = (x1 - x0, y1 - y0);
    assert!(
        (2 * width).abs_diff(height) <= height / 25,
        "{:?}",
        [x0, y0, x1, y1]
    );
}

/// Pixels whose colour differs by more than 8/255 in a channel.
fn changed_pixels(a: &Srgb8Image, b: &Srgb8Image) -> usize {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .filter(|(p, q)| p.iter().zip(q.iter()).any(|(x, y)| x.abs_diff(*y) > 8))
        .count()
}

#[test]
fn cast_shadow_and_transmission_toggles() {
    let mut harness = harness();
    let poster = render(&mut harness);
    harness.get_by_label("cast shadows").click();
    harness.run_steps(2);
    assert!(harness.state().settings().non_local.shadows);
    assert_eq!(harness.state().error(), None);
    let shadows = render(&mut harness);
    // Lit from the left, the bunny's head and ears shadow parts of its body.
    let by_shadows = changed_pixels(&poster, &shadows);
    harness.get_by_label("transmission").click();
    harness.run_steps(2);
    assert!(harness.state().settings().non_local.transmission);
    let both = render(&mut harness);
    let by_transmission = changed_pixels(&shadows, &both);
    println!("pixels changed: {by_shadows} by shadows, {by_transmission} by transmission");
    assert!(by_shadows > 500, "{by_shadows}");
    assert!(by_transmission > 100, "{by_transmission}");
    assert_golden("viewer_non_local", &both, TOLERANCE);
}

/// An equirectangular sky written to `path`: light from above and from +x, dark below.
fn write_sky(path: &Path) {
    let (width, height) = (64u32, 32u32);
    let mut image = cdrf_core::image_file::RgbaImage::new(width, height);
    for row in 0..height {
        for column in 0..width {
            let v = (row as f32 + 0.5) / height as f32;
            let up = (std::f32::consts::PI * v).cos().max(0.0);
            let side = if (width / 8..3 * width / 8).contains(&column) {
                1.0
            } else {
                0.0
            };
            let value = [
                0.6 * up + side,
                0.5 * up + 0.6 * side,
                0.8 * up + 0.3 * side,
            ]
            .map(|v| 0.15 * v);
            image.pixels[(row * width + column) as usize] = [value[0], value[1], value[2], 1.0];
        }
    }
    image
        .write_exr(path)
        .unwrap_or_else(|error| panic!("{error}"));
}

#[test]
fn environment_drop_specular_toggle_and_light_kind() {
    let mut harness = harness();
    assert!(
        harness.state().settings().specular,
        "the viewer's default look has the specular layer"
    );
    let default_look = render(&mut harness);
    // The checkbox is there (below the fold of the side panel at this window size, so set it
    // as the click would).
    harness.get_by_label("specular layer");
    harness.state_mut().settings_mut().specular = false;
    harness.run_steps(2);
    assert_eq!(harness.state().error(), None);
    let cross_polarised = render(&mut harness);
    let by_specular = changed_pixels(&default_look, &cross_polarised);

    let dir = tempfile::tempdir().unwrap();
    let sky = dir.path().join("sky.exr");
    write_sky(&sky);
    harness
        .input_mut()
        .dropped_files
        .push(Arc::new(Dropped(sky)));
    harness.run_steps(3);
    assert_eq!(harness.state().error(), None);
    harness.get_by_label_contains("environment: sky.exr");
    let with_sky = render(&mut harness);
    let by_sky = changed_pixels(&cross_polarised, &with_sky);

    harness.state_mut().settings_mut().light_kind = LightKind::Point;
    harness.run_steps(2);
    assert_eq!(harness.state().error(), None);
    let point = render(&mut harness);
    let by_point = changed_pixels(&with_sky, &point);
    println!(
        "pixels changed: {by_specular} by the specular layer, {by_sky} by the sky, \
         {by_point} by a point light"
    );
    assert!(by_specular > 200, "{by_specular}");
    assert!(by_sky > 2000, "{by_sky}");
    assert!(by_point > 200, "{by_point}");
    assert_golden("viewer_environment", &with_sky, TOLERANCE);
}

/// The textured test asset dropped on the viewer: drawn with its glTF materials (checker tint,
/// bumps, the small sphere's tint), and the "asset textures" toggle takes them off.
#[test]
fn textured_gltf_drop_shows_its_materials() {
    let mut harness = harness();
    let asset = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures/textured.glb");
    assert!(asset.is_file(), "{} is missing", asset.display());
    harness
        .input_mut()
        .dropped_files
        .push(Arc::new(Dropped(asset)));
    harness.run_steps(3);
    assert_eq!(harness.state().error(), None);
    // The file is in mm (glTF's metres would make it 60 m across).
    harness.state_mut().settings_mut().mm_per_unit = 1.0;
    harness.run_steps(3);
    assert_eq!(harness.state().error(), None);
    harness.get_by_label("asset textures");
    assert!(harness.state().settings().textures);
    let textured = render(&mut harness);
    harness.state_mut().settings_mut().textures = false;
    harness.run_steps(2);
    let bare = render(&mut harness);
    let by_textures = changed_pixels(&textured, &bare);
    println!("pixels changed by the asset's textures: {by_textures}");
    assert!(by_textures > 5000, "{by_textures}");
    assert_golden("viewer_textured", &textured, TOLERANCE);
}

/// The material picker swaps the bundled fit for a preset medium's table (computed on the
/// spot) and says that such a table has no diffusion profile for the subsurface gather.
#[test]
fn material_picker_loads_a_built_in_preset_with_every_term() {
    let files = StartupFiles::bundled().unwrap_or_else(|error| panic!("{error}"));
    let mut harness = harness_with(&files, 1.0, |_| {});
    let wax = render(&mut harness);
    harness.get_by_label("material").click();
    harness.run_steps(2);
    harness.get_by_label("marble").click();
    harness.run_steps(3);
    assert_eq!(harness.state().error(), None);
    // A simulated preset carries the diffusion profile: the gather needs no fallback.
    assert!(
        harness
            .query_by_label_contains("no diffusion profile")
            .is_none(),
        "the built-in marble has a diffusion profile"
    );
    let marble = render(&mut harness);
    let changed = changed_pixels(&wax, &marble);
    println!("pixels the material changes: {changed}");
    assert!(changed > 10_000, "{changed} pixels changed");
}
