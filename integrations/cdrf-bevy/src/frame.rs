//! The main world's side: what a frame draws, gathered after transforms propagate — CDRF
//! meshes with their curvature (computed once per mesh asset), materials, Bevy's lights in
//! cdrf's units — for the render world to extract.

use std::collections::HashMap;
use std::sync::Arc;

use bevy::light::{EnvironmentMapLight, GlobalAmbientLight};
use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
use bevy::mesh::{Indices, PrimitiveTopology, VertexAttributeValues};
use bevy::prelude::*;
use cdrf_core::curvature::{CurvatureOptions, curvature_per_mm, material_filter_length_mm};
use cdrf_core::environment::{Environment, ShCoefficients};
use cdrf_core::glam;
use cdrf_core::light::{self as cdrf_light, Light};
use cdrf_core::mesh::MeshData;

use crate::CdrfSettings;
use crate::assets::{CdrfMaterial, CdrfMaterial3d, CdrfTable, ResolvedMaterial};
use crate::environment::{add_sh, diffuse_map_sh};
use crate::skinning::{self, Pose, SkinWeights};
use crate::surface::{CdrfSurface, PreparedSurface, prepare_surface};
use crate::units;

/// A mesh asset as cdrf-render takes it: its triangles and per-vertex curvature.
pub struct PreparedMesh {
    /// The mesh as cdrf reads it.
    pub mesh: cdrf_core::Mesh,
    /// Signed mean curvature per vertex, mm⁻¹.
    pub curvature_per_mm: Vec<f32>,
    /// The curvature tensor's anisotropy per vertex, mm⁻¹ (model space).
    pub anisotropy_per_mm: Vec<glam::Vec3>,
    /// Its joint weights, where the Bevy mesh has them and cdrf kept every vertex in order.
    pub(crate) skin: Option<SkinWeights>,
    /// Its tangents (`ATTRIBUTE_TANGENT`, for normal maps), on the same condition.
    pub tangents: Option<Vec<glam::Vec4>>,
}

/// One CDRF entity of the frame.
#[derive(Clone)]
pub(crate) struct FrameDraw {
    pub mesh: Arc<PreparedMesh>,
    pub material: Arc<ResolvedMaterial>,
    pub world_from_model: glam::Mat4,
    /// A skinned entity's vertices this frame (world units / the skin's scale; the transform is
    /// then that scale), and the entity, whose own deforming copy of the mesh they move.
    pub pose: Option<(Entity, Arc<Pose>)>,
    /// What it is painted with ([`CdrfSurface`]).
    pub surface: Option<Arc<PreparedSurface>>,
}

/// Everything the render world needs for a frame (cheap to clone: shared data is in `Arc`s).
#[derive(Resource, Clone, Default)]
pub(crate) struct CdrfFrame {
    pub draws: Vec<FrameDraw>,
    pub lights: Vec<Light>,
    pub environment: Option<ShCoefficients>,
    pub settings: CdrfSettings,
}

/// Curvature per mesh asset and curvature filter (a material's diffusion length sets it), and
/// the materials' tables; entries go when their asset changes.
#[derive(Resource, Default)]
pub(crate) struct CdrfCaches {
    meshes: HashMap<(AssetId<Mesh>, u32), Option<Arc<PreparedMesh>>>,
    materials: HashMap<AssetId<CdrfMaterial>, Arc<ResolvedMaterial>>,
    /// Surfaces by `StandardMaterial` (`None`: it cannot paint; said once).
    surfaces: HashMap<AssetId<StandardMaterial>, Option<Arc<PreparedSurface>>>,
    /// The last environment map's projection (before its intensity), by its diffuse map and
    /// rotation; `None` inside when it cannot be read.
    environment: Option<(EnvironmentKey, Option<ShCoefficients>)>,
}

type EnvironmentKey = (AssetId<Image>, [u32; 4]);

