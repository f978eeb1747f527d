//! The independent benchmark of `magswarm diagnose` (crates/magswarm-scenarios): every
//! scenario's training log diagnosed with its withheld log, scored against its truth, on the
//! tuning set and on the held-out set.
//!
//! ```sh
//! cargo run --release --example diagnose_benchmark -- [--set tuning|heldout|both] [--subset N] [--only CATEGORY] [--ids I,J] [--seed S] [--out DIR] [--reports DIR] [--write-docs]
//! ```
//!
//! Verdicts (tests/common/bench_score.rs): **right** (the true effect named first, both in a
//! two-effect log; a reported region overlaps where it acts; at least half of the withheld
//! log's excess over the true noise floor removed; null logs: nothing named; camera biases:
//! nothing else named; anomalies: nothing named and an unexplained region at the anomaly),
//! **right name** (named right, region or shrink short), **wrong** (another effect named
//! first), **nothing**, **unexplained** (nothing named, the gap reported unexplained).
//! Strengths are the ones each scenario reached (the part the baseline cannot absorb, in visit
//! noise SDs). Writes DIR/results.csv, DIR/summary.md, DIR/shrink.png; with `--write-docs` the
//! summary replaces the benchmark section of docs/diagnose.md.

use magswarm::diagnose::{self, Config};

#[path = "../tests/common/bench_score.rs"]
mod bench_score;
use bench_score::{score, withheld_shrink};
use magswarm::log::Log;
use magswarm::model::Model;
use magswarm::plot::{self, Labels, Series};
use magswarm_scenarios::{heldout, scenarios, Scenario, Set};
use rayon::prelude::*;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

struct Outcome {
    sc: Scenario,
    /// Smallest strength the scenario's truths reached.
    strength: f64,
    verdict: &'static str,
    named: Vec<String>,
    unexplained: usize,
    p: f64,
    /// Share of the withheld log's excess over the true floor removed.
    shrink: Option<f64>,
    /// Diagnose's own figure: by cross-validation, against its estimated floor.
    shrink_cv: Option<f64>,
    secs: f64,
}

fn run(sc: &Scenario, cfg: &Config, reports: Option<&std::path::Path>) -> Outcome {
    let t0 = Instant::now();
    let re = sc.realise();
    let strength = re.strengths.iter().copied().fold(f64::INFINITY, f64::min);
    let strength = if strength.is_finite() { strength } else { 0.0 };
    let log = Log::from_str_named(&re.train, &format!("scenario{}.csv", sc.id)).expect("valid log");
    let w = Log::from_str_named(&re.withheld, &format!("scenario{}-withheld.csv", sc.id))
        .expect("valid log");
    match diagnose::diagnose(&log, Some(&w), &Model::paper(), cfg) {
        Ok(d) => {
            if let Some(dir) = reports {
                let dir = dir.join(format!("{}-{}", sc.set.name(), sc.id));
                let _ = std::fs::create_dir_all(&dir);
                let _ = std::fs::write(dir.join("train.csv"), &re.train);
                let _ = std::fs::write(dir.join("withheld.csv"), &re.withheld);
                let truth: String = re
                    .withheld_truth
                    .iter()
                    .map(|r| format!("{},{}\n", r[0], r[1]))
                    .collect();
                let _ = std::fs::write(
                    dir.join("withheld_truth.csv"),
                    format!("r1_mm,r2_mm\n{truth}"),
                );
                if let Err(e) = diagnose::report::write(&d, &dir) {
                    eprintln!("scenario {}: report: {e:#}", sc.id);
                }
            }
            Outcome {
                sc: sc.clone(),
                strength,
                verdict: score(sc, &re, &d),
                named: d.attr.accepted.clone(),
                unexplained: d.unexplained.len(),
                p: d.tests.p_value,
                shrink: withheld_shrink(&re, &d),
                shrink_cv: d.excess_removed()[2],
                secs: t0.elapsed().as_secs_f64(),
            }
        }
        Err(e) => {
            eprintln!("scenario {} ({}): {e:#}", sc.id, sc.set.name());
            Outcome {
                sc: sc.clone(),
                strength,
                verdict: "error",
                named: Vec::new(),
                unexplained: 0,
                p: f64::NAN,
                shrink: None,
                shrink_cv: None,
                secs: t0.elapsed().as_secs_f64(),
            }
        }
    }
}

