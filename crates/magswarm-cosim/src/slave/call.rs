//! The raw calls, one per operation, for each FMI version: [`Api`] is the loaded function
//! table of either version and every method returns the FMI function's name with its raw
//! status, so [`super::FmuSlave`] checks and reports them the same way for both.
//!
//! Every symbol used here was checked when the FMU was loaded ([`crate::Fmu::load`]), so the
//! bindings' `expect`s cannot fire. All methods are `unsafe`: the caller passes a live
//! instance of this library and arrays of the lengths stated.

use std::ffi::{c_char, c_void};

use fmi::fmi2::binding as b2;

use crate::import::Api;

/// An instance (`fmi2Component` / `fmi3Instance`) or an FMU state: the same pointer type in
/// both versions.
pub(crate) type Ptr = *mut c_void;

/// One call's outcome: the FMI function called and its raw status.
pub(crate) type Call = (&'static str, u32);

/// Both versions' names of one function.
macro_rules! names {
    ($self:ident, $v2:literal, $v3:literal) => {
        match $self {
            Api::V2(_) => $v2,
            Api::V3(_) => $v3,
        }
    };
}

/// A value type with a typed get and set in both versions.
pub trait Scalar: Copy + Default + sealed::Sealed {
    /// The variable type it belongs to.
    const VAR_TYPE: crate::VarType;
    #[doc(hidden)]
    /// # Safety
    /// A live instance of `api`'s library.
    unsafe fn set(api: &Api, c: Ptr, vrs: &[u32], values: &[Self]) -> Call;
    #[doc(hidden)]
    /// # Safety
    /// A live instance of `api`'s library.
    unsafe fn get(api: &Api, c: Ptr, vrs: &[u32], values: &mut [Self]) -> Call;
}

mod sealed {
    pub trait Sealed {}
    impl Sealed for f64 {}
    impl Sealed for i32 {}
    impl Sealed for bool {}
}

impl Scalar for f64 {
    const VAR_TYPE: crate::VarType = crate::VarType::Real;
    #[inline]
    unsafe fn set(api: &Api, c: Ptr, vrs: &[u32], v: &[f64]) -> Call {
        let n = vrs.len();
        match api {
            Api::V2(b) => ("fmi2SetReal", unsafe {
                b.fmi2SetReal(c, vrs.as_ptr(), n, v.as_ptr())
            }),
            Api::V3(b) => ("fmi3SetFloat64", unsafe {
                b.fmi3SetFloat64(c, vrs.as_ptr(), n, v.as_ptr(), v.len())
            }),
        }
    }
    #[inline]
    unsafe fn get(api: &Api, c: Ptr, vrs: &[u32], v: &mut [f64]) -> Call {
        let n = vrs.len();
        match api {
            Api::V2(b) => ("fmi2GetReal", unsafe {
                b.fmi2GetReal(c, vrs.as_ptr(), n, v.as_mut_ptr())
            }),
            Api::V3(b) => ("fmi3GetFloat64", unsafe {
                b.fmi3GetFloat64(c, vrs.as_ptr(), n, v.as_mut_ptr(), v.len())
            }),
        }
    }
}

impl Scalar for i32 {
    const VAR_TYPE: crate::VarType = crate::VarType::Integer;
    unsafe fn set(api: &Api, c: Ptr, vrs: &[u32], v: &[i32]) -> Call {
        let n = vrs.len();
        match api {
            Api::V2(b) => ("fmi2SetInteger", unsafe {
                b.fmi2SetInteger(c, vrs.as_ptr(), n, v.as_ptr())
            }),
            Api::V3(b) => ("fmi3SetInt32", unsafe {
                b.fmi3SetInt32(c, vrs.as_ptr(), n, v.as_ptr(), v.len())
            }),
        }
    }
    unsafe fn get(api: &Api, c: Ptr, vrs: &[u32], v: &mut [i32]) -> Call {
        let n = vrs.len();
        match api {
            Api::V2(b) => ("fmi2GetInteger", unsafe {
                b.fmi2GetInteger(c, vrs.as_ptr(), n, v.as_mut_ptr())
            }),
            Api::V3(b) => ("fmi3GetInt32", unsafe {
                b.fmi3GetInt32(c, vrs.as_ptr(), n, v.as_mut_ptr(), v.len())
            }),
        }
    }
}

impl Scalar for bool {
    const VAR_TYPE: crate::VarType = crate::VarType::Boolean;
    unsafe fn set(api: &Api, c: Ptr, vrs: &[u32], v: &[bool]) -> Call {
        let n = vrs.len();
        match api {
            Api::V2(b) => {
                let raw: Vec<b2::fmi2Boolean> = v.iter().map(|&x| x as _).collect();
                ("fmi2SetBoolean", unsafe {
                    b.fmi2SetBoolean(c, vrs.as_ptr(), n, raw.as_ptr())
                })
            }
            Api::V3(b) => ("fmi3SetBoolean", unsafe {
                b.fmi3SetBoolean(c, vrs.as_ptr(), n, v.as_ptr(), v.len())
            }),
        }
    }
    unsafe fn get(api: &Api, c: Ptr, vrs: &[u32], v: &mut [bool]) -> Call {
        let n = vrs.len();
        match api {
            Api::V2(b) => {
                let mut raw: Vec<b2::fmi2Boolean> = vec![0; n];
                let s = unsafe { b.fmi2GetBoolean(c, vrs.as_ptr(), n, raw.as_mut_ptr()) };
                for (x, r) in v.iter_mut().zip(raw) {
                    *x = r != 0;
                }
                ("fmi2GetBoolean", s)
            }
            Api::V3(b) => ("fmi3GetBoolean", unsafe {
                b.fmi3GetBoolean(c, vrs.as_ptr(), n, v.as_mut_ptr(), v.len())
            }),
        }
    }
}

/// The experiment `fmi2SetupExperiment` fixes (FMI 3.0 passes it to
/// `fmi3EnterInitializationMode`).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Experiment {
    pub(crate) tolerance: Option<f64>,
    pub(crate) start: f64,
    pub(crate) stop: Option<f64>,
}

