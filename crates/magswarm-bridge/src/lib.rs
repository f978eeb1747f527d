//! magswarm-bridge: the magswarm plant interface on the real rig.
//!
//! A UR e-Series robot moves the magnet along z (RTDE on port 30004 for the target and the
//! state, a URScript servo program uploaded to the secondary interface, the dashboard for
//! power and brakes); a TMCL stepper spins the magnet; a camera films the swarm. The rig is
//! one more implementation of the plant interface, so the controller that closes the loop
//! around the FMU closes it around the rig. Emulators of every device make the whole loop
//! run without hardware.
//!
//! Nothing here is linked into the FMU libraries: sockets, serial lines and ptys stay in
//! this crate.

pub mod bake;
pub mod camera;
pub mod check;
pub mod config;
pub mod emulate;
pub mod error;
pub mod measure;
pub mod plant;
pub mod rig;
pub mod robot;
pub mod robots;
pub mod rtde;
pub mod run;
pub mod safety;
pub mod schedule;
pub mod session;
pub mod shadow;
pub mod signals;
pub mod stepper;
pub mod stepper_emu;
pub mod ur;
pub mod watchdog;
