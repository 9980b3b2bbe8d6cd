//! The render pass: [`Renderer`].

use std::collections::HashMap;

use cdrf_core::environment::sh_basis_factors;
use cdrf_core::glam::{Mat3, Mat4, Vec3};
use cdrf_core::light::{Light, NonLocal};
use cdrf_core::specular::SpecularLayer;

use crate::error::{MaterialError, MeshUploadError, PrepareError, SurfaceError};
use crate::frame::{FrameDesc, ToCamera};
use crate::gpu_types::{
    GpuDraw, GpuEmitter, GpuFrame, GpuLight, GpuPatch, GpuVertexTerms, SHADING_STAGES,
    uniform_layout_entry, uniform_size,
};
use crate::interreflection::Emitters;
use crate::material::{GpuMaterialEntry, MaterialDesc, MaterialFactory, MaterialId};
use crate::mesh::{GpuMesh, MeshDesc, MeshId};
use crate::non_local::{LightViewBindings, NonLocalPass, ShadowCaster};
use crate::pipelines::{Pipelines, TermsPipelines, runs_vertex_terms, uses_vertex_terms};
use crate::shaders::{
    ENVIRONMENT_SH_ORDER, GPU_LIGHT_DIRECTIONAL, GPU_LIGHT_POINT, GPU_LIGHT_SPOT, MAX_LIGHTS, Model,
};
use crate::surface::{GpuSurface, SurfaceDesc, SurfaceId, SurfaceParameters};
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
    indices: std::ops::Range<u32>,
    /// The draw's transforms in the draw buffer.
    offset: u32,
    /// Its vertices' non-local terms in the terms buffer (bytes), if its pipeline reads them.
    terms: Option<std::ops::Range<u64>>,
}

/// One run of the vertex terms pass: a mesh's vertices under one transform, material and set
/// of non-local terms (draws that share all four share its terms).
struct TermsRegion {
    key: TermsKey,
    model: Model,
    /// Its first draw's transforms in the draw buffer.
    draw_offset: u32,
    vertex_count: u32,
    /// Where its terms go in the terms buffer (bytes).
    range: std::ops::Range<u64>,
    /// With the inter-reflection: its mesh's patches' first emitter of the frame, and how
    /// many (`None`: it sends out no light; another run of the same mesh and transform does,
    /// or it has no patches).
    emitters: Option<(u32, u32)>,
}

