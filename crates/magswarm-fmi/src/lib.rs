//! What an FMU crate uses: the version-neutral model interface ([`magswarm_fmi_core`],
//! re-exported here) and both shells, FMI 2.0 ([`fmi2`]) and FMI 3.0 ([`fmi3`]), behind one
//! macro and one function.
//!
//! - [`export_fmu!`] emits every `fmi2*` and `fmi3*` symbol for a model into the FMU's
//!   library (the names do not clash, so one `.so` serves both versions: the FMI 2.0 FMU
//!   packs it under `binaries/linux64/`, the FMI 3.0 FMU under `binaries/x86_64-linux/`);
//! - [`model_description_xml`] writes the XML of either version from the one table.
//!
//! ```ignore
//! #[cfg(feature = "export")]
//! magswarm_fmi::export_fmu!(my_crate::Plant);
//! let xml = magswarm_fmi::model_description_xml::<Plant>(FmiVersion::V3, &Default::default());
//! ```

#![warn(missing_docs)]

pub use magswarm_fmi2 as fmi2;
pub use magswarm_fmi3 as fmi3;
pub use magswarm_fmi_core::*;

/// The FMI major version of an FMU.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum FmiVersion {
    /// FMI 2.0 (Co-Simulation and Model Exchange in one FMU).
    #[default]
    V2,
    /// FMI 3.0 (Co-Simulation and Model Exchange in one FMU).
    V3,
}

impl FmiVersion {
    /// From the major version number (2 or 3).
    pub fn from_major(major: u32) -> Option<FmiVersion> {
        match major {
            2 => Some(FmiVersion::V2),
            3 => Some(FmiVersion::V3),
            _ => None,
        }
    }

    /// The major version number.
    pub fn major(self) -> u32 {
        match self {
            FmiVersion::V2 => 2,
            FmiVersion::V3 => 3,
        }
    }

    /// `"2.0"` or `"3.0"`, as `fmiVersion` spells it.
    pub fn as_str(self) -> &'static str {
        match self {
            FmiVersion::V2 => "2.0",
            FmiVersion::V3 => "3.0",
        }
    }
}

impl std::fmt::Display for FmiVersion {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "FMI {}", self.as_str())
    }
}

/// The modelDescription.xml of model `M` in FMI `version`. Panics with every problem listed
/// if the table is invalid (a programming error that must stop packaging).
pub fn model_description_xml<M: FmuModel>(
    version: FmiVersion,
    options: &xml::XmlOptions,
) -> String {
    match version {
        FmiVersion::V2 => fmi2::model_description_xml::<M>(options),
        FmiVersion::V3 => fmi3::model_description_xml::<M>(options),
    }
}

/// The GUID (FMI 2.0) or instantiation token (FMI 3.0) of model `M` in FMI `version`: FMI
/// 3.0's table carries the independent variable as well, so the two differ.
pub fn token<M: FmuModel>(version: FmiVersion) -> String {
    match version {
        FmiVersion::V2 => guid::guid::<M>(),
        FmiVersion::V3 => guid::guid_of(fmi3::shell::info_of::<M>()),
    }
}

/// Emit every FMI 2.0 and FMI 3.0 symbol for a type implementing [`FmuModel`], and
/// `fmu_model_description` / `fmu_free_string` ([`export_describe!`]) with `$describe`
/// mapping (JSON of the defaults to bake in, [`FmiVersion`]) to the XML.
///
/// ```ignore
/// magswarm_fmi::export_fmu!(Plant, |json: Option<&str>, v| Some(describe(json?, v)));
/// ```
#[macro_export]
macro_rules! export_fmu {
    ($model:ty, $describe:expr) => {
        $crate::fmi2::export_fmi2!($model);
        $crate::fmi3::export_fmi3!($model);
        $crate::export_describe!(|json: Option<&str>, major: u32| {
            let version = $crate::FmiVersion::from_major(major)?;
            ($describe)(json, version)
        });
    };
}
