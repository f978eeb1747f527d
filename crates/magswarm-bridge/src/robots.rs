//! The arms this build drives: the one place where `[robot] kind` meets an implementation of
//! [`Robot`]. Another arm is one more file (its type) and one more arm of [`open`] (and its
//! name in [`crate::config::ROBOT_KINDS`], which the config checks).

use crate::config::RigConfig;
use crate::error::SetupError;
use crate::robot::Robot;
use crate::safety::Envelope;

/// The kinds of arm this build drives (`[robot] kind`), one per arm of [`open`].
pub use crate::config::ROBOT_KINDS as KINDS;

/// Connect to the arm of the config, bring it up and start its program, with the envelope
/// `env` (the arm's own clamps where it has them).
pub fn open(cfg: &RigConfig, env: &Envelope) -> Result<Box<dyn Robot>, SetupError> {
    match cfg.robot.kind.as_str() {
        "ur" => Ok(Box::new(crate::ur::UrRobot::open(cfg, env)?)),
        k => Err(SetupError::UnknownRobot(k.to_string())),
    }
}
