//! The emulated camera and the shadow model read what a camera sees: the model's observed
//! radii (formation mode, drift and camera bias applied), not the physical ODE state. A
//! camera offset switched on in their model must show in both.

mod support;

use magswarm_bridge::run::{self, Mode, RunOptions, Signals};
use magswarm_bridge::safety::FaultLatch;
use magswarm_bridge::schedule::Schedule;
use magswarm_log::Log;
use magswarm_model::effects::CameraBias;
use magswarm_model::{hz_to_rad_s, steady, Model};
use support::*;

const OFFSET_MM: f64 = 1.0;

#[test]
fn a_camera_offset_shows_in_the_emulated_camera_and_in_the_shadow_model() {
    let models = tempfile::tempdir().unwrap();
    let biased = models.path().join("biased.json");
    let mut m = Model::paper();
    m.effects.camera_bias = Some(CameraBias {
        scale: 1.0,
        offset_mm: OFFSET_MM,
        tilt_deg: 0.0,
    });
    m.save(&biased).unwrap();
    let path = biased.display().to_string();
    let rig = rig(&config_text(
        "",
        &format!("model = {path:?}"),
        &format!("[shadow]\nmodel = {path:?}\n"),
    ));
    // Constant inputs from the start: the swarm rests on the map of (13.5 mm, 4 Hz).
    let plan =
        Schedule::parse("t_s,z_m_mm,f_hz\n0,13.5,4.0\n", ["z_m_mm", "f_hz"], "PLAN").unwrap();
    let opts = RunOptions {
        mode: Mode::Plan(plan),
        log: rig.log_path(),
        duration: Some(1.5),
        dry_run: false,
    };
    let report = run::run(&rig.cfg, &opts, &Signals::default(), &FaultLatch::new()).unwrap();
    assert!(report.fault.is_none(), "{:?}", report.fault);
    let log = Log::read(&rig.log_path()).unwrap();
    assert!(log.rows.len() >= 10, "{} rows", log.rows.len());
    let map = steady::evaluate(&Model::paper(), 13.5e-3, hz_to_rad_s(4.0)).radii();
    let col = |name: &str| {
        log.layout
            .extra_columns
            .iter()
            .position(|c| c == name)
            .unwrap_or_else(|| panic!("no column {name}"))
    };
    let (c1, c2) = (col("shadow_r1_mm"), col("shadow_r2_mm"));
    for row in &log.rows {
        // The shadow model: exactly the map plus the offset.
        let shadow: [f64; 2] = [
            row.extra[c1].parse().unwrap(),
            row.extra[c2].parse().unwrap(),
        ];
        for i in 0..2 {
            assert!(
                (shadow[i] - map[i] - OFFSET_MM).abs() < 1e-6,
                "shadow r{} = {} mm, map {} mm + offset {OFFSET_MM} mm",
                i + 1,
                shadow[i],
                map[i]
            );
        }
    }
    // The emulated camera: what the vision measures on its frames, within the vision's
    // error (well below the offset).
    let measured: Vec<[f64; 2]> = log.rows.iter().filter_map(|r| r.radii()).collect();
    assert!(measured.len() >= 10, "{} valid frames", measured.len());
    for i in 0..2 {
        let mean = measured.iter().map(|r| r[i]).sum::<f64>() / measured.len() as f64;
        assert!(
            (mean - map[i] - OFFSET_MM).abs() < 0.3,
            "camera r{} = {mean} mm, map {} mm + offset {OFFSET_MM} mm",
            i + 1,
            map[i]
        );
    }
}
