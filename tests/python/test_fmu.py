"""MagSwarm.fmu through fmpy, as an importer sees it (README, "The FMU").

Value references are always looked up in modelDescription.xml.
"""

from __future__ import annotations

import math
import resource

import numpy as np
import pytest

from conftest import INPUTS, OUTPUTS, SCHEDULE_SEGMENTS, hz, mm, step_schedule

CONTRACT_UNITS = {
    "z_m": "m", "omega_m": "rad/s",
    "r1": "m", "r2": "m", "r1_ss": "m", "r2_ss": "m",
    "B": "T", "g_z": "T/m", "k_xx": "T2/m2", "k_yy": "T2/m2",
}
DISPLAY_UNITS = {"m": "mm", "rad/s": "Hz"}


# ----------------------------------------------------------------------------- modelDescription

def test_validate_fmu_reports_no_problems(fmu_path):
    from fmpy.validation import validate_fmu

    problems = validate_fmu(str(fmu_path))
    assert problems == [], "fmpy.validation.validate_fmu problems:\n" + "\n".join(problems)


def test_interface_matches_contract(model_description, variables):
    md = model_description
    assert md.fmiVersion == "2.0"
    assert md.coSimulation is not None, "not a Co-Simulation FMU"
    assert md.coSimulation.modelIdentifier == "MagSwarm"
    for name in INPUTS:
        v = variables[name]
        assert (v.causality, v.type) == ("input", "Real"), name
    for name in OUTPUTS:
        v = variables[name]
        assert (v.causality, v.type) == ("output", "Real"), name
    mf = variables.get("model_file")
    assert mf is not None, "String parameter model_file missing"
    assert (mf.causality, mf.type) == ("parameter", "String")

    for name, unit in CONTRACT_UNITS.items():
        assert variables[name].unit == unit, f"{name}: unit {variables[name].unit!r}, contract {unit!r}"
    for name in ("S_x", "S_y"):
        assert variables[name].unit in (None, "1"), f"{name} is dimensionless"

    units = {u.name: u for u in md.unitDefinitions}
    for unit, display in DISPLAY_UNITS.items():
        assert unit in units, f"UnitDefinitions lacks {unit}"
        assert display in [d.name for d in units[unit].displayUnits], f"{unit} has no display unit {display}"


def test_capability_flags(model_description):
    cs = model_description.coSimulation
    assert cs.canGetAndSetFMUstate
    assert cs.canSerializeFMUstate
    assert cs.providesDirectionalDerivative
    assert cs.canHandleVariableCommunicationStepSize
    assert not cs.canBeInstantiatedOnlyOncePerProcess


# ----------------------------------------------------------------------------- simulate_fmu

SEG = 40.0  # s per setpoint segment: long enough for the formation dynamics to settle


def test_simulate_fmu_with_input_table(fmu_path):
    """Steps of z_m and omega_m from an input table; the dynamic radii settle on the steady map."""
    from fmpy import simulate_fmu

    segs = [(8.5, 4.0), (13.5, 4.0), (13.5, 7.0), (5.0, 2.0)]
    rows = []
    for k, (z_mm, f_hz) in enumerate(segs):
        t0, t1 = k * SEG, (k + 1) * SEG
        rows += [(t0, mm(z_mm), hz(f_hz)), (t1, mm(z_mm), hz(f_hz))]  # repeated times make steps
    signals = np.array(rows, dtype=[("time", np.float64), ("z_m", np.float64), ("omega_m", np.float64)])
    stop = len(segs) * SEG
    dt = 0.05

    res = simulate_fmu(str(fmu_path), start_time=0.0, stop_time=stop, output_interval=dt, input=signals,
                       output=list(OUTPUTS))

    t = res["time"]
    assert t[0] == 0.0 and math.isclose(t[-1], stop)
    for name in OUTPUTS:
        assert np.all(np.isfinite(res[name])), f"{name} has non-finite values"

    for k, (z_mm, f_hz) in enumerate(segs):
        seg = (t > k * SEG + 1e-9) & (t <= (k + 1) * SEG + 1e-9)
        r1_ss, r2_ss, r1, r2 = (res[n][seg] for n in ("r1_ss", "r2_ss", "r1", "r2"))
        where = f"segment {k} (z_m {z_mm} mm, f {f_hz} Hz)"
        # the steady map depends on the inputs only: constant within a segment
        assert np.ptp(r1_ss) <= 1e-12 + 1e-9 * abs(r1_ss[-1]), where
        assert np.ptp(r2_ss) <= 1e-12 + 1e-9 * abs(r2_ss[-1]), where
        # metres, not millimetres; plausible magnitudes
        for name, v in (("r1_ss", r1_ss[-1]), ("r2_ss", r2_ss[-1])):
            assert mm(5.0) <= v <= mm(20.0), f"{where}: {name} = {v} m is not within 5-20 mm"
        assert r2_ss[-1] > r1_ss[-1], where
        # the dynamic radii approach the map and settle on it
        g1, g2 = np.abs(r1 - r1_ss), np.abs(r2 - r2_ss)
        assert g1[-1] <= 0.01 * r1_ss[-1] and g2[-1] <= 0.01 * r2_ss[-1], \
            f"{where}: not settled after {SEG} s: |r1-r1_ss|={g1[-1]:.3e}, |r2-r2_ss|={g2[-1]:.3e} m"
        if k > 0:
            assert g1[-1] <= 0.2 * g1[0] + 1e-7 and g2[-1] <= 0.2 * g2[0] + 1e-7, f"{where}: gap did not shrink"

    # the input steps changed the map
    ends = [res["r1_ss"][np.searchsorted(t, (k + 1) * SEG - 1e-9)] for k in range(len(segs))]
    assert len({round(e, 12) for e in ends}) == len(segs), f"steady map did not respond to the inputs: {ends}"


