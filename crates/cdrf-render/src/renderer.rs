//! The render pass: [`Renderer`] and the descriptions the host hands it.

use std::collections::HashMap;
use std::fmt;
use std::num::NonZeroU64;

use cdrf_core::gaussian::GaussianCdrf;
use cdrf_core::glam::{Mat3, Mat4, Vec3, Vec4};
use cdrf_core::lut::LutError;
use cdrf_core::scene::{DirectionalLight, NonLocal};
use cdrf_core::{CdrfLut, CurvatureAxis, Mesh, ViewCorrection};
use wgpu::util::DeviceExt;

use crate::gpu_data::{Bytes, block_on, rgba16f_texels};
use crate::target::{GaussianEvaluation, LutFiltering, Options, TargetDesc};

/// The WGSL source of every shading pipeline (`shaders/cdrf.wgsl`).
pub const SHADER_SOURCE: &str = include_str!("../../../shaders/cdrf.wgsl");
/// The WGSL source of the shadow pass (`shaders/shadow.wgsl`).
pub const SHADOW_SHADER_SOURCE: &str = include_str!("../../../shaders/shadow.wgsl");

/// Most directional lights in one frame (`MAX_LIGHTS` in the shader).
pub const MAX_LIGHTS: usize = 16;
/// Lights with a shadow map: the first ones of a frame (`MAX_SHADOW_LIGHTS` in the shader). Later
/// lights shade with the local model only.
pub const MAX_SHADOW_LIGHTS: usize = 4;
/// The shadow maps' depth format.
const SHADOW_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// Size of the `Shadows` uniform: per light a mat4 and a vec4, then the parameters.
const SHADOWS_UNIFORM_SIZE: u64 = (64 + 16) * MAX_SHADOW_LIGHTS as u64 + 16;

/// Bytes per vertex: position (3 × f32), normal (3 × f32), curvature (f32).
const VERTEX_STRIDE: u64 = 28;
/// Size of the `Frame` uniform: clip_from_world, to_camera, exposure_count, lights.
const FRAME_UNIFORM_SIZE: u64 = 64 + 16 + 16 + 32 * MAX_LIGHTS as u64;
/// Penumbra taps per shadowed light (`PENUMBRA_TAPS` in the shader).
const PENUMBRA_TAPS: usize = 12;
/// Size of the `Material` uniform: eight vec4s and a tap weight per penumbra tap.
const MATERIAL_UNIFORM_SIZE: u64 = (8 + PENUMBRA_TAPS as u64) * 16;
/// Size of one `Draw` uniform: two mat4s and a vec4.
const DRAW_UNIFORM_SIZE: u64 = 64 + 64 + 16;

/// A mesh uploaded with [`Renderer::create_mesh`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MeshId(u64);

/// A material uploaded with [`Renderer::create_material`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MaterialId(u64);

/// A mesh to upload: triangles with per-vertex normals and mean curvature.
#[derive(Clone, Copy, Debug)]
pub struct MeshDesc<'a> {
    /// Positions, normals and triangles (model units).
    pub mesh: &'a Mesh,
    /// Signed mean curvature per vertex in mm⁻¹, of the mesh as it is in model units (e.g.
    /// `cdrf_core::mean_curvature_per_mm` with the mesh's mm-per-unit). A draw's model
    /// transform rescales it: an object drawn twice as large has half the curvature.
    pub curvature_per_mm: &'a [f32],
}

/// How a material shades: the shading model and its data.
#[derive(Clone, Copy, Debug)]
pub enum MaterialDesc<'a> {
    /// The measured CDRF: `LUT(κ, θ) · g(θ, φ)` from a table (cdrf-fit's `measured.exr`).
    Measured {
        /// The table with its view correction.
        lut: &'a CdrfLut,
    },
    /// Kubo's Gaussian CDRF with a view correction (evaluated as [`Options::gaussian`] says).
    Gaussian {
        /// σ and scale per channel.
        model: &'a GaussianCdrf,
        /// g(θ, φ), usually the one of the measured table fitted from the same photographs.
        view_correction: &'a ViewCorrection,
    },
    /// Lambert: `π·L/E = albedo · max(cos θ, 0)`, no view dependence.
    Lambert {
        /// Albedo per RGB channel.
        albedo: [f32; 3],
    },
    /// Debug view: the curvature colour-mapped (cool–warm) from `range_per_mm[0]` (blue) to
    /// `range_per_mm[1]` (red); not radiance.
    Curvature {
        /// κ at the colour map's ends, mm⁻¹.
        range_per_mm: [f32; 2],
    },
}

/// Where the camera is, for the view angle φ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ToCamera {
    /// A perspective camera at this world position.
    Point(Vec3),
    /// An orthographic camera: this unit vector points toward it.
    Direction(Vec3),
}

/// The camera of a frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// World → clip space (wgpu conventions: depth 0..1).
    pub clip_from_world: Mat4,
    /// The camera position or direction.
    pub to_camera: ToCamera,
}

impl View {
    /// The view of a scene-file camera, with the given near and far distances (world units).
    pub fn from_camera(camera: &cdrf_core::scene::Camera, near: f32, far: f32) -> Self {
        let to_camera = match camera.projection {
            cdrf_core::scene::Projection::Orthographic { .. } => {
                ToCamera::Direction((camera.eye - camera.target).normalize())
            }
            cdrf_core::scene::Projection::Perspective { .. } => ToCamera::Point(camera.eye),
        };
        Self {
            clip_from_world: camera.clip_from_view(near, far) * camera.view_from_world(),
            to_camera,
        }
    }
}

/// One object to draw: a mesh, a material and where it is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Draw {
    /// The mesh.
    pub mesh: MeshId,
    /// How it is shaded.
    pub material: MaterialId,
    /// Model → world. Its scale (the cube root of the determinant, for a non-uniform scale)
    /// divides the mesh's curvature.
    pub world_from_model: Mat4,
}

