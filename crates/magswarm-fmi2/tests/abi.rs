//! The exported C ABI, driven through raw pointers exactly as an importer would: the
//! `export_fmi2!` symbols of the toy model, a C-style logger that records messages, and
//! the standard's calling sequences (and deliberate violations of them).

mod toy;

use std::ffi::{c_char, c_int, c_void, CStr, CString};
use std::ptr::{null, null_mut};
use std::sync::Mutex;

use magswarm_fmi2::abi::*;
use magswarm_fmi2::Fmi2Status;
use toy::*;

magswarm_fmi2::export_fmi2!(toy::Lag);

use Fmi2Status::{Discard, Error, Ok as OK, Warning};

#[derive(Debug, Clone)]
struct Entry {
    instance: String,
    status: c_int,
    category: String,
    message: String,
}

/// What the importer's logger received. Each test owns one (passed as componentEnvironment),
/// so tests running in parallel do not see each other's messages.
#[derive(Default)]
struct Log(Mutex<Vec<Entry>>);

impl Log {
    fn entries(&self) -> Vec<Entry> {
        self.0.lock().unwrap().clone()
    }
    fn clear(&self) {
        self.0.lock().unwrap().clear()
    }
    /// Messages with status >= Error.
    fn errors(&self) -> Vec<String> {
        self.entries()
            .into_iter()
            .filter(|e| e.status >= Error as c_int)
            .map(|e| e.message)
            .collect()
    }
    fn has(&self, status: Fmi2Status, category: &str, needle: &str) -> bool {
        self.entries().iter().any(|e| {
            e.status == status as c_int && e.category == category && e.message.contains(needle)
        })
    }
}

/// A logger with the fixed part of the C signature; the shell calls it through the variadic
/// `fmi2CallbackLogger` type without extra arguments, which is ABI-compatible.
unsafe extern "C" fn test_logger(
    env: *mut c_void,
    instance: *const c_char,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    let log = &*(env as *const Log);
    let s = |p: *const c_char| {
        if p.is_null() {
            "<null>".to_string()
        } else {
            CStr::from_ptr(p).to_string_lossy().into_owned()
        }
    };
    log.0.lock().unwrap().push(Entry {
        instance: s(instance),
        status,
        category: s(category),
        message: s(message),
    });
}

fn callbacks(log: &Log) -> Fmi2CallbackFunctions {
    type Fixed =
        unsafe extern "C" fn(*mut c_void, *const c_char, c_int, *const c_char, *const c_char);
    let logger: Fixed = test_logger;
    Fmi2CallbackFunctions {
        // SAFETY: see `test_logger`.
        logger: Some(unsafe { std::mem::transmute::<Fixed, Fmi2CallbackLogger>(logger) }),
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: log as *const Log as *mut c_void,
    }
}

fn cs(s: &str) -> CString {
    CString::new(s).unwrap()
}

struct Fmu {
    c: Fmi2Component,
    // Kept alive for the instance's lifetime (the importer owns them).
    _cb: Box<Fmi2CallbackFunctions>,
}

impl Drop for Fmu {
    fn drop(&mut self) {
        unsafe { fmi2FreeInstance(self.c) }
    }
}

fn instantiate_named(log: &Log, name: &str, logging_on: bool) -> Option<Fmu> {
    let cb = Box::new(callbacks(log));
    let guid = cs(&magswarm_fmi2::guid::<Lag>());
    let name = cs(name);
    // An existing folder (a missing one is a warning), with a percent-escaped space and a
    // trailing slash.
    let dir = std::env::temp_dir().join("magswarm fmi2 abi/resources");
    std::fs::create_dir_all(&dir).unwrap();
    let res = cs(&format!(
        "file://{}/",
        dir.display().to_string().replace(' ', "%20")
    ));
    let c = unsafe {
        fmi2Instantiate(
            name.as_ptr(),
            FMI2_CO_SIMULATION,
            guid.as_ptr(),
            res.as_ptr(),
            &*cb,
            FMI2_FALSE,
            logging_on as c_int,
        )
    };
    (!c.is_null()).then_some(Fmu { c, _cb: cb })
}

fn instantiate(log: &Log) -> Fmu {
    instantiate_named(log, "lag1", false).expect("instantiation works")
}

