"""MagSwarmRig.fmu (`magswarm-bridge fmu`) driving the emulated rig (`magswarm-bridge emulate`).

The emulator runs as its own process (UR controller on a private loopback address, TMCL stepper
on a pty, every stepper instruction traced with its wall-clock time); the FMU is built from the
same config and imported by fmpy and by libcosim (in a child process: libcosimpy segfaults when
an FMU fails to load). The emulated camera films a swarm whose model has a 1 mm camera offset
while the shadow model has none, so the FMU's r1, r2 can be told from the shadow's: they are
the camera's if and only if they sit 1 mm above r1_shadow, r2_shadow.

Needs target/release/magswarm-bridge, its libmagswarm_rig_fmu.so and magswarm-stepper-watchdog
(`cargo build --release --workspace`), and target/fmu/MagSwarm.fmu for the paper model's JSON.
"""

from __future__ import annotations

import json
import math
import os
import pathlib
import random
import signal
import subprocess
import sys
import textwrap
import time
import zipfile

import numpy as np
import pytest

from conftest import DEFAULT_FMU, REPO

RELEASE = REPO / "target" / "release"
BRIDGE = RELEASE / "magswarm-bridge"
NEEDED = [BRIDGE, RELEASE / "libmagswarm_rig_fmu.so", RELEASE / "magswarm-stepper-watchdog"]
RUNNER = pathlib.Path(__file__).with_name("_libcosim_run.py")
OFFSET_MM = 1.0
ROR, MST = 1, 3
VELOCITY_PER_HZ = 51200.0
TWO_PI = 2.0 * math.pi


def need_binaries():
    missing = [str(p) for p in NEEDED + [DEFAULT_FMU] if not p.is_file()]
    if missing:
        msg = f"not built: {missing} (cargo build --release --workspace && target/release/magswarm fmu)"
        if os.environ.get("CI"):
            pytest.fail(msg + " [CI is set: a failure]", pytrace=False)
        pytest.skip(msg)


CONFIG = """
[robot]
host = "{host}"
z_tcp_at_zero_m = 0.400
# Longer link timeouts than the defaults: a loaded test machine can stall a stream 100 ms.
timeout_s = 0.5
watchdog_hz = 4.0

[stepper]
kind = "tmcl"
device = "{dir}/tmcl"
velocity_per_hz = {vph}
watchdog_timeout_s = 0.5
reply_timeout_s = 0.5

[camera]
kind = "emulated"
mm_per_px = 0.15
fps = 20.0
width = 480
height = 360
model = "biased.json"

[limits]
z_m_mm = [3.5, 23.5]
f_hz = [1.0, 10.0]
z_rate_mm_s = 10.0
f_rate_hz_s = 2.0

[control]
start = [12.0, 4.0]

{extra}
"""


class Rig:
    """One emulated rig (its own process) and the FMU built for it."""

    def __init__(self, d: pathlib.Path, extra: str = ""):
        need_binaries()
        self.dir = d
        host = f"127.{random.randint(2, 250)}.{random.randint(2, 250)}.{random.randint(2, 250)}"
        with zipfile.ZipFile(DEFAULT_FMU) as z:
            model = json.loads(z.read("resources/model.json"))
        model["name"] = "paper model seen through a camera with a 1 mm offset"
        model.setdefault("effects", {})["camera_bias"] = {"scale": 1.0, "offset_mm": OFFSET_MM,
                                                          "tilt_deg": 0.0}
        (d / "biased.json").write_text(json.dumps(model))
        self.config = d / "rig.toml"
        self.config.write_text(CONFIG.format(host=host, dir=d, vph=VELOCITY_PER_HZ, extra=extra))
        self.trace = d / "stepper.csv"
        self.emu_out = open(d / "emulate.out", "w")
        self.emu_err = open(d / "emulate.err", "w")
        self.emu = subprocess.Popen([str(BRIDGE), "emulate", "--config", str(self.config), "--trace",
                                     str(self.trace)], stdout=self.emu_out, stderr=self.emu_err)
        deadline = time.time() + 20
        while "ready" not in (d / "emulate.out").read_text():
            if self.emu.poll() is not None or time.time() > deadline:
                self.close()
                pytest.fail(f"the emulator did not start: {(d / 'emulate.err').read_text()}")
            time.sleep(0.05)
        self.fmu = d / "MagSwarmRig.fmu"
        p = subprocess.run([str(BRIDGE), "fmu", "--config", str(self.config), "--out", str(self.fmu),
                            "--no-build"], capture_output=True, text=True, timeout=120)
        if p.returncode != 0:
            self.close()
            pytest.fail(f"magswarm-bridge fmu failed: {p.stderr}")
        self.build_summary = p.stdout

    def stepper(self):
        """[(t_unix_s, instruction, value)] the emulated module received so far."""
        time.sleep(0.1)  # the emulator appends within 20 ms
        rows = self.trace.read_text().splitlines()[1:]
        return [(float(t), int(i), int(v)) for t, i, _, v in (r.split(",") for r in rows)]

    def close(self):
        if self.emu.poll() is None:
            self.emu.send_signal(signal.SIGTERM)
            try:
                self.emu.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.emu.kill()
        self.emu_out.close()
        self.emu_err.close()