/// Everything that changes per frame.
#[derive(Clone, Copy, Debug)]
pub struct FrameDesc<'a> {
    /// The camera.
    pub view: View,
    /// Directional lights (at most [`MAX_LIGHTS`]), irradiance in linear units.
    pub lights: &'a [DirectionalLight],
    /// Multiplies the radiance (1 for physical output).
    pub exposure: f32,
    /// The objects, drawn in this order.
    pub draws: &'a [Draw],
    /// The non-local terms ([`NonLocal::OFF`]: the poster's local model). When any is on,
    /// `prepare` renders a shadow map for each of the first [`MAX_SHADOW_LIGHTS`] lights and
    /// returns its commands.
    pub non_local: NonLocal,
    /// Millimetres per world unit: turns shadow-map depths into the thicknesses T(d) and the
    /// penumbra widths need (the scene file's `mm_per_unit`).
    pub mm_per_world_unit: f32,
}

/// Why a mesh could not be uploaded.
#[derive(Debug)]
#[non_exhaustive]
pub enum MeshUploadError {
    /// The mesh has no triangles.
    Empty,
    /// The curvature slice does not have one value per vertex.
    CurvatureCount {
        /// Values given.
        found: usize,
        /// Vertices in the mesh.
        vertices: usize,
    },
    /// A curvature value is NaN or infinite.
    NonFiniteCurvature {
        /// The vertex.
        vertex: usize,
        /// Its value.
        value: f32,
    },
}

/// Why a material could not be created.
#[derive(Debug)]
#[non_exhaustive]
pub enum MaterialError {
    /// Tabulating the Gaussian CDRF failed.
    Tabulate(LutError),
    /// A parameter is out of range.
    Parameter {
        /// The parameter.
        what: &'static str,
        /// Its value.
        value: Vec<f32>,
        /// What it must be.
        requirement: &'static str,
    },
    /// A table is larger than the device's largest 2D texture.
    TooLarge {
        /// Which table.
        what: &'static str,
        /// Columns.
        width: usize,
        /// Rows.
        height: usize,
        /// The device's limit.
        max: u32,
    },
}

/// Why a frame could not be prepared. Nothing is drawn until a `prepare` succeeds.
#[derive(Debug)]
#[non_exhaustive]
pub enum PrepareError {
    /// More lights than the shader holds.
    TooManyLights {
        /// Lights given.
        count: usize,
    },
    /// A light's direction or irradiance is not usable.
    BadLight {
        /// The light.
        index: usize,
        /// What is wrong.
        problem: &'static str,
    },
    /// A draw names a mesh that does not exist (never created, or removed).
    UnknownMesh {
        /// The draw.
        index: usize,
        /// Its mesh.
        mesh: MeshId,
    },
    /// A draw names a material that does not exist.
    UnknownMaterial {
        /// The draw.
        index: usize,
        /// Its material.
        material: MaterialId,
    },
    /// A draw's transform is singular, mirroring (negative determinant) or not finite.
    BadTransform {
        /// The draw.
        index: usize,
    },
    /// The view matrix, camera position or direction, or exposure is unusable.
    BadView,
    /// [`FrameDesc::mm_per_world_unit`] is not finite and > 0.
    BadUnits {
        /// The value given.
        mm_per_world_unit: f32,
    },
    /// The device refused the pipeline for the current target (an unsupported colour format,
    /// sample count or depth format).
    Pipeline {
        /// The target.
        target: TargetDesc,
        /// What wgpu said.
        message: String,
    },
}

impl fmt::Display for MeshUploadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Empty => write!(f, "the mesh has no triangles"),
            Self::CurvatureCount { found, vertices } => {
                write!(f, "{found} curvature values for {vertices} vertices")
            }
            Self::NonFiniteCurvature { vertex, value } => {
                write!(f, "curvature of vertex {vertex} is {value}: must be finite")
            }
        }
    }
}

impl std::error::Error for MeshUploadError {}

impl fmt::Display for MaterialError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Tabulate(error) => write!(f, "tabulating the Gaussian CDRF: {error}"),
            Self::Parameter {
                what,
                value,
                requirement,
            } => write!(f, "{what} = {value:?}: {requirement}"),
            Self::TooLarge {
                what,
                width,
                height,
                max,
            } => write!(
                f,
                "{what} is {width} × {height} texels; the device allows {max} per side"
            ),
        }
    }
}

impl std::error::Error for MaterialError {}

impl From<LutError> for MaterialError {
    fn from(error: LutError) -> Self {
        Self::Tabulate(error)
    }
}

impl fmt::Display for PrepareError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::TooManyLights { count } => {
                write!(f, "{count} lights: at most {MAX_LIGHTS} per frame")
            }
            Self::BadLight { index, problem } => write!(f, "light {index}: {problem}"),
            Self::UnknownMesh { index, mesh } => write!(f, "draw {index}: unknown mesh {mesh:?}"),
            Self::UnknownMaterial { index, material } => {
                write!(f, "draw {index}: unknown material {material:?}")
            }
            Self::BadTransform { index } => write!(
                f,
                "draw {index}: the model transform is singular, mirroring or not finite"
            ),
            Self::BadView => write!(
                f,
                "the view matrix or camera position is not finite, the camera direction is zero, \
                 or the exposure is negative or not finite"
            ),
            Self::BadUnits { mm_per_world_unit } => write!(
                f,
                "mm per world unit = {mm_per_world_unit}: must be finite and > 0"
            ),
            Self::Pipeline { target, message } => {
                write!(f, "the device cannot render to {target:?}: {message}")
            }
        }
    }
}

impl std::error::Error for PrepareError {}

/// The pipelines' shading variants (the shader's `MODEL` constant).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Model {
    Measured = 0,
    GaussianLut = 1,
    GaussianAnalytic = 2,
    Lambert = 3,
    Curvature = 4,
}

