//! FMI 3.0: `Fmi3Import`, its binding, every symbol this importer calls checked at load.

use std::path::Path;

use fmi::fmi3::import::Fmi3Import;
use fmi::fmi3::schema::{
    self as schema, AbstractVariableTrait, Fmi3ModelDescription, InitializableVariableTrait,
};
use fmi::traits::FmiImport;

use super::Api;
use super::{Capabilities, Causality, Import, Loaded, Start, VarType, Variable};
use crate::error::{CosimError, Result};

/// Load an unpacked FMI 3.0 FMU.
pub(crate) fn load(path: &Path, dir: tempfile::TempDir, xml: &str) -> Result<Loaded> {
    let import = Fmi3Import::new(dir, xml).map_err(|source| CosimError::Import {
        path: path.to_path_buf(),
        source,
    })?;
    let md = import.model_description();
    let cs = md.co_simulation.as_ref().ok_or_else(|| {
        CosimError::Unsupported(format!(
            "{}: no CoSimulation element (not a Co-Simulation FMU)",
            path.display()
        ))
    })?;
    let caps = Capabilities {
        get_set_state: cs.can_get_and_set_fmu_state.unwrap_or(false),
        serialize_state: cs.can_serialize_fmu_state.unwrap_or(false),
        directional_derivative: cs.provides_directional_derivatives.unwrap_or(false),
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
        fmi3GetVersion,
        fmi3SetDebugLogging,
        fmi3InstantiateCoSimulation,
        fmi3FreeInstance,
        fmi3EnterInitializationMode,
        fmi3ExitInitializationMode,
        fmi3Terminate,
        fmi3Reset,
        fmi3GetFloat64,
        fmi3GetInt32,
        fmi3GetBoolean,
        fmi3GetString,
        fmi3SetFloat64,
        fmi3SetInt32,
        fmi3SetBoolean,
        fmi3SetString,
        fmi3GetFMUState,
        fmi3SetFMUState,
        fmi3FreeFMUState,
        fmi3SerializedFMUStateSize,
        fmi3SerializeFMUState,
        fmi3DeserializeFMUState,
        fmi3GetDirectionalDerivative,
        fmi3DoStep,
    );
    super::refuse_missing(path, &missing)?;
    // SAFETY: the symbol exists (checked above) and returns a static string.
    let version = unsafe { std::ffi::CStr::from_ptr(binding.fmi3GetVersion()) }
        .to_string_lossy()
        .into_owned();
    if !version.starts_with("3.") {
        return Err(CosimError::Unsupported(format!(
            "{}: fmi3GetVersion() = {version:?}",
            path.display()
        )));
    }
    let variables = variables_of(md);
    let guid = md.instantiation_token.clone();
    // FMI 3.0 passes the resources folder as a path with a trailing separator.
    let mut resource_location = import.canonical_resource_path_string();
    if !resource_location.ends_with(std::path::MAIN_SEPARATOR) {
        resource_location.push(std::path::MAIN_SEPARATOR);
    }
    Ok(Loaded {
        api: Api::V3(binding),
        import: Import::V3(import),
        model_identifier,
        guid,
        resource_location,
        variables,
        caps,
    })
}

fn first<T: Copy>(v: &impl InitializableVariableTrait<StartType = T>) -> Option<T> {
    v.start().and_then(|s| s.first().copied())
}

fn variables_of(md: &Fmi3ModelDescription) -> Vec<Variable> {
    use schema::Variable as V;
    md.model_variables
        .variables
        .iter()
        .enumerate()
        .map(|(i, var)| {
            let (var_type, start) = match var {
                V::Float64(x) => (VarType::Real, first(x).map(Start::Real)),
                V::Float32(x) => (VarType::Real, first(x).map(|v| Start::Real(v.into()))),
                V::Int32(x) => (VarType::Integer, first(x).map(Start::Integer)),
                V::Boolean(x) => (VarType::Boolean, first(x).map(Start::Boolean)),
                V::String(_) => (VarType::String, None),
                // Other types are listed under the closest FMI 2.0 kind without a start;
                // this importer reads and writes Float64, Int32, Boolean and String only.
                V::Int8(_)
                | V::UInt8(_)
                | V::Int16(_)
                | V::UInt16(_)
                | V::UInt32(_)
                | V::Int64(_)
                | V::UInt64(_) => (VarType::Integer, None),
                V::Binary(_) | V::Clock(_) => (VarType::Enumeration, None),
            };
            let a: &dyn AbstractVariableTrait = match var {
                V::Int8(x) => x,
                V::UInt8(x) => x,
                V::Int16(x) => x,
                V::UInt16(x) => x,
                V::Int32(x) => x,
                V::UInt32(x) => x,
                V::Int64(x) => x,
                V::UInt64(x) => x,
                V::Float32(x) => x,
                V::Float64(x) => x,
                V::Boolean(x) => x,
                V::String(x) => x,
                V::Binary(x) => x,
                V::Clock(x) => x,
            };
            let causality = match a.causality() {
                schema::Causality::Parameter | schema::Causality::StructuralParameter => {
                    Causality::Parameter
                }
                schema::Causality::CalculatedParameter => Causality::CalculatedParameter,
                schema::Causality::Input => Causality::Input,
                schema::Causality::Output => Causality::Output,
                schema::Causality::Local | schema::Causality::Dependent => Causality::Local,
                schema::Causality::Independent => Causality::Independent,
            };
            Variable {
                name: a.name().to_string(),
                vr: a.value_reference(),
                var_type,
                causality,
                description: a.description().map(str::to_string),
                start,
                index: i + 1,
            }
        })
        .collect()
}
