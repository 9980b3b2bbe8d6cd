#!/usr/bin/env python3
"""What the subsurface gather loses by reading each pyramid texel at its light's mean position
(issue 37; docs/research/thick-bodies.md, eleventh pass). A CPU model of gather.wgsl on a sphere
lit by a directional light: the lit surface is sampled finely, summed into the light's pyramid
(level 0 of N texels across the sphere, halved per level, as subsurface_pyramid.rs builds it),
and each level's texels are weighted as `level_share` does. It prints, for a point at each θ,
the gathered sum over the exact surface integral: read at the texel's mean (as the shader did
until session 21), with a second-order correction from each texel's spread (its trace alone,
its full covariance, and its width²/12 across the light with its depth variance along it),
with that spread read at sigma points (`sigma`), and as gather.wgsl's spread_kernel_value
reads it (`shader`: two reads at d ± s, the depth variance from the trace as the pyramid's
Φ·|position|² gives it, bounded by BOUND × the reads' geometric mean; docs/research/
thick-bodies.md, twelfth and thirteenth passes).

  python pyramid_lumping.py [--radius 35] [--ell 5] [--resolution 128] [--levels 5] [--sub 16]
      [--reach 3] [--clamp 0.4] [--bound 1.15] [--from-level 0] [--thetas 60,85,...]

One exponential term R(d) = exp(-d/ell) / (2 pi ell d) stands for R_far; the entry factor is
mu^(p-1) per unit of the light's area (p = 0.85, the bundled fit's).
"""
import argparse
import numpy as np

ap = argparse.ArgumentParser()
ap.add_argument("--radius", type=float, default=35.0, help="sphere radius, mm")
ap.add_argument("--ell", type=float, default=5.0, help="the kernel's length, mm")
ap.add_argument("--power", type=float, default=0.85, help="entry cosine power p")
ap.add_argument("--resolution", type=int, default=128, help="level 0's texels across the sphere")
ap.add_argument("--levels", type=int, default=5)
ap.add_argument("--sub", type=int, default=16, help="surface samples per level-0 texel and axis")
ap.add_argument("--reach", type=float, default=3.0, help="SUBSURFACE_LEVEL_REACH, texels")
ap.add_argument("--clamp", type=float, default=0.4, help="the sigma points' spread, at most this x d")
ap.add_argument("--bound", type=float, default=1.15, help="the shader's bound on its two reads")
ap.add_argument("--from-level", type=int, default=0, help="the shader's spread read from this level on")
ap.add_argument("--thetas", default="60,85,92,95,100,110,130,160", help="the points' theta, deg")
a = ap.parse_args()

R, ell = a.radius, a.ell
n = a.resolution * a.sub
u = (np.arange(n) + 0.5) / n * 2 * R - R
X, Y = np.meshgrid(u, u, indexing="xy")
lit = X**2 + Y**2 < R * R
depth = np.sqrt(np.maximum(R * R - X**2 - Y**2, 0.0))
Z = -depth  # the light travels +z; the lit pole is at z = -R
mu = depth / R
flux = np.where(lit, np.power(np.maximum(mu, 1e-9), a.power - 1) * (2 * R / n) ** 2, 0.0)


def kernel(d):
    d = np.maximum(d, 1e-9)
    return np.exp(-d / ell) / (2 * np.pi * ell * d)


def kernel_d1(d):
    d = np.maximum(d, 1e-9)
    return kernel(d) * (-1 / ell - 1 / d)


def kernel_d2(d):
    d = np.maximum(d, 1e-9)
    return kernel(d) * ((1 / ell + 1 / d) ** 2 + 1 / d**2)


def level_share(rho):
    t = np.clip((rho - a.reach) / a.reach, 0, 1)
    return 1 - t * t * (3 - 2 * t)


def reduce(x, k):
    h = x.shape[0] // k
    return x[: h * k, : h * k].reshape(h, k, h, k).sum((1, 3))


# Per texel: the flux, its first moments and its second moments (xx, yy, zz, xy, xz, yz).
moments = [flux, flux * X, flux * Y, flux * Z, flux * X * X, flux * Y * Y, flux * Z * Z,
           flux * X * Y, flux * X * Z, flux * Y * Z]
pyramid = [[reduce(m, a.sub) for m in moments]]
for _ in range(1, a.levels):
    pyramid.append([reduce(m, 2) for m in pyramid[-1]])

