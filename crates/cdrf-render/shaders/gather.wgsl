// The subsurface gather G: light that entered the lit surface near a point and reached it
// through the medium, summed over the subsurface pyramids with the far-field kernel R_far(d)
// (docs/shading.md, "Subsurface gather").

// Whether this material's subsurface gather is on (a diffusion profile, and the pipeline's).
fn gathers_subsurface() -> bool {
    return SUBSURFACE && material.subsurface_reach_mm > 0.0 && MODEL != MODEL_LAMBERT;
}

// R_far(d) per channel, mm⁻² (0 beyond the table's reach).
fn subsurface_kernel_value(distance_mm: f32) -> vec3<f32> {
    let reach = material.subsurface_reach_mm;
    if distance_mm >= reach {
        return vec3<f32>(0.0);
    }
    let last = f32(SUBSURFACE_KERNEL_SAMPLES - 1u);
    let x = sqrt(max(distance_mm, 0.0) / reach) * last;
    let i = min(u32(x), SUBSURFACE_KERNEL_SAMPLES - 2u);
    let a = material.subsurface_kernel[i].xyz;
    let b = material.subsurface_kernel[i + 1u].xyz;
    return mix(a, b, clamp(x - f32(i), 0.0, 1.0));
}

// R_far averaged over a texel's light rather than read at its mean (`to_point`: from the mean to
// the point): the light spreads `across_mm2` per axis across the light (the texel's width²/12)
// and `depth_mm2` along it (a surface turning from the light spans depths). R_far is convex, so
// the mean alone reads too little: on a sphere's shadow side about 0.9 of the light
// (docs/research/thick-bodies.md). Read at d ± s, s the spread along the direction to the
// point kept within SPREAD_STEP_PER_DISTANCE (5–40 %) of d (the expansion fails where the
// spread is not small against the distance), and the spread across it through the slope
// between the two reads; at most SPREAD_BOUND × the two reads' geometric mean (≈ R_far(d) for
// an exponential: where a texel spreads further than about half the kernel's length the
// expansion is no guide).
const SPREAD_BOUND: f32 = 1.15;
const SPREAD_STEP_PER_DISTANCE: vec2<f32> = vec2<f32>(0.05, 0.4);
const SPREAD_STEP_PER_CUT: f32 = 0.05;
fn spread_kernel_value(
    to_point: vec3<f32>,
    ray: vec3<f32>,
    across_mm2: f32,
    depth_mm2: f32,
) -> vec3<f32> {
    let d = length(to_point);
    let c = dot(to_point, ray) / max(d, 1e-6);
    let radial_mm2 = mix(across_mm2, depth_mm2, min(c * c, 1.0));
    let lateral_mm2 = max(2.0 * across_mm2 + depth_mm2 - radial_mm2, 0.0);
    // At least SPREAD_STEP_PER_CUT · ℓ_c: the kernel is linear in √d, so its slope near d = 0
    // grows without bound and a step narrower than that would read a texel at the point as
    // nothing.
    let s = max(
        clamp(sqrt(radial_mm2), SPREAD_STEP_PER_DISTANCE.x * d, SPREAD_STEP_PER_DISTANCE.y * d),
        SPREAD_STEP_PER_CUT * material.subsurface_cut_mm,
    ) + 1e-6;
    let farther = subsurface_kernel_value(d + s);
    let nearer = subsurface_kernel_value(d - s);
    let slope = (farther - nearer) / (2.0 * s);
    let spread = 0.5 * (farther + nearer) + slope * (sqrt(d * d + lateral_mm2) - d);
    return min(max(spread, vec3<f32>(0.0)), SPREAD_BOUND * sqrt(farther * nearer));
}

// The share of the light level L keeps, at ρ of its texels from the point: 1 within
// SUBSURFACE_LEVEL_REACH texels, 0 beyond twice that, smooth between.
const SUBSURFACE_LEVEL_REACH: f32 = 3.0;
fn level_share(rho: f32) -> f32 {
    return 1.0 - smoothstep(SUBSURFACE_LEVEL_REACH, 2.0 * SUBSURFACE_LEVEL_REACH, rho);
}

// G at frame point p (mm) from the pyramids of light `index` (one per face), per unit of the
// light's strength (light_strength).
fn subsurface_gather(index: u32, shape: LocalShape) -> vec3<f32> {
    let p = shape.point;
    var sum = vec3<f32>(0.0);
    if shadows.subsurface_levels == 0u {
        return sum;
    }
    let light = &shadows.lights[index];
    for (var face = 0u; face < (*light).face_count; face++) {
        let local = light_face_point(index, face, p);
        // Behind a perspective face the point is far from all of it: its coarsest level only.
        let in_front = (*light).projection == SHADOW_ORTHOGRAPHIC || local.z > 0.0;
        var uv = vec2<f32>(0.0);
        if in_front {
            uv = face_uv(index, local);
        }
        sum += subsurface_gather_face(index, face, shape, uv, in_front);
    }
    return sum;
}

