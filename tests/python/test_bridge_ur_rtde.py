"""The emulated UR controller of `magswarm-bridge emulate` against ur_rtde's own client.

ur_rtde (PyPI `ur-rtde`, SDU Robotics) is an independent RTDE implementation: its
RTDEReceiveInterface negotiates protocol version 2, asks the controller version, sets up an
output recipe (by default every variable it knows, with a trailing comma, at 500 Hz for an
e-Series controller) and starts the synchronisation. If the emulator got the wire format
wrong, the constructor throws or the values read back are garbage.

The second test closes the triangle: the bridge writes the tool's target z over RTDE (its
own client), the emulated program servoes to it, and ur_rtde reads the pose.

ur_rtde's port is fixed at 30004, so the emulator binds a random 127.x.y.z loopback address.
"""

from __future__ import annotations

import os
import pathlib
import random
import signal
import subprocess
import time

import pytest

rtde_receive = pytest.importorskip(
    "rtde_receive", reason="ur-rtde is not installed (pip install ur-rtde, see requirements.txt)"
)

REPO = pathlib.Path(__file__).resolve().parents[2]
BRIDGE = REPO / "target" / "release" / "magswarm-bridge"

CONFIG = """
[robot]
host = "{host}"
rtde_port = 30004
script_port = 0
dashboard_port = 29999
z_tcp_at_zero_m = 0.400

[stepper]
kind = "tmcl"
device = "{tty}"
velocity_per_hz = 51200.0

[camera]
kind = "emulated"
mm_per_px = 0.15
fps = 20.0
width = 480
height = 360

[limits]
z_m_mm = [3.5, 23.5]
f_hz = [1.0, 10.0]
z_rate_mm_s = 10.0
f_rate_hz_s = 2.0
"""


@pytest.fixture()
def emulator(tmp_path):
    if not BRIDGE.exists():
        pytest.fail(f"{BRIDGE} is missing: build it with cargo build --release -p magswarm-bridge")
    host = f"127.{random.randint(1, 254)}.{random.randint(1, 254)}.{random.randint(2, 254)}"
    cfg = tmp_path / "rig.toml"
    cfg.write_text(CONFIG.format(host=host, tty=tmp_path / "tmcl"))
    proc = subprocess.Popen(
        [str(BRIDGE), "emulate", "--config", str(cfg)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    lines = []
    t0 = time.time()
    while True:
        line = proc.stdout.readline()
        if not line:
            raise AssertionError(f"emulate ended: {proc.stderr.read()}")
        lines.append(line.strip())
        if line.strip() == "ready":
            break
        assert time.time() - t0 < 20, lines
    assert f"rtde {host}:30004" in lines, lines
    yield host, cfg, tmp_path
    proc.send_signal(signal.SIGTERM)
    proc.wait(timeout=10)


def test_ur_rtde_receive_interface_reads_the_emulator(emulator):
    host, _, _ = emulator
    # Default recipe: every output ur_rtde knows for this controller version.
    r = rtde_receive.RTDEReceiveInterface(host, 500.0, [])
    try:
        assert r.isConnected()
        time.sleep(0.2)
        pose = r.getActualTCPPose()
        assert len(pose) == 6
        # Start pose: middle of the envelope, 0.400 + 13.5 mm.
        assert abs(pose[2] - 0.4135) < 1e-9, pose
        assert r.getSafetyMode() == 1
        assert r.getRobotMode() == 3  # POWER_OFF: the dashboard powers it on
        assert r.getRuntimeState() == 2  # script_port = 0: the program is already playing
        # Data at 500 Hz: the controller timestamp advances ~0.2 s in 0.2 s.
        t1 = r.getTimestamp()
        time.sleep(0.2)
        t2 = r.getTimestamp()
        assert 0.1 < t2 - t1 < 0.4, (t1, t2)
    finally:
        r.disconnect()

    # A named recipe, as a lab script would use.
    names = ["timestamp", "actual_TCP_pose", "robot_mode", "safety_mode", "runtime_state"]
    r = rtde_receive.RTDEReceiveInterface(host, 125.0, names)
    try:
        time.sleep(0.1)
        assert abs(r.getActualTCPPose()[2] - 0.4135) < 1e-9
    finally:
        r.disconnect()


def test_bridge_commands_are_seen_by_ur_rtde(emulator):
    host, cfg, tmp = emulator
    plan = tmp / "plan.csv"
    plan.write_text("t_s,z_m_mm,f_hz\n0,20,4\n")
    log = tmp / "log.csv"
    r = rtde_receive.RTDEReceiveInterface(host, 500.0, ["timestamp", "actual_TCP_pose"])
    try:
        run = subprocess.Popen(
            [str(BRIDGE), "run", "--config", str(cfg), "--plan", str(plan), "--log", str(log),
             "--duration", "2.0"],
            stderr=subprocess.PIPE,
            text=True,
        )
        zs = []
        while run.poll() is None:
            zs.append(r.getActualTCPPose()[2])
            time.sleep(0.01)
        err = run.stderr.read()
        assert run.returncode == 0, err
        # 13.5 -> 20 mm at 10 mm/s takes 0.65 s: ur_rtde sees the tool arrive at 0.420 m.
        assert abs(zs[-1] - 0.420) < 3e-4, zs[-5:]
        assert max(zs) <= 0.4235 + 1e-9
        # It moved gradually (rate limit), not in one jump.
        steps = [b - a for a, b in zip(zs, zs[1:])]
        assert max(steps) < 0.002, max(steps)
    finally:
        r.disconnect()
