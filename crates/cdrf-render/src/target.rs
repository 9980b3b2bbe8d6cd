//! What the host renders into, and the renderer's options.

use wgpu::{CompareFunction, TextureFormat};

/// The render target the host's pass draws into: the pass's colour format, its MSAA sample
/// count and its depth format. Pipelines are built (and cached) per `TargetDesc`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct TargetDesc {
    /// The colour attachment's format: sRGB, UNORM or float (HDR) formats all work (see
    /// [`TargetDesc::encodes_srgb_in_shader`]).
    pub color_format: TextureFormat,
    /// MSAA sample count of the colour (and depth) attachment: 1 or what the adapter supports.
    pub sample_count: u32,
    /// The depth attachment's format, or `None` for a pass without depth (then the pass draws
    /// without a depth test: correct for convex meshes only).
    pub depth_format: Option<TextureFormat>,
}

impl TargetDesc {
    /// A single-sampled target of `color_format` with no depth.
    pub fn new(color_format: TextureFormat) -> Self {
        Self {
            color_format,
            sample_count: 1,
            depth_format: None,
        }
    }

    /// With `sample_count` MSAA samples.
    pub fn with_sample_count(mut self, sample_count: u32) -> Self {
        self.sample_count = sample_count;
        self
    }

    /// With a depth attachment of `depth_format`.
    pub fn with_depth(mut self, depth_format: TextureFormat) -> Self {
        self.depth_format = Some(depth_format);
        self
    }

    /// Whether the shader writes sRGB-encoded values. The renderer shades in linear radiance;
    /// an sRGB format encodes on store, a float format keeps linear radiance (HDR), and an
    /// 8-bit or 10-bit UNORM display format that is not sRGB (`Rgba8Unorm`, `Bgra8Unorm` — e.g.
    /// eframe's swap chain — or `Rgb10a2Unorm`) gets the sRGB curve applied in the shader so it
    /// displays correctly. Other formats (e.g. `Rgba16Unorm`) receive linear radiance.
    pub fn encodes_srgb_in_shader(&self) -> bool {
        use TextureFormat as F;
        matches!(
            self.color_format,
            F::Rgba8Unorm | F::Bgra8Unorm | F::Rgb10a2Unorm
        )
    }
}

/// How the LUT and view-correction textures are filtered between their texels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum LutFiltering {
    /// The sampler's bilinear filter (`Rgba16Float` is filterable everywhere). On many GPUs the
    /// filter weights have only 8 fractional bits.
    #[default]
    Hardware,
    /// Bilinear by hand: four texel loads and f32 weights — the same on every adapter.
    Manual,
}

/// How the Gaussian CDRF is evaluated per pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum GaussianEvaluation {
    /// A LUT tabulated on the CPU by cdrf-core (one texture read per light, like the measured
    /// CDRF, so the two models cost the same).
    #[default]
    Lut,
    /// The closed form in the shader (Fourier series or terminator quadrature per channel).
    Analytic,
}

/// Renderer options; [`Options::default`] for applications, [`Options::PREDICTABLE`] for golden
/// images.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// LUT filtering.
    pub lut_filtering: LutFiltering,
    /// Gaussian CDRF evaluation.
    pub gaussian: GaussianEvaluation,
    /// Rows of the curvature axis of a tabulated Gaussian CDRF, over
    /// `[0, gaussian_lut_max_curvature_per_mm]`.
    pub gaussian_lut_rows: u32,
    /// The most curved row of a tabulated Gaussian CDRF, mm⁻¹; higher curvatures read that row.
    pub gaussian_lut_max_curvature_per_mm: f32,
    /// θ columns of a tabulated Gaussian CDRF over `[0, π]`.
    pub gaussian_lut_columns: u32,
    /// Depth comparison (use `Greater` for a reversed-Z host).
    pub depth_compare: CompareFunction,
    /// Cull back faces (counter-clockwise triangles are front faces). Turn off for meshes whose
    /// winding is not consistent.
    pub cull_back_faces: bool,
    /// Texels per side of each light's shadow map (used only when a frame turns on a non-local
    /// term; the map covers the bounding sphere of the frame's draws).
    pub shadow_map_resolution: u32,
    /// How much nearer the light than the local surface predicts an occluder must be to count,
    /// mm (on top of one texel times the surface's depth slope).
    pub shadow_bias_mm: f32,
    /// About how many patches [`Renderer::create_mesh`] cuts each mesh into for the
    /// inter-reflection (its emitters and receivers; cdrf-core's
    /// [`SurfacePatches`](cdrf_core::patches::SurfacePatches)): each vertex gathers every patch
    /// of the frame's draws, so the cost grows with vertices × patches. 0: none (the mesh sends
    /// out no inter-reflected light). A mesh takes the count it is created with.
    ///
    /// [`Renderer::create_mesh`]: crate::Renderer::create_mesh
    pub interreflection_patches: u32,
    /// Bounces of the inter-reflection (at least 1): light from the patches' own exitance,
    /// then what they pass on to each other, each further bounce one pass over patches ×
    /// patches.
    pub interreflection_bounces: u32,
    /// The subsurface gather's cut ℓ_c, mm: the diffusion profile's terms longer than this
    /// reach beyond the point's osculating sphere and are gathered (their far part); shorter
    /// ones stay in the measured table alone (see [`FarField`]). The gather's map is made fine
    /// enough for ℓ_c to span 1.5 texels, up to [`Options::subsurface_max_resolution`]; a
    /// material takes the cut it is created with.
    ///
    /// [`FarField`]: cdrf_core::diffusion::FarField
    pub subsurface_cut_mm: f32,
    /// Most texels per side of the subsurface gather's finest map (a power of two is used).
    /// Objects wider than about `subsurface_max_resolution · ℓ_c / 1.5` are sampled more
    /// coarsely than the cut (smooth, but less exact). Memory: 20 bytes × 4/3 per texel and
    /// face of each shadowed light (a point light has six faces): the light's sum and its
    /// spread.
    pub subsurface_max_resolution: u32,
}

impl Options {
    /// Options whose renders are the same on every adapter up to rounding: filtering by hand
    /// in f32. Golden-image tests use these.
    pub const PREDICTABLE: Self = Self {
        lut_filtering: LutFiltering::Manual,
        gaussian: GaussianEvaluation::Lut,
        gaussian_lut_rows: 256,
        gaussian_lut_max_curvature_per_mm: 1.0,
        gaussian_lut_columns: 361,
        depth_compare: CompareFunction::Less,
        cull_back_faces: true,
        shadow_map_resolution: 512,
        shadow_bias_mm: 0.5,
        interreflection_patches: 256,
        interreflection_bounces: 3,
        subsurface_cut_mm: 1.0,
        subsurface_max_resolution: 512,
    };
}

impl Default for Options {
    fn default() -> Self {
        Self {
            lut_filtering: LutFiltering::Hardware,
            ..Self::PREDICTABLE
        }
    }
}