impl Fmu {
    fn init(&self, start: f64) {
        unsafe {
            assert_eq!(
                fmi2SetupExperiment(self.c, FMI2_FALSE, 0.0, start, FMI2_FALSE, 0.0),
                OK
            );
            assert_eq!(fmi2EnterInitializationMode(self.c), OK);
            assert_eq!(fmi2ExitInitializationMode(self.c), OK);
        }
    }
    fn set_real(&self, vr: u32, x: f64) -> Fmi2Status {
        unsafe { fmi2SetReal(self.c, &vr, 1, &x) }
    }
    fn get_real(&self, vr: u32) -> (Fmi2Status, f64) {
        let mut x = f64::NAN;
        let s = unsafe { fmi2GetReal(self.c, &vr, 1, &mut x) };
        (s, x)
    }
    fn real(&self, vr: u32) -> f64 {
        let (s, x) = self.get_real(vr);
        assert_eq!(s, OK);
        x
    }
    fn step(&self, t: f64, h: f64) -> Fmi2Status {
        unsafe { fmi2DoStep(self.c, t, h, FMI2_TRUE) }
    }
    fn time(&self) -> f64 {
        let mut t = f64::NAN;
        assert_eq!(
            unsafe { fmi2GetRealStatus(self.c, FMI2_LAST_SUCCESSFUL_TIME, &mut t) },
            OK
        );
        t
    }
    /// Step n times from the current time, recording (y bits, der_y bits, n_steps).
    fn run(&self, n: usize, h: f64, u: impl Fn(usize) -> f64) -> Vec<(u64, u64, i32)> {
        let mut out = Vec::new();
        for i in 0..n {
            assert!(self.set_real(U, u(i)) <= Warning);
            let t = self.time();
            assert_eq!(self.step(t, h), OK);
            let mut n_steps = 0;
            assert_eq!(
                unsafe { fmi2GetInteger(self.c, &N_STEPS, 1, &mut n_steps) },
                OK
            );
            out.push((self.real(Y).to_bits(), self.real(DER_Y).to_bits(), n_steps));
        }
        out
    }
}

#[test]
fn platform_and_version() {
    unsafe {
        assert_eq!(
            CStr::from_ptr(fmi2GetTypesPlatform()).to_str().unwrap(),
            "default"
        );
        assert_eq!(CStr::from_ptr(fmi2GetVersion()).to_str().unwrap(), "2.0");
    }
}

#[test]
fn step_response_matches_the_exact_solution() {
    let log = Log::default();
    let f = instantiate(&log);
    unsafe {
        assert_eq!(
            fmi2SetupExperiment(f.c, FMI2_TRUE, 1e-6, 1.0, FMI2_TRUE, 10.0),
            OK
        );
        assert_eq!(fmi2EnterInitializationMode(f.c), OK);
        assert_eq!(f.set_real(Y0, 0.25), OK);
        assert_eq!(f.set_real(TAU, 2.0), OK);
        assert_eq!(fmi2ExitInitializationMode(f.c), OK);
    }
    assert_eq!(f.real(Y), 0.25);
    assert_eq!(f.set_real(U, 1.0), OK);
    let mut t = 1.0;
    for _ in 0..100 {
        assert_eq!(f.step(t, 0.05), OK);
        t += 0.05;
    }
    let y = f.real(Y);
    let exact = 1.0 + (0.25 - 1.0) * (-5.0f64 / 2.0).exp();
    assert!((y - exact).abs() < 1e-12, "{y} vs {exact}");
    assert!((f.time() - 6.0).abs() < 1e-12);
    // Variable step size.
    assert_eq!(f.step(f.time(), 0.001), OK);
    assert_eq!(f.step(f.time(), 0.5), OK);
    // Tunable parameter may change while stepping; fixed may not.
    assert_eq!(f.set_real(K, 2.0), OK);
    assert_eq!(f.set_real(TAU, 1.0), Error);
    assert!(
        log.has(Error, "logStatusError", "\"tau\""),
        "{:?}",
        log.entries()
    );
    assert!(log.entries().iter().all(|e| e.instance == "lag1"));
}

#[test]
fn illegal_call_sequences_return_error_and_log() {
    let log = Log::default();
    let f = instantiate(&log);
    unsafe {
        // doStep before initialization.
        assert_eq!(f.step(0.0, 0.1), Error);
        let e = log.errors();
        assert!(
            e.iter().any(|m| m.contains("fmi2DoStep")
                && m.contains("illegal call sequence")
                && m.contains("Instantiated")),
            "{e:?}"
        );
        assert!(log.has(Error, "logStatusError", "fmi2DoStep"));
        // After fmi2Error the instance is in the error state: getters allowed, setters not.
        assert_eq!(f.get_real(Y).0, OK);
        assert_eq!(f.set_real(U, 1.0), Error);
        assert_eq!(fmi2EnterInitializationMode(f.c), Error);
        // Reset recovers.
        assert_eq!(fmi2Reset(f.c), OK);
        log.clear();
        // Getters are not allowed before initialization mode.
        assert_eq!(f.get_real(Y).0, Error);
        assert!(log.errors()[0].contains("fmi2GetReal"));
        assert_eq!(fmi2Reset(f.c), OK);
        // Outputs can never be set.
        assert_eq!(f.set_real(Y, 1.0), Error);
        assert!(
            log.errors()
                .iter()
                .any(|m| m.contains("\"y\"") && m.contains("output")),
            "{:?}",
            log.errors()
        );
        assert_eq!(fmi2Reset(f.c), OK);
        // ExitInitializationMode without Enter, Terminate before init.
        assert_eq!(fmi2ExitInitializationMode(f.c), Error);
        assert_eq!(fmi2Reset(f.c), OK);
        assert_eq!(fmi2Terminate(f.c), Error);
        assert_eq!(fmi2Reset(f.c), OK);
        // Status functions are for after initialization.
        let mut t = 0.0;
        assert_eq!(
            fmi2GetRealStatus(f.c, FMI2_LAST_SUCCESSFUL_TIME, &mut t),
            Error
        );
        assert_eq!(fmi2Reset(f.c), OK);
        // Proper run, then terminate, then stepping is illegal.
        f.init(0.0);
        assert_eq!(f.step(0.0, 0.1), OK);
        assert_eq!(fmi2Terminate(f.c), OK);
        assert_eq!(f.get_real(Y).0, OK, "getters allowed after terminate");
        assert_eq!(f.step(0.1, 0.1), Error);
        assert_eq!(fmi2Reset(f.c), OK);
        // CancelStep: nothing is ever pending.
        f.init(0.0);
        assert_eq!(fmi2CancelStep(f.c), Error);
        assert!(log
            .errors()
            .last()
            .unwrap()
            .contains("never returns fmi2Pending"));
    }
}

