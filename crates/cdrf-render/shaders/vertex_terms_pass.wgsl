// The vertex terms pass (compute): cs_vertex_terms writes every vertex's non-local terms once
// per frame — the shading pass reads them as a second vertex buffer — and, with the
// inter-reflection, its exitance. The pass's bind groups: 0–1 and 3 in bindings.wgsl, its
// group 2 here. See docs/shading.md.

// Group 2: the draw's transforms (dynamic offset), the mesh's vertex buffer as f32s
// (compute_mesh.wgsl) and the terms written for each of its vertices.
@group(2) @binding(0) var<uniform> draw: Draw;
@group(2) @binding(7) var<storage, read> terms_mesh_vertices: array<f32>;
@group(2) @binding(8) var<storage, read_write> terms_out: array<VertexTerms>;

@compute @workgroup_size(COMPUTE_WORKGROUP_SIZE)
fn cs_vertex_terms(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = invocation_index(id, groups);
    if i >= arrayLength(&terms_out) {
        return;
    }
    let v = mesh_vertex(i);
    var lights: array<NonLocalTerms, MAX_SHADOW_LIGHTS>;
    for (var k = 0u; k < MAX_SHADOW_LIGHTS; k++) {
        lights[k] = no_terms();
    }
    let count = min(shadows.light_count, frame.light_count);
    let curvatures = light_curvatures_per_mm(
        v.world_position,
        v.normal,
        v.curvature_per_mm,
        v.anisotropy,
    );
    if LIGHT_MAPS && MODEL != MODEL_CURVATURE {
        for (var k = 0u; k < count; k++) {
            if MODEL == MODEL_LAMBERT {
                // Lambert's terms are the shading pass's, per pixel; the exitance needs them here.
                if INTERREFLECTION && SHADOWS {
                    lights[k] = non_local_terms(k, v.world_position, v.normal, v.curvature_per_mm);
                }
            } else {
                lights[k] = vertex_non_local(
                    k,
                    v.world_position,
                    v.normal,
                    v.curvature_per_mm,
                    curvatures[k],
                );
            }
        }
    }
    var terms: VertexTerms;
    for (var k = 0u; k < MAX_SHADOW_LIGHTS; k++) {
        terms.lights[k].visibility = vec4<f32>(lights[k].visibility, 1.0);
        terms.lights[k].through = vec4<f32>(pack_through(lights[k]), 0.0);
    }
    if INTERREFLECTION && MODEL != MODEL_CURVATURE {
        // The light leaving the vertex, as if evenly (the inter-reflection's source).
        var exitance = vec3<f32>(0.0);
        for (var k = 0u; k < min(frame.light_count, MAX_LIGHTS); k++) {
            let incidence = light_incidence(frame.lights[k], v.world_position);
            let cos_theta = dot(v.normal, incidence.to_light);
            var curvature_per_mm = v.curvature_per_mm;
            var light_terms = no_terms();
            if k < MAX_SHADOW_LIGHTS {
                curvature_per_mm = curvatures[k];
                light_terms = lights[k];
            }
            exitance += light_share(
                k,
                incidence,
                cos_theta,
                angle(cos_theta),
                curvature_per_mm,
                light_terms,
            ).reflected;
        }
        terms.exitance = vec4<f32>(exitance, 0.0);
    }
    terms_out[i] = terms;
}

// The curvature of the local shape the shadow test and the gather compare the light map with
// (light_space.wgsl's local_shape), and the confinement gain the body's thickness: where the
// mean curvature is positive, the smaller of it and the curvature along the light, but at
// least a quarter of the mean. A body curving slowly along the light (an egg lit from one
// end) meets the light farther out than its mean-curvature sphere, which would call its own
// surface an occluder past the terminator; never more than the mean, so a tube lit across
// keeps its sphere; never a plane, whose facing test flips at θ = 90° (bright dashes along a
// torus's terminator). Negative mean curvature is kept as it is.
fn shadow_shape_curvature_per_mm(mean_per_mm: f32, along_light_per_mm: f32) -> f32 {
    if mean_per_mm <= 0.0 {
        return mean_per_mm;
    }
    return max(min(mean_per_mm, along_light_per_mm), 0.25 * mean_per_mm);
}

