// The shading pass: vs_main (the vertex alone), vs_main_terms (with the vertex terms pass's
// output as a second vertex buffer) and fs_main (the radiance of a pixel). The pass's bind
// groups: 0–1 and 3 in bindings.wgsl, its group 2 here. See docs/shading.md.

// Group 2: the draw's transforms and surface factors (dynamic offset), and its surface's
// textures: sRGB base colour (decoded by the format), tangent-space normals, roughness in G.
@group(2) @binding(0) var<uniform> draw: Draw;
@group(2) @binding(1) var base_color_texture: texture_2d<f32>;
@group(2) @binding(2) var normal_texture: texture_2d<f32>;
@group(2) @binding(3) var roughness_texture: texture_2d<f32>;
@group(2) @binding(4) var base_color_sampler: sampler;
@group(2) @binding(5) var normal_sampler: sampler;
@group(2) @binding(6) var roughness_sampler: sampler;

// VertexTerms read back as a second vertex buffer (src/gpu_types.rs: GpuVertexTerms's
// attributes). Stage inputs hold no arrays, so the MAX_SHADOW_LIGHTS slots are written out;
// tests/shaders.rs counts them against the constant.
struct VertexTermsIn {
    @location(5) visibility_0: vec4<f32>,
    @location(6) through_0: vec4<f32>,
    @location(7) visibility_1: vec4<f32>,
    @location(8) through_1: vec4<f32>,
    @location(9) visibility_2: vec4<f32>,
    @location(10) through_2: vec4<f32>,
    @location(11) visibility_3: vec4<f32>,
    @location(12) through_3: vec4<f32>,
    @location(13) radiance: vec4<f32>,
}

// Centroid interpolation: with MSAA, a silhouette pixel whose centre lies outside the triangle
// is shaded inside it instead of at an extrapolated normal.
struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(perspective, centroid) world_position: vec3<f32>,
    @location(1) @interpolate(perspective, centroid) world_normal: vec3<f32>,
    @location(2) @interpolate(perspective, centroid) curvature_per_mm: f32,
    // The curvature along the direction to each of the first MAX_SHADOW_LIGHTS lights
    // (light_curvatures_per_mm), shadowed or not.
    @location(3) @interpolate(perspective, centroid) light_curvatures_per_mm: vec4<f32>,
    // Shadowed light i's terms, per vertex (slot i, as VertexTermsIn): visibility and the
    // light through the material (pack_through).
    @location(4) @interpolate(perspective, centroid) visibility_0: vec3<f32>,
    @location(5) @interpolate(perspective, centroid) through_0: vec3<f32>,
    @location(6) @interpolate(perspective, centroid) visibility_1: vec3<f32>,
    @location(7) @interpolate(perspective, centroid) through_1: vec3<f32>,
    @location(8) @interpolate(perspective, centroid) visibility_2: vec3<f32>,
    @location(9) @interpolate(perspective, centroid) through_2: vec3<f32>,
    @location(10) @interpolate(perspective, centroid) visibility_3: vec3<f32>,
    @location(11) @interpolate(perspective, centroid) through_3: vec3<f32>,
    // Radiance evaluated per vertex (before exposure): the inter-reflected light of all
    // shadowed lights and the environment light, both smooth over the surface.
    @location(12) @interpolate(perspective, centroid) vertex_radiance: vec3<f32>,
    @location(13) @interpolate(perspective, centroid) uv: vec2<f32>,
    @location(14) @interpolate(perspective, centroid) world_tangent: vec4<f32>,
}

// The pipelines without per-vertex terms (no non-local terms, or Lambert's, which are per
// pixel).
@vertex
fn vs_main(vertex: VertexIn) -> VertexOut {
    return vertex_out(vertex);
}

// vs_main, with the vertex's non-local terms from the vertex terms pass.
@vertex
fn vs_main_terms(vertex: VertexIn, terms: VertexTermsIn) -> VertexOut {
    var out = vertex_out(vertex);
    out.visibility_0 = terms.visibility_0.xyz;
    out.through_0 = terms.through_0.xyz;
    out.visibility_1 = terms.visibility_1.xyz;
    out.through_1 = terms.through_1.xyz;
    out.visibility_2 = terms.visibility_2.xyz;
    out.through_2 = terms.through_2.xyz;
    out.visibility_3 = terms.visibility_3.xyz;
    out.through_3 = terms.through_3.xyz;
    var inter_reflected = terms.radiance.xyz;
    if MODEL != MODEL_LAMBERT {
        // The view correction of light arriving at its mean angle θ_ω (w), for this view's
        // camera: light between a body's parts arrives far from the normal, where a skin-like
        // medium's view correction is far from that of light along it.
        let phi = angle(dot(normalize(out.world_normal), to_camera_from(out.world_position)));
        inter_reflected *= view_value(out.curvature_per_mm, terms.radiance.w, phi);
    }
    out.vertex_radiance += inter_reflected;
    return out;
}

