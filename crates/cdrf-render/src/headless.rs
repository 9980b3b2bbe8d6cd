//! Rendering a scene file to an image without a window: for tests, benchmarks, the viewer's
//! `render` command and the accuracy evaluation.
//!
//! This is the one place where cdrf-render creates a wgpu instance and device itself
//! ([`HeadlessDevice`]); an application embedding the pass uses [`Renderer`] with its own.
//!
//! The image is rendered into an `Rgba16Float` target (linear radiance; 11 significant bits,
//! far below the 1 % noise of a path-traced reference) with the scene's MSAA sample count and
//! a `Depth32Float` depth buffer; resolved alpha is the pixel's coverage. The orthographic
//! camera follows the conventions of the bundled data (`data/README.md`): pixel (i, j), row 0
//! at the top, has its centre at `x = (i + 0.5 − W/2)·2h/H` along the camera's right axis.

use std::fmt;
use std::path::{Path, PathBuf};
use std::time::Instant;

use cdrf_core::glam::Mat4;
use cdrf_core::image_file::RgbaImage;
use cdrf_core::scene::{Material, Projection, Scene, SceneAssets, SceneError};

use crate::gpu_data::{block_on, f16_bits_to_f32};
use crate::offscreen::OffscreenTarget;
use crate::renderer::{
    Draw, FrameDesc, MaterialDesc, MaterialError, MeshDesc, MeshUploadError, PrepareError,
    Renderer, View,
};
use crate::target::{Options, TargetDesc};

/// The colour format of headless renders.
pub const HEADLESS_COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// The depth format of headless renders.
pub const HEADLESS_DEPTH_FORMAT: wgpu::TextureFormat = crate::offscreen::DEFAULT_DEPTH_FORMAT;

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
}

/// Why a headless render failed.
#[derive(Debug)]
#[non_exhaustive]
pub enum HeadlessError {
    /// No adapter (of the preferred kind) exists.
    NoAdapter {
        /// What was asked for.
        preference: AdapterPreference,
        /// The adapters that do exist (name and type).
        available: Vec<String>,
    },
    /// The adapter refused to create a device.
    Device(wgpu::RequestDeviceError),
    /// The scene file or one of its assets is unusable.
    Scene(SceneError),
    /// The mesh could not be uploaded.
    Mesh {
        /// The mesh file.
        path: PathBuf,
        /// Why.
        error: MeshUploadError,
    },
    /// The material could not be created.
    Material(MaterialError),
    /// The frame could not be prepared.
    Prepare(PrepareError),
    /// The frame settings are out of range.
    Settings(String),
    /// wgpu reported an error while rendering or reading back.
    Gpu(String),
}

impl fmt::Display for HeadlessError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NoAdapter {
                preference,
                available,
            } => {
                let wanted = match preference {
                    AdapterPreference::Any => "no graphics adapter found",
                    AdapterPreference::Software => "no software (CPU) graphics adapter found",
                };
                let found = if available.is_empty() {
                    "none".to_owned()
                } else {
                    available.join(", ")
                };
                write!(
                    f,
                    "{wanted} (adapters present: {found}). For software rendering install \
                     Mesa's Vulkan driver: `sudo apt-get install mesa-vulkan-drivers libvulkan1` \
                     (Debian/Ubuntu)"
                )
            }
            Self::Device(error) => write!(f, "creating the device: {error}"),
            Self::Scene(error) => write!(f, "{error}"),
            Self::Mesh { path, error } => write!(f, "{}: {error}", path.display()),
            Self::Material(error) => write!(f, "material: {error}"),
            Self::Prepare(error) => write!(f, "{error}"),
            Self::Settings(message) => write!(f, "{message}"),
            Self::Gpu(message) => write!(f, "wgpu: {message}"),
        }
    }
}

impl std::error::Error for HeadlessError {}

impl From<SceneError> for HeadlessError {
    fn from(error: SceneError) -> Self {
        Self::Scene(error)
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
        let adapters = block_on(instance.enumerate_adapters(wgpu::Backends::all()));
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
        let (device, queue) = block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("cdrf headless device"),
            required_features: wgpu::Features::empty(),
            required_limits: wgpu::Limits::default().using_resolution(adapter.limits()),
            ..Default::default()
        }))
        .map_err(HeadlessError::Device)?;
        Ok(Self {
            device,
            queue,
            adapter_info: adapter.get_info(),
        })
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