/// What a vertex's terms depend on: mesh, material, non-local terms, the transform's bits.
type TermsKey = (MeshId, MaterialId, NonLocal, [u32; 16]);

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
    non_local: NonLocalPass,
    draw_layout: wgpu::BindGroupLayout,
    frame_buffer: wgpu::Buffer,
    frame_bind_group: wgpu::BindGroup,
    draw_buffer: wgpu::Buffer,
    draw_stride: u64,
    draw_capacity: u64,
    /// The vertex terms pass's output, the shading pass's second vertex buffer (grown as
    /// needed; `terms_capacity` bytes).
    terms_buffer: wgpu::Buffer,
    terms_capacity: u64,
    /// The inter-reflection's emitters of the frame.
    emitters: Emitters,
    /// Bound in the compute passes' place of a mesh's patches when it has none.
    no_patches: wgpu::Buffer,
    /// The surface of draws without one (white, no textures), made by the first `prepare`
    /// (its textures need the queue); its bind group also serves the non-local passes, which
    /// read only the draw buffer.
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
            entries: &[uniform_layout_entry::<GpuFrame>(0, SHADING_STAGES, false)],
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
        let non_local = NonLocalPass::new(device, &draw_layout);
        let pipelines = Pipelines::new(
            device,
            [
                &frame_layout,
                &materials_factory.layout,
                &draw_layout,
                &non_local.layout,
            ],
        );
        let frame_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cdrf frame uniforms"),
            size: uniform_size::<GpuFrame>().get(),
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
        let alignment = u64::from(device.limits().min_uniform_buffer_offset_alignment);
        let draw_stride = uniform_size::<GpuDraw>().get().next_multiple_of(alignment);
        let draw_capacity = 16;
        let draw_buffer = create_draw_buffer(device, draw_stride, draw_capacity);
        let terms_capacity = GpuVertexTerms::STRIDE;
        let terms_buffer = create_terms_buffer(device, terms_capacity);
        let no_patches = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cdrf no patches"),
            size: size_of::<GpuPatch>() as u64,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        Self {
            options,
            target: *target,
            pipelines,
            materials_factory,
            non_local,
            draw_layout,
            frame_buffer,
            frame_bind_group,
            draw_buffer,
            draw_stride,
            draw_capacity,
            terms_buffer,
            terms_capacity,
            emitters: Emitters::new(device),
            no_patches,
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
            &draw_binding(&self.draw_buffer),
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
        self.non_local.clear();
        let frame_uniforms = frame_uniforms(frame)?;
        if self.default_surface.is_none() {
            let surface = GpuSurface::upload(
                device,
                queue,
                &SurfaceDesc::default(),
                &self.draw_layout,
                &draw_binding(&self.draw_buffer),
            )
            .expect("the default surface (1 × 1 textures, unit factors) is valid");
            self.default_surface = Some(surface);
        }

        let mut draws = vec![0u8; frame.draws.len() * self.draw_stride as usize];
        let mut prepared = Vec::with_capacity(frame.draws.len());
        let mut regions: Vec<TermsRegion> = Vec::new();
        let terms_alignment = u64::from(device.limits().min_storage_buffer_offset_alignment);
        let max_terms_vertices =
            device.limits().max_storage_buffer_binding_size / GpuVertexTerms::STRIDE;
        let mut terms_end = 0;
        let mut emitter_count = 0u32;
        for (index, draw) in frame.draws.iter().enumerate() {
            let Some(mesh) = self.meshes.get(&draw.mesh) else {
                return Err(PrepareError::UnknownMesh {
                    index,
                    mesh: draw.mesh,
                });
            };
            let Some(material) = self.materials.get(&draw.material) else {
                return Err(PrepareError::UnknownMaterial {
                    index,
                    material: draw.material,
                });
            };
            let model = material.model;
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
            let mut uniforms = draw_uniforms(draw.world_from_model, &parameters)
                .ok_or(PrepareError::BadTransform { index })?;
            let offset = index * self.draw_stride as usize;
            let non_local = if model == Model::Curvature {
                NonLocal::OFF
            } else {
                frame.non_local
            };
            if uses_vertex_terms(model, non_local) && !self.pipelines.has_vertex_terms() {
                return Err(PrepareError::NoComputeShaders { index });
            }
            self.pipelines
                .ensure(device, &self.options, self.target, model, non_local)?;
            if non_local.subsurface {
                self.pipelines.ensure_subsurface_map(device)?;
            }
            let terms = if uses_vertex_terms(model, non_local) {
                let key = (
                    draw.mesh,
                    draw.material,
                    non_local,
                    draw.world_from_model.to_cols_array().map(f32::to_bits),
                );
                if let Some(region) = regions.iter().find(|region| region.key == key) {
                    uniforms.emitter_first = region.emitters.map_or(0, |(first, _)| first);
                    Some(region.range.clone())
                } else {
                    if u64::from(mesh.vertex_count) > max_terms_vertices {
                        return Err(PrepareError::TooManyVertices {
                            index,
                            vertices: mesh.vertex_count,
                            max_vertices: max_terms_vertices,
                        });
                    }
                    let start = u64::next_multiple_of(terms_end, terms_alignment);
                    terms_end = start + u64::from(mesh.vertex_count) * GpuVertexTerms::STRIDE;
                    // One run of a mesh and transform sends out its light (another material
                    // on the same surface would send it twice).
                    let emits_already = regions.iter().any(|region| {
                        region.emitters.is_some() && region.key.0 == key.0 && region.key.3 == key.3
                    });
                    let emitters = match &mesh.patches {
                        Some(patches) if non_local.interreflection && !emits_already => {
                            let first = emitter_count;
                            emitter_count += patches.count;
                            Some((first, patches.count))
                        }
                        _ => None,
                    };
                    uniforms.emitter_first = emitters.map_or(0, |(first, _)| first);
                    regions.push(TermsRegion {
                        key,
                        model,
                        draw_offset: offset as u32,
                        vertex_count: mesh.vertex_count,
                        range: start..terms_end,
                        emitters,
                    });
                    Some(start..terms_end)
                }
            } else {
                None
            };
            draws[offset..offset + size_of::<GpuDraw>()]
                .copy_from_slice(bytemuck::bytes_of(&uniforms));
            prepared.push(PreparedDraw {
                model,
                non_local,
                mesh: draw.mesh,
                material: draw.material,
                surface: draw.surface,
                indices: 3 * triangles.start..3 * triangles.end,
                offset: offset as u32,
                terms,
            });
        }
        queue.write_buffer(&self.frame_buffer, 0, bytemuck::bytes_of(&frame_uniforms));

        let needed = frame.draws.len() as u64;
        if needed > self.draw_capacity {
            let capacity = needed.next_power_of_two();
            self.draw_buffer = create_draw_buffer(device, self.draw_stride, capacity);
            self.draw_capacity = capacity;
            let binding = draw_binding(&self.draw_buffer);
            for surface in self
                .surfaces
                .values_mut()
                .chain(self.default_surface.as_mut())
            {
                surface.rebind(device, &self.draw_layout, &binding);
            }
        }
        if !draws.is_empty() {
            queue.write_buffer(&self.draw_buffer, 0, &draws);
        }
        if terms_end > self.terms_capacity {
            self.terms_capacity = terms_end.next_power_of_two();
            self.terms_buffer = create_terms_buffer(device, self.terms_capacity);
        }
        self.emitters.reserve(device, emitter_count);
        let mut commands = Vec::new();
        let light_maps = frame.non_local.light_maps();
        if light_maps && !prepared.is_empty() {
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
            commands.push(
                self.non_local.prepare(
                    device,
                    queue,
                    &self.options,
                    frame,
                    &self.meshes,
                    &casters,
                    LightViewBindings {
                        frame: &self.frame_bind_group,
                        draws: &self
                            .default_surface
                            .as_ref()
                            .expect("made above")
                            .bind_group,
                        subsurface_pipeline: prepared
                            .iter()
                            .any(|draw| draw.non_local.subsurface)
                            .then(|| self.pipelines.subsurface_map())
                            .flatten(),
                    },
                ),
            );
        }
        if !regions.is_empty() {
            commands.push(self.vertex_terms_pass(device, &regions, emitter_count));
        }
        self.prepared = prepared;
        Ok(commands)
    }

    /// The compute passes, after the light maps they read: each region's vertices' non-local
    /// terms, once; then with the inter-reflection its `emitter_count` emitters (the regions'
    /// patches), their bounces and each region's gather.
    fn vertex_terms_pass(
        &self,
        device: &wgpu::Device,
        regions: &[TermsRegion],
        emitter_count: u32,
    ) -> wgpu::CommandBuffer {
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("cdrf vertex terms"),
        });
        if emitter_count == 0 {
            // Gathers read one blank emitter.
            for buffer in &self.emitters.buffers {
                encoder.clear_buffer(buffer, 0, Some(size_of::<GpuEmitter>() as u64));
            }
        }
        // Per region: its pipelines and its group 2 reading emitter buffer `source` (0 or 1)
        // and writing the other.
        let runs: Vec<_> = regions
            .iter()
            .filter_map(|region| {
                let (mesh_id, material_id, non_local, _) = region.key;
                let mesh = self.meshes.get(&mesh_id)?;
                let material = self.materials.get(&material_id)?;
                let pipelines = self.pipelines.vertex_terms(region.model, non_local)?;
                let layout = self.pipelines.terms_layout()?;
                let bind_group = |source: usize| {
                    let (patches, members) = match &mesh.patches {
                        Some(patches) => (&patches.patches, &patches.members),
                        None => (&self.no_patches, &self.no_patches),
                    };
                    device.create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some("cdrf vertex terms"),
                        layout,
                        entries: &[
                            wgpu::BindGroupEntry {
                                binding: 0,
                                resource: wgpu::BindingResource::Buffer(draw_binding(
                                    &self.draw_buffer,
                                )),
                            },
                            wgpu::BindGroupEntry {
                                binding: 7,
                                resource: mesh.vertices.as_entire_binding(),
                            },
                            wgpu::BindGroupEntry {
                                binding: 8,
                                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                                    buffer: &self.terms_buffer,
                                    offset: region.range.start,
                                    size: wgpu::BufferSize::new(
                                        region.range.end - region.range.start,
                                    ),
                                }),
                            },
                            wgpu::BindGroupEntry {
                                binding: 9,
                                resource: patches.as_entire_binding(),
                            },
                            wgpu::BindGroupEntry {
                                binding: 10,
                                resource: members.as_entire_binding(),
                            },
                            wgpu::BindGroupEntry {
                                binding: 11,
                                resource: self.emitters.binding(source, emitter_count),
                            },
                            wgpu::BindGroupEntry {
                                binding: 12,
                                resource: self.emitters.binding(1 - source, emitter_count),
                            },
                        ],
                    })
                };
                Some((region, material, pipelines, [bind_group(0), bind_group(1)]))
            })
            .collect();
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("cdrf vertex terms"),
                timestamp_writes: None,
            });
            pass.set_bind_group(0, &self.frame_bind_group, &[]);
            pass.set_bind_group(3, self.non_local.bind_group(), &[]);
            // Each stage over every run: `count` invocations of `pipeline` reading emitter
            // buffer `source`.
            let mut stage =
                |pipeline: &dyn Fn(&TermsPipelines) -> Option<&wgpu::ComputePipeline>,
                 count: &dyn Fn(&TermsRegion) -> Option<u32>,
                 source: usize| {
                    for (region, material, pipelines, bind_groups) in &runs {
                        let (Some(pipeline), Some(count)) = (pipeline(pipelines), count(region))
                        else {
                            continue;
                        };
                        pass.set_pipeline(pipeline);
                        pass.set_bind_group(1, &material.bind_group, &[]);
                        pass.set_bind_group(2, &bind_groups[source], &[region.draw_offset]);
                        // 64 invocations a group (the shader's workgroup size), on a grid whose
                        // rows hold at most 65 535 groups.
                        let groups = count.div_ceil(64);
                        let columns = groups.clamp(1, 65_535);
                        pass.dispatch_workgroups(columns, groups.div_ceil(columns), 1);
                    }
                };
            let vertices = |region: &TermsRegion| Some(region.vertex_count);
            let patches = |region: &TermsRegion| region.emitters.map(|(_, count)| count);
            stage(&|p| Some(&p.vertex_terms), &vertices, 1);
            if emitter_count > 0 {
                // The emitters' own light into buffer 0, then each bounce into the other.
                stage(
                    &|p| p.interreflection.as_ref().map(|[e, _, _]| e),
                    &patches,
                    1,
                );
                let mut source = 0;
                for _ in 1..self.options.interreflection_bounces.max(1) {
                    stage(
                        &|p| p.interreflection.as_ref().map(|[_, b, _]| b),
                        &patches,
                        source,
                    );
                    source = 1 - source;
                }
                stage(
                    &|p| p.interreflection.as_ref().map(|[_, _, g]| g),
                    &vertices,
                    source,
                );
            } else {
                stage(
                    &|p| p.interreflection.as_ref().map(|[_, _, g]| g),
                    &vertices,
                    0,
                );
            }
        }
        encoder.finish()
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
        pass.set_bind_group(3, self.non_local.bind_group(), &[]);
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
                pass.set_vertex_buffer(1, self.terms_buffer.slice(terms.clone()));
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

