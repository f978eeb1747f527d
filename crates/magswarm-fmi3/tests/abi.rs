//! The exported FMI 3.0 C ABI, driven through raw pointers exactly as an importer would: the
//! `export_fmi3!` symbols of the FMI 2.0 shell's toy model (one model source for both
//! versions), a C logger that records messages, the standard's calling sequences and
//! deliberate violations of them. Every guarantee of the FMI 2.0 shell holds here: the state
//! machine is checked on every call, no panic crosses, non-finite input is refused naming
//! the variable, many instances, reset.

#[path = "../../magswarm-fmi2/tests/toy/mod.rs"]
mod toy;

use std::ffi::{c_char, c_void, CStr, CString};
use std::ptr::{null, null_mut};
use std::sync::Mutex;

use magswarm_fmi3::abi::*;
use magswarm_fmi_core::Status;
use toy::*;

magswarm_fmi3::export_fmi3!(toy::Lag);

use Status::{Error, Ok as OK, Warning};

/// What the importer's logger received (one per test, passed as instanceEnvironment).
#[derive(Default)]
struct Log(Mutex<Vec<(i32, String, String)>>);

impl Log {
    fn errors(&self) -> Vec<String> {
        let v = self.0.lock().unwrap();
        v.iter().filter(|e| e.0 >= 3).map(|e| e.2.clone()).collect()
    }
    fn has(&self, status: Status, needle: &str) -> bool {
        let v = self.0.lock().unwrap();
        v.iter()
            .any(|e| e.0 == status as i32 && e.2.contains(needle))
    }
    fn clear(&self) {
        self.0.lock().unwrap().clear()
    }
}

unsafe extern "C" fn logger(
    env: *mut c_void,
    status: Status,
    category: *const c_char,
    message: *const c_char,
) {
    let s = |p: *const c_char| CStr::from_ptr(p).to_string_lossy().into_owned();
    let log = &*(env as *const Log);
    log.0
        .lock()
        .unwrap()
        .push((status as i32, s(category), s(message)));
}

fn token() -> CString {
    let info = magswarm_fmi_core::table::with_independent_time(&toy::INFO);
    CString::new(magswarm_fmi_core::guid::guid_of(info)).unwrap()
}

/// Instantiate for Co-Simulation with `name`; NULL on failure.
fn cs_named(log: &Log, name: &str) -> Fmi3Instance {
    let n = CString::new(name).unwrap();
    let t = token();
    unsafe {
        fmi3InstantiateCoSimulation(
            n.as_ptr(),
            t.as_ptr(),
            null(),
            0,
            0,
            0,
            0,
            null(),
            0,
            log as *const Log as *mut c_void,
            Some(logger),
            None,
        )
    }
}

fn cs(log: &Log) -> Fmi3Instance {
    let c = cs_named(log, "lag");
    assert!(!c.is_null(), "{:?}", log.errors());
    c
}

unsafe fn init(c: Fmi3Instance) {
    assert_eq!(fmi3EnterInitializationMode(c, 0, 0.0, 0.0, 0, 0.0), OK);
    assert_eq!(fmi3ExitInitializationMode(c), OK);
}

unsafe fn set(c: Fmi3Instance, vr: u32, x: f64) -> Status {
    fmi3SetFloat64(c, &vr, 1, &x, 1)
}

unsafe fn get(c: Fmi3Instance, vr: u32) -> f64 {
    let mut x = f64::NAN;
    assert_eq!(fmi3GetFloat64(c, &vr, 1, &mut x, 1), OK);
    x
}

/// `fmi3DoStep` with every output argument: (status, lastSuccessfulTime).
unsafe fn step(c: Fmi3Instance, t: f64, h: f64) -> (Status, f64) {
    let (mut ev, mut term, mut early, mut last) = (9u8, 9u8, 9u8, f64::NAN);
    let s = fmi3DoStep(c, t, h, 1, &mut ev, &mut term, &mut early, &mut last);
    if s == OK {
        assert_eq!(
            (ev, term, early),
            (0, 0, 0),
            "no events, no termination, no early return"
        );
    }
    (s, last)
}

