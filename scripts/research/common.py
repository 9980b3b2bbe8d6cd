import os, sys
HERE = os.path.dirname(os.path.abspath(__file__))
import numpy as np, OpenEXR, json
from scipy.optimize import nnls

def load_lut(path=os.path.join(HERE, "..", "..", "data", "wax-fit", "measured.exr")):
    f = OpenEXR.File(path)
    lut = f.parts[0]; view = f.parts[1]
    h = lut.header
    return dict(lut=lut.channels['RGB'].pixels.astype(np.float64), kmin=h['cdrf.curvature_min_per_mm'],
                kmax=h['cdrf.curvature_max_per_mm'], view=view.channels['RGB'].pixels.astype(np.float64))

def lut_row(L, kappa):
    t = (kappa - L['kmin'])/(L['kmax']-L['kmin'])*(L['lut'].shape[0]-1)
    t = np.clip(t, 0, L['lut'].shape[0]-1); i = int(np.floor(t)); i2=min(i+1,L['lut'].shape[0]-1); a=t-i
    return (1-a)*L['lut'][i]+a*L['lut'][i2]   # (361,3) over theta 0..pi

def lut_value(L, kappa, theta):
    rows = L['lut'].shape[0]; cols = L['lut'].shape[1]
    r = np.clip((kappa - L['kmin'])/(L['kmax']-L['kmin']),0,1)*(rows-1)
    c = np.clip(theta/np.pi,0,1)*(cols-1)
    return bilinear(L['lut'], r, c)

def bilinear(T, r, c):
    r0 = np.clip(np.floor(r).astype(int),0,T.shape[0]-1); c0=np.clip(np.floor(c).astype(int),0,T.shape[1]-1)
    r1 = np.minimum(r0+1,T.shape[0]-1); c1=np.minimum(c0+1,T.shape[1]-1)
    a=(r-r0)[...,None]; b=(c-c0)[...,None]
    return (1-a)*((1-b)*T[r0,c0]+b*T[r0,c1]) + a*((1-b)*T[r1,c0]+b*T[r1,c1])

def view_value(L, theta, phi):
    V = L['view']  # rows theta (37) cols phi (19)
    r = np.clip(theta/np.pi,0,1)*(V.shape[0]-1); c=np.clip(phi/(np.pi/2),0,1)*(V.shape[1]-1)
    return bilinear(V, r, c)

def basis(d, ells):
    d = np.maximum(d, 1e-6)[...,None]
    return np.exp(-d/ells)/(2*np.pi*ells*d)

# sphere integral of basis: F[k](theta) for sphere radius r
def sphere_basis(r, thetas, ells, na=1500, nb=128):
    alpha = np.concatenate([[0], np.geomspace(1e-6, np.pi, na)])
    beta = (np.arange(nb)+0.5)*2*np.pi/nb
    d = 2*r*np.sin(alpha/2)
    B = basis(d, ells)  # na, K
    out = np.zeros((len(thetas), len(ells)))
    for i,th in enumerate(thetas):
        cq = np.cos(th)*np.cos(alpha)[:,None] + np.sin(th)*np.sin(alpha)[:,None]*np.cos(beta)[None,:]
        lit = np.maximum(cq,0).mean(axis=1)*2*np.pi  # ∫ dβ
        integrand = (lit*r*r*np.sin(alpha))[:,None]*B
        out[i] = np.trapezoid(integrand, alpha, axis=0)
    return out

def sphere_basis_h(r, thetas, ells, p, na=1200, nb=96):
    alpha = np.concatenate([[0], np.geomspace(1e-6, np.pi, na)])
    beta = (np.arange(nb)+0.5)*2*np.pi/nb
    d = 2*r*np.sin(alpha/2); B = basis(d, ells)
    out = np.zeros((len(thetas), len(ells)))
    for i,th in enumerate(thetas):
        cq = np.cos(th)*np.cos(alpha)[:,None] + np.sin(th)*np.sin(alpha)[:,None]*np.cos(beta)[None,:]
        lit = (np.maximum(cq,0)**p).mean(axis=1)*2*np.pi
        out[i] = np.trapezoid((lit*r*r*np.sin(alpha))[:,None]*B, alpha, axis=0)
    return out
