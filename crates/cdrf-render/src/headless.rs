//! Rendering a scene file to an image without a window: for tests, benchmarks, the viewer's
//! `render` command and the accuracy evaluation.
//!
//! This is the one place where cdrf-render creates a wgpu instance and device itself
//! ([`HeadlessDevice`]); an application embedding the pass uses [`Renderer`] with its own.
//! [`SceneRenderer`] renders one scene's object with several materials, lights and non-local
//! terms through one [`Renderer`] (the mesh uploaded and each pipeline built once);
//! [`render_scene`] is the one-image shorthand.
//!
//! The image is rendered into an `Rgba16Float` target (linear radiance; 11 significant bits,
//! far below the 1 % noise of a path-traced reference) with the scene's MSAA sample count and
//! a `Depth32Float` depth buffer; resolved alpha is the pixel's coverage. The orthographic
//! camera follows the conventions of the bundled data (`data/README.md`): pixel (i, j), row 0
//! at the top, has its centre at `x = (i + 0.5 − W/2)·2h/H` along the camera's right axis.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use cdrf_core::environment::{Environment, ShCoefficients};
use cdrf_core::glam::Mat4;
use cdrf_core::image_file::RgbaImage;
use cdrf_core::light::{Light, NonLocal};
use cdrf_core::scene::{Material, Projection, Scene, SceneAssets, SceneError};
use cdrf_core::specular::SpecularLayer;
use thiserror::Error;

use crate::constants::ENVIRONMENT_SH_ORDER;
use crate::error::{MaterialError, MeshUploadError, PrepareError, SurfaceError, TargetError};
use crate::frame::{Draw, FrameDesc, View};
use crate::ids::{MaterialId, MeshId, SurfaceId};
use crate::material::MaterialDesc;
use crate::mesh::MeshDesc;
use crate::offscreen::OffscreenTarget;
use crate::readback::{ReadbackError, TextureReadback, readback_bytes};
use crate::renderer::Renderer;
use crate::surface::SurfaceDesc;
use crate::target::{Options, TargetDesc};

/// The colour format of headless renders.
pub const HEADLESS_COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// The depth format of headless renders.
pub const HEADLESS_DEPTH_FORMAT: wgpu::TextureFormat = crate::offscreen::DEFAULT_DEPTH_FORMAT;

/// The backends cdrf renders on: Vulkan, Metal, DX12 (wgpu's primary backends). OpenGL is
/// refused up front: its GLSL has no `textureLoad` from a depth texture, which the shadow maps
/// need, so every pipeline would fail to build. Without a Vulkan driver on Linux install
/// Mesa's (`mesa-vulkan-drivers libvulkan1`), whose lavapipe renders on the CPU.
pub const SUPPORTED_BACKENDS: wgpu::Backends = wgpu::Backends::PRIMARY;

/// The message of a missing Vulkan driver: the packages that give one.
pub const VULKAN_HINT: &str = "cdrf renders with Vulkan (or Metal/DX12), not OpenGL; for a \
     software Vulkan driver install Mesa's: `sudo apt-get install mesa-vulkan-drivers libvulkan1` \
     (Debian/Ubuntu)";

/// Which adapter a [`HeadlessDevice`] uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum AdapterPreference {
    /// Whatever wgpu picks first (a GPU when there is one).
    #[default]
    Any,
    /// A software (CPU) adapter such as lavapipe: the same pixels on every machine.
    Software,
}

/// A device and queue of cdrf-render's own, for rendering without a window.
pub struct HeadlessDevice {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// The adapter it runs on.
    pub adapter_info: wgpu::AdapterInfo,
    /// wgpu errors outside any error scope, recorded instead of wgpu's default panic.
    uncaptured: Arc<Mutex<Vec<String>>>,
}

