// cdrf: shading of curvature-tagged meshes with a curvature-dependent reflectance function.
//
// Output is linear radiance: L = Σ_lights E/π · f(κ, θ) · g(θ, φ), where f is the table value in
// the LUT convention π·L/E (a white Lambertian surface gives max(cos θ, 0)), κ the mean curvature
// in mm⁻¹, θ the angle between the normal and the direction to the light, φ the angle between the
// normal and the direction to the camera. See crates/cdrf-core/src/lut.rs for the conventions.
//
// Bind groups (all owned by cdrf-render's Renderer):
//   0: frame    camera, lights
//   1: material LUT, view correction, model parameters
//   2: draw     model transform (dynamic offset)
//   3: shadows  per-light light-space transforms and shadow maps (first-surface depth)
//
// The shading model, the LUT filtering and the non-local terms are pipeline-overridable
// constants, so each pipeline compiles to one straight-line shader.
//
// Non-local terms (NON_LOCAL; see crates/cdrf-core/src/translucency.rs). The CDRF answers as if
// the point lay on its osculating sphere (radius 1/κ, centre p − n/κ). For each shadow-map texel
// around the point we compare the first surface the light meets with the one that sphere (or,
// for flat and concave points, the tangent plane) predicts in that column:
//   - nearer the light than predicted: the column is occluded by something the CDRF does not
//     know (a cast shadow). Visibility V is the Gaussian-weighted share of unoccluded columns,
//     σ = the material's scattering length per channel, so the shadow edge is soft;
//   - transmission: light of occluded columns arrives through d mm of the occluder (light-space
//     depth difference) as T(d, μ), μ the cosine at which it entered the occluder (from the
//     shadow map's depth slope); where the point's own column is thinner than the sphere
//     predicts (a fin, a slab lit from behind) T(d, μ) − T(d_sphere, μ) is added.
// Per light: f → V·f (shadows) + T_occluded + T_thin (transmission), all times g(θ, φ). The
// terms are evaluated per vertex and interpolated (they vary over σ); Lambert's, per pixel.

const PI: f32 = 3.14159265358979;
const FRAC_1_PI: f32 = 0.318309886183791;
const FRAC_2_PI: f32 = 0.636619772367581;
const FRAC_PI_2: f32 = 1.5707963267949;
const FRAC_1_SQRT_TAU: f32 = 0.398942280401433;
const MAX_LIGHTS: u32 = 16u;
const MAX_SHADOW_LIGHTS: u32 = 4u;
// Columns read per point and shadowed light when the penumbra is wider than a texel: the centre
// and a Vogel spiral out to 2σ.
const PENUMBRA_TAPS: u32 = 12u;
const GOLDEN_ANGLE: f32 = 2.39996322972865;
// Taps read before deciding whether the point is in a penumbra at all.
const PROBE_TAPS: u32 = 5u;
// Principal curvatures may differ from the mean curvature the mesh carries (saddles, cylinders):
// an occluder counts only if it is nearer the light than this much extra curvature explains.
const CURVATURE_ALLOWANCE_PER_MM: f32 = 0.05;

// Shading models (MODEL).
const MODEL_MEASURED: u32 = 0u;
const MODEL_GAUSSIAN_LUT: u32 = 1u;
const MODEL_GAUSSIAN_ANALYTIC: u32 = 2u;
const MODEL_LAMBERT: u32 = 3u;
const MODEL_CURVATURE: u32 = 4u;

override MODEL: u32 = 0u;
// true: bilinear filtering by hand (four texel loads, f32 weights); false: the sampler's.
override MANUAL_FILTERING: bool = false;
// true when the target is an 8-bit UNORM format that is not sRGB: encode in the shader.
override ENCODE_SRGB: bool = false;
// Bit 0: translucent visibility (shadow maps); bit 1: transmission. 0: the poster's local model.
override NON_LOCAL: u32 = 0u;
const NON_LOCAL_SHADOWS: u32 = 1u;
const NON_LOCAL_TRANSMISSION: u32 = 2u;

struct Light {
    // Unit vector toward the light, world space (w unused).
    to_light: vec4<f32>,
    // Irradiance on a surface facing the light, linear RGB (w unused).
    irradiance: vec4<f32>,
}