/// Drops cached curvature and tables whose assets changed (hot reload).
pub(crate) fn invalidate_caches(
    mut caches: ResMut<CdrfCaches>,
    mut meshes: MessageReader<AssetEvent<Mesh>>,
    mut materials: MessageReader<AssetEvent<CdrfMaterial>>,
    mut tables: MessageReader<AssetEvent<CdrfTable>>,
    mut images: MessageReader<AssetEvent<Image>>,
    mut standard: MessageReader<AssetEvent<StandardMaterial>>,
) {
    for event in standard.read() {
        if let AssetEvent::Modified { id } | AssetEvent::Removed { id } = event {
            caches.surfaces.remove(id);
        }
    }
    for event in meshes.read() {
        if let AssetEvent::Modified { id } | AssetEvent::Removed { id } = event {
            caches.meshes.retain(|(mesh, _), _| mesh != id);
        }
    }
    for event in materials.read() {
        if let AssetEvent::Modified { id } | AssetEvent::Removed { id } = event {
            caches.materials.remove(id);
        }
    }
    for event in images.read() {
        if let AssetEvent::Modified { .. } | AssetEvent::Removed { .. } = event {
            caches.surfaces.clear(); // (a texture of one of them, perhaps)
        }
        if let AssetEvent::Modified { id } | AssetEvent::Removed { id } = event
            && caches
                .environment
                .as_ref()
                .is_some_and(|((image, _), _)| image == id)
        {
            caches.environment = None;
        }
    }
    // A material is cached only once its table has loaded: only a reloaded table matters.
    if tables
        .read()
        .any(|event| matches!(event, AssetEvent::Modified { .. }))
    {
        caches.materials.clear();
    }
}

/// What gather_frame reads of a CDRF entity.
type CdrfEntity = (
    Entity,
    &'static Mesh3d,
    &'static CdrfMaterial3d,
    &'static GlobalTransform,
    &'static InheritedVisibility,
    Option<&'static SkinnedMesh>,
    Option<&'static CdrfSurface>,
);

/// Gathers the frame: draws (their curvature computed on first use), lights, the sky.
#[allow(clippy::too_many_arguments)]
pub(crate) fn gather_frame(
    mut frame: ResMut<CdrfFrame>,
    mut caches: ResMut<CdrfCaches>,
    settings: Res<CdrfSettings>,
    meshes: Res<Assets<Mesh>>,
    materials: Res<Assets<CdrfMaterial>>,
    tables: Res<Assets<CdrfTable>>,
    draws: Query<CdrfEntity>,
    bindposes: Res<Assets<SkinnedMeshInverseBindposes>>,
    transforms: Query<&GlobalTransform>,
    directional: Query<(&DirectionalLight, &GlobalTransform, &InheritedVisibility)>,
    point: Query<(&PointLight, &GlobalTransform, &InheritedVisibility)>,
    spot: Query<(&SpotLight, &GlobalTransform, &InheritedVisibility)>,
    ambient: Option<Res<GlobalAmbientLight>>,
    environment_maps: Query<(&EnvironmentMapLight, &Camera), With<Camera3d>>,
    images: Res<Assets<Image>>,
    standard_materials: Res<Assets<StandardMaterial>>,
) {
    let caches = &mut *caches;
    frame.settings = settings.clone();
    frame.draws.clear();
    for (entity, mesh, material, transform, visibility, skin, surface) in &draws {
        if !visibility.get() {
            continue;
        }
        let Some(material) =
            resolved_material(&mut caches.materials, material.id(), &materials, &tables)
        else {
            continue; // still loading
        };
        let diffusion_length_mm = material.diffusion_length_mm();
        let Some(mesh) = prepared_mesh(
            &mut caches.meshes,
            mesh.id(),
            &meshes,
            diffusion_length_mm,
            &settings,
        ) else {
            continue;
        };
        let surface = match surface {
            None => None,
            Some(CdrfSurface(handle)) => {
                match resolved_surface(&mut caches.surfaces, handle, &standard_materials, &images) {
                    Some(surface) => surface,
                    None => continue, // its textures are loading
                }
            }
        };
        let pose = skin.and_then(|skin| {
            pose(&mesh, skin, &bindposes, &transforms)
                .inspect_err(|error| {
                    warn_once!("cdrf: skinned entity {entity}: {error}; drawn in its rest pose");
                })
                .ok()
        });
        frame.draws.push(FrameDraw {
            world_from_model: if let Some(pose) = &pose {
                glam::Mat4::from_scale(glam::Vec3::splat(pose.scale))
            } else {
                to_glam_mat4(transform.to_matrix())
            },
            pose: pose.map(|pose| (entity, Arc::new(pose))),
            mesh,
            material,
            surface,
        });
    }

    let mm_per_unit = settings.mm_per_unit;
    let mut lights = Vec::new();
    for (light, transform, visibility) in &directional {
        if visibility.get() {
            lights.push(Light::Directional(cdrf_light::DirectionalLight {
                to_light: to_glam_vec3(-transform.forward().as_vec3()),
                irradiance: units::directional_irradiance(linear(light.color), light.illuminance),
            }));
        }
    }
    for (light, transform, visibility) in &point {
        if visibility.get() {
            lights.push(Light::Point(cdrf_light::PointLight {
                position: to_glam_vec3(transform.translation()),
                intensity: units::point_intensity(
                    linear(light.color),
                    light.intensity,
                    mm_per_unit,
                ),
            }));
        }
    }
    for (light, transform, visibility) in &spot {
        if visibility.get() {
            let outer = light.outer_angle.clamp(1e-3, std::f32::consts::FRAC_PI_2);
            lights.push(Light::Spot(cdrf_light::SpotLight {
                position: to_glam_vec3(transform.translation()),
                direction: to_glam_vec3(transform.forward().as_vec3()),
                intensity: units::point_intensity(
                    linear(light.color),
                    light.intensity,
                    mm_per_unit,
                ),
                inner_angle_rad: light.inner_angle.clamp(0.0, outer * 0.999),
                outer_angle_rad: outer,
            }));
        }
    }
    if lights.len() > cdrf_render::MAX_LIGHTS {
        warn_once!(
            "cdrf: {} lights in the scene; the CDRF meshes are lit by the first {}",
            lights.len(),
            cdrf_render::MAX_LIGHTS
        );
        lights.truncate(cdrf_render::MAX_LIGHTS);
    }
    frame.lights = lights;

    let ambient = ambient.and_then(|ambient| {
        let radiance = units::ambient_radiance(linear(ambient.color), ambient.brightness);
        (radiance.iter().any(|&r| r > 0.0))
            .then(|| Environment::uniform(radiance).ok())
            .flatten()
            .map(|sky| sky.project_sh(cdrf_render::ENVIRONMENT_SH_ORDER))
    });
    let map = environment_map(&mut caches.environment, &environment_maps, &images);
    frame.environment = match (ambient, map) {
        (Some(a), Some(b)) => Some(add_sh(&a, &b)),
        (a, b) => a.or(b),
    };
}