impl Api {
    pub(crate) unsafe fn set_debug_logging(
        &self,
        c: Ptr,
        on: bool,
        cats: &[*const c_char],
    ) -> Call {
        let n = cats.len();
        match self {
            Api::V2(b) => ("fmi2SetDebugLogging", unsafe {
                b.fmi2SetDebugLogging(c, on as b2::fmi2Boolean, n, cats.as_ptr())
            }),
            Api::V3(b) => ("fmi3SetDebugLogging", unsafe {
                b.fmi3SetDebugLogging(c, on, n, cats.as_ptr())
            }),
        }
    }

    /// FMI 2.0: `fmi2SetupExperiment`; FMI 3.0 has none (the experiment is passed on entering
    /// initialisation) and reports OK.
    pub(crate) unsafe fn setup_experiment(&self, c: Ptr, e: Experiment) -> Call {
        match self {
            Api::V2(b) => ("fmi2SetupExperiment", unsafe {
                b.fmi2SetupExperiment(
                    c,
                    e.tolerance.is_some() as b2::fmi2Boolean,
                    e.tolerance.unwrap_or(0.0),
                    e.start,
                    e.stop.is_some() as b2::fmi2Boolean,
                    e.stop.unwrap_or(0.0),
                )
            }),
            Api::V3(_) => ("fmi3EnterInitializationMode", 0),
        }
    }

    pub(crate) unsafe fn enter_initialization_mode(&self, c: Ptr, e: Experiment) -> Call {
        match self {
            Api::V2(b) => ("fmi2EnterInitializationMode", unsafe {
                b.fmi2EnterInitializationMode(c)
            }),
            Api::V3(b) => ("fmi3EnterInitializationMode", unsafe {
                b.fmi3EnterInitializationMode(
                    c,
                    e.tolerance.is_some(),
                    e.tolerance.unwrap_or(0.0),
                    e.start,
                    e.stop.is_some(),
                    e.stop.unwrap_or(0.0),
                )
            }),
        }
    }

