//! The controller FMU's state as data ([`magswarm_fmi::FmuModel::State`]): the shell encodes,
//! frames and checks it; restoring validates it like set values.

use super::*;

/// The serialized FMU state of [`MagSwarmPid`]: the parameters, inputs and, once the
/// controller runs, its configuration and state. The shell encodes it; restoring validates it
/// like set values and rebuilds the controller.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MagSwarmPidState {
    /// The plant model the controller assumes.
    pub model: Model,
    /// Value of the `model_file` parameter.
    pub model_file: String,
    /// The configuration before parameter overrides (`config_file`'s or the default).
    pub base_cfg: PidConfig,
    /// Value of the `config_file` parameter.
    pub config_file: String,
    /// Numeric parameters set to other values than their start: (index into PARAMS, value).
    pub overrides: Vec<(usize, f64)>,
    /// Boolean `feedforward`, if set.
    pub feedforward: Option<bool>,
    /// Boolean `conditional_integration`, if set.
    pub conditional_integration: Option<bool>,
    /// Parameters `z_start` \[m\], `omega_start` \[rad/s\].
    pub start: [f64; 2],
    /// Inputs `r1_ref`, `r2_ref` \[m\].
    pub r_ref: [f64; 2],
    /// Inputs `r1`, `r2` \[m\].
    pub y: [f64; 2],
    /// Start time of the experiment (sample 0) \[s\].
    pub t0: f64,
    /// The running controller (None before initialisation).
    pub running: Option<RunningState>,
}

/// The controller part of [`MagSwarmPidState`], present once it has been built.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunningState {
    /// The configuration the controller was built with.
    pub cfg: PidConfig,
    /// The controller's state.
    pub controller: ControllerSnapshot,
    /// Samples taken.
    pub k: u64,
    /// Command outputs (z_m \[m\], omega_m \[rad/s\]).
    pub u: [f64; 2],
    /// Goal outputs \[m\].
    pub goal: [f64; 2],
    /// Distance from the setpoint to the goal \[m\].
    pub distance: f64,
    /// Setpoint the goal outputs belong to \[mm\] (NaN: none yet).
    pub goal_for: [f64; 2],
    /// Output `target_feasible`.
    pub feasible: bool,
}
