#!/usr/bin/env python3
"""A second, independent scenario generator for `magswarm diagnose` (numpy + standard library).

It shares no code and no formula with magswarm's effect terms or its Rust scenario generator:
the baseline is written here from the seed paper (dipole field of the 20 mm sphere averaged over
a turn numerically, stiffness (7), steady map (5)-(6), a first-order approach of this script's
own "lab"), and every unmodelled effect is written from its physical description in shapes of
its own (bands, hinges, saturations, logistic/power/exponential onsets, slow modes, ringing,
dead times, sudden/stepwise/late losses, local bumps and dips).

    python scripts/blind/gen_blind.py --seed 1 --out /tmp/blind1

writes, per scenario, `NAME.csv` (training log), `NAME.withheld.csv` (operating points between
the grid's, interleaved in the same session clock), `NAME.truth_withheld.csv` (noise-free
withheld radii with and without the effect, for scoring the shrink), and `truth.json` (one entry
per scenario: kind, truth effect names or null/anomaly, variant, protocol, region, strength in
units of the lab's visit noise, lab parameters). Logs follow docs/log-format.md exactly:
`t_s,z_m_mm,f_hz,r1_mm,r2_mm`.
"""
from __future__ import annotations

import argparse
import csv
import json
import math
import pathlib

import numpy as np

# --------------------------------------------------------------------------------------------
# The lab: the seed's physics with this lab's own constants
# --------------------------------------------------------------------------------------------

Z_GRID = np.array([3.5, 8.5, 13.5, 18.5, 23.5])  # mm, the seed's 50-point grid
F_GRID = np.arange(1.0, 11.0)  # Hz
Z_MID = np.array([6.0, 11.0, 16.0, 21.0])  # withheld: between the grid's
F_MID = np.arange(1.5, 10.0, 1.0)

TABLE_I = dict(C1=7.76, C2=16.6, aK1=0.487, aK2=2.58, al1=0.10, al2=0.45, g1=0.21, g2=0.10,
               s0=0.023, aG=0.20, N=-0.273, q=0.24, aP=0.823, muP=0.33, cP=-0.77, qP=0.10,
               fref=6.0)


def draw_lab(rng: np.random.Generator) -> dict:
    """Another lab: Table I moved (gains, exponents), its own magnet, offsets, units and noise."""
    p = dict(TABLE_I)
    p["C1"] *= rng.uniform(0.9, 1.1)
    p["C2"] *= rng.uniform(0.9, 1.1)
    p["aK1"] *= rng.uniform(0.85, 1.15)
    p["aK2"] *= rng.uniform(0.85, 1.15)
    p["al1"] += rng.uniform(-0.02, 0.02)
    p["al2"] += rng.uniform(-0.04, 0.04)
    p["N"] *= rng.uniform(0.9, 1.1)
    p["q"] += rng.uniform(-0.02, 0.02)
    p["aG"] *= rng.uniform(0.95, 1.05)
    p["aP"] *= rng.uniform(0.97, 1.03)
    lab = dict(
        par=p,
        Br=rng.uniform(1.22, 1.42),  # T, remanence of this lab's magnet
        radius_mm=20.0,
        z_off_mm=rng.uniform(-0.3, 1.0),  # where this lab's z_m = 0 sits above the surface
        lat_mm=rng.uniform(4.5, 7.5),  # swarm centroid off the spin axis
        lat_angle=rng.uniform(0.0, math.pi),
        k_unit=720.0 * rng.uniform(0.9, 1.1),  # T^2/m^2
        g_unit=1.69 * rng.uniform(0.9, 1.1),  # T/m
        B_ref=0.129 * rng.uniform(0.95, 1.05),
        rho=0.52,
        tau0=rng.uniform(0.35, 0.7),  # s, formation time at the closest point
        tau_growth=rng.uniform(1.8, 3.0),  # tau grows by this factor over the z range
        sv=(rng.uniform(0.12, 0.2), rng.uniform(0.2, 0.34)),  # visit noise SD, mm (r1, r2)
        sr=(rng.uniform(0.04, 0.09), rng.uniform(0.06, 0.13)),  # row noise SD, mm
        heavy=bool(rng.uniform() < 0.3),  # visit offsets Student-t (5 dof) rather than Gaussian
    )
    return lab


def mean_B2(x, y, zdepth, K):
    """<|B|^2> over one turn of a dipole spinning in the horizontal plane (numerical average
    over 8 phases; |B|^2 is a degree-2 trigonometric polynomial in the phase, so 8 is exact).
    x, y, zdepth in metres (zdepth > 0 below the centre), K = mu0 m / 4 pi [T m^3]."""
    acc = 0.0
    r = np.sqrt(x * x + y * y + zdepth * zdepth)
    for k in range(8):
        ph = 2 * math.pi * k / 8
        mx, my = math.cos(ph), math.sin(ph)
        mdotr = (mx * x + my * y) / r
        bx = K * (3 * mdotr * x / r - mx) / r ** 3
        by = K * (3 * mdotr * y / r - my) / r ** 3
        bz = K * (3 * mdotr * (-zdepth) / r) / r ** 3
        acc = acc + bx * bx + by * by + bz * bz
    return acc / 8


