//! The yardstick FMU `Euler2.fmu`: one forward-Euler step of a two-state ODE per `fmi2DoStep`,
//! no checks (`benches/fixture/euler2.c`). It is compiled here, at run time, with the system C
//! compiler (`$CC`, else `cc`) and packaged as an FMI 2.0 Co-Simulation FMU, so that the
//! benches load it through exactly the same importer (unzip, XML, `dlopen`) as `MagSwarm.fmu`.
//!
//! Variables: inputs `u1`, `u2` (value references 0, 1), outputs `x1`, `x2` (2, 3).

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, Context, Result};

/// The C source of the fixture.
pub const SOURCE: &str = include_str!("../../benches/fixture/euler2.c");

/// Model identifier (and binary name) of the fixture.
pub const MODEL_IDENTIFIER: &str = "Euler2";

const GUID: &str = "{4e6f9a2c-0b1d-4c55-9a3e-7f1e2d3c4b5a}";

/// modelDescription.xml of the fixture.
pub fn model_description() -> String {
    format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="{id}" guid="{GUID}"
    description="Benchmark yardstick: one forward-Euler step of a 2-state ODE per doStep"
    generationTool="magswarm perf fixture" variableNamingConvention="flat" numberOfEventIndicators="0">
  <CoSimulation modelIdentifier="{id}" canHandleVariableCommunicationStepSize="true"/>
  <ModelVariables>
    <ScalarVariable name="u1" valueReference="0" causality="input" variability="continuous"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="u2" valueReference="1" causality="input" variability="continuous"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="x1" valueReference="2" causality="output" variability="continuous" initial="exact"><Real start="1"/></ScalarVariable>
    <ScalarVariable name="x2" valueReference="3" causality="output" variability="continuous" initial="exact"><Real start="0"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure>
    <Outputs>
      <Unknown index="3" dependencies=""/>
      <Unknown index="4" dependencies=""/>
    </Outputs>
  </ModelStructure>
</fmiModelDescription>
"#,
        id = MODEL_IDENTIFIER
    )
}

/// Compile the fixture into `dir` and package it; returns the path of `dir/Euler2.fmu`.
/// Errors name the compiler command and its output.
pub fn build(dir: &Path) -> Result<PathBuf> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let src = dir.join("euler2.c");
    std::fs::write(&src, SOURCE).with_context(|| format!("cannot write {}", src.display()))?;
    let so = dir.join(format!("{MODEL_IDENTIFIER}.so"));
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".to_string());
    let out = Command::new(&cc)
        .args(["-O2", "-shared", "-fPIC", "-fvisibility=hidden", "-o"])
        .arg(&so)
        .arg(&src)
        .output()
        .with_context(|| format!("cannot run the C compiler `{cc}` (set CC to choose one)"))?;
    if !out.status.success() {
        bail!(
            "`{cc} -O2 -shared -fPIC -o {} {}` failed ({}):\n{}",
            so.display(),
            src.display(),
            out.status,
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let binary = std::fs::read(&so).with_context(|| format!("cannot read {}", so.display()))?;
    let fmu = dir.join(format!("{MODEL_IDENTIFIER}.fmu"));
    // The same archive layout as MagSwarm.fmu (crate magswarm-packaging), plus the C source.
    use magswarm_packaging::archive::{fmu_zip, Entry};
    let xml = model_description();
    let bytes = fmu_zip(&[
        Entry::model_description(&xml),
        Entry::binary(
            MODEL_IDENTIFIER,
            &binary,
            magswarm_packaging::FmiVersion::V2,
        ),
        Entry::file("sources/euler2.c", SOURCE.as_bytes()),
    ])
    .with_context(|| format!("cannot package {}", fmu.display()))?;
    std::fs::write(&fmu, bytes).with_context(|| format!("cannot write {}", fmu.display()))?;
    Ok(fmu)
}