# ----------------------------------------------------------------------------- state

H = 0.01


def schedule():
    return step_schedule(SCHEDULE_SEGMENTS, H)


def test_get_set_fmu_state_replays_bit_identically(make_slave):
    s = make_slave("state")
    sched = schedule()
    s.run(sched[:150], H)                  # somewhere mid-transient
    t_saved = s.t
    state = s.fmu.getFMUstate()
    first = s.run(sched[150:], H)
    s.fmu.setFMUstate(state)
    s.t = t_saved
    second = s.run(sched[150:], H)
    s.fmu.freeFMUstate(state)
    assert np.array_equal(first, second), "replay after setFMUstate differs"
    assert np.all(np.isfinite(first))


def test_serialized_state_replays_bit_identically_in_another_instance(make_slave):
    a = make_slave("origin")
    sched = schedule()
    a.run(sched[:230], H)
    t_saved = a.t
    state = a.fmu.getFMUstate()
    blob = a.fmu.serializeFMUstate(state)
    a.fmu.freeFMUstate(state)
    assert isinstance(blob, bytes) and len(blob) > 0
    reference = a.run(sched[230:], H)

    # into the same instance, overwriting a state it had moved on from
    st = a.fmu.deSerializeFMUstate(blob)
    a.fmu.setFMUstate(st)
    a.fmu.freeFMUstate(st)
    a.t = t_saved
    assert np.array_equal(a.run(sched[230:], H), reference)

    # into a fresh instance
    b = make_slave("restored")
    st = b.fmu.deSerializeFMUstate(blob)
    b.fmu.setFMUstate(st)
    b.fmu.freeFMUstate(st)
    b.t = t_saved
    assert np.array_equal(b.run(sched[230:], H), reference)

    # serialization is deterministic
    st = b.fmu.getFMUstate()
    b.fmu.setFMUstate(b.fmu.deSerializeFMUstate(blob))
    st2 = b.fmu.getFMUstate()
    assert b.fmu.serializeFMUstate(st2) == blob
    b.fmu.freeFMUstate(st)
    b.fmu.freeFMUstate(st2)