def field(z_mm, lab):
    """B (RMS over a turn) [T], g_z = |dB/dz| [T/m], k_xx, k_yy = d2<B^2>/dx2, dy2 [T^2/m^2]."""
    z_mm = np.asarray(z_mm, float)
    R = lab["radius_mm"] * 1e-3
    K = lab["Br"] * R ** 3 / 3.0
    d = (z_mm + lab["radius_mm"] + lab["z_off_mm"]) * 1e-3
    x0 = lab["lat_mm"] * 1e-3 * math.cos(lab["lat_angle"])
    y0 = lab["lat_mm"] * 1e-3 * math.sin(lab["lat_angle"])
    h = 2e-4
    b2 = mean_B2(x0, y0, d, K)
    B = np.sqrt(b2)
    gz = np.abs(np.sqrt(mean_B2(x0, y0, d + h, K)) - np.sqrt(mean_B2(x0, y0, d - h, K))) / (2 * h)
    kxx = (mean_B2(x0 + h, y0, d, K) - 2 * b2 + mean_B2(x0 - h, y0, d, K)) / h ** 2
    kyy = (mean_B2(x0, y0 + h, d, K) - 2 * b2 + mean_B2(x0, y0 - h, d, K)) / h ** 2
    return B, gz, kxx, kyy


_FIELD_CACHE: dict = {}


def field_at(z_mm, lab):
    """field() memoised per distance (a log visits a few distances many times)."""
    z = np.asarray(z_mm, float)
    key0 = (lab["Br"], lab["z_off_mm"], lab["lat_mm"], lab["lat_angle"], lab["radius_mm"])
    uz, inv = np.unique(z, return_inverse=True)
    vals = []
    for zz in uz:
        key = key0 + (float(zz),)
        if key not in _FIELD_CACHE:
            if len(_FIELD_CACHE) > 100000:
                _FIELD_CACHE.clear()
            _FIELD_CACHE[key] = tuple(float(np.ravel(v)[0]) for v in field(np.array([zz]), lab))
        vals.append(_FIELD_CACHE[key])
    arr = np.array(vals)[inv.ravel()].reshape(z.shape + (4,))
    return arr[..., 0], arr[..., 1], arr[..., 2], arr[..., 3]


def steady(z_mm, f_hz, lab, f_eff=None):
    """Steady radii (r1, r2) [mm] from the stiffness (7) and the map (5)-(6)."""
    p = lab["par"]
    B, gz, kxx, kyy = field_at(z_mm, lab)
    f = np.asarray(f_hz, float) if f_eff is None else np.asarray(f_eff, float)
    w = np.abs(f) / p["fref"]
    inter = p["aP"] * (B / lab["B_ref"]) ** p["muP"] * (1 + np.log(1 + p["cP"] * w ** p["qP"]))
    grad = p["aG"] * (gz / lab["g_unit"]) ** lab["rho"]
    Sx = p["s0"] + p["aK1"] * np.abs(kxx / lab["k_unit"]) ** p["g1"] + grad + inter
    Sy = p["s0"] + p["aK2"] * np.abs(kyy / lab["k_unit"]) ** p["g2"] + grad + inter
    Sx = np.maximum(Sx, 1e-3)
    Sy = np.maximum(Sy, 1e-3)
    phi = np.exp(p["N"] * (w ** p["q"] - 1))
    return p["C1"] * phi / Sx ** p["al1"], p["C2"] * phi / Sy ** p["al2"]


def tau_of(z_mm, lab):
    """This lab's formation time constant [s]: grows with distance (weaker confinement)."""
    u = (np.asarray(z_mm, float) - 3.5) / 20.0
    return lab["tau0"] * lab["tau_growth"] ** u


# --------------------------------------------------------------------------------------------
# Protocols: a schedule of setpoints (holds) and the times of the rows recorded in each
# --------------------------------------------------------------------------------------------

