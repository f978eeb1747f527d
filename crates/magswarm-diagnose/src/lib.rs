//! `magswarm diagnose`: the sim-to-real gap report. Where the gap between the model and a
//! measured log lies, which unmodelled effect causes it, and how far it shrinks once that
//! effect is added, checked on data the fits never saw.
//!
//! The procedure (each step in its module):
//!
//! 1. **Baseline**: the model without effects, fitted by identify (steady map; ODE time
//!    scales where the log holds transients) on the training log.
//! 2. **Is there a gap** ([`gap`]): lack of fit against the pure error of the repeats, and
//!    residual structure over the inputs, over session time and after input changes, by
//!    permutation and paired tests with the visit as the unit, calibrated by simulated logs
//!    ([`detect`]). The candidates of step 4 are scored on the same simulated logs, and the gap
//!    is declared when the tests' smallest p or the candidate that would be named, each
//!    adjusted over the tests and the candidates together (a weighted min-p), reaches alpha.
//!    No significant gap: nothing is accepted.
//! 3. **Where** ([`gap::localise`]): regions as ranges of z_m, f and time, with
//!    Benjamini-Hochberg control over the boxes searched.
//! 4. **Which effect** ([`attribute`]): each candidate ([`candidates`]) refitted with the
//!    baseline on training folds grouped by visit; accepted by withheld-likelihood gain over a
//!    BIC penalty, a paired test, plausible parameters and a matching residual signature;
//!    forward selection for several effects; ambiguity reported, never resolved silently.
//! 5. **What stays unexplained**: significant regions no accepted effect explains, with a
//!    Gaussian-process discrepancy over the inputs ([`gp`]) and the share of the withheld
//!    error there it recovers.
//! 6. **How far it shrinks**: baseline and augmented RMSE per axis on withheld visits (grouped
//!    cross-validation) and on the `--withheld` log, against the pure-error floor.
//!
//! Outputs ([`report`]): `DIR/report.json`, `DIR/baseline.json`, `DIR/augmented.json`,
//! `DIR/report.md` with its figures.

pub mod attribute;
pub mod candidates;
pub mod data;
pub mod detect;
pub mod error;
pub mod fitter;
pub mod gap;
pub mod gp;
pub mod learned;
pub mod linear;
pub mod noise;
pub mod report;
pub mod shapes;
pub mod stats;

use candidates::{Augmented, Ctx};
use data::{Dataset, PureError};
pub use error::DiagnoseError;
use magswarm_identify::{self as identify, data::SettleRule, Progress, Silent};
use magswarm_log::Log;
use magswarm_model::Model;
use std::collections::BTreeMap;
use std::time::{Duration, Instant};

/// Level of the one-sided test that flags an augmented model predicting the withheld log
/// worse than the baseline (a caution for the reader, not a decision: the conventional 5 %).
pub const WORSE_ALPHA: f64 = 0.05;

/// Library face of the flags.
#[derive(Debug, Clone)]
pub struct Config {
    /// Significance level.
    pub alpha: f64,
    /// Folds.
    pub folds: usize,
    /// Seed.
    pub seed: u64,
    /// Most effects accepted together.
    pub max_effects: usize,
    /// Bootstrap replicates (simulated logs) that calibrate the gap tests and the acceptance.
    pub boot: usize,
    /// Steady parameters held at the prior's values in the baseline (removed from identify's
    /// default free set): a log that cannot tell them apart (a single distance, a single
    /// frequency) is diagnosed with them held, as identify is with `--fix`.
    pub fix: Vec<String>,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            alpha: 0.01,
            folds: 5,
            seed: 1,
            max_effects: 3,
            boot: 499,
            fix: Vec::new(),
        }
    }
}

/// Errors of a model on a set of rows, per axis \[mm\].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rmse {
    /// RMSE per axis \[mm\].
    pub rmse: [f64; 2],
    /// Rows.
    pub n: usize,
}

fn rmse(ds: &Dataset, pred: &[[f64; 2]]) -> Rmse {
    let mut s = [0.0; 2];
    for (r, p) in ds.rows.iter().zip(pred) {
        for a in 0..2 {
            s[a] += (r.r[a] - p[a]).powi(2);
        }
    }
    let n = ds.rows.len().max(1) as f64;
    Rmse {
        rmse: [(s[0] / n).sqrt(), (s[1] / n).sqrt()],
        n: ds.rows.len(),
    }
}

