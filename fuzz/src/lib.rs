//! The fuzz driver: a (buggy) importer that turns fuzz bytes into a sequence of FMI 2.0 calls
//! on one model, through the shell's C entry points ([`magswarm_fmi::fmi2::host::Host`]), and
//! checks the invariants after every call:
//! - no crash, no abort, no panic across the boundary (the process would die);
//! - no panic *inside* either: the panic barrier is the last line, never the check, so a
//!   "the model panicked" message is a failure too;
//! - the status matches the state machine (Error leaves the instance in Error, Fatal in Fatal),
//!   and every Error or Fatal was explained through the logger;
//! - in StepComplete, Terminated and the Model Exchange modes every Real output reads OK and
//!   finite.
//!
//! One bit of the first byte instantiates Model Exchange instead of Co-Simulation, and the
//! op codes 18-23 are the Model Exchange calls, so both interfaces share one driver.

pub mod fmi3;
pub mod planted;

pub use fmi3::drive3;

use magswarm_fmi::fmi2::abi::Fmi2FmuState;
use magswarm_fmi::fmi2::host::Host;
use magswarm_fmi::fmi2::{Fmi2Status, FmuModel, VarType};

/// Reads the fuzz input as a stream of choices; zeros when exhausted.
pub struct Bytes<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> Bytes<'a> {
    /// Over `data`.
    pub fn new(data: &'a [u8]) -> Self {
        Bytes { data, pos: 0 }
    }
    /// Whether everything was read.
    pub fn done(&self) -> bool {
        self.pos >= self.data.len()
    }
    /// One byte.
    pub fn u8(&mut self) -> u8 {
        let b = self.data.get(self.pos).copied().unwrap_or(0);
        self.pos += 1;
        b
    }
    /// Up to `n` bytes.
    pub fn take(&mut self, n: usize) -> &'a [u8] {
        let end = (self.pos + n).min(self.data.len());
        let s = &self.data[self.pos.min(end)..end];
        self.pos = end;
        s
    }
    /// A number an importer might pass: mostly interesting values, sometimes raw bits.
    pub fn f64(&mut self) -> f64 {
        const SPECIAL: [f64; 24] = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            1e308,
            -1e308,
            5e-324,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            1e-9,
            1e9,
            0.0085,
            0.0135,
            0.008,
            0.011,
            25.13,
            62.8,
            0.05,
            0.01,
            1e-3,
            -1e-3,
            0.5,
            f64::MAX,
        ];
        let k = self.u8();
        if k < 200 {
            SPECIAL[k as usize % SPECIAL.len()]
        } else {
            let mut b = [0u8; 8];
            b.copy_from_slice(&{
                let s = self.take(8);
                let mut a = [0u8; 8];
                a[..s.len()].copy_from_slice(s);
                a
            });
            f64::from_le_bytes(b)
        }
    }
}

fn assert_no_panic<M: FmuModel>(h: &Host<M>, what: &str) {
    for e in h.log().entries() {
        assert!(
            !e.message.contains("panicked"),
            "{what}: a panic inside the FMU (validation must come first): {}",
            e.message
        );
    }
}

/// A value reference: mostly one of the model's variables of type `ty`, sometimes any.
pub fn vr_of<M: FmuModel>(b: &mut Bytes<'_>, ty: VarType) -> u32 {
    let vars: Vec<u32> = M::model_info()
        .variables
        .iter()
        .filter(|v| v.ty == ty)
        .map(|v| v.vr)
        .collect();
    let k = b.u8();
    if k < 240 && !vars.is_empty() {
        vars[k as usize % vars.len()]
    } else {
        u32::from_le_bytes([b.u8(), b.u8(), 0, 0])
    }
}

