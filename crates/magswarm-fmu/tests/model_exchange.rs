//! MagSwarm.fmu as Model Exchange, in FMI 2.0 and FMI 3.0, driven through the shells' entry
//! points the way an importer with its own integrator drives them: the ODE it exposes (ODE
//! (4) and the slow formation mode of `formation_lag`) must reproduce the Co-Simulation FMU,
//! and every new entry point must refuse what the standard forbids.

use magswarm_fmi::fmi2::abi::{FMI2_CO_SIMULATION, FMI2_MODEL_EXCHANGE};
use magswarm_fmi::fmi2::host::Host;
use magswarm_fmi::fmi2::{Fmi2Status, Mode};
use magswarm_fmi::fmi3::host::{Host as Host3, Kind};
use magswarm_fmi::Status;
use magswarm_fmu::{vr, MagSwarm};
use magswarm_model::effects::FormationLag;
use magswarm_model::Model;

use Fmi2Status::{Error, Ok as OK};

type H = Host<MagSwarm>;
type H3 = Host3<MagSwarm>;

/// The number of continuous states: r1_ode, r2_ode and the formation mode (x, v) per axis.
const NX: usize = 6;

/// What the scenario needs of an instance, in either FMI version (statuses as C ints).
trait Drive {
    fn set_real(&self, vr: u32, x: f64) -> i32;
    fn get_real(&self, vr: u32) -> (i32, f64);
    fn set_string(&self, vr: u32, s: &str) -> i32;
    fn init(&self) -> i32;
    fn step(&self, t: f64, h: f64) -> i32;
    /// Event iteration (nothing to do) and into continuous-time mode.
    fn to_continuous(&self) -> i32;
    fn set_time(&self, t: f64) -> i32;
    fn set_states(&self, x: &[f64]) -> i32;
    fn get_states(&self) -> (i32, Vec<f64>);
    fn get_derivatives(&self) -> (i32, Vec<f64>);
    fn completed(&self) -> (i32, bool);
    fn messages(&self) -> Vec<String>;
}

impl Drive for H {
    fn set_real(&self, vr: u32, x: f64) -> i32 {
        Host::set_real(self, vr, x) as i32
    }
    fn get_real(&self, vr: u32) -> (i32, f64) {
        let (s, x) = Host::get_real(self, vr);
        (s as i32, x)
    }
    fn set_string(&self, vr: u32, s: &str) -> i32 {
        Host::set_string(self, vr, s) as i32
    }
    fn init(&self) -> i32 {
        Host::init(self, 0.0) as i32
    }
    fn step(&self, t: f64, h: f64) -> i32 {
        Host::step(self, t, h) as i32
    }
    fn to_continuous(&self) -> i32 {
        let (s, info) = self.new_discrete_states();
        assert_eq!(info.new_discrete_states_needed, 0);
        assert_eq!(info.terminate_simulation, 0);
        (s as i32).max(self.enter_continuous_time_mode() as i32)
    }
    fn set_time(&self, t: f64) -> i32 {
        Host::set_time(self, t) as i32
    }
    fn set_states(&self, x: &[f64]) -> i32 {
        Host::set_states(self, x) as i32
    }
    fn get_states(&self) -> (i32, Vec<f64>) {
        let (s, x) = Host::get_states(self, NX);
        (s as i32, x)
    }
    fn get_derivatives(&self) -> (i32, Vec<f64>) {
        let (s, x) = Host::get_derivatives(self, NX);
        (s as i32, x)
    }
    fn completed(&self) -> (i32, bool) {
        let (s, e) = self.completed_integrator_step();
        (s as i32, e)
    }
    fn messages(&self) -> Vec<String> {
        self.log()
            .entries()
            .into_iter()
            .map(|e| e.message)
            .collect()
    }
}

