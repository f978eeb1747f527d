use magswarm::diagnose::{self, Config};
use magswarm::lab::presets::Campaign;
use magswarm::model::Model;
fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    for a in args {
        let (n, s) = a.split_once('=').unwrap();
        let s: f64 = s.parse().unwrap();
        let mut c = if n == "own_phase" {
            Campaign::seed_grid(&[], 11).unwrap()
        } else {
            Campaign::seed_grid(&[(n, s)], 11).unwrap()
        };
        if n == "own_phase" {
            c.truth.effects.phase_lag = Some(magswarm_model::effects::PhaseLag {
                f_so_hz: s,
                nu: 0.0,
            });
        }
        let d = diagnose::diagnose(
            &c.log("x").unwrap(),
            None,
            &Model::paper(),
            &Config {
                permutations: 299,
                ..Config::default()
            },
        )
        .unwrap();
        let t = d.rmse_table();
        let ex = d.excess_removed();
        println!("{n}={s}: sig {} p {:.2e} regions {} accepted {:?} cv r1 {:.3}->{:.3} r2 {:.3}->{:.3} floor {:.3}/{:.3} ex {:?}", d.tests.significant, d.tests.p_value, d.regions.len(), d.attr.accepted, t[0].1.rmse[0], t[1].1.rmse[0], t[0].1.rmse[1], t[1].1.rmse[1], d.floor[0], d.floor[1], ex[2]);
        for e in &d.attr.evals {
            println!(
                "   {} gain {:.1} pen {:.1} p {:.2e} impl {:?} sig {:.2} passed {}",
                e.name, e.gain, e.penalty, e.p, e.implausible, e.signature.0, e.passed
            );
            println!(
                "      {:?}",
                magswarm::diagnose::candidates::model_params(&e.name, &e.model.full.aug.synced())
            );
        }
        if n == "own_phase" {
            use magswarm::diagnose::candidates::{self as cand, Augmented};
            let sd = d.pe.row_sd();
            let sse = |a: &Augmented| {
                let p = cand::predict(a, &d.ds);
                d.ds.rows
                    .iter()
                    .zip(&p)
                    .map(|(r, p)| {
                        ((r.r[0] - p[0]) / sd[0]).powi(2) + ((r.r[1] - p[1]) / sd[1]).powi(2)
                    })
                    .sum::<f64>()
            };
            let mut t = Augmented::baseline(&magswarm::lab::presets::rig_truth(), &d.ctx);
            let b = magswarm_model::effects::PhaseLag {
                f_so_hz: s,
                nu: 0.0,
            };
            t.effects.push(("phase_lag".into(), vec![b.f_so_hz, 0.0]));
            println!("truth-params sse {:.1}", sse(&t));
            let pt = cand::predict(&t, &d.ds);
            let rt: Vec<[f64; 2]> =
                d.ds.rows
                    .iter()
                    .zip(&pt)
                    .map(|(r, p)| [r.r[0] - p[0], r.r[1] - p[1]])
                    .collect();
            for r in &d.regions {
                println!(
                    "truth region mean {:.4} (region mean before {:.4})",
                    magswarm::diagnose::gap::region_mean(&d.ds, &rt, &d.base_map, r),
                    r.mean
                );
            }
            let e = d.attr.evals.iter().find(|e| e.name == "phase_lag").unwrap();
            println!(
                "fitted sse {:.1} (cost {:.1}); baseline sse {:.1}",
                sse(&e.model.full.aug),
                e.model.full.cost,
                sse(&d.attr.baseline.full.aug)
            );
            println!(
                "fitted base C_1 {} truth C_1 {}",
                e.model.full.aug.model.steady.C_1, t.model.steady.C_1
            );
            println!(
                "free: {:?}",
                d.ident
                    .steady
                    .free
                    .iter()
                    .map(|f| f.name())
                    .collect::<Vec<_>>()
            );
            let all: Vec<usize> = (0..d.ds.rows.len()).collect();
            let sdm = [sd[0].max(1e-3), sd[1].max(1e-3)];
            let fr = magswarm::diagnose::fitter::fit(
                &t,
                &d.ident.steady.free,
                &d.ds,
                &d.ctx,
                &all,
                sdm,
                &[],
            );
            println!(
                "fit from truth: cost {:.1} params {:?}",
                fr.cost, fr.aug.effects
            );
            let mut t2 = e.model.full.aug.clone();
            t2.effects[0].1 = vec![s, 0.0];
            let fr2 = magswarm::diagnose::fitter::fit(
                &t2,
                &d.ident.steady.free,
                &d.ds,
                &d.ctx,
                &all,
                sdm,
                &[],
            );
            println!(
                "fit from fitted baseline + true effect: cost {:.1} params {:?}",
                fr2.cost, fr2.aug.effects
            );
            let mut t3 = d.attr.baseline.full.aug.clone();
            t3.effects.push(("phase_lag".into(), vec![100.0, 0.0]));
            for st in [
                vec![4.15, 0.0],
                vec![4.15, 1.0],
                vec![6.4, 0.0],
                vec![6.4, 1.0],
                vec![3.0, 0.5],
            ] {
                let fr3 = magswarm::diagnose::fitter::fit(
                    &t3,
                    &d.ident.steady.free,
                    &d.ds,
                    &d.ctx,
                    &all,
                    sdm,
                    &[st.clone()],
                );
                println!(
                    "from baseline start {:?}: cost {:.1} params {:?}",
                    st, fr3.cost, fr3.aug.effects
                );
            }
        }
        for r in &d.regions {
            println!("   region {:?}", r);
        }
    }
}
