//! The table against the exact map, and its proven bound, over the envelope.

use super::*;
use crate::hz_to_rad_s as hz;

#[test]
fn interval_jets_enclose_the_f64_jets() {
    let m = Model::paper();
    for &d in &[0.021, 0.03, 0.045] {
        let x = d * (1.0 + 1e-4);
        let f = depth_part(&m, Jet::var(x)).unwrap();
        let e = depth_part(&m, Jet::var(Iv::new(d, d * (1.0 + 2e-4)))).unwrap();
        for k in 0..3 {
            for c in 0..=ORDER {
                let (v, iv) = (f[k].0[c], e[k].0[c]);
                assert!(
                    iv.lo <= v && v <= iv.hi,
                    "fn {k} coef {c}: {v} not in {iv:?}"
                );
            }
        }
    }
}

/// A jet of fewer coefficients is the start of the full one, bit for bit (what lets a cell's
/// nodes be computed with two coefficients and its midpoint with five): over the depth and
/// frequency ranges of the table, in f64 and in intervals, on points and on ranges.
#[test]
fn short_jets_are_the_start_of_the_full_jets_bit_for_bit() {
    let m = Model::paper();
    let bits = |x: f64| x.to_bits();
    let same_iv = |a: Iv, b: Iv| bits(a.lo) == bits(b.lo) && bits(a.hi) == bits(b.hi);
    for i in 0..200 {
        let d = 0.015 + 0.0002 * i as f64;
        let w = 0.02 + 0.013 * i as f64;
        let full = depth_part(&m, Jet::var(d)).unwrap();
        let two = depth_part_n::<f64, 2>(&m, Jet::var(d)).unwrap();
        let fw = frequency_part(&m, Jet::var(w)).unwrap();
        let fw2 = frequency_part_n::<f64, 2>(&m, Jet::var(w)).unwrap();
        for (a, b) in full.iter().zip(&two).chain(fw.iter().zip(&fw2)) {
            assert_eq!(
                a.0[..2].iter().map(|&x| bits(x)).collect::<Vec<_>>(),
                b.0.map(bits)
            );
        }
        for x in [Iv::new(d, d), Iv::new(d, d * (1.0 + 1.0 / 1024.0))] {
            let full = depth_part(&m, Jet::var(x)).unwrap();
            let five = depth_part_n::<Iv, 5>(&m, Jet::var(x)).unwrap();
            for (a, b) in full.iter().zip(&five) {
                assert!((0..5).all(|c| same_iv(a.0[c], b.0[c])), "depth {d}");
            }
        }
        for x in [Iv::new(w, w), Iv::new(w, w * (1.0 + 1.0 / 256.0))] {
            let full = frequency_part(&m, Jet::var(x)).unwrap();
            let five = frequency_part_n::<Iv, 5>(&m, Jet::var(x)).unwrap();
            for (a, b) in full.iter().zip(&five) {
                assert!((0..5).all(|c| same_iv(a.0[c], b.0[c])), "frequency {w}");
            }
        }
    }
}

#[test]
fn node_slopes_are_the_derivatives() {
    let m = Model::paper();
    let h = 1e-8;
    for &d in &[0.022, 0.031, 0.04] {
        let f = |x: f64| depth_part(&m, Jet::var(x)).unwrap();
        let (a, p, q) = (f(d), f(d + h), f(d - h));
        for k in 0..3 {
            let fd = (p[k].0[0] - q[k].0[0]) / (2.0 * h);
            assert!((fd - a[k].0[1]).abs() <= 1e-6 * fd.abs(), "{k}");
        }
    }
}

/// Over the validated envelope: every point is answered by the table, its proven bound
/// is below 1e-9 mm, and the table is within that bound (plus the exact code's own
/// rounding) of `steady::evaluate`; the Jacobian within 1e-7 relative.
#[test]
fn table_is_within_its_proven_bound_of_the_exact_map() {
    let m = Model::paper();
    let t = MapTable::new(&m).unwrap();
    let e = m.envelope;
    let mut worst_bound: f64 = 0.0;
    let mut worst_err: f64 = 0.0;
    let (nz, nf) = (401, 361);
    for i in 0..nz {
        for j in 0..nf {
            // Points that are not nodes: irrational offsets.
            let z = e.z_min_m + (e.z_max_m - e.z_min_m) * (i as f64 + 0.29) / nz as f64;
            let f = e.f_min_hz + (e.f_max_hz - e.f_min_hz) * (j as f64 + 0.61) / nf as f64;
            let a = t.interpolate(&m, z, hz(f)).expect("inside the envelope");
            let b = steady::evaluate(&m, z, hz(f));
            let bound = t.bound(&m, z, hz(f)).unwrap();
            for (k, (x, y)) in [(a.r1, b.r1), (a.r2, b.r2)].into_iter().enumerate() {
                let err = (x - y).abs();
                assert!(
                    err <= bound[k] + 1e-13 * y.abs(),
                    "z {z} f {f}: r{} table {x} exact {y} (err {err:e} > bound {:e})",
                    k + 1,
                    bound[k]
                );
                worst_bound = worst_bound.max(bound[k]);
                worst_err = worst_err.max(err);
            }
            // The Jacobian from the slopes: within 1e-6 relative, or 1e-9 r per unit input
            // where its terms cancel (dr2/domega crosses zero in the envelope).
            for (r, rr) in [b.r1, b.r2].into_iter().enumerate() {
                for c in 0..2 {
                    let (x, y) = (a.jac[r][c], b.jac[r][c]);
                    assert!(
                        (x - y).abs() <= 1e-6 * y.abs() + 1e-9 * rr,
                        "jac {r}{c}: {x} vs {y}"
                    );
                }
            }
        }
    }
    assert!(worst_bound < 1e-9, "bound {worst_bound:e} mm");
    eprintln!("worst proven bound {worst_bound:e} mm, worst error {worst_err:e} mm");
}

#[test]
fn outside_the_table_and_with_map_effects_it_is_the_exact_map() {
    let m = Model::paper();
    let t = MapTable::new(&m).unwrap();
    for (z, f) in [(0.2, 4.0), (0.0085, 0.01), (0.0085, 80.0), (0.0085, -4.0)] {
        let a = t.evaluate(&m, z, hz(f));
        let b = steady::evaluate(&m, z, hz(f));
        if f < 0.0 {
            // Inside the table: the same radii, the slope in omega mirrored.
            assert!(
                (a.r1 - b.r1).abs() < 1e-9
                    && (a.jac[0][1] - b.jac[0][1]).abs() < 1e-7 * b.jac[0][1].abs()
            );
        } else {
            assert_eq!(a, b, "z {z} f {f}");
        }
    }
    let mut fx = Model::paper();
    fx.effects.phase_lag = Some(crate::effects::PhaseLag {
        f_so_hz: 8.0,
        nu: 1.0,
        spread: 0.0,
    });
    assert!(MapTable::new(&fx).is_none());
    assert!(!t.answers_for(&fx));
    let mut other = Model::paper();
    other.steady.a_G *= 1.01;
    assert!(!t.answers_for(&other));
    assert!(t.answers_for(&m));
}
