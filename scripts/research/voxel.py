"""Diffusion on a voxel grid of the object, lit by a directional light (issue 16's second prototype).

Solves the steady diffusion equation  -div(D grad phi) + sigma_a phi = Q  on the object's voxels
(finite volumes, Robin boundary phi + 2 A D dphi/dn = 0), with Q the light scattered out of the
collimated beam: E * albedo * sigma_t * exp(-sigma_t * s), s the path length inside the object
along the light (cast shadows and thin parts come out of the same sum). Radiance leaving the
surface: the P1 angular distribution  phi_s / (4 pi) * (1 + 3/(2A) cos(view)).

usage: python3 voxel.py STEM [H_MM] [SIGMA_A_R,G,B] [D_MM]
  STEM: knot | knot-view2 | torus | sphereR (e.g. sphere35)
"""
import os, sys, json, time
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import numpy as np, OpenEXR
import scipy.sparse as sp
import pyamg
from scipy.spatial import cKDTree

SHARED = os.path.join(HERE, '..', '..', '..', 'shared', 'data')


def load_obj(path):
    V, F = [], []
    for line in open(path):
        if line.startswith('v '):
            V.append([float(x) for x in line.split()[1:4]])
        elif line.startswith('f '):
            F.append([int(x.split('/')[0]) - 1 for x in line.split()[1:4]])
    return np.array(V), np.array(F)


def icosphere(r, level=6):
    t = (1 + 5 ** 0.5) / 2
    V = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
         (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    F = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6),
         (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7),
         (9, 8, 1)]
    V = [np.array(v, float) / np.linalg.norm(v) for v in V]
    for _ in range(level):
        cache = {}
        def mid(a, b):
            k = (min(a, b), max(a, b))
            if k not in cache:
                m = V[a] + V[b]; V.append(m / np.linalg.norm(m)); cache[k] = len(V) - 1
            return cache[k]
        F2 = []
        for a, b, c in F:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            F2 += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        F = F2
    return np.array(V) * r, np.array(F)


def light_frame(travel):
    """Rows: x along the light's travel, y and z across it."""
    x = travel / np.linalg.norm(travel)
    y = np.cross(x, [0, 0, 1.0])
    if np.linalg.norm(y) < 1e-3:
        y = np.cross(x, [0, 1.0, 0])
    y /= np.linalg.norm(y)
    return np.stack([x, y, np.cross(x, y)])


def column_crossings(Vl, F, h, origin):
    """Per (j, k) column of the light-frame grid: sorted x of the surface crossings."""
    A, B, C = Vl[F[:, 0]], Vl[F[:, 1]], Vl[F[:, 2]]
    lo = np.minimum(np.minimum(A, B), C); hi = np.maximum(np.maximum(A, B), C)
    j0 = np.ceil((lo[:, 1] - origin[1]) / h - 0.5).astype(int); j1 = np.floor((hi[:, 1] - origin[1]) / h - 0.5).astype(int)
    k0 = np.ceil((lo[:, 2] - origin[2]) / h - 0.5).astype(int); k1 = np.floor((hi[:, 2] - origin[2]) / h - 0.5).astype(int)
    span = max(int((j1 - j0).max()) + 1, int((k1 - k0).max()) + 1, 1)
    keys, xs = [], []
    for dj in range(span):
        for dk in range(span):
            j = j0 + dj; k = k0 + dk
            ok = (j <= j1) & (k <= k1)
            if not ok.any():
                continue
            idx = np.nonzero(ok)[0]
            py = origin[1] + (j[idx] + 0.5) * h; pz = origin[2] + (k[idx] + 0.5) * h
            a, b, c = A[idx], B[idx], C[idx]
            # barycentric in the (y, z) projection
            d = (b[:, 1] - a[:, 1]) * (c[:, 2] - a[:, 2]) - (c[:, 1] - a[:, 1]) * (b[:, 2] - a[:, 2])
            w1 = ((py - a[:, 1]) * (c[:, 2] - a[:, 2]) - (c[:, 1] - a[:, 1]) * (pz - a[:, 2])) / np.where(d == 0, 1, d)
            w2 = ((b[:, 1] - a[:, 1]) * (pz - a[:, 2]) - (py - a[:, 1]) * (b[:, 2] - a[:, 2])) / np.where(d == 0, 1, d)
            w0 = 1 - w1 - w2
            hit = (d != 0) & (w0 >= 0) & (w1 >= 0) & (w2 >= 0)
            x = w0 * a[:, 0] + w1 * b[:, 0] + w2 * c[:, 0]
            keys.append((j[idx][hit], k[idx][hit])); xs.append(x[hit])
    jj = np.concatenate([k[0] for k in keys]); kk = np.concatenate([k[1] for k in keys]); xx = np.concatenate(xs)
    return jj, kk, xx


