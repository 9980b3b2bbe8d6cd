import os, sys
HERE = os.path.dirname(os.path.abspath(__file__))
import sys; sys.path.insert(0, HERE)
exec(open('fit2.py').read().split("Y=np.vstack")[0])
Y=np.vstack([lut_row(L,1/r)[::6] for r in radii])
p=float(sys.argv[1])
A=np.vstack([sphere_basis_h(r,thetas,ells,p) for r in radii])
W=[]
for c in range(3):
    y=Y[:,c]; wr=1/np.maximum(y,0.002)
    w,_=nnls(A*wr[:,None],y*wr); pred=A@w; W.append(w)
    print('c',c,np.round(w,3))
    for i,r in enumerate(radii):
        s=slice(i*61,(i+1)*61); rel=(pred[s]-y[s])/np.maximum(y[s],1e-4)
        print(f' r={r}', ' '.join(f'{t:.0f}:{q:+.2f}' for t,q in zip(np.degrees(thetas[::5]),rel[::5])))
np.save(os.path.join(HERE, 'w.npy'),np.array(W)); np.save(os.path.join(HERE, 'ells.npy'),ells)
