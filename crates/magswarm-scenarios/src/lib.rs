//! An independent benchmark for `magswarm diagnose`: logs from "another lab", with unmodelled
//! effects in shapes that are not the library's forms, and the truth to score against.
//!
//! What makes it independent of what diagnose fits:
//!
//! - **Its own lab conventions**: every scenario draws its own rig (gains and exponents of the
//!   steady map moved, the magnet's distance offset and remanence off by up to a millimetre and
//!   10 %), its own visit noise and row noise, its own transient (a first-order approach
//!   with its own time constant, not ODE (4)). Only the baseline steady map (5)-(7) of
//!   `magswarm-model` is used, as the physics both labs share.
//! - **Foreign shapes**: the effects are written here from their physical description, in at
//!   least three shapes each, none of them the library's parametric form or the
//!   piecewise-linear tables diagnose fits (bands, tanh and logistic roll-offs, knees, power-law and
//!   exponential onsets, sudden losses, ringing and dead-time transients, off-axis geometry).
//!   A test on this crate's source checks that it names no item of `magswarm_model::effects`.
//! - **Protocols**: the seed's 50-point grid visited once with 10 rows per visit, the grid
//!   visited twice with 5 rows, and far-apart setpoint steps; each scenario also has a withheld
//!   log at operating points between the grid's.
//!
//! Strength is in units of the visit noise (the scatter of a visit's mean): 1 is barely above
//! what one visit shows, 5 is plain in a residual map.

use magswarm_model::{hz_to_rad_s, steady, Model};
use rand::{seq::SliceRandom, RngExt, SeedableRng};
use rand_distr::{Distribution, StandardNormal};

/// The seed's grid of distances \[mm\].
pub const GRID_Z: [f64; 5] = [3.5, 8.5, 13.5, 18.5, 23.5];
/// The seed's grid of frequencies \[Hz\].
pub const GRID_F: [f64; 10] = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0];

/// How the operating points are visited.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Protocol {
    /// The 50-point grid once, 10 rows per visit, random order.
    GridOnce,
    /// The grid twice, 5 rows per visit, random order.
    GridTwice,
    /// Far-apart setpoint steps over the grid's points, 8 rows per visit.
    FarSteps,
}

impl Protocol {
    /// Name for tables.
    pub fn name(self) -> &'static str {
        match self {
            Protocol::GridOnce => "grid x1 (10 rows)",
            Protocol::GridTwice => "grid x2 (5 rows)",
            Protocol::FarSteps => "far-apart steps",
        }
    }
}

/// A foreign shape of an effect (or an anomaly, or nothing).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// A band of r2 around `f0` \[Hz\] at every z_m (Gaussian in f).
    BandR2 { f0: f64 },
    /// A tanh roll-off of the drive above `f0` \[Hz\]: both radii grow in proportion.
    DriveRollOff { f0: f64 },
    /// A step-out whose onset moves with distance: above `f0 + slope (z - 3.5)` the radii
    /// grow linearly with the excess frequency.
    MovingKnee { f0: f64, slope: f64 },
    /// Radii growing past `z0` \[mm\] linearly.
    LinearOnset { z0: f64 },
    /// Radii growing past `z0` exponentially (length `len` mm).
    ExpOnset { z0: f64, len: f64 },
    /// A smooth logistic onset around `z0` (width `w` mm), r2 twice r1.
    LogisticOnset { z0: f64, w: f64 },
    /// Radii shrinking linearly over the session.
    LinearLoss,
    /// Radii shrinking as the square root of session time.
    SqrtLoss,
    /// A sudden loss at a fraction `at` of the session.
    SuddenLoss { at: f64 },
    /// Growth (clumping) saturating with time constant `frac` of the session.
    SaturatingGrowth { frac: f64 },
    /// A slow first-order formation mode (time constant `tau` s) on top of the fast one.
    SlowMode { tau: f64 },
    /// An underdamped formation: ringing with period `period` s, decaying over `tau` s.
    Ringing { period: f64, tau: f64 },
    /// A dead time `delay` s before the swarm responds to a change.
    DeadTime { delay: f64 },
    /// The swarm `offset` mm off the axis at every depth: it sees the field of a larger
    /// distance (sqrt(d^2 + offset^2)).
    OffAxis { offset: f64 },
    /// An axis that is tilted: the offset grows with depth, `offset` mm at the largest z_m.
    TiltedAxis { offset: f64 },
    /// An eccentric swarm: off the axis it is stretched along the field lines and squeezed
    /// across them, the more the weaker the field (r2 up, r1 down, growing with z_m).
    Eccentric,
    /// The camera's scale (1 + eps) on both radii.
    CameraScale,
    /// An offset of both radii in the image.
    CameraOffset,
    /// An image plane tilted about the r1 axis: r2 foreshortened by cos(tilt).
    CameraTilt,
    /// A local bump at `n` neighbouring grid points around (z0, f0), both radii.
    Bump { z0: f64, f0: f64, n: usize },
    /// A local dip of r1 only at two neighbouring frequencies.
    DipR1 { z0: f64, f0: f64 },
}

