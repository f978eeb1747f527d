#!/usr/bin/env python3
"""Run `magswarm diagnose` on the logs written by gen_blind.py and score it.

    python scripts/blind/score.py /tmp/blind1 [/tmp/blind2 ...] --md docs-table.md [--jobs 2]

For each scenario: diagnose on NAME.csv with --withheld NAME.withheld.csv, then `magswarm
predict` with the written baseline.json and augmented.json on the withheld log, scored against
the generator's noise-free withheld radii (NAME.truth_withheld.csv), so the shrink is the share
of the withheld excess over the noise floor removed, measured without the floor's noise:

    shrink = 1 - MSE(augmented - truth) / MSE(baseline - truth)      (both radii pooled)

Scores per scenario:
- effect logs: right name first (a two-effect log: both named, the first one of them), region
  located (a reported region, or the named effect's signature region, overlaps the truth
  region along the effect's axis), shrink >= 50 %; "right" needs all three;
- null logs: right when nothing is named (an unexplained gap is counted separately);
- anomalies: right when nothing is named and an unexplained region overlaps the anomaly's place.

The binary is $MAGSWARM_BIN, default target/release/magswarm of this repository.
"""
from __future__ import annotations

import argparse
import concurrent.futures as cf
import csv
import json
import os
import pathlib
import subprocess
import sys
import time

import numpy as np

REPO = pathlib.Path(__file__).resolve().parents[2]
AXIS_KEY = dict(phase_lag="f_hz", cohesion_loss="z_m_mm", formation_lag="time_since_change_s",
                particle_drift="t_s", centroid_offset="z_m_mm", camera_bias="z_m_mm")
REPORT_KEY = dict(f_hz="f_hz", z_m_mm="z_m_mm", time_since_change_s="since_change_s", t_s="t_s")
# tolerance when comparing ranges: half a grid step on z and f; a few seconds on the time axes
TOL = dict(f_hz=0.5, z_m_mm=2.5, time_since_change_s=1.0, t_s=10.0)


def binary() -> pathlib.Path:
    return pathlib.Path(os.environ.get("MAGSWARM_BIN", REPO / "target" / "release" / "magswarm"))


def overlaps(a, b, tol):
    if a is None or b is None:
        return False
    return a[0] - tol <= b[1] and b[0] - tol <= a[1]


def read_csv(path):
    with open(path) as fh:
        rows = list(csv.DictReader(fh))
    out = {}
    for k in (rows[0] if rows else []):
        try:
            out[k] = np.array([float(r[k]) for r in rows])
        except ValueError:      # a text column (`session`)
            pass
    return out


def run_one(scn: dict, logdir: pathlib.Path, outroot: pathlib.Path, extra: list[str], reuse: bool = False) -> dict:
    name = scn["name"]
    out = outroot / name
    out.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ)
    env.setdefault("RAYON_NUM_THREADS", "1")
    t0 = time.time()
    cmd = [str(binary()), "diagnose", "--log", str(logdir / f"{name}.csv"),
           "--withheld", str(logdir / f"{name}.withheld.csv"), "--out", str(out)] + extra
    if reuse and (out / "report.json").is_file():
        p = subprocess.CompletedProcess(cmd, 0, "", "")
    else:
        p = subprocess.run(cmd, capture_output=True, text=True, env=env)
    res = dict(scn=scn, elapsed=time.time() - t0, rc=p.returncode, stderr=p.stderr[-2000:])
    if p.returncode != 0:
        return res
    rep = json.loads((out / "report.json").read_text())
    res["report"] = rep
    # shrink on the withheld log against the noise-free truth
    truth = read_csv(logdir / f"{name}.truth_withheld.csv")
    preds = {}
    for m in ("baseline", "augmented"):
        pc = [str(binary()), "predict", "--model", str(out / f"{m}.json"),
              "--log", str(logdir / f"{name}.withheld.csv"), "--out", str(out / f"pred_{m}.csv")]
        q = subprocess.run(pc, capture_output=True, text=True, env=env)
        if q.returncode != 0:
            res["predict_error"] = q.stderr[-500:]
            return res
        preds[m] = read_csv(out / f"pred_{m}.csv")
    mse = {}
    for m, pr in preds.items():
        e1 = pr["r1_mm"] - truth["r1_true_mm"]
        e2 = pr["r2_mm"] - truth["r2_true_mm"]
        mse[m] = float(np.mean(np.concatenate([e1 ** 2, e2 ** 2])))
    res["mse"] = mse
    res["shrink"] = 1 - mse["augmented"] / mse["baseline"] if mse["baseline"] > 0 else None
    # the excess the true effect leaves on the baseline-truth (for reference)
    e_eff = np.concatenate([truth["r1_true_mm"] - truth["r1_base_mm"], truth["r2_true_mm"] - truth["r2_base_mm"]])
    res["effect_rms_withheld"] = float(np.sqrt(np.mean(e_eff ** 2)))
    # the excess is measurable where the baseline's error on the noise-free withheld rows is at
    # least a quarter of the visit noise (else the effect is absorbed and the ratio is noise)
    sv = float(np.sqrt(np.mean(np.square(scn.get("visit_sd_mm", [0.2, 0.3])))))
    res["baseline_excess_rms"] = float(np.sqrt(mse["baseline"]))
    res["measurable"] = res["baseline_excess_rms"] >= 0.25 * sv
    return res


