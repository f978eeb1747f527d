//! The foreign shapes: each unmodelled effect written here from its physical description, in
//! forms that are neither the library's parametric terms nor the piecewise-linear tables
//! diagnose learns. A shape acts with an *amplitude* `x` in its own natural unit (a multiple
//! of the lab's visit noise for the shapes that add millimetres, an offset or a share for the
//! others); [`crate::strength`] finds the amplitude at which the part of the shape that the
//! baseline cannot absorb reaches the scenario's strength.

use crate::GRID_F;
use crate::GRID_Z;

/// A foreign shape of an effect (or an anomaly no effect describes).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    // ---- phase_lag: over f, near the step-out ----
    /// A band of r2 around `f0` \[Hz\] at every z_m (Gaussian in f).
    BandR2 { f0: f64 },
    /// A tanh roll-off of the drive above `f0` \[Hz\]: both radii grow in proportion.
    DriveRollOff { f0: f64 },
    /// A step-out whose onset moves with distance: above `f0 + slope (z - 3.5)` the radii
    /// grow linearly with the excess frequency.
    MovingKnee { f0: f64, slope: f64 },
    /// (held out) A logistic step of both radii above `f0` \[Hz\] (the rotation reverses).
    StepAbove { f0: f64 },
    /// (held out) A Lorentzian band of both radii centred at `f0 + slope (z - 13.5)`.
    SlidingBand { f0: f64, slope: f64 },
    /// (held out) The retrograde transition at `f0`: the radii dip just below it and rise
    /// just above it (a derivative of a Gaussian in f), r2 more than r1.
    Retrograde { f0: f64 },
    // ---- cohesion_loss: growing with z_m past an onset ----
    /// Radii growing past `z0` \[mm\] linearly.
    LinearOnset { z0: f64 },
    /// Radii growing past `z0` exponentially (length `len` mm).
    ExpOnset { z0: f64, len: f64 },
    /// A smooth logistic onset around `z0` (width `w` mm), r2 twice r1.
    LogisticOnset { z0: f64, w: f64 },
    /// (held out) Radii growing as the square of the distance past `z0`.
    QuadOnset { z0: f64 },
    /// (held out) Only r2 grows, in a logistic step around `z0` (fragmentation along the
    /// chains).
    R2Onset { z0: f64 },
    /// (held out) A linear onset past `z0` that is stronger at high f.
    OnsetWithF { z0: f64 },
    // ---- particle_drift: over session time ----
    /// Radii shrinking linearly over the session.
    LinearLoss,
    /// Radii shrinking as the square root of session time.
    SqrtLoss,
    /// A sudden loss at a fraction `at` of the session.
    SuddenLoss { at: f64 },
    /// Growth (clumping) saturating with time constant `frac` of the session.
    SaturatingGrowth { frac: f64 },
    /// (held out) Two sudden losses, at a third and at two thirds of the session.
    TwoStepLoss,
    /// (held out) Nothing until `at`, then a linear loss.
    LateLinearLoss { at: f64 },
    /// (held out) Growth that accelerates (clumping feeding on itself).
    AcceleratingGrowth,
    // ---- formation_lag: over the time since an input change ----
    /// A slow first-order formation mode (time constant `tau` s) on top of the fast one.
    SlowMode { tau: f64 },
    /// An underdamped formation: ringing with period `period` s, decaying over `tau` s.
    Ringing { period: f64, tau: f64 },
    /// A dead time before the swarm responds to a change (`delay` s at amplitude 3).
    DeadTime { delay: f64 },
    /// (held out) A formation that stalls halfway (a share of the swarm waits, vortices
    /// merging) until `stall` s after the change, then completes at the rig's own pace.
    Stalled { stall: f64 },
    /// (held out) An overshoot past the new target that relaxes over `tau` s.
    Overshoot { tau: f64 },
    /// (held out) A slow mode only when the swarm grows (hysteresis: it shrinks fast).
    SlowGrowth { tau: f64 },
    // ---- centroid_offset: the swarm off the field axis ----
    /// The swarm `offset` mm off the axis at every depth (at amplitude 1): it sees the field
    /// of a larger distance (sqrt(d^2 + offset^2)).
    OffAxis { offset: f64 },
    /// An axis that is tilted: the offset grows with depth, `offset` mm at the largest z_m.
    TiltedAxis { offset: f64 },
    /// An eccentric swarm: off the axis it is stretched along the field lines and squeezed
    /// across them, the more the weaker the field (r2 up, r1 down, growing with z_m).
    Eccentric,
    /// (held out) Off the axis by `rho` mm the field's rotation plane is tilted at the swarm:
    /// driven unevenly over a turn, the faster it turns the more r1 grows and r2 shrinks, in
    /// proportion to (rho/d)^2.
    UnevenDrive { rho: f64 },
    /// (held out) Off the axis by `rho` mm the curvature splits: r1 squeezed and r2
    /// stretched in proportion to (rho/d)^2.
    CurvatureSplit { rho: f64 },
    /// (held out) The swarm orbits further out the faster the field turns: `rho` mm at 10 Hz.
    OrbitWithF { rho: f64 },
    // ---- camera_bias: what the radii cannot show apart from the rig's gains ----
    /// The camera's scale (1 + 0.02 x) on both radii.
    CameraScale,
    /// An offset of both radii in the image.
    CameraOffset,
    /// An image plane tilted about the r1 axis: r2 foreshortened by cos(tilt).
    CameraTilt,
    // ---- anomalies no effect describes ----
    /// A local bump at `n` neighbouring grid points around (z0, f0), both radii.
    Bump { z0: f64, f0: f64, n: usize },
    /// A local dip of r1 only at two neighbouring frequencies.
    DipR1 { z0: f64, f0: f64 },
    /// (held out) A patch of 2 x 2 grid points (z0 and the next z level, f0 and f0 + 1).
    Patch { z0: f64, f0: f64 },
    /// (held out) A spike of r2 only at three neighbouring frequencies.
    SpikeR2 { z0: f64, f0: f64 },
}

