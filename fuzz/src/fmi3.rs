//! The fuzz driver for the FMI 3.0 shell: the same idea as [`super::drive`] (random call
//! sequences through the shell's entry points, [`magswarm_fmi::fmi3::host::Host`], the
//! invariants checked after every call), over every `fmi3*` function a model of this shell
//! has: both interfaces (bit 2 of the first byte), FMU states, directional and adjoint
//! derivatives, variable dependencies, the types no variable has, and the clock and
//! configuration functions that must refuse with a message.

use magswarm_fmi::fmi3::abi::Fmi3FmuState;
use magswarm_fmi::fmi3::host::{Host, Kind};
use magswarm_fmi::fmi3::shell;
use magswarm_fmi::{FmuModel, Status, VarType};

use super::{vr_of, Bytes};

fn assert_no_panic<M: FmuModel>(h: &Host<M>, what: &str) {
    for e in h.log().entries() {
        assert!(
            !e.message.contains("panicked"),
            "{what}: a panic inside the FMU (validation must come first): {}",
            e.message
        );
    }
}

/// Run one fuzz input against model `M` through the FMI 3.0 shell.
pub fn drive3<M: FmuModel>(data: &[u8]) {
    let mut b = Bytes::new(data);
    let first = b.u8();
    let kind = if first & 4 != 0 {
        Kind::ModelExchange
    } else {
        Kind::CoSimulation
    };
    let dir = std::env::temp_dir().display().to_string();
    let resource: Option<String> = match first % 4 {
        0 => None,
        1 => Some("/nonexistent/resources/".to_string()),
        2 => Some(format!("{dir}/")),
        _ => {
            let n = b.u8() as usize % 32;
            Some(String::from_utf8_lossy(b.take(n)).into_owned())
        }
    };
    let h = match Host::<M>::instantiate("fuzz3", resource.as_deref(), kind) {
        Ok(h) => h,
        Err(log) => {
            assert!(
                !log.iter().any(|e| e.message.contains("panicked")),
                "instantiate: {log:?}"
            );
            return;
        }
    };
    let c = h.instance();
    let mut states: Vec<Fmi3FmuState> = Vec::new();
    let mut saved: Vec<Vec<u8>> = Vec::new();
    let mut ops = 0;
    while !b.done() && ops < 64 {
        ops += 1;
        let before = h.log().len();
        let op = b.u8() % 24;
        // SAFETY (every `unsafe` below): `c` is a live instance of this host; every array
        // passed has the length passed beside it.
        let status = match op {
            0 => h.init(b.f64()),
            1 => h.set_real(vr_of::<M>(&mut b, VarType::Real), b.f64()),
            2 => h.get_real(vr_of::<M>(&mut b, VarType::Real)).0,
            3 | 4 => {
                let t = if b.u8() < 220 { h.time() } else { b.f64() };
                let t = if t.is_finite() { t } else { 0.0 };
                let step = b.f64();
                h.step(t, step).0
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
                None => Status::Ok,
            },
            9 => {
                if states.is_empty() {
                    Status::Ok
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
                        Status::Ok
                    }
                    Err(s) => s,
                },
                None => Status::Ok,
            },
            11 => {
                let mut bytes = saved.last().cloned().unwrap_or_default();
                match b.u8() % 3 {
                    0 if !bytes.is_empty() => {
                        let i = b.u8() as usize * 7 % bytes.len();
                        bytes[i] ^= b.u8() | 1;
                    }
                    1 => bytes.truncate(b.u8() as usize * 3),
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
                h.set_string(vr_of::<M>(&mut b, VarType::String), &s)
            }
            14 => {
                // Directional or adjoint derivatives over random references and seeds.
                let n = 1 + b.u8() as usize % 3;
                let unknowns: Vec<u32> =
                    (0..n).map(|_| vr_of::<M>(&mut b, VarType::Real)).collect();
                let knowns: Vec<u32> = (0..n).map(|_| vr_of::<M>(&mut b, VarType::Real)).collect();
                let seed: Vec<f64> = (0..n).map(|_| b.f64()).collect();
                h.derivative(&unknowns, &knowns, &seed, b.u8() & 1 == 1).0
            }
            15 => {
                // Variable dependencies, with a wrong count sometimes.
                let vr = vr_of::<M>(&mut b, VarType::Real);
                let mut n = 0usize;
                let s =
                    unsafe { shell::fmi3_get_number_of_variable_dependencies::<M>(c, vr, &mut n) };
                let n = if b.u8() < 200 {
                    n.min(64)
                } else {
                    b.u8() as usize % 8
                };
                let (mut ed, mut ind, mut ei) = (vec![0usize; n], vec![0u32; n], vec![0usize; n]);
                let mut kinds = vec![0i32; n];
                let t = unsafe {
                    shell::fmi3_get_variable_dependencies::<M>(
                        c,
                        vr,
                        ed.as_mut_ptr(),
                        ind.as_mut_ptr(),
                        ei.as_mut_ptr(),
                        kinds.as_mut_ptr(),
                        n,
                    )
                };
                s.max(t)
            }
            16 => {
                // A type no variable has, with a real variable's reference or none.
                let vr = vr_of::<M>(&mut b, VarType::Real);
                let n = b.u8() as usize % 2;
                let mut v = [0f32; 1];
                unsafe {
                    if b.u8() & 1 == 0 {
                        shell::fmi3_get_float32::<M>(c, &vr, n, v.as_mut_ptr(), n)
                    } else {
                        shell::fmi3_set_uint64::<M>(c, &vr, n, [7u64].as_ptr(), n)
                    }
                }
            }
            17 => unsafe {
                match b.u8() % 4 {
                    0 => shell::fmi3_enter_configuration_mode::<M>(c),
                    1 => shell::fmi3_exit_configuration_mode::<M>(c),
                    2 => shell::fmi3_evaluate_discrete_states::<M>(c),
                    _ => shell::fmi3_get_clock::<M>(c, &0, 1, [0u8].as_mut_ptr()),
                }
            },
            18 => h.set_time(b.f64()),
            19 => {
                let n = b.u8() as usize % 8;
                let x: Vec<f64> = (0..n).map(|_| b.f64()).collect();
                h.set_states(&x)
            }
            20 => {
                let n = b.u8() as usize % 8;
                if b.u8() & 1 == 0 {
                    h.get_derivatives(n).0
                } else {
                    h.get_states(n).0
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
                    h.update_discrete_states().0
                } else {
                    h.completed_integrator_step().0
                }
            }
            _ => unsafe {
                if b.u8() & 1 == 0 {
                    shell::fmi3_enter_initialization_mode::<M>(
                        c,
                        b.u8() & 1,
                        b.f64(),
                        b.f64(),
                        b.u8() & 1,
                        b.f64(),
                    )
                } else {
                    shell::fmi3_exit_initialization_mode::<M>(c)
                }
            },
        };
        if let Err(e) = h.check(status, before) {
            panic!("after FMI 3.0 op {op}: {e}");
        }
        assert_no_panic(&h, &format!("FMI 3.0 op {op}"));
    }
    for mut st in states {
        // SAFETY: handles of this instance (freed ones are refused without being read).
        unsafe { h.free_state(&mut st) };
    }
}
