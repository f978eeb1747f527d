//! Arguments of `magswarm lab` and the command itself over the library (`magswarm::lab`).

use std::path::PathBuf;

/// Arguments of `magswarm lab`.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Units: z_m in mm, f in Hz, times in s, radii in mm (log columns \
t_s,z_m_mm,f_hz,r1_mm,r2_mm[,session][,valid]). Protocols: grid (randomised z_m x f grid, \
settle then repeats; default the seed's 5 x 10 points, 20 s settle, 10 repeats 1 s apart), \
sweep (f up then down at each z_m, measured through each dwell), steps (random setpoints, \
measured through each dwell), long (grid, 3 sessions of 2 passes). The scenario file (JSON) \
holds truth, foreign effects, protocol, sessions and noise; see docs/lab.md."
)]
pub struct LabArgs {
    /// Output measurement log (CSV).
    #[arg(long)]
    pub out: PathBuf,
    /// Truth model JSON (magswarm-model/2 with any effects; default the paper model, or the
    /// scenario's truth).
    #[arg(long)]
    pub truth: Option<PathBuf>,
    /// Scenario file (JSON): truth, foreign effects, protocol, sessions, noise.
    #[arg(long)]
    pub scenario: Option<PathBuf>,
    /// Protocol: grid, sweep, steps or long (replaces the scenario's protocol with its
    /// defaults, then the options below apply).
    #[arg(long)]
    pub protocol: Option<String>,
    /// Seed of every random draw (order, noise, invalid frames).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Number of sessions (`session` column s1, s2, ... when more than one).
    #[arg(long)]
    pub sessions: Option<usize>,
    /// Grid: measurements per visit.
    #[arg(long)]
    pub repeats: Option<usize>,
    /// Grid: passes over the grid per session.
    #[arg(long)]
    pub visits: Option<usize>,
    /// Grid: wait after an input change before the first measurement \[s\].
    #[arg(long)]
    pub settle_s: Option<f64>,
    /// Time between measurements \[s\].
    #[arg(long)]
    pub sample_s: Option<f64>,
    /// Add an unmodelled effect in the lab's foreign form at a strength (1: the documented
    /// size; see docs/lab.md): phase_lag, cohesion_loss, formation_lag, particle_drift,
    /// centroid_offset, camera_bias. Repeat for several.
    #[arg(long = "effect", value_name = "NAME[=STRENGTH]")]
    pub effects: Vec<String>,
    /// Noise-free measurements (no scatter, no invalid frames).
    #[arg(long)]
    pub no_noise: bool,
    /// Print the resolved scenario (JSON) and exit: a template for scenario files.
    #[arg(long)]
    pub print_scenario: bool,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

impl LabArgs {
    /// The library's options: each `--effect NAME[=STRENGTH]` parsed (strength 1 by default).
    pub fn options(&self) -> anyhow::Result<magswarm::lab::LabOptions> {
        let mut effects = Vec::new();
        for e in &self.effects {
            let (name, strength) = match e.split_once('=') {
                Some((n, s)) => {
                    let v: f64 = s.trim().parse().map_err(|_| {
                        anyhow::anyhow!("--effect {e}: strength {s:?} is not a number")
                    })?;
                    if !(v.is_finite() && v >= 0.0) {
                        anyhow::bail!("--effect {e}: strength must be >= 0");
                    }
                    (n.trim(), v)
                }
                None => (e.trim(), 1.0),
            };
            effects.push((name.to_string(), strength));
        }
        Ok(magswarm::lab::LabOptions {
            truth: self.truth.clone(),
            scenario: self.scenario.clone(),
            protocol: self.protocol.clone(),
            sessions: self.sessions,
            repeats: self.repeats,
            visits: self.visits,
            settle_s: self.settle_s,
            sample_s: self.sample_s,
            effects,
            no_noise: self.no_noise,
        })
    }
}

/// Run `magswarm lab`: resolve the scenario, generate the rows with a progress bar, write
/// the log, say what was written.
pub fn run(a: &LabArgs) -> anyhow::Result<()> {
    use anyhow::Context;
    use magswarm::log::{Layout, LogWriter};
    let sc = magswarm::lab::resolve(&a.options()?)?;
    if a.print_scenario {
        println!("{}", serde_json::to_string_pretty(&sc)?);
        return Ok(());
    }
    let model = sc.truth_model()?;
    let pb = if a.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        let pb = indicatif::ProgressBar::new(0);
        pb.set_style(
            indicatif::ProgressStyle::with_template(
                "lab {bar:30} {pos}/{len} visits {elapsed} (eta {eta})",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        pb
    };
    let rows = magswarm::lab::generate(&model, &sc, a.seed, |done, total| {
        pb.set_length(total as u64);
        pb.set_position(done as u64);
    })?;
    pb.finish_and_clear();
    let layout = Layout::standard(true, sc.sessions > 1, true, false);
    let mut w = LogWriter::create(&a.out, layout)
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    for r in &rows {
        w.write_row(r)
            .with_context(|| format!("writing {}", a.out.display()))?;
    }
    w.finish()
        .with_context(|| format!("writing {}", a.out.display()))?;
    let invalid = rows.iter().filter(|r| !r.valid).count();
    let all: Vec<String> = model
        .effects
        .enabled()
        .iter()
        .map(|s| s.to_string())
        .chain(
            sc.foreign
                .iter()
                .map(|f| format!("{} (foreign form)", f.effect())),
        )
        .collect();
    eprintln!(
        "lab: wrote {} rows ({} invalid) in {} session(s) to {}; truth effects: {}",
        rows.len(),
        invalid,
        sc.sessions,
        a.out.display(),
        if all.is_empty() {
            "none".to_string()
        } else {
            all.join(", ")
        }
    );
    Ok(())
}