// One face's pyramid (face `face` of light `index`), the point (its local shape) at map
// coordinates `uv` (`near`: false when it has none, and all the light counts as far): level L
// weighs its texel at ρ (its texels) from the point by level_share(ρ) − level_share(2ρ)
// (level 0: level_share(ρ); the coarsest: 1 − level_share(2ρ)), which sum to 1 at every
// distance; and each texel by the share of its light that reaches the point through the
// medium (through_medium) and against the light's travel (upstream_weight).
fn subsurface_gather_face(
    index: u32,
    face: u32,
    shape: LocalShape,
    uv: vec2<f32>,
    near: bool,
) -> vec3<f32> {
    let layer = i32(shadows.lights[index].first_layer + face);
    var sum = vec3<f32>(0.0);
    for (var level = 0u; level < shadows.subsurface_levels; level++) {
        sum += subsurface_gather_level(index, layer, shape, uv, near, level);
    }
    return sum;
}

// Level `level` of one face's pyramid (subsurface_gather_face).
fn subsurface_gather_level(
    index: u32,
    layer: i32,
    shape: LocalShape,
    uv: vec2<f32>,
    near: bool,
    level: u32,
) -> vec3<f32> {
    let p = shape.point;
    let levels = shadows.subsurface_levels;
    // The light's projection, read once per level: per texel, both projections' rays and
    // texel widths are computed and one selected (software rasterisers run both sides of a
    // branch, and read a uniform's fields inside the loop per invocation).
    let orthographic = shadows.lights[index].projection == SHADOW_ORTHOGRAPHIC;
    let half_extent = shadows.lights[index].half_extent;
    var sum = vec3<f32>(0.0);
    let resolution = shadows.subsurface_resolution >> level;
    let size = i32(resolution);
    // texel_width_of at this level: this times the depth (perspective) or the frame's
    // unit (orthographic).
    let texel_width_per_depth = 2.0 * half_extent / f32(resolution);
    let centre = uv * f32(size);
    let coarsest = level + 1u == levels;
    // The texels whose centres lie within 2·SUBSURFACE_LEVEL_REACH of the point along each
    // axis (any other has ρ at least that, and share 0): 4·REACH per side.
    var first = vec2<i32>(floor(centre - 2.0 * SUBSURFACE_LEVEL_REACH - 0.5)) + 1;
    var count = i32(4.0 * SUBSURFACE_LEVEL_REACH);
    if coarsest {
        first = vec2<i32>(0);
        count = size;
    } else if !near || any(first + count <= vec2<i32>(0)) || any(first >= vec2<i32>(size)) {
        // No texel of this level's window lies on the map.
        return sum;
    }
    for (var dy = 0; dy < count; dy++) {
        // Below the coarsest level, only the row's texels within 2·REACH of the point (the
        // rest have share 0): a fifth of the window fewer.
        var row_first = 0;
        var row_end = count;
        if !coarsest {
            let y = f32(first.y + dy) + 0.5 - centre.y;
            let radius = 2.0 * SUBSURFACE_LEVEL_REACH;
            let half_width = sqrt(max(radius * radius - y * y, 0.0));
            row_first = max(i32(ceil(centre.x - half_width - 0.5)) - first.x, 0);
            row_end = min(i32(floor(centre.x + half_width - 0.5)) - first.x + 1, count);
        }
        for (var dx = row_first; dx < row_end; dx++) {
            let texel = first + vec2<i32>(dx, dy);
            if any(texel < vec2<i32>(0)) || any(texel >= vec2<i32>(size)) {
                continue;
            }
            var share = 1.0;
            if near {
                let rho = length(vec2<f32>(texel) + 0.5 - centre);
                if level > 0u {
                    share -= level_share(2.0 * rho);
                }
                if !coarsest {
                    share -= 1.0 - level_share(rho);
                }
            }
            if share <= 0.0 {
                continue;
            }
            let texel_sum = textureLoad(subsurface_pyramid, texel, layer, i32(level));
            if texel_sum.w <= 0.0 {
                continue;
            }
            // The texel's flux at its mean position.
            let q = texel_sum.xyz / texel_sum.w;
            let distance_from_light = length(q);
            let ray = select(
                q / max(distance_from_light, 1e-6),
                vec3<f32>(0.0, 0.0, 1.0),
                orthographic,
            );
            let texel_mm = texel_width_per_depth
                * select(distance_from_light, shadows.mm_per_world_unit, orthographic);
            let tolerance = max(SUBSURFACE_AIR_TOLERANCE_MM, texel_mm);
            share *= through_medium(ray, shape, q, tolerance)
                * upstream_weight(ray, shape, q, texel_mm);
            // How far the texel's light spreads along the light about q: its spread less the
            // texel's width²/6 across it.
            let spread = textureLoad(subsurface_spread, texel, layer, i32(level)).x;
            let across_mm2 = texel_mm * texel_mm / 12.0;
            let depth_mm2 = max(spread / texel_sum.w - 2.0 * across_mm2, 0.0);
            sum += share * texel_sum.w * spread_kernel_value(p - q, ray, across_mm2, depth_mm2);
        }
    }
    return sum;
}