@pytest.fixture
def rig(tmp_path):
    r = Rig(tmp_path)
    yield r
    r.close()


def step_input(t_step=1.0):
    """12 mm / 4 Hz, then 8 mm / 6 Hz from t_step (a repeated time is a step for fmpy)."""
    return np.array([(0.0, 12e-3, TWO_PI * 4.0), (t_step, 12e-3, TWO_PI * 4.0),
                     (t_step, 8e-3, TWO_PI * 6.0)],
                    dtype=[("time", float), ("z_m", float), ("omega_m", float)])


def do_step(s, t, h):
    """fmi2DoStep's status, straight from the library (fmpy's wrapper drops warnings)."""
    import ctypes

    return s.dll.fmi2DoStep(s.component, ctypes.c_double(t), ctypes.c_double(h), 1)


def assert_stopped_at_the_end(rig: Rig, after: float):
    seen = rig.stepper()
    rors = [s for s in seen if s[1] == ROR]
    assert rors, f"the stepper never turned: {seen[:10]}"
    assert max(v for _, _, v in rors) == round(6.0 * VELOCITY_PER_HZ), "6 Hz never reached the stepper"
    motion = [s for s in seen if s[1] in (ROR, MST)]
    assert motion[-1][1] == MST, f"the last motion instruction is not a stop: {motion[-3:]}"
    assert motion[-1][0] >= after, "the stop came before the end"


def test_fmpy_step_drives_the_rig_in_real_time(rig):
    from fmpy import simulate_fmu
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(rig.fmu)) == [], "fmpy validate found problems"
    outputs = ["r1", "r2", "valid", "r1_shadow", "r2_shadow", "z_m_applied", "omega_m_applied",
               "z_m_measured", "t_frame", "late", "late_steps"]
    stop = 3.0
    t0 = time.time()
    res = simulate_fmu(str(rig.fmu), stop_time=stop, step_size=0.05, input=step_input(), output=outputs)
    wall = time.time() - t0
    print(f"fmpy: {stop} s simulated in {wall:.3f} s of wall time ({len(res)} rows); "
          f"late steps {res['late_steps'][-1]}")
    # Paced to the wall clock: never faster than real time; opening the rig adds ~0.5 s.
    assert stop <= wall <= stop + 2.0, wall
    assert res["late_steps"][-1] <= 3, "the host kept up but steps were late"
    # Each row's measurement is a frame taken during that step (20 fps: at most ~2 frames old).
    lag = res["time"][1:] - res["t_frame"][1:]
    assert np.all((lag >= -0.01) & (lag <= 0.15)), f"frame age {lag.min():.3f}..{lag.max():.3f} s"
    assert res["valid"][1:].all()
    # The inputs reached the devices through the safety core: the rate limit (10 mm/s) makes
    # 12 -> 8 mm take 0.4 s; the robot's reported pose follows.
    tail = res["time"] >= 2.2  # 4 -> 6 Hz at 2 Hz/s ends at 2.0 s
    assert np.allclose(res["z_m_applied"][tail], 8e-3, atol=1e-9)
    assert np.allclose(res["omega_m_applied"][tail], TWO_PI * 6.0, atol=1e-9)
    assert np.all(np.abs(res["z_m_measured"][tail] - 8e-3) < 0.2e-3)
    # r1, r2 are the camera's: 1 mm above the (unbiased) shadow model, after the transient.
    for r in ("r1", "r2"):
        d = (res[r][tail] - res[f"{r}_shadow"][tail]) * 1e3
        assert abs(d.mean() - OFFSET_MM) < 0.3, f"{r} - {r}_shadow = {d.mean():.3f} mm"
    # And they moved with the step: 8 mm / 6 Hz gives a smaller swarm than 12 mm / 4 Hz.
    early = (res["time"] > 0.2) & (res["time"] < 1.0)
    assert res["r2"][tail].mean() < res["r2"][early].mean() - 0.3e-3
    assert_stopped_at_the_end(rig, t0 + stop)


