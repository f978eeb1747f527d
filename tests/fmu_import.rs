//! MagSwarm.fmu loaded as an importer loads it (what an FMI 2.0 importer sees): the packaged archive is
//! unzipped, modelDescription.xml parsed and the shared library called through the C ABI,
//! with the `fmi` crate (import side) and `magswarm::cosim` (the same crate's raw bindings,
//! for the logger, FMU state and directional derivatives). Value references always come from
//! the XML.
//!
//! Each test process packages its own FMU with `magswarm fmu --out <tmp>` (tests/common/fmu.rs).

#[path = "common/fmu.rs"]
mod fmu_common;

use std::f64::consts::TAU;

use magswarm::cosim::{
    CoSimConfig, CoSimulation, Command, CosimError, FmiVersion, Fmu, FmuSlave, SlaveOptions, Start,
    Status,
};
use magswarm::log::{Layout, LogRow, LogWriter};
use magswarm::model::{Model, Plant};

const Z0: f64 = 8.5e-3;
const W0: f64 = 4.0 * TAU;
const Z1: f64 = 13.5e-3;
const W1: f64 = 6.0 * TAU;
const H: f64 = 0.01;

fn fmu() -> Fmu {
    Fmu::load(fmu_common::packaged()).expect("load MagSwarm.fmu")
}

fn fmu3() -> Fmu {
    Fmu::load(fmu_common::packaged_fmi3()).expect("load the FMI 3.0 MagSwarm.fmu")
}

/// The name of the FMI function `name` (`DoStep`, `SetString`) in `f`'s version.
fn function(f: &Fmu, name: &str) -> String {
    format!("fmi{}{name}", f.fmi_version().major())
}

/// The function that sets Reals: `fmi2SetReal`, `fmi3SetFloat64`.
fn set_real_fn(f: &Fmu) -> &'static str {
    match f.fmi_version() {
        FmiVersion::V2 => "fmi2SetReal",
        FmiVersion::V3 => "fmi3SetFloat64",
    }
}

/// One test per FMI version for each check written over an [`Fmu`].
macro_rules! both_versions {
    ($($check:ident),* $(,)?) => {$(
        mod $check {
            #[test]
            fn fmi2() {
                super::$check(super::fmu())
            }
            #[test]
            fn fmi3() {
                super::$check(super::fmu3())
            }
        }
    )*};
}

both_versions!(
    import_resolves_contract_variables_from_xml,
    fmu_state_get_set_and_serialize_replay_bit_identically,
    reset_restarts_the_run,
    two_instances_do_not_share_state,
    nan_or_infinite_input_is_an_error_naming_the_variable,
    one_warning_per_envelope_excursion,
    directional_derivatives_match_finite_differences,
    shared_library_links_only_the_c_runtime,
    model_file_parameter_loads_or_names_the_bad_field,
    wrong_guid_is_refused_with_a_message,
    many_instantiate_free_cycles,
    runner_writes_contract_log_and_matches_in_process_plant,
    errors_carry_function_status_and_message,
);

fn slave(fmu: &Fmu, name: &str) -> FmuSlave {
    fmu.instantiate(name, SlaveOptions::default())
        .expect("instantiate")
}

/// Setup, enter init, set the inputs, exit init.
fn init(s: &mut FmuSlave, z: f64, w: f64) {
    s.setup_experiment(None, 0.0, None).unwrap();
    s.enter_initialization_mode().unwrap();
    s.set_real_by_name("z_m", z).unwrap();
    s.set_real_by_name("omega_m", w).unwrap();
    s.exit_initialization_mode().unwrap();
}

/// Inputs of a test sequence at step k: steps and a ramp, inside the envelope.
fn inputs_at(k: usize) -> (f64, f64) {
    match k / 50 {
        0 => (Z1, W1),
        1 => (6.0e-3, 2.0 * TAU),
        2 => (6.0e-3 + (k % 50) as f64 * 0.2e-3, 5.0 * TAU),
        _ => (18.0e-3, 8.0 * TAU),
    }
}