#[test]
fn version_and_a_step_response_that_matches_the_exact_solution() {
    let log = Log::default();
    unsafe {
        assert_eq!(CStr::from_ptr(fmi3GetVersion()).to_str().unwrap(), "3.0");
        let c = cs(&log);
        init(c);
        assert_eq!(set(c, U, 2.0), OK);
        let mut t = 0.0;
        for _ in 0..10 {
            let (s, last) = step(c, t, 0.1);
            assert_eq!(s, OK);
            t += 0.1;
            assert_eq!(last, t, "lastSuccessfulTime is the time reached");
        }
        let exact = 2.0 * (1.0 - (-1.0f64 / 0.5).exp());
        assert!((get(c, Y) - exact).abs() < 1e-12);
        assert_eq!(
            get(c, TIME),
            t,
            "the independent variable is the instance's time"
        );
        let mut n = 0i32;
        assert_eq!(fmi3GetInt32(c, &N_STEPS, 1, &mut n, 1), OK);
        assert_eq!(n, 10);
        fmi3FreeInstance(c);
    }
}

#[test]
fn illegal_call_sequences_are_refused_with_the_rule() {
    let log = Log::default();
    unsafe {
        let c = cs(&log);
        assert_eq!(step(c, 0.0, 0.1).0, Error);
        assert!(
            log.has(Error, "not allowed in state Instantiated"),
            "{:?}",
            log.errors()
        );
        assert!(log.has(Error, "fmi3EnterInitializationMode"));
        // Error: only getters, FMU states, reset and free; the message lists them.
        assert_eq!(fmi3Terminate(c), Error);
        assert!(log.has(Error, "allowed in state Error"));
        assert_eq!(fmi3Reset(c), OK);
        init(c);
        // Parameters that are not tunable cannot be set in Step Mode.
        assert_eq!(set(c, TAU, 1.0), Error);
        assert!(log.has(Error, "\"tau\""), "{:?}", log.errors());
        assert_eq!(fmi3Reset(c), OK);
        init(c);
        // Event mode does not exist in Co-Simulation here; Model Exchange functions neither.
        assert_eq!(fmi3EnterEventMode(c), Error);
        assert_eq!(fmi3Reset(c), OK);
        init(c);
        assert_eq!(fmi3SetTime(c, 1.0), Error);
        assert!(log.has(Error, "belongs to Model Exchange"));
        fmi3FreeInstance(c);
    }
}

#[test]
fn null_pointers_and_wrong_lengths_do_not_crash() {
    let log = Log::default();
    unsafe {
        assert_eq!(
            fmi3EnterInitializationMode(null_mut(), 0, 0.0, 0.0, 0, 0.0),
            Error
        );
        fmi3FreeInstance(null_mut());
        let c = cs(&log);
        init(c);
        assert_eq!(fmi3GetFloat64(c, null(), 1, null_mut(), 1), Error);
        assert!(log.has(Error, "valueReferences must not be NULL"));
        assert_eq!(fmi3Reset(c), OK);
        init(c);
        let mut x = [0.0; 2];
        assert_eq!(
            fmi3GetFloat64(c, [U, Y].as_ptr(), 2, x.as_mut_ptr(), 3),
            Error
        );
        assert!(log.has(Error, "nValues = 3"), "{:?}", log.errors());
        assert_eq!(fmi3Reset(c), OK);
        init(c);
        let (mut ev, mut term, mut early) = (0u8, 0u8, 0u8);
        let s = fmi3DoStep(c, 0.0, 0.1, 1, &mut ev, &mut term, &mut early, null_mut());
        assert_eq!(s, Error);
        assert!(log.has(Error, "lastSuccessfulTime"));
        assert_eq!(fmi3Reset(c), OK);
        let mut st: Fmi3FmuState = null_mut();
        assert_eq!(fmi3GetFMUState(c, &mut st), OK);
        assert_eq!(fmi3SerializedFMUStateSize(c, st, null_mut()), Error);
        assert_eq!(fmi3Reset(c), OK);
        assert_eq!(fmi3FreeFMUState(c, &mut st), OK);
        assert!(st.is_null());
        fmi3FreeInstance(c);
    }
}