def protocol_rows(kind, rng, lab, short_wait=False, sweep_ok=True, order="mixed"):
    """Returns holds: list of dict(z, f, t0 (the change), t_rows (array)), and the session
    length. Grid visits in a random order, or (30 %, where sweep_ok) as a sweep: z outer, f
    inner. A sweep confounds session time with z_m, so drift scenarios never use it, unless
    `order` is "sweep" (every grid pass a sweep, drifts included: a stress test of how a
    diagnosis tells a drift from the inputs) or "random" (never a sweep)."""
    holds = []
    t = 0.0
    if kind in ("single", "twice"):
        pts = [(z, f) for z in Z_GRID for f in F_GRID]
        nvis, nrow = (1, 10) if kind == "single" else (2, 5)
        order = []
        for _ in range(nvis):
            sweep = rng.uniform() >= 0.7
            if order == "sweep":
                sweep, sweep_ok = True, True
            elif order == "random":
                sweep = False
            idx = np.arange(len(pts)) if (sweep and sweep_ok) else rng.permutation(len(pts))
            order += [pts[i] for i in idx]
        wait = rng.uniform(1.0, 3.0) if short_wait else rng.uniform(8.0, 20.0)
        dt = rng.choice([0.5, 1.0])
        for z, f in order:
            t_rows = t + wait + dt * np.arange(nrow)
            holds.append(dict(z=z, f=f, t0=t, t_rows=t_rows))
            # the log format's rule: a row's inputs act since the previous row, so the change
            # is made right after the last row of the previous visit
            t = t_rows[-1]
    else:  # far-apart setpoint steps, streamed
        n = int(rng.integers(30, 40))
        dt = rng.choice([0.5, 1.0])
        z, f = rng.choice(Z_GRID), rng.choice(F_GRID)
        for _ in range(n):
            while True:
                z2, f2 = rng.choice(Z_GRID), rng.choice(F_GRID)
                if abs(z2 - z) >= 10 or abs(f2 - f) >= 5:
                    break
            z, f = z2, f2
            hold = rng.uniform(14, 22)
            t_rows = t + dt * np.arange(1, int(hold / dt) + 1)
            holds.append(dict(z=z, f=f, t0=t, t_rows=t_rows))
            t = t_rows[-1]
    return holds, t


def withheld_holds(kind, rng, lab, T, nrow=6):
    """Operating points between the grid's, at times spread over the same session clock."""
    pts = [(z, f) for z in Z_MID for f in F_MID]
    sel = rng.choice(len(pts), size=20, replace=False)
    holds = []
    if kind == "steps":
        # a streamed run of steps between the off-grid points
        # one streamed block of steps (contiguous: the inputs change right after a row)
        t = rng.uniform(0, max(T - 16.0 * len(sel), 1.0))
        for i in sel:
            z, f = pts[i]
            t0 = t
            t_rows = t0 + 1.0 * np.arange(1, 17)
            holds.append(dict(z=z, f=f, t0=t0, t_rows=t_rows))
            t = t_rows[-1]
    else:
        starts = np.sort(rng.uniform(0, max(T - 20, 1), size=len(sel)))
        t = 0.0
        for k, i in enumerate(sel):
            z, f = pts[i]
            t0 = t  # the change right after the previous row (log format's rule)
            t_rows = max(starts[k], t) + 6.0 + 1.0 * np.arange(nrow)
            holds.append(dict(z=z, f=f, t0=t0, t_rows=t_rows))
            t = t_rows[-1]
    return holds


# --------------------------------------------------------------------------------------------
# Effects, each from its physical description. An effect is a dict of hooks:
#   "target": (z, f, lab, A) -> (dr1, dr2) added to the steady radii (mm)  [static in inputs]
#   "ftarget": (z, f, lab, A) -> f_eff (the swarm's effective frequency)    [static]
#   "resp": (s, tau, A) -> remaining fraction of a step after s seconds     [transient]
#   "gain": (t, T, A) -> multiplicative factor of both radii over session time [drift]
#   "add": (z, f, A) -> (dr1, dr2) added to the measured radii, not through the map [anomaly]
# Every effect has an amplitude A, calibrated so that the largest deviation of the noise-free
# training log from the noise-free baseline is `strength` visit-noise SDs.
# --------------------------------------------------------------------------------------------

def smooth_box(x, lo, hi, w):
    """1 inside [lo, hi], logistic edges of width w (w -> 0: hard edges)."""
    w = max(w, 1e-3)
    return 1 / (1 + np.exp(-(x - lo) / w)) * 1 / (1 + np.exp((x - hi) / w))