/// The frame's camera and lights, checked.
fn frame_uniforms(frame: &FrameDesc<'_>) -> Result<GpuFrame, PrepareError> {
    let needs_units =
        frame.non_local.any() || frame.directional_lights().count() < frame.lights.len();
    if needs_units && !(frame.mm_per_world_unit.is_finite() && frame.mm_per_world_unit > 0.0) {
        return Err(PrepareError::BadUnits {
            mm_per_world_unit: frame.mm_per_world_unit,
        });
    }
    if frame.lights.len() > MAX_LIGHTS {
        return Err(PrepareError::TooManyLights {
            count: frame.lights.len(),
        });
    }
    let mut uniforms = GpuFrame {
        clip_from_world: frame.view.clip_from_world,
        exposure: frame.exposure,
        light_count: frame.lights.len() as u32,
        mm_per_world_unit: frame.mm_per_world_unit,
        ..bytemuck::Zeroable::zeroed()
    };
    for (index, light) in frame.lights.iter().enumerate() {
        gpu_light(light).map_err(|problem| PrepareError::BadLight { index, problem })?;
    }
    for (slot, light) in uniforms
        .lights
        .iter_mut()
        .zip(frame.lights_in_shading_order())
    {
        *slot = gpu_light(light).expect("checked above");
    }
    let (to_camera, is_point) = match frame.view.to_camera {
        ToCamera::Point(eye) => (eye, true),
        ToCamera::Direction(direction) => (direction.normalize_or_zero(), false),
    };
    if !frame.view.clip_from_world.is_finite()
        || !to_camera.is_finite()
        || (!is_point && to_camera == Vec3::ZERO)
    {
        return Err(PrepareError::BadView);
    }
    if !(0.0..=crate::frame::MAX_EXPOSURE).contains(&frame.exposure) {
        return Err(PrepareError::BadExposure {
            exposure: frame.exposure,
        });
    }
    uniforms.to_camera = to_camera;
    uniforms.camera_is_point = u32::from(is_point);
    if let Some(sh) = frame.environment {
        if sh.coefficients.iter().flatten().any(|c| !c.is_finite()) {
            return Err(PrepareError::BadEnvironment);
        }
        let bands = (sh.order() + 1).min(ENVIRONMENT_SH_ORDER + 1);
        let factors = sh_basis_factors(bands - 1);
        for ((slot, c), factor) in uniforms
            .environment_sh
            .iter_mut()
            .zip(&sh.coefficients)
            .zip(&factors)
        {
            *slot = [c[0] * factor, c[1] * factor, c[2] * factor, 0.0];
        }
        uniforms.environment_bands = if sh.coefficients.is_empty() {
            0
        } else {
            bands as u32
        };
    }
    Ok(uniforms)
}

