"""MagSwarm.fmu in all four combinations, FMI 2.0 and 3.0 x Co-Simulation and Model Exchange,
under fmpy (Model Exchange with CVode, and fmpy's Euler), each checked against the FMI 2.0
Co-Simulation reference: one model source, two shells, two interfaces each."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import hz, mm

SEGS = [(8.5, 4.0), (13.5, 4.0), (13.5, 7.0), (5.0, 2.0), (20.0, 9.0)]
SEG = 8.0  # s per segment
DT = 0.01
NAMES = ("r1", "r2", "r1_ss", "r2_ss")


def _inputs():
    rows = []
    for k, (z_mm, f_hz) in enumerate(SEGS):
        rows += [(k * SEG, mm(z_mm), hz(f_hz)), ((k + 1) * SEG, mm(z_mm), hz(f_hz))]
    return np.array(rows, dtype=[("time", np.float64), ("z_m", np.float64), ("omega_m", np.float64)])


def _away_from_steps(t):
    """Samples more than 0.2 s away from every input step (where the interpolation of a
    sampled result around a discontinuity says nothing about the model)."""
    steps = np.array([k * SEG for k in range(1, len(SEGS))])
    return np.min(np.abs(t[:, None] - steps[None, :]), axis=1) > 0.2


def _simulate(path, fmi_type, solver=None):
    from fmpy import simulate_fmu

    common = dict(start_time=0.0, stop_time=len(SEGS) * SEG, output_interval=DT, input=_inputs(),
                  output=list(NAMES))
    if fmi_type == "CoSimulation":
        return simulate_fmu(str(path), fmi_type=fmi_type, **common)
    extra = dict(relative_tolerance=1e-8) if solver == "CVode" else dict(step_size=1e-4)
    return simulate_fmu(str(path), fmi_type=fmi_type, solver=solver, **extra, **common)


_REFERENCE = {}


def _reference(fmu_path):
    """The FMI 2.0 Co-Simulation run every combination is compared with (computed once)."""
    if "cs2" not in _REFERENCE:
        _REFERENCE["cs2"] = _simulate(fmu_path, "CoSimulation")
    return _REFERENCE["cs2"]


def _worst_mm(ref, res):
    t = ref["time"]
    ok = _away_from_steps(t)
    worst = {}
    for name in NAMES:
        y = np.interp(t, res["time"], res[name])
        worst[name] = float(np.max(np.abs(y - ref[name])[ok]) * 1e3)
    return worst


def test_xml_declares_both_interfaces_with_one_identifier(model_description):
    me, cs = model_description.modelExchange, model_description.coSimulation
    assert me is not None and cs is not None
    assert me.modelIdentifier == cs.modelIdentifier == "MagSwarm"
    assert me.canGetAndSetFMUstate and me.providesDirectionalDerivative
    states = [d.variable.derivative.name for d in model_description.derivatives]
    # ODE (4), then the slow formation mode of the formation_lag effect (per axis x, dx/dt).
    assert states == ["r1_ode", "r2_ode", "form_x1", "form_v1", "form_x2", "form_v2"]


@pytest.mark.parametrize("version,fmi_type,solver", [
    (2, "ModelExchange", "CVode"),
    (3, "CoSimulation", None),
    (3, "ModelExchange", "CVode"),
    (2, "ModelExchange", "Euler"),
])
def test_every_combination_agrees_with_fmi2_co_simulation(fmu_path, fmu3_path, version, fmi_type, solver):
    ref = _reference(fmu_path)
    res = _simulate(fmu_path if version == 2 else fmu3_path, fmi_type, solver)
    worst = _worst_mm(ref, res)
    # CVode (BDF, rtol 1e-8) and the FMI 3.0 Co-Simulation shell meet the 1e-3 mm target;
    # fmpy's explicit Euler at 0.1 ms is first order (6e-3 mm measured on this schedule), so
    # it only checks the interface, more loosely.
    tol_mm = 2e-2 if solver == "Euler" else 1e-3
    for name, w in worst.items():
        assert w <= tol_mm, f"FMI {version}.0 {fmi_type} {solver or ''}: {name} differs from the FMI 2.0 CS reference by {w:.2e} mm"
    if version == 3 and fmi_type == "CoSimulation":
        # The same model behind the other shell: the same numbers.
        assert max(worst.values()) == 0.0, worst
    # The run moved the swarm: r2 spans several millimetres.
    assert np.ptp(ref["r2"]) > mm(2.0)
