"""Gathers the fitted profile over the knot's (or torus's) lit surface and bins render / reference by
theta (see docs/research/diffusion-gather.md).

usage: python3 knot.py STEM P WEIGHTS.npy [TEXEL_MM [STRIDE]]   (STEM: knot | knot-view2 | torus)
"""
import os, sys
HERE = os.path.dirname(os.path.abspath(__file__))
import sys, json; sys.path.insert(0, HERE)
from common import *
from scipy.spatial import cKDTree
stem = sys.argv[1]; p_entry=float(sys.argv[2]); wfile=sys.argv[3]
h = float(sys.argv[4]) if len(sys.argv)>4 else 0.35
base = os.path.join(HERE, '..', '..', '..', 'shared', 'data') + '/' + ('wax-knot/' if 'knot' in stem else 'wax-torus/')
aovstem = {'knot':'knot','knot-view2':'knot-view2','torus':'torus'}[stem]
meta = json.load(open(base+stem+'.json'))
objf = base + ('knot.obj' if 'knot' in stem else 'torus.obj')
V=[];F=[]
for line in open(objf):
    if line.startswith('v '): V.append([float(x) for x in line.split()[1:4]])
    elif line.startswith('f '): F.append([int(x.split('/')[0])-1 for x in line.split()[1:4]])
V=np.array(V); F=np.array(F)
# vertex normals & mean curvature (cotan)
e0=V[F[:,1]]-V[F[:,0]]; e1=V[F[:,2]]-V[F[:,0]]; fn=np.cross(e0,e1); area=np.linalg.norm(fn,axis=1)/2
vn=np.zeros_like(V); np.add.at(vn,F[:,0],fn); np.add.at(vn,F[:,1],fn); np.add.at(vn,F[:,2],fn); vn/=np.linalg.norm(vn,axis=1)[:,None]
lap=np.zeros_like(V); A=np.zeros(len(V))
for i in range(3):
    a,b,c=F[:,i],F[:,(i+1)%3],F[:,(i+2)%3]
    u=V[b]-V[a]; w=V[c]-V[a]; cot=np.sum(u*w,1)/np.linalg.norm(np.cross(u,w),axis=1)
    # angle at a is opposite edge b-c
    np.add.at(lap,b,(cot/2)[:,None]*(V[c]-V[b])); np.add.at(lap,c,(cot/2)[:,None]*(V[b]-V[c]))
    np.add.at(A,a,area/3)
Hn = -np.sum(lap*vn,1)/A/2  # mean curvature, positive convex
tl = np.array(meta['light']['vector_to_light_L']); t=-tl
u = np.cross(t,[0,0,1.]); 
if np.linalg.norm(u)<1e-3: u=np.cross(t,[0,1.,0])
u/=np.linalg.norm(u); v=np.cross(t,u)
# sample surface
rng=np.random.default_rng(1)
ns = np.maximum(1,np.round(area/(h*h)*12).astype(int))
fi = np.repeat(np.arange(len(F)), ns)
r1=np.sqrt(rng.random(len(fi))); r2=rng.random(len(fi))
P = V[F[fi,0]]*(1-r1)[:,None] + V[F[fi,1]]*(r1*(1-r2))[:,None] + V[F[fi,2]]*(r1*r2)[:,None]
N = fn[fi]/np.linalg.norm(fn[fi],axis=1)[:,None]
pu=P@u; pv=P@v; pd=P@t
iu=np.floor(pu/h).astype(int); iv=np.floor(pv/h).astype(int)
iu-=iu.min(); iv-=iv.min(); W=iu.max()+1
key=iu*(iv.max()+1)+iv
order=np.lexsort((pd,key)); key_s=key[order]; first=np.ones(len(order),bool); first[1:]=key_s[1:]!=key_s[:-1]
sel=order[first]
mu=np.clip(N[sel]@tl,1e-3,1)
# texel-centre positions: use the sample's own position (first-surface)
Q=P[sel]; flux=h*h*mu**(p_entry-1)
print('lit texels',len(sel))
shadow_key = dict(zip(key[sel], pd[sel]))
ells=np.load(os.path.join(HERE, 'ells.npy')); w=np.load(wfile); K=len(ells)
dd=np.linspace(0,200,20001); Ra=np.stack([basis(np.maximum(dd,1e-4),ells)@w[c][:K] for c in range(3)],1); Rb=np.stack([basis(np.maximum(dd,1e-4),ells)@w[c][K:] for c in range(3)],1)
M=1.0
def Ra_(d): return np.stack([np.interp(d,dd,Ra[:,c]) for c in range(3)],-1)
def Rb_(d): return np.stack([np.interp(d,dd,Rb[:,c]) for c in range(3)],-1)
def R(d): 
    return None