def make_effect(name, variant, rng, lab):
    """Returns (effect_name, hooks, description, axis). `rng` draws the shape's own constants."""
    if name == "phase_lag":
        if variant == 0:  # a band of r2 between two frequencies, soft or hard edges
            lo = rng.uniform(4.6, 5.2)
            hi = lo + rng.uniform(0.8, 1.6)
            w = rng.choice([0.05, 0.25, 0.5])
            desc = f"band of r2 over f in [{lo:.2f}, {hi:.2f}] Hz, edge width {w} Hz, every z_m"
            return dict(target=lambda z, f, lab, A: (0 * f, A * smooth_box(f, lo, hi, w))), desc
        if variant == 1:  # step-out: above a frequency that falls with the field, the swarm slips
            f0 = rng.uniform(5.5, 7.5)
            bmid = field(13.5, lab)[0]
            k = rng.uniform(0.3, 0.8)

            def hook(z, f, lab, A):
                fso = f0 * (field(z, lab)[0] / bmid) ** k
                slip = np.maximum(0.0, f - fso)
                return A * 0.4 * slip, A * slip  # both radii grow past step-out, r2 more
            desc = f"step-out hinge above f = {f0:.1f} Hz (B/B_mid)^{k:.2f}, growth with slip"
            return dict(target=hook), desc
        if variant == 2:  # a soft knee over f: past f_k the swarm lags the field more and more
            fk = rng.uniform(5.5, 7.5)
            wk = rng.uniform(0.3, 1.0)
            share = rng.uniform(0.0, 0.4)

            def knee(z, f, lab, A):
                u = wk * np.log1p(np.exp((f - fk) / wk))
                return share * A * u, A * u
            desc = f"soft knee over f at {fk:.1f} Hz (width {wk:.1f} Hz), r1 share {share:.2f}, every z_m"
            return dict(target=knee), desc
        # variant 3: retrograde dip past the reversal frequency
        fr = rng.uniform(6.0, 7.5)
        wd = rng.uniform(0.6, 1.2)
        desc = f"dip of both radii (relative) centred at {fr:.1f} Hz, width {wd:.1f} Hz"

        def hook3(z, f, lab, A):
            r1, r2 = steady(z, f, lab)
            g = np.exp(-0.5 * ((f - fr) / wd) ** 2)
            return -A * 0.05 * g * r1, -A * 0.05 * g * r2
        return dict(target=hook3, amax=8.0), desc

    if name == "cohesion_loss":
        if variant == 0:  # linear past an onset
            z0 = rng.uniform(8.0, 14.0)
            share = rng.uniform(0.3, 0.7)
            desc = f"linear growth past z = {z0:.1f} mm (r1 share {share:.2f})"
            return dict(target=lambda z, f, lab, A: (share * A * np.maximum(0, z - z0) / (23.5 - z0),
                                                     A * np.maximum(0, z - z0) / (23.5 - z0))), desc
        if variant == 1:  # smooth logistic onset at large z, relative
            z0 = rng.uniform(16.0, 20.0)
            w = rng.uniform(1.2, 2.5)

            def hook(z, f, lab, A):
                r1, r2 = steady(z, f, lab)
                s = 1 / (1 + np.exp(-(z - z0) / w))
                return 0.05 * A * s * r1, 0.05 * A * s * r2
            desc = f"logistic onset at z = {z0:.1f} mm, width {w:.1f} mm, relative on both radii"
            return dict(target=hook, amax=8.0), desc
        if variant == 2:  # power law in distance, stronger at high f (weaker binding when spun fast)
            pw = rng.uniform(3.0, 6.0)

            def hook2(z, f, lab, A):
                s = (z / 23.5) ** pw * (0.6 + 0.4 * f / 10)
                return 0.3 * A * s, A * s
            desc = f"power law (z/23.5)^{pw:.1f}, growing with f"
            return dict(target=hook2), desc
        L = rng.uniform(2.5, 5.0)  # variant 3: exponential approach to fragmentation
        desc = f"exponential onset exp((z - 23.5)/{L:.1f}) on r2, half on r1"
        return dict(target=lambda z, f, lab, A: (0.5 * A * np.exp((z - 23.5) / L),
                                                 A * np.exp((z - 23.5) / L))), desc

    if name == "formation_lag":
        if variant == 0:  # a slow second mode
            t2 = rng.uniform(3.0, 7.0)
            desc = f"slow second mode, tau2 = {t2:.1f} s"
            return dict(resp=lambda s, tau, A: (1 - A) * np.exp(-s / tau) + A * np.exp(-s / t2),
                        amax=1.0), desc
        if variant == 1:  # underdamped: ringing after each change
            period = rng.uniform(2.0, 6.0)
            zeta = rng.uniform(0.12, 0.35)

            def ring(s, tau, A):
                wn = 2 * math.pi / period / math.sqrt(1 - zeta ** 2)
                wd = wn * math.sqrt(1 - zeta ** 2)
                g2 = np.exp(-zeta * wn * s) * (np.cos(wd * s) + zeta / math.sqrt(1 - zeta ** 2) * np.sin(wd * s))
                return (1 - A) * np.exp(-s / tau) + A * g2
            desc = f"underdamped, period {period:.1f} s, damping ratio {zeta:.2f}"
            return dict(resp=ring, amax=1.0), desc
        if variant == 2:  # dead time before the swarm starts to re-form
            td = rng.uniform(1.5, 4.0)

            def dead(s, tau, A):
                g = np.where(s < td, 1.0, np.exp(-(s - td) / tau))
                return (1 - A) * np.exp(-s / tau) + A * g
            desc = f"dead time {td:.1f} s then the lab's approach"
            return dict(resp=dead, amax=1.0), desc
        t3 = rng.uniform(1.5, 4.0)  # variant 3: overshoot (a transient that passes the target)

        def over(s, tau, A):
            return np.exp(-s / tau) - A * 2.5 * (s / t3) * np.exp(1 - s / t3) / 2.5
        desc = f"overshoot bump peaking at {t3:.1f} s"
        return dict(resp=over, amax=1.0), desc

    if name == "particle_drift":
        # losses shrink the swarm: factor (1 - loss(t/T)); T the session length
        if variant == 0:
            return dict(gain=lambda t, T, A: 1 - 0.05 * A * t / T, amax=8.0), "linear loss over the session"
        if variant == 1:
            t0 = rng.uniform(0.3, 0.7)
            ramp = rng.uniform(0.0, 0.02)
            desc = f"sudden loss at {t0:.2f} T (ramp {ramp:.2f} T)"
            return dict(gain=lambda t, T, A: 1 - 0.05 * A * np.clip((t / T - t0) / max(ramp, 1e-4), 0, 1), amax=8.0), desc
        if variant == 2:
            ts = np.sort(rng.uniform(0.15, 0.9, size=3))
            sz = rng.dirichlet(np.ones(3))
            desc = "stepwise loss at " + ", ".join(f"{a:.2f} T" for a in ts)
            return dict(gain=lambda t, T, A: 1 - 0.05 * A * sum(s * (t / T >= a) for a, s in zip(ts, sz)), amax=8.0), desc
        if variant == 3:
            t0 = rng.uniform(0.5, 0.75)
            desc = f"late, accelerating loss from {t0:.2f} T (quadratic)"
            return dict(gain=lambda t, T, A: 1 - 0.05 * A * np.clip((t / T - t0) / (1 - t0), 0, 1) ** 2, amax=8.0), desc
        k = rng.uniform(4.0, 7.0)  # variant 4: exponential, heavy at the end
        desc = f"exponential loss (e^({k:.1f} t/T) - 1)/(e^{k:.1f} - 1)"
        return dict(gain=lambda t, T, A: 1 - 0.05 * A * (np.exp(k * t / T) - 1) / (math.exp(k) - 1), amax=8.0), desc

    if name == "camera_bias":
        if variant == 0:
            return dict(add=lambda z, f, A: (A + 0 * z, A + 0 * z)), "constant offset of both radii"
        return dict(add=lambda z, f, A: (0.6 * A + 0 * z, A + 0 * z)), "offset, r1 at 60 %"

    if name == "anomaly":
        # something no effect describes: a local bump/dip at a few neighbouring operating points
        if variant == 0:  # a box of 1-3 grid points (present at every visit there)
            iz = int(rng.integers(1, 4))
            ifr = int(rng.integers(1, 8))
            nf = int(rng.integers(1, 4))
            zs = [float(Z_GRID[iz])]
            fs = [float(x) for x in F_GRID[ifr:ifr + nf]]
            sign = 1.0 if rng.uniform() < 0.7 else -1.0

            def box(z, f, A):
                m = np.isin(z, zs) & np.isin(f, fs)
                return 0.5 * sign * A * m, sign * A * m
            desc = f"{'bump' if sign > 0 else 'dip'} at z = {zs} mm, f = {fs} Hz"
            return dict(add=box, place=(min(zs), max(zs), min(fs), max(fs))), desc
        if variant == 1:  # a Gaussian bump in (z, f) between grid points, r2 only
            zc = rng.uniform(6.0, 21.0)
            fc = rng.uniform(2.0, 9.0)
            sz, sf = rng.uniform(1.5, 3.0), rng.uniform(0.6, 1.2)

            def gb(z, f, A):
                g = np.exp(-0.5 * (((z - zc) / sz) ** 2 + ((f - fc) / sf) ** 2))
                return 0 * g, A * g
            desc = f"Gaussian bump of r2 at z = {zc:.1f} mm, f = {fc:.1f} Hz (SD {sz:.1f} mm, {sf:.1f} Hz)"
            return dict(add=gb, place=(zc - 1.5 * sz, zc + 1.5 * sz, fc - 1.5 * sf, fc + 1.5 * sf)), desc
        # variant 2: an aspect flip at a 2x2 patch (r1 up, r2 down: a transient vortex state)
        iz = int(rng.integers(0, 4))
        ifr = int(rng.integers(0, 9))
        zs, fs = [float(x) for x in Z_GRID[iz:iz + 2]], [float(x) for x in F_GRID[ifr:ifr + 2]]

        def flip(z, f, A):
            m = np.isin(z, zs) & np.isin(f, fs)
            return 0.7 * A * m, -A * m
        desc = f"aspect flip (r1 up, r2 down) at z = {zs} mm, f = {fs} Hz"
        return dict(add=flip, place=(min(zs), max(zs), min(fs), max(fs))), desc
    raise ValueError(name)


