// Kubo's Gaussian CDRF evaluated in the shader (GaussianEvaluation::Analytic): the clamped
// cosine blurred by a Gaussian of angular width σκ. See docs/shading.md.

// (cos⁺ ⊛ g_s)(θ) for θ ∈ [0, π]: the clamped cosine blurred by a wrapped Gaussian of angular
// standard deviation s. The same two forms as cdrf-core's `convolved_clamped_cosine` (Fourier
// series for s ≥ 0.25, terminator correction with 16-point Gauss–Legendre below), in f32.
fn convolved_clamped_cosine(theta: f32, s: f32) -> f32 {
    if s <= 0.0 {
        return max(cos(theta), 0.0);
    }
    if s >= 0.25 {
        let q = s * s;
        let cos_2theta = cos(2.0 * theta);
        var cos_prev = 1.0;
        var cos_k = cos_2theta;
        let step = exp(-4.0 * q);
        var ratio = exp(-6.0 * q);
        var damping = exp(-2.0 * q);
        var series = 0.0;
        var sign = 1.0;
        for (var k = 1; k < 32; k++) {
            let kf = f32(k);
            let magnitude = damping / (4.0 * kf * kf - 1.0);
            if magnitude < 1e-8 {
                break;
            }
            series += sign * magnitude * cos_k;
            sign = -sign;
            let next = 2.0 * cos_2theta * cos_k - cos_prev;
            cos_prev = cos_k;
            cos_k = next;
            damping *= ratio;
            ratio *= step;
        }
        return FRAC_1_PI + 0.5 * exp(-0.5 * q) * cos(theta) + FRAC_2_PI * series;
    }
    // Local form: the kernel offset t = s·u is lit iff t > θ − π/2; the Gaussian is cut at 6s.
    let u_terminator = (theta - FRAC_PI_2) / s;
    if u_terminator >= 6.0 {
        return 0.0;
    }
    let full = exp(-0.5 * s * s) * cos(theta);
    if u_terminator <= -6.0 {
        return full;
    }
    let lit_side = u_terminator <= 0.0;
    var a = u_terminator;
    var sign = 1.0;
    if lit_side {
        a = -u_terminator;
        sign = -1.0;
    }
    let tail = half_gaussian_tail(theta, s, a, sign);
    if lit_side {
        return full - tail;
    }
    return tail;
}

// ∫_a^6 cos(θ ∓ s·u)·φ(u) du (φ the standard normal density), 16-point Gauss–Legendre.
fn half_gaussian_tail(theta: f32, s: f32, a: f32, sign: f32) -> f32 {
    var nodes = array<vec2<f32>, 8>(
        vec2<f32>(0.0950125098376374, 0.189450610455068),
        vec2<f32>(0.281603550779259, 0.182603415044924),
        vec2<f32>(0.458016777657227, 0.169156519395003),
        vec2<f32>(0.617876244402644, 0.149595988816577),
        vec2<f32>(0.755404408355003, 0.124628971255534),
        vec2<f32>(0.865631202387832, 0.0951585116824929),
        vec2<f32>(0.944575023073233, 0.0622535239386478),
        vec2<f32>(0.98940093499165, 0.0271524594117541),
    );
    let mid = 0.5 * (a + 6.0);
    let half_width = 0.5 * (6.0 - a);
    let sin_theta = sin(theta);
    let cos_theta = cos(theta);
    var sum = 0.0;
    for (var i = 0; i < 8; i++) {
        let node = nodes[i];
        for (var side = -1.0; side <= 1.0; side += 2.0) {
            let u = mid + side * half_width * node.x;
            let su = s * u;
            let value = (cos_theta * cos(su) + sign * sin_theta * sin(su)) * exp(-0.5 * u * u);
            sum += node.y * half_width * value;
        }
    }
    return sum * FRAC_1_SQRT_TAU;
}

fn gaussian_analytic(curvature_per_mm: f32, theta: f32) -> vec3<f32> {
    let kappa = max(curvature_per_mm, 0.0);
    let s = material.sigma_mm * kappa;
    let f = vec3<f32>(
        convolved_clamped_cosine(theta, s.x),
        convolved_clamped_cosine(theta, s.y),
        convolved_clamped_cosine(theta, s.z),
    );
    return material.gaussian_scale * f;
}
