"""Logs of another lab from the third independent generator (scripts/blind/gen_other_lab.py,
written from the seed paper alone: its own turn-averaged field, formation law, AR(1) rows,
outliers, `valid` and `session` columns and protocols), diagnosed by the release binary and
scored like the blind check (docs/diagnose.md):

- far-apart setpoint steps at operating points off any grid, recorded in two sessions, with a
  swarm whose rotation reverses past f_off: once refused ("too few visits to estimate the
  visit-to-visit noise"), now diagnosed: phase_lag named first and at least half of the
  withheld excess removed by augmented.json in `magswarm predict`;
- a Latin hypercube of operating points without any effect: nothing named;
- the same design with a slow loss of particles: particle_drift named first, half of the
  withheld excess removed;
- the seed's grid with rows 0.6-32 s after each change, a particle drift and a formation
  effect together: the drift, significant over session time while no stretch of the session
  stands out on its own, was once declared a gap and then left without a region, a candidate
  table or a name; now the session is its region and particle_drift is named;
- chains of r2 that break where a Mason number (f / B^2) passes 1, on a 6 x 8 grid, and the
  same beside two sticking events of particles on a Latin hypercube: an onset that moves with
  f, which no shape over z_m alone follows, once reported unexplained (and, beside the drift,
  lost); now `cohesion_loss` is named along the Mason number's axis (both effects in the pair)
  and at least half of the withheld excess is removed;
- the seed's grid once from a camera whose successive rows are correlated (AR(1)), without any
  effect: the gap tests once read the correlated rows as a transient within the visits
  (p ~ 2e-6); now the correlation is estimated and simulated, and no gap is declared;
- a formation whose radii cannot change faster than a set rate, on streamed steps: plain
  within the visits (p ~ 1e-12) but once lost in the wide null of the shapes that move the
  visits' means and reported unexplained; now `formation_lag` is named;
- an underdamped formation and one slower to grow than to shrink, on streamed steps: the
  within-visit tests once let the visits' offsets into their nulls (no gap, or unexplained);
  now `formation_lag` is named on both, and streamed steps without effect show no gap.

Needs target/release/magswarm (`cargo build --release`); skips without it, fails under CI.
"""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

from conftest import BLIND, blind_script, diagnose_scored, magswarm_exe_or_skip


def _diagnosed(tmp_path_factory, tag, runs, keep=lambda scn: True):
    """Generate each (seed, kinds) with gen_other_lab.py, diagnose every scenario `keep`
    accepts with the release binary and score it: {kind: (scenario, run result, score)}."""
    magswarm_exe_or_skip()
    score = blind_script("score")
    results = {}
    for seed, kinds in runs:
        out = tmp_path_factory.mktemp(f"{tag}{seed}")
        subprocess.run([sys.executable, str(BLIND / "gen_other_lab.py"), "--seed", str(seed),
                        "--only", kinds, "--out", str(out)], check=True, capture_output=True)
        for scn in json.loads((out / "truth.json").read_text())["scenarios"]:
            if keep(scn):
                results[scn["kind"]] = diagnose_scored(score, scn, out)
    return results


def _named_first_and_half_removed(entry, effect):
    """The effect named first, and at least half of the withheld excess removed."""
    scn, res, s = entry
    assert s["named"][:1] == [effect], f"{scn['name']}: named {s['named']}; {s['candidates']}"
    assert res["shrink"] >= 0.5, f"{scn['name']}: {100 * res['shrink']:.0f} % of the withheld excess removed"


@pytest.fixture(scope="module")
def other(tmp_path_factory):
    return _diagnosed(tmp_path_factory, "other",
                      ((103, "phase_reversal"), (101, "null,drift_slow_loss"), (202, "pair_formation_drift")),
                      keep=lambda scn: scn["protocol"] in ("steps", "lhs", "grid_spread"))


def test_steps_off_the_grid_in_two_sessions_name_the_phase_lag(other):
    _named_first_and_half_removed(other["phase_reversal"], "phase_lag")


