//! Experiment protocols of the virtual lab: which inputs, for how long, measured when.
//!
//! A protocol expands into sessions of *visits*. A visit holds one operating point: the
//! inputs change right after the previous visit's last measurement (or at t = 0, where the
//! swarm has formed at the first point), the swarm is left `settle_s` seconds, then measured
//! `n` times every `sample_s` seconds. Measurement logs record only measurements, so this
//! timing is what `predict` replays (it holds each row's inputs since the previous row).

use super::LabError;
use rand::rngs::StdRng;
use rand::RngExt;
use serde::{Deserialize, Serialize};

/// One operating point held and measured.
#[derive(Debug, Clone, PartialEq)]
pub struct Visit {
    /// Commanded z_m \[mm\].
    pub z_mm: f64,
    /// Commanded frequency \[Hz\].
    pub f_hz: f64,
    /// Session times of the measurements \[s\] (increasing).
    pub t_s: Vec<f64>,
}

/// A protocol, as in a scenario file (`"kind"` selects it; every other field has a default).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Protocol {
    /// Randomised operating-point grid with settle time and repeats (the seed's Sec. III-C:
    /// 50 points, 10 repeats each). Each pass visits every point once, in a fresh random order.
    Grid {
        /// Distances \[mm\].
        #[serde(default = "seed_z")]
        z_mm: Vec<f64>,
        /// Frequencies \[Hz\].
        #[serde(default = "seed_f")]
        f_hz: Vec<f64>,
        /// Passes over the grid per session.
        #[serde(default = "one")]
        visits: usize,
        /// Measurements per visit.
        #[serde(default = "ten")]
        repeats: usize,
        /// Wait after an input change before the first measurement \[s\].
        #[serde(default = "twenty")]
        settle_s: f64,
        /// Time between measurements of a visit \[s\].
        #[serde(default = "one_f")]
        sample_s: f64,
        /// Extra measurements during the approach, at these times after the input change \[s\]
        /// (each before `settle_s`): they show formation and transients.
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        approach_s: Vec<f64>,
    },
    /// Frequency sweeps up then down at each distance, measured through each dwell
    /// (transients included).
    Sweep {
        /// Distances \[mm\], swept in this order.
        #[serde(default = "sweep_z")]
        z_mm: Vec<f64>,
        /// Lowest frequency \[Hz\].
        #[serde(default = "one_f")]
        f_min_hz: f64,
        /// Highest frequency \[Hz\].
        #[serde(default = "ten_f")]
        f_max_hz: f64,
        /// Frequency step \[Hz\].
        #[serde(default = "one_f")]
        f_step_hz: f64,
        /// Time at each frequency \[s\].
        #[serde(default = "fifteen")]
        dwell_s: f64,
        /// Time between measurements \[s\].
        #[serde(default = "one_f")]
        sample_s: f64,
    },
    /// Random setpoint steps inside ranges of z_m and f, measured through each dwell.
    Steps {
        /// Number of steps per session.
        #[serde(default = "forty")]
        n_steps: usize,
        /// z_m range \[mm\].
        #[serde(default = "z_range")]
        z_range_mm: [f64; 2],
        /// Frequency range \[Hz\].
        #[serde(default = "f_range")]
        f_range_hz: [f64; 2],
        /// Time at each setpoint \[s\].
        #[serde(default = "thirty")]
        dwell_s: f64,
        /// Time between measurements \[s\].
        #[serde(default = "half")]
        sample_s: f64,
    },
}

fn seed_z() -> Vec<f64> {
    vec![3.5, 8.5, 13.5, 18.5, 23.5]
}
fn seed_f() -> Vec<f64> {
    (1..=10).map(|f| f as f64).collect()
}
fn sweep_z() -> Vec<f64> {
    vec![8.5, 18.5]
}
fn one() -> usize {
    1
}
fn ten() -> usize {
    10
}
fn forty() -> usize {
    40
}
fn one_f() -> f64 {
    1.0
}
fn half() -> f64 {
    0.5
}
fn ten_f() -> f64 {
    10.0
}
fn fifteen() -> f64 {
    15.0
}
fn twenty() -> f64 {
    20.0
}
fn thirty() -> f64 {
    30.0
}
fn z_range() -> [f64; 2] {
    [3.5, 23.5]
}
fn f_range() -> [f64; 2] {
    [1.0, 10.0]
}

