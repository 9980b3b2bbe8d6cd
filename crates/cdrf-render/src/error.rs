//! Why an upload or a frame failed.

use cdrf_core::lut::LutError;
use thiserror::Error;

use crate::constants::MAX_LIGHTS;
use crate::frame::MAX_EXPOSURE;
use crate::ids::{MaterialId, MeshId, SurfaceId};
use crate::target::TargetDesc;

/// Why a mesh could not be uploaded.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum MeshUploadError {
    /// The mesh has no triangles.
    #[error("the mesh has no triangles")]
    Empty,
    /// The index list is not whole triangles.
    #[error("{count} indices: not a multiple of 3 (whole triangles)")]
    IndexCount {
        /// Indices given.
        count: usize,
    },
    /// An index names a vertex that does not exist.
    #[error("index {position} is {index}, but the mesh has {vertices} vertices")]
    IndexOutOfRange {
        /// Where in the index list.
        position: usize,
        /// The index.
        index: u32,
        /// Vertices in the mesh.
        vertices: usize,
    },
    /// A per-vertex slice does not have one value per position.
    #[error("{found} {what} for {vertices} vertices")]
    AttributeCount {
        /// `"normals"`, `"curvature values"`, `"curvature anisotropies"`, `"UVs"`,
        /// `"tangents"`, or for an update `"positions"`.
        what: &'static str,
        /// Values given.
        found: usize,
        /// Positions given.
        vertices: usize,
    },
    /// A value is NaN or infinite.
    #[error("a {what} is not finite")]
    NonFinite {
        /// `"UV"`, `"tangent"`, `"curvature anisotropy"`, and for an update also
        /// `"position"`, `"normal"` or `"curvature value"`.
        what: &'static str,
    },
    /// New vertices for a mesh not created with [`MeshDesc::deforming`](crate::MeshDesc::deforming).
    #[error("the mesh was not created as deforming: its vertices cannot be updated")]
    NotDeforming,
    /// The mesh was removed (or made by another renderer).
    #[error("no such mesh: it was removed or belongs to another renderer")]
    Unknown,
    /// A curvature value is NaN or infinite.
    #[error("curvature of vertex {vertex} is {value}: must be finite")]
    NonFiniteCurvature {
        /// The vertex.
        vertex: usize,
        /// Its value.
        value: f32,
    },
}

/// Why a material could not be created or changed.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum MaterialError {
    /// Tabulating the Gaussian CDRF failed.
    #[error("tabulating the Gaussian CDRF: {0}")]
    Tabulate(LutError),
    /// A parameter is out of range.
    #[error("{what} = {value:?}: {requirement}")]
    Parameter {
        /// The parameter.
        what: &'static str,
        /// Its value.
        value: Vec<f32>,
        /// What it must be.
        requirement: &'static str,
    },
    /// The material was removed (or made by another renderer).
    #[error("no such material: it was removed or belongs to another renderer")]
    Unknown,
    /// A table is larger than the device's largest 2D texture.
    #[error("{what} is {width} × {height} texels; the device allows {max} per side")]
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

// The message holds the cause's, which `source()` therefore does not repeat.
impl From<LutError> for MaterialError {
    fn from(error: LutError) -> Self {
        Self::Tabulate(error)
    }
}

/// Why a surface could not be uploaded.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum SurfaceError {
    /// A factor is out of range.
    #[error("{what} = {value:?}: {requirement}")]
    Parameter {
        /// The parameter.
        what: &'static str,
        /// Its value.
        value: Vec<f32>,
        /// What it must be.
        requirement: &'static str,
    },
    /// A texture is empty or larger than the device's largest 2D texture.
    #[error("{what} is {width} × {height} px: each side must be 1..={max} on this device")]
    TextureSize {
        /// Which texture.
        what: &'static str,
        /// Width, pixels.
        width: u32,
        /// Height, pixels.
        height: u32,
        /// The device's `max_texture_dimension_2d`.
        max: u32,
    },
    /// A texture's pixels do not fill its width × height.
    #[error("{what} has {found} pixels, its width × height is {expected}")]
    TextureData {
        /// Which texture.
        what: &'static str,
        /// Pixels given.
        found: usize,
        /// Width × height.
        expected: usize,
    },
}

