//! The independent benchmark of `magswarm diagnose` (crates/magswarm-scenarios): every
//! scenario's training log diagnosed with its withheld log, scored against its truth.
//!
//! ```sh
//! cargo run --release --example diagnose_benchmark -- [--subset N] [--only CATEGORY] [--seed S] [--out DIR] [--write-docs]
//! ```
//!
//! Verdicts: **right** (the true effect named first, both in a two-effect log; a reported
//! region overlaps where it acts; at least half of the withheld excess over the floor removed;
//! null and camera logs: nothing named; anomalies: nothing named and an unexplained region at
//! the anomaly), **right name** (named right, region or shrink short), **wrong** (another
//! effect named first), **nothing** (nothing named, nothing unexplained), **unexplained**
//! (nothing named, the gap reported unexplained). Writes DIR/results.csv, DIR/summary.md,
//! DIR/shrink.png; with `--write-docs` the summary replaces the benchmark section of
//! docs/diagnose.md.

use magswarm::diagnose::{self, Config};

#[path = "../tests/common/bench_score.rs"]
mod bench_score;
use bench_score::score;
use magswarm::log::Log;
use magswarm::model::Model;
use magswarm::plot::{self, Labels, Series};
use magswarm_scenarios::{scenarios, Scenario};
use rayon::prelude::*;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

struct Outcome {
    sc: Scenario,
    verdict: &'static str,
    named: Vec<String>,
    unexplained: usize,
    p: f64,
    shrink: Option<f64>,
    secs: f64,
}