/// The environment map of the 3D cameras (the first active one with a map: cdrf lights a
/// frame with one sky), projected once per diffuse map and rotation, times its intensity.
fn environment_map(
    cache: &mut Option<(EnvironmentKey, Option<ShCoefficients>)>,
    maps: &Query<(&EnvironmentMapLight, &Camera), With<Camera3d>>,
    images: &Assets<Image>,
) -> Option<ShCoefficients> {
    let mut active = maps.iter().filter(|(_, camera)| camera.is_active);
    let (light, _) = active.next()?;
    if active.any(|(other, _)| other.diffuse_map != light.diffuse_map) {
        warn_once!("cdrf: cameras with different environment maps; CDRF meshes use the first");
    }
    let key = (
        light.diffuse_map.id(),
        light.rotation.to_array().map(f32::to_bits),
    );
    if cache.as_ref().is_none_or(|(cached, _)| *cached != key) {
        let image = images.get(&light.diffuse_map)?; // still loading
        let sh = diffuse_map_sh(image, light.rotation)
            .inspect_err(|error| {
                error!("cdrf: the environment map does not light the CDRF meshes: {error}");
            })
            .ok();
        *cache = Some((key, sh));
    }
    let (_, sh) = cache.as_ref()?;
    sh.as_ref().map(|sh| ShCoefficients {
        coefficients: sh
            .coefficients
            .iter()
            .map(|c| c.map(|v| v * light.intensity))
            .collect(),
    })
}