struct GpuMesh {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
    /// Bounding sphere in model units: centre and radius.
    bounds: (Vec3, f32),
}

/// The shadow maps and what the shading pipelines read of them (bind group 3).
struct ShadowMaps {
    resolution: u32,
    /// One view per layer, to render into.
    layers: Vec<wgpu::TextureView>,
    bind_group: wgpu::BindGroup,
}

/// The pipeline variants' key: target, shading model, non-local terms.
type PipelineKey = (TargetDesc, Model, NonLocal);

struct GpuMaterial {
    model: Model,
    bind_group: wgpu::BindGroup,
}

#[derive(Clone, Copy)]
struct PreparedDraw {
    non_local: NonLocal,
    mesh: MeshId,
    material: MaterialId,
    offset: u32,
}

/// Shades curvature-tagged meshes with a CDRF inside the host's render pass.
///
/// The host owns the device, the queue and the pass. Per frame: [`Renderer::prepare`] (uploads
/// the camera, lights and draw transforms, builds any missing pipeline), then
/// [`Renderer::render`] records into the host's pass. Meshes and materials are uploaded once
/// with [`Renderer::create_mesh`] / [`Renderer::create_material`]. See the crate docs for an
/// example.
pub struct Renderer {
    options: Options,
    target: TargetDesc,
    shader: wgpu::ShaderModule,
    material_layout: wgpu::BindGroupLayout,
    draw_layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
    pipelines: HashMap<PipelineKey, wgpu::RenderPipeline>,
    shadow_layout: wgpu::BindGroupLayout,
    shadows_buffer: wgpu::Buffer,
    /// Bound when no shadow map exists yet (a 1 × 1 map).
    no_shadows: wgpu::BindGroup,
    shadow_maps: Option<ShadowMaps>,
    shadow_pass_buffer: wgpu::Buffer,
    shadow_pass_bind_group: wgpu::BindGroup,
    shadow_pass_stride: u64,
    shadow_pipeline: wgpu::RenderPipeline,
    /// Lights whose shadow map the last `prepare` rendered.
    shadowed_lights: usize,
    sampler: wgpu::Sampler,
    frame_buffer: wgpu::Buffer,
    frame_bind_group: wgpu::BindGroup,
    draw_buffer: wgpu::Buffer,
    draw_bind_group: wgpu::BindGroup,
    draw_stride: u64,
    draw_capacity: u64,
    meshes: HashMap<MeshId, GpuMesh>,
    materials: HashMap<MaterialId, GpuMaterial>,
    next_id: u64,
    prepared: Vec<PreparedDraw>,
    max_texture_side: u32,
}

