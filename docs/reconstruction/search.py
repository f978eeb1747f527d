"""Reconstruction search: choose the constants Table I leaves out (docs/reconstruction.md).

usage: python search.py LOG_BASE SEED W_INTERIOR W_RANGES W_MEDIANS W_POINTS
e.g.   python search.py 2.718281828 1 0.05 1 4 1   (the weights of the shipped reconstruction)

Needs numpy and scipy. Minimises a weighted sum of squared log-errors of the seed's figures
(median S_x, S_y, k_xx/k_yy, ranges of r1 and r2), penalties for r2 <= r1 and for radii
falling with z_m, the squared distance of each closed-loop model point of Sec. III-D to the
reachable set, and a penalty per z_m whose radii do not fall-then-rise with frequency.
Nelder-Mead from 60 random starts; prints the best vector and its figures.
"""
from model import *
import sys
tgt=dict(Sx=0.393,Sy=2.455,r1r=2.02,r2r=5.66)
pts=[(7.61,10.43),(8.14,11.23),(8.50,11.70)]
zf=np.linspace(3.5,23.5,41); ff=np.linspace(1,10,46); ZF,FF=np.meshgrid(zf,ff,indexing='ij')
def loss(x,logb):
    d0,xo,lks,lgs,lB,rho=x
    if not (0<=d0<25 and 0<=xo<15 and 0.05<rho<4): return 1e9
    p=[d0,xo,10**lks,10**lgs,10**lB,rho,logb]
    Sx,Sy,r1,r2,kxx,kyy=model(p)
    L=0
    L+=WS*((np.log(np.median(Sx)/0.393))**2+(np.log(np.median(Sy)/2.455))**2)
    L+=WR*((np.log((r1.max()-r1.min())/2.02))**2+(np.log((r2.max()-r2.min())/5.66))**2)
    L+=20*(np.log(np.median(kxx/kyy)/1.04))**2
    L+=10*np.sum(np.maximum(0,r1-r2+0.3)**2)
    L+=10*np.sum(np.maximum(0,-np.diff(r1,axis=0))**2)+10*np.sum(np.maximum(0,-np.diff(r2,axis=0))**2)
    # reachability on fine grid
    _,_,R1,R2,_,_=model(p,Z=ZF,F=FF)
    for a,b in pts:
        dd=np.min((R1-a)**2+(R2-b)**2); L+=WP*dd
    # interior minimum in f at each z
    for i in range(r1.shape[0]):
        for r in (r1[i],r2[i]):
            j=np.argmin(r); 
            if j==0 or j==len(r)-1: L+=W
    return L
best=None
rng=np.random.default_rng(int(sys.argv[2]) if len(sys.argv)>2 else 0)
logb=float(sys.argv[1]); W=float(sys.argv[3]); WR=float(sys.argv[4]); WS=float(sys.argv[5]); WP=float(sys.argv[6])
for s in range(60):
    x0=[rng.uniform(0,15),rng.uniform(0,10),rng.uniform(-8,1),rng.uniform(-4,1),rng.uniform(-3,0.5),rng.uniform(0.2,2.5)]
    r=minimize(loss,x0,args=(logb,),method='Nelder-Mead',options=dict(maxiter=3000,xatol=1e-5,fatol=1e-9))
    if best is None or r.fun<best.fun: best=r
print(logb,best.fun,list(best.x))
x=best.x; p=[x[0],x[1],10**x[2],10**x[3],10**x[4],x[5],logb]
print(report(p))
_,_,R1,R2,_,_=model(p,Z=ZF,F=FF)
for a,b in pts:
    dd=(R1-a)**2+(R2-b)**2; i=np.unravel_index(np.argmin(dd),dd.shape); print(a,b,'->',R1[i],R2[i],'z',zf[i[0]],'f',ff[i[1]])
