"""Plot a magswarm-bridge log: measured radii, setpoints and the shadow model; the inputs.

    python examples/bridge/plot_tracking.py LOG.csv OUT.png

Needs matplotlib (skipped with a note when it is missing).
"""

import csv
import sys


def main() -> int:
    log, out = sys.argv[1], sys.argv[2]
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib not installed: no plot", file=sys.stderr)
        return 0
    rows = list(csv.DictReader(open(log)))
    ok = [r for r in rows if r.get("valid", "1") != "0" and r["r1_mm"]]

    def col(rs, name):
        return [float(r[name]) for r in rs if r.get(name)]

    t = col(ok, "t_s")
    fig, ax = plt.subplots(3, 1, figsize=(9, 8), sharex=True)
    for i, c in ((1, "tab:blue"), (2, "tab:orange")):
        ax[0].plot(t, col(ok, f"r{i}_mm"), color=c, lw=1, label=f"r{i} measured (emulated camera)")
        if ok and ok[0].get(f"r{i}_ref_mm"):
            ax[0].step(t, col(ok, f"r{i}_ref_mm"), where="post", color=c, ls="--", label=f"r{i}* setpoint")
        if ok and ok[0].get(f"shadow_r{i}_mm"):
            ax[0].plot(t, col(ok, f"shadow_r{i}_mm"), color=c, ls=":", label=f"r{i} shadow model")
    ax[0].set_ylabel("radius [mm]")
    ax[0].legend(fontsize=8, ncol=3)
    ax[0].set_title("magswarm-bridge on the emulated rig: PID tracking")
    ax[1].plot(t, col(ok, "z_m_mm"), label="z_m commanded")
    if ok and ok[0].get("z_meas_mm"):
        ax[1].plot(t, col(ok, "z_meas_mm"), ls=":", label="z_m from the robot's pose (RTDE)")
    ax[1].set_ylabel("z_m [mm]")
    ax[1].legend(fontsize=8)
    ax[2].plot(t, col(ok, "f_hz"))
    ax[2].set_ylabel("f [Hz]")
    ax[2].set_xlabel("t [s]")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"plot: {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