/// Why a headless render failed.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum HeadlessError {
    /// No adapter (of the preferred kind) exists on a supported backend.
    #[error(
        "{} (Vulkan/Metal/DX12 adapters present: {}; OpenGL ones are not used). {VULKAN_HINT}",
        no_adapter_message(*preference),
        adapter_list(available)
    )]
    NoAdapter {
        /// What was asked for.
        preference: AdapterPreference,
        /// The adapters that do exist (name and type).
        available: Vec<String>,
    },
    /// The adapter refused to create a device.
    #[error("creating the device: {0}")]
    Device(wgpu::RequestDeviceError),
    /// The scene file or one of its assets is unusable.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// The mesh could not be uploaded.
    #[error("{}: {error}", path.display())]
    Mesh {
        /// The mesh file.
        path: PathBuf,
        /// Why.
        error: MeshUploadError,
    },
    /// The assets' primitives do not cover the mesh's triangles in order, once each, or name
    /// a material that is not there (surfaces of another mesh).
    #[error("{}: the surfaces' primitives do not cover the mesh's {triangles} triangles", path.display())]
    Surfaces {
        /// The mesh file.
        path: PathBuf,
        /// Triangles in the mesh.
        triangles: u32,
    },
    /// A material of the mesh file (its textures) could not be uploaded.
    #[error("{}: material {}: {error}", path.display(), material.as_deref().unwrap_or("(unnamed)"))]
    Surface {
        /// The mesh file.
        path: PathBuf,
        /// The glTF material's name.
        material: Option<String>,
        /// Why.
        error: SurfaceError,
    },
    /// The material could not be created.
    #[error("material: {0}")]
    Material(MaterialError),
    /// The frame could not be prepared.
    #[error(transparent)]
    Prepare(#[from] PrepareError),
    /// Reading the image back failed.
    #[error("reading the image back: {0}")]
    Readback(ReadbackError),
    /// The image is larger than this device can render or read back.
    #[error("image size {width} × {height} px: {reason}")]
    Size {
        /// Width, pixels.
        width: u32,
        /// Height, pixels.
        height: u32,
        /// Which limit it exceeds.
        reason: String,
    },
    /// The device could not create the render target.
    #[error(transparent)]
    Target(#[from] TargetError),
    /// wgpu reported an error while rendering or reading back.
    #[error("wgpu: {0}")]
    Gpu(String),
}

// The variants that prefix their cause's message keep it out of `source()`, so a printed chain
// says it once (the error conventions: ARCHITECTURE.md).
impl From<wgpu::RequestDeviceError> for HeadlessError {
    fn from(error: wgpu::RequestDeviceError) -> Self {
        Self::Device(error)
    }
}

impl From<MaterialError> for HeadlessError {
    fn from(error: MaterialError) -> Self {
        Self::Material(error)
    }
}

impl From<ReadbackError> for HeadlessError {
    fn from(error: ReadbackError) -> Self {
        Self::Readback(error)
    }
}

fn no_adapter_message(preference: AdapterPreference) -> &'static str {
    match preference {
        AdapterPreference::Any => "no graphics adapter found",
        AdapterPreference::Software => "no software (CPU) graphics adapter found",
    }
}

fn adapter_list(available: &[String]) -> String {
    if available.is_empty() {
        "none".to_owned()
    } else {
        available.join(", ")
    }
}

