//! The render world's side: cdrf-render `Renderer`s on Bevy's device, one per target (colour
//! format and MSAA) that 3D cameras render into, prepared once a frame with the extracted frame
//! and recorded into each camera's HDR target and depth buffer after Bevy's opaque pass, from
//! the camera's own view.

use std::collections::HashMap;
use std::sync::Arc;

use bevy::core_pipeline::Core3d;
use bevy::ecs::schedule::ScheduleLabel;
use bevy::prelude::*;
use bevy::render::Extract;
use bevy::render::camera::ExtractedCamera;
use bevy::render::renderer::{RenderContext, RenderDevice, RenderQueue, ViewQuery};
use bevy::render::view::{ExtractedView, Msaa, ViewDepthStencilTexture, ViewTarget};
use cdrf_render::{
    Draw, FrameDesc, MaterialDesc, MaterialId, MeshDesc, MeshId, MeshVertices, Renderer, SurfaceId,
    TargetDesc, ToCamera, View, wgpu,
};

use crate::assets::{ResolvedMaterial, ResolvedModel};
use crate::frame::{CdrfFrame, FrameDraw, PreparedMesh, to_glam_mat4, to_glam_vec3};
use crate::surface::PreparedSurface;

/// Bevy's main-pass depth format (`CORE_3D_DEPTH_FORMAT`), reversed Z.
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// The renderers by target, and which renderer and view each 3D camera draws with this frame
/// (by render-world entity). Cameras with the same target (split screen, several windows or
/// image targets of one format) share a renderer: meshes, materials and the non-local passes
/// once, a view each.
#[derive(Resource, Default)]
pub(crate) struct CdrfViews {
    renderers: HashMap<TargetDesc, TargetRenderer>,
    cameras: HashMap<Entity, (TargetDesc, usize)>,
}

struct TargetRenderer {
    renderer: Renderer,
    /// Uploaded meshes and materials, by the address of the frame's shared data (kept alive
    /// here, so an address is not reused while its entry exists).
    meshes: HashMap<usize, (Arc<PreparedMesh>, MeshId)>,
    materials: HashMap<usize, (Arc<ResolvedMaterial>, MaterialId)>,
    surfaces: HashMap<usize, (Arc<PreparedSurface>, SurfaceId)>,
    /// Skinned entities' own deforming meshes, by the main-world entity.
    skinned: HashMap<Entity, (Arc<PreparedMesh>, MeshId)>,
    /// Whether this frame's `prepare` succeeded (else the pass draws nothing).
    prepared: bool,
}

pub(crate) fn extract_frame(mut commands: Commands, frame: Extract<Res<CdrfFrame>>) {
    commands.insert_resource((*frame).clone());
}

/// Prepares a renderer per target with the first camera (by `order`) that renders into it,
/// and adds the other cameras as views: uploads new meshes and materials, drops unused ones,
/// and records the frame's non-local passes once per target.
pub(crate) fn prepare_views(
    mut views: ResMut<CdrfViews>,
    frame: Res<CdrfFrame>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    cameras: Query<(
        Entity,
        &ExtractedView,
        &ExtractedCamera,
        &ViewTarget,
        Option<&Msaa>,
    )>,
) {
    let device = device.wgpu_device();
    let queue: &wgpu::Queue = &queue;
    let core_3d = Core3d.intern();
    let mut cameras: Vec<_> = cameras
        .iter()
        .filter(|(_, _, camera, _, _)| camera.schedule == core_3d)
        .collect();
    cameras.sort_by_key(|(_, _, camera, _, _)| camera.order);
    let views = &mut *views;
    views.cameras.clear();
    let mut prepared_targets: Vec<TargetDesc> = Vec::new();
    for (entity, view, camera, target, msaa) in cameras {
        let target = TargetDesc::new(target.main_texture_format())
            .with_sample_count(msaa.map_or(1, Msaa::samples))
            .with_depth(DEPTH_FORMAT);
        let state = views.renderers.entry(target).or_insert_with(|| {
            let options = cdrf_render::Options {
                depth_compare: wgpu::CompareFunction::Greater,
                ..frame.settings.options
            };
            TargetRenderer {
                renderer: Renderer::new(device, &target, options),
                meshes: HashMap::new(),
                materials: HashMap::new(),
                surfaces: HashMap::new(),
                skinned: HashMap::new(),
                prepared: false,
            }
        });
        let index = if prepared_targets.contains(&target) {
            if !state.prepared {
                continue;
            }
            match state
                .renderer
                .add_view(device, queue, &view_of(view), camera.exposure)
            {
                Ok(index) => index,
                Err(error) => {
                    error_once!("cdrf: cannot render the CDRF meshes from a camera: {error}");
                    continue;
                }
            }
        } else {
            prepared_targets.push(target);
            state.prepared = false;
            match prepare_frame(state, device, queue, &frame, view, camera) {
                Ok(commands) => {
                    // Submitted now, ahead of every camera's pass this frame.
                    queue.submit(commands);
                    state.prepared = true;
                }
                Err(error) => {
                    error_once!("cdrf: cannot render the CDRF meshes: {error}");
                    continue;
                }
            }
            0
        };
        views.cameras.insert(entity, (target, index));
    }
    views
        .renderers
        .retain(|target, _| prepared_targets.contains(target));
}

