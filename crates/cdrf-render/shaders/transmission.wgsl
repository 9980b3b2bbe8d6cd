// Transmission T(d, μ): light through d mm of material that entered it at cosine μ, the entry
// cosine read from a shadow map's depth slope, and the thin-part term (docs/shading.md,
// "Non-local terms").

// T(d, μ) was measured on the spheres' shadow side, θ ≥ 110°; nearer the terminator sideways
// diffusion (the CDRF) dominates. The thin-part term fades in as the normal turns away from
// the light, from θ = 90° (light-space n.z = 0) to θ = 110° (n.z = −cos 110°).
const THIN_PART_FADE_END: f32 = 0.342020143325669;

// T(d, μ): light through `thickness_mm` of material that entered it at the cosine
// `entry_cosine` to the surface.
fn transmission_profile(thickness_mm: f32, entry_cosine: f32) -> vec3<f32> {
    return material.transmission_amplitude * entry_factor(entry_cosine)
        * exp(-max(thickness_mm, 0.0) / material.transmission_length_mm);
}

// μ^p of T(d, μ) (p = 0: 1).
fn entry_factor(entry_cosine: f32) -> f32 {
    if material.transmission_entry_cosine_power > 0.0 {
        return pow(clamp(entry_cosine, 1e-6, 1.0), material.transmission_entry_cosine_power);
    }
    return 1.0;
}

// Depth (0–1) of map layer `layer` at `texel + step`, clamped to the map.
fn neighbour_depth(layer: u32, texel: vec2<i32>, step: vec2<i32>) -> f32 {
    let last = vec2<i32>(i32(shadows.resolution) - 1);
    return textureLoad(shadow_maps, clamp(texel + step, vec2<i32>(0), last), i32(layer), 0);
}

// Cosine between the light and the first surface it meets in column `texel` of map layer
// `layer`, from the map's depth slope (the gentler one-sided difference per axis, so a depth
// jump at a silhouette does not count as slope); `texel_mm` the texel's width there.
fn entry_cosine(layer: u32, texel: vec2<i32>, texel_mm: f32, depth_range_mm: f32) -> f32 {
    let here = textureLoad(shadow_maps, texel, i32(layer), 0);
    let left = neighbour_depth(layer, texel, vec2<i32>(-1, 0));
    let right = neighbour_depth(layer, texel, vec2<i32>(1, 0));
    let down = neighbour_depth(layer, texel, vec2<i32>(0, -1));
    let up = neighbour_depth(layer, texel, vec2<i32>(0, 1));
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

// Light through a part thinner than the local shape by more than the tolerance: T at the
// thickness the map shows minus T at the thickness the shape predicts, both at the entry cosine
// the map shows, so on the sphere itself the difference vanishes whatever the error of the
// slope estimate (read only where it is needed).
fn thin_part_transmission(
    layer: u32,
    texel: vec2<i32>,
    thickness_mm: f32,
    expected_thickness_mm: f32,
    texel_mm: f32,
    depth_range_mm: f32,
) -> vec3<f32> {
    let thin = max(
        transmission_profile(thickness_mm, 1.0) - transmission_profile(expected_thickness_mm, 1.0),
        vec3<f32>(0.0),
    );
    if any(thin > vec3<f32>(0.0)) {
        return thin * entry_factor(entry_cosine(layer, texel, texel_mm, depth_range_mm));
    }
    return thin;
}