#[test]
fn do_step_checks_its_arguments() {
    let log = Log::default();
    let f = instantiate(&log);
    let fresh = |f: &Fmu| unsafe {
        assert_eq!(fmi2Reset(f.c), OK);
        assert_eq!(
            fmi2SetupExperiment(f.c, FMI2_FALSE, 0.0, 0.0, FMI2_TRUE, 1.0),
            OK
        );
        assert_eq!(fmi2EnterInitializationMode(f.c), OK);
        assert_eq!(fmi2ExitInitializationMode(f.c), OK);
    };
    for (t, h, needle) in [
        (0.0, 0.0, "communicationStepSize"),
        (0.0, -0.1, "communicationStepSize"),
        (0.0, f64::NAN, "communicationStepSize"),
        (0.0, f64::INFINITY, "communicationStepSize"),
        (0.5, 0.1, "currentCommunicationPoint"),
        (f64::NAN, 0.1, "currentCommunicationPoint"),
        (0.0, 2.0, "stopTime"),
    ] {
        fresh(&f);
        log.clear();
        assert_eq!(f.step(t, h), Error, "t={t} h={h}");
        assert!(
            log.errors().iter().any(|m| m.contains(needle)),
            "{needle}: {:?}",
            log.errors()
        );
    }
    // Rounding differences in the communication point are tolerated.
    fresh(&f);
    let mut t = 0.0;
    for i in 0..10 {
        assert_eq!(f.step(t, 0.1), OK);
        t = (i + 1) as f64 * 0.1 + 1e-15;
    }
}