/// Why a frame could not be prepared. Nothing is drawn until a `prepare` succeeds.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum PrepareError {
    /// More lights than the shader holds.
    #[error("{count} lights: at most {MAX_LIGHTS} per frame")]
    TooManyLights {
        /// Lights given.
        count: usize,
    },
    /// An environment coefficient is NaN or infinite.
    #[error("the environment's SH coefficients must be finite")]
    BadEnvironment,
    /// A light's direction or irradiance is not usable.
    #[error("light {index}: {problem}")]
    BadLight {
        /// The light.
        index: usize,
        /// What is wrong.
        problem: &'static str,
    },
    /// A draw names a mesh that does not exist (never created, or removed).
    #[error("draw {index}: unknown mesh {mesh:?}")]
    UnknownMesh {
        /// The draw.
        index: usize,
        /// Its mesh.
        mesh: MeshId,
    },
    /// A draw names a material that does not exist.
    #[error("draw {index}: unknown material {material:?}")]
    UnknownMaterial {
        /// The draw.
        index: usize,
        /// Its material.
        material: MaterialId,
    },
    /// A draw names a surface that does not exist.
    #[error("draw {index}: unknown surface {surface:?}")]
    UnknownSurface {
        /// The draw.
        index: usize,
        /// Its surface.
        surface: SurfaceId,
    },
    /// A draw's triangle range is empty, reversed or beyond its mesh's triangles.
    #[error("draw {index}: triangles {start}..{end}, but the mesh has {triangles}")]
    BadTriangles {
        /// The draw.
        index: usize,
        /// The range's start.
        start: u32,
        /// The range's end.
        end: u32,
        /// Triangles in the mesh.
        triangles: u32,
    },
    /// A draw asks for per-vertex non-local terms, which the vertex terms pass (a compute
    /// shader writing a storage buffer) computes, on a device without compute shaders or
    /// storage buffers (e.g. WebGL 2's limits).
    #[error(
        "draw {index}: the non-local terms need compute shaders and storage buffers, which this device lacks"
    )]
    NoComputeShaders {
        /// The draw.
        index: usize,
    },
    /// A draw with per-vertex non-local terms has more vertices than one storage binding of
    /// the device holds terms for.
    #[error(
        "draw {index}: {vertices} vertices, but this device holds non-local terms for at most {max_vertices} per mesh"
    )]
    TooManyVertices {
        /// The draw.
        index: usize,
        /// Its mesh's vertices.
        vertices: u32,
        /// The most the device's `max_storage_buffer_binding_size` allows.
        max_vertices: u64,
    },
    /// A draw's transform is singular, mirroring (negative determinant) or not finite.
    #[error("draw {index}: the model transform is singular, mirroring or not finite")]
    BadTransform {
        /// The draw.
        index: usize,
    },
    /// The view matrix, camera position or direction is unusable.
    #[error("the view matrix or camera position is not finite, or the camera direction is zero")]
    BadView,
    /// A view was added before a frame was prepared (or after a `prepare` failed).
    #[error("no prepared frame to add a view to: call prepare first")]
    NotPrepared,
    /// The exposure is negative, not finite or above [`MAX_EXPOSURE`].
    #[error("exposure {exposure}: must be in 0..={MAX_EXPOSURE}")]
    BadExposure {
        /// The value given.
        exposure: f32,
    },
    /// [`FrameDesc::mm_per_world_unit`](crate::FrameDesc::mm_per_world_unit) is not finite
    /// and > 0 where it is needed (a non-local term on, or a point or spot light).
    #[error("mm per world unit = {mm_per_world_unit}: must be finite and > 0")]
    BadUnits {
        /// The value given.
        mm_per_world_unit: f32,
    },
    /// The device refused the pipeline for the current target (an unsupported colour format,
    /// sample count or depth format).
    #[error("the device cannot render to {target:?}: {message}")]
    Pipeline {
        /// The target.
        target: TargetDesc,
        /// What wgpu said.
        message: String,
    },
}

/// Why an [`OffscreenTarget`](crate::offscreen::OffscreenTarget) could not be created.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum TargetError {
    /// A side is zero or beyond the device's largest 2D texture.
    #[error("target size {width} × {height} px: each side must be 1..={max} on this device")]
    Size {
        /// Width, pixels.
        width: u32,
        /// Height, pixels.
        height: u32,
        /// The device's `max_texture_dimension_2d`.
        max: u32,
    },
    /// The device refused the textures or ran out of memory.
    #[error("creating the {width} × {height} px target ({samples} samples a pixel): {message}")]
    Create {
        /// Width, pixels.
        width: u32,
        /// Height, pixels.
        height: u32,
        /// MSAA samples.
        samples: u32,
        /// What wgpu said.
        message: String,
    },
}