impl Drive for H3 {
    fn set_real(&self, vr: u32, x: f64) -> i32 {
        Host3::set_real(self, vr, x) as i32
    }
    fn get_real(&self, vr: u32) -> (i32, f64) {
        let (s, x) = Host3::get_real(self, vr);
        (s as i32, x)
    }
    fn set_string(&self, vr: u32, s: &str) -> i32 {
        Host3::set_string(self, vr, s) as i32
    }
    fn init(&self) -> i32 {
        Host3::init(self, 0.0) as i32
    }
    fn step(&self, t: f64, h: f64) -> i32 {
        Host3::step(self, t, h).0 as i32
    }
    fn to_continuous(&self) -> i32 {
        let (s, any) = self.update_discrete_states();
        assert!(!any, "no discrete states, no events");
        (s as i32).max(self.enter_continuous_time_mode() as i32)
    }
    fn set_time(&self, t: f64) -> i32 {
        Host3::set_time(self, t) as i32
    }
    fn set_states(&self, x: &[f64]) -> i32 {
        Host3::set_states(self, x) as i32
    }
    fn get_states(&self) -> (i32, Vec<f64>) {
        let (s, x) = Host3::get_states(self, NX);
        (s as i32, x)
    }
    fn get_derivatives(&self) -> (i32, Vec<f64>) {
        let (s, x) = Host3::get_derivatives(self, NX);
        (s as i32, x)
    }
    fn completed(&self) -> (i32, bool) {
        let (s, e) = self.completed_integrator_step();
        (s as i32, e)
    }
    fn messages(&self) -> Vec<String> {
        self.log()
            .entries()
            .into_iter()
            .map(|e| e.message)
            .collect()
    }
}

/// The derivatives at state `x` and time `t` (the importer's right-hand side).
fn rhs(h: &dyn Drive, t: f64, x: &[f64]) -> Vec<f64> {
    assert_eq!(h.set_time(t), 0);
    assert_eq!(h.set_states(x), 0, "{:?}", h.messages());
    let (s, dx) = h.get_derivatives();
    assert_eq!(s, 0, "{:?}", h.messages());
    dx
}

/// A model file with the `formation_lag` effect (oscillating slow mode), in `dir`.
fn formation_lag_model(dir: &std::path::Path) -> String {
    let mut m = Model::paper();
    m.effects.formation_lag = Some(FormationLag {
        share: 0.35,
        tau_s: 0.6,
        zeta: 0.4,
    });
    let p = dir.join("formation_lag.json");
    std::fs::write(&p, m.to_json().unwrap()).unwrap();
    p.display().to_string()
}

