// A draw's surface (cdrf-render's surface module): the per-pixel normal bent by its normal
// map, and the specular roughness from its roughness texture. Reads `draw`. See
// docs/shading.md.

// The per-pixel normal: the interpolated one, bent by the surface's normal map (its texel
// `encoded`) where the draw has one and its mesh has tangents (glTF's convention:
// B = cross(N, T) · w).
fn shading_normal(
    world_normal: vec3<f32>,
    world_tangent: vec4<f32>,
    encoded: vec3<f32>,
) -> vec3<f32> {
    let normal = normalize(world_normal);
    if (draw.surface_flags & SURFACE_NORMAL_MAP) == 0u || abs(world_tangent.w) < 0.5 {
        return normal;
    }
    let t = world_tangent.xyz - normal * dot(normal, world_tangent.xyz);
    if dot(t, t) < 1e-12 {
        return normal;
    }
    let tangent = normalize(t);
    let bitangent = cross(normal, tangent) * sign(world_tangent.w);
    let m = (encoded * 2.0 - 1.0) * vec3<f32>(draw.normal_scale, draw.normal_scale, 1.0);
    return normalize(tangent * m.x + bitangent * m.y + normal * m.z);
}

// The specular layer's Beckmann α at this pixel: the surface's (roughness², `texel` its
// roughness texture's G) or the material's.
fn specular_alpha(texel: f32) -> f32 {
    if (draw.surface_flags & SURFACE_ROUGHNESS) == 0u {
        return material.specular_roughness_alpha;
    }
    let roughness = draw.roughness_factor * texel;
    // (Beckmann's D is singular at α = 0: a mirror is α = 0.01 here.)
    return max(roughness * roughness, 0.01);
}
