//! The model file: one versioned JSON (`"schema": "magswarm-model/2"`) holding every
//! parameter of the plant and the unmodelled effects switched on. `identify` and `diagnose`
//! write it; the FMU, `predict`, the lab and the bridge's shadow model read it.
//!
//! Versions: `magswarm-model/1` files (no effects: their `effects` section is empty) are
//! still read, and are upgraded to the current schema in memory; files are written as
//! `magswarm-model/2`.
//!
//! Loading is strict on purpose: a model file drives hardware-facing experiments, so an
//! unknown field (a typo, a newer version), a missing one, a non-finite or an out-of-range
//! value is an error that names the field, never a silent default.

use serde::{Deserialize, Serialize};
use std::path::Path;

use crate::envelope::Envelope;
use crate::field::MagnetConfig;
use crate::params::{Conventions, DynParams, SteadyParams};

pub use crate::effects::Effects;

/// The schema tag model files are written with.
pub const SCHEMA: &str = "magswarm-model/2";

/// The first schema version (no effects), still read.
pub const SCHEMA_V1: &str = "magswarm-model/1";

/// A complete plant model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Model {
    /// Always [`SCHEMA`].
    pub schema: String,
    /// Short name of the model (e.g. "paper" or the rig it was identified on).
    #[serde(default)]
    pub name: String,
    /// Where the values come from (free text: paper, identify run, ...).
    #[serde(default)]
    pub provenance: String,
    /// Steady-map parameters (5)-(7).
    pub steady: SteadyParams,
    /// Units and conventions of (7).
    pub conventions: Conventions,
    /// Magnet and swarm geometry.
    pub magnet: MagnetConfig,
    /// ODE (4) parameters.
    pub dynamics: DynParams,
    /// Validated input envelope.
    #[serde(default)]
    pub envelope: Envelope,
    /// Unmodelled effects switched on.
    #[serde(default)]
    pub effects: Effects,
}

/// A model file that cannot be used, with the field (JSON path) at fault.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{source_name}: {path}: {message}")]
pub struct ModelError {
    /// File name or `"<string>"`.
    pub source_name: String,
    /// JSON path of the offending field, e.g. `steady.C_1` ("" for the whole document).
    pub path: String,
    /// What is wrong.
    pub message: String,
}

impl Default for Model {
    fn default() -> Self {
        Model::paper()
    }
}

impl Model {
    /// Parse and validate a model from JSON text; `source_name` appears in errors.
    pub fn from_json_str(text: &str, source_name: &str) -> Result<Model, ModelError> {
        let de = &mut serde_json::Deserializer::from_str(text);
        let mut model: Model = serde_path_to_error::deserialize(de).map_err(|e| {
            let path = e.path().to_string();
            let inner = e.into_inner();
            ModelError {
                source_name: source_name.to_string(),
                path: if path == "." { String::new() } else { path },
                message: inner.to_string(),
            }
        })?;
        model.validate().map_err(|mut e| {
            e.source_name = source_name.to_string();
            e
        })?;
        if model.schema == SCHEMA_V1 {
            model.schema = SCHEMA.to_string();
        }
        Ok(model)
    }

    /// Load and validate a model file.
    pub fn load(path: &Path) -> Result<Model, ModelError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| ModelError {
            source_name: name.clone(),
            path: String::new(),
            message: format!("cannot read: {e}"),
        })?;
        Model::from_json_str(&text, &name)
    }

    /// The model a command works with: the file at `path` (loaded and validated), else the
    /// built-in paper model. Every `--model` option is optional with this default.
    pub fn load_or_paper(path: Option<&Path>) -> Result<Model, ModelError> {
        match path {
            Some(p) => Model::load(p),
            None => Ok(Model::paper()),
        }
    }

    /// Serialise to pretty JSON (validated first, so a saved file always loads).
    pub fn to_json(&self) -> Result<String, ModelError> {
        self.validate()?;
        serde_json::to_string_pretty(self).map_err(|e| ModelError {
            source_name: "<model>".into(),
            path: String::new(),
            message: e.to_string(),
        })
    }

    /// Write the model file, atomically (temp file + rename) so a crash loses nothing.
    pub fn save(&self, path: &Path) -> Result<(), ModelError> {
        let text = self.to_json()?;
        let err = |e: std::io::Error| ModelError {
            source_name: path.display().to_string(),
            path: String::new(),
            message: format!("cannot write: {e}"),
        };
        let tmp = path.with_extension("json.tmp");
        std::fs::write(&tmp, text + "\n").map_err(err)?;
        std::fs::rename(&tmp, path).map_err(err)
    }

    /// Check every value: finite and in its physical range (the parameters' ranges come from
    /// [`crate::registry`]; the envelope's are checked here). The first violation is returned
    /// with its JSON path.
    pub fn validate(&self) -> Result<(), ModelError> {
        let mut c = Checker::default();
        if self.schema == SCHEMA_V1 {
            if !self.effects.is_empty() {
                c.fail(
                    "effects",
                    format!(
                        "effects need schema {SCHEMA:?} ({SCHEMA_V1:?} has none): switched on: {}",
                        self.effects
                            .enabled()
                            .iter()
                            .map(|k| k.name())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                );
            }
        } else if self.schema != SCHEMA {
            c.fail(
                "schema",
                format!(
                    "unsupported schema {:?}, expected {SCHEMA:?} (or {SCHEMA_V1:?})",
                    self.schema
                ),
            );
        }
        // Every numeric parameter: its physical range from the registry.
        if let Err((path, err)) = crate::registry::check_all(self) {
            c.fail(path, err.to_string());
        }
        for (i, t) in self.effects.learned.iter().enumerate() {
            if let Err(e) = t.validate(&crate::effect_kind::NAMES) {
                c.fail(&format!("effects.learned[{i}].{}", e.field), e.message);
            }
        }
        let m = &self.magnet;
        let e = &self.envelope;
        c.range("envelope.z_min_m", e.z_min_m, -m.radius_m * 0.99, 10.0);
        c.range("envelope.z_max_m", e.z_max_m, e.z_min_m, 10.0);
        c.range("envelope.f_min_hz", e.f_min_hz, 0.0, 1e4);
        c.range("envelope.f_max_hz", e.f_max_hz, e.f_min_hz, 1e4);
        if e.z_max_m <= e.z_min_m {
            c.fail("envelope.z_max_m", "must be larger than z_min_m".into());
        }

        match c.first {
            None => Ok(()),
            Some((path, message)) => Err(ModelError {
                source_name: "<model>".into(),
                path,
                message,
            }),
        }
    }
}

