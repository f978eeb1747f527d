//! The checked-in modelDescription/modelDescription.xml must be what the code generates.

#[test]
fn checked_in_model_description_is_up_to_date() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/modelDescription/modelDescription.xml"
    );
    let on_disk = std::fs::read_to_string(path).expect("modelDescription/modelDescription.xml");
    let generated = magswarm_fmu::model_description(&magswarm::model::Model::paper(), None);
    assert!(
        on_disk == generated,
        "modelDescription/modelDescription.xml is stale: regenerate it with \
         `target/release/magswarm fmu --xml modelDescription/modelDescription.xml`"
    );
}
