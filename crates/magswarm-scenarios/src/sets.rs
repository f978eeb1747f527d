//! The two sets of scenarios: the tuning set (three shapes per effect, the set diagnose's
//! choices were made on) and the held-out set (three other shapes per effect, other anomalies
//! and pairs, other draws), each with null logs, anomalies and two-effect logs.

use crate::shape::Shape;
use crate::{Protocol, Scenario, Set, Truth};
use rand::{RngExt, SeedableRng};

const PROTOCOLS: [Protocol; 3] = [Protocol::GridOnce, Protocol::GridTwice, Protocol::FarSteps];

struct Builder {
    seed: u64,
    set: Set,
    out: Vec<Scenario>,
}

impl Builder {
    fn push(&mut self, protocol: Protocol, truths: Vec<Truth>) {
        let id = self.out.len();
        let salt = match self.set {
            Set::Tuning => 0,
            Set::HeldOut => 0x4E1D_0000_0000,
        };
        self.out.push(Scenario {
            id,
            protocol,
            truths,
            seed: self
                .seed
                .wrapping_mul(1000)
                .wrapping_add(id as u64 * 7919)
                .wrapping_add(salt),
            set: self.set,
        });
    }

    fn one(&mut self, protocol: Protocol, shape: Shape, strength: f64) {
        self.push(protocol, vec![Truth { shape, strength }]);
    }

    fn pair(&mut self, protocol: Protocol, shapes: (Shape, Shape), strength: f64) {
        let t = |shape| Truth { shape, strength };
        self.push(protocol, vec![t(shapes.0), t(shapes.1)]);
    }
}

/// The tuning set from a seed (161 scenarios): every effect in three foreign shapes at
/// strengths 1, 2, 3 and 5 over the three protocols, null logs, anomalies, two-effect logs and
/// camera biases the baseline absorbs.
pub fn scenarios(seed: u64) -> Vec<Scenario> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let mut u = |a: f64, b: f64| a + (b - a) * rng.random::<f64>();
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
    let mut b = Builder {
        seed,
        set: Set::Tuning,
        out: Vec::new(),
    };
    // Every shape at every strength, the protocol rotating.
    for (k, &shape) in shapes.iter().enumerate() {
        for (j, strength) in [1.0, 2.0, 3.0, 5.0].into_iter().enumerate() {
            b.one(PROTOCOLS[(k + j) % 3], shape, strength);
        }
    }
    // Strength 3 once more on a protocol each shape has not had at 3.
    for (k, &shape) in shapes.iter().enumerate() {
        b.one(PROTOCOLS[(k + 1) % 3], shape, 3.0);
    }
    // Strengths 2 and 5 on the protocol each shape has had at neither.
    for (k, &shape) in shapes.iter().enumerate() {
        for (j, strength) in [(1, 2.0), (3, 5.0)] {
            b.one(PROTOCOLS[(k + j + 2) % 3], shape, strength);
        }
    }
    for i in 0..18 {
        b.push(PROTOCOLS[i % 3], Vec::new());
    }
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
            b.one(PROTOCOLS[(i + strength as usize) % 3], shape, strength);
        }
    }
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
    for (i, &pair) in pairs.iter().enumerate() {
        for strength in [3.0, 5.0] {
            b.pair(PROTOCOLS[(i + 1) % 2], pair, strength);
        }
    }
    camera(&mut b);
    b.out
}

/// Camera biases: a scale, an offset, a tilt, at two sizes (nominal amplitudes: what the
/// baseline's gains absorb; a right diagnosis names nothing else).
fn camera(b: &mut Builder) {
    for strength in [2.0, 5.0] {
        b.one(Protocol::GridOnce, Shape::CameraScale, strength);
        b.one(Protocol::GridTwice, Shape::CameraOffset, strength);
        b.one(Protocol::FarSteps, Shape::CameraTilt, strength);
    }
}

/// The held-out set from a seed: three other foreign shapes per effect at strengths 1 to 5
/// over the three protocols, null logs, other anomalies, other pairs, camera biases, all with
/// other draws and other withheld operating points.
pub fn heldout(seed: u64) -> Vec<Scenario> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed ^ 0x4E1D);
    let mut u = |a: f64, b: f64| a + (b - a) * rng.random::<f64>();
    let shapes: Vec<Shape> = vec![
        Shape::StepAbove { f0: u(4.5, 7.5) },
        Shape::SlidingBand {
            f0: u(4.5, 6.5),
            slope: u(-0.15, 0.15),
        },
        Shape::Retrograde { f0: u(4.5, 6.5) },
        Shape::QuadOnset { z0: u(9.0, 14.0) },
        Shape::R2Onset { z0: u(14.0, 19.0) },
        Shape::OnsetWithF { z0: u(10.0, 16.0) },
        Shape::TwoStepLoss,
        Shape::LateLinearLoss { at: u(0.2, 0.6) },
        Shape::AcceleratingGrowth,
        Shape::Stalled { stall: u(5.0, 9.0) },
        Shape::Overshoot { tau: u(2.0, 5.0) },
        Shape::SlowGrowth { tau: u(5.0, 10.0) },
        Shape::UnevenDrive { rho: u(4.0, 8.0) },
        Shape::CurvatureSplit { rho: u(4.0, 8.0) },
        Shape::OrbitWithF { rho: u(4.0, 8.0) },
    ];
    let mut b = Builder {
        seed,
        set: Set::HeldOut,
        out: Vec::new(),
    };
    for (k, &shape) in shapes.iter().enumerate() {
        for (j, strength) in [1.0, 2.0, 3.0, 4.0, 5.0].into_iter().enumerate() {
            b.one(PROTOCOLS[(k + j) % 3], shape, strength);
        }
        for (j, strength) in [(1, 2.5), (2, 3.5)] {
            b.one(PROTOCOLS[(k + j + 1) % 3], shape, strength);
        }
    }
    for i in 0..15 {
        b.push(PROTOCOLS[i % 3], Vec::new());
    }
    let anomalies = [
        Shape::Patch { z0: 8.5, f0: 6.0 },
        Shape::SpikeR2 { z0: 18.5, f0: 3.0 },
        Shape::Bump {
            z0: 13.5,
            f0: 8.0,
            n: 3,
        },
        Shape::Patch { z0: 13.5, f0: 2.0 },
    ];
    for (i, &shape) in anomalies.iter().enumerate() {
        for strength in [3.0, 4.0, 5.0] {
            b.one(PROTOCOLS[(i + strength as usize) % 3], shape, strength);
        }
    }
    let pairs = [
        (Shape::TwoStepLoss, Shape::QuadOnset { z0: 12.0 }),
        (
            Shape::StepAbove { f0: 6.0 },
            Shape::LateLinearLoss { at: 0.4 },
        ),
        (Shape::Overshoot { tau: 3.0 }, Shape::R2Onset { z0: 16.0 }),
        (
            Shape::SlidingBand {
                f0: 5.0,
                slope: 0.1,
            },
            Shape::Stalled { stall: 6.0 },
        ),
        (Shape::AcceleratingGrowth, Shape::OnsetWithF { z0: 13.0 }),
    ];
    for (i, &pair) in pairs.iter().enumerate() {
        for strength in [3.0, 4.0] {
            b.pair(PROTOCOLS[(i + strength as usize) % 3], pair, strength);
        }
    }
    camera(&mut b);
    b.out
}