#[test]
fn null_pointers_do_not_crash() {
    let log = Log::default();
    unsafe {
        // NULL instance everywhere: fmi2Error, no crash, nothing to log through.
        let n = null_mut();
        let vr = [U];
        let mut x = [0.0];
        assert_eq!(fmi2DoStep(n, 0.0, 0.1, 0), Error);
        assert_eq!(fmi2GetReal(n, vr.as_ptr(), 1, x.as_mut_ptr()), Error);
        assert_eq!(fmi2SetReal(n, vr.as_ptr(), 1, x.as_ptr()), Error);
        assert_eq!(fmi2SetupExperiment(n, 0, 0.0, 0.0, 0, 0.0), Error);
        assert_eq!(fmi2EnterInitializationMode(n), Error);
        assert_eq!(fmi2ExitInitializationMode(n), Error);
        assert_eq!(fmi2Terminate(n), Error);
        assert_eq!(fmi2Reset(n), Error);
        assert_eq!(fmi2SetDebugLogging(n, 1, 0, null()), Error);
        assert_eq!(fmi2GetFMUstate(n, null_mut()), Error);
        assert_eq!(fmi2CancelStep(n), Error);
        fmi2FreeInstance(n);

        // Instantiate with NULL arguments.
        let cb = callbacks(&log);
        let guid = cs(&magswarm_fmi2::guid::<Lag>());
        let name = cs("x");
        assert!(fmi2Instantiate(name.as_ptr(), 1, guid.as_ptr(), null(), null(), 0, 0).is_null());
        assert!(fmi2Instantiate(null(), 1, guid.as_ptr(), null(), &cb, 0, 0).is_null());
        assert!(
            log.errors().iter().any(|m| m.contains("instanceName")),
            "{:?}",
            log.errors()
        );
        assert!(fmi2Instantiate(name.as_ptr(), 1, null(), null(), &cb, 0, 0).is_null());
        assert!(log.errors().iter().any(|m| m.contains("fmuGUID")));
        // A NULL logger is tolerated (nothing can be logged, but the FMU works).
        let quiet = Fmi2CallbackFunctions { logger: None, ..cb };
        let c = fmi2Instantiate(name.as_ptr(), 1, guid.as_ptr(), null(), &quiet, 0, 0);
        assert!(!c.is_null());
        assert_eq!(fmi2DoStep(c, 0.0, 0.1, 0), Error);
        fmi2FreeInstance(c);

        // NULL arrays with non-zero counts; zero counts are fine with NULL.
        let f = instantiate(&log);
        f.init(0.0);
        assert_eq!(fmi2GetReal(f.c, null(), 0, null_mut()), OK);
        assert_eq!(fmi2SetReal(f.c, null(), 0, null()), OK);
        log.clear();
        assert_eq!(fmi2GetReal(f.c, null(), 1, x.as_mut_ptr()), Error);
        assert!(
            log.errors()[0].contains("vr must not be NULL"),
            "{:?}",
            log.errors()
        );
        let f = instantiate(&log);
        f.init(0.0);
        assert_eq!(fmi2GetReal(f.c, vr.as_ptr(), 1, null_mut()), Error);
        for call in 0..12 {
            let f = instantiate(&log);
            f.init(0.0);
            let s = match call {
                0 => fmi2SetReal(f.c, vr.as_ptr(), 1, null()),
                1 => fmi2SetString(f.c, &LABEL, 1, null()),
                2 => {
                    let p: [Fmi2String; 1] = [null()];
                    fmi2SetString(f.c, &LABEL, 1, p.as_ptr())
                }
                3 => fmi2GetString(f.c, &LABEL, 1, null_mut()),
                4 => fmi2GetFMUstate(f.c, null_mut()),
                5 => fmi2SetFMUstate(f.c, null_mut()),
                6 => fmi2FreeFMUstate(f.c, null_mut()),
                7 => fmi2SerializedFMUstateSize(f.c, null_mut(), null_mut()),
                8 => fmi2DeSerializeFMUstate(f.c, null(), 10, null_mut()),
                9 => fmi2GetDirectionalDerivative(f.c, &DER_Y, 1, &U, 1, null(), x.as_mut_ptr()),
                10 => fmi2GetRealStatus(f.c, FMI2_LAST_SUCCESSFUL_TIME, null_mut()),
                _ => fmi2SetDebugLogging(f.c, 1, 2, null()),
            };
            assert_eq!(s, Error, "call {call}");
        }
        // Freeing a NULL FMU state is a no-op.
        let f = instantiate(&log);
        let mut st: Fmi2FmuState = null_mut();
        assert_eq!(fmi2FreeFMUstate(f.c, &mut st), OK);
    }
}

#[test]
fn guid_and_fmu_type_are_checked() {
    let log = Log::default();
    let cb = callbacks(&log);
    let name = cs("x");
    unsafe {
        let wrong = cs("{00000000-0000-0000-0000-000000000000}");
        assert!(fmi2Instantiate(name.as_ptr(), 1, wrong.as_ptr(), null(), &cb, 0, 0).is_null());
        assert!(
            log.has(Error, "logStatusError", "GUID mismatch"),
            "{:?}",
            log.entries()
        );
        let guid = cs(&magswarm_fmi2::guid::<Lag>());
        assert!(fmi2Instantiate(
            name.as_ptr(),
            FMI2_MODEL_EXCHANGE,
            guid.as_ptr(),
            null(),
            &cb,
            0,
            0
        )
        .is_null());
        assert!(
            log.errors()
                .iter()
                .any(|m| m.contains("Co-Simulation only")),
            "{:?}",
            log.errors()
        );
        assert!(fmi2Instantiate(name.as_ptr(), 7, guid.as_ptr(), null(), &cb, 0, 0).is_null());
        let c = fmi2Instantiate(name.as_ptr(), 1, guid.as_ptr(), null(), &cb, 0, 0);
        assert!(!c.is_null());
        fmi2FreeInstance(c);
    }
    // A constructor error is reported and gives NULL.
    assert!(instantiate_named(&log, "fail-in-constructor", false).is_none());
    assert!(log
        .errors()
        .iter()
        .any(|m| m.contains("constructor asked to fail")));
}

#[test]
fn non_finite_inputs_are_rejected_naming_the_variable() {
    let log = Log::default();
    let f = instantiate(&log);
    f.init(0.0);
    assert_eq!(f.set_real(U, 0.5), OK);
    assert_eq!(f.step(0.0, 0.1), OK);
    let y = f.real(Y);
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        log.clear();
        assert_eq!(f.set_real(U, bad), Error);
        let e = log.errors();
        assert!(
            e.iter()
                .any(|m| m.contains("\"u\"") && m.contains("not finite")),
            "{e:?}"
        );
        // The value was not applied: outputs stay finite and unchanged.
        assert_eq!(f.real(U), 0.5);
        assert_eq!(f.real(Y), y);
        assert!(f.real(DER_Y).is_finite());
        unsafe { assert_eq!(fmi2SetFMUstate(f.c, null_mut()), Error) };
        unsafe { assert_eq!(fmi2Reset(f.c), OK) };
        f.init(0.0);
        assert_eq!(f.set_real(U, 0.5), OK);
        assert_eq!(f.step(0.0, 0.1), OK);
    }
    // Parameters too; and a batch with one bad value changes nothing.
    unsafe {
        assert_eq!(fmi2Reset(f.c), OK);
        let vrs = [TAU, Y0];
        let vals = [3.0, f64::NAN];
        assert_eq!(fmi2SetReal(f.c, vrs.as_ptr(), 2, vals.as_ptr()), Error);
        assert!(log.errors().iter().any(|m| m.contains("\"y0\"")));
        assert_eq!(fmi2Reset(f.c), OK);
        assert_eq!(fmi2EnterInitializationMode(f.c), OK);
        assert_eq!(f.real(TAU), 0.5, "nothing of the bad batch was applied");
        // Model-level validation errors name the variable too.
        assert_eq!(f.set_real(TAU, -1.0), Error);
        assert!(log
            .errors()
            .iter()
            .any(|m| m.contains("\"tau\"") && m.contains("tau must be > 0")));
    }
}