impl Renderer {
    /// A renderer for passes with the given target. Builds its layouts and shader; pipelines
    /// are built in [`Renderer::prepare`] for the shading models the frame uses.
    pub fn new(device: &wgpu::Device, target: &TargetDesc, options: Options) -> Self {
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("cdrf shader"),
            source: wgpu::ShaderSource::Wgsl(SHADER_SOURCE.into()),
        });
        let uniform = |binding, size: u64, dynamic| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: dynamic,
                min_binding_size: NonZeroU64::new(size),
            },
            count: None,
        };
        let texture = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: true },
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            },
            count: None,
        };
        let frame_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cdrf frame layout"),
            entries: &[uniform(0, FRAME_UNIFORM_SIZE, false)],
        });
        let material_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cdrf material layout"),
            entries: &[
                uniform(0, MATERIAL_UNIFORM_SIZE, false),
                texture(1),
                texture(2),
                wgpu::BindGroupLayoutEntry {
                    binding: 3,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        });
        let draw_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cdrf draw layout"),
            entries: &[uniform(0, DRAW_UNIFORM_SIZE, true)],
        });
        let shadow_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cdrf shadows layout"),
            entries: &[
                uniform(0, SHADOWS_UNIFORM_SIZE, false),
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    // Read per vertex (translucent materials) and per pixel (Lambert).
                    visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Depth,
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                    count: None,
                },
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("cdrf pipeline layout"),
            bind_group_layouts: &[
                Some(&frame_layout),
                Some(&material_layout),
                Some(&draw_layout),
                Some(&shadow_layout),
            ],
            immediate_size: 0,
        });
        let shadows_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cdrf shadow uniforms"),
            size: SHADOWS_UNIFORM_SIZE,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let (_, no_shadows) = create_shadow_maps(device, &shadow_layout, &shadows_buffer, 1);
        let shadow_pass_layout =
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("cdrf shadow pass layout"),
                entries: &[wgpu::BindGroupLayoutEntry {
                    visibility: wgpu::ShaderStages::VERTEX,
                    ..uniform(0, 64, true)
                }],
            });
        let alignment = u64::from(device.limits().min_uniform_buffer_offset_alignment);
        let shadow_pass_stride = 64u64.next_multiple_of(alignment);
        let shadow_pass_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cdrf shadow pass uniforms"),
            size: shadow_pass_stride * MAX_SHADOW_LIGHTS as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let shadow_pass_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cdrf shadow pass"),
            layout: &shadow_pass_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &shadow_pass_buffer,
                    offset: 0,
                    size: NonZeroU64::new(64),
                }),
            }],
        });
        let shadow_pipeline = create_shadow_pipeline(device, &[&shadow_pass_layout, &draw_layout]);
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("cdrf lut sampler"),
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let frame_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cdrf frame uniforms"),
            size: FRAME_UNIFORM_SIZE,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let frame_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cdrf frame"),
            layout: &frame_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: frame_buffer.as_entire_binding(),
            }],
        });
        let draw_stride = DRAW_UNIFORM_SIZE.next_multiple_of(alignment);
        let (draw_buffer, draw_bind_group) =
            create_draw_buffer(device, &draw_layout, draw_stride, 16);
        Self {
            options,
            target: *target,
            shader,
            material_layout,
            draw_layout,
            pipeline_layout,
            pipelines: HashMap::new(),
            shadow_layout,
            shadows_buffer,
            no_shadows,
            shadow_maps: None,
            shadow_pass_buffer,
            shadow_pass_bind_group,
            shadow_pass_stride,
            shadow_pipeline,
            shadowed_lights: 0,
            sampler,
            frame_buffer,
            frame_bind_group,
            draw_buffer,
            draw_bind_group,
            draw_stride,
            draw_capacity: 16,
            meshes: HashMap::new(),
            materials: HashMap::new(),
            next_id: 0,
            prepared: Vec::new(),
            max_texture_side: device.limits().max_texture_dimension_2d,
        }
    }

    /// The options this renderer was made with.
    pub fn options(&self) -> &Options {
        &self.options
    }

    /// The target the next [`Renderer::render`] records for.
    pub fn target(&self) -> &TargetDesc {
        &self.target
    }

    /// Renders into passes with another target from the next [`Renderer::prepare`] on
    /// (pipelines are cached per target, so switching back is free). Until that `prepare`,
    /// `render` draws nothing.
    pub fn set_target(&mut self, target: &TargetDesc) {
        if *target != self.target {
            self.target = *target;
            self.prepared.clear();
        }
    }

    /// Uploads a mesh.
    ///
    /// # Errors
    /// [`MeshUploadError`] when the mesh is empty or the curvature does not match it.
    pub fn create_mesh(
        &mut self,
        device: &wgpu::Device,
        desc: &MeshDesc<'_>,
    ) -> Result<MeshId, MeshUploadError> {
        let mesh = desc.mesh;
        if mesh.triangles.is_empty() {
            return Err(MeshUploadError::Empty);
        }
        if desc.curvature_per_mm.len() != mesh.positions.len() {
            return Err(MeshUploadError::CurvatureCount {
                found: desc.curvature_per_mm.len(),
                vertices: mesh.positions.len(),
            });
        }
        if let Some((vertex, &value)) = desc
            .curvature_per_mm
            .iter()
            .enumerate()
            .find(|(_, k)| !k.is_finite())
        {
            return Err(MeshUploadError::NonFiniteCurvature { vertex, value });
        }
        let mut vertices = Bytes::with_capacity(mesh.positions.len() * VERTEX_STRIDE as usize);
        for ((&position, &normal), &curvature) in mesh
            .positions
            .iter()
            .zip(&mesh.normals)
            .zip(desc.curvature_per_mm)
        {
            vertices.vec3(position).vec3(normal).f32(curvature);
        }
        let indices: Vec<u8> = mesh
            .triangles
            .iter()
            .flatten()
            .flat_map(|index| index.to_ne_bytes())
            .collect();
        let id = MeshId(self.next_id());
        let gpu = GpuMesh {
            vertices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("cdrf mesh vertices"),
                contents: &vertices.0,
                usage: wgpu::BufferUsages::VERTEX,
            }),
            indices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("cdrf mesh indices"),
                contents: &indices,
                usage: wgpu::BufferUsages::INDEX,
            }),
            index_count: (mesh.triangles.len() * 3) as u32,
            bounds: bounding_sphere(&mesh.positions),
        };
        self.meshes.insert(id, gpu);
        Ok(id)
    }

    /// Frees a mesh; draws naming it are skipped from the next `prepare` on.
    pub fn remove_mesh(&mut self, mesh: MeshId) {
        self.meshes.remove(&mesh);
        self.prepared.retain(|draw| draw.mesh != mesh);
    }

    /// Uploads a material: its table(s) as `Rgba16Float` textures and its parameters. A
    /// Gaussian CDRF with [`GaussianEvaluation::Lut`] is tabulated here (a few milliseconds).
    ///
    /// # Errors
    /// [`MaterialError`] for out-of-range parameters or a table larger than the device allows.
    pub fn create_material(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        desc: &MaterialDesc<'_>,
    ) -> Result<MaterialId, MaterialError> {
        let identity = ViewCorrection::identity();
        let mut albedo_or_scale = Vec4::ONE;
        let mut sigma_mm = Vec4::ZERO;
        let mut curvature_range = Vec4::ZERO;
        // Non-local terms: penumbra width and T(d, μ), its entry cosine power in the amplitude's
        // w (none: a hard edge and no transmission).
        let mut scattering_length_mm = Vec4::ZERO;
        let mut transmission_amplitude = Vec4::ZERO;
        let mut transmission_length_mm = Vec4::ONE;
        let tabulated;
        let (model, lut, view) = match *desc {
            MaterialDesc::Measured { lut } => {
                if let Some(translucency) = lut.translucency() {
                    scattering_length_mm =
                        Vec3::from_array(translucency.scattering_length_mm).extend(0.0);
                    let transmission = translucency.transmission;
                    transmission_amplitude = Vec3::from_array(transmission.amplitude)
                        .extend(transmission.entry_cosine_power);
                    transmission_length_mm = Vec3::from_array(transmission.length_mm).extend(1.0);
                }
                (Model::Measured, Some(lut), lut.view_correction())
            }
            MaterialDesc::Gaussian {
                model,
                view_correction,
            } => {
                // Kubo's σ is the terminator's width in mm: the same sideways spread.
                scattering_length_mm = Vec3::from_array(model.sigma_mm()).extend(0.0);
                match self.options.gaussian {
                    GaussianEvaluation::Lut => {
                        let axis = CurvatureAxis {
                            min_per_mm: 0.0,
                            max_per_mm: self.options.gaussian_lut_max_curvature_per_mm,
                            count: self.options.gaussian_lut_rows as usize,
                        };
                        tabulated = CdrfLut::tabulate(
                            model,
                            axis,
                            self.options.gaussian_lut_columns as usize,
                        )?;
                        (Model::GaussianLut, Some(&tabulated), view_correction)
                    }
                    GaussianEvaluation::Analytic => {
                        sigma_mm = Vec3::from_array(model.sigma_mm()).extend(0.0);
                        albedo_or_scale = Vec3::from_array(model.scale()).extend(1.0);
                        (Model::GaussianAnalytic, None, view_correction)
                    }
                }
            }
            MaterialDesc::Lambert { albedo } => {
                check_finite_non_negative("albedo", &albedo)?;
                albedo_or_scale = Vec3::from_array(albedo).extend(1.0);
                (Model::Lambert, None, &identity)
            }
            MaterialDesc::Curvature { range_per_mm } => {
                let [low, high] = range_per_mm;
                if !(low.is_finite() && high.is_finite() && high > low) {
                    return Err(MaterialError::Parameter {
                        what: "curvature range (mm⁻¹)",
                        value: range_per_mm.to_vec(),
                        requirement: "must be finite with low < high",
                    });
                }
                curvature_range = Vec4::new(low, high, 0.0, 0.0);
                (Model::Curvature, None, &identity)
            }
        };

        let lut_texture = match lut {
            Some(lut) => {
                let axis = lut.curvature_axis();
                self.upload_table(
                    device,
                    queue,
                    "cdrf lut",
                    lut.theta_count(),
                    axis.count,
                    lut.radiance(),
                )?
            }
            None => self.upload_table(device, queue, "cdrf lut (unused)", 1, 1, &[Vec3::ONE])?,
        };
        let lut_axis = lut.map_or(Vec4::new(0.0, 0.0, 1.0, 1.0), |lut| {
            let axis = lut.curvature_axis();
            Vec4::new(
                axis.min_per_mm,
                axis.max_per_mm,
                axis.count as f32,
                lut.theta_count() as f32,
            )
        });
        let view_texture = self.upload_table(
            device,
            queue,
            "cdrf view correction",
            view.phi_count(),
            view.theta_count(),
            view.values(),
        )?;
        let view_axis = Vec4::new(view.phi_count() as f32, view.theta_count() as f32, 0.0, 0.0);

        let mut uniforms = Bytes::with_capacity(MATERIAL_UNIFORM_SIZE as usize);
        uniforms
            .vec4(albedo_or_scale)
            .vec4(sigma_mm)
            .vec4(lut_axis)
            .vec4(view_axis)
            .vec4(curvature_range)
            .vec4(scattering_length_mm)
            .vec4(transmission_amplitude)
            .vec4(transmission_length_mm);
        for weight in penumbra_weights(scattering_length_mm.truncate()) {
            uniforms.vec4(weight.extend(0.0));
        }
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("cdrf material uniforms"),
            contents: &uniforms.0,
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let lut_view = lut_texture.create_view(&Default::default());
        let view_view = view_texture.create_view(&Default::default());
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cdrf material"),
            layout: &self.material_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&lut_view),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(&view_view),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::Sampler(&self.sampler),
                },
            ],
        });
        let id = MaterialId(self.next_id());
        self.materials.insert(id, GpuMaterial { model, bind_group });
        Ok(id)
    }

    /// Frees a material; draws naming it are skipped from the next `prepare` on.
    pub fn remove_material(&mut self, material: MaterialId) {
        self.materials.remove(&material);
        self.prepared.retain(|draw| draw.material != material);
    }

    /// Uploads the frame's camera, lights and draw transforms and builds the pipelines the
    /// draws need for the current target.
    ///
    /// With a non-local term on ([`FrameDesc::non_local`]) it also records the shadow pass (a
    /// depth map of the draws per light, for the first [`MAX_SHADOW_LIGHTS`] lights) and
    /// returns its commands: the host submits them before, or together with and ahead of, the
    /// commands of the pass that calls [`Renderer::render`]. Otherwise the list is empty.
    ///
    /// # Errors
    /// [`PrepareError`]; then nothing is drawn until a later `prepare` succeeds.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        frame: &FrameDesc<'_>,
    ) -> Result<Vec<wgpu::CommandBuffer>, PrepareError> {
        self.prepared.clear();
        self.shadowed_lights = 0;
        if frame.non_local.any()
            && !(frame.mm_per_world_unit.is_finite() && frame.mm_per_world_unit > 0.0)
        {
            return Err(PrepareError::BadUnits {
                mm_per_world_unit: frame.mm_per_world_unit,
            });
        }
        if frame.lights.len() > MAX_LIGHTS {
            return Err(PrepareError::TooManyLights {
                count: frame.lights.len(),
            });
        }
        for (index, light) in frame.lights.iter().enumerate() {
            if !light.to_light.is_finite() || light.to_light.length_squared() < 1e-12 {
                return Err(PrepareError::BadLight {
                    index,
                    problem: "direction is zero or not finite",
                });
            }
            if light.irradiance.iter().any(|e| !e.is_finite() || *e < 0.0) {
                return Err(PrepareError::BadLight {
                    index,
                    problem: "irradiance must be finite and ≥ 0",
                });
            }
        }
        let (to_camera, is_point) = match frame.view.to_camera {
            ToCamera::Point(eye) => (eye, 1.0),
            ToCamera::Direction(direction) => (direction.normalize_or_zero(), 0.0),
        };
        if !frame.view.clip_from_world.is_finite()
            || !to_camera.is_finite()
            || (is_point == 0.0 && to_camera == Vec3::ZERO)
            || !frame.exposure.is_finite()
            || frame.exposure < 0.0
        {
            return Err(PrepareError::BadView);
        }

        let mut draws = Bytes::with_capacity(frame.draws.len() * self.draw_stride as usize);
        let mut prepared = Vec::with_capacity(frame.draws.len());
        for (index, draw) in frame.draws.iter().enumerate() {
            if !self.meshes.contains_key(&draw.mesh) {
                return Err(PrepareError::UnknownMesh {
                    index,
                    mesh: draw.mesh,
                });
            }
            let Some(material) = self.materials.get(&draw.material) else {
                return Err(PrepareError::UnknownMaterial {
                    index,
                    material: draw.material,
                });
            };
            let linear = Mat3::from_mat4(draw.world_from_model);
            let determinant = linear.determinant();
            // A mirroring transform (determinant < 0) would flip the winding and cull the
            // wrong faces.
            if !draw.world_from_model.is_finite() || determinant < 1e-30 {
                return Err(PrepareError::BadTransform { index });
            }
            let curvature_scale = 1.0 / determinant.cbrt();
            let normal_from_model = Mat4::from_mat3(linear.inverse().transpose());
            let offset = draws.0.len() as u32;
            draws
                .mat4(draw.world_from_model)
                .mat4(normal_from_model)
                .vec4(Vec4::new(curvature_scale, 0.0, 0.0, 0.0))
                .pad_to(self.draw_stride as usize);
            let non_local = if material.model == Model::Curvature {
                NonLocal::OFF
            } else {
                frame.non_local
            };
            self.ensure_pipeline(device, material.model, non_local)?;
            prepared.push(PreparedDraw {
                non_local,
                mesh: draw.mesh,
                material: draw.material,
                offset,
            });
        }

        let mut uniforms = Bytes::with_capacity(FRAME_UNIFORM_SIZE as usize);
        uniforms
            .mat4(frame.view.clip_from_world)
            .vec4(to_camera.extend(is_point))
            .vec4(Vec4::new(
                frame.exposure,
                frame.lights.len() as f32,
                0.0,
                0.0,
            ));
        for light in frame.lights {
            uniforms
                .vec4(light.to_light.normalize().extend(0.0))
                .vec4(Vec3::from_array(light.irradiance).extend(0.0));
        }
        uniforms.0.resize(FRAME_UNIFORM_SIZE as usize, 0);
        queue.write_buffer(&self.frame_buffer, 0, &uniforms.0);

        let needed = frame.draws.len() as u64;
        if needed > self.draw_capacity {
            let capacity = needed.next_power_of_two();
            (self.draw_buffer, self.draw_bind_group) =
                create_draw_buffer(device, &self.draw_layout, self.draw_stride, capacity);
            self.draw_capacity = capacity;
        }
        if !draws.0.is_empty() {
            queue.write_buffer(&self.draw_buffer, 0, &draws.0);
        }
        let commands = if frame.non_local.any() && !prepared.is_empty() {
            self.prepare_shadows(device, queue, frame, &prepared)
        } else {
            Vec::new()
        };
        self.prepared = prepared;
        Ok(commands)
    }

    /// Fits an orthographic light camera to the bounding sphere of the draws for each of the
    /// first [`MAX_SHADOW_LIGHTS`] lights, uploads the transforms and records the depth pass.
    fn prepare_shadows(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        frame: &FrameDesc<'_>,
        prepared: &[PreparedDraw],
    ) -> Vec<wgpu::CommandBuffer> {
        let resolution = self
            .options
            .shadow_map_resolution
            .clamp(1, device.limits().max_texture_dimension_2d);
        if self.shadow_maps.as_ref().map(|m| m.resolution) != Some(resolution) {
            let (layers, bind_group) = create_shadow_maps(
                device,
                &self.shadow_layout,
                &self.shadows_buffer,
                resolution,
            );
            self.shadow_maps = Some(ShadowMaps {
                resolution,
                layers,
                bind_group,
            });
        }
        let (centre, radius) = scene_bounds(frame.draws, &self.meshes);
        let lights = frame.lights.len().min(MAX_SHADOW_LIGHTS);
        let mut shadows = Bytes::with_capacity(SHADOWS_UNIFORM_SIZE as usize);
        let mut passes = vec![0u8; (self.shadow_pass_stride * MAX_SHADOW_LIGHTS as u64) as usize];
        for (index, light) in frame.lights.iter().take(lights).enumerate() {
            let camera = LightCamera::fit(light.to_light, centre, radius);
            shadows.mat4(camera.light_from_world).vec4(Vec4::new(
                camera.half_extent,
                camera.depth_range,
                0.0,
                0.0,
            ));
            let mut pass = Bytes::with_capacity(64);
            pass.mat4(camera.clip_from_world());
            let start = index * self.shadow_pass_stride as usize;
            passes[start..start + 64].copy_from_slice(&pass.0);
        }
        shadows.0.resize(SHADOWS_UNIFORM_SIZE as usize - 16, 0);
        shadows.vec4(Vec4::new(
            frame.mm_per_world_unit,
            self.options.shadow_bias_mm.max(0.0),
            resolution as f32,
            lights as f32,
        ));
        queue.write_buffer(&self.shadows_buffer, 0, &shadows.0);
        queue.write_buffer(&self.shadow_pass_buffer, 0, &passes);

        let maps = self.shadow_maps.as_ref().expect("created above");
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("cdrf shadow pass"),
        });
        for (index, layer) in maps.layers.iter().take(lights).enumerate() {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("cdrf shadow map"),
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: layer,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.shadow_pipeline);
            let offset = (index as u64 * self.shadow_pass_stride) as u32;
            pass.set_bind_group(0, &self.shadow_pass_bind_group, &[offset]);
            for draw in prepared {
                let Some(mesh) = self.meshes.get(&draw.mesh) else {
                    continue;
                };
                pass.set_bind_group(1, &self.draw_bind_group, &[draw.offset]);
                pass.set_vertex_buffer(0, mesh.vertices.slice(..));
                pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..mesh.index_count, 0, 0..1);
            }
        }
        self.shadowed_lights = lights;
        vec![encoder.finish()]
    }

    /// Records the prepared draws into the host's pass (whose attachments must match the
    /// current [`TargetDesc`]). Sets its own pipeline and bind groups 0–2; draws nothing
    /// before a successful [`Renderer::prepare`].
    pub fn render(&self, pass: &mut wgpu::RenderPass<'_>) {
        self.render_draws(pass, 0..self.prepared.len());
    }

    /// Records the prepared draws with indices in `draws` (positions in the last
    /// [`FrameDesc::draws`]; out-of-range indices are skipped). With it one `prepare` serves
    /// several passes that share the camera and lights, e.g. the same mesh with two materials
    /// into two targets. Otherwise as [`Renderer::render`].
    pub fn render_draws(&self, pass: &mut wgpu::RenderPass<'_>, draws: std::ops::Range<usize>) {
        let end = draws.end.min(self.prepared.len());
        let Some(prepared) = self.prepared.get(draws.start.min(end)..end) else {
            return;
        };
        if prepared.is_empty() {
            return;
        }
        pass.set_bind_group(0, &self.frame_bind_group, &[]);
        let shadows = match &self.shadow_maps {
            Some(maps) if self.shadowed_lights > 0 => &maps.bind_group,
            _ => &self.no_shadows,
        };
        pass.set_bind_group(3, shadows, &[]);
        let mut current: Option<(Model, NonLocal)> = None;
        for draw in prepared {
            let (Some(mesh), Some(material)) = (
                self.meshes.get(&draw.mesh),
                self.materials.get(&draw.material),
            ) else {
                continue;
            };
            let variant = (material.model, draw.non_local);
            let Some(pipeline) = self
                .pipelines
                .get(&(self.target, material.model, draw.non_local))
            else {
                continue;
            };
            if current != Some(variant) {
                pass.set_pipeline(pipeline);
                current = Some(variant);
            }
            pass.set_bind_group(1, &material.bind_group, &[]);
            pass.set_bind_group(2, &self.draw_bind_group, &[draw.offset]);
            pass.set_vertex_buffer(0, mesh.vertices.slice(..));
            pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..mesh.index_count, 0, 0..1);
        }
    }

    fn next_id(&mut self) -> u64 {
        self.next_id += 1;
        self.next_id
    }

    fn upload_table(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        label: &'static str,
        width: usize,
        height: usize,
        values: &[Vec3],
    ) -> Result<wgpu::Texture, MaterialError> {
        let max = self.max_texture_side;
        if width > max as usize || height > max as usize {
            return Err(MaterialError::TooLarge {
                what: label,
                width,
                height,
                max,
            });
        }
        Ok(device.create_texture_with_data(
            queue,
            &wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width: width as u32,
                    height: height as u32,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::Rgba16Float,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            },
            wgpu::util::TextureDataOrder::LayerMajor,
            &rgba16f_texels(values),
        ))
    }

    /// Builds the pipeline for the current target and `model` unless cached. wgpu reports a
    /// target the device cannot use through an error scope, returned here instead of reaching
    /// the host's uncaptured-error handler.
    fn ensure_pipeline(
        &mut self,
        device: &wgpu::Device,
        model: Model,
        non_local: NonLocal,
    ) -> Result<(), PrepareError> {
        let key = (self.target, model, non_local);
        if self.pipelines.contains_key(&key) {
            return Ok(());
        }
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let target = self.target;
        let constants = [
            ("MODEL", model as u32 as f64),
            (
                "MANUAL_FILTERING",
                f64::from(u8::from(self.options.lut_filtering == LutFiltering::Manual)),
            ),
            (
                "ENCODE_SRGB",
                f64::from(u8::from(target.encodes_srgb_in_shader())),
            ),
            (
                "NON_LOCAL",
                f64::from(u8::from(non_local.shadows) | (u8::from(non_local.transmission) << 1)),
            ),
        ];
        let compilation_options = wgpu::PipelineCompilationOptions {
            constants: &constants,
            ..Default::default()
        };
        let vertex_layout = wgpu::VertexBufferLayout {
            array_stride: VERTEX_STRIDE,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![
                0 => Float32x3,
                1 => Float32x3,
                2 => Float32,
            ],
        };
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("cdrf pipeline"),
            layout: Some(&self.pipeline_layout),
            vertex: wgpu::VertexState {
                module: &self.shader,
                entry_point: Some("vs_main"),
                compilation_options: compilation_options.clone(),
                buffers: &[Some(vertex_layout)],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                front_face: wgpu::FrontFace::Ccw,
                cull_mode: self.options.cull_back_faces.then_some(wgpu::Face::Back),
                ..Default::default()
            },
            depth_stencil: target.depth_format.map(|format| wgpu::DepthStencilState {
                format,
                depth_write_enabled: Some(true),
                depth_compare: Some(self.options.depth_compare),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: wgpu::MultisampleState {
                count: target.sample_count,
                ..Default::default()
            },
            fragment: Some(wgpu::FragmentState {
                module: &self.shader,
                entry_point: Some("fs_main"),
                compilation_options,
                targets: &[Some(wgpu::ColorTargetState {
                    format: target.color_format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        if let Some(error) = block_on(scope.pop()) {
            return Err(PrepareError::Pipeline {
                target: self.target,
                message: error.to_string(),
            });
        }
        self.pipelines.insert(key, pipeline);
        Ok(())
    }
}

fn create_draw_buffer(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    stride: u64,
    capacity: u64,
) -> (wgpu::Buffer, wgpu::BindGroup) {
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("cdrf draw uniforms"),
        size: stride * capacity,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("cdrf draws"),
        layout,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer: &buffer,
                offset: 0,
                size: NonZeroU64::new(DRAW_UNIFORM_SIZE),
            }),
        }],
    });
    (buffer, bind_group)
}

