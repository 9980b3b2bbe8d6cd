// cdrf shadow pass: the first surface each light meets, as depth in a light-space orthographic
// map (one array layer per shadowed light). Depth only; no fragment stage.
//
// Bind groups (owned by cdrf-render's Renderer):
//   0: the light's clip-from-world transform (dynamic offset: one per shadowed light)
//   1: draw model transform (dynamic offset; the same buffer and layout as cdrf.wgsl's group 2)

struct ShadowPass {
    clip_from_world: mat4x4<f32>,
}

@group(0) @binding(0) var<uniform> shadow_pass: ShadowPass;
@group(1) @binding(0) var<uniform> draw: Draw;

@vertex
fn vs_shadow(@location(0) position: vec3<f32>) -> @builtin(position) vec4<f32> {
    return shadow_pass.clip_from_world * draw.world_from_model * vec4<f32>(position, 1.0);
}
