// The environment light: the material's zonal coefficients a_l(κ), the CDRF's answer to light
// from one direction as their expansion (also the inter-reflection's), and the SH sum over the
// environment. See docs/shading.md.

// The material's zonal coefficients a_l(κ), l = 0 … ENVIRONMENT_SH_ORDER (its environment
// table, rows uniform in κ, interpolated linearly).
fn zonal_row(curvature_per_mm: f32) -> array<vec3<f32>, ENVIRONMENT_SH_BANDS> {
    let range = material.environment_curvature_per_mm;
    var t = 0.0;
    if range.y > range.x {
        t = clamp((curvature_per_mm - range.x) / (range.y - range.x), 0.0, 1.0)
            * f32(ENVIRONMENT_ZONAL_ROWS - 1u);
    }
    let row0 = min(u32(t), ENVIRONMENT_ZONAL_ROWS - 1u);
    let row1 = min(row0 + 1u, ENVIRONMENT_ZONAL_ROWS - 1u);
    let w = t - f32(row0);
    var a: array<vec3<f32>, ENVIRONMENT_SH_BANDS>;
    for (var l = 0u; l < ENVIRONMENT_SH_BANDS; l++) {
        a[l] = mix(
            material.environment_zonal[row0 * ENVIRONMENT_SH_BANDS + l].xyz,
            material.environment_zonal[row1 * ENVIRONMENT_SH_BANDS + l].xyz,
            w,
        );
    }
    return a;
}

// The CDRF's answer to light from one direction as its zonal expansion: f(κ, θ) =
// π Σ_l (2l + 1)/(4π) · a_l(κ) · P_l(cos θ) (Funk–Hecke: a_l are the coefficients of f/π), up to
// ENVIRONMENT_SH_ORDER. Per receiver its coefficients (zonal_response), per direction a
// Legendre recurrence (zonal_value): no texture read.
fn zonal_response(curvature_per_mm: f32) -> array<vec3<f32>, ENVIRONMENT_SH_BANDS> {
    var b = zonal_row(curvature_per_mm);
    for (var l = 0u; l < ENVIRONMENT_SH_BANDS; l++) {
        b[l] *= 0.25 * f32(2u * l + 1u);
    }
    return b;
}

fn zonal_value(b: array<vec3<f32>, ENVIRONMENT_SH_BANDS>, cos_theta: f32) -> vec3<f32> {
    var p_previous = 1.0;
    var p = cos_theta;
    var value = b[0] + b[1] * cos_theta;
    for (var l = 2u; l < ENVIRONMENT_SH_BANDS; l++) {
        let next = (f32(2u * l - 1u) * cos_theta * p - f32(l - 1u) * p_previous) / f32(l);
        p_previous = p;
        p = next;
        value += b[l] * p;
    }
    return max(value, vec3<f32>(0.0));
}

// The environment light (cdrf-core's environment::radiance_sh): Σ_l a_l(κ) Σ_m L_lm Y_lm(n),
// the real SH basis as polynomials in the normal (P̃_l^m(z) · Re/Im (x + i y)^m; the
// normalisation is in frame.environment_sh), clamped at 0 against ringing. Local: no shadows.
fn environment_radiance(normal: vec3<f32>, curvature_per_mm: f32) -> vec3<f32> {
    let bands = min(frame.environment_bands, ENVIRONMENT_SH_BANDS);
    let a = zonal_row(curvature_per_mm);
    var radiance = vec3<f32>(0.0);
    // Re and Im of (x + i y)^m, and P̃_m^m = (2m − 1)!!.
    var re = 1.0;
    var im = 0.0;
    var p_mm = 1.0;
    for (var m = 0u; m < bands; m++) {
        if m > 0u {
            let re_next = re * normal.x - im * normal.y;
            im = re * normal.y + im * normal.x;
            re = re_next;
            p_mm *= f32(2u * m - 1u);
        }
        var p_previous = 0.0;
        var p = p_mm;
        for (var l = m; l < bands; l++) {
            if l == m + 1u {
                p_previous = p;
                p = f32(2u * m + 1u) * normal.z * p_mm;
            } else if l > m + 1u {
                let next = (f32(2u * l - 1u) * normal.z * p - f32(l + m - 1u) * p_previous)
                    / f32(l - m);
                p_previous = p;
                p = next;
            }
            let centre = l * l + l;
            if m == 0u {
                radiance += a[l] * p * frame.environment_sh[centre].xyz;
            } else {
                radiance += a[l] * p * (frame.environment_sh[centre + m].xyz * re
                    + frame.environment_sh[centre - m].xyz * im);
            }
        }
    }
    return max(radiance, vec3<f32>(0.0));
}
