// The subsurface pyramid's reduction (docs/shading.md, "Subsurface gather"): each texel of a
// level sums the 2 × 2 texels below it (Φ·position and Φ), so a coarse texel holds the light
// entering the surface it covers and (divided by Φ) where it enters on average; and its
// spread, Φ·|position − mean|² summed, by the parallel-axis rule: the finer texels' own spreads
// plus each one's Φ times its mean's squared distance from the new mean (a centred sum, so no
// square of a position far from the frame's origin is differenced).
// Bind group 0: the finer level's textures.

@group(0) @binding(0) var finer: texture_2d<f32>;
@group(0) @binding(1) var finer_spread: texture_2d<f32>;

// One triangle over the whole target.
@vertex
fn vs_fullscreen(@builtin(vertex_index) index: u32) -> @builtin(position) vec4<f32> {
    let corner = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    return vec4<f32>(corner * 2.0 - 1.0, 0.0, 1.0);
}

struct Reduced {
    @location(0) sum: vec4<f32>,
    @location(1) spread: f32,
}

@fragment
fn fs_reduce(@builtin(position) position: vec4<f32>) -> Reduced {
    let base = vec2<i32>(floor(position.xy)) * 2;
    var finer_sums: array<vec4<f32>, 4>;
    var out: Reduced;
    for (var i = 0; i < 4; i++) {
        let texel = base + vec2<i32>(i & 1, i >> 1u);
        finer_sums[i] = textureLoad(finer, texel, 0);
        out.sum += finer_sums[i];
        out.spread += textureLoad(finer_spread, texel, 0).x;
    }
    if out.sum.w > 0.0 {
        let mean = out.sum.xyz / out.sum.w;
        for (var i = 0; i < 4; i++) {
            let flux = finer_sums[i].w;
            if flux > 0.0 {
                let offset = finer_sums[i].xyz / flux - mean;
                out.spread += flux * dot(offset, offset);
            }
        }
    }
    return out;
}