/// Collects the first range violation.
#[derive(Default)]
struct Checker {
    first: Option<(String, String)>,
}

impl Checker {
    fn fail(&mut self, path: &str, msg: String) {
        if self.first.is_none() {
            self.first = Some((path.to_string(), msg));
        }
    }
    fn range(&mut self, path: &str, v: f64, lo: f64, hi: f64) {
        if !v.is_finite() {
            self.fail(path, format!("must be finite (got {v})"));
        } else if v < lo || v > hi {
            self.fail(path, format!("out of range: {v} not in [{lo}, {hi}]"));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_model_round_trips() {
        let m = Model::paper();
        let text = m.to_json().unwrap();
        assert!(text.contains("\"schema\": \"magswarm-model/2\""));
        let back = Model::from_json_str(&text, "t").unwrap();
        assert_eq!(m, back);
    }

    #[test]
    fn arbitrary_values_round_trip_bit_exactly() {
        // identify writes fitted values with all their digits; loading must give them back
        // exactly, or an FMU state or a replay would differ in the last bit.
        let mut m = Model::paper();
        m.steady.C_1 = 7.760000000000001;
        m.steady.N = -0.27300000000000013;
        m.steady.B_ref = 0.12880000000000003;
        m.magnet.lateral_offset_m = 0.006135000000000001;
        let back = Model::from_json_str(&m.to_json().unwrap(), "t").unwrap();
        assert_eq!(back.steady.C_1.to_bits(), m.steady.C_1.to_bits());
        assert_eq!(back, m);
    }

    #[test]
    fn unknown_field_is_named() {
        let mut v: serde_json::Value = serde_json::to_value(Model::paper()).unwrap();
        v["steady"]["C_3"] = 1.0.into();
        let e = Model::from_json_str(&v.to_string(), "m.json").unwrap_err();
        assert_eq!(e.path, "steady.C_3");
        assert!(e.message.contains("unknown field"), "{e}");
        assert!(e.to_string().starts_with("m.json: steady.C_3"), "{e}");
    }

    #[test]
    fn out_of_range_and_non_finite_values_are_named() {
        let mut v: serde_json::Value = serde_json::to_value(Model::paper()).unwrap();
        v["steady"]["C_1"] = (-1.0).into();
        let e = Model::from_json_str(&v.to_string(), "m.json").unwrap_err();
        assert_eq!(e.path, "steady.C_1", "{e}");
        let mut v: serde_json::Value = serde_json::to_value(Model::paper()).unwrap();
        v["dynamics"]["beta"] = serde_json::Value::String("NaN".into());
        let e = Model::from_json_str(&v.to_string(), "m.json").unwrap_err();
        assert_eq!(e.path, "dynamics.beta", "{e}");
        let text = serde_json::to_string(&Model::paper())
            .unwrap()
            .replace("\"remanence_t\":1.32", "\"remanence_t\":1e999");
        let e = Model::from_json_str(&text, "m.json").unwrap_err();
        assert!(
            e.path.contains("remanence_t") || e.message.contains("remanence"),
            "{e}"
        );
    }

    #[test]
    fn missing_field_and_wrong_schema_are_errors() {
        let mut v: serde_json::Value = serde_json::to_value(Model::paper()).unwrap();
        v["steady"].as_object_mut().unwrap().remove("q_P");
        let e = Model::from_json_str(&v.to_string(), "m.json").unwrap_err();
        assert!(e.message.contains("q_P"), "{e}");
        let mut v: serde_json::Value = serde_json::to_value(Model::paper()).unwrap();
        v["schema"] = "magswarm-model/9".into();
        let e = Model::from_json_str(&v.to_string(), "m.json").unwrap_err();
        assert_eq!(e.path, "schema");
    }

    #[test]
    fn load_or_paper_gives_the_file_or_the_paper_model() {
        assert_eq!(Model::load_or_paper(None).unwrap(), Model::paper());
        let dir = std::env::temp_dir().join(format!("magswarm-lop-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut m = Model::paper();
        m.steady.C_1 = 8.25;
        let p = dir.join("m.json");
        m.save(&p).unwrap();
        assert_eq!(Model::load_or_paper(Some(&p)).unwrap(), m);
        let e = Model::load_or_paper(Some(&dir.join("missing.json"))).unwrap_err();
        assert!(e.to_string().contains("missing.json"), "{e}");
    }

    #[test]
    fn save_and_load_file() {
        let dir = std::env::temp_dir().join(format!("magswarm-model-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("m.json");
        Model::paper().save(&p).unwrap();
        assert_eq!(Model::load(&p).unwrap(), Model::paper());
        let e = Model::load(&dir.join("missing.json")).unwrap_err();
        assert!(e.message.contains("cannot read"));
    }
}
