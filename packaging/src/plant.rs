//! `MagSwarm.fmu`, the plant, in FMI 2.0 or 3.0 (Co-Simulation and Model Exchange in both):
//! `modelDescription.xml` from the compiled library, `binaries/<platform>/MagSwarm.so` (the
//! same library for both versions), the model baked into `resources/model.json` (the XML's
//! parameter start values are that model's, so an importer that sets every parameter to its
//! start value gets exactly the baked model) and `documentation/index.html`.

use std::path::Path;

use crate::error::Result;
use magswarm_model::Model;

use crate::archive::{self, Entry};
use crate::{esc, library, stale};
use magswarm_fmi::FmiVersion;

/// Where `magswarm fmu` writes the plant FMU unless told otherwise.
pub const DEFAULT_OUT: &str = "target/fmu/MagSwarm.fmu";
/// Where `magswarm fmu --fmi-version 3` writes unless told otherwise (the same file name, so
/// the FMI 2.0 and 3.0 FMUs can sit side by side).
pub const DEFAULT_OUT_FMI3: &str = "target/fmu/fmi3/MagSwarm.fmu";

/// The default output path for FMI `version`.
pub fn default_out(version: FmiVersion) -> &'static str {
    match version {
        FmiVersion::V2 => DEFAULT_OUT,
        FmiVersion::V3 => DEFAULT_OUT_FMI3,
    }
}
/// Cargo package of the plant library.
pub const CRATE: &str = "magswarm-fmu";
/// File name of the compiled cdylib on this platform.
pub const LIB_FILE: &str = "libmagswarm_fmu.so";
/// Environment variable that names the library to package instead of building it.
pub const LIB_ENV: &str = "MAGSWARM_FMU_LIB";

/// modelDescription.xml (FMI `version`) of the plant with `model`'s values as parameter
/// start values, from the variable table this build links (no library needed:
/// `magswarm fmu --xml`).
pub fn model_description(model: &Model, version: FmiVersion) -> String {
    magswarm_fmu::model_description_for(model, None, version)
}

/// Package `lib` with `model` baked in as `out` in FMI `version`; returns a one-paragraph
/// summary.
pub fn package(model: &Model, lib: &Path, out: &Path, version: FmiVersion) -> Result<String> {
    let so = archive::read_shared_library(lib)?;
    let model_json = model.to_json()?;
    let xml = library::xml_from_library(lib, &model_json, "model", version.major())?;
    let guid = stale::check_plant_library(lib, &xml, version)?;
    let doc = documentation_html(&xml, model, version);
    let bytes = archive::fmu_zip(&[
        Entry::model_description(&xml),
        Entry::binary(magswarm_fmu::MODEL_IDENTIFIER, &so, version),
        Entry::resource(magswarm_fmu::RESOURCE_MODEL, model_json.as_bytes()),
        Entry::documentation(&doc),
    ])?;
    archive::write_atomic(out, &bytes)?;
    Ok(format!(
        "wrote {} ({} kB): {version} Co-Simulation and Model Exchange, model identifier {}, {} \
         {guid}, {} variables, model \"{}\" baked into resources/{}",
        out.display(),
        bytes.len() / 1024,
        magswarm_fmu::MODEL_IDENTIFIER,
        stale::token_attr(version),
        magswarm_fmu::model_info().variables.len(),
        model.name,
        magswarm_fmu::RESOURCE_MODEL
    ))
}

