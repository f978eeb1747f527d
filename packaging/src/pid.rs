//! `MagSwarmPID.fmu`, the controller (crate `magswarm-pid-fmu`).
//!
//! The magswarm binary does not link the controller crate (its `export` feature would clash
//! with the plant's `fmi2*` symbols, and the plant crate is already linked): everything about
//! the controller FMU comes from its compiled `.so`, through `fmu_model_description`
//! (libloading), exactly as for the plant. The archive holds `modelDescription.xml`,
//! `binaries/linux64/MagSwarmPID.so`, `resources/model.json` (the plant model the controller
//! assumes), `resources/pid.json` (the controller configuration; the XML's parameter start
//! values are its values) and `documentation/index.html`.

use std::path::Path;

use anyhow::Result;
use magswarm_control::PidConfig;
use magswarm_model::Model;

use crate::archive::{self, Entry};
use crate::{esc, library, stale};

/// Model identifier of the controller FMU.
pub const MODEL_IDENTIFIER: &str = "MagSwarmPID";
/// Cargo package of the controller library.
pub const CRATE: &str = "magswarm-pid-fmu";
/// File name of the compiled controller cdylib on this platform.
pub const LIB_FILE: &str = "libmagswarm_pid_fmu.so";
/// Environment variable that names the library to package instead of building it.
pub const LIB_ENV: &str = "MAGSWARM_PID_FMU_LIB";
/// Default output path.
pub const DEFAULT_OUT: &str = "target/fmu/MagSwarmPID.fmu";

/// modelDescription.xml of the controller with `cfg`'s values as parameter start values, as
/// the compiled library `lib` writes it.
pub fn model_description(lib: &Path, cfg: &PidConfig) -> Result<String> {
    library::xml_from_library(lib, &cfg.to_json(), "controller configuration", 2)
}

/// Package `lib` with `model` and `cfg` baked in as `out`; returns a one-line summary.
pub fn package(model: &Model, cfg: &PidConfig, lib: &Path, out: &Path) -> Result<String> {
    let so = archive::read_shared_library(lib)?;
    let cfg_json = cfg.to_json();
    let xml = library::xml_from_library(lib, &cfg_json, "controller configuration", 2)?;
    stale::check_model_identifier(lib, &xml, MODEL_IDENTIFIER)?;
    let guid = stale::attr(&xml, "guid").unwrap_or_default();
    let model_json = model.to_json()?;
    let doc = documentation_html(&xml, model, cfg);
    let bytes = archive::fmu_zip(&[
        Entry::model_description(&xml),
        Entry::binary(MODEL_IDENTIFIER, &so),
        Entry::resource("model.json", model_json.as_bytes()),
        Entry::resource("pid.json", cfg_json.as_bytes()),
        Entry::documentation(&doc),
    ])?;
    archive::write_atomic(out, &bytes)?;
    Ok(format!(
        "wrote {} ({} kB): FMI 2.0 Co-Simulation, model identifier {MODEL_IDENTIFIER}, GUID {guid}, \
         {} variables, sample time {} s, plant model \"{}\" in resources/model.json, \
         configuration in resources/pid.json",
        out.display(),
        bytes.len() / 1024,
        xml.matches("<ScalarVariable").count(),
        cfg.sample_time_s,
        model.name
    ))
}

/// `documentation/index.html`, the variable table read back from the packaged XML.
fn documentation_html(xml: &str, model: &Model, cfg: &PidConfig) -> String {
    let mut rows = String::new();
    for block in xml.split("<ScalarVariable").skip(1) {
        let head = block.split("</ScalarVariable>").next().unwrap_or(block);
        let get = |n: &str| stale::attr(head, n).unwrap_or_default();
        rows.push_str(&format!(
            "<tr><td><code>{}</code></td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
            esc(&get("name")),
            esc(&get("causality")),
            esc(&get("unit")),
            esc(&get("displayUnit")),
            esc(&get("start")),
            get("description") // already XML-escaped
        ));
    }
    format!(
        r#"<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>MagSwarmPID FMU</title>
<style>body{{font-family:sans-serif;max-width:60em;margin:2em auto;line-height:1.45}}
table{{border-collapse:collapse}}td,th{{border:1px solid #bbb;padding:.2em .5em;text-align:left}}
code{{background:#f3f3f3}}</style></head><body>
<h1>MagSwarmPID {version}: decoupled 2x2 PID for MagSwarm.fmu (FMI 2.0 Co-Simulation)</h1>
<p>The controller of <code>magswarm-control</code>: feedforward from the inverse steady map of the
model in <code>resources/model.json</code> ("{model}"), a model-predicted reference, a PID in radius
space decoupled through the inverse of the map's Jacobian, derivative filter, anti-windup
(conditional integration and back-calculation), saturation to the envelope and rate limits.
Setpoints that the plant cannot reach are replaced by the nearest reachable radii (outputs
<code>r1_goal</code>, <code>r2_goal</code>, <code>target_feasible</code>).</p>
<p>Wiring: the plant's <code>r1</code>, <code>r2</code> to this FMU's <code>r1</code>, <code>r2</code>;
this FMU's <code>z_m</code>, <code>omega_m</code> to the plant's inputs; setpoints on
<code>r1_ref</code>, <code>r2_ref</code>. Discrete time: samples at multiples of
<code>sample_time</code> ({ts} s) inside <code>fmi2DoStep</code>; use it as the communication step.
The configuration (<code>resources/pid.json</code>, schema magswarm-pid/1) can be replaced with the
String parameter <code>config_file</code>; parameters set to other values than their start values
override it.</p>
<h2>Variables</h2>
<table><tr><th>name</th><th>causality</th><th>unit</th><th>display</th><th>start</th><th>description</th></tr>
{rows}</table>
</body></html>
"#,
        version = env!("CARGO_PKG_VERSION"),
        model = esc(&model.name),
        ts = cfg.sample_time_s,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn documentation_reads_the_variable_table_back_from_the_xml() {
        let xml = r#"<ModelVariables>
<ScalarVariable name="r1_ref" valueReference="0" causality="input" description="a &lt; b"><Real unit="m" displayUnit="mm" start="0.008"/></ScalarVariable>
</ModelVariables>"#;
        let html = documentation_html(xml, &Model::paper(), &PidConfig::default());
        assert!(html.contains(
            "<tr><td><code>r1_ref</code></td><td>input</td><td>m</td><td>mm</td><td>0.008</td><td>a &lt; b</td></tr>"
        ), "{html}");
    }
}
