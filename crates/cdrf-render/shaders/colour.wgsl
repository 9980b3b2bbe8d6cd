// Colour: sRGB encoding and decoding, and the curvature view's colour map. See
// docs/shading.md.

// A diverging colour map (Moreland's cool–warm ends) over [0, 1], in linear RGB.
fn cool_warm(t: f32) -> vec3<f32> {
    let cool = vec3<f32>(0.230, 0.299, 0.754);
    let middle = vec3<f32>(0.865, 0.865, 0.865);
    let warm = vec3<f32>(0.706, 0.016, 0.150);
    let x = clamp(t, 0.0, 1.0);
    var srgb: vec3<f32>;
    if x < 0.5 {
        srgb = mix(cool, middle, x * 2.0);
    } else {
        srgb = mix(middle, warm, x * 2.0 - 1.0);
    }
    return srgb_to_linear(srgb);
}

fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    let low = c / 12.92;
    let high = pow((c + 0.055) / 1.055, vec3<f32>(2.4));
    return select(high, low, c <= vec3<f32>(0.04045));
}

fn linear_to_srgb(c: vec3<f32>) -> vec3<f32> {
    let x = clamp(c, vec3<f32>(0.0), vec3<f32>(1.0));
    let low = x * 12.92;
    let high = 1.055 * pow(x, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(high, low, x <= vec3<f32>(0.0031308));
}