// F_sphere(κ, θ), the far field the table holds (lut_blocks' first block), π·L/E as the table;
// 0 for models without a table. Taken out of G per vertex rather than out of f per pixel, so
// that G and the far field it replaces are interpolated alike and cancel on a sphere.
fn sphere_far_field(curvature_per_mm: f32, theta: f32) -> vec3<f32> {
    if !(MODEL == MODEL_MEASURED || MODEL == MODEL_GAUSSIAN_LUT) {
        return vec3<f32>(0.0);
    }
    return sphere_far_field_value(curvature_per_mm, theta);
}

// The per-vertex terms of shadowed light `index`: visibility and T(d, μ) from the shadow map,
// or with the subsurface gather G (where V < 1 scaled by √s at the mean curvature) instead of T.
fn vertex_non_local(
    index: u32,
    world_position: vec3<f32>,
    normal: vec3<f32>,
    curvature_per_mm: f32,
    light_curvature_per_mm: f32,
) -> NonLocalTerms {
    var terms = no_terms();
    let shape_curvature_per_mm = shadow_shape_curvature_per_mm(
        curvature_per_mm,
        light_curvature_per_mm,
    );
    // V also without shadows where the gather runs: G − V·F_sphere below needs it.
    if SHADOWS || TRANSMISSION || gathers_subsurface() {
        terms = non_local_terms(index, world_position, normal, shape_curvature_per_mm);
    }
    if gathers_subsurface() {
        let shape = local_shape(
            light_frame_point(index, world_position),
            light_frame_vector(index, normal),
            shape_curvature_per_mm,
        );
        let light = frame.lights[index];
        let incidence = light_incidence(light, world_position);
        let theta = angle(dot(normal, incidence.to_light));
        let v = terms.visibility;
        let gathered = subsurface_gather(index, shape)
            * confinement_gain(
                terms.thickness_mm,
                dot(shape.normal, light_ray(index, shape.point)),
                shape_curvature_per_mm,
            );
        // The shadowed share's light, (1 − V)·G, is scaled by √s where shadows are on: s read
        // at the mean curvature, the sphere whose shadow side stands for the body around the
        // point (both directions confine the light). Along the light, a face lit at grazing
        // angles would read the largest sphere's shadow side, which the photographs barely
        // measure. s is that sphere's own correction of the profile; a body that is not the
        // sphere gets half of it in log (√s): the 15 mm cap at the end of a 70 mm capsule is lit
        // through the capsule's length (docs/shading.md).
        var shadow_scale = vec3<f32>(1.0);
        if SHADOWS && any(v < vec3<f32>(1.0)) {
            shadow_scale = sqrt(subsurface_gain_value(curvature_per_mm, theta));
        }
        // The lit share: G less the far field F_sphere the table already holds, by V whether or
        // not shadows are on (G misses the sources the light's map cannot see as V·F_sphere
        // does, so in a cast shadow G ≈ 0 ≈ V·F_sphere and without shadows the pixel keeps its
        // f whole). Where G falls short of F_sphere (most of all where sources lie hidden beyond
        // a cast shadow's edge) the shortfall is at most the table's own share f / F_sphere of
        // it: where the profile's F_sphere exceeds the table (a large sphere's terminator, up to
        // 1.4 f) the near field f − F_sphere is negative, and the whole shortfall would leave a
        // cast shadow's lit edge darker than its umbra.
        let far = sphere_far_field(light_curvature_per_mm, theta);
        let table_share = min(
            lut_value(light_curvature_per_mm, theta) / max(far, vec3<f32>(1e-30)),
            vec3<f32>(1.0),
        );
        // F_sphere in G's units: per unit of the light's strength, at this point's irradiance.
        let strength = light_strength(light);
        let per_strength = select(
            vec3<f32>(0.0),
            incidence.irradiance / strength,
            strength > vec3<f32>(0.0),
        );
        let lit = v * (gathered - far * per_strength);
        terms.gather = select(lit, lit * table_share, lit < vec3<f32>(0.0))
            + (vec3<f32>(1.0) - v) * shadow_scale * gathered;
    }
    return terms;
}