    pub(crate) unsafe fn exit_initialization_mode(&self, c: Ptr) -> Call {
        match self {
            Api::V2(b) => ("fmi2ExitInitializationMode", unsafe {
                b.fmi2ExitInitializationMode(c)
            }),
            Api::V3(b) => ("fmi3ExitInitializationMode", unsafe {
                b.fmi3ExitInitializationMode(c)
            }),
        }
    }

    pub(crate) unsafe fn terminate(&self, c: Ptr) -> Call {
        match self {
            Api::V2(b) => ("fmi2Terminate", unsafe { b.fmi2Terminate(c) }),
            Api::V3(b) => ("fmi3Terminate", unsafe { b.fmi3Terminate(c) }),
        }
    }

    pub(crate) unsafe fn reset(&self, c: Ptr) -> Call {
        match self {
            Api::V2(b) => ("fmi2Reset", unsafe { b.fmi2Reset(c) }),
            Api::V3(b) => ("fmi3Reset", unsafe { b.fmi3Reset(c) }),
        }
    }

    pub(crate) unsafe fn free_instance(&self, c: Ptr) {
        match self {
            Api::V2(b) => unsafe { b.fmi2FreeInstance(c) },
            Api::V3(b) => unsafe { b.fmi3FreeInstance(c) },
        }
    }

    /// `doStep`; FMI 3.0 also reports the last successful time (written to `last`).
    #[inline]
    pub(crate) unsafe fn do_step(
        &self,
        c: Ptr,
        t: f64,
        h: f64,
        no_prior: bool,
        last: &mut f64,
    ) -> Call {
        match self {
            Api::V2(b) => ("fmi2DoStep", unsafe {
                b.fmi2DoStep(c, t, h, no_prior as b2::fmi2Boolean)
            }),
            Api::V3(b) => {
                let (mut event, mut terminate, mut early) = (false, false, false);
                let s = unsafe {
                    b.fmi3DoStep(
                        c,
                        t,
                        h,
                        no_prior,
                        &mut event,
                        &mut terminate,
                        &mut early,
                        last,
                    )
                };
                ("fmi3DoStep", s)
            }
        }
    }

    /// FMI 2.0: `fmi2GetRealStatus(fmi2LastSuccessfulTime)` into `last`; FMI 3.0 has none
    /// (`last` already holds what `fmi3DoStep` reported).
    pub(crate) unsafe fn last_successful_time(&self, c: Ptr, last: &mut f64) -> Call {
        match self {
            Api::V2(b) => ("fmi2GetRealStatus", unsafe {
                b.fmi2GetRealStatus(c, b2::fmi2StatusKind_fmi2LastSuccessfulTime, last)
            }),
            Api::V3(_) => ("fmi3DoStep", 0),
        }
    }

    pub(crate) unsafe fn set_string(&self, c: Ptr, vrs: &[u32], v: &[*const c_char]) -> Call {
        let n = vrs.len();
        match self {
            Api::V2(b) => ("fmi2SetString", unsafe {
                b.fmi2SetString(c, vrs.as_ptr(), n, v.as_ptr())
            }),
            Api::V3(b) => ("fmi3SetString", unsafe {
                b.fmi3SetString(c, vrs.as_ptr(), n, v.as_ptr(), v.len())
            }),
        }
    }

    pub(crate) unsafe fn get_string(&self, c: Ptr, vrs: &[u32], v: &mut [*const c_char]) -> Call {
        let n = vrs.len();
        match self {
            Api::V2(b) => ("fmi2GetString", unsafe {
                b.fmi2GetString(c, vrs.as_ptr(), n, v.as_mut_ptr())
            }),
            Api::V3(b) => ("fmi3GetString", unsafe {
                b.fmi3GetString(c, vrs.as_ptr(), n, v.as_mut_ptr(), v.len())
            }),
        }
    }