// The vertex without non-local terms (visibility 1, nothing through the material, no
// inter-reflection), with the environment light's radiance.
fn vertex_out(vertex: VertexIn) -> VertexOut {
    let world = draw.world_from_model * vec4<f32>(vertex.position, 1.0);
    var out: VertexOut;
    out.clip = frame.clip_from_world * world;
    out.world_position = world.xyz / world.w;
    out.world_normal = world_normal_of(vertex.normal);
    out.curvature_per_mm = vertex.curvature_per_mm * draw.curvature_scale;
    out.uv = vertex.uv;
    out.world_tangent = vec4<f32>(
        (draw.world_from_model * vec4<f32>(vertex.tangent.xyz, 0.0)).xyz,
        vertex.tangent.w,
    );
    out.light_curvatures_per_mm = light_curvatures_per_mm(
        out.world_position,
        normalize(out.world_normal),
        out.curvature_per_mm,
        world_anisotropy_of(vertex.curvature_anisotropy_per_mm),
    );
    out.visibility_0 = vec3<f32>(1.0);
    out.visibility_1 = vec3<f32>(1.0);
    out.visibility_2 = vec3<f32>(1.0);
    out.visibility_3 = vec3<f32>(1.0);
    out.through_0 = vec3<f32>(0.0);
    out.through_1 = vec3<f32>(0.0);
    out.through_2 = vec3<f32>(0.0);
    out.through_3 = vec3<f32>(0.0);
    out.vertex_radiance = vec3<f32>(0.0);
    // The environment light: its order-4 SH sum varies as slowly as the normal does, so per
    // vertex.
    if frame.environment_bands != 0u && MODEL != MODEL_CURVATURE {
        let normal = normalize(out.world_normal);
        var environment = environment_radiance(normal, out.curvature_per_mm);
        if MODEL != MODEL_LAMBERT {
            // Light from everywhere: the view correction of light along the normal.
            let phi = angle(dot(normal, to_camera_from(out.world_position)));
            environment *= view_value(out.curvature_per_mm, 0.0, phi);
        }
        out.vertex_radiance = environment;
    }
    return out;
}

// The curvature light `index` sees at a fragment (light_curvatures_per_mm, interpolated; the
// mean curvature for lights without a slot).
fn light_curvature_per_mm(in: VertexOut, index: u32) -> f32 {
    if index < MAX_SHADOW_LIGHTS {
        return in.light_curvatures_per_mm[index];
    }
    return in.curvature_per_mm;
}

// The per-vertex terms of shadowed light `index` (slot `index`), interpolated.
fn slot_terms(in: VertexOut, index: u32) -> NonLocalTerms {
    var terms = no_terms();
    switch index {
        case 0u: {
            terms = unpack_terms(in.visibility_0, in.through_0);
        }
        case 1u: {
            terms = unpack_terms(in.visibility_1, in.through_1);
        }
        case 2u: {
            terms = unpack_terms(in.visibility_2, in.through_2);
        }
        case 3u: {
            terms = unpack_terms(in.visibility_3, in.through_3);
        }
        default: {}
    }
    return terms;
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    // (Every texture sampled before any branch: implicit derivatives need uniform control
    // flow.)
    let tint = draw.base_color_factor
        * textureSample(base_color_texture, base_color_sampler, in.uv).rgb;
    let normal = shading_normal(
        in.world_normal,
        in.world_tangent,
        textureSample(normal_texture, normal_sampler, in.uv).xyz,
    );
    let alpha = specular_alpha(textureSample(roughness_texture, roughness_sampler, in.uv).g);
    var radiance = vec3<f32>(0.0);
    if MODEL == MODEL_CURVATURE {
        let range = material.curvature_range_per_mm;
        radiance = cool_warm((in.curvature_per_mm - range.x) / max(range.y - range.x, 1e-12));
    } else {
        let to_camera = to_camera_from(in.world_position);
        let phi = angle(dot(normal, to_camera));
        let light_count = min(frame.light_count, MAX_LIGHTS);
        // The first surface's reflection, added after the subsurface light is scaled by what
        // the boundary lets through.
        var specular = vec3<f32>(0.0);
        for (var i = 0u; i < light_count; i++) {
            let incidence = light_incidence(frame.lights[i], in.world_position);
            let cos_theta = dot(normal, incidence.to_light);
            let theta = angle(cos_theta);
            let curvature_per_mm = light_curvature_per_mm(in, i);
            var terms = no_terms();
            if LIGHT_MAPS && i < shadows.light_count {
                if MODEL == MODEL_LAMBERT {
                    terms = non_local_terms(i, in.world_position, normal, in.curvature_per_mm);
                } else {
                    terms = slot_terms(in, i);
                }
            }
            let share = light_share(i, incidence, cos_theta, theta, curvature_per_mm, terms);
            var reflected = share.reflected;
            if MODEL != MODEL_LAMBERT {
                reflected *= view_value(curvature_per_mm, theta, phi)
                    * view_azimuth(curvature_per_mm, theta, dot(to_camera, incidence.to_light));
            }
            radiance += FRAC_1_PI * reflected;
            if material.specular_on != 0u {
                specular += incidence.irradiance * share.visibility
                    * specular_radiance(normal, incidence.to_light, to_camera, alpha);
            }
        }
        radiance += in.vertex_radiance;
        radiance = (radiance * material.subsurface_transmission * tint + specular)
            * frame.exposure;
    }
    if ENCODE_SRGB {
        radiance = linear_to_srgb(radiance);
    }
    return vec4<f32>(radiance, 1.0);
}
