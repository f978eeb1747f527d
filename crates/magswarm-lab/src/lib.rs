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

pub mod error;
pub mod plant;
pub mod presets;
pub mod protocol;
pub mod truth;

pub use error::LabError;
use magswarm_model::{hz_to_rad_s, Model};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

use magswarm_log::LogRow;
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

    fn validate(&self) -> Result<(), LabError> {
        for (name, v) in [
            ("sd_mm", self.sd_mm),
            ("rel", self.rel),
            ("visit_sd_mm", self.visit_sd_mm),
        ] {
            if v.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
                return Err(LabError::invalid(
                    format!("noise.{name}"),
                    format!("must be finite and >= 0 (got {v:?})"),
                ));
            }
        }
        if !(0.0..=0.5).contains(&self.p_invalid) {
            return Err(LabError::invalid(
                "noise.p_invalid",
                format!("must be in [0, 0.5] (got {})", self.p_invalid),
            ));
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
    pub fn load(path: &Path) -> Result<Scenario, LabError> {
        let text = std::fs::read_to_string(path).map_err(|source| LabError::ReadScenario {
            path: path.to_path_buf(),
            source,
        })?;
        let de = &mut serde_json::Deserializer::from_str(&text);
        let mut s: Scenario =
            serde_path_to_error::deserialize(de).map_err(|e| LabError::ParseScenario {
                path: path.to_path_buf(),
                at: e.path().to_string(),
                message: e.inner().to_string(),
            })?;
        if let Some(t) = &s.truth {
            if t.is_relative() {
                s.truth = Some(path.parent().unwrap_or(Path::new(".")).join(t));
            }
        }
        s.validate().map_err(|e| LabError::InScenario {
            path: path.to_path_buf(),
            source: Box::new(e),
        })?;
        Ok(s)
    }

    /// Check every part.
    pub fn validate(&self) -> Result<(), LabError> {
        self.protocol.validate()?;
        self.noise.validate()?;
        if self.sessions == 0 {
            return Err(LabError::invalid("sessions", "must be >= 1"));
        }
        for f in &self.foreign {
            f.validate()?;
        }
        let mut seen = Vec::new();
        for f in &self.foreign {
            let k = std::mem::discriminant(f);
            if seen.contains(&k) {
                return Err(LabError::DuplicateForeign(f.effect()));
            }
            seen.push(k);
        }
        Ok(())
    }

    /// The truth model: the file named in the scenario, or the paper model.
    pub fn truth_model(&self) -> Result<Model, LabError> {
        Ok(Model::load_or_paper(self.truth.as_deref())?)
    }
}

/// Generate the rows of a lab run. `progress` is called with (visits done, visits total).
pub fn generate(
    model: &Model,
    sc: &Scenario,
    seed: u64,
    mut progress: impl FnMut(usize, usize),
) -> Result<Vec<LogRow>, LabError> {
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
                swarm.advance_to(t).map_err(|e| LabError::Integrate {
                    session: k + 1,
                    t,
                    z_mm: e.z_mm,
                    f_hz: e.f_hz,
                    message: e.message,
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

/// What `magswarm lab` asks for besides the scenario file: the options that override it
/// (None: keep the file's or the default's value). The command's arguments convert into it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LabOptions {
    /// Truth model file (replaces the scenario's).
    pub truth: Option<PathBuf>,
    /// Scenario file.
    pub scenario: Option<PathBuf>,
    /// Protocol: grid, sweep, steps or long (replaces the scenario's with its defaults).
    pub protocol: Option<String>,
    /// Sessions.
    pub sessions: Option<usize>,
    /// Grid: measurements per visit.
    pub repeats: Option<usize>,
    /// Grid: passes over the grid per session.
    pub visits: Option<usize>,
    /// Grid: wait after an input change before the first measurement \[s\].
    pub settle_s: Option<f64>,
    /// Time between measurements \[s\].
    pub sample_s: Option<f64>,
    /// Effects added in the lab's foreign form: (name, strength).
    pub effects: Vec<(String, f64)>,
    /// Noise-free measurements.
    pub no_noise: bool,
}

/// The scenario of the options: the file (or defaults), then the options on top.
pub fn resolve(a: &LabOptions) -> Result<Scenario, LabError> {
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
                sc.protocol = default_protocol();
                if let Protocol::Grid { visits, .. } = &mut sc.protocol {
                    *visits = 2;
                }
                sc.sessions = 3;
            }
            k => {
                sc.protocol = Protocol::default_of(k)
                    .ok_or_else(|| LabError::UnknownProtocol(k.to_string()))?;
            }
        }
    }
    if let Some(n) = a.sessions {
        sc.sessions = n;
    }
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
                return Err(LabError::GridOnly("repeats"));
            }
            if a.visits.is_some() {
                return Err(LabError::GridOnly("visits"));
            }
            if a.settle_s.is_some() {
                return Err(LabError::GridOnly("settle-s"));
            }
            if let Some(v) = a.sample_s {
                *sample_s = v;
            }
        }
    }
    for (name, strength) in &a.effects {
        if !(strength.is_finite() && *strength >= 0.0) {
            return Err(LabError::invalid(
                format!("effect {name}"),
                format!("strength {strength} must be >= 0"),
            ));
        }
        sc.foreign.push(presets::foreign(name, *strength)?);
    }
    if a.no_noise {
        sc.noise = Noise::none();
    }
    sc.validate()?;
    Ok(sc)
}
