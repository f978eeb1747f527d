"""Run MagSwarm.fmu in libcosim (libcosimpy) and print the observed outputs as JSON.

Run in a subprocess by test_libcosim.py: libcosimpy does not check the pointers libcosimc hands
back, so an FMU that libcosim refuses to load (bad modelDescription, failed fmi2Instantiate) ends
in a segfault on the next call rather than an exception. In a child process that becomes a clear
test failure with libcosim's log (on stderr) attached.

usage: python _libcosim_run.py JSON
  {"mode": "single", "fmu": PATH, "step_ns": 10000000, "steps": 300,
   "initial": {"z_m": 0.0085, "omega_m": 25.13},
   "changes": [[step_index, {"z_m": 0.0135}], ...],      # override before that step
   "outputs": ["r1", ...]}
  {"mode": "ssp" | "osp", "path": DIR_OR_FILE, "instance": "swarm", "until_ns": N, "outputs": [...]}
stdout (last line): {"t_ns": [...], "values": [[...], ...], "status": {...}}
"""

from __future__ import annotations

import json
import sys


def main() -> int:
    cfg = json.loads(sys.argv[1])

    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

    # The default prints FMI Library's debug chatter; "log_level": "TRACE" asks for all of it.
    log_output_level(getattr(CosimLogLevel, cfg.get("log_level", "WARNING")))

    from libcosimpy._internal import get_last_error_message
    from libcosimpy.CosimEnums import CosimErrorCode, CosimExecutionState
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimManipulator import CosimManipulator
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    def die(msg: str) -> int:
        print(json.dumps({"error": f"{msg}: {get_last_error_message()}"}))
        return 2

    mode = cfg["mode"]
    if mode == "single":
        ex = CosimExecution.from_step_size(step_size=int(cfg["step_ns"]))
        slave = CosimLocalSlave(fmu_path=cfg["fmu"], instance_name="swarm")
        if not slave.ptr():
            return die("libcosim could not load the FMU")
        idx = ex.add_local_slave(local_slave=slave)
        if idx < 0:
            return die("add_local_slave failed")
    elif mode == "ssp":
        ex = CosimExecution.from_ssp_file(ssp_path=cfg["path"])
    elif mode == "osp":
        ex = CosimExecution.from_osp_config_file(osp_path=cfg["path"])
    else:
        raise SystemExit(f"unknown mode {mode}")

    if mode != "single":
        idx = ex.slave_index_from_instance_name(cfg.get("instance", "swarm"))
        if idx is None:
            return die("instance not found in the system")

    refs = {v.name.decode(): v.reference for v in ex.slave_variables(idx)}
    missing = [n for n in cfg["outputs"] if n not in refs]
    if missing:
        print(json.dumps({"error": f"variables unknown to libcosim: {missing}"}))
        return 2
    out_refs = [refs[n] for n in cfg["outputs"]]

    observer = CosimObserver.create_last_value()
    ex.add_observer(observer=observer)

    def status():
        s = ex.status()
        return {"state": CosimExecutionState(s.state).name, "error_code": CosimErrorCode(s.error_code).name,
                "current_time": s.current_time}

    t_ns, values = [], []
    if mode == "single":
        for name, value in cfg.get("initial", {}).items():
            if not ex.real_initial_value(idx, refs[name], float(value)):
                return die(f"real_initial_value {name}")
        manipulator = CosimManipulator.create_override()
        ex.add_manipulator(manipulator=manipulator)
        changes = {int(k): v for k, v in cfg.get("changes", [])}
        for k in range(int(cfg["steps"])):
            if k in changes:
                names = list(changes[k])
                if not manipulator.slave_real_values(idx, [refs[n] for n in names],
                                                     [float(changes[k][n]) for n in names]):
                    return die(f"override at step {k}")
            if not ex.step():
                print(json.dumps({"error": f"step {k} failed: {get_last_error_message()}", "status": status()}))
                return 3
            t_ns.append(ex.status().current_time)
            values.append(observer.last_real_values(idx, out_refs))
    else:
        if not ex.simulate_until(target_time=int(cfg["until_ns"])):
            print(json.dumps({"error": f"simulate_until failed: {get_last_error_message()}", "status": status()}))
            return 3
        t_ns.append(ex.status().current_time)
        values.append(observer.last_real_values(idx, out_refs))

    print(json.dumps({"t_ns": t_ns, "values": values, "status": status()}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
