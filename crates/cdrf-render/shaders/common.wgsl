// Declarations every pass shares, the shadow pass's included. cdrf-render composes each
// shader from the constants it generates from its Rust definitions (src/constants.rs), then this
// file, then the pass's parts (src/shaders.rs; docs/shading.md). Every struct is `#[repr(C)]` in
// src/gpu_types.rs; a test holds sizes and offsets against naga's reflection.

// One draw's transforms and its surface's factors (cdrf-render's surface module): group 2,
// binding 0 of the shading-side passes, group 1 of the shadow pass (dynamic offset into one
// buffer).
struct Draw {
    world_from_model: mat4x4<f32>,
    // Inverse transpose of world_from_model's upper 3×3 (columns in xyz).
    normal_from_model: mat4x4<f32>,
    // Linear tint of the subsurface light (times the base colour texture).
    base_color_factor: vec3<f32>,
    // Factor from the mesh's curvature attribute (mm⁻¹) to the drawn object's (1 / scale).
    curvature_scale: f32,
    // Multiplies the normal texture's x and y.
    normal_scale: f32,
    // Perceptual roughness (times the roughness texture's G) when SURFACE_ROUGHNESS is set.
    roughness_factor: f32,
    // SURFACE_NORMAL_MAP | SURFACE_ROUGHNESS.
    surface_flags: u32,
    // The inter-reflection's passes: the frame's emitter of the draw's mesh's first patch.
    emitter_first: u32,
}