/// Run `n` steps of [`inputs_at`] from `t0`, recording the bits of r1, r2, r1_ss, r2_ss.
fn record(s: &mut FmuSlave, t0: f64, k0: usize, n: usize) -> Vec<[u64; 4]> {
    let f = s.fmu().clone();
    let ins = f.real_vrs(&["z_m", "omega_m"]).unwrap();
    let outs = f.real_vrs(&["r1", "r2", "r1_ss", "r2_ss"]).unwrap();
    let mut y = [0.0; 4];
    let mut rec = Vec::with_capacity(n);
    let mut t = t0;
    for k in k0..k0 + n {
        let (z, w) = inputs_at(k);
        s.set_real(&ins, &[z, w]).unwrap();
        s.do_step(t, H).unwrap();
        t += H;
        s.get_real(&outs, &mut y).unwrap();
        rec.push(y.map(f64::to_bits));
    }
    rec
}

// ----------------------------------------------------------------------------- fmi crate

/// The step response, through the `fmi` crate's own import and instance API: r1, r2 settle
/// on r1_ss, r2_ss.
#[test]
fn step_response_settles_on_steady_map_via_fmi_crate() {
    use fmi::fmi2::import::Fmi2Import;
    use fmi::fmi2::instance::{CoSimulation as _, Common};
    use fmi::traits::{FmiImport, FmiInstance};

    let import: Fmi2Import = fmi::import::from_path(fmu_common::packaged()).unwrap();
    let md = import.model_description();
    assert_eq!(md.fmi_version, "2.0");
    let vr = |n: &str| md.model_variable_by_name(n).unwrap().value_reference;
    let (vz, vw) = (vr("z_m"), vr("omega_m"));
    let outs = [vr("r1"), vr("r2"), vr("r1_ss"), vr("r2_ss")];

    let mut inst = import.instantiate_cs("step", false, false).unwrap();
    FmiInstance::enter_initialization_mode(&mut inst, None, 0.0, None).unwrap();
    Common::set_real(&mut inst, &[vz, vw], &[Z0, W0]).unwrap();
    FmiInstance::exit_initialization_mode(&mut inst).unwrap();

    let mut y = [0.0; 4];
    Common::get_real(&mut inst, &outs, &mut y).unwrap();
    let y0 = y;
    // Starts formed (settle_at_start): on the map of the initial inputs.
    assert!(
        (y[0] - y[2]).abs() <= 1e-9 * y[2],
        "r1 {} vs r1_ss {}",
        y[0],
        y[2]
    );
    assert!(
        (y[1] - y[3]).abs() <= 1e-9 * y[3],
        "r2 {} vs r2_ss {}",
        y[1],
        y[3]
    );

    // Step z_m 8.5 -> 13.5 mm, f 4 -> 6 Hz.
    Common::set_real(&mut inst, &[vz, vw], &[Z1, W1]).unwrap();
    Common::get_real(&mut inst, &outs, &mut y).unwrap();
    let ss = [y[2], y[3]];
    assert!(
        (ss[0] - y0[2]).abs() > 0.2e-3 || (ss[1] - y0[3]).abs() > 0.2e-3,
        "the map moves by less than 0.2 mm: {y0:?} -> {ss:?}"
    );
    assert_eq!(
        [y[0], y[1]],
        [y0[0], y0[1]],
        "r1, r2 are states: no feedthrough"
    );

    let mut t = 0.0;
    let mut rel_at = Vec::new();
    for k in 1..=4000 {
        inst.do_step(t, H, true).unwrap();
        t = k as f64 * H;
        Common::get_real(&mut inst, &outs, &mut y).unwrap();
        assert_eq!([y[2], y[3]], ss, "the map depends on the inputs only");
        let rel = ((y[0] - ss[0]) / ss[0])
            .abs()
            .max(((y[1] - ss[1]) / ss[1]).abs());
        if k % 500 == 0 {
            rel_at.push((t, rel));
        }
        if k == 10 {
            assert!(
                rel > 1e-3,
                "no dynamics: settled within 0.1 s (rel {rel:e})"
            );
        }
    }
    eprintln!("relative distance to the map: {rel_at:?}");
    let rel = rel_at.last().unwrap().1;
    assert!(
        rel < 1e-6,
        "after {t} s: r = ({}, {}) mm, map ({}, {}) mm, relative {rel:e}",
        y[0] * 1e3,
        y[1] * 1e3,
        ss[0] * 1e3,
        ss[1] * 1e3
    );
}

