//! The candidate effects diagnose tries: the model's own effect terms
//! ([`magswarm_model::effects`], docs/effects.md), not report-only curve fits. A candidate
//! that diagnose accepts is switched on in `augmented.json` with its fitted parameters, so the
//! FMU, `predict` and the bridge's shadow model run exactly the model diagnose judged.
//!
//! Each effect's library form is described by the effect itself ([`Effect`]: the parameters
//! its fit frees, with bounds following the data's ranges, its neutral values, its start grid,
//! how fit-space values map onto its model parameters, and why a fit is implausible); this
//! module only predicts through the model's code: the steady map [`steady::evaluate`] carries
//! the effects that act on it; the slow formation mode is propagated by
//! [`FormationLag::propagate`] between rows exactly as [`magswarm_model::Plant`] does; the
//! observation effects act through [`Effects::observe`]. Only the baseline's ODE (4)
//! transient is held fixed while candidates are refitted (see [`super::data`]);
//! `augmented.json` replayed by `predict` gives the same radii up to that transient's change
//! (tested).
//!
//! [`Effect`]: magswarm_model::effects::Effect

use super::data::Dataset;
use super::shapes::{self, Mode, Shape};
pub use magswarm_model::effects::DataContext as Ctx;
use magswarm_model::effects::{self, EffectKind, Effects, FitParam, FormationLag};
use magswarm_model::registry;
use magswarm_model::{hz_to_rad_s, steady, Model};
use std::sync::Arc;

/// The candidates, in report order (the effect names of docs/effects.md).
pub const NAMES: [&str; 6] = effects::NAMES;

/// The parameters a candidate's library form frees (fit space), bounds following the data.
pub fn params(kind: EffectKind, ctx: &Ctx) -> Vec<FitParam> {
    kind.fit_params(ctx)
}

/// The model parameters of an effect switched on in `m` (registry name without the effect
/// prefix, unit, value): what `augmented.json` holds and the report shows.
pub fn model_params(kind: EffectKind, m: &Model) -> Vec<(&'static str, &'static str, f64)> {
    registry::params_of(kind)
        .map(|p| {
            let field = p.name.split_once('.').map(|x| x.1).unwrap_or(p.name);
            (field, display_unit(p), (p.get)(m))
        })
        .collect()
}

/// A registry row's unit for people: its FMI unit, else the unit its description names in
/// brackets (units FMI has no definition for, such as 1/mm2), else "-".
fn display_unit(p: &registry::Param) -> &'static str {
    if let Some(u) = p.unit {
        return u;
    }
    let d = p.description;
    match (d.find('['), d.find(']')) {
        (Some(a), Some(b)) if a < b => &d[a + 1..b],
        _ => "-",
    }
}

/// An augmented model: the baseline's (refitted) parameters and the active candidates'
/// fit-space values; [`Augmented::sync_model`] writes them into `model.effects`.
#[derive(Debug, Clone, PartialEq)]
pub struct Augmented {
    /// The plant model, effects included once synced.
    pub model: Model,
    /// Active candidates (effect, fit-space values), in order of addition.
    pub effects: Vec<(EffectKind, Vec<f64>)>,
    /// The data's context (ranges, |B| at the middle of the z_m range: the reference of the
    /// field-scaled axes and of `phase_lag`'s fit space).
    pub ctx: Arc<Ctx>,
    /// Learned shapes along effects' axes (effect, shape), in order of addition: applied by
    /// [`predict`] after the parametric effects, and written into the model file as learned
    /// effect terms by [`Augmented::model_file`].
    pub learned: Vec<(EffectKind, Shape)>,
}

impl Augmented {
    /// The baseline alone (any effect of `model` switched off).
    pub fn baseline(model: &Model, ctx: &Ctx) -> Augmented {
        let mut model = model.clone();
        model.effects = Effects::default();
        Augmented {
            model,
            effects: Vec::new(),
            ctx: Arc::new(ctx.clone()),
            learned: Vec::new(),
        }
    }

    /// |B| at the middle of the data's z_m range \[T\].
    pub fn b_mid(&self) -> f64 {
        self.ctx.b_mid
    }

    /// Write the candidates' values into the model's effects section (and nothing else on).
    pub fn sync_model(&mut self) {
        self.model.effects = Effects::default();
        for (kind, v) in &self.effects {
            kind.set_fit(v, &self.ctx, &mut self.model);
        }
    }

    /// The model with every active parametric candidate switched on (learned shapes are
    /// applied by [`predict`], not by the model).
    pub fn synced(&self) -> Model {
        let mut a = self.clone();
        a.sync_model();
        a.model
    }

