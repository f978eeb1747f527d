"""MagSwarm.fmu as FMI 2.0 Model Exchange under fmpy's solvers (CVode, and fmpy's Euler),
checked against the same FMU run as Co-Simulation: one binary, one XML, both interfaces."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import hz, mm

SEGS = [(8.5, 4.0), (13.5, 4.0), (13.5, 7.0), (5.0, 2.0), (20.0, 9.0)]
SEG = 8.0  # s per segment
DT = 0.01


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


def test_xml_declares_both_interfaces_with_one_identifier(model_description):
    me, cs = model_description.modelExchange, model_description.coSimulation
    assert me is not None and cs is not None
    assert me.modelIdentifier == cs.modelIdentifier == "MagSwarm"
    assert me.canGetAndSetFMUstate and me.providesDirectionalDerivative
    states = [d.variable.derivative.name for d in model_description.derivatives]
    assert states == ["r1", "r2"]


@pytest.mark.parametrize("solver", ["CVode", "Euler"])
def test_model_exchange_agrees_with_co_simulation(fmu_path, solver):
    from fmpy import simulate_fmu

    common = dict(start_time=0.0, stop_time=len(SEGS) * SEG, output_interval=DT, input=_inputs(),
                  output=["r1", "r2", "r1_ss", "r2_ss"])
    cs = simulate_fmu(str(fmu_path), fmi_type="CoSimulation", **common)
    extra = dict(relative_tolerance=1e-8) if solver == "CVode" else dict(step_size=1e-4)
    me = simulate_fmu(str(fmu_path), fmi_type="ModelExchange", solver=solver, **extra, **common)
    t = cs["time"]
    ok = _away_from_steps(t)
    # CVode (BDF, rtol 1e-8) meets the 1e-3 mm target; fmpy's explicit Euler at 0.1 ms is first
    # order (6e-3 mm measured on this schedule), so it only checks the interface, more loosely.
    tol_mm = 1e-3 if solver == "CVode" else 2e-2
    for name in ("r1", "r2", "r1_ss", "r2_ss"):
        y_me = np.interp(t, me["time"], me[name])
        worst = np.max(np.abs(y_me - cs[name])[ok]) * 1e3
        assert worst <= tol_mm, f"{solver}: {name} differs from Co-Simulation by {worst:.2e} mm"
    # The run moved the swarm: r2 spans several millimetres.
    assert np.ptp(cs["r2"]) > mm(2.0)
