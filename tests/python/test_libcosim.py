"""MagSwarm.fmu in libcosim (OSP's co-simulation engine on FMI Library, via libcosimpy).

libcosim runs in a child process (see _libcosim_run.py): a load failure in libcosimpy is a
segfault, not an exception. Its outputs are compared with fmpy's at the same communication points.
"""

from __future__ import annotations

import json
import pathlib
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest

from conftest import OUTPUTS, Slave, hz, mm

RUNNER = pathlib.Path(__file__).with_name("_libcosim_run.py")
STEP = 0.01
STEP_NS = 10_000_000
STEPS = 300  # 3 s
INITIAL = {"z_m": mm(8.5), "omega_m": hz(4.0)}
CHANGES = [(100, {"z_m": mm(13.5)}), (200, {"z_m": mm(6.0), "omega_m": hz(7.0)})]
RTOL = 1e-9

FMIL_ERROR = re.compile(r"\[error\].*", re.IGNORECASE)


def run_libcosim(cfg: dict) -> tuple[dict, str]:
    proc = subprocess.run([sys.executable, str(RUNNER), json.dumps(cfg)], capture_output=True, text=True,
                          timeout=300)
    log = proc.stderr.strip()
    last = proc.stdout.strip().splitlines()[-1] if proc.stdout.strip() else ""
    if proc.returncode != 0:
        crash = f"crashed with signal {-proc.returncode}" if proc.returncode < 0 else f"exit {proc.returncode}"
        pytest.fail(f"libcosim run {crash}: {last}\n--- libcosim log ---\n{log[-4000:]}", pytrace=False)
    return json.loads(last), log


def fmpy_reference(model_description, unzipdir, vr):
    s = Slave(model_description, unzipdir, vr, name="fmpy_ref", z=INITIAL["z_m"], omega=INITIAL["omega_m"])
    try:
        inputs = dict(INITIAL)
        changes = dict(CHANGES)
        out = np.empty((STEPS, len(OUTPUTS)))
        for k in range(STEPS):
            if k in changes:
                inputs.update(changes[k])
                s.set_inputs(inputs["z_m"], inputs["omega_m"])
            s.step(STEP)
            out[k] = s.outputs()
        return out
    finally:
        s.free()


def assert_close(actual, expected, what):
    actual, expected = np.asarray(actual), np.asarray(expected)
    assert np.all(np.isfinite(actual)), f"{what}: non-finite libcosim outputs"
    err = np.abs(actual - expected)
    bad = err > RTOL * np.maximum(np.abs(expected), 1e-300)
    if bad.any():
        k, j = np.argwhere(bad)[0]
        pytest.fail(f"{what}: libcosim and fmpy differ at step {k}, {OUTPUTS[j]}: "
                    f"{actual[k, j]!r} vs {expected[k, j]!r} ({bad.sum()} values beyond rel {RTOL})",
                    pytrace=False)


def test_libcosim_matches_fmpy_with_overridden_inputs(fmu_path, model_description, unzipdir, vr):
    res, log = run_libcosim({
        "mode": "single", "fmu": str(fmu_path), "step_ns": STEP_NS, "steps": STEPS,
        "initial": INITIAL, "changes": CHANGES, "outputs": list(OUTPUTS),
    })
    errors = FMIL_ERROR.findall(log)
    assert not errors, "libcosim / FMI Library reported errors loading the FMU:\n" + "\n".join(errors)

    assert res["t_ns"] == [STEP_NS * (k + 1) for k in range(STEPS)]
    assert_close(res["values"], fmpy_reference(model_description, unzipdir, vr), "libcosim vs fmpy")