/// `documentation/index.html`: what the model is, its variables (from the same table as the
/// XML), units, the envelope and the seed.
pub fn documentation_html(xml: &str, model: &Model, version: FmiVersion) -> String {
    use magswarm_fmi::{Causality, Start};
    let info = magswarm_fmu::model_info();
    let mut rows = String::new();
    for v in info.variables {
        // Start values as packaged (baked model), read back from the generated XML's table.
        let start = match (v.causality, v.start) {
            (Causality::Parameter, _) => start_in_xml(xml, v.name).unwrap_or_default(),
            (_, Some(Start::Real(x))) => format!("{x}"),
            (_, Some(s)) => s.to_xml_text(),
            _ => String::new(),
        };
        rows.push_str(&format!(
            "<tr><td><code>{}</code></td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
            esc(v.name),
            v.causality.as_str(),
            esc(v.unit.unwrap_or("")),
            esc(v.display_unit.unwrap_or("")),
            esc(&start),
            esc(v.description)
        ));
    }
    let e = &model.envelope;
    let m = &model.magnet;
    format!(
        r#"<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>MagSwarm FMU</title>
<style>body{{font-family:sans-serif;max-width:60em;margin:2em auto;line-height:1.45}}
table{{border-collapse:collapse}}td,th{{border:1px solid #bbb;padding:.2em .5em;text-align:left}}
code{{background:#f3f3f3}}</style></head><body>
<h1>MagSwarm {crate_version}: magnetic microparticle swarm ({version}, Co-Simulation and Model Exchange)</h1>
<p>A reduced-order model of a swarm of NdFeB microparticles in water under a rotating
spherical NdFeB magnet (radius {radius_mm} mm, remanence {br} T, dipole moment {moment:.1} A m&sup2;)
held by a robot arm. Inputs are the magnet-swarm distance <code>z_m</code> and the field angular
velocity <code>omega_m</code> = 2&pi;f<sub>m</sub>; outputs are the principal radii of the swarm's
elliptical footprint.</p>
<ul>
<li><b>Steady map</b> (5)-(7): r<sub>i</sub> = C<sub>i</sub> &Phi;(&omega;) / S<sub>i</sub><sup>&alpha;<sub>i</sub></sup>,
with the anisotropic stiffness S<sub>x</sub>, S<sub>y</sub> built from the curvature of &lt;B&sup2;&gt;,
the axial gradient g<sub>z</sub> and the field B of the rotating dipole at the swarm
(outputs <code>r1_ss</code>, <code>r2_ss</code>).</li>
<li><b>Dynamics</b> ODE (4): confinement, rotation-driven expansion and relaxation; the confinement
gains are scheduled on the inputs so that the equilibrium of (4) is the steady map
(outputs <code>r1</code>, <code>r2</code>; formation time constants 0.2-5 s).</li>
<li><b>Validated envelope</b>: z_m {zmin}-{zmax} mm, f {fmin}-{fmax} Hz. Outside it the model
extrapolates and the FMU returns one warning status per excursion (output <code>in_envelope</code>).
NaN or infinite inputs are rejected with an error status naming the variable.</li>
<li><b>Model</b>: "{name}" ({provenance}). The model JSON is in <code>resources/model.json</code>;
the String parameter <code>model_file</code> loads another one at run time.</li>
</ul>
<h2>Variables</h2>
<p>SI units on the interface; display units for people (m shown as mm, rad/s as Hz).</p>
<table><tr><th>name</th><th>causality</th><th>unit</th><th>display</th><th>start</th><th>description</th></tr>
{rows}</table>
<h2>Source</h2>
<p>Seed paper: <i>Physics-Based Reduced-Order Modeling of Magnetic Microparticle Swarms for Biomedical
Control</i> (Table I, Eqs. (1)-(7)). The constants Table I leaves out are a documented reconstruction
(magswarm <code>docs/reconstruction.md</code>); <code>magswarm paper</code> prints each reported figure
beside the model's.</p>
<p>Capabilities: variable communication step size, get/set and serialize FMU state, directional
derivatives (analytic; knowns <code>z_m</code>, <code>omega_m</code>, <code>r1</code>, <code>r2</code>),
any number of instances.</p>
</body></html>
"#,
        crate_version = env!("CARGO_PKG_VERSION"),
        radius_mm = m.radius_m * 1e3,
        br = m.remanence_t,
        moment = m.dipole_moment(),
        zmin = e.z_min_m * 1e3,
        zmax = e.z_max_m * 1e3,
        fmin = e.f_min_hz,
        fmax = e.f_max_hz,
        name = esc(&model.name),
        provenance = esc(&model.provenance),
    )
}

/// The `start` attribute of variable `name` in a generated modelDescription (FMI 2.0's
/// `<ScalarVariable>` or FMI 3.0's typed element).
fn start_in_xml(xml: &str, name: &str) -> Option<String> {
    let at = xml.find(&format!("name=\"{name}\""))?;
    let rest = &xml[at..];
    let end = rest.find("</ScalarVariable>").or_else(|| rest.find("/>"))?;
    let block = &rest[..end];
    let s = block.find("start=\"")? + 7;
    let e = block[s..].find('"')?;
    Some(block[s..s + e].to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn documentation_lists_every_variable_with_the_baked_start_values() {
        let mut model = Model::paper();
        model.name = "rig <A>".into();
        for version in [FmiVersion::V2, FmiVersion::V3] {
            let xml = model_description(&model, version);
            let html = documentation_html(&xml, &model, version);
            for v in magswarm_fmu::model_info().variables {
                assert!(
                    html.contains(&format!("<code>{}</code>", esc(v.name))),
                    "{}",
                    v.name
                );
            }
            assert!(html.contains("rig &lt;A&gt;"));
            let c1 = start_in_xml(&xml, "C_1").expect("C_1 start in the XML");
            assert!(html.contains(&format!("<td>{}</td>", esc(&c1))));
            assert_eq!(start_in_xml(&xml, "no_such_variable"), None);
            assert!(html.contains(&version.to_string()), "{version}");
        }
    }
}
