//! Loading a packaged `.fmu` as any importer does: unzip, parse `modelDescription.xml`, load
//! `binaries/<platform>/<modelIdentifier>.so` (FMI 2.0: `linux64`; FMI 3.0: `x86_64-linux`).
//! Both versions load into the same [`Fmu`]; what differs is in [`v2`] and [`v3`].

use std::collections::HashMap;
use std::ffi::CString;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use fmi::fmi2::binding::Fmi2Binding;
use fmi::fmi3::binding::Fmi3Binding;
use fmi::traits::FmiImport;
pub use magswarm_fmi::FmiVersion;

use crate::error::{CosimError, Result};

mod v2;
mod v3;

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

/// Causality of a variable: the same enum the export shells use.
pub use magswarm_fmi::Causality;

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

/// Capability flags of the CoSimulation element (FMI 3.0 spells them `...FMUState`,
/// `providesDirectionalDerivatives`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Capabilities {
    /// `canGetAndSetFMUstate`.
    pub get_set_state: bool,
    /// `canSerializeFMUstate`.
    pub serialize_state: bool,
    /// `providesDirectionalDerivative(s)`.
    pub directional_derivative: bool,
    /// `canHandleVariableCommunicationStepSize`.
    pub variable_step: bool,
    /// `canBeInstantiatedOnlyOncePerProcess`.
    pub only_once_per_process: bool,
}

/// The `fmi` crate's import of either version (it owns the unpacked folder).
pub(crate) enum Import {
    V2(fmi::fmi2::import::Fmi2Import),
    V3(fmi::fmi3::import::Fmi3Import),
}

impl Import {
    fn archive_path(&self) -> &Path {
        match self {
            Import::V2(i) => i.archive_path(),
            Import::V3(i) => i.archive_path(),
        }
    }

    fn shared_lib_path(&self, id: &str) -> Option<PathBuf> {
        match self {
            Import::V2(i) => i.shared_lib_path(id).ok(),
            Import::V3(i) => i.shared_lib_path(id).ok(),
        }
    }
}

/// The function table of the loaded library (the `fmi` crate's raw bindings), for
/// benchmarks that call the C ABI directly ([`crate::FmuSlave::api`]).
// One per loaded FMU, inside its shared handle: the size difference costs nothing, a box
// would cost an indirection per call.
#[allow(clippy::large_enum_variant)]
pub enum Api {
    /// FMI 2.0.
    V2(Fmi2Binding),
    /// FMI 3.0.
    V3(Fmi3Binding),
}

/// What a version's loader found.
pub(crate) struct Loaded {
    pub(crate) api: Api,
    pub(crate) import: Import,
    pub(crate) model_identifier: String,
    pub(crate) guid: String,
    pub(crate) resource_location: String,
    pub(crate) variables: Vec<Variable>,
    pub(crate) caps: Capabilities,
}

pub(crate) struct FmuInner {
    // Field order is drop order: the library is closed before its directory is removed.
    pub(crate) api: Api,
    pub(crate) import: Import,
    /// Keeps the unpacked folder registered for removal at exit or on a signal until here.
    pub(crate) _registration: crate::extract::Registration,
    pub(crate) version: FmiVersion,
    pub(crate) path: PathBuf,
    pub(crate) model_identifier: String,
    pub(crate) guid: CString,
    pub(crate) resource_uri: CString,
    pub(crate) variables: Vec<Variable>,
    pub(crate) by_name: HashMap<String, usize>,
    pub(crate) caps: Capabilities,
}

/// An imported FMU, FMI 2.0 or 3.0: the archive unpacked into a temporary directory (removed
/// when the last clone of this handle and the last [`FmuSlave`](crate::FmuSlave) made from it are dropped),
/// its modelDescription.xml parsed and its shared library loaded once.
///
/// Unpacking is [`crate::extract`]'s (checked entry by entry), parsing and loading the `fmi`
/// crate's (`Fmi2Import`, `Fmi3Import` and their bindings, `libloading` under the hood).
/// Cheap to clone.
#[derive(Clone)]
pub struct Fmu {
    pub(crate) inner: Arc<FmuInner>,
}