/// A skinned entity's vertices this frame.
fn pose(
    mesh: &PreparedMesh,
    skin: &SkinnedMesh,
    bindposes: &Assets<SkinnedMeshInverseBindposes>,
    transforms: &Query<&GlobalTransform>,
) -> Result<Pose, skinning::SkinError> {
    let weights = mesh.skin.as_ref().ok_or(skinning::SkinError::Weights)?;
    let matrices = skinning::joint_matrices(skin, bindposes, transforms)?;
    let rest = skinning::RestPose {
        positions: &mesh.mesh.positions,
        normals: &mesh.mesh.normals,
        tangents: mesh.tangents.as_deref(),
        anisotropy_per_mm: &mesh.anisotropy_per_mm,
    };
    skinning::skin(&rest, weights, &matrices)
}

/// A `StandardMaterial`'s surface: `None` while it loads, `Some(None)` when it cannot paint.
fn resolved_surface(
    cache: &mut HashMap<AssetId<StandardMaterial>, Option<Arc<PreparedSurface>>>,
    handle: &Handle<StandardMaterial>,
    materials: &Assets<StandardMaterial>,
    images: &Assets<Image>,
) -> Option<Option<Arc<PreparedSurface>>> {
    if let Some(surface) = cache.get(&handle.id()) {
        return Some(surface.clone());
    }
    let surface = match prepare_surface(materials.get(handle)?, images) {
        Ok(surface) => surface?.into(),
        Err(error) => {
            warn!("cdrf: material {handle:?} does not paint its CDRF meshes: {error}");
            None
        }
    }
    .map(Arc::new);
    cache.insert(handle.id(), surface.clone());
    Some(surface)
}

fn resolved_material(
    cache: &mut HashMap<AssetId<CdrfMaterial>, Arc<ResolvedMaterial>>,
    id: AssetId<CdrfMaterial>,
    materials: &Assets<CdrfMaterial>,
    tables: &Assets<CdrfTable>,
) -> Option<Arc<ResolvedMaterial>> {
    if let Some(material) = cache.get(&id) {
        return Some(material.clone());
    }
    let material = Arc::new(materials.get(id)?.resolve(tables)?);
    cache.insert(id, material.clone());
    Some(material)
}

/// The mesh with its curvature, filtered over the material's diffusion length as cdrf's scene
/// files do (at the entity's scale 1).
fn prepared_mesh(
    cache: &mut HashMap<(AssetId<Mesh>, u32), Option<Arc<PreparedMesh>>>,
    id: AssetId<Mesh>,
    meshes: &Assets<Mesh>,
    diffusion_length_mm: Option<f32>,
    settings: &CdrfSettings,
) -> Option<Arc<PreparedMesh>> {
    let key = (id, diffusion_length_mm.unwrap_or(0.0).to_bits());
    if let Some(prepared) = cache.get(&key) {
        return prepared.clone();
    }
    let source = meshes.get(id)?; // still loading
    let prepared = prepare_mesh(source, diffusion_length_mm, settings.mm_per_unit)
        .inspect_err(|error| error!("cdrf: mesh {id}: {error}; it is not drawn"))
        .ok()
        .map(Arc::new);
    cache.insert(key, prepared.clone());
    prepared
}