def voxelize(V, F, travel, h, pad=2):
    R = light_frame(travel)
    Vl = V @ R.T
    rng = np.random.default_rng(7)
    origin = Vl.min(0) - pad * h + rng.random(3) * 1e-3 * h  # jitter: no column centre on an edge
    n = np.ceil((Vl.max(0) + pad * h - origin) / h).astype(int)
    jj, kk, xx = column_crossings(Vl, F, h, origin)
    order = np.lexsort((xx, kk, jj)); jj, kk, xx = jj[order], kk[order], xx[order]
    inside = np.zeros(n, bool)
    power = np.zeros(n)  # fraction of the column's entering flux scattered in each voxel (times albedo later)
    first_x = np.full((n[1], n[2]), np.inf)
    bad = 0
    col = jj * n[2] + kk
    starts = np.r_[0, np.nonzero(np.diff(col))[0] + 1, len(col)]
    xc = origin[0] + (np.arange(n[0]) + 0.5) * h
    x0 = xc - h / 2; x1 = xc + h / 2
    for s, e in zip(starts[:-1], starts[1:]):
        if (e - s) % 2:
            bad += 1
            continue
        j, k = jj[s], kk[s]
        cr = xx[s:e]
        first_x[j, k] = cr[0]
        acc = 0.0
        cum_lo = np.zeros(n[0]); cum_hi = np.zeros(n[0]); any_in = np.zeros(n[0], bool)
        depth_at = np.zeros(n[0])
        for a, b in zip(cr[0::2], cr[1::2]):
            m = (xc >= a) & (xc < b)
            if not m.any():  # thinner than a voxel: deposit in the voxel holding its middle
                m = np.zeros(n[0], bool); m[min(max(int((0.5 * (a + b) - origin[0]) / h), 0), n[0] - 1)] = True
            inside[:, j, k] |= m
            # every bit of the interval belongs to one inside voxel: the first reaches back to
            # the entry, the last on to the exit
            lo = np.clip(x0, a, b); hi = np.clip(x1, a, b)
            first, last = np.nonzero(m)[0][[0, -1]]
            lo[first] = a; hi[last] = b
            # path length inside before lo and hi
            cum_lo[m] = acc + (lo[m] - a); cum_hi[m] = acc + (hi[m] - a)
            power[m, j, k] += np.exp(-cum_lo[m]) - np.exp(-cum_hi[m])  # sigma_t = 1 / mm below
            acc += b - a
    return dict(R=R, origin=origin, h=h, n=n, inside=inside, power=power, first_x=first_x, bad_columns=bad)