/// Why a view could not be prepared.
#[derive(Debug, thiserror::Error)]
enum ViewError {
    #[error("mesh upload: {0}")]
    Mesh(#[from] cdrf_render::MeshUploadError),
    #[error("material: {0}")]
    Material(#[from] cdrf_render::MaterialError),
    #[error("surface: {0}")]
    Surface(#[from] cdrf_render::SurfaceError),
    #[error("frame: {0}")]
    Prepare(#[from] cdrf_render::PrepareError),
}

/// What the frame's draws use, by key (the rest is removed).
#[derive(Default)]
struct Used {
    meshes: Vec<usize>,
    materials: Vec<usize>,
    skinned: Vec<Entity>,
    surfaces: Vec<usize>,
}

/// Uploads what a draw needs that the renderer does not hold yet (moving a skinned mesh).
fn upload_draw(
    state: &mut TargetRenderer,
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    draw: &FrameDraw,
    used: &mut Used,
) -> Result<Draw, ViewError> {
    let mesh = if let Some((entity, pose)) = &draw.pose {
        let id = skinned_mesh(state, device, *entity, &draw.mesh)?;
        state.renderer.update_mesh(
            queue,
            id,
            &MeshVertices {
                tangents: pose.tangents.as_deref(),
                curvature_anisotropy_per_mm: Some(&pose.anisotropy_per_mm),
                ..MeshVertices::new(&pose.positions, &pose.normals)
            },
        )?;
        used.skinned.push(*entity);
        id
    } else {
        let mesh_key = Arc::as_ptr(&draw.mesh) as usize;
        used.meshes.push(mesh_key);
        match state.meshes.get(&mesh_key) {
            Some((_, id)) => *id,
            None => {
                let prepared = &draw.mesh;
                let id = state.renderer.create_mesh(device, &mesh_desc(prepared))?;
                state.meshes.insert(mesh_key, (prepared.clone(), id));
                id
            }
        }
    };
    let material_key = Arc::as_ptr(&draw.material) as usize;
    let material = match state.materials.get(&material_key) {
        Some((_, id)) => *id,
        None => {
            let desc = match &draw.material.model {
                ResolvedModel::Measured(lut) => MaterialDesc::Measured { lut },
                &ResolvedModel::Lambert(albedo) => MaterialDesc::Lambert { albedo },
            };
            let id = state.renderer.create_material(device, queue, &desc)?;
            state
                .renderer
                .set_material_specular(queue, id, draw.material.specular)?;
            state
                .materials
                .insert(material_key, (draw.material.clone(), id));
            id
        }
    };
    used.materials.push(material_key);
    let mut cdrf_draw = Draw::new(mesh, material, draw.world_from_model);
    if let Some(surface) = &draw.surface {
        let key = Arc::as_ptr(surface) as usize;
        let id = match state.surfaces.get(&key) {
            Some((_, id)) => *id,
            None => {
                let id = state
                    .renderer
                    .create_surface(device, queue, &surface.desc())?;
                state.surfaces.insert(key, (surface.clone(), id));
                id
            }
        };
        used.surfaces.push(key);
        cdrf_draw = cdrf_draw.with_surface(id);
    }
    Ok(cdrf_draw)
}

fn prepare_frame(
    state: &mut TargetRenderer,
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    frame: &CdrfFrame,
    view: &ExtractedView,
    camera: &ExtractedCamera,
) -> Result<Vec<wgpu::CommandBuffer>, ViewError> {
    let mut draws = Vec::with_capacity(frame.draws.len());
    let mut used = Used::default();
    for draw in &frame.draws {
        // A draw that cannot be uploaded is left out; the others are drawn.
        match upload_draw(state, device, queue, draw, &mut used) {
            Ok(draw) => draws.push(draw),
            Err(error) => warn_once!("cdrf: a CDRF mesh is not drawn: {error}"),
        }
    }
    let Used {
        meshes: used_meshes,
        materials: used_materials,
        skinned: used_skinned,
        surfaces: used_surfaces,
    } = used;
    // What no draw uses any more (a hot-reloaded asset's old version, a despawned mesh) goes.
    let renderer = &mut state.renderer;
    state.meshes.retain(|key, (_, id)| {
        used_meshes.contains(key) || {
            renderer.remove_mesh(*id);
            false
        }
    });
    state.surfaces.retain(|key, (_, id)| {
        used_surfaces.contains(key) || {
            renderer.remove_surface(*id);
            false
        }
    });
    state.skinned.retain(|entity, (_, id)| {
        used_skinned.contains(entity) || {
            renderer.remove_mesh(*id);
            false
        }
    });
    state.materials.retain(|key, (_, id)| {
        used_materials.contains(key) || {
            renderer.remove_material(*id);
            false
        }
    });

    let desc = FrameDesc {
        view: view_of(view),
        lights: &frame.lights,
        exposure: camera.exposure,
        draws: &draws,
        non_local: frame.settings.non_local,
        mm_per_world_unit: frame.settings.mm_per_unit,
        environment: frame.environment.as_ref(),
    };
    Ok(state.renderer.prepare(device, queue, &desc)?)
}

/// A Bevy camera's view as cdrf's.
fn view_of(view: &ExtractedView) -> View {
    let clip_from_view = view.clip_from_view;
    let world_from_view = view.world_from_view.to_matrix();
    let clip_from_world = view
        .clip_from_world
        .unwrap_or(clip_from_view * world_from_view.inverse());
    let to_camera = if clip_from_view.w_axis.w == 1.0 {
        ToCamera::Direction(to_glam_vec3(view.world_from_view.back().as_vec3()))
    } else {
        ToCamera::Point(to_glam_vec3(view.world_from_view.translation()))
    };
    View {
        clip_from_world: to_glam_mat4(clip_from_world),
        to_camera,
    }
}

fn mesh_desc(prepared: &PreparedMesh) -> MeshDesc<'_> {
    MeshDesc::from_mesh(&prepared.mesh, &prepared.curvature_per_mm)
        .with_curvature_anisotropy(&prepared.anisotropy_per_mm)
        .with_tangents(prepared.tangents.as_deref())
}

/// A skinned entity's deforming mesh, made anew when the entity's mesh asset changed.
fn skinned_mesh(
    state: &mut TargetRenderer,
    device: &wgpu::Device,
    entity: Entity,
    prepared: &Arc<PreparedMesh>,
) -> Result<MeshId, ViewError> {
    if let Some((current, id)) = state.skinned.get(&entity) {
        if Arc::ptr_eq(current, prepared) {
            return Ok(*id);
        }
        state.renderer.remove_mesh(*id);
    }
    let id = state
        .renderer
        .create_mesh(device, &mesh_desc(prepared).deforming())?;
    state.skinned.insert(entity, (prepared.clone(), id));
    Ok(id)
}

/// Draws the CDRF meshes into the camera's main texture, testing and writing Bevy's depth.
pub(crate) fn cdrf_main_pass_3d(
    view: ViewQuery<(&ExtractedCamera, &ViewTarget, &ViewDepthStencilTexture)>,
    views: Res<CdrfViews>,
    mut ctx: RenderContext,
) {
    let Some((target, index)) = views.cameras.get(&view.entity()) else {
        return;
    };
    let Some(state) = views.renderers.get(target).filter(|state| state.prepared) else {
        return;
    };
    let (camera, target, depth) = view.into_inner();
    let mut pass = ctx
        .command_encoder()
        .begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("cdrf_main_pass_3d"),
            color_attachments: &[Some(target.get_color_attachment())],
            depth_stencil_attachment: Some(depth.get_attachment(wgpu::StoreOp::Store)),
            ..Default::default()
        });
    if let Some(viewport) = &camera.viewport {
        let (position, size) = (viewport.physical_position, viewport.physical_size);
        pass.set_viewport(
            position.x as f32,
            position.y as f32,
            size.x as f32,
            size.y as f32,
            viewport.depth.start,
            viewport.depth.end,
        );
    }
    state.renderer.render_view(&mut pass, *index);
}
