//! Joint fit of the baseline's free steady parameters and the active effects' parameters on a
//! subset of the rows (bounded Levenberg-Marquardt, as identify's steady fit).

use super::candidates::{self, Augmented, Ctx};
use super::data::Dataset;
use super::shapes::Mode;
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
    /// The height at knot `idx` of learned shape `term`, a rotation-rate deficit \[Hz\] (one
    /// value for both radii), within +-`bound`.
    Rate {
        term: usize,
        idx: usize,
        bound: f64,
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
            Knob::Rate { bound, .. } => (-bound, bound, false),
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
            Knob::Rate { term, idx, .. } => a.learned[*term].1.values[0][*idx],
        }
    }
    fn set(&self, a: &mut Augmented, v: f64) {
        match self {
            Knob::Base(f) => params::set(&mut a.model, f.name(), v),
            Knob::Eff { effect, idx, .. } => a.effects[*effect].1[*idx] = v,
            Knob::Rate { term, idx, .. } => {
                let vals = &mut a.learned[*term].1.values;
                vals[0][*idx] = v;
                vals[1][*idx] = v;
            }
        }
    }
}

/// A weak prior on the baseline's free parameters: where the data hold them, nothing; along
/// the combinations the data barely determine (the exponents against the gains, N against q
/// of (6)), it keeps a refit from running off to the bounds. The same ridge as the linear
/// world's design (a coefficient of a unit-norm Jacobian column costs `ridge` times its
/// square), so that a nonlinear refit per fold and the linear one judge alike: without it a
/// fold that holds few operating points sends the free parameters to their bounds and its
/// withheld error says more about that than about the effect being judged.
#[derive(Debug, Clone, Default)]
pub struct Anchor {
    /// The baseline's values of the free parameters (in the order of `free`).
    pub theta: Vec<f64>,
    /// Weight of each parameter's departure: the weighted norm of its Jacobian column (row
    /// noise per unit of the parameter) times the square root of the ridge.
    pub weight: Vec<f64>,
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
    /// Weight of the second differences of the rate knobs' heights (0: none).
    smooth: f64,
    /// The prior on the baseline's free parameters.
    anchor: Option<&'a Anchor>,
}