struct Frame {
    clip_from_world: mat4x4<f32>,
    // w = 1: xyz is the eye position (perspective); w = 0: xyz is the unit vector toward the
    // camera (orthographic).
    to_camera: vec4<f32>,
    // x: exposure (multiplies the radiance), y: light count.
    exposure_count: vec4<f32>,
    lights: array<Light, MAX_LIGHTS>,
}

struct Material {
    // Lambert: albedo; Gaussian (analytic): scale per channel.
    albedo_or_scale: vec4<f32>,
    // Gaussian (analytic): σ per channel, mm.
    sigma_mm: vec4<f32>,
    // κ of the first and last LUT row (mm⁻¹), row count, θ column count.
    lut_axis: vec4<f32>,
    // View correction grid: φ columns, θ rows.
    view_axis: vec4<f32>,
    // Curvature view: κ mapped to the colour map's ends (mm⁻¹).
    curvature_range: vec4<f32>,
    // Penumbra width σ per channel, mm (0: opaque, a hard shadow edge).
    scattering_length_mm: vec4<f32>,
    // T(d, μ) = amplitude · μ^p · exp(−d / length), π·L/E and mm per channel (amplitude 0:
    // none); p (the entry cosine power) in amplitude.w.
    transmission_amplitude: vec4<f32>,
    transmission_length_mm: vec4<f32>,
    // Gaussian weight per channel of penumbra tap k (radius 2σ_max·√(k / PENUMBRA_TAPS)).
    penumbra_weights: array<vec4<f32>, PENUMBRA_TAPS>,
}

struct ShadowLight {
    // World → light space, world units: x, y across the light, z along it (0 at the map's
    // light-side plane, growing away from the light). Rotation and translation only.
    light_from_world: mat4x4<f32>,
    // x: half the map's side, y: depth range (stored depth 1), world units.
    extent: vec4<f32>,
}

struct Shadows {
    lights: array<ShadowLight, MAX_SHADOW_LIGHTS>,
    // x: mm per world unit, y: depth bias (mm), z: map resolution (texels per side),
    // w: number of lights with a map (the first ones of the frame).
    params: vec4<f32>,
}

struct Draw {
    world_from_model: mat4x4<f32>,
    // Inverse transpose of world_from_model's upper 3×3 (columns in xyz).
    normal_from_model: mat4x4<f32>,
    // x: factor from the mesh's curvature attribute (mm⁻¹) to the drawn object's (1 / scale).
    curvature_scale: vec4<f32>,
}

@group(0) @binding(0) var<uniform> frame: Frame;
@group(1) @binding(0) var<uniform> material: Material;
@group(1) @binding(1) var lut: texture_2d<f32>;
@group(1) @binding(2) var view_correction: texture_2d<f32>;
@group(1) @binding(3) var lut_sampler: sampler;
@group(2) @binding(0) var<uniform> draw: Draw;
@group(3) @binding(0) var<uniform> shadows: Shadows;
@group(3) @binding(1) var shadow_maps: texture_depth_2d_array;

struct VertexIn {
    @builtin(vertex_index) index: u32,
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) curvature_per_mm: f32,
}

// Centroid interpolation: with MSAA, a silhouette pixel whose centre lies outside the triangle
// is shaded inside it instead of at an extrapolated normal.
struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(perspective, centroid) world_position: vec3<f32>,
    @location(1) @interpolate(perspective, centroid) world_normal: vec3<f32>,
    @location(2) @interpolate(perspective, centroid) curvature_per_mm: f32,
    // Non-local terms of the shadowed lights 0–3, evaluated per vertex (see vs_main):
    // visibility (xyz) and transmission (xyz, π·L/E) each.
    @location(3) @interpolate(perspective, centroid) visibility_0: vec3<f32>,
    @location(4) @interpolate(perspective, centroid) transmission_0: vec3<f32>,
    @location(5) @interpolate(perspective, centroid) visibility_1: vec3<f32>,
    @location(6) @interpolate(perspective, centroid) transmission_1: vec3<f32>,
    @location(7) @interpolate(perspective, centroid) visibility_2: vec3<f32>,
    @location(8) @interpolate(perspective, centroid) transmission_2: vec3<f32>,
    @location(9) @interpolate(perspective, centroid) visibility_3: vec3<f32>,
    @location(10) @interpolate(perspective, centroid) transmission_3: vec3<f32>,
}