N_VARIANTS = dict(phase_lag=4, cohesion_loss=4, formation_lag=4, particle_drift=5, camera_bias=2, anomaly=3)


# --------------------------------------------------------------------------------------------
# Simulation of a log
# --------------------------------------------------------------------------------------------

def simulate(holds, T, lab, effects, amps, with_effects=True):
    """Noise-free rows: arrays t, z, f, r1, r2, s (time since change), idx (hold index)."""
    ts, zs, fs, r1s, r2s, ss, hidx = [], [], [], [], [], [], []
    state = None
    for k, h in enumerate(holds):
        z, f = h["z"], h["f"]
        zz, ff = np.array([z]), np.array([f])
        f_eff = None
        d1 = d2 = 0.0
        resp = None
        if with_effects:
            for e, A in zip(effects, amps):
                if "ftarget" in e:
                    f_eff = e["ftarget"](zz, ff, lab, A)
                if "target" in e:
                    a1, a2 = e["target"](zz, ff, lab, A)
                    d1, d2 = d1 + float(np.ravel(a1)[0]), d2 + float(np.ravel(a2)[0])
                if "resp" in e:
                    resp = (e["resp"], A)
        r1t, r2t = steady(zz, ff, lab, f_eff)
        tgt = np.array([float(r1t[0]) + d1, float(r2t[0]) + d2])
        if state is None:
            state = tgt.copy()
        tau = float(tau_of(z, lab))
        t_rows = h["t_rows"]
        s = t_rows - h["t0"]
        g = resp[0](s, tau, resp[1]) if resp else np.exp(-s / tau)
        r = tgt[None, :] + (state - tgt)[None, :] * g[:, None]
        # the state at the next change (the next hold starts at the next hold's t0)
        t_next = holds[k + 1]["t0"] if k + 1 < len(holds) else t_rows[-1]
        s_next = np.array([max(t_next - h["t0"], 0.0)])
        g_next = resp[0](s_next, tau, resp[1]) if resp else np.exp(-s_next / tau)
        state = tgt + (state - tgt) * float(g_next[0])
        ts.append(t_rows); zs.append(np.full(len(t_rows), z)); fs.append(np.full(len(t_rows), f))
        r1s.append(r[:, 0]); r2s.append(r[:, 1]); ss.append(s); hidx.append(np.full(len(t_rows), k))
    t = np.concatenate(ts); z = np.concatenate(zs); f = np.concatenate(fs)
    r1 = np.concatenate(r1s); r2 = np.concatenate(r2s)
    if with_effects:
        for e, A in zip(effects, amps):
            if "gain" in e:
                gfac = e["gain"](t, T, A)
                r1 = r1 * gfac
                r2 = r2 * gfac
            if "add" in e:
                a1, a2 = e["add"](z, f, A)
                r1 = r1 + a1
                r2 = r2 + a2
    return dict(t=t, z=z, f=f, r1=r1, r2=r2, s=np.concatenate(ss), hold=np.concatenate(hidx))


