//! The passes `prepare` records before the host's shading pass, each in its own module: the
//! light maps (shadow maps and the subsurface pyramid's level 0, per face of each shadowed
//! light), the subsurface pyramid's reduction, and the compute passes — the vertex terms and,
//! with the inter-reflection, its stages. `Renderer::prepare` decides which run and in what
//! order.

pub(crate) mod interreflection;
pub(crate) mod light_maps;
pub(crate) mod subsurface_pyramid;
pub(crate) mod vertex_terms;