fn check_finite_non_negative(what: &'static str, values: &[f32]) -> Result<(), MaterialError> {
    if values.iter().all(|v| v.is_finite() && *v >= 0.0) {
        Ok(())
    } else {
        Err(MaterialError::Parameter {
            what,
            value: values.to_vec(),
            requirement: "must be finite and ≥ 0",
        })
    }
}

/// An orthographic camera looking along a directional light, fitted to a bounding sphere.
struct LightCamera {
    /// World → light space: x, y across the light, z along it from the map's light-side plane.
    light_from_world: Mat4,
    /// Half the map's side, world units.
    half_extent: f32,
    /// Depth that maps to 1, world units.
    depth_range: f32,
}

impl LightCamera {
    fn fit(to_light: Vec3, centre: Vec3, radius: f32) -> Self {
        let forward = -to_light.normalize();
        let helper = if forward.y.abs() < 0.9 {
            Vec3::Y
        } else {
            Vec3::X
        };
        let x = helper.cross(forward).normalize();
        let y = forward.cross(x);
        // A margin so the sphere's rim is not on the map's edge or its far plane.
        let half_extent = radius * 1.02;
        let rotation = Mat4::from_mat3(Mat3::from_cols(x, y, forward).transpose());
        let light_from_world = Mat4::from_translation(Vec3::new(0.0, 0.0, half_extent))
            * rotation
            * Mat4::from_translation(-centre);
        Self {
            light_from_world,
            half_extent,
            depth_range: 2.0 * half_extent,
        }
    }

