"""An FMU with unmodelled effects switched on reproduces `magswarm predict` on the same inputs.

Two ways of getting the effects into the FMU are checked: a model JSON baked into
resources/ (`magswarm fmu --model M.json --out X.fmu`) and the default FMU with its String
parameter `model_file` pointing at the JSON. The model switches on every effect with
non-neutral values (formation lag and particle drift make the outputs depend on the FMU's
time and on the slow formation mode, camera bias on the output map), and the schedule has
steps in both inputs across the step-out frequency and the cohesion onset.
"""

from __future__ import annotations

import csv
import json
import pathlib
import subprocess
import zipfile

import numpy as np
import pytest

from conftest import hz, mm
from conftest import magswarm_exe_or_skip as magswarm_exe

EFFECTS = {
    "phase_lag": {"f_so_hz": 6.0, "nu": 1.0, "spread": 0.3},
    "cohesion_loss": {"z_c_mm": 15.0, "k_per_mm2": 0.01},
    "formation_lag": {"share": 0.4, "tau_s": 6.0, "zeta": 0.5},
    "particle_drift": {"rate_per_h": -0.5},
    "centroid_offset": {"offset_mm": 1.0},
    "camera_bias": {"scale": 1.03, "offset_mm": 0.1, "tilt_deg": 12.0},
    # Learned terms (what `magswarm diagnose` writes where an effect's shape is not its
    # library form): one along every axis, every mode.
    "learned": [
        {"effect": "phase_lag", "axis": "f_hz", "mode": "rate_hz", "knots": [3.0, 5.0, 7.0, 9.0],
         "r1": [0.0, 0.3, 0.8, 1.2], "r2": [0.0, 0.3, 0.8, 1.2], "field_exponent": 0.5},
        {"effect": "phase_lag", "axis": "f_hz", "mode": "add_mm", "knots": [4.0, 6.0, 8.0],
         "r1": [0.0, 0.4, 0.1], "r2": [0.0, 0.8, 0.2], "amplitude_exponent": 1.0},
        {"effect": "cohesion_loss", "axis": "z_m_mm", "mode": "relative", "knots": [10.0, 15.0, 20.0, 25.0],
         "r1": [0.0, 0.02, 0.06, 0.1], "r2": [0.0, 0.03, 0.08, 0.15]},
        {"effect": "particle_drift", "axis": "t_s", "mode": "add_mm", "knots": [0.0, 10.0, 20.0, 40.0],
         "r1": [0.0, -0.1, -0.3, -0.3], "r2": [0.0, -0.2, -0.4, -0.5]},
        {"effect": "formation_lag", "axis": "since_change_s", "mode": "step_fraction",
         "knots": [0.0, 2.0, 5.0, 10.0], "r1": [-0.8, -0.3, 0.1, 0.0], "r2": [-0.6, -0.2, 0.15, 0.0],
         "sd_r1": [0.05, 0.05, 0.05, 0.05], "sd_r2": [0.05, 0.05, 0.05, 0.05]},
        # A transient that follows only the changes that make a radius shrink.
        {"effect": "formation_lag", "axis": "since_change_s", "mode": "step_fraction",
         "steps": "shrinking", "knots": [0.0, 3.0, 8.0], "r1": [0.5, 0.2, 0.0], "r2": [0.4, 0.1, 0.0]},
        # A transient that grows with the step's size (a rate limit): heights x |step| / 1.5 mm.
        {"effect": "formation_lag", "axis": "since_change_s", "mode": "step_fraction",
         "step_size_mm": 1.5, "knots": [0.0, 1.0, 4.0], "r1": [0.3, 0.2, 0.0], "r2": [0.4, 0.15, 0.0]},
    ],
}

# (duration_s, z_mm, f_hz): rows every 0.5 s.
SEGMENTS = [(6.0, 8.5, 4.0), (8.0, 20.5, 4.0), (8.0, 20.5, 8.5), (6.0, 6.0, 9.5), (6.0, 13.5, 2.0)]
DT = 0.5


@pytest.fixture(scope="module")
def effects_model(fmu_path, tmp_path_factory) -> pathlib.Path:
    """The FMU's baked paper model with every effect switched on, as a model file."""
    with zipfile.ZipFile(fmu_path) as z:
        model = json.loads(z.read("resources/model.json"))
    model["schema"] = "magswarm-model/2"
    model["effects"] = EFFECTS
    path = tmp_path_factory.mktemp("effects") / "effects_model.json"
    path.write_text(json.dumps(model, indent=1))
    return path


@pytest.fixture(scope="module")
def schedule_log(tmp_path_factory) -> tuple[pathlib.Path, list[tuple[float, float, float]]]:
    rows = []
    t = 0.0
    for dur, z, f in SEGMENTS:
        for _ in range(int(round(dur / DT))):
            rows.append((round(t, 6), z, f))
            t += DT
    path = tmp_path_factory.mktemp("effects") / "inputs.csv"
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t_s", "z_m_mm", "f_hz"])
        w.writerows(rows)
    return path, rows