impl Shape {
    /// The effect name the shape belongs to ("anomaly" for shapes no effect describes).
    pub fn effect(self) -> &'static str {
        match self {
            Shape::BandR2 { .. } | Shape::DriveRollOff { .. } | Shape::MovingKnee { .. } => {
                "phase_lag"
            }
            Shape::LinearOnset { .. } | Shape::ExpOnset { .. } | Shape::LogisticOnset { .. } => {
                "cohesion_loss"
            }
            Shape::LinearLoss
            | Shape::SqrtLoss
            | Shape::SuddenLoss { .. }
            | Shape::SaturatingGrowth { .. } => "particle_drift",
            Shape::SlowMode { .. } | Shape::Ringing { .. } | Shape::DeadTime { .. } => {
                "formation_lag"
            }
            Shape::OffAxis { .. } | Shape::TiltedAxis { .. } | Shape::Eccentric => {
                "centroid_offset"
            }
            Shape::CameraScale | Shape::CameraOffset | Shape::CameraTilt => "camera_bias",
            Shape::Bump { .. } | Shape::DipR1 { .. } => "anomaly",
        }
    }

    /// Short label.
    pub fn label(self) -> String {
        format!("{self:?}")
            .split([' ', '{'])
            .next()
            .unwrap_or("")
            .to_string()
    }

    /// Where it acts: (z range, f range) for shapes over the inputs; None for time shapes.
    pub fn region(self) -> Option<((f64, f64), (f64, f64))> {
        let all_z = (GRID_Z[0], GRID_Z[4]);
        let all_f = (GRID_F[0], GRID_F[9]);
        match self {
            Shape::BandR2 { f0 } => Some((all_z, (f0 - 1.0, f0 + 1.0))),
            Shape::DriveRollOff { f0 } | Shape::MovingKnee { f0, .. } => Some((all_z, (f0, 10.0))),
            Shape::LinearOnset { z0 } | Shape::ExpOnset { z0, .. } => Some(((z0, 23.5), all_f)),
            Shape::LogisticOnset { z0, .. } => Some(((z0 - 2.5, 23.5), all_f)),
            Shape::OffAxis { .. } | Shape::TiltedAxis { .. } | Shape::Eccentric => {
                Some((all_z, all_f))
            }
            Shape::Bump { z0, f0, .. } => Some(((z0, z0), (f0 - 1.0, f0 + 1.0))),
            Shape::DipR1 { z0, f0 } => Some(((z0, z0), (f0, f0 + 1.0))),
            _ => None,
        }
    }
}

/// One effect in a scenario: a shape at a strength (in visit-noise units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Truth {
    /// The shape.
    pub shape: Shape,
    /// Strength [visit-noise SDs].
    pub strength: f64,
}

/// A scenario: a lab, a protocol, the truths, and its logs.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// Index.
    pub id: usize,
    /// Protocol.
    pub protocol: Protocol,
    /// The effects (empty: a null log).
    pub truths: Vec<Truth>,
    /// Seed of its draws.
    pub seed: u64,
}

