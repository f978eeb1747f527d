"""The FMI 3.0 FMUs (`magswarm fmu --fmi-version 3`, and `--pid`): fmpy's validation, the
variables, units and value references of the FMI 2.0 FMUs kept exactly, the controller
giving the same commands in both versions, and rust-fmi's `fmi-sim` (a second, independent
FMI 3.0 importer) running the plant in both interfaces against the FMI 2.0 reference."""

from __future__ import annotations

import csv
import subprocess

import numpy as np
import pytest

from conftest import fmi_sim_or_skip, hz, mm


def _unit(v):
    """A variable's unit and display unit, wherever the XML put them (FMI 3.0 uses types)."""
    t = v.declaredType
    unit = v.unit or (t.unit if t is not None else None)
    display = v.displayUnit or (t.displayUnit if t is not None else None)
    return unit, display


def test_fmpy_validates_all_four_fmus(fmu_path, fmu3_path, pid_paths):
    """The plant and the controller, FMI 2.0 and 3.0: fmpy finds nothing to report."""
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    for path, version in ((fmu_path, "2.0"), (pid_paths[2], "2.0"), (fmu3_path, "3.0"), (pid_paths[3], "3.0")):
        assert validate_fmu(str(path)) == [], path
        md = read_model_description(str(path))
        assert md.fmiVersion == version
        if version == "3.0":
            assert md.coSimulation.providesAdjointDerivatives


@pytest.mark.parametrize("which", ["plant", "pid"])
def test_names_units_and_value_references_of_the_fmi2_fmu_are_kept(fmu_path, fmu3_path, pid_paths, which):
    from fmpy import read_model_description

    p2, p3 = (fmu_path, fmu3_path) if which == "plant" else (pid_paths[2], pid_paths[3])
    md2, md3 = read_model_description(str(p2)), read_model_description(str(p3))
    v3 = {v.name: v for v in md3.modelVariables}
    for v in md2.modelVariables:
        assert v.name in v3, f"{v.name} missing from the FMI 3.0 FMU"
        w = v3[v.name]
        assert w.valueReference == v.valueReference, v.name
        assert w.causality == v.causality, v.name
        assert _unit(w) == _unit(v), v.name
    extra = set(v3) - {v.name for v in md2.modelVariables}
    assert extra == {"time"}, f"FMI 3.0 adds only the independent variable, got {extra}"
    assert v3["time"].causality == "independent"


def test_the_controller_commands_the_same_in_both_versions(pid_paths):
    from fmpy import simulate_fmu

    ins = np.array([(0.0, mm(8.4), mm(11.9)), (1.0, mm(8.0), mm(11.5)), (2.0, mm(8.0), mm(11.5))],
                   dtype=[("time", np.float64), ("r1", np.float64), ("r2", np.float64)])
    runs = {v: simulate_fmu(str(p), fmi_type="CoSimulation", start_time=0.0, stop_time=2.0,
                            output_interval=0.05, input=ins, output=["z_m", "omega_m"])
            for v, p in pid_paths.items()}
    for name in ("z_m", "omega_m"):
        assert np.array_equal(runs[2][name], runs[3][name]), name
    assert np.ptp(runs[3]["z_m"]) > 0, "the controller acted"


def _fmi_sim(fmu, interface, inputs_csv, out_csv, step):
    cmd = [fmi_sim_or_skip(), "--model", str(fmu), "-i", str(inputs_csv), "-o", str(out_csv),
           interface, "-s", "0", "-f", "12", "--step", str(step), "-n", "0"]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, f"{' '.join(cmd)}\n{r.stderr[-2000:]}"
    with open(out_csv) as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in ("time", "r1", "r2")}


def test_fmi_sim_runs_the_fmi3_fmu_in_both_interfaces(fmu_path, fmu3_path, tmp_path):
    from fmpy import simulate_fmu

    # A step of both inputs at 4 s and another at 8 s, held in between.
    steps = [(0.0, 8.5, 4.0), (4.0, 18.5, 8.0), (8.0, 6.0, 3.0)]
    rows = []
    for k, (t0, z, f) in enumerate(steps):
        t1 = steps[k + 1][0] if k + 1 < len(steps) else 12.0
        rows += [(t0, mm(z), hz(f)), (t1, mm(z), hz(f))]
    inputs = tmp_path / "inputs.csv"
    with open(inputs, "w") as f:
        f.write("time,z_m,omega_m\n")
        # fmi-sim holds an input from its row on; duplicate times mark the steps.
        for t, z, w in rows:
            f.write(f"{t!r},{z!r},{w!r}\n")
    arr = np.array(rows, dtype=[("time", np.float64), ("z_m", np.float64), ("omega_m", np.float64)])
    ref = simulate_fmu(str(fmu_path), fmi_type="CoSimulation", start_time=0.0, stop_time=12.0,
                       output_interval=0.01, input=arr, output=["r1", "r2"])
    t = ref["time"]
    away = np.min(np.abs(t[:, None] - np.array([4.0, 8.0])[None, :]), axis=1) > 0.2
    cs = _fmi_sim(fmu3_path, "co-simulation", inputs, tmp_path / "cs.csv", 0.01)
    me = _fmi_sim(fmu3_path, "model-exchange", inputs, tmp_path / "me.csv", 1e-4)
    for label, res, tol_mm in (("co-simulation", cs, 1e-3), ("model-exchange (Euler, 0.1 ms)", me, 2e-2)):
        for name in ("r1", "r2"):
            y = np.interp(t, res["time"], res[name])
            worst = np.max(np.abs(y - ref[name])[away]) * 1e3
            assert worst <= tol_mm, f"fmi-sim {label}: {name} differs from fmpy FMI 2.0 CS by {worst:.2e} mm"
    assert np.ptp(cs["r2"]) > mm(1.0), "the steps moved the swarm"
