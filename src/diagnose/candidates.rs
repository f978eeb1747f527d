//! The candidate effects diagnose tries: the model's own effect terms
//! ([`magswarm_model::effects`], docs/effects.md), not report-only curve fits. A candidate
//! that diagnose accepts is switched on in `augmented.json` with its fitted parameters, so the
//! FMU, `predict` and the bridge's shadow model run exactly the model diagnose judged.
//!
//! A candidate frees some of its effect's registry rows (the rest stay neutral) and predicts
//! through the model's code: the steady map [`steady::evaluate`] carries `phase_lag`,
//! `cohesion_loss` and `centroid_offset`; the slow mode of `formation_lag` is propagated by
//! [`FormationLag::propagate`] between rows exactly as [`magswarm_model::Plant`] does; drift
//! and camera act through [`Effects::observe`]. Only the baseline's ODE (4) transient is held
//! fixed while candidates are refitted (see [`super::data`]); `augmented.json` replayed by
//! `predict` gives the same radii up to that transient's change (tested).
//!
//! | candidate | freed parameters (fit space) | model parameters | fixed at neutral, and why |
//! | --- | --- | --- | --- |
//! | `phase_lag` | f_mid \[Hz\] (step-out frequency at the data's mid-range field), nu [-], spread [-] | `f_so_hz = f_mid (B_ref / B_mid)^nu`, `nu`, `spread` | - |
//! | `cohesion_loss` | z_c \[mm\], k [1/mm^2] | `z_c_mm`, `k_per_mm2` | - |
//! | `formation_lag` | share [-], tau_s \[s\], zeta [-] | the same | - |
//! | `particle_drift` | rate [1/h] | `rate_per_h` | - |
//! | `centroid_offset` | offset \[mm\] | `offset_mm` | - |
//! | `camera_bias` | offset \[mm\] | `offset_mm` | `scale`, `tilt_deg`: a scale of the radii (and the cos(tilt) of r2) is the baseline's C_1, C_2, which are refitted with every candidate: not identifiable from radii |
//!
//! Fitting `phase_lag` at the data's mid-range field rather than at B_ref keeps the step-out
//! location and its field exponent nearly uncorrelated (the fit is better conditioned), and
//! lets the plausibility rule ask the question that matters: does the step-out lie inside the
//! frequencies measured?

use super::data::Dataset;
use super::shapes::{self, Mode, Shape};
use magswarm_model::effects::{self, EffectKind, Effects, FormationLag};
use magswarm_model::registry::{self, Transform};
use magswarm_model::{hz_to_rad_s, steady, Model};

/// The candidates, in report order (the effect names of docs/effects.md).
pub const NAMES: [&str; 6] = effects::NAMES;

/// One freed parameter of a candidate (fit space).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EffParam {
    /// Name.
    pub name: &'static str,
    /// Unit.
    pub unit: &'static str,
    /// Fit bounds.
    pub lo: f64,
    /// Fit bounds.
    pub hi: f64,
    /// Log transform (strictly positive scale) rather than the double-bounded sine.
    pub log: bool,
    /// True for a location (step frequency, distance): it must lie inside the data's range
    /// to be a plausible description of the residual rather than of a trend.
    pub location: Option<Axis>,
    /// Which bounds mean "the data want more than the form allows" when reached: (lower,
    /// upper). A bound where the effect vanishes (a share or rate at 0, an onset past the
    /// data) or a sharpness past what the grid resolves is not such a bound.
    pub flag: (bool, bool),
    /// Held at each start's value in the first, coarse stage of the multi-start fit (a
    /// location or a time scale: the parameters that make the cost piecewise smooth).
    pub scan: bool,
}

/// Which input a location parameter refers to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    /// z_m.
    Z,
    /// f.
    F,
}

/// A registry row's fit bounds and transform, as a fit-space parameter.
fn row(name: &'static str, field: &'static str) -> EffParam {
    let p = registry::find(name).unwrap_or_else(|| panic!("registry has no row {name}"));
    let fit = p.fit.unwrap_or_else(|| panic!("{name} is not fittable"));
    EffParam {
        name: field,
        unit: p.unit.unwrap_or("-"),
        lo: fit.lo,
        hi: fit.hi,
        log: fit.transform == Transform::Log,
        location: None,
        flag: (true, true),
        scan: false,
    }
}

