//! The model behind the shells: the [`FmuModel`] trait and what instantiation tells it.
//!
//! Nothing here names an FMI version. The FMI 2.0 shell (`magswarm-fmi2`) and the FMI 3.0
//! shell (`magswarm-fmi3`) both call these hooks, after their own checks of pointers, the
//! state machine, causality and finiteness, and turn the results (and panics) into their
//! status codes and log messages. A model is written once and exported in both versions.
//!
//! | hook | FMI 2.0 | FMI 3.0 |
//! | --- | --- | --- |
//! | [`FmuModel::instantiate`] | `fmi2Instantiate`, `fmi2Reset` | `fmi3Instantiate*`, `fmi3Reset` |
//! | [`FmuModel::setup_experiment`] | `fmi2SetupExperiment` | `fmi3EnterInitializationMode` (first) |
//! | [`FmuModel::step`] | `fmi2DoStep` | `fmi3DoStep` |
//! | [`FmuModel::jacobian`] | `fmi2GetDirectionalDerivative` | `fmi3GetDirectionalDerivative`, `fmi3GetAdjointDerivative` |
//! | [`FmuModel::get_derivatives`] | `fmi2GetDerivatives` | `fmi3GetContinuousStateDerivatives` |
//!
//! Events: the models of this shell have no event indicators and no discrete states. What
//! they do have are envelope events (inputs leaving or re-entering the range the model was
//! validated on): a model reports them with [`Ctx::warning`] (once per excursion) from
//! [`FmuModel::step`] in Co-Simulation and from [`FmuModel::completed_integrator_step`] in
//! Model Exchange, so both interfaces and both versions report them the same way.

use serde::{de::DeserializeOwned, Serialize};
use std::path::Path;

use crate::info::ModelInfo;
use crate::log::Ctx;
use crate::status::ModelError;
use crate::variable::{Causality, VarType};

/// What instantiation (`fmi2Instantiate`, `fmi3Instantiate*`) tells the model.
#[derive(Debug, Clone)]
pub struct InstantiateArgs<'a> {
    /// The importer's name for this instance.
    pub instance_name: &'a str,
    /// The resource location exactly as passed (FMI 2.0: a `file:` URI; FMI 3.0: a path
    /// ending in a separator), if any.
    pub resource_location: Option<&'a str>,
    /// The same decoded to a local directory, if it was a decodable `file:` URI or path.
    pub resource_dir: Option<&'a Path>,
    /// The `resources/` folder next to this binary's `binaries/` folder in the unpacked FMU,
    /// if there is one (see [`crate::uri::packaged_resources`]): what the FMU was packaged
    /// with, whatever the importer passed.
    pub packaged_resources: Option<&'a Path>,
    /// `visible` (ignored by the shell).
    pub visible: bool,
    /// `loggingOn` at instantiation.
    pub logging_on: bool,
}