impl HeadlessDevice {
    /// Creates an instance, picks an adapter and creates a device with default limits.
    ///
    /// # Errors
    /// [`HeadlessError::NoAdapter`] (with a hint naming the package to install) or
    /// [`HeadlessError::Device`].
    pub fn new(preference: AdapterPreference) -> Result<Self, HeadlessError> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle());
        let adapters = pollster::block_on(instance.enumerate_adapters(SUPPORTED_BACKENDS));
        let describe = |adapter: &wgpu::Adapter| {
            let info = adapter.get_info();
            format!("{} ({:?}, {:?})", info.name, info.device_type, info.backend)
        };
        let available: Vec<String> = adapters.iter().map(describe).collect();
        let rank = |adapter: &wgpu::Adapter| {
            let info = adapter.get_info();
            let software = info.device_type == wgpu::DeviceType::Cpu;
            let vulkan = info.backend == wgpu::Backend::Vulkan;
            match preference {
                AdapterPreference::Software => (software, false, vulkan),
                AdapterPreference::Any => (
                    info.device_type == wgpu::DeviceType::DiscreteGpu,
                    info.device_type == wgpu::DeviceType::IntegratedGpu,
                    vulkan,
                ),
            }
        };
        let adapter = adapters
            .into_iter()
            .filter(|adapter| {
                preference == AdapterPreference::Any
                    || adapter.get_info().device_type == wgpu::DeviceType::Cpu
            })
            .max_by_key(rank)
            .ok_or(HeadlessError::NoAdapter {
                preference,
                available,
            })?;
        let (device, queue) =
            pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
                label: Some("cdrf headless device"),
                required_features: wgpu::Features::empty(),
                required_limits: wgpu::Limits::default().using_resolution(adapter.limits()),
                ..Default::default()
            }))?;
        // wgpu's default handler panics; errors outside a scope are recorded and reported by
        // the next render instead.
        let uncaptured = Arc::new(Mutex::new(Vec::new()));
        let sink = uncaptured.clone();
        device.on_uncaptured_error(Arc::new(move |error: wgpu::Error| {
            if let Ok(mut errors) = sink.lock() {
                errors.push(error.to_string());
            }
        }));
        Ok(Self {
            device,
            queue,
            adapter_info: adapter.get_info(),
            uncaptured,
        })
    }

    /// The wgpu errors raised outside any error scope since the last call (the device
    /// records them instead of panicking).
    pub fn take_uncaptured_errors(&self) -> Vec<String> {
        self.uncaptured
            .lock()
            .map(|mut errors| std::mem::take(&mut *errors))
            .unwrap_or_default()
    }

    /// Whether this device can render and read back a `width` × `height` headless image:
    /// each side at most `max_texture_dimension_2d`, and the read-back buffer (8 bytes a
    /// pixel, rows padded to 256 bytes) within `max_buffer_size` — with wgpu's default
    /// limits, 256 MiB: about 5790 × 5790 pixels.
    ///
    /// # Errors
    /// [`HeadlessError::Size`] naming the size and the limit.
    pub fn check_image_size(&self, width: u32, height: u32) -> Result<(), HeadlessError> {
        let limits = self.device.limits();
        let max_side = limits.max_texture_dimension_2d;
        let size_error = |reason: String| HeadlessError::Size {
            width,
            height,
            reason,
        };
        if width == 0 || height == 0 || width > max_side || height > max_side {
            return Err(size_error(format!(
                "each side must be 1..={max_side} on this device"
            )));
        }
        let texel_bytes = HEADLESS_COLOR_FORMAT.block_copy_size(None).unwrap_or(8);
        let bytes = readback_bytes(width, height, texel_bytes);
        if bytes > limits.max_buffer_size {
            return Err(size_error(format!(
                "reading it back needs {bytes} bytes, beyond this device's largest buffer \
                 ({} bytes)",
                limits.max_buffer_size
            )));
        }
        Ok(())
    }

    fn uncaptured_error(&self) -> Result<(), HeadlessError> {
        let errors = self.take_uncaptured_errors();
        if errors.is_empty() {
            Ok(())
        } else {
            Err(HeadlessError::Gpu(errors.join("; ")))
        }
    }

    /// A one-line description of the adapter (name, type, backend, driver).
    pub fn adapter_description(&self) -> String {
        let info = &self.adapter_info;
        format!(
            "{} ({:?}, {:?}, {} {})",
            info.name, info.device_type, info.backend, info.driver, info.driver_info
        )
    }
}

/// How to render: renderer options and how many frames to time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    /// Renderer options.
    pub options: Options,
    /// Frames rendered and timed after the image is taken (0: no timing). They are submitted
    /// back to back and waited for once; the time per frame covers uploads and GPU work.
    pub timed_frames: u32,
    /// Untimed frames before the timed ones.
    pub warm_up_frames: u32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            options: Options::default(),
            timed_frames: 0,
            warm_up_frames: 2,
        }
    }
}