@pytest.fixture(scope="module")
def predicted(effects_model, schedule_log, tmp_path_factory):
    log, rows = schedule_log
    out = tmp_path_factory.mktemp("effects") / "pred.csv"
    subprocess.run([str(magswarm_exe()), "predict", "--model", str(effects_model), "--log", str(log),
                    "--out", str(out)], check=True, capture_output=True)
    with out.open() as fh:
        data = list(csv.DictReader(fh))
    assert len(data) == len(rows)
    return np.array([[float(d[k]) for k in ("r1_mm", "r2_mm", "r1_ss_mm", "r2_ss_mm")] for d in data])


def predict_radii(exe, model, inputs, out):
    """`magswarm predict` of a model on an inputs CSV: (rows, 2) radii in mm."""
    subprocess.run([str(exe), "predict", "--model", str(model), "--log", str(inputs), "--out",
                    str(out)], check=True, capture_output=True)
    with out.open() as fh:
        return np.array([[float(r["r1_mm"]), float(r["r2_mm"])] for r in csv.DictReader(fh)])


def run_fmu(md, unzipdir, vr, rows, model_file=None, fmu_log=None):
    """Replay the rows as predict does: inputs of row k held from row k-1 to row k. Radii in mm."""
    from fmpy.fmi2 import FMU2Slave

    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir,
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="parity")
    fmu.instantiate(callbacks=fmu_log.callbacks if fmu_log else None)
    fmu.setupExperiment(startTime=rows[0][0])
    fmu.enterInitializationMode()
    if model_file is not None:
        fmu.setString([vr["model_file"]], [str(model_file)])
    names = [vr[n] for n in ("r1", "r2", "r1_ss", "r2_ss")]
    inputs = [vr["z_m"], vr["omega_m"]]
    _, z0, f0 = rows[0]
    fmu.setReal(inputs, [mm(z0), hz(f0)])
    fmu.exitInitializationMode()
    out = [fmu.getReal(names)]
    for k in range(1, len(rows)):
        t, z, f = rows[k]
        fmu.setReal(inputs, [mm(z), hz(f)])
        fmu.doStep(currentCommunicationPoint=rows[k - 1][0], communicationStepSize=t - rows[k - 1][0])
        out.append(fmu.getReal(names))
    fmu.terminate()
    fmu.freeInstance()
    return np.array(out) * 1e3


def test_baked_fmu_with_effects_reproduces_predict(effects_model, schedule_log, predicted,
                                                   tmp_path_factory, fmu_log):
    from fmpy import extract, read_model_description

    _, rows = schedule_log
    fmu = tmp_path_factory.mktemp("effects") / "MagSwarmEffects.fmu"
    subprocess.run([str(magswarm_exe()), "fmu", "--no-build", "--model", str(effects_model), "--out",
                    str(fmu)], check=True, capture_output=True)
    with zipfile.ZipFile(fmu) as z:
        baked = json.loads(z.read("resources/model.json"))
    assert baked["effects"] == EFFECTS
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipdir = extract(str(fmu), unzipdir=str(tmp_path_factory.mktemp("baked")))
    got = run_fmu(md, unzipdir, vr, rows, fmu_log=fmu_log)
    err = np.abs(got - predicted).max(axis=0)
    assert err.max() < 1e-4, f"baked FMU vs predict, max |diff| per output [mm]: {err}"


def test_model_file_parameter_with_effects_reproduces_predict(effects_model, schedule_log, predicted,
                                                              model_description, unzipdir, vr, fmu_log):
    _, rows = schedule_log
    got = run_fmu(model_description, unzipdir, vr, rows, model_file=effects_model, fmu_log=fmu_log)
    err = np.abs(got - predicted).max(axis=0)
    assert err.max() < 1e-4, f"model_file FMU vs predict, max |diff| per output [mm]: {err}"
    # The effects are really in force: the default FMU without model_file differs by far more.
    base = run_fmu(model_description, unzipdir, vr, rows, fmu_log=fmu_log)
    assert np.abs(base - predicted).max() > 0.5