impl Scenario {
    /// What a right diagnosis names ("none" for null logs, "anomaly" for unexplained).
    pub fn expected(&self) -> Vec<&'static str> {
        self.truths.iter().map(|t| t.shape.effect()).collect()
    }

    /// A one-line description.
    pub fn describe(&self) -> String {
        if self.truths.is_empty() {
            return format!("null, {}", self.protocol.name());
        }
        let t: Vec<String> = self
            .truths
            .iter()
            .map(|t| format!("{} {} x{}", t.shape.effect(), t.shape.label(), t.strength))
            .collect();
        format!("{}, {}", t.join(" + "), self.protocol.name())
    }

    /// The training log and the withheld log (CSV in the project's log format).
    pub fn logs(&self) -> (String, String) {
        let lab = Lab::draw(self.seed);
        let train = lab.run(self, &self.visits(false), self.seed ^ 0x7A11);
        let withheld = lab.run(self, &self.visits(true), self.seed ^ 0x3E1D);
        (train, withheld)
    }

    /// The operating points in visiting order.
    fn visits(&self, withheld: bool) -> Vec<(f64, f64)> {
        let mut rng = rand::rngs::StdRng::seed_from_u64(self.seed ^ (u64::from(withheld) * 0xBEEF));
        if withheld {
            let mut v: Vec<(f64, f64)> = Vec::new();
            for z in [6.0, 11.0, 16.0, 21.0] {
                for f in [1.5, 4.5, 5.5, 7.5, 9.5] {
                    v.push((z, f));
                }
            }
            v.shuffle(&mut rng);
            return v;
        }
        let grid: Vec<(f64, f64)> = GRID_Z
            .iter()
            .flat_map(|&z| GRID_F.iter().map(move |&f| (z, f)))
            .collect();
        match self.protocol {
            Protocol::GridOnce => {
                let mut v = grid;
                v.shuffle(&mut rng);
                v
            }
            Protocol::GridTwice => {
                let mut v = grid.clone();
                v.extend(grid);
                v.shuffle(&mut rng);
                v
            }
            Protocol::FarSteps => {
                // Each step at least 10 mm or 4 Hz away from the last; every point at least
                // once, up to 60 visits.
                let mut left = grid.clone();
                left.shuffle(&mut rng);
                let mut v = vec![left.pop().unwrap_or((13.5, 5.0))];
                while v.len() < 60 {
                    let last = v[v.len() - 1];
                    let far = |p: &(f64, f64)| {
                        (p.0 - last.0).abs() >= 10.0 || (p.1 - last.1).abs() >= 4.0
                    };
                    let pick = match left.iter().position(far) {
                        Some(i) => left.swap_remove(i),
                        None => {
                            let c: Vec<&(f64, f64)> = grid.iter().filter(|p| far(p)).collect();
                            *c[rng.random_range(0..c.len())]
                        }
                    };
                    v.push(pick);
                }
                v
            }
        }
    }
}

/// Another lab: its rig, its noise, its transient.
#[derive(Debug, Clone)]
struct Lab {
    model: Model,
    /// Visit noise SD per axis [mm].
    visit_sd: [f64; 2],
    /// Row noise SD per axis [mm].
    row_sd: [f64; 2],
    /// Time constant of the approach after a change [s].
    tau: f64,
    /// Wait before the first row after a change [s].
    settle: f64,
    /// Time between rows [s].
    dt: f64,
}

fn normal(rng: &mut rand::rngs::StdRng) -> f64 {
    StandardNormal.sample(rng)
}

