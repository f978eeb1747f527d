//! Loading a packaged `.fmu` as any importer does: unzip, parse `modelDescription.xml`,
//! load `binaries/linux64/<modelIdentifier>.so`.

use std::collections::HashMap;
use std::ffi::CString;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use fmi::fmi2::binding::Fmi2Binding;
use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::schema::{self as schema, Fmi2ModelDescription, ScalarVariableElement};
use fmi::traits::FmiImport;

use super::error::{CosimError, Result};
use super::slave::{FmuSlave, SlaveOptions};

/// Type of a scalar variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum VarType {
    /// `Real`.
    Real,
    /// `Integer`.
    Integer,
    /// `Boolean`.
    Boolean,
    /// `String`.
    String,
    /// `Enumeration`.
    Enumeration,
}

impl VarType {
    /// The XML element name.
    pub fn name(self) -> &'static str {
        match self {
            VarType::Real => "Real",
            VarType::Integer => "Integer",
            VarType::Boolean => "Boolean",
            VarType::String => "String",
            VarType::Enumeration => "Enumeration",
        }
    }
}

impl fmt::Display for VarType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Causality of a scalar variable: the same FMI 2.0 enum the export shell uses.
pub use magswarm_fmi2::Causality;

/// Start value from modelDescription.xml (String start values are not parsed by the `fmi`
/// crate's schema and are reported as `None`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Start {
    /// Real start.
    Real(f64),
    /// Integer start.
    Integer(i32),
    /// Boolean start.
    Boolean(bool),
}

/// One scalar variable of the FMU, as modelDescription.xml declares it.
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    /// Name.
    pub name: String,
    /// Value reference.
    pub vr: u32,
    /// Type.
    pub var_type: VarType,
    /// Causality.
    pub causality: Causality,
    /// Description.
    pub description: Option<String>,
    /// Start value, where the XML has one (not for Strings).
    pub start: Option<Start>,
    /// 1-based index in ModelVariables (as ModelStructure refers to it).
    pub index: usize,
}

/// Capability flags of the CoSimulation element.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Capabilities {
    /// `canGetAndSetFMUstate`.
    pub get_set_state: bool,
    /// `canSerializeFMUstate`.
    pub serialize_state: bool,
    /// `providesDirectionalDerivative`.
    pub directional_derivative: bool,
    /// `canHandleVariableCommunicationStepSize`.
    pub variable_step: bool,
    /// `canBeInstantiatedOnlyOncePerProcess`.
    pub only_once_per_process: bool,
}

pub(crate) struct FmuInner {
    // Field order is drop order: the library is closed before its directory is removed.
    pub(crate) binding: Fmi2Binding,
    pub(crate) import: Fmi2Import,
    /// Keeps the unpacked folder registered for removal at exit or on a signal until here.
    pub(crate) _registration: super::extract::Registration,
    pub(crate) path: PathBuf,
    pub(crate) model_identifier: String,
    pub(crate) guid: CString,
    pub(crate) resource_uri: CString,
    pub(crate) variables: Vec<Variable>,
    pub(crate) by_name: HashMap<String, usize>,
    pub(crate) caps: Capabilities,
}

/// An imported FMU: the archive unpacked into a temporary directory (removed when the last
/// clone of this handle and the last [`FmuSlave`] made from it are dropped), its
/// modelDescription.xml parsed and its shared library loaded once.
///
/// Unpacking and parsing are the `fmi` crate's ([`fmi::import::from_path`], which uses the
/// `zip` crate, and [`Fmi2Import`]); the library is loaded by [`FmiImport::binding`]
/// (`libloading` under the hood). Cheap to clone.
#[derive(Clone)]
pub struct Fmu {
    pub(crate) inner: Arc<FmuInner>,
}

impl fmt::Debug for Fmu {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Fmu")
            .field("path", &self.inner.path)
            .field("model_identifier", &self.inner.model_identifier)
            .field("guid", &self.inner.guid)
            .field("extracted", &self.extracted_dir())
            .finish()
    }
}

/// Every FMI 2.0 function a Co-Simulation importer may call, checked at load so that no call
/// can hit a missing symbol (the `fmi` crate's bindings panic on those).
macro_rules! check_symbols {
    ($b:expr, $missing:expr, $($sym:ident),* $(,)?) => {
        $( if $b.$sym.is_err() { $missing.push(stringify!($sym)); } )*
    };
}

