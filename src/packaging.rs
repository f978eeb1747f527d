//! `magswarm fmu`: build and package `MagSwarm.fmu`.
//!
//! An FMU is a zip with `modelDescription.xml`, the shared library under
//! `binaries/<platform>/`, `resources/` and `documentation/`. The XML comes from the same
//! variable table the library is compiled from (`magswarm_fmu::model_description`), the
//! parameter start values from the model that is baked into `resources/model.json`, so an
//! importer that sets every parameter to its start value gets exactly the baked model.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, Context, Result};
use magswarm_model::Model;

/// Arguments of `magswarm fmu`.
#[derive(Debug, clap::Args)]
pub struct FmuArgs {
    /// Model JSON to bake into resources/ as the FMU's default model (default: paper model).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Output path of the FMU [default: target/fmu/MagSwarm.fmu, with --pid
    /// target/fmu/MagSwarmPID.fmu].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// The compiled shared library to package (default: build it with cargo, or take
    /// libmagswarm_fmu.so beside this executable).
    #[arg(long)]
    pub lib: Option<PathBuf>,
    /// Do not run cargo; package the library found beside this executable.
    #[arg(long)]
    pub no_build: bool,
    /// Only write modelDescription.xml to this path (no build, no zip).
    #[arg(long, value_name = "PATH")]
    pub xml: Option<PathBuf>,
    // --- issue 4: the controller FMU (src/pid_fmu_packaging.rs) ---
    /// Package the controller FMU MagSwarmPID.fmu instead (crate magswarm-pid-fmu; default
    /// --out target/fmu/MagSwarmPID.fmu; --model is the plant model the controller assumes,
    /// --lib the controller's libmagswarm_pid_fmu.so).
    #[arg(long)]
    pub pid: bool,
    /// With --pid: controller configuration JSON (magswarm-pid/1) baked into resources/pid.json.
    #[arg(long, value_name = "CFG.json", requires = "pid")]
    pub pid_config: Option<PathBuf>,
}

/// `magswarm fmu --pid`: the controller FMU (issue 4), kept in its own file.
#[path = "pid_fmu_packaging.rs"]
pub mod pid;

/// Where `magswarm fmu` writes the plant FMU unless told otherwise.
pub const DEFAULT_OUT: &str = "target/fmu/MagSwarm.fmu";

/// File name of the compiled cdylib on this platform.
pub const LIB_FILE: &str = "libmagswarm_fmu.so";
/// Platform folder inside the FMU.
pub const PLATFORM: &str = "linux64";

/// Run the command.
pub fn run(a: &FmuArgs) -> Result<()> {
    if a.pid {
        return pid::run(a);
    }
    let model = match &a.model {
        Some(p) => Model::load(p).with_context(|| format!("--model {}", p.display()))?,
        None => Model::paper(),
    };
    if let Some(xml_path) = &a.xml {
        let xml = magswarm_fmu::model_description(&model, None);
        write_atomic(xml_path, xml.as_bytes())?;
        println!("wrote {}", xml_path.display());
        return Ok(());
    }
    let lib = match &a.lib {
        Some(p) => p.clone(),
        None => locate_library("magswarm-fmu", LIB_FILE, "MAGSWARM_FMU_LIB", a.no_build)?,
    };
    let out = a.out.clone().unwrap_or_else(|| PathBuf::from(DEFAULT_OUT));
    let summary = package(&model, &lib, &out)?;
    println!("{summary}");
    Ok(())
}

/// Find (and unless `no_build`, build) the shared library of the FMU crate `krate`
/// (`lib_file` on disk): `$env_var` if set, else `cargo build -p krate` in the workspace this
/// executable was built in (same profile) and the library beside the executable.
pub(crate) fn locate_library(
    krate: &str,
    lib_file: &str,
    env_var: &str,
    no_build: bool,
) -> Result<PathBuf> {
    if let Ok(p) = std::env::var(env_var) {
        return Ok(PathBuf::from(p));
    }
    let exe = std::env::current_exe().context("cannot locate the magswarm executable")?;
    let exe_dir = exe.parent().map(Path::to_path_buf).unwrap_or_default();
    // target/<profile>/magswarm -> the workspace two levels up, if this is a source build.
    let workspace = exe_dir
        .ancestors()
        .find(|d| d.join(format!("crates/{krate}/Cargo.toml")).is_file());
    if let (false, Some(ws)) = (no_build, workspace) {
        let profile = exe_dir
            .file_name()
            .and_then(|s| s.to_str())
            .unwrap_or("release");
        let mut cmd = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
        cmd.current_dir(ws).args(["build", "-p", krate]);
        if profile == "release" {
            cmd.arg("--release");
        }
        eprintln!("building the FMU library: cargo build -p {krate} ({profile})");
        let status = cmd
            .status()
            .with_context(|| format!("cannot run cargo to build {krate}"))?;
        if !status.success() {
            bail!("cargo build -p {krate} failed ({status})");
        }
    }
    let lib = exe_dir.join(lib_file);
    if !lib.is_file() {
        bail!(
            "{} not found; build it with `cargo build --release -p {krate}` or pass --lib PATH",
            lib.display()
        );
    }
    Ok(lib)
}

