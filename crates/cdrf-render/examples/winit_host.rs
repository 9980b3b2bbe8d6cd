//! A bare winit + wgpu host that embeds cdrf-render: the example to copy first.
//!
//! The host owns everything a game engine owns — instance, adapter, device, queue, surface and
//! its own render pass each frame (a clear colour, a `Depth32Float` depth attachment, 4× MSAA
//! when the adapter supports it) — and cdrf-render only records its draws into that pass. It
//! shows the bundled Stanford bunny (or any OBJ / glTF file) in wax: the measured CDRF from
//! `data/wax-fit/measured.exr`, Kubo's Gaussian CDRF, Lambert and the curvature itself, under
//! one light that circles the model (directional, or a point or spot lamp), with the specular
//! layer on and, on request, a sky.
//!
//! ```text
//! cargo run --release -p cdrf-render --example winit_host [MESH.obj] [MM_PER_UNIT]
//! ```
//!
//! `MESH` defaults to `data/bunny/bunny.obj`, `MM_PER_UNIT` (millimetres per model unit, which
//! sets the curvature and so how translucent the model looks) to 10 when `MESH` is omitted
//! (the bunny is 9.66 units, 97 mm, tall), else 1.
//! Keys: `1` measured CDRF, `2` Gaussian CDRF, `3` Lambert, `4` curvature (blue concave, red
//! convex); `←`/`→` move the light around the vertical axis, `↑`/`↓` raise and lower it (either
//! stops the rotation), `Space` starts or stops the rotation, `M` toggles 4× MSAA, `S` cast
//! shadows, `T` transmission, `I` inter-reflection and `U` the subsurface gather (the non-local
//! terms), `L` cycles the light's kind (directional, point, spot: a lamp three radii from
//! the model, as bright there as the directional light), `P` the specular layer (on at start),
//! `E` the environment light (a uniform sky, or the equirectangular OpenEXR dropped on the
//! window), `Esc` quits.
//! The title shows the model, the shading, the sample count and the time per frame.
//!
//! `CDRF_EXIT_AFTER_FRAMES=N` exits cleanly (status 0) after N frames were presented — for
//! smoke tests such as `xvfb-run -a cargo run -p cdrf-render --example winit_host` on a
//! machine with only a software Vulkan driver (Mesa's lavapipe). wgpu validation errors end
//! the program with a non-zero status and the error's text.
//!
//! # The lines that matter for embedding
//! ```text
//! // Once: describe your pass's attachments, upload meshes and materials.
//! let target = TargetDesc::new(surface_format).with_sample_count(4).with_depth(Depth32Float);
//! let mut renderer = Renderer::new(&device, &target, Options::default());
//! let mesh = renderer.create_mesh(&device, &MeshDesc::from_mesh(&mesh, &kappa))?;
//! let wax = renderer.create_material(&device, &queue, &MaterialDesc::Measured { lut: &lut })?;
//! // Each frame, before your pass: camera, lights, draws.
//! let draws = [Draw::new(mesh, wax, world_from_model)];
//! let frame = FrameDesc {
//!     view, lights: &lights, exposure: 1.0, draws: &draws, non_local, mm_per_world_unit,
//!     environment: None,
//! };
//! let shadow_pass = renderer.prepare(&device, &queue, &frame)?; // empty unless non_local is on
//! // Inside your pass (whose attachments match `target`):
//! renderer.render(&mut pass);
//! // Submit the shadow pass first: queue.submit(shadow_pass.into_iter().chain([encoder.finish()]));
//! // When your pass changes format or sample count: renderer.set_target(&new_target);
//! ```
//! Everything else here is ordinary winit/wgpu plumbing (see `Gpu::draw_frame`).

use std::error::Error;
use std::f32::consts::{FRAC_PI_2, PI};
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use cdrf_core::environment::{Environment, EnvironmentRadiance, EquirectMap};
use cdrf_core::gaussian::GaussianCdrf;
use cdrf_core::gaussian_file::read_gaussian;
use cdrf_core::glam::Vec3;
use cdrf_core::glam::camera::rh::{proj::directx, view};
use cdrf_core::{
    CdrfLut, CurvatureOptions, Mesh, ShadingModel, ViewCorrection, curvature_per_mm, read_lut,
};
use cdrf_render::{
    DirectionalLight, ENVIRONMENT_SH_ORDER, NonLocal, PointLight, ShCoefficients, SpecularLayer,
    SpotLight,
};
use cdrf_render::{
    Draw, FrameDesc, MaterialDesc, MaterialId, MeshDesc, MeshId, Options, Renderer, TargetDesc,
    ToCamera, View, wgpu,
};
use winit::application::ApplicationHandler;
use winit::dpi::LogicalSize;
use winit::event::{ElementState, KeyEvent, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop, OwnedDisplayHandle};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

