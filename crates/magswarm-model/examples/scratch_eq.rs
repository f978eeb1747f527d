use magswarm_model::*;
fn main(){
  let a: Vec<f64> = std::env::args().skip(1).map(|s| s.parse().unwrap()).collect();
  let mut m=Model::paper();
  m.dynamics.beta=a[0]; m.dynamics.K_d1=a[1]; m.dynamics.K_d2=a[1]; m.dynamics.K_tau=a[2]; m.dynamics.p=a[3]; m.dynamics.r1_min=a[4]; m.dynamics.r2_min=a[5];
  let (mut tmin,mut tmax,mut nmax,mut errmax)=(1e9f64,0f64,0,0f64);
  for i in 0..=40 { for j in 0..=45 {
    let z=0.0035+0.0005*i as f64; let f=1.0+0.2*j as f64;
    let t=dynamics::InputTerms::new(&m,z,hz_to_rad_s(f));
    let e=dynamics::equilibria(&m,&t);
    let tau=e.time_constant(); tmin=tmin.min(tau); tmax=tmax.max(tau); nmax=nmax.max(e.count);
    errmax=errmax.max(((e.r[0]-t.steady.r1)/t.steady.r1).abs().max(((e.r[1]-t.steady.r2)/t.steady.r2).abs()));
    if e.count!=1 || !e.stable() || t.steady.validity.dynamics_clamped { println!("bad z {z} f {f} n {} tau {tau}", e.count); }
  }}
  println!("tau {tmin:.2}..{tmax:.2} s  max roots {nmax} max rel err {errmax:e}");
}