/// A region no accepted effect explains.
#[derive(Debug, Clone, PartialEq)]
pub struct Unexplained {
    /// The region (as localised on the baseline).
    pub region: gap::Region,
    /// Its mean residual under the augmented model \[mm\].
    pub mean_after: f64,
    /// Share of the withheld error there that the discrepancy recovers (None: not applicable).
    pub heldout_shrink: Option<f64>,
}

/// Validation on the `--withheld` log.
#[derive(Debug, Clone)]
pub struct Withheld {
    /// Name.
    pub source: String,
    /// RMSE of the baseline as written (baseline.json, identify's model).
    pub baseline: Rmse,
    /// RMSE of the augmented model as written (augmented.json).
    pub augmented: Rmse,
    /// Per valid row: its line in the file and the baseline's and the augmented model's
    /// radii there \[mm\].
    pub rows: Vec<(usize, [f64; 2], [f64; 2])>,
    /// Visits of the withheld log the comparison is paired over.
    pub visits: usize,
    /// One-sided p that the augmented model predicts the withheld log worse than the
    /// baseline: a t test over its visits of the difference of their squared errors (both
    /// radii, each in units of the training floor). A visit's offset is shared by its rows,
    /// so a handful of visits can make either model look better by chance: the visits are the
    /// independent units (1 with fewer than 3 visits: too few to tell).
    pub worse_p: f64,
}

impl Withheld {
    /// Whether the augmented model's error on the withheld log is higher than the baseline's
    /// (both radii's MSE together), beyond chance or not ([`Withheld::worse_p`]).
    pub fn augmented_higher(&self) -> bool {
        let ms = |r: [f64; 2]| r[0] * r[0] + r[1] * r[1];
        ms(self.augmented.rmse) > ms(self.baseline.rmse)
    }
}

/// One-sided p that predictions `pa` fit the rows of `ds` worse than `pb`, paired over visits
/// (squared errors per axis in units of `floor`).
fn worse_p(ds: &Dataset, pb: &[[f64; 2]], pa: &[[f64; 2]], floor: [f64; 2]) -> (usize, f64) {
    let mut by_visit: BTreeMap<usize, f64> = BTreeMap::new();
    for ((r, b), a) in ds.rows.iter().zip(pb).zip(pa) {
        let d: f64 = (0..2)
            .map(|ax| {
                let s2 = floor[ax].powi(2).max(1e-12);
                ((r.r[ax] - a[ax]).powi(2) - (r.r[ax] - b[ax]).powi(2)) / s2
            })
            .filter(|v| v.is_finite())
            .sum();
        *by_visit.entry(r.visit).or_insert(0.0) += d;
    }
    let d: Vec<f64> = by_visit.into_values().collect();
    let (m, t, _) = stats::one_sample_t(&d);
    let p = if d.len() < 3 || m <= 0.0 {
        1.0
    } else {
        stats::t_sf(t, (d.len() - 1) as f64)
    };
    (d.len(), p)
}

/// Everything a diagnosis produced.
#[derive(Debug, Clone)]
pub struct Diagnosis {
    /// Input log names.
    pub sources: Vec<String>,
    /// The baseline identification.
    pub ident: identify::Identification,
    /// Training data.
    pub ds: Dataset,
    /// Context of the effects.
    pub ctx: Ctx,
    /// Pure error.
    pub pe: PureError,
    /// Row SD of the pure error around the augmented model: the noise floor \[mm\].
    pub floor: [f64; 2],
    /// Pure error around the augmented model (repeat visits compared after its effects).
    pub pe_aug: PureError,
    /// Family tests.
    pub tests: gap::GapTests,
    /// The bootstrap-calibrated gap tests on the baseline.
    pub detection: detect::Detection,
    /// The noise levels the tests and the simulations use.
    pub noise: noise::Noise,
    /// Regions.
    pub regions: Vec<gap::Region>,
    /// Baseline steady map at the points.
    pub base_map: Vec<[f64; 2]>,
    /// Attribution.
    pub attr: attribute::Attribution,
    /// Unexplained regions.
    pub unexplained: Vec<Unexplained>,
    /// Withheld log.
    pub withheld: Option<Withheld>,
    /// Wall time.
    pub elapsed: Duration,
    /// Settings.
    pub cfg: Config,
}

