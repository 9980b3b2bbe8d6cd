//! The counts and codes the Rust side and the WGSL share, defined once here; `shaders` writes
//! them into every shader it composes, and `gpu_types` sizes its arrays with them.

use cdrf_core::ShadingModel;

use crate::target::GaussianEvaluation;

/// Most lights in one frame.
pub const MAX_LIGHTS: usize = 16;
/// Lights with a shadow map: the first four of a frame, directional lights first (an
/// orthographic map each; point and spot lights a perspective map, or a cube of six when the
/// light is among the draws). Later ones shade with the local model only. Each has a slot of
/// the shading pass's per-vertex terms, written out by hand in `shading_pass.wgsl` (stage
/// inputs and outputs hold no arrays); `src/gpu_types.rs` and `tests/shaders.rs` hold the
/// slots to this constant.
pub const MAX_SHADOW_LIGHTS: usize = 4;
/// Faces of a shadowed light's map at most (a cube).
pub(crate) const MAX_SHADOW_FACES: usize = 6;
/// Penumbra taps per shadowed light: the centre and a Vogel spiral out to
/// [`PENUMBRA_DISC_PER_WIDTH`] × the penumbra's width (σ; ℓ_c with the gather), the same spiral
/// at every vertex and every tap read, so neighbouring vertices agree about a shadow's edge.
/// Each tap's lit-or-not is a step, so an edge crossing the spiral moves the sum in steps of
/// a tap's weight: this many keeps those steps from showing as streaks along cast shadows.
/// The vertex terms pass reads them once per vertex.
pub(crate) const PENUMBRA_TAPS: usize = 256;
/// The penumbra spiral's radius in widths (the shader's taps; the near field's tap weights
/// are computed over the same disc).
pub(crate) const PENUMBRA_DISC_PER_WIDTH: f32 = 2.0;
/// Invocations per workgroup of the compute passes (the WGSL's `@workgroup_size`).
pub(crate) const COMPUTE_WORKGROUP_SIZE: u32 = 64;
/// Samples of the subsurface gather's far-field kernel R_far(d), on a square-root grid in d
/// (fine where R_far changes fastest).
pub(crate) const SUBSURFACE_KERNEL_SAMPLES: usize = 128;

/// The spherical-harmonics order of the environment light: bands 0…4, 25 coefficients. Order 2
/// (the classic irradiance map's 9) misses up to 20 % of the brightest radiance under a sun for
/// the measured table, whose rows are flatter than cos θ near the normal; order 4 keeps it
/// under 4 % (`crates/cdrf-core/tests/environment.rs`).
pub const ENVIRONMENT_SH_ORDER: usize = 4;
pub(crate) const ENVIRONMENT_SH_BANDS: usize = ENVIRONMENT_SH_ORDER + 1;
pub(crate) const ENVIRONMENT_SH_COEFFICIENTS: usize = ENVIRONMENT_SH_BANDS * ENVIRONMENT_SH_BANDS;
/// Rows of a material's zonal table a_l(κ), uniform in κ over its table's curvature axis.
pub(crate) const ENVIRONMENT_ZONAL_ROWS: usize = 64;

/// `Light.kind` in the WGSL.
pub(crate) const GPU_LIGHT_DIRECTIONAL: u32 = 0;
pub(crate) const GPU_LIGHT_POINT: u32 = 1;
pub(crate) const GPU_LIGHT_SPOT: u32 = 2;

/// `ShadowLight.projection` in the WGSL.
pub(crate) const GPU_SHADOW_ORTHOGRAPHIC: u32 = 0;
pub(crate) const GPU_SHADOW_PERSPECTIVE: u32 = 1;

/// The shader's code path for a material (its `MODEL` override and `MODEL_*` constants): the
/// [`ShadingModel`], with the Gaussian's split by [`GaussianEvaluation`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Model {
    Measured = 0,
    GaussianLut = 1,
    GaussianAnalytic = 2,
    Lambert = 3,
    Curvature = 4,
}

impl Model {
    /// The code path that shades `model`, the Gaussian CDRF as `gaussian` says.
    pub(crate) fn new(model: ShadingModel, gaussian: GaussianEvaluation) -> Self {
        match (model, gaussian) {
            (ShadingModel::Measured, _) => Self::Measured,
            (ShadingModel::Gaussian, GaussianEvaluation::Lut) => Self::GaussianLut,
            (ShadingModel::Gaussian, GaussianEvaluation::Analytic) => Self::GaussianAnalytic,
            (ShadingModel::Lambert, _) => Self::Lambert,
            (ShadingModel::Curvature, _) => Self::Curvature,
        }
    }

    /// Every model with its WGSL constant's name.
    pub(crate) const ALL: [(Self, &'static str); 5] = [
        (Self::Measured, "MODEL_MEASURED"),
        (Self::GaussianLut, "MODEL_GAUSSIAN_LUT"),
        (Self::GaussianAnalytic, "MODEL_GAUSSIAN_ANALYTIC"),
        (Self::Lambert, "MODEL_LAMBERT"),
        (Self::Curvature, "MODEL_CURVATURE"),
    ];
}