    /// The model file: the parametric candidates switched on and the learned shapes as the
    /// model's learned effect terms, so that `predict`, the FMU and the bridge's shadow model
    /// run them.
    pub fn model_file(&self) -> Model {
        let mut m = self.synced();
        for (kind, sh) in &self.learned {
            super::learned::push(&mut m, *kind, sh, self.ctx.b_mid);
        }
        m
    }
}

/// What the candidates need to know of the training data besides its rows: its ranges and
/// levels, |B| at the middle of its z_m range, its time scales, the baseline's geometry.
pub fn context(model: &Model, ds: &Dataset) -> Ctx {
    let (zs, fs) = ds.levels();
    let z_min = zs.first().copied().unwrap_or(3.5);
    let z_max = zs.last().copied().unwrap_or(23.5);
    let dt_min = ds
        .rows
        .iter()
        .map(|r| r.dt)
        .filter(|d| *d > 0.0)
        .fold(f64::INFINITY, f64::min);
    let t_span = ds.rows.iter().map(|r| r.t).fold(0.0, f64::max);
    let visit_durations_s = ds
        .visits
        .iter()
        .filter_map(|vi| {
            let a = ds.rows[*vi.rows.first()?].since;
            let b = ds.rows[*vi.rows.last()?].since;
            Some(b.max(a))
        })
        .collect();
    Ctx {
        b_mid: field_b(model, (z_min + z_max) / 2.0).max(1e-12),
        z_max,
        z_min,
        f_min: fs.first().copied().unwrap_or(1.0),
        f_max: fs.last().copied().unwrap_or(10.0),
        dt_min: if dt_min.is_finite() { dt_min } else { 1.0 },
        t_span,
        lateral_mm: model.magnet.lateral_offset_m * 1e3,
        z_levels: zs,
        f_levels: fs,
        visit_durations_s,
    }
}

/// The physical steady map (with the effects that change it) at (z_m [mm], f [Hz]), with a
/// large finite value where the model breaks [mm].
fn map_point(m: &Model, z_mm: f64, f_hz: f64) -> [f64; 2] {
    let sp = steady::evaluate(m, z_mm * 1e-3, hz_to_rad_s(f_hz));
    let ok = |v: f64| if v.is_finite() { v } else { 1e6 };
    [ok(sp.r1), ok(sp.r2)]
}

/// The physical steady map of a model at (z_m \[mm\], f \[Hz\]) \[mm\] (large where it breaks).
pub fn map_at(m: &Model, z_mm: f64, f_hz: f64) -> [f64; 2] {
    map_point(m, z_mm, f_hz)
}

/// Physical steady map of the augmented model at every point of `ds` \[mm\].
pub fn point_map(aug: &Augmented, ds: &Dataset) -> Vec<[f64; 2]> {
    map_of(&aug.synced(), ds)
}

/// Physical steady map of a model at every point of `ds` [mm].
fn map_of(m: &Model, ds: &Dataset) -> Vec<[f64; 2]> {
    ds.points.iter().map(|&(z, f)| map_point(m, z, f)).collect()
}

/// Predicted (observed) radii at every row of `ds` \[mm\]: the steady map plus the baseline's
/// transient part, the formation mode blended in, then drift and camera as observed at the
/// row's session time.
pub fn predict(aug: &Augmented, ds: &Dataset) -> Vec<[f64; 2]> {
    let m = aug.synced();
    let map = map_of(&m, ds);
    let fx = &m.effects;
    let mut out: Vec<[f64; 2]> = Vec::with_capacity(ds.rows.len());
    // The state at the current visit's input change: this model's radius at the row before.
    let mut start: Option<[f64; 2]> = None;
    for (i, r) in ds.rows.iter().enumerate() {
        let s = map[r.point];
        if i == 0 || ds.rows[i - 1].sess != r.sess {
            start = None;
        } else if ds.rows[i - 1].visit != r.visit {
            start = Some(out[i - 1]);
        }
        let mut x = [0.0; 2];
        for a in 0..2 {
            x[a] = match start {
                Some(st) if r.frac[a].is_finite() => s[a] + r.frac[a] * (st[a] - s[a]),
                _ => s[a] + r.trans[a],
            };
        }
        out.push(x);
    }
    if let Some(fl) = &fx.formation_lag {
        formation(fl, ds, &map, &mut out);
    }
    if fx.observes() {
        for (o, r) in out.iter_mut().zip(&ds.rows) {
            *o = fx.observe(*o, r.t);
        }
    }
    if !aug.learned.is_empty() {
        apply_learned(aug, &m, ds, &map, &mut out);
    }
    out
}