/// The FMI 3.0 FMU through the `fmi` crate's own FMI 3.0 import and instance API (its
/// `fmi3` feature) gives bit for bit the outputs of the FMI 2.0 FMU through `cosim`: one model
/// behind two shells.
#[test]
fn fmi3_via_fmi_crate_matches_fmi2_bit_for_bit() {
    use fmi::fmi3::import::Fmi3Import;
    use fmi::fmi3::instance::InstanceCS;
    use fmi::fmi3::{CoSimulation as _, Common as _, Fmi3Model as _, GetSet as _};
    use fmi::traits::FmiImport as _;

    let import: Fmi3Import = fmi::import::from_path(fmu_common::packaged_fmi3()).unwrap();
    let md = import.model_description();
    assert_eq!(md.fmi_version, "3.0");
    let vr = |n: &str| {
        md.model_variables
            .find_by_name(n)
            .unwrap_or_else(|| panic!("{n}"))
            .value_reference()
    };
    let ins = [vr("z_m"), vr("omega_m")];
    let outs = [vr("r1"), vr("r2"), vr("r1_ss"), vr("r2_ss")];
    let mut inst: InstanceCS = import
        .instantiate_cs("fmi3", false, false, false, false, &[])
        .unwrap();
    inst.enter_initialization_mode(None, 0.0, None).unwrap();
    inst.set_float64(&ins, &[Z0, W0]).unwrap();
    inst.exit_initialization_mode().unwrap();
    let mut got = Vec::new();
    let mut y = [0.0; 4];
    let mut t = 0.0;
    for k in 0..200 {
        let (z, w) = inputs_at(k);
        inst.set_float64(&ins, &[z, w]).unwrap();
        let (mut ev, mut term, mut early, mut last) = (false, false, false, 0.0);
        inst.do_step(t, H, true, &mut ev, &mut term, &mut early, &mut last)
            .unwrap();
        t += H;
        assert_eq!(last, t, "lastSuccessfulTime");
        assert!(!ev && !term && !early);
        inst.get_float64(&outs, &mut y).unwrap();
        got.push(y.map(f64::to_bits));
    }
    let f2 = fmu();
    let mut s = slave(&f2, "fmi2");
    init(&mut s, Z0, W0);
    assert_eq!(got, record(&mut s, 0.0, 0, 200));
}

/// The seed's tracking scenario (PID at 1 kHz, 180 s) through the Rust harness gives the
/// same samples with the FMI 3.0 FMU as with the FMI 2.0 one.
#[test]
fn tracking_through_fmi3_equals_fmi2() {
    use magswarm::control::{seed_scenario, sim, Controller, PidConfig};
    let run = |f: &Fmu| {
        let cfg = PidConfig {
            sample_time_s: 0.001,
            ..PidConfig::default()
        };
        let mut co = CoSimulation::new(
            f,
            &CoSimConfig {
                step_s: cfg.sample_time_s,
                initial_inputs: [sim::SEED_START.0, sim::SEED_START.1],
                ..CoSimConfig::default()
            },
        )
        .unwrap();
        let mut ctrl = Controller::new(Model::paper(), cfg).unwrap();
        let segs = seed_scenario();
        sim::tracking(
            &mut co,
            &mut ctrl,
            &segs,
            false,
            &mut magswarm::cosim::NoLog,
        )
        .unwrap()
        .samples
    };
    let (a, b) = (run(&fmu()), run(&fmu3()));
    assert_eq!(a.len(), 180_000);
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(format!("{x:?}"), format!("{y:?}"));
    }
}

// ----------------------------------------------------------------------------- cosim

fn import_resolves_contract_variables_from_xml(f: Fmu) {
    assert_eq!(f.model_identifier(), "MagSwarm");
    let caps = f.capabilities();
    assert!(caps.get_set_state && caps.serialize_state && caps.directional_derivative);
    for n in [
        "z_m", "omega_m", "r1", "r2", "r1_ss", "r2_ss", "S_x", "S_y", "B", "g_z", "k_xx", "k_yy",
    ] {
        f.real_vr(n).unwrap_or_else(|e| panic!("{n}: {e}"));
    }
    assert!(matches!(
        f.variable("model_file").unwrap().var_type,
        magswarm::cosim::VarType::String
    ));
    assert!(matches!(
        f.real_vr("nope"),
        Err(CosimError::UnknownVariable(_))
    ));
    assert!(matches!(
        f.real_vr("model_file"),
        Err(CosimError::VariableType { .. })
    ));
    assert!(f.library_path().is_file(), "{}", f.library_path().display());
    match f.fmi_version() {
        FmiVersion::V2 => assert!(f.resource_uri().starts_with("file:///")),
        // FMI 3.0: the resources folder's absolute path with a trailing separator.
        FmiVersion::V3 => assert!(
            f.resource_uri().starts_with('/') && f.resource_uri().ends_with("/resources/"),
            "{}",
            f.resource_uri()
        ),
    }
}

