//! `magswarm lab`: the virtual lab. It writes measurement logs (docs/log-format.md format) from a
//! chosen truth under realistic protocols and noise, deterministically for a seed.
//!
//! - Truth: a model file with any effects (`--truth`, default the paper model), plus optional
//!   *foreign* effects ([`truth::Foreign`]) written in forms that differ from the candidate
//!   forms of `magswarm_model::effects`.
//! - Protocols ([`protocol::Protocol`]): randomised operating-point grid with settle time and
//!   repeats (the seed's Sec. III-C), up/down frequency sweeps, setpoint steps, long runs of
//!   several sessions (`session` column; `t_s` restarts per session, and the swarm is formed
//!   afresh at the start of each).
//! - Noise ([`Noise`]): per measurement (heteroscedastic: sd = sd_mm + rel * r), per visit (an
//!   offset drawn once per visit: the swarm re-forms a little differently each time), and
//!   occasional invalid frames (`valid` = 0: a fragment measured instead of the swarm).
//!
//! A scenario file (JSON) gathers all of it:
//!
//! ```json
//! {
//!   "truth": "truth.json",
//!   "foreign": [{"kind": "phase_lag_logistic", "f_c_hz": 6.0, "width_hz": 0.5, "depth": 0.6}],
//!   "protocol": {"kind": "grid", "repeats": 10, "settle_s": 20},
//!   "sessions": 1,
//!   "noise": {"sd_mm": [0.1, 0.15], "rel": [0.02, 0.025], "visit_sd_mm": [0.1, 0.2], "p_invalid": 0.02}
//! }
//! ```
//!
//! Command-line options override the file. The log records measurements only; each row's
//! inputs are those in force since the previous row (the convention `predict` replays), so a
//! noise-free lab run of a model without foreign effects is exactly `predict` of its inputs.

pub mod plant;
pub mod presets;
pub mod protocol;
pub mod truth;

use anyhow::{bail, Context, Result};
use magswarm_model::{hz_to_rad_s, Model};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

use crate::log::{Layout, LogRow, LogWriter};
pub use protocol::{Protocol, Visit};
pub use truth::{Foreign, LabSwarm};

/// Measurement noise of the lab.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Noise {
    /// Per-measurement standard deviation floor \[mm\] (r1, r2).
    pub sd_mm: [f64; 2],
    /// Per-measurement standard deviation per mm of radius [-] (r1, r2): heteroscedastic.
    pub rel: [f64; 2],
    /// Standard deviation of the per-visit offset \[mm\] (r1, r2).
    pub visit_sd_mm: [f64; 2],
    /// Probability that a frame is invalid (`valid` = 0).
    pub p_invalid: f64,
}

impl Default for Noise {
    /// Close to the seed's scatter: about 0.26 mm on r1 ~ 8 mm and 0.45 mm on r2 ~ 12 mm per
    /// measurement (Sec. III-D: +-0.26-0.57 and +-0.33-0.51 mm), plus per-visit offsets.
    fn default() -> Self {
        Noise {
            sd_mm: [0.10, 0.15],
            rel: [0.02, 0.025],
            visit_sd_mm: [0.10, 0.20],
            p_invalid: 0.02,
        }
    }
}

impl Noise {
    /// No noise and no invalid frames.
    pub fn none() -> Noise {
        Noise {
            sd_mm: [0.0; 2],
            rel: [0.0; 2],
            visit_sd_mm: [0.0; 2],
            p_invalid: 0.0,
        }
    }

    fn validate(&self) -> Result<()> {
        for (name, v) in [
            ("sd_mm", self.sd_mm),
            ("rel", self.rel),
            ("visit_sd_mm", self.visit_sd_mm),
        ] {
            if v.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
                bail!("noise.{name} must be finite and >= 0 (got {v:?})");
            }
        }
        if !(0.0..=0.5).contains(&self.p_invalid) {
            bail!(
                "noise.p_invalid must be in [0, 0.5] (got {})",
                self.p_invalid
            );
        }
        Ok(())
    }

    /// Per-measurement standard deviation at radii r \[mm\].
    pub fn sd_at(&self, r: [f64; 2]) -> [f64; 2] {
        [
            self.sd_mm[0] + self.rel[0] * r[0].abs(),
            self.sd_mm[1] + self.rel[1] * r[1].abs(),
        ]
    }
}

