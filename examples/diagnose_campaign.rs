//! A lab-made campaign with a withheld effect, end to end: generate a training log and a
//! withheld log from a rig whose truth carries an unmodelled effect (in the virtual lab's
//! foreign form, see `magswarm::lab::presets`), write both logs and the truth, run `diagnose`
//! on the training log with the other as `--withheld`, and write the report.
//!
//! ```sh
//! cargo run --release --example diagnose_campaign -- --effect cohesion_loss --out target/diagnose-demo
//! ```
//!
//! `--effect` takes a comma-separated list of NAME or NAME=STRENGTH (1: the size documented in
//! `magswarm::lab::presets`), or `none`; `--seed` changes the noise.

use anyhow::{bail, Result};
use magswarm::diagnose;
use magswarm::lab::{presets::Campaign, Protocol};

fn main() -> Result<()> {
    let mut effect = "cohesion_loss".to_string();
    let mut out = std::path::PathBuf::from("target/diagnose-demo");
    let mut seed = 7u64;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--effect" => effect = args.next().unwrap_or_default(),
            "--out" => out = args.next().unwrap_or_default().into(),
            "--seed" => seed = args.next().and_then(|s| s.parse().ok()).unwrap_or(seed),
            o => bail!("unknown argument {o} (expected --effect NAMES, --out DIR, --seed N)"),
        }
    }
    let effects: Vec<(&str, f64)> = if effect == "none" {
        Vec::new()
    } else {
        effect
            .split(',')
            .map(|e| match e.split_once('=') {
                Some((n, k)) => (n.trim(), k.trim().parse().unwrap_or(1.0)),
                None => (e.trim(), 1.0),
            })
            .collect()
    };
    for (e, _) in &effects {
        if !diagnose::candidates::NAMES.contains(e) {
            bail!(
                "--effect {e}: unknown (known: {})",
                diagnose::candidates::NAMES.join(", ")
            );
        }
    }
    std::fs::create_dir_all(&out)?;
    let train = Campaign::seed_grid(&effects, seed)?;
    let mut held = train.with_seed(seed + 1000);
    // The withheld campaign visits the points between the training grid's.
    if let Protocol::Grid {
        z_mm, f_hz, visits, ..
    } = &mut held.scenario.protocol
    {
        *z_mm = vec![6.0, 11.0, 16.0, 21.0];
        *f_hz = vec![1.5, 2.5, 3.5, 4.5, 5.5, 6.5, 7.5, 8.5, 9.5];
        *visits = 1;
    }
    let tp = out.join("campaign.csv");
    let wp = out.join("withheld.csv");
    std::fs::write(&tp, train.csv()?)?;
    std::fs::write(&wp, held.csv()?)?;
    train.truth.save(&out.join("truth-without-effect.json"))?;
    std::fs::write(
        out.join("scenario.json"),
        serde_json::to_string_pretty(&train.scenario)? + "\n",
    )?;
    eprintln!(
        "diagnose_campaign: truth effect(s) {effect} (foreign forms: scenario.json, docs/lab.md); logs {} and {}",
        tp.display(),
        wp.display()
    );
    let log = magswarm::log::Log::read(&tp)?;
    let withheld = magswarm::log::Log::read(&wp)?;
    let cfg = diagnose::Config::default();
    let d = diagnose::diagnose(
        &log,
        Some(&withheld),
        &magswarm::model::Model::paper(),
        &cfg,
    )?;
    diagnose::report::write(&d, &out)?;
    eprint!("{}", diagnose::report::summary(&d));
    eprintln!(
        "diagnose_campaign: report in {}",
        out.join("report.md").display()
    );
    Ok(())
}
