//! The plant keeps its input terms without their Jacobian parts and computes those when
//! asked: nothing a caller can see may change. Every comparison here is bit for bit against
//! [`InputTerms::with_map`], the full computation.

use super::*;
use crate::effects::{CohesionLoss, FormationLag};
use crate::hz_to_rad_s as hz;

/// Inputs inside, on the edge of and outside the envelope (the map table answers for most,
/// the exact map for the rest).
fn inputs() -> Vec<(f64, f64)> {
    let mut v = Vec::new();
    for z in [0.0006, 0.0035, 0.0085, 0.01337, 0.0235, 0.031, 0.08] {
        for f in [0.02, 0.4, 1.0, 3.3, 7.77, 10.0, 19.0, 60.0] {
            v.push((z, hz(f)));
            v.push((z, -hz(f)));
        }
    }
    v
}

fn models() -> Vec<Model> {
    let paper = Model::paper();
    let mut constant = paper.clone();
    constant.dynamics.confinement = crate::params::Confinement::Constant;
    let mut lag = paper.clone();
    lag.effects.formation_lag = Some(FormationLag {
        share: 0.3,
        tau_s: 4.0,
        zeta: 0.7,
    });
    let mut cohesion = paper.clone();
    cohesion.effects.cohesion_loss = Some(CohesionLoss {
        z_c_mm: 15.0,
        k_per_mm2: 0.01,
    });
    vec![paper, constant, lag, cohesion]
}

/// The values of the terms without the Jacobian are those of the full terms, bit for bit;
/// completed, they are the full terms (every field, the Jacobian included).
#[test]
fn terms_without_the_jacobian_are_the_full_terms_values_bit_for_bit() {
    for m in models() {
        let table = MapTable::new(&m);
        for map in [None, table.as_ref()] {
            for &(z, w) in &inputs() {
                let full = InputTerms::with_map(&m, z, w, map);
                let lean = InputTerms::values_with_map(&m, z, w, map);
                assert!(full.has_jacobian());
                let (a, b) = (&full.steady, &lean.steady);
                let bits = |x: &SteadyPoint| {
                    [
                        x.field.b,
                        x.field.g_z,
                        x.field.k_xx,
                        x.field.k_yy,
                        x.field.db_dz,
                        x.s_x,
                        x.s_y,
                        x.phi,
                        x.r1,
                        x.r2,
                    ]
                    .map(f64::to_bits)
                };
                assert_eq!(bits(a), bits(b), "{} at {z} m, {w} rad/s", m.name);
                assert_eq!(a.validity, b.validity);
                assert_eq!(full.e0.to_bits(), lean.e0.to_bits());
                assert_eq!(full.k_b.map(f64::to_bits), lean.k_b.map(f64::to_bits));
                assert_eq!(
                    full.rhs_key(&m).map(f64::to_bits),
                    lean.rhs_key(&m).map(f64::to_bits)
                );
                let done = lean.with_jacobian(&m, map);
                assert!(done.has_jacobian());
                assert_eq!(done, full, "{} at {z} m, {w} rad/s", m.name);
                assert_eq!(done.id(), lean.id(), "the same coefficients keep their id");
                let r = [full.steady.r1 * 1.1, full.steady.r2 * 0.9];
                assert_eq!(
                    done.jac_input(&m, r).map(|row| row.map(f64::to_bits)),
                    full.jac_input(&m, r).map(|row| row.map(f64::to_bits))
                );
            }
        }
    }
}

/// What a plant reports (outputs with the steady point's Jacobian, the Jacobians of (4),
/// the Model Exchange Jacobian) is what the full terms at its inputs give, through input
/// changes, with the map table and without, and asked for in any order.
#[test]
fn a_plant_reports_the_jacobian_of_the_full_terms() {
    for m in models() {
        for table in [false, true] {
            let mut p = Plant::new(m.clone(), 0.0085, hz(4.0));
            p.use_map_table(table);
            for (k, &(z, w)) in inputs().iter().enumerate() {
                p.set_inputs(z, w);
                p.step(0.002).unwrap();
                let full = InputTerms::with_map(&m, z, w, p.map_in_force());
                let check = |p: &Plant| {
                    assert_eq!(p.terms(), &full);
                    assert_eq!(
                        p.outputs().steady,
                        m.effects.observe_steady(&full.steady, p.time())
                    );
                    assert_eq!(p.jac_input(), full.jac_input(&m, p.state()));
                };
                if k % 2 == 0 {
                    check(&p);
                    assert_eq!(
                        p.continuous_jacobian()[0][0],
                        full.jac_input(&m, p.state())[0][0]
                    );
                } else {
                    // Asked for first through the Model Exchange Jacobian.
                    let j = p.continuous_jacobian();
                    assert_eq!(j[1][1], full.jac_input(&m, p.state())[1][1]);
                    check(&p);
                }
            }
        }
    }
}

/// Stepping never needs the Jacobian: two plants through the same inputs, one asked for its
/// Jacobian at every step, stay bit for bit equal (state, snapshot, step counts).
#[test]
fn asking_for_the_jacobian_changes_no_trajectory() {
    for m in models() {
        let mut a = Plant::new(m.clone(), 0.0085, hz(4.0));
        a.use_map_table_after(20, None);
        let mut b = a.clone();
        for k in 0..400 {
            let s = (k as f64 * 0.021).sin();
            for p in [&mut a, &mut b] {
                p.set_inputs(0.0085 + 0.004 * s, hz(5.0 + 3.0 * s));
                p.step(0.005).unwrap();
            }
            let _ = b.outputs();
            let _ = b.continuous_jacobian();
            assert_eq!(a.state(), b.state());
            assert_eq!(a.formation(), b.formation());
            assert_eq!(a.snapshot(), b.snapshot());
        }
    }
}