fn fmu_state_get_set_and_serialize_replay_bit_identically(f: Fmu) {
    let mut a = slave(&f, "a");
    init(&mut a, Z0, W0);
    let _ = record(&mut a, 0.0, 0, 30);
    let t_s = 30.0 * H;

    let st = a.get_state().unwrap();
    let bytes = a.serialize_state(&st).unwrap();
    assert!(!bytes.is_empty());
    let reference = record(&mut a, t_s, 30, 170);

    // get/set
    a.set_state(&st).unwrap();
    assert_eq!(
        record(&mut a, t_s, 30, 170),
        reference,
        "setFMUstate replay"
    );
    // update_state overwrites an existing state
    let mut st_upd = a.get_state().unwrap();
    a.set_state(&st).unwrap();
    a.update_state(&mut st_upd).unwrap();
    a.set_state(&st_upd).unwrap();
    assert_eq!(
        record(&mut a, t_s, 30, 170),
        reference,
        "updated state replay"
    );

    // serialize -> deserialize in the same instance
    let st2 = a.deserialize_state(&bytes).unwrap();
    a.set_state(&st2).unwrap();
    assert_eq!(
        record(&mut a, t_s, 30, 170),
        reference,
        "deserialized replay"
    );
    assert_eq!(
        a.serialize_state(&st2).unwrap(),
        bytes,
        "serialisation is stable"
    );

    // ... and in another instance of the same FMU (never stepped before)
    let mut b = slave(&f, "b");
    init(&mut b, 20e-3, 9.0 * TAU);
    let st_b = b.deserialize_state(&bytes).unwrap();
    b.set_state(&st_b).unwrap();
    assert_eq!(
        record(&mut b, t_s, 30, 170),
        reference,
        "replay in another instance"
    );

    // a state is bound to its instance
    assert!(matches!(b.set_state(&st), Err(CosimError::ForeignState)));

    for s in [st, st2, st_upd] {
        a.free_state(s).unwrap();
    }
    b.free_state(st_b).unwrap();
    assert!(
        a.log().iter().all(|m| m.status < Status::Warning),
        "{:?}",
        a.log()
    );
}

fn reset_restarts_the_run(f: Fmu) {
    let mut s = slave(&f, "r");
    let c1_start = f.real_start("C_1").unwrap().unwrap();
    init(&mut s, Z0, W0);
    let first = record(&mut s, 0.0, 0, 150);

    // a different run: another C_1 (a fixed parameter: set before initialisation)
    s.reset().unwrap();
    s.set_real_by_name("C_1", c1_start * 1.5).unwrap();
    init(&mut s, Z0, W0);
    assert_ne!(record(&mut s, 0.0, 0, 150), first);
    s.reset().unwrap();
    s.setup_experiment(None, 0.0, None).unwrap();
    s.enter_initialization_mode().unwrap();
    assert_eq!(
        s.get_real_by_name("C_1").unwrap(),
        c1_start,
        "parameters back to start"
    );
    s.set_real(&f.real_vrs(&["z_m", "omega_m"]).unwrap(), &[Z0, W0])
        .unwrap();
    s.exit_initialization_mode().unwrap();
    assert_eq!(
        record(&mut s, 0.0, 0, 150),
        first,
        "a reset instance repeats the run"
    );

    // terminate, reset, and run again
    s.terminate().unwrap();
    s.reset().unwrap();
    init(&mut s, Z0, W0);
    assert_eq!(record(&mut s, 0.0, 0, 150), first);
}

