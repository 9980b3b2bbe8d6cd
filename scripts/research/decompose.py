#!/usr/bin/env python3
"""Split a path-traced wax image into where its light travelled (issue 16's research).

A volumetric path tracer of its own (Dr.Jit + Mitsuba's ray tracing of the mesh only), for the
data set's conventions: homogeneous isotropic medium inside a closed mesh, index-matched boundary
(nothing reflects or refracts), an orthographic camera and a directional or point light, every
unit in mm. It estimates the same radiance as the references' `volpath` and adds it into buckets
by the camera path's history:

  direct   - the path never left the wax between the camera's entry and the scattering event
             that saw the light, and the light reached that event without crossing another part
             of the object;
  through  - as direct, but the light's ray crossed another part first (light through occluders);
  bounce1  - the path left the wax once and re-entered it (one inter-reflection through the air);
  bounce2  - two or more re-entries;
  bounce1_lit - the part of bounce1 whose emitter (the point where the light left the other
             part, the camera path's re-entry) lies on the surface the light sees (facing it,
             unoccluded): the light's first surface. bounce1 - bounce1_lit left from elsewhere.

direct + through is the subsurface light (what a CDRF, its shadows and a gather model); the
bounce buckets are light between parts of the object. The sum equals the reference up to noise.

Usage (the venv of ../shared/gt/README.md):
  decompose.py SIDECAR.json OBJ|sphere:RADIUS_MM --size 128 --spp 64 --out OUT.npz
It writes OUT.npz with float32 arrays direct, through, bounce1, bounce2 (H, W, 3) and coverage.
"""
import argparse
import json
import os
import time

os.environ.setdefault('DRJIT_LIBLLVM_PATH', '/usr/lib/x86_64-linux-gnu/libLLVM-19.so')

import numpy as np
import drjit as dr
import mitsuba as mi

mi.set_variant('llvm_ad_rgb')

from mitsuba import Float, UInt32, Bool, Vector3f, Color3f, Point3f, Ray3f  # noqa: E402

BUCKETS = ('direct', 'through', 'bounce1', 'bounce2', 'bounce1_lit')


EPS = 1e-3  # mm: a ray leaving a surface starts this far along its direction
SIGMA_T = 1.0  # mm⁻¹, the data set's wax (and the sidecar's sigma_t_per_mm)
# The light (set from the sidecar): a directional light's to-light vector, or a point light's
# position and intensity.
LIGHT = {}