def add_noise(sim, lab, rng):
    nh = int(sim["hold"].max()) + 1
    out = dict(sim)
    for i, key in enumerate(("r1", "r2")):
        if lab["heavy"]:
            off = rng.standard_t(5, size=nh) * lab["sv"][i] / math.sqrt(5 / 3)
        else:
            off = rng.normal(0, lab["sv"][i], size=nh)
        out[key] = sim[key] + off[sim["hold"]] + rng.normal(0, lab["sr"][i], size=len(sim[key]))
    return out


FREE = ("C1", "C2", "aK1", "aK2", "al1", "al2", "N", "q")  # what a user's identification moves


def imitate(holds, values, lab):
    """The baseline's best imitation of settled values (the last row of each hold): a
    Levenberg-Marquardt fit of the seed's free parameters (C_i, a_K,i, alpha_i, N, q) of this
    lab's own map, in units of the visit noise. Returns the residual (n_holds, 2) in mm."""
    z = np.array([h["z"] for h in holds])
    f = np.array([h["f"] for h in holds])
    sv = np.array(lab["sv"])
    lab2 = dict(lab, par=dict(lab["par"]))
    th = np.array([lab["par"][k] for k in FREE])

    def res(theta):
        for k, v in zip(FREE, theta):
            lab2["par"][k] = v
        r1, r2 = steady(z, f, lab2)
        return ((values - np.stack([r1, r2], 1)) / sv).ravel()

    np.seterr(over="ignore", invalid="ignore")
    r = res(th)
    lam = 1e-3
    for _ in range(30):
        J = np.empty((r.size, th.size))
        for j in range(th.size):
            h = 1e-6 * max(abs(th[j]), 1e-2)
            tp = th.copy(); tp[j] += h
            J[:, j] = (res(tp) - r) / h
        g = J.T @ r
        H = J.T @ J
        while True:
            step = np.linalg.solve(H + lam * np.diag(np.diag(H) + 1e-12), -g)
            r_new = res(th + step)
            if r_new @ r_new < r @ r:
                th, r, lam = th + step, r_new, lam * 0.3
                break
            lam *= 10
            if lam > 1e8:
                break
        if lam > 1e8 or np.linalg.norm(step) < 1e-9 * (1 + np.linalg.norm(th)):
            break
    return r.reshape(-1, 2) * sv


def last_rows(sim):
    last = np.r_[np.nonzero(np.diff(sim["hold"]))[0], len(sim["hold"]) - 1]
    return np.stack([sim["r1"][last], sim["r2"][last]], 1)


