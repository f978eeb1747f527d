//! Every variable of MagSwarmPID.fmu as it was before FMI 3.0
//! (`tests/fixtures/pid_fmi2_variables.csv` at the workspace root) keeps its name, value
//! reference, causality, variability, type, unit and display unit in the FMI 2.0 and 3.0 XML.

#[path = "../../../tests/common/variables_kept.rs"]
mod variables_kept;

#[test]
fn the_variables_of_the_controller_are_kept_in_both_versions() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/fixtures");
    variables_kept::assert_kept(dir, "pid_fmi2_variables.csv", &|v| {
        magswarm_pid_fmu::model_description_for(&Default::default(), None, v)
    });
}