/// The bundled mesh and measured table.
const BUNNY_PATH: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/bunny/bunny.obj");
const MEASURED_LUT_PATH: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../data/wax-fit/measured.exr"
);
/// One bunny unit is 10 mm (data/bunny/README.md).
const BUNNY_MM_PER_UNIT: f32 = 10.0;
/// Kubo's Gaussian CDRF fitted to the same wax photographs (shares the table's view correction).
const GAUSSIAN_PATH: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../data/wax-fit/gaussian.toml"
);

const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
const MSAA_SAMPLES: u32 = 4;
/// Linear clear colour (a dark neutral grey).
const CLEAR_LINEAR: [f64; 3] = [0.02, 0.02, 0.025];
const VERTICAL_FOV_RAD: f32 = 35.0 * PI / 180.0;
/// Light rotation speed and arrow-key step.
const LIGHT_RAD_PER_S: f32 = 0.4;
const LIGHT_STEP_RAD: f32 = 5.0 * PI / 180.0;
const TITLE_INTERVAL: Duration = Duration::from_millis(500);

fn main() -> Result<(), Box<dyn Error>> {
    let Some(config) = Config::from_env()? else {
        return Ok(());
    };
    let scene = SceneData::load(&config)?;
    let event_loop =
        EventLoop::new().map_err(|e| Failure::caused("creating the event loop", &e))?;
    let mut app = App::new(event_loop.owned_display_handle(), config, scene);
    event_loop
        .run_app(&mut app)
        .map_err(|e| Failure::caused("running the event loop", &e))?;
    match app.failure {
        Some(failure) => Err(failure.into()),
        None => Ok(()),
    }
}

/// An error `main` prints as it is: what failed (with the file), then each cause.
struct Failure(String);

impl Failure {
    fn new(message: impl Into<String>) -> Self {
        Self(message.into())
    }

    /// `context: error: cause: …` over the error's whole source chain.
    fn caused(context: impl fmt::Display, error: &dyn Error) -> Self {
        let mut message = format!("{context}: {error}");
        let mut source = error.source();
        while let Some(cause) = source {
            message.push_str(&format!(": {cause}"));
            source = cause.source();
        }
        Self(message)
    }
}

// `main` returning `Err` prints the error with `Debug`: make that the plain message.
impl fmt::Debug for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl Error for Failure {}

/// Command line and environment, validated.
struct Config {
    mesh_path: PathBuf,
    mm_per_unit: f32,
    exit_after_frames: Option<u64>,
}

impl Config {
    const USAGE: &str = "usage: winit_host [MESH.obj|.gltf|.glb] [MM_PER_UNIT]\n\
        MESH defaults to the bundled bunny; MM_PER_UNIT (millimetres per model unit) to 10 when \
        MESH is omitted, 1 otherwise.\n\
        CDRF_EXIT_AFTER_FRAMES=N exits after N presented frames.";

    /// `None` when only help was asked for.
    fn from_env() -> Result<Option<Self>, Failure> {
        let args: Vec<String> = std::env::args().skip(1).collect();
        if args.iter().any(|a| a == "-h" || a == "--help") {
            println!("{}", Self::USAGE);
            return Ok(None);
        }
        if args.len() > 2 {
            return Err(Failure::new(format!(
                "{} arguments given, at most 2 expected\n{}",
                args.len(),
                Self::USAGE
            )));
        }
        let mesh_path = args
            .first()
            .map_or_else(|| PathBuf::from(BUNNY_PATH), PathBuf::from);
        let mm_per_unit = match args.get(1) {
            Some(text) => match text.parse::<f32>() {
                Ok(value) if value.is_finite() && value > 0.0 => value,
                _ => {
                    return Err(Failure::new(format!(
                        "MM_PER_UNIT {text:?}: must be a number > 0 (millimetres per model unit)"
                    )));
                }
            },
            None if args.is_empty() => BUNNY_MM_PER_UNIT,
            None => 1.0,
        };
        let exit_after_frames = match std::env::var("CDRF_EXIT_AFTER_FRAMES") {
            Ok(text) => match text.parse::<u64>() {
                Ok(frames) if frames > 0 => Some(frames),
                _ => {
                    return Err(Failure::new(format!(
                        "CDRF_EXIT_AFTER_FRAMES={text:?}: must be a whole number > 0"
                    )));
                }
            },
            Err(_) => None,
        };
        Ok(Some(Self {
            mesh_path,
            mm_per_unit,
            exit_after_frames,
        }))
    }
}