def test_the_interface_is_magswarm_fmus(rig):
    """z_m, omega_m, r1, r2: same names, causality, units and value references as MagSwarm.fmu."""
    from fmpy import read_model_description

    plant = {v.name: v for v in read_model_description(str(DEFAULT_FMU)).modelVariables}
    md = read_model_description(str(rig.fmu))
    ours = {v.name: v for v in md.modelVariables}
    for n in ("z_m", "omega_m", "r1", "r2"):
        a, b = ours[n], plant[n]
        assert (a.causality, a.unit, a.displayUnit, a.valueReference) == \
            (b.causality, b.unit, b.displayUnit, b.valueReference), n
    assert md.coSimulation.canHandleVariableCommunicationStepSize
    assert md.modelExchange is None
    for n in ("valid", "r1_shadow", "r2_shadow", "late", "late_steps", "max_late", "z_m_max"):
        assert n in ours, n


def test_the_fmu_is_self_contained(rig, tmp_path):
    """Config, watchdog and binary inside; the binary needs only the C runtime."""
    import shutil

    with zipfile.ZipFile(rig.fmu) as z:
        names = set(z.namelist())
        z.extractall(tmp_path)
    for n in ("modelDescription.xml", "binaries/linux64/MagSwarmRig.so", "resources/rig.toml",
              "resources/camera-model.json", "resources/magswarm-stepper-watchdog",
              "documentation/index.html"):
        assert n in names, n
    # The baked config names the copied model relative to resources/, not the original file.
    assert 'model = "camera-model.json"' in (tmp_path / "resources" / "rig.toml").read_text()
    if shutil.which("ldd") is None:
        pytest.skip("no ldd")
    for binary in ("binaries/linux64/MagSwarmRig.so", "resources/magswarm-stepper-watchdog"):
        out = subprocess.run(["ldd", str(tmp_path / binary)], capture_output=True, text=True).stdout
        libs = [line.split()[0] for line in out.splitlines() if line.strip()]
        allowed = ("linux-vdso", "libc.so", "libm.so", "ld-linux", "/lib64/ld-linux")
        heavy = [lib for lib in libs if not lib.startswith(allowed)]
        assert not heavy, f"{binary} links {heavy}"


def test_libcosim_step_drives_the_rig_in_real_time(rig):
    steps, step_ns = 60, 50_000_000
    cfg = {"mode": "single", "fmu": str(rig.fmu), "step_ns": step_ns, "steps": steps,
           "initial": {"z_m": 12e-3, "omega_m": TWO_PI * 4.0},
           "changes": [[20, {"z_m": 8e-3, "omega_m": TWO_PI * 6.0}]],
           "outputs": ["r1", "r2", "r1_shadow", "r2_shadow", "z_m_applied", "late"]}
    t0 = time.time()
    p = subprocess.run([sys.executable, str(RUNNER), json.dumps(cfg)], capture_output=True, text=True,
                       timeout=120)
    wall = time.time() - t0
    last = p.stdout.strip().splitlines()[-1] if p.stdout.strip() else ""
    if p.returncode != 0:
        crash = f"signal {-p.returncode}" if p.returncode < 0 else f"exit {p.returncode}"
        pytest.fail(f"libcosim run {crash}: {last}\n{p.stderr[-3000:]}", pytrace=False)
    out = json.loads(last)
    v = np.array(out["values"])
    print(f"libcosim: {steps} steps of {step_ns / 1e9} s in {wall:.3f} s of wall time")
    assert wall >= steps * step_ns / 1e9, "libcosim ran faster than real time"
    assert len(v) == steps
    tail = v[40:]
    assert np.allclose(tail[:, 4], 8e-3, atol=1e-9)
    d = (tail[:, 0:2] - tail[:, 2:4]).mean(axis=0) * 1e3
    assert np.all(np.abs(d - OFFSET_MM) < 0.3), f"camera - shadow = {d} mm"
    assert_stopped_at_the_end(rig, t0 + steps * step_ns / 1e9)


