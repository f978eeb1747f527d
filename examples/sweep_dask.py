#!/usr/bin/env python3
"""Monte Carlo of the seed's closed-loop tracking scenario under parameter uncertainty, on
dask.distributed: the same study as `magswarm sweep`, with the same draws and results.

usage: python examples/sweep_dask.py --fmu target/fmu/MagSwarm.fmu --runs N --seed S --out OUT.csv
           [--workers K | --scheduler tcp://HOST:8786] [--pid-fmu MagSwarmPID.fmu]
           [--model M.json] [--uncertainty U.json] [--plot OUT.png] [--chunk C]

One run: MagSwarm.fmu with this run's parameters (the plant) and MagSwarmPID.fmu (the decoupled
PID of magswarm-control, designed on the nominal model) in the co-simulation loop of
examples/pid_tracking.py, over the seed's scenario (r1* = 7, 8, 9 mm, r2* = 11 mm, 60 s each).
Result: rmse_r1_mm, rmse_r2_mm (RMS of radius minus setpoint over all samples) and
final_err_mm (largest |r - r*| over the last 10 s of each segment), with the drawn parameters.

Scale-out: tasks are chunks of runs (--chunk, default 4). Each worker process extracts the two
FMUs once, instantiates them once and resets them between runs (fmpy's parameter-variation
pattern). --workers K starts a LocalCluster of K single-threaded worker processes (default 2);
--scheduler tcp://HOST:8786 uses a running cluster (every worker needs fmpy and read access to the
FMU paths, or pass paths on a shared file system). --workers 0 runs serially in this process
(no dask), the reference the tests compare with.

Draws (identical to crates/magswarm-sweep/src/draws.rs, bit for bit): counter-based SplitMix64 from
(seed, run, stream) and Box-Muller; parameter i uses stream 2 i (uniform ranges) or the normal
from streams 2 i, 2 i + 1 (covariance, mean + L z with the textbook Cholesky L). Default ranges:
C_1, C_2, alpha_1, alpha_2 +-10 %, K_tau +-30 % around the model's values.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import pathlib
import shutil
import sys
import tempfile
import time

MASK = (1 << 64) - 1
DEFAULT_RANGES = [("C_1", 0.10), ("C_2", 0.10), ("alpha_1", 0.10), ("alpha_2", 0.10), ("K_tau", 0.30)]
SEED_SEGMENTS = [(60.0, 7.0, 11.0), (60.0, 8.0, 11.0), (60.0, 9.0, 11.0)]
START = (8.5e-3, 4.0 * 2.0 * math.pi)


# ---------------------------------------------------------------------------- draws

def splitmix64(x: int) -> int:
    z = (x + 0x9E3779B97F4A7C15) & MASK
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK
    return z ^ (z >> 31)


def bits(seed: int, run: int, j: int) -> int:
    return splitmix64(splitmix64(splitmix64(seed & MASK) ^ run) ^ j)


def uniform(seed: int, run: int, j: int) -> float:
    return (float(bits(seed, run, j) >> 11) + 0.5) * (1.0 / 9007199254740992.0)


def normal(seed: int, run: int, i: int) -> float:
    u1 = uniform(seed, run, 2 * i)
    u2 = uniform(seed, run, 2 * i + 1)
    return math.sqrt(-2.0 * math.log(u1)) * math.cos(math.tau * u2)


def cholesky(a: list[list[float]]) -> list[list[float]]:
    n = len(a)
    low = [[0.0] * n for _ in range(n)]
    for i in range(n):
        if len(a[i]) != n:
            raise SystemExit(f"covariance row {i} has {len(a[i])} entries, expected {n}")
        for j in range(i + 1):
            s = a[i][j]
            for k in range(j):
                s -= low[i][k] * low[j][k]
            if i == j:
                if s < -1e-12 * max(abs(a[i][i]), 1e-300):
                    raise SystemExit(f"covariance is not positive semi-definite (pivot {i} = {s:e})")
                low[i][i] = math.sqrt(s) if s > 1e-300 else 0.0
            else:
                low[i][j] = s / low[j][j] if low[j][j] > 0.0 else 0.0
    return low


class Uncertainty:
    """kind "ranges": spec = [(name, lo, hi)]; kind "normal": names, mean, chol."""

    def __init__(self, kind: str, names: list[str], spec):
        self.kind, self.names, self.spec = kind, names, spec

    @staticmethod
    def from_json(v: dict, nominal: dict[str, float], place: str) -> "Uncertainty":
        unknown = set(v) - {"ranges", "names", "mean", "cov"}
        if unknown:
            raise SystemExit(f"{place}: unknown uncertainty fields {sorted(unknown)}")
        if "ranges" in v and "cov" not in v and "names" not in v:
            # Rust reads the ranges into a BTreeMap: sorted by name.
            spec = [(n, float(lo), float(hi)) for n, (lo, hi) in sorted(v["ranges"].items())]
            for n, _, _ in spec:
                if n not in nominal:
                    raise SystemExit(f"{place}: unknown parameter {n!r}")
            return Uncertainty("ranges", [s[0] for s in spec], spec)
        if "names" in v and "cov" in v and "ranges" not in v:
            names = list(v["names"])
            for n in names:
                if n not in nominal:
                    raise SystemExit(f"{place}: unknown parameter {n!r}")
            mean = [float(x) for x in v["mean"]] if "mean" in v else [nominal[n] for n in names]
            return Uncertainty("normal", names, (mean, cholesky([[float(x) for x in r] for r in v["cov"]])))
        raise SystemExit(f'{place}: uncertainty needs either "ranges" or "names" + "cov" (not both)')

    @staticmethod
    def default(nominal: dict[str, float]) -> "Uncertainty":
        spec = [(n, nominal[n] * (1.0 - rel), nominal[n] * (1.0 + rel)) for n, rel in DEFAULT_RANGES]
        return Uncertainty("ranges", [s[0] for s in spec], spec)

    def draw(self, seed: int, run: int) -> list[float]:
        if self.kind == "ranges":
            return [lo + (hi - lo) * uniform(seed, run, 2 * i) for i, (_, lo, hi) in enumerate(self.spec)]
        mean, low = self.spec
        z = [normal(seed, run, i) for i in range(len(mean))]
        out = []
        for i in range(len(mean)):
            v = mean[i]
            for k in range(i + 1):
                v += low[i][k] * z[k]
            out.append(v)
        return out


# ---------------------------------------------------------------------------- one run

class Simulator:
    """Both FMUs extracted and instantiated once; reset between runs."""

    def __init__(self, fmu: str, pid_fmu: str, model_file: str | None):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        self.dirs = []
        self.inst = {}
        for key, path in (("plant", fmu), ("pid", pid_fmu)):
            md = read_model_description(path)
            d = extract(path)
            self.dirs.append(d)
            f = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier,
                          instanceName=key)
            f.instantiate(loggingOn=False)
            self.inst[key] = (f, {v.name: v.valueReference for v in md.modelVariables})
        self.model_file = model_file
        self.fresh = {"plant": True, "pid": True}

    def nominal(self) -> dict[str, float]:
        """The plant FMU's parameter values (the nominal model) by name."""
        f, vr = self.inst["plant"]
        self._init(f, vr, {}, plant=True)
        names = [n for n in vr if n in PARAM_NAMES]
        vals = f.getReal([vr[n] for n in names])
        return dict(zip(names, vals))

    def _init(self, f, vr, params: dict[str, float], plant: bool):
        key = "plant" if plant else "pid"
        if not self.fresh[key]:
            f.reset()
        self.fresh[key] = False
        f.setupExperiment(startTime=0.0)
        f.enterInitializationMode()
        if self.model_file:
            f.setString([vr["model_file"]], [self.model_file])
        if plant:
            if params:
                f.setReal([vr[n] for n in params], list(params.values()))
            f.setReal([vr["z_m"], vr["omega_m"]], list(START))
        else:
            f.setReal([vr["z_start"], vr["omega_start"]], list(START))
            f.setReal([vr["r1_ref"], vr["r2_ref"]], [SEED_SEGMENTS[0][1] * 1e-3, SEED_SEGMENTS[0][2] * 1e-3])
        f.exitInitializationMode()

    def run(self, names: list[str], values: list[float]) -> tuple[float, float, float, str]:
        plant, pvr = self.inst["plant"]
        pid, cvr = self.inst["pid"]
        try:
            self._init(plant, pvr, dict(zip(names, values)), plant=True)
            self._init(pid, cvr, {}, plant=False)
        except Exception as e:  # an invalid draw is a failed run, as in Rust
            return math.nan, math.nan, math.nan, f"initialisation: {e}"
        p_in, p_out = [pvr["z_m"], pvr["omega_m"]], [pvr["r1"], pvr["r2"]]
        c_in = [cvr["r1_ref"], cvr["r2_ref"], cvr["r1"], cvr["r2"]]
        c_out = [cvr["z_m"], cvr["omega_m"]]
        h = pid.getReal([cvr["sample_time"]])[0]
        s1 = s2 = 0.0
        n = 0
        tail = 0.0
        t = 0.0
        k = 0
        try:
            for d, r1_ref, r2_ref in SEED_SEGMENTS:
                count = int(round(d / h))
                tail_from = max(count - int(round(10.0 / h)), 0)
                for i in range(count):
                    y = plant.getReal(p_out)
                    y_mm = (y[0] * 1e3, y[1] * 1e3)
                    e1, e2 = y_mm[0] - r1_ref, y_mm[1] - r2_ref
                    s1 += e1 * e1
                    s2 += e2 * e2
                    n += 1
                    if i >= tail_from:
                        tail = max(tail, abs(e1), abs(e2))
                    pid.setReal(c_in, [r1_ref * 1e-3, r2_ref * 1e-3, y[0], y[1]])
                    pid.doStep(currentCommunicationPoint=t, communicationStepSize=h)
                    u = pid.getReal(c_out)
                    plant.setReal(p_in, u)
                    plant.doStep(currentCommunicationPoint=t, communicationStepSize=h)
                    k += 1
                    t = k * h
        except Exception as e:
            return math.nan, math.nan, math.nan, f"plant integration at t = {t:.2f} s: {e}"
        return math.sqrt(s1 / n), math.sqrt(s2 / n), tail, ""


