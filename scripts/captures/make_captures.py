#!/usr/bin/env python3
"""Path-traced "realistic captures" of wax spheres for cdrf-fit (data/captures/).

Two stages:

  render   : Mitsuba 3 (llvm_ad_rgb, volpath, max_depth = rr_depth = 2048, i.e. no Russian
             roulette, exactly the medium of data/wax-spheres) renders the studio scenes with a
             perspective camera and a point lamp into float EXRs + JSON truth sidecars under
             --work (default /work/refs/captures, outside the repo).  Rendering is done in
             passes with distinct seeds; the running sums are checkpointed after every pass
             (<name>_acc.npz) so a render can be stopped and resumed / extended (--spp).
  degrade  : a deterministic (seeded) numpy pipeline turns those renders into the data sets
             data/captures/{lamp,raw14,jpeg,multi}/ (PNG/JPEG + cdrf-dataset.toml + truth.json).
             Needs no re-render.

Conventions (camera space = world space here): camera at the origin looking along -z, +x image
right, +y image up, +z toward the viewer; millimetres.  Pinhole: a point (x, y, z), z < 0,
projects to continuous pixel coordinates (0,0 = top-left corner of the top-left pixel)
    u = W/2 + f * x / (-z),   v = H/2 - f * y / (-z),   f = (H/2) / tan(vfov/2).
Pixel (col i, row j) has its centre at (i + 0.5, j + 0.5).
Mitsuba itself gets the scene translated so that a wax sphere's centre is its origin (mi_origin,
render_tiles): its ray-spawn offset grows with the distance from the origin and would otherwise
darken the terminators by 9-24 %.  The images do not depend on this translation otherwise.

Usage (venv python; export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so):
  python make_captures.py check-camera   # camera convention + analytic labels vs Mitsuba shape-index AOV
  nice -n 10 python make_captures.py render --only single_r10 single_r20 single_matte --spp 256
  nice -n 10 python make_captures.py render --only single_r30 --spp 256
  nice -n 10 python make_captures.py render --only single_r50 --spp 192
  nice -n 10 python make_captures.py render --only multi --spp 128
  python make_captures.py check-flags    # flagged scenes: flag shadows cover every sphere, no flag over a disk
  nice -n 10 python make_captures.py render --only single_r10_flag single_r20_flag single_matte_flag --spp 256
  nice -n 10 python make_captures.py render --only single_r30_flag --spp 256
  nice -n 10 python make_captures.py render --only multi_flag --spp 32    # all five flagged (ratios only)
  nice -n 10 python make_captures.py render --only multi_flag_r50 --spp 64
  nice -n 10 python make_captures.py render --only multi_flag_r10 multi_flag_r20 multi_flag_r30 multi_flag_matte --spp 32
  nice -n 10 python make_captures.py render --only single_r50_flag --spp 192
  python make_captures.py degrade        # writes data/captures/{lamp,raw14,jpeg,multi}/
  python make_captures.py info           # scene geometry summary
Scenes: single_r10, single_r20, single_r30 (in the cup), single_r50, single_matte (calibration),
multi; and each one's flagged variant <name>_flag (the same scene plus one black flag per sphere
between the lamp and the sphere: no direct lamp light on any sphere, the room's bounce light
remains; degrade writes it as <stem>_flag.<ext>, the manifests' ambient_image).  multi also has
multi_flag_<r50|r10|r20|r30|matte>: only THAT sphere's flag (the other four stay lit, so their glow on
it is kept); these are multi/'s ambient_images (one per entry); multi_flag is kept for the ratios.  The single-sphere photographs share one camera and one lamp (the manifest format has one
[camera] and one [light] per data set): each sphere in turn sits on the same spot.
"""
import os
import sys
import json
import time
import argparse
import platform

os.environ.setdefault('DRJIT_LIBLLVM_PATH', '/usr/lib/x86_64-linux-gnu/libLLVM-19.so')

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.abspath(os.path.join(HERE, '..', '..'))
DEFAULT_WORK = '/work/refs/captures'
DEFAULT_OUT = os.path.join(REPO, 'data', 'captures')

# ---------------------------------------------------------------------------------------------
# Materials (identical to /work/shared/gt/render_gt3.py MATERIALS['wax'], boundary 'null')
# ---------------------------------------------------------------------------------------------
WAX = {'sigma_t': 1.0, 'albedo': [0.997, 0.993, 0.985]}
MATTE_ALBEDO = 0.5
POST_REFL = 0.02      # black posts / cup
TABLE_REFL = 0.03     # black velvet
WALL_REFL = 0.2       # grey background wall
LAMP_I = 1.0e6        # point lamp intensity per channel: irradiance 1.0 at 1000 mm
MAX_DEPTH = 2048

POST_R = 3.0
TABLE_DROP = 80.0     # table 80 mm below the lowest sphere bottom
WALL_BEHIND = 1500.0  # wall 1.5 m behind the spheres

# residual highlight (imperfect cross-polarisation) for raw14 / jpeg / multi
HL_FRACTION = 0.04
HL_ETA = 1.5
HL_ALPHA = 0.1        # Beckmann roughness


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def focal_px(H, vfov_deg):
    return (H / 2.0) / np.tan(np.radians(vfov_deg) / 2.0)


# ---------------------------------------------------------------------------------------------
# Scene definitions
# ---------------------------------------------------------------------------------------------
SINGLE_W, SINGLE_H = 640, 480
SINGLE_D = 1000.0
SINGLE_R50_PX = 190.0     # on-axis disk radius of the r = 50 sphere -> the common fov


def single_setup():
    """The single-sphere studio (one camera, one lamp for all photographs, as the manifest format
    has one [camera] and one [light] per data set): every sphere is put on the same spot, ~1 m
    from the camera, its centre projected at 27 % of the half-width right and 10 % of the
    half-height up of the frame; fixed zoom so the r = 50 sphere's disk radius is ~190 px (r = 10:
    ~38 px); lamp 1 m from the spot, from the image's left, slightly above and in front."""
    W, H, D = SINGLE_W, SINGLE_H, SINGLE_D
    f = SINGLE_R50_PX * np.sqrt(D * D - 50.0 ** 2) / 50.0
    vfov = float(np.round(np.degrees(2 * np.arctan((H / 2) / f)), 4))
    f = focal_px(H, vfov)
    u0, v0 = W / 2 + 0.27 * W / 2, H / 2 - 0.10 * H / 2
    c = D * unit([(u0 - W / 2) / f, -(v0 - H / 2) / f, -1.0])
    lamp = c + 1000.0 * unit([-1.0, 0.15, 0.1])
    return {'W': W, 'H': H, 'vfov_deg': vfov, 'center_mm': c, 'lamp_mm': lamp,
            'table_y_mm': float(c[1] - 50.0 - TABLE_DROP), 'wall_z_mm': float(c[2] - WALL_BEHIND)}


def single_scene(name, r, material, support):
    st = single_setup()
    sph = {'name': name, 'radius_mm': float(r), 'center_mm': st['center_mm'].tolist(),
           'material': material, 'support': support}
    return {'name': name, 'W': st['W'], 'H': st['H'], 'vfov_deg': st['vfov_deg'], 'spheres': [sph],
            'lamp_mm': st['lamp_mm'].tolist(), 'lamp_intensity': LAMP_I,
            'table_y_mm': st['table_y_mm'], 'wall_z_mm': st['wall_z_mm']}


def multi_scene():
    W, H = 1400, 600
    D = 1000.0
    r50px = 160.0
    f = r50px * np.sqrt(D * D - 50.0 ** 2) / 50.0
    vfov = float(np.round(np.degrees(2 * np.arctan((H / 2) / f)), 4))
    order = [(50.0, 'wax'), (10.0, 'wax'), (25.0, 'matte'), (20.0, 'wax'), (30.0, 'wax')]
    gap = 30.0
    xs, x = [], 0.0
    for k, (r, m) in enumerate(order):
        if k:
            x += order[k - 1][0] + gap + r
        xs.append(x)
    xs = np.array(xs) - (xs[0] - order[0][0] + xs[-1] + order[-1][0]) / 2
    yc, zc = -10.0, -D
    spheres = []
    for (r, m), xx in zip(order, xs):
        nm = f'wax_r{int(r)}' if m == 'wax' else 'matte_r25'
        spheres.append({'name': nm, 'radius_mm': r, 'center_mm': [float(xx), yc, zc],
                        'material': m, 'support': 'post'})
    centre = np.array([0.0, yc, zc])
    lamp = centre + 1500.0 * unit(MULTI_LAMP_DIR)
    return {'name': 'multi', 'W': W, 'H': H, 'vfov_deg': vfov, 'spheres': spheres,
            'lamp_mm': lamp.tolist(), 'lamp_intensity': LAMP_I,
            'table_y_mm': float(yc - 50.0 - TABLE_DROP), 'wall_z_mm': float(zc - WALL_BEHIND)}


MULTI_LAMP_DIR = [-0.9, 0.7, 0.7]   # from the row's centre: left, above, in front


def all_scenes():
    s = {}
    for r in (10, 20, 50):
        s[f'single_r{r}'] = single_scene(f'wax_r{r}', float(r), 'wax', 'post')
    s['single_r30'] = single_scene('wax_r30', 30.0, 'wax', 'cup')
    # calibration: matte r=25 on the same spot, same camera, lamp and table
    s['single_matte'] = single_scene('matte_r25', 25.0, 'matte', 'post')
    s['multi'] = multi_scene()
    for n in list(s):
        s[n + '_flag'] = flag_scene(s[n])
    # multi: one flagged frame per sphere, with ONLY that sphere's flag (the same flag as in
    # multi_flag; the other four spheres stay lit, so their glow on the flagged sphere is kept)
    for sph in s['multi']['spheres']:
        short = MULTI_FLAG_SHORT[sph['name']]
        one = json.loads(json.dumps(s['multi_flag']))
        one['name'] = 'multi_flag_' + short
        one['flags'] = [fl for fl in one['flags'] if fl['of'] == sph['name']]
        assert len(one['flags']) == 1
        s['multi_flag_' + short] = one
    return s


# multi sphere name -> suffix of its own flagged frame multi_flag_<suffix>
MULTI_FLAG_SHORT = {'wax_r50': 'r50', 'wax_r10': 'r10', 'wax_r20': 'r20', 'wax_r30': 'r30',
                    'matte_r25': 'matte'}


# ---------------------------------------------------------------------------------------------
# Flagged frames: the same shot with an opaque black card ("flag") between the lamp and EACH
# sphere, so the lamp's direct light no longer reaches any sphere; the room's bounce light still
# does.  cdrf-fit subtracts this frame pixel by pixel (manifest key ambient_image).
# ---------------------------------------------------------------------------------------------
FLAG_REFL = 0.02          # black card, both sides (twosided diffuse)
FLAG_DIST = 150.0         # flag centre: this far from the sphere centre toward the lamp
FLAG_MARGIN = 1.10        # flag half-angle seen from the lamp >= 1.1 * asin(r / D)
FLAG_STEP = 25.0          # if a flag is seen over a sphere's disk: move it this much toward the lamp