/// Freed parameters of a candidate on data with context `ctx` (location bounds follow the
/// data's ranges, so a rig with another workspace is judged on its own ranges).
pub fn params(name: &str, ctx: &Ctx) -> Vec<EffParam> {
    let span_z = (ctx.z_max - ctx.z_min).max(1.0);
    match name {
        "phase_lag" => vec![
            EffParam {
                name: "f_mid",
                unit: "Hz",
                lo: (0.3 * ctx.f_min).max(0.05),
                hi: 3.0 * ctx.f_max,
                log: true,
                location: Some(Axis::F),
                // At the upper bound the step-out lies past the data: no effect.
                flag: (true, false),
                scan: true,
            },
            EffParam {
                // nu = 0 (a step-out independent of the field) is a physical limit, not a
                // misfit.
                flag: (false, true),
                ..row("phase_lag.nu", "nu")
            },
            EffParam {
                // 0 (one sharp step-out) is a physical limit, not a misfit.
                flag: (false, true),
                ..row("phase_lag.spread", "spread")
            },
        ],
        "cohesion_loss" => vec![
            EffParam {
                lo: ctx.z_min - 0.5 * span_z,
                hi: ctx.z_max,
                location: Some(Axis::Z),
                // At the upper bound the fade starts past the data: no effect.
                flag: (true, false),
                scan: true,
                ..row("cohesion_loss.z_c_mm", "z_c_mm")
            },
            EffParam {
                // From a fading length of twice the span (barely visible) to 0.3 mm (a step
                // sharper than any grid resolves, so not a misfit at its bound).
                lo: 0.25 / (span_z * span_z),
                hi: 10.0,
                log: true,
                flag: (false, false),
                unit: "1/mm^2",
                ..row("cohesion_loss.k_per_mm2", "k_per_mm2")
            },
        ],
        "formation_lag" => vec![
            EffParam {
                lo: 0.01,
                flag: (false, false),
                ..row("formation_lag.share", "share")
            },
            EffParam {
                lo: (0.5 * ctx.dt_min).max(0.05),
                hi: ctx.t_span.max(10.0),
                flag: (false, true),
                scan: true,
                ..row("formation_lag.tau_s", "tau_s")
            },
            EffParam {
                lo: 0.1,
                hi: 5.0,
                flag: (false, false),
                ..row("formation_lag.zeta", "zeta")
            },
        ],
        "particle_drift" => vec![row("particle_drift.rate_per_h", "rate_per_h")],
        "centroid_offset" => vec![EffParam {
            // From the swarm on the axis (lateral distance 0, a physical limit) to 30 mm
            // further out than the model's geometry.
            lo: -ctx.lateral_mm,
            hi: 30.0,
            flag: (false, true),
            ..row("centroid_offset.offset_mm", "offset_mm")
        }],
        "camera_bias" => vec![row("camera_bias.offset_mm", "offset_mm")],
        _ => Vec::new(),
    }
}

/// Fit-space values with which the candidate is the baseline exactly.
pub fn neutral(name: &str, ctx: &Ctx) -> Vec<f64> {
    match name {
        // Step-out above every frequency of the data at every field: w_eff = w.
        "phase_lag" => vec![3.0 * ctx.f_max, 0.0, 0.0],
        // Onset at the data's largest z_m: (z - z_c)_+ = 0 everywhere.
        "cohesion_loss" => vec![ctx.z_max, 0.1],
        "formation_lag" => vec![0.0, 10.0, 1.0],
        "particle_drift" => vec![0.0],
        "centroid_offset" => vec![0.0],
        "camera_bias" => vec![0.0],
        _ => Vec::new(),
    }
}