@dr.syntax
def walk(scene, sampler, o, d, albedo, max_events):
    """One path per lane from a camera ray (o, d). Returns the four buckets' radiance."""
    out0, out1, out2, out3, out4 = Color3f(0.0), Color3f(0.0), Color3f(0.0), Color3f(0.0), Color3f(0.0)
    emitter_lit = Bool(False)
    si = scene.ray_intersect(Ray3f(o, d))
    active = Bool(si.is_valid())
    pos = Point3f(si.p)
    direction = Vector3f(d)
    beta = Color3f(1.0)
    reentries = UInt32(0)
    events = UInt32(0)
    inside = Bool(True)
    while dr.hint(active, include=[sampler]):
        hit = scene.ray_intersect(Ray3f(pos + direction * EPS, direction))
        if inside:
            t = -dr.log(1.0 - sampler.next_1d()) / SIGMA_T
            if t < hit.t:
                x = Point3f(pos + direction * (t + EPS))
                beta *= albedo
                # Next-event estimation: optical length inside the object toward the light and
                # how many boundaries the light's ray crosses.
                is_point = Bool(LIGHT['point'] is not None)
                lp = Point3f(LIGHT['point'] or [0.0, 0.0, 0.0])
                to_l = dr.select(is_point, dr.normalize(lp - x),
                                 Vector3f(LIGHT['to_light'] or [0.0, 0.0, 1.0]))
                dist = dr.select(is_point, dr.norm(lp - x), dr.inf)
                e = dr.select(is_point, LIGHT.get('intensity', 1.0) / dr.square(dist), 1.0)
                length = Float(0.0)
                crossings = UInt32(0)
                sp = Point3f(x)
                travelled = Float(0.0)
                s_in = Bool(True)
                s_active = Bool(True)
                while s_active:
                    sh = scene.ray_intersect(Ray3f(sp, to_l))
                    reach = sh.is_valid() & (travelled + sh.t < dist)
                    seg = dr.select(reach, sh.t, 0.0)
                    length += dr.select(s_in, seg, 0.0)
                    crossings += dr.select(reach, 1, 0)
                    travelled += dr.select(reach, sh.t + EPS, 0.0)
                    sp = Point3f(dr.select(reach, sh.p + to_l * EPS, sp))
                    s_in = s_in ^ reach
                    s_active = reach & (crossings < 32)
                c = beta * e * dr.exp(-SIGMA_T * length) / (4.0 * dr.pi)
                out0 += dr.select((reentries == 0) & (crossings <= 1), c, 0.0)
                out1 += dr.select((reentries == 0) & (crossings > 1), c, 0.0)
                out2 += dr.select(reentries == 1, c, 0.0)
                out3 += dr.select(reentries > 1, c, 0.0)
                out4 += dr.select((reentries == 1) & emitter_lit, c, 0.0)
                # Isotropic phase function.
                u = sampler.next_2d()
                z = 1.0 - 2.0 * u.x
                r = dr.safe_sqrt(1.0 - z * z)
                ph = 2.0 * dr.pi * u.y
                direction = Vector3f(r * dr.cos(ph), r * dr.sin(ph), z)
                pos = Point3f(x - direction * EPS)
                events += 1
                active = events < max_events
            else:
                pos = hit.p
                inside = Bool(False)
                active = hit.is_valid()
        else:
            active = hit.is_valid()
            pos = hit.p
            inside = Bool(True)
            reentries += 1
            if reentries == 1:
                # Is the emitter (this re-entry point) on the light's first surface?
                is_point = Bool(LIGHT['point'] is not None)
                lp = Point3f(LIGHT['point'] or [0.0, 0.0, 0.0])
                to_l = dr.select(is_point, dr.normalize(lp - pos),
                                 Vector3f(LIGHT['to_light'] or [0.0, 0.0, 1.0]))
                dist = dr.select(is_point, dr.norm(lp - pos), dr.inf)
                facing = dr.dot(hit.n, to_l) > 0.0
                shadow = Ray3f(pos + hit.n * EPS, to_l)
                shadow.maxt = dist
                emitter_lit = facing & ~scene.ray_test(shadow)
    return out0, out1, out2, out3, out4


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('sidecar')
    ap.add_argument('obj')
    ap.add_argument('--size', type=int, default=128)
    ap.add_argument('--spp', type=int, default=64)
    ap.add_argument('--pass-spp', type=int, default=4)
    ap.add_argument('--max-events', type=int, default=4096)
    ap.add_argument('--seed', type=int, default=7)
    ap.add_argument('--channel', type=int, choices=(0, 1, 2),
                    help="a medium of per-channel sigma_t (Skin1): trace this channel's sigma_t and "
                         "albedo in all three (read that channel of the output)")
    ap.add_argument('--out', required=True)
    a = ap.parse_args()
    meta = json.load(open(a.sidecar))
    cam = meta['camera']
    half = cam['ortho_half_extent_mm']
    right = np.array(cam.get('image_right_world', [1.0, 0.0, 0.0]))
    up = np.array(cam.get('image_up_world', [0.0, 1.0, 0.0]))
    to_cam = np.array(cam['vector_to_camera_V'])
    look = np.array(cam['look_at_mm'])
    global SIGMA_T
    mat = meta['material']
    albedo = Color3f(*mat['albedo'])
    sigma_t = mat.get('sigma_t_per_mm', SIGMA_T)
    if isinstance(sigma_t, list) and len(set(sigma_t)) == 1:
        SIGMA_T = float(sigma_t[0])
    elif isinstance(sigma_t, list):
        if a.channel is None:
            ap.error('the sidecar has a sigma_t per channel: name one with --channel')
        SIGMA_T = float(mat['sigma_t_per_mm'][a.channel])
        albedo = Color3f(float(mat['albedo'][a.channel]))
    lt = meta['light']
    if 'position_mm' in lt:
        LIGHT.update(point=lt['position_mm'], intensity=lt['intensity_rgb'][0], to_light=None)
    else:
        LIGHT.update(point=None, to_light=lt['vector_to_light_L'])
    if a.obj.startswith('sphere:'):
        shape = {'type': 'sphere', 'radius': float(a.obj.split(':')[1])}
    else:
        shape = {'type': 'obj', 'filename': a.obj}
    shape['bsdf'] = {'type': 'null'}
    scene = mi.load_dict({'type': 'scene', 'shape': shape})
    n = a.size
    mm_per_px = 2 * half / n
    acc = np.zeros((len(BUCKETS), n, n, 3))
    cover = np.zeros((n, n))
    sampler = mi.load_dict({'type': 'independent'})
    passes = max(1, a.spp // a.pass_spp)
    t0 = time.time()
    for p in range(passes):
        lanes = n * n * a.pass_spp
        sampler.seed(a.seed + p, lanes)
        idx = dr.arange(UInt32, lanes) // a.pass_spp
        i = Float(idx % n)
        j = Float(idx // n)
        jit = sampler.next_2d()
        x = (i + jit.x - n / 2) * mm_per_px
        y = (n / 2 - j - jit.y) * mm_per_px
        o = Point3f(*[float(look[k]) + x * float(right[k]) + y * float(up[k]) + 1000.0 * float(to_cam[k]) for k in range(3)])
        d = Vector3f(*[float(-v) for v in to_cam])
        hit = scene.ray_intersect(Ray3f(o, d)).is_valid()
        res = walk(scene, sampler, o, d, albedo, a.max_events)
        for b, r in enumerate(res):
            arr = np.array(r)  # (3, lanes)
            arr = arr.T.reshape(n, n, a.pass_spp, 3).mean(axis=2)
            acc[b] += arr
        cover += np.array(hit, dtype=np.float64).reshape(n, n, a.pass_spp).mean(axis=2)
        print(f'pass {p + 1}/{passes} {time.time() - t0:.0f}s', flush=True)
    acc /= passes
    cover /= passes
    np.savez_compressed(a.out, coverage=cover.astype(np.float32),
                        **{b: acc[k].astype(np.float32) for k, b in enumerate(BUCKETS)})
    total = acc.sum(axis=(1, 2, 3))
    print('total per bucket', dict(zip(BUCKETS, (total / total.sum()).round(4))))


if __name__ == '__main__':
    main()