/// Everything that defines a lab run besides the seed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Truth model file (relative paths are relative to the scenario file); none: the paper
    /// model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub truth: Option<PathBuf>,
    /// Foreign effects on top of the truth model.
    #[serde(default)]
    pub foreign: Vec<Foreign>,
    /// The protocol.
    #[serde(default = "default_protocol")]
    pub protocol: Protocol,
    /// Sessions (each a fresh swarm and a fresh randomisation of the protocol).
    #[serde(default = "one")]
    pub sessions: usize,
    /// Measurement noise.
    #[serde(default)]
    pub noise: Noise,
}

fn default_protocol() -> Protocol {
    Protocol::default_of("grid").expect("grid has defaults")
}
fn one() -> usize {
    1
}

impl Default for Scenario {
    fn default() -> Self {
        Scenario {
            truth: None,
            foreign: Vec::new(),
            protocol: default_protocol(),
            sessions: 1,
            noise: Noise::default(),
        }
    }
}

impl Scenario {
    /// Read a scenario file; relative truth paths become relative to its folder.
    pub fn load(path: &Path) -> Result<Scenario> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read scenario {}", path.display()))?;
        let de = &mut serde_json::Deserializer::from_str(&text);
        let mut s: Scenario = serde_path_to_error::deserialize(de).map_err(|e| {
            anyhow::anyhow!("scenario {}: {}: {}", path.display(), e.path(), e.inner())
        })?;
        if let Some(t) = &s.truth {
            if t.is_relative() {
                s.truth = Some(path.parent().unwrap_or(Path::new(".")).join(t));
            }
        }
        s.validate()
            .with_context(|| format!("scenario {}", path.display()))?;
        Ok(s)
    }

    /// Check every part.
    pub fn validate(&self) -> Result<()> {
        self.protocol.validate().map_err(anyhow::Error::msg)?;
        self.noise.validate()?;
        if self.sessions == 0 {
            bail!("sessions must be >= 1");
        }
        for f in &self.foreign {
            f.validate()?;
        }
        let mut seen = Vec::new();
        for f in &self.foreign {
            let k = std::mem::discriminant(f);
            if seen.contains(&k) {
                bail!("foreign effect {} given twice", f.effect());
            }
            seen.push(k);
        }
        Ok(())
    }

    /// The truth model: the file named in the scenario, or the paper model.
    pub fn truth_model(&self) -> Result<Model> {
        match &self.truth {
            None => Ok(Model::paper()),
            Some(p) => Model::load(p).context("truth model"),
        }
    }
}

/// Generate the rows of a lab run. `progress` is called with (visits done, visits total).
pub fn generate(
    model: &Model,
    sc: &Scenario,
    seed: u64,
    mut progress: impl FnMut(usize, usize),
) -> Result<Vec<LogRow>> {
    sc.validate()?;
    let mut rng = StdRng::seed_from_u64(seed);
    let sessions: Vec<Vec<Visit>> = (0..sc.sessions)
        .map(|_| sc.protocol.session(&mut rng))
        .collect();
    let total: usize = sessions.iter().map(|s| s.len()).sum();
    let mut done = 0;
    let gauss = |rng: &mut StdRng| -> f64 { StandardNormal.sample(rng) };
    let mut rows = Vec::new();
    for (k, visits) in sessions.iter().enumerate() {
        let name = if sc.sessions > 1 {
            format!("s{}", k + 1)
        } else {
            String::new()
        };
        let Some(first) = visits.first() else {
            continue;
        };
        let mut swarm = LabSwarm::new(
            model.clone(),
            sc.foreign.clone(),
            first.z_mm * 1e-3,
            hz_to_rad_s(first.f_hz),
        );
        for v in visits {
            swarm.set_inputs(v.z_mm * 1e-3, hz_to_rad_s(v.f_hz));
            let offset = [
                sc.noise.visit_sd_mm[0] * gauss(&mut rng),
                sc.noise.visit_sd_mm[1] * gauss(&mut rng),
            ];
            for &t in &v.t_s {
                swarm.advance_to(t).with_context(|| {
                    format!(
                        "session {} at t = {t} s (z_m {} mm, f {} Hz)",
                        k + 1,
                        v.z_mm,
                        v.f_hz
                    )
                })?;
                let truth = swarm.true_radii(&mut rng);
                let sd = sc.noise.sd_at(truth);
                let e = [gauss(&mut rng), gauss(&mut rng)];
                let mut r = [
                    truth[0] + offset[0] + sd[0] * e[0],
                    truth[1] + offset[1] + sd[1] * e[1],
                ];
                let invalid = sc.noise.p_invalid > 0.0 && rng.random::<f64>() < sc.noise.p_invalid;
                if invalid {
                    // A fragment or a merged blob measured instead of the swarm.
                    r = [
                        truth[0] * rng.random_range(0.3..0.8),
                        truth[1] * rng.random_range(0.3..0.8),
                    ];
                }
                let r = [round4(r[0].max(0.0)), round4(r[1].max(0.0))];
                let mut row = LogRow::new(t, v.z_mm, v.f_hz, Some(r));
                row.session = name.clone();
                row.valid = !invalid;
                rows.push(row);
            }
            done += 1;
            progress(done, total);
        }
    }
    Ok(rows)
}