def test_diagnose_augmented_model_runs_in_the_fmu(model_description, unzipdir, vr, fmu_log,
                                                  tmp_path_factory):
    """The user's path end to end: a lab campaign whose truth carries a cohesion loss in the
    lab's foreign form, `magswarm diagnose` on it, and its augmented.json (the accepted effect
    switched on) loaded into the FMU through `model_file`: the FMU reproduces `magswarm predict`
    with that model on the campaign's inputs, and both differ from the baseline.json model."""
    exe = magswarm_exe()
    d = tmp_path_factory.mktemp("diagnose")
    scenario = {
        "foreign": [{"kind": "cohesion_poly", "z0_mm": 14.0, "gain": [0.0008, 0.0015],
                     "power": 2.0, "tau_s": 0.5}],
        "protocol": {"kind": "grid", "visits": 2, "repeats": 4, "settle_s": 20.0,
                     "approach_s": [2.0, 5.0]},
    }
    (d / "scenario.json").write_text(json.dumps(scenario))
    log = d / "campaign.csv"
    subprocess.run([str(exe), "lab", "--scenario", str(d / "scenario.json"), "--seed", "3",
                    "--quiet", "--out", str(log)], check=True, capture_output=True)
    out = d / "report"
    subprocess.run([str(exe), "diagnose", "--log", str(log), "--permutations", "199", "--out",
                    str(out)], check=True, capture_output=True)
    report = json.loads((out / "report.json").read_text())
    assert "cohesion_loss" in report["accepted"], report["accepted"]
    augmented = json.loads((out / "augmented.json").read_text())
    # Each accepted effect is switched on, in its library form or as a learned term.
    on = {k for k in augmented["effects"] if k != "learned"}
    on |= {t["effect"] for t in augmented["effects"].get("learned", [])}
    assert on == set(report["accepted"]), augmented["effects"]
    # The first 120 rows of the campaign (about a fifth of it) through both.
    with log.open() as fh:
        rows = [(float(r["t_s"]), float(r["z_m_mm"]), float(r["f_hz"])) for r in csv.DictReader(fh)][:120]
    inputs = d / "inputs.csv"
    with inputs.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t_s", "z_m_mm", "f_hz"])
        w.writerows(rows)
    preds = {name: predict_radii(exe, out / f"{name}.json", inputs, d / f"pred_{name}.csv")
             for name in ("augmented", "baseline")}
    try:
        got = run_fmu(model_description, unzipdir, vr, rows, model_file=out / "augmented.json",
                      fmu_log=fmu_log)[:, :2]
    except Exception as e:
        raise AssertionError(f"FMU with augmented.json failed: {e}; FMU log: {fmu_log.messages}") from e
    err = np.abs(got - preds["augmented"]).max()
    assert err < 1e-4, f"FMU with augmented.json vs predict: max |diff| {err} mm"
    assert np.abs(preds["augmented"] - preds["baseline"]).max() > 0.2


def test_diagnosed_learned_shape_runs_in_the_fmu(model_description, unzipdir, vr, fmu_log,
                                                 tmp_path_factory):
    """A learned shape as `magswarm diagnose` writes it, end to end: the seed's grid visited
    once (10 rows a visit) with a +1 mm band of r2 at 5-6 Hz at every z_m, which no library
    form describes; diagnose names phase_lag and writes its learned shape over f into
    augmented.json; the FMU with that model (through `model_file`) reproduces `magswarm
    predict`, and both differ from the baseline where the band is."""
    exe = magswarm_exe()
    d = tmp_path_factory.mktemp("learned")
    rng = np.random.default_rng(7)
    points = [(z, f) for z in (3.5, 8.5, 13.5, 18.5, 23.5) for f in range(1, 11)]
    order = rng.permutation(len(points))
    rows = []
    t = 0.0
    for i in order:
        z, f = points[i]
        for k in range(10):
            rows.append((round(t + 3.0 + k, 3), z, float(f)))
        t += 13.0
    inputs = d / "inputs.csv"
    with inputs.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t_s", "z_m_mm", "f_hz"])
        w.writerows(rows)
    paper = d / "paper.csv"
    subprocess.run([str(exe), "predict", "--log", str(inputs), "--out", str(paper)], check=True,
                   capture_output=True)
    with paper.open() as fh:
        truth = np.array([[float(r["r1_mm"]), float(r["r2_mm"])] for r in csv.DictReader(fh)])
    f_of = np.array([r[2] for r in rows])
    truth[:, 1] += np.where((f_of >= 5.0) & (f_of <= 6.0), 1.0, 0.0)
    visit = np.repeat(rng.normal(0.0, [0.15, 0.3], size=(len(points), 2)), 10, axis=0)
    meas = truth + visit + rng.normal(0.0, [0.2, 0.35], size=truth.shape)
    log = d / "band.csv"
    with log.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t_s", "z_m_mm", "f_hz", "r1_mm", "r2_mm"])
        w.writerows([(t, z, f, f"{a:.4f}", f"{b:.4f}") for (t, z, f), (a, b) in zip(rows, meas)])
    out = d / "report"
    subprocess.run([str(exe), "diagnose", "--log", str(log), "--bootstrap", "199", "--out",
                    str(out)], check=True, capture_output=True)
    report = json.loads((out / "report.json").read_text())
    assert report["accepted"][:1] == ["phase_lag"], report["accepted"]
    augmented = json.loads((out / "augmented.json").read_text())
    learned = augmented["effects"].get("learned", [])
    assert any(t["effect"] == "phase_lag" and t["axis"] == "f_hz" for t in learned), augmented["effects"]
    preds = {name: predict_radii(exe, out / f"{name}.json", inputs, d / f"pred_{name}.csv")
             for name in ("augmented", "baseline")}
    got = run_fmu(model_description, unzipdir, vr, rows, model_file=out / "augmented.json",
                  fmu_log=fmu_log)[:, :2]
    err = np.abs(got - preds["augmented"]).max()
    assert err < 1e-4, f"FMU with the learned shape vs predict: max |diff| {err} mm"
    band = (f_of >= 5.0) & (f_of <= 6.0)
    lift = (preds["augmented"] - preds["baseline"])[:, 1]
    assert lift[band].mean() - lift[~band].mean() > 0.4, (lift[band].mean(), lift[~band].mean())