impl Lab {
    fn draw(seed: u64) -> Lab {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed ^ 0x1AB);
        let mut u = |a: f64, b: f64| a + (b - a) * rng.random::<f64>();
        let mut m = Model::paper();
        let s = &mut m.steady;
        s.C_1 *= u(0.9, 1.1);
        s.C_2 *= u(0.9, 1.1);
        s.a_K1 *= u(0.8, 1.25);
        s.a_K2 *= u(0.8, 1.25);
        s.alpha_1 += u(-0.03, 0.03);
        s.alpha_2 += u(-0.04, 0.04);
        s.N += u(-0.05, 0.05);
        s.q += u(-0.04, 0.04);
        m.magnet.z_offset_m += u(-0.5e-3, 1.5e-3);
        m.magnet.remanence_t *= u(0.9, 1.05);
        Lab {
            model: m,
            visit_sd: [u(0.1, 0.2), u(0.2, 0.35)],
            row_sd: [u(0.15, 0.25), u(0.25, 0.4)],
            tau: u(1.0, 2.5),
            settle: u(2.0, 4.0),
            dt: u(0.8, 1.2),
        }
    }

    fn map(&self, z: f64, f: f64) -> [f64; 2] {
        steady::evaluate(&self.model, z * 1e-3, hz_to_rad_s(f)).radii()
    }

    /// The steady radii at (z, f) with the input-shaped effects.
    fn steady(&self, sc: &Scenario, z: f64, f: f64) -> [f64; 2] {
        let mut r = self.map(z, f);
        let base = r;
        for tr in &sc.truths {
            let a = [
                tr.strength * self.visit_sd[0],
                tr.strength * self.visit_sd[1],
            ];
            let bump = |x: f64, c: f64, w: f64| (-(x - c) * (x - c) / (2.0 * w * w)).exp();
            match tr.shape {
                Shape::BandR2 { f0 } => r[1] += 1.6 * a[1] * bump(f, f0, 0.6),
                Shape::DriveRollOff { f0 } => {
                    let g = 0.5 * (1.0 + ((f - f0) / 0.8).tanh());
                    // a relative growth sized so that its largest change is about the strength
                    for i in 0..2 {
                        r[i] += 1.5 * a[i] * g * base[i] / 10.0;
                    }
                }
                Shape::MovingKnee { f0, slope } => {
                    let on = f0 + slope * (z - 3.5);
                    let x = ((f - on) / (10.0 - on).max(1.0)).max(0.0);
                    r[0] += 1.5 * a[0] * x;
                    r[1] += 1.5 * a[1] * x;
                }
                Shape::LinearOnset { z0 } => {
                    let x = ((z - z0) / (23.5 - z0)).max(0.0);
                    r[0] += 2.0 * a[0] * x;
                    r[1] += 2.0 * a[1] * x;
                }
                Shape::ExpOnset { z0, len } => {
                    let x = ((z - z0).max(0.0) / len).exp_m1() / ((23.5 - z0) / len).exp_m1();
                    r[0] += 2.0 * a[0] * x;
                    r[1] += 2.0 * a[1] * x;
                }
                Shape::LogisticOnset { z0, w } => {
                    let x = 1.0 / (1.0 + (-(z - z0) / w).exp());
                    r[0] += a[0] * x;
                    r[1] += 2.0 * a[1] * x;
                }
                Shape::OffAxis { offset } | Shape::TiltedAxis { offset } => {
                    let off = match tr.shape {
                        Shape::TiltedAxis { .. } => offset * (z - 3.5) / 20.0,
                        _ => offset,
                    } * tr.strength;
                    // The distance from the magnet's centre grows to sqrt(d^2 + off^2): the
                    // swarm sees the field of a larger z_m.
                    let d = z + 20.0 + self.model.magnet.z_offset_m * 1e3;
                    let dz = (d * d + off * off).sqrt() - d;
                    let far = self.map(z + dz, f);
                    for i in 0..2 {
                        r[i] += far[i] - base[i];
                    }
                }
                Shape::Eccentric => {
                    let g = ((z - 3.5) / 20.0).clamp(0.0, 1.0).powf(1.5);
                    r[0] -= 1.5 * a[0] * g;
                    r[1] += 2.0 * a[1] * g;
                }
                Shape::CameraTilt => {
                    let c = (0.08 * tr.strength).min(0.6).cos();
                    r[1] *= c;
                }
                Shape::CameraScale => {
                    let eps = 0.02 * tr.strength;
                    r = [r[0] * (1.0 + eps), r[1] * (1.0 + eps)];
                }
                Shape::CameraOffset => {
                    r = [r[0] + 0.5 * a[0], r[1] + 0.5 * a[0]];
                }
                Shape::Bump { z0, f0, n } => {
                    let near =
                        (z - z0).abs() < 1e-6 && (f - f0).abs() <= 0.5 * (n as f64 - 1.0) + 1e-6;
                    if near {
                        r[0] += 2.0 * a[0];
                        r[1] += 2.0 * a[1];
                    }
                }
                Shape::DipR1 { z0, f0 }
                    if (z - z0).abs() < 1e-6 && (f >= f0 - 1e-6 && f <= f0 + 1.0 + 1e-6) =>
                {
                    r[0] -= 3.0 * a[0];
                }
                _ => {}
            }
        }
        r
    }

    /// Time-shaped effects at session time t (fraction `frac` of the session) on radii r.
    fn over_time(&self, sc: &Scenario, r: [f64; 2], frac: f64) -> [f64; 2] {
        let mut r = r;
        for tr in &sc.truths {
            let a = [
                tr.strength * self.visit_sd[0],
                tr.strength * self.visit_sd[1],
            ];
            let g = match tr.shape {
                Shape::LinearLoss => -frac,
                Shape::SqrtLoss => -frac.sqrt(),
                Shape::SuddenLoss { at } => {
                    if frac >= at {
                        -1.0
                    } else {
                        0.0
                    }
                }
                Shape::SaturatingGrowth { frac: c } => 1.0 - (-frac / c).exp(),
                _ => continue,
            };
            r[0] += 2.0 * a[0] * g;
            r[1] += 2.0 * a[1] * g;
        }
        r
    }

    /// The transient after a change: the fraction of the step (new - old) still missing at
    /// `since` s, the lab's own approach and the formation shapes.
    fn missing(&self, sc: &Scenario, since: f64) -> f64 {
        let mut m = (-since / self.tau).exp();
        for tr in &sc.truths {
            let k = (0.25 * tr.strength).min(1.0);
            match tr.shape {
                Shape::SlowMode { tau } => m += k * (-since / tau).exp(),
                Shape::Ringing { period, tau } => {
                    m += k * (-since / tau).exp() * (std::f64::consts::TAU * since / period).cos()
                }
                Shape::DeadTime { delay } => {
                    if since < delay * tr.strength.min(3.0) / 3.0 {
                        m = 1.0;
                    } else {
                        m = m.max(k * (-(since - delay) / self.tau).exp());
                    }
                }
                _ => {}
            }
        }
        m
    }

    /// A session over `visits`: CSV with t_s,z_m_mm,f_hz,r1_mm,r2_mm.
    fn run(&self, sc: &Scenario, visits: &[(f64, f64)], seed: u64) -> String {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let rows = match sc.protocol {
            Protocol::GridOnce => 10,
            Protocol::GridTwice => 5,
            Protocol::FarSteps => 8,
        };
        let per_visit = self.settle + rows as f64 * self.dt;
        let total = per_visit * visits.len() as f64;
        let mut s = String::from("t_s,z_m_mm,f_hz,r1_mm,r2_mm\n");
        let mut t = 0.0;
        let mut prev: Option<[f64; 2]> = None;
        for &(z, f) in visits {
            let target = self.steady(sc, z, f);
            let step = prev
                .map(|p| [target[0] - p[0], target[1] - p[1]])
                .unwrap_or([0.0; 2]);
            let off = [
                self.visit_sd[0] * normal(&mut rng),
                self.visit_sd[1] * normal(&mut rng),
            ];
            for k in 0..rows {
                let since = self.settle + k as f64 * self.dt;
                let m = self.missing(sc, since);
                let mut r = [target[0] - m * step[0], target[1] - m * step[1]];
                r = self.over_time(sc, r, (t + since) / total);
                for i in 0..2 {
                    r[i] += off[i] + self.row_sd[i] * normal(&mut rng);
                }
                s.push_str(&format!(
                    "{:.3},{z},{f},{:.4},{:.4}\n",
                    t + since,
                    r[0].max(0.01),
                    r[1].max(0.01)
                ));
            }
            t += per_visit;
            prev = Some(target);
        }
        s
    }
}