/// Effect names, as diagnose reports them.
pub const EFFECTS: [&str; 6] = [
    "phase_lag",
    "cohesion_loss",
    "formation_lag",
    "particle_drift",
    "centroid_offset",
    "camera_bias",
];

/// What a shape does at one operating point, given the rig's map there (`base`), the rig's
/// map at another point (`map`), the distance from the magnet's centre to the swarm plane
/// `d` \[mm\] and the lab's visit noise per axis `sd` \[mm\].
pub(crate) struct At<'a> {
    pub z: f64,
    pub f: f64,
    pub d: f64,
    pub base: [f64; 2],
    pub sd: [f64; 2],
    pub map: &'a dyn Fn(f64, f64) -> [f64; 2],
}

fn bump(x: f64, c: f64, w: f64) -> f64 {
    (-(x - c) * (x - c) / (2.0 * w * w)).exp()
}

fn logistic(u: f64) -> f64 {
    1.0 / (1.0 + (-u).exp())
}

impl Shape {
    /// The effect the shape belongs to ("anomaly" for shapes no effect describes).
    pub fn effect(self) -> &'static str {
        use Shape::*;
        match self {
            BandR2 { .. }
            | DriveRollOff { .. }
            | MovingKnee { .. }
            | StepAbove { .. }
            | SlidingBand { .. }
            | Retrograde { .. } => EFFECTS[0],
            LinearOnset { .. }
            | ExpOnset { .. }
            | LogisticOnset { .. }
            | QuadOnset { .. }
            | R2Onset { .. }
            | OnsetWithF { .. } => EFFECTS[1],
            SlowMode { .. }
            | Ringing { .. }
            | DeadTime { .. }
            | Stalled { .. }
            | Overshoot { .. }
            | SlowGrowth { .. } => EFFECTS[2],
            LinearLoss
            | SqrtLoss
            | SuddenLoss { .. }
            | SaturatingGrowth { .. }
            | TwoStepLoss
            | LateLinearLoss { .. }
            | AcceleratingGrowth => EFFECTS[3],
            OffAxis { .. }
            | TiltedAxis { .. }
            | Eccentric
            | UnevenDrive { .. }
            | CurvatureSplit { .. }
            | OrbitWithF { .. } => EFFECTS[4],
            CameraScale | CameraOffset | CameraTilt => EFFECTS[5],
            Bump { .. } | DipR1 { .. } | Patch { .. } | SpikeR2 { .. } => "anomaly",
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
        use Shape::*;
        let all_z = (GRID_Z[0], GRID_Z[4]);
        let all_f = (GRID_F[0], GRID_F[9]);
        match self {
            BandR2 { f0 } => Some((all_z, (f0 - 1.0, f0 + 1.0))),
            DriveRollOff { f0 } | MovingKnee { f0, .. } | StepAbove { f0 } => {
                Some((all_z, (f0, 10.0)))
            }
            Retrograde { f0 } => Some((all_z, (f0 - 1.5, f0 + 1.5))),
            SlidingBand { f0, slope } => {
                let (a, b) = (f0 - 10.0 * slope.abs(), f0 + 10.0 * slope.abs());
                Some((all_z, (a - 1.0, b + 1.0)))
            }
            LinearOnset { z0 } | ExpOnset { z0, .. } | QuadOnset { z0 } | OnsetWithF { z0 } => {
                Some(((z0, 23.5), all_f))
            }
            LogisticOnset { z0, .. } | R2Onset { z0 } => Some(((z0 - 2.5, 23.5), all_f)),
            OffAxis { .. }
            | TiltedAxis { .. }
            | Eccentric
            | UnevenDrive { .. }
            | CurvatureSplit { .. }
            | OrbitWithF { .. } => Some((all_z, all_f)),
            Bump { z0, f0, .. } => Some(((z0, z0), (f0 - 1.0, f0 + 1.0))),
            DipR1 { z0, f0 } => Some(((z0, z0), (f0, f0 + 1.0))),
            Patch { z0, f0 } => Some(((z0, z0 + 5.0), (f0, f0 + 1.0))),
            SpikeR2 { z0, f0 } => Some(((z0, z0), (f0 - 1.0, f0 + 1.0))),
            _ => None,
        }
    }