#[test]
fn envelope_warning_once_per_excursion() {
    let log = Log::default();
    let f = instantiate(&log);
    f.init(0.0);
    assert_eq!(f.set_real(U, 7.0), Warning);
    assert!(
        log.has(
            Warning,
            "logStatusWarning",
            "u = 7 is outside the validated envelope"
        ),
        "{:?}",
        log.entries()
    );
    assert_eq!(f.set_real(U, 8.0), OK, "still the same excursion");
    assert_eq!(
        f.step(0.0, 0.1),
        OK,
        "a warning does not stop the simulation"
    );
    assert_eq!(f.set_real(U, 1.0), OK);
    assert_eq!(f.set_real(U, -6.0), Warning);
    let warnings = log
        .entries()
        .iter()
        .filter(|e| e.status == Warning as c_int)
        .count();
    assert_eq!(warnings, 2);
}

#[test]
fn strings_are_kept_alive_and_settable() {
    let log = Log::default();
    let f = instantiate(&log);
    unsafe {
        let v = cs("new label %d %s");
        let p = [v.as_ptr()];
        assert_eq!(fmi2SetString(f.c, &LABEL, 1, p.as_ptr()), OK);
        assert_eq!(fmi2EnterInitializationMode(f.c), OK);
        let mut out: [Fmi2String; 2] = [null(); 2];
        let vrs = [LABEL, LABEL];
        assert_eq!(fmi2GetString(f.c, vrs.as_ptr(), 2, out.as_mut_ptr()), OK);
        // Other calls in between do not invalidate the strings.
        assert_eq!(f.get_real(U).0, OK);
        assert_eq!(fmi2ExitInitializationMode(f.c), OK);
        assert_eq!(f.step(0.0, 0.1), OK);
        assert_eq!(CStr::from_ptr(out[0]).to_str().unwrap(), "new label %d %s");
        assert_eq!(CStr::from_ptr(out[1]).to_str().unwrap(), "new label %d %s");
        // Fixed String parameter cannot be set after initialization.
        assert_eq!(fmi2SetString(f.c, &LABEL, 1, p.as_ptr()), Error);
        assert!(log.errors().iter().any(|m| m.contains("\"label\"")));
        // Type mismatch: a Real reference through fmi2GetString.
        assert_eq!(fmi2Reset(f.c), OK);
        f.init(0.0);
        assert_eq!(fmi2GetString(f.c, &U, 1, out.as_mut_ptr()), Error);
        assert!(log.errors().last().unwrap().contains("not String"));
        // Unknown value reference.
        assert_eq!(fmi2Reset(f.c), OK);
        f.init(0.0);
        assert_eq!(f.get_real(999).0, Error);
        assert!(log
            .errors()
            .last()
            .unwrap()
            .contains("unknown value reference 999"));
        // Percent signs in messages are doubled for printf-style loggers.
        let cat = cs("50%_off_%s");
        assert_eq!(fmi2SetDebugLogging(f.c, 1, 1, &cat.as_ptr()), Warning);
        assert!(
            log.has(Warning, "logStatusWarning", "50%%_off_%%s"),
            "{:?}",
            log.entries()
        );
    }
}

#[test]
fn booleans_and_integers() {
    let log = Log::default();
    let f = instantiate(&log);
    f.init(0.0);
    unsafe {
        let mut b: [Fmi2Boolean; 2] = [7, 7];
        let vrs = [SATURATED, PANIC_NOW];
        assert_eq!(fmi2GetBoolean(f.c, vrs.as_ptr(), 2, b.as_mut_ptr()), OK);
        assert_eq!(b, [0, 0]);
        assert_eq!(f.set_real(U, 20.0), Warning);
        assert_eq!(f.step(0.0, 100.0), OK);
        assert_eq!(fmi2GetBoolean(f.c, vrs.as_ptr(), 2, b.as_mut_ptr()), OK);
        assert_eq!(b, [1, 0]);
        let mut n = 0;
        assert_eq!(fmi2GetInteger(f.c, &N_STEPS, 1, &mut n), OK);
        assert_eq!(n, 1);
        assert_eq!(
            fmi2SetInteger(f.c, &N_STEPS, 1, &5),
            Error,
            "outputs cannot be set"
        );
    }
}

