//! cdrf-render: an embeddable wgpu render pass that shades curvature-tagged meshes with a
//! curvature-dependent reflectance function (CDRF).
//!
//! The pass is *middleware*: the host owns the instance, device, queue, surface and render
//! pass. [`Renderer::new`] takes the pass's [`TargetDesc`] (colour format, MSAA samples,
//! optional depth format); meshes and materials are uploaded once; each frame
//! [`Renderer::prepare`] uploads camera, lights and draw transforms and
//! [`Renderer::render`] records into the host's `RenderPass`.
//!
//! Output is **linear radiance** `L = Σ E/π · f(κ, θ) · g(θ, φ)` over the lights
//! (irradiance `E` per RGB channel), so a render can be compared pixel for pixel with a
//! physical reference. Shading models, per draw ([`MaterialDesc`]): the measured CDRF (a
//! [`cdrf_core::CdrfLut`] with its view correction), Kubo's Gaussian CDRF (tabulated or
//! analytic, [`GaussianEvaluation`]), Lambert, and a curvature view for debugging.
//!
//! ```
//! use cdrf_core::glam::{self, Mat4, Vec3};
//! use cdrf_core::{Mesh, mean_curvature_per_mm, read_lut, CurvatureOptions};
//! use cdrf_render::headless::{AdapterPreference, HeadlessDevice};
//! use cdrf_render::{wgpu, DirectionalLight, Draw, FrameDesc, Light, MaterialDesc, MeshDesc,
//!                   NonLocal, Options, PointLight, Renderer, TargetDesc, ToCamera, View};
//! # let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data");
//!
//! // The host's device (here a software one) and its colour target.
//! let host = HeadlessDevice::new(AdapterPreference::Software)?;
//! let (device, queue) = (&host.device, &host.queue);
//! let format = wgpu::TextureFormat::Rgba8UnormSrgb;
//! let mut renderer = Renderer::new(device, &TargetDesc::new(format), Options::default());
//!
//! // A sphere of radius 20 mm (mesh units are mm) and wax built into the crates: a full table
//! // (view correction, translucency, diffusion profile) fitted to simulated wax spheres.
//! // A table of your own, from cdrf-fit or cdrf-preset, is `MaterialDesc::Measured`:
//! // `read_lut(data.join("wax-fit/measured.exr"))?` is the one fitted to the wax photographs.
//! let sphere = Mesh::icosphere(20.0, 3);
//! let curvature = mean_curvature_per_mm(&sphere, &CurvatureOptions::new(1.0))?;
//! let mesh = renderer.create_mesh(device, &MeshDesc::from_mesh(&sphere, &curvature))?;
//! let material = renderer.create_material(device, queue, &MaterialDesc::preset("wax")?)?;
//! # let _measured = read_lut(data.join("wax-fit/measured.exr"))?;
//!
//! // Per frame: camera, lights, draws; then record into the host's pass.
//! let view = View {
//!     clip_from_world: glam::camera::rh::proj::directx::orthographic(-25.0, 25.0, -25.0, 25.0, 0.0, 100.0)
//!         * glam::camera::rh::view::look_at_mat4(Vec3::new(0.0, 0.0, 50.0), Vec3::ZERO, Vec3::Y),
//!     to_camera: ToCamera::Direction(Vec3::Z),
//! };
//! // A light from the left, and a lamp 100 mm in front (irradiance 0.2 facing it there).
//! let lights = [
//!     Light::Directional(DirectionalLight { to_light: Vec3::NEG_X, irradiance: [1.0; 3] }),
//!     Light::Point(PointLight { position: Vec3::new(0.0, 0.0, 100.0), intensity: [2000.0; 3] }),
//! ];
//! let draws = [Draw::new(mesh, material, Mat4::IDENTITY)];
//! let frame = FrameDesc {
//!     view, lights: &lights, exposure: 1.0, draws: &draws,
//!     non_local: NonLocal::OFF, mm_per_world_unit: 1.0, environment: None,
//! };
//! // The shadow pass's commands (none here: the non-local terms are off).
//! let shadow_pass = renderer.prepare(device, queue, &frame)?;
//!
//! let texture = device.create_texture(&wgpu::TextureDescriptor {
//!     label: Some("host target"),
//!     size: wgpu::Extent3d { width: 64, height: 64, depth_or_array_layers: 1 },
//!     mip_level_count: 1,
//!     sample_count: 1,
//!     dimension: wgpu::TextureDimension::D2,
//!     format,
//!     usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
//!     view_formats: &[],
//! });
//! let target = texture.create_view(&Default::default());
//! let mut encoder = device.create_command_encoder(&Default::default());
//! {
//!     let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
//!         color_attachments: &[Some(wgpu::RenderPassColorAttachment {
//!             view: &target,
//!             depth_slice: None,
//!             resolve_target: None,
//!             ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store },
//!         })],
//!         ..Default::default()
//!     });
//!     renderer.render(&mut pass);
//! }
//! queue.submit(shadow_pass.into_iter().chain([encoder.finish()]));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Without a window, [`headless::render_scene_file`] renders a scene file (format:
//! [`cdrf_core::scene`]) to an image — what tests, benchmarks and the viewer's `render`
//! command use.
//!
//! # Pass structure
//! Bind groups 0 (frame: camera, lights), 1 (material: LUT, view correction, parameters),
//! 2 (draw: transform, dynamic offset) and 3 (shadow maps) are set inside [`Renderer::render`].
//!
//! # Beyond the poster: cast shadows, transmission, inter-reflection, subsurface gather
//! [`FrameDesc::non_local`] turns on translucent visibility (cast shadows with a penumbra as wide
//! as the material's scattering length) and transmission T(d, μ) (see
//! [`cdrf_core::translucency`]). Then `prepare` also records a depth-only shadow pass — a map
//! per light for the first [`MAX_SHADOW_LIGHTS`] lights (directional ones first), fitted to the
//! bounding sphere of the frame's draws ([`Options::shadow_map_resolution`]): orthographic for
//! a directional light; for a point or spot light a perspective face aimed at the draws, or a
//! cube of six faces when the light is among them — and returns its
//! command buffer, which the host submits before the commands of its own pass (egui-wgpu's
//! callbacks return it from their `prepare`). The terms are evaluated per vertex (they vary
//! over the scattering length, millimetres, so meshes with shorter edges resolve them;
//! Lambert's hard shadows per pixel), once per vertex and frame by a compute pass recorded in
//! the same command buffers after the maps (the device needs compute shaders and storage
//! buffers for it: [`PrepareError::NoComputeShaders`] otherwise). A measured table carries its material terms
//! (LUT file format version 3, or 2 without the entry cosine); the Gaussian CDRF uses its σ as scattering length and has no
//! T(d); Lambert gets hard shadows.
//!
//! [`NonLocal::interreflection`] adds the light that leaves one part of the draws — lit side
//! and glow alike — and enters another through the air, bounce after bounce: every mesh is cut
//! into patches when it is created ([`Options::interreflection_patches`];
//! [`cdrf_core::patches`]), and after the vertex terms further compute passes average each
//! patch's exitance, pass light between the patches ([`Options::interreflection_bounces`]) and
//! gather it at every vertex, which answers with its CDRF. It needs no light map, and serves
//! every light.
//!
//! [`NonLocal::subsurface`] adds the light that entered the lit surface near each point and
//! reached it through the medium, by the table's diffusion profile (LUT format version 4;
//! [`cdrf_core::diffusion::FarField`]): the command buffer then also renders each shadowed
//! light's lit surface into a pyramid ([`Options::subsurface_cut_mm`],
//! [`Options::subsurface_max_resolution`]) that every vertex gathers, and the shading reads the
//! table without what it already holds through the osculating sphere. For a material with a
//! profile it replaces T(d, μ), and the penumbra spreads as the table's near field does
//! (about the cut's width, per channel).