// The non-local terms of a translucent material vary over the scattering length σ (light
// diffuses under a shadow's edge over about σ), so they are evaluated per vertex and
// interpolated: meshes whose edges are well below σ (millimetres for wax) resolve them, at a
// cost per vertex instead of per pixel. Lambert (opaque, hard edges) is evaluated per pixel.
@vertex
fn vs_main(vertex: VertexIn) -> VertexOut {
    let world = draw.world_from_model * vec4<f32>(vertex.position, 1.0);
    var out: VertexOut;
    out.clip = frame.clip_from_world * world;
    out.world_position = world.xyz / world.w;
    out.world_normal = (draw.normal_from_model * vec4<f32>(vertex.normal, 0.0)).xyz;
    out.curvature_per_mm = vertex.curvature_per_mm * draw.curvature_scale.x;
    out.visibility_0 = vec3<f32>(1.0);
    out.visibility_1 = vec3<f32>(1.0);
    out.visibility_2 = vec3<f32>(1.0);
    out.visibility_3 = vec3<f32>(1.0);
    out.transmission_0 = vec3<f32>(0.0);
    out.transmission_1 = vec3<f32>(0.0);
    out.transmission_2 = vec3<f32>(0.0);
    out.transmission_3 = vec3<f32>(0.0);
    if NON_LOCAL != 0u && MODEL != MODEL_LAMBERT && MODEL != MODEL_CURVATURE {
        let count = min(u32(shadows.params.w), u32(frame.exposure_count.y));
        let normal = normalize(out.world_normal);
        // Decorrelates neighbouring vertices' tap spirals.
        let seed = vec2<f32>(f32(vertex.index % 4096u), f32(vertex.index / 4096u));
        if count > 0u {
            let terms = non_local_terms(0u, seed, out.world_position, normal, out.curvature_per_mm);
            out.visibility_0 = terms.visibility;
            out.transmission_0 = terms.transmission;
        }
        if count > 1u {
            let terms = non_local_terms(1u, seed, out.world_position, normal, out.curvature_per_mm);
            out.visibility_1 = terms.visibility;
            out.transmission_1 = terms.transmission;
        }
        if count > 2u {
            let terms = non_local_terms(2u, seed, out.world_position, normal, out.curvature_per_mm);
            out.visibility_2 = terms.visibility;
            out.transmission_2 = terms.transmission;
        }
        if count > 3u {
            let terms = non_local_terms(3u, seed, out.world_position, normal, out.curvature_per_mm);
            out.visibility_3 = terms.visibility;
            out.transmission_3 = terms.transmission;
        }
    }
    return out;
}

// The per-vertex terms of shadowed light `index`, interpolated.
fn vertex_terms(in: VertexOut, index: u32) -> NonLocalTerms {
    var terms: NonLocalTerms;
    switch index {
        case 0u: {
            terms.visibility = in.visibility_0;
            terms.transmission = in.transmission_0;
        }
        case 1u: {
            terms.visibility = in.visibility_1;
            terms.transmission = in.transmission_1;
        }
        case 2u: {
            terms.visibility = in.visibility_2;
            terms.transmission = in.transmission_2;
        }
        default: {
            terms.visibility = in.visibility_3;
            terms.transmission = in.transmission_3;
        }
    }
    return terms;
}

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
    let axis = material.lut_axis;
    var row = 0.0;
    if axis.z > 1.0 && axis.y > axis.x {
        row = clamp((curvature_per_mm - axis.x) / (axis.y - axis.x), 0.0, 1.0) * (axis.z - 1.0);
    }
    let column = node_coordinate(theta, PI, axis.w);
    return read_bilinear(lut, column, row, axis.wz);
}

// g(θ, φ): φ across (columns over [0, π/2]), θ down (rows over [0, π]).
fn view_value(theta: f32, phi: f32) -> vec3<f32> {
    let axis = material.view_axis;
    let column = node_coordinate(phi, FRAC_PI_2, axis.x);
    let row = node_coordinate(theta, PI, axis.y);
    return read_bilinear(view_correction, column, row, axis.xy);
}