/// What the CPU prepares before any window exists: mesh, curvature, shading data.
struct SceneData {
    name: String,
    mesh: Mesh,
    curvature_per_mm: Vec<f32>,
    curvature_anisotropy_per_mm: Vec<Vec3>,
    measured: CdrfLut,
    gaussian: GaussianCdrf,
    view_correction: ViewCorrection,
    /// Ends of the curvature view's colour map, mm⁻¹.
    curvature_range_per_mm: [f32; 2],
    bounds_min: Vec3,
    bounds_max: Vec3,
}

impl SceneData {
    fn load(config: &Config) -> Result<Self, Failure> {
        let path = &config.mesh_path;
        let loaded = Mesh::load(path).map_err(|e| Failure::caused("loading the mesh", &e))?;
        if !loaded.report.is_clean() {
            println!("{}: repaired: {}", path.display(), loaded.report);
        }
        let mesh = loaded.mesh;
        let curvature = curvature_per_mm(&mesh, &CurvatureOptions::new(config.mm_per_unit))
            .map_err(|e| Failure::caused(format!("{}: curvature", path.display()), &e))?;
        let curvature_per_mm = curvature.mean_per_mm;

        let measured = read_lut(MEASURED_LUT_PATH)
            .map_err(|e| Failure::caused("reading the measured CDRF", &e))?;
        let (gaussian, view_correction) = read_gaussian(GAUSSIAN_PATH)
            .and_then(|parameters| parameters.load_model(Path::new(GAUSSIAN_PATH)))
            .map_err(|e| Failure::caused("reading the Gaussian CDRF", &e))?;

        // The colour map spans ±(95th percentile of |κ|), so a few spikes don't wash it out.
        let mut magnitudes: Vec<f32> = curvature_per_mm.iter().map(|k| k.abs()).collect();
        magnitudes.sort_by(f32::total_cmp);
        let extent = magnitudes[(magnitudes.len() - 1) * 95 / 100].max(1e-3);

        let (bounds_min, bounds_max) = mesh.positions.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), &p| (lo.min(p), hi.max(p)),
        );
        let name = path.file_name().map_or_else(
            || path.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        println!(
            "{name}: {} vertices, {} triangles, {:.0} mm tall, curvature ±{extent:.3} mm⁻¹ (95%)",
            mesh.vertex_count(),
            mesh.triangle_count(),
            (bounds_max.y - bounds_min.y) * config.mm_per_unit
        );
        Ok(Self {
            name,
            mesh,
            curvature_per_mm,
            curvature_anisotropy_per_mm: curvature.anisotropy_per_mm,
            measured,
            gaussian,
            view_correction,
            curvature_range_per_mm: [-extent, extent],
            bounds_min,
            bounds_max,
        })
    }

    /// A perspective camera looking at the bounding box's centre from slightly above the +z
    /// side, far enough for the bounding sphere to fit the window.
    fn view(&self, aspect: f32) -> View {
        let center = 0.5 * (self.bounds_min + self.bounds_max);
        let radius = (0.5 * (self.bounds_max - self.bounds_min).length()).max(1e-6);
        let half_vertical = 0.5 * VERTICAL_FOV_RAD;
        let half_horizontal = ((half_vertical).tan() * aspect).atan();
        let distance = 1.05 * radius / half_vertical.min(half_horizontal).sin();
        let eye = center + distance * Vec3::new(0.0, 0.25, 1.0).normalize();
        let near = (distance - 1.01 * radius).max(distance * 1e-3);
        let far = distance + 1.01 * radius;
        View {
            clip_from_world: directx::perspective(VERTICAL_FOV_RAD, aspect, near, far)
                * view::look_at_mat4(eye, center, Vec3::Y),
            to_camera: ToCamera::Point(eye),
        }
    }
}

/// What kind of light circles the model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum LightKind {
    Directional,
    Point,
    Spot,
}

impl LightKind {
    fn next(self) -> Self {
        match self {
            Self::Directional => Self::Point,
            Self::Point => Self::Spot,
            Self::Spot => Self::Directional,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Self::Directional => "directional",
            Self::Point => "point",
            Self::Spot => "spot",
        }
    }
}

/// The light: angle around the vertical axis and height above the horizon.
struct Light {
    azimuth_rad: f32,
    elevation_rad: f32,
    rotating: bool,
}

