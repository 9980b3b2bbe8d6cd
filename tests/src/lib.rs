//! Shared helpers for the workspace integration tests in `tests/tests/`.

use std::path::PathBuf;
use std::sync::OnceLock;

use cdrf_core::image_file::RgbaImage;
use cdrf_core::scene::{Scene, SceneAssets};
use cdrf_render::Options;
use cdrf_render::headless::{AdapterPreference, HeadlessDevice, RenderSettings, render_scene};

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
