"""Fits the radial profile to the measured table's sphere rows (see docs/research/diffusion-gather.md).

usage: python3 fit.py M P
  M < 0: the plain kernel R(d); M >= 0: R_a(d) + s^M R_b(d) (s: depth below the receiver's tangent
  plane over d). P: the entry-cosine power of h(mu) = mu^P. Writes w.npy (weights, 3 x 2K) and
  ells.npy next to this file.
"""
import os, sys
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from common import *
import sphere_basis
L = load_lut()
ells = np.array([0.5,1,2,3,4,6,8,12,16,24.])
radii = [15,20,25,30,35,40,45,50]
thetas = np.linspace(0,np.pi,61)
m=float(sys.argv[1]); p=float(sys.argv[2])
K=len(ells)
A=np.vstack([sphere_basis.sb(r, thetas, ells, p, abs(m)) for r in radii])
if m < 0:
    A[:, K:] = 0.0  # the plain kernel: no oriented part
Y=np.vstack([lut_row(L,1/r)[::6] for r in radii])
W=[]
for c in range(3):
    y=Y[:,c]; wr=1/np.maximum(y,0.002)
    w,_=nnls(A*wr[:,None],y*wr); pred=A@w; W.append(w)
    rel=(pred-y)/np.maximum(y,1e-4); mk=y>0.002
    print('c',c,'a',np.round(w[:K],3),'b',np.round(w[K:],3),'rms',np.sqrt(np.mean(rel[mk]**2)).round(3))
    for i,r in enumerate(radii):
        s=slice(i*61,(i+1)*61); q=rel[s]
        print(f' r={r}', ' '.join(f'{t:.0f}:{v:+.2f}' for t,v in zip(np.degrees(thetas[::5]),q[::5])))
np.save(os.path.join(HERE,'w.npy'),np.array(W)); np.save(os.path.join(HERE,'ells.npy'),ells)