def test_deserialize_rejects_garbage(make_slave):
    from fmpy.fmi1 import FMICallException

    s = make_slave("garbage")
    state = s.fmu.getFMUstate()
    blob = s.fmu.serializeFMUstate(state)
    s.fmu.freeFMUstate(state)
    with pytest.raises(FMICallException):
        s.fmu.deSerializeFMUstate(blob[: len(blob) // 2])


def test_reset_restarts_the_run(make_slave):
    sched = schedule()
    fresh = make_slave("fresh")
    reference = fresh.run(sched, H)

    s = make_slave("reset")
    s.run(sched[::-1][:250], H)
    s.fmu.reset()
    s.initialize()
    assert np.array_equal(s.run(sched, H), reference), "after fmi2Reset the run differs from a fresh instance"


def test_two_instances_do_not_share_state(make_slave):
    sched = schedule()
    other = [(mm(20.0), hz(9.0))] * len(sched)
    ref_a = make_slave("solo_a").run(sched, H)
    ref_b = make_slave("solo_b").run(other, H)

    a, b = make_slave("a"), make_slave("b")
    out_a, out_b = np.empty_like(ref_a), np.empty_like(ref_b)
    for k in range(len(sched)):  # interleaved
        a.set_inputs(*sched[k])
        b.set_inputs(*other[k])
        a.step(H)
        b.step(H)
        out_a[k], out_b[k] = a.outputs(), b.outputs()
    assert np.array_equal(out_a, ref_a)
    assert np.array_equal(out_b, ref_b)
    assert not np.array_equal(out_a, out_b)


def _rss_kib() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * resource.getpagesize() // 1024


def test_1000_instantiate_free_cycles(model_description, unzipdir, vr):
    """1000 fmi2Instantiate/fmi2FreeInstance cycles on one loaded library, memory stays flat."""
    from fmpy.fmi2 import FMU2Slave

    fmu = FMU2Slave(guid=model_description.guid, unzipDirectory=unzipdir,
                    modelIdentifier=model_description.coSimulation.modelIdentifier, instanceName="cycle")
    r1 = vr["r1"]
    rss = None
    try:
        for k in range(1000):
            fmu.instantiate()
            fmu.setupExperiment(startTime=0.0)
            fmu.enterInitializationMode()
            fmu.exitInitializationMode()
            fmu.doStep(0.0, H)
            assert math.isfinite(fmu.getReal([r1])[0])
            fmu.terminate()
            fmu.fmi2FreeInstance(fmu.component)
            fmu.component = None
            if k == 99:
                rss = _rss_kib()
        grown = _rss_kib() - rss
        assert grown < 16 * 1024, f"RSS grew by {grown} KiB over 900 instantiate/free cycles"
    finally:
        fmu.freeLibrary()


def test_repeated_load_unload_of_the_library(model_description, unzipdir):
    """What fmpy.simulate_fmu does on every call: dlopen, instantiate, free, dlclose."""
    from fmpy.fmi2 import FMU2Slave

    for _ in range(50):
        fmu = FMU2Slave(guid=model_description.guid, unzipDirectory=unzipdir,
                        modelIdentifier=model_description.coSimulation.modelIdentifier, instanceName="load")
        fmu.instantiate()
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        fmu.doStep(0.0, H)
        fmu.terminate()
        fmu.freeInstance()  # also unloads the library


def test_wrong_guid_is_refused(model_description, unzipdir):
    from fmpy.fmi2 import FMU2Slave

    fmu = FMU2Slave(guid="{00000000-0000-0000-0000-000000000000}", unzipDirectory=unzipdir,
                    modelIdentifier=model_description.coSimulation.modelIdentifier, instanceName="badguid")
    try:
        with pytest.raises(Exception, match="instantiate"):
            fmu.instantiate()
    finally:
        fmu.freeLibrary()


# ----------------------------------------------------------------------------- errors

@pytest.mark.parametrize("bad", [float("nan"), float("inf"), float("-inf")], ids=["nan", "inf", "-inf"])
@pytest.mark.parametrize("name", INPUTS)
def test_non_finite_input_is_an_error_not_nan_outputs(make_slave, vr, fmu_log, name, bad):
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import fmi2Error

    log = fmu_log
    s = make_slave(f"bad_{name}", callbacks=log.callbacks, logging_on=True)
    s.run(step_schedule([(0.5, 8.5, 4.0)], H), H)
    before = s.outputs()

    with pytest.raises(FMICallException) as exc:
        s.fmu.setReal([vr[name]], [bad])
    assert exc.value.status >= fmi2Error, f"status {exc.value.status}, expected fmi2Error"
    errors = [m for st, _, m in log.messages if st >= fmi2Error]
    assert errors, "no error message through the importer's logger"
    assert any(name in m for m in errors), f"error message does not name {name}: {errors}"

    # outputs are not NaN: either still readable and unchanged, or refused (instance in error state)
    try:
        after = s.outputs()
    except FMICallException:
        after = None
    if after is not None:
        assert np.all(np.isfinite(after)), f"non-finite outputs after a rejected {name}={bad}"
        assert np.array_equal(after, before)

    # the instance can be brought back with fmi2Reset and is then as good as new
    s.fmu.reset()
    s.initialize()
    out = s.run(step_schedule([(0.2, 8.5, 4.0)], H), H)
    assert np.all(np.isfinite(out))


def test_z_inside_the_magnet_is_an_error_naming_z_m(make_slave, vr, fmu_log):
    """A z_m that would put the swarm inside the magnet sphere is bad input, not extrapolation."""
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import fmi2Error

    s = make_slave("inside", callbacks=fmu_log.callbacks, logging_on=True)
    s.run(step_schedule([(0.2, 8.5, 4.0)], H), H)
    before = s.outputs()
    with pytest.raises(FMICallException):
        s.fmu.setReal([vr["z_m"]], [-0.5])
    errors = [m for st, _, m in fmu_log.messages if st >= fmi2Error]
    assert any("z_m" in m and "inside the magnet" in m for m in errors), errors
    assert np.array_equal(s.outputs(), before)


def test_absurd_frequency_is_refused_with_a_message_naming_the_input(make_slave, vr, fmu_log):
    """1e9 rad/s is no field frequency: a clear fmi2Error when it is set, never a crash or NaN."""
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import fmi2Error

    s = make_slave("stiff", callbacks=fmu_log.callbacks, logging_on=True)
    before = s.outputs()
    with pytest.raises(FMICallException):
        s.fmu.setReal([vr["omega_m"]], [1e9])
    errors = [m for st, _, m in fmu_log.messages if st >= fmi2Error]
    assert any("omega_m" in m and "validated" in m for m in errors), errors
    assert np.all(np.isfinite(s.outputs()))
    assert np.array_equal(s.outputs(), before)


def test_nan_in_an_input_table_fails_the_simulation(fmu_path):
    from fmpy import simulate_fmu
    from fmpy.fmi1 import FMICallException

    signals = np.array([(0.0, mm(8.5), hz(4.0)), (0.5, mm(8.5), hz(4.0)), (0.5, float("nan"), hz(4.0)),
                        (1.0, float("nan"), hz(4.0))],
                       dtype=[("time", np.float64), ("z_m", np.float64), ("omega_m", np.float64)])
    with pytest.raises(FMICallException):
        simulate_fmu(str(fmu_path), start_time=0.0, stop_time=1.0, output_interval=0.01, input=signals)


def test_out_of_envelope_input_warns_but_evaluates(make_slave, vr, fmu_log):
    """z_m beyond 23.5 mm: an fmi2Warning (returned or logged), not an error; outputs still finite."""
    from fmpy.fmi2 import fmi2Real, fmi2ValueReference, fmi2Warning

    s = make_slave("envelope", callbacks=fmu_log.callbacks, logging_on=True)
    f = s.fmu
    vrs = (fmi2ValueReference * 2)(vr["z_m"], vr["omega_m"])
    vals = (fmi2Real * 2)(mm(30.0), hz(4.0))
    statuses = [f.fmi2SetReal(f.component, vrs, 2, vals)]   # fmpy raises only for > fmi2Warning
    statuses.append(f.fmi2DoStep(f.component, s.t, H, 1))
    s.t += H
    assert np.all(np.isfinite(s.outputs()))
    logged = [m for st, _, m in fmu_log.messages if st == fmi2Warning]
    assert fmi2Warning in statuses or logged, \
        f"no fmi2Warning for z_m = 30 mm outside the envelope (statuses {statuses}, log {fmu_log.messages})"


# ----------------------------------------------------------------------------- derivatives

def test_directional_derivatives_match_finite_differences(make_slave, vr):
    s = make_slave("jac")
    z0, w0 = mm(10.0), hz(5.0)
    s.set_inputs(z0, w0)
    unknowns = ["r1_ss", "r2_ss"]
    for known, x0, dx in (("z_m", z0, 1e-7), ("omega_m", w0, 1e-4)):
        d = np.array(s.fmu.getDirectionalDerivative([vr[u] for u in unknowns], [vr[known]], [1.0]))
        xs = {"z_m": z0, "omega_m": w0}
        xs[known] = x0 + dx
        s.set_inputs(xs["z_m"], xs["omega_m"])
        plus = s.outputs(unknowns)
        xs[known] = x0 - dx
        s.set_inputs(xs["z_m"], xs["omega_m"])
        minus = s.outputs(unknowns)
        s.set_inputs(z0, w0)
        fd = (plus - minus) / (2 * dx)
        assert np.allclose(d, fd, rtol=1e-4, atol=1e-9 * np.max(np.abs(fd)) + 1e-15), \
            f"d{unknowns}/d{known}: analytic {d}, finite differences {fd}"