HOST_CRASH = textwrap.dedent("""
    import os, signal, sys, time
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    fmu = sys.argv[1]
    md = read_model_description(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    s = FMU2Slave(guid=md.guid, unzipDirectory=extract(fmu), modelIdentifier="MagSwarmRig",
                  instanceName="crash")
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.setReal([vr["z_m"], vr["omega_m"]], [0.010, 2 * 3.141592653589793 * 5.0])
    s.exitInitializationMode()
    for k in range(20):
        s.doStep(currentCommunicationPoint=k * 0.05, communicationStepSize=0.05)
    print(f"{time.time():.6f}", flush=True)
    os.kill(os.getpid(), signal.SIGKILL)
""")


def test_a_host_crash_stops_the_stepper_within_150_ms(rig):
    p = subprocess.run([sys.executable, "-c", HOST_CRASH, str(rig.fmu)], capture_output=True, text=True,
                       timeout=60)
    assert p.returncode == -signal.SIGKILL, p.stderr[-2000:]
    killed = float(p.stdout.strip().splitlines()[-1])
    seen = rig.stepper()
    assert any(s[1] == ROR and s[2] == round(5.0 * VELOCITY_PER_HZ) for s in seen), "5 Hz never reached"
    stops = [t for t, i, _ in seen if i == MST and t >= killed]
    assert stops, "no MST after the host was killed"
    delay = stops[0] - killed
    print(f"host SIGKILL -> MST at the emulated module: {delay * 1e3:.1f} ms")
    assert delay <= 0.150


def test_a_late_host_gets_a_warning_and_a_stall_stops_the_rig(rig, fmu_log):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave, fmi2Error, fmi2Warning

    md = read_model_description(str(rig.fmu))
    assert md.coSimulation.canGetAndSetFMUstate is False
    vr = {v.name: v.valueReference for v in md.modelVariables}
    s = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(rig.fmu)), modelIdentifier="MagSwarmRig",
                  instanceName="late")
    s.instantiate(callbacks=fmu_log.callbacks)
    s.setReal([vr["max_late"]], [0.4])
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    t, h = 0.0, 0.05
    for _ in range(5):
        s.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        t += h
    time.sleep(0.15)  # the host falls 0.15 s behind: the next step ends 0.1 s late
    status = do_step(s, t, h)
    t += h
    assert status == fmi2Warning
    late = s.getReal([vr["late"]])[0]
    assert 0.05 < late < 0.3, late
    assert s.getInteger([vr["late_steps"]]) == [1]
    assert any("late step" in m for _, _, m in fmu_log.messages), fmu_log.messages
    # Then it stops calling for longer than max_late: the rig stops, the next step says why.
    stalled = time.time()
    time.sleep(0.8)
    status = do_step(s, t, h)
    assert status == fmi2Error
    errors = [m for st, _, m in fmu_log.messages if st == fmi2Error]
    assert any("host_stalled" in m for m in errors), errors
    stops = [x for x, i, _ in rig.stepper() if i == MST and x >= stalled]
    assert stops and stops[0] - stalled <= 0.4 + 0.15, stops
    s.freeInstance()


def test_a_protective_stop_is_an_fmi2error_naming_the_fault(tmp_path, fmu_log):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave, fmi2Error

    r = Rig(tmp_path, extra="[emulator]\nprotective_stop_after_s = 1.0\n")
    try:
        md = read_model_description(str(r.fmu))
        s = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(r.fmu)), modelIdentifier="MagSwarmRig",
                      instanceName="pstop")
        s.instantiate(callbacks=fmu_log.callbacks)
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.exitInitializationMode()
        t, status = 0.0, None
        while t < 5.0:
            status = do_step(s, t, 0.05)
            if status != 0:
                break
            t += 0.05
        assert status == fmi2Error, f"no error by t = {t}"
        assert t < 3.0, t
        errors = [m for st, _, m in fmu_log.messages if st == fmi2Error]
        assert any("rig fault safety_mode" in m for m in errors), errors
        stops = [x for x, i, _ in r.stepper() if i == MST]
        assert stops, "the stepper was not stopped"
        s.freeInstance()
    finally:
        r.close()
