//! Reading the controller configuration (`magswarm-pid/1` JSON) and sanity checks on data
//! that comes back in serialized FMU states.

use std::path::Path;

use magswarm_control::PidConfig;
use magswarm_fmi::ModelError;

/// The configuration in the file `path`, or an error naming the file and the field.
pub(crate) fn load_config(path: &Path) -> Result<PidConfig, ModelError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| ModelError::error(format!("cannot read {}: {e}", path.display())))?;
    PidConfig::from_json(&text).map_err(|e| ModelError::error(format!("{}: {e}", path.display())))
}

/// The first number in `v` whose magnitude exceeds `max` (or that is not finite).
pub(crate) fn first_absurd_number(v: &serde_json::Value, max: f64) -> Option<f64> {
    match v {
        serde_json::Value::Number(n) => n.as_f64().filter(|x| x.is_nan() || x.abs() > max),
        serde_json::Value::Array(a) => a.iter().find_map(|x| first_absurd_number(x, max)),
        serde_json::Value::Object(o) => o.values().find_map(|x| first_absurd_number(x, max)),
        _ => None,
    }
}
