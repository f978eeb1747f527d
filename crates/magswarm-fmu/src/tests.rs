//! Unit tests of the plant FMU that need its private state (the plant behind the
//! variables): the variable table, parameters, and directional derivatives against finite
//! differences.

use super::*;

#[test]
fn xml_is_generated_and_names_every_contract_variable() {
    let xml = model_description(&Model::paper(), None);
    for name in [
        "z_m",
        "omega_m",
        "r1",
        "r2",
        "r1_ss",
        "r2_ss",
        "S_x",
        "S_y",
        "B",
        "g_z",
        "k_xx",
        "k_yy",
        "model_file",
        "C_1",
        "C_2",
        "a_K1",
        "a_K2",
        "alpha_1",
        "alpha_2",
        "gamma_1",
        "gamma_2",
        "s_0",
        "a_G",
        "rho",
        "N",
        "q",
        "a_P",
        "mu_P",
        "c_P",
        "q_P",
        "f_ref",
        "B_ref",
        "K_b1",
        "K_b2",
        "beta",
        "r1_min",
        "r2_min",
        "K_tau",
        "p",
        "s_B",
        "K_d1",
        "K_d2",
    ] {
        assert!(xml.contains(&format!("name=\"{name}\"")), "missing {name}");
    }
    assert!(xml.contains("modelIdentifier=\"MagSwarm\""));
}

#[test]
fn baked_model_changes_start_values_not_guid() {
    let mut m = Model::paper();
    m.steady.C_1 = 8.5;
    let a = model_description(&Model::paper(), None);
    let b = model_description(&m, None);
    assert_ne!(a, b);
    let guid = |x: &str| {
        x.split("guid=\"")
            .nth(1)
            .unwrap()
            .split('"')
            .next()
            .unwrap()
            .to_string()
    };
    assert_eq!(guid(&a), guid(&b));
    assert!(b.contains("start=\"8.5\""));
}

#[test]
fn parameter_accessors_round_trip() {
    let mut m = Model::paper();
    for (i, p) in PARAMS.iter().enumerate() {
        let v = (p.get)(&m) + 0.001 * (i as f64 + 1.0);
        (p.set)(&mut m, v);
        assert_eq!((p.get)(&m), v, "{}", p.name);
    }
}

/// A model file with every effect switched on (the JSON of docs/effects.md).
fn model_file_with_every_effect(dir: &Path) -> PathBuf {
    let mut v: serde_json::Value =
        serde_json::from_str(&Model::paper().to_json().unwrap()).unwrap();
    v["schema"] = serde_json::json!("magswarm-model/2");
    v["effects"] = serde_json::json!({
        "phase_lag":       {"f_so_hz": 6.0, "nu": 1.0},
        "cohesion_loss":   {"z_c_mm": 9.0, "k_per_mm2": 0.02},
        "formation_lag":   {"share": 0.4, "tau_s": 8.0, "zeta": 0.5},
        "particle_drift":  {"rate_per_h": -0.1},
        "centroid_offset": {"offset_mm": 2.0},
        "camera_bias":     {"scale": 1.03, "offset_mm": 0.1, "tilt_deg": 10.0},
        // Learned terms on the steady map and over session time (the outputs' derivatives
        // with respect to the inputs and the state must carry them too).
        "learned": [
            {"effect": "phase_lag", "axis": "f_hz", "mode": "rate_hz", "knots": [1.0, 4.0, 8.0],
             "r1": [0.0, 0.3, 0.9], "r2": [0.0, 0.3, 0.9], "field_exponent": 0.5},
            {"effect": "phase_lag", "axis": "f_hz", "mode": "add_mm", "knots": [1.0, 4.0, 8.0],
             "r1": [0.0, 0.2, 0.1], "r2": [0.1, 0.5, 0.2], "amplitude_exponent": 1.0},
            {"effect": "cohesion_loss", "axis": "z_m_mm", "mode": "relative", "knots": [5.0, 15.0, 25.0],
             "r1": [0.0, 0.05, 0.2], "r2": [0.0, 0.1, 0.3]},
            {"effect": "particle_drift", "axis": "t_s", "mode": "relative", "knots": [0.0, 3600.0],
             "r1": [0.0, -0.05], "r2": [0.0, -0.08]}
        ]
    });
    let path = dir.join("every_effect.json");
    std::fs::write(&path, v.to_string()).unwrap();
    path
}

