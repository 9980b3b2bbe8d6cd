//! The render pass: [`Renderer`]. `prepare` checks the frame, uploads its uniforms and records
//! the passes before the shading (`passes`); `render` records the shading into the host's pass.

use std::collections::HashMap;
use std::ops::Range;

use cdrf_core::light::NonLocal;
use cdrf_core::specular::SpecularLayer;

use crate::constants::Model;
use crate::draw_buffer::{DrawBuffer, draw_binding, draw_uniforms, stage_draw};
use crate::error::{MaterialError, MeshUploadError, PrepareError, SurfaceError};
use crate::frame::View;
use crate::frame::{Draw, FrameDesc};
use crate::frame_uniforms::{ViewBuffer, frame_uniforms};
use crate::gpu_types::{GpuDraw, GpuFrame, SHADING_STAGES, uniform_layout_entry};
use crate::ids::{MaterialId, MeshId, SurfaceId};
use crate::material::{GpuMaterialEntry, MaterialDesc, MaterialFactory};
use crate::mesh::{GpuMesh, MeshDesc, MeshVertices};
use crate::passes::light_maps::{LightMaps, LightViewBindings, ShadowCaster};
use crate::passes::vertex_terms::{
    PlacedMesh, TermsInputs, TermsKey, TermsLayout, VertexTermsPass,
};
use crate::pipelines::{Pipelines, uses_vertex_terms};
use crate::surface::{GpuSurface, SurfaceDesc, SurfaceParameters};
use crate::target::{Options, TargetDesc};

/// A draw of the last `prepare`: what to bind.
#[derive(Clone)]
struct PreparedDraw {
    model: Model,
    non_local: NonLocal,
    mesh: MeshId,
    material: MaterialId,
    surface: Option<SurfaceId>,
    /// The draw's indices in the mesh's index buffer.
    indices: Range<u32>,
    /// The draw's transforms in the draw buffer.
    offset: u32,
    /// Its vertices' non-local terms in the terms buffer (bytes), if its pipeline reads them.
    terms: Option<Range<u64>>,
}

/// What checking a draw yields: its shading model, its indices and its uniforms.
struct CheckedDraw {
    model: Model,
    indices: Range<u32>,
    uniforms: GpuDraw,
}

/// Shades curvature-tagged meshes with a CDRF inside the host's render pass.
///
/// The host owns the device, the queue and the pass. Per frame: [`Renderer::prepare`] (uploads
/// the camera, lights and draw transforms, builds any missing pipeline), then
/// [`Renderer::render`] records into the host's pass. Meshes and materials are uploaded once
/// with [`Renderer::create_mesh`] / [`Renderer::create_material`]. The crate docs show a whole
/// frame.
pub struct Renderer {
    options: Options,
    target: TargetDesc,
    pipelines: Pipelines,
    materials_factory: MaterialFactory,
    light_maps: LightMaps,
    vertex_terms: VertexTermsPass,
    draw_layout: wgpu::BindGroupLayout,
    /// The frame uniforms, once per view.
    views: ViewBuffer,
    draws: DrawBuffer,
    /// The surface of draws without one (white, no textures), made by the first `prepare`
    /// (its textures need the queue); its bind group also serves the light maps, which read
    /// only the draw buffer.
    default_surface: Option<GpuSurface>,
    meshes: HashMap<MeshId, GpuMesh>,
    materials: HashMap<MaterialId, GpuMaterialEntry>,
    surfaces: HashMap<SurfaceId, GpuSurface>,
    next_id: u64,
    prepared: Vec<PreparedDraw>,
}

