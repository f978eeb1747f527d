//! `magswarm fmu --pid`: build and package the controller FMU `MagSwarmPID.fmu` (crate
//! `magswarm-pid-fmu`, default output `target/fmu/MagSwarmPID.fmu`).
//!
//! The magswarm binary does not link the controller crate (its `export` feature would clash
//! with the plant's `fmi2*` symbols, and the plant crate is already linked): everything about
//! the controller FMU comes from its compiled `.so`, through `fmu_model_description`
//! (libloading), exactly as for the plant. The archive holds `modelDescription.xml`,
//! `binaries/linux64/MagSwarmPID.so`, `resources/model.json` (the plant model the controller
//! assumes: `--model`, default the paper model), `resources/pid.json` (the controller
//! configuration: `--pid-config`, default the library's; the XML's parameter start values are
//! its values) and `documentation/index.html`.
//!
//! ```text
//! magswarm fmu --pid [--model M.json] [--pid-config cfg.json] [--out target/fmu/MagSwarmPID.fmu]
//!                    [--lib libmagswarm_pid_fmu.so] [--no-build] [--xml PATH]
//! ```

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use magswarm_control::PidConfig;
use magswarm_model::Model;

use super::{esc, FmuArgs};

/// Model identifier of the controller FMU.
pub const MODEL_IDENTIFIER: &str = "MagSwarmPID";
/// File name of the compiled controller cdylib on this platform.
pub const LIB_FILE: &str = "libmagswarm_pid_fmu.so";
/// Default output path.
pub const DEFAULT_OUT: &str = "target/fmu/MagSwarmPID.fmu";

/// Run `magswarm fmu --pid`.
pub fn run(a: &FmuArgs) -> Result<()> {
    let model = match &a.model {
        Some(p) => Model::load(p).with_context(|| format!("--model {}", p.display()))?,
        None => Model::paper(),
    };
    let cfg = match &a.pid_config {
        Some(p) => {
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("cannot read --pid-config {}", p.display()))?;
            PidConfig::from_json(&text).with_context(|| format!("--pid-config {}", p.display()))?
        }
        None => PidConfig::default(),
    };
    let lib = match &a.lib {
        Some(p) => p.clone(),
        None => super::locate_library(
            "magswarm-pid-fmu",
            LIB_FILE,
            "MAGSWARM_PID_FMU_LIB",
            a.no_build,
        )?,
    };
    if let Some(xml_path) = &a.xml {
        let xml = super::xml_from_library(&lib, &cfg.to_json(), "controller configuration")?;
        super::write_atomic(xml_path, xml.as_bytes())?;
        println!("wrote {}", xml_path.display());
        return Ok(());
    }
    let out = a.out.clone().unwrap_or_else(|| PathBuf::from(DEFAULT_OUT));
    println!("{}", package(&model, &cfg, &lib, &out)?);
    Ok(())
}

/// Package `lib` with `model` and `cfg` baked in as `out`; returns a one-line summary.
pub fn package(model: &Model, cfg: &PidConfig, lib: &Path, out: &Path) -> Result<String> {
    let so = std::fs::read(lib).with_context(|| format!("cannot read {}", lib.display()))?;
    if so.len() < 4 || &so[..4] != b"\x7fELF" {
        bail!("{} is not an ELF shared library", lib.display());
    }
    let cfg_json = cfg.to_json();
    let xml = super::xml_from_library(lib, &cfg_json, "controller configuration")?;
    if !xml.contains(&format!("modelIdentifier=\"{MODEL_IDENTIFIER}\"")) {
        bail!("{} is not the MagSwarmPID library", lib.display());
    }
    let guid = attr(&xml, "guid").unwrap_or_default();
    let model_json = model.to_json()?;
    let doc = documentation_html(&xml, model, cfg);
    let mut buf = std::io::Cursor::new(Vec::new());
    {
        let mut zip = zip::ZipWriter::new(&mut buf);
        let deflate = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated);
        let exec = deflate.unix_permissions(0o755);
        let entries: [(String, &[u8], zip::write::SimpleFileOptions); 5] = [
            ("modelDescription.xml".into(), xml.as_bytes(), deflate),
            (
                format!("binaries/{}/{MODEL_IDENTIFIER}.so", super::PLATFORM),
                &so,
                exec,
            ),
            (
                "resources/model.json".into(),
                model_json.as_bytes(),
                deflate,
            ),
            ("resources/pid.json".into(), cfg_json.as_bytes(), deflate),
            ("documentation/index.html".into(), doc.as_bytes(), deflate),
        ];
        for (name, data, opts) in entries {
            zip.start_file(name.as_str(), opts)
                .with_context(|| format!("zip entry {name}"))?;
            zip.write_all(data)?;
        }
        zip.finish().context("cannot finish the FMU zip")?;
    }
    let bytes = buf.into_inner();
    super::write_atomic(out, &bytes)?;
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

/// Value of attribute `name` in an XML fragment (first occurrence).
fn attr(xml: &str, name: &str) -> Option<String> {
    let key = format!(" {name}=\"");
    let s = xml.find(&key)? + key.len();
    let e = xml[s..].find('"')?;
    Some(xml[s..s + e].to_string())
}

/// `documentation/index.html`, the variable table read back from the packaged XML.
fn documentation_html(xml: &str, model: &Model, cfg: &PidConfig) -> String {
    let mut rows = String::new();
    for block in xml.split("<ScalarVariable").skip(1) {
        let head = block.split("</ScalarVariable>").next().unwrap_or(block);
        let get = |n: &str| attr(head, n).unwrap_or_default();
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