fn run(sc: &Scenario, cfg: &Config) -> Outcome {
    let t0 = Instant::now();
    let (train, withheld) = sc.logs();
    let log = Log::from_str_named(&train, &format!("scenario{}.csv", sc.id)).expect("valid log");
    let w = Log::from_str_named(&withheld, &format!("scenario{}-withheld.csv", sc.id))
        .expect("valid log");
    match diagnose::diagnose(&log, Some(&w), &Model::paper(), cfg) {
        Ok(d) => Outcome {
            sc: sc.clone(),
            verdict: score(sc, &d),
            named: d.attr.accepted.clone(),
            unexplained: d.unexplained.len(),
            p: d.tests.p_value,
            shrink: d.excess_removed()[2],
            secs: t0.elapsed().as_secs_f64(),
        },
        Err(e) => {
            eprintln!("scenario {}: {e:#}", sc.id);
            Outcome {
                sc: sc.clone(),
                verdict: "error",
                named: Vec::new(),
                unexplained: 0,
                p: f64::NAN,
                shrink: None,
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

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let (mut subset, mut seed, mut out, mut docs) = (
        None,
        1u64,
        PathBuf::from("target/diagnose-benchmark"),
        false,
    );
    let mut only: Option<String> = None;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--subset" => subset = Some(args.next().unwrap_or_default().parse::<usize>()?),
            "--seed" => seed = args.next().unwrap_or_default().parse()?,
            "--out" => out = PathBuf::from(args.next().unwrap_or_default()),
            "--write-docs" => docs = true,
            "--only" => only = args.next(),
            other => anyhow::bail!("unknown argument {other:?} (--subset N, --only CATEGORY, --seed S, --out DIR, --write-docs)"),
        }
    }
    std::fs::create_dir_all(&out)?;
    let mut all = scenarios(seed);
    if let Some(c) = &only {
        all.retain(|s| &category(s) == c);
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
            let o = run(sc, &cfg);
            pb.inc(1);
            o
        })
        .collect();
    pb.finish_and_clear();
    let wall = t0.elapsed().as_secs_f64();
    // results.csv
    let mut csv = String::from("id,category,truth,protocol,strength,verdict,named,unexplained,p_value,excess_removed,seconds\n");
    for o in &outcomes {
        let _ = writeln!(
            csv,
            "{},{},\"{}\",{},{},{},\"{}\",{},{:.3e},{},{:.2}",
            o.sc.id,
            category(&o.sc),
            o.sc.describe(),
            o.sc.protocol.name(),
            o.sc.truths.first().map(|t| t.strength).unwrap_or(0.0),
            o.verdict,
            o.named.join(" "),
            o.unexplained,
            o.p,
            o.shrink.map(|s| format!("{s:.3}")).unwrap_or_default(),
            o.secs
        );
    }
    std::fs::write(out.join("results.csv"), csv)?;
    // Confusion matrix: category x verdict.
    let verdicts = [
        "right",
        "right name",
        "wrong",
        "nothing",
        "unexplained",
        "error",
    ];
    let cats = [
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
    let mut md = String::new();
    let _ = writeln!(
        md,
        "{} scenarios (seed {seed}), diagnosed in {:.0} s wall on this machine ({:.2} s per diagnosis on average, {} threads).\n",
        outcomes.len(),
        wall,
        outcomes.iter().map(|o| o.secs).sum::<f64>() / outcomes.len().max(1) as f64,
        rayon::current_num_threads()
    );
    let _ = writeln!(md, "| truth | {} | total |", verdicts.join(" | "));
    let _ = writeln!(md, "|---{}|---|", "|---".repeat(verdicts.len()));
    for c in cats {
        let row: Vec<&Outcome> = outcomes.iter().filter(|o| category(&o.sc) == c).collect();
        if row.is_empty() {
            continue;
        }
        let counts: Vec<String> = verdicts
            .iter()
            .map(|v| row.iter().filter(|o| o.verdict == *v).count().to_string())
            .collect();
        let _ = writeln!(md, "| {c} | {} | {} |", counts.join(" | "), row.len());
    }
    let share = |f: &dyn Fn(&Outcome) -> bool, g: &dyn Fn(&Outcome) -> bool| -> (usize, usize) {
        let sel: Vec<&Outcome> = outcomes.iter().filter(|o| f(o)).collect();
        (sel.iter().filter(|o| g(o)).count(), sel.len())
    };
    let is_effect = |o: &Outcome| {
        let e = o.sc.expected();
        !e.is_empty() && !e.contains(&"anomaly") && !e.contains(&"camera_bias")
    };
    let strong = |o: &Outcome| is_effect(o) && o.sc.truths.iter().all(|t| t.strength >= 2.0);
    let (a, b) = share(&strong, &|o| {
        o.verdict == "right" || o.verdict == "right name"
    });
    let (a2, b2) = share(&strong, &|o| o.verdict == "right");
    let (a1, b1) = share(&|o| is_effect(o) && o.sc.truths[0].strength < 2.0, &|o| {
        o.verdict == "right" || o.verdict == "right name"
    });
    let (n, nn) = share(&|o| o.sc.truths.is_empty(), &|o| !o.named.is_empty());
    let (u, uu) = share(&|o| o.sc.expected() == ["anomaly"], &|o| {
        o.verdict == "right"
    });
    let pct = |a: usize, b: usize| 100.0 * a as f64 / b.max(1) as f64;
    let _ = writeln!(md, "\n| measure | value |\n|---|---|");
    let _ = writeln!(
        md,
        "| right name at strength >= 2x the visit noise | {a} / {b} ({:.0} %) |",
        pct(a, b)
    );
    let _ = writeln!(md, "| fully right (name, region, >= 50 % of the withheld excess removed) at strength >= 2x | {a2} / {b2} ({:.0} %) |", pct(a2, b2));
    let _ = writeln!(
        md,
        "| right name at strength 1x | {a1} / {b1} ({:.0} %) |",
        pct(a1, b1)
    );
    let _ = writeln!(
        md,
        "| null logs with a name (false claims, alpha = {}) | {n} / {nn} ({:.0} %) |",
        cfg.alpha,
        pct(n, nn)
    );
    let _ = writeln!(
        md,
        "| anomalies reported unexplained at their place | {u} / {uu} ({:.0} %) |",
        pct(u, uu)
    );
    // Shrink distribution.
    let mut sh: Vec<f64> = outcomes
        .iter()
        .filter(|o| is_effect(o) && !o.named.is_empty())
        .filter_map(|o| o.shrink)
        .map(|s| 100.0 * s)
        .collect();
    sh.sort_by(|x, y| x.total_cmp(y));
    let q = |p: f64| {
        sh.get(((sh.len().max(1) - 1) as f64 * p).round() as usize)
            .copied()
            .unwrap_or(f64::NAN)
    };
    let _ = writeln!(
        md,
        "\nShare of the withheld excess over the floor removed (effect logs with a name, {} logs): 10 % {:.0} %, 25 % {:.0} %, median {:.0} %, 75 % {:.0} %, 90 % {:.0} %.\n",
        sh.len(),
        q(0.1),
        q(0.25),
        q(0.5),
        q(0.75),
        q(0.9)
    );
    if !sh.is_empty() {
        let mut hist = [0usize; 12];
        for s in &sh {
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
        plot::lines(
            &out.join("shrink.png"),
            &Labels {
                title: "diagnose benchmark: withheld excess removed",
                x: "share of the withheld excess over the floor removed [%]",
                y: "scenarios [-]",
            },
            &[Series::line("effect logs with a name", pts)],
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
