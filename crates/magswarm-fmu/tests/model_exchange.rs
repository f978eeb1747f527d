//! MagSwarm.fmu as FMI 2.0 Model Exchange, driven through the shell's entry points the way an
//! importer with its own integrator drives it: the ODE it exposes must reproduce the
//! Co-Simulation FMU, and every new entry point must refuse what the standard forbids.

use magswarm_fmi::fmi2::abi::{FMI2_CO_SIMULATION, FMI2_MODEL_EXCHANGE};
use magswarm_fmi::fmi2::host::Host;
use magswarm_fmi::fmi2::{Fmi2Status, Mode};
use magswarm_fmu::{vr, MagSwarm};

use Fmi2Status::{Error, Ok as OK};

type H = Host<MagSwarm>;

fn me() -> H {
    H::instantiate_as("plant-me", None, FMI2_MODEL_EXCHANGE).expect("instantiates as ME")
}

/// Initialise an ME instance and bring it to continuous-time mode.
fn to_continuous(h: &H) {
    assert_eq!(h.init(0.0), OK, "{:?}", h.log().entries());
    assert_eq!(h.mode(), Mode::EventMode);
    let (s, info) = h.new_discrete_states();
    assert_eq!(s, OK);
    assert_eq!(info.new_discrete_states_needed, 0);
    assert_eq!(info.terminate_simulation, 0);
    assert_eq!(h.enter_continuous_time_mode(), OK);
    assert_eq!(h.mode(), Mode::ContinuousTimeMode);
}

/// The derivatives at state `x` and time `t` (the importer's right-hand side).
fn rhs(h: &H, t: f64, x: &[f64]) -> Vec<f64> {
    assert_eq!(h.set_time(t), OK);
    assert_eq!(h.set_states(x), OK, "{:?}", h.log().entries());
    let (s, dx) = h.get_derivatives(x.len());
    assert_eq!(s, OK, "{:?}", h.log().entries());
    dx
}

