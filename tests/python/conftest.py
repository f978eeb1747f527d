"""Shared fixtures for the FMU tests (fmpy and libcosimpy importers).

The FMU under test is $MAGSWARM_FMU, default target/fmu/MagSwarm.fmu (built by `magswarm fmu`,
which scripts/test.sh runs first). When it is absent the tests skip with a reason, except under
CI (env CI set), where a missing FMU is a failure.
"""

from __future__ import annotations

import math
import os
import pathlib
import shutil

import numpy as np
import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]
DEFAULT_FMU = REPO / "target" / "fmu" / "MagSwarm.fmu"
# `magswarm fmu --fmi-version 3` (and `--pid --fmi-version 3`) write these.
DEFAULT_FMU3 = REPO / "target" / "fmu" / "fmi3" / "MagSwarm.fmu"
DEFAULT_PID3 = REPO / "target" / "fmu" / "fmi3" / "MagSwarmPID.fmu"
DEFAULT_PID = REPO / "target" / "fmu" / "MagSwarmPID.fmu"

INPUTS = ("z_m", "omega_m")
OUTPUTS = ("r1", "r2", "r1_ss", "r2_ss", "S_x", "S_y", "B", "g_z", "k_xx", "k_yy")
RADII = ("r1", "r2", "r1_ss", "r2_ss")

TWO_PI = 2.0 * math.pi


def hz(f: float) -> float:
    """Stepper frequency in Hz -> omega_m in rad/s."""
    return TWO_PI * f


def mm(x: float) -> float:
    """Millimetres -> metres."""
    return x * 1e-3


def fmu_path_or_skip(env: str = "MAGSWARM_FMU", default: pathlib.Path = DEFAULT_FMU,
                     command: str = "magswarm fmu") -> pathlib.Path:
    path = pathlib.Path(os.environ.get(env, str(default)))
    if not path.is_absolute():
        path = (REPO / path).resolve()
    if path.is_file():
        return path
    msg = (
        f"FMU not found at {path}: build it with `cargo build --release && target/release/{command}` "
        f"(or set {env})"
    )
    if os.environ.get("CI"):
        pytest.fail(msg + " [CI is set: a missing FMU is a failure]", pytrace=False)
    pytest.skip(msg)


@pytest.fixture(scope="session")
def fmu_path() -> pathlib.Path:
    return fmu_path_or_skip()


@pytest.fixture(scope="session")
def fmu3_path() -> pathlib.Path:
    """The FMI 3.0 plant FMU ($MAGSWARM_FMU3, default target/fmu/fmi3/MagSwarm.fmu)."""
    return fmu_path_or_skip("MAGSWARM_FMU3", DEFAULT_FMU3, "magswarm fmu --fmi-version 3")


@pytest.fixture(scope="session")
def pid_paths() -> dict:
    """The controller FMU in both versions: {2: path, 3: path}."""
    return {
        2: fmu_path_or_skip("MAGSWARM_PID_FMU", DEFAULT_PID, "magswarm fmu --pid"),
        3: fmu_path_or_skip("MAGSWARM_PID_FMU3", DEFAULT_PID3, "magswarm fmu --pid --fmi-version 3"),
    }


def fmi_sim_or_skip() -> str:
    """The `fmi-sim` executable (rust-fmi's simulator, `cargo install fmi-sim`, which
    scripts/setup.sh does): $MAGSWARM_FMI_SIM, the PATH, or ~/.cargo/bin."""
    candidates = [os.environ.get("MAGSWARM_FMI_SIM"), shutil.which("fmi-sim"),
                  str(pathlib.Path(os.environ.get("CARGO_HOME", pathlib.Path.home() / ".cargo")) / "bin" / "fmi-sim")]
    for c in candidates:
        if c and pathlib.Path(c).is_file():
            return c
    msg = "fmi-sim not found: `cargo install fmi-sim --version 0.7.0 --locked` (scripts/setup.sh does it)"
    if os.environ.get("CI"):
        pytest.fail(msg + " [CI is set: a missing importer is a failure]", pytrace=False)
    pytest.skip(msg)


@pytest.fixture(scope="session")
def model_description(fmu_path):
    from fmpy import read_model_description

    return read_model_description(str(fmu_path))


@pytest.fixture(scope="session")
def variables(model_description):
    """name -> fmpy ScalarVariable"""
    return {v.name: v for v in model_description.modelVariables}


@pytest.fixture(scope="session")
def vr(variables):
    """name -> value reference, looked up from modelDescription.xml (never hard-coded)."""
    missing = [n for n in INPUTS + OUTPUTS if n not in variables]
    assert not missing, f"modelDescription.xml lacks contract variables: {missing}"
    return {name: v.valueReference for name, v in variables.items()}


@pytest.fixture(scope="session")
def unzipdir(fmu_path, tmp_path_factory):
    from fmpy import extract

    d = extract(str(fmu_path), unzipdir=str(tmp_path_factory.mktemp("MagSwarm_fmu")))
    yield d
    shutil.rmtree(d, ignore_errors=True)