/// The model behind the shells. No FMI types appear here: a shell checks pointers, the
/// state machine, causality rules and finiteness before any of these is called, and turns
/// results (and panics) into its status codes plus a log message.
///
/// `Clone` is the FMU state: getting an FMU state clones the model. `Send` because importers
/// may drive an instance from a different thread than the one that created it.
pub trait FmuModel: Clone + Send + Sized + 'static {
    /// The static description (also the source of `modelDescription.xml` and the GUID).
    fn model_info() -> &'static ModelInfo;

    /// Construct a fresh instance with every variable at its start value. Also used by
    /// reset, so it must not depend on anything but its arguments.
    fn instantiate(ctx: &mut Ctx<'_>, args: &InstantiateArgs<'_>) -> Result<Self, ModelError>;

    /// The experiment: tolerance, start and stop time (`None`: not defined). FMI 2.0 calls it
    /// at `fmi2SetupExperiment`, FMI 3.0 at `fmi3EnterInitializationMode` just before
    /// [`FmuModel::enter_initialization_mode`].
    fn setup_experiment(
        &mut self,
        _ctx: &mut Ctx<'_>,
        _tolerance: Option<f64>,
        _start_time: f64,
        _stop_time: Option<f64>,
    ) -> Result<(), ModelError> {
        Ok(())
    }

    /// Entering initialisation mode.
    fn enter_initialization_mode(&mut self, _ctx: &mut Ctx<'_>) -> Result<(), ModelError> {
        Ok(())
    }

    /// Leaving initialisation mode: compute calculated parameters and initial outputs.
    fn exit_initialization_mode(&mut self, _ctx: &mut Ctx<'_>) -> Result<(), ModelError> {
        Ok(())
    }

    /// Co-Simulation: advance from `current_time` by `step` (> 0, finite, contiguous with
    /// the previous step; checked by the shell).
    fn step(&mut self, ctx: &mut Ctx<'_>, current_time: f64, step: f64) -> Result<(), ModelError>;

    /// Termination.
    fn terminate(&mut self, _ctx: &mut Ctx<'_>) -> Result<(), ModelError> {
        Ok(())
    }

    /// Value of a Real variable (any causality). `&mut self` so outputs may be computed lazily.
    fn get_real(&mut self, vr: u32) -> Result<f64, ModelError>;
    /// Values of several Real variables (`fmi2GetReal`, `fmi3GetFloat64`): the shell has
    /// checked every reference (a Real of the table, not the independent variable). The
    /// default asks [`FmuModel::get_real`] for each; a model overrides it to do once what
    /// every output shares (a master reads all its outputs in one call). `Err` names the
    /// reference that failed.
    fn get_reals(&mut self, vrs: &[u32], out: &mut [f64]) -> Result<(), (u32, ModelError)> {
        for (&vr, o) in vrs.iter().zip(out.iter_mut()) {
            *o = self.get_real(vr).map_err(|e| (vr, e))?;
        }
        Ok(())
    }
    /// Set a Real variable. The shell has already checked that the value is finite and that
    /// the variable may be set now; warnings (e.g. outside the validated envelope) go through
    /// [`Ctx::warning`].
    fn set_real(&mut self, ctx: &mut Ctx<'_>, vr: u32, value: f64) -> Result<(), ModelError>;

    /// Value of an Integer variable.
    fn get_integer(&mut self, vr: u32) -> Result<i32, ModelError> {
        Err(ModelError::unknown_vr(VarType::Integer, vr))
    }
    /// Set an Integer variable.
    fn set_integer(&mut self, _ctx: &mut Ctx<'_>, vr: u32, _value: i32) -> Result<(), ModelError> {
        Err(ModelError::unknown_vr(VarType::Integer, vr))
    }
    /// Value of a Boolean variable.
    fn get_boolean(&mut self, vr: u32) -> Result<bool, ModelError> {
        Err(ModelError::unknown_vr(VarType::Boolean, vr))
    }
    /// Set a Boolean variable.
    fn set_boolean(&mut self, _ctx: &mut Ctx<'_>, vr: u32, _value: bool) -> Result<(), ModelError> {
        Err(ModelError::unknown_vr(VarType::Boolean, vr))
    }
    /// Value of a String variable (the shell keeps the C copy alive for the importer).
    fn get_string(&mut self, vr: u32) -> Result<String, ModelError> {
        Err(ModelError::unknown_vr(VarType::String, vr))
    }
    /// Set a String variable.
    fn set_string(&mut self, _ctx: &mut Ctx<'_>, vr: u32, _value: &str) -> Result<(), ModelError> {
        Err(ModelError::unknown_vr(VarType::String, vr))
    }

    /// The model's complete dynamic state as data, for serialized FMU states
    /// (`fmi2SerializeFMUstate`, `fmi3SerializeFMUState` and their inverses). The shell alone encodes it (CBOR, with a header naming the
    /// GUID, [`FmuModel::STATE_VERSION`], the length and a CRC-32; see [`crate::snapshot`]),
    /// so a model declares *what* its state is and never writes paired byte code. Floats
    /// keep their exact bits, so a restored state replays bit-identically. In-memory states
    /// (`fmi2GetFMUstate`, `fmi3GetFMUState`) do not use it: they are clones of the model.
    type State: Serialize + DeserializeOwned;

    /// Version of [`FmuModel::State`]'s layout, written into every serialized state. Bump it
    /// when the state type changes, so that bytes saved by another build of the FMU are
    /// refused with a message saying so instead of being misread.
    const STATE_VERSION: u32 = 1;

    /// The current dynamic state.
    fn save_state(&self) -> Result<Self::State, ModelError>;

    /// Put `self` (a clone of the live instance, so anything not in the state, like
    /// configuration read from resources, is already there) into `state`. The bytes it came
    /// from passed the shell's checksum, which proves them intact, not honest: validate the
    /// values as if they had been set (`Err` leaves `self` unusable; the shell discards it).
    fn restore_state(&mut self, state: Self::State) -> Result<(), ModelError>;

    /// Whether the instance can save and restore its state (`canGetAndSetFMUstate` and
    /// `canSerializeFMUstate` in the XML). A model driving hardware cannot go back in time:
    /// it sets this to `false`, and both shells refuse the FMU-state functions, naming the
    /// capability, without cloning or serializing the model.
    const CAN_GET_AND_SET_FMU_STATE: bool = true;

    /// Whether the instance answers directional (and, in FMI 3.0, adjoint) derivatives
    /// (`providesDirectionalDerivative(s)`, `providesAdjointDerivatives` in the XML);
    /// `false` makes both shells refuse the calls.
    const PROVIDES_DIRECTIONAL_DERIVATIVE: bool = true;

    /// The Jacobian of the `unknowns` with respect to the `knowns` (inputs and continuous
    /// states) at the current point, row-major (`unknowns.len()` rows of `knowns.len()`
    /// values). The shells derive both directional derivatives (`J v`) and, in FMI 3.0,
    /// adjoint derivatives (`v^T J`) from it. The shell has checked the references exist
    /// and are Reals.
    ///
    /// The default is a central finite difference that perturbs *inputs* on clones (see
    /// [`finite_difference`]); models with states or analytic Jacobians
    /// should override it.
    fn jacobian(&mut self, unknowns: &[u32], knowns: &[u32]) -> Result<Vec<f64>, ModelError> {
        finite_difference(self, unknowns, knowns)
    }

    // ---------------------------------------------------------------------------------
    // Model Exchange (optional). Every hook has a default, so a Co-Simulation-only model
    // (such as a rig) implements none of them and keeps `MODEL_EXCHANGE = false`: the XML
    // then has no `<ModelExchange>` element and instantiating as Model Exchange is refused.
    // ---------------------------------------------------------------------------------

    /// Whether the FMU also offers Model Exchange. When `true`, the continuous
    /// states are the table's variables that a `derivative_of` row points at (in
    /// `<Derivatives>` order, see [`crate::table::continuous_states`]), and the model must
    /// implement [`FmuModel::set_continuous_states`] and return the states and their
    /// derivatives from [`FmuModel::get_real`] (or override the getters below).
    const MODEL_EXCHANGE: bool = false;

    /// Model Exchange: the integrator's time. The shell has checked it is
    /// finite and does not go backwards.
    fn set_time(&mut self, _time: f64) -> Result<(), ModelError> {
        Ok(())
    }

    /// Model Exchange: the continuous states `x`, in the order of [`crate::table::continuous_states`],
    /// already checked finite and of the right length by the shell.
    fn set_continuous_states(&mut self, _ctx: &mut Ctx<'_>, _x: &[f64]) -> Result<(), ModelError> {
        Err(ModelError::error(
            "this model has no continuous states to set",
        ))
    }

    /// Model Exchange: the continuous states. The default reads each state's value reference with
    /// [`FmuModel::get_real`].
    fn get_continuous_states(&mut self, states: &[u32], x: &mut [f64]) -> Result<(), ModelError> {
        for (xi, &vr) in x.iter_mut().zip(states) {
            *xi = self.get_real(vr)?;
        }
        Ok(())
    }

    /// Model Exchange: the derivatives of the continuous states. The default reads each derivative's value reference with
    /// [`FmuModel::get_real`]. A model with a faster joint evaluation overrides it.
    fn get_derivatives(&mut self, derivatives: &[u32], dx: &mut [f64]) -> Result<(), ModelError> {
        for (di, &vr) in dx.iter_mut().zip(derivatives) {
            *di = self.get_real(vr)?;
        }
        Ok(())
    }

    /// Model Exchange: a point the integrator accepted (for models that
    /// check validity or log envelope crossings there). Returning `true` asks the importer
    /// to enter event mode.
    fn completed_integrator_step(&mut self, _ctx: &mut Ctx<'_>) -> Result<bool, ModelError> {
        Ok(false)
    }
}

// A generic fallback for [`FmuModel::jacobian`]. Directional (and in FMI 3.0 adjoint)
// derivatives are declared for every FMU of these shells, so every model needs *some*
// Jacobian. Models with analytic Jacobians (the plant) override it; this fallback perturbs
// each input on two clones and takes a central difference. It cannot perturb states (there
// is no generic way to set them), so a known that is not an input is an error.

/// Central finite differences of `unknowns` with respect to each of the `knowns` (which
/// must be Real inputs): the Jacobian, row-major.
pub fn finite_difference<M: FmuModel>(
    model: &M,
    unknowns: &[u32],
    knowns: &[u32],
) -> Result<Vec<f64>, ModelError> {
    let info = M::model_info();
    for k in knowns {
        let v = info.variables.iter().find(|v| v.vr == *k);
        if !v.is_some_and(|v| v.causality == Causality::Input) {
            return Err(ModelError::error(format!(
                "derivative with respect to value reference {k}: this model only provides \
                 finite differences with respect to inputs"
            )));
        }
    }
    let mut j = vec![0.0; unknowns.len() * knowns.len()];
    let mut base = model.clone();
    let mut ctx = Ctx::silent();
    for (c, &k) in knowns.iter().enumerate() {
        let x = base.get_real(k)?;
        // Cube root of epsilon balances truncation and rounding.
        let h = f64::EPSILON.cbrt() * x.abs().max(1.0);
        let mut plus = model.clone();
        let mut minus = model.clone();
        plus.set_real(&mut ctx, k, x + h)?;
        minus.set_real(&mut ctx, k, x - h)?;
        for (r, &u) in unknowns.iter().enumerate() {
            j[r * knowns.len() + c] = (plus.get_real(u)? - minus.get_real(u)?) / (2.0 * h);
        }
    }
    Ok(j)
}