# Names the FMU exposes as model parameters (the uncertain ones must be among them).
PARAM_NAMES = {"C_1", "C_2", "a_K1", "a_K2", "alpha_1", "alpha_2", "gamma_1", "gamma_2", "s_0", "a_G", "rho",
               "N", "q", "a_P", "mu_P", "c_P", "q_P", "f_ref", "B_ref", "K_b1", "K_b2", "beta", "r1_min",
               "r2_min", "K_tau", "p", "s_B", "K_d1", "K_d2"}


def _simulator(fmu: str, pid_fmu: str, model_file: str | None) -> Simulator:
    """The worker's simulator, built on first use (one FMU extraction per worker process)."""
    try:
        from distributed import get_worker
        holder = get_worker()
    except (ImportError, ValueError):
        holder = sys.modules[__name__]
    key = (fmu, pid_fmu, model_file)
    cache = getattr(holder, "_magswarm_simulators", None)
    if cache is None:
        cache = {}
        setattr(holder, "_magswarm_simulators", cache)
    if key not in cache:
        cache[key] = Simulator(fmu, pid_fmu, model_file)
    return cache[key]


def run_chunk(runs: list[int], seed: int, unc: Uncertainty, fmu: str, pid_fmu: str,
              model_file: str | None) -> list[dict]:
    sim = _simulator(fmu, pid_fmu, model_file)
    out = []
    for r in runs:
        values = unc.draw(seed, r)
        rm1, rm2, tail, err = sim.run(unc.names, values)
        out.append({"run": r, "rmse_r1_mm": rm1, "rmse_r2_mm": rm2, "final_err_mm": tail,
                    "params": values, "error": err})
    return out


