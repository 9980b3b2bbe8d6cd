//! cdrf-viewer: an egui inspector that compares the measured curvature-dependent reflectance
//! function (CDRF) with Kubo's Gaussian CDRF and Lambert on a mesh, plus the headless `render`,
//! `screenshot` and `compare` commands (`compare` runs cdrf-eval).
//!
//! - [`app::ViewerApp`]: the UI (controls, 3D view, inspector). eframe runs it in a window;
//!   tests and [`offscreen::OffscreenUi`] call [`app::ViewerApp::show`] directly.
//! - [`gpu`]: the paint callback that drives `cdrf-render` inside egui's pass.
//! - [`assets`]: loading meshes, LUTs, Gaussian parameters and fit folders.
//! - [`camera`], [`pick`]: the orbit camera and the CPU ray cast behind the (κ, θ) read-out.
//! - [`panels`]: the light gizmo, LUT image, radiance plot and legends.

pub mod app;
pub mod assets;
pub mod camera;
pub mod gpu;
pub mod offscreen;
pub mod outputs;
pub mod panels;
pub mod pick;

pub use app::{Compare, LightKind, SLOT_MODELS, Settings, ViewerApp};
pub use assets::StartupFiles;
