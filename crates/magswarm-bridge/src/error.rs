//! Why the rig, a run or a session could not start. Faults *during* a run are
//! [`crate::safety::Fault`]s (reported, latched, the rig stopped); these are the errors before
//! anything moved, each naming the config section, file or device it is about.

use std::path::PathBuf;

use crate::camera::{CameraError, CameraSetupError};
use crate::config::ConfigError;
use crate::rtde::RtdeError;
use crate::safety::Fault;
use crate::schedule::ScheduleError;
use crate::stepper::StepperError;
use crate::ur::UrError;

/// A setup error.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    /// The config, or a model file it names.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A PLAN or TARGETS file.
    #[error(transparent)]
    Schedule(#[from] ScheduleError),
    /// Neither or both of `--plan` and `--targets`.
    #[error("give exactly one of --plan PLAN.csv and --targets TARGETS.csv")]
    PlanOrTargets,
    /// The run's length cannot be known or is not a length.
    #[error("{0}")]
    Duration(String),
    /// The PID configuration or its model.
    #[error("[control] {what}: {source}")]
    Controller {
        /// The file or the step (`pid FILE`, `the controller`).
        what: String,
        /// Why.
        source: magswarm_control::pid::ConfigError,
    },
    /// A file that cannot be read or written (the PID config, the log).
    #[error("{path}: {source}")]
    File {
        /// The file.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// The camera or the vision settings.
    #[error(transparent)]
    Camera(#[from] CameraSetupError),
    /// The camera's thread could not start.
    #[error("[camera] {0}")]
    CameraStart(#[from] CameraError),
    /// No frame came after the start.
    #[error("[camera] no frame within {0:.1} s of the start")]
    NoFirstFrame(f64),
    /// The stepper (or its watchdog).
    #[error("[stepper] {device}: {source}")]
    Stepper {
        /// `stepper.device`.
        device: String,
        /// Why.
        source: StepperError,
    },
    /// `[robot] kind` names no arm of this build.
    #[error("[robot] kind {0:?}: not a known robot (known: {known:?})", known = crate::config::ROBOT_KINDS)]
    UnknownRobot(String),
    /// The arm's RTDE link.
    #[error("[robot] {0}")]
    Rtde(#[from] RtdeError),
    /// The arm's dashboard or secondary interface.
    #[error("[robot] {0}")]
    Ur(UrError),
    /// The arm is not ready (no data, its program does not play).
    #[error("[robot] {0}")]
    RobotNotReady(String),
    /// The rig is in a fault state before the start (e.g. a protective stop), or faulted while
    /// starting.
    #[error("{name}: {0}", name = .0.name())]
    Fault(Fault),
    /// A thread of the session could not start.
    #[error("starting {what}: {source}")]
    Thread {
        /// Which.
        what: &'static str,
        /// The error.
        source: std::io::Error,
    },
}

/// The arm's setup errors keep the names they have for every arm: its RTDE link's, a fault's,
/// "not ready"; the rest are the UR's own.
impl From<UrError> for SetupError {
    fn from(e: UrError) -> Self {
        match e {
            UrError::Rtde(e) => SetupError::Rtde(e),
            UrError::Fault(f) => SetupError::Fault(f),
            UrError::NotReady(m) => SetupError::RobotNotReady(m),
            e => SetupError::Ur(e),
        }
    }
}