fn category(sc: &Scenario) -> String {
    let e = sc.expected();
    match e.len() {
        0 => "null".into(),
        1 => e[0].into(),
        _ => "two effects".into(),
    }
}

const VERDICTS: [&str; 6] = [
    "right",
    "right name",
    "wrong",
    "nothing",
    "unexplained",
    "error",
];
const CATS: [&str; 9] = [
    "phase_lag",
    "cohesion_loss",
    "formation_lag",
    "particle_drift",
    "centroid_offset",
    "two effects",
    "anomaly",
    "camera_bias",
    "null",
];

fn is_effect(o: &Outcome) -> bool {
    let e = o.sc.expected();
    !e.is_empty() && !e.contains(&"anomaly") && !e.contains(&"camera_bias")
}

fn named_right(o: &Outcome) -> bool {
    o.verdict == "right" || o.verdict == "right name"
}

/// The confusion matrix, the rates and the shrink distribution of one set's outcomes.
fn summary(md: &mut String, outcomes: &[&Outcome], alpha: f64) {
    let _ = writeln!(
        md,
        "| truth | {} | total | right name at >= 2x |",
        VERDICTS.join(" | ")
    );
    let _ = writeln!(md, "|---{}|---|---|", "|---".repeat(VERDICTS.len()));
    for c in CATS {
        let row: Vec<&&Outcome> = outcomes.iter().filter(|o| category(&o.sc) == c).collect();
        if row.is_empty() {
            continue;
        }
        let counts: Vec<String> = VERDICTS
            .iter()
            .map(|v| row.iter().filter(|o| o.verdict == *v).count().to_string())
            .collect();
        let strong: Vec<&&&Outcome> = row.iter().filter(|o| o.strength >= 2.0).collect();
        let s = if is_effect(row[0]) {
            format!(
                "{} / {}",
                strong.iter().filter(|o| named_right(o)).count(),
                strong.len()
            )
        } else {
            "-".into()
        };
        let _ = writeln!(md, "| {c} | {} | {} | {s} |", counts.join(" | "), row.len());
    }
    let share = |f: &dyn Fn(&Outcome) -> bool, g: &dyn Fn(&Outcome) -> bool| -> (usize, usize) {
        let sel: Vec<&&Outcome> = outcomes.iter().filter(|o| f(o)).collect();
        (sel.iter().filter(|o| g(o)).count(), sel.len())
    };
    let pct =
        |(a, b): (usize, usize)| format!("{a} / {b} ({:.0} %)", 100.0 * a as f64 / b.max(1) as f64);
    let strong = |o: &Outcome| is_effect(o) && o.strength >= 2.0;
    let _ = writeln!(md, "\n| measure | value |\n|---|---|");
    let rows: [(&str, (usize, usize)); 7] = [
        (
            "right name at strength >= 2x the visit noise",
            share(&strong, &named_right),
        ),
        (
            "fully right (name, region, >= 50 % of the withheld log's excess removed) at strength >= 2x",
            share(&strong, &|o| o.verdict == "right"),
        ),
        (
            "right name at strength 1-2x",
            share(&|o| is_effect(o) && o.strength >= 1.0 && o.strength < 2.0, &named_right),
        ),
        (
            "a wrong name first at strength < 1x (what the baseline absorbs)",
            share(&|o| is_effect(o) && o.strength < 1.0, &|o| o.verdict == "wrong"),
        ),
        (
            "null logs with a name (false claims)",
            share(&|o| o.sc.truths.is_empty(), &|o| !o.named.is_empty()),
        ),
        (
            "anomalies reported unexplained at their place",
            share(&|o| o.sc.expected() == ["anomaly"], &|o| o.verdict == "right"),
        ),
        (
            "camera biases the baseline absorbs with nothing else named",
            share(&|o| o.sc.expected().contains(&"camera_bias"), &|o| o.verdict == "right"),
        ),
    ];
    for (name, v) in rows {
        let _ = writeln!(md, "| {name} | {} |", pct(v));
    }
    let _ = writeln!(md, "\nalpha = {alpha}.");
    let sh = shrinks(outcomes);
    let q = |p: f64| {
        sh.get(((sh.len().max(1) - 1) as f64 * p).round() as usize)
            .copied()
            .unwrap_or(f64::NAN)
    };
    let _ = writeln!(
        md,
        "Share of the withheld log's excess over the true floor removed (effect logs with a right name and a measurable excess, {} logs): 10 % {:.0} %, 25 % {:.0} %, median {:.0} %, 75 % {:.0} %, 90 % {:.0} %.\n",
        sh.len(),
        q(0.1),
        q(0.25),
        q(0.5),
        q(0.75),
        q(0.9)
    );
}

