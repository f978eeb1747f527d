//! MagSwarmPID.fmu driven through the shell's C entry points by a hostile importer: absurd
//! but finite inputs and parameters, steps that would never end, forged states. Each case
//! must end in a clear fmi2Error (never fmi2OK with NaN or inf outputs, never a panic, never
//! minutes of work).

use std::time::{Duration, Instant};

use magswarm_fmi::fmi2::host::Host;
use magswarm_fmi::fmi2::{Fmi2Status, Mode};
use magswarm_pid_fmu::{vr, MagSwarmPid, MagSwarmPidState, RunningState, PARAMS};

use Fmi2Status::{Error, Ok as OK};

type H = Host<MagSwarmPid>;

fn host() -> H {
    H::instantiate("pid", None).expect("instantiates")
}

fn param(name: &str) -> u32 {
    vr::PARAM_BASE + PARAMS.iter().position(|p| p.name == name).unwrap() as u32
}

fn no_panic(h: &H) {
    let e = h.log().entries();
    assert!(
        !e.iter().any(|e| e.message.contains("panicked")),
        "validation, not the panic barrier: {e:?}"
    );
}

/// Drive `f` and check the invariants after it: OK or Warning only with finite outputs.
fn checked(h: &H, f: impl FnOnce(&H) -> Fmi2Status) -> Fmi2Status {
    let before = h.log().len();
    let s = f(h);
    h.check(s, before).unwrap_or_else(|e| panic!("{e}"));
    s
}

#[test]
fn huge_measured_radius_is_refused_not_turned_into_nan() {
    let h = host();
    assert_eq!(h.init(0.0), OK);
    let s = checked(&h, |h| h.set_real(vr::R1, 1e308));
    for k in 0..3 {
        if h.mode() != Mode::StepComplete {
            break;
        }
        checked(&h, |h| h.step(k as f64 * 0.05, 0.05));
    }
    assert_eq!(s, Error, "1e308 m is not a radius");
    assert!(h.log().has(Error, "r1"), "{:?}", h.log().entries());
    no_panic(&h);
}

#[test]
fn huge_setpoint_is_refused() {
    let h = host();
    assert_eq!(h.init(0.0), OK);
    assert_eq!(checked(&h, |h| h.set_real(vr::R1_REF, 1e308)), Error);
    let h = host();
    assert_eq!(checked(&h, |h| h.set_real(vr::R1_REF, 1e308)), Error);
    no_panic(&h);
}

#[test]
fn every_absurd_finite_input_keeps_outputs_finite() {
    for value in [1e308, -1e308, 1e-308, 5e-324, 1e30, -1.0, 0.0, 0.9] {
        for input in [vr::R1, vr::R2, vr::R1_REF, vr::R2_REF] {
            let h = host();
            assert_eq!(h.init(0.0), OK);
            checked(&h, |h| h.set_real(input, value));
            for k in 0..3 {
                if h.mode() != Mode::StepComplete {
                    break;
                }
                checked(&h, |h| h.step(k as f64 * 0.05, 0.05));
            }
            no_panic(&h);
        }
    }
}

#[test]
fn tiny_sample_times_are_refused_before_any_work() {
    for ts in [5e-324, 1e-9] {
        let h = host();
        let t0 = Instant::now();
        let s = h.set_real(param("sample_time"), ts);
        let s = if s <= Fmi2Status::Warning {
            h.init(0.0)
        } else {
            s
        };
        if s <= Fmi2Status::Warning {
            assert_eq!(h.step(0.0, 1.0), Error, "sample_time {ts}");
        }
        assert!(t0.elapsed() < Duration::from_secs(2), "sample_time {ts}");
        assert!(h.log().has(Error, "sample_time"), "{:?}", h.log().entries());
        no_panic(&h);
    }
}

#[test]
fn a_step_needing_too_many_samples_is_refused_with_the_limit() {
    let h = host();
    assert_eq!(h.init(0.0), OK);
    let t0 = Instant::now();
    assert_eq!(h.step(0.0, 1e9), Error);
    assert!(t0.elapsed() < Duration::from_secs(2));
    let m = h.log().at_least(Error).join("\n");
    assert!(m.contains("samples") && m.contains("limit"), "{m}");
    // Within the limit, a long step works.
    let h = host();
    assert_eq!(h.init(0.0), OK);
    assert_eq!(h.step(0.0, 100.0), OK);
}

