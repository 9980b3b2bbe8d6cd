import os, sys
HERE = os.path.dirname(os.path.abspath(__file__))
import sys; sys.path.insert(0, HERE)
from common import *
L = load_lut()
ells = np.array([0.5,1,2,3,4,6,8,12,16,24.])
radii = [15,20,25,30,35,40,45,50]
thetas = np.linspace(0,np.pi,61)
m=float(sys.argv[1]); p=float(sys.argv[2])
def sb(r, na=1200, nb=96):
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
A=np.vstack([sb(r) for r in radii]); Y=np.vstack([lut_row(L,1/r)[::6] for r in radii])
W=[]
for c in range(3):
    y=Y[:,c]; wr=1/np.maximum(y,0.002)
    w,_=nnls(A*wr[:,None],y*wr); pred=A@w; W.append(w)
    rel=(pred-y)/np.maximum(y,1e-4); mk=y>0.002
    print('c',c,'a',np.round(w[:len(ells)],3),'b',np.round(w[len(ells):],3),'rms',np.sqrt(np.mean(rel[mk]**2)).round(3))
np.save('w_s.npy',np.array(W)); np.save('ells_s.npy',ells)