impl Diagnosis {
    /// Row-level RMSE (train, withheld-by-CV) of the baseline and the augmented model.
    pub fn rmse_table(&self) -> [(Rmse, Rmse); 2] {
        [
            (
                rmse(&self.ds, &self.attr.baseline.pred),
                rmse(&self.ds, &self.attr.baseline.cv),
            ),
            (
                rmse(&self.ds, &self.attr.augmented.pred),
                rmse(&self.ds, &self.attr.augmented.cv),
            ),
        ]
    }

    /// Whether the augmented model predicts the withheld log worse than the baseline, beyond
    /// what the withheld log's own visit offsets make of chance (paired over its visits, at
    /// [`WORSE_ALPHA`]); None without a withheld log or without a named effect. The withheld
    /// log is the one test the naming never saw: a reader must hear of this first.
    pub fn worse_on_withheld_log(&self) -> Option<bool> {
        let x = self
            .withheld
            .as_ref()
            .filter(|_| !self.attr.accepted.is_empty())?;
        Some(x.worse_p <= WORSE_ALPHA)
    }

    /// Share of the withheld excess MSE over the floor that the augmented model removes, per
    /// axis and for both axes together (None where the baseline has no excess).
    pub fn excess_removed(&self) -> [Option<f64>; 3] {
        let t = self.rmse_table();
        let (b, a) = (t[0].1.rmse, t[1].1.rmse);
        let f = self.floor;
        let one = |b: f64, a: f64, f: f64| {
            let eb = b * b - f * f;
            (eb > 0.05 * f * f).then(|| 1.0 - (a * a - f * f) / eb)
        };
        let both = {
            let eb = b[0] * b[0] + b[1] * b[1] - f[0] * f[0] - f[1] * f[1];
            let ea = a[0] * a[0] + a[1] * a[1] - f[0] * f[0] - f[1] * f[1];
            (eb > 0.05 * (f[0] * f[0] + f[1] * f[1])).then(|| 1.0 - ea / eb)
        };
        [one(b[0], a[0], f[0]), one(b[1], a[1], f[1]), both]
    }
}

/// Refuse a log that cannot support a diagnosis, naming what is missing.
fn check_usable(ds: &Dataset, source: &str) -> Result<(), DiagnoseError> {
    let (zs, fs) = ds.levels();
    let source_name = source.to_string();
    if ds.points.len() < 6 {
        return Err(DiagnoseError::TooFewPoints {
            source_name,
            points: ds.points.len(),
        });
    }
    if fs.len() < 2 {
        return Err(DiagnoseError::OneFrequency {
            source_name,
            f_hz: fs[0],
        });
    }
    if zs.len() < 2 {
        return Err(DiagnoseError::OneDistance {
            source_name,
            z_mm: zs[0],
        });
    }
    Ok(())
}

/// The log's own refusals that no baseline can lift, said before the baseline is fitted: a
/// log at one distance or one frequency cannot show an effect along it, whatever parameters
/// identify is told to hold (its own refusal would only say which to fix).
fn check_levels(log: &Log) -> Result<(), DiagnoseError> {
    let valid = || log.rows.iter().filter(|r| r.valid);
    let one = |x: &dyn Fn(&magswarm_log::LogRow) -> f64| {
        let mut v = valid().map(x).filter(|x| x.is_finite());
        let first = v.next()?;
        v.all(|y| (y - first).abs() < 1e-9).then_some(first)
    };
    let source_name = log.source.clone();
    if let Some(f_hz) = one(&|r| r.f_hz) {
        return Err(DiagnoseError::OneFrequency { source_name, f_hz });
    }
    if let Some(z_mm) = one(&|r| r.z_m_mm) {
        return Err(DiagnoseError::OneDistance { source_name, z_mm });
    }
    Ok(())
}

/// Diagnose a log (and validate on `withheld`).
pub fn diagnose(
    log: &Log,
    withheld: Option<&Log>,
    prior: &Model,
    cfg: &Config,
) -> Result<Diagnosis, DiagnoseError> {
    diagnose_with_progress(log, withheld, prior, cfg, &Silent)
}