impl Light {
    fn to_light(&self) -> Vec3 {
        let (sin_a, cos_a) = self.azimuth_rad.sin_cos();
        let (sin_e, cos_e) = self.elevation_rad.sin_cos();
        Vec3::new(cos_e * sin_a, sin_e, cos_e * cos_a)
    }
}

/// Everything that exists once there is a window.
struct Gpu {
    window: Arc<Window>,
    instance: wgpu::Instance,
    surface: wgpu::Surface<'static>,
    device: wgpu::Device,
    queue: wgpu::Queue,
    config: wgpu::SurfaceConfiguration,
    /// 4 if both attachment formats support 4× MSAA here, else 1.
    max_samples: u32,
    target: TargetDesc,
    attachments: Attachments,
    /// Validation errors reported by wgpu; checked after each frame.
    gpu_errors: Arc<Mutex<Vec<String>>>,
    renderer: Renderer,
    mesh: MeshId,
    materials: [MaterialId; 4],
}

/// The host's own attachments besides the swap-chain image.
struct Attachments {
    /// The multisampled colour target (resolved into the swap-chain image), when MSAA is on.
    msaa_color: Option<wgpu::TextureView>,
    depth: wgpu::TextureView,
}

/// Whether a frame reached the screen.
enum Frame {
    Presented,
    Skipped,
}