print("theta  mean  trace  covariance  depth  sigma  shader   (gathered / exact)")
for theta in (int(t) for t in a.thetas.split(",")):
    t = np.radians(theta)
    p = np.array([R * np.sin(t), 0.0, -R * np.cos(t)])
    exact = (flux * kernel(np.sqrt((X - p[0]) ** 2 + (Y - p[1]) ** 2 + (Z - p[2]) ** 2))).sum()
    sums = np.zeros(6)
    for level, m in enumerate(pyramid):
        w = m[0]
        size = w.shape[0]
        texel_mm = 2 * R / size
        centres = np.arange(size) + 0.5
        cx, cy = np.meshgrid(centres, centres, indexing="xy")
        rho = np.hypot(cx - (p[0] + R) / texel_mm, cy - (p[1] + R) / texel_mm)
        share = np.ones_like(rho)
        if level > 0:
            share -= level_share(2 * rho)
        if level < a.levels - 1:
            share -= 1 - level_share(rho)
        share = np.maximum(share, 0.0)
        use = (w > 0) & (share > 0)
        wd = np.maximum(w, 1e-30)
        q = np.stack([m[1], m[2], m[3]], -1) / wd[..., None]
        cov = np.empty(w.shape + (3, 3))
        for (i, j), k in zip([(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)], range(4, 10)):
            cov[..., i, j] = cov[..., j, i] = m[k] / wd - q[..., i] * q[..., j]
        v = p - q
        d = np.linalg.norm(v, axis=-1)
        along = v / np.maximum(d, 1e-9)[..., None]
        trace = np.trace(cov, axis1=-2, axis2=-1)
        radial = np.einsum("...i,...ij,...j", along, cov, along)
        at_mean = kernel(d)
        # Second order in the texel's spread: R'' along the direction to the point, R'/d across.
        with_trace = at_mean + 0.5 * (kernel_d2(d) * trace / 3 + kernel_d1(d) / d * 2 * trace / 3)
        with_cov = at_mean + 0.5 * (kernel_d2(d) * radial + kernel_d1(d) / d * (trace - radial))
        # Across the light the texel's width²/12 per axis, along it the depth variance.
        split = np.zeros_like(cov)
        split[..., 0, 0] = split[..., 1, 1] = texel_mm**2 / 12
        split[..., 2, 2] = cov[..., 2, 2]
        trace_split = np.trace(split, axis1=-2, axis2=-1)
        radial_split = np.einsum("...i,...ij,...j", along, split, along)
        with_depth = at_mean + 0.5 * (
            kernel_d2(d) * radial_split + kernel_d1(d) / d * (trace_split - radial_split)
        )
        # Sigma points (implementable): the depth variance from the trace less the lateral
        # w^2/6, the radial spread s read at d +- s (s at most CLAMP d), the lateral one at
        # sqrt(d^2 + t).
        depth_var = np.maximum(trace - texel_mm**2 / 6, 0.0)
        c = np.abs(along[..., 2])
        radial_s = texel_mm**2 / 12 * (1 - c * c) + depth_var * c * c
        lateral_t = texel_mm**2 / 6 + depth_var - radial_s
        sig = np.minimum(np.sqrt(radial_s), a.clamp * d)
        with_sigma = 0.5 * (kernel(d + sig) + kernel(d - sig)) + kernel(np.sqrt(d * d + lateral_t)) - at_mean
        # The shader's two reads: d +- s, s at least 0.05 d, the lateral spread through the
        # slope between them, bounded by BOUND x their geometric mean.
        s2 = np.maximum(sig, 0.05 * d)
        kp, km = kernel(d + s2), kernel(d - s2)
        with_shader = np.maximum(0.5 * (kp + km) + (kp - km) / (2 * s2) * (np.sqrt(d * d + lateral_t) - d), 0)
        with_shader = np.minimum(with_shader, a.bound * np.sqrt(kp * km))
        if level < a.from_level:
            with_shader = at_mean
        for k, value in enumerate((at_mean, with_trace, with_cov, with_depth, with_sigma, with_shader)):
            sums[k] += (share * w * value)[use].sum()
    print(f"{theta:5d}  " + "  ".join(f"{s / exact:.3f}" for s in sums))
