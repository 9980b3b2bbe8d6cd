// What a light gives a point, before the view correction: the local model's f(κ, θ), and the
// same with the light's non-local terms (visibility V, transmission T, gather G). Used by the
// shading pass per pixel and by the vertex terms pass for the exitance. See docs/shading.md.

// A shadowed light's non-local terms at a point.
struct NonLocalTerms {
    // Share of the light the CDRF term keeps, per channel.
    visibility: vec3<f32>,
    // T(d, μ): light through material the CDRF does not see, π·L/E, per unit of the
    // irradiance at the point. Zero where the gather brings that light.
    transmission: vec3<f32>,
    // G: light that entered the lit surface near the point and reached it through the medium
    // (the subsurface gather), π·L per unit of the light's strength (light_strength).
    gather: vec3<f32>,
    // The body's thickness along the light at a point on its shadow side whose column's first
    // surface is its own (mm; 0 elsewhere): the gather's confinement gain reads it.
    thickness_mm: f32,
}

// No terms: visibility 1, nothing through the material.
fn no_terms() -> NonLocalTerms {
    var terms: NonLocalTerms;
    terms.visibility = vec3<f32>(1.0);
    terms.transmission = vec3<f32>(0.0);
    terms.gather = vec3<f32>(0.0);
    terms.thickness_mm = 0.0;
    return terms;
}

// The per-vertex slot's `through` (LightTerms, VertexOut): T, or G where this material
// gathers (then T is zero), so one vec3 per light carries either.
fn pack_through(terms: NonLocalTerms) -> vec3<f32> {
    return select(terms.transmission, terms.gather, gathers_subsurface());
}

// The terms from a per-vertex slot (pack_through's inverse).
fn unpack_terms(visibility: vec3<f32>, through: vec3<f32>) -> NonLocalTerms {
    var terms = no_terms();
    terms.visibility = visibility;
    if gathers_subsurface() {
        terms.gather = through;
    } else {
        terms.transmission = through;
    }
    return terms;
}

// The local model's f(κ, θ) (π·L/E; the curvature view has none).
fn local_value(curvature_per_mm: f32, cos_theta: f32, theta: f32) -> vec3<f32> {
    if MODEL == MODEL_LAMBERT {
        return material.lambert_albedo * max(cos_theta, 0.0);
    } else if MODEL == MODEL_GAUSSIAN_ANALYTIC {
        return gaussian_analytic(curvature_per_mm, theta);
    }
    return lut_value(curvature_per_mm, theta);
}

// What light `index` gives a point, before the view correction: π·L/E times the light (the
// exitance the point would have if the light left it evenly), and the share V of it the
// shadows let through (1 without). `terms`: the light's non-local terms at the point
// (no_terms where it has none).
struct LightShare {
    reflected: vec3<f32>,
    visibility: vec3<f32>,
}

fn light_share(
    index: u32,
    incidence: Incidence,
    cos_theta: f32,
    theta: f32,
    curvature_per_mm: f32,
    terms: NonLocalTerms,
) -> LightShare {
    let shadowed = LIGHT_MAPS && index < shadows.light_count;
    // The whole table, also with the gather: the far field it holds through the osculating
    // sphere is taken out of G per vertex (sphere_far_field).
    var f = local_value(curvature_per_mm, cos_theta, theta);
    var share: LightShare;
    share.visibility = vec3<f32>(1.0);
    // The light through material the table does not see: T(d, μ) in π·L/E (times the
    // irradiance here), or the gather's G (times the light's strength: the light entered
    // elsewhere, where the irradiance is not this point's).
    var through = vec3<f32>(0.0);
    var through_scale = incidence.irradiance;
    if shadowed {
        if gathers_subsurface() {
            through_scale = light_strength(frame.lights[index]);
            through = terms.gather;
        } else {
            through = terms.transmission;
        }
        if SHADOWS {
            f *= terms.visibility;
            share.visibility = terms.visibility;
        }
    }
    share.reflected = max(incidence.irradiance * f + through_scale * through, vec3<f32>(0.0));
    return share;
}