class LogCapture:
    """fmi2CallbackFunctions whose logger records (status, category, message).

    fmpy quirk: fmpy.logging.addLoggerProxy (which formats the FMU's printf-style message in C)
    keeps ONE process-wide pointer to the Python logger of the last callbacks it was given, and
    uses it for every instance, fmpy's default callbacks included. If that ctypes callback is
    garbage-collected, the next message from any FMU segfaults the interpreter. So there is one
    capture for the whole session, kept alive here, and tests clear it (fixture fmu_log).
    """

    def __init__(self):
        import ctypes

        from fmpy import calloc, free
        from fmpy.fmi2 import (fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                               fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)
        from fmpy.logging import addLoggerProxy

        self.messages = []

        def logger(component, instance_name, status, category, message):
            self.messages.append((status, (category or b"").decode(errors="replace"),
                                  (message or b"").decode(errors="replace")))

        self._logger = logger
        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = fmi2CallbackLoggerTYPE(logger)
        self.callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self.callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        addLoggerProxy(ctypes.byref(self.callbacks))


_LOG_CAPTURE = None


@pytest.fixture
def fmu_log():
    global _LOG_CAPTURE
    if _LOG_CAPTURE is None:
        _LOG_CAPTURE = LogCapture()  # lives until the process ends (see LogCapture)
    _LOG_CAPTURE.messages.clear()
    return _LOG_CAPTURE


class Slave:
    """A thin wrapper over fmpy's FMU2Slave: instantiate + initialise, step with inputs, read outputs."""

    def __init__(self, model_description, unzipdir, vr, name="instance", z=None, omega=None,
                 callbacks=None, logging_on=False):
        from fmpy.fmi2 import FMU2Slave

        self.md = model_description
        self.vr = vr
        self.fmu = FMU2Slave(
            guid=model_description.guid,
            unzipDirectory=unzipdir,
            modelIdentifier=model_description.coSimulation.modelIdentifier,
            instanceName=name,
        )
        self.fmu.instantiate(callbacks=callbacks, loggingOn=logging_on)
        self.t = 0.0
        self.initialize(z, omega)

    def initialize(self, z=None, omega=None, t0=0.0):
        self.fmu.setupExperiment(startTime=t0)
        self.fmu.enterInitializationMode()
        if z is not None:
            self.set_inputs(z, omega)
        self.fmu.exitInitializationMode()
        self.t = t0

    def set_inputs(self, z, omega):
        self.fmu.setReal([self.vr["z_m"], self.vr["omega_m"]], [float(z), float(omega)])

    def outputs(self, names=OUTPUTS):
        return np.array(self.fmu.getReal([self.vr[n] for n in names]))

    def step(self, h):
        self.fmu.doStep(currentCommunicationPoint=self.t, communicationStepSize=h)
        self.t += h

    def run(self, schedule, h=0.01, names=OUTPUTS):
        """schedule: sequence of (z_m, omega_m), one per step, set before each doStep.
        Returns an array (steps, len(names)) of the outputs after each step."""
        out = np.empty((len(schedule), len(names)))
        for k, (z, w) in enumerate(schedule):
            self.set_inputs(z, w)
            self.step(h)
            out[k] = self.outputs(names)
        return out

    def free(self):
        if self.fmu is not None:
            self.fmu.terminate()
            self.fmu.freeInstance()
            self.fmu = None


@pytest.fixture
def make_slave(model_description, unzipdir, vr):
    made = []

    def make(name="instance", **kw):
        s = Slave(model_description, unzipdir, vr, name=name, **kw)
        made.append(s)
        return s

    yield make
    for s in made:
        if s.fmu is not None:
            try:
                s.fmu.freeInstance()
            except Exception:
                pass


def step_schedule(segments, h=0.01):
    """[(duration_s, z_mm, f_hz), ...] -> per-step list of (z_m [m], omega_m [rad/s])."""
    sched = []
    for dur, z_mm, f_hz in segments:
        sched += [(mm(z_mm), hz(f_hz))] * int(round(dur / h))
    return sched


# A schedule inside the validated envelope (z_m 3.5-23.5 mm, f 1-10 Hz) with steps in both inputs.
SCHEDULE_SEGMENTS = [(1.0, 8.5, 4.0), (1.0, 13.5, 4.0), (1.0, 13.5, 7.0), (1.0, 6.0, 2.0)]


BLIND = REPO / "scripts" / "blind"


def blind_script(name: str):
    """A module of scripts/blind (the independent generators and their scorer), loaded by path."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(f"blind_{name}", BLIND / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def magswarm_exe_or_skip() -> pathlib.Path:
    """The release `magswarm` ($MAGSWARM_BIN, default target/release/magswarm): skips without
    it, fails under CI."""
    exe = pathlib.Path(os.environ.get("MAGSWARM_BIN", REPO / "target" / "release" / "magswarm"))
    if not exe.is_file():
        msg = f"{exe} not built (cargo build --release)"
        if os.environ.get("CI"):
            pytest.fail(msg, pytrace=False)
        pytest.skip(msg)
    return exe


def diagnose_scored(score, scn: dict, logdir: pathlib.Path):
    """Diagnose one generated log with the release binary and score it (`score` is the
    scripts/blind/score.py module): (scenario, run result, score); fails where diagnose does."""
    res = score.run_one(scn, logdir, logdir / "diag", [])
    assert res["rc"] == 0, f"diagnose failed on {scn['name']}: {res['stderr']}"
    return scn, res, score.score(res)