/// Package `lib` with `model` baked in as `out`; returns a one-paragraph summary.
pub fn package(model: &Model, lib: &Path, out: &Path) -> Result<String> {
    let so = std::fs::read(lib).with_context(|| format!("cannot read {}", lib.display()))?;
    if so.len() < 4 || &so[..4] != b"\x7fELF" {
        bail!("{} is not an ELF shared library", lib.display());
    }
    let model_json = model.to_json()?;
    let xml = xml_from_library(lib, &model_json, "model")?;
    // The CLI links the same table as an rlib (for the documentation page); if the two
    // disagree the library is stale and the FMU would fail its GUID check in importers.
    let guid = magswarm_fmi2::guid::<magswarm_fmu::MagSwarm>();
    if !xml.contains(&format!("guid=\"{guid}\"")) {
        bail!(
            "{} was built from other sources than this magswarm binary (GUID differs); \
             rebuild both with `cargo build --release --workspace`",
            lib.display()
        );
    }
    let doc = documentation_html(&xml, model);

    let mut buf = std::io::Cursor::new(Vec::new());
    {
        let mut zip = zip::ZipWriter::new(&mut buf);
        let deflate = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated);
        let exec = deflate.unix_permissions(0o755);
        let entries: [(&str, &[u8], zip::write::SimpleFileOptions); 4] = [
            ("modelDescription.xml", xml.as_bytes(), deflate),
            (
                &format!("binaries/{PLATFORM}/{}.so", magswarm_fmu::MODEL_IDENTIFIER),
                &so,
                exec,
            ),
            (
                &format!("resources/{}", magswarm_fmu::RESOURCE_MODEL),
                model_json.as_bytes(),
                deflate,
            ),
            ("documentation/index.html", doc.as_bytes(), deflate),
        ];
        for (name, data, opts) in entries {
            zip.start_file(name, opts)
                .with_context(|| format!("zip entry {name}"))?;
            zip.write_all(data)?;
        }
        zip.finish().context("cannot finish the FMU zip")?;
    }
    let bytes = buf.into_inner();
    write_atomic(out, &bytes)?;
    Ok(format!(
        "wrote {} ({} kB): FMI 2.0 Co-Simulation, model identifier {}, GUID {guid}, \
         {} variables, model \"{}\" baked into resources/{}",
        out.display(),
        bytes.len() / 1024,
        magswarm_fmu::MODEL_IDENTIFIER,
        magswarm_fmu::model_info().variables.len(),
        model.name,
        magswarm_fmu::RESOURCE_MODEL
    ))
}

/// Ask the compiled library itself for its modelDescription.xml (the `fmu_model_description`
/// symbol of `magswarm_fmi2::export_describe!`), with the defaults of `json` baked in, so the
/// XML packaged beside a binary is the one that binary was compiled from. `what` names the
/// JSON in errors ("model", "controller configuration").
pub(crate) fn xml_from_library(lib: &Path, json: &str, what: &str) -> Result<String> {
    type Describe = unsafe extern "C" fn(*const std::ffi::c_char) -> *mut std::ffi::c_char;
    type Free = unsafe extern "C" fn(*mut std::ffi::c_char);
    let json = std::ffi::CString::new(json).with_context(|| format!("{what} JSON contains NUL"))?;
    // SAFETY: loading a magswarm FMU library; the two symbols have exactly these signatures.
    unsafe {
        let l = libloading::Library::new(lib)
            .with_context(|| format!("cannot load {}", lib.display()))?;
        let describe: libloading::Symbol<Describe> = l
            .get(b"fmu_model_description\0")
            .with_context(|| format!("{} is not a magswarm FMU library", lib.display()))?;
        let free: libloading::Symbol<Free> = l.get(b"fmu_free_string\0")?;
        let p = describe(json.as_ptr());
        if p.is_null() {
            bail!("{} rejected the {what}", lib.display());
        }
        let xml = std::ffi::CStr::from_ptr(p).to_string_lossy().into_owned();
        free(p);
        Ok(xml)
    }
}

/// Write a file via a temporary sibling and a rename, creating parent folders.
fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    let tmp = path.with_extension("tmp-magswarm");
    std::fs::write(&tmp, bytes).with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("cannot write {}", path.display()))
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// `documentation/index.html`: what the model is, its variables (from the same table as the
/// XML), units, the envelope and the seed.
pub fn documentation_html(xml: &str, model: &Model) -> String {
    use magswarm_fmi2::{Causality, Start};
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
<h1>MagSwarm {version}: magnetic microparticle swarm (FMI 2.0 Co-Simulation)</h1>
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
extrapolates and the FMU returns one fmi2Warning per excursion (output <code>in_envelope</code>).
NaN or infinite inputs are rejected with fmi2Error.</li>
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
        version = env!("CARGO_PKG_VERSION"),
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

/// The `start` attribute of variable `name` in a generated modelDescription.
fn start_in_xml(xml: &str, name: &str) -> Option<String> {
    let at = xml.find(&format!("name=\"{name}\""))?;
    let rest = &xml[at..];
    let end = rest.find("</ScalarVariable>")?;
    let block = &rest[..end];
    let s = block.find("start=\"")? + 7;
    let e = block[s..].find('"')?;
    Some(block[s..s + e].to_string())
}