impl Renderer {
    /// A renderer for passes with the given target. Builds its layouts and shader; pipelines
    /// are built in [`Renderer::prepare`] for the shading models the frame uses.
    ///
    /// ```
    /// use cdrf_render::headless::{AdapterPreference, HeadlessDevice};
    /// use cdrf_render::{Options, Renderer, TargetDesc, wgpu};
    ///
    /// // The host's device (here a software one) and the format of the pass it records into.
    /// let host = HeadlessDevice::new(AdapterPreference::Software)?;
    /// let target = TargetDesc::new(wgpu::TextureFormat::Rgba8UnormSrgb)
    ///     .with_sample_count(4)
    ///     .with_depth(wgpu::TextureFormat::Depth32Float);
    /// let renderer = Renderer::new(&host.device, &target, Options::default());
    /// assert_eq!(renderer.target(), &target);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn new(device: &wgpu::Device, target: &TargetDesc, options: Options) -> Self {
        let frame_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cdrf frame layout"),
            // A dynamic offset: one copy per view (`add_view`).
            entries: &[uniform_layout_entry::<GpuFrame>(0, SHADING_STAGES, true)],
        });
        let [t0, t1, t2, s0, s1, s2] = crate::surface::texture_layout_entries();
        let draw_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cdrf draw layout"),
            entries: &[
                uniform_layout_entry::<GpuDraw>(0, wgpu::ShaderStages::VERTEX_FRAGMENT, true),
                t0,
                t1,
                t2,
                s0,
                s1,
                s2,
            ],
        });
        let materials_factory = MaterialFactory::new(device);
        let light_maps = LightMaps::new(device, &draw_layout);
        let pipelines = Pipelines::new(
            device,
            [
                &frame_layout,
                &materials_factory.layout,
                &draw_layout,
                &light_maps.layout,
            ],
        );
        Self {
            options,
            target: *target,
            pipelines,
            materials_factory,
            light_maps,
            vertex_terms: VertexTermsPass::new(device),
            draw_layout,
            views: ViewBuffer::new(device, frame_layout),
            draws: DrawBuffer::new(device),
            default_surface: None,
            meshes: HashMap::new(),
            materials: HashMap::new(),
            surfaces: HashMap::new(),
            next_id: 0,
            prepared: Vec::new(),
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

    /// Uploads a mesh from slices of the host's vertex data ([`MeshDesc::from_mesh`] makes
    /// them from a [`cdrf_core::Mesh`]).
    ///
    /// # Errors
    /// [`MeshUploadError`] when the mesh is empty, the slices do not match or an index or
    /// curvature value is out of range.
    pub fn create_mesh(
        &mut self,
        device: &wgpu::Device,
        desc: &MeshDesc<'_>,
    ) -> Result<MeshId, MeshUploadError> {
        let gpu = GpuMesh::upload(device, desc, self.options.interreflection_patches)?;
        let id = MeshId(self.next_id());
        self.meshes.insert(id, gpu);
        Ok(id)
    }

    /// Moves a deforming mesh's vertices (one made with [`MeshDesc::deforming`]), e.g. after
    /// skinning: every draw of it from the next `prepare` on — its shading, shadows,
    /// transmission, gather and inter-reflection — sees the new shape. Call it before
    /// `prepare`, once per frame the mesh moves. See [`MeshVertices`] for what stays.
    ///
    /// ```
    /// use cdrf_core::{CurvatureOptions, Mesh, mean_curvature_per_mm};
    /// use cdrf_render::headless::{AdapterPreference, HeadlessDevice};
    /// use cdrf_render::{MeshDesc, MeshVertices, Options, Renderer, TargetDesc, wgpu};
    ///
    /// # let host = HeadlessDevice::new(AdapterPreference::Software)?;
    /// # let (device, queue) = (&host.device, &host.queue);
    /// let mut renderer = Renderer::new(device, &TargetDesc::new(wgpu::TextureFormat::Rgba16Float),
    ///                                  Options::default());
    /// let rest = Mesh::icosphere(20.0, 3); // mm
    /// let curvature = mean_curvature_per_mm(&rest, &CurvatureOptions::new(1.0))?;
    /// let mesh = renderer.create_mesh(device, &MeshDesc::from_mesh(&rest, &curvature).deforming())?;
    /// // This frame's pose (here squashed along y; the host's skinning in practice).
    /// let posed: Vec<_> = rest.positions.iter().map(|p| p * cdrf_core::glam::Vec3::new(1.0, 0.8, 1.0)).collect();
    /// renderer.update_mesh(queue, mesh, &MeshVertices::new(&posed, &rest.normals))?;
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    ///
    /// # Errors
    /// [`MeshUploadError`]: an unknown or non-deforming mesh, a slice of the wrong length or a
    /// value that is not finite. The mesh then keeps its last vertices.
    pub fn update_mesh(
        &mut self,
        queue: &wgpu::Queue,
        mesh: MeshId,
        vertices: &MeshVertices<'_>,
    ) -> Result<(), MeshUploadError> {
        self.meshes
            .get_mut(&mesh)
            .ok_or(MeshUploadError::Unknown)?
            .update(queue, vertices)
    }

    /// Frees a mesh; draws naming it are skipped from the next `prepare` on.
    pub fn remove_mesh(&mut self, mesh: MeshId) {
        self.meshes.remove(&mesh);
        self.prepared.retain(|draw| draw.mesh != mesh);
    }

    /// Uploads a material: its table(s) as `Rgba16Float` textures and its parameters. A
    /// Gaussian CDRF with [`GaussianEvaluation::Lut`](crate::GaussianEvaluation::Lut) is
    /// tabulated here (a few milliseconds). A measured table carries its own non-local terms
    /// (LUT file format version 3; see [`cdrf_core::translucency`]).
    ///
    /// ```
    /// use cdrf_render::headless::{AdapterPreference, HeadlessDevice};
    /// use cdrf_render::{MaterialDesc, Options, Renderer, TargetDesc, wgpu};
    ///
    /// # let host = HeadlessDevice::new(AdapterPreference::Software)?;
    /// # let (device, queue) = (&host.device, &host.queue);
    /// # let target = TargetDesc::new(wgpu::TextureFormat::Rgba8UnormSrgb);
    /// let mut renderer = Renderer::new(device, &target, Options::default());
    /// // The measured table cdrf-fit wrote (here the bundled fit of the wax spheres).
    /// let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/wax-fit/measured.exr");
    /// let lut = cdrf_core::read_lut(std::path::Path::new(path))?;
    /// let wax = renderer.create_material(device, queue, &MaterialDesc::Measured { lut: &lut })?;
    /// // A material per draw: an opaque control beside it.
    /// let clay = renderer.create_material(device, queue, &MaterialDesc::Lambert { albedo: [0.8; 3] })?;
    /// assert_ne!(wax, clay);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    ///
    /// # Errors
    /// [`MaterialError`] for out-of-range parameters or a table larger than the device allows.
    pub fn create_material(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        desc: &MaterialDesc<'_>,
    ) -> Result<MaterialId, MaterialError> {
        let material = self
            .materials_factory
            .create(device, queue, &self.options, desc)?;
        let id = MaterialId(self.next_id());
        self.materials.insert(id, material);
        Ok(id)
    }

    /// Puts the first-surface reflection of a rough dielectric boundary on a material
    /// (`Some`), or takes it off (`None`, as created): a microfacet lobe per light on top of
    /// the subsurface light, which is scaled by the share the boundary lets through
    /// ([`SpecularLayer::subsurface_transmission`](cdrf_core::specular::SpecularLayer::subsurface_transmission)
    /// of the model's albedo facing the light). It takes effect at once, with no new pipeline.
    /// Non-local shadows dim it as they dim the subsurface light.
    ///
    /// # Errors
    /// [`MaterialError::Parameter`] for the curvature view; [`MaterialError::Unknown`] for a
    /// removed material.
    pub fn set_material_specular(
        &mut self,
        queue: &wgpu::Queue,
        material: MaterialId,
        layer: Option<SpecularLayer>,
    ) -> Result<(), MaterialError> {
        self.materials
            .get_mut(&material)
            .ok_or(MaterialError::Unknown)?
            .set_specular(queue, layer)
    }

    /// Frees a material; draws naming it are skipped from the next `prepare` on.
    pub fn remove_material(&mut self, material: MaterialId) {
        self.materials.remove(&material);
        self.prepared.retain(|draw| draw.material != material);
    }

    /// Uploads a surface: what an asset paints on a material (base colour tint, normal map,
    /// specular roughness; see [`crate::surface`]), with a mip chain per texture. Draws name
    /// it with [`Draw::with_surface`](crate::Draw::with_surface).
    ///
    /// ```
    /// use cdrf_core::{CurvatureOptions, Mesh, mean_curvature_per_mm};
    /// use cdrf_core::glam::Mat4;
    /// use cdrf_render::headless::{AdapterPreference, HeadlessDevice};
    /// use cdrf_render::{Draw, MaterialDesc, MeshDesc, Options, Renderer, SurfaceDesc,
    ///                   TargetDesc, wgpu};
    ///
    /// # let host = HeadlessDevice::new(AdapterPreference::Software)?;
    /// # let (device, queue) = (&host.device, &host.queue);
    /// let mut renderer = Renderer::new(device, &TargetDesc::new(wgpu::TextureFormat::Rgba16Float),
    ///                                  Options::default());
    /// // A glTF file with two materials (tests/fixtures/textured.glb; mm units).
    /// let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/fixtures/textured.glb");
    /// let (repaired, surfaces) = Mesh::load_with_surfaces(path)?;
    /// let mesh = &repaired.mesh;
    /// // Curvature on the welded geometry (UV seams do not cut it).
    /// let curvature = mean_curvature_per_mm(mesh, &CurvatureOptions::new(1.0))?;
    /// let mesh_id = renderer.create_mesh(device, &MeshDesc::from_mesh(mesh, &curvature)
    ///     .with_tangents(surfaces.tangents.as_deref()))?;
    /// let wax = renderer.create_material(device, queue, &MaterialDesc::Lambert { albedo: [0.8; 3] })?;
    /// let surface_ids = surfaces.materials.iter()
    ///     .map(|material| renderer.create_surface(device, queue, &SurfaceDesc::from_material(material)))
    ///     .collect::<Result<Vec<_>, _>>()?;
    /// // One draw per primitive: its triangles, its material's surface.
    /// let draws: Vec<Draw> = surfaces.primitives.iter()
    ///     .map(|primitive| Draw::new(mesh_id, wax, Mat4::IDENTITY)
    ///         .with_triangles(primitive.triangles.clone())
    ///         .with_surface(surface_ids[primitive.material]))
    ///     .collect();
    /// assert_eq!(draws.len(), 2);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    ///
    /// # Errors
    /// [`SurfaceError`] for a factor out of range or a texture that is empty, short of pixels
    /// or larger than the device allows.
    pub fn create_surface(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        desc: &SurfaceDesc<'_>,
    ) -> Result<SurfaceId, SurfaceError> {
        let surface = GpuSurface::upload(
            device,
            queue,
            desc,
            &self.draw_layout,
            &draw_binding(&self.draws.buffer),
        )?;
        let id = SurfaceId(self.next_id());
        self.surfaces.insert(id, surface);
        Ok(id)
    }

    /// Frees a surface; draws naming it are skipped from the next `prepare` on.
    pub fn remove_surface(&mut self, surface: SurfaceId) {
        self.surfaces.remove(&surface);
        self.prepared.retain(|draw| draw.surface != Some(surface));
    }

    /// Uploads the frame's camera, lights and draw transforms and builds the pipelines the
    /// draws need for the current target.
    ///
    /// With a non-local term on ([`FrameDesc::non_local`]) it also records the shadow pass (a
    /// depth map of the draws per light, for the first
    /// [`MAX_SHADOW_LIGHTS`](crate::MAX_SHADOW_LIGHTS) lights) and returns its commands:
    /// **the host submits them before**, or together with and ahead of, the commands of the
    /// pass that calls [`Renderer::render`]. Otherwise the list is empty.
    ///
    /// ```
    /// use cdrf_core::glam::{self, Mat4, Vec3};
    /// use cdrf_core::{Mesh, CurvatureOptions, mean_curvature_per_mm};
    /// use cdrf_render::headless::{AdapterPreference, HeadlessDevice};
    /// use cdrf_render::{DirectionalLight, Draw, FrameDesc, MaterialDesc, MeshDesc, NonLocal,
    ///                   Options, Renderer, TargetDesc, ToCamera, View, wgpu};
    ///
    /// # let host = HeadlessDevice::new(AdapterPreference::Software)?;
    /// # let (device, queue) = (&host.device, &host.queue);
    /// let mut renderer = Renderer::new(device, &TargetDesc::new(wgpu::TextureFormat::Rgba16Float),
    ///                                  Options::default());
    /// let sphere = Mesh::icosphere(20.0, 3); // mm
    /// let curvature = mean_curvature_per_mm(&sphere, &CurvatureOptions::new(1.0))?;
    /// let mesh = renderer.create_mesh(device, &MeshDesc::from_mesh(&sphere, &curvature))?;
    /// let material = renderer.create_material(device, queue, &MaterialDesc::Lambert { albedo: [0.8; 3] })?;
    /// let frame = FrameDesc {
    ///     view: View {
    ///         clip_from_world: glam::camera::rh::proj::directx::orthographic(
    ///             -25.0, 25.0, -25.0, 25.0, 0.0, 100.0,
    ///         ) * glam::camera::rh::view::look_at_mat4(Vec3::new(0.0, 0.0, 50.0), Vec3::ZERO, Vec3::Y),
    ///         to_camera: ToCamera::Direction(Vec3::Z),
    ///     },
    ///     lights: &[DirectionalLight { to_light: Vec3::NEG_X, irradiance: [1.0; 3] }.into()],
    ///     exposure: 1.0,
    ///     draws: &[Draw::new(mesh, material, Mat4::IDENTITY)],
    ///     // Cast shadows and transmission: prepare returns the shadow pass.
    ///     non_local: NonLocal { shadows: true, transmission: true, ..NonLocal::OFF },
    ///     mm_per_world_unit: 1.0,
    ///     environment: None,
    /// };
    /// let shadow_pass = renderer.prepare(device, queue, &frame)?;
    /// assert_eq!(shadow_pass.len(), 1);
    /// // Submit the shadow pass first, then the host's pass that calls `render`:
    /// // queue.submit(shadow_pass.into_iter().chain([host_encoder.finish()]));
    /// # queue.submit(shadow_pass);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
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
        self.views.clear();
        self.light_maps.clear();
        let frame_uniforms = frame_uniforms(frame)?;
        self.ensure_default_surface(device, queue);
        let mut staging = self.draws.staging(frame.draws.len());
        let mut terms = TermsLayout::new(&device.limits());
        let mut prepared = Vec::with_capacity(frame.draws.len());
        for (index, draw) in frame.draws.iter().enumerate() {
            prepared.push(self.prepare_draw(
                device,
                frame,
                index,
                draw,
                &mut terms,
                &mut staging,
            )?);
        }
        self.views.set_frame(queue, frame_uniforms);
        self.upload_draws(device, queue, &staging, frame.draws.len());
        self.vertex_terms.reserve(device, &terms);

        let mut commands = Vec::new();
        if frame.non_local.light_maps() && !prepared.is_empty() {
            commands.push(self.record_light_maps(device, queue, frame, &prepared));
        }
        if !terms.is_empty() {
            let inputs = TermsInputs {
                frame: &self.views.bind_group,
                light_maps: self.light_maps.bind_group(),
                draws: &self.draws.buffer,
                meshes: &self.meshes,
                materials: &self.materials,
                pipelines: &self.pipelines,
                bounces: self.options.interreflection_bounces,
            };
            commands.push(self.vertex_terms.record(device, &terms, &inputs));
        }
        self.prepared = prepared;
        Ok(commands)
    }

    /// Checks draw `index`, builds the pipelines it needs, stages its uniforms and places its
    /// vertex terms (a run of its own, or the run of an earlier draw with the same key).
    fn prepare_draw(
        &mut self,
        device: &wgpu::Device,
        frame: &FrameDesc<'_>,
        index: usize,
        draw: &Draw,
        terms: &mut TermsLayout,
        staging: &mut [u8],
    ) -> Result<PreparedDraw, PrepareError> {
        let CheckedDraw {
            model,
            indices,
            mut uniforms,
        } = self.check_draw(index, draw)?;
        // The curvature view shows no non-local term.
        let non_local = if model == Model::Curvature {
            NonLocal::OFF
        } else {
            frame.non_local
        };
        let reads_terms = uses_vertex_terms(model, non_local);
        if reads_terms && !self.pipelines.has_vertex_terms() {
            return Err(PrepareError::NoComputeShaders { index });
        }
        self.pipelines
            .ensure(device, &self.options, self.target, model, non_local)?;
        if non_local.subsurface {
            self.pipelines.ensure_subsurface_map(device)?;
        }
        let offset = self.draws.offset(index);
        let terms = if reads_terms {
            let key = TermsKey {
                placed: PlacedMesh::new(draw.mesh, draw.world_from_model),
                material: draw.material,
                non_local,
            };
            let mesh = self.meshes.get(&draw.mesh).expect("checked above");
            let region = terms.place(index, key, model, mesh, offset)?;
            uniforms.emitter_first = region.emitters.map_or(0, |emitters| emitters.first);
            Some(region.range.clone())
        } else {
            None
        };
        stage_draw(staging, offset, &uniforms);
        Ok(PreparedDraw {
            model,
            non_local,
            mesh: draw.mesh,
            material: draw.material,
            surface: draw.surface,
            indices,
            offset,
            terms,
        })
    }

    /// Checks that draw `index` names a mesh, a material and a surface of this renderer, a
    /// triangle range within its mesh and a usable transform.
    fn check_draw(&self, index: usize, draw: &Draw) -> Result<CheckedDraw, PrepareError> {
        let mesh = self
            .meshes
            .get(&draw.mesh)
            .ok_or(PrepareError::UnknownMesh {
                index,
                mesh: draw.mesh,
            })?;
        let material = self
            .materials
            .get(&draw.material)
            .ok_or(PrepareError::UnknownMaterial {
                index,
                material: draw.material,
            })?;
        let parameters = match draw.surface {
            None => self.default_parameters(),
            Some(surface) => {
                self.surfaces
                    .get(&surface)
                    .ok_or(PrepareError::UnknownSurface { index, surface })?
                    .parameters
            }
        };
        let triangle_count = mesh.index_count / 3;
        let triangles = draw.triangles.clone().unwrap_or(0..triangle_count);
        if triangles.start >= triangles.end || triangles.end > triangle_count {
            return Err(PrepareError::BadTriangles {
                index,
                start: triangles.start,
                end: triangles.end,
                triangles: triangle_count,
            });
        }
        let uniforms = draw_uniforms(draw.world_from_model, &parameters)
            .ok_or(PrepareError::BadTransform { index })?;
        Ok(CheckedDraw {
            model: material.model,
            indices: 3 * triangles.start..3 * triangles.end,
            uniforms,
        })
    }

    /// Makes the default surface unless made (its textures need the queue).
    fn ensure_default_surface(&mut self, device: &wgpu::Device, queue: &wgpu::Queue) {
        if self.default_surface.is_none() {
            let surface = GpuSurface::upload(
                device,
                queue,
                &SurfaceDesc::default(),
                &self.draw_layout,
                &draw_binding(&self.draws.buffer),
            )
            .expect("the default surface (1 × 1 textures, unit factors) is valid");
            self.default_surface = Some(surface);
        }
    }

    /// Uploads the staged uniforms of `draws` draws, growing the draw buffer first if it has
    /// no room for them (then every surface's bind group is made again for the new buffer).
    fn upload_draws(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        staging: &[u8],
        draws: usize,
    ) {
        if self.draws.reserve(device, draws as u64) {
            let binding = draw_binding(&self.draws.buffer);
            for surface in self
                .surfaces
                .values_mut()
                .chain(self.default_surface.as_mut())
            {
                surface.rebind(device, &self.draw_layout, &binding);
            }
        }
        if !staging.is_empty() {
            queue.write_buffer(&self.draws.buffer, 0, staging);
        }
    }

    /// Records the light maps of the prepared draws (the subsurface pyramid too when a draw
    /// gathers).
    fn record_light_maps(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        frame: &FrameDesc<'_>,
        prepared: &[PreparedDraw],
    ) -> wgpu::CommandBuffer {
        let casters: Vec<ShadowCaster<'_>> = prepared
            .iter()
            .filter_map(|draw| {
                Some(ShadowCaster {
                    mesh: self.meshes.get(&draw.mesh)?,
                    indices: draw.indices.clone(),
                    draw_offset: draw.offset,
                    material: &self.materials.get(&draw.material)?.bind_group,
                })
            })
            .collect();
        let bindings = LightViewBindings {
            frame: &self.views.bind_group,
            draws: &self
                .default_surface
                .as_ref()
                .expect("made at the start of prepare")
                .bind_group,
            subsurface_pipeline: prepared
                .iter()
                .any(|draw| draw.non_local.subsurface)
                .then(|| self.pipelines.subsurface_map())
                .flatten(),
        };
        self.light_maps.prepare(
            device,
            queue,
            &self.options,
            frame,
            &self.meshes,
            &casters,
            bindings,
        )
    }

    /// Records the prepared draws into the host's pass (whose attachments must match the
    /// current [`TargetDesc`]). Sets its own pipelines and bind groups 0–3; draws nothing
    /// before a successful [`Renderer::prepare`].
    ///
    /// ```
    /// use cdrf_render::headless::{AdapterPreference, HeadlessDevice};
    /// use cdrf_render::{OffscreenTarget, Options, Renderer, TargetDesc, wgpu};
    ///
    /// # let host = HeadlessDevice::new(AdapterPreference::Software)?;
    /// # let (device, queue) = (&host.device, &host.queue);
    /// let target = TargetDesc::new(wgpu::TextureFormat::Rgba16Float).with_sample_count(4);
    /// let renderer = Renderer::new(device, &target, Options::default());
    /// // ... create_mesh, create_material, prepare (see `Renderer::prepare`) ...
    /// let offscreen = OffscreenTarget::new(device, &target, 64, 64);
    /// let mut encoder = device.create_command_encoder(&Default::default());
    /// {
    ///     let mut pass = offscreen.begin_pass(&mut encoder, wgpu::Color::BLACK);
    ///     renderer.render(&mut pass); // before any prepare: draws nothing
    /// }
    /// queue.submit([encoder.finish()]);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn render(&self, pass: &mut wgpu::RenderPass<'_>) {
        self.record(pass, 0, 0..self.prepared.len());
    }

    /// Adds another view of the last prepared frame — a second camera of a split screen, a
    /// reflection probe's face — with its own camera and exposure; the lights, draws and
    /// non-local passes are the frame's, prepared once. Returns the index to give
    /// [`Renderer::render_view`] (the [`FrameDesc`]'s own view is 0). Views last until the next
    /// `prepare`; each is drawn into a pass with this renderer's target.
    ///
    /// ```
    /// use cdrf_core::glam::{self, Mat4, Vec3};
    /// use cdrf_core::{CurvatureOptions, Mesh, mean_curvature_per_mm};
    /// use cdrf_render::headless::{AdapterPreference, HeadlessDevice};
    /// use cdrf_render::{DirectionalLight, Draw, FrameDesc, MaterialDesc, MeshDesc, NonLocal,
    ///                   Options, Renderer, TargetDesc, ToCamera, View, wgpu};
    ///
    /// # let host = HeadlessDevice::new(AdapterPreference::Software)?;
    /// # let (device, queue) = (&host.device, &host.queue);
    /// let mut renderer = Renderer::new(device, &TargetDesc::new(wgpu::TextureFormat::Rgba16Float),
    ///                                  Options::default());
    /// # let sphere = Mesh::icosphere(20.0, 3);
    /// # let curvature = mean_curvature_per_mm(&sphere, &CurvatureOptions::new(1.0))?;
    /// # let mesh = renderer.create_mesh(device, &MeshDesc::from_mesh(&sphere, &curvature))?;
    /// # let material = renderer.create_material(device, queue, &MaterialDesc::Lambert { albedo: [0.8; 3] })?;
    /// let camera = |eye: Vec3| View {
    ///     clip_from_world: glam::camera::rh::proj::directx::orthographic(-25.0, 25.0, -25.0, 25.0, 0.0, 100.0)
    ///         * glam::camera::rh::view::look_at_mat4(eye, Vec3::ZERO, Vec3::Y),
    ///     to_camera: ToCamera::Direction(eye.normalize()),
    /// };
    /// let frame = FrameDesc {
    ///     view: camera(Vec3::new(0.0, 0.0, 50.0)), // the left half of a split screen
    ///     lights: &[DirectionalLight { to_light: Vec3::NEG_X, irradiance: [1.0; 3] }.into()],
    ///     exposure: 1.0,
    ///     draws: &[Draw::new(mesh, material, Mat4::IDENTITY)],
    ///     non_local: NonLocal::OFF,
    ///     mm_per_world_unit: 1.0,
    ///     environment: None,
    /// };
    /// let commands = renderer.prepare(device, queue, &frame)?;
    /// let right = renderer.add_view(device, queue, &camera(Vec3::new(50.0, 0.0, 0.0)), 1.0)?;
    /// assert_eq!(right, 1);
    /// // Then, in the left half's pass: renderer.render(&mut pass);
    /// // in the right half's: renderer.render_view(&mut pass, right);
    /// # queue.submit(commands);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    ///
    /// # Errors
    /// [`PrepareError::BadView`] or [`PrepareError::BadExposure`]; [`PrepareError::NotPrepared`]
    /// before a `prepare` succeeded.
    pub fn add_view(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        view: &View,
        exposure: f32,
    ) -> Result<usize, PrepareError> {
        self.views.add_view(device, queue, view, exposure)
    }

    /// [`Renderer::render`] from view `view` ([`Renderer::add_view`]; 0: the frame's own). An
    /// unknown view draws nothing.
    pub fn render_view(&self, pass: &mut wgpu::RenderPass<'_>, view: usize) {
        self.record(pass, view, 0..self.prepared.len());
    }

    /// Records the prepared draws with indices in `draws` (positions in the last
    /// [`FrameDesc::draws`]; out-of-range indices are skipped). With it one `prepare` serves
    /// several passes that share the camera and lights, e.g. the same mesh with two materials
    /// into two targets. Otherwise as [`Renderer::render`].
    pub fn render_draws(&self, pass: &mut wgpu::RenderPass<'_>, draws: Range<usize>) {
        self.record(pass, 0, draws);
    }

    fn record(&self, pass: &mut wgpu::RenderPass<'_>, view: usize, draws: Range<usize>) {
        let Some(view_offset) = self.views.offset(view) else {
            return;
        };
        let end = draws.end.min(self.prepared.len());
        let Some(prepared) = self.prepared.get(draws.start.min(end)..end) else {
            return;
        };
        if prepared.is_empty() {
            return;
        }
        pass.set_bind_group(0, &self.views.bind_group, &[view_offset]);
        pass.set_bind_group(3, self.light_maps.bind_group(), &[]);
        let mut current: Option<(Model, NonLocal)> = None;
        for draw in prepared {
            let surface = match draw.surface {
                None => self.default_surface.as_ref(),
                Some(surface) => self.surfaces.get(&surface),
            };
            let (Some(mesh), Some(material), Some(surface)) = (
                self.meshes.get(&draw.mesh),
                self.materials.get(&draw.material),
                surface,
            ) else {
                continue;
            };
            let variant = (draw.model, draw.non_local);
            let Some(pipeline) = self.pipelines.get(self.target, draw.model, draw.non_local) else {
                continue;
            };
            if current != Some(variant) {
                pass.set_pipeline(pipeline);
                current = Some(variant);
            }
            pass.set_bind_group(1, &material.bind_group, &[]);
            pass.set_bind_group(2, &surface.bind_group, &[draw.offset]);
            pass.set_vertex_buffer(0, mesh.vertices.slice(..));
            if let Some(terms) = &draw.terms {
                pass.set_vertex_buffer(1, self.vertex_terms.buffer.slice(terms.clone()));
            }
            pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(draw.indices.clone(), 0, 0..1);
        }
    }

    fn default_parameters(&self) -> SurfaceParameters {
        self.default_surface
            .as_ref()
            .expect("made at the start of prepare")
            .parameters
    }

    fn next_id(&mut self) -> u64 {
        self.next_id += 1;
        self.next_id
    }
}