impl Gpu {
    fn new(
        event_loop: &ActiveEventLoop,
        display: &OwnedDisplayHandle,
        scene: &SceneData,
    ) -> Result<Self, Failure> {
        let attributes = Window::default_attributes()
            .with_title(format!("cdrf winit_host — {}", scene.name))
            .with_inner_size(LogicalSize::new(1024.0, 768.0));
        let window = Arc::new(
            event_loop
                .create_window(attributes)
                .map_err(|e| Failure::caused("creating the window", &e))?,
        );

        // The host's GPU objects: cdrf-render never creates these.
        let instance = wgpu::Instance::new(
            wgpu::InstanceDescriptor::new_with_display_handle_from_env(Box::new(display.clone())),
        );
        let surface = instance
            .create_surface(window.clone())
            .map_err(|e| Failure::caused("creating the window's surface", &e))?;
        let adapter =
            pollster::block_on(
                instance.request_adapter(&wgpu::RequestAdapterOptions {
                    power_preference: wgpu::PowerPreference::from_env()
                        .unwrap_or(wgpu::PowerPreference::HighPerformance),
                    compatible_surface: Some(&surface),
                    ..Default::default()
                }),
            )
            .map_err(|e| {
                Failure::caused(
                    "no graphics adapter can draw to this window (for software rendering install \
                 Mesa's Vulkan driver: `apt-get install mesa-vulkan-drivers libvulkan1`)",
                    &e,
                )
            })?;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("winit_host device"),
            required_limits: wgpu::Limits::default().using_resolution(adapter.limits()),
            ..Default::default()
        }))
        .map_err(|e| Failure::caused("creating the device", &e))?;
        let gpu_errors = Arc::new(Mutex::new(Vec::new()));
        let sink = gpu_errors.clone();
        device.on_uncaptured_error(Arc::new(move |error: wgpu::Error| {
            if let Ok(mut errors) = sink.lock() {
                errors.push(error.to_string());
            }
        }));

        // The surface's preferred format, sRGB or not: cdrf-render encodes sRGB itself for
        // UNORM targets (`TargetDesc::encodes_srgb_in_shader`).
        let capabilities = surface.get_capabilities(&adapter);
        let Some(&format) = capabilities.formats.first() else {
            return Err(Failure::new(format!(
                "the adapter {} cannot present to this window (no surface formats)",
                adapter.get_info().name
            )));
        };
        let size = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            color_space: wgpu::SurfaceColorSpace::Auto,
            width: size.width.max(1),
            height: size.height.max(1),
            desired_maximum_frame_latency: 2,
            present_mode: wgpu::PresentMode::AutoVsync,
            alpha_mode: capabilities
                .alpha_modes
                .first()
                .copied()
                .unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: vec![],
        };
        surface.configure(&device, &config);

        let supports_msaa = |format| {
            adapter
                .get_texture_format_features(format)
                .flags
                .sample_count_supported(MSAA_SAMPLES)
        };
        let max_samples = if supports_msaa(format) && supports_msaa(DEPTH_FORMAT) {
            MSAA_SAMPLES
        } else {
            1
        };
        let target = TargetDesc::new(format)
            .with_sample_count(max_samples)
            .with_depth(DEPTH_FORMAT);
        let info = adapter.get_info();
        println!(
            "adapter: {} ({:?}, {:?}); surface {format:?}, {max_samples}× MSAA{}",
            info.name,
            info.device_type,
            info.backend,
            if target.encodes_srgb_in_shader() {
                ", sRGB encoded in the shader"
            } else {
                ""
            }
        );

        // cdrf-render: one renderer per target; meshes and materials uploaded once.
        let mut renderer = Renderer::new(&device, &target, Options::default());
        let mesh = renderer
            .create_mesh(
                &device,
                &MeshDesc::from_mesh(&scene.mesh, &scene.curvature_per_mm)
                    .with_curvature_anisotropy(&scene.curvature_anisotropy_per_mm),
            )
            .map_err(|e| Failure::caused(format!("uploading {}", scene.name), &e))?;
        let gaussian_desc = MaterialDesc::Gaussian {
            model: &scene.gaussian,
            view_correction: &scene.view_correction,
        };
        let descs = [
            MaterialDesc::Measured {
                lut: &scene.measured,
            },
            gaussian_desc,
            // The Gaussian's scale as albedo: same colour, no translucency.
            MaterialDesc::Lambert {
                albedo: scene.gaussian.scale(),
            },
            MaterialDesc::Curvature {
                range_per_mm: scene.curvature_range_per_mm,
            },
        ];
        // One material per model, indexed by `ShadingModel as usize` (the keys 1 to 4).
        debug_assert!(descs.iter().map(MaterialDesc::model).eq(ShadingModel::ALL));
        let mut materials = Vec::with_capacity(descs.len());
        for desc in &descs {
            let material = renderer
                .create_material(&device, &queue, desc)
                .map_err(|e| Failure::caused("creating a material", &e))?;
            materials.push(material);
        }
        let materials = [materials[0], materials[1], materials[2], materials[3]];
        // The specular layer on at start (the `P` key takes it off).
        for material in &materials[..3] {
            renderer
                .set_material_specular(&queue, *material, Some(SpecularLayer::default()))
                .map_err(|e| Failure::caused("setting the specular layer", &e))?;
        }

        let attachments = Attachments::new(&device, &config, &target);
        Ok(Self {
            window,
            instance,
            surface,
            device,
            queue,
            config,
            max_samples,
            target,
            attachments,
            gpu_errors,
            renderer,
            mesh,
            materials,
        })
    }

    fn is_minimized(&self) -> bool {
        let size = self.window.inner_size();
        size.width == 0 || size.height == 0
    }

    /// Reconfigures the surface for the window's size (a 0 × 0 window is left alone: nothing is
    /// drawn until it has an area again).
    fn resize(&mut self) {
        let size = self.window.inner_size();
        if size.width == 0 || size.height == 0 {
            return;
        }
        self.config.width = size.width;
        self.config.height = size.height;
        self.surface.configure(&self.device, &self.config);
        self.attachments = Attachments::new(&self.device, &self.config, &self.target);
    }

    /// Switches between 4× MSAA and none: new attachments, and the renderer told of the new
    /// target (its pipelines are cached per target, so switching back costs nothing).
    fn toggle_msaa(&mut self) {
        let samples = if self.target.sample_count == 1 {
            self.max_samples
        } else {
            1
        };
        self.target = self.target.with_sample_count(samples);
        self.renderer.set_target(&self.target);
        self.attachments = Attachments::new(&self.device, &self.config, &self.target);
    }

    /// Puts the specular layer on the three shading materials, or takes it off.
    fn set_specular(&mut self, layer: Option<SpecularLayer>) -> Result<(), Failure> {
        for material in &self.materials[..3] {
            self.renderer
                .set_material_specular(&self.queue, *material, layer)
                .map_err(|e| Failure::caused("setting the specular layer", &e))?;
        }
        Ok(())
    }

    fn draw_frame(
        &mut self,
        view: View,
        lights: &[cdrf_render::Light],
        shading: ShadingModel,
        non_local: NonLocal,
        mm_per_world_unit: f32,
        environment: Option<&ShCoefficients>,
    ) -> Result<Frame, Failure> {
        let (surface_texture, suboptimal) = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(texture) => (texture, false),
            wgpu::CurrentSurfaceTexture::Suboptimal(texture) => (texture, true),
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => {
                return Ok(Frame::Skipped);
            }
            wgpu::CurrentSurfaceTexture::Outdated => {
                self.resize();
                return Ok(Frame::Skipped);
            }
            wgpu::CurrentSurfaceTexture::Lost => {
                self.surface = self
                    .instance
                    .create_surface(self.window.clone())
                    .map_err(|e| Failure::caused("recreating the lost surface", &e))?;
                self.resize();
                return Ok(Frame::Skipped);
            }
            wgpu::CurrentSurfaceTexture::Validation => {
                return Err(self.take_gpu_errors().unwrap_or_else(|| {
                    Failure::new("wgpu: validation error acquiring the swap-chain image")
                }));
            }
        };
        let surface_view = surface_texture.texture.create_view(&Default::default());

        // cdrf-render: upload this frame's camera, light and draw list.
        let draws = [Draw::new(
            self.mesh,
            self.materials[shading as usize],
            cdrf_core::glam::Mat4::IDENTITY,
        )];
        // With shadows or transmission on, this returns the shadow pass to submit first.
        let shadow_pass = self
            .renderer
            .prepare(
                &self.device,
                &self.queue,
                &FrameDesc {
                    view,
                    lights,
                    exposure: 1.0,
                    draws: &draws,
                    non_local,
                    mm_per_world_unit,
                    environment,
                },
            )
            .map_err(|e| Failure::caused("preparing the frame", &e))?;

        // The host's pass: its own clear colour, depth and MSAA resolve.
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("winit_host frame"),
            });
        {
            let (view, resolve_target, store) = match &self.attachments.msaa_color {
                Some(msaa) => (msaa, Some(&surface_view), wgpu::StoreOp::Discard),
                None => (&surface_view, None, wgpu::StoreOp::Store),
            };
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("winit_host pass"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view,
                    depth_slice: None,
                    resolve_target,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(clear_color(&self.target)),
                        store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.attachments.depth,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                ..Default::default()
            });
            // (The host would draw its own geometry here too.)
            // cdrf-render: record into the host's pass.
            self.renderer.render(&mut pass);
        }
        self.queue
            .submit(shadow_pass.into_iter().chain([encoder.finish()]));
        self.queue.present(surface_texture);
        if suboptimal {
            self.resize();
        }
        match self.take_gpu_errors() {
            Some(failure) => Err(failure),
            None => Ok(Frame::Presented),
        }
    }

    fn take_gpu_errors(&self) -> Option<Failure> {
        let mut errors = self.gpu_errors.lock().ok()?;
        if errors.is_empty() {
            return None;
        }
        let message = format!("wgpu: {}", errors.join("\nwgpu: "));
        errors.clear();
        Some(Failure::new(message))
    }
}