impl Problem<'_> {
    fn res_of(&self, a: &Augmented) -> DVector<f64> {
        let pred = candidates::predict(a, self.ds);
        let mut rough = roughness(self.knobs, a, self.smooth);
        if let Some(an) = self.anchor {
            for (c, k) in self.knobs.iter().enumerate() {
                if let (Knob::Base(_), Some(t0), Some(w)) = (k, an.theta.get(c), an.weight.get(c)) {
                    rough.push(w * (k.get(a) - t0));
                }
            }
        }
        let mut out = DVector::zeros(2 * self.train.len() + rough.len());
        for (k, &i) in self.train.iter().enumerate() {
            for ax in 0..2 {
                let v = (pred[i][ax] - self.ds.rows[i].r[ax]) / self.sd[ax];
                out[2 * k + ax] = if v.is_finite() { v } else { 1e6 };
            }
        }
        for (k, r) in rough.into_iter().enumerate() {
            out[2 * self.train.len() + k] = r;
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
/// start as is). Row residuals are weighted by `sd` per axis; `anchor` holds the free
/// parameters near the baseline where the data do not determine them.
#[allow(clippy::too_many_arguments)]
pub fn fit(
    start: &Augmented,
    free: &[Free],
    ds: &Dataset,
    ctx: &Ctx,
    train: &[usize],
    sd: [f64; 2],
    anchor: Option<&Anchor>,
    effect_starts: &[Vec<f64>],
) -> FitResult {
    let knobs = knobs_of(start, free, ctx);
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
                let (aug, cost) = local_fit(&a, &held, ds, train, sd, anchor, 8, 0.0);
                (cost, aug)
            })
            .collect();
        ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
        inits = ranked.into_iter().take(MAX_REFINED).map(|x| x.1).collect();
    }
    let mut best: Option<FitResult> = None;
    for init in inits {
        let (mut aug, cost) = local_fit(&init, &knobs, ds, train, sd, anchor, 30, 0.0);
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

/// The knobs of `start`: the baseline's `free` parameters, then every active effect's.
fn knobs_of(start: &Augmented, free: &[Free], ctx: &Ctx) -> Vec<Knob> {
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
    knobs
}

/// A bounded Levenberg-Marquardt fit of `knobs` from `init` on the rows `train`: the fitted
/// model and its weighted sum of squares (infinite where the model breaks).
#[allow(clippy::too_many_arguments)]
fn local_fit(
    init: &Augmented,
    knobs: &[Knob],
    ds: &Dataset,
    train: &[usize],
    sd: [f64; 2],
    anchor: Option<&Anchor>,
    patience: usize,
    smooth: f64,
) -> (Augmented, f64) {
    let u0 = DVector::from_iterator(knobs.len(), knobs.iter().map(|k| k.to_u(k.get(init))));
    let prob = Problem {
        aug: init.clone(),
        knobs,
        ds,
        train,
        sd,
        u: u0.clone(),
        smooth,
        anchor,
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

/// The weighted second differences of the heights of each learned rate shape among `knobs`
/// (consecutive knobs of one shape), as extra residuals.
fn roughness(knobs: &[Knob], a: &Augmented, smooth: f64) -> Vec<f64> {
    if smooth <= 0.0 {
        return Vec::new();
    }
    let w = smooth.sqrt();
    let mut out = Vec::new();
    for (term, (_, sh)) in a.learned.iter().enumerate() {
        let idx: Vec<usize> = knobs
            .iter()
            .filter_map(|k| match k {
                Knob::Rate { term: t, idx, .. } if *t == term => Some(*idx),
                _ => None,
            })
            .collect();
        let h = &sh.values[0];
        for j in idx.windows(3) {
            out.push(w * (h[j[0]] - 2.0 * h[j[1]] + h[j[2]]));
        }
    }
    out
}

/// The final model where a learned shape is a rate deficit: the one learned mode that acts
/// nonlinearly (the map re-evaluated at the slower rotation, clamped where the swarm would
/// stop), so the linear fit's heights, exact only near the baseline, are refitted with the
/// free parameters and the library forms by the nonlinear fitter, from the linear solution and
/// from no deficit, keeping the better (a weak second-difference penalty holds the knots the
/// data do not reach). Returns `start` unchanged when it has no rate shape.
pub fn refit_rates(
    start: &Augmented,
    free: &[Free],
    ds: &Dataset,
    ctx: &Ctx,
    train: &[usize],
    sd: [f64; 2],
    anchor: Option<&Anchor>,
) -> Augmented {
    let bound = 2.0 * ctx.f_max.max(1.0);
    let mut knobs = knobs_of(start, free, ctx);
    let n_before = knobs.len();
    for (term, (_, sh)) in start.learned.iter().enumerate() {
        if sh.family.mode == Mode::Rate {
            let first = usize::from(sh.family.pin_first);
            for idx in first..first + crate::shapes::free_knots(&sh.family) {
                knobs.push(Knob::Rate { term, idx, bound });
            }
        }
    }
    if knobs.len() == n_before {
        return start.clone();
    }
    let mut zero = start.clone();
    for (_, sh) in zero.learned.iter_mut() {
        if sh.family.mode == Mode::Rate {
            for v in sh.values.iter_mut() {
                v.iter_mut().for_each(|x| *x = 0.0);
            }
        }
    }
    let clamp = |mut a: Augmented| {
        for k in &knobs {
            if let Knob::Rate { .. } = k {
                let v = k.get(&a).clamp(-bound, bound);
                k.set(&mut a, v);
            }
        }
        a
    };
    let mut best: Option<(f64, Augmented)> = None;
    for init in [clamp(start.clone()), zero] {
        let (aug, cost) = local_fit(&init, &knobs, ds, train, sd, anchor, 30, 1.0);
        if best.as_ref().map(|b| cost < b.0).unwrap_or(true) {
            best = Some((cost, aug));
        }
    }
    let mut aug = best.expect("two starts").1;
    aug.sync_model();
    aug
}
