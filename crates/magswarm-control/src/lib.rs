//! Control of the magswarm plant.
//!
//! - [`pid`]: a discrete-time 2x2 PID acting in radius space, decoupled through the inverse
//!   of the steady map's Jacobian scheduled at the operating point, with feedforward from the
//!   inverse map, a model-predicted reference (bumpless setpoint changes), derivative
//!   filtering, anti-windup, and saturation and rate limits on the inputs;
//! - [`inverse`]: the inverse steady map (feedforward): inputs for target radii, or the
//!   nearest reachable radii of an infeasible target;
//! - [`linearize`]: A, B, C, D of ODE (4) at an equilibrium (SI), with JSON, MATLAB and
//!   python-control output;
//! - [`plant`]: the plant trait [`SwarmPlant`] (inputs z_m, omega_m in; timestamped radii
//!   with validity out), implemented for the in-process [`magswarm_model::Plant`];
//! - [`driver`]: the one closed-loop driver over any [`SwarmPlant`], writing one
//!   measurement-log row ([`magswarm_log::LogRow`]) per sample;
//! - [`sim`]: the seed's tracking scenario (Sec. III-D) over the driver.
//!
//! Units: the controller's measurement and setpoint are radii in mm (the camera's and the
//! seed's unit); the inputs it returns are SI (z_m in m, omega in rad/s), like the FMU's.
//! The configuration ([`PidConfig`], JSON schema `magswarm-pid/1`) is in human units
//! (mm, Hz, s).
//!
//! # Defaults and why
//!
//! - Sample time 0.05 s (20 Hz): a camera-in-the-loop rate the seed's EXO174CU3 and a ROS2
//!   loop sustain easily, and half the fastest time constant of (4) over the envelope
//!   (about 0.1 s at z_m = 3.5 mm, f = 10 Hz; the slowest is about 5 s at 23.5 mm, 1 Hz).
//! - z_m rate 10 mm/s: the UR10e itself could move 100 times faster (1 m/s tool speed),
//!   so the bound is the swarm: near the magnet the field changes by about 13 % per mm, and
//!   10 mm/s crosses the whole 20 mm envelope in 2 s, the order of the formation time, with
//!   0.5 mm per sample; the seed's moves are slow preprogrammed Cartesian trajectories.
//! - Frequency rate 2 Hz/s: the stepper could accelerate the 20 mm sphere far faster (the
//!   torque needed is below 1 mN m); the bound is again the swarm, which must stay
//!   synchronised with the field (step-out, retrograde rotation near f_off ~ 6 Hz): about
//!   1 Hz per formation time, 4.5 s across 1-10 Hz, 0.1 Hz per sample.
//! - Gains kp 0.3, ki 0.8 1/s, kd 0.02 s per radius (after decoupling the loop's static gain
//!   is the identity, so kp is in mm per mm). With feedforward the PID only corrects model
//!   error: these gains remove a 1 % error of the model's gains C_i with a time constant of
//!   about 1.5-2 s in the middle of the envelope and about 5 s at its slow corner (23.5 mm,
//!   1 Hz, where the plant's own time constant is 5 s), with no visible overshoot. They
//!   were chosen by simulation against mismatched plants, not by a formal design. The
//!   derivative is small because (4) is first order per axis; its filter
//!   (0.1 s, two samples) keeps camera noise off the inputs (0.05 mm of noise moves z_m by
//!   about 0.2 mm rms).
//! - Anti-windup: conditional integration and back-calculation with tracking time 0.5 s
//!   (about the integral time kp/ki).
//! - Decoupler damping 0.05 of the largest singular value: the inverse is exact where the
//!   Jacobian is well conditioned (to 0.25 %) and bounded along the fold, where it is singular.

// Units are written in brackets, e.g. `[mm]`, as in the model crate; they are not links.
#![allow(rustdoc::broken_intra_doc_links)]

pub mod driver;
pub mod inverse;
pub mod linearize;
mod mat2;
pub mod pid;
pub mod plant;
mod reference;
pub mod sim;

pub use driver::{run_loop, Command, LogSink, LoopError, LoopSummary, Tick};
pub use inverse::{inverse, inverse_with, InverseOptions, InverseResult};
pub use linearize::{linearize, Linearization};
pub use pid::{
    ConfigError, Controller, ControllerSnapshot, Fidelity, Gains, Limits, PidConfig, StepInfo,
    CONFIG_SCHEMA,
};
pub use plant::{Inputs, PlantError, Reading, SwarmPlant};
pub use sim::{
    closed_loop, seed_scenario, summarize, tracking, Sample, Segment, SegmentSummary, Tracking,
};
