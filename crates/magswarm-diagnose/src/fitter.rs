//! Joint fit of the baseline's free steady parameters and the active effects' parameters on a
//! subset of the rows (bounded Levenberg-Marquardt, as identify's steady fit).

use super::candidates::{self, Augmented, Ctx};
use super::data::Dataset;
use magswarm_fit::lm::{self, LevenbergMarquardt};
use magswarm_identify::params::{self, Free};
use magswarm_model::effects::FitParam as EffParam;
use nalgebra::{DMatrix, DVector};

/// Most starts refined by a local fit (the rest of a start grid is ranked by cost only).
const MAX_REFINED: usize = 3;

/// One free knob: a baseline parameter or an effect parameter.
#[derive(Debug, Clone, Copy)]
enum Knob {
    Base(Free),
    Eff {
        effect: usize,
        idx: usize,
        def: EffParam,
    },
}

impl Knob {
    fn bounds(self) -> (f64, f64, bool) {
        match self {
            Knob::Base(f) => (
                f.lo,
                f.hi,
                f.def.transform == magswarm_identify::params::Transform::Log,
            ),
            Knob::Eff { def, .. } => (def.lo, def.hi, def.log),
        }
    }
    fn to_theta(self, u: f64) -> f64 {
        let (lo, hi, log) = self.bounds();
        if log {
            u.exp().clamp(lo, hi)
        } else {
            lo + (hi - lo) * (1.0 + u.sin()) / 2.0
        }
    }
    fn to_u(self, t: f64) -> f64 {
        let (lo, hi, log) = self.bounds();
        let t = t.clamp(lo, hi);
        if log {
            t.max(1e-300).ln()
        } else {
            (2.0 * (t - lo) / (hi - lo) - 1.0).clamp(-1.0, 1.0).asin()
        }
    }
    fn get(&self, a: &Augmented) -> f64 {
        match self {
            Knob::Base(f) => params::get(&a.model, f.name()),
            Knob::Eff { effect, idx, .. } => a.effects[*effect].1[*idx],
        }
    }
    fn set(&self, a: &mut Augmented, v: f64) {
        match self {
            Knob::Base(f) => params::set(&mut a.model, f.name(), v),
            Knob::Eff { effect, idx, .. } => a.effects[*effect].1[*idx] = v,
        }
    }
}

/// A fitted augmented model on a row subset.
#[derive(Debug, Clone)]
pub struct FitResult {
    /// The model.
    pub aug: Augmented,
    /// Weighted sum of squares on the training rows.
    pub cost: f64,
    /// Effect parameters within 0.1 % of a bound: (effect, parameter name).
    pub at_bound: Vec<(String, String)>,
}

struct Problem<'a> {
    aug: Augmented,
    knobs: &'a [Knob],
    ds: &'a Dataset,

    train: &'a [usize],
    sd: [f64; 2],
    u: DVector<f64>,
}

impl Problem<'_> {
    fn res_of(&self, a: &Augmented) -> DVector<f64> {
        let pred = candidates::predict(a, self.ds);
        let mut out = DVector::zeros(2 * self.train.len());
        for (k, &i) in self.train.iter().enumerate() {
            for ax in 0..2 {
                let v = (pred[i][ax] - self.ds.rows[i].r[ax]) / self.sd[ax];
                out[2 * k + ax] = if v.is_finite() { v } else { 1e6 };
            }
        }
        out
    }
}

impl lm::Fit for Problem<'_> {
    fn set(&mut self, u: &[f64]) {
        self.u.copy_from_slice(u);
        for (k, &ui) in self.knobs.iter().zip(u.iter()) {
            k.set(&mut self.aug, k.to_theta(ui));
        }
    }
    fn residuals(&self) -> DVector<f64> {
        self.res_of(&self.aug)
    }
    fn jacobian(&self) -> DMatrix<f64> {
        let base = self.res_of(&self.aug);
        let mut j = DMatrix::zeros(base.len(), self.knobs.len());
        for (c, k) in self.knobs.iter().enumerate() {
            let h = 1e-6 * (1.0 + self.u[c].abs());
            let mut a = self.aug.clone();
            k.set(&mut a, k.to_theta(self.u[c] + h));
            let r = self.res_of(&a);
            for i in 0..base.len() {
                j[(i, c)] = (r[i] - base[i]) / h;
            }
        }
        j
    }
}