impl Fmu {
    /// Import `path` (a `.fmu`): unzip, parse modelDescription.xml, load the library for this
    /// platform and check that it exports the FMI 2.0 Co-Simulation API.
    pub fn load(path: impl AsRef<Path>) -> Result<Fmu> {
        let path = path.as_ref().to_path_buf();
        // Unpacked by `extract` (checked entry by entry, removed on every way out), then
        // handed to the `fmi` crate's import type.
        let (unpacked, xml) = super::extract::unpack(&path)?;
        let (dir, registration) = unpacked.into_parts();
        let import = Fmi2Import::new(dir, &xml).map_err(|source| CosimError::Import {
            path: path.clone(),
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
                path: path.clone(),
                source,
            })?;
        let mut missing = Vec::new();
        check_symbols!(
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
        if !missing.is_empty() {
            return Err(CosimError::Unsupported(format!(
                "{}: the library does not export {}",
                path.display(),
                missing.join(", ")
            )));
        }
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
        let by_name = variables
            .iter()
            .enumerate()
            .map(|(i, v)| (v.name.clone(), i))
            .collect();
        let nul = |what: &str| CosimError::Usage(format!("{what} contains a NUL byte"));
        let guid = CString::new(md.guid.clone()).map_err(|_| nul("guid"))?;
        let resource_uri =
            CString::new(import.canonical_resource_path_string()).map_err(|_| nul("path"))?;
        Ok(Fmu {
            inner: Arc::new(FmuInner {
                binding,
                import,
                _registration: registration,
                path,
                model_identifier,
                guid,
                resource_uri,
                variables,
                by_name,
                caps,
            }),
        })
    }

    /// The .fmu this was imported from.
    pub fn path(&self) -> &Path {
        &self.inner.path
    }

    /// Where the archive was unpacked.
    pub fn extracted_dir(&self) -> &Path {
        self.inner.import.archive_path()
    }

    /// The shared library that was loaded (`binaries/linux64/<id>.so` in the unpacked FMU).
    pub fn library_path(&self) -> PathBuf {
        self.extracted_dir().join(
            self.inner
                .import
                .shared_lib_path(&self.inner.model_identifier)
                .unwrap_or_default(),
        )
    }

    /// The `fmi2FMUResourceLocation` passed to instances (a `file://` URI).
    pub fn resource_uri(&self) -> &str {
        self.inner.resource_uri.to_str().unwrap_or_default()
    }

    /// The parsed modelDescription.xml (the `fmi` crate's schema types).
    pub fn model_description(&self) -> &Fmi2ModelDescription {
        self.inner.import.model_description()
    }

    /// `modelIdentifier` of the CoSimulation element.
    pub fn model_identifier(&self) -> &str {
        &self.inner.model_identifier
    }

    /// The GUID.
    pub fn guid(&self) -> &str {
        self.inner.guid.to_str().unwrap_or_default()
    }

    /// Capability flags.
    pub fn capabilities(&self) -> Capabilities {
        self.inner.caps
    }

    /// All scalar variables, in ModelVariables order.
    pub fn variables(&self) -> &[Variable] {
        &self.inner.variables
    }

    /// The variable called `name`.
    pub fn variable(&self, name: &str) -> Result<&Variable> {
        self.inner
            .by_name
            .get(name)
            .map(|&i| &self.inner.variables[i])
            .ok_or_else(|| CosimError::UnknownVariable(name.to_string()))
    }

    /// The value reference of `name`, checking its type.
    pub fn vr_of(&self, name: &str, var_type: VarType) -> Result<u32> {
        let v = self.variable(name)?;
        if v.var_type != var_type {
            return Err(CosimError::VariableType {
                name: name.to_string(),
                expected: var_type.name(),
                found: v.var_type.name(),
            });
        }
        Ok(v.vr)
    }

    /// The value reference of the Real variable `name`.
    pub fn real_vr(&self, name: &str) -> Result<u32> {
        self.vr_of(name, VarType::Real)
    }

    /// Value references of several Real variables.
    pub fn real_vrs(&self, names: &[&str]) -> Result<Vec<u32>> {
        names.iter().map(|n| self.real_vr(n)).collect()
    }

    /// The Real start value of `name` from the XML.
    pub fn real_start(&self, name: &str) -> Result<Option<f64>> {
        self.real_vr(name)?;
        Ok(match self.variable(name)?.start {
            Some(Start::Real(x)) => Some(x),
            _ => None,
        })
    }

    /// Instantiate a Co-Simulation slave (shorthand for [`FmuSlave::instantiate`]).
    pub fn instantiate(&self, instance_name: &str, options: SlaveOptions) -> Result<FmuSlave> {
        FmuSlave::instantiate(self, instance_name, options)
    }
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
