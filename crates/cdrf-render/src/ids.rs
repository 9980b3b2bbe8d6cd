//! The handles of what a [`Renderer`](crate::Renderer) holds: meshes, materials and surfaces.
//! Each is unique within its renderer and is never reused after a removal.

/// A mesh uploaded with [`Renderer::create_mesh`](crate::Renderer::create_mesh).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MeshId(pub(crate) u64);

/// A material uploaded with [`Renderer::create_material`](crate::Renderer::create_material).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MaterialId(pub(crate) u64);

/// A surface uploaded with [`Renderer::create_surface`](crate::Renderer::create_surface).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SurfaceId(pub(crate) u64);
