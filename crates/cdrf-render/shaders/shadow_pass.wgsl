// The shadow pass: the first surface each light meets, as depth in a light-space map (one array
// layer per face: one per directional light, orthographic; one or six per point or spot light,
// perspective). Orthographic maps store the clip depth (z over the depth range) with no
// fragment stage; perspective maps store the distance from the light over the depth range
// (fs_shadow_distance), so every map's depth is linear along the light's rays. See
// docs/shading.md.
//
// Bind groups (owned by cdrf-render's Renderer):
//   0: the face's clip-from-world transform (dynamic offset: one per face)
//   1: draw model transform (dynamic offset; the same buffer as the shading pass's `draw`)

struct ShadowPass {
    clip_from_world: mat4x4<f32>,
    // Perspective faces: the light's position, world units, and 1 / the depth range (world
    // units); orthographic: unused.
    light_position: vec3<f32>,
    inverse_depth_range: f32,
}

@group(0) @binding(0) var<uniform> shadow_pass: ShadowPass;
@group(1) @binding(0) var<uniform> draw: Draw;

struct ShadowOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world_position: vec3<f32>,
}

@vertex
fn vs_shadow(@location(0) position: vec3<f32>) -> ShadowOut {
    let world = draw.world_from_model * vec4<f32>(position, 1.0);
    var out: ShadowOut;
    out.clip = shadow_pass.clip_from_world * world;
    out.world_position = world.xyz / world.w;
    return out;
}

@fragment
fn fs_shadow_distance(in: ShadowOut) -> @builtin(frag_depth) f32 {
    return distance(in.world_position, shadow_pass.light_position)
        * shadow_pass.inverse_depth_range;
}