impl Protocol {
    /// The default protocol of a kind name (`grid`, `sweep`, `steps`).
    pub fn default_of(kind: &str) -> Option<Protocol> {
        let text = format!("{{\"kind\": {kind:?}}}");
        serde_json::from_str(&text).ok()
    }

    /// Check the values; the message names the field.
    pub fn validate(&self) -> Result<(), LabError> {
        let pos = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(LabError::invalid(
                    format!("protocol.{name}"),
                    format!("must be > 0 s (got {v})"),
                ))
            }
        };
        let nonneg = |name: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(LabError::invalid(
                    format!("protocol.{name}"),
                    format!("must be >= 0 (got {v})"),
                ))
            }
        };
        let inputs = |zs: &[f64], fs: &[f64]| -> Result<(), LabError> {
            if let Some(z) = zs.iter().find(|z| !(z.is_finite() && **z > -10.0)) {
                return Err(LabError::invalid(
                    "protocol z_m",
                    format!("{z} mm is not a usable distance"),
                ));
            }
            if let Some(f) = fs.iter().find(|f| !(f.is_finite() && **f > 0.0)) {
                return Err(LabError::invalid(
                    "protocol frequency",
                    format!("{f} Hz must be > 0"),
                ));
            }
            Ok(())
        };
        match self {
            Protocol::Grid {
                z_mm,
                f_hz,
                visits,
                repeats,
                settle_s,
                sample_s,
                approach_s,
            } => {
                if z_mm.is_empty() || f_hz.is_empty() {
                    return Err(LabError::invalid(
                        "protocol.z_mm and protocol.f_hz",
                        "need at least one value",
                    ));
                }
                if *visits == 0 || *repeats == 0 {
                    return Err(LabError::invalid(
                        "protocol.visits and protocol.repeats",
                        "must be >= 1",
                    ));
                }
                inputs(z_mm, f_hz)?;
                nonneg("settle_s", *settle_s)?;
                let mut prev = 0.0;
                for (k, a) in approach_s.iter().enumerate() {
                    if !(a.is_finite() && *a > prev && *a < *settle_s) {
                        return Err(LabError::invalid(
                            format!("protocol.approach_s[{k}]"),
                            format!(
                                "= {a}: approach times must increase, be > 0 and lie before \
                                 settle_s = {settle_s} s"
                            ),
                        ));
                    }
                    prev = *a;
                }
                pos("sample_s", *sample_s)
            }
            Protocol::Sweep {
                z_mm,
                f_min_hz,
                f_max_hz,
                f_step_hz,
                dwell_s,
                sample_s,
            } => {
                if z_mm.is_empty() {
                    return Err(LabError::invalid(
                        "protocol.z_mm",
                        "needs at least one value",
                    ));
                }
                inputs(z_mm, &[*f_min_hz, *f_max_hz])?;
                if f_max_hz < f_min_hz {
                    return Err(LabError::invalid(
                        "protocol.f_max_hz",
                        format!("{f_max_hz} is below f_min_hz {f_min_hz}"),
                    ));
                }
                pos("f_step_hz", *f_step_hz)?;
                pos("dwell_s", *dwell_s)?;
                pos("sample_s", *sample_s)
            }
            Protocol::Steps {
                n_steps,
                z_range_mm,
                f_range_hz,
                dwell_s,
                sample_s,
            } => {
                if *n_steps == 0 {
                    return Err(LabError::invalid("protocol.n_steps", "must be >= 1"));
                }
                inputs(z_range_mm, f_range_hz)?;
                if z_range_mm[1] < z_range_mm[0] || f_range_hz[1] < f_range_hz[0] {
                    return Err(LabError::invalid("protocol ranges", "must be [low, high]"));
                }
                pos("dwell_s", *dwell_s)?;
                pos("sample_s", *sample_s)
            }
        }
    }

    /// The visits of one session, in time order (randomised where the protocol says).
    pub fn session(&self, rng: &mut StdRng) -> Vec<Visit> {
        // (z, f, settle, n, dt, approach) per visit; times are laid out below.
        let mut plan: Vec<Planned> = Vec::new();
        match self {
            Protocol::Grid {
                z_mm,
                f_hz,
                visits,
                repeats,
                settle_s,
                sample_s,
                approach_s,
            } => {
                for _ in 0..*visits {
                    let mut pts: Vec<(f64, f64)> = z_mm
                        .iter()
                        .flat_map(|&z| f_hz.iter().map(move |&f| (z, f)))
                        .collect();
                    shuffle(&mut pts, rng);
                    plan.extend(
                        pts.into_iter()
                            .map(|(z, f)| (z, f, *settle_s, *repeats, *sample_s, &approach_s[..])),
                    );
                }
            }
            Protocol::Sweep {
                z_mm,
                f_min_hz,
                f_max_hz,
                f_step_hz,
                dwell_s,
                sample_s,
            } => {
                let n = ((f_max_hz - f_min_hz) / f_step_hz + 1e-9).floor() as usize;
                let up: Vec<f64> = (0..=n).map(|k| f_min_hz + k as f64 * f_step_hz).collect();
                let per = samples_in(*dwell_s, *sample_s);
                for &z in z_mm {
                    for &f in up.iter().chain(up.iter().rev().skip(1)) {
                        plan.push((z, f, *sample_s, per, *sample_s, &[]));
                    }
                }
            }
            Protocol::Steps {
                n_steps,
                z_range_mm,
                f_range_hz,
                dwell_s,
                sample_s,
            } => {
                let per = samples_in(*dwell_s, *sample_s);
                for _ in 0..*n_steps {
                    let z = lerp(z_range_mm, rng.random::<f64>());
                    let f = lerp(f_range_hz, rng.random::<f64>());
                    // Commanded values at the resolution a rig would log.
                    let (z, f) = ((z * 100.0).round() / 100.0, (f * 100.0).round() / 100.0);
                    plan.push((z, f, *sample_s, per, *sample_s, &[]));
                }
            }
        }
        let mut t = 0.0f64;
        plan.into_iter()
            .map(|(z, f, settle, n, dt, approach)| {
                let start = t;
                let t_s: Vec<f64> = approach
                    .iter()
                    .map(|a| round_us(start + a))
                    .chain((0..n).map(|j| round_us(start + settle + j as f64 * dt)))
                    .collect();
                t = *t_s.last().unwrap_or(&start);
                Visit {
                    z_mm: z,
                    f_hz: f,
                    t_s,
                }
            })
            .collect()
    }
}

/// A visit before its times are laid out: z [mm], f [Hz], settle [s], measurements, their
/// spacing [s], approach measurement times [s].
type Planned<'a> = (f64, f64, f64, usize, f64, &'a [f64]);

fn samples_in(dwell: f64, dt: f64) -> usize {
    ((dwell / dt + 1e-9).floor() as usize).max(1)
}

fn lerp(r: &[f64; 2], u: f64) -> f64 {
    r[0] + (r[1] - r[0]) * u
}

/// Times are logged to the microsecond.
pub fn round_us(t: f64) -> f64 {
    (t * 1e6).round() / 1e6
}

/// Fisher-Yates with the lab's generator.
pub fn shuffle<T>(v: &mut [T], rng: &mut StdRng) {
    for i in (1..v.len()).rev() {
        let j = rng.random_range(0..=i);
        v.swap(i, j);
    }
}
