import os, sys
HERE = os.path.dirname(os.path.abspath(__file__))
import numpy as np
from common import basis
def sb(r, thetas, ells, p, m, na=1200, nb=96):
    alpha = np.concatenate([[0], np.geomspace(1e-6, np.pi, na)])
    beta = (np.arange(nb)+0.5)*2*np.pi/nb
    d = 2*r*np.sin(alpha/2); B = basis(d, ells); s=np.sin(alpha/2)
    B = np.concatenate([B, B*(s**m)[:,None]],1)
    out = np.zeros((len(thetas), B.shape[1]))
    for i,th in enumerate(thetas):
        cq = np.cos(th)*np.cos(alpha)[:,None] + np.sin(th)*np.sin(alpha)[:,None]*np.cos(beta)[None,:]
        lit = (np.maximum(cq,0)**p).mean(axis=1)*2*np.pi
        out[i] = np.trapezoid((lit*r*r*np.sin(alpha))[:,None]*B, alpha, axis=0)
    return out
