"""Both FMUs (MagSwarm.fmu and MagSwarmPID.fmu) pass fmpy's validation and load, initialise and
run in libcosim with its logging at the most verbose level (TRACE) without one warning or error.

libcosimpy 0.0.6 segfaults instead of raising when an FMU fails to load, so libcosim runs in a
subprocess (tests/python/_libcosim_run.py)."""

import json
import os
import pathlib
import subprocess
import sys

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]
RUNNER = pathlib.Path(__file__).with_name("_libcosim_run.py")


@pytest.fixture(scope="module")
def pid_fmu_path(tmp_path_factory) -> pathlib.Path:
    env = os.environ.get("MAGSWARM_PID_FMU")
    if env:
        return pathlib.Path(env).resolve()
    exe = REPO / "target" / "release" / "magswarm"
    if not exe.is_file():
        pytest.fail(f"{exe} missing: run `cargo build --release --workspace`")
    out = tmp_path_factory.mktemp("pidfmu") / "MagSwarmPID.fmu"
    proc = subprocess.run([str(exe), "fmu", "--pid", "--no-build", "--out", str(out)], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, f"magswarm fmu --pid failed:\n{proc.stdout}\n{proc.stderr}"
    return out


def both(fmu_path, pid_fmu_path):
    return {"MagSwarm": (fmu_path, ["r1", "r2"]), "MagSwarmPID": (pid_fmu_path, ["z_m", "omega_m"])}


@pytest.mark.parametrize("which", ["MagSwarm", "MagSwarmPID"])
def test_fmpy_validate_reports_no_problems(which, fmu_path, pid_fmu_path):
    from fmpy.validation import validate_fmu

    path, _ = both(fmu_path, pid_fmu_path)[which]
    problems = validate_fmu(str(path))
    assert problems == [], f"{which}: " + "\n".join(problems)


@pytest.mark.parametrize("which", ["MagSwarm", "MagSwarmPID"])
def test_libcosim_at_trace_level_logs_no_warning(which, fmu_path, pid_fmu_path):
    path, outputs = both(fmu_path, pid_fmu_path)[which]
    proc = subprocess.run([sys.executable, str(RUNNER), json.dumps({
        "mode": "single", "fmu": str(path), "step_ns": 50_000_000, "steps": 20, "outputs": outputs,
        "log_level": "TRACE",
    })], capture_output=True, text=True, timeout=300)
    text = proc.stdout + proc.stderr
    assert proc.returncode == 0, f"{which}: libcosim run failed ({proc.returncode}):\n{text[-4000:]}"
    lines = text.splitlines()
    bad = [l for l in lines if "[warning]" in l.lower() or "[error]" in l.lower() or "[fatal]" in l.lower()]
    assert bad == [], f"{which}: libcosim warnings/errors at TRACE level:\n" + "\n".join(bad)
    res = json.loads([l for l in lines if l.startswith("{")][-1])
    assert len(res["t_ns"]) == 20
    # The trace level really was on (FMI Library's own debug lines are there).
    assert sum("[trace]" in l.lower() or "[debug]" in l.lower() for l in lines) > 0, text[-2000:]
    print(f"{which}: {len(lines)} libcosim log lines at TRACE, 0 warnings, 0 errors")