mod constants;
mod draw_buffer;
mod error;
mod frame;
mod frame_uniforms;
mod gpu_data;
mod gpu_types;
pub mod headless;
mod ids;
mod material;
mod mesh;
pub mod offscreen;
mod passes;
mod pipelines;
pub mod readback;
mod renderer;
pub mod shaders;
pub mod surface;
mod target;

pub use cdrf_core::environment::{Environment, ShCoefficients};
pub use cdrf_core::light::{DirectionalLight, Incidence, Light, NonLocal, PointLight, SpotLight};
pub use cdrf_core::specular::SpecularLayer;
pub use constants::{ENVIRONMENT_SH_ORDER, MAX_LIGHTS, MAX_SHADOW_LIGHTS};
pub use error::{MaterialError, MeshUploadError, PrepareError, SurfaceError, TargetError};
pub use frame::{Draw, FrameDesc, MAX_EXPOSURE, ToCamera, View};
pub use ids::{MaterialId, MeshId, SurfaceId};
pub use material::MaterialDesc;
pub use mesh::{MeshDesc, MeshVertices};
pub use offscreen::OffscreenTarget;
pub use renderer::Renderer;
pub use surface::{SurfaceDesc, SurfaceRoughness};
pub use target::{GaussianEvaluation, LutFiltering, Options, TargetDesc};
/// The wgpu this crate is built against (use it to avoid version mismatches).
pub use wgpu;