def flag_for(sc, s, dist):
    L = np.array(sc['lamp_mm'])
    c = np.array(s['center_mm'])
    D = float(np.linalg.norm(L - c))
    u = (L - c) / D
    half = FLAG_MARGIN * np.arcsin(s['radius_mm'] / D)
    rho = (D - dist) * np.tan(half)
    return {'of': s['name'], 'center_mm': (c + dist * u).tolist(), 'normal': u.tolist(),
            'radius_mm': float(rho), 'distance_from_sphere_center_mm': float(dist),
            'distance_from_lamp_mm': float(D - dist),
            'half_angle_from_lamp_deg': float(np.degrees(half)),
            'sphere_half_angle_from_lamp_deg': float(np.degrees(np.arcsin(s['radius_mm'] / D))),
            'bsdf': f'twosided diffuse {FLAG_REFL}'}


def hit_disk(o, d, fl):
    """t of o + t d with the (two-sided) flag disk, inf if none."""
    n = np.array(fl['normal'])
    c = np.array(fl['center_mm'])
    dn = d @ n
    with np.errstate(divide='ignore', invalid='ignore'):
        t = ((c - o) @ n) / dn
    P = o + t[..., None] * d
    r2 = np.einsum('...i,...i', P - c, P - c)
    ok = np.isfinite(t) & (t > 1e-6) & (r2 <= fl['radius_mm'] ** 2)
    return np.where(ok, t, np.inf)


def flags_over_disks(sc, flags, sub=4, chunk=32):
    """Number of pixel subsamples (sub x sub per pixel) that see a sphere's disk but hit a flag
    in front of it (must be 0), per flag; also counts where the flag is anywhere over the disk
    (in front or behind) and the flags' total visible subsamples in the frame."""
    H = sc['H']
    front = np.zeros(len(flags), int)
    vis = np.zeros(len(flags), int)
    for r0 in range(0, H, chunk):
        rows = np.arange(r0, min(H, r0 + chunk))
        dirs, _ = pixel_rays(sc, rows, sub)
        dirs = dirs.reshape(-1, 3)
        ts = np.stack([hit_sphere(np.zeros(3), dirs, np.array(s['center_mm']), s['radius_mm'])
                       for s in sc['spheres']], -1).min(-1)
        tf = np.stack([hit_disk(np.zeros(3), dirs, fl) for fl in flags], -1)
        for j in range(len(flags)):
            front[j] += int((np.isfinite(ts) & (tf[:, j] < ts)).sum())
            vis[j] += int((np.isfinite(tf[:, j]) & (tf[:, j] <= tf.min(-1)) & (tf[:, j] < ts)).sum())
    return front, vis


def flag_scene(sc):
    """The scene of sc plus one flag per sphere (see FLAG_*): a thin black disk facing the lamp,
    centred on the lamp -> sphere-centre line FLAG_DIST from the centre, radius such that its
    shadow (point lamp) covers the sphere with a 10 % angular margin.  A flag seen (by any 4x4
    pixel subsample) in front of any sphere's disk is moved FLAG_STEP toward the lamp (and
    enlarged to keep its angular size) until none is."""
    out = json.loads(json.dumps(sc))
    out['name'] = sc['name'] + '_flag'
    dist = {s['name']: FLAG_DIST for s in sc['spheres']}
    for _ in range(40):
        flags = [flag_for(sc, s, dist[s['name']]) for s in sc['spheres']]
        front, _ = flags_over_disks(sc, flags, sub=2)
        if not front.any():
            break
        for fl, n in zip(flags, front):
            if n:
                dist[fl['of']] += FLAG_STEP
    else:
        raise RuntimeError('could not place the flags')
    out['flags'] = flags
    return out


def check_flags(scenes, only=None):
    """Print the flags of every _flag scene with the analytic checks: each sphere entirely in its
    flag's shadow (max crossing offset / flag radius < 1), no flag in front of any sphere's disk
    (4x4 subsamples per pixel), the flags' visible subsamples elsewhere in the frame."""
    ok = True
    for n, sc in scenes.items():
        if not n.endswith('_flag') or (only and n not in only):
            continue
        sh = flag_shadow_check(sc)
        front, vis = flags_over_disks(sc, sc['flags'], sub=4)
        print(n)
        for fl, fr, v in zip(sc['flags'], front, vis):
            print(f'  flag of {fl["of"]}: centre {np.round(fl["center_mm"], 1).tolist()} radius '
                  f'{fl["radius_mm"]:.2f} mm, {fl["distance_from_sphere_center_mm"]:.0f} mm from the centre, '
                  f'{fl["distance_from_lamp_mm"]:.0f} mm from the lamp, half-angle '
                  f'{fl["half_angle_from_lamp_deg"]:.4f} deg (sphere {fl["sphere_half_angle_from_lamp_deg"]:.4f}); '
                  f'shadow max offset/radius {sh[fl["of"]]:.4f}; subsamples in front of a sphere disk {fr}; '
                  f'visible in the frame {v / 16:.0f} px')
            ok &= sh[fl['of']] < 1 and fr == 0
    print('flag check', 'OK' if ok else 'FAILED')


def flag_shadow_check(sc, n_pts=20000):
    """Analytic: for every sphere, n_pts points spread over its WHOLE surface (Fibonacci) plus
    its lamp-facing pole: the segment point -> lamp must cross that sphere's flag disk.  Returns
    per sphere the largest (radial offset of the crossing / flag radius) (< 1: fully shadowed)."""
    L = np.array(sc['lamp_mm'])
    k = np.arange(n_pts) + 0.5
    z = 1 - 2 * k / n_pts
    ph = np.pi * (1 + 5 ** 0.5) * k
    U = np.stack([np.sqrt(1 - z * z) * np.cos(ph), np.sqrt(1 - z * z) * np.sin(ph), z], -1)
    res = {}
    for s in sc['spheres']:
        fls = [f for f in sc['flags'] if f['of'] == s['name']]
        if not fls:                         # per-sphere flagged frame: the other spheres stay lit
            continue
        fl = fls[0]
        c = np.array(s['center_mm'])
        pts = np.concatenate([c + s['radius_mm'] * U, (c + s['radius_mm'] * unit(L - c))[None]])
        d = L - pts
        t = hit_disk(pts, d, dict(fl, radius_mm=1e9))
        assert np.all(t < 1), 'flag plane not between sphere and lamp'
        P = pts + t[:, None] * d
        off = np.linalg.norm(P - np.array(fl['center_mm']), axis=1)
        # any OTHER flag crossing is fine too, but each sphere's own flag must suffice
        res[s['name']] = float(off.max() / fl['radius_mm'])
    return res


def cup_geometry(sph):
    """Open black cup (tube) of radius 0.55 r and height 0.35 r around the sphere's bottom: the
    sphere rests on its rim (the rim circle touches the sphere), closed by a bottom disk."""
    r = sph['radius_mm']
    c = np.array(sph['center_mm'])
    rc = 0.55 * r
    h = 0.35 * r
    y_rim = c[1] - np.sqrt(r * r - rc * rc)      # sphere's horizontal radius = rc here
    return {'radius_mm': rc, 'y_top_mm': float(y_rim), 'y_bottom_mm': float(y_rim - h),
            'axis_xz_mm': [float(c[0]), float(c[2])]}


def scene_occluders(sc):
    """Vertical cylinders (posts, cups) as dicts: axis (x, z), radius, y range."""
    cyl = []
    for s in sc['spheres']:
        c = np.array(s['center_mm'])
        r = s['radius_mm']
        if s['support'] == 'cup':
            cg = cup_geometry(s)
            cyl.append({'kind': 'cup', 'of': s['name'], 'x': c[0], 'z': c[2], 'r': cg['radius_mm'],
                        'y0': cg['y_bottom_mm'], 'y1': cg['y_top_mm']})
            cyl.append({'kind': 'post', 'of': s['name'], 'x': c[0], 'z': c[2], 'r': POST_R,
                        'y0': sc['table_y_mm'], 'y1': cg['y_bottom_mm']})
        else:
            cyl.append({'kind': 'post', 'of': s['name'], 'x': c[0], 'z': c[2], 'r': POST_R,
                        'y0': sc['table_y_mm'], 'y1': c[1] - r})
    return cyl


# ---------------------------------------------------------------------------------------------
# Mitsuba scene
# ---------------------------------------------------------------------------------------------
def mi_rgb(v):
    return {'type': 'rgb', 'value': [float(t) for t in v]}


def mi_origin(sc):
    """The world point put at Mitsuba's origin: the mean of the sphere centres (a single sphere's
    centre).  Mitsuba moves every ray it spawns from a surface (1 + max|p|) * 1500 * 2^-24 scene
    units along the normal (Interaction::offset_p, math::RayEpsilon), p in world coordinates:
    0.09 mm at 1 m from the origin.  At a wax sphere's null boundary the camera ray therefore starts
    0.09 mm inside the wax and misses the thin grazing-lit layer that carries the terminator's
    light (85-90 deg: -13 % at r = 20 mm, -24 % at r = 50 mm).  Rendering the scene translated by
    -mi_origin(sc) leaves the image unchanged otherwise (camera space = world space everywhere
    else in this script)."""
    return np.mean([np.asarray(s['center_mm'], float) for s in sc['spheres']], axis=0)


def render_tiles(sc):
    """How the frame is rendered: a partition of it into rectangles (x0, y0, w, h) (pixels), each
    rendered (hdrfilm crop) with its own Mitsuba origin (world mm), as dicts.  One sphere: the whole
    frame, origin at the sphere centre (mi_origin).  Several spheres (multi*): they sit up to
    ~210 mm from the row's centre, which would leave a 0.01-0.02 mm entry offset (about -8 % at
    85-90 deg for r = 50, see mi_origin), so each WAX sphere's rectangle (bounding box of its
    projected disk + TILE_MARGIN px) is rendered with the origin at THAT sphere's centre, and the
    rest of the frame (above / below those boxes and the columns between them, matte sphere
    included) with the origin at the row's centre (mi_origin).  Every pixel is rendered once, so
    this costs no more than one full frame.  Tile t uses the seeds base + TILE_SEED_STRIDE*t + pass
    (tile 0 = the plain seeds; no two tiles of a pass share a seed)."""
    W, H = sc['W'], sc['H']
    row = mi_origin(sc).tolist()
    if len(sc['spheres']) == 1:
        return [{'x0': 0, 'y0': 0, 'w': W, 'h': H, 'origin_mm': row, 'what': 'frame'}]
    boxes = []
    for s in sc['spheres']:
        if s['material'] != 'wax':
            continue
        e = projected_ellipse(sc, s)
        a, b = e['semi_major_px'], e['semi_minor_px']
        phi = np.radians(e['major_axis_angle_deg'])
        hw = np.sqrt((a * np.cos(phi)) ** 2 + (b * np.sin(phi)) ** 2)
        hh = np.sqrt((a * np.sin(phi)) ** 2 + (b * np.cos(phi)) ** 2)
        cx, cy = e['ellipse_center_px']
        x0, x1 = max(0, int(np.floor(cx - hw)) - TILE_MARGIN), min(W, int(np.ceil(cx + hw)) + TILE_MARGIN)
        y0, y1 = max(0, int(np.floor(cy - hh)) - TILE_MARGIN), min(H, int(np.ceil(cy + hh)) + TILE_MARGIN)
        boxes.append((x0, x1, y0, y1, s))
    boxes.sort(key=lambda t: t[0])
    tiles, cur = [], 0
    for x0, x1, y0, y1, s in boxes:
        assert x0 >= cur, 'sphere boxes overlap in x'
        if x0 > cur:
            tiles.append({'x0': cur, 'y0': 0, 'w': x0 - cur, 'h': H, 'origin_mm': row, 'what': 'row'})
        if y0 > 0:
            tiles.append({'x0': x0, 'y0': 0, 'w': x1 - x0, 'h': y0, 'origin_mm': row, 'what': 'row'})
        tiles.append({'x0': x0, 'y0': y0, 'w': x1 - x0, 'h': y1 - y0,
                      'origin_mm': [float(t) for t in s['center_mm']], 'what': s['name']})
        if y1 < H:
            tiles.append({'x0': x0, 'y0': y1, 'w': x1 - x0, 'h': H - y1, 'origin_mm': row, 'what': 'row'})
        cur = x1
    if cur < W:
        tiles.append({'x0': cur, 'y0': 0, 'w': W - cur, 'h': H, 'origin_mm': row, 'what': 'row'})
    assert sum(t['w'] * t['h'] for t in tiles) == W * H
    return tiles