// How much of the light entering at frame point q reaches the point of `shape` through the
// medium: none where q lies in front of the point's local shape along q's light ray by more
// than twice `tolerance_mm` — another part, an occluder, whose light crosses the air to get
// here (the inter-reflection carries that) — all of it where it lies within `tolerance_mm`
// of the shape's first surface or behind it (the point's own part, whose surface curves
// inside its osculating sphere), smooth between. The shape's surface the light meets first in
// q's column: the sphere's near side (none where the ray misses it), or the tangent plane
// where it faces the light.
const SUBSURFACE_AIR_TOLERANCE_MM: f32 = 1.0;
// `ray`: the unit vector along the light's rays at q (light_ray).
fn through_medium(ray: vec3<f32>, shape: LocalShape, q: vec3<f32>, tolerance_mm: f32) -> f32 {
    var ahead = -1e30;
    if shape.curved {
        let v = q - shape.centre;
        let b = dot(ray, v);
        let discriminant = b * b - (dot(v, v) - shape.radius_mm * shape.radius_mm);
        if discriminant > 0.0 {
            ahead = -b - sqrt(discriminant);
        }
    } else {
        let facing = dot(ray, shape.normal);
        if facing < 0.0 {
            ahead = dot(shape.point - q, shape.normal) / facing;
        }
    }
    return 1.0 - smoothstep(tolerance_mm, 2.0 * tolerance_mm, ahead);
}

// The share of the far field from frame point q (a texel's mean, `texel_mm` across as the light
// sees it) that reaches the point of `shape`: 1 − UPSTREAM_LOSS·max(−c, 0), c the cosine between
// the light's travel (`ray`, light_ray at q) and q's direction to the point (cdrf-core's
// diffusion::UPSTREAM_LOSS; F_sphere in the near field's table integrates the same). A texel's
// points spread by texel_mm²/6 about their mean, and on a curved surface the mean lies inside
// it by half that over the radius: read as it is, it would lie further down the light than the
// surface it stands for, and nearer the point.
fn upstream_weight(ray: vec3<f32>, shape: LocalShape, q: vec3<f32>, texel_mm: f32) -> f32 {
    let spread_mm2 = texel_mm * texel_mm / 6.0;
    var source = q;
    if shape.curved {
        source += normalize(q - shape.centre) * (0.5 * spread_mm2 / shape.radius_mm);
    }
    let to_point = shape.point - source;
    let c = dot(to_point, ray) / sqrt(max(dot(to_point, to_point) + spread_mm2, 1e-12));
    return upstream_share(c, UPSTREAM_LOSS);
}

// The share of a source's light that reaches a point lying at cosine c to the light's travel
// from it (c < 0: the point lies upstream), for a loss `loss` straight upstream (cdrf-core's
// diffusion module, "Against the light's travel").
fn upstream_share(c: f32, loss: f32) -> f32 {
    return max(1.0 - loss * max(-c, 0.0), 0.0);
}

// The gain on G on the shadow side of a body thinner along the light than the circle of the
// point's local shape predicts (the curvature the shadow test and the gather read, so one
// circle stands for the body in all three): cdrf-core's subsurface::confinement_gain, whose
// constants these are (CONFINEMENT_*), per channel on the material's transmission length. A
// point flat or concave along the light on a convex body reads a quarter of the mean
// (shadow_shape_curvature_per_mm). `thickness_mm`: the body along the light at the point
// (NonLocalTerms); `along`: n · the light's ray (> 0 on the shadow side).
fn confinement_gain(thickness_mm: f32, along: f32, shape_curvature_per_mm: f32) -> vec3<f32> {
    if thickness_mm <= 0.0 || along <= 0.0 {
        return vec3<f32>(1.0);
    }
    // Mean curvature ≤ 0 (concave or a saddle): the chord is unbounded (the limit of a
    // vanishing curvature, so the gain is continuous where the mean curvature changes sign).
    let chord_mm = 2.0 * along / max(shape_curvature_per_mm, 1e-6);
    let thinner_mm = clamp(chord_mm - thickness_mm - CONFINEMENT_TOLERANCE_MM, 0.0, thickness_mm);
    let length_mm = material.transmission_length_mm;
    let thick = 1.0 - exp(-thickness_mm / (CONFINEMENT_THICKNESS_LENGTHS * length_mm));
    let deep = smoothstep(0.0, CONFINEMENT_FULL_FROM, along);
    let gain = 1.0 + CONFINEMENT_GAIN * deep * thick * (1.0 - exp(-thinner_mm / length_mm));
    return select(vec3<f32>(1.0), gain, length_mm > vec3<f32>(0.0));
}
