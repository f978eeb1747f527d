//! The one benchmark loop over an imported FMU's C ABI: [`RawLoop`] holds an initialised
//! Co-Simulation instance (FMI 2.0 or 3.0, loaded by [`crate::cosim`] exactly as an importer
//! does) and calls its `doStep` / `Set` / `Get` function pointers directly, as a C master
//! does. `examples/perf_table.rs` and `benches/fmi_dostep.rs` both time these loops.

use std::f64::consts::TAU;
use std::hint::black_box;
use std::time::Instant;

use crate::cosim::fmi::fmi2::binding as b2;
use crate::cosim::fmi::fmi3::binding as b3;
use crate::cosim::{Api, Fmu, FmuSlave, SlaveOptions};
use anyhow::{bail, Result};

/// Loops per figure; the figure is their median.
pub const REPEATS: usize = 7;

/// The median of `v`.
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// Inputs at time t: z_m 8.5 +- 2 mm, f 4 +- 1 Hz at 0.2 Hz (a new value every call).
pub fn inputs(t: f64) -> [f64; 2] {
    let s = (TAU * 0.2 * t).sin();
    [8.5e-3 + 2.0e-3 * s, (4.0 + s) * TAU]
}

/// Variable names (two inputs, two outputs) of MagSwarm.fmu.
pub const MAGSWARM: [&str; 4] = ["z_m", "omega_m", "r1", "r2"];
/// Variable names of the yardstick (`super::fixture`).
pub const EULER2: [&str; 4] = ["u1", "u2", "x1", "x2"];

/// The three functions of a communication step, in the FMU's version.
enum Fns {
    V2 {
        do_step: b2::fmi2DoStepTYPE,
        set: b2::fmi2SetRealTYPE,
        get: b2::fmi2GetRealTYPE,
    },
    V3 {
        do_step: b3::fmi3DoStepTYPE,
        set: b3::fmi3SetFloat64TYPE,
        get: b3::fmi3GetFloat64TYPE,
    },
}

/// One initialised instance and its raw function pointers.
pub struct RawLoop {
    slave: FmuSlave,
    fns: Fns,
    ins: [u32; 2],
    outs: [u32; 2],
    t: f64,
    h: f64,
}

impl RawLoop {
    /// Instantiate `fmu`, initialise it with `inputs(0)` on the inputs `names[0..2]` and
    /// step by `h`; `names[2..4]` are the outputs read.
    pub fn new(fmu: &Fmu, names: [&str; 4], h: f64) -> Result<RawLoop> {
        Self::with_start(fmu, names, h, &[], &[])
    }

    /// As [`RawLoop::new`], with these Real and Boolean start values set during
    /// initialisation (e.g. MagSwarm's `settle_at_start = false`, `r1_start`, `r2_start`: a
    /// swarm that starts away from the steady map, so that the first seconds are a transient).
    pub fn with_start(
        fmu: &Fmu,
        names: [&str; 4],
        h: f64,
        reals: &[(&str, f64)],
        bools: &[(&str, bool)],
    ) -> Result<RawLoop> {
        let mut slave = fmu.instantiate("bench", SlaveOptions::default())?;
        let ins = [fmu.real_vr(names[0])?, fmu.real_vr(names[1])?];
        let outs = [fmu.real_vr(names[2])?, fmu.real_vr(names[3])?];
        slave.setup_experiment(None, 0.0, None)?;
        slave.enter_initialization_mode()?;
        slave.set_real(&ins, &inputs(0.0))?;
        for &(n, x) in reals {
            slave.set_real_by_name(n, x)?;
        }
        for &(n, b) in bools {
            slave.set_boolean_by_name(n, b)?;
        }
        slave.exit_initialization_mode()?;
        let fns = match slave.api() {
            Api::V2(b) => match (&b.fmi2DoStep, &b.fmi2SetReal, &b.fmi2GetReal) {
                (Ok(d), Ok(s), Ok(g)) => Fns::V2 {
                    do_step: Some(*d),
                    set: Some(*s),
                    get: Some(*g),
                },
                _ => bail!(
                    "{}: fmi2DoStep/SetReal/GetReal missing",
                    fmu.path().display()
                ),
            },
            Api::V3(b) => match (&b.fmi3DoStep, &b.fmi3SetFloat64, &b.fmi3GetFloat64) {
                (Ok(d), Ok(s), Ok(g)) => Fns::V3 {
                    do_step: Some(*d),
                    set: Some(*s),
                    get: Some(*g),
                },
                _ => bail!(
                    "{}: fmi3DoStep/SetFloat64/GetFloat64 missing",
                    fmu.path().display()
                ),
            },
        };
        Ok(RawLoop {
            slave,
            fns,
            ins,
            outs,
            t: 0.0,
            h,
        })
    }