TILE_MARGIN = 4             # px around a wax sphere's projected disk (render_tiles)
TILE_SEED_STRIDE = 100000   # tile t of a pass: seed base + TILE_SEED_STRIDE * t + pass


def build_mi_scene(sc, spp_pass, integrator=None, sampler=None, origin=None, tile=None):
    """The Mitsuba scene dict, translated by -origin (default mi_origin(sc)); tile: render only
    that rectangle of the frame (see render_tiles)."""
    import mitsuba as mi
    T = mi.ScalarTransform4f
    o = mi_origin(sc) if origin is None else np.asarray(origin, float)

    def P(p):                      # world (camera) mm -> Mitsuba coordinates
        return (np.asarray(p, float) - o).tolist()

    d = {'type': 'scene'}
    d['integrator'] = integrator or {'type': 'volpath', 'max_depth': MAX_DEPTH,
                                     'rr_depth': MAX_DEPTH}
    d['sensor'] = {
        'type': 'perspective', 'fov_axis': 'y', 'fov': float(sc['vfov_deg']),
        'near_clip': 1.0, 'far_clip': 20000.0,
        'to_world': T().look_at(origin=P([0, 0, 0]), target=P([0, 0, -1]), up=[0, 1, 0]),
        'film': {'type': 'hdrfilm', 'width': sc['W'], 'height': sc['H'],
                 'rfilter': {'type': 'box'}, 'pixel_format': 'rgb',
                 'component_format': 'float32'},
        'sampler': sampler or {'type': 'independent', 'sample_count': spp_pass},
    }
    if tile is not None and (tile['w'], tile['h']) != (sc['W'], sc['H']):
        d['sensor']['film'].update({'crop_offset_x': tile['x0'], 'crop_offset_y': tile['y0'],
                                    'crop_width': tile['w'], 'crop_height': tile['h']})
    I = float(sc['lamp_intensity'])
    d['lamp'] = {'type': 'point', 'position': P(sc['lamp_mm']),
                 'intensity': mi_rgb([I, I, I])}
    black = {'type': 'diffuse', 'reflectance': mi_rgb([POST_REFL] * 3)}
    for s in sc['spheres']:
        shape = {'type': 'sphere', 'center': P(s['center_mm']),
                 'radius': float(s['radius_mm'])}
        if s['material'] == 'wax':
            shape['bsdf'] = {'type': 'null'}
            shape['interior'] = {'type': 'homogeneous', 'sigma_t': WAX['sigma_t'],
                                 'albedo': mi_rgb(WAX['albedo']),
                                 'phase': {'type': 'isotropic'}, 'scale': 1.0}
        else:
            shape['bsdf'] = {'type': 'diffuse', 'reflectance': mi_rgb([MATTE_ALBEDO] * 3)}
        d['sphere_' + s['name']] = shape
    for k, cy in enumerate(scene_occluders(sc)):
        d[f'cyl{k}_{cy["kind"]}'] = {'type': 'cylinder', 'p0': P([cy['x'], cy['y0'], cy['z']]),
                                     'p1': P([cy['x'], cy['y1'], cy['z']]), 'radius': cy['r'],
                                     'bsdf': black}
        if cy['kind'] == 'cup':   # bottom of the cup, facing up
            d[f'cyl{k}_cupbottom'] = {
                'type': 'disk', 'bsdf': black,
                'to_world': T().translate(P([cy['x'], cy['y0'], cy['z']])) @ T().rotate([1, 0, 0], -90)
                @ T().scale([cy['r'], cy['r'], 1])}
    for k, fl in enumerate(sc.get('flags', [])):
        c = fl['center_mm']
        n = np.array(fl['normal'])
        up = [0, 1, 0] if abs(n[1]) < 0.9 else [1, 0, 0]
        d[f'flag{k}_{fl["of"]}'] = {
            'type': 'disk',
            'bsdf': {'type': 'twosided', 'bsdf': {'type': 'diffuse', 'reflectance': mi_rgb([FLAG_REFL] * 3)}},
            'to_world': T().look_at(origin=P(c), target=P(np.array(c) + n), up=up)
            @ T().scale([fl['radius_mm'], fl['radius_mm'], 1])}
    zw = sc['wall_z_mm']
    # table: y = table_y, x in [-2500, 2500], z from the wall to 300 mm in front of the camera
    z_front = 300.0
    d['table'] = {'type': 'rectangle', 'bsdf': {'type': 'diffuse', 'reflectance': mi_rgb([TABLE_REFL] * 3)},
                  'to_world': T().translate(P([0, sc['table_y_mm'], (zw + z_front) / 2]))
                  @ T().rotate([1, 0, 0], -90) @ T().scale([2500, (z_front - zw) / 2, 1])}
    # wall: z = wall_z, facing +z, x in [-4000, 4000], y from the table to +3000
    y0, y1 = sc['table_y_mm'], 3000.0
    d['wall'] = {'type': 'rectangle', 'bsdf': {'type': 'diffuse', 'reflectance': mi_rgb([WALL_REFL] * 3)},
                 'to_world': T().translate(P([0, (y0 + y1) / 2, zw])) @ T().scale([4000, (y1 - y0) / 2, 1])}
    return d


# ---------------------------------------------------------------------------------------------
# Analytic geometry (numpy): rays, intersections, projected ellipses
# ---------------------------------------------------------------------------------------------
def pixel_rays(sc, rows, sub=1):
    """Unnormalised ray directions (N, 3) for pixel rows `rows` (array), sub x sub subsamples per
    pixel on a regular grid ((k + 0.5)/sub); sub = 1 -> pixel centres.  Returns (dirs, shape)."""
    W, H = sc['W'], sc['H']
    f = focal_px(H, sc['vfov_deg'])
    o = (np.arange(sub) + 0.5) / sub
    u = (np.arange(W)[:, None] + o[None, :]).reshape(-1)           # W*sub
    v = (np.asarray(rows)[:, None] + o[None, :]).reshape(-1)       # R*sub
    U, V = np.meshgrid(u, v)                                       # (R*sub, W*sub)
    X = (U - W / 2) / f
    Y = -(V - H / 2) / f
    dirs = np.stack([X, Y, -np.ones_like(X)], -1)
    return dirs, U.shape


def hit_sphere(o, d, c, r):
    """Nearest positive t of o + t d with the sphere, inf if none.  o: (3,) or (N,3)."""
    oc = o - c
    a = np.einsum('...i,...i', d, d)
    b = np.einsum('...i,...i', oc, d)
    cc = np.einsum('...i,...i', oc, oc) - r * r
    disc = b * b - a * cc
    sq = np.sqrt(np.maximum(disc, 0))
    t0 = (-b - sq) / a
    t1 = (-b + sq) / a
    t = np.where(t0 > 1e-6, t0, np.where(t1 > 1e-6, t1, np.inf))
    return np.where(disc >= 0, t, np.inf)


def hit_cylinder(o, d, cy):
    """Nearest positive t with an open vertical tube (both faces), inf if none."""
    ox = o[..., 0] - cy['x']
    oz = o[..., 2] - cy['z']
    dx, dz = d[..., 0], d[..., 2]
    a = dx * dx + dz * dz
    b = ox * dx + oz * dz
    c = ox * ox + oz * oz - cy['r'] ** 2
    disc = b * b - a * c
    sq = np.sqrt(np.maximum(disc, 0))
    a = np.where(a == 0, 1e-300, a)
    best = np.full(np.broadcast(ox, dx).shape, np.inf)
    for t in ((-b - sq) / a, (-b + sq) / a):
        y = o[..., 1] + t * d[..., 1]
        ok = (disc >= 0) & (t > 1e-6) & (y >= cy['y0']) & (y <= cy['y1'])
        best = np.where(ok & (t < best), t, best)
    return best


def first_hits(sc, dirs):
    """For camera rays dirs (N,3): index of the sphere hit first (-1: none / other) and its t,
    and whether a cylinder (post/cup) is hit first (-2)."""
    o = np.zeros(3)
    ts = np.stack([hit_sphere(o, dirs, np.array(s['center_mm']), s['radius_mm'])
                   for s in sc['spheres']], -1)
    idx = np.argmin(ts, -1)
    tmin = np.take_along_axis(ts, idx[..., None], -1)[..., 0]
    tcyl = np.full(tmin.shape, np.inf)
    for cy in scene_occluders(sc):
        tcyl = np.minimum(tcyl, hit_cylinder(o, dirs, cy))
    occl = tcyl < tmin
    idx = np.where(np.isfinite(tmin) & ~occl, idx, np.where(np.isfinite(tmin) & occl, -2, -1))
    return idx, tmin


def label_image(sc, sub=1, chunk=64):
    """Per pixel (sub = 1) or per subsample: index of the sphere seen unoccluded, -2 = sphere
    behind an occluder, -1 = no sphere."""
    H = sc['H']
    out = []
    for r0 in range(0, H, chunk):
        rows = np.arange(r0, min(H, r0 + chunk))
        dirs, shp = pixel_rays(sc, rows, sub)
        idx, _ = first_hits(sc, dirs.reshape(-1, 3))
        out.append(idx.reshape(shp))
    return np.concatenate(out, 0)


def projected_ellipse(sc, s):
    """Exact image of the sphere (perspective): the conic p^T Q p >= 0 (p = (u, v, 1), pixel
    coords), its centre, semi-axes and orientation; plus the projection of the sphere centre."""
    W, H = sc['W'], sc['H']
    f = focal_px(H, sc['vfov_deg'])
    c = np.array(s['center_mm'])
    r = s['radius_mm']
    M = np.outer(c, c) - (c @ c - r * r) * np.eye(3)
    A = np.array([[1 / f, 0, -W / 2 / f], [0, -1 / f, H / 2 / f], [0, 0, -1.0]])
    Q = A.T @ M @ A
    B = Q[:2, :2]
    p0 = np.linalg.solve(B, -Q[:2, 2])
    k = np.array([*p0, 1.0]) @ Q @ np.array([*p0, 1.0])
    lam, vec = np.linalg.eigh(B)          # both negative (ellipse)
    axes = np.sqrt(k / -lam)              # eigh: ascending lam -> lam[0] most negative -> minor
    major = axes.argmax()
    ang = np.degrees(np.arctan2(vec[1, major], vec[0, major]))
    ang = (ang + 90) % 180 - 90
    cp = [W / 2 + f * c[0] / -c[2], H / 2 - f * c[1] / -c[2]]
    return {'ellipse_center_px': p0.tolist(),
            'semi_major_px': float(axes.max()), 'semi_minor_px': float(axes.min()),
            'major_axis_angle_deg': float(ang),
            'major_axis_angle_note': 'angle of the major axis from the +column axis toward +row (image rows go down)',
            'projected_sphere_center_px': cp,
            'equivalent_radius_px': float(np.sqrt(axes.prod())),
            'conic_Q_px': (Q / np.abs(Q).max()).tolist(),
            'conic_note': 'pixel (u, v) (continuous, 0,0 = top-left corner) sees the sphere iff '
                          '[u v 1] Q [u v 1]^T >= 0'}