def solve(vox, sigma_t, albedo, D, A=1.0, E=1.0):
    """phi per inside voxel for each channel; returns phi grids (3, nx, ny, nz)."""
    inside = vox['inside']; h = vox['h']; n = vox['n']
    idx = -np.ones(n, np.int64); cells = np.nonzero(inside.ravel())[0]
    idx.ravel()[cells] = np.arange(len(cells))
    N = len(cells)
    coords = np.stack(np.unravel_index(cells, n), -1)
    rows, cols, vals = [], [], []
    boundary_faces = np.zeros(N)
    for axis in range(3):
        for step in (-1, 1):
            c2 = coords.copy(); c2[:, axis] += step
            okb = (c2[:, axis] >= 0) & (c2[:, axis] < n[axis])
            nb = np.full(N, -1)
            nb[okb] = idx[c2[okb, 0], c2[okb, 1], c2[okb, 2]]
            interior = nb >= 0
            rows.append(np.nonzero(interior)[0]); cols.append(nb[interior]); vals.append(np.full(interior.sum(), -D / h ** 2))
            boundary_faces += ~interior
    off = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(N, N))
    interior_faces = 6 - boundary_faces
    robin = 2 * D / (h * (h + 4 * A * D))
    phis = []
    for c in range(3):
        sigma_a = sigma_t * (1 - albedo[c])
        diag = interior_faces * D / h ** 2 + boundary_faces * robin + sigma_a
        M = off + sp.diags(diag)
        q = E * albedo[c] * vox['power'].ravel()[cells] * (h * h) / h ** 3  # power per volume
        ml = pyamg.smoothed_aggregation_solver(M.tocsr(), symmetry='symmetric')
        t = time.time()
        x = ml.solve(q, tol=1e-8, accel='cg')
        print(f'  channel {c}: {N} cells, solve {time.time() - t:.1f} s, residual {np.linalg.norm(M @ x - q) / np.linalg.norm(q):.1e}')
        g = np.zeros(n); g.ravel()[cells] = x
        phis.append(g)
    return np.stack(phis), robin


def surface_phi(vox, phi, pts, nrm, D, A=1.0):
    """Extrapolate phi to the surface at world points (with outward normals) from the inside voxels."""
    R, origin, h, n = vox['R'], vox['origin'], vox['h'], vox['n']
    inside = vox['inside']
    out = np.zeros((len(pts), 3)); wsum = np.zeros(len(pts))
    pl = pts @ R.T; nl = nrm @ R.T
    zb = 2 * A * D
    # phi grows linearly inward from zero at the extrapolated boundary: phi(z) = slope (z + zb);
    # take the inside voxels within 1.5 h of the point, estimate phi_s = phi_i * zb / (z_i + zb).
    base = np.floor((pl - origin) / h - 0.5).astype(int)
    for di in range(-1, 3):
        for dj in range(-1, 3):
            for dk in range(-1, 3):
                c = base + [di, dj, dk]
                ok = np.all((c >= 0) & (c < n), 1)
                c = np.clip(c, 0, n - 1)
                ins = ok & inside[c[:, 0], c[:, 1], c[:, 2]]
                centre = origin + (c + 0.5) * h
                z = -np.einsum('ij,ij->i', centre - pl, nl)  # depth below the tangent plane
                dist = np.linalg.norm(centre - pl, axis=1)
                w = np.where(ins & (z > 0) & (dist < 1.6 * h), np.exp(-(dist / h) ** 2), 0)
                val = phi[:, c[:, 0], c[:, 1], c[:, 2]].T * (zb / (z + zb))[:, None]
                out += w[:, None] * val; wsum += w
    return out / np.maximum(wsum, 1e-12)[:, None], wsum > 0


def reference(stem):
    """(meta, reference radiance, coverage, positions, normals, (V, F)) for a data-set stem."""
    if stem.startswith('sphere'):
        r = float(stem[6:])
        base = os.path.join(SHARED, 'wax-spheres', f'sphere_r{int(r)}')
        meta = json.load(open(base + '.json'))
        ref = OpenEXR.File(base + '.exr').parts[0].channels['RGB'].pixels.astype(np.float64)
        mpp = r / 230
        i = np.arange(512)
        x = (i[None, :] + 0.5 - 256) * mpp; y = (256 - i[:, None] - 0.5) * mpp
        x, y = np.broadcast_arrays(x, y)
        rho2 = x * x + y * y
        cov = (np.sqrt(rho2) < r - mpp).astype(float)
        z = np.sqrt(np.maximum(r * r - rho2, 0))
        pp = np.stack([x, y, z], -1); nn = pp / r
        meta.setdefault('camera', {})['vector_to_camera_V'] = [0, 0, 1]
        meta.setdefault('light', {})['vector_to_light_L'] = [-1, 0, 0]
        return meta, ref, cov, pp, nn, icosphere(r, 6)
    base = os.path.join(SHARED, 'wax-knot' if 'knot' in stem else 'wax-torus')
    meta = json.load(open(os.path.join(base, stem + '.json')))
    ref = OpenEXR.File(os.path.join(base, stem + '.exr')).parts[0].channels['RGB'].pixels.astype(np.float64)
    aov = OpenEXR.File(os.path.join(base, stem + '_aov.exr')).parts[0].channels
    cov = aov['coverage'].pixels
    pp = np.stack([aov['pp.X'].pixels, aov['pp.Y'].pixels, aov['pp.Z'].pixels], -1) / np.maximum(cov, 1e-9)[..., None]
    nn = np.stack([aov['nn.X'].pixels, aov['nn.Y'].pixels, aov['nn.Z'].pixels], -1)
    nn /= np.maximum(np.linalg.norm(nn, axis=-1), 1e-9)[..., None]
    return meta, ref, cov, pp, nn, load_obj(os.path.join(base, 'knot.obj' if 'knot' in stem else 'torus.obj'))