# reference
ref=OpenEXR.File(base+stem+'.exr').parts[0].channels['RGB'].pixels.astype(np.float64)
aov=OpenEXR.File(base+aovstem+'_aov.exr').parts[0].channels
cov=aov['coverage'].pixels
pp=np.stack([aov['pp.X'].pixels,aov['pp.Y'].pixels,aov['pp.Z'].pixels],-1)/np.maximum(cov,1e-9)[...,None]
nn=np.stack([aov['nn.X'].pixels,aov['nn.Y'].pixels,aov['nn.Z'].pixels],-1); nn/=np.maximum(np.linalg.norm(nn,axis=-1),1e-9)[...,None]
stride=int(sys.argv[5]) if len(sys.argv)>5 else 3
mask=np.zeros_like(cov,bool); mask[::stride,::stride]=True; mask&=cov>0.999
pts=pp[mask]; nrm=nn[mask]; Lref=ref[mask]
tree=cKDTree(V); _,vi=tree.query(pts); kap=Hn[vi]
G=np.zeros((len(pts),3))
d_min=0.28*h
for s in range(0,len(pts),400):
    d=np.linalg.norm(pts[s:s+400,None,:]-Q[None,:,:],axis=-1)
    z=np.einsum('pk,pk->p',nrm[s:s+400],pts[s:s+400])[:,None]-nrm[s:s+400]@Q.T
    sv=np.clip(z/np.maximum(d,1e-6),0,1)**M
    d=np.sqrt(d*d+d_min*d_min)
    G[s:s+400]=np.einsum('pt,ptc->pc',np.broadcast_to(flux,d.shape),R(d)) if False else ((Ra_(d)+sv[...,None]*Rb_(d))*flux[None,:,None]).sum(1)
camV=np.array(meta['camera']['vector_to_camera_V'])
cth=nrm@tl; th=np.arccos(np.clip(cth,-1,1)); ph=np.arccos(np.clip(nrm@camV,0,1))
L=load_lut(); kc=np.clip(kap,L['kmin'],L['kmax'])
lutv=lut_value(L,kc,th); g=view_value(L,th,ph)
# G_sphere table over (kappa rows, theta)

ks=np.linspace(L['kmin'],L['kmax'],12); tt=np.linspace(0,np.pi,91)
import sphere_basis; Gs_tab=np.array([sphere_basis.sb(1/k,tt,ells,p_entry,M)@w.T for k in ks])  # 12,91,3
Gs=bilinear(Gs_tab,(kc-ks[0])/(ks[1]-ks[0]),th/np.pi*90)
# cast shadow: facing light but behind first surface
pk_u=np.floor(pts@u/h).astype(int)-np.floor(P@u/h).astype(int).min(); pk_v=np.floor(pts@v/h).astype(int)-np.floor(P@v/h).astype(int).min()
kk=pk_u*(iv.max()+1)+pk_v
first_d=np.array([shadow_key.get(k,1e9) for k in kk])
cast=(cth>0.05)&((pts@t)>first_d+1.0)
models={'poster':lutv,'pureG':G,'add':np.maximum(lutv+G-Gs,0),
        'hybrid':G+(lutv-Gs)*np.clip(G/np.maximum(Gs,1e-9),0,1),'ratio':lutv*G/np.maximum(Gs,1e-6)}
bins=[0,50,70,80,90,100,110,130,180]; deg=np.degrees(th)
print('bin     ', ' '.join(f'{bins[i]}-{bins[i+1]:>3}' for i in range(len(bins)-1)),' cast  whole')
lum=lambda x: x.mean(-1)
for name,f in models.items():
    pred=f*g/np.pi
    out=[]
    for i in range(len(bins)-1):
        m=(deg>=bins[i])&(deg<bins[i+1])&~cast
        out.append(lum(pred[m]).sum()/lum(Lref[m]).sum())
    out.append(lum(pred[cast]).sum()/max(lum(Lref[cast]).sum(),1e-12))
    rel=np.sqrt(np.mean((lum(pred)-lum(Lref))**2))/np.mean(lum(Lref))
    print(f'{name:8s}',' '.join(f'{x:6.2f}' for x in out), f' rmsrel(px) {rel:.3f}  cast n={cast.sum()}')
np.savez(os.path.join(HERE, '')+stem+'_res.npz',pts=pts,G=G,Gs=Gs,lutv=lutv,g=g,ref=Lref,th=th,cast=cast,mask=mask)