fn two_instances_do_not_share_state(f: Fmu) {
    let solo = |z: f64, w: f64, c1: Option<f64>| {
        let mut s = slave(&f, "solo");
        if let Some(c) = c1 {
            s.set_real_by_name("C_1", c).unwrap();
        }
        init(&mut s, z, w);
        let vrs = f
            .real_vrs(&["z_m", "omega_m", "r1", "r2", "r1_ss"])
            .unwrap();
        let mut out = Vec::new();
        let mut y = [0.0; 5];
        for k in 0..200 {
            let (zk, wk) = if k < 100 { (z, w) } else { (z * 1.3, w * 0.7) };
            s.set_real(&vrs[..2], &[zk, wk]).unwrap();
            s.do_step(k as f64 * H, H).unwrap();
            s.get_real(&vrs, &mut y).unwrap();
            out.push(y.map(f64::to_bits));
        }
        out
    };
    let c1 = f.real_start("C_1").unwrap().unwrap() * 0.8;
    let ref_a = solo(Z0, W0, None);
    let ref_b = solo(15e-3, 7.0 * TAU, Some(c1));

    let mut a = slave(&f, "a");
    let mut b = slave(&f, "b");
    b.set_real_by_name("C_1", c1).unwrap();
    init(&mut a, Z0, W0);
    init(&mut b, 15e-3, 7.0 * TAU);
    assert_ne!(a.get_real_by_name("C_1").unwrap(), c1);
    let vrs = f
        .real_vrs(&["z_m", "omega_m", "r1", "r2", "r1_ss"])
        .unwrap();
    let (mut ya, mut yb) = ([0.0; 5], [0.0; 5]);
    let (mut out_a, mut out_b) = (Vec::new(), Vec::new());
    for k in 0..200 {
        let (za, wa) = if k < 100 {
            (Z0, W0)
        } else {
            (Z0 * 1.3, W0 * 0.7)
        };
        let (zb, wb) = if k < 100 {
            (15e-3, 7.0 * TAU)
        } else {
            (15e-3 * 1.3, 7.0 * TAU * 0.7)
        };
        a.set_real(&vrs[..2], &[za, wa]).unwrap();
        b.set_real(&vrs[..2], &[zb, wb]).unwrap();
        a.do_step(k as f64 * H, H).unwrap();
        b.do_step(k as f64 * H, H).unwrap();
        a.get_real(&vrs, &mut ya).unwrap();
        b.get_real(&vrs, &mut yb).unwrap();
        out_a.push(ya.map(f64::to_bits));
        out_b.push(yb.map(f64::to_bits));
    }
    assert_eq!(out_a, ref_a, "instance a disturbed by b");
    assert_eq!(out_b, ref_b, "instance b disturbed by a");
}

fn nan_or_infinite_input_is_an_error_naming_the_variable(f: Fmu) {
    for (name, bad) in [
        ("z_m", f64::NAN),
        ("omega_m", f64::INFINITY),
        ("z_m", f64::NEG_INFINITY),
    ] {
        let mut s = slave(&f, "nan");
        init(&mut s, Z0, W0);
        s.do_step(0.0, H).unwrap();
        let err = s.set_real_by_name(name, bad).unwrap_err();
        eprintln!("{name} = {bad}: {err}");
        match &err {
            CosimError::Fmi {
                function,
                status,
                message,
            } => {
                assert_eq!(*function, set_real_fn(&f));
                assert_eq!(*status, Status::Error);
                assert!(
                    message.contains(name),
                    "message does not name {name}: {message}"
                );
            }
            other => panic!("expected an FMI error, got {other}"),
        }
        let logged: Vec<_> = s
            .log()
            .into_iter()
            .filter(|m| m.status == Status::Error)
            .collect();
        assert_eq!(logged.len(), 1, "{logged:?}");
        assert!(logged[0].message.contains(name), "{}", logged[0]);
        assert!(
            err.to_string()
                .contains(&format!("{} returned Error", set_real_fn(&f))),
            "{err}"
        );
        // No NaN reaches the outputs: either they are refused or they are finite.
        if let Ok(r1) = s.get_real_by_name("r1") {
            assert!(r1.is_finite(), "r1 = {r1} after a rejected {name} = {bad}");
        }
    }
}

fn one_warning_per_envelope_excursion(f: Fmu) {
    let mut s = slave(&f, "env");
    init(&mut s, Z0, W0);
    assert!(s.take_log().iter().all(|m| m.status < Status::Warning));
    let vz = f.real_vr("z_m").unwrap();
    let vw = f.real_vr("omega_m").unwrap();
    let mut t = 0.0;
    let mut excursion = |s: &mut FmuSlave, z: f64, w: f64, steps: usize| -> (usize, usize) {
        let mut warn_status = 0;
        for _ in 0..steps {
            for st in [
                s.set_real(&[vz, vw], &[z, w]).unwrap(),
                s.do_step(t, H).unwrap(),
            ] {
                if st == Status::Warning {
                    warn_status += 1;
                }
            }
            t += H;
        }
        let warn_logged = s
            .take_log()
            .iter()
            .filter(|m| m.status == Status::Warning)
            .count();
        (warn_status, warn_logged)
    };
    assert_eq!(
        excursion(&mut s, 30e-3, W0, 20),
        (1, 1),
        "z_m above the envelope"
    );
    assert!(!s.get_boolean_by_name("in_envelope").unwrap());
    assert_eq!(excursion(&mut s, Z1, W1, 20), (0, 0), "back inside");
    assert!(s.get_boolean_by_name("in_envelope").unwrap());
    assert_eq!(
        excursion(&mut s, Z1, 12.0 * TAU, 20),
        (1, 1),
        "f above the envelope"
    );
    assert_eq!(
        excursion(&mut s, 2.0e-3, 12.0 * TAU, 20),
        (0, 0),
        "still outside"
    );
    assert_eq!(excursion(&mut s, Z0, W0, 5), (0, 0), "inside");
    assert_eq!(
        excursion(&mut s, 2.0e-3, W0, 5),
        (1, 1),
        "z_m below the envelope"
    );
}

