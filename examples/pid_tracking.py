#!/usr/bin/env python3
"""The seed's tracking experiment (Sec. III-D, Fig. 6) in closed loop from fmpy.

Two FMUs, Python as the co-simulation master:
  - the plant MagSwarm.fmu (--fmu),
  - the controller MagSwarmPID.fmu (--pid-fmu; default MagSwarmPID.fmu beside --fmu): the same
    decoupled PID of magswarm-control the Rust harness (examples/pid_tracking.rs) runs
    in-process, with the same gains and sample time (its resources/pid.json, or --config).
The controller has an internal model (feedforward through the inverse steady map and a
model-predicted reference), which is why it is run as its FMU rather than re-implemented here.

One communication step (= one controller sample, 0.05 s) is, at t_k:
  read the plant's r1, r2 -> set the controller's r1, r2, r1_ref, r2_ref -> controller doStep(t_k, h)
  -> read z_m, omega_m -> log row -> set the plant's z_m, omega_m -> plant doStep(t_k, h).
That is the Rust harness's order, so the two logs agree row by row.

usage: python examples/pid_tracking.py --fmu target/fmu/MagSwarm.fmu --out LOG.csv
           [--pid-fmu target/fmu/MagSwarmPID.fmu] [--config cfg.json]
           [--segments 60:7:11,60:8:11,60:9:11] [--plot fig.png]

Needs fmpy and numpy; the plot needs matplotlib (skipped with a note when it is missing).
The log is the measurement log of docs/log-format.md (t_s,z_m_mm,f_hz,r1_mm,r2_mm,r1_ref_mm,r2_ref_mm)
plus r1_goal_mm, r2_goal_mm (nearest reachable radii) and target_feasible (0/1).
"""

from __future__ import annotations

import argparse
import math
import pathlib
import shutil
import sys
import time

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

SEED_SEGMENTS = [(60.0, 7.0, 11.0), (60.0, 8.0, 11.0), (60.0, 9.0, 11.0)]
SEED_PAPER = [(7.61, 10.43), (8.14, 11.23), (8.50, 11.70)]
START = (8.5e-3, 4.0 * 2.0 * math.pi)  # the plant's initial inputs: 8.5 mm, 4 Hz
COLUMNS = ["t_s", "z_m_mm", "f_hz", "r1_mm", "r2_mm", "r1_ref_mm", "r2_ref_mm",
           "r1_goal_mm", "r2_goal_mm", "target_feasible"]


def parse_segments(text: str) -> list[tuple[float, float, float]]:
    segs = []
    for part in text.split(","):
        d, r1, r2 = (float(x) for x in part.split(":"))
        if min(d, r1, r2) <= 0:
            raise SystemExit(f"segment {part!r}: expected seconds:r1_mm:r2_mm, all positive")
        segs.append((d, r1, r2))
    return segs


class Instance:
    """One FMU instance through fmpy, variables by name from its modelDescription."""

    def __init__(self, path: pathlib.Path, name: str):
        self.md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.dir = extract(str(path))
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.dir,
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate(loggingOn=False)

    def refs(self, *names: str) -> list[int]:
        missing = [n for n in names if n not in self.vr]
        if missing:
            raise SystemExit(f"{self.md.modelName}: no variables {missing}")
        return [self.vr[n] for n in names]

    def close(self):
        try:
            self.fmu.terminate()
            self.fmu.freeInstance()
        finally:
            shutil.rmtree(self.dir, ignore_errors=True)


