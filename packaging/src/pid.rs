//! `MagSwarmPID.fmu`, the controller (crate `magswarm-pid-fmu`).
//!
//! The magswarm binary does not link the controller crate (its `export` feature would clash
//! with the plant's `fmi2*` symbols, and the plant crate is already linked): everything about
//! the controller FMU comes from its compiled `.so`, through `fmu_model_description`
//! (libloading), exactly as for the plant, in FMI 2.0 or 3.0 (Co-Simulation). The archive
//! holds `modelDescription.xml`, `binaries/<platform>/MagSwarmPID.so`, `resources/model.json` (the plant model the controller
//! assumes), `resources/pid.json` (the controller configuration; the XML's parameter start
//! values are its values) and `documentation/index.html`.

use std::path::Path;

use crate::error::Result;
use magswarm_control::PidConfig;
use magswarm_model::Model;

use crate::archive::{self, Entry};
use crate::{esc, library, stale};
use magswarm_fmi::FmiVersion;

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
/// Where `magswarm fmu --pid --fmi-version 3` writes unless told otherwise (the same file name, so
/// the FMI 2.0 and 3.0 FMUs can sit side by side).
pub const DEFAULT_OUT_FMI3: &str = "target/fmu/fmi3/MagSwarmPID.fmu";

/// The default output path for FMI `version`.
pub fn default_out(version: FmiVersion) -> &'static str {
    match version {
        FmiVersion::V2 => DEFAULT_OUT,
        FmiVersion::V3 => DEFAULT_OUT_FMI3,
    }
}

/// modelDescription.xml (FMI `version`) of the controller with `cfg`'s values as parameter
/// start values, as the compiled library `lib` writes it.
pub fn model_description(lib: &Path, cfg: &PidConfig, version: FmiVersion) -> Result<String> {
    library::xml_from_library(
        lib,
        &cfg.to_json(),
        "controller configuration",
        version.major(),
    )
}

/// Package `lib` with `model` and `cfg` baked in as `out` in FMI `version`; returns a
/// one-line summary.
pub fn package(
    model: &Model,
    cfg: &PidConfig,
    lib: &Path,
    out: &Path,
    version: FmiVersion,
) -> Result<String> {
    let so = archive::read_shared_library(lib)?;
    let cfg_json = cfg.to_json();
    let xml = model_description(lib, cfg, version)?;
    stale::check_model_identifier(lib, &xml, MODEL_IDENTIFIER)?;
    let guid = stale::attr(&xml, stale::token_attr(version)).unwrap_or_default();
    let model_json = model.to_json()?;
    let doc = documentation_html(&xml, model, cfg, version);
    let bytes = archive::fmu_zip(&[
        Entry::model_description(&xml),
        Entry::binary(MODEL_IDENTIFIER, &so, version),
        Entry::resource("model.json", model_json.as_bytes()),
        Entry::resource("pid.json", cfg_json.as_bytes()),
        Entry::documentation(&doc),
    ])?;
    archive::write_atomic(out, &bytes)?;
    Ok(format!(
        "wrote {} ({} kB): {version} Co-Simulation, model identifier {MODEL_IDENTIFIER}, {} {guid}, \
         {} variables, sample time {} s, plant model \"{}\" in resources/model.json, \
         configuration in resources/pid.json",
        out.display(),
        bytes.len() / 1024,
        stale::token_attr(version),
        magswarm_variables(&xml).len(),
        cfg.sample_time_s,
        model.name
    ))
}

/// The variable elements of a generated modelDescription (FMI 2.0 `<ScalarVariable ...>`
/// with its type element, FMI 3.0 `<Float64 ...>` and the like), as text blocks.
fn magswarm_variables(xml: &str) -> Vec<&str> {
    let Some(start) = xml.find("<ModelVariables>") else {
        return Vec::new();
    };
    let end = xml.find("</ModelVariables>").unwrap_or(xml.len());
    let body = &xml[start + "<ModelVariables>".len()..end];
    body.split('\n')
        .map(str::trim)
        .filter(|l| l.starts_with('<') && !l.starts_with("</") && l.contains(" name=\""))
        .filter(|l| {
            !l.starts_with("<Real") && !l.starts_with("<Integer") && !l.starts_with("<Start")
        })
        .collect()
}

/// `documentation/index.html`, the variable table read back from the packaged XML.
fn documentation_html(xml: &str, model: &Model, cfg: &PidConfig, version: FmiVersion) -> String {
    let mut rows = String::new();
    let lines: Vec<&str> = xml.lines().collect();
    for head in magswarm_variables(xml) {
        // FMI 2.0 keeps unit and start on the type element of the next line.
        let next = lines
            .iter()
            .position(|l| l.trim() == head)
            .and_then(|i| lines.get(i + 1))
            .map_or("", |l| l.trim());
        let get = |n: &str| {
            stale::attr(head, n)
                .or_else(|| stale::attr(next, n).filter(|_| head.starts_with("<ScalarVariable")))
                .unwrap_or_default()
        };
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
<h1>MagSwarmPID {crate_version}: decoupled 2x2 PID for MagSwarm.fmu ({version} Co-Simulation)</h1>
<p>The controller of <code>magswarm-control</code>: feedforward from the inverse steady map of the
model in <code>resources/model.json</code> ("{model}"), a model-predicted reference, a PID in radius
space decoupled through the inverse of the map's Jacobian, derivative filter, anti-windup
(conditional integration and back-calculation), saturation to the envelope and rate limits.
Setpoints that the plant cannot reach are replaced by the nearest reachable radii (outputs
<code>r1_goal</code>, <code>r2_goal</code>, <code>target_feasible</code>).</p>
<p>Wiring: the plant's <code>r1</code>, <code>r2</code> to this FMU's <code>r1</code>, <code>r2</code>;
this FMU's <code>z_m</code>, <code>omega_m</code> to the plant's inputs; setpoints on
<code>r1_ref</code>, <code>r2_ref</code>. Discrete time: samples at multiples of
<code>sample_time</code> ({ts} s) inside each communication step (<code>DoStep</code>); use it as the communication step.
The configuration (<code>resources/pid.json</code>, schema magswarm-pid/1) can be replaced with the
String parameter <code>config_file</code>; parameters set to other values than their start values
override it.</p>
<h2>Variables</h2>
<table><tr><th>name</th><th>causality</th><th>unit</th><th>display</th><th>start</th><th>description</th></tr>
{rows}</table>
</body></html>
"#,
        crate_version = env!("CARGO_PKG_VERSION"),
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
        let html = documentation_html(xml, &Model::paper(), &PidConfig::default(), FmiVersion::V2);
        assert!(html.contains(
            "<tr><td><code>r1_ref</code></td><td>input</td><td>m</td><td>mm</td><td>0.008</td><td>a &lt; b</td></tr>"
        ), "{html}");
        let xml3 = r#"<ModelVariables>
    <Float64 name="r1_ref" valueReference="1" description="setpoint" causality="input" variability="continuous" unit="m" displayUnit="mm" start="0.007"/>
    <String name="model_file" valueReference="40" causality="parameter" variability="fixed" initial="exact">
      <Start value=""/>
    </String>
</ModelVariables>"#;
        let html = documentation_html(xml3, &Model::paper(), &PidConfig::default(), FmiVersion::V3);
        assert!(html.contains(
            "<tr><td><code>r1_ref</code></td><td>input</td><td>m</td><td>mm</td><td>0.007</td><td>setpoint</td></tr>"
        ), "{html}");
        assert!(
            html.contains("<code>model_file</code>") && html.contains("FMI 3.0"),
            "{html}"
        );
    }
}