def sphere_normals(sc, s, sub=1):
    """Per pixel centre: hit point and normal on sphere s (nan where the ray misses it)."""
    H = sc['H']
    dirs, shp = pixel_rays(sc, np.arange(H), sub)
    dirs = dirs.reshape(-1, 3)
    c = np.array(s['center_mm'])
    t = hit_sphere(np.zeros(3), dirs, c, s['radius_mm'])
    P = dirs * t[:, None]
    N = (P - c) / s['radius_mm']
    return P.reshape(*shp, 3), N.reshape(*shp, 3)


def sphere_angles(sc, s):
    """Per pixel centre on sphere s: theta to the lamp (degrees), its cosine, the squared
    distance to the lamp, and the mask of pixels at least ~1.5 px inside the silhouette
    (cos(view) > sqrt(2 * 1.5 / R_px)); nan / False where the ray misses the sphere."""
    P, N = sphere_normals(sc, s)
    Lv = np.array(sc['lamp_mm']) - P
    d2 = np.einsum('...i,...i', Lv, Lv)
    cth = np.einsum('...i,...i', N, Lv) / np.sqrt(d2)
    cosv = np.einsum('...i,...i', N, -P / np.linalg.norm(P, axis=-1, keepdims=True))
    inner = cosv > np.sqrt(2 * 1.5 / projected_ellipse(sc, s)['equivalent_radius_px'])
    return np.degrees(np.arccos(np.clip(cth, -1, 1))), cth, d2, inner


# ---------------------------------------------------------------------------------------------
# Residual highlight (analytic, box-filtered over sub x sub subsamples per pixel)
# ---------------------------------------------------------------------------------------------
def fresnel_dielectric(cos_i, eta):
    cos_i = np.clip(cos_i, 0, 1)
    sin_t2 = (1 - cos_i ** 2) / eta ** 2
    cos_t = np.sqrt(np.maximum(0, 1 - sin_t2))
    rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    return 0.5 * (rs ** 2 + rp ** 2)


def beckmann_D(cos_h, alpha):
    c2 = np.clip(cos_h, 1e-9, 1) ** 2
    tan2 = (1 - c2) / c2
    return np.exp(-tan2 / alpha ** 2) / (np.pi * alpha ** 2 * c2 * c2)


def smith_G1_beckmann(cos_t, alpha):
    from math import erf
    verf = np.vectorize(erf)
    cos_t = np.clip(cos_t, 1e-9, 1)
    tan_t = np.sqrt(1 - cos_t ** 2) / cos_t
    a = 1.0 / (alpha * np.maximum(tan_t, 1e-12))
    lam = (verf(a) - 1) / 2 + np.exp(-a * a) / (2 * a * np.sqrt(np.pi))
    return np.where(a > 8, 1.0, 1.0 / (1.0 + lam))


def highlight_image(sc, sub=4, chunk=32):
    """Radiance of the first-surface reflection of the point lamp on every WAX sphere (rough
    dielectric eta 1.5, Beckmann alpha 0.1, Cook-Torrance with Smith G), pixel-box-filtered with
    sub x sub subsamples; occlusion of the view ray and of the light ray by spheres, posts and cups
    is exact.  Returned unscaled (multiply by HL_FRACTION)."""
    W, H = sc['W'], sc['H']
    lamp = np.array(sc['lamp_mm'])
    I = sc['lamp_intensity']
    occ = scene_occluders(sc)
    out = np.zeros((H, W))
    for r0 in range(0, H, chunk):
        rows = np.arange(r0, min(H, r0 + chunk))
        dirs, shp = pixel_rays(sc, rows, sub)
        dirs = dirs.reshape(-1, 3)
        idx, t = first_hits(sc, dirs)
        val = np.zeros(len(dirs))
        for k, s in enumerate(sc['spheres']):
            if s['material'] != 'wax':
                continue
            sel = np.nonzero(idx == k)[0]
            if len(sel) == 0:
                continue
            dv = dirs[sel]
            P = dv * t[sel, None]
            c = np.array(s['center_mm'])
            N = (P - c) / s['radius_mm']
            Vv = -dv / np.linalg.norm(dv, axis=1, keepdims=True)
            Lv = lamp - P
            dist = np.linalg.norm(Lv, axis=1)
            Lv /= dist[:, None]
            cos_i = np.einsum('ij,ij->i', N, Lv)
            cos_o = np.einsum('ij,ij->i', N, Vv)
            ok = (cos_i > 0) & (cos_o > 0)
            # shadow rays toward the lamp (other spheres, posts, cups)
            Po = P + 1e-4 * N
            for j, s2 in enumerate(sc['spheres']):
                if j == k:
                    continue
                ts = hit_sphere(Po, Lv, np.array(s2['center_mm']), s2['radius_mm'])
                ok &= ~(ts < dist)
            for cy in occ:
                ok &= ~(hit_cylinder(Po, Lv, cy) < dist)
            Hh = Lv + Vv
            Hh /= np.linalg.norm(Hh, axis=1, keepdims=True)
            cos_h = np.einsum('ij,ij->i', N, Hh)
            F = fresnel_dielectric(np.einsum('ij,ij->i', Hh, Lv), HL_ETA)
            D = beckmann_D(cos_h, HL_ALPHA)
            G = smith_G1_beckmann(cos_i, HL_ALPHA) * smith_G1_beckmann(cos_o, HL_ALPHA)
            E = I / dist ** 2 * np.maximum(cos_i, 0)
            fr = F * D * G / (4 * np.maximum(cos_i, 1e-9) * np.maximum(cos_o, 1e-9))
            val[sel] = np.where(ok, fr * E, 0.0)
        val = val.reshape(shp).reshape(len(rows), sub, W, sub).mean(axis=(1, 3))
        out[rows] = val
    return out


# ---------------------------------------------------------------------------------------------
# Rendering
# ---------------------------------------------------------------------------------------------
def seed_base(name):
    if name.startswith('multi_flag_'):     # per-sphere flagged multi frames: 75100, 75200, ...
        order = ['r50', 'r10', 'r20', 'r30', 'matte']
        return seed_base('multi_flag') + 100 * (1 + order.index(name[len('multi_flag_'):]))
    if name.endswith('_flag'):             # flagged frames: own seeds (+5000)
        return seed_base(name[:-5]) + 5000
    return {'single_r10': 10000, 'single_r20': 20000, 'single_r30': 30000, 'single_r50': 50000,
            'single_matte': 60000, 'multi': 70000}[name]


def render_scene(sc_name, sc, work, spp, pass_spp, max_seconds=None):
    import mitsuba as mi
    mi.set_variant('llvm_ad_rgb')
    acc_path = os.path.join(work, sc_name + '_acc.npz')
    W, H = sc['W'], sc['H']
    if os.path.exists(acc_path):
        z = np.load(acc_path)
        acc = [z['sumA'], z['sumB']]
        n = [int(z['nA']), int(z['nB'])]
        t_acc = float(z['seconds'])
        assert int(z['pass_spp']) == pass_spp, 'pass_spp changed; delete the checkpoint'
    else:
        acc = [np.zeros((H, W, 3)), np.zeros((H, W, 3))]
        n = [0, 0]
        t_acc = 0.0
    tiles = render_tiles(sc)
    if os.path.exists(acc_path):
        assert json.loads(str(z['tiles'])) == tiles, 'tiles changed; delete the checkpoint'
    passes = spp // pass_spp
    mis = [mi.load_dict(build_mi_scene(sc, pass_spp, origin=t['origin_mm'], tile=t)) for t in tiles]
    t_start = time.time()
    for p in range(n[0] + n[1], passes):
        seed = seed_base(sc_name) + p
        t0 = time.time()
        img = np.zeros((H, W, 3))
        for k, (t, scene) in enumerate(zip(tiles, mis)):
            img[t['y0']:t['y0'] + t['h'], t['x0']:t['x0'] + t['w']] = np.array(
                mi.render(scene, spp=pass_spp, seed=seed + TILE_SEED_STRIDE * k), dtype=np.float64)
        k = p % 2
        acc[k] += img
        n[k] += 1
        dt = time.time() - t0
        t_acc += dt
        np.savez(acc_path, sumA=acc[0], sumB=acc[1], nA=n[0], nB=n[1], seconds=t_acc,
                 pass_spp=pass_spp, seed_base=seed_base(sc_name), tiles=json.dumps(tiles))
        print(f'  [{sc_name}] pass {p + 1}/{passes} seed {seed} {dt:.1f}s', flush=True)
        if max_seconds and time.time() - t_start > max_seconds:
            print(f'  [{sc_name}] stopping early (time limit)', flush=True)
            break
    finalize(sc_name, sc, work)


def region_noise(mean, A, B, mask):
    if mask.sum() == 0:
        return None
    d = (A - B)[mask]
    sig = np.sqrt(np.mean(d ** 2, axis=0)) / 2.0
    mu = mean[mask].mean(axis=0)
    return {'pixels': int(mask.sum()), 'mean_radiance': mu.tolist(),
            'pixel_std_error': sig.tolist(),
            'relative_pixel_std_error': (sig / np.maximum(mu, 1e-30)).tolist()}


def save_exr(img, path):
    import mitsuba as mi
    mi.Bitmap(np.ascontiguousarray(img.astype(np.float32))).write(path)


def load_exr(path):
    import mitsuba as mi
    mi.set_variant('scalar_rgb')
    return np.array(mi.Bitmap(path), dtype=np.float64)


