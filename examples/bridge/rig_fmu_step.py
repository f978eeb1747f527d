"""Drive the rig through MagSwarmRig.fmu with fmpy: a step of z_m and omega_m, in real time.

    python examples/bridge/rig_fmu_step.py MagSwarmRig.fmu OUT.csv [OUT.png]

The rig is whatever the FMU's config describes (scripts/bridge_demo.sh builds one for the
emulated rig). Writes the outputs at every communication point (SI units) and, with
matplotlib installed, a plot: camera radii beside the shadow model's, and the inputs asked and
applied by the rig's safety core.
"""

import csv
import math
import sys
import time

import numpy as np
from fmpy import simulate_fmu

OUTPUTS = ["r1", "r2", "valid", "r1_shadow", "r2_shadow", "z_m_applied", "omega_m_applied",
           "z_m_measured", "late", "late_steps"]


def main() -> int:
    fmu, out = sys.argv[1], sys.argv[2]
    png = sys.argv[3] if len(sys.argv) > 3 else None
    tau = 2 * math.pi
    # 12 mm / 4 Hz, then at 3 s 8 mm / 6 Hz (a repeated time is a step for fmpy).
    u = np.array([(0.0, 12e-3, tau * 4), (3.0, 12e-3, tau * 4), (3.0, 8e-3, tau * 6)],
                 dtype=[("time", float), ("z_m", float), ("omega_m", float)])
    t0 = time.time()
    res = simulate_fmu(fmu, stop_time=8.0, step_size=0.05, input=u, output=OUTPUTS)
    wall = time.time() - t0
    with open(out, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["time"] + OUTPUTS)
        for row in res:
            w.writerow([float(x) for x in row.tolist()])
    ok = res["valid"]
    d = (res["r2"][ok] - res["r2_shadow"][ok]) * 1e3
    print(f"MagSwarmRig.fmu: 8 s simulated in {wall:.2f} s of wall time, {len(res)} points, "
          f"{int(ok.sum())} with a valid frame, {int(res['late_steps'][-1])} late steps; "
          f"camera r2 - shadow r2: mean {d.mean():+.3f} mm -> {out}")
    if png:
        try:
            import matplotlib

            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
        except ImportError:
            print("matplotlib not installed: no plot", file=sys.stderr)
            return 0
        t = res["time"]
        fig, ax = plt.subplots(3, 1, figsize=(9, 8), sharex=True)
        for r, c in (("r1", "tab:blue"), ("r2", "tab:orange")):
            ax[0].plot(t, res[r] * 1e3, color=c, lw=1, label=f"{r} camera")
            ax[0].plot(t, res[f"{r}_shadow"] * 1e3, color=c, ls=":", label=f"{r} shadow model")
        ax[0].set_ylabel("radius [mm]")
        ax[0].legend(fontsize=8, ncol=2)
        ax[0].set_title("MagSwarmRig.fmu driven by fmpy: a step of z_m and omega_m")
        ax[1].plot(t, res["z_m_applied"] * 1e3, label="z_m applied")
        ax[1].plot(t, res["z_m_measured"] * 1e3, ls="--", label="z_m from the robot's pose")
        ax[1].set_ylabel("z_m [mm]")
        ax[1].legend(fontsize=8)
        ax[2].plot(t, res["omega_m_applied"] / tau, label="f applied")
        ax[2].set_ylabel("f [Hz]")
        ax[2].set_xlabel("time [s]")
        ax[2].legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(png, dpi=110)
        print(f"plot: {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
