// Table reads: the LUT f(κ, θ), F_sphere(κ, θ), the gain s(κ, θ) and the view
// correction g(κ, θ, φ), bilinear by the sampler or by hand (MANUAL_FILTERING). See
// docs/shading.md.

// Texture coordinate of a value on a uniform axis over [0, extent] with `count` texels whose
// centres sit on the axis nodes (node 0 at 0, the last at `extent`); clamped to the end nodes.
fn node_coordinate(value: f32, extent: f32, count: f32) -> f32 {
    return clamp(value / extent, 0.0, 1.0) * (count - 1.0);
}

// Bilinear read of `texture` at continuous node coordinates (column, row).
fn read_bilinear(texture: texture_2d<f32>, column: f32, row: f32, size: vec2<f32>) -> vec3<f32> {
    if MANUAL_FILTERING {
        let last = vec2<i32>(size) - vec2<i32>(1);
        let base = vec2<i32>(floor(vec2<f32>(column, row)));
        let t = vec2<f32>(column, row) - vec2<f32>(base);
        let p00 = clamp(base, vec2<i32>(0), last);
        let p11 = clamp(base + vec2<i32>(1), vec2<i32>(0), last);
        let a = textureLoad(texture, p00, 0).rgb;
        let b = textureLoad(texture, vec2<i32>(p11.x, p00.y), 0).rgb;
        let c = textureLoad(texture, vec2<i32>(p00.x, p11.y), 0).rgb;
        let d = textureLoad(texture, p11, 0).rgb;
        return mix(mix(a, b, t.x), mix(c, d, t.x), t.y);
    }
    let uv = (vec2<f32>(column, row) + 0.5) / size;
    return textureSampleLevel(texture, lut_sampler, uv, 0.0).rgb;
}

// f(κ, θ) from the LUT: θ across (columns over [0, π]), κ down (rows over the curvature axis,
// clamped to its ends).
fn lut_value(curvature_per_mm: f32, theta: f32) -> vec3<f32> {
    let at = lut_coordinates(curvature_per_mm, theta);
    return read_bilinear(lut, at.x, at.y, material.lut_size);
}

// Node coordinates (column, row) of (κ, θ) on the LUT's axes, as lut_value reads them.
fn lut_coordinates(curvature_per_mm: f32, theta: f32) -> vec2<f32> {
    let kappa = material.lut_curvature_per_mm;
    let size = material.lut_size;
    var row = 0.0;
    if size.y > 1.0 && kappa.y > kappa.x {
        row = clamp((curvature_per_mm - kappa.x) / (kappa.y - kappa.x), 0.0, 1.0) * (size.y - 1.0);
    }
    return vec2<f32>(node_coordinate(theta, PI, size.x), row);
}

// g(κ, θ, φ): φ across (columns over [0, π/2]), θ down (rows over [0, π]) in each curvature
// layer, the layers stacked down the texture; bilinear within the two layers around κ, linear
// between them.
fn view_value(curvature_per_mm: f32, theta: f32, phi: f32) -> vec3<f32> {
    let size = material.view_size;
    let layers = material.view_layers;
    let texture_size = vec2<f32>(size.x, size.y * layers);
    let column = node_coordinate(phi, FRAC_PI_2, size.x);
    let row = node_coordinate(theta, PI, size.y);
    let kappa = material.view_curvature_per_mm;
    var layer = 0.0;
    if layers > 1.0 && kappa.y > kappa.x {
        layer = clamp((curvature_per_mm - kappa.x) / (kappa.y - kappa.x), 0.0, 1.0)
            * (layers - 1.0);
    }
    let below = floor(layer);
    let above = min(below + 1.0, layers - 1.0);
    let a = read_bilinear(view_correction, column, below * size.y + row, texture_size);
    let b = read_bilinear(view_correction, column, above * size.y + row, texture_size);
    return mix(a, b, layer - below);
}

// Block `block` of lut_blocks at (κ, θ): 0 F_sphere, 1 the flow (as lut_value: the row
// coordinate is clamped to its block, so filtering never mixes two).
fn lut_block_value(curvature_per_mm: f32, theta: f32, block: f32) -> vec3<f32> {
    let at = lut_coordinates(curvature_per_mm, theta);
    let rows = material.lut_size.y;
    return read_bilinear(
        lut_blocks,
        at.x,
        at.y + block * rows,
        vec2<f32>(material.lut_size.x, 2.0 * rows),
    );
}

// F_sphere(κ, θ): R_far over the osculating sphere, what the table holds of the gather's light.
fn sphere_far_field_value(curvature_per_mm: f32, theta: f32) -> vec3<f32> {
    return lut_block_value(curvature_per_mm, theta, 0.0);
}

// ℓ·a(κ, θ) = ℓ·κ·(−∂ ln f / ∂θ), no unit: how fast f falls along the surface away from the
// light, per transport mean free path ℓ. ℓ·(−∂ ln f / ∂θ) (cdrf-core's
// CdrfLut::flow_mm_per_rad, ℓ per channel and 0 for an opaque table) is the second block of
// lut_blocks; κ is the point's own, so a plane (κ = 0, below the table's axis) has no flow.
fn surface_flow_value(curvature_per_mm: f32, theta: f32) -> vec3<f32> {
    return max(curvature_per_mm, 0.0) * lut_block_value(curvature_per_mm, theta, 1.0);
}

// s(κ, θ) on the LUT's axes (as lut_value).
fn subsurface_gain_value(curvature_per_mm: f32, theta: f32) -> vec3<f32> {
    let at = lut_coordinates(curvature_per_mm, theta);
    return read_bilinear(subsurface_gain, at.x, at.y, material.lut_size);
}

// The view's azimuth, which the table's photographs never varied (their camera at 90° to the
// light): light under the surface flows away from the light, and a view along the flow sees
// more of it. h(x) per channel, x = ℓ·a·(−v·l)/sin θ: e^x, or 1/(1 − AGAINST_FLOW_SCALE·x) where
// x < 0 (gentler, as the spheres lit from beside the camera show); 1 wherever the camera is at
// 90° to the light.
// ℓ the material's (in lut_blocks' second block), on the shadow side for views along the flow
// ℓ·(1 + SHADOW_FLUX_GAIN·|cos θ|). Mirrors cdrf-core's azimuth::factor, whose constants these
// are (docs/shading.md, "The view's azimuth").
fn view_azimuth(curvature_per_mm: f32, theta: f32, view_dot_light: f32) -> vec3<f32> {
    if MODEL != MODEL_MEASURED && MODEL != MODEL_GAUSSIAN_LUT {
        return vec3<f32>(1.0);
    }
    let sine_floor = select(AZIMUTH_SHADOW_MIN_SINE, AZIMUTH_LIT_MIN_SINE, cos(theta) > 0.0);
    let across = -view_dot_light / max(sin(theta), sine_floor);
    let shadow = max(-cos(theta), 0.0) * step(0.0, across);
    let growth = 1.0 + SHADOW_FLUX_GAIN * shadow;
    let x = min(growth * surface_flow_value(curvature_per_mm, theta) * across, vec3<f32>(AZIMUTH_LIMIT));
    return select(1.0 / (1.0 - AGAINST_FLOW_SCALE * x), exp(x), x >= vec3<f32>(0.0));
}
