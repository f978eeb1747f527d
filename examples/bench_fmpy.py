#!/usr/bin/env python3
"""The doStep loops of the performance table through fmpy, for MagSwarm.fmu and the Euler2
yardstick FMU (docs/performance.md; examples/perf_table.rs runs this script and puts its
figures beside the C-host ones).

usage: python examples/bench_fmpy.py --fmu target/fmu/MagSwarm.fmu --fixture target/perf/Euler2.fmu
           [--calls 20000] [--repeats 5] [--json]

For each FMU and each communication step h (10 ms, 1 ms), median ns per call over --repeats
loops of --calls calls (after a warm-up) of
  - doStep at constant inputs;
  - setReal(2 inputs, a new value every call) + doStep + getReal(2 outputs), the closed-loop
    pattern, through fmpy's FMU2Slave methods (what a Python master calls).
fmpy converts the Python lists to ctypes arrays at every call: that is most of its cost, and
the same for both FMUs, so the two FMUs should be within a few per cent of each other.
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import statistics
import time

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

PAIRS = {  # FMU model name -> (inputs, outputs)
    "MagSwarm": (["z_m", "omega_m"], ["r1", "r2"]),
    "Euler2": (["u1", "u2"], ["x1", "x2"]),
}


def inputs(t: float) -> list[float]:
    s = math.sin(2.0 * math.pi * 0.2 * t)
    return [8.5e-3 + 2.0e-3 * s, (4.0 + s) * 2.0 * math.pi]


class Loop:
    def __init__(self, path: str, h: float):
        md = read_model_description(path)
        names = {v.name: v.valueReference for v in md.modelVariables}
        ins, outs = PAIRS[md.coSimulation.modelIdentifier]
        self.ins = [names[n] for n in ins]
        self.outs = [names[n] for n in outs]
        self.dir = extract(path)
        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=self.dir,
                             modelIdentifier=md.coSimulation.modelIdentifier, instanceName="bench")
        self.fmu.instantiate(loggingOn=False)
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        self.fmu.setReal(self.ins, inputs(0.0))
        self.fmu.exitInitializationMode()
        self.t = 0.0
        self.h = h

    def const(self, n: int) -> None:
        fmu, t, h = self.fmu, self.t, self.h
        for _ in range(n):
            fmu.doStep(t, h)
            t += h
        self.t = t

    def closed(self, n: int) -> None:
        fmu, t, h, ins, outs = self.fmu, self.t, self.h, self.ins, self.outs
        for _ in range(n):
            fmu.setReal(ins, inputs(t))
            fmu.doStep(t, h)
            fmu.getReal(outs)
            t += h
        self.t = t

    def close(self) -> None:
        self.fmu.terminate()
        self.fmu.freeInstance()
        shutil.rmtree(self.dir, ignore_errors=True)


def measure(path: str, h: float, case: str, calls: int, repeats: int) -> float:
    loop = Loop(path, h)
    run = getattr(loop, case)
    run(max(calls // 10, 1))
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter_ns()
        run(calls)
        times.append((time.perf_counter_ns() - t0) / calls)
    loop.close()
    return statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--fmu", required=True, help="MagSwarm.fmu")
    ap.add_argument("--fixture", required=True, help="Euler2.fmu (the yardstick)")
    ap.add_argument("--calls", type=int, default=20000, help="calls per timed loop")
    ap.add_argument("--repeats", type=int, default=5, help="timed loops per figure (median)")
    ap.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    a = ap.parse_args()
    out = {}
    # Interleave the two FMUs so that a load change on the machine hits both alike.
    for case in ("const", "closed"):
        for h in (0.01, 0.001):
            for name, path in (("MagSwarm", a.fmu), ("Euler2", a.fixture)):
                out[f"{name}/{case}/{h}"] = measure(path, h, case, a.calls, a.repeats)
    if a.json:
        print(json.dumps(out))
        return
    print(f"{'case':<30} {'MagSwarm [ns]':>14} {'Euler2 [ns]':>12} {'ratio':>7}")
    for case in ("const", "closed"):
        for h in (0.01, 0.001):
            m, e = out[f"MagSwarm/{case}/{h}"], out[f"Euler2/{case}/{h}"]
            print(f"{case + f', h = {h * 1e3:g} ms':<30} {m:>14.0f} {e:>12.0f} {m / e:>7.3f}")


if __name__ == "__main__":
    main()
