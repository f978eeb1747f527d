//! `magswarm-bridge fmu` (a module of the binary): package `MagSwarmRig.fmu` from the compiled
//! rig FMU library (crate `magswarm-rig-fmu`), the stepper watchdog program and a baked rig
//! config, in the archive layout of `magswarm-packaging`.
//!
//! ```text
//! MagSwarmRig.fmu
//!   modelDescription.xml                 asked from the library, with the config's values
//!   binaries/linux64/MagSwarmRig.so
//!   resources/rig.toml                   the baked config (magswarm_bridge::bake)
//!   resources/shadow-model.json, ...     model files the config names
//!   resources/magswarm-stepper-watchdog  (0755) stops the motor if the host dies
//!   documentation/index.html
//! ```

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use magswarm_bridge::bake::{self, Baked};
use magswarm_bridge::watchdog;
use magswarm_packaging::archive::{self, Entry};
use magswarm_packaging::{library, stale};

/// Model identifier of the rig FMU.
pub const MODEL_IDENTIFIER: &str = "MagSwarmRig";
/// Cargo package of the rig FMU library.
pub const CRATE: &str = "magswarm-rig-fmu";
/// File name of the compiled library.
pub const LIB_FILE: &str = "libmagswarm_rig_fmu.so";
/// Environment variable naming the library to package instead of building it.
pub const LIB_ENV: &str = "MAGSWARM_RIG_FMU_LIB";

/// What to package.
pub struct Request<'a> {
    /// The rig config.
    pub config: &'a Path,
    /// The archive to write.
    pub out: &'a Path,
    /// The library (default: found, or built, like `magswarm fmu` does).
    pub lib: Option<PathBuf>,
    /// Do not run cargo.
    pub no_build: bool,
    /// The watchdog program (default: beside this executable).
    pub watchdog: Option<PathBuf>,
}

/// Build the archive; returns a summary.
pub fn package(r: &Request<'_>) -> Result<String> {
    let baked = bake::bake(r.config)?;
    let lib = match &r.lib {
        Some(l) => l.clone(),
        None => library::locate_library(CRATE, LIB_FILE, LIB_ENV, r.no_build)?,
    };
    let so = archive::read_shared_library(&lib)?;
    let wd = watchdog::locate(r.watchdog.clone())?;
    let wd_bytes = std::fs::read(&wd).with_context(|| format!("reading {}", wd.display()))?;
    let xml = library::xml_from_library(&lib, &baked.text, "rig config")?;
    stale::check_model_identifier(&lib, &xml, MODEL_IDENTIFIER)?;
    let guid = stale::attr(&xml, "guid").unwrap_or_default();
    let doc = documentation_html(&baked, r.config);
    let mut entries = vec![
        Entry::model_description(&xml),
        Entry::binary(MODEL_IDENTIFIER, &so),
        Entry::resource("rig.toml", baked.text.as_bytes()),
    ];
    for (name, bytes) in &baked.files {
        entries.push(Entry::resource(name, bytes));
    }
    entries.push(Entry {
        name: format!("resources/{}", watchdog::PROGRAM),
        data: &wd_bytes,
        executable: true,
    });
    entries.push(Entry::documentation(&doc));
    let bytes = archive::fmu_zip(&entries)?;
    archive::write_atomic(r.out, &bytes)?;
    let mut s = format!(
        "wrote {} ({} kB): FMI 2.0 Co-Simulation, model identifier {MODEL_IDENTIFIER}, GUID {guid}, \
         {} variables; rig config {} baked into resources/rig.toml{}, stepper watchdog in \
         resources/{}",
        r.out.display(),
        bytes.len() / 1024,
        xml.matches("<ScalarVariable").count(),
        r.config.display(),
        if baked.files.is_empty() {
            String::new()
        } else {
            format!(
                " (with {})",
                baked
                    .files
                    .iter()
                    .map(|f| f.0.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        },
        watchdog::PROGRAM
    );
    for o in &baked.outside {
        s.push_str(&format!("\n  outside the FMU (absolute path): {o}"));
    }
    Ok(s)
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// `documentation/index.html`: what the FMU does to the rig, and the baked config.
fn documentation_html(baked: &Baked, config: &Path) -> String {
    format!(
        r#"<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>MagSwarmRig FMU</title>
<style>body{{font-family:sans-serif;max-width:60em;margin:2em auto;line-height:1.45}}
pre,code{{background:#f3f3f3}}</style></head><body>
<h1>MagSwarmRig {version}: the magnetic swarm rig as an FMU (FMI 2.0 Co-Simulation)</h1>
<p>The interface of MagSwarm.fmu on hardware: inputs <code>z_m</code> [m] and <code>omega_m</code>
[rad/s] go to the robot arm and the stepper through magswarm-bridge's safety core (clamps to the
limits, rate limits, a non-finite value is refused); outputs <code>r1</code>, <code>r2</code> [m] are
the camera's measurement of the swarm (<code>valid</code> false when the newest frame shows none),
<code>r1_shadow</code>, <code>r2_shadow</code> the shadow model's.</p>
<ul>
<li><b>Real time.</b> fmi2DoStep(t, h) returns when the wall clock reaches t + h (the first step
anchors the FMU's time). A step that is already late returns at once with fmi2Warning; the outputs
<code>late</code> and <code>late_steps</code> show it. A host that does not call fmi2DoStep for more
than <code>max_late</code> after a step was due stops the rig (fault <code>host_stalled</code>).</li>
<li><b>Faults</b> (protective stop, lost RTDE link, camera timeout, stepper errors) stop the stepper
and hold the robot at once; fmi2DoStep then returns fmi2Error with the fault's name in the log.</li>
<li><b>End.</b> fmi2Terminate and fmi2FreeInstance stop the stepper (MST) and hold the robot. If the
host process dies, <code>resources/magswarm-stepper-watchdog</code> stops the stepper and the robot
program stops on its RTDE watchdog.</li>
<li><b>Parameters.</b> The limits may be narrowed before initialisation, never widened; the
calibration is read-only; <code>config_file</code> runs another rig config.</li>
<li>No FMU state (a rig cannot go back in time), no directional derivatives.</li>
</ul>
<h2>The rig config (resources/rig.toml, from {src})</h2>
<pre>{cfg}</pre>
</body></html>
"#,
        version = env!("CARGO_PKG_VERSION"),
        src = esc(&config.display().to_string()),
        cfg = esc(&baked.text),
    )
}