def test_a_latin_hypercube_without_effect_names_nothing(other):
    scn, res, s = other["null"]
    assert s["named"] == [], f"{scn['name']}: named {s['named']}"


def test_a_slow_loss_on_a_latin_hypercube_is_a_drift(other):
    _named_first_and_half_removed(other["drift_slow_loss"], "particle_drift")


def test_a_significant_drift_without_a_standout_stretch_is_weighed_and_named(other):
    scn, res, s = other["pair_formation_drift"]
    assert res["report"]["gap"]["significant"], f"{scn['name']}: no gap declared"
    assert s["candidates"], f"{scn['name']}: a gap declared and no candidate weighed"
    assert "particle_drift" in s["named"], f"{scn['name']}: named {s['named']}; {s['candidates']}"


# Change 13 (docs/diagnose.md): the gap tests' min-p now reads every simulated log's p-values as
# the real log's are, and holds the level set (on 100 null grids a gap on 1, before on 6). These
# logs' gaps (o408_07; for o410_18 the gap left once its drift is named) rested on a statistic
# just beyond every simulation of one of some 50 alternatives (combined p 2e-3 before, 0.028
# now): at alpha = 0.01 that is no longer a gap, and the effect is not reached. Change 14's
# joint gate (the candidates judged with the tests) won back the rate-limited formation
# (o402_08) but not these: the hysteresis's own candidate reads p 0.008 before the choice is
# paid (0.034 after), and a second name is judged by the tests alone. Kept as expected
# failures, so that they show when power is won back honestly.
LEVEL_HELD = pytest.mark.xfail(strict=True, reason="gap p 0.028-0.034 once the min-p holds its level (Change 13)")


@pytest.fixture(scope="module")
def mason(tmp_path_factory):
    return _diagnosed(tmp_path_factory, "mason", ((408, "cohesion_mason"), (410, "pair_drift_cohesion")))


def test_chains_breaking_past_a_mason_number_are_a_cohesion_loss(mason):
    _named_first_and_half_removed(mason["cohesion_mason"], "cohesion_loss")


@LEVEL_HELD
def test_a_mason_loosening_beside_a_drift_is_named_with_it(mason):
    scn, res, s = mason["pair_drift_cohesion"]
    assert set(s["named"][:2]) == {"particle_drift", "cohesion_loss"}, \
        f"{scn['name']}: named {s['named']}; {s['candidates']}"
    assert res["shrink"] >= 0.5, f"{scn['name']}: {100 * res['shrink']:.0f} % of the withheld excess removed"


@pytest.fixture(scope="module")
def rows(tmp_path_factory):
    return _diagnosed(tmp_path_factory, "rows", ((408, "null"), (402, "formation_rate_limit")),
                      keep=lambda scn: scn["kind"] != "null" or scn["protocol"] == "grid1x10")


def test_rows_that_follow_each_other_are_not_a_gap(rows):
    # The seed's grid once, 10 rows a visit from a camera whose rows are AR(1): the gap tests
    # once saw the correlated rows as a transient within the visits (p ~ 2e-6).
    scn, res, s = rows["null"]
    assert not res["report"]["gap"]["significant"], \
        f"{scn['name']}: gap declared (p = {res['report']['gap']['p_value']:.2e})"
    assert s["named"] == [], f"{scn['name']}: named {s['named']}"
    assert max(res["report"]["gap"]["noise"]["row_lag1_correlation"].values()) > 0.2


def test_a_rate_limited_formation_on_streamed_steps_is_named(rows):
    # Plain within the visits (p ~ 1e-12), once lost in the null of the shapes that move the
    # visits' means: reported unexplained. Then (Change 13) the gap tests' smallest p, paid over
    # some 50 alternatives, came to 0.014, and the candidate was never reached. Since Change 14
    # the candidates are judged with the tests in one min-p: formation_lag's own evidence
    # opens the gate, and the report says so.
    scn, res, s = rows["formation_rate_limit"]
    assert s["named"][:1] == ["formation_lag"], f"{scn['name']}: named {s['named']}; {s['candidates']}"
    gap = res["report"]["gap"]
    assert gap["significant"] and gap["p_value"] <= gap["alpha"], gap["p_value"]
    if gap["tests_p_value"] > gap["alpha"]:
        assert (gap["opened_by"] or {}).get("effect") == "formation_lag", gap["opened_by"]