/// The analytic directional derivatives agree with central differences of what
/// `fmi2GetReal` returns, for every Real output and state derivative, with respect to
/// the inputs and to the state (the radii of ODE (4)), with every effect on: the
/// observed radii carry the observation gain and the formation share.
#[test]
fn directional_derivatives_match_finite_differences_with_every_effect() {
    let dir = tempfile::tempdir().unwrap();
    let mut ctx = Ctx::silent();
    let mut fmu = MagSwarm::new(None).unwrap();
    let file = model_file_with_every_effect(dir.path());
    fmu.set_string(&mut ctx, vr::MODEL_FILE, file.to_str().unwrap())
        .unwrap();
    assert_eq!(fmu.model().effects.enabled().len(), 6);
    fmu.exit_initialization_mode(&mut ctx).unwrap();
    // A step in the inputs, half an hour into the session: the slow formation mode
    // lags the ODE state and the drift has shrunk the observed radii.
    fmu.set_real(&mut ctx, vr::Z_M, 0.0115).unwrap();
    fmu.set_real(&mut ctx, vr::OMEGA_M, 3.0 * std::f64::consts::TAU)
        .unwrap();
    for k in 0..4 {
        fmu.step(&mut ctx, 1800.0 + 0.5 * k as f64, 0.5).unwrap();
    }
    let unknowns = [
        vr::R1,
        vr::R2,
        vr::R1_SS,
        vr::R2_SS,
        vr::S_X,
        vr::S_Y,
        vr::B,
        vr::G_Z,
        vr::K_XX,
        vr::K_YY,
        vr::DER_R1,
        vr::DER_R2,
        vr::R1_ODE,
        vr::FORM_V2,
        vr::DER_FORM_X1,
        vr::DER_FORM_V1,
        vr::DER_FORM_X2,
        vr::DER_FORM_V2,
    ];
    let read = |m: &mut MagSwarm| -> Vec<f64> {
        unknowns.iter().map(|&u| m.get_real(u).unwrap()).collect()
    };
    // Perturbations of the inputs (through fmi2SetReal) and of the state (the plant's).
    let perturbed = |m: &MagSwarm, known: u32, h: f64| -> Vec<f64> {
        let mut c = m.clone();
        let mut ctx = Ctx::silent();
        match known {
            vr::Z_M | vr::OMEGA_M => {
                let x = c.get_real(known).unwrap();
                c.set_real(&mut ctx, known, x + h).unwrap();
            }
            _ => {
                let p = c.plant.as_mut().unwrap();
                let mut x = p.continuous_state();
                x[(known - vr::R1_ODE) as usize] += h * 1e3; // SI -> mm
                p.set_continuous_state(x);
            }
        }
        read(&mut c)
    };
    let observed = fmu.plant().outputs();
    let state = fmu.plant().state();
    assert!(
        (observed.r1 - state[0]).abs() > 0.05,
        "the observed r1 {} mm should differ from the state {} mm",
        observed.r1,
        state[0]
    );
    // Move the formation mode off its rest so every term of its right-hand side counts.
    let p = fmu.plant.as_mut().unwrap();
    let mut x = p.continuous_state();
    x[3] = 0.4;
    x[4] -= 0.3;
    p.set_continuous_state(x);
    for (known, h) in [
        (vr::Z_M, 1e-7),
        (vr::OMEGA_M, 1e-5),
        (vr::R1_ODE, 1e-7),
        (vr::R2_ODE, 1e-7),
        (vr::FORM_X1, 1e-7),
        (vr::FORM_V1, 1e-7),
        (vr::FORM_X2, 1e-7),
        (vr::FORM_V2, 1e-7),
    ] {
        let plus = perturbed(&fmu, known, h);
        let minus = perturbed(&fmu, known, -h);
        let analytic = fmu.jacobian(&unknowns, &[known]).unwrap();
        for (j, &u) in unknowns.iter().enumerate() {
            let fd = (plus[j] - minus[j]) / (2.0 * h);
            let scale = fd.abs().max(analytic[j].abs());
            assert!(
                (analytic[j] - fd).abs() <= 1e-5 * scale + 1e-9,
                "d(vr {u})/d(vr {known}): analytic {:e}, finite difference {fd:e}",
                analytic[j]
            );
        }
    }
}

/// The shell's per-call checks read a precomputed kind per value reference
/// (`Table::is_typed`, `Table::is_settable`); they must say exactly what the table lookup
/// and the setting rules (`may_set`) say, for every reference (known or not), type and
/// mode, including the independent variable the shell adds to the table.
#[test]
fn the_shell_fast_checks_agree_with_the_table_and_the_rules() {
    use magswarm_fmi::mode::may_set;
    use magswarm_fmi::table::{with_independent_time, Table};
    use magswarm_fmi::{Causality, Mode, VarType};
    let modes = Mode::ALL;
    let types = [
        VarType::Real,
        VarType::Integer,
        VarType::Boolean,
        VarType::String,
    ];
    let mut settable = 0;
    for info in [
        <MagSwarm as FmuModel>::model_info(),
        with_independent_time(<MagSwarm as FmuModel>::model_info()),
    ] {
        let table = Table::new(info).expect("valid table");
        let max = info.variables.iter().map(|v| v.vr).max().unwrap();
        for vr in (0..=max + 3).chain([u32::MAX, 1 << 20]) {
            for ty in types {
                let expected = match table.get(vr) {
                    Some(v) if v.ty == ty => Some(v.causality == Causality::Independent),
                    _ => None,
                };
                assert_eq!(table.is_typed(vr, ty), expected, "vr {vr} {ty:?}");
                for mode in modes {
                    let expected = match table.get(vr) {
                        Some(v) if v.ty == ty => may_set(v, mode).is_ok(),
                        _ => false,
                    };
                    settable += expected as usize;
                    assert_eq!(
                        table.is_settable(vr, ty, mode),
                        expected,
                        "vr {vr} {ty:?} {mode:?}"
                    );
                }
            }
        }
    }
    // Not vacuous: inputs and parameters are settable in several modes.
    assert!(settable > 50, "{settable}");
}