/// Renders `scene` (its assets already loaded) on `device`.
///
/// # Errors
/// [`HeadlessError`].
pub fn render_scene(
    device: &HeadlessDevice,
    scene: &Scene,
    assets: &SceneAssets,
    settings: &RenderSettings,
) -> Result<Rendered, HeadlessError> {
    let camera = &scene.camera;
    let (width, height) = (camera.width, camera.height);
    let max_side = device.device.limits().max_texture_dimension_2d;
    if width == 0 || height == 0 || width > max_side || height > max_side {
        return Err(HeadlessError::Settings(format!(
            "image size {width} × {height}: each side must be 1..={max_side} on this device"
        )));
    }
    let target = TargetDesc::new(HEADLESS_COLOR_FORMAT)
        .with_sample_count(camera.msaa_samples)
        .with_depth(HEADLESS_DEPTH_FORMAT);
    let scope = device
        .device
        .push_error_scope(wgpu::ErrorFilter::Validation);

    // Headless builds its own projection (depth 0 at near, 1 at far), so the depth test is
    // `Less` whatever the options say.
    let options = Options {
        depth_compare: wgpu::CompareFunction::Less,
        ..settings.options
    };
    let mut renderer = Renderer::new(&device.device, &target, options);
    let mesh = renderer
        .create_mesh(
            &device.device,
            &MeshDesc {
                mesh: &assets.mesh,
                curvature_per_mm: &assets.curvature_per_mm,
            },
        )
        .map_err(|error| HeadlessError::Mesh {
            path: scene.mesh.path.clone(),
            error,
        })?;
    let material_desc = match &assets.material {
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
    let material = renderer
        .create_material(&device.device, &device.queue, &material_desc)
        .map_err(HeadlessError::Material)?;

    let world_from_model = scene.mesh.transform.world_from_model();
    let (near, far) = depth_range(scene, assets, world_from_model);
    let draws = [Draw {
        mesh,
        material,
        world_from_model,
    }];
    let frame = FrameDesc {
        view: View::from_camera(camera, near, far),
        lights: &scene.lights,
        exposure: 1.0,
        draws: &draws,
        non_local: scene.non_local,
        mm_per_world_unit: scene.mesh.mm_per_unit,
    };

    let targets = OffscreenTarget::new(&device.device, &target, width, height);
    // The frame's commands: the shadow pass (when a non-local term is on), then the pass.
    let render_frame =
        |renderer: &mut Renderer| -> Result<Vec<wgpu::CommandBuffer>, HeadlessError> {
            let mut commands = renderer
                .prepare(&device.device, &device.queue, &frame)
                .map_err(HeadlessError::Prepare)?;
            let mut encoder =
                device
                    .device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                        label: Some("cdrf headless frame"),
                    });
            {
                let mut pass = targets.begin_pass(&mut encoder, wgpu::Color::TRANSPARENT);
                renderer.render(&mut pass);
            }
            commands.push(encoder.finish());
            Ok(commands)
        };

    let mut commands = render_frame(&mut renderer)?;
    let mut encoder = device
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("cdrf headless readback"),
        });
    let readback = copy_to_buffer(&targets, &device.device, &mut encoder);
    commands.push(encoder.finish());
    device.queue.submit(commands);
    let image = readback.read(&device.device)?;

    let mut ms_per_frame = None;
    if settings.timed_frames > 0 {
        for _ in 0..settings.warm_up_frames {
            device.queue.submit(render_frame(&mut renderer)?);
            wait(&device.device)?;
        }
        // Frames are submitted back to back and waited for once, as an application's frames
        // overlap: the time is throughput, not the latency of one frame plus a round trip.
        let start = Instant::now();
        for _ in 0..settings.timed_frames {
            device.queue.submit(render_frame(&mut renderer)?);
        }
        wait(&device.device)?;
        ms_per_frame = Some(start.elapsed().as_secs_f64() * 1e3 / f64::from(settings.timed_frames));
    }
    if let Some(error) = block_on(scope.pop()) {
        return Err(HeadlessError::Gpu(error.to_string()));
    }
    Ok(Rendered {
        image,
        ms_per_frame,
        timed_frames: settings.timed_frames,
    })
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

/// Copies the resolved colour into a buffer to map.
fn copy_to_buffer(
    target: &OffscreenTarget,
    device: &wgpu::Device,
    encoder: &mut wgpu::CommandEncoder,
) -> Readback {
    let (width, height) = target.size();
    let bytes_per_row = (width * 8).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("cdrf headless readback"),
        size: u64::from(bytes_per_row) * u64::from(height),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    encoder.copy_texture_to_buffer(
        target.resolved().as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(bytes_per_row),
                rows_per_image: Some(height),
            },
        },
        wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
    );
    Readback {
        buffer,
        bytes_per_row,
        width,
        height,
    }
}

struct Readback {
    buffer: wgpu::Buffer,
    bytes_per_row: u32,
    width: u32,
    height: u32,
}

impl Readback {
    fn read(self, device: &wgpu::Device) -> Result<RgbaImage, HeadlessError> {
        let (sender, receiver) = std::sync::mpsc::channel();
        self.buffer
            .map_async(wgpu::MapMode::Read, .., move |result| {
                let _ = sender.send(result);
            });
        wait(device)?;
        receiver
            .recv()
            .map_err(|_| HeadlessError::Gpu("readback never completed".into()))?
            .map_err(|error| HeadlessError::Gpu(format!("mapping the readback buffer: {error}")))?;
        let data = self
            .buffer
            .get_mapped_range(..)
            .map_err(|error| HeadlessError::Gpu(format!("reading the readback buffer: {error}")))?;
        let mut pixels = Vec::with_capacity((self.width * self.height) as usize);
        for row in data.chunks_exact(self.bytes_per_row as usize) {
            for texel in row[..self.width as usize * 8].chunks_exact(8) {
                let channel = |i: usize| {
                    f16_bits_to_f32(u16::from_ne_bytes([texel[2 * i], texel[2 * i + 1]]))
                };
                pixels.push([channel(0), channel(1), channel(2), channel(3)]);
            }
        }
        drop(data);
        self.buffer.unmap();
        Ok(RgbaImage {
            width: self.width,
            height: self.height,
            pixels,
        })
    }
}

fn wait(device: &wgpu::Device) -> Result<(), HeadlessError> {
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map(|_| ())
        .map_err(|error| HeadlessError::Gpu(format!("waiting for the GPU: {error}")))
}