def scene_truth(sc):
    f = focal_px(sc['H'], sc['vfov_deg'])
    t = {'camera': {'projection': 'perspective (pinhole)', 'position_mm': [0, 0, 0],
                    'looks_along': [0, 0, -1], 'up': [0, 1, 0],
                    'vertical_fov_deg': sc['vfov_deg'], 'focal_px': f,
                    'principal_point_px': [sc['W'] / 2, sc['H'] / 2],
                    'projection_formula': 'u = W/2 + f x/(-z), v = H/2 - f y/(-z); (u, v) continuous '
                                          'pixel coords, (0,0) = top-left corner; pixel centre (i+0.5, j+0.5)',
                    'pixel_filter': 'box (pixel = mean radiance over its footprint)'},
         'image': {'width': sc['W'], 'height': sc['H']},
         'light': {'type': 'point (isotropic)', 'position_mm': sc['lamp_mm'],
                   'intensity_radiance_units': [sc['lamp_intensity']] * 3,
                   'note': 'irradiance on a surface facing the lamp at d mm = intensity/d^2 (1.0 at 1000 mm, '
                           'the irradiance of data/wax-spheres)'},
         'spheres': [], 'supports': scene_occluders(sc),
         'table': {'y_mm': sc['table_y_mm'], 'extent': 'x in [-2500, 2500], z in [wall_z, 300]',
                   'bsdf': f'diffuse {TABLE_REFL}'},
         'wall': {'z_mm': sc['wall_z_mm'], 'facing': '+z', 'bsdf': f'diffuse {WALL_REFL}',
                  'extent': 'x in [-4000, 4000], y in [table_y, 3000]'},
         'post_bsdf': f'diffuse {POST_REFL} (posts, cups)'}
    if 'flags' in sc:
        t['flags'] = sc['flags']
        if len(sc['flags']) == 1 and len(sc['spheres']) > 1:
            t['flags_note'] = ('flagged frame of ONE sphere (' + sc['flags'][0]['of'] + '): one opaque black '
                               f'card (thin disk, two-sided diffuse {FLAG_REFL}) facing the lamp, centred on the '
                               'lamp -> sphere-centre line; its shadow covers that whole sphere (no direct lamp '
                               'light on it); the other spheres stay lit')
        else:
            t['flags_note'] = ('flagged frame: one opaque black card (thin disk, two-sided diffuse '
                               f'{FLAG_REFL}) per sphere, facing the lamp, centred on the lamp -> sphere-centre '
                               'line; its shadow covers the whole sphere (no direct lamp light on any sphere)')
        t['flag_shadow_max_offset_over_radius'] = flag_shadow_check(sc)
    for s in sc['spheres']:
        e = dict(s)
        c = np.array(s['center_mm'])
        e['distance_to_camera_mm'] = float(np.linalg.norm(c))
        dl = np.linalg.norm(np.array(sc['lamp_mm']) - c)
        e['lamp_distance_from_center_mm'] = float(dl)
        e['lamp_direction_from_center'] = ((np.array(sc['lamp_mm']) - c) / dl).tolist()
        e['angle_lamp_camera_deg'] = float(np.degrees(np.arccos(
            np.dot((np.array(sc['lamp_mm']) - c) / dl, -c / np.linalg.norm(c)))))
        e['projection'] = projected_ellipse(sc, s)
        if s['material'] == 'wax':
            e['bsdf'] = 'null (index-matched boundary: no surface reflection)'
            e['medium'] = {'type': 'homogeneous', 'sigma_t_per_mm': WAX['sigma_t'],
                           'albedo': WAX['albedo'], 'phase': 'isotropic'}
        else:
            e['bsdf'] = f'diffuse (Lambertian), reflectance {MATTE_ALBEDO} (all channels)'
        if s['support'] == 'cup':
            e['cup'] = cup_geometry(s)
        t['spheres'].append(e)
    return t


def finalize(sc_name, sc, work):
    z = np.load(os.path.join(work, sc_name + '_acc.npz'))
    nA, nB = int(z['nA']), int(z['nB'])
    A = z['sumA'] / nA
    B = z['sumB'] / nB if nB else A
    mean = (z['sumA'] + z['sumB']) / (nA + nB)
    save_exr(mean, os.path.join(work, sc_name + '.exr'))
    save_exr(A, os.path.join(work, sc_name + '_A.exr'))
    save_exr(B, os.path.join(work, sc_name + '_B.exr'))
    pass_spp = int(z['pass_spp'])
    truth = scene_truth(sc)
    truth['render'] = {
        'renderer': 'Mitsuba 3.9.1, variant llvm_ad_rgb (CPU)',
        'integrator': {'type': 'volpath', 'max_depth': MAX_DEPTH, 'rr_depth': MAX_DEPTH,
                       'note': 'rr_depth = max_depth: no Russian roulette (as data/wax-spheres)'},
        'spp': (nA + nB) * pass_spp, 'passes': nA + nB, 'spp_per_pass': pass_spp,
        'seeds': [int(z['seed_base']) + p for p in range(nA + nB)], 'sampler': 'independent',
        'tiles': [dict(t, seeds=f'{int(z["seed_base"]) + TILE_SEED_STRIDE * k} + pass')
                  for k, t in enumerate(render_tiles(sc))],
        'tiles_note': ('the frame is rendered in these rectangles (hdrfilm crop), each with the Mitsuba '
                       'scene translated by -origin_mm: Mitsuba offsets every ray spawned from a surface by '
                       '(1 + max|p|) * 1500 * 2^-24 along the normal, which must stay negligible at the wax '
                       'spheres (see make_captures.mi_origin / render_tiles); the image is otherwise the '
                       'same scene (camera at the world origin)'),
        'render_time_s': round(float(z['seconds']), 1),
        'machine': f'{platform.machine()} {os.cpu_count()} cores, shared with cargo builds, nice 10',
        'files': {sc_name + '.exr': 'mean radiance (float32 linear RGB)',
                  sc_name + '_A.exr': 'mean of the even passes', sc_name + '_B.exr': 'mean of the odd passes'}}
    # noise estimate per sphere / region
    lab = label_image(sc, 1)
    noise = {'method': 'even/odd pass halves A, B: per-pixel std error of the final image = rms(A-B)/2 '
                       'over the region; theta = angle between the surface normal and the direction '
                       'to the lamp at the pixel-centre hit point; only pixels whose centre sees the '
                       'sphere unoccluded and at least 1.5 px inside the silhouette'}
    for k, s in enumerate(sc['spheres']):
        th, _, _, inner = sphere_angles(sc, s)
        inner &= lab == k
        noise[s['name']] = {
            'all': region_noise(mean, A, B, inner),
            'lit(theta<60)': region_noise(mean, A, B, inner & (th < 60)),
            'terminator(80<theta<100)': region_noise(mean, A, B, inner & (th > 80) & (th < 100)),
            'shadow(theta>120)': region_noise(mean, A, B, inner & (th > 120)),
        }
    bg = lab == -1
    noise['background(no sphere)'] = region_noise(mean, A, B, bg)
    truth['render']['noise'] = noise
    with open(os.path.join(work, sc_name + '.json'), 'w') as f:
        json.dump(truth, f, indent=1)
    sh = [noise[s['name']]['shadow(theta>120)'] for s in sc['spheres']]
    print(f'finalized {sc_name}: {(nA + nB) * pass_spp} spp, {float(z["seconds"]):.0f}s; shadow rel. noise '
          + '; '.join(f'{s["name"]}: ' + (', '.join(f'{v:.3f}' for v in x['relative_pixel_std_error']) if x else '-')
                      for s, x in zip(sc['spheres'], sh)), flush=True)


# ---------------------------------------------------------------------------------------------
# Camera convention / mask check with Mitsuba (pixel-centre samples)
# ---------------------------------------------------------------------------------------------
def check_camera(args):
    import mitsuba as mi
    mi.set_variant('llvm_ad_rgb')
    scenes = all_scenes()
    ok_all = True
    for name in args.only or ['single_r30', 'single_r10', 'multi']:
        sc = scenes[name]
        integ = {'type': 'aov', 'aovs': 'si:shape_index'}
        sampler = {'type': 'stratified', 'sample_count': 1, 'jitter': False}
        d = build_mi_scene(sc, 1, integrator=integ, sampler=sampler)
        scene = mi.load_dict(d)
        img = np.array(mi.render(scene, spp=1))
        sidx = np.rint(img[..., -1]).astype(int)
        # the aov shape_index numbering is not the scene.shapes() order: identify each value
        # with the analytic sphere label it overlaps most (must be a bijection, checked below)
        lab = label_image(sc, 1)
        lab_mi = np.full(sidx.shape, -1)
        used = set()
        for k, s in enumerate(sc['spheres']):
            vals, cnt = np.unique(sidx[lab == k], return_counts=True)
            j = int(vals[cnt.argmax()])
            assert j not in used
            used.add(j)
            lab_mi[sidx == j] = k
        lab_cmp = np.where(lab >= 0, lab, -1)
        diff = lab_cmp != lab_mi
        print(f'{name}:')
        for k, s in enumerate(sc['spheres']):
            m = lab_mi == k
            jj, ii = np.nonzero(m)
            e = projected_ellipse(sc, s)
            print(f'  {s["name"]}: mitsuba centroid px ({ii.mean() + 0.5:.2f}, {jj.mean() + 0.5:.2f}) '
                  f'analytic ellipse centre ({e["ellipse_center_px"][0]:.2f}, {e["ellipse_center_px"][1]:.2f}), '
                  f'pixels mitsuba {m.sum()} analytic {(lab == k).sum()} '
                  f'ellipse area {np.pi * e["semi_major_px"] * e["semi_minor_px"]:.0f} '
                  f'(occluded {(lab == -2).sum()})')
        print(f'  label mismatches: {diff.sum()}')
        ok_all &= diff.sum() <= 2
        # a coarse render for a look
        if args.preview:
            d = build_mi_scene(sc, 4)
            scene = mi.load_dict(d)
            im = np.array(mi.render(scene, spp=4))
            os.makedirs(args.work, exist_ok=True)
            save_preview(im, os.path.join(args.work, f'check_{name}.png'))
    print('camera/mask check', 'OK' if ok_all else 'FAILED')


# ---------------------------------------------------------------------------------------------
# Image writers
# ---------------------------------------------------------------------------------------------
def srgb_encode(x):
    x = np.clip(x, 0, 1)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def save_preview(img, path, scale=None):
    from PIL import Image
    if scale is None:
        scale = 1.0 / max(np.percentile(img, 99.5), 1e-8)
    out = (srgb_encode(img * scale) * 255 + 0.5).astype(np.uint8)
    Image.fromarray(out).save(path)


def write_png16(path, codes):
    import png
    codes = np.asarray(codes)
    assert codes.dtype == np.uint16
    H, W = codes.shape[:2]
    if codes.ndim == 3:
        w = png.Writer(W, H, greyscale=False, bitdepth=16, compression=9)
        rows = codes.reshape(H, W * 3)
    else:
        w = png.Writer(W, H, greyscale=True, bitdepth=16, compression=9)
        rows = codes
    with open(path, 'wb') as f:
        w.write(f, rows.tolist())


def write_mask(path, mask):
    from PIL import Image
    Image.fromarray(np.where(mask, 255, 0).astype(np.uint8), mode='L').save(path, optimize=True)


# ---------------------------------------------------------------------------------------------
# Degradation pipeline
# ---------------------------------------------------------------------------------------------
def box3(x):
    """3x3 box filter of an (H, W) image (edge-replicated): robust 'brightest pixel'."""
    p = np.pad(x, 1, mode='edge')
    return sum(p[1 + a:1 + a + x.shape[0], 1 + b:1 + b + x.shape[1]]
               for a in (-1, 0, 1) for b in (-1, 0, 1)) / 9.0


def wax_max(img, lab, sc):
    """Brightest wax-sphere pixel (max over channels of the 3x3-box-filtered radiance, pixels whose
    centre sees a wax sphere unoccluded): robust against single MC fireflies."""
    wax = np.zeros(lab.shape, bool)
    for k, s in enumerate(sc['spheres']):
        if s['material'] == 'wax':
            wax |= lab == k
    return max(float(box3(img[..., c])[wax].max()) for c in range(3))


