// Bind groups 0, 1 and 3, the same in every shading-side pass (the renderer's layouts); each
// pass file declares its own group 2. See docs/shading.md.

@group(0) @binding(0) var<uniform> frame: Frame;

@group(1) @binding(0) var<uniform> material: Material;
@group(1) @binding(1) var lut: texture_2d<f32>;
@group(1) @binding(2) var view_correction: texture_2d<f32>;
@group(1) @binding(3) var lut_sampler: sampler;
// The rows of F_sphere(κ, θ), R_far over the osculating sphere (0 where the material has no
// diffusion profile), which the vertex terms take out of the gather (sphere_far_field); then
// the rows of ℓ·(−∂ ln f/∂θ) the view's azimuth reads (surface_flow_value).
@group(1) @binding(4) var lut_blocks: texture_2d<f32>;
// s(κ, θ): the measured table over F_sphere on the sphere's shadow side (docs/shading.md).
@group(1) @binding(5) var subsurface_gain: texture_2d<f32>;

@group(3) @binding(0) var<uniform> shadows: Shadows;
@group(3) @binding(1) var shadow_maps: texture_depth_2d_array;
// The subsurface pyramid: per texel Φ·(position in the light's frame, mm) and Φ (per unit of
// the light's irradiance or intensity), summed over the level-0 texels it covers; one layer
// per face of each shadowed light.
@group(3) @binding(2) var subsurface_pyramid: texture_2d_array<f32>;
// Beside it, per texel Φ·|position − mean|² summed over the level-0 texels it covers (mm² × Φ's
// unit; subsurface_reduce_pass.wgsl): how far a texel's light spreads about its mean position.
@group(3) @binding(3) var subsurface_spread: texture_2d_array<f32>;
