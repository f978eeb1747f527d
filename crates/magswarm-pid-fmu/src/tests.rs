//! Unit tests of the controller FMU through its model trait (no C ABI).

use super::*;

fn ready() -> MagSwarmPid {
    let mut m = MagSwarmPid::new(None).unwrap();
    let mut ctx = Ctx::silent();
    m.setup_experiment(&mut ctx, None, 0.0, None).unwrap();
    m.exit_initialization_mode(&mut ctx).unwrap();
    m
}

#[test]
fn xml_is_generated_and_names_the_interface() {
    let xml = model_description(&PidConfig::default(), None);
    for name in [
        "r1_ref",
        "r2_ref",
        "r1",
        "r2",
        "z_m",
        "omega_m",
        "target_feasible",
        "r1_goal",
        "r2_goal",
        "model_file",
        "config_file",
        "sample_time",
        "kp_r1",
        "z_rate",
        "f_rate",
    ] {
        assert!(xml.contains(&format!("name=\"{name}\"")), "missing {name}");
    }
    assert!(xml.contains("modelIdentifier=\"MagSwarmPID\""));
    let de = xml
        .lines()
        .find(|l| l.contains("<DefaultExperiment"))
        .expect("a DefaultExperiment");
    assert!(de.contains("tolerance=\"1e-8\""), "{de}");
}

#[test]
fn same_commands_as_the_library_controller() {
    let mut fmu = ready();
    let mut ctrl = Controller::new(Model::paper(), PidConfig::default()).unwrap();
    let mut ctx = Ctx::silent();
    let y = [8.1, 11.2];
    ctrl.reset(Z_START, OMEGA_START, y);
    fmu.r_ref = [0.008, 0.011];
    fmu.y = [y[0] * 1e-3, y[1] * 1e-3];
    for k in 0..20 {
        let t = k as f64 * 0.05;
        fmu.step(&mut ctx, t, 0.05).unwrap();
        let (z, w) = ctrl.step([fmu.y[0] * 1e3, fmu.y[1] * 1e3], [8.0, 11.0]);
        assert!(
            (fmu.u[0] - z).abs() < 1e-15 && (fmu.u[1] - w).abs() < 1e-12,
            "sample {k}"
        );
    }
    assert_eq!(fmu.k, 20);
}

#[test]
fn non_multiple_steps_sample_at_the_sample_instants() {
    let mut fmu = ready();
    let mut ctx = Ctx::silent();
    fmu.step(&mut ctx, 0.0, 0.02).unwrap(); // sample 0 at t = 0
    assert_eq!(fmu.k, 1);
    fmu.step(&mut ctx, 0.02, 0.02).unwrap(); // none in [0.02, 0.04)
    assert_eq!(fmu.k, 1);
    fmu.step(&mut ctx, 0.04, 0.02).unwrap(); // t = 0.05
    assert_eq!(fmu.k, 2);
    fmu.step(&mut ctx, 0.06, 0.2).unwrap(); // 0.1, 0.15, 0.2, 0.25
    assert_eq!(fmu.k, 6);
}

#[test]
fn state_round_trips_through_bytes_at_a_fixed_size() {
    let mut fmu = ready();
    let mut ctx = Ctx::silent();
    for k in 0..40 {
        if k == 20 {
            fmu.r_ref = [0.009, 0.011];
            fmu.set_real(&mut ctx, vr::PARAM_BASE + 1, 0.5).unwrap(); // kp_r1, bumpless
        }
        fmu.y = [0.008 + 1e-5 * k as f64, 0.011];
        fmu.step(&mut ctx, k as f64 * 0.05, 0.05).unwrap();
    }
    let guid = magswarm_fmi::guid::guid_u128(MagSwarmPid::model_info());
    let shell = magswarm_fmi::snapshot::ShellState::fresh();
    let bytes = magswarm_fmi::snapshot::serialize(guid, &shell, &fmu).unwrap();
    let (_, mut other) = magswarm_fmi::snapshot::deserialize(guid, &bytes, ready()).unwrap();
    assert_eq!(other.k, fmu.k);
    assert_eq!(other.u, fmu.u);
    for k in 40..60 {
        fmu.step(&mut ctx, k as f64 * 0.05, 0.05).unwrap();
        other.step(&mut ctx, k as f64 * 0.05, 0.05).unwrap();
        assert_eq!(other.u, fmu.u, "sample {k}");
    }
    assert!(magswarm_fmi::snapshot::deserialize(guid, &bytes[..bytes.len() - 3], ready()).is_err());
    // The state does not grow with the run (no sample history).
    for k in 60..600 {
        fmu.step(&mut ctx, k as f64 * 0.05, 0.05).unwrap();
    }
    let later = magswarm_fmi::snapshot::serialize(guid, &shell, &fmu).unwrap();
    assert!(
        later.len() < bytes.len() + 64,
        "{} -> {}",
        bytes.len(),
        later.len()
    );
}

#[test]
fn parameters_override_the_config_file_unless_at_their_start() {
    let mut fmu = MagSwarmPid::new(None).unwrap();
    let mut ctx = Ctx::silent();
    let dir = std::env::temp_dir().join(format!("magswarm-pid-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("cfg.json");
    let mut cfg = PidConfig::default();
    cfg.gains.kp = [0.7, 0.6];
    cfg.gains.ki = [0.1, 0.2];
    std::fs::write(&path, cfg.to_json()).unwrap();
    // start value written first: does not erase the file's value
    fmu.set_real(&mut ctx, vr::PARAM_BASE + 1, 0.3).unwrap();
    fmu.set_real(&mut ctx, vr::PARAM_BASE + 3, 0.9).unwrap(); // ki_r1 overridden
    fmu.set_string(&mut ctx, vr::CONFIG_FILE, path.to_str().unwrap())
        .unwrap();
    let eff = fmu.effective_config();
    assert_eq!(eff.gains.kp, [0.7, 0.6]);
    assert_eq!(eff.gains.ki, [0.9, 0.2]);
    std::fs::remove_dir_all(&dir).ok();
}
