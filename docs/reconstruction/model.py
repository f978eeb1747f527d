"""Closed forms of the magswarm steady map in numpy, for the reconstruction search only.

Mirrors crates/magswarm-model (field.rs, steady.rs); the Rust crate is authoritative and
`magswarm paper` prints the figures of the built-in model. Parameters of the search vector p:
d0 (z offset, mm), lateral offset (mm), k unit multiplier, g unit multiplier, B_ref (T), rho,
log base. The k/g "multipliers" are 1/unit: k_used = k_SI * ks, so k_unit = 1/ks T^2/m^2.
"""
import numpy as np, itertools
from scipy.optimize import minimize
mu0=4e-7*np.pi; R=0.02
T1=dict(C1=7.76,C2=16.6,aK1=0.487,aK2=2.58,a1=0.10,a2=0.45,g1=0.21,g2=0.10,s0=0.023,aG=0.20,N=-0.273,q=0.24,aP=0.823,muP=0.33,cP=-0.77,qP=0.10,fref=6.0)
zs=np.arange(3.5,24,5.0); fs=np.arange(1,11,1.0)
Z,F=np.meshgrid(zs,fs,indexing='ij')
def field(zmm,d0mm,xoff_rel,Br=1.32):
    m=Br*(4/3*np.pi*R**3)/mu0; K=mu0*m/(4*np.pi)
    d=R+(zmm+d0mm)*1e-3
    B=K/d**3; gz=3*K/d**4
    # rotation-avg B^2 = K^2 (d^2+2.5 u)/(u+d^2)^4 , u=rho^2 ; radial/tangential curvature at rho=xoff
    rho=xoff_rel*1e-3
    u=rho**2
    g=lambda u: (d**2+2.5*u)/(u+d**2)**4
    gp=lambda u: 2.5/(u+d**2)**4-4*(d**2+2.5*u)/(u+d**2)**5
    gpp=lambda u: -20/(u+d**2)**5+20*(d**2+2.5*u)/(u+d**2)**6
    kyy=K**2*(2*gp(u)+4*u*gpp(u)); kxx=K**2*2*gp(u)
    return B,gz,kxx,kyy
def model(p,T=T1,Z=Z,F=F):
    d0,xo,ks,gs,Bref,rho,logb=p
    B,gz,kxx,kyy=field(Z,d0,xo)
    w=F/T['fref']
    lg=np.log(1+T['cP']*w**T['qP'])/np.log(logb)
    P=T['aP']*(B/Bref)**T['muP']*(1+lg)
    Sx=T['s0']+T['aK1']*np.abs(kxx*ks)**T['g1']+T['aG']*(gz*gs)**rho+P
    Sy=T['s0']+T['aK2']*np.abs(kyy*ks)**T['g2']+T['aG']*(gz*gs)**rho+P
    Sx=np.maximum(Sx,1e-6); Sy=np.maximum(Sy,1e-6)
    Phi=np.exp(T['N']*(w**T['q']-1))
    r1=T['C1']*Phi/Sx**T['a1']; r2=T['C2']*Phi/Sy**T['a2']
    return Sx,Sy,r1,r2,kxx,kyy
def report(p):
    Sx,Sy,r1,r2,kxx,kyy=model(p)
    return dict(Sx=np.median(Sx),Sy=np.median(Sy),ratio=np.median(Sx)/np.median(Sy),kr=np.median(kxx/kyy),r1r=r1.max()-r1.min(),r2r=r2.max()-r2.min(),
      r2gtr1=bool((r2>r1).all()), zmono=bool((np.diff(r1,axis=0)>0).all() and (np.diff(r2,axis=0)>0).all()),
      r1min=r1.min(),r1max=r1.max(),r2min=r2.min(),r2max=r2.max(), fargmin1=list(np.argmin(r1,axis=1)+1), fargmin2=list(np.argmin(r2,axis=1)+1), Smin=min(Sx.min(),Sy.min()))