#[test]
fn absurd_limits_are_validation_errors_not_panics() {
    for (name, value) in [
        ("z_min", -1e308),
        ("z_max", 1e308),
        ("f_max", 1e308),
        ("z_rate", 1e308),
        ("kp_r1", 1e308),
        ("decoupler_damping", 1e308),
    ] {
        let h = host();
        let s = h.set_real(param(name), value);
        let s = if s <= Fmi2Status::Warning {
            h.init(0.0)
        } else {
            s
        };
        if s <= Fmi2Status::Warning {
            for k in 0..3 {
                if h.mode() != Mode::StepComplete {
                    break;
                }
                checked(&h, |h| h.step(k as f64 * 0.05, 0.05));
            }
        }
        assert_eq!(s, Error, "{name} = {value}");
        assert!(h.log().has(Error, name), "{name}: {:?}", h.log().entries());
        no_panic(&h);
    }
    for (vr_, value) in [(vr::Z_START, 1e308), (vr::OMEGA_START, -1e308)] {
        let h = host();
        assert_eq!(h.set_real(vr_, value), Error);
        no_panic(&h);
    }
}

/// The running controller's part of a state.
fn run(s: &mut MagSwarmPidState) -> &mut RunningState {
    s.running.as_mut().expect("the controller runs")
}

/// Genuine-looking controller states with absurd content (what a forger who knows the
/// format writes: the shell's checksum passes, only the content checks can refuse them).
fn forgeries(good: &MagSwarmPidState) -> Vec<(&'static str, MagSwarmPidState)> {
    let edit = |f: &dyn Fn(&mut MagSwarmPidState)| {
        let mut s = good.clone();
        f(&mut s);
        s
    };
    vec![
        ("start time -1e308", edit(&|s| s.t0 = -1e308)),
        ("start time 1e308", edit(&|s| s.t0 = 1e308)),
        (
            "controller sample time 1e-9",
            edit(&|s| run(s).cfg.sample_time_s = 1e-9),
        ),
        (
            "configured sample time 1e-9",
            edit(&|s| s.base_cfg.sample_time_s = 1e-9),
        ),
        (
            "integrator state -1e300",
            edit(&|s| {
                let mut v = serde_json::to_value(&run(s).controller).unwrap();
                v["integ"] = serde_json::json!([-1e300, -1e300]);
                run(s).controller = serde_json::from_value(v).unwrap();
            }),
        ),
        ("command -inf", edit(&|s| run(s).u[0] = f64::NEG_INFINITY)),
        ("sample count u64::MAX", edit(&|s| run(s).k = u64::MAX)),
        ("measured r1 1e308", edit(&|s| s.y[0] = 1e308)),
        (
            "parameter index 9999",
            edit(&|s| s.overrides.push((9999, 1.0))),
        ),
        ("model C_1 NaN", edit(&|s| s.model.steady.C_1 = f64::NAN)),
    ]
}

#[test]
fn forged_controller_states_are_refused() {
    use magswarm_fmi::fmi2::FmuModel;
    let mut m = MagSwarmPid::new(None).unwrap();
    let mut ctx = magswarm_fmi::fmi2::Ctx::silent();
    m.setup_experiment(&mut ctx, None, 0.0, None).unwrap();
    m.exit_initialization_mode(&mut ctx).unwrap();
    m.step(&mut ctx, 0.0, 0.5).unwrap();
    let good = m.save_state().unwrap();
    assert!(m.clone().restore_state(good.clone()).is_ok());
    for (what, forged) in forgeries(&good) {
        let mut victim = m.clone();
        let t0 = Instant::now();
        let r = victim.restore_state(forged);
        let r = r.and_then(|_| victim.step(&mut ctx, 0.5, 0.05));
        assert!(r.is_err(), "{what} was accepted");
        assert!(t0.elapsed() < Duration::from_secs(2), "{what}");
    }
}

/// The PID FMU is Co-Simulation only: instantiating it as Model Exchange is refused with a
/// message saying so (its XML has no `<ModelExchange>` element either).
#[test]
fn model_exchange_is_refused_by_the_co_simulation_only_pid() {
    let r = Host::<MagSwarmPid>::instantiate_as(
        "pid",
        None,
        magswarm_fmi::fmi2::abi::FMI2_MODEL_EXCHANGE,
    );
    let log = r.err().expect("refused");
    assert!(
        log.iter().any(|e| e.message.contains("Co-Simulation only")),
        "{log:?}"
    );
    let xml = magswarm_pid_fmu::model_description(&Default::default(), None);
    assert!(!xml.contains("<ModelExchange"));
}