// (cos⁺ ⊛ g_s)(θ) for θ ∈ [0, π]: the clamped cosine blurred by a wrapped Gaussian of angular
// standard deviation s. The same two forms as cdrf-core's `convolved_clamped_cosine` (Fourier
// series for s ≥ 0.25, terminator correction with 16-point Gauss–Legendre below), in f32.
fn convolved_clamped_cosine(theta: f32, s: f32) -> f32 {
    if s <= 0.0 {
        return max(cos(theta), 0.0);
    }
    if s >= 0.25 {
        let q = s * s;
        let cos_2theta = cos(2.0 * theta);
        var cos_prev = 1.0;
        var cos_k = cos_2theta;
        let step = exp(-4.0 * q);
        var ratio = exp(-6.0 * q);
        var damping = exp(-2.0 * q);
        var series = 0.0;
        var sign = 1.0;
        for (var k = 1; k < 32; k++) {
            let kf = f32(k);
            let magnitude = damping / (4.0 * kf * kf - 1.0);
            if magnitude < 1e-8 {
                break;
            }
            series += sign * magnitude * cos_k;
            sign = -sign;
            let next = 2.0 * cos_2theta * cos_k - cos_prev;
            cos_prev = cos_k;
            cos_k = next;
            damping *= ratio;
            ratio *= step;
        }
        return FRAC_1_PI + 0.5 * exp(-0.5 * q) * cos(theta) + FRAC_2_PI * series;
    }
    // Local form: the kernel offset t = s·u is lit iff t > θ − π/2; the Gaussian is cut at 6s.
    let u_terminator = (theta - FRAC_PI_2) / s;
    if u_terminator >= 6.0 {
        return 0.0;
    }
    let full = exp(-0.5 * s * s) * cos(theta);
    if u_terminator <= -6.0 {
        return full;
    }
    let lit_side = u_terminator <= 0.0;
    var a = u_terminator;
    var sign = 1.0;
    if lit_side {
        a = -u_terminator;
        sign = -1.0;
    }
    let tail = half_gaussian_tail(theta, s, a, sign);
    if lit_side {
        return full - tail;
    }
    return tail;
}

// ∫_a^6 cos(θ ∓ s·u)·φ(u) du (φ the standard normal density), 16-point Gauss–Legendre.
fn half_gaussian_tail(theta: f32, s: f32, a: f32, sign: f32) -> f32 {
    var nodes = array<vec2<f32>, 8>(
        vec2<f32>(0.0950125098376374, 0.189450610455068),
        vec2<f32>(0.281603550779259, 0.182603415044924),
        vec2<f32>(0.458016777657227, 0.169156519395003),
        vec2<f32>(0.617876244402644, 0.149595988816577),
        vec2<f32>(0.755404408355003, 0.124628971255534),
        vec2<f32>(0.865631202387832, 0.0951585116824929),
        vec2<f32>(0.944575023073233, 0.0622535239386478),
        vec2<f32>(0.98940093499165, 0.0271524594117541),
    );
    let mid = 0.5 * (a + 6.0);
    let half_width = 0.5 * (6.0 - a);
    let sin_theta = sin(theta);
    let cos_theta = cos(theta);
    var sum = 0.0;
    for (var i = 0; i < 8; i++) {
        let node = nodes[i];
        for (var side = -1.0; side <= 1.0; side += 2.0) {
            let u = mid + side * half_width * node.x;
            let su = s * u;
            let value = (cos_theta * cos(su) + sign * sin_theta * sin(su)) * exp(-0.5 * u * u);
            sum += node.y * half_width * value;
        }
    }
    return sum * FRAC_1_SQRT_TAU;
}

fn gaussian_analytic(curvature_per_mm: f32, theta: f32) -> vec3<f32> {
    let kappa = max(curvature_per_mm, 0.0);
    let s = material.sigma_mm.xyz * kappa;
    let f = vec3<f32>(
        convolved_clamped_cosine(theta, s.x),
        convolved_clamped_cosine(theta, s.y),
        convolved_clamped_cosine(theta, s.z),
    );
    return material.albedo_or_scale.xyz * f;
}

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