    /// ns per call of `f`, median of [`REPEATS`] loops of `calls` calls after a warm-up.
    pub fn time(&mut self, calls: usize, f: fn(&mut RawLoop)) -> f64 {
        for _ in 0..calls / 10 {
            f(self);
        }
        median(
            (0..REPEATS)
                .map(|_| {
                    let t0 = Instant::now();
                    for _ in 0..calls {
                        f(self);
                    }
                    t0.elapsed().as_nanos() as f64 / calls as f64
                })
                .collect(),
        )
    }

    /// ns per call of `f`: the median over [`REPEATS`] fresh loops from `make` (built outside
    /// the timing), each timed over its first `calls` calls with no warm-up: for states that
    /// a long loop would leave (a transient).
    pub fn time_fresh(
        calls: usize,
        mut make: impl FnMut() -> Result<RawLoop>,
        f: fn(&mut RawLoop),
    ) -> Result<f64> {
        let mut v = Vec::with_capacity(REPEATS);
        for _ in 0..REPEATS {
            let mut r = make()?;
            let t0 = Instant::now();
            for _ in 0..calls {
                f(&mut r);
            }
            v.push(t0.elapsed().as_nanos() as f64 / calls as f64);
        }
        Ok(median(v))
    }

    /// One `doStep` at the current inputs.
    pub fn step(&mut self) {
        let c = self.slave.component();
        // SAFETY: a live, initialised instance of this library; the pointers were checked.
        let s = unsafe {
            match &self.fns {
                Fns::V2 { do_step, .. } => do_step.unwrap_unchecked()(c, self.t, self.h, 1),
                Fns::V3 { do_step, .. } => {
                    let (mut ev, mut term, mut early, mut last) = (false, false, false, 0.0);
                    do_step.unwrap_unchecked()(
                        c, self.t, self.h, true, &mut ev, &mut term, &mut early, &mut last,
                    )
                }
            }
        };
        assert!(s <= 1, "doStep returned {s}");
        self.t += self.h;
    }

    /// Set both inputs to a new value, then `doStep`.
    pub fn set_step(&mut self) {
        let u = inputs(self.t);
        let c = self.slave.component();
        let vr = self.ins.as_ptr();
        // SAFETY: live instance, arrays of 2.
        let s = unsafe {
            match &self.fns {
                Fns::V2 { set, .. } => set.unwrap_unchecked()(c, vr, 2, u.as_ptr()),
                Fns::V3 { set, .. } => set.unwrap_unchecked()(c, vr, 2, u.as_ptr(), 2),
            }
        };
        assert!(s <= 1, "set returned {s}");
        self.step();
    }

    /// The master's communication step: set both inputs, `doStep`, get both outputs.
    pub fn set_step_get(&mut self) {
        self.set_step();
        let mut y = [0.0; 2];
        let c = self.slave.component();
        let vr = self.outs.as_ptr();
        // SAFETY: live instance, arrays of 2.
        let s = unsafe {
            match &self.fns {
                Fns::V2 { get, .. } => get.unwrap_unchecked()(c, vr, 2, y.as_mut_ptr()),
                Fns::V3 { get, .. } => get.unwrap_unchecked()(c, vr, 2, y.as_mut_ptr(), 2),
            }
        };
        assert!(s <= 1, "get returned {s}");
        black_box(y);
    }
}