/// [`diagnose`], reporting its stages and steps to `pb` (the program draws them: a progress
/// bar on a terminal).
pub fn diagnose_with_progress(
    log: &Log,
    withheld: Option<&Log>,
    prior: &Model,
    cfg: &Config,
    pb: &dyn Progress,
) -> Result<Diagnosis, DiagnoseError> {
    let t0 = Instant::now();
    // The arguments first: a parameter to hold that the baseline does not fit.
    let mut icfg = identify::Config {
        starts: 4,
        bootstrap: 0,
        seed: cfg.seed,
        ..identify::Config::default()
    };
    if let Some(name) = cfg.fix.iter().find(|n| !icfg.free.contains(n)) {
        return Err(DiagnoseError::NotFree {
            name: name.clone(),
            free: icfg.free,
        });
    }
    icfg.free.retain(|p| !cfg.fix.contains(p));
    if !log.has_radii() {
        return Err(DiagnoseError::NoRadii {
            source_name: log.source.clone(),
        });
    }
    for s in &log.skipped {
        log::warn!("{}: skipped {s}", log.source);
    }
    check_levels(log)?;
    pb.start(3 + 1 + 6 + 5 + 4);
    pb.stage("baseline");
    // The baseline is the prior without effects: a prior that has some (an earlier run's
    // augmented.json) lends its base parameters as start values; the effects are what the
    // candidates are for.
    let mut prior = prior.clone();
    prior.effects = magswarm_model::effects::Effects::default();
    let ident = identify::identify(std::slice::from_ref(log), &prior, &icfg)
        .map_err(DiagnoseError::Baseline)?;
    pb.inc(1);
    let baseline = ident.model.clone();
    let settle = ident.settle;
    let sessions = data::sessions(std::slice::from_ref(log), settle, &baseline);
    let ds = Dataset::build(&sessions, &baseline)?;
    let pe = data::pure_error(&ds);
    check_usable(&ds, &log.source)?;
    let ctx = candidates::context(&baseline, &ds);
    let base_aug = Augmented::baseline(&baseline, &ctx);
    let base_map = candidates::point_map(&base_aug, &ds);
    let base_pred = candidates::predict(&base_aug, &ds);
    let res = ds.residuals(&base_pred);
    let n_free = ident.steady.free.len();
    if pe.between_dof == 0 && ds.visits.len() < 3 * n_free {
        return Err(DiagnoseError::TooFewVisits {
            source_name: log.source.clone(),
            visits: ds.visits.len(),
            free: n_free,
            need: 3 * n_free,
        });
    }
    let noise = noise::estimate(&ds, &res).map_err(|source| DiagnoseError::Noise {
        source_name: log.source.clone(),
        source,
    })?;
    let nv = ds.visits.len();
    let k = cfg.folds.min(nv).max(2);
    let fold_of_visit = attribute::folds(nv, k, cfg.seed);
    let lin = attribute::Linear::new(
        &ds,
        &ctx,
        &base_aug,
        &ident.steady.free,
        noise,
        &fold_of_visit,
        k,
    );
    pb.stage("gap tests");
    let to_tests =
        |det: &detect::Detection, verdict: &detect::Verdict, r: &[[f64; 2]]| -> gap::GapTests {
            let old = gap::tests(&ds, r, &pe, &base_map, n_free, cfg.alpha, 0, cfg.seed);
            gap::GapTests::from_detection(old, det, verdict)
        };
    let det0 = detect::detect(
        &detect::Setting {
            ds: &ds,
            rc: &lin.rc,
            y: &lin.y,
            base: &lin.jac,
            noise: &lin.noise,
            boot: cfg.boot,
            seed: cfg.seed ^ detect::SEED,
        },
        cfg.alpha,
    )
    .ok_or_else(|| DiagnoseError::GapTests {
        source_name: log.source.clone(),
    })?;
    pb.inc(2);
    pb.stage("candidates");
    let mut attr = attribute::attribute(
        &lin,
        &fold_of_visit,
        &det0,
        attribute::Settings {
            folds: cfg.folds,
            alpha: cfg.alpha,
            max_effects: cfg.max_effects,
            seed: cfg.seed,
            boot: cfg.boot,
        },
        pb,
    );
    let tests = to_tests(&det0, &attr.verdict, &res);
    let regions = if tests.significant {
        gap::localise(&ds, &res, &base_map, &tests)
    } else {
        Vec::new()
    };
    attribute::signatures(&mut attr, &ds, &regions, &base_map);
    // Unexplained regions, with the discrepancy's withheld recovery.
    let res_aug = ds.residuals(&attr.augmented.pred);
    let res_cv = ds.residuals(&attr.augmented.cv);
    let vr_cv = gap::visit_residuals(&ds, &res_cv);
    let pe_aug = data::pure_error_of(&ds, &res_aug);
    // The floor is what a perfect model would leave on withheld rows: the rows' scatter within
    // a visit (an RMS, not a robust scale: heavy-tailed rows count in an RMSE) and the
    // visit-to-visit part, from repeat visits where there are any, else from the roughness of
    // the augmented model's residual surface.
    let floor = if pe_aug.between_dof > 0 {
        pe_aug.row_sd()
    } else {
        match noise::estimate(&ds, &res_aug) {
            Ok(n) => [0, 1].map(|a| (pe_aug.within_sd[a].powi(2) + n.between[a].powi(2)).sqrt()),
            Err(_) => pe_aug.row_sd(),
        }
    };
    let vr_aug = gap::visit_residuals(&ds, &res_aug);
    let xs: Vec<Vec<f64>> = gap::coords(&ds).iter().map(|c| c.to_vec()).collect();
    let ts: Vec<Vec<f64>> = {
        let tmax = ds.visits.iter().map(|v| v.t_mid).fold(1e-9f64, f64::max);
        ds.visits.iter().map(|v| vec![v.t_mid / tmax]).collect()
    };
    // What the augmented model leaves: the regions of the last round's gap tests.
    let left = if attr.accepted.is_empty() {
        regions.clone()
    } else {
        match attr.rounds.last() {
            Some(r) if r.verdict.significant => {
                let t = to_tests(&r.detection, &r.verdict, &res_aug);
                gap::localise(&ds, &res_aug, &base_map, &t)
            }
            _ => Vec::new(),
        }
    };
    let mut unexplained = Vec::new();
    for r in &left {
        let after = gap::region_mean(&ds, &res_aug, &base_map, r);
        let shrink = match r.kind {
            gap::Kind::Formation => None,
            kind => {
                let x = if kind == gap::Kind::Drift { &ts } else { &xs };
                let y: Vec<f64> = vr_aug.e.iter().map(|e| e[r.axis]).collect();
                let noise2 = tests.visit_sd[r.axis].powi(2);
                let g = gp::cv_predict(x, &y, &attr.fold_of_visit, noise2);
                let (mut before, mut after) = (0.0, 0.0);
                for &v in &r.visits {
                    let e = vr_cv.e[v][r.axis];
                    before += e * e;
                    after += (e - g[v]).powi(2);
                }
                (before > 0.0).then(|| 1.0 - after / before)
            }
        };
        unexplained.push(Unexplained {
            region: r.clone(),
            mean_after: after,
            heldout_shrink: shrink,
        });
    }
    // The withheld log.
    let withheld = match withheld {
        None => None,
        Some(w) => {
            if !w.has_radii() {
                return Err(DiagnoseError::WithheldNoRadii {
                    source_name: w.source.clone(),
                });
            }
            let ws = data::sessions(std::slice::from_ref(w), settle, &baseline);
            let wds = Dataset::build(&ws, &baseline)?;
            if wds.rows.is_empty() {
                return Err(DiagnoseError::WithheldEmpty {
                    source_name: w.source.clone(),
                });
            }
            // The two written model files, predicted as `magswarm predict` runs them: the
            // baseline is identify's model (baseline.json), not the attribution's linear step
            // from it, so that the excess removed on the withheld log is the one a user
            // measures with the files and is not credited with that step; with nothing named
            // the augmented model is the baseline itself (augmented.json).
            let pb_ = candidates::predict(&base_aug, &wds);
            let pa = match attr.named_model() {
                None => pb_.clone(),
                Some(aug) => candidates::predict(aug, &wds),
            };
            let (visits, worse_p) = worse_p(&wds, &pb_, &pa, floor);
            Some(Withheld {
                source: w.source.clone(),
                baseline: rmse(&wds, &pb_),
                augmented: rmse(&wds, &pa),
                visits,
                worse_p,
                rows: wds
                    .rows
                    .iter()
                    .zip(pb_.iter().zip(&pa))
                    .map(|(r, (b, a))| (r.line, *b, *a))
                    .collect(),
            })
        }
    };
    pb.finish();
    Ok(Diagnosis {
        sources: vec![log.source.clone()],
        ident,
        ds,
        ctx,
        pe,
        floor,
        pe_aug,
        tests,
        detection: det0,
        noise,
        regions,
        base_map,
        attr,
        unexplained,
        withheld,
        elapsed: t0.elapsed(),
        cfg: cfg.clone(),
    })
}

/// The settle rule diagnose inherits from identify's defaults (for the docs).
pub fn default_settle() -> SettleRule {
    identify::Config::default().settle
}
