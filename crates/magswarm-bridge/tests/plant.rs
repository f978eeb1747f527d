//! The rig behind `magswarm_control::plant::SwarmPlant`: the same tracking function and PID
//! that run around the in-process model and the FMU close the loop around the (emulated) rig.

mod support;

use magswarm_bridge::plant::RigPlant;
use magswarm_bridge::rig::Rig;
use magswarm_bridge::run::Signals;
use magswarm_control::plant::{PlantError, SwarmPlant};
use magswarm_control::sim::{tracking, Segment};
use magswarm_control::{Controller, PidConfig};
use magswarm_log::LogRow;
use magswarm_model::Model;
use support::*;

#[test]
fn the_fmu_tracking_loop_runs_on_the_rig_unchanged() {
    let rig = rig(&config_text("", "", ""));
    let r = Rig::open(&rig.cfg, false, (13.5, 4.0), Signals::default(), None).unwrap();
    let mut plant = RigPlant::new(r, rig.cfg.camera.fps);
    let mut ctrl = Controller::new(Model::paper(), PidConfig::default()).unwrap();
    let segs = [Segment {
        duration_s: 6.0,
        r1: 8.05,
        r2: 10.98,
    }];
    let mut rows: Vec<LogRow> = Vec::new();
    let out = tracking(&mut plant, &mut ctrl, &segs, false, &mut rows).unwrap();
    // 6 s at the PID's 0.05 s sample time.
    assert_eq!(rows.len(), 120);
    // The plant's clock is the camera's: readings ~one sample apart.
    for w in rows.windows(2) {
        let dt = w[1].t_s - w[0].t_s;
        assert!((0.02..=0.11).contains(&dt), "sample spacing {dt} s");
    }
    let last = out.summary.last.radii_mm().expect("a valid last reading");
    let err = (last[0] - 8.05).abs().max((last[1] - 10.98).abs());
    assert!(err < 0.15, "tracking error {err} mm at the end");
    // The rig's own safety stays in force: nothing outside the limits reached the robot.
    rig.assert_targets_inside();
    plant.shutdown();
}

#[test]
fn a_rig_fault_is_a_plant_error_and_the_stepper_stops() {
    let rig = rig(&config_text("", "", ""));
    let r = Rig::open(&rig.cfg, false, (10.0, 4.0), Signals::default(), None).unwrap();
    let mut plant = RigPlant::new(r, rig.cfg.camera.fps);
    let u = plant.inputs();
    for _ in 0..10 {
        plant.step(u, 0.05).unwrap();
    }
    let cue = std::time::Instant::now();
    rig.emu.robot.protective_stop();
    let mut err = None;
    for _ in 0..20 {
        if let Err(e) = plant.step(u, 0.05) {
            err = Some(e);
            break;
        }
    }
    match err {
        Some(PlantError::Fault(w)) => assert!(w.contains("safety_mode"), "{w}"),
        other => panic!("{other:?}"),
    }
    assert_stop_within(&rig, cue, std::time::Duration::from_millis(100));
    // Latched: later calls fail too.
    assert!(plant.step(u, 0.05).is_err());
}