/// A rendered scene.
#[derive(Clone, Debug)]
pub struct Rendered {
    /// Linear radiance, alpha = coverage, row 0 at the top.
    pub image: RgbaImage,
    /// Mean wall-clock milliseconds per timed frame (`None` without timed frames).
    pub ms_per_frame: Option<f64>,
    /// Timed frames.
    pub timed_frames: u32,
}

/// Loads `scene_path` and its assets and renders it on a new device.
///
/// # Errors
/// [`HeadlessError`] naming the file or step that failed.
pub fn render_scene_file(
    scene_path: impl AsRef<Path>,
    preference: AdapterPreference,
    settings: &RenderSettings,
) -> Result<Rendered, HeadlessError> {
    let scene = Scene::load(scene_path)?;
    let assets = scene.load_assets()?;
    let device = HeadlessDevice::new(preference)?;
    render_scene(&device, &scene, &assets, settings)
}

/// Renders `scene` (its assets already loaded) on `device` with the scene's material, lights
/// and non-local terms.
///
/// # Errors
/// [`HeadlessError`].
pub fn render_scene(
    device: &HeadlessDevice,
    scene: &Scene,
    assets: &SceneAssets,
    settings: &RenderSettings,
) -> Result<Rendered, HeadlessError> {
    let mut renderer = SceneRenderer::new(device, scene, assets, settings)?;
    renderer.set_environment(scene.load_environment()?.as_ref());
    let material = renderer.add_material(&assets.material)?;
    renderer.render(material, &scene.lights, scene.non_local)
}

/// One scene's object rendered headless through one [`Renderer`]: the mesh is uploaded once,
/// each material once ([`SceneRenderer::add_material`]) and each pipeline built once, so a
/// comparison of several models, lights or non-local terms on one object costs a frame each.
/// The camera, mesh, transform and units are the scene's.
pub struct SceneRenderer<'a> {
    device: &'a HeadlessDevice,
    scene: &'a Scene,
    settings: RenderSettings,
    renderer: Renderer,
    mesh: MeshId,
    /// One draw per glTF primitive: its triangles and its material's surface (empty: one
    /// untextured draw of the whole mesh).
    primitives: Vec<(std::ops::Range<u32>, SurfaceId)>,
    world_from_model: Mat4,
    view: View,
    targets: OffscreenTarget,
    environment: Option<ShCoefficients>,
}

