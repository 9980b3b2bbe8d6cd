// cdrf-viewer: shows the two offscreen renders of the 3D view inside egui's render pass.
//
// Slots A and B hold linear radiance with alpha = coverage (cleared to transparent black, so a
// resolved MSAA edge is premultiplied). Layouts: 0 A alone, 1 A | B side by side (each slot is
// half the view wide), 2 A left of the split line and B right of it, 3 the signed difference
// A − B in luminance (orange: A brighter, blue: B brighter, black: equal), full colour at
// ±range. The viewport is the callback's rectangle; one triangle covers it.

// Non-sRGB 8/10/16-bit UNORM targets (eframe's Bgra8Unorm) need the sRGB curve applied here.
override ENCODE_SRGB: bool = false;

struct Params {
    // x: layout (see above), y: split position as a fraction of the view width, z: difference range
    // (radiance at full colour), w: unused.
    mode: vec4<f32>,
    // xy: view size in pixels, zw: slot size in pixels.
    sizes: vec4<f32>,
    // rgb: background, linear.
    background: vec4<f32>,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var slot_a: texture_2d<f32>;
@group(0) @binding(2) var slot_b: texture_2d<f32>;

struct VertexOut {
    @builtin(position) position: vec4<f32>,
    @location(0) uv: vec2<f32>,
};

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> VertexOut {
    // (0,0), (2,0), (0,2): one triangle over the whole viewport, uv = 0..1 inside it.
    let uv = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    var out: VertexOut;
    out.position = vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.0, 1.0);
    out.uv = uv;
    return out;
}

fn load(slot: texture_2d<f32>, pixel: vec2<f32>) -> vec4<f32> {
    let size = vec2<i32>(textureDimensions(slot));
    let texel = clamp(vec2<i32>(floor(pixel)), vec2<i32>(0), size - vec2<i32>(1));
    return textureLoad(slot, texel, 0);
}

fn over_background(sample: vec4<f32>) -> vec3<f32> {
    return sample.rgb + params.background.rgb * (1.0 - sample.a);
}

fn luminance(c: vec3<f32>) -> f32 {
    return dot(c, vec3<f32>(0.2126, 0.7152, 0.0722));
}

fn linear_to_srgb(c: vec3<f32>) -> vec3<f32> {
    let low = c * 12.92;
    let high = 1.055 * pow(c, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(high, low, c <= vec3<f32>(0.0031308));
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    let mode = u32(params.mode.x);
    let pixel = in.uv * params.sizes.xy;
    var colour: vec3<f32>;
    switch mode {
        case 1u: {
            if pixel.x < params.sizes.z {
                colour = over_background(load(slot_a, pixel));
            } else {
                colour = over_background(load(slot_b, pixel - vec2<f32>(params.sizes.z, 0.0)));
            }
        }
        case 2u: {
            if in.uv.x < params.mode.y {
                colour = over_background(load(slot_a, pixel));
            } else {
                colour = over_background(load(slot_b, pixel));
            }
        }
        case 3u: {
            let a = load(slot_a, pixel);
            let b = load(slot_b, pixel);
            if max(a.a, b.a) <= 0.0 {
                colour = params.background.rgb;
            } else {
                let t = clamp((luminance(a.rgb) - luminance(b.rgb)) / max(params.mode.z, 1e-12), -1.0, 1.0);
                let orange = vec3<f32>(1.0, 0.35, 0.02);
                let blue = vec3<f32>(0.05, 0.35, 1.0);
                colour = select(blue, orange, t > 0.0) * abs(t);
            }
        }
        default: {
            colour = over_background(load(slot_a, pixel));
        }
    }
    colour = max(colour, vec3<f32>(0.0));
    if ENCODE_SRGB {
        colour = linear_to_srgb(min(colour, vec3<f32>(1.0)));
    }
    return vec4<f32>(colour, 1.0);
}
