#!/usr/bin/env python3
"""A thick, sculpted wax body in world mm (issue 37's references): an egg-like ellipsoid
(60 x 40 x 36 mm) with a raised "head" lobe and a shallow saddle dent, so it has thick convex
parts, a neck of negative curvature and no thin strands. Star-shaped about the origin, so a
displaced icosphere is a closed, manifold mesh.

  python make_blob.py OUT.obj [--level 5] [--capsule LENGTH RADIUS]

With --capsule: a capsule (a 70 x 30 mm pill, say) tilted 20° in the image plane instead.
"""
import argparse
import numpy as np

ap = argparse.ArgumentParser()
ap.add_argument("out")
ap.add_argument("--level", type=int, default=5, help="icosphere subdivisions (5: 10 242 vertices)")
ap.add_argument("--capsule", type=float, nargs=2, metavar=("LENGTH", "RADIUS"),
                help="instead: a capsule (cylinder with hemispherical ends) along x, mm")
a = ap.parse_args()

t = (1 + 5 ** 0.5) / 2
V = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
     (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
F = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
     (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5),
     (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
V = [np.array(v, float) / np.linalg.norm(v) for v in V]
for _ in range(a.level):
    mid = {}
    def m(i, j):
        k = (min(i, j), max(i, j))
        if k not in mid:
            p = V[i] + V[j]
            V.append(p / np.linalg.norm(p))
            mid[k] = len(V) - 1
        return mid[k]
    F = [f for (i, j, k) in F for f in ((i, m(i, j), m(k, i)), (j, m(j, k), m(i, j)),
                                        (k, m(k, i), m(j, k)), (m(i, j), m(j, k), m(k, i)))]
U = np.array(V)
if a.capsule:
    # Distance along each direction to the capsule's surface (segment half-length h, radius R).
    h, R = a.capsule[0] / 2 - a.capsule[1], a.capsule[1]
    ux, rho = np.abs(U[:, 0]), np.hypot(U[:, 1], U[:, 2])
    side = R / np.maximum(rho, 1e-9)
    # Beyond the cylinder's end: the end cap sphere centred at (h, 0, 0).
    b = ux * h
    cap = b + np.sqrt(np.maximum(b * b - (h * h - R * R), 0))
    r = np.where(side * ux <= h, side, cap)
    P = U * r[:, None]
else:
    P = None
semi = np.array([30.0, 20.0, 18.0])
r = 1 / np.sqrt(((U / semi) ** 2).sum(1))
if P is not None:
    r = np.linalg.norm(P, axis=1)
head = np.array([0.75, 0.6, 0.28]); head /= np.linalg.norm(head)
dent = np.array([-0.2, -0.9, 0.4]); dent /= np.linalg.norm(dent)
r *= 1 if a.capsule else 1 + 0.22 * np.exp((U @ head - 1) / 0.06) - 0.07 * np.exp((U @ dent - 1) / 0.05)
P = U * r[:, None]
if a.capsule:
    # Tilted 20° in the image plane, so its axis is neither the light's nor the image's.
    c, s_ = np.cos(np.radians(20)), np.sin(np.radians(20))
    P = P @ np.array([[c, -s_, 0], [s_, c, 0], [0, 0, 1]]).T
P -= (P.max(0) + P.min(0)) / 2
with open(a.out, "w") as f:
    f.write(f"# make_blob.py --level {a.level}: {len(P)} vertices, world mm\n")
    for p in P:
        f.write(f"v {p[0]:.6f} {p[1]:.6f} {p[2]:.6f}\n")
    for i, j, k in F:
        f.write(f"f {i + 1} {j + 1} {k + 1}\n")
print(f"{len(P)} vertices, {len(F)} faces, bbox {P.min(0).round(2)} .. {P.max(0).round(2)}")