impl<'a> SceneRenderer<'a> {
    /// Uploads the scene's mesh and sizes the target to its camera.
    ///
    /// # Errors
    /// [`HeadlessError::Size`] for an image size the device cannot render or read back
    /// ([`HeadlessDevice::check_image_size`]), [`HeadlessError::Target`] when the target
    /// cannot be created (out of memory), [`HeadlessError::Mesh`] naming the mesh file.
    pub fn new(
        device: &'a HeadlessDevice,
        scene: &'a Scene,
        assets: &SceneAssets,
        settings: &RenderSettings,
    ) -> Result<Self, HeadlessError> {
        let camera = &scene.camera;
        let (width, height) = (camera.width, camera.height);
        device.check_image_size(width, height)?;
        let target = TargetDesc::new(HEADLESS_COLOR_FORMAT)
            .with_sample_count(camera.msaa_samples)
            .with_depth(HEADLESS_DEPTH_FORMAT);
        // Headless builds its own projection (depth 0 at near, 1 at far), so the depth test is
        // `Less` whatever the options say.
        let options = Options {
            depth_compare: wgpu::CompareFunction::Less,
            ..settings.options
        };
        let scope = device
            .device
            .push_error_scope(wgpu::ErrorFilter::Validation);
        let mut renderer = Renderer::new(&device.device, &target, options);
        let mesh = renderer
            .create_mesh(
                &device.device,
                &MeshDesc::from_mesh(&assets.mesh, &assets.curvature_per_mm)
                    .with_curvature_anisotropy(&assets.curvature_anisotropy_per_mm)
                    .with_tangents(assets.surfaces.tangents.as_deref()),
            )
            .map_err(|error| HeadlessError::Mesh {
                path: scene.mesh.path.clone(),
                error,
            })?;
        let triangles = assets.mesh.triangles.len() as u32;
        let mut covered = 0;
        for primitive in &assets.surfaces.primitives {
            if primitive.triangles.start != covered
                || primitive.triangles.end <= covered
                || assets.surfaces.materials.get(primitive.material).is_none()
            {
                break;
            }
            covered = primitive.triangles.end;
        }
        if !assets.surfaces.primitives.is_empty() && covered != triangles {
            return Err(HeadlessError::Surfaces {
                path: scene.mesh.path.clone(),
                triangles,
            });
        }
        let surfaces = assets
            .surfaces
            .materials
            .iter()
            .map(|material| {
                renderer
                    .create_surface(
                        &device.device,
                        &device.queue,
                        &SurfaceDesc::from_material(material),
                    )
                    .map_err(|error| HeadlessError::Surface {
                        path: scene.mesh.path.clone(),
                        material: material.name.clone(),
                        error,
                    })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let primitives = assets
            .surfaces
            .primitives
            .iter()
            .filter_map(|primitive| {
                Some((
                    primitive.triangles.clone(),
                    *surfaces.get(primitive.material)?,
                ))
            })
            .collect();
        let targets = OffscreenTarget::try_new(&device.device, &target, width, height)?;
        if let Some(error) = pollster::block_on(scope.pop()) {
            return Err(HeadlessError::Gpu(error.to_string()));
        }
        device.uncaptured_error()?;
        let world_from_model = scene.mesh.transform.world_from_model();
        let (near, far) = depth_range(scene, assets, world_from_model);
        Ok(Self {
            device,
            scene,
            settings: *settings,
            renderer,
            mesh,
            primitives,
            world_from_model,
            view: View::from_camera(camera, near, far),
            targets,
            environment: None,
        })
    }

    /// Uploads a material to render the object with, with the scene's specular layer
    /// (`[shading] specular`) on it unless it is the curvature view.
    ///
    /// # Errors
    /// [`HeadlessError::Material`].
    pub fn add_material(&mut self, material: &Material) -> Result<MaterialId, HeadlessError> {
        let desc = match material {
            Material::Measured(lut) => MaterialDesc::Measured { lut },
            Material::Gaussian {
                model,
                view_correction,
            } => MaterialDesc::Gaussian {
                model,
                view_correction,
            },
            Material::Lambert { albedo } => MaterialDesc::Lambert { albedo: *albedo },
            Material::Curvature { range_per_mm } => MaterialDesc::Curvature {
                range_per_mm: *range_per_mm,
            },
        };
        let id = self
            .renderer
            .create_material(&self.device.device, &self.device.queue, &desc)?;
        if !matches!(material, Material::Curvature { .. }) {
            self.set_specular(id, self.scene.specular)?;
        }
        Ok(id)
    }

    /// Lights the next renders with an environment (its SH projected here, at
    /// [`ENVIRONMENT_SH_ORDER`]), or without one. [`render_scene`] sets the scene's.
    pub fn set_environment(&mut self, environment: Option<&Environment>) {
        self.environment = environment.map(|e| e.project_sh(ENVIRONMENT_SH_ORDER));
    }

    /// Puts a specular layer on a material or takes it off
    /// ([`Renderer::set_material_specular`]).
    ///
    /// # Errors
    /// [`HeadlessError::Material`].
    pub fn set_specular(
        &mut self,
        material: MaterialId,
        layer: Option<SpecularLayer>,
    ) -> Result<(), HeadlessError> {
        Ok(self
            .renderer
            .set_material_specular(&self.device.queue, material, layer)?)
    }

    /// Renders the object with `material` under `lights` and reads the image back; then, if
    /// the settings ask for it, times frames.
    ///
    /// # Errors
    /// [`HeadlessError`].
    pub fn render(
        &mut self,
        material: MaterialId,
        lights: &[Light],
        non_local: NonLocal,
    ) -> Result<Rendered, HeadlessError> {
        let device = self.device;
        let scope = device
            .device
            .push_error_scope(wgpu::ErrorFilter::Validation);
        let whole = Draw::new(self.mesh, material, self.world_from_model);
        let draws: Vec<Draw> = if self.primitives.is_empty() {
            vec![whole]
        } else {
            self.primitives
                .iter()
                .map(|(triangles, surface)| {
                    whole
                        .clone()
                        .with_triangles(triangles.clone())
                        .with_surface(*surface)
                })
                .collect()
        };
        // (A copy: frame_commands borrows self mutably.)
        let environment = self.environment.clone();
        let frame = FrameDesc {
            view: self.view,
            lights,
            exposure: self.scene.camera.exposure,
            draws: &draws,
            non_local,
            mm_per_world_unit: self.scene.mesh.mm_per_unit,
            environment: environment.as_ref(),
        };
        let mut commands = self.frame_commands(&frame)?;
        let mut encoder = device
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("cdrf headless readback"),
            });
        let readback =
            TextureReadback::record(&device.device, &mut encoder, self.targets.resolved())?;
        commands.push(encoder.finish());
        device.queue.submit(commands);
        let image = readback.read_rgba16f(&device.device)?;

        let settings = self.settings;
        let mut ms_per_frame = None;
        if settings.timed_frames > 0 {
            for _ in 0..settings.warm_up_frames {
                let commands = self.frame_commands(&frame)?;
                device.queue.submit(commands);
                wait(&device.device)?;
            }
            // Frames are submitted back to back and waited for once, as an application's frames
            // overlap: the time is throughput, not the latency of one frame plus a round trip.
            let start = Instant::now();
            for _ in 0..settings.timed_frames {
                let commands = self.frame_commands(&frame)?;
                device.queue.submit(commands);
            }
            wait(&device.device)?;
            ms_per_frame =
                Some(start.elapsed().as_secs_f64() * 1e3 / f64::from(settings.timed_frames));
        }
        if let Some(error) = pollster::block_on(scope.pop()) {
            return Err(HeadlessError::Gpu(error.to_string()));
        }
        device.uncaptured_error()?;
        Ok(Rendered {
            image,
            ms_per_frame,
            timed_frames: settings.timed_frames,
        })
    }