def run(fmu: pathlib.Path, pid_fmu: pathlib.Path, segments, config: pathlib.Path | None = None,
        order: str = "sequential"):
    """Returns (rows as an array with COLUMNS, segment index per row, sample time).

    order "sequential" (Gauss-Seidel, the Rust harness's): the plant steps under the command the
    controller computed from the measurement at the same instant. order "jacobi": both FMUs step
    in parallel on the values of the previous communication point, as libcosim does with
    connections: the plant steps under the previous sample's command (one sample of delay)."""
    plant = Instance(fmu, "swarm")
    pid = Instance(pid_fmu, "pid")
    try:
        p_in, p_out = plant.refs("z_m", "omega_m"), plant.refs("r1", "r2")
        c_in = pid.refs("r1_ref", "r2_ref", "r1", "r2")
        c_out = pid.refs("z_m", "omega_m", "r1_goal", "r2_goal")
        c_feasible = pid.refs("target_feasible")

        plant.fmu.setupExperiment(startTime=0.0)
        plant.fmu.enterInitializationMode()
        plant.fmu.setReal(p_in, list(START))
        plant.fmu.exitInitializationMode()

        pid.fmu.setupExperiment(startTime=0.0)
        pid.fmu.enterInitializationMode()
        if config is not None:
            pid.fmu.setString(pid.refs("config_file"), [str(config.resolve())])
        pid.fmu.setReal(pid.refs("z_start", "omega_start"), list(START))
        pid.fmu.setReal(c_in[:2], [segments[0][1] * 1e-3, segments[0][2] * 1e-3])
        pid.fmu.exitInitializationMode()
        ts = pid.fmu.getReal(pid.refs("sample_time"))[0]
        h = ts  # one communication step per controller sample

        seg_of = []
        for i, (d, _, _) in enumerate(segments):
            seg_of += [i] * int(round(d / h))
        rows = np.empty((len(seg_of), len(COLUMNS)))
        t = 0.0
        u_prev = list(START)
        for k, i in enumerate(seg_of):
            _, r1_ref, r2_ref = segments[i]
            y = plant.fmu.getReal(p_out)
            pid.fmu.setReal(c_in, [r1_ref * 1e-3, r2_ref * 1e-3, y[0], y[1]])
            pid.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
            z, w, g1, g2 = pid.fmu.getReal(c_out)
            feasible = pid.fmu.getBoolean(c_feasible)[0]
            u = [z, w] if order == "sequential" else u_prev
            u_prev = [z, w]
            rows[k] = (t, u[0] * 1e3, u[1] / (2.0 * math.pi), y[0] * 1e3, y[1] * 1e3, r1_ref, r2_ref,
                       g1 * 1e3, g2 * 1e3, 1.0 if feasible else 0.0)
            plant.fmu.setReal(p_in, u)
            plant.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
            t += h
        return rows, np.array(seg_of), h
    finally:
        pid.close()
        plant.close()