FULL_WELL = 30000.0
READ_NOISE = 3.0
BLACK = 512
WHITE = 16383
E_PER_CODE = FULL_WELL / (WHITE - BLACK)


def sensor_electrons(rad, k, rng):
    e = rng.poisson(np.clip(rad * k, 0, None)).astype(np.float64)
    e += rng.normal(0.0, READ_NOISE, size=e.shape)
    return e


def raw_codes(e):
    return np.clip(np.rint(e / E_PER_CODE + BLACK), 0, WHITE).astype(np.uint16)


def fmt(v):
    return '[' + ', '.join(f'{float(t):.10g}' for t in v) + ']'


def toml_head(comment, sc, intensity=None):
    t = ''.join(f'# {line}\n' if line else '#\n' for line in comment.strip('\n').split('\n'))
    t += f"""
[camera]
projection = "perspective"
vertical_fov_deg = {sc['vfov_deg']:.10g}

[light]
position_mm = {fmt(sc['lamp_mm'])}
"""
    if intensity is not None:
        t += f'intensity = {fmt(intensity)}\n'
    return t


def toml_levels(cs, levels):
    t = f'color_space = "{cs}"\n'
    if levels:
        t += f'black_level = {BLACK}\nwhite_level = {WHITE}\n'
    return t


AMBIENT_COMMENT = ('   # the same shot with the lamp\'s direct light flagged off the sphere '
                   '(black card between lamp and sphere); subtracted pixel by pixel')


def toml_calib(image, cs, levels, ambient=None):
    t = f'\n[calibration]\nimage = "{image}"\n'
    if ambient:
        t += f'ambient_image = "{ambient}"{AMBIENT_COMMENT}\n'
    return t + 'radius_mm = 25.0\nalbedo = [0.5, 0.5, 0.5]\n' + toml_levels(cs, levels)


def toml_sphere(image, r, cs, levels, mask=None, ambient=None):
    t = f'\n[[sphere]]\nimage = "{image}"\n'
    if ambient:
        t += f'ambient_image = "{ambient}"{AMBIENT_COMMENT}\n'
    t += f'radius_mm = {float(r):.1f}\n' + toml_levels(cs, levels)
    if mask:
        t += f'mask = "{mask}"\n'
    return t


def flag_name(path):
    b, e = os.path.splitext(path)
    return b + '_flag' + e


def read_png16_check(path, expect):
    """Read a 16-bit PNG back with Mitsuba's Bitmap (a different library than pypng, which wrote
    it) and compare the codes exactly."""
    import mitsuba as mi
    b = mi.Bitmap(path)
    got = np.array(b)
    assert got.dtype == np.uint16, (path, got.dtype)
    got = got.reshape(expect.shape)
    assert np.array_equal(got, expect), path
    return True


SINGLES = ['single_r10', 'single_r20', 'single_r30', 'single_r50']
FILE = {'single_r10': 'sphere_r10', 'single_r20': 'sphere_r20', 'single_r30': 'sphere_r30',
        'single_r50': 'sphere_r50', 'single_matte': 'matte', 'multi': 'multi'}
SEEDS = {'single_r10': 1, 'single_r20': 2, 'single_r30': 3, 'single_r50': 5, 'single_matte': 6,
         'multi': 7}
NOISE_SEED = 20261204
FLAG_TOML_NOTE = (
    'ambient_image = <stem>_flag.<ext>: the flagged frame, the same shot (nothing moved, same exposure and\n'
    'processing, its own sensor-noise draw) with an opaque black card (a "flag": thin disk, diffuse 0.02)\n'
    'between the lamp and the sphere, 150 mm from the sphere centre toward the lamp, its shadow covering\n'
    'the whole sphere with a 10 % angular margin: no direct lamp light on the sphere (so no highlight),\n'
    'only the bounce light of the room (wall, table). Subtract it pixel by pixel. The flag is outside\n'
    'every sphere\'s disk in the image.')
MULTI_FLAGS = ['multi_flag_r50', 'multi_flag_r10', 'multi_flag_r20', 'multi_flag_r30', 'multi_flag_matte']
MULTI_FLAG_NOISE = {'r50': 1, 'r10': 2, 'r20': 3, 'r30': 4, 'matte': 5}   # extra noise-seed word
MULTI_FLAG_TOML_NOTE = (
    'ambient_image = multi_flag_<sphere>.png (r50, r10, r20, r30, matte): ONE flagged frame PER SPHERE,\n'
    'the same shot (nothing moved, same exposure and processing, its own sensor-noise draw) with an\n'
    'opaque black card (a "flag": thin disk, diffuse 0.02) between the lamp and THAT sphere only, 150 mm\n'
    'from its centre toward the lamp, its shadow covering the whole sphere with a 10 % angular margin: no\n'
    'direct lamp light on that sphere (so no highlight); the other four spheres stay lit, so the frame\n'
    'keeps the room\'s bounce light AND the glow of the lit neighbours (30 mm gaps) on it. Subtract it\n'
    'pixel by pixel, each sphere with its own frame. The flag is outside every sphere\'s disk in the image.')
MULTI_FLAG_TRUTH_NOTE = (
    'multi_flag_<sphere>.png (r50, r10, r20, r30, matte): one flagged frame per sphere, the same shot with '
    'ONE black flag (thin disk, two-sided diffuse 0.02) between the lamp and that sphere only (the other '
    'four spheres stay lit, so their glow on it is kept), centred on the lamp -> sphere-centre line (150 mm '
    'from the centre, or farther if needed to keep it off every disk; the same flag as that sphere\'s in '
    'the all-flags frame of the previous version), radius such that its half-angle from the lamp is '
    '1.1 asin(r / D) (shadow covers the sphere with a 10 % margin; checked analytically on 20001 surface '
    'points, see flag_shadow_max_offset_over_radius); no flag over any sphere\'s disk (4x4 subsamples per '
    'pixel). Same gain / exposure / levels as the lit frame, its own sensor-noise realisation (noise_seed), '
    'no residual highlight; own Monte-Carlo seeds (75100, 75200, ... + pass). Flag geometry per image in '
    'images[...].flags.')
FLAG_TRUTH_NOTE = (
    '<stem>_flag.<ext>: the same shot with one black flag (thin disk, two-sided diffuse 0.02) per sphere '
    'between the lamp and the sphere, centred on the lamp -> sphere-centre line 150 mm from the centre, '
    'radius such that its half-angle from the lamp is 1.1 asin(r / D) (shadow covers the sphere with '
    'a 10 % margin; checked analytically on 20001 surface points per sphere, see '
    'flag_shadow_max_offset_over_radius); no flag over any sphere\'s disk (4x4 subsamples per pixel). '
    'Same gain / exposure / levels / tone curve as the lit frame, its own sensor-noise realisation '
    '(seed list + [1]), no residual highlight (no direct light on the spheres); own Monte-Carlo seeds '
    '(base + 5000). Flag geometry per image in images[...].flags.')