def calibrate(holds, T, lab, effects, hooks_idx, strength, base, absorb=True):
    """Amplitude of effects[hooks_idx] so that its strength is `strength` visit-noise SDs.
    Strength: the largest deviation of the noise-free log from the baseline's best imitation of
    it (absorb=True: static and drift effects; the seed's free parameters refitted to the
    settled values), else from this lab's baseline (transients), in units of the visit SD of
    each axis, the larger of the two axes."""
    e = effects[hooks_idx]
    amax = e.get("amax", 50.0)
    sv = np.array(lab["sv"])

    # transients: the baseline's imitation is the lab's own first-order approach with its time
    # scale stretched (a rig's formation law is not a formation effect)
    stretched = []
    if not absorb:
        for c in np.geomspace(0.3, 4.0, 15):
            st = dict(resp=lambda s_, tau, A_, c=c: np.exp(-s_ / (c * tau)))
            stretched.append(simulate(holds, T, lab, [st], [0.0]))

    def dev(A):
        amps = [0.0] * len(effects)
        amps[hooks_idx] = A
        sim = simulate(holds, T, lab, effects, amps)
        if absorb:
            return float(np.max(np.abs(imitate(holds, last_rows(sim), lab)) / sv))
        best, best_ss = None, np.inf
        for b in [base] + stretched:
            e = np.stack([(sim["r1"] - b["r1"]) / sv[0], (sim["r2"] - b["r2"]) / sv[1]])
            if (e ** 2).sum() < best_ss:
                best_ss, best = (e ** 2).sum(), e
        return float(np.max(np.abs(best)))

    top = dev(amax)
    if top < strength:
        return amax, top
    lo, hi = 0.0, amax
    for _ in range(18):
        mid = 0.5 * (lo + hi)
        if dev(mid) < strength:
            lo = mid
        else:
            hi = mid
    return hi, dev(hi)


def region_of(sim, base, axis_key):
    d = np.maximum(np.abs(sim["r1"] - base["r1"]), np.abs(sim["r2"] - base["r2"]))
    if d.max() <= 0:
        return None
    m = d >= 0.3 * d.max()
    x = sim[axis_key][m]
    return [float(x.min()), float(x.max())]


AXIS = dict(phase_lag="f", cohesion_loss="z", formation_lag="s", particle_drift="t",
            camera_bias=None, anomaly=None)


def write_log(path, sim):
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t_s", "z_m_mm", "f_hz", "r1_mm", "r2_mm"])
        for i in range(len(sim["t"])):
            w.writerow([f"{sim['t'][i]:.3f}", f"{sim['z'][i]:g}", f"{sim['f'][i]:g}",
                        f"{max(sim['r1'][i], 0.01):.4f}", f"{max(sim['r2'][i], 0.01):.4f}"])


# --------------------------------------------------------------------------------------------
# The catalogue: the blind check's 14 kinds (plus camera bias), a variant per seed
# --------------------------------------------------------------------------------------------

# (kind, [effect names], protocol, strength range, fixed variant or None, extra)
CATALOGUE = [
    ("null_single", [], "single", None, None),
    ("null_twice", [], "twice", None, None),
    ("null_steps", [], "steps", None, None),
    ("anomaly_single", ["anomaly"], "single", (3.0, 5.0), None),
    ("anomaly_3visits", ["anomaly"], "twice", (3.0, 5.0), 0),
    ("cohesion_linear", ["cohesion_loss"], None, (2.5, 5.0), 0),
    ("cohesion_smooth_large_z", ["cohesion_loss"], "single", (2.5, 5.0), 1),
    ("cohesion_other", ["cohesion_loss"], None, (2.0, 5.0), "23"),
    ("drift_sudden", ["particle_drift"], None, (2.5, 5.0), 1),
    ("drift_heavy_tail", ["particle_drift"], None, (2.5, 5.0), "34"),
    ("drift_other", ["particle_drift"], None, (2.0, 5.0), "02"),
    ("phase_band_single", ["phase_lag"], "single", (2.5, 5.0), 0),
    ("phase_other", ["phase_lag"], None, (2.0, 5.0), "123"),
    ("formation_underdamped", ["formation_lag"], None, (2.5, 5.0), 1),
    ("formation_other", ["formation_lag"], None, (2.0, 5.0), "023"),
    ("pair_drift_cohesion", ["particle_drift", "cohesion_loss"], None, (2.5, 5.0), None),
    ("pair_other", ["phase_lag", "cohesion_loss"], None, (2.5, 5.0), None),
]