def run_libcosim(system: pathlib.Path, kind: str, fmu: pathlib.Path, pid_fmu: pathlib.Path, segments):
    """The closed loop in libcosim (libcosimpy) from the system files in `system` (SSP
    SystemStructure.ssd or OSP OspSystemStructure.xml, kind "ssp" / "osp"), copied with both FMUs
    into a temporary folder. The setpoints after the system file's initial values come from a
    libcosim scenario written from `segments` (one override per segment start). Returns the same
    rows as run(): row k holds the plant's radii at t_k, the inputs the plant was stepped with
    over [t_k, t_k + h) and the controller's setpoints at t_k."""
    import json
    import tempfile

    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

    log_output_level(CosimLogLevel.WARNING)
    from libcosimpy._internal import get_last_error_message
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimManipulator import CosimManipulator
    from libcosimpy.CosimObserver import CosimObserver

    tmp = pathlib.Path(tempfile.mkdtemp(prefix="magswarm-libcosim-"))
    try:
        for f in system.iterdir():
            if f.is_file():
                shutil.copy(f, tmp / f.name)
        shutil.copy(fmu, tmp / "MagSwarm.fmu")
        shutil.copy(pid_fmu, tmp / "MagSwarmPID.fmu")
        events, t = [], 0.0
        for d, r1, r2 in segments:
            events += [{"time": t, "variable": "r1_ref", "value": r1 * 1e-3},
                       {"time": t, "variable": "r2_ref", "value": r2 * 1e-3}]
            t += d
        scenario = tmp / "scenario.json"
        scenario.write_text(json.dumps({"description": "setpoint segments", "events": events, "end": t,
                                        "defaults": {"model": "pid", "action": "override"}}))
        if kind == "ssp":
            ex = CosimExecution.from_ssp_file(ssp_path=str(tmp / "SystemStructure.ssd"))
        else:
            ex = CosimExecution.from_osp_config_file(osp_path=str(tmp / "OspSystemStructure.xml"))
        s, p = ex.slave_index_from_instance_name("swarm"), ex.slave_index_from_instance_name("pid")
        if s is None or p is None:
            raise SystemExit(f"libcosim: instances swarm/pid not found: {get_last_error_message()}")
        rs = {v.name.decode(): v.reference for v in ex.slave_variables(s)}
        rp = {v.name.decode(): v.reference for v in ex.slave_variables(p)}
        obs = CosimObserver.create_last_value()
        ex.add_observer(observer=obs)
        manager = CosimManipulator.create_scenario_manager()
        ex.add_manipulator(manipulator=manager)
        if not ex.load_scenario(manipulator=manager, scenario_file=str(scenario)):
            raise SystemExit(f"libcosim: scenario not loaded: {get_last_error_message()}")
        seg_of = []
        h = None
        rows = []
        k = 0
        for i, (d, _, _) in enumerate(segments):
            n = int(round(d / 0.05))
            seg_of += [i] * n
        for k in range(len(seg_of)):
            if not ex.step():
                raise SystemExit(f"libcosim: step {k} failed: {get_last_error_message()}")
            t_ns = ex.status().current_time
            h = h or t_ns * 1e-9
            z, w = obs.last_real_values(s, [rs["z_m"], rs["omega_m"]])
            y1, y2, s1, s2, g1, g2 = obs.last_real_values(
                p, [rp["r1"], rp["r2"], rp["r1_ref"], rp["r2_ref"], rp["r1_goal"], rp["r2_goal"]])
            ok = obs.last_boolean_values(p, [rp["target_feasible"]])[0]
            rows.append((k * h, z * 1e3, w / (2.0 * math.pi), y1 * 1e3, y2 * 1e3, s1 * 1e3, s2 * 1e3,
                         g1 * 1e3, g2 * 1e3, 1.0 if ok else 0.0))
        return np.array(rows), np.array(seg_of), h
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def write_log(path: pathlib.Path, rows: np.ndarray):
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w") as f:
        f.write(",".join(COLUMNS) + "\n")
        for r in rows:
            cells = [repr(float(x)) for x in r[:9]] + [str(int(r[9]))]
            f.write(",".join(cells) + "\n")


def report(rows: np.ndarray, seg_of: np.ndarray, segments) -> str:
    is_seed = [tuple(s) for s in segments] == SEED_SEGMENTS
    lines = ["| segment | r1*, r2* [mm] | final r1, r2 [mm] | nearest reachable r1, r2 [mm] | distance [mm] "
             "| feasible | final z_m [mm], f [Hz] |" + (" seed model r1, r2 [mm] |" if is_seed else "")]
    lines.append("|---|---|---|---|---|---|---|" + ("---|" if is_seed else ""))
    for i, _ in enumerate(segments):
        last = rows[np.nonzero(seg_of == i)[0][-1]]
        t, z, f, r1, r2, s1, s2, g1, g2, ok = last
        line = (f"| {i + 1} | {s1:.2f}, {s2:.2f} | {r1:.3f}, {r2:.3f} | {g1:.3f}, {g2:.3f} "
                f"| {math.hypot(s1 - g1, s2 - g2):.3f} | {'yes' if ok else 'no (infeasible)'} | {z:.2f}, {f:.2f} |")
        if is_seed:
            line += f" {SEED_PAPER[i][0]:.2f}, {SEED_PAPER[i][1]:.2f} |"
        lines.append(line)
    return "\n".join(lines)


