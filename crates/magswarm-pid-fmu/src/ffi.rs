//! Every fmi2* and fmi3* symbol, and `fmu_model_description`: packaging asks the compiled
//! library for its own XML in either version, with the start values of the controller configuration JSON to
//! bake in. Only in the cdylib's build (feature `export`).

use magswarm_control::PidConfig;

use crate::{model_description_for, MagSwarmPid};

magswarm_fmi::export_fmu!(MagSwarmPid, |json: Option<&str>, version| {
    let cfg = match json {
        None => PidConfig::default(),
        Some(text) => PidConfig::from_json(text).ok()?,
    };
    Some(model_description_for(&cfg, None, version))
});
