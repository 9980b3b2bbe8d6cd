// The subsurface pyramid's reduction (docs/shading.md, "Subsurface gather"): each texel of a
// level is the sum of the 2 × 2 texels below it, Φ·position and Φ alike, so a coarse texel
// holds the light entering the surface it covers and (divided by Φ) where it enters on average.
// Bind group 0: the finer level.

@group(0) @binding(0) var finer: texture_2d<f32>;

// One triangle over the whole target.
@vertex
fn vs_fullscreen(@builtin(vertex_index) index: u32) -> @builtin(position) vec4<f32> {
    let corner = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    return vec4<f32>(corner * 2.0 - 1.0, 0.0, 1.0);
}

@fragment
fn fs_reduce(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let base = vec2<i32>(floor(position.xy)) * 2;
    return textureLoad(finer, base, 0) + textureLoad(finer, base + vec2<i32>(1, 0), 0)
        + textureLoad(finer, base + vec2<i32>(0, 1), 0) + textureLoad(finer, base + vec2<i32>(1, 1), 0);
}
