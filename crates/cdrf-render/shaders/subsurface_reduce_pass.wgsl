// The subsurface pyramid's reduction (docs/shading.md, "Subsurface gather"): each texel of a
// level is the sum of the 2 × 2 texels below it, in both textures (Φ·position and Φ;
// Φ·|position|²), so a coarse texel holds the light entering the surface it covers, (divided
// by Φ) where it enters on average, and how far about that mean it spreads.
// Bind group 0: the finer level's textures.

@group(0) @binding(0) var finer: texture_2d<f32>;
@group(0) @binding(1) var finer_squares: texture_2d<f32>;

// One triangle over the whole target.
@vertex
fn vs_fullscreen(@builtin(vertex_index) index: u32) -> @builtin(position) vec4<f32> {
    let corner = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    return vec4<f32>(corner * 2.0 - 1.0, 0.0, 1.0);
}

struct Reduced {
    @location(0) sum: vec4<f32>,
    @location(1) square: f32,
}

@fragment
fn fs_reduce(@builtin(position) position: vec4<f32>) -> Reduced {
    let base = vec2<i32>(floor(position.xy)) * 2;
    var out: Reduced;
    for (var i = 0; i < 4; i++) {
        let texel = base + vec2<i32>(i & 1, i >> 1u);
        out.sum += textureLoad(finer, texel, 0);
        out.square += textureLoad(finer_squares, texel, 0).x;
    }
    return out;
}