#[test]
fn fmu_state_get_set_replays_bit_identically() {
    let log = Log::default();
    let f = instantiate(&log);
    f.init(0.0);
    let u = |i: usize| (i as f64 * 0.37).sin() * 3.0;
    f.run(10, 0.01, u);
    unsafe {
        let mut s: Fmi2FmuState = null_mut();
        assert_eq!(fmi2GetFMUstate(f.c, &mut s), OK);
        assert!(!s.is_null());
        let a = f.run(25, 0.013, |i| u(i + 10));
        assert_eq!(fmi2SetFMUstate(f.c, s), OK);
        let b = f.run(25, 0.013, |i| u(i + 10));
        assert_eq!(a, b);
        // Re-using the state handle: the standard lets fmi2GetFMUstate overwrite it.
        let s_before = s;
        assert_eq!(fmi2GetFMUstate(f.c, &mut s), OK);
        assert_eq!(s, s_before);
        let c1 = f.run(5, 0.01, u);
        assert_eq!(fmi2SetFMUstate(f.c, s), OK);
        assert_eq!(f.run(5, 0.01, u), c1);
        assert_eq!(fmi2FreeFMUstate(f.c, &mut s), OK);
        assert!(s.is_null());

        // A state restores the state machine too: taken during initialization mode, it
        // puts a stepping instance back into initialization mode.
        let g = instantiate(&log);
        assert_eq!(fmi2EnterInitializationMode(g.c), OK);
        let mut s0: Fmi2FmuState = null_mut();
        assert_eq!(fmi2GetFMUstate(g.c, &mut s0), OK);
        assert_eq!(fmi2ExitInitializationMode(g.c), OK);
        assert_eq!(g.step(0.0, 0.1), OK);
        assert_eq!(fmi2SetFMUstate(g.c, s0), OK);
        assert_eq!(g.step(0.0, 0.1), Error);
        assert_eq!(
            fmi2SetFMUstate(g.c, s0),
            OK,
            "fmi2SetFMUstate recovers from the error state"
        );
        assert_eq!(fmi2ExitInitializationMode(g.c), OK);
        assert_eq!(fmi2FreeFMUstate(g.c, &mut s0), OK);

        // A component is not an FMU state.
        assert_eq!(fmi2SetFMUstate(f.c, g.c), Error);
    }
}

#[test]
fn serialized_state_replays_bit_identically_in_another_instance() {
    let log = Log::default();
    let f = instantiate(&log);
    f.init(0.0);
    let u = |i: usize| ((i * i) as f64 * 0.01).cos() * 2.0;
    f.run(17, 0.02, u);
    unsafe {
        // Tunable and String parameters are part of the state.
        assert_eq!(f.set_real(K, 1.5), OK);
        let mut s: Fmi2FmuState = null_mut();
        assert_eq!(fmi2GetFMUstate(f.c, &mut s), OK);
        let mut size = 0usize;
        assert_eq!(fmi2SerializedFMUstateSize(f.c, s, &mut size), OK);
        let mut bytes = vec![0u8; size];
        assert_eq!(
            fmi2SerializeFMUstate(f.c, s, bytes.as_mut_ptr() as *mut Fmi2Byte, size),
            OK
        );
        let expected = f.run(30, 0.02, |i| u(i + 17));

        // Fresh instance (only instantiated), deserialize, set, replay.
        let g = instantiate_named(&log, "lag2", false).unwrap();
        let mut s2: Fmi2FmuState = 0x1 as Fmi2FmuState; // garbage in: must not be read
        assert_eq!(
            fmi2DeSerializeFMUstate(g.c, bytes.as_ptr() as *const Fmi2Byte, size, &mut s2),
            OK
        );
        assert_eq!(fmi2SetFMUstate(g.c, s2), OK);
        assert_eq!(g.real(K), 1.5);
        assert_eq!(g.run(30, 0.02, |i| u(i + 17)), expected);
        // Serializing the deserialized state gives the same bytes.
        let mut size2 = 0;
        assert_eq!(fmi2SerializedFMUstateSize(g.c, s2, &mut size2), OK);
        let mut bytes2 = vec![0u8; size2];
        assert_eq!(
            fmi2SerializeFMUstate(g.c, s2, bytes2.as_mut_ptr() as *mut Fmi2Byte, size2),
            OK
        );
        assert_eq!(bytes, bytes2);
        assert_eq!(fmi2FreeFMUstate(g.c, &mut s2), OK);
        // A buffer size other than fmi2SerializedFMUstateSize is refused.
        assert_eq!(
            fmi2SerializeFMUstate(f.c, s, bytes.as_mut_ptr() as *mut Fmi2Byte, size - 1),
            Error
        );
        assert_eq!(fmi2FreeFMUstate(f.c, &mut s), OK);

        // Bad bytes: every corruption is an fmi2Error with a reason, never a crash.
        let mut cases: Vec<Vec<u8>> = vec![
            Vec::new(),
            bytes[..7].to_vec(),
            bytes[..size - 1].to_vec(),
            vec![0xAB; size],
        ];
        for i in [0, 9, 13, 30, 45, size / 2, size - 9, size - 1] {
            let mut b = bytes.clone();
            b[i] ^= 0x5A;
            cases.push(b);
        }
        let mut longer = bytes.clone();
        longer.push(0);
        cases.push(longer);
        for (k, b) in cases.iter().enumerate() {
            let h = instantiate_named(&log, "lag3", false).unwrap();
            log.clear();
            let mut s3: Fmi2FmuState = null_mut();
            let p = if b.is_empty() {
                null()
            } else {
                b.as_ptr() as *const Fmi2Byte
            };
            assert_eq!(
                fmi2DeSerializeFMUstate(h.c, p, b.len(), &mut s3),
                Error,
                "case {k}"
            );
            assert!(s3.is_null());
            assert!(!log.errors().is_empty(), "case {k} logs a reason");
        }
    }
}

