//! Arguments of `magswarm lab` (run by [`crate::lab::run`]).

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