fn directional_derivatives_match_finite_differences(f: Fmu) {
    let mut s = slave(&f, "dd");
    init(&mut s, Z0, W0);
    let ins = f.real_vrs(&["z_m", "omega_m"]).unwrap();
    let outs = f.real_vrs(&["r1_ss", "r2_ss"]).unwrap();
    let mut y = [0.0; 2];
    for (z, w) in [(Z0, W0), (Z1, W1), (5e-3, 2.0 * TAU), (20e-3, 9.0 * TAU)] {
        s.set_real(&ins, &[z, w]).unwrap();
        let jac = s
            .jacobian(&["r1_ss", "r2_ss"], &["z_m", "omega_m"])
            .unwrap();
        for (j, (x0, hrel)) in [(z, 1e-6), (w, 1e-6)].into_iter().enumerate() {
            let h = x0 * hrel;
            let mut at = |x: f64| {
                let mut u = [z, w];
                u[j] = x;
                s.set_real(&ins, &u).unwrap();
                s.get_real(&outs, &mut y).unwrap();
                y
            };
            let (p, m) = (at(x0 + h), at(x0 - h));
            for i in 0..2 {
                let fd = (p[i] - m[i]) / (2.0 * h);
                let dd = jac[i][j];
                // scale: the output's change over 1 % of the input
                let scale = (fd.abs() * x0).max(1e-9);
                assert!(
                    (dd - fd).abs() * x0 <= 1e-6 * scale.max(1e-6),
                    "d{}/d{} at z={z} w={w}: analytic {dd:e}, finite difference {fd:e}",
                    ["r1_ss", "r2_ss"][i],
                    ["z_m", "omega_m"][j]
                );
            }
        }
        s.set_real(&ins, &[z, w]).unwrap();
    }
    // the dynamic radii have no direct feedthrough from the inputs
    let d = s
        .directional_derivative(&f.real_vrs(&["r1", "r2"]).unwrap(), &ins, &[1.0, 1.0])
        .unwrap();
    assert_eq!(d, vec![0.0, 0.0]);
}

fn shared_library_links_only_the_c_runtime(f: Fmu) {
    let lib = f.library_path();
    let out = match std::process::Command::new("ldd").arg(&lib).output() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("SKIPPED: ldd is not available ({e})");
            return;
        }
    };
    assert!(
        out.status.success(),
        "ldd failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    let allowed = ["linux-vdso.so", "libc.so", "libm.so", "ld-linux"];
    let mut libs = Vec::new();
    for line in text.lines().map(str::trim).filter(|l| !l.is_empty()) {
        let name = line.split_whitespace().next().unwrap_or_default();
        let base = name.rsplit('/').next().unwrap_or(name);
        assert!(
            allowed.iter().any(|a| base.starts_with(a)),
            "{} links {name}:\n{text}",
            lib.display()
        );
        libs.push(base.to_string());
    }
    assert!(libs.iter().any(|l| l.starts_with("libc.so")), "{text}");
}

fn paper_json_value() -> serde_json::Value {
    serde_json::to_value(Model::paper()).unwrap()
}

