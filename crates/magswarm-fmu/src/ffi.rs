//! Every fmi2* and fmi3* symbol, and `fmu_model_description`: packaging asks the compiled
//! library for its own XML in either version, with the start values of the model JSON to
//! bake in. Only in the cdylib's build (feature `export`).

use magswarm_model::Model;

use crate::{model_description_for, MagSwarm};

magswarm_fmi::export_fmu!(MagSwarm, |json: Option<&str>, version| {
    let model = match json {
        None => Model::paper(),
        Some(text) => Model::from_json_str(text, "model").ok()?,
    };
    Some(model_description_for(&model, None, version))
});