#[test]
fn instantiation_checks_token_interface_and_options() {
    let log = Log::default();
    unsafe {
        let n = CString::new("x").unwrap();
        let bad = CString::new("{00000000-0000-0000-0000-000000000000}").unwrap();
        let env = &log as *const Log as *mut c_void;
        let c = fmi3InstantiateCoSimulation(
            n.as_ptr(),
            bad.as_ptr(),
            null(),
            0,
            0,
            0,
            0,
            null(),
            0,
            env,
            Some(logger),
            None,
        );
        assert!(c.is_null());
        assert!(
            log.has(Error, "instantiationToken mismatch"),
            "{:?}",
            log.errors()
        );
        let t = token();
        let c = fmi3InstantiateCoSimulation(
            n.as_ptr(),
            t.as_ptr(),
            null(),
            0,
            0,
            1,
            0,
            null(),
            0,
            env,
            Some(logger),
            None,
        );
        assert!(c.is_null());
        assert!(log.has(Error, "eventModeUsed"));
        let c = fmi3InstantiateCoSimulation(
            n.as_ptr(),
            t.as_ptr(),
            null(),
            0,
            0,
            0,
            0,
            [U].as_ptr(),
            1,
            env,
            Some(logger),
            None,
        );
        assert!(c.is_null());
        assert!(log.has(Error, "intermediate update"));
        // The toy model is Co-Simulation only.
        let c =
            fmi3InstantiateModelExchange(n.as_ptr(), t.as_ptr(), null(), 0, 0, env, Some(logger));
        assert!(c.is_null());
        assert!(log.has(Error, "Co-Simulation only"));
        let c = fmi3InstantiateScheduledExecution(
            n.as_ptr(),
            t.as_ptr(),
            null(),
            0,
            0,
            env,
            Some(logger),
            None,
            None,
            None,
        );
        assert!(c.is_null());
        assert!(log.has(Error, "not Scheduled Execution"));
        // A constructor that panics is an error, not an abort.
        assert!(cs_named(&log, "panic-in-constructor").is_null());
        assert!(log.has(Error, "panicked"));
        // No logger at all: refused quietly, never a crash.
        let c = fmi3InstantiateCoSimulation(
            n.as_ptr(),
            bad.as_ptr(),
            null(),
            0,
            0,
            0,
            0,
            null(),
            0,
            null_mut(),
            None,
            None,
        );
        assert!(c.is_null());
    }
}

#[test]
fn non_finite_values_are_refused_naming_the_variable() {
    let log = Log::default();
    unsafe {
        let c = cs(&log);
        init(c);
        for x in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            log.clear();
            assert_eq!(set(c, U, x), Error);
            assert!(log.has(Error, "\"u\""), "{:?}", log.errors());
            assert_eq!(fmi3Reset(c), OK);
            init(c);
        }
        assert_eq!(set(c, U, 1.0), OK);
        assert_eq!(get(c, U), 1.0, "the refused values left no trace");
        // The independent variable cannot be set.
        assert_eq!(set(c, TIME, 1.0), Error);
        assert!(log.has(Error, "independent"));
        fmi3FreeInstance(c);
    }
}

#[test]
fn types_without_variables_and_clocks_answer_with_the_reason() {
    let log = Log::default();
    unsafe {
        let c = cs(&log);
        init(c);
        let mut f = [0f32; 1];
        assert_eq!(
            fmi3GetFloat32(c, null(), 0, f.as_mut_ptr(), 0),
            OK,
            "an empty call is fine"
        );
        assert_eq!(fmi3GetFloat32(c, &U, 1, f.as_mut_ptr(), 1), Error);
        assert!(
            log.has(Error, "\"u\" of type Float64, not Float32"),
            "{:?}",
            log.errors()
        );
        assert_eq!(fmi3Reset(c), OK);
        init(c);
        let mut clock = [0u8; 1];
        assert_eq!(fmi3GetClock(c, &U, 1, clock.as_mut_ptr()), Error);
        assert!(log.has(Error, "no clocks"));
        assert_eq!(fmi3Reset(c), OK);
        assert_eq!(fmi3EnterConfigurationMode(c), Error);
        assert!(log.has(Error, "no structural parameters"));
        fmi3FreeInstance(c);
    }
}