impl Attachments {
    fn new(
        device: &wgpu::Device,
        config: &wgpu::SurfaceConfiguration,
        target: &TargetDesc,
    ) -> Self {
        let texture = |label, format, samples| {
            device
                .create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size: wgpu::Extent3d {
                        width: config.width,
                        height: config.height,
                        depth_or_array_layers: 1,
                    },
                    mip_level_count: 1,
                    sample_count: samples,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                    view_formats: &[],
                })
                .create_view(&Default::default())
        };
        let samples = target.sample_count;
        Self {
            msaa_color: (samples > 1)
                .then(|| texture("winit_host msaa colour", config.format, samples)),
            depth: texture("winit_host depth", DEPTH_FORMAT, samples),
        }
    }
}

/// The clear colour as the target stores it: clear values bypass the shader, so a UNORM
/// target whose sRGB encoding cdrf-render does in the shader needs it encoded here as well.
fn clear_color(target: &TargetDesc) -> wgpu::Color {
    let encode = |c: f64| {
        if !target.encodes_srgb_in_shader() {
            c
        } else if c <= 0.003_130_8 {
            12.92 * c
        } else {
            1.055 * c.powf(1.0 / 2.4) - 0.055
        }
    };
    let [r, g, b] = CLEAR_LINEAR.map(encode);
    wgpu::Color { r, g, b, a: 1.0 }
}

/// The winit application: scene data, the GPU once resumed, input state and timing.
struct App {
    display: OwnedDisplayHandle,
    config: Config,
    scene: SceneData,
    gpu: Option<Gpu>,
    /// Set when something failed; `main` returns it after the loop exits.
    failure: Option<Failure>,
    shading: ShadingModel,
    non_local: NonLocal,
    light: Light,
    light_kind: LightKind,
    specular: bool,
    /// The environment light's SH (a uniform sky until a map is dropped), and whether it is on.
    environment: ShCoefficients,
    environment_on: bool,
    last_frame: Option<Instant>,
    frames_presented: u64,
    title_frames: u32,
    title_since: Instant,
}

