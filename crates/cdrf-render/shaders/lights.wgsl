// The lights: what a light gives a surface point, a spot's cone, the direction to the camera,
// and the curvature each light sees. See docs/shading.md.

// What a light gives a surface point (cdrf-core's light::Incidence).
struct Incidence {
    to_light: vec3<f32>,
    irradiance: vec3<f32>,
}

// The light arriving at a world position: cdrf-core's Light::incidence.
fn light_incidence(light: Light, world_position: vec3<f32>) -> Incidence {
    var incidence: Incidence;
    if light.kind == LIGHT_DIRECTIONAL {
        incidence.to_light = light.to_light;
        incidence.irradiance = light.irradiance;
        return incidence;
    }
    let offset = light.position - world_position;
    let d_mm = length(offset) * frame.mm_per_world_unit;
    incidence.to_light = offset / max(length(offset), 1e-30);
    incidence.irradiance = light.intensity / max(d_mm * d_mm, 1e-12)
        * spot_falloff(light, incidence.to_light);
    return incidence;
}

// A directional light's irradiance, a point or spot light's intensity: the unit of the light
// maps' texel areas (texel_light_area) and of the subsurface gather G.
fn light_strength(light: Light) -> vec3<f32> {
    return select(light.intensity, light.irradiance, light.kind == LIGHT_DIRECTIONAL);
}

// A spot light's cone (1 inside the inner angle, 0 outside the outer, a smoothstep in the cosine
// between) at the unit vector `to_light`; 1 for other lights.
fn spot_falloff(light: Light, to_light: vec3<f32>) -> f32 {
    if light.kind != LIGHT_SPOT {
        return 1.0;
    }
    let t = clamp(
        (dot(-to_light, light.spot_direction) - light.spot_cos_outer)
            / max(light.spot_cos_inner - light.spot_cos_outer, 1e-6),
        0.0,
        1.0,
    );
    return t * t * (3.0 - 2.0 * t);
}

// The unit vector toward the camera from a world position.
fn to_camera_from(world_position: vec3<f32>) -> vec3<f32> {
    if frame.camera_is_point != 0u {
        return normalize(frame.to_camera - world_position);
    }
    return frame.to_camera;
}

// The curvature each of the first MAX_SHADOW_LIGHTS lights sees at a vertex, shadowed or not
// (one per vertex slot; vec4: MAX_SHADOW_LIGHTS is 4, asserted in src/gpu_types.rs): along
// the direction to the light, across which its angle θ changes (a tube lit across its axis
// falls off like a sphere of the tube's radius, lit along it like a flat strip). Later lights
// use the mean curvature.
fn light_curvatures_per_mm(
    world_position: vec3<f32>,
    normal: vec3<f32>,
    mean_per_mm: f32,
    anisotropy: vec3<f32>,
) -> vec4<f32> {
    var curvatures = vec4<f32>(mean_per_mm);
    let count = min(frame.light_count, MAX_SHADOW_LIGHTS);
    for (var i = 0u; i < count; i++) {
        let to_light = light_incidence(frame.lights[i], world_position).to_light;
        curvatures[i] = directional_curvature(mean_per_mm, anisotropy, normal, to_light);
    }
    return curvatures;
}