def located(rep, effect, truth_region) -> bool:
    key = AXIS_KEY.get(effect)
    if key is None or truth_region is None or truth_region.get(key) is None:
        return False
    rk = REPORT_KEY[key]
    cands = [r.get(rk) for r in rep["gap"].get("regions", [])]
    for e in rep.get("effects", []):
        if e.get("name") == effect and e.get("accepted"):
            sr = e.get("signature_region")
            if isinstance(sr, dict):
                cands.append(sr.get(rk))
            elif isinstance(sr, list) and len(sr) == 2 and all(isinstance(x, (int, float)) for x in sr):
                cands.append(sr)
    # located where the effect acts or where its unabsorbed part shows (the baseline's refit
    # moves the residual of a smooth onset to where it compensates)
    truths = [truth_region[key]] + ([truth_region["unabsorbed_" + key]] if truth_region.get("unabsorbed_" + key) else [])
    return any(overlaps(c, t, TOL[key]) for c in cands if c for t in truths)


def score(res: dict) -> dict:
    scn = res["scn"]
    s = dict(name=scn["name"], kind=scn["kind"], truth=scn["truth"], effects=scn["effects"],
             protocol=scn["protocol"], strength=scn["strength"], shapes=scn["shapes"])
    if "report" not in res:
        s.update(outcome="error", named=[], detail=res.get("stderr", "")[-300:] + res.get("predict_error", ""))
        return s
    rep = res["report"]
    named = list(rep.get("accepted") or [])
    unexp = rep.get("unexplained") or []
    s.update(named=named, unexplained=len(unexp), gap_p=rep["gap"].get("p_value"),
             shrink=res.get("shrink"), report_excess=(rep.get("excess_removed") or {}).get("both"),
             elapsed=res["elapsed"])
    cands = sorted((e for e in rep.get("effects", [])),
                   key=lambda e: -(e.get("heldout_loglik_gain") or 0))
    s["candidates"] = "; ".join(
        f"{e['name']}{'*' if e.get('accepted') else ''} gain {e.get('heldout_loglik_gain', 0):.0f} "
        f"p {e.get('p_value') if e.get('p_value') is None else format(e.get('p_value'), '.2g')}"
        for e in cands[:3])
    if scn["truth"] == "null":
        s["outcome"] = "right" if not named else "wrong"
        s["name_ok"] = not named
        s["gap_claimed"] = bool(rep["gap"].get("significant"))
        return s
    if scn["truth"] == "anomaly":
        reg = scn["regions"][0]
        at_place = any(overlaps(u.get("region", u).get("z_m_mm"), reg["z_m_mm"], 2.5)
                       and overlaps(u.get("region", u).get("f_hz"), reg["f_hz"], 0.5) for u in unexp)
        s["at_place"] = at_place
        if named:
            s["outcome"] = "wrong"
        elif unexp:
            s["outcome"] = "right" if at_place else "unexplained_elsewhere"
        else:
            s["outcome"] = "nothing"
        s["name_ok"] = s["outcome"] == "right"
        return s
    truth = scn["effects"]
    if scn.get("absorbed"):
        # (gen_other_lab.py) the baseline's refit imitates the effect to within a visit SD: right
        # when nothing else is named
        s["name_ok"] = set(named) <= set(truth)
        s["outcome"] = "right" if s["name_ok"] else "wrong"
        s["measurable"] = res.get("measurable")
        return s
    if not named:
        s["outcome"] = "unexplained" if unexp else "nothing"
        s["name_ok"] = False
    else:
        s["name_ok"] = named[0] in truth and set(truth) <= set(named)
        s["outcome"] = "right_name" if s["name_ok"] else "wrong"
    s["region_ok"] = all(located(rep, e, r) for e, r in zip(truth, scn["regions"])) if s["name_ok"] else False
    sh = res.get("shrink")
    s["measurable"] = res.get("measurable")
    # where the baseline leaves no measurable excess on the withheld log, there is nothing to remove
    s["shrink_ok"] = (sh is not None and sh >= 0.5) or res.get("measurable") is False
    if s["name_ok"] and s["region_ok"] and s["shrink_ok"]:
        s["outcome"] = "right"
    return s