impl App {
    fn new(display: OwnedDisplayHandle, config: Config, scene: SceneData) -> Self {
        Self {
            display,
            config,
            scene,
            gpu: None,
            failure: None,
            shading: ShadingModel::Measured,
            non_local: NonLocal::OFF,
            // Start lit from the left, like the wax photographs.
            light: Light {
                azimuth_rad: -FRAC_PI_2,
                elevation_rad: 0.0,
                rotating: true,
            },
            light_kind: LightKind::Directional,
            specular: true,
            environment: Environment::uniform([0.3; 3])
                .expect("a finite sky")
                .project_sh(ENVIRONMENT_SH_ORDER),
            environment_on: false,
            last_frame: None,
            frames_presented: 0,
            title_frames: 0,
            title_since: Instant::now(),
        }
    }

    fn fail(&mut self, event_loop: &ActiveEventLoop, failure: Failure) {
        self.failure = Some(failure);
        event_loop.exit();
    }

    fn key(&mut self, event_loop: &ActiveEventLoop, event: &KeyEvent) {
        if event.state != ElementState::Pressed {
            return;
        }
        let PhysicalKey::Code(code) = event.physical_key else {
            return;
        };
        let light = &mut self.light;
        match code {
            KeyCode::Digit1 | KeyCode::Numpad1 => self.shading = ShadingModel::Measured,
            KeyCode::Digit2 | KeyCode::Numpad2 => self.shading = ShadingModel::Gaussian,
            KeyCode::Digit3 | KeyCode::Numpad3 => self.shading = ShadingModel::Lambert,
            KeyCode::Digit4 | KeyCode::Numpad4 => self.shading = ShadingModel::Curvature,
            KeyCode::ArrowLeft | KeyCode::ArrowRight => {
                let sign = if code == KeyCode::ArrowLeft {
                    -1.0
                } else {
                    1.0
                };
                light.azimuth_rad += sign * LIGHT_STEP_RAD;
                light.rotating = false;
            }
            KeyCode::ArrowUp | KeyCode::ArrowDown => {
                let sign = if code == KeyCode::ArrowDown {
                    -1.0
                } else {
                    1.0
                };
                let limit = 85.0_f32.to_radians();
                light.elevation_rad =
                    (light.elevation_rad + sign * LIGHT_STEP_RAD).clamp(-limit, limit);
                light.rotating = false;
            }
            KeyCode::Space if !event.repeat => light.rotating = !light.rotating,
            KeyCode::KeyM if !event.repeat => {
                if let Some(gpu) = &mut self.gpu {
                    gpu.toggle_msaa();
                }
            }
            KeyCode::KeyS if !event.repeat => self.non_local.shadows = !self.non_local.shadows,
            KeyCode::KeyT if !event.repeat => {
                self.non_local.transmission = !self.non_local.transmission;
            }
            KeyCode::KeyI if !event.repeat => {
                self.non_local.interreflection = !self.non_local.interreflection;
            }
            KeyCode::KeyU if !event.repeat => {
                self.non_local.subsurface = !self.non_local.subsurface;
            }
            KeyCode::KeyL if !event.repeat => self.light_kind = self.light_kind.next(),
            KeyCode::KeyP if !event.repeat => {
                self.specular = !self.specular;
                if let Some(gpu) = &mut self.gpu
                    && let Err(failure) =
                        gpu.set_specular(self.specular.then(SpecularLayer::default))
                {
                    self.fail(event_loop, failure);
                }
            }
            KeyCode::KeyE if !event.repeat => self.environment_on = !self.environment_on,
            KeyCode::Escape => event_loop.exit(),
            _ => {}
        }
    }