/// The benchmark's scenarios from a seed: every effect in at least three foreign shapes at
/// strengths 1, 2, 3 and 5 over the three protocols, null logs, anomalies and two-effect logs.
pub fn scenarios(seed: u64) -> Vec<Scenario> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let mut u = |a: f64, b: f64| a + (b - a) * rng.random::<f64>();
    let protocols = [Protocol::GridOnce, Protocol::GridTwice, Protocol::FarSteps];
    // One draw of each shape's location and time scale per benchmark seed.
    let shapes: Vec<Shape> = vec![
        Shape::BandR2 {
            f0: u(4.5, 6.5).round() + 0.5,
        },
        Shape::DriveRollOff { f0: u(5.0, 7.0) },
        Shape::MovingKnee {
            f0: u(4.0, 6.0),
            slope: u(0.05, 0.15),
        },
        Shape::LinearOnset { z0: u(11.0, 16.0) },
        Shape::ExpOnset {
            z0: u(8.0, 13.0),
            len: u(4.0, 8.0),
        },
        Shape::LogisticOnset {
            z0: u(15.0, 19.0),
            w: u(1.0, 2.5),
        },
        Shape::LinearLoss,
        Shape::SqrtLoss,
        Shape::SuddenLoss { at: u(0.3, 0.7) },
        Shape::SaturatingGrowth { frac: u(0.2, 0.5) },
        Shape::SlowMode { tau: u(5.0, 12.0) },
        Shape::Ringing {
            period: u(3.0, 6.0),
            tau: u(4.0, 10.0),
        },
        Shape::DeadTime { delay: u(3.0, 6.0) },
        Shape::OffAxis {
            offset: u(3.0, 5.0),
        },
        Shape::TiltedAxis {
            offset: u(5.0, 8.0),
        },
        Shape::Eccentric,
    ];
    let mut out = Vec::new();
    let mut id = 0;
    let mut push = |protocol, truths: Vec<Truth>, out: &mut Vec<Scenario>| {
        out.push(Scenario {
            id,
            protocol,
            truths,
            seed: seed.wrapping_mul(1000).wrapping_add(id as u64 * 7919),
        });
        id += 1;
    };
    // Every shape at every strength, the protocol rotating.
    for (k, &shape) in shapes.iter().enumerate() {
        for (j, strength) in [1.0, 2.0, 3.0, 5.0].into_iter().enumerate() {
            let protocol = protocols[(k + j) % 3];
            push(protocol, vec![Truth { shape, strength }], &mut out);
        }
    }
    // Strength 3 once more on the two protocols each shape has not had at 3.
    for (k, &shape) in shapes.iter().enumerate() {
        let p = protocols[(k + 1) % 3];
        push(
            p,
            vec![Truth {
                shape,
                strength: 3.0,
            }],
            &mut out,
        );
    }
    // Strengths 2 and 5 on the protocol each shape has had at neither.
    for (k, &shape) in shapes.iter().enumerate() {
        for (j, strength) in [(1, 2.0), (3, 5.0)] {
            let p = protocols[(k + j + 2) % 3];
            push(p, vec![Truth { shape, strength }], &mut out);
        }
    }
    // Null logs.
    for i in 0..18 {
        push(protocols[i % 3], Vec::new(), &mut out);
    }
    // Anomalies no effect describes.
    let anomalies = [
        Shape::Bump {
            z0: 13.5,
            f0: 5.0,
            n: 3,
        },
        Shape::Bump {
            z0: 8.5,
            f0: 3.5,
            n: 2,
        },
        Shape::Bump {
            z0: 18.5,
            f0: 7.5,
            n: 4,
        },
        Shape::DipR1 { z0: 13.5, f0: 8.0 },
        Shape::Bump {
            z0: 8.5,
            f0: 8.0,
            n: 3,
        },
    ];
    for (i, &shape) in anomalies.iter().enumerate() {
        for strength in [3.0, 5.0, 4.0] {
            push(
                protocols[(i + strength as usize) % 3],
                vec![Truth { shape, strength }],
                &mut out,
            );
        }
    }
    // Two effects in one log.
    let pairs = [
        (
            Shape::SuddenLoss { at: 0.5 },
            Shape::LinearOnset { z0: 14.0 },
        ),
        (Shape::BandR2 { f0: 5.5 }, Shape::LinearLoss),
        (
            Shape::Ringing {
                period: 4.0,
                tau: 6.0,
            },
            Shape::ExpOnset { z0: 10.0, len: 5.0 },
        ),
        (Shape::DriveRollOff { f0: 6.0 }, Shape::SqrtLoss),
        (Shape::SlowMode { tau: 8.0 }, Shape::BandR2 { f0: 4.5 }),
    ];
    for (i, &(a, b)) in pairs.iter().enumerate() {
        for strength in [3.0, 5.0] {
            push(
                protocols[(i + 1) % 2],
                vec![Truth { shape: a, strength }, Truth { shape: b, strength }],
                &mut out,
            );
        }
    }
    // Camera bias: what the radii cannot show (absorbed by the baseline's gains).
    for strength in [2.0, 5.0] {
        push(
            Protocol::GridOnce,
            vec![Truth {
                shape: Shape::CameraScale,
                strength,
            }],
            &mut out,
        );
        push(
            Protocol::GridTwice,
            vec![Truth {
                shape: Shape::CameraOffset,
                strength,
            }],
            &mut out,
        );
        push(
            Protocol::FarSteps,
            vec![Truth {
                shape: Shape::CameraTilt,
                strength,
            }],
            &mut out,
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_set_is_large_deterministic_and_covers_every_effect() {
        let a = scenarios(1);
        let b = scenarios(1);
        assert!(a.len() >= 150, "{}", a.len());
        assert_eq!(a.len(), b.len());
        assert_eq!(a[17].logs(), b[17].logs());
        for e in [
            "phase_lag",
            "cohesion_loss",
            "particle_drift",
            "formation_lag",
            "centroid_offset",
            "camera_bias",
        ] {
            let shapes: std::collections::BTreeSet<String> = a
                .iter()
                .flat_map(|s| s.truths.iter())
                .filter(|t| t.shape.effect() == e)
                .map(|t| t.shape.label())
                .collect();
            assert!(
                shapes.len() >= 3,
                "{e}: at least 3 foreign shapes: {shapes:?}"
            );
        }
        assert!(a.iter().filter(|s| s.truths.is_empty()).count() >= 18);
    }

    #[test]
    fn strength_scales_what_an_effect_does() {
        let mk = |s: f64| Scenario {
            id: 0,
            protocol: Protocol::GridOnce,
            truths: vec![Truth {
                shape: Shape::LinearOnset { z0: 13.5 },
                strength: s,
            }],
            seed: 5,
        };
        let null = Scenario {
            truths: Vec::new(),
            ..mk(1.0)
        };
        let lab = Lab::draw(5);
        let d = |s: &Scenario| lab.steady(s, 23.5, 5.0)[1] - lab.steady(&null, 23.5, 5.0)[1];
        assert!(d(&mk(1.0)) > 0.0);
        assert!((d(&mk(4.0)) / d(&mk(1.0)) - 4.0).abs() < 1e-9);
    }

    #[test]
    fn names_no_item_of_the_models_effect_terms() {
        let src = include_str!("lib.rs");
        for forbidden in [
            "effects::",
            "PhaseLag",
            "CohesionLoss",
            "FormationLag",
            "ParticleDrift",
            "CentroidOffset",
            "CameraBias",
            "learned",
        ] {
            let hits = src.matches(forbidden).count();
            // The list above is the only place the names may appear.
            assert!(hits <= 1, "{forbidden} appears {hits} times");
        }
    }
}