/// A draw's transforms, or `None` for a transform that is singular, mirroring (it would flip
/// the winding and cull the wrong faces) or not finite.
fn draw_uniforms(world_from_model: Mat4, surface: &SurfaceParameters) -> Option<GpuDraw> {
    let linear = Mat3::from_mat4(world_from_model);
    let determinant = linear.determinant();
    if !world_from_model.is_finite() || determinant < 1e-30 {
        return None;
    }
    Some(GpuDraw {
        world_from_model,
        normal_from_model: Mat4::from_mat3(linear.inverse().transpose()),
        base_color_factor: surface.base_color_factor,
        curvature_scale: 1.0 / determinant.cbrt(),
        normal_scale: surface.normal_scale,
        roughness_factor: surface.roughness_factor,
        surface_flags: surface.flags,
        emitter_first: 0,
    })
}

/// The vertex terms buffer: written by the vertex terms pass, read as a vertex buffer (a
/// vertex buffer only, never written, on a device that does not run the pass).
fn create_terms_buffer(device: &wgpu::Device, size: u64) -> wgpu::Buffer {
    let usage = if runs_vertex_terms(&device.limits()) {
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::VERTEX
    } else {
        wgpu::BufferUsages::VERTEX
    };
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("cdrf vertex terms"),
        size,
        usage,
        mapped_at_creation: false,
    })
}