/// Why a Bevy mesh cannot be drawn by cdrf.
#[derive(Debug, thiserror::Error)]
pub enum MeshConversionError {
    /// Only triangle lists are drawn.
    #[error("its topology is {0:?}, not a triangle list")]
    Topology(PrimitiveTopology),
    /// Positions are missing, not `Float32x3`, or the main world no longer holds them
    /// (`RenderAssetUsages::RENDER_WORLD` only).
    #[error("it has no Float32x3 positions in the main world")]
    Positions,
    /// The geometry was refused.
    #[error(transparent)]
    Mesh(#[from] cdrf_core::mesh::MeshError),
    /// The curvature could not be estimated.
    #[error(transparent)]
    Curvature(#[from] cdrf_core::curvature::CurvatureError),
}

/// A Bevy mesh as a cdrf mesh with curvature (model units × `mm_per_unit`), filtered over
/// the material's diffusion length as cdrf's scene files do.
pub fn prepare_mesh(
    source: &Mesh,
    diffusion_length_mm: Option<f32>,
    mm_per_unit: f32,
) -> Result<PreparedMesh, MeshConversionError> {
    if source.primitive_topology() != PrimitiveTopology::TriangleList {
        return Err(MeshConversionError::Topology(source.primitive_topology()));
    }
    let float3 = |attribute| match source.try_attribute_option(attribute) {
        Ok(Some(VertexAttributeValues::Float32x3(values))) => Some(
            values
                .iter()
                .map(|&v| glam::Vec3::from_array(v))
                .collect::<Vec<_>>(),
        ),
        _ => None,
    };
    let positions = float3(Mesh::ATTRIBUTE_POSITION).ok_or(MeshConversionError::Positions)?;
    let normals = float3(Mesh::ATTRIBUTE_NORMAL);
    let uvs = match source.try_attribute_option(Mesh::ATTRIBUTE_UV_0) {
        Ok(Some(VertexAttributeValues::Float32x2(values))) => {
            Some(values.iter().map(|&v| glam::Vec2::from_array(v)).collect())
        }
        _ => None,
    };
    let indices: Vec<u32> = match source.try_indices_option() {
        Ok(Some(Indices::U16(indices))) => indices.iter().map(|&i| u32::from(i)).collect(),
        Ok(Some(Indices::U32(indices))) => indices.clone(),
        _ => (0..positions.len() as u32).collect(),
    };
    let vertex_count = positions.len();
    let triangles = indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    let mut mesh = cdrf_core::Mesh::from_data(MeshData {
        positions,
        normals,
        uvs,
        triangles,
    })?
    .mesh;
    if mesh.normals.len() != mesh.positions.len() {
        mesh.compute_normals();
    }
    let filter_mm = material_filter_length_mm(diffusion_length_mm, &mesh, mm_per_unit, 1.0);
    let curvature = curvature_per_mm(
        &mesh,
        &CurvatureOptions::new(mm_per_unit).with_filter_length_mm(filter_mm),
    )?;
    // Skin weights and tangents follow the vertices only where the repair removed none.
    let kept_order = mesh.positions.len() == vertex_count;
    let skin = SkinWeights::of(source).filter(|skin| kept_order && skin.len() == vertex_count);
    let tangents = match source.try_attribute_option(Mesh::ATTRIBUTE_TANGENT) {
        Ok(Some(VertexAttributeValues::Float32x4(values)))
            if kept_order && values.len() == vertex_count =>
        {
            Some(values.iter().map(|&t| glam::Vec4::from_array(t)).collect())
        }
        _ => None,
    };
    Ok(PreparedMesh {
        mesh,
        curvature_per_mm: curvature.mean_per_mm,
        anisotropy_per_mm: curvature.anisotropy_per_mm,
        skin,
        tangents,
    })
}

fn linear(color: Color) -> [f32; 3] {
    let c = color.to_linear();
    [c.red, c.green, c.blue]
}

pub(crate) fn to_glam_vec3(v: Vec3) -> glam::Vec3 {
    glam::Vec3::from_array(v.to_array())
}

pub(crate) fn to_glam_mat4(m: Mat4) -> glam::Mat4 {
    glam::Mat4::from_cols_array(&m.to_cols_array())
}

/// A cdrf mesh (from [`cdrf_core::Mesh::load`], OBJ or glTF) as a Bevy triangle mesh with
/// positions, normals and, where it has them, texture coordinates.
pub fn mesh_from_cdrf(mesh: &cdrf_core::Mesh, usages: bevy::asset::RenderAssetUsages) -> Mesh {
    let mut out = Mesh::new(PrimitiveTopology::TriangleList, usages);
    out.insert_attribute(
        Mesh::ATTRIBUTE_POSITION,
        mesh.positions
            .iter()
            .map(|p| p.to_array())
            .collect::<Vec<_>>(),
    );
    out.insert_attribute(
        Mesh::ATTRIBUTE_NORMAL,
        mesh.normals
            .iter()
            .map(|n| n.to_array())
            .collect::<Vec<_>>(),
    );
    if let Some(uvs) = &mesh.uvs {
        out.insert_attribute(
            Mesh::ATTRIBUTE_UV_0,
            uvs.iter().map(|uv| uv.to_array()).collect::<Vec<_>>(),
        );
    }
    out.insert_indices(Indices::U32(
        mesh.triangles.iter().flatten().copied().collect(),
    ));
    out
}