def build_scenario(kind, names, protocol, srange, fixed, seed, k, out, order="mixed"):
    rng = np.random.default_rng([seed, k, 7919])
    lab = draw_lab(rng)
    if protocol is None:
        if any(n == "formation_lag" for n in names):
            protocol = ["steps", "single"][(seed + k) % 2]
        else:
            protocol = ["single", "twice", "steps"][(seed + k) % 3]
    # rows soon after each change only where the transient is the point (formation lag)
    short = protocol != "steps" and any(n == "formation_lag" for n in names)
    holds, T = protocol_rows(protocol, rng, lab, short_wait=short,
                             sweep_ok="particle_drift" not in names, order=order)
    wh = withheld_holds(protocol, rng, lab, T)
    effects, descs, variants = [], [], []
    for j, n in enumerate(names):
        nv = N_VARIANTS[n]
        if isinstance(fixed, int):
            v = fixed
        elif isinstance(fixed, str):
            v = int(fixed[(seed + j) % len(fixed)])
        else:
            v = (seed + k + j) % nv
        e, d = make_effect(n, v, rng, lab)
        effects.append(e); descs.append(d); variants.append(v)
    base = simulate(holds, T, lab, [], [], with_effects=False)
    amps, strengths, regions = [], [], []
    for j, n in enumerate(names):
        target = float(rng.uniform(*srange))
        only = [effects[j]]
        A, st = calibrate(holds, T, lab, only, 0, target, base, absorb=(n != "formation_lag"))
        amps.append(A); strengths.append(st)
        sim_j = simulate(holds, T, lab, only, [A])
        if n == "anomaly":
            regions.append(dict(z_m_mm=[effects[j]["place"][0], effects[j]["place"][1]],
                                f_hz=[effects[j]["place"][2], effects[j]["place"][3]]))
        elif AXIS[n]:
            key = dict(f="f_hz", z="z_m_mm", s="time_since_change_s", t="t_s")[AXIS[n]]
            reg = {key: region_of(sim_j, base, AXIS[n])}
            if AXIS[n] in ("f", "z", "t"):
                # where the part the baseline cannot imitate shows (the residual a method can see)
                res = np.abs(imitate(holds, last_rows(sim_j), lab)) / np.array(lab["sv"])
                mag = res.max(axis=1)
                last = np.r_[np.nonzero(np.diff(sim_j["hold"]))[0], len(sim_j["hold"]) - 1]
                ax = sim_j[AXIS[n]][last]
                m = mag >= 0.5 * mag.max()
                reg["unabsorbed_" + key] = [float(ax[m].min()), float(ax[m].max())]
            regions.append(reg)
        else:
            regions.append(None)
    clean = simulate(holds, T, lab, effects, amps)
    noisy = add_noise(clean, lab, rng)
    w_clean = simulate(wh, T, lab, effects, amps)
    w_base = simulate(wh, T, lab, [], [], with_effects=False)
    w_noisy = add_noise(w_clean, lab, rng)
    name = f"s{seed}_{k:02d}_{kind}"
    write_log(out / f"{name}.csv", noisy)
    write_log(out / f"{name}.withheld.csv", w_noisy)
    with open(out / f"{name}.truth_withheld.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t_s", "z_m_mm", "f_hz", "r1_true_mm", "r2_true_mm", "r1_base_mm", "r2_base_mm"])
        for i in range(len(w_clean["t"])):
            w.writerow([f"{w_clean['t'][i]:.3f}", f"{w_clean['z'][i]:g}", f"{w_clean['f'][i]:g}",
                        f"{w_clean['r1'][i]:.5f}", f"{w_clean['r2'][i]:.5f}",
                        f"{w_base['r1'][i]:.5f}", f"{w_base['r2'][i]:.5f}"])
    truth = "null" if not names else ("anomaly" if names == ["anomaly"] else "effect")
    return dict(
        name=name, kind=kind, truth=truth,
        effects=[n for n in names if n != "anomaly"], variants=variants, shapes=descs,
        protocol=protocol, short_wait=bool(short), rows=int(len(noisy["t"])),
        regions=regions, strength=[round(float(s), 2) for s in strengths], amplitude=amps,
        visit_sd_mm=list(lab["sv"]), row_sd_mm=list(lab["sr"]), heavy_tailed_visits=lab["heavy"],
        lab=dict(Br=lab["Br"], z_off_mm=lab["z_off_mm"], lat_mm=lab["lat_mm"], tau0=lab["tau0"]),
    )


def generate(seed: int, out: pathlib.Path, only=None, verbose=False, order="mixed") -> list[dict]:
    """Writes the logs of the catalogue's kinds (all, or those in `only`) for `seed` into `out`
    with their truth.json; returns the truth entries. `order`: "mixed" (the default: 30 % of
    grid passes swept, drifts never), "sweep" (every grid pass swept) or "random"."""
    out.mkdir(parents=True, exist_ok=True)
    truths = []
    for k, (kind, names, protocol, srange, fixed) in enumerate(CATALOGUE):
        if only and kind not in only:
            continue
        truths.append(build_scenario(kind, names, protocol, srange, fixed, seed, k, out, order))
        if verbose:
            print(f"{truths[-1]['name']}: {truths[-1]['protocol']}, {truths[-1]['rows']} rows, "
                  f"strength {truths[-1]['strength']}, {'; '.join(truths[-1]['shapes']) or 'no effect'}",
                  flush=True)
    with open(out / "truth.json", "w") as fh:
        json.dump(dict(seed=seed, order=order, scenarios=truths), fh, indent=1)
    return truths


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", required=True, type=pathlib.Path)
    ap.add_argument("--only", default=None, help="comma-separated kinds (default: all); kinds: "
                    + ", ".join(c[0] for c in CATALOGUE))
    ap.add_argument("--order", choices=["mixed", "sweep", "random"], default="mixed",
                    help="visit order of the grid protocols: mixed (30 %% swept, drift scenarios "
                    "never), sweep (z_m outer, f inner, every pass, drifts included: session time "
                    "then follows the inputs) or random")
    args = ap.parse_args(argv)
    generate(args.seed, args.out, set(args.only.split(",")) if args.only else None, verbose=True,
             order=args.order)


if __name__ == "__main__":
    main()