impl fmt::Debug for Fmu {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Fmu")
            .field("path", &self.inner.path)
            .field("version", &self.inner.version)
            .field("model_identifier", &self.inner.model_identifier)
            .field("guid", &self.inner.guid)
            .field("extracted", &self.extracted_dir())
            .finish()
    }
}

/// Refuse a library that lacks symbols this importer calls.
fn refuse_missing(path: &Path, missing: &[&str]) -> Result<()> {
    if missing.is_empty() {
        Ok(())
    } else {
        Err(CosimError::Unsupported(format!(
            "{}: the library does not export {}",
            path.display(),
            missing.join(", ")
        )))
    }
}

/// The `fmiVersion` attribute of a modelDescription.xml (`2.0`, `3.0`, ...).
fn fmi_version_attr(xml: &str) -> Option<String> {
    let s = xml.find("fmiVersion=")? + "fmiVersion=".len();
    let quote = xml[s..].chars().next()?;
    let rest = &xml[s + 1..];
    Some(rest[..rest.find(quote)?].trim().to_string())
}

impl Fmu {
    /// Import `path` (a `.fmu`): unzip, parse modelDescription.xml, load the library for this
    /// platform and check that it exports the API of its FMI version (2.0 or 3.0,
    /// Co-Simulation).
    pub fn load(path: impl AsRef<Path>) -> Result<Fmu> {
        let path = path.as_ref().to_path_buf();
        let (unpacked, xml) = crate::extract::unpack(&path)?;
        let (dir, registration) = unpacked.into_parts();
        let version = match fmi_version_attr(&xml).as_deref() {
            Some(v) if v.starts_with("3.") => FmiVersion::V3,
            Some(v) if v.starts_with("2.") => FmiVersion::V2,
            // No attribute to be found: the XML parser names what is wrong with it.
            None => FmiVersion::V2,
            other => {
                return Err(CosimError::Unsupported(format!(
                    "{}: fmiVersion {other:?}, this importer runs FMI 2.0 and 3.0",
                    path.display()
                )))
            }
        };
        let loaded = match version {
            FmiVersion::V2 => v2::load(&path, dir, &xml)?,
            FmiVersion::V3 => v3::load(&path, dir, &xml)?,
        };
        let by_name = loaded
            .variables
            .iter()
            .enumerate()
            .map(|(i, v)| (v.name.clone(), i))
            .collect();
        let nul = |what: &str| CosimError::Usage(format!("{what} contains a NUL byte"));
        let guid = CString::new(loaded.guid).map_err(|_| nul("guid"))?;
        let resource_uri = CString::new(loaded.resource_location).map_err(|_| nul("path"))?;
        Ok(Fmu {
            inner: Arc::new(FmuInner {
                api: loaded.api,
                import: loaded.import,
                _registration: registration,
                version,
                path,
                model_identifier: loaded.model_identifier,
                guid,
                resource_uri,
                variables: loaded.variables,
                by_name,
                caps: loaded.caps,
            }),
        })
    }

    /// The FMI version of the FMU.
    pub fn fmi_version(&self) -> FmiVersion {
        self.inner.version
    }

    /// The .fmu this was imported from.
    pub fn path(&self) -> &Path {
        &self.inner.path
    }

    /// Where the archive was unpacked.
    pub fn extracted_dir(&self) -> &Path {
        self.inner.import.archive_path()
    }

    /// The shared library that was loaded (`binaries/<platform>/<id>.so` in the unpacked FMU).
    pub fn library_path(&self) -> PathBuf {
        self.extracted_dir().join(
            self.inner
                .import
                .shared_lib_path(&self.inner.model_identifier)
                .unwrap_or_default(),
        )
    }

    /// The resource location passed to instances (FMI 2.0: a `file://` URI; FMI 3.0: the
    /// folder's path with a trailing separator).
    pub fn resource_uri(&self) -> &str {
        self.inner.resource_uri.to_str().unwrap_or_default()
    }

    /// `modelIdentifier` of the CoSimulation element.
    pub fn model_identifier(&self) -> &str {
        &self.inner.model_identifier
    }

    /// The GUID (FMI 2.0) or instantiation token (FMI 3.0).
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
}