/// Starting values for the multi-start fit of a candidate: a grid over its parameters, with
/// the locations between the data's levels and the time scales from the visits' durations.
/// The fitter ranks them by cost and refines the best few.
pub fn starts(name: &str, ctx: &Ctx, ds: &Dataset) -> Vec<Vec<f64>> {
    let (zs, fs) = ds.levels();
    let mids = |v: &[f64]| -> Vec<f64> { v.windows(2).map(|w| 0.5 * (w[0] + w[1])).collect() };
    let mut v = Vec::new();
    match name {
        "phase_lag" => {
            // A step-out between two measured frequencies (at mid-range field), or just
            // below the lowest.
            let mut locs = mids(&fs);
            locs.insert(0, 0.8 * ctx.f_min);
            for f in locs {
                for nu in [0.3, 1.5] {
                    v.push(vec![f, nu, 0.3]);
                }
            }
        }
        "cohesion_loss" => {
            let mut locs = mids(&zs);
            locs.insert(0, ctx.z_min);
            for zc in locs {
                let len = (ctx.z_max - zc).max(0.5);
                for k in [0.3, 3.0] {
                    v.push(vec![zc, k / (len * len)]);
                }
            }
        }
        "formation_lag" => {
            let mut durs: Vec<f64> = ds
                .visits
                .iter()
                .filter_map(|vi| {
                    let a = ds.rows[*vi.rows.first()?].since;
                    let b = ds.rows[*vi.rows.last()?].since;
                    Some(b.max(a))
                })
                .collect();
            durs.sort_by(|a, b| a.total_cmp(b));
            let med = durs.get(durs.len() / 2).copied().unwrap_or(10.0).max(0.5);
            for tau in [med / 20.0, med / 8.0, med / 3.0, med] {
                for zeta in [1.0, 0.4] {
                    v.push(vec![0.5, tau.max(0.1), zeta]);
                }
            }
        }
        "particle_drift" => {
            for r in [-0.4, -0.1, 0.1, 0.4] {
                v.push(vec![r]);
            }
        }
        "centroid_offset" => {
            for o in [2.0, 5.0, 9.0, 15.0] {
                v.push(vec![o]);
            }
        }
        "camera_bias" => {
            for o in [-0.6, -0.2, 0.2, 0.6] {
                v.push(vec![o]);
            }
        }
        _ => v.push(Vec::new()),
    }
    v
}

/// Write a candidate's fit-space values into the model (switching the effect on; the
/// parameters it does not free stay neutral).
pub fn to_model(name: &str, vals: &[f64], b_mid: f64, m: &mut Model) {
    let Some(kind) = EffectKind::from_name(name) else {
        return;
    };
    m.effects.switch_on(kind);
    let set = |m: &mut Model, row: &str, v: f64| {
        if let Some(p) = registry::find(row) {
            (p.set)(m, v);
        }
    };
    match (name, vals) {
        ("phase_lag", [f_mid, nu, spread]) => {
            let b = (b_mid / m.steady.B_ref).max(1e-300);
            set(m, "phase_lag.f_so_hz", f_mid * b.powf(-nu));
            set(m, "phase_lag.nu", *nu);
            set(m, "phase_lag.spread", *spread);
        }
        ("cohesion_loss", [zc, k]) => {
            set(m, "cohesion_loss.z_c_mm", *zc);
            set(m, "cohesion_loss.k_per_mm2", *k);
        }
        ("formation_lag", [share, tau, zeta]) => {
            set(m, "formation_lag.share", *share);
            set(m, "formation_lag.tau_s", *tau);
            set(m, "formation_lag.zeta", *zeta);
        }
        ("particle_drift", [r]) => set(m, "particle_drift.rate_per_h", *r),
        ("centroid_offset", [o]) => set(m, "centroid_offset.offset_mm", *o),
        ("camera_bias", [o]) => set(m, "camera_bias.offset_mm", *o),
        _ => {}
    }
}

/// The model parameters of an effect switched on in `m` (registry name without the effect
/// prefix, unit, value): what `augmented.json` holds and the report shows.
pub fn model_params(name: &str, m: &Model) -> Vec<(&'static str, &'static str, f64)> {
    EffectKind::from_name(name)
        .into_iter()
        .flat_map(effects::params_of)
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
    /// Active candidates (name, fit-space values), in order of addition.
    pub effects: Vec<(String, Vec<f64>)>,
    /// |B| at the middle of the data's z_m range \[T\] (the reference of `phase_lag`'s f_mid).
    pub b_mid: f64,
    /// Learned shapes along effects' axes (name of the effect, shape), in order of addition:
    /// applied by [`predict`] after the parametric effects, and written into the model file
    /// as learned effect terms by [`Augmented::model_file`].
    pub learned: Vec<(String, Shape)>,
}

impl Augmented {
    /// The baseline alone (any effect of `model` switched off).
    pub fn baseline(model: &Model, ctx: &Ctx) -> Augmented {
        let mut model = model.clone();
        model.effects = Effects::default();
        Augmented {
            model,
            effects: Vec::new(),
            b_mid: ctx.b_mid,
            learned: Vec::new(),
        }
    }