/// Run one fuzz input against model `M`.
pub fn drive<M: FmuModel>(data: &[u8]) {
    let mut b = Bytes::new(data);
    let first = b.u8();
    // Bit 2 of the first byte: instantiate as Model Exchange (refused, with a message, by
    // Co-Simulation-only models; then nothing more happens).
    let fmu_type = if first & 4 != 0 {
        magswarm_fmi::fmi2::abi::FMI2_MODEL_EXCHANGE
    } else {
        magswarm_fmi::fmi2::abi::FMI2_CO_SIMULATION
    };
    let resource: Option<Vec<u8>> = match first % 4 {
        0 => None,
        1 => Some(b"file:///nonexistent/resources".to_vec()),
        2 => Some(format!("file://{}", std::env::temp_dir().display()).into_bytes()),
        _ => {
            let n = b.u8() as usize % 32;
            Some(b.take(n).to_vec())
        }
    };
    let h = match Host::<M>::instantiate_as("fuzz", resource.as_deref(), fmu_type) {
        Ok(h) => h,
        Err(log) => {
            assert!(
                !log.iter().any(|e| e.message.contains("panicked")),
                "instantiate: {log:?}"
            );
            return;
        }
    };
    let mut states: Vec<Fmi2FmuState> = Vec::new();
    let mut saved: Vec<Vec<u8>> = Vec::new();
    let mut ops = 0;
    while !b.done() && ops < 64 {
        ops += 1;
        let before = h.log().len();
        let op = b.u8() % 24;
        let status = match op {
            0 => h.init(b.f64()),
            1 => h.set_real(vr_of::<M>(&mut b, VarType::Real), b.f64()),
            2 => h.get_real(vr_of::<M>(&mut b, VarType::Real)).0,
            3 | 4 => {
                // Usually contiguous, sometimes off; a step from the list.
                let t = if b.u8() < 220 { h.time() } else { b.f64() };
                let t = if t.is_finite() { t } else { 0.0 };
                let step = b.f64();
                h.step(t, step)
            }
            5 => h.terminate(),
            6 => h.reset(),
            7 => {
                let (s, st) = h.get_state();
                if !st.is_null() {
                    states.push(st);
                }
                s
            }
            8 => match states.get(b.u8() as usize % states.len().max(1)) {
                // SAFETY: a handle this instance handed out (maybe freed since: the shell
                // must refuse it without reading it).
                Some(&st) => unsafe { h.set_state(st) },
                None => Fmi2Status::Ok,
            },
            9 => {
                if states.is_empty() {
                    Fmi2Status::Ok
                } else {
                    let i = b.u8() as usize % states.len();
                    let mut st = states[i];
                    // SAFETY: as above; a double free is refused, not performed.
                    let s = unsafe { h.free_state(&mut st) };
                    if b.u8() < 200 {
                        states.remove(i);
                    }
                    s
                }
            }
            10 => match states.last() {
                // SAFETY: as above.
                Some(&st) => match unsafe { h.serialize(st) } {
                    Ok(bytes) => {
                        saved.push(bytes);
                        Fmi2Status::Ok
                    }
                    Err(s) => s,
                },
                None => Fmi2Status::Ok,
            },
            11 => {
                // Deserialize: a saved state, corrupted, truncated or replaced by fuzz bytes.
                let mut bytes = saved.last().cloned().unwrap_or_default();
                match b.u8() % 4 {
                    0 => {}
                    1 if !bytes.is_empty() => {
                        let i = b.u8() as usize * 7 % bytes.len();
                        bytes[i] ^= b.u8() | 1;
                    }
                    2 => {
                        let n = b.u8() as usize * 3;
                        bytes.truncate(n);
                    }
                    _ => {
                        let n = b.u8() as usize;
                        bytes = b.take(n).to_vec();
                    }
                }
                let (s, st) = h.deserialize(&bytes);
                if !st.is_null() {
                    states.push(st);
                }
                s
            }
            12 => h.set_boolean(vr_of::<M>(&mut b, VarType::Boolean), b.u8() & 1 == 1),
            13 => {
                let n = b.u8() as usize % 24;
                let s = String::from_utf8_lossy(b.take(n)).into_owned();
                let s = match b.u8() % 3 {
                    0 => String::new(),
                    1 => "/nonexistent/model.json".to_string(),
                    _ => s,
                };
                h.set_string(vr_of::<M>(&mut b, VarType::String), &s)
            }
            14 => {
                let vr = vr_of::<M>(&mut b, VarType::Integer);
                let x = i32::from_le_bytes([b.u8(), b.u8(), b.u8(), b.u8()]);
                // SAFETY: live instance, one-element arrays.
                unsafe {
                    magswarm_fmi::fmi2::shell::fmi2_set_integer::<M>(h.component(), &vr, 1, &x)
                }
            }
            15 => {
                let n = 1 + b.u8() as usize % 3;
                let unknowns: Vec<u32> =
                    (0..n).map(|_| vr_of::<M>(&mut b, VarType::Real)).collect();
                let knowns: Vec<u32> = (0..n).map(|_| vr_of::<M>(&mut b, VarType::Real)).collect();
                let dv: Vec<f64> = (0..n).map(|_| b.f64()).collect();
                let mut out = vec![0.0; n];
                // SAFETY: arrays of the stated lengths.
                unsafe {
                    magswarm_fmi::fmi2::shell::fmi2_get_directional_derivative::<M>(
                        h.component(),
                        unknowns.as_ptr(),
                        n,
                        knowns.as_ptr(),
                        n,
                        dv.as_ptr(),
                        out.as_mut_ptr(),
                    )
                }
            }
            16 => {
                let (start, stop, tol) = (b.f64(), b.f64(), b.f64());
                // SAFETY: live instance.
                unsafe {
                    magswarm_fmi::fmi2::shell::fmi2_setup_experiment::<M>(
                        h.component(),
                        (b.u8() & 1) as i32,
                        tol,
                        start,
                        (b.u8() & 1) as i32,
                        stop,
                    )
                }
            }
            // Model Exchange calls (refused on a Co-Simulation instance, and out of sequence).
            18 => h.set_time(b.f64()),
            19 => {
                let n = b.u8() as usize % 4;
                let x: Vec<f64> = (0..n).map(|_| b.f64()).collect();
                h.set_states(&x)
            }
            20 => {
                let n = b.u8() as usize % 4;
                match b.u8() % 3 {
                    0 => h.get_derivatives(n).0,
                    1 => h.get_states(n).0,
                    _ => h.get_nominals(n).0,
                }
            }
            21 => {
                if b.u8() & 1 == 0 {
                    h.enter_event_mode()
                } else {
                    h.enter_continuous_time_mode()
                }
            }
            22 => {
                if b.u8() & 1 == 0 {
                    h.new_discrete_states().0
                } else {
                    h.completed_integrator_step().0
                }
            }
            23 => {
                let n = b.u8() as usize % 3;
                let mut ind = vec![0.0; n];
                // SAFETY: live instance, `ind` has `n` writable elements.
                unsafe {
                    magswarm_fmi::fmi2::shell::fmi2_get_event_indicators::<M>(
                        h.component(),
                        ind.as_mut_ptr(),
                        n,
                    )
                }
            }
            _ => {
                // SAFETY: live instance.
                unsafe {
                    if b.u8() & 1 == 0 {
                        magswarm_fmi::fmi2::shell::fmi2_enter_initialization_mode::<M>(
                            h.component(),
                        )
                    } else {
                        magswarm_fmi::fmi2::shell::fmi2_exit_initialization_mode::<M>(h.component())
                    }
                }
            }
        };
        if let Err(e) = h.check(status, before) {
            panic!("after op {op}: {e}");
        }
        assert_no_panic(&h, "call");
    }
    // Dropping the host frees the instance and every state the fuzz input did not free.
}
