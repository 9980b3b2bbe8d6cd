#!/usr/bin/env python3
"""Re-render each wax sphere's own tile of the several-sphere photograph's flagged frames at the
lit frame's samples per pixel, into a COPY of data/captures/multi/ (an experiment; the bundled
set is not refined: docs/research/captures.md, "2026-12-06 (session 15)", says what it changed
and why the set was kept).

multi/'s flagged frames (multi_flag_<r50|r10|r20|r30>.png) were rendered at 32-64 samples per
pixel against the lit frame's 128.  Only the flagged sphere's pixels of a flagged frame are read
(the manifest names it as that sphere's ambient image), so only that sphere's tile (render_tiles:
its projected disk's bounding box + TILE_MARGIN px, rendered with the Mitsuba origin at its
centre) is replaced.

Pixel model: make_captures.py's (sensor_electrons, raw_codes) with the frame's own gain k
(truth.json), a new noise realisation per tile (seed words [NOISE_SEED, SEEDS['multi'], 14, 1,
MULTI_FLAG_NOISE[sphere], REFINE_NOISE_WORD]); Mitsuba seeds seed_base(frame) + REFINE_SEED_OFFSET
+ pass, distinct from every render's.  truth.json records the tile, its samples and seeds.
Writes each PNG and truth.json to a temporary file first and renames it.

Usage (venv python with pypng; export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so),
about four minutes on two cores:
  cp -r data/captures/multi /tmp/multi-refined
  python scripts/captures/refine_flags.py --dir /tmp/multi-refined [--spp 128] [--only r20 ...]
"""

import argparse
import json
import os
import time

import numpy as np

import make_captures as mc

REFINE_SEED_OFFSET = 50000   # Mitsuba seeds: seed_base(frame) + this + pass
REFINE_NOISE_WORD = 128      # extra noise-seed word of a refined tile


def render_tile(sc_name, sc, sphere_name, spp, pass_spp):
    import mitsuba as mi
    mi.set_variant('llvm_ad_rgb')
    tile = [t for t in mc.render_tiles(sc) if t['what'] == sphere_name]
    assert len(tile) == 1, (sc_name, sphere_name)
    tile = tile[0]
    scene = mi.load_dict(mc.build_mi_scene(sc, pass_spp, origin=tile['origin_mm'], tile=tile))
    total = np.zeros((tile['h'], tile['w'], 3))
    seeds = []
    t0 = time.time()
    for p in range(spp // pass_spp):
        seed = mc.seed_base(sc_name) + REFINE_SEED_OFFSET + p
        total += np.array(mi.render(scene, spp=pass_spp, seed=seed), dtype=np.float64)
        seeds.append(seed)
    print(f'  [{sc_name}] tile {tile["w"]}x{tile["h"]} at {spp} spp in {time.time() - t0:.0f} s',
          flush=True)
    return tile, total / len(seeds), seeds


def read_png16(path, shape):
    import mitsuba as mi
    got = np.array(mi.Bitmap(path))
    assert got.dtype == np.uint16, (path, got.dtype)
    return got.reshape(shape).copy()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--dir', required=True, help='a copy of data/captures/multi (changed in place)')
    ap.add_argument('--spp', type=int, default=128)
    ap.add_argument('--pass-spp', type=int, default=16)
    wax = ['r50', 'r10', 'r20', 'r30']       # the wax spheres' tiles (the matte one has none)
    ap.add_argument('--only', nargs='+', default=wax, choices=wax)
    args = ap.parse_args()
    assert args.spp % args.pass_spp == 0
    bundled = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'data',
                           'captures', 'multi')
    if os.path.realpath(args.dir) == os.path.realpath(bundled):
        ap.error('--dir is the bundled set: copy it first (the bundled set is not refined)')
    scenes = mc.all_scenes()
    truth_path = os.path.join(args.dir, 'truth.json')
    with open(truth_path) as f:
        truth = json.load(f)
    k = truth['k_electrons_per_radiance']
    by_short = {v: n for n, v in mc.MULTI_FLAG_SHORT.items()}
    for short in args.only:
        sphere = by_short[short]
        frame = 'multi_flag_' + short
        sc = scenes[frame]
        tile, rad, seeds = render_tile(frame, sc, sphere, args.spp, args.pass_spp)
        noise_seed = [mc.NOISE_SEED, mc.SEEDS['multi'], 14, 1, mc.MULTI_FLAG_NOISE[short],
                      REFINE_NOISE_WORD]
        codes_tile = mc.raw_codes(mc.sensor_electrons(rad, k, np.random.default_rng(noise_seed)))
        png = os.path.join(args.dir, frame + '.png')
        codes = read_png16(png, (sc['H'], sc['W'], 3))
        y0, x0, h, w = tile['y0'], tile['x0'], tile['h'], tile['w']
        codes[y0:y0 + h, x0:x0 + w] = codes_tile
        tmp = png + '.tmp'
        mc.write_png16(tmp, codes)
        mc.read_png16_check(tmp, codes)
        os.replace(tmp, png)
        entry = truth['images'][frame + '.png']
        entry['refined_tile'] = {
            'x0': x0, 'y0': y0, 'w': w, 'h': h, 'sphere': sphere, 'spp': args.spp,
            'mitsuba_seeds': [seeds[0], seeds[-1]], 'noise_seed': noise_seed,
            'note': ('this sphere\'s tile re-rendered at the lit frame\'s samples per pixel '
                     '(scripts/captures/refine_flags.py); the rest of the frame is as rendered '
                     f'at {entry["render"]["spp"]} spp'),
        }
        tmp = truth_path + '.tmp'
        with open(tmp, 'w') as f:
            json.dump(truth, f, indent=1)
            f.write('\n')
        os.replace(tmp, truth_path)


if __name__ == '__main__':
    main()