def plot(path: pathlib.Path, rows: np.ndarray) -> bool:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib not installed: no plot", file=sys.stderr)
        return False
    t = rows[:, 0]
    fig, ax = plt.subplots(4, 1, sharex=True, figsize=(10, 11))
    for a, (j, s, g, name) in zip(ax[:2], [(3, 5, 7, "r1"), (4, 6, 8, "r2")]):
        a.plot(t, rows[:, j], label=f"{name} (MagSwarm.fmu)")
        a.plot(t, rows[:, s], "--", label=f"{name}* setpoint")
        a.plot(t, rows[:, g], ":", label="nearest reachable")
        a.set_ylabel(f"{name} [mm]")
        a.legend(loc="upper right")
    ax[2].plot(t, rows[:, 1]); ax[2].set_ylabel("z_m [mm]")
    ax[3].plot(t, rows[:, 2]); ax[3].set_ylabel("f [Hz]"); ax[3].set_xlabel("t [s]")
    fig.suptitle("MagSwarm.fmu + MagSwarmPID.fmu from fmpy (seed Fig. 6 scenario)")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    return True


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--fmu", type=pathlib.Path, default=pathlib.Path("target/fmu/MagSwarm.fmu"),
                    help="plant FMU (default: %(default)s)")
    ap.add_argument("--out", type=pathlib.Path, default=pathlib.Path("target/demo/pid_tracking_fmpy.csv"),
                    help="measurement log to write, docs/log-format.md format (default: %(default)s)")
    ap.add_argument("--pid-fmu", type=pathlib.Path, default=None,
                    help="controller FMU (default: MagSwarmPID.fmu beside --fmu)")
    ap.add_argument("--config", type=pathlib.Path, default=None,
                    help="controller configuration (magswarm-pid/1 JSON) passed as config_file")
    ap.add_argument("--segments", default=None, help='"seconds:r1_mm:r2_mm,..." (default the seed\'s)')
    ap.add_argument("--plot", type=pathlib.Path, default=None,
                    help="PNG of radii vs references and inputs vs time (needs matplotlib)")
    ap.add_argument("--order", choices=["sequential", "jacobi"], default="sequential",
                    help="sequential (default, the Rust harness's) or jacobi (libcosim's one-sample delay)")
    ap.add_argument("--libcosim", type=pathlib.Path, default=None, metavar="SYSTEM_DIR",
                    help="run the loop in libcosim from the system files in SYSTEM_DIR (e.g. systems/magswarm_pid) "
                         "instead of fmpy; needs libcosimpy")
    ap.add_argument("--system", choices=["ssp", "osp"], default="ssp",
                    help="with --libcosim: SystemStructure.ssd or OspSystemStructure.xml")
    a = ap.parse_args(argv)
    pid_fmu = a.pid_fmu or a.fmu.with_name("MagSwarmPID.fmu")
    for p, how in [(a.fmu, "target/release/magswarm fmu"), (pid_fmu, "target/release/magswarm fmu --pid")]:
        if not p.is_file():
            print(f"{p} not found: build it with `{how}`", file=sys.stderr)
            return 2
    segments = parse_segments(a.segments) if a.segments else SEED_SEGMENTS
    t0 = time.perf_counter()
    if a.libcosim is not None:
        if a.config is not None:
            print("--config is not used with --libcosim (set config_file in the system file)", file=sys.stderr)
            return 2
        rows, seg_of, h = run_libcosim(a.libcosim, a.system, a.fmu, pid_fmu, segments)
        how = f"libcosim ({a.system}: {a.libcosim})"
    else:
        rows, seg_of, h = run(a.fmu, pid_fmu, segments, a.config, a.order)
        how = f"fmpy ({a.order})"
    write_log(a.out, rows)
    print(f"closed loop from {how}: {len(rows)} samples of {h} s, {a.fmu} + {pid_fmu} "
          f"in {time.perf_counter() - t0:.2f} s; log {a.out}")
    print(report(rows, seg_of, segments))
    if a.plot and plot(a.plot, rows):
        print(f"plot {a.plot}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