// Angle in [0, π] from its cosine: Abramowitz & Stegun 4.4.45, |error| ≤ 6.8e-5 rad (0.004°,
// a hundredth of a LUT column), cheaper than acos on software rasterisers.
fn angle(cosine: f32) -> f32 {
    let x = clamp(cosine, -1.0, 1.0);
    let a = abs(x);
    let r = sqrt(1.0 - a) * (1.5707288 + a * (-0.2121144 + a * (0.0742610 - 0.0187293 * a)));
    return select(r, PI - r, x < 0.0);
}

struct NonLocalTerms {
    // Share of the light the CDRF term keeps, per channel.
    visibility: vec3<f32>,
    // Light through material the CDRF does not see, π·L/E.
    transmission: vec3<f32>,
}

// T(d, μ): light through `thickness_mm` of material that entered it at the cosine
// `entry_cosine` to the surface.
fn transmission_profile(thickness_mm: f32, entry_cosine: f32) -> vec3<f32> {
    return material.transmission_amplitude.xyz * entry_factor(entry_cosine)
        * exp(-max(thickness_mm, 0.0) / material.transmission_length_mm.xyz);
}

// μ^p of T(d, μ) (p = 0: 1).
fn entry_factor(entry_cosine: f32) -> f32 {
    if material.transmission_amplitude.w > 0.0 {
        return pow(clamp(entry_cosine, 1e-6, 1.0), material.transmission_amplitude.w);
    }
    return 1.0;
}

// Depth (0–1) of map `index` at `texel + step`, clamped to the map.
fn neighbour_depth(index: u32, texel: vec2<i32>, step: vec2<i32>) -> f32 {
    let last = vec2<i32>(i32(shadows.params.z) - 1);
    return textureLoad(shadow_maps, clamp(texel + step, vec2<i32>(0), last), i32(index), 0);
}

// Cosine between the light and the first surface it meets in column `texel` of map `index`,
// from the map's depth slope (the gentler one-sided difference per axis, so a depth jump at a
// silhouette does not count as slope).
fn entry_cosine(index: u32, texel: vec2<i32>, texel_mm: f32, depth_range_mm: f32) -> f32 {
    let here = textureLoad(shadow_maps, texel, i32(index), 0);
    let left = neighbour_depth(index, texel, vec2<i32>(-1, 0));
    let right = neighbour_depth(index, texel, vec2<i32>(1, 0));
    let down = neighbour_depth(index, texel, vec2<i32>(0, -1));
    let up = neighbour_depth(index, texel, vec2<i32>(0, 1));
    var dx = right - here;
    if abs(here - left) < abs(dx) {
        dx = here - left;
    }
    var dy = up - here;
    if abs(here - down) < abs(dy) {
        dy = here - down;
    }
    let slope = vec2<f32>(dx, dy) * depth_range_mm / texel_mm;
    return inverseSqrt(1.0 + dot(slope, slope));
}