def test_libcosim_reports_a_nan_input_as_a_model_error(fmu_path):
    proc = subprocess.run([sys.executable, str(RUNNER), json.dumps({
        "mode": "single", "fmu": str(fmu_path), "step_ns": STEP_NS, "steps": 5,
        "initial": INITIAL, "changes": [[2, {"z_m": float("nan")}]], "outputs": ["r1"],
    })], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 3, f"expected a failed step (exit 3), got {proc.returncode}:\n{proc.stdout}\n{proc.stderr}"
    # libcosim prints the FMU's log lines too (after a failed step it calls fmi2Terminate, which
    # the standard does not allow in the Error state and the FMU refuses, with a message).
    res = json.loads([l for l in proc.stdout.strip().splitlines() if l.startswith("{")][-1])
    assert "step 2 failed" in res["error"], res
    assert res["status"]["state"] == "ERROR", res
    assert "z_m" in res["error"] + proc.stderr, "libcosim's error does not name the variable"


SSD = """<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription name="magswarm" version="1.0"
    xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"
    xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon"
    xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"
    xmlns:osp="http://opensimulationplatform.com/SSP/OSPAnnotations">
  <ssd:System name="magswarm-system">
    <ssd:Elements>
      <ssd:Component name="swarm" source="MagSwarm.fmu">
        <ssd:Connectors>
          <ssd:Connector name="z_m" kind="input"><ssc:Real/></ssd:Connector>
          <ssd:Connector name="omega_m" kind="input"><ssc:Real/></ssd:Connector>
        </ssd:Connectors>
        <ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues>
          <ssv:ParameterSet version="1.0" name="initialValues"><ssv:Parameters>
            <ssv:Parameter name="z_m"><ssv:Real value="{z!r}"/></ssv:Parameter>
            <ssv:Parameter name="omega_m"><ssv:Real value="{w!r}"/></ssv:Parameter>
          </ssv:Parameters></ssv:ParameterSet>
        </ssd:ParameterValues></ssd:ParameterBinding></ssd:ParameterBindings>
      </ssd:Component>
    </ssd:Elements>
  </ssd:System>
  <ssd:DefaultExperiment startTime="0.0"><ssd:Annotations>
    <ssc:Annotation type="com.opensimulationplatform">
      <osp:Algorithm><osp:FixedStepAlgorithm baseStepSize="{h!r}"/></osp:Algorithm>
    </ssc:Annotation>
  </ssd:Annotations></ssd:DefaultExperiment>
</ssd:SystemStructureDescription>
"""

OSP = """<?xml version="1.0" encoding="UTF-8"?>
<OspSystemStructure xmlns="http://opensimulationplatform.com/MSMI/OSPSystemStructure" version="0.1">
  <StartTime>0.0</StartTime>
  <BaseStepSize>{h!r}</BaseStepSize>
  <Algorithm>fixedStep</Algorithm>
  <Simulators>
    <Simulator name="swarm" source="MagSwarm.fmu">
      <InitialValues>
        <InitialValue variable="z_m"><Real value="{z!r}"/></InitialValue>
        <InitialValue variable="omega_m"><Real value="{w!r}"/></InitialValue>
      </InitialValues>
    </Simulator>
  </Simulators>
</OspSystemStructure>
"""


@pytest.mark.parametrize("kind", ["ssp", "osp"])
def test_system_file_runs_in_libcosim(kind, fmu_path, model_description, unzipdir, vr, tmp_path):
    """The FMU loads from an SSP system structure and an OSP config, as the closed loop with the PID FMU does."""
    z, w = mm(13.5), hz(6.0)
    shutil.copy(fmu_path, tmp_path / "MagSwarm.fmu")
    text = (SSD if kind == "ssp" else OSP).format(z=z, w=w, h=STEP)
    (tmp_path / ("SystemStructure.ssd" if kind == "ssp" else "OspSystemStructure.xml")).write_text(text)
    res, _ = run_libcosim({"mode": kind, "path": str(tmp_path), "instance": "swarm",
                           "until_ns": 100 * STEP_NS, "outputs": list(OUTPUTS)})
    assert res["t_ns"] == [100 * STEP_NS]

    s = Slave(model_description, unzipdir, vr, name="fmpy_sys", z=z, omega=w)
    try:
        for _ in range(100):
            s.step(STEP)
        expected = s.outputs()
    finally:
        s.free()
    assert_close([res["values"][0]], [expected], f"{kind} system vs fmpy")