# ---------------------------------------------------------------------------- driver

class Bar:
    def __init__(self, total: int):
        self.total, self.done, self.t0 = total, 0, time.perf_counter()

    def add(self, n: int):
        self.done += n
        el = time.perf_counter() - self.t0
        rate = self.done / el if el > 0 else 0.0
        width = 40
        fill = int(width * self.done / self.total)
        sys.stderr.write(f"\r[{'#' * fill}{'.' * (width - fill)}] {self.done}/{self.total} runs  "
                         f"{rate:.1f} runs/s")
        if self.done >= self.total:
            sys.stderr.write("\n")
        sys.stderr.flush()


def write_csv(path: pathlib.Path, names: list[str], rows: list[dict]):
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["run", "rmse_r1_mm", "rmse_r2_mm", "final_err_mm", *names, "error"])
        for r in rows:
            w.writerow([r["run"], repr(r["rmse_r1_mm"]), repr(r["rmse_r2_mm"]), repr(r["final_err_mm"]),
                        *[repr(v) for v in r["params"]], r["error"]])


def plot(path: pathlib.Path, rows: list[dict]):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print(f"matplotlib not installed: no plot ({path})", file=sys.stderr)
        return
    r1 = [r["rmse_r1_mm"] for r in rows if r["error"] == ""]
    r2 = [r["rmse_r2_mm"] for r in rows if r["error"] == ""]
    fig, ax = plt.subplots(figsize=(7, 4))
    bins = max(10, int(math.sqrt(len(rows))))
    ax.hist(r1, bins=bins, alpha=0.6, label="r1")
    ax.hist(r2, bins=bins, alpha=0.6, label="r2")
    ax.set_xlabel("RMS tracking error over the seed scenario [mm]")
    ax.set_ylabel("runs [-]")
    ax.set_title(f"Tracking error under parameter uncertainty ({len(rows)} runs)")
    ax.legend()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--fmu", required=True, help="MagSwarm.fmu (the plant)")
    ap.add_argument("--pid-fmu", help="MagSwarmPID.fmu (default: beside --fmu)")
    ap.add_argument("--runs", type=int, required=True, help="number of Monte Carlo runs")
    ap.add_argument("--seed", type=int, required=True, help="seed of the draws")
    ap.add_argument("--out", required=True, help="results CSV, one row per run ordered by run")
    g = ap.add_mutually_exclusive_group()
    g.add_argument("--workers", type=int, default=2,
                   help="LocalCluster worker processes (default 2; 0: serial in this process, no dask)")
    g.add_argument("--scheduler", help="address of a running dask scheduler, e.g. tcp://HOST:8786")
    ap.add_argument("--model", help="nominal model JSON (may carry an \"uncertainty\" member)")
    ap.add_argument("--uncertainty", help='uncertainty JSON: {"ranges": {...}} or {"names", "mean", "cov"}')
    ap.add_argument("--chunk", type=int, default=4, help="runs per task (default 4)")
    ap.add_argument("--plot", help="histogram of the tracking errors (default OUT with .png)")
    a = ap.parse_args(argv)
    if a.runs < 1:
        raise SystemExit("--runs must be at least 1")

    fmu = str(pathlib.Path(a.fmu).resolve())
    pid_fmu = str(pathlib.Path(a.pid_fmu).resolve() if a.pid_fmu
                  else pathlib.Path(a.fmu).resolve().parent / "MagSwarmPID.fmu")
    for p in (fmu, pid_fmu):
        if not pathlib.Path(p).is_file():
            raise SystemExit(f"{p} not found (build with `magswarm fmu` and `magswarm fmu --pid`)")

    tmp = None
    model_file = None
    embedded = None
    if a.model:
        doc = json.loads(pathlib.Path(a.model).read_text())
        embedded = doc.pop("uncertainty", None)
        tmp = tempfile.mkdtemp(prefix="magswarm-sweep-")
        model_file = str(pathlib.Path(tmp) / "model.json")
        pathlib.Path(model_file).write_text(json.dumps(doc))

    try:
        local = Simulator(fmu, pid_fmu, model_file)
        nominal = local.nominal()
        if a.uncertainty:
            unc = Uncertainty.from_json(json.loads(pathlib.Path(a.uncertainty).read_text()), nominal, a.uncertainty)
        elif embedded is not None:
            unc = Uncertainty.from_json(embedded, nominal, "--model (uncertainty member)")
        else:
            unc = Uncertainty.default(nominal)

        chunks = [list(range(i, min(i + a.chunk, a.runs))) for i in range(0, a.runs, a.chunk)]
        bar = Bar(a.runs)
        t0 = time.perf_counter()
        rows: list[dict] = []
        if a.scheduler is None and a.workers == 0:
            sys.modules[__name__]._magswarm_simulators = {(fmu, pid_fmu, model_file): local}
            for c in chunks:
                rows += run_chunk(c, a.seed, unc, fmu, pid_fmu, model_file)
                bar.add(len(c))
            workers = 0
        else:
            from distributed import Client, LocalCluster, as_completed
            cluster = None
            if a.scheduler:
                client = Client(a.scheduler)
            else:
                cluster = LocalCluster(n_workers=a.workers, threads_per_worker=1, processes=True,
                                       dashboard_address=None)
                client = Client(cluster)
            try:
                if cluster is not None:
                    client.wait_for_workers(a.workers)
                workers = len(client.scheduler_info()["workers"])
                print(f"cluster up in {time.perf_counter() - t0:.2f} s ({workers} workers)", file=sys.stderr)
                t0 = time.perf_counter()  # throughput below excludes the cluster's start
                futures = [client.submit(run_chunk, c, a.seed, unc, fmu, pid_fmu, model_file, pure=False)
                           for c in chunks]
                for fut in as_completed(futures):
                    part = fut.result()
                    rows += part
                    bar.add(len(part))
            finally:
                client.close()
                if cluster is not None:
                    cluster.close()
        secs = time.perf_counter() - t0
        rows.sort(key=lambda r: r["run"])
        out = pathlib.Path(a.out)
        write_csv(out, unc.names, rows)
        plot(pathlib.Path(a.plot) if a.plot else out.with_suffix(".png"), rows)
        failed = sum(1 for r in rows if r["error"])
        print(f"{a.runs} runs in {secs:.2f} s ({a.runs / secs:.2f} runs/s, "
              f"{workers if workers else 'serial'} workers); {failed} failed; {out}")
    finally:
        if tmp:
            shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
