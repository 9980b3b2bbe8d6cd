#!/usr/bin/env python3
"""Compare cdrf's mean-curvature estimator with libigl's `principal_curvature` on the same meshes.

Not part of CI. Needs Python 3 with libigl and numpy:

    python3 -m venv /tmp/igl && /tmp/igl/bin/pip install libigl numpy
    /tmp/igl/bin/python scripts/compare_libigl.py

Steps:
1. runs `cargo bench -p cdrf-core --bench curvature` with CDRF_BENCH_EXPORT=DIR, which times
   cdrf (all threads and one thread) and writes, per case, NAME.obj (the exact f32 mesh),
   NAME.truth.txt (analytic mean curvature per vertex), NAME.cdrf.txt (cdrf's estimate) and
   cdrf_timings.json;
2. loads every NAME.obj, times `igl.principal_curvature(V, F, radius)` (best of a few runs; the
   1M-vertex mesh once) and takes its mean curvature H = (PV1 + PV2) / 2;
3. prints RMS / max relative error of both against the analytic values, and the speed ratio;
4. times whole processes on the 1M-vertex torus: the release `cdrf-curvature` binary (read OBJ,
   weld, estimate, write CSV) against a Python process doing the same with libigl (import,
   `read_triangle_mesh`, `principal_curvature`, write CSV).

Sign: libigl's principal values come from a quadric fitted along its own per-vertex normals;
on these outward-wound meshes they are positive on the sphere, like cdrf's (checked below).
"""

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

try:
    import igl
except ImportError:
    sys.exit("libigl is not installed: pip install libigl numpy")

if not hasattr(igl, "principal_curvature"):
    sys.exit(f"this libigl ({getattr(igl, '__file__', '?')}) has no principal_curvature")

REPO = Path(__file__).resolve().parent.parent


def relative_error(estimate, truth):
    r = (estimate - truth) / truth
    return float(np.sqrt(np.mean(r * r))), float(np.max(np.abs(r)))


def load_values(path):
    return np.loadtxt(path, dtype=np.float64)


def time_igl(V, F, radius, runs):
    best_wall, best_cpu, result = float("inf"), float("inf"), None
    for _ in range(runs):
        wall, cpu = time.perf_counter(), time.process_time()
        result = igl.principal_curvature(V, F, radius)
        best_wall = min(best_wall, time.perf_counter() - wall)
        best_cpu = min(best_cpu, time.process_time() - cpu)
    pv1, pv2 = result[2], result[3]
    bad = len(result[4]) if len(result) > 4 else 0
    return best_wall, best_cpu, 0.5 * (pv1 + pv2), bad


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--dir", type=Path, default=Path("/tmp/cdrf-libigl"),
                        help="where the benchmark exports its meshes (default %(default)s)")
    parser.add_argument("--skip-bench", action="store_true",
                        help="reuse an earlier export instead of running cargo bench")
    parser.add_argument("--radius", type=int, nargs="+", default=[5, 2],
                        help="libigl neighbourhood radii to try (5 is libigl's default)")
    args = parser.parse_args()

    if not args.skip_bench:
        env = dict(os.environ, CDRF_BENCH_EXPORT=str(args.dir))
        subprocess.run(["cargo", "bench", "-p", "cdrf-core", "--bench", "curvature"],
                       cwd=REPO, env=env, check=True)
    timings = json.loads((args.dir / "cdrf_timings.json").read_text())
    threads = timings["threads"]
    print(f"\nlibigl {getattr(igl, '__version__', '?')}, numpy {np.__version__}; "
          f"cdrf on {threads} threads and on 1 thread\n")

    rows = []
    for name, t in timings["cases"].items():
        V, F = igl.read_triangle_mesh(str(args.dir / f"{name}.obj"))
        V = np.ascontiguousarray(V, dtype=np.float64)
        F = np.ascontiguousarray(F, dtype=np.int64)
        truth = load_values(args.dir / f"{name}.truth.txt")
        cdrf = load_values(args.dir / f"{name}.cdrf.txt")
        assert len(truth) == len(V) == len(cdrf), name
        cdrf_rms, cdrf_max = relative_error(cdrf, truth)
        runs = 1 if len(V) > 500_000 else 3
        for radius in args.radius:
            wall, cpu, h, bad = time_igl(V, F, radius, runs)
            if name.startswith("sphere") and np.mean(h) < 0:
                print(f"warning: libigl's H is negative on {name}: sign convention differs")
            igl_rms, igl_max = relative_error(h, truth)
            rows.append((name, len(V), radius, t["seconds_parallel"], t["seconds_one_thread"],
                         wall, cpu, cdrf_rms, cdrf_max, igl_rms, igl_max, bad))
            print(f"{name:>16} r={radius}: libigl {wall:8.3f} s (cpu {cpu:8.3f} s), "
                  f"cdrf {t['seconds_parallel']:7.4f} s / 1 thread {t['seconds_one_thread']:7.4f} s"
                  f" -> {wall / t['seconds_parallel']:6.1f}x / {wall / t['seconds_one_thread']:6.1f}x;"
                  f" RMS % cdrf {100 * cdrf_rms:.4f} libigl {100 * igl_rms:.4f};"
                  f" max % cdrf {100 * cdrf_max:.4f} libigl {100 * igl_max:.4f}"
                  + (f"; libigl bad vertices {bad}" if bad else ""), flush=True)

    print("\n| mesh | vertices | libigl radius | libigl s | cdrf s (threads / 1) | speed-up "
          "(threads / 1) | RMS rel. error cdrf / libigl | max rel. error cdrf / libigl |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for (name, n, radius, tp, ts, wall, _cpu, crms, cmax, irms, imax, _bad) in rows:
        print(f"| {name} | {n} | {radius} | {wall:.3f} | {tp:.4f} / {ts:.4f} | "
              f"{wall / tp:.0f}x / {wall / ts:.0f}x | {100 * crms:.3f} % / {100 * irms:.3f} % | "
              f"{100 * cmax:.3f} % / {100 * imax:.3f} % |")
    for radius in args.radius:
        whole_process(args.dir, radius)



IGL_PROCESS = """
import sys, numpy as np, igl
V, F = igl.read_triangle_mesh(sys.argv[1])
r = igl.principal_curvature(V, F, int(sys.argv[3]))
np.savetxt(sys.argv[2], np.c_[V, 0.5 * (r[2] + r[3])], delimiter=",", fmt="%.7g")
"""


def whole_process(directory, radius):
    """Wall-clock seconds of one cdrf-curvature process and one libigl process on the big torus."""
    subprocess.run(["cargo", "build", "--release", "--quiet", "-p", "cdrf-fit", "--bin",
                    "cdrf-curvature"], cwd=REPO, check=True)
    mesh = directory / "torus_1024x1024.obj"
    cdrf = [str(REPO / "target" / "release" / "cdrf-curvature"), str(mesh), "--mm-per-unit", "1",
            "--out", str(directory / "whole_cdrf.csv")]
    igl_cmd = [sys.executable, "-c", IGL_PROCESS, str(mesh), str(directory / "whole_igl.csv"),
               str(radius)]
    times = {}
    for name, cmd in [("cdrf", cdrf), ("libigl", igl_cmd)]:
        start = time.perf_counter()
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        times[name] = time.perf_counter() - start
    print(f"\nwhole process on {mesh.name} (1M vertices, libigl radius {radius}): "
          f"cdrf-curvature {times['cdrf']:.2f} s, libigl {times['libigl']:.2f} s "
          f"-> {times['libigl'] / times['cdrf']:.1f}x")


if __name__ == "__main__":
    main()