BINS = [0, 50, 70, 80, 90, 100, 110, 130, 180]


def binned(deg, cast, pred, ref, label):
    lum = lambda x: x.mean(-1)
    out = []
    for i in range(len(BINS) - 1):
        m = (deg >= BINS[i]) & (deg < BINS[i + 1]) & ~cast
        out.append(lum(pred[m]).sum() / lum(ref[m]).sum())
    out.append(lum(pred[cast]).sum() / max(lum(ref[cast]).sum(), 1e-12))
    print(f'{label:28s}', ' '.join(f'{x:5.2f}' for x in out))
    return out


def main():
    stem = sys.argv[1]
    h = float(sys.argv[2]) if len(sys.argv) > 2 else 0.5
    albedo = np.array([0.997, 0.993, 0.985]); sigma_t = 1.0
    if len(sys.argv) > 3:
        albedo = 1 - np.array([float(x) for x in sys.argv[3].split(',')]) / sigma_t
    D = float(sys.argv[4]) if len(sys.argv) > 4 else 1 / (3 * sigma_t)
    meta, ref, cov, pp, nn, (V, F) = reference(stem)
    to_light = np.array(meta['light']['vector_to_light_L'])
    t = time.time()
    vox = voxelize(V, F, -to_light, h)
    print(f'voxels {vox["n"]}, inside {vox["inside"].sum()}, odd columns {vox["bad_columns"]}, {time.time() - t:.1f} s')
    phi, _ = solve(vox, sigma_t, albedo, D)
    mask = cov > 0.999
    pts = pp[mask]; nrm = nn[mask]; Lref = ref[mask]
    phis, ok = surface_phi(vox, phi, pts, nrm, D)
    camV = np.array(meta['camera']['vector_to_camera_V'])
    cos_view = np.clip(nrm @ camV, 0, 1)
    pred = phis / (4 * np.pi) * (1 + 1.5 * cos_view)[:, None]
    cth = nrm @ to_light; deg = np.degrees(np.arccos(np.clip(cth, -1, 1)))
    pl = pts @ vox['R'].T
    j = np.floor((pl[:, 1] - vox['origin'][1]) / h).astype(int); k = np.floor((pl[:, 2] - vox['origin'][2]) / h).astype(int)
    fx = vox['first_x'][np.clip(j, 0, vox['n'][1] - 1), np.clip(k, 0, vox['n'][2] - 1)]
    cast = (cth > 0.05) & (pl[:, 0] > fx + 1.0)
    print('missing surface samples', (~ok).sum())
    print(f'{"ratio render / reference":28s}', ' '.join(f'{BINS[i]}-{BINS[i + 1]}'.rjust(5) for i in range(len(BINS) - 1)), ' cast')
    binned(deg, cast, pred, Lref, 'voxel diffusion (P1 exit)')
    np.savez(os.path.join('/tmp', f'voxel_{stem}_{h}.npz'), pred=pred, ref=Lref, deg=deg, cast=cast, mask=mask,
             pts=pts, nrm=nrm)
    img = np.zeros_like(ref); img[mask] = pred
    hdr = {'compression': OpenEXR.ZIP_COMPRESSION, 'type': OpenEXR.scanlineimage}
    OpenEXR.File(hdr, {'RGB': img.astype(np.float32)}).write(f'/tmp/voxel_{stem}.exr')


if __name__ == '__main__':
    main()
