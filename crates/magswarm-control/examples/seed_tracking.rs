//! The seed's tracking scenario (Sec. III-D, Fig. 6) in closed loop against the in-process
//! plant: prints the model radii per segment beside the seed's, and optionally the log.
//!
//! `cargo run -p magswarm-control --example seed_tracking [-- --csv]`

use magswarm_control::{
    closed_loop, inverse, seed_scenario, sim, summarize, Controller, PidConfig,
};
use magswarm_model::{Model, Plant};

fn main() {
    let model = Model::paper();
    let cfg = PidConfig::default();
    let mut ctrl = Controller::new(model.clone(), cfg).expect("default config is valid");
    let mut plant = Plant::new(model.clone(), sim::SEED_START.0, sim::SEED_START.1);
    let scenario = seed_scenario();
    let samples = closed_loop(&mut plant, &mut ctrl, &scenario, false);
    if std::env::args().any(|a| a == "--csv") {
        println!("t_s,z_m_mm,f_hz,r1_mm,r2_mm,r1_ref_mm,r2_ref_mm");
        for s in &samples {
            println!(
                "{:.2},{:.6},{:.6},{:.6},{:.6},{},{}",
                s.t_s, s.z_m_mm, s.f_hz, s.r1_mm, s.r2_mm, s.r1_ref_mm, s.r2_ref_mm
            );
        }
        return;
    }
    let seed = [(7.61, 10.43), (8.14, 11.23), (8.50, 11.70)];
    println!("| segment | r1*, r2* [mm] | seed model r1, r2 [mm] | magswarm r1, r2 [mm] | distance to target [mm] | z_m [mm], f [Hz] | settling to 0.1 mm [s] |");
    println!("|---|---|---|---|---|---|---|");
    for (k, ((s, seg), sd)) in summarize(&samples, 0.1)
        .iter()
        .zip(&scenario)
        .zip(seed)
        .enumerate()
    {
        let inv = inverse(&model, seg.r1, seg.r2);
        println!(
            "| {} | {:.0}, {:.0} | {:.2}, {:.2} | {:.2}, {:.2} | {:.2}{} | {:.2}, {:.2} | {:.2} |",
            k + 1,
            seg.r1,
            seg.r2,
            sd.0,
            sd.1,
            s.final_radii[0],
            s.final_radii[1],
            inv.distance_mm,
            if inv.feasible { "" } else { " (infeasible)" },
            s.final_inputs[0],
            s.final_inputs[1],
            s.settling_time_s.unwrap_or(f64::NAN)
        );
    }
}