    pub(crate) unsafe fn directional_derivative(
        &self,
        c: Ptr,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Call {
        let (u, k) = (unknowns, knowns);
        match self {
            Api::V2(b) => ("fmi2GetDirectionalDerivative", unsafe {
                b.fmi2GetDirectionalDerivative(
                    c,
                    u.as_ptr(),
                    u.len(),
                    k.as_ptr(),
                    k.len(),
                    seed.as_ptr(),
                    out.as_mut_ptr(),
                )
            }),
            Api::V3(b) => ("fmi3GetDirectionalDerivative", unsafe {
                b.fmi3GetDirectionalDerivative(
                    c,
                    u.as_ptr(),
                    u.len(),
                    k.as_ptr(),
                    k.len(),
                    seed.as_ptr(),
                    seed.len(),
                    out.as_mut_ptr(),
                    out.len(),
                )
            }),
        }
    }

    /// Get the instance's state into `*state` (a new one when it is NULL).
    pub(crate) unsafe fn get_state(&self, c: Ptr, state: &mut Ptr) -> Call {
        match self {
            Api::V2(b) => ("fmi2GetFMUstate", unsafe { b.fmi2GetFMUstate(c, state) }),
            Api::V3(b) => ("fmi3GetFMUState", unsafe { b.fmi3GetFMUState(c, state) }),
        }
    }

    pub(crate) unsafe fn set_state(&self, c: Ptr, state: Ptr) -> Call {
        match self {
            Api::V2(b) => ("fmi2SetFMUstate", unsafe { b.fmi2SetFMUstate(c, state) }),
            Api::V3(b) => ("fmi3SetFMUState", unsafe { b.fmi3SetFMUState(c, state) }),
        }
    }

    pub(crate) unsafe fn free_state(&self, c: Ptr, state: &mut Ptr) -> Call {
        match self {
            Api::V2(b) => ("fmi2FreeFMUstate", unsafe { b.fmi2FreeFMUstate(c, state) }),
            Api::V3(b) => ("fmi3FreeFMUState", unsafe { b.fmi3FreeFMUState(c, state) }),
        }
    }

    pub(crate) unsafe fn serialized_size(&self, c: Ptr, state: Ptr, size: &mut usize) -> Call {
        match self {
            Api::V2(b) => ("fmi2SerializedFMUstateSize", unsafe {
                b.fmi2SerializedFMUstateSize(c, state, size)
            }),
            Api::V3(b) => ("fmi3SerializedFMUStateSize", unsafe {
                b.fmi3SerializedFMUStateSize(c, state, size)
            }),
        }
    }

    pub(crate) unsafe fn serialize(&self, c: Ptr, state: Ptr, buf: &mut [u8]) -> Call {
        match self {
            Api::V2(b) => ("fmi2SerializeFMUstate", unsafe {
                b.fmi2SerializeFMUstate(c, state, buf.as_mut_ptr() as *mut b2::fmi2Byte, buf.len())
            }),
            Api::V3(b) => ("fmi3SerializeFMUState", unsafe {
                b.fmi3SerializeFMUState(c, state, buf.as_mut_ptr(), buf.len())
            }),
        }
    }

    pub(crate) unsafe fn deserialize(&self, c: Ptr, bytes: &[u8], state: &mut Ptr) -> Call {
        match self {
            Api::V2(b) => ("fmi2DeSerializeFMUstate", unsafe {
                b.fmi2DeSerializeFMUstate(
                    c,
                    bytes.as_ptr() as *const b2::fmi2Byte,
                    bytes.len(),
                    state,
                )
            }),
            Api::V3(b) => ("fmi3DeserializeFMUState", unsafe {
                b.fmi3DeserializeFMUState(c, bytes.as_ptr(), bytes.len(), state)
            }),
        }
    }

    /// The name of the function that makes a new FMU state (for messages).
    pub(crate) fn get_state_name(&self) -> &'static str {
        names!(self, "fmi2GetFMUstate", "fmi3GetFMUState")
    }

    /// The name of the function that deserialises an FMU state (for messages).
    pub(crate) fn deserialize_name(&self) -> &'static str {
        names!(self, "fmi2DeSerializeFMUstate", "fmi3DeserializeFMUState")
    }
}