#[test]
fn reset_restores_a_fresh_instance() {
    let log = Log::default();
    let f = instantiate(&log);
    unsafe {
        assert_eq!(fmi2SetDebugLogging(f.c, 1, 0, null()), OK);
        assert_eq!(fmi2EnterInitializationMode(f.c), OK);
        assert_eq!(f.set_real(Y0, 3.0), OK);
        assert_eq!(fmi2ExitInitializationMode(f.c), OK);
        let first = f.run(20, 0.05, |_| 1.0);
        assert_eq!(fmi2Reset(f.c), OK);
        // Back to Instantiated with start values; the logger and debug settings are kept.
        assert_eq!(f.step(0.0, 0.05), Error);
        assert_eq!(fmi2Reset(f.c), OK);
        assert_eq!(fmi2EnterInitializationMode(f.c), OK);
        assert_eq!(f.real(Y0), 0.0);
        assert_eq!(f.set_real(Y0, 3.0), OK);
        assert_eq!(fmi2ExitInitializationMode(f.c), OK);
        assert_eq!(f.time(), 0.0);
        assert_eq!(f.run(20, 0.05, |_| 1.0), first);
        assert!(
            log.has(OK, "logEvents", "reset"),
            "debug logging survives reset"
        );
    }
}

#[test]
fn panics_become_errors_not_aborts() {
    let log = Log::default();
    let f = instantiate(&log);
    f.init(0.0);
    unsafe {
        assert_eq!(fmi2SetBoolean(f.c, &PANIC_NOW, 1, &FMI2_TRUE), OK);
        assert_eq!(f.step(0.0, 0.1), Error);
        assert!(
            log.errors()
                .iter()
                .any(|m| m.contains("panicked") && m.contains("do_step asked to panic")),
            "{:?}",
            log.errors()
        );
        assert_eq!(
            f.step(0.0, 0.1),
            Error,
            "the instance is in the error state"
        );
        assert_eq!(fmi2Reset(f.c), OK);
        f.init(0.0);
        assert_eq!(f.step(0.0, 0.1), OK);
        // A panic in a setter.
        assert_eq!(fmi2Reset(f.c), OK);
        let p = cs("panic");
        assert_eq!(fmi2SetString(f.c, &LABEL, 1, &p.as_ptr()), Error);
        assert!(log
            .errors()
            .iter()
            .any(|m| m.contains("set_string asked to panic")));
    }
    // A panic in the constructor: NULL and a message.
    assert!(instantiate_named(&log, "panic-in-constructor", false).is_none());
    assert!(log
        .errors()
        .iter()
        .any(|m| m.contains("constructor asked to panic")));
}

#[test]
fn thousand_instantiate_free_cycles() {
    let log = Log::default();
    for i in 0..1000 {
        let f = instantiate(&log);
        if i % 100 == 0 {
            f.init(0.0);
            assert_eq!(f.set_real(U, 1.0), OK);
            assert_eq!(f.step(0.0, 0.1), OK);
        }
    }
    assert!(log.errors().is_empty());
}

#[test]
fn instances_do_not_share_state() {
    let log = Log::default();
    let a = instantiate_named(&log, "a", false).unwrap();
    let b = instantiate_named(&log, "b", false).unwrap();
    a.init(0.0);
    b.init(0.0);
    assert_eq!(a.set_real(U, 1.0), OK);
    assert_eq!(b.set_real(U, -1.0), OK);
    assert_eq!(a.step(0.0, 1.0), OK);
    assert_eq!(b.step(0.0, 1.0), OK);
    assert!(a.real(Y) > 0.0 && b.real(Y) < 0.0);
    assert_eq!(a.real(Y), -b.real(Y));
    // An error in one leaves the other alone.
    assert_eq!(a.set_real(U, f64::NAN), Error);
    assert_eq!(b.step(1.0, 1.0), OK);
}