def table(scores):
    kinds = sorted({s["kind"] for s in scores})
    cols = ["right", "right_name", "wrong", "nothing", "unexplained", "unexplained_elsewhere", "error"]
    lines = ["| kind | n | right name | region | shrink >= 50 % | fully right | wrong | nothing | unexplained | error | median shrink |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    tot = dict(n=0, name=0, region=0, shrink=0, right=0, wrong=0, nothing=0, unexp=0, error=0)
    for k in kinds:
        ss = [s for s in scores if s["kind"] == k]
        n = len(ss)
        name = sum(1 for s in ss if s.get("name_ok"))
        eff = ss[0]["truth"] == "effect"
        region = sum(1 for s in ss if s.get("region_ok")) if eff else None
        shrink = sum(1 for s in ss if s.get("shrink_ok") and s.get("name_ok")) if eff else None
        right = sum(1 for s in ss if s["outcome"] == "right")
        wrong = sum(1 for s in ss if s["outcome"] == "wrong")
        nothing = sum(1 for s in ss if s["outcome"] == "nothing")
        unexp = sum(1 for s in ss if s["outcome"] in ("unexplained", "unexplained_elsewhere"))
        err = sum(1 for s in ss if s["outcome"] == "error")
        shr = [s["shrink"] for s in ss if eff and s.get("shrink") is not None and s.get("measurable")]
        med = f"{100 * np.median(shr):.0f} %" if shr else "-"
        fmt = lambda v: "-" if v is None else str(v)
        lines.append(f"| {k} | {n} | {name} | {fmt(region)} | {fmt(shrink)} | {right} | {wrong} | {nothing} | {unexp} | {err} | {med} |")
        for key, v in (("n", n), ("name", name), ("region", region or 0), ("shrink", shrink or 0), ("right", right),
                       ("wrong", wrong), ("nothing", nothing), ("unexp", unexp), ("error", err)):
            tot[key] += v
    lines.append(f"| **total** | {tot['n']} | {tot['name']} | {tot['region']} | {tot['shrink']} | {tot['right']} | "
                 f"{tot['wrong']} | {tot['nothing']} | {tot['unexp']} | {tot['error']} | |")
    return "\n".join(lines)


def summary(scores):
    eff = [s for s in scores if s["truth"] == "effect"]
    nul = [s for s in scores if s["truth"] == "null"]
    ano = [s for s in scores if s["truth"] == "anomaly"]
    pct = lambda a, b: f"{a} / {b} ({100 * a / b:.0f} %)" if b else "-"
    shr = sorted(s["shrink"] for s in eff if s.get("name_ok") and s.get("measurable") and s.get("shrink") is not None)
    q = lambda p: f"{100 * shr[min(len(shr) - 1, int(p * len(shr)))]:.0f} %" if shr else "-"
    # the written model against the report's own figure
    worse = [s["name"] for s in eff if s.get("named") and s.get("shrink") is not None and s.get("report_excess") is not None
             and s["shrink"] < s["report_excess"] - 0.3]
    rows = [
        ("effect logs: right name first (both, in two-effect logs)", pct(sum(1 for s in eff if s.get("name_ok")), len(eff))),
        ("effect logs: fully right (name, region, >= 50 % of the withheld excess removed)", pct(sum(1 for s in eff if s["outcome"] == "right"), len(eff))),
        ("effect logs: a wrong name first / nothing named", f"{sum(1 for s in eff if s['outcome'] == 'wrong')} / {sum(1 for s in eff if s['outcome'] in ('nothing', 'unexplained'))}"),
        ("null logs with a name (false claims)", pct(sum(1 for s in nul if s.get("named")), len(nul))),
        ("anomalies reported unexplained at their place", pct(sum(1 for s in ano if s["outcome"] == "right"), len(ano))),
        ("shrink of right names (10 % / 25 % / median / 75 % / 90 %)", " / ".join(q(p) for p in (0.1, 0.25, 0.5, 0.75, 0.9))),
        ("named logs whose augmented.json (in predict) removes > 30 points less than the report's excess_removed", f"{len(worse)}: {', '.join(worse) or '-'}"),
    ]
    for proto in sorted({s["protocol"] for s in eff}):
        ps = [s for s in eff if s["protocol"] == proto]
        rows.append((f"effect logs on protocol `{proto}`: right name / fully right",
                     f"{sum(1 for s in ps if s.get('name_ok'))} / {sum(1 for s in ps if s['outcome'] == 'right')} of {len(ps)}"))
    return "| measure | value |\n|---|---|\n" + "\n".join(f"| {a} | {b} |" for a, b in rows)


def detail(scores):
    lines = ["| scenario | protocol | strength | named | unexpl. | gap p | shrink | outcome | top candidates (gain, p) |",
             "|---|---|---|---|---|---|---|---|---|"]
    for s in scores:
        sh = s.get("shrink")
        gp = s.get("gap_p")
        lines.append(f"| {s['name']} | {s['protocol']} | {s['strength']} | {', '.join(s.get('named', [])) or '-'} | "
                     f"{s.get('unexplained', '-')} | {'-' if gp is None else format(gp, '.2g')} | "
                     f"{'-' if sh is None else f'{100 * sh:.0f} %'}{'' if s.get('measurable', True) else ' (n/m)'} | {s['outcome']} | {s.get('candidates', s.get('detail', ''))} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description="score magswarm diagnose on gen_blind.py logs")
    ap.add_argument("dirs", nargs="+", type=pathlib.Path, help="directories written by gen_blind.py")
    ap.add_argument("--jobs", type=int, default=2, help="parallel diagnoses (at most 2 on this machine)")
    ap.add_argument("--out", type=pathlib.Path, default=None, help="where diagnose writes (default DIR/diag)")
    ap.add_argument("--md", type=pathlib.Path, default=None, help="write the tables to this markdown file")
    ap.add_argument("--json", type=pathlib.Path, default=None, help="write per-scenario scores as JSON")
    ap.add_argument("--only", default=None, help="comma-separated kinds")
    ap.add_argument("--reuse", action="store_true", help="score existing report.json files again (no diagnose run)")
    ap.add_argument("--diagnose-args", default="", help="extra arguments for diagnose, e.g. '--seed 2'")
    args = ap.parse_args(argv)
    if not binary().is_file():
        sys.exit(f"score.py: {binary()} not found: cargo build --release (or set MAGSWARM_BIN)")
    jobs = []
    for d in args.dirs:
        truth = json.loads((d / "truth.json").read_text())
        for scn in truth["scenarios"]:
            if args.only and scn["kind"] not in args.only.split(","):
                continue
            jobs.append((scn, d, (args.out or d / "diag")))
    t0 = time.time()
    scores = []
    with cf.ThreadPoolExecutor(max_workers=max(1, min(args.jobs, 2))) as ex:
        futs = {ex.submit(run_one, scn, d, o, args.diagnose_args.split(), args.reuse): scn for scn, d, o in jobs}
        for f in cf.as_completed(futs):
            s = score(f.result())
            scores.append(s)
            print(f"{s['name']}: {s['outcome']} named={s.get('named')} shrink={s.get('shrink')}", flush=True)
    scores.sort(key=lambda s: s["name"])
    wall = time.time() - t0
    text = (f"{len(scores)} logs from {', '.join(str(d) for d in args.dirs)}, diagnosed in {wall:.0f} s wall "
            f"({args.jobs} at a time).\n\n" + table(scores) + "\n\n" + summary(scores) + "\n\nPer scenario:\n\n" + detail(scores) + "\n")
    print("\n" + table(scores) + "\n\n" + summary(scores))
    if args.md:
        args.md.write_text(text)
    if args.json:
        args.json.write_text(json.dumps(scores, indent=1, default=str))


if __name__ == "__main__":
    main()