/// Fit `start` (its effects' parameters and the baseline's `free` parameters) on the rows
/// `train`, from each of `effect_starts` (values for the last effect's parameters; empty:
/// start as is). Row residuals are weighted by `sd` per axis.
pub fn fit(
    start: &Augmented,
    free: &[Free],
    ds: &Dataset,
    ctx: &Ctx,
    train: &[usize],
    sd: [f64; 2],
    effect_starts: &[Vec<f64>],
) -> FitResult {
    let mut knobs: Vec<Knob> = free.iter().map(|f| Knob::Base(*f)).collect();
    for (e, (name, _)) in start.effects.iter().enumerate() {
        for (i, def) in candidates::params(*name, ctx).into_iter().enumerate() {
            knobs.push(Knob::Eff {
                effect: e,
                idx: i,
                def,
            });
        }
    }
    let mut inits: Vec<Augmented> = Vec::new();
    if effect_starts.is_empty() || start.effects.is_empty() {
        inits.push(start.clone());
    } else {
        let last = start.effects.len() - 1;
        for s in effect_starts {
            let mut a = start.clone();
            if s.len() == a.effects[last].1.len() {
                a.effects[last].1 = s.clone();
            }
            inits.push(a);
        }
    }
    // A grid of starts (more than a few): each is first fitted with the new effect's scan
    // parameters (its location or time scale) held at their start value and few iterations;
    // the best few are then refined with everything free. The locations (a step-out between
    // two measured frequencies, an onset between two distances) make the cost piecewise
    // smooth, and a local fit from a distorted baseline otherwise runs off to the piece where
    // the effect vanishes.
    if inits.len() > MAX_REFINED {
        let last = start.effects.len() - 1;
        let held: Vec<Knob> = knobs
            .iter()
            .copied()
            .filter(|k| !matches!(k, Knob::Eff { effect, def, .. } if *effect == last && def.scan))
            .collect();
        let mut ranked: Vec<(f64, Augmented)> = inits
            .into_iter()
            .map(|a| {
                let (aug, cost) = local_fit(&a, &held, ds, train, sd, 8);
                (cost, aug)
            })
            .collect();
        ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
        inits = ranked.into_iter().take(MAX_REFINED).map(|x| x.1).collect();
    }
    let mut best: Option<FitResult> = None;
    for init in inits {
        let (mut aug, cost) = local_fit(&init, &knobs, ds, train, sd, 30);
        if best.as_ref().map(|b| cost < b.cost).unwrap_or(true) {
            aug.sync_model();
            let mut at_bound = Vec::new();
            for k in &knobs {
                if let Knob::Eff { effect, def, .. } = k {
                    let v = k.get(&aug);
                    let (lo, hi) = if def.log {
                        (v <= def.lo * 1.01, v >= def.hi / 1.01)
                    } else {
                        let tol = 2e-3 * (def.hi - def.lo);
                        (v <= def.lo + tol, v >= def.hi - tol)
                    };
                    let near = (lo && def.flag.0) || (hi && def.flag.1);
                    if near {
                        at_bound.push((
                            aug.effects[*effect].0.name().to_string(),
                            def.name.to_string(),
                        ));
                    }
                }
            }
            best = Some(FitResult {
                aug,
                cost,
                at_bound,
            });
        }
    }
    best.expect("at least one start")
}

/// A bounded Levenberg-Marquardt fit of `knobs` from `init` on the rows `train`: the fitted
/// model and its weighted sum of squares (infinite where the model breaks).
fn local_fit(
    init: &Augmented,
    knobs: &[Knob],
    ds: &Dataset,
    train: &[usize],
    sd: [f64; 2],
    patience: usize,
) -> (Augmented, f64) {
    let u0 = DVector::from_iterator(knobs.len(), knobs.iter().map(|k| k.to_u(k.get(init))));
    let prob = Problem {
        aug: init.clone(),
        knobs,
        ds,
        train,
        sd,
        u: u0.clone(),
    };
    let prob = lm::minimize(
        prob,
        u0,
        LevenbergMarquardt::new()
            .with_ftol(1e-7)
            .with_xtol(1e-7)
            .with_gtol(1e-9)
            .with_patience(patience),
    )
    .fit;
    let cost = prob.res_of(&prob.aug).norm_squared();
    let cost = if cost.is_finite() {
        cost
    } else {
        f64::INFINITY
    };
    (prob.aug, cost)
}
