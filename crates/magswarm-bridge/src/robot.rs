//! The arm that moves the magnet along z, as the rig sees it: one trait, one implementation
//! per kind of robot (`[robot] kind`; today `"ur"`, [`crate::ur::UrRobot`]).
//!
//! Another arm is one more file: a type implementing [`Robot`] (its link, its own watchdog
//! on the commands, its safety state) and one arm in [`crate::robots::open`]. Every command it gets has been
//! through the bridge's safety core already (clamped, rate limited, finite); the arm's own
//! controller should clamp again, as the UR's servo program does.

use crate::safety::Fault;

/// What the rig needs of an arm.
pub trait Robot: Send {
    /// Check the link and the arm's state (safety, program running, data fresh) and return
    /// z_m \[mm\] from the arm's reported tool pose. Any problem is the fault that names it.
    fn check(&mut self) -> Result<f64, Fault>;

    /// Send the target z_m \[mm\] (shaped already). Sending it also feeds the arm's watchdog,
    /// so the rig calls this between frames too, with an unchanged target.
    fn command(&mut self, z_mm: f64) -> Result<(), Fault>;

    /// Hold where the tool is and stop the arm's program (after a fault, and at the end).
    fn hold(&mut self);

    /// One line about the arm (controller, version, address).
    fn describe(&self) -> String;
}