fn shrinks(outcomes: &[&Outcome]) -> Vec<f64> {
    let mut sh: Vec<f64> = outcomes
        .iter()
        .filter(|o| is_effect(o) && named_right(o))
        .filter_map(|o| o.shrink)
        .map(|s| 100.0 * s)
        .collect();
    sh.sort_by(|x, y| x.total_cmp(y));
    sh
}

fn histogram(sh: &[f64]) -> Vec<(f64, f64)> {
    let mut hist = [0usize; 12];
    for s in sh {
        let b = ((s.clamp(-10.0, 109.0) + 10.0) / 10.0) as usize;
        hist[b.min(11)] += 1;
    }
    let mut pts = Vec::new();
    for (b, c) in hist.iter().enumerate() {
        let x0 = -10.0 + 10.0 * b as f64;
        pts.push((x0, 0.0));
        pts.push((x0, *c as f64));
        pts.push((x0 + 10.0, *c as f64));
        pts.push((x0 + 10.0, 0.0));
    }
    pts
}

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let (mut subset, mut seed, mut out, mut docs) = (
        None,
        1u64,
        PathBuf::from("target/diagnose-benchmark"),
        false,
    );
    let mut only: Option<String> = None;
    let mut which = "both".to_string();
    let mut ids: Option<Vec<usize>> = None;
    let mut reports: Option<PathBuf> = None;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--subset" => subset = Some(args.next().unwrap_or_default().parse::<usize>()?),
            "--seed" => seed = args.next().unwrap_or_default().parse()?,
            "--out" => out = PathBuf::from(args.next().unwrap_or_default()),
            "--write-docs" => docs = true,
            "--only" => only = args.next(),
            "--set" => which = args.next().unwrap_or_default(),
            "--ids" => {
                ids = Some(
                    args.next()
                        .unwrap_or_default()
                        .split(',')
                        .map(|x| x.trim().parse::<usize>())
                        .collect::<Result<_, _>>()?,
                )
            }
            "--reports" => reports = args.next().map(PathBuf::from),
            other => anyhow::bail!("unknown argument {other:?} (--set tuning|heldout|both, --subset N, --only CATEGORY, --ids I,J, --seed S, --out DIR, --reports DIR, --write-docs)"),
        }
    }
    let mut all = match which.as_str() {
        "tuning" => scenarios(seed),
        "heldout" => heldout(seed),
        "both" => {
            let mut v = scenarios(seed);
            v.extend(heldout(seed));
            v
        }
        o => anyhow::bail!("--set {o}: expected tuning, heldout or both"),
    };
    if docs && (which != "both" || subset.is_some() || only.is_some() || ids.is_some()) {
        anyhow::bail!("--write-docs needs the whole benchmark (--set both, no --subset or --only)");
    }
    std::fs::create_dir_all(&out)?;
    if let Some(c) = &only {
        all.retain(|s| &category(s) == c);
    }
    if let Some(ids) = &ids {
        all.retain(|s| ids.contains(&s.id));
    }
    if let Some(n) = subset {
        let step = (all.len() / n.max(1)).max(1);
        all = all.into_iter().step_by(step).take(n).collect();
    }
    let cfg = Config::default();
    let t0 = Instant::now();
    let pb = indicatif::ProgressBar::new(all.len() as u64);
    let outcomes: Vec<Outcome> = all
        .par_iter()
        .map(|sc| {
            let o = run(sc, &cfg, reports.as_deref());
            pb.inc(1);
            o
        })
        .collect();
    pb.finish_and_clear();
    let wall = t0.elapsed().as_secs_f64();
    let mut csv = String::from("set,id,category,truth,protocol,strength_asked,strength_reached,verdict,named,unexplained,p_value,withheld_excess_removed,cv_excess_removed,seconds\n");
    for o in &outcomes {
        let f = |s: Option<f64>| s.map(|s| format!("{s:.3}")).unwrap_or_default();
        let _ = writeln!(
            csv,
            "{},{},{},\"{}\",{},{},{:.2},{},\"{}\",{},{:.3e},{},{},{:.2}",
            o.sc.set.name(),
            o.sc.id,
            category(&o.sc),
            o.sc.describe(),
            o.sc.protocol.name(),
            o.sc.truths.first().map(|t| t.strength).unwrap_or(0.0),
            o.strength,
            o.verdict,
            o.named.join(" "),
            o.unexplained,
            o.p,
            f(o.shrink),
            f(o.shrink_cv),
            o.secs
        );
    }
    std::fs::write(out.join("results.csv"), csv)?;
    let mut md = String::new();
    let _ = writeln!(
        md,
        "{} scenarios (seed {seed}), diagnosed in {:.0} s wall on this machine ({:.2} s per diagnosis on average, {} threads).\n",
        outcomes.len(),
        wall,
        outcomes.iter().map(|o| o.secs).sum::<f64>() / outcomes.len().max(1) as f64,
        rayon::current_num_threads()
    );
    let mut series = Vec::new();
    for set in [Set::Tuning, Set::HeldOut] {
        let part: Vec<&Outcome> = outcomes.iter().filter(|o| o.sc.set == set).collect();
        if part.is_empty() {
            continue;
        }
        let _ = writeln!(md, "**{} set** ({} scenarios):\n", set.name(), part.len());
        summary(&mut md, &part, cfg.alpha);
        let sh = shrinks(&part);
        if !sh.is_empty() {
            series.push(Series::line(format!("{} set", set.name()), histogram(&sh)));
        }
    }
    if !series.is_empty() {
        plot::lines(
            &out.join("shrink.png"),
            &Labels {
                title: "diagnose benchmark: withheld log's excess removed",
                x: "share of the withheld log's excess over the true floor removed [%]",
                y: "scenarios [-]",
            },
            &series,
        )?;
        let _ = writeln!(md, "![Distribution of the share of the withheld excess removed](diagnose-benchmark-shrink.png)\n");
    }
    let _ = writeln!(md, "Per-scenario results: `cargo run --release --example diagnose_benchmark -- --out DIR` writes DIR/results.csv.");
    std::fs::write(out.join("summary.md"), &md)?;
    print!("{md}");
    if docs {
        let path = PathBuf::from("docs/diagnose.md");
        let text = std::fs::read_to_string(&path)?;
        let (a, b) = (
            text.find("<!-- benchmark:start -->")
                .ok_or_else(|| anyhow::anyhow!("no benchmark:start marker in docs/diagnose.md"))?,
            text.find("<!-- benchmark:end -->")
                .ok_or_else(|| anyhow::anyhow!("no benchmark:end marker in docs/diagnose.md"))?,
        );
        let new = format!("{}<!-- benchmark:start -->\n{md}{}", &text[..a], &text[b..]);
        std::fs::write(&path, new)?;
        if out.join("shrink.png").exists() {
            std::fs::copy(out.join("shrink.png"), "docs/diagnose-benchmark-shrink.png")?;
        }
        eprintln!("docs/diagnose.md: benchmark section rewritten");
    }
    Ok(())
}