    /// Light space → the shadow pass's clip space (depth = z / depth range).
    fn clip_from_world(&self) -> Mat4 {
        Mat4::from_scale(Vec3::new(
            1.0 / self.half_extent,
            1.0 / self.half_extent,
            1.0 / self.depth_range,
        )) * self.light_from_world
    }
}

/// A bounding sphere of `positions` (the box's centre and the farthest point from it).
fn bounding_sphere(positions: &[Vec3]) -> (Vec3, f32) {
    let (min, max) = positions.iter().fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    let centre = (min + max) * 0.5;
    let radius = positions
        .iter()
        .map(|p| p.distance(centre))
        .fold(0.0, f32::max);
    (centre, radius)
}

/// A sphere around every draw's mesh in world space (radius > 0).
fn scene_bounds(draws: &[Draw], meshes: &HashMap<MeshId, GpuMesh>) -> (Vec3, f32) {
    let spheres: Vec<(Vec3, f32)> = draws
        .iter()
        .filter_map(|draw| {
            let (centre, radius) = meshes.get(&draw.mesh)?.bounds;
            let linear = Mat3::from_mat4(draw.world_from_model);
            let scale = linear
                .x_axis
                .length()
                .max(linear.y_axis.length())
                .max(linear.z_axis.length());
            Some((
                draw.world_from_model.transform_point3(centre),
                radius * scale,
            ))
        })
        .collect();
    let (min, max) = spheres.iter().fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(lo, hi), &(c, r)| (lo.min(c - r), hi.max(c + r)),
    );
    let centre = (min + max) * 0.5;
    let radius = spheres
        .iter()
        .map(|&(c, r)| c.distance(centre) + r)
        .fold(0.0, f32::max);
    (centre, radius.max(1e-6))
}

