//! FMI 2.0: `Fmi2Import`, its binding, every Co-Simulation symbol checked at load.

use std::path::Path;

use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::schema::{self as schema, Fmi2ModelDescription, ScalarVariableElement};
use fmi::traits::FmiImport;

use super::Api;
use super::{Capabilities, Causality, Import, Loaded, Start, VarType, Variable};
use crate::error::{CosimError, Result};

/// Load an unpacked FMI 2.0 FMU.
pub(crate) fn load(path: &Path, dir: tempfile::TempDir, xml: &str) -> Result<Loaded> {
    let import = Fmi2Import::new(dir, xml).map_err(|source| CosimError::Import {
        path: path.to_path_buf(),
        source,
    })?;
    let md = import.model_description();
    if md.fmi_version.trim() != "2.0" {
        return Err(CosimError::Unsupported(format!(
            "{}: fmiVersion {:?}, this importer runs FMI 2.0",
            path.display(),
            md.fmi_version
        )));
    }
    let cs = md.co_simulation.as_ref().ok_or_else(|| {
        CosimError::Unsupported(format!(
            "{}: no CoSimulation element (not a Co-Simulation FMU)",
            path.display()
        ))
    })?;
    let caps = Capabilities {
        get_set_state: cs.can_get_and_set_fmu_state.unwrap_or(false),
        serialize_state: cs.can_serialize_fmu_state.unwrap_or(false),
        directional_derivative: cs.provides_directional_derivative.unwrap_or(false),
        variable_step: cs
            .can_handle_variable_communication_step_size
            .unwrap_or(false),
        only_once_per_process: cs
            .can_be_instantiated_only_once_per_process
            .unwrap_or(false),
    };
    let model_identifier = cs.model_identifier.clone();
    let binding = import
        .binding(&model_identifier)
        .map_err(|source| CosimError::Import {
            path: path.to_path_buf(),
            source,
        })?;
    let mut missing = Vec::new();
    crate::check_symbols!(
        binding,
        missing,
        fmi2GetTypesPlatform,
        fmi2GetVersion,
        fmi2SetDebugLogging,
        fmi2Instantiate,
        fmi2FreeInstance,
        fmi2SetupExperiment,
        fmi2EnterInitializationMode,
        fmi2ExitInitializationMode,
        fmi2Terminate,
        fmi2Reset,
        fmi2GetReal,
        fmi2GetInteger,
        fmi2GetBoolean,
        fmi2GetString,
        fmi2SetReal,
        fmi2SetInteger,
        fmi2SetBoolean,
        fmi2SetString,
        fmi2GetFMUstate,
        fmi2SetFMUstate,
        fmi2FreeFMUstate,
        fmi2SerializedFMUstateSize,
        fmi2SerializeFMUstate,
        fmi2DeSerializeFMUstate,
        fmi2GetDirectionalDerivative,
        fmi2SetRealInputDerivatives,
        fmi2GetRealOutputDerivatives,
        fmi2DoStep,
        fmi2CancelStep,
        fmi2GetStatus,
        fmi2GetRealStatus,
        fmi2GetIntegerStatus,
        fmi2GetBooleanStatus,
        fmi2GetStringStatus,
    );
    super::refuse_missing(path, &missing)?;
    // SAFETY: the symbol exists (checked above) and returns a static string.
    let version = unsafe { std::ffi::CStr::from_ptr(binding.fmi2GetVersion()) }
        .to_string_lossy()
        .into_owned();
    if version != "2.0" {
        return Err(CosimError::Unsupported(format!(
            "{}: fmi2GetVersion() = {version:?}",
            path.display()
        )));
    }
    let variables = variables_of(md);
    let guid = md.guid.clone();
    let resource_location = import.canonical_resource_path_string();
    Ok(Loaded {
        api: Api::V2(binding),
        import: Import::V2(import),
        model_identifier,
        guid,
        resource_location,
        variables,
        caps,
    })
}

fn variables_of(md: &Fmi2ModelDescription) -> Vec<Variable> {
    md.model_variables
        .variables
        .iter()
        .enumerate()
        .map(|(i, sv)| {
            let (var_type, start) = match &sv.elem {
                ScalarVariableElement::Real(r) => (VarType::Real, r.start.map(Start::Real)),
                ScalarVariableElement::Integer(x) => {
                    (VarType::Integer, x.start.map(Start::Integer))
                }
                ScalarVariableElement::Boolean(b) => {
                    (VarType::Boolean, b.start.map(Start::Boolean))
                }
                ScalarVariableElement::String => (VarType::String, None),
                ScalarVariableElement::Enumeration => (VarType::Enumeration, None),
            };
            let causality = match sv.causality {
                schema::Causality::Parameter => Causality::Parameter,
                schema::Causality::CalculatedParameter => Causality::CalculatedParameter,
                schema::Causality::Input => Causality::Input,
                schema::Causality::Output => Causality::Output,
                schema::Causality::Local => Causality::Local,
                schema::Causality::Independent => Causality::Independent,
            };
            Variable {
                name: sv.name.clone(),
                vr: sv.value_reference,
                var_type,
                causality,
                description: sv.description.clone(),
                start,
                index: i + 1,
            }
        })
        .collect()
}