fn round4(v: f64) -> f64 {
    (v * 1e4).round() / 1e4
}

pub use crate::cli::LabArgs;

/// The scenario of the arguments: the file (or defaults), then the options on top.
pub fn resolve(a: &LabArgs) -> Result<Scenario> {
    let mut sc = match &a.scenario {
        Some(p) => Scenario::load(p)?,
        None => Scenario::default(),
    };
    if let Some(t) = &a.truth {
        sc.truth = Some(t.clone());
    }
    if let Some(kind) = &a.protocol {
        match kind.as_str() {
            "long" => {
                sc.protocol = Protocol::default_of("grid").expect("grid");
                if let Protocol::Grid { visits, .. } = &mut sc.protocol {
                    *visits = 2;
                }
                sc.sessions = 3;
            }
            k => {
                sc.protocol = Protocol::default_of(k).with_context(|| {
                    format!("--protocol {k:?}: expected grid, sweep, steps or long")
                })?;
            }
        }
    }
    if let Some(n) = a.sessions {
        sc.sessions = n;
    }
    let grid_only = |name: &str| {
        anyhow::anyhow!("--{name} applies to the grid protocol only (use a scenario file)")
    };
    match &mut sc.protocol {
        Protocol::Grid {
            visits,
            repeats,
            settle_s,
            sample_s,
            ..
        } => {
            if let Some(v) = a.repeats {
                *repeats = v;
            }
            if let Some(v) = a.visits {
                *visits = v;
            }
            if let Some(v) = a.settle_s {
                *settle_s = v;
            }
            if let Some(v) = a.sample_s {
                *sample_s = v;
            }
        }
        Protocol::Sweep { sample_s, .. } | Protocol::Steps { sample_s, .. } => {
            if a.repeats.is_some() {
                return Err(grid_only("repeats"));
            }
            if a.visits.is_some() {
                return Err(grid_only("visits"));
            }
            if a.settle_s.is_some() {
                return Err(grid_only("settle-s"));
            }
            if let Some(v) = a.sample_s {
                *sample_s = v;
            }
        }
    }
    for e in &a.effects {
        let (name, strength) = match e.split_once('=') {
            Some((n, s)) => {
                let v: f64 = s
                    .trim()
                    .parse()
                    .map_err(|_| anyhow::anyhow!("--effect {e}: strength {s:?} is not a number"))?;
                if !(v.is_finite() && v >= 0.0) {
                    bail!("--effect {e}: strength must be >= 0");
                }
                (n.trim(), v)
            }
            None => (e.trim(), 1.0),
        };
        let f = presets::foreign(name, strength).with_context(|| format!("--effect {e}"))?;
        sc.foreign.push(f);
    }
    if a.no_noise {
        sc.noise = Noise::none();
    }
    sc.validate()?;
    Ok(sc)
}

/// Run the command.
pub fn run(a: &LabArgs) -> Result<()> {
    let sc = resolve(a)?;
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
    let rows = generate(&model, &sc, a.seed, |done, total| {
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
    let effects = model.effects.enabled();
    let foreign: Vec<String> = sc
        .foreign
        .iter()
        .map(|f| format!("{} (foreign form)", f.effect()))
        .collect();
    let all: Vec<String> = effects
        .iter()
        .map(|s| s.to_string())
        .chain(foreign)
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