/// The shadow maps (one depth layer per shadowed light, `resolution` texels per side) and the
/// shading pipelines' bind group 3 reading them.
fn create_shadow_maps(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    uniforms: &wgpu::Buffer,
    resolution: u32,
) -> (Vec<wgpu::TextureView>, wgpu::BindGroup) {
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("cdrf shadow maps"),
        size: wgpu::Extent3d {
            width: resolution,
            height: resolution,
            depth_or_array_layers: MAX_SHADOW_LIGHTS as u32,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: SHADOW_FORMAT,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        view_formats: &[],
    });
    let array = texture.create_view(&wgpu::TextureViewDescriptor {
        label: Some("cdrf shadow maps (array)"),
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    });
    let layers = (0..MAX_SHADOW_LIGHTS as u32)
        .map(|layer| {
            texture.create_view(&wgpu::TextureViewDescriptor {
                label: Some("cdrf shadow map"),
                dimension: Some(wgpu::TextureViewDimension::D2),
                base_array_layer: layer,
                array_layer_count: Some(1),
                ..Default::default()
            })
        })
        .collect();
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("cdrf shadows"),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: uniforms.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::TextureView(&array),
            },
        ],
    });
    (layers, bind_group)
}

/// The depth-only pipeline of the shadow pass (no culling: the first surface whatever its
/// winding).
fn create_shadow_pipeline(
    device: &wgpu::Device,
    layouts: &[&wgpu::BindGroupLayout],
) -> wgpu::RenderPipeline {
    let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("cdrf shadow shader"),
        source: wgpu::ShaderSource::Wgsl(SHADOW_SHADER_SOURCE.into()),
    });
    let layouts: Vec<Option<&wgpu::BindGroupLayout>> = layouts.iter().copied().map(Some).collect();
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("cdrf shadow pipeline layout"),
        bind_group_layouts: &layouts,
        immediate_size: 0,
    });
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("cdrf shadow pipeline"),
        layout: Some(&layout),
        vertex: wgpu::VertexState {
            module: &shader,
            entry_point: Some("vs_shadow"),
            compilation_options: Default::default(),
            buffers: &[Some(wgpu::VertexBufferLayout {
                array_stride: VERTEX_STRIDE,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &wgpu::vertex_attr_array![0 => Float32x3],
            })],
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: SHADOW_FORMAT,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Less),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: None,
        multiview_mask: None,
        cache: None,
    })
}

/// The Gaussian weight per channel of each penumbra tap: tap k lies at radius
/// `2·σ_max·√(k / PENUMBRA_TAPS)` on the surface (a Vogel spiral, see the shader).
fn penumbra_weights(sigma_mm: Vec3) -> [Vec3; PENUMBRA_TAPS] {
    let sigma_max = sigma_mm.max_element();
    std::array::from_fn(|k| {
        if sigma_max <= 0.0 {
            return Vec3::ONE;
        }
        let radius_squared = 4.0 * sigma_max * sigma_max * k as f32 / PENUMBRA_TAPS as f32;
        Vec3::from_array(
            sigma_mm
                .to_array()
                .map(|sigma| (-0.5 * radius_squared / (sigma * sigma).max(1e-12)).exp()),
        )
    })
}
