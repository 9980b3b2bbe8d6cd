// The specular layer (cdrf-core's specular module): a dielectric boundary's reflection with a
// Beckmann microfacet distribution. See docs/shading.md.

// cdrf-core's SpecularLayer::radiance_per_irradiance: F(v·h) D(h) G₁(l) G₁(v) / (4 cos φ),
// Beckmann D, Smith G₁ in Walter et al.'s rational form, the dielectric's unpolarised Fresnel.
fn specular_radiance(
    normal: vec3<f32>,
    to_light: vec3<f32>,
    to_camera: vec3<f32>,
    alpha: f32,
) -> f32 {
    let cos_theta = dot(normal, to_light);
    let cos_phi = dot(normal, to_camera);
    let half_sum = to_light + to_camera;
    if cos_theta <= 0.0 || cos_phi <= 0.0 || dot(half_sum, half_sum) < 1e-12 {
        return 0.0;
    }
    let half = normalize(half_sum);
    let cos_half = dot(normal, half);
    if cos_half <= 0.0 {
        return 0.0;
    }
    let c2 = cos_half * cos_half;
    let a2 = alpha * alpha;
    let d = exp(-max(1.0 - c2, 0.0) / (c2 * a2)) / (PI * a2 * c2 * c2);
    let g = smith_g1(cos_theta, alpha) * smith_g1(cos_phi, alpha);
    return dielectric_fresnel(dot(to_camera, half), material.specular_ior) * d * g
        / (4.0 * cos_phi);
}

fn smith_g1(cosine: f32, alpha: f32) -> f32 {
    let tangent = sqrt(max(1.0 - cosine * cosine, 0.0)) / cosine;
    if tangent == 0.0 {
        return 1.0;
    }
    let a = 1.0 / (alpha * tangent);
    if a >= 1.6 {
        return 1.0;
    }
    return (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a);
}

fn dielectric_fresnel(cos_incident: f32, eta: f32) -> f32 {
    let c = clamp(cos_incident, 0.0, 1.0);
    let ct = sqrt(max(1.0 - (1.0 - c * c) / (eta * eta), 0.0));
    let rs = (c - eta * ct) / (c + eta * ct);
    let rp = (eta * c - ct) / (eta * c + ct);
    return 0.5 * (rs * rs + rp * rp);
}
