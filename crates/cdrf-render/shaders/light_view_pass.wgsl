// The light-view pass: the draws seen from each face of each shadowed light (vs_light_view),
// and fs_subsurface_map, which renders level 0 of the subsurface pyramid (the light entering
// the first surface). One pipeline for every model: no override is set here. The pass's bind
// groups: the shading pass's layout (bindings.wgsl and the draw here). See docs/shading.md,
// "Subsurface gather".

// Group 2: the draw's transforms (dynamic offset).
@group(2) @binding(0) var<uniform> draw: Draw;

struct LightViewOut {
    @builtin(position) clip: vec4<f32>,
    // The light's frame (light_frame_point), mm, and the normal in it.
    @location(0) light_position_mm: vec3<f32>,
    @location(1) light_normal: vec3<f32>,
    @location(2) @interpolate(flat) light: u32,
    // Face of a perspective light (0 for orthographic ones).
    @location(3) @interpolate(flat) face: u32,
}

// The light-view pass (the subsurface map): the draws seen from face `face` of shadowed light
// `light` (the instance index is light · MAX_SHADOW_FACES + face), in the shadow
// map's square or frustum.
@vertex
fn vs_light_view(vertex: VertexIn, @builtin(instance_index) instance: u32) -> LightViewOut {
    let light = instance / MAX_SHADOW_FACES;
    let face = instance % MAX_SHADOW_FACES;
    let camera = shadows.lights[light];
    let world = (draw.world_from_model * vec4<f32>(vertex.position, 1.0)).xyz;
    let local = (camera.light_from_world[face] * vec4<f32>(world, 1.0)).xyz;
    var out: LightViewOut;
    if camera.projection == SHADOW_ORTHOGRAPHIC {
        out.clip = vec4<f32>(
            local.xy / camera.half_extent,
            local.z / camera.depth_range,
            1.0,
        );
    } else {
        // As the shadow pass's perspective faces: depth from 0.1 % to 100 % of the range.
        let far = camera.depth_range;
        let near = 1e-3 * far;
        out.clip = vec4<f32>(
            local.xy / camera.half_extent,
            (local.z - near) * far / (far - near),
            local.z,
        );
    }
    out.light_position_mm = light_frame_point(light, world);
    let normal = world_normal_of(vertex.normal);
    out.light_normal = light_frame_vector(light, normal);
    out.light = light;
    out.face = face;
    return out;
}

// What the light gives the first surface of a light-view pass's fragment: the cosine between
// its normal and the light, and the area the light sees of one texel of a `resolution`-texel
// map there (texel_light_area).
struct LitTexel {
    normal: vec3<f32>,
    cos_theta: f32,
    area: f32,
}

fn lit_texel(in: LightViewOut, resolution: u32) -> LitTexel {
    var texel: LitTexel;
    texel.normal = normalize(in.light_normal);
    texel.cos_theta = -dot(texel.normal, light_ray(in.light, in.light_position_mm));
    texel.area = texel_light_area(in.light, in.face, in.light_position_mm, resolution);
    return texel;
}

// Level 0 of the subsurface pyramid's two textures.
struct SubsurfaceTexel {
    // Φ·position and Φ.
    @location(0) sum: vec4<f32>,
    // Φ·|position − mean|² summed over the texel's points: 0 at level 0.
    @location(1) spread: f32,
}

// The subsurface map pass: level 0 of the pyramid, Φ·position and Φ per texel (its spread is 0:
// one point), Φ = A · μ^(p−1) (A: texel_light_area, μ^p the entry factor, 1/μ the surface a
// texel covers). Materials without a diffusion profile (Lambert, the Gaussian CDRF) occlude but
// let no light in.
@fragment
fn fs_subsurface_map(in: LightViewOut) -> SubsurfaceTexel {
    var out: SubsurfaceTexel;
    if !(material.subsurface_reach_mm > 0.0) {
        return out;
    }
    let texel = lit_texel(in, shadows.subsurface_resolution);
    // μ at least 0.1 (a silhouette texel's surface is a guess).
    let mu = max(texel.cos_theta, 0.1);
    let flux = texel.area * pow(mu, material.subsurface_entry_cosine_power - 1.0);
    out.sum = vec4<f32>(in.light_position_mm * flux, flux);
    return out;
}
