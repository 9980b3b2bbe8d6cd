import os, sys
HERE = os.path.dirname(os.path.abspath(__file__))
import sys; sys.path.insert(0, HERE)
from common import *
import sphere_basis
L = load_lut()
ells = np.array([0.5,1,2,3,4,6,8,12,16,24.])
thetas = np.linspace(0,np.pi,61)
m=float(sys.argv[1]); p=0.8
train=[int(x) for x in sys.argv[2].split(',')]; test=[15,20]
cols = slice(None) if m>=0 else slice(0,len(ells))
A=np.vstack([sphere_basis.sb(r,thetas,ells,p,abs(m))[:,cols] for r in train]); Y=np.vstack([lut_row(L,1/r)[::6] for r in train])
for c in range(3):
    y=Y[:,c]; wr=1/np.maximum(y,0.002); w,_=nnls(A*wr[:,None],y*wr)
    for r in test:
        pr=sphere_basis.sb(r,thetas,ells,p,abs(m))[:,cols]@w; yt=lut_row(L,1/r)[::6][:,c]
        print(c,r,' '.join(f'{t:.0f}:{a/b:.2f}' for t,a,b in zip(np.degrees(thetas[30::5]),pr[30::5],yt[30::5])))