@pytest.fixture(scope="module")
def transients(tmp_path_factory):
    return _diagnosed(tmp_path_factory, "transients",
                      ((410, "formation_underdamped_z"), (408, "null,formation_hysteresis")),
                      keep=lambda scn: scn["protocol"] == "steps")


def test_an_underdamped_formation_on_streamed_steps_is_named(transients):
    # Overshoots of 4-8 row SDs within the visits, beside visit offsets 3-4 times the row
    # noise: the within-visit test once refitted the baseline's own columns with the shape,
    # which let the visits' offsets into its null (p ~ 0.15), and formation_lag was weighed
    # the same way (gain 47, p 0.02): reported unexplained.
    scn, res, s = transients["formation_underdamped_z"]
    assert res["report"]["gap"]["significant"], f"{scn['name']}: no gap declared"
    assert s["named"][:1] == ["formation_lag"], f"{scn['name']}: named {s['named']}; {s['candidates']}"


@LEVEL_HELD
def test_a_formation_slower_to_grow_than_to_shrink_is_named(transients):
    # Once the baseline's time scale has taken the average approach, what is left is a lag
    # after the changes that make a radius grow and a lead after those that shrink it, which
    # a shape over every change cancels: once "no significant gap" (p = 0.36).
    scn, res, s = transients["formation_hysteresis"]
    assert s["named"][:1] == ["formation_lag"], f"{scn['name']}: named {s['named']}; {s['candidates']}"


def test_streamed_steps_without_effect_name_nothing(transients):
    scn, res, s = transients["null"]
    assert not res["report"]["gap"]["significant"], \
        f"{scn['name']}: gap declared (p = {res['report']['gap']['p_value']:.2e})"
    assert s["named"] == [], f"{scn['name']}: named {s['named']}"


@pytest.fixture(scope="module")
def pairs(tmp_path_factory):
    return {seed: _diagnosed(tmp_path_factory, "pairs", ((seed, "pair_formation_drift"),))
            for seed in (410, 415)}


@pytest.mark.parametrize("seed", [
    # Seed 410, a hysteresis between far-apart steps (a growing radius slower than a shrinking
    # one) beside a slow loss, is a known loss, kept here so that it shows when it is won
    # back: on streamed steps the changes that make a radius grow mostly go deeper, so the gap
    # tests' nuisance for a rig whose own approach slows with depth (docs/diagnose.md, "Change
    # 12") also takes most of this hysteresis (formation tests p 4e-3 ... 1e-2, no longer
    # significant as a family). Taking it out of that nuisance gives back the false
    # `formation_lag` on five of six null logs of the second generator's streamed steps
    # (tests/python/test_blind_check.py), and a false name is worse than a missed second one.
    pytest.param(410, marks=pytest.mark.xfail(strict=True, reason="hysteresis confounded with "
                                              "an approach slowing with depth (Change 12)")),
    415,
])
def test_a_formation_beside_a_drift_is_named_with_it(pairs, seed):
    # Seed 410: a hysteresis between far-apart steps beside a slow loss; seed 415: a rate
    # limit on a spread grid beside two sticking events. Once the drift is named, the
    # formation is plain within the visits (p 1e-8 and 1e-48), but its gain was counted in
    # units of a row's whole noise (visit offset included) rather than of its noise about the
    # visit's mean, and at 1.9 and 1.4 it fell below the 2 units that name an effect.
    scn, res, s = pairs[seed]["pair_formation_drift"]
    assert sorted(s["named"][:2]) == ["formation_lag", "particle_drift"], \
        f"{scn['name']}: named {s['named']}; {s['candidates']}"