#[test]
fn baked_model_changes_start_values_and_outputs() {
    let dir = fmu_common::scratch_dir().join("baked");
    std::fs::create_dir_all(&dir).unwrap();
    let mut m = Model::paper();
    let c1 = m.steady.C_1 * 1.25;
    m.steady.C_1 = c1;
    m.name = "baked-test".into();
    let model_path = dir.join("baked.json");
    m.save(&model_path).unwrap();
    let baked_path = fmu_common::package(&dir.join("MagSwarm.fmu"), Some(&model_path));

    let default = fmu();
    let baked = Fmu::load(&baked_path).unwrap();
    assert_eq!(default.guid(), baked.guid(), "same interface, same GUID");
    assert_eq!(baked.variable("C_1").unwrap().start, Some(Start::Real(c1)));
    assert_eq!(
        default.variable("C_1").unwrap().start,
        Some(Start::Real(Model::paper().steady.C_1))
    );
    assert_eq!(
        baked.variable("C_2").unwrap().start,
        default.variable("C_2").unwrap().start
    );
    let res = baked.extracted_dir().join("resources/model.json");
    let text = std::fs::read_to_string(&res).unwrap();
    assert!(text.contains("baked-test"), "{}", res.display());

    let outputs = |f: &Fmu| {
        let mut s = slave(f, "x");
        init(&mut s, Z0, W0);
        (
            s.get_real_by_name("C_1").unwrap(),
            s.get_reals_by_name(&["r1_ss", "r2_ss", "r1"]).unwrap(),
        )
    };
    let (c_d, y_d) = outputs(&default);
    let (c_b, y_b) = outputs(&baked);
    assert_eq!(c_d, Model::paper().steady.C_1);
    assert_eq!(c_b, c1);
    assert!(
        (y_b[0] / y_d[0] - 1.25).abs() < 0.05,
        "r1_ss {} -> {} mm",
        y_d[0] * 1e3,
        y_b[0] * 1e3
    );
    assert!(y_b[2] != y_d[2], "the dynamic r1 starts on the baked map");
}

fn model_file_parameter_loads_or_names_the_bad_field(f: Fmu) {
    let dir = fmu_common::scratch_dir().join("model_file");
    std::fs::create_dir_all(&dir).unwrap();

    // a good file replaces the defaults
    let mut good = paper_json_value();
    let c1 = good["steady"]["C_1"].as_f64().unwrap() * 0.9;
    good["steady"]["C_1"] = c1.into();
    let good_path = dir.join("good.json");
    std::fs::write(&good_path, serde_json::to_string_pretty(&good).unwrap()).unwrap();
    let mut s = slave(&f, "good");
    s.setup_experiment(None, 0.0, None).unwrap();
    s.set_string_by_name("model_file", good_path.to_str().unwrap())
        .unwrap();
    s.enter_initialization_mode().unwrap();
    s.exit_initialization_mode().unwrap();
    assert_eq!(s.get_real_by_name("C_1").unwrap(), c1);
    assert_eq!(
        s.get_string_by_name("model_file").unwrap(),
        good_path.to_str().unwrap()
    );

    type Edit = Box<dyn Fn(&mut serde_json::Value)>;
    let cases: [(&str, Edit, &str); 3] = [
        (
            "negative",
            Box::new(|v| v["steady"]["C_1"] = (-1.0).into()),
            "C_1",
        ),
        (
            "wrong type",
            Box::new(|v| v["steady"]["K_d2"] = "fast".into()),
            "K_d2",
        ),
        (
            "missing",
            Box::new(|v| {
                v["dynamics"].as_object_mut().unwrap().remove("beta");
            }),
            "beta",
        ),
    ];
    for (what, edit, field) in cases {
        let mut v = paper_json_value();
        edit(&mut v);
        let p = dir.join(format!("bad-{}.json", what.replace(' ', "_")));
        std::fs::write(&p, serde_json::to_string_pretty(&v).unwrap()).unwrap();
        let mut s = slave(&f, "bad");
        s.setup_experiment(None, 0.0, None).unwrap();
        let err = s
            .set_string_by_name("model_file", p.to_str().unwrap())
            .unwrap_err();
        assert_eq!(
            err.function(),
            Some(function(&f, "SetString").as_str()),
            "{what}: {err}"
        );
        assert_eq!(err.status(), Some(Status::Error), "{what}: {err}");
        let msg = err.fmu_message().unwrap();
        assert!(
            msg.contains(field),
            "{what}: the message does not name {field}: {msg}"
        );
    }

    // a file that does not exist
    let mut s = slave(&f, "missing");
    let err = s
        .set_string_by_name("model_file", "/nonexistent/model.json")
        .unwrap_err();
    assert_eq!(err.status(), Some(Status::Error));
    assert!(
        err.fmu_message()
            .unwrap()
            .contains("/nonexistent/model.json"),
        "{err}"
    );
}