#[test]
fn fmu_states_replay_bit_identically_and_foreign_bytes_are_refused() {
    let log = Log::default();
    unsafe {
        let c = cs(&log);
        init(c);
        assert_eq!(set(c, U, 1.5), OK);
        assert_eq!(step(c, 0.0, 0.3).0, OK);
        let mut st: Fmi3FmuState = null_mut();
        assert_eq!(fmi3GetFMUState(c, &mut st), OK);
        let mut size = 0usize;
        assert_eq!(fmi3SerializedFMUStateSize(c, st, &mut size), OK);
        let mut bytes = vec![0u8; size];
        assert_eq!(fmi3SerializeFMUState(c, st, bytes.as_mut_ptr(), size), OK);
        assert_eq!(step(c, 0.3, 0.4).0, OK);
        let y_later = get(c, Y);
        // Back, and forward again: the same number.
        assert_eq!(fmi3SetFMUState(c, st), OK);
        assert_eq!(step(c, 0.3, 0.4).0, OK);
        assert_eq!(get(c, Y).to_bits(), y_later.to_bits());
        // In another instance, from bytes.
        let d = cs(&log);
        let mut st2: Fmi3FmuState = null_mut();
        assert_eq!(
            fmi3DeserializeFMUState(d, bytes.as_ptr(), size, &mut st2),
            OK
        );
        assert_eq!(fmi3SetFMUState(d, st2), OK);
        assert_eq!(step(d, 0.3, 0.4).0, OK);
        assert_eq!(get(d, Y).to_bits(), y_later.to_bits());
        // A handle of the other instance is refused without being read.
        assert_eq!(fmi3SetFMUState(d, st), Error);
        assert!(log.has(Error, "not an FMU state of this instance"));
        // Corrupted bytes: the check that failed is named.
        let mut bad = bytes.clone();
        let last = bad.len() - 1;
        bad[last] ^= 1;
        assert_eq!(fmi3Reset(d), OK);
        let mut st3: Fmi3FmuState = null_mut();
        assert_eq!(
            fmi3DeserializeFMUState(d, bad.as_ptr(), bad.len(), &mut st3),
            Error
        );
        assert!(log.has(Error, "CRC-32"), "{:?}", log.errors());
        assert_eq!(fmi3FreeFMUState(c, &mut st), OK);
        fmi3FreeInstance(d);
        fmi3FreeInstance(c);
    }
}

#[test]
fn panics_become_errors_and_reset_gives_a_fresh_instance() {
    let log = Log::default();
    unsafe {
        let c = cs(&log);
        init(c);
        let t = 1u8;
        assert_eq!(fmi3SetBoolean(c, &PANIC_NOW, 1, &t, 1), OK);
        assert_eq!(step(c, 0.0, 0.1).0, Error);
        assert!(log.has(Error, "the model panicked"), "{:?}", log.errors());
        assert_eq!(fmi3Reset(c), OK);
        init(c);
        assert_eq!(get(c, Y), 0.0);
        assert_eq!(step(c, 0.0, 0.1).0, OK, "the panic switch was reset too");
        fmi3FreeInstance(c);
    }
}

#[test]
fn many_instances_on_many_threads_do_not_share_state() {
    let handles: Vec<_> = (0..8)
        .map(|k| {
            std::thread::spawn(move || {
                let log = Log::default();
                unsafe {
                    let c = cs_named(&log, &format!("lag-{k}"));
                    init(c);
                    assert_eq!(set(c, U, k as f64 * 0.5), OK);
                    for i in 0..100 {
                        assert_eq!(step(c, i as f64 * 0.01, 0.01).0, OK);
                    }
                    let y = get(c, Y);
                    fmi3FreeInstance(c);
                    y
                }
            })
        })
        .collect();
    let ys: Vec<f64> = handles.into_iter().map(|h| h.join().unwrap()).collect();
    for (k, y) in ys.iter().enumerate() {
        let exact = k as f64 * 0.5 * (1.0 - (-1.0f64 / 0.5).exp());
        assert!((y - exact).abs() < 1e-12, "instance {k}: {y} vs {exact}");
    }
}

