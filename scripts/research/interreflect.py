"""Is the knot's shadow-side glow light that left one strand and entered another through the air?

One bounce of inter-reflection between the object's own surfaces, estimated on top of the voxel
diffusion solution (voxel.py): emitters are mesh faces with the diffusion's exitance M (Lambertian
radiance M / pi), receivers the reference pixels; visibility by marching through the voxel grid.
The received irradiance E_ind re-enters the wax; it leaves again with the wax's diffuse albedo
(measured on the spheres: the lit-side LUT at theta = 0), roughly E_ind * f(0) / pi.

usage: python3 interreflect.py STEM [H_MM]
"""
import sys, os, time
HERE = os.path.dirname(os.path.abspath(__file__)); sys.path.insert(0, HERE)
from voxel import *

stem = sys.argv[1]; h = float(sys.argv[2]) if len(sys.argv) > 2 else 0.5
albedo = np.array([0.997, 0.993, 0.985]); D = 1 / 3
meta, ref, cov, pp, nn, (V, F) = reference(stem)
to_light = np.array(meta['light']['vector_to_light_L'])
vox = voxelize(V, F, -to_light, h)
phi, _ = solve(vox, 1.0, albedo, D)
# emitters: face centroids, exitance from the diffusion solution
c = V[F].mean(1); fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]); area = np.linalg.norm(fn, axis=1) / 2
fn /= (2 * area)[:, None]
rng = np.random.default_rng(3)
pick = rng.choice(len(F), size=min(6000, len(F)), replace=False, p=area / area.sum())
w_area = area.sum() / len(pick)
ephi, ok = surface_phi(vox, phi, c[pick], fn[pick], D)
M_e = ephi / 2  # exitance of each emitter (per channel)
# Second emitter model: the measured table, which our renderer reproduces on the lit side to a
# few per cent: exitance ≈ f(κ, θ) E (the LUT convention f = π L / E, its view factor ≈ 1).
from common import load_lut, lut_value
def vertex_mean_curvature(V, F):
    e0 = V[F[:, 1]] - V[F[:, 0]]; e1 = V[F[:, 2]] - V[F[:, 0]]
    fnv = np.cross(e0, e1); ar = np.linalg.norm(fnv, axis=1) / 2
    vn = np.zeros_like(V)
    for i in range(3):
        np.add.at(vn, F[:, i], fnv)
    vn /= np.linalg.norm(vn, axis=1)[:, None]
    lap = np.zeros_like(V); A = np.zeros(len(V))
    for i in range(3):
        a, b, cc = F[:, i], F[:, (i + 1) % 3], F[:, (i + 2) % 3]
        u = V[b] - V[a]; w = V[cc] - V[a]
        cot = np.sum(u * w, 1) / np.linalg.norm(np.cross(u, w), axis=1)
        np.add.at(lap, b, (cot / 2)[:, None] * (V[cc] - V[b])); np.add.at(lap, cc, (cot / 2)[:, None] * (V[b] - V[cc]))
        np.add.at(A, a, ar / 3)
    return -np.sum(lap * vn, 1) / A / 2