    /// The frame's commands: the shadow pass (when a non-local term is on), then the pass.
    fn frame_commands(
        &mut self,
        frame: &FrameDesc<'_>,
    ) -> Result<Vec<wgpu::CommandBuffer>, HeadlessError> {
        let device = self.device;
        let mut commands = self
            .renderer
            .prepare(&device.device, &device.queue, frame)?;
        let mut encoder = device
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("cdrf headless frame"),
            });
        {
            let mut pass = self
                .targets
                .begin_pass(&mut encoder, wgpu::Color::TRANSPARENT);
            self.renderer.render(&mut pass);
        }
        commands.push(encoder.finish());
        Ok(commands)
    }
}

/// Near and far planes enclosing the drawn mesh, with a margin.
fn depth_range(scene: &Scene, assets: &SceneAssets, world_from_model: Mat4) -> (f32, f32) {
    let camera = &scene.camera;
    let forward = (camera.target - camera.eye).normalize();
    let (mut nearest, mut farthest) = (f32::INFINITY, f32::NEG_INFINITY);
    for &position in &assets.mesh.positions {
        let depth = (world_from_model.transform_point3(position) - camera.eye).dot(forward);
        nearest = nearest.min(depth);
        farthest = farthest.max(depth);
    }
    let margin = 0.01 * (farthest - nearest).max(1e-3) + 1e-3;
    match camera.projection {
        Projection::Orthographic { .. } => (nearest - margin, farthest + margin),
        Projection::Perspective { .. } => {
            let far = (farthest + margin).max(1e-3);
            ((nearest - margin).max(far * 1e-4), far)
        }
    }
}

fn wait(device: &wgpu::Device) -> Result<(), HeadlessError> {
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map(|_| ())
        .map_err(|error| HeadlessError::Gpu(format!("waiting for the GPU: {error}")))
}