#[test]
fn model_exchange_with_rk4_agrees_with_co_simulation_after_an_input_step() {
    let cs = H::instantiate_as("plant-cs", None, FMI2_CO_SIMULATION).unwrap();
    assert_eq!(cs.init(0.0), OK);
    let h = me();
    to_continuous(&h);
    let (s, mut x) = h.get_states(2);
    assert_eq!(s, OK);
    // Settled at start: the states are the outputs.
    assert!((x[0] - cs.get_real(vr::R1).1).abs() < 1e-12);
    let (dt, comm) = (1e-3, 0.05);
    let mut t = 0.0;
    let mut worst: f64 = 0.0;
    let r2_before = cs.get_real(vr::R2).1;
    for k in 0..200 {
        // A step of both inputs at t = 1 s: a new operating point to converge to.
        if k == 20 {
            for host in [&cs, &h] {
                assert_eq!(host.set_real(vr::Z_M, 0.012), OK);
                assert_eq!(host.set_real(vr::OMEGA_M, 40.0), OK);
            }
        }
        assert_eq!(cs.step(t, comm), OK);
        let n = (comm / dt).round() as usize;
        for _ in 0..n {
            let k1 = rhs(&h, t, &x);
            let x2: Vec<f64> = x.iter().zip(&k1).map(|(a, d)| a + 0.5 * dt * d).collect();
            let k2 = rhs(&h, t + 0.5 * dt, &x2);
            let x3: Vec<f64> = x.iter().zip(&k2).map(|(a, d)| a + 0.5 * dt * d).collect();
            let k3 = rhs(&h, t + 0.5 * dt, &x3);
            let x4: Vec<f64> = x.iter().zip(&k3).map(|(a, d)| a + dt * d).collect();
            let k4 = rhs(&h, t + dt, &x4);
            for i in 0..2 {
                x[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
            t += dt;
            assert_eq!(h.set_time(t), OK);
            assert_eq!(h.set_states(&x), OK);
            assert_eq!(h.completed_integrator_step(), (OK, false));
        }
        for (i, out) in [vr::R1, vr::R2].into_iter().enumerate() {
            let (s, y_me) = h.get_real(out);
            assert_eq!(s, OK);
            assert!((y_me - x[i]).abs() < 1e-15, "output r is the state");
            worst = worst.max((y_me - cs.get_real(out).1).abs());
        }
    }
    assert!(
        worst < 1e-6,
        "ME and CS differ by {:.3e} mm at most",
        worst * 1e3
    );
    // The step moved the swarm: the comparison was not between two constants.
    let moved = (cs.get_real(vr::R2).1 - r2_before).abs();
    assert!(moved > 1e-4, "r2 moved only {moved:e} m");
    assert_eq!(h.enter_event_mode(), OK);
    assert_eq!(h.terminate(), OK);
}

#[test]
fn non_finite_or_wrongly_sized_states_are_refused_naming_the_problem() {
    let h = me();
    to_continuous(&h);
    assert_eq!(h.set_states(&[f64::NAN, 0.01]), Error);
    assert!(h.log().has(Error, "\"r1\""), "{:?}", h.log().entries());
    assert_eq!(h.mode(), Mode::Error);

    let h = me();
    to_continuous(&h);
    assert_eq!(h.set_states(&[0.01, 0.01, 0.01]), Error);
    assert!(h.log().has(Error, "3 elements"), "{:?}", h.log().entries());

    let h = me();
    to_continuous(&h);
    assert_eq!(h.get_derivatives(1).0, Error);
    assert!(h.log().has(Error, "2 continuous states"));

    let h = me();
    to_continuous(&h);
    assert_eq!(h.set_states(&[-0.01, 0.01]), Error);
    assert!(h.log().has(Error, "positive radii"));

    let h = me();
    to_continuous(&h);
    assert_eq!(h.set_time(f64::INFINITY), Error);
    assert!(h.log().has(Error, "time must be finite"));
}

#[test]
fn calls_of_the_other_interface_and_out_of_sequence_calls_are_refused() {
    // ME instance: Co-Simulation functions do not exist for it.
    let h = me();
    to_continuous(&h);
    assert_eq!(h.step(0.0, 0.1), Error);
    assert!(
        h.log().has(Error, "fmi2ModelExchange"),
        "{:?}",
        h.log().entries()
    );

    // CS instance: Model Exchange functions do not exist for it.
    let cs = H::instantiate_as("plant-cs", None, FMI2_CO_SIMULATION).unwrap();
    assert_eq!(cs.init(0.0), OK);
    assert_eq!(cs.get_derivatives(2).0, Error);
    assert!(cs.log().has(Error, "fmi2CoSimulation"));

    // Out of sequence: states can only be set in continuous-time mode.
    let h = me();
    assert_eq!(h.init(0.0), OK);
    assert_eq!(h.set_states(&[0.01, 0.01]), Error);
    assert!(h.log().has(Error, "EventMode"), "{:?}", h.log().entries());

    // Inputs may be set in continuous-time mode; a non-finite one is refused by name.
    let h = me();
    to_continuous(&h);
    assert_eq!(h.set_real(vr::Z_M, 0.009), OK);
    assert_eq!(h.set_real(vr::Z_M, f64::NAN), Error);
    assert!(h.log().has(Error, "z_m"));

    // An unknown fmuType is refused with a message.
    let bad = H::instantiate_as("plant", None, 7);
    assert!(bad.is_err());
}

#[test]
fn reset_and_fmu_states_work_in_model_exchange() {
    let h = me();
    to_continuous(&h);
    assert_eq!(h.set_states(&[0.007, 0.011]), OK);
    let (s, st) = h.get_state();
    assert_eq!(s, OK);
    assert_eq!(h.set_states(&[0.008, 0.012]), OK);
    // SAFETY: a state this instance handed out and did not free.
    assert_eq!(unsafe { h.set_state(st) }, OK);
    assert_eq!(h.get_states(2).1, vec![0.007, 0.011]);
    assert_eq!(h.reset(), OK);
    assert_eq!(h.mode(), Mode::Instantiated);
    to_continuous(&h);
    let (s, nominal) = h.get_nominals(2);
    assert_eq!(s, OK);
    assert_eq!(nominal, vec![0.01, 0.01]);
}

#[test]
fn a_state_serialized_by_a_co_simulation_instance_is_refused_by_a_model_exchange_one() {
    let cs = H::instantiate_as("plant-cs", None, FMI2_CO_SIMULATION).unwrap();
    assert_eq!(cs.init(0.0), OK);
    let (s, st) = cs.get_state();
    assert_eq!(s, OK);
    // SAFETY: a state `cs` handed out.
    let bytes = unsafe { cs.serialize(st) }.expect("serializes");
    let h = me();
    to_continuous(&h);
    let (s, foreign) = h.deserialize(&bytes);
    assert_eq!(s, OK, "the bytes themselves are intact");
    // SAFETY: a state `h` handed out.
    assert_eq!(unsafe { h.set_state(foreign) }, Error);
    assert!(
        h.log().has(Error, "other interface"),
        "{:?}",
        h.log().entries()
    );
}

#[test]
fn directional_derivatives_of_the_state_derivatives_match_finite_differences() {
    use magswarm_fmi::fmi2::shell::fmi2_get_directional_derivative;
    let h = me();
    to_continuous(&h);
    let x = [0.008, 0.0125];
    let f0 = rhs(&h, 0.0, &x);
    let eps = 1e-8;
    for (j, known) in [vr::R1, vr::R2].into_iter().enumerate() {
        let mut xp = x;
        xp[j] += eps;
        let fp = rhs(&h, 0.0, &xp);
        assert_eq!(h.set_states(&x), OK);
        let unknowns = [vr::DER_R1, vr::DER_R2];
        let mut out = [f64::NAN; 2];
        // SAFETY: a live instance; arrays of the stated lengths.
        let s = unsafe {
            fmi2_get_directional_derivative::<MagSwarm>(
                h.component(),
                unknowns.as_ptr(),
                2,
                &known,
                1,
                &1.0,
                out.as_mut_ptr(),
            )
        };
        assert_eq!(s, OK, "{:?}", h.log().entries());
        for i in 0..2 {
            let fd = (fp[i] - f0[i]) / eps;
            assert!(
                (out[i] - fd).abs() <= 1e-4 * fd.abs().max(1.0),
                "d der_r{}/d r{}: analytic {} vs finite difference {fd}",
                i + 1,
                j + 1,
                out[i]
            );
        }
    }
}