/// Apply the learned shapes row by row, as the model's learned terms act: shapes over f and
/// z_m on the steady radii, over session time on the observed radii, over the time since the
/// last input change as a fraction of that change's step of the steady map (the map with the
/// shapes over f and z_m; zero for a session's first visit).
fn apply_learned(aug: &Augmented, m: &Model, ds: &Dataset, map: &[[f64; 2]], out: &mut [[f64; 2]]) {
    let ln_b: Vec<f64> = ds
        .points
        .iter()
        .map(|&(z, _)| (field_b(m, z) / aug.ctx.b_mid).max(1e-300).ln())
        .collect();
    let x_of = |axis: shapes::Axis, p: usize, t: f64, since: f64| -> f64 {
        let (z, f) = ds.points[p];
        match axis {
            shapes::Axis::F { nu } => f * (-nu * ln_b[p]).exp(),
            shapes::Axis::Z => z,
            shapes::Axis::T => t,
            shapes::Axis::Since => since,
        }
    };
    let steady_axes = |a: shapes::Axis| matches!(a, shapes::Axis::F { .. } | shapes::Axis::Z);
    // The learned steady shapes' change of the steady map, per point: evaluated by the model
    // file's own steady map with the shapes as its learned terms, so what diagnose fits,
    // scores and reports is exactly what `predict` and the FMU run from augmented.json (the
    // rate deficits first and clamped where they would stop the swarm, then the changes in mm
    // and the relative changes on top, in the model's order).
    let mut corr = vec![[0.0; 2]; map.len()];
    let mut map2 = map.to_vec();
    if aug.learned.iter().any(|(_, s)| steady_axes(s.family.axis)) {
        let mut mf = m.clone();
        for (kind, sh) in aug
            .learned
            .iter()
            .filter(|(_, s)| steady_axes(s.family.axis))
        {
            super::learned::push(&mut mf, *kind, sh, aug.ctx.b_mid);
        }
        for (p, v) in map2.iter_mut().enumerate() {
            let (z, f) = ds.points[p];
            let w = map_point(&mf, z, f);
            for a in 0..2 {
                corr[p][a] = w[a] - v[a];
                v[a] = w[a];
            }
        }
    }
    for (i, r) in ds.rows.iter().enumerate() {
        let delta = match ds.visits[r.visit].prev {
            Some(pv) => {
                let (a, b) = (map2[r.point], map2[ds.visits[pv].point]);
                [a[0] - b[0], a[1] - b[1]]
            }
            None => [0.0; 2],
        };
        for a in 0..2 {
            out[i][a] += corr[r.point][a];
        }
        for (_, sh) in aug
            .learned
            .iter()
            .filter(|(_, s)| !steady_axes(s.family.axis))
        {
            let scale = (sh.family.amp * ln_b[r.point]).exp();
            let c = sh
                .at(x_of(sh.family.axis, r.point, r.t, r.since))
                .map(|c| c * scale);
            for a in 0..2 {
                match sh.family.mode {
                    Mode::Relative | Mode::Aspect | Mode::Common => out[i][a] *= 1.0 + c[a],
                    Mode::StepFraction => {
                        out[i][a] += c[a] * delta[a] * sh.family.steps.of(delta[a])
                    }
                    Mode::Add | Mode::Rate => out[i][a] += c[a],
                }
            }
        }
    }
}

/// Blend the slow formation mode into the footprint, row by row: formed at rest at a
/// session's first row, then driven toward the steady map of each row's inputs over the time
/// since the previous row (the inputs a row names are in force since that row: the log
/// convention `predict` replays).
fn formation(fl: &FormationLag, ds: &Dataset, map: &[[f64; 2]], out: &mut [[f64; 2]]) {
    let mut xv = [[0.0; 2]; 2];
    for (i, r) in ds.rows.iter().enumerate() {
        let target = map[r.point];
        if i == 0 || ds.rows[i - 1].sess != r.sess {
            xv = [[target[0], 0.0], [target[1], 0.0]];
        } else if r.dt > 0.0 {
            for a in 0..2 {
                xv[a] = fl.propagate(xv[a], target[a], r.dt);
            }
        }
        for a in 0..2 {
            out[i][a] = fl.blend(out[i][a], xv[a][0]);
        }
    }
}

/// |B| at a z_m \[mm\] \[T\].
pub fn field_b(model: &Model, z_mm: f64) -> f64 {
    steady::evaluate(model, z_mm * 1e-3, 1.0).field.b
}
