//! What the host describes per frame: camera, lights, draws.

use std::ops::Range;

use cdrf_core::environment::ShCoefficients;
use cdrf_core::glam::{Mat4, Vec3};
use cdrf_core::light::{Light, NonLocal};

use crate::ids::{MaterialId, MeshId, SurfaceId};

/// The largest [`FrameDesc::exposure`] a frame accepts (the scene file's bound): beyond it every
/// lit pixel saturates, which is a mistake, not a setting.
pub const MAX_EXPOSURE: f32 = cdrf_core::scene::MAX_EXPOSURE;

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

/// One object to draw: a mesh (or a run of its triangles), a material, optionally a surface,
/// and where it is. [`Draw::new`] draws a whole mesh without a surface.
///
/// A textured asset is one draw per primitive, each with its triangles and its material's
/// surface ([`MeshSurfaces`](cdrf_core::mesh::MeshSurfaces); the example of
/// [`Renderer::create_surface`](crate::Renderer::create_surface)).
#[derive(Clone, Debug, PartialEq)]
pub struct Draw {
    /// The mesh.
    pub mesh: MeshId,
    /// How it is shaded.
    pub material: MaterialId,
    /// Model → world. Its scale (the cube root of the determinant, for a non-uniform scale)
    /// divides the mesh's curvature.
    pub world_from_model: Mat4,
    /// What the asset paints on the material (`None`: white, no textures; see
    /// [`crate::surface`]).
    pub surface: Option<SurfaceId>,
    /// The triangles drawn, indices into the mesh's triangles (`None`: all). The non-local
    /// terms' maps hold only these too.
    pub triangles: Option<Range<u32>>,
}

impl Draw {
    /// The whole mesh with the material, no surface.
    pub fn new(mesh: MeshId, material: MaterialId, world_from_model: Mat4) -> Self {
        Self {
            mesh,
            material,
            world_from_model,
            surface: None,
            triangles: None,
        }
    }

    /// With a surface.
    pub fn with_surface(self, surface: SurfaceId) -> Self {
        Self {
            surface: Some(surface),
            ..self
        }
    }

    /// Only these triangles of the mesh (e.g. one glTF primitive's).
    pub fn with_triangles(self, triangles: Range<u32>) -> Self {
        Self {
            triangles: Some(triangles),
            ..self
        }
    }
}

/// Everything that changes per frame.
#[derive(Clone, Copy, Debug)]
pub struct FrameDesc<'a> {
    /// The camera.
    pub view: View,
    /// The lights (at most [`MAX_LIGHTS`](crate::MAX_LIGHTS)), irradiance in linear units.
    /// The non-local terms are for the first [`MAX_SHADOW_LIGHTS`](crate::MAX_SHADOW_LIGHTS)
    /// in shading order (directional ones first), every kind.
    pub lights: &'a [Light],
    /// Multiplies the radiance (1 for physical output): 0..=[`MAX_EXPOSURE`].
    pub exposure: f32,
    /// The objects, drawn in this order.
    pub draws: &'a [Draw],
    /// The non-local terms ([`NonLocal::OFF`]: the poster's local model). When any is on,
    /// `prepare` renders a shadow map for each of the first
    /// [`MAX_SHADOW_LIGHTS`](crate::MAX_SHADOW_LIGHTS) lights and returns its commands.
    pub non_local: NonLocal,
    /// Millimetres per world unit: turns shadow-map depths into the thicknesses T(d) and the
    /// penumbra widths need, and distances to point and spot lights into mm for their 1/d²
    /// (the scene file's `mm_per_unit`).
    pub mm_per_world_unit: f32,
    /// An environment light: its spherical harmonics (`None`: none), projected once by the
    /// host with [`Environment::project_sh`](cdrf_core::environment::Environment::project_sh)
    /// at [`ENVIRONMENT_SH_ORDER`](crate::ENVIRONMENT_SH_ORDER) (bands beyond it are ignored,
    /// fewer are used as given). It lights every model through the material's zonal
    /// coefficients; it is local (no shadows) and has no specular reflection.
    pub environment: Option<&'a ShCoefficients>,
}

impl FrameDesc<'_> {
    /// The lights in the order the shader holds them: the directional ones first (the first
    /// [`MAX_SHADOW_LIGHTS`](crate::MAX_SHADOW_LIGHTS) lights have the non-local terms, light
    /// i its map i), then the rest, each group in the frame's order.
    pub(crate) fn lights_in_shading_order(&self) -> impl Iterator<Item = &Light> {
        let directional = |light: &&Light| light.as_directional().is_some();
        self.lights
            .iter()
            .filter(directional)
            .chain(self.lights.iter().filter(move |l| !directional(l)))
    }

    /// The directional lights, in the frame's order.
    pub(crate) fn directional_lights(
        &self,
    ) -> impl Iterator<Item = &cdrf_core::light::DirectionalLight> {
        self.lights.iter().filter_map(Light::as_directional)
    }
}