fn create_draw_buffer(device: &wgpu::Device, stride: u64, capacity: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("cdrf draw uniforms"),
        size: stride * capacity,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// One draw's window of the draw buffer (moved by the dynamic offset).
fn draw_binding(buffer: &wgpu::Buffer) -> wgpu::BufferBinding<'_> {
    wgpu::BufferBinding {
        buffer,
        offset: 0,
        size: Some(uniform_size::<GpuDraw>()),
    }
}

/// One light as the shader holds it, or what is wrong with it.
fn gpu_light(light: &Light) -> Result<GpuLight, &'static str> {
    let unit = |v: Vec3, what| {
        if v.is_finite() && v.length_squared() >= 1e-12 {
            Ok(v.normalize())
        } else {
            Err(what)
        }
    };
    let colour = |c: [f32; 3], what| {
        if c.iter().all(|e| e.is_finite() && *e >= 0.0) {
            Ok(Vec3::from_array(c))
        } else {
            Err(what)
        }
    };
    let position = |p: Vec3| {
        if p.is_finite() {
            Ok(p)
        } else {
            Err("position is not finite")
        }
    };
    Ok(match *light {
        Light::Directional(light) => GpuLight {
            to_light: unit(light.to_light, "direction is zero or not finite")?,
            kind: GPU_LIGHT_DIRECTIONAL,
            irradiance: colour(light.irradiance, "irradiance must be finite and ≥ 0")?,
            ..bytemuck::Zeroable::zeroed()
        },
        Light::Point(light) => GpuLight {
            position: position(light.position)?,
            kind: GPU_LIGHT_POINT,
            intensity: colour(light.intensity, "intensity must be finite and ≥ 0")?,
            ..bytemuck::Zeroable::zeroed()
        },
        Light::Spot(light) => {
            let (inner, outer) = (light.inner_angle_rad, light.outer_angle_rad);
            // (NaN fails every comparison.)
            if !(0.0 <= inner && inner < outer && outer <= std::f32::consts::FRAC_PI_2) {
                return Err("spot angles must satisfy 0 ≤ inner < outer ≤ π/2");
            }
            GpuLight {
                position: position(light.position)?,
                kind: GPU_LIGHT_SPOT,
                intensity: colour(light.intensity, "intensity must be finite and ≥ 0")?,
                spot_cos_outer: outer.cos(),
                spot_direction: unit(light.direction, "spot direction is zero or not finite")?,
                spot_cos_inner: inner.cos(),
                ..bytemuck::Zeroable::zeroed()
            }
        }
    })
}
