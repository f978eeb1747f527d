//! A rig config made self-contained, for the `resources/` of `MagSwarmRig.fmu`.
//!
//! The FMU reads `resources/rig.toml`, whose relative paths are relative to `resources/`.
//! Model files the config names (`[shadow] model`, `[camera] model`) are small and part of
//! the rig's definition: they are copied in. Recorded data (`[camera] dir`, a frame folder)
//! and the controller's files stay where they are, named by absolute path. The stepper
//! watchdog program is the FMU's own, so `[stepper] watchdog_exe` is dropped.

use std::path::{Path, PathBuf};

use crate::config::{ConfigError, RigConfig};

/// A config ready to be packaged.
#[derive(Debug, Clone)]
pub struct Baked {
    /// The text of `resources/rig.toml`.
    pub text: String,
    /// Files to put beside it (name in `resources/`, contents).
    pub files: Vec<(String, Vec<u8>)>,
    /// What stays outside the FMU (absolute paths), for the packager's summary.
    pub outside: Vec<String>,
}

/// Why a config cannot be baked.
#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    /// The config itself is wrong.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A file it names cannot be read.
    #[error("{key} = {path}: {source}")]
    Read {
        /// Dotted key.
        key: String,
        /// The file.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// The text does not parse as a TOML table (already validated: should not happen).
    #[error("{0}")]
    Toml(String),
}

/// Models copied into `resources/`: (section, key, file name in `resources/`).
const MODELS: [(&str, &str, &str); 2] = [
    ("shadow", "model", "shadow-model.json"),
    ("camera", "model", "camera-model.json"),
];
/// Paths left outside and made absolute.
const OUTSIDE: [(&str, &str); 3] = [("camera", "dir"), ("control", "pid"), ("control", "model")];

/// Bake the config at `path`.
pub fn bake(path: &Path) -> Result<Baked, BakeError> {
    let cfg = RigConfig::load(path)?;
    // Every model it names must load now, not when the FMU starts.
    cfg.model("shadow.model", cfg.shadow.model.as_ref())?;
    cfg.model("camera.model", cfg.camera.model.as_ref())?;
    let text = std::fs::read_to_string(path).map_err(|e| BakeError::Read {
        key: "config".into(),
        path: path.into(),
        source: e,
    })?;
    let mut table: toml::Table = text.parse().map_err(|e| BakeError::Toml(format!("{e}")))?;
    let mut files = Vec::new();
    let mut outside = Vec::new();
    let entry = |t: &toml::Table, sec: &str, key: &str| -> Option<String> {
        t.get(sec)?
            .as_table()?
            .get(key)?
            .as_str()
            .map(str::to_string)
    };
    let set = |t: &mut toml::Table, sec: &str, key: &str, v: toml::Value| {
        if let Some(s) = t.get_mut(sec).and_then(toml::Value::as_table_mut) {
            s.insert(key.to_string(), v);
        }
    };
    for (sec, key, name) in MODELS {
        if let Some(p) = entry(&table, sec, key) {
            let full = cfg.resolve(Path::new(&p));
            let bytes = std::fs::read(&full).map_err(|e| BakeError::Read {
                key: format!("{sec}.{key}"),
                path: full.clone(),
                source: e,
            })?;
            files.push((name.to_string(), bytes));
            set(&mut table, sec, key, toml::Value::String(name.into()));
        }
    }
    for (sec, key) in OUTSIDE {
        if let Some(p) = entry(&table, sec, key) {
            let full = cfg.resolve(Path::new(&p));
            let full = std::fs::canonicalize(&full).unwrap_or(full);
            outside.push(format!("{sec}.{key} = {}", full.display()));
            set(
                &mut table,
                sec,
                key,
                toml::Value::String(full.display().to_string()),
            );
        }
    }
    if let Some(s) = table.get_mut("stepper").and_then(toml::Value::as_table_mut) {
        s.remove("watchdog_exe");
    }
    let body = toml::to_string(&table).map_err(|e| BakeError::Toml(e.to_string()))?;
    let text = format!(
        "# The rig config of this FMU, baked by `magswarm-bridge fmu` from {}.\n\
         # Paths are relative to this folder (resources/).\n\n{body}",
        std::fs::canonicalize(path)
            .unwrap_or_else(|_| path.to_path_buf())
            .display()
    );
    Ok(Baked {
        text,
        files,
        outside,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn models_are_copied_paths_made_absolute_and_the_result_loads() {
        let dir = tempfile::tempdir().unwrap();
        let m = magswarm_model::Model::paper();
        m.save(&dir.path().join("shadow.json")).unwrap();
        std::fs::create_dir(dir.path().join("frames")).unwrap();
        let cfg = dir.path().join("rig.toml");
        std::fs::write(
            &cfg,
            r#"
[robot]
host = "127.0.0.1"
z_tcp_at_zero_m = 0.4
[stepper]
device = "/dev/ttyACM0"
velocity_per_hz = 51200.0
watchdog_exe = "somewhere/else"
[camera]
kind = "replay"
dir = "frames"
mm_per_px = 0.05
[limits]
z_m_mm = [3.5, 23.5]
f_hz = [1.0, 10.0]
z_rate_mm_s = 10.0
f_rate_hz_s = 2.0
[shadow]
model = "shadow.json"
"#,
        )
        .unwrap();
        let b = bake(&cfg).unwrap();
        assert_eq!(b.files.len(), 1);
        assert_eq!(b.files[0].0, "shadow-model.json");
        let res = tempfile::tempdir().unwrap();
        std::fs::write(res.path().join("rig.toml"), &b.text).unwrap();
        std::fs::write(res.path().join("shadow-model.json"), &b.files[0].1).unwrap();
        let back = RigConfig::load(&res.path().join("rig.toml")).unwrap();
        assert!(back.stepper.watchdog_exe.is_none());
        assert_eq!(back.limits.z_m_mm, [3.5, 23.5]);
        assert!(back.camera.dir.as_ref().unwrap().is_absolute());
        assert!(back
            .model("shadow.model", back.shadow.model.as_ref())
            .is_ok());
        assert!(b.outside.iter().any(|o| o.starts_with("camera.dir = /")));
        // A model file that does not load stops the baking, naming the key.
        std::fs::write(dir.path().join("shadow.json"), "{}").unwrap();
        let e = bake(&cfg).unwrap_err().to_string();
        assert!(e.contains("shadow.model"), "{e}");
    }
}
