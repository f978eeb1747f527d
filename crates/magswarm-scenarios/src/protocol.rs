//! How the operating points are visited: the seed's grid once or twice, far-apart setpoint
//! steps, and the withheld log's points between the grid's.

use crate::lab::Plan;
use crate::{GRID_F, GRID_Z};
use rand::{seq::SliceRandom, RngExt, SeedableRng};

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

    /// Rows per visit.
    pub fn rows(self) -> usize {
        match self {
            Protocol::GridOnce => 10,
            Protocol::GridTwice => 5,
            Protocol::FarSteps => 8,
        }
    }

    /// The training plan, visiting order drawn from `seed`.
    pub(crate) fn plan(self, seed: u64) -> Plan {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let grid: Vec<(f64, f64)> = GRID_Z
            .iter()
            .flat_map(|&z| GRID_F.iter().map(move |&f| (z, f)))
            .collect();
        let visits = match self {
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
        };
        Plan {
            visits,
            rows: self.rows(),
        }
    }

    /// The withheld plan: operating points between the grid's (`zs` x `fs`), shuffled.
    pub(crate) fn withheld(self, zs: &[f64], fs: &[f64], seed: u64) -> Plan {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let mut visits: Vec<(f64, f64)> = zs
            .iter()
            .flat_map(|&z| fs.iter().map(move |&f| (z, f)))
            .collect();
        visits.shuffle(&mut rng);
        Plan {
            visits,
            rows: self.rows(),
        }
    }
}