LUT = load_lut()
kappa_face = vertex_mean_curvature(V, F)[F[pick]].mean(1)
theta_face = np.arccos(np.clip(fn[pick] @ to_light, -1, 1))
# cast shadows of the emitters: the light's first surface along each emitter's column
pl_e = c[pick] @ vox['R'].T
je = np.floor((pl_e[:, 1] - vox['origin'][1]) / h).astype(int); ke = np.floor((pl_e[:, 2] - vox['origin'][2]) / h).astype(int)
first_e = vox['first_x'][np.clip(je, 0, vox['n'][1] - 1), np.clip(ke, 0, vox['n'][2] - 1)]
lit_e = ~((fn[pick] @ to_light > 0.05) & (pl_e[:, 0] > first_e + 1.0))
M_lut = lut_value(LUT, np.clip(kappa_face, LUT['kmin'], LUT['kmax']), theta_face) * lit_e[:, None]
# receivers: reference pixels, every 4th
mask = cov > 0.999
sub = np.zeros_like(mask); sub[::4, ::4] = True; mask &= sub
pts = pp[mask]; nrm = nn[mask]; Lref = ref[mask]
rphi, _ = surface_phi(vox, phi, pts, nrm, D)
camV = np.array(meta['camera']['vector_to_camera_V'])
cos_view = np.clip(nrm @ camV, 0, 1)
direct = rphi / (4 * np.pi) * (1 + 1.5 * cos_view)[:, None]
# visibility by marching through the inside mask (coarse: every h, from 1.5 h off each end)
R, origin, n = vox['R'], vox['origin'], vox['n']
inside = vox['inside']
def blocked(a, b):
    d = b - a; L = np.linalg.norm(d, axis=-1)
    steps = int(np.ceil(L.max() / h))
    hit = np.zeros(a.shape[:-1], bool)
    for s in range(steps):
        t = (1.5 * h + s * h) / np.maximum(L, 1e-9)
        live = t < 1 - 1.5 * h / np.maximum(L, 1e-9)
        q = a + d * np.minimum(t, 1)[..., None]
        ql = (q @ R.T - origin) / h
        ci = np.floor(ql).astype(int)
        okc = np.all((ci >= 0) & (ci < n), -1)
        ci = np.clip(ci, 0, n - 1)
        hit |= live & okc & inside[ci[..., 0], ci[..., 1], ci[..., 2]]
    return hit
E_ind = np.zeros((len(pts), 3)); E_lut = np.zeros((len(pts), 3))
t0 = time.time()
ce, ne = c[pick], fn[pick]
for s in range(0, len(pts), 64):
    p = pts[s:s + 64, None, :]; nr = nrm[s:s + 64, None, :]
    d = ce[None] - p; dist2 = (d * d).sum(-1); dist = np.sqrt(dist2)
    u = d / dist[..., None]
    cr = (u * nr).sum(-1); cemit = -(u * ne[None]).sum(-1)
    good = (cr > 0) & (cemit > 0) & (dist > 2 * h)
    vis = good & ~blocked(np.broadcast_to(p, d.shape), np.broadcast_to(ce[None], d.shape))
    geom = np.where(vis, cr * cemit / np.maximum(dist2, (2 * h) ** 2), 0) * w_area / np.pi
    E_ind[s:s + 64] = geom @ M_e
    E_lut[s:s + 64] = geom @ M_lut
print(f'inter-reflection gather {time.time() - t0:.0f} s for {len(pts)} receivers x {len(pick)} emitters')
from common import lut_row
f0 = lut_row(LUT, 1 / 35.0)[0]
second = E_ind * f0[None] / np.pi
cth = nrm @ to_light; deg = np.degrees(np.arccos(np.clip(cth, -1, 1)))
pl = pts @ R.T
j = np.floor((pl[:, 1] - origin[1]) / h).astype(int); k = np.floor((pl[:, 2] - origin[2]) / h).astype(int)
fx = vox['first_x'][np.clip(j, 0, n[1] - 1), np.clip(k, 0, n[2] - 1)]
cast = (cth > 0.05) & (pl[:, 0] > fx + 1.0)
print(f'{"ratio render / reference":28s}', ' '.join(f'{BINS[i]}-{BINS[i + 1]}'.rjust(5) for i in range(len(BINS) - 1)), ' cast')
binned(deg, cast, direct, Lref, 'diffusion, no bounce')
binned(deg, cast, second, Lref, 'one inter-reflection alone')
binned(deg, cast, direct + second, Lref, 'diffusion + inter-reflection')
binned(deg, cast, E_lut * f0[None] / np.pi, Lref, 'bounce from measured table')
lum = lambda x: x.mean(-1)
for lo, hi in [(110, 180)]:
    m = (deg >= lo) & ~cast
    print(f'theta >= {lo}: reference mean radiance {lum(Lref[m]).mean():.4f}, diffusion {lum(direct[m]).mean():.4f}, bounce {lum(second[m]).mean():.4f}')
np.savez(f'/tmp/inter_{stem}.npz', direct=direct, second=second, ref=Lref, deg=deg, cast=cast)