    /// Largest amplitude the physics allows (an offset of 20 mm, a full share, a tilt of 35
    /// degrees); shapes that add millimetres are bounded only by the search.
    pub(crate) fn max_amplitude(self) -> f64 {
        use Shape::*;
        match self {
            OffAxis { offset } | TiltedAxis { offset } => 20.0 / offset,
            UnevenDrive { rho } | CurvatureSplit { rho } | OrbitWithF { rho } => 20.0 / rho,
            SlowMode { .. }
            | Ringing { .. }
            | Stalled { .. }
            | Overshoot { .. }
            | SlowGrowth { .. } => 4.0,
            DeadTime { .. } => 3.0,
            CameraScale => 10.0,
            CameraTilt => 7.5,
            Eccentric => 12.0,
            _ => 25.0,
        }
    }

    /// The steady radii at one operating point with this shape at amplitude `x`, from `r`.
    pub(crate) fn steady(self, x: f64, at: &At, r: [f64; 2]) -> [f64; 2] {
        use Shape::*;
        let mut r = r;
        let a = [x * at.sd[0], x * at.sd[1]];
        let (z, f, base) = (at.z, at.f, at.base);
        let shift = |r: &mut [f64; 2], far: [f64; 2]| {
            for i in 0..2 {
                r[i] += far[i] - base[i];
            }
        };
        match self {
            BandR2 { f0 } => r[1] += 1.6 * a[1] * bump(f, f0, 0.6),
            DriveRollOff { f0 } => {
                let g = 0.5 * (1.0 + ((f - f0) / 0.8).tanh());
                for i in 0..2 {
                    r[i] += 1.5 * a[i] * g * base[i] / 10.0;
                }
            }
            MovingKnee { f0, slope } => {
                let on = f0 + slope * (z - 3.5);
                let u = ((f - on) / (10.0 - on).max(1.0)).max(0.0);
                r[0] += 1.5 * a[0] * u;
                r[1] += 1.5 * a[1] * u;
            }
            StepAbove { f0 } => {
                let g = logistic((f - f0) / 0.3);
                r[0] += a[0] * g;
                r[1] += 1.5 * a[1] * g;
            }
            SlidingBand { f0, slope } => {
                let c = f0 + slope * (z - 13.5);
                let g = 1.0 / (1.0 + ((f - c) / 0.8).powi(2));
                r[0] += 0.6 * a[0] * g;
                r[1] += 1.2 * a[1] * g;
            }
            Retrograde { f0 } => {
                let u = (f - f0) / 0.8;
                let g = 1.65 * u * (-0.5 * u * u).exp();
                r[0] += 0.7 * a[0] * g;
                r[1] += 1.4 * a[1] * g;
            }
            LinearOnset { z0 } => {
                let u = ((z - z0) / (23.5 - z0)).max(0.0);
                r[0] += 2.0 * a[0] * u;
                r[1] += 2.0 * a[1] * u;
            }
            ExpOnset { z0, len } => {
                let u = ((z - z0).max(0.0) / len).exp_m1() / ((23.5 - z0) / len).exp_m1();
                r[0] += 2.0 * a[0] * u;
                r[1] += 2.0 * a[1] * u;
            }
            LogisticOnset { z0, w } => {
                let u = logistic((z - z0) / w);
                r[0] += a[0] * u;
                r[1] += 2.0 * a[1] * u;
            }
            QuadOnset { z0 } => {
                let u = ((z - z0) / (23.5 - z0)).max(0.0).powi(2);
                r[0] += a[0] * u;
                r[1] += 2.0 * a[1] * u;
            }
            R2Onset { z0 } => r[1] += 2.0 * a[1] * logistic((z - z0) / 1.5),
            OnsetWithF { z0 } => {
                let u = ((z - z0) / (23.5 - z0)).max(0.0) * (0.5 + f / 10.0);
                r[0] += a[0] * u;
                r[1] += 1.5 * a[1] * u;
            }
            OffAxis { offset } | TiltedAxis { offset } => {
                let off = match self {
                    TiltedAxis { .. } => offset * (z - 3.5) / 20.0,
                    _ => offset,
                } * x;
                // The distance from the magnet's centre grows to sqrt(d^2 + off^2): the swarm
                // sees the field of a larger z_m.
                let dz = (at.d * at.d + off * off).sqrt() - at.d;
                shift(&mut r, (at.map)(z + dz, f));
            }
            OrbitWithF { rho } => {
                let off = rho * x * f / 10.0;
                let dz = (at.d * at.d + off * off).sqrt() - at.d;
                shift(&mut r, (at.map)(z + dz, f));
            }
            UnevenDrive { rho } => {
                let u = 3.0 * (rho * x / at.d).powi(2) * f / 10.0;
                r[0] *= 1.0 + u;
                r[1] *= 1.0 - 0.5 * u;
            }
            CurvatureSplit { rho } => {
                let u = 2.0 * (rho * x / at.d).powi(2);
                r[0] *= 1.0 - 0.5 * u;
                r[1] *= 1.0 + u;
            }
            Eccentric => {
                let g = ((z - 3.5) / 20.0).clamp(0.0, 1.0).powf(1.5);
                r[0] -= 1.5 * a[0] * g;
                r[1] += 2.0 * a[1] * g;
            }
            CameraTilt => r[1] *= (0.08 * x).min(0.6).cos(),
            CameraScale => {
                let eps = 0.02 * x;
                r = [r[0] * (1.0 + eps), r[1] * (1.0 + eps)];
            }
            CameraOffset => r = [r[0] + 0.5 * a[0], r[1] + 0.5 * a[0]],
            Bump { z0, f0, n } => {
                let near = (z - z0).abs() < 1e-6 && (f - f0).abs() <= 0.5 * (n as f64 - 1.0) + 1e-6;
                if near {
                    r[0] += 2.0 * a[0];
                    r[1] += 2.0 * a[1];
                }
            }
            DipR1 { z0, f0 } if (z - z0).abs() < 1e-6 && f >= f0 - 1e-6 && f <= f0 + 1.0 + 1e-6 => {
                r[0] -= 3.0 * a[0];
            }
            Patch { z0, f0 }
                if z >= z0 - 1e-6
                    && z <= z0 + 5.0 + 1e-6
                    && f >= f0 - 1e-6
                    && f <= f0 + 1.0 + 1e-6 =>
            {
                r[0] += 1.5 * a[0];
                r[1] += 1.5 * a[1];
            }
            SpikeR2 { z0, f0 } if (z - z0).abs() < 1e-6 && (f - f0).abs() <= 1.0 + 1e-6 => {
                r[1] += 2.0 * a[1];
            }
            _ => {}
        }
        r
    }