def degrade(args):
    from PIL import Image
    import mitsuba as mi
    mi.set_variant('scalar_rgb')
    work, out = args.work, args.out
    scenes = all_scenes()
    allsc = SINGLES + ['single_matte', 'multi']
    allsc += [n + '_flag' for n in allsc]
    allsc += MULTI_FLAGS
    R = {n: load_exr(os.path.join(work, n + '.exr')) for n in allsc}
    T = {n: json.load(open(os.path.join(work, n + '.json'))) for n in allsc}
    LAB = {n: label_image(scenes[n], 1) for n in allsc}
    # exact cup mask: the pixel centre sees the r = 30 sphere unoccluded AND none of the 4x4
    # subsamples of the pixel footprint sees the cup (or post) in front of the sphere
    sc30 = scenes['single_r30']
    sub = 4
    lab_sub = label_image(sc30, sub)
    occl_sub = (lab_sub == -2).reshape(sc30['H'], sub, sc30['W'], sub).any(axis=(1, 3))
    mask30 = (LAB['single_r30'] == 0) & ~occl_sub
    print('residual highlights ...', flush=True)
    HL = {n: HL_FRACTION * highlight_image(scenes[n], sub=4) for n in SINGLES + ['multi']}
    HL['single_matte'] = np.zeros(R['single_matte'].shape[:2])
    # flagged frames: no direct lamp light on any sphere (checked analytically: flag_shadow_check),
    # hence no first-surface highlight either
    for n in SINGLES + ['single_matte', 'multi']:
        sh = flag_shadow_check(scenes[n + '_flag'])
        assert max(sh.values()) < 1, sh
        HL[n + '_flag'] = np.zeros(R[n].shape[:2])
    for n in MULTI_FLAGS:                  # per-sphere multi frames: only that sphere is flagged
        sh = flag_shadow_check(scenes[n])
        assert len(sh) == 1 and max(sh.values()) < 1, sh
        HL[n] = np.zeros(R[n].shape[:2])
    prev = os.path.join(work, 'previews')
    os.makedirs(prev, exist_ok=True)
    for n in HL:
        if n.endswith('_flag') or n in MULTI_FLAGS:
            continue
        save_exr(np.repeat(HL[n][..., None], 3, -1), os.path.join(work, n + '_highlight.exr'))

    def img_truth(n):
        t = {k: T[n][k] for k in ('camera', 'image', 'light', 'spheres', 'supports', 'table', 'wall',
                                  'post_bsdf', 'flags', 'flags_note', 'flag_shadow_max_offset_over_radius')
             if k in T[n]}
        t['render'] = {k: T[n]['render'][k] for k in ('renderer', 'integrator', 'spp', 'passes',
                                                       'seeds', 'tiles', 'tiles_note', 'render_time_s',
                                                       'noise') if k in T[n]['render']}
        t['source_exr'] = os.path.join(work, n + '.exr') + ' (not in the repo)'
        return t

    def dump(folder, truth, toml):
        with open(os.path.join(folder, 'truth.json'), 'w') as f:
            json.dump(truth, f, indent=1)
        with open(os.path.join(folder, 'cdrf-dataset.toml'), 'w') as f:
            f.write(toml)

    setup = ('Studio: perspective camera at the origin looking along -z (+x right, +y up), point lamp,\n'
             'black posts (r 3 mm, diffuse 0.02) down to a black velvet table (diffuse 0.03, 80 mm below\n'
             'the lowest sphere bottom), grey wall (diffuse 0.2) 1.5 m behind: the background is not black.\n'
             'Wax: homogeneous medium sigma_t 1/mm, albedo (0.997, 0.993, 0.985), isotropic, index-matched\n'
             'boundary (as data/wax-spheres); Mitsuba 3.9.1 volpath. Truth (sphere centres, ellipses,\n'
             'gains, noise) in truth.json; center_px / radius_px deliberately not given.')
    single_geo = ('Single-sphere photographs, one per sphere, same camera, lamp and spot: each sphere in turn\n'
                  'on the same spot ~1 m from the camera (centre 27 % of the half-width right, 10 % of the\n'
                  'half-height up: slightly off-axis), lamp 1 m from the spot on the image\'s left, slightly\n'
                  'above and in front (83 deg from the camera). Disk radius ~ 3.8 px per mm of radius\n'
                  '(r = 10 -> 38 px, r = 50 -> 190 px). The r = 30 sphere rests in a black cup (radius 16.5\n'
                  'mm, 10.5 mm tall) that hides the bottom of its disk: mask_r30.png (255 = the pixel sees\n'
                  'the sphere and no part of it sees the cup).')
    summary = {}

    # ================= lamp/ ========================================================
    folder = os.path.join(out, 'lamp')
    os.makedirs(folder, exist_ok=True)
    mx = max(wax_max(R[n], LAB[n], scenes[n]) for n in SINGLES)
    gain = 0.8 * 65535 / mx
    I = LAMP_I * gain / 65535          # cdrf-fit normalises 16-bit linear codes: code / 65535
    truth = {'case': 'lamp: ideal linear 16-bit sensor, known lamp intensity, no highlight, no noise '
                     'other than the Monte-Carlo noise of the render',
             'pixel_model': 'code = round(radiance * gain), clipped to [0, 65535]',
             'gain_codes_per_radiance': gain,
             'brightest_wax_radiance_3x3box': mx,
             'intensity_pixel_units': [I] * 3,
             'intensity_pixel_units_note': 'pixel units = code / 65535 (what cdrf-fit reads); a surface facing '
                                           'the lamp at d mm receives intensity / d^2 in these units',
             'intensity_raw_code_units': [I * 65535] * 3,
             'flagged_frames': FLAG_TRUTH_NOTE,
             'mask_r30.png': '255 = pixel centre sees the r = 30 sphere and none of the 4x4 subsamples '
                             'of the pixel sees the cup/post in front of it; 0 = anything else',
             'images': {}}
    toml = toml_head(
        'lamp/: realistic studio capture with an IDEAL linear sensor and a KNOWN lamp intensity.\n'
        + single_geo + '\n' + setup + '\n'
        f'Pixels: 16-bit linear PNG, code = round(radiance * {gain:.6g}); no sensor noise, no highlight\n'
        '(perfect cross-polarisation). intensity is in the units of the NORMALISED codes, code / 65535\n'
        f'(= 1e6 * gain / 65535): a surface facing the lamp at d mm receives intensity / d^2 in those units, so\n'
        '(code / 65535) / irradiance is the exact radiance / irradiance. (In raw code units it would be\n'
        f'{I * 65535:.8g}.) matte.png (Lambertian albedo 0.5, r = 25 mm, same spot, camera and lamp) is\n'
        'in the folder as a cross-check only; it is not referenced here.\n' + FLAG_TOML_NOTE,
        scenes['single_r10'], intensity=[I] * 3)
    for n0 in SINGLES + ['single_matte']:
        for n in (n0, n0 + '_flag'):
            fn = FILE[n0] + ('_flag' if n != n0 else '') + '.png'
            codes = np.clip(np.rint(R[n] * gain), 0, 65535).astype(np.uint16)
            p = os.path.join(folder, fn)
            write_png16(p, codes)
            read_png16_check(p, codes)
            t = img_truth(n)
            t['clipped_pixels'] = int((codes == 65535).any(-1).sum())
            if n != n0:
                t['flagged_frame_of'] = FILE[n0] + '.png'
            truth['images'][fn] = t
            save_preview(codes / 65535.0, os.path.join(prev, f'lamp_{fn}'), 1 / 0.8)
            if n != n0:
                save_preview(codes / 65535.0, os.path.join(prev, f'lamp_{FILE[n0]}_flag_x20.png'), 20 / 0.8)
        if n0 != 'single_matte':
            r = scenes[n0]['spheres'][0]['radius_mm']
            toml += toml_sphere(FILE[n0] + '.png', r, 'linear', False,
                                'mask_r30.png' if n0 == 'single_r30' else None, FILE[n0] + '_flag.png')
    write_mask(os.path.join(folder, 'mask_r30.png'), mask30)
    dump(folder, truth, toml)
    summary['lamp'] = {'gain': gain, 'intensity': I}

    # ================= raw14/ and jpeg/ ==============================================
    mx_hl = max(wax_max(R[n] + HL[n][..., None], LAB[n], scenes[n]) for n in SINGLES)
    k_e = 0.70 * FULL_WELL / mx_hl                     # electrons per radiance unit
    I_lin = LAMP_I * k_e / FULL_WELL                   # (code - black)/(white - black) units
    hl_note = (f'Residual highlight (imperfect cross-polarisation) added before the noise: {HL_FRACTION} x '
               f'the first-surface reflection of the lamp off a rough dielectric (eta {HL_ETA}, Beckmann '
               f'alpha {HL_ALPHA}, Cook-Torrance F D G / (4 cos_i cos_o) with Smith G, irradiance I/d^2 cos_i), '
               'analytic, box-filtered over 4x4 subsamples per pixel; wax spheres only.')
    raw_model = (f'electrons = Poisson((radiance + highlight) * k) + Normal(0, {READ_NOISE}); '
                 f'code = clip(round(electrons * {WHITE - BLACK}/{FULL_WELL:.0f} + {BLACK}), 0, {WHITE}); '
                 f'full well {FULL_WELL:.0f} e-, black level {BLACK}, white level {WHITE}; numpy '
                 f'default_rng([{NOISE_SEED}, image_seed])')
    rf = os.path.join(out, 'raw14')
    jf = os.path.join(out, 'jpeg')
    os.makedirs(rf, exist_ok=True)
    os.makedirs(jf, exist_ok=True)
    truth_r = {'case': 'raw14: RAW-like linear sensor, shot noise + read noise, black level, 14-bit codes in '
                       '16-bit PNG, residual highlight, unknown intensity (calibrate with matte.png)',
               'pixel_model': raw_model, 'highlight': hl_note,
               'k_electrons_per_radiance': k_e,
               'brightest_wax_radiance_incl_highlight_3x3box': mx_hl,
               'true_intensity_linear_units': [I_lin] * 3,
               'true_intensity_linear_units_note': 'linear = (code - black_level)/(white_level - black_level); '
                                                   'a surface facing the lamp at d mm receives this / d^2',
               'true_intensity_codes_above_black': [I_lin * (WHITE - BLACK)] * 3,
               'mask_r30.png': truth['mask_r30.png'], 'flagged_frames': FLAG_TRUTH_NOTE, 'images': {}}
    # JPEG exposure: brightest wax pixel (noise-free, incl. highlight) -> 0.9 of white (linear)
    jexp = 0.9 / 0.70                                   # applied to (code - black)/(white - black)
    I_j = I_lin * jexp
    truth_j = {'case': 'jpeg: the raw14 sensor (independent noise draw), developed like an in-camera JPEG: '
                       'linear = (code - black)/(white - black) * exposure, sRGB curve, 8-bit, JPEG quality 95 '
                       '(Pillow, 4:2:0 chroma subsampling), residual highlight, unknown intensity',
               'pixel_model': raw_model + f'; then linear = (code - {BLACK})/({WHITE - BLACK}) * {jexp:.6g}, '
                              'clip [0, 1], sRGB encode, round to 8 bit, JPEG q95',
               'highlight': hl_note, 'k_electrons_per_radiance': k_e, 'exposure_after_raw': jexp,
               'true_intensity_linear_units': [I_j] * 3,
               'true_intensity_linear_units_note': 'linear = sRGB-decoded 8-bit value / 255 (0..1); a surface '
                                                   'facing the lamp at d mm receives this / d^2',
               'mask_r30.png': truth['mask_r30.png'], 'flagged_frames': FLAG_TRUTH_NOTE, 'images': {}}
    toml_r = toml_head(
        'raw14/: the same single-sphere photographs through a RAW-like linear sensor, UNKNOWN intensity.\n'
        + single_geo + '\n' + setup + '\n'
        f'Sensor: full well {FULL_WELL:.0f} e-, brightest wax pixel ~70 % of it, Poisson shot noise, read noise\n'
        f'{READ_NOISE} e-, 14-bit codes (black level {BLACK} added, white {WHITE}) stored as-is in 16-bit PNG.\n'
        f'{HL_FRACTION * 100:.0f} % residual highlight (imperfect cross-polarisation; eta 1.5, alpha 0.1).\n'
        'The lamp intensity is not given: matte.png is the calibration photograph (same camera, lamp,\n'
        'exposure; Lambertian albedo 0.5, r = 25 mm on the same spot).\n' + FLAG_TOML_NOTE, scenes['single_r10'])
    toml_r += toml_calib('matte.png', 'linear', True, 'matte_flag.png')
    toml_j = toml_head(
        'jpeg/: the same single-sphere photographs as in-camera JPEGs (sRGB, 8 bit, quality 95), UNKNOWN\n'
        'intensity. Sensor as raw14/ (independent noise draw), then exposure so the brightest wax pixel\n'
        f'is ~90 % of white (linear), sRGB curve, JPEG. {HL_FRACTION * 100:.0f} % residual highlight.\n'
        + single_geo + '\n' + setup + '\n'
        'matte.jpg is the calibration photograph (same camera, lamp, exposure; albedo 0.5, r = 25 mm).\n'
        + FLAG_TOML_NOTE, scenes['single_r10'])
    toml_j += toml_calib('matte.jpg', 'srgb', False, 'matte_flag.jpg')
    for n in SINGLES + ['single_matte'] + [m + '_flag' for m in SINGLES + ['single_matte']]:
        rad = R[n] + HL[n][..., None]
        fl = n.endswith('_flag')
        n0 = n[:-5] if fl else n
        stem = FILE[n0] + ('_flag' if fl else '')
        # raw14 (flagged frame: its own noise realisation, extra seed word 1)
        rng = np.random.default_rng([NOISE_SEED, SEEDS[n0], 14] + ([1] if fl else []))
        codes = raw_codes(sensor_electrons(rad, k_e, rng))
        p = os.path.join(rf, stem + '.png')
        write_png16(p, codes)
        read_png16_check(p, codes)
        t = img_truth(n)
        t['clipped_pixels'] = int((codes >= WHITE).any(-1).sum())
        t['highlight_peak_radiance'] = float(HL[n].max())
        if fl:
            t['flagged_frame_of'] = FILE[n0] + '.png'
        truth_r['images'][stem + '.png'] = t
        save_preview((codes - BLACK) / (WHITE - BLACK), os.path.join(prev, f'raw14_{stem}.png'), 1 / 0.7)
        # jpeg (independent noise draw)
        rng = np.random.default_rng([NOISE_SEED, SEEDS[n0], 8] + ([1] if fl else []))
        cj = raw_codes(sensor_electrons(rad, k_e, rng))
        lin = np.clip((cj.astype(np.float64) - BLACK) / (WHITE - BLACK) * jexp, 0, 1)
        c8 = np.rint(srgb_encode(lin) * 255).astype(np.uint8)
        pj = os.path.join(jf, stem + '.jpg')
        Image.fromarray(c8, mode='RGB').save(pj, quality=95, subsampling='4:2:0')
        back = np.array(Image.open(pj).convert('RGB'), dtype=np.float64)
        tj = img_truth(n)
        tj['clipped_pixels_before_jpeg'] = int((c8 == 255).any(-1).sum())
        tj['jpeg_rms_error_8bit'] = float(np.sqrt(np.mean((back - c8) ** 2)))
        tj['highlight_peak_radiance'] = float(HL[n].max())
        if fl:
            tj['flagged_frame_of'] = FILE[n0] + '.jpg'
        truth_j['images'][stem + '.jpg'] = tj
        if fl:
            save_preview(lin, os.path.join(prev, f'jpeg_{stem}_x20.png'), 20.0)
        if n in SINGLES:
            r = scenes[n]['spheres'][0]['radius_mm']
            m = 'mask_r30.png' if n == 'single_r30' else None
            toml_r += toml_sphere(FILE[n] + '.png', r, 'linear', True, m, FILE[n] + '_flag.png')
            toml_j += toml_sphere(FILE[n] + '.jpg', r, 'srgb', False, m, FILE[n] + '_flag.jpg')
    write_mask(os.path.join(rf, 'mask_r30.png'), mask30)
    write_mask(os.path.join(jf, 'mask_r30.png'), mask30)
    dump(rf, truth_r, toml_r)
    dump(jf, truth_j, toml_j)
    summary['raw14'] = {'k': k_e, 'I_lin': I_lin}
    summary['jpeg'] = {'I_lin': I_j}

    # ================= multi/ ========================================================
    n = 'multi'
    sc = scenes[n]
    mf = os.path.join(out, 'multi')
    os.makedirs(mf, exist_ok=True)
    rad = R[n] + HL[n][..., None]
    mxm = wax_max(rad, LAB[n], sc)
    km = 0.70 * FULL_WELL / mxm
    Im = LAMP_I * km / FULL_WELL
    rng = np.random.default_rng([NOISE_SEED, SEEDS[n], 14])
    codes = raw_codes(sensor_electrons(rad, km, rng))
    p = os.path.join(mf, 'multi.png')
    write_png16(p, codes)
    read_png16_check(p, codes)
    save_preview((codes - BLACK) / (WHITE - BLACK), os.path.join(prev, 'multi_multi.png'), 1 / 0.7)
    t = img_truth(n)
    t['clipped_pixels'] = int((codes >= WHITE).any(-1).sum())
    t['highlight_peak_radiance'] = float(HL[n].max())
    # flagged frames, one per sphere (only that sphere's flag; the other four stay lit): same
    # gain, each its own noise realisation (seed list + [1, j]), no highlight on the flagged sphere
    # (the lit neighbours' first-surface highlights are not seen by the flagged sphere's pixels and
    # are left out of these frames, as in every flagged frame)
    images_m = {'multi.png': t}
    for nf in MULTI_FLAGS:
        short = nf[len('multi_flag_'):]
        radf = R[nf] + HL[nf][..., None]
        rng = np.random.default_rng([NOISE_SEED, SEEDS[n], 14, 1, MULTI_FLAG_NOISE[short]])
        codesf = raw_codes(sensor_electrons(radf, km, rng))
        pf = os.path.join(mf, nf + '.png')
        write_png16(pf, codesf)
        read_png16_check(pf, codesf)
        save_preview((codesf - BLACK) / (WHITE - BLACK), os.path.join(prev, f'multi_{nf}.png'), 1 / 0.7)
        tf = img_truth(nf)
        tf['clipped_pixels'] = int((codesf >= WHITE).any(-1).sum())
        tf['highlight_peak_radiance'] = 0.0
        tf['flagged_frame_of'] = 'multi.png'
        tf['flagged_sphere'] = scenes[nf]['flags'][0]['of']
        tf['noise_seed'] = [NOISE_SEED, SEEDS[n], 14, 1, MULTI_FLAG_NOISE[short]]
        images_m[nf + '.png'] = tf
    stale = os.path.join(mf, 'multi_flag.png')   # the old all-flags frame: no entry names it
    if os.path.exists(stale):
        os.remove(stale)
    order = ', '.join(f'{s["name"]}' for s in sc['spheres'])
    truth_m = {'case': 'multi: four wax spheres and the matte calibration sphere in one raw14-style frame',
               'pixel_model': raw_model, 'highlight': hl_note, 'k_electrons_per_radiance': km,
               'brightest_wax_radiance_incl_highlight_3x3box': mxm,
               'true_intensity_linear_units': [Im] * 3,
               'true_intensity_codes_above_black': [Im * (WHITE - BLACK)] * 3,
               'left_to_right': order, 'flagged_frames': MULTI_FLAG_TRUTH_NOTE,
               'images': images_m}
    toml_m = toml_head(
        'multi/: one photograph, 1400x600, of four wax spheres (r = 50, 10, 20, 30 mm) and the matte\n'
        f'calibration sphere (Lambertian albedo 0.5, r = 25 mm), left to right: {order}.\n'
        'A row at 1 m from the camera (centres y = -10 mm, z = -1000 mm, gaps 30 mm), each on a post;\n'
        'lamp 1.5 m from the row centre, left / above / in front (53-62 deg from the camera); no sphere\n'
        'shadows another. The r = 50 disk is ~160 px in radius, r = 10 ~32 px.\n'
        + setup + '\n'
        f'Sensor as raw14/ (brightest wax pixel ~70 % of the {FULL_WELL:.0f} e- well, shot + read noise, black level\n'
        f'{BLACK}, 14-bit codes in 16-bit PNG), {HL_FRACTION * 100:.0f} % residual highlight. Intensity unknown: the\n'
        'matte sphere in the same frame calibrates it.\n' + MULTI_FLAG_TOML_NOTE, sc)
    for s in sc['spheres']:
        if s['material'] != 'wax':
            toml_m += toml_calib('multi.png', 'linear', True,
                                 f'multi_flag_{MULTI_FLAG_SHORT[s["name"]]}.png')
    for s in sc['spheres']:
        if s['material'] == 'wax':
            toml_m += toml_sphere('multi.png', s['radius_mm'], 'linear', True, None,
                                  f'multi_flag_{MULTI_FLAG_SHORT[s["name"]]}.png')
    dump(mf, truth_m, toml_m)
    summary['multi'] = {'k': km, 'I_lin': Im}

    # flagged / lit radiance on the wax spheres (float renders), shadow side and lit side
    ratios = {}
    for n in SINGLES + ['single_matte', 'multi']:
        sc = scenes[n]
        for k, s in enumerate(sc['spheres']):
            th, cth, d2, inner = sphere_angles(sc, s)
            inner &= LAB[n] == k
            rr = {}
            for reg, m in (('shadow(theta>110)', inner & (th > 110)), ('lit(theta<60)', inner & (th < 60))):
                if m.sum():
                    a = R[n + '_flag'][m].mean(0)
                    b = R[n][m].mean(0)
                    rr[reg] = {'pixels': int(m.sum()), 'flag_over_lit_rgb': (a / b).tolist(),
                               'lit_mean_rgb': b.tolist(), 'flag_mean_rgb': a.tolist()}
            ratios[f'{n}:{s["name"]}'] = rr
            if n == 'multi':               # the sphere's own flagged frame (only its flag)
                nf = 'multi_flag_' + MULTI_FLAG_SHORT[s['name']]
                ro = {}
                for reg, m in (('shadow(theta>110)', inner & (th > 110)), ('lit(theta<60)', inner & (th < 60))):
                    a = R[nf][m].mean(0)
                    b = R[n][m].mean(0)
                    ro[reg] = {'pixels': int(m.sum()), 'own_flag_over_lit_rgb': (a / b).tolist(),
                               'all_flags_over_lit_rgb': (R['multi_flag'][m].mean(0) / b).tolist()}
                if s['material'] != 'wax':  # matte: (lit - own flag) / Lambert on the lit side
                    m = inner & (th < 60)
                    pred = MATTE_ALBEDO / np.pi * sc['lamp_intensity'] * cth / d2
                    ro['matte_lit_minus_own_flag_over_lambert_rgb'] = (
                        (R[n][m] - R[nf][m]).mean(0) / pred[m].mean()).tolist()
                    ro['matte_lit_minus_all_flags_over_lambert_rgb'] = (
                        (R[n][m] - R['multi_flag'][m]).mean(0) / pred[m].mean()).tolist()
                    ro['matte_lit_over_lambert_rgb'] = (R[n][m].mean(0) / pred[m].mean()).tolist()
                ratios[f'{nf}:{s["name"]}'] = ro
    summary['flag_over_lit'] = ratios
    # lamp/ intensity check: matte code/65535 vs albedo/pi * I cos(theta) / d^2 on cos(theta) > 0.5,
    # pixels away from the silhouette (edge pixels mix in the wall, which the flagged frame keeps)
    sc = scenes['single_matte']
    s = sc['spheres'][0]
    _, cth, d2, inner = sphere_angles(sc, s)
    m = (LAB['single_matte'] == 0) & (cth > 0.5) & inner
    codes = np.clip(np.rint(R['single_matte'] * gain), 0, 65535)
    pred = MATTE_ALBEDO / np.pi * I * cth / d2
    summary['lamp_matte_check_code65535_over_prediction'] = float((codes[m] / 65535).mean() / pred[m].mean())
    codesf = np.clip(np.rint(R['single_matte_flag'] * gain), 0, 65535)
    summary['lamp_matte_check_after_ambient_subtraction'] = float(
        ((codes[m] - codesf[m]) / 65535).mean() / pred[m].mean())
    # sizes
    tot = 0
    for dp, dn, fn in os.walk(out):
        for f in fn:
            tot += os.path.getsize(os.path.join(dp, f))
    summary['total_MB'] = tot / 1e6
    print(json.dumps(summary, indent=1))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('what', choices=['check-camera', 'check-flags', 'render', 'finalize', 'degrade', 'info'])
    ap.add_argument('--work', default=DEFAULT_WORK)
    ap.add_argument('--out', default=DEFAULT_OUT)
    ap.add_argument('--only', nargs='*', default=None)
    ap.add_argument('--spp', type=int, default=64)
    ap.add_argument('--pass-spp', type=int, default=8)
    ap.add_argument('--max-seconds', type=float, default=None,
                    help='per scene: stop after the pass that crosses this time')
    ap.add_argument('--preview', action='store_true')
    args = ap.parse_args()
    os.makedirs(args.work, exist_ok=True)
    scenes = all_scenes()
    if args.what == 'info':
        for n, sc in scenes.items():
            print(n, json.dumps({k: sc[k] for k in ('W', 'H', 'vfov_deg', 'lamp_mm', 'table_y_mm', 'wall_z_mm')}))
            for fl in sc.get('flags', []):
                print('    flag of', fl['of'], np.round(fl['center_mm'], 2).tolist(), 'radius',
                      round(fl['radius_mm'], 2))
            for s in sc['spheres']:
                e = projected_ellipse(sc, s)
                print('   ', s['name'], np.round(s['center_mm'], 2).tolist(),
                      'ellipse c', np.round(e['ellipse_center_px'], 2).tolist(),
                      'axes', round(e['semi_major_px'], 2), round(e['semi_minor_px'], 2),
                      'ang', round(e['major_axis_angle_deg'], 1))
        return
    if args.what == 'check-camera':
        check_camera(args)
        return
    if args.what == 'check-flags':
        check_flags(scenes, args.only)
        return
    if args.what == 'render':
        for n in args.only or list(scenes):
            render_scene(n, scenes[n], args.work, args.spp, args.pass_spp, args.max_seconds)
        return
    if args.what == 'finalize':
        for n in args.only or list(scenes):
            finalize(n, scenes[n], args.work)
        return
    degrade(args)


if __name__ == '__main__':
    main()
