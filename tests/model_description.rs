//! The modelDescription.xml files: the checked-in copies must be what the code generates, and
//! every variable of the plant FMU as it was before FMI 3.0 and the exposed Model Exchange
//! states (`tests/fixtures/plant_fmi2_variables.csv`, read from the XML of that version) must
//! keep its name, value reference, causality, variability, type, unit and display unit, in the
//! FMI 2.0 and the FMI 3.0 XML alike. New variables may only be added. (The controller's
//! check is crates/magswarm-pid-fmu/tests/variables_kept.rs: no test binary links both FMU
//! crates.)

#[path = "common/variables_kept.rs"]
mod variables_kept;

use magswarm::model::Model;
use magswarm_fmi::FmiVersion;

#[test]
fn checked_in_model_descriptions_are_up_to_date() {
    for (file, version, cmd) in [
        ("modelDescription.xml", FmiVersion::V2, ""),
        (
            "fmi3/modelDescription.xml",
            FmiVersion::V3,
            " --fmi-version 3",
        ),
    ] {
        let path = format!("{}/modelDescription/{file}", env!("CARGO_MANIFEST_DIR"));
        let on_disk = std::fs::read_to_string(&path).expect("checked-in modelDescription");
        let generated = magswarm_fmu::model_description_for(&Model::paper(), None, version);
        assert!(
            on_disk == generated,
            "modelDescription/{file} is stale: regenerate it with \
             `target/release/magswarm fmu{cmd} --xml modelDescription/{file}`"
        );
    }
}

#[test]
fn the_variables_of_the_plant_are_kept_in_both_versions() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures");
    variables_kept::assert_kept(dir, "plant_fmi2_variables.csv", &|v| {
        magswarm_fmu::model_description_for(&Model::paper(), None, v)
    });
}