/// RK4 over the Model Exchange interface against the Co-Simulation FMU across an input
/// step: the largest difference of the outputs r1, r2 [m] at the communication points.
fn me_against_cs(cs: &dyn Drive, me: &dyn Drive, model_file: Option<&str>) -> f64 {
    if let Some(f) = model_file {
        assert_eq!(cs.set_string(vr::MODEL_FILE, f), 0, "{:?}", cs.messages());
        assert_eq!(me.set_string(vr::MODEL_FILE, f), 0, "{:?}", me.messages());
    }
    assert_eq!(cs.init(), 0);
    assert_eq!(me.init(), 0, "{:?}", me.messages());
    assert_eq!(me.to_continuous(), 0);
    let (s, mut x) = me.get_states();
    assert_eq!(s, 0);
    assert_eq!(x.len(), NX);
    // Settled at start: the ODE states are the outputs, the formation mode is at rest there.
    assert!((x[0] - cs.get_real(vr::R1).1).abs() < 1e-12);
    assert!((x[2] - x[0]).abs() < 1e-12 && x[3] == 0.0);
    let (dt, comm) = (1e-3, 0.05);
    let mut t = 0.0;
    let mut worst: f64 = 0.0;
    let r1_before = cs.get_real(vr::R1).1;
    for k in 0..120 {
        // A step of both inputs at t = 1 s: a new operating point to converge to.
        if k == 20 {
            for host in [cs, me] {
                assert_eq!(host.set_real(vr::Z_M, 0.012), 0);
                assert_eq!(host.set_real(vr::OMEGA_M, 40.0), 0);
            }
        }
        assert_eq!(cs.step(t, comm), 0);
        let n = (comm / dt).round() as usize;
        for _ in 0..n {
            let k1 = rhs(me, t, &x);
            let at = |k: &[f64], c: f64| -> Vec<f64> {
                x.iter().zip(k).map(|(a, d)| a + c * dt * d).collect()
            };
            let k2 = rhs(me, t + 0.5 * dt, &at(&k1, 0.5));
            let k3 = rhs(me, t + 0.5 * dt, &at(&k2, 0.5));
            let k4 = rhs(me, t + dt, &at(&k3, 1.0));
            for i in 0..NX {
                x[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
            t += dt;
            assert_eq!(me.set_time(t), 0);
            assert_eq!(me.set_states(&x), 0);
            assert_eq!(me.completed(), (0, false));
        }
        for out in [vr::R1, vr::R2] {
            let (s, y_me) = me.get_real(out);
            assert_eq!(s, 0);
            worst = worst.max((y_me - cs.get_real(out).1).abs());
        }
    }
    // The step moved the swarm: the comparison was not between two constants.
    let moved = (cs.get_real(vr::R1).1 - r1_before).abs();
    assert!(moved > 1e-4, "r1 moved only {moved:e} m");
    worst
}

#[test]
fn model_exchange_with_rk4_agrees_with_co_simulation_in_both_versions() {
    let dir = tempfile::tempdir().unwrap();
    let lag = formation_lag_model(dir.path());
    for model in [None, Some(lag.as_str())] {
        let cs = H::instantiate_as("plant-cs", None, FMI2_CO_SIMULATION).unwrap();
        let me = H::instantiate_as("plant-me", None, FMI2_MODEL_EXCHANGE).unwrap();
        let w2 = me_against_cs(&cs, &me, model);
        let cs3 = H3::instantiate("plant-cs", None, Kind::CoSimulation).unwrap();
        let me3 = H3::instantiate("plant-me", None, Kind::ModelExchange).unwrap();
        let w3 = me_against_cs(&cs3, &me3, model);
        for (v, w) in [("FMI 2.0", w2), ("FMI 3.0", w3)] {
            // RK4 at 1 ms against the FMU's own Dormand-Prince: 1e-7 mm apart.
            assert!(
                w < 1e-10,
                "{v}, model {model:?}: ME and CS differ by {:.3e} mm at most",
                w * 1e3
            );
        }
    }
}

#[test]
fn the_formation_mode_is_a_state_that_model_exchange_integrates() {
    let dir = tempfile::tempdir().unwrap();
    let lag = formation_lag_model(dir.path());
    let me = H3::instantiate("plant-me", None, Kind::ModelExchange).unwrap();
    assert_eq!(me.set_string(vr::MODEL_FILE, &lag), Status::Ok);
    assert_eq!(me.init(0.0), Status::Ok);
    assert_eq!(Drive::to_continuous(&me), 0);
    assert_eq!(me.n_states(), (Status::Ok, NX));
    // After an input step the slow mode is pulled toward the new map: its rate's derivative
    // is not zero, and r1 observes the blend of both states.
    assert_eq!(me.set_real(vr::Z_M, 0.014), Status::Ok);
    let (_, x) = me.get_states(NX);
    let (_, dx) = me.get_derivatives(NX);
    assert!(dx[3].abs() > 1e-6, "d(form_v1)/dt = {}", dx[3]);
    assert_eq!(dx[2], x[3], "d(form_x1)/dt is form_v1");
    let mut moved = x.clone();
    moved[2] += 1e-4;
    assert_eq!(me.set_states(&moved), Status::Ok);
    let r1_moved = me.get_real(vr::R1).1;
    assert_eq!(me.set_states(&x), Status::Ok);
    let r1 = me.get_real(vr::R1).1;
    assert!(
        ((r1_moved - r1) / 1e-4 - 0.35).abs() < 1e-9,
        "r1 observes form_x1 with the share 0.35: {}",
        (r1_moved - r1) / 1e-4
    );
}

fn me() -> H {
    H::instantiate_as("plant-me", None, FMI2_MODEL_EXCHANGE).expect("instantiates as ME")
}

fn to_continuous(h: &H) {
    assert_eq!(h.init(0.0), OK, "{:?}", h.log().entries());
    assert_eq!(h.mode(), Mode::EventMode);
    assert_eq!(Drive::to_continuous(h), 0);
    assert_eq!(h.mode(), Mode::ContinuousTimeMode);
}

const X0: [f64; NX] = [0.008, 0.0125, 0.008, 0.0, 0.0125, 0.0];

#[test]
fn non_finite_or_wrongly_sized_states_are_refused_naming_the_problem() {
    let h = me();
    to_continuous(&h);
    let mut bad = X0;
    bad[0] = f64::NAN;
    assert_eq!(h.set_states(&bad), Error);
    assert!(h.log().has(Error, "\"r1_ode\""), "{:?}", h.log().entries());
    assert_eq!(h.mode(), Mode::Error);

    let h = me();
    to_continuous(&h);
    assert_eq!(h.set_states(&[0.01, 0.01, 0.01]), Error);
    assert!(h.log().has(Error, "3 elements"), "{:?}", h.log().entries());

    let h = me();
    to_continuous(&h);
    assert_eq!(h.get_derivatives(2).0, Error);
    assert!(h.log().has(Error, "6 continuous states"));

    let h = me();
    to_continuous(&h);
    let mut negative = X0;
    negative[0] = -0.01;
    assert_eq!(h.set_states(&negative), Error);
    assert!(h.log().has(Error, "positive radii"));

    let h = me();
    to_continuous(&h);
    assert_eq!(h.set_time(f64::INFINITY), Error);
    assert!(h.log().has(Error, "time must be finite"));

    // The same in FMI 3.0, naming the state.
    let h3 = H3::instantiate("plant-me", None, Kind::ModelExchange).unwrap();
    assert_eq!(h3.init(0.0), Status::Ok);
    assert_eq!(Drive::to_continuous(&h3), 0);
    let mut bad = X0;
    bad[3] = f64::INFINITY;
    assert_eq!(h3.set_states(&bad), Status::Error);
    assert!(
        h3.log().has(Status::Error, "\"form_v1\""),
        "{:?}",
        h3.log().entries()
    );
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
    assert_eq!(cs.get_derivatives(NX).0, Error);
    assert!(cs.log().has(Error, "fmi2CoSimulation"));

    // FMI 3.0: the same two refusals.
    let me3 = H3::instantiate("plant-me", None, Kind::ModelExchange).unwrap();
    assert_eq!(me3.init(0.0), Status::Ok);
    assert_eq!(me3.step(0.0, 0.1).0, Status::Error);
    let cs3 = H3::instantiate("plant-cs", None, Kind::CoSimulation).unwrap();
    assert_eq!(cs3.init(0.0), Status::Ok);
    assert_eq!(cs3.get_derivatives(NX).0, Status::Error);
    assert!(cs3.log().has(Status::Error, "belongs to Model Exchange"));

    // Out of sequence: states can only be set in continuous-time mode.
    let h = me();
    assert_eq!(h.init(0.0), OK);
    assert_eq!(h.set_states(&X0), Error);
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
    assert_eq!(h.set_states(&X0), OK);
    let (s, st) = h.get_state();
    assert_eq!(s, OK);
    let mut other = X0;
    other[1] = 0.013;
    other[5] = 0.001;
    assert_eq!(h.set_states(&other), OK);
    // SAFETY: a state this instance handed out and did not free.
    assert_eq!(unsafe { h.set_state(st) }, OK);
    assert_eq!(h.get_states(NX).1, X0.to_vec());
    assert_eq!(h.reset(), OK);
    assert_eq!(h.mode(), Mode::Instantiated);
    to_continuous(&h);
    let (s, nominal) = h.get_nominals(NX);
    assert_eq!(s, OK);
    assert_eq!(nominal, vec![0.01, 0.01, 0.01, 1.0, 0.01, 1.0]);
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
fn directional_and_adjoint_derivatives_of_the_state_derivatives_match_finite_differences() {
    let dir = tempfile::tempdir().unwrap();
    let lag = formation_lag_model(dir.path());
    let h = H3::instantiate("plant-me", None, Kind::ModelExchange).unwrap();
    assert_eq!(h.set_string(vr::MODEL_FILE, &lag), Status::Ok);
    assert_eq!(h.init(0.0), Status::Ok);
    assert_eq!(Drive::to_continuous(&h), 0);
    let x = [0.008, 0.0125, 0.0079, 0.002, 0.0127, -0.001];
    let f0 = rhs(&h, 0.0, &x);
    let unknowns = [
        vr::DER_R1,
        vr::DER_R2,
        vr::DER_FORM_X1,
        vr::DER_FORM_V1,
        vr::DER_FORM_X2,
        vr::DER_FORM_V2,
    ];
    let eps = 1e-8;
    let mut jac = [[0.0; NX]; NX];
    for (j, &known) in vr::STATES.iter().enumerate() {
        let mut xp = x;
        xp[j] += eps;
        let fp = rhs(&h, 0.0, &xp);
        assert_eq!(h.set_states(&x), Status::Ok);
        let (s, out) = h.derivative(&unknowns, &[known], &[1.0], false);
        assert_eq!(s, Status::Ok, "{:?}", h.log().entries());
        for i in 0..NX {
            let fd = (fp[i] - f0[i]) / eps;
            assert!(
                (out[i] - fd).abs() <= 1e-4 * fd.abs().max(1.0),
                "d(vr {})/d(vr {known}): analytic {} vs finite difference {fd}",
                unknowns[i],
                out[i]
            );
            jac[i][j] = out[i];
        }
    }
    // The adjoint is the transposed product: seed e_i gives row i of the Jacobian.
    for (i, &u) in unknowns.iter().enumerate() {
        let (s, row) = h.derivative(&[u], &vr::STATES, &[1.0], true);
        assert_eq!(s, Status::Ok);
        assert_eq!(row, jac[i].to_vec(), "adjoint row of vr {u}");
    }
}
