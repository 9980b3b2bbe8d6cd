// Declarations shared by cdrf.wgsl and shadow.wgsl. cdrf-render composes each shader as: the
// constants it generates from its Rust definitions (MAX_LIGHTS, MAX_SHADOW_LIGHTS,
// PENUMBRA_TAPS, MODEL_*, LIGHT_*; see src/shaders.rs), then this file, then the shader's own file.
// Every struct here and there is `#[repr(C)]` on the Rust side (src/gpu_types.rs); a test holds
// their sizes and offsets against naga's reflection of these declarations.

// One draw's transforms: bind group 2 of the shading pass, 1 of the shadow pass (dynamic
// offset into one buffer).
struct Draw {
    world_from_model: mat4x4<f32>,
    // Inverse transpose of world_from_model's upper 3×3 (columns in xyz).
    normal_from_model: mat4x4<f32>,
    // Factor from the mesh's curvature attribute (mm⁻¹) to the drawn object's (1 / scale).
    curvature_scale: f32,
}