    /// Write the candidates' values into the model's effects section (and nothing else on).
    pub fn sync_model(&mut self) {
        self.model.effects = Effects::default();
        for (n, v) in &self.effects {
            to_model(n, v, self.b_mid, &mut self.model);
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
        for (name, sh) in &self.learned {
            super::learned::push(&mut m, name, sh, self.b_mid);
        }
        m
    }
}

/// What the candidates need to know of the training data besides its rows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ctx {
    /// |B| at the middle of the z_m range of the training data \[T\].
    pub b_mid: f64,
    /// Largest z_m of the training data \[mm\].
    pub z_max: f64,
    /// Smallest z_m of the training data \[mm\].
    pub z_min: f64,
    /// Smallest f of the training data \[Hz\].
    pub f_min: f64,
    /// Largest f of the training data \[Hz\].
    pub f_max: f64,
    /// Smallest positive spacing of rows within a session \[s\].
    pub dt_min: f64,
    /// Longest session \[s\].
    pub t_span: f64,
    /// The baseline's lateral distance of the swarm from the rotation axis \[mm\].
    pub lateral_mm: f64,
}

impl Ctx {
    /// From the data set.
    pub fn new(model: &Model, ds: &Dataset) -> Ctx {
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
        Ctx {
            b_mid: field_b(model, (z_min + z_max) / 2.0).max(1e-12),
            z_max,
            z_min,
            f_min: fs.first().copied().unwrap_or(1.0),
            f_max: fs.last().copied().unwrap_or(10.0),
            dt_min: if dt_min.is_finite() { dt_min } else { 1.0 },
            t_span,
            lateral_mm: model.magnet.lateral_offset_m * 1e3,
        }
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
        .map(|&(z, _)| (field_b(m, z) / aug.b_mid).max(1e-300).ln())
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
    // The learned steady shapes' change of the steady map, per point (a rate deficit
    // re-evaluates the map at the slower rotation).
    let mut corr = vec![[0.0; 2]; map.len()];
    let mut map2 = map.to_vec();
    for (_, sh) in aug
        .learned
        .iter()
        .filter(|(_, s)| steady_axes(s.family.axis))
    {
        for (p, v) in map2.iter_mut().enumerate() {
            let scale = (sh.family.amp * ln_b[p]).exp();
            let c = sh.at(x_of(sh.family.axis, p, 0.0, 0.0)).map(|c| c * scale);
            let before = *v;
            match sh.family.mode {
                Mode::Relative | Mode::Aspect => {
                    for a in 0..2 {
                        v[a] *= 1.0 + c[a];
                    }
                }
                Mode::Rate => {
                    let (z, f) = ds.points[p];
                    let shifted = map_point(m, z, f - c[0]);
                    for a in 0..2 {
                        v[a] += shifted[a] - map[p][a];
                    }
                }
                _ => {
                    for a in 0..2 {
                        v[a] += c[a];
                    }
                }
            }
            for a in 0..2 {
                corr[p][a] += v[a] - before[a];
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
                    Mode::Relative | Mode::Aspect => out[i][a] *= 1.0 + c[a],
                    Mode::StepFraction => out[i][a] += c[a] * delta[a],
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

/// Step-out frequency \[Hz\] of a model's `phase_lag` at z_m \[mm\] (None when it is off).
pub fn step_out_hz(model: &Model, z_mm: f64) -> Option<f64> {
    let pl = model.effects.phase_lag?;
    let b = field_b(model, z_mm) / model.steady.B_ref;
    Some(pl.f_so_hz * b.powf(pl.nu))
}

/// Why a fitted candidate is not a plausible description of the data's residual (empty:
/// plausible): a location outside the data (a step-out that no measured frequency reaches, or
/// one below every measured frequency at every field, is a trend over the whole grid, not a
/// step-out; a fade that starts before the smallest z_m likewise).
pub fn implausible(name: &str, aug: &Augmented, ctx: &Ctx) -> Vec<String> {
    let m = aug.synced();
    let mut out = Vec::new();
    match name {
        "phase_lag" => {
            if let (Some(a), Some(b)) = (step_out_hz(&m, ctx.z_min), step_out_hz(&m, ctx.z_max)) {
                let (lo, hi) = (a.min(b), a.max(b));
                if hi < ctx.f_min || lo > ctx.f_max {
                    out.push(format!(
                        "step-out frequency {lo:.3}-{hi:.3} Hz over the data's z_m outside the \
                         measured frequencies [{}, {}] Hz",
                        ctx.f_min, ctx.f_max
                    ));
                }
            }
        }
        "cohesion_loss" => {
            if let Some(c) = m.effects.cohesion_loss {
                if c.z_c_mm < ctx.z_min || c.z_c_mm >= ctx.z_max {
                    out.push(format!(
                        "onset z_c = {:.3} mm outside the data's z_m range [{}, {}) mm",
                        c.z_c_mm, ctx.z_min, ctx.z_max
                    ));
                }
            }
        }
        _ => {}
    }
    out
}