    /// The change over session time at a fraction `frac` of the session, in units of the
    /// amplitude (None for shapes that do not act over session time).
    pub(crate) fn over_time(self, frac: f64) -> Option<f64> {
        use Shape::*;
        Some(match self {
            LinearLoss => -frac,
            SqrtLoss => -frac.sqrt(),
            SuddenLoss { at } => {
                if frac >= at {
                    -1.0
                } else {
                    0.0
                }
            }
            SaturatingGrowth { frac: c } => 1.0 - (-frac / c).exp(),
            TwoStepLoss => {
                -0.5 * (f64::from(u8::from(frac >= 1.0 / 3.0))
                    + f64::from(u8::from(frac >= 2.0 / 3.0)))
            }
            LateLinearLoss { at } => -((frac - at) / (1.0 - at)).max(0.0),
            AcceleratingGrowth => (2.0 * frac).exp_m1() / 2f64.exp_m1(),
            _ => return None,
        })
    }

    /// What the shape adds to the share of an input change's step (per axis, `step` \[mm\])
    /// still missing at `since` s after it, given the lab's own share `own` and time constant
    /// `tau` \[s\]; None for shapes that do not act on transients.
    pub(crate) fn missing(
        self,
        x: f64,
        since: f64,
        own: f64,
        tau: f64,
        step: [f64; 2],
    ) -> Option<[f64; 2]> {
        use Shape::*;
        let k = (0.25 * x).min(1.0);
        let both = |v: f64| Some([v, v]);
        match self {
            SlowMode { tau: t } => both(k * (-since / t).exp()),
            Ringing { period, tau: t } => {
                both(k * (-since / t).exp() * (std::f64::consts::TAU * since / period).cos())
            }
            DeadTime { delay } => {
                // The lab's own approach, started `dead` s late.
                let dead = delay * x / 3.0;
                let late = if since < dead {
                    1.0
                } else {
                    (-(since - dead) / tau).exp()
                };
                both(late - own)
            }
            Stalled { stall } => {
                let held = if since < stall {
                    own.max(0.5)
                } else {
                    0.5 * (-(since - stall) / tau).exp()
                };
                both(k * (held - own))
            }
            Overshoot { tau: t } => {
                let u = since / t;
                both(-k * u * (1.0 - u).exp())
            }
            SlowGrowth { tau: t } => {
                let slow = k * (-since / t).exp();
                Some([0, 1].map(|i| if step[i] > 0.0 { slow } else { 0.0 }))
            }
            _ => None,
        }
    }
}