#[test]
fn directional_and_adjoint_derivatives_are_transposes() {
    let log = Log::default();
    unsafe {
        let c = cs(&log);
        init(c);
        assert_eq!(set(c, U, 2.0), OK);
        let unknowns = [DER_Y, Y];
        let knowns = [U, Y];
        let mut jac = [[0.0; 2]; 2];
        for (j, seed) in [[1.0, 0.0], [0.0, 1.0]].iter().enumerate() {
            let mut out = [f64::NAN; 2];
            let s = fmi3GetDirectionalDerivative(
                c,
                unknowns.as_ptr(),
                2,
                knowns.as_ptr(),
                2,
                seed.as_ptr(),
                2,
                out.as_mut_ptr(),
                2,
            );
            assert_eq!(s, OK);
            jac[0][j] = out[0];
            jac[1][j] = out[1];
        }
        assert_eq!(jac, [[1.0 / 0.5, -1.0 / 0.5], [0.0, 1.0]]);
        for (i, seed) in [[1.0, 0.0], [0.0, 1.0]].iter().enumerate() {
            let mut out = [f64::NAN; 2];
            let s = fmi3GetAdjointDerivative(
                c,
                unknowns.as_ptr(),
                2,
                knowns.as_ptr(),
                2,
                seed.as_ptr(),
                2,
                out.as_mut_ptr(),
                2,
            );
            assert_eq!(s, OK);
            assert_eq!(out, jac[i], "adjoint with e_{i} is row {i}");
        }
        // A non-finite seed is refused naming the known; a wrong length too.
        let mut out = [0.0; 2];
        let nan = [f64::NAN, 0.0];
        let s = fmi3GetDirectionalDerivative(
            c,
            unknowns.as_ptr(),
            2,
            knowns.as_ptr(),
            2,
            nan.as_ptr(),
            2,
            out.as_mut_ptr(),
            2,
        );
        assert_eq!(s, Error);
        assert!(log.has(Error, "\"u\""), "{:?}", log.errors());
        assert_eq!(fmi3Reset(c), OK);
        init(c);
        let s = fmi3GetAdjointDerivative(
            c,
            unknowns.as_ptr(),
            2,
            knowns.as_ptr(),
            2,
            nan.as_ptr(),
            1,
            out.as_mut_ptr(),
            2,
        );
        assert_eq!(s, Error);
        assert!(log.has(Error, "nSeed = 1"));
        fmi3FreeInstance(c);
    }
}

#[test]
fn variable_dependencies_come_from_the_model_structure() {
    let log = Log::default();
    unsafe {
        let c = cs(&log);
        let mut n = 0usize;
        assert_eq!(fmi3GetNumberOfVariableDependencies(c, DER_Y, &mut n), OK);
        assert_eq!(n, 2);
        let (mut ed, mut ind, mut ei, mut kinds) = ([9usize; 2], [0u32; 2], [9usize; 2], [0i32; 2]);
        let s = fmi3GetVariableDependencies(
            c,
            DER_Y,
            ed.as_mut_ptr(),
            ind.as_mut_ptr(),
            ei.as_mut_ptr(),
            kinds.as_mut_ptr(),
            2,
        );
        assert_eq!(s, OK);
        assert_eq!(ind, [U, Y]);
        assert_eq!((ed, ei, kinds), ([0, 0], [0, 0], [FMI3_DEPENDENT; 2]));
        assert_eq!(fmi3GetNumberOfVariableDependencies(c, TAU, &mut n), Error);
        assert!(log.has(Error, "neither an output nor a state derivative"));
        fmi3FreeInstance(c);
    }
}

#[test]
fn envelope_warnings_and_debug_logging() {
    let log = Log::default();
    unsafe {
        let c = cs(&log);
        init(c);
        // The toy warns once when u leaves [-5, 5].
        assert_eq!(set(c, U, 7.0), Warning);
        let cats = [
            CString::new("logEvents").unwrap(),
            CString::new("bogus").unwrap(),
        ];
        let ptrs: Vec<*const c_char> = cats.iter().map(|c| c.as_ptr()).collect();
        assert_eq!(fmi3SetDebugLogging(c, 1, 2, ptrs.as_ptr()), Warning);
        assert!(log.has(Warning, "bogus"));
        fmi3FreeInstance(c);
    }
}
