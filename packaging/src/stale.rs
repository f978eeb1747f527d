//! The staleness check: is the library about to be packaged the one this build was made from?
//!
//! The CLI links the plant's variable table as an rlib (for the documentation page and the
//! GUID); the `.so` carries its own copy. If the two disagree the library is stale (built from
//! other sources), and the archive would pass here but fail the GUID check of every importer,
//! so packaging stops with the command that fixes it.

use std::path::Path;

use crate::error::{PackagingError, Result};
use magswarm_fmi::FmiVersion;

/// Value of attribute `name` in an XML fragment (first occurrence).
pub fn attr(xml: &str, name: &str) -> Option<String> {
    let key = format!(" {name}=\"");
    let s = xml.find(&key)? + key.len();
    let e = xml[s..].find('"')?;
    Some(xml[s..s + e].to_string())
}

/// The GUID (FMI 2.0) or instantiation token (FMI 3.0) of the plant FMU as this build
/// computes it from its variable table.
pub fn plant_guid(version: FmiVersion) -> String {
    magswarm_fmi::token::<magswarm_fmu::MagSwarm>(version)
}

/// The attribute that carries the GUID in FMI `version`.
pub fn token_attr(version: FmiVersion) -> &'static str {
    match version {
        FmiVersion::V2 => "guid",
        FmiVersion::V3 => "instantiationToken",
    }
}

/// Fail unless the plant XML that `lib` produced carries this build's GUID.
pub fn check_plant_library(lib: &Path, xml: &str, version: FmiVersion) -> Result<String> {
    let guid = plant_guid(version);
    if !xml.contains(&format!("{}=\"{guid}\"", token_attr(version))) {
        return Err(PackagingError::Stale(lib.to_path_buf()));
    }
    Ok(guid)
}

/// Fail unless the XML that `lib` produced declares `model_identifier` (a library of another
/// FMU passed as `--lib`).
pub fn check_model_identifier(lib: &Path, xml: &str, model_identifier: &str) -> Result<()> {
    if !xml.contains(&format!("modelIdentifier=\"{model_identifier}\"")) {
        return Err(PackagingError::WrongModel {
            lib: lib.to_path_buf(),
            model_identifier: model_identifier.to_string(),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plant_xml_with_another_guid_is_stale() {
        let lib = Path::new("/x/libmagswarm_fmu.so");
        let v2 = FmiVersion::V2;
        let good = format!("<fmiModelDescription guid=\"{}\">", plant_guid(v2));
        assert_eq!(check_plant_library(lib, &good, v2).unwrap(), plant_guid(v2));
        let v3 = FmiVersion::V3;
        let good3 = format!(
            "<fmiModelDescription instantiationToken=\"{}\">",
            plant_guid(v3)
        );
        assert_eq!(
            check_plant_library(lib, &good3, v3).unwrap(),
            plant_guid(v3)
        );
        assert!(
            check_plant_library(lib, &good, v3).is_err(),
            "an FMI 2.0 XML is not FMI 3.0's"
        );
        let e = check_plant_library(lib, "<fmiModelDescription guid=\"{0}\">", v2)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("GUID differs") && e.contains("/x/libmagswarm_fmu.so"),
            "{e}"
        );
    }

    #[test]
    fn model_identifier_and_attributes() {
        let xml = r#"<CoSimulation modelIdentifier="MagSwarmPID" canGetAndSetFMUstate="true"/>"#;
        let lib = Path::new("l.so");
        assert!(check_model_identifier(lib, xml, "MagSwarmPID").is_ok());
        assert!(check_model_identifier(lib, xml, "MagSwarm").is_err());
        assert_eq!(attr(xml, "canGetAndSetFMUstate").as_deref(), Some("true"));
        assert_eq!(attr(xml, "guid"), None);
    }
}