    fn redraw(&mut self, event_loop: &ActiveEventLoop) {
        let Some(gpu) = &mut self.gpu else {
            return;
        };
        if gpu.is_minimized() {
            // Nothing to draw into; `Resized` asks for a redraw once there is.
            self.last_frame = None;
            return;
        }
        let now = Instant::now();
        let dt_s = self
            .last_frame
            .map_or(0.0, |last| (now - last).as_secs_f32().min(0.1));
        self.last_frame = Some(now);
        if self.light.rotating {
            self.light.azimuth_rad = (self.light.azimuth_rad + LIGHT_RAD_PER_S * dt_s) % (2.0 * PI);
        }

        let size = gpu.window.inner_size();
        let view = self.scene.view(size.width as f32 / size.height as f32);
        // Irradiance π: a white Lambertian surface facing the light has radiance 1 (for a
        // lamp, at the model's centre, three radii away).
        let to_light = self.light.to_light();
        let centre = (self.scene.bounds_min + self.scene.bounds_max) / 2.0;
        let distance = 1.5 * (self.scene.bounds_max - self.scene.bounds_min).length();
        let lamp =
            || PointLight::facing(centre, to_light, distance, self.config.mm_per_unit, [PI; 3]);
        let lights: [cdrf_render::Light; 1] = [match self.light_kind {
            LightKind::Directional => DirectionalLight {
                to_light,
                irradiance: [PI; 3],
            }
            .into(),
            LightKind::Point => lamp().into(),
            LightKind::Spot => {
                SpotLight::aimed_at(lamp(), centre, 15f32.to_radians(), 25f32.to_radians()).into()
            }
        }];
        let environment = self.environment_on.then_some(&self.environment);
        // The mesh is drawn in its own units: world units are model units.
        let mm_per_world_unit = self.config.mm_per_unit;
        match gpu.draw_frame(
            view,
            &lights,
            self.shading,
            self.non_local,
            mm_per_world_unit,
            environment,
        ) {
            Ok(Frame::Presented) => {
                self.frames_presented += 1;
                self.title_frames += 1;
            }
            Ok(Frame::Skipped) => {}
            Err(failure) => return self.fail(event_loop, failure),
        }

        let elapsed = now.duration_since(self.title_since);
        if elapsed >= TITLE_INTERVAL && self.title_frames > 0 {
            let ms_per_frame = elapsed.as_secs_f64() * 1e3 / f64::from(self.title_frames);
            gpu.window.set_title(&format!(
                "cdrf winit_host — {} — {} light — {}{}{}{}{}{}{} — {}× MSAA — {ms_per_frame:.1} ms/frame",
                self.scene.name,
                self.light_kind.name(),
                self.shading.label(),
                if self.specular { " + specular" } else { "" },
                if self.environment_on { " + sky" } else { "" },
                if self.non_local.shadows {
                    " + shadows"
                } else {
                    ""
                },
                if self.non_local.transmission {
                    " + transmission"
                } else {
                    ""
                },
                if self.non_local.interreflection {
                    " + inter-reflection"
                } else {
                    ""
                },
                if self.non_local.subsurface {
                    " + subsurface"
                } else {
                    ""
                },
                gpu.target.sample_count,
            ));
            self.title_since = now;
            self.title_frames = 0;
        }

        if self
            .config
            .exit_after_frames
            .is_some_and(|n| self.frames_presented >= n)
        {
            println!(
                "presented {} frames; exiting (CDRF_EXIT_AFTER_FRAMES)",
                self.frames_presented
            );
            event_loop.exit();
            return;
        }
        gpu.window.request_redraw();
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.gpu.is_some() {
            return;
        }
        match Gpu::new(event_loop, &self.display, &self.scene) {
            Ok(gpu) => {
                println!(
                    "keys: 1 measured, 2 Gaussian, 3 Lambert, 4 curvature; arrows move the \
                     light, Space rotates it, L its kind; P specular, E sky (drop an EXR map); \
                     S, T, I, U the non-local terms; M toggles MSAA; Esc quits"
                );
                gpu.window.request_redraw();
                self.title_since = Instant::now();
                self.gpu = Some(gpu);
            }
            Err(failure) => self.fail(event_loop, failure),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(_) => {
                if let Some(gpu) = &mut self.gpu {
                    gpu.resize();
                    gpu.window.request_redraw();
                }
            }
            WindowEvent::Occluded(false) => {
                if let Some(gpu) = &self.gpu {
                    gpu.window.request_redraw();
                }
            }
            WindowEvent::KeyboardInput { event, .. } => self.key(event_loop, &event),
            // An equirectangular OpenEXR becomes the environment light.
            WindowEvent::DroppedFile(path) => {
                let loaded = EquirectMap::read_exr(&path)
                    .and_then(|map| Environment::new(EnvironmentRadiance::Map(map), 1.0, 0.0));
                match loaded {
                    Ok(environment) => {
                        self.environment = environment.project_sh(ENVIRONMENT_SH_ORDER);
                        self.environment_on = true;
                        println!("{}: environment light", path.display());
                    }
                    Err(error) => eprintln!("{}: not used: {error}", path.display()),
                }
            }
            WindowEvent::RedrawRequested => self.redraw(event_loop),
            _ => {}
        }
    }
}