#[test]
fn directional_derivatives() {
    let log = Log::default();
    let f = instantiate(&log);
    f.init(0.0);
    unsafe {
        assert_eq!(f.set_real(U, 2.0), OK);
        let unknowns = [DER_Y, Y];
        let knowns = [U, Y];
        let dv = [1.0, 0.5];
        let mut out = [f64::NAN; 2];
        assert_eq!(
            fmi2GetDirectionalDerivative(
                f.c,
                unknowns.as_ptr(),
                2,
                knowns.as_ptr(),
                2,
                dv.as_ptr(),
                out.as_mut_ptr()
            ),
            OK
        );
        assert_eq!(out, [1.0 / 0.5 - 0.5 / 0.5, 0.5]);
        let nan = [f64::NAN, 0.0];
        assert_eq!(
            fmi2GetDirectionalDerivative(
                f.c,
                unknowns.as_ptr(),
                2,
                knowns.as_ptr(),
                2,
                nan.as_ptr(),
                out.as_mut_ptr()
            ),
            Error
        );
        assert_eq!(fmi2Reset(f.c), OK);
        f.init(0.0);
        assert_eq!(
            fmi2GetDirectionalDerivative(f.c, &LABEL, 1, &U, 1, dv.as_ptr(), out.as_mut_ptr()),
            Error,
            "String variables have no derivatives"
        );
    }
}

#[test]
fn unsupported_functions_and_status_queries() {
    let log = Log::default();
    let f = instantiate(&log);
    f.init(2.0);
    unsafe {
        let mut i: c_int = 0;
        let mut b: Fmi2Boolean = 1;
        let mut s: Fmi2String = null();
        let mut t = 0.0;
        assert_eq!(
            fmi2GetRealStatus(f.c, FMI2_LAST_SUCCESSFUL_TIME, &mut t),
            OK
        );
        assert_eq!(t, 2.0);
        assert_eq!(fmi2GetBooleanStatus(f.c, FMI2_TERMINATED, &mut b), OK);
        assert_eq!(b, FMI2_FALSE);
        assert_eq!(fmi2GetStatus(f.c, FMI2_DO_STEP_STATUS, &mut i), Discard);
        assert_eq!(
            fmi2GetIntegerStatus(f.c, FMI2_DO_STEP_STATUS, &mut i),
            Discard
        );
        assert_eq!(
            fmi2GetStringStatus(f.c, FMI2_PENDING_STATUS, &mut s),
            Discard
        );
        assert_eq!(
            f.step(2.0, 0.1),
            OK,
            "fmi2Discard from a status query leaves the instance usable"
        );
        assert!(log.has(Discard, "logStatusDiscard", "fmi2DoStepStatus"));
        let order = [1];
        let v = [0.0];
        let mut o = [0.0];
        assert_eq!(
            fmi2SetRealInputDerivatives(f.c, &U, 1, order.as_ptr(), v.as_ptr()),
            Error
        );
        assert!(log
            .errors()
            .last()
            .unwrap()
            .contains("canInterpolateInputs"));
        assert_eq!(fmi2Reset(f.c), OK);
        f.init(0.0);
        assert_eq!(
            fmi2GetRealOutputDerivatives(f.c, &Y, 1, order.as_ptr(), o.as_mut_ptr()),
            Error
        );
        assert_eq!(fmi2Reset(f.c), OK);
        f.init(0.0);
        assert_eq!(fmi2GetStatus(f.c, 42, &mut i), Error, "invalid status kind");
    }
}

#[test]
fn debug_logging_categories() {
    let log = Log::default();
    let f = instantiate_named(&log, "quiet", false).unwrap();
    f.init(0.0);
    assert!(
        log.entries().is_empty(),
        "no debug output when logging is off: {:?}",
        log.entries()
    );
    unsafe {
        let cats = [cs("logEvents"), cs("noSuchCategory")];
        let ptrs: Vec<Fmi2String> = cats.iter().map(|c| c.as_ptr()).collect();
        assert_eq!(fmi2SetDebugLogging(f.c, 1, 2, ptrs.as_ptr()), Warning);
        assert!(log.has(Warning, "logStatusWarning", "noSuchCategory"));
        assert_eq!(fmi2Terminate(f.c), OK);
        assert!(
            log.has(OK, "logEvents", "terminated"),
            "{:?}",
            log.entries()
        );
        // Switching the category off again.
        log.clear();
        assert_eq!(fmi2SetDebugLogging(f.c, 0, 1, ptrs.as_ptr()), OK);
        assert_eq!(fmi2Reset(f.c), OK);
        assert!(log.entries().is_empty(), "{:?}", log.entries());
    }
    // loggingOn at instantiation enables model categories too.
    let log2 = Log::default();
    let _g = instantiate_named(&log2, "loud", true).unwrap();
    assert!(
        log2.has(OK, "logLag", "magswarm fmi2 abi"),
        "{:?}",
        log2.entries()
    );
    assert!(log2.has(OK, "logEvents", "instantiated"));
}