// See the header: compare the shadow map of light `index` around the point with the osculating
// sphere (or tangent plane) of the point.
fn non_local_terms(
    index: u32,
    seed: vec2<f32>,
    world_position: vec3<f32>,
    normal: vec3<f32>,
    curvature_per_mm: f32,
) -> NonLocalTerms {
    let shadow = shadows.lights[index];
    let mm = shadows.params.x;
    let resolution = shadows.params.z;
    let p = (shadow.light_from_world * vec4<f32>(world_position, 1.0)).xyz * mm;
    let n = (shadow.light_from_world * vec4<f32>(normal, 0.0)).xyz;
    let half_extent_mm = shadow.extent.x * mm;
    let depth_range_mm = shadow.extent.y * mm;
    let texel_mm = 2.0 * half_extent_mm / resolution;
    let curved = curvature_per_mm > 1e-3;
    let radius_mm = 1.0 / max(curvature_per_mm, 1e-3);
    let centre = p - n * radius_mm;
    let sigma = material.scattering_length_mm.xyz;
    let sigma_max = max(sigma.x, max(sigma.y, sigma.z));
    var taps = 1u;
    if sigma_max > texel_mm {
        taps = PENUMBRA_TAPS;
    }
    // The footprint lies on the surface (tangent plane), not across the light: at grazing light
    // a step along the surface moves little across the light.
    var helper = vec3<f32>(0.0, 0.0, 1.0);
    if abs(n.z) > 0.9 {
        helper = vec3<f32>(1.0, 0.0, 0.0);
    }
    let tangent = normalize(cross(helper, n));
    let bitangent = cross(n, tangent);
    // The spiral turns by a different angle for every `seed` (the pixel, or the vertex index;
    // interleaved gradient noise, Jimenez 2014): a few taps leave fine noise instead of contour
    // bands in the penumbra.
    let spin = 6.28318530718 * fract(52.9829189 * fract(dot(seed, vec2<f32>(0.06711056, 0.00583715))));
    var unoccluded = vec3<f32>(0.0);
    var weights = vec3<f32>(0.0);
    // Occluded columns (counted − lit of them): their weight, and their summed distance through
    // the occluder.
    var through_weight = vec3<f32>(0.0);
    var through_mm = 0.0;
    var through_entry_cosine = -1.0;
    var thin = vec3<f32>(0.0);
    var counted = 0u;
    var lit = 0u;
    for (var j = 0u; j < taps; j++) {
        // The centre first, then the PROBE_TAPS − 1 outermost taps, then the rest: when the
        // probes agree (all lit or all occluded), the point is not in a penumbra and the rest
        // are skipped.
        var k = j;
        if j >= 1u && j < PROBE_TAPS {
            k = PENUMBRA_TAPS - j;
        } else if j >= PROBE_TAPS {
            k = j - PROBE_TAPS + 1u;
        }
        if j == PROBE_TAPS && (lit == counted || lit == 0u) {
            break;
        }
        // Tap k of a Vogel spiral over the disc of radius 2σ on the tangent plane (tap 0 at the
        // centre), moved onto the local shape: `surface`, with normal `facing`.
        let radius = 2.0 * sigma_max * sqrt(f32(k) / f32(PENUMBRA_TAPS));
        let angle = f32(k) * GOLDEN_ANGLE + spin;
        var surface = p + radius * (cos(angle) * tangent + sin(angle) * bitangent);
        var facing = n;
        if curved {
            facing = normalize(surface - centre);
            surface = centre + radius_mm * facing;
        }
        // The first surface the local shape puts in this column: the tap itself where it faces
        // the light, else the near end of the shape's chord through it (none for a plane).
        var expected = surface.z;
        if facing.z > 0.0 {
            if curved {
                expected = surface.z - 2.0 * radius_mm * facing.z;
            } else {
                expected = -1e30;
            }
        }
        let uv = vec2<f32>(0.5, 0.5) + vec2<f32>(0.5, -0.5) * surface.xy / half_extent_mm;
        let texel = vec2<i32>(floor(uv * resolution));
        var occluder = depth_range_mm;
        if all(texel >= vec2<i32>(0)) && all(texel < vec2<i32>(i32(resolution))) {
            occluder = textureLoad(shadow_maps, texel, i32(index), 0) * depth_range_mm;
        }
        // Allowed mismatch: the bias, plus (half a texel across the light, and the shape's sag
        // if its principal curvatures differ from the mean by up to CURVATURE_ALLOWANCE) turned
        // into depth by the surface's slope — at most σ + 4 texels, so grazing light still
        // sees occluders farther away than the penumbra is wide.
        let sag = 0.5 * radius * radius * (abs(curvature_per_mm) + CURVATURE_ALLOWANCE_PER_MM);
        let across = 0.5 * texel_mm * length(facing.xy) + sag;
        let tolerance = shadows.params.y
            + min(across / max(abs(facing.z), 1e-3), sigma_max + 4.0 * texel_mm);
        // No surface where the local shape puts one (the tangent plane reaching over a hole or
        // past an edge): this column says nothing about the light near the point.
        if k > 0u && expected > -1e29 && occluder > expected + tolerance {
            continue;
        }
        // Gaussian weight of the tap per channel (σ per channel), precomputed per material.
        var weight = vec3<f32>(1.0);
        if taps > 1u {
            weight = material.penumbra_weights[k].xyz;
        }
        weights += weight;
        counted += 1u;
        if occluder < expected - tolerance {
            through_weight += weight;
            through_mm += surface.z - occluder;
            // The entry cosine at the first occluded column only: read at every occluded
            // column instead, the torus's errors against path tracing moved by ≤ 1.6 points
            // (cast shadow 111.5 % instead of 109.9 %).
            if (NON_LOCAL & NON_LOCAL_TRANSMISSION) != 0u && through_entry_cosine < 0.0 {
                through_entry_cosine = entry_cosine(index, texel, texel_mm, depth_range_mm);
            }
        } else {
            unoccluded += weight;
            lit += 1u;
            if k == 0u && (NON_LOCAL & NON_LOCAL_TRANSMISSION) != 0u && n.z > 0.0 {
                // Thinner than the local shape by more than the tolerance; both chords at the
                // entry cosine the map shows, so on the sphere itself the difference vanishes
                // whatever the error of the slope estimate (read only where it is needed).
                thin = max(
                    transmission_profile(p.z - occluder, 1.0)
                        - transmission_profile(p.z - expected - tolerance, 1.0),
                    vec3<f32>(0.0),
                );
                if any(thin > vec3<f32>(0.0)) {
                    thin *= entry_factor(entry_cosine(index, texel, texel_mm, depth_range_mm));
                }
            }
        }
    }
    var terms: NonLocalTerms;
    terms.visibility = unoccluded / weights;
    // T(d, μ) is measured on the spheres at θ ≥ 110°; nearer the terminator sideways diffusion
    // (the CDRF) dominates, so the thin-part term fades in from θ = 90° to 110°.
    terms.transmission = thin * smoothstep(0.0, 0.342, n.z);
    if (NON_LOCAL & NON_LOCAL_SHADOWS) != 0u && (NON_LOCAL & NON_LOCAL_TRANSMISSION) != 0u
        && counted > lit {
        // Light through the occluders, at their mean thickness and entry cosine (one T per
        // light).
        let occluded = f32(counted - lit);
        terms.transmission += through_weight / weights
            * transmission_profile(through_mm / occluded, through_entry_cosine);
    }
    return terms;
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    let normal = normalize(in.world_normal);
    var radiance = vec3<f32>(0.0);
    if MODEL == MODEL_CURVATURE {
        let range = material.curvature_range;
        radiance = cool_warm((in.curvature_per_mm - range.x) / max(range.y - range.x, 1e-12));
    } else {
        var to_camera = frame.to_camera.xyz;
        if frame.to_camera.w > 0.5 {
            to_camera = normalize(frame.to_camera.xyz - in.world_position);
        }
        let phi = angle(dot(normal, to_camera));
        let light_count = min(u32(frame.exposure_count.y), MAX_LIGHTS);
        for (var i = 0u; i < light_count; i++) {
            let light = frame.lights[i];
            let cos_theta = dot(normal, light.to_light.xyz);
            let theta = angle(cos_theta);
            var f: vec3<f32>;
            if MODEL == MODEL_LAMBERT {
                f = material.albedo_or_scale.xyz * max(cos_theta, 0.0);
            } else if MODEL == MODEL_GAUSSIAN_ANALYTIC {
                f = gaussian_analytic(in.curvature_per_mm, theta);
            } else {
                f = lut_value(in.curvature_per_mm, theta);
            }
            if NON_LOCAL != 0u && i < u32(shadows.params.w) {
                var terms: NonLocalTerms;
                if MODEL == MODEL_LAMBERT {
                    terms = non_local_terms(
                        i,
                        in.clip.xy,
                        in.world_position,
                        normal,
                        in.curvature_per_mm,
                    );
                } else {
                    terms = vertex_terms(in, i);
                }
                if (NON_LOCAL & NON_LOCAL_SHADOWS) != 0u {
                    f *= terms.visibility;
                }
                f += terms.transmission;
            }
            if MODEL != MODEL_LAMBERT {
                f *= view_value(theta, phi);
            }
            radiance += light.irradiance.rgb * FRAC_1_PI * f;
        }
        radiance *= frame.exposure_count.x;
    }
    if ENCODE_SRGB {
        radiance = linear_to_srgb(radiance);
    }
    return vec4<f32>(radiance, 1.0);
}
