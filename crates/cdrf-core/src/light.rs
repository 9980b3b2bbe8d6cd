//! Lights and the non-local shading terms: the types a renderer takes per frame. Scene files
//! ([`crate::scene`]) parse into them; `cdrf-render` re-exports them.

use glam::Vec3;

/// A directional light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionalLight {
    /// Unit vector toward the light, world space.
    pub to_light: Vec3,
    /// Irradiance on a surface facing the light, linear, per RGB channel.
    pub irradiance: [f32; 3],
}

/// Which non-local terms a render adds to the CDRF (see [`crate::translucency`]). The default,
/// all off, is the poster's local model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct NonLocal {
    /// Translucent visibility: cast shadows from shadow maps, with a penumbra as wide as the
    /// material's scattering length.
    pub shadows: bool,
    /// Transmission: light through parts thinner than the CDRF assumes, and (with `shadows`)
    /// through occluders, by the material's T(d, μ).
    pub transmission: bool,
    /// One inter-reflection: light that left the lit surface and enters another part of the
    /// object (or another draw) through the air, as between the strands of a knot. Zero on
    /// convex objects, where no two points of the surface face each other.
    pub interreflection: bool,
    /// Subsurface gather: light that entered the lit surface near the point — beside it, behind
    /// it, through an occluder — weighted by the material's diffusion profile
    /// ([`crate::diffusion`]) beyond what the point's osculating sphere already lets the CDRF
    /// see. For materials with a profile it replaces `transmission`'s T(d, μ) (the gather holds
    /// the light through thin parts and occluders too); without one, T(d, μ) stays.
    pub subsurface: bool,
}

impl NonLocal {
    /// No term: the poster's local model.
    pub const OFF: Self = Self {
        shadows: false,
        transmission: false,
        interreflection: false,
        subsurface: false,
    };

    /// Every term.
    pub const ALL: Self = Self {
        shadows: true,
        transmission: true,
        interreflection: true,
        subsurface: true,
    };

    /// Whether any term is on.
    pub fn any(self) -> bool {
        self.shadows || self.transmission || self.interreflection || self.subsurface
    }
}