fn wrong_guid_is_refused_with_a_message(f: Fmu) {
    let err = f
        .instantiate(
            "guid",
            SlaveOptions {
                guid_override: Some("{00000000-0000-0000-0000-000000000000}".into()),
                ..Default::default()
            },
        )
        .unwrap_err();
    match err {
        CosimError::Instantiate { message, .. } => {
            let m = message.to_lowercase();
            assert!(
                m.contains("guid") || m.contains("instantiationtoken"),
                "{message}"
            )
        }
        other => panic!("expected Instantiate, got {other}"),
    }
}

fn many_instantiate_free_cycles(f: Fmu) {
    for i in 0..300 {
        let mut s = slave(&f, &format!("cycle{i}"));
        if i % 10 == 0 {
            init(&mut s, Z0, W0);
            s.do_step(0.0, H).unwrap();
            let st = s.get_state().unwrap();
            let _leaked_on_purpose = st; // freed by the slave's drop
        }
    }
}

/// The co-simulation runner: one log row per sample in the contract's format, and the FMU
/// driven through the C ABI gives the same radii as the in-process plant.
fn runner_writes_contract_log_and_matches_in_process_plant(f: Fmu) {
    let cfg = CoSimConfig {
        step_s: 0.02,
        initial_inputs: [Z0, W0],
        extra_outputs: vec!["r1_ss".into()],
        ..Default::default()
    };
    let mut sim = CoSimulation::new(&f, &cfg).unwrap();
    // open loop: z_m steps at 1 s, f ramps from 2 s
    let ctrl = |m: &magswarm::cosim::Measurement| {
        let z = if m.t_s < 1.0 { 8.5 } else { 12.0 };
        let fhz = if m.t_s < 2.0 {
            4.0
        } else {
            4.0 + (m.t_s - 2.0)
        };
        Command::from_mm_hz(z, fhz).with_reference_mm(8.0, 11.0)
    };
    let mut rows: Vec<LogRow> = Vec::new();
    let sum = sim.run_for(5.0, ctrl, &mut rows).unwrap();
    assert_eq!(sum.steps, 250);
    assert_eq!(rows.len(), 250);
    assert!((sum.t_end_s - 5.0).abs() < 1e-9);
    assert_eq!(sum.warnings, 0);
    assert!(rows.windows(2).all(|w| w[1].t_s > w[0].t_s));
    assert_eq!(rows[0].t_s, 0.0);
    assert_eq!((rows[0].z_m_mm, rows[0].f_hz), (8.5, 4.0));
    assert_eq!(rows[100].r1_ref_mm, Some(8.0));

    // the same inputs through the in-process plant
    let mut plant = Plant::new(Model::paper(), Z0, W0);
    for r in &rows {
        let y = plant.state();
        assert!(
            (y[0] - r.r1_mm.unwrap()).abs() < 1e-9 && (y[1] - r.r2_mm.unwrap()).abs() < 1e-9,
            "t = {}: plant {y:?} vs FMU ({:?}, {:?})",
            r.t_s,
            r.r1_mm,
            r.r2_mm
        );
        plant.set_inputs(r.z_m_mm * 1e-3, r.f_hz * TAU);
        plant.step(0.02).unwrap();
    }

    // the CSV sink writes the contract's header
    let mut sim = CoSimulation::new(&f, &cfg).unwrap();
    let mut w = LogWriter::new(Vec::new(), Layout::standard(true, false, false, true)).unwrap();
    sim.run(3, ctrl, &mut w).unwrap();
    let csv = String::from_utf8(w.into_inner().unwrap()).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t_s,z_m_mm,f_hz,r1_mm,r2_mm,r1_ref_mm,r2_ref_mm"
    );
    assert_eq!(lines.count(), 3);
    let back = magswarm::log::Log::from_str_named(&csv, "runner").unwrap();
    assert_eq!(back.rows.len(), 3);
}

fn errors_carry_function_status_and_message(f: Fmu) {
    let mut s = slave(&f, "err");
    // doStep before initialisation is a state-machine error
    let err = s.do_step(0.0, H).unwrap_err();
    assert_eq!(err.function(), Some(function(&f, "DoStep").as_str()));
    assert!(err.status().unwrap() >= Status::Error);
    assert!(!err.fmu_message().unwrap().is_empty());
    assert!(
        !err.fmu_message().unwrap().contains("logged nothing"),
        "{err}"
    );
}
