//! Shapes along an effect's axis: the flexible half of every candidate, and the generic
//! structures the gap tests look for.
//!
//! A shape is a piecewise-linear function of one variable with heights at knots and flat
//! extrapolation beyond the end knots -- the same interpolation the model's learned effect
//! term uses, so a shape fitted here runs unchanged in `predict` and the FMU. Each effect
//! keeps its physical axis and way of acting:
//!
//! | effect | axis | acts as |
//! | --- | --- | --- |
//! | `phase_lag` | f, optionally scaled by the field, `f (B(z)/B_mid)^-nu` (an onset that moves with the field) | mm added to the steady radii |
//! | `cohesion_loss` | z_m | a relative change of both radii the same way (r1's at 1/2, 1 or 2 times r2's), or mm added to one radius |
//! | `particle_drift` | session time | relative change of the observed radii |
//! | `centroid_offset` | z_m, or f with an amplitude going as `d^-2` (`(B/B_mid)^(2/3)`) | an aspect change: r1 and r2 in opposite proportion, r1's at 1/2, 1 or 2 times r2's |
//! | `formation_lag` | time since the last input change | fraction of that change's step still missing (any stable transient: monotone, overshooting, oscillating; after every change, or only after those that make a radius grow, or shrink; optionally only what varies within each visit, for naming) |
//!
//! The heights are unknowns of a penalised linear model ([`super::linear`]): the roughness
//! penalty keeps a shape smooth unless the data insist (a sudden particle loss is a steep
//! segment between two knots).

use super::data::Dataset;
use super::linear::{self, Design};
use nalgebra::DMatrix;

/// The variable a shape runs along.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Axis {
    /// Field frequency \[Hz\], scaled by `(B(z_m)/B_mid)^-nu`.
    F {
        /// Field exponent of the onset.
        nu: f64,
    },
    /// Magnet distance z_m \[mm\].
    Z,
    /// Session time \[s\].
    T,
    /// Time since the last input change \[s\].
    Since,
}

impl Axis {
    /// Name as in the model file's learned terms.
    pub fn key(self) -> &'static str {
        match self {
            Axis::F { .. } => "f_hz",
            Axis::Z => "z_m_mm",
            Axis::T => "t_s",
            Axis::Since => "since_change_s",
        }
    }

    /// Label with unit, for tables and figures.
    pub fn label(self) -> String {
        match self {
            Axis::F { nu } if nu != 0.0 => format!("f (B/B_mid)^-{nu} [Hz]"),
            Axis::F { .. } => "f [Hz]".into(),
            Axis::Z => "z_m [mm]".into(),
            Axis::T => "session time [s]".into(),
            Axis::Since => "time since input change [s]".into(),
        }
    }
}

/// How the shape's value acts on a radius.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Added \[mm\].
    Add,
    /// Relative change [-]: r (1 + v).
    Relative,
    /// Fraction of the last input change's step of the steady map [-].
    StepFraction,
    /// A deficit of the swarm's rotation rate \[Hz\]: the steady map at the drive frequency
    /// less the value (one value for both radii: a step-out slows the whole swarm).
    Rate,
    /// A change of the swarm's aspect [-]: r1 (1 - ratio v) and r2 (1 + v), one value for both
    /// radii (stretched along one principal direction, squeezed along the other). Written
    /// into the model file as a relative change with opposite heights.
    Aspect,
    /// A relative change of the swarm as a whole [-]: r1 (1 + ratio v) and r2 (1 + v), one
    /// value for both radii (a loosening swarm grows along both principal directions: the
    /// signature that tells a cohesion loss from an aspect change).
    Common,
}

impl Mode {
    /// Name as in the model file's learned terms.
    pub fn key(self) -> &'static str {
        match self {
            Mode::Add => "add_mm",
            Mode::Relative => "relative",
            Mode::StepFraction => "step_fraction",
            Mode::Rate => "rate_hz",
            Mode::Aspect => "aspect",
            Mode::Common => "common",
        }
    }
}

/// A family of shapes: axis, mode, knots and smoothing.
#[derive(Debug, Clone, PartialEq)]
pub struct Family {
    /// Axis.
    pub axis: Axis,
    /// Mode.
    pub mode: Mode,
    /// Knots (strictly increasing).
    pub knots: Vec<f64>,
    /// Heights of the first knot held at 0 (a band that starts past it).
    pub pin_first: bool,
    /// Heights of the last knot held at 0 (a transient that has died out, a band that ends
    /// before it).
    pub pin_last: bool,
    /// Roughness weight relative to the columns' mean information.
    pub smooth: f64,
    /// Exponent of the field in the amplitude: the value acts scaled by `(B(z_m)/B_mid)^amp`
    /// (a step-out that shows where the field is strong).
    pub amp: f64,
    /// The radii the shape acts on (r1, r2): an effect may show in one only (a band of r2);
    /// a shape that also fits the other radius would fit its noise. Ignored by `Rate`, which
    /// acts on both through the map.
    pub axes: [bool; 2],
    /// The heights must run one way along the axis (a drift, a growth past an onset): each
    /// radius' heights are a monotone block of the fit.
    pub monotone: Option<linear::Monotone>,
    /// Only what varies within each visit counts (each visit's mean of the columns taken
    /// out): evidence of a transient that no visit offset can make, for naming; the shape
    /// that enters a model is always the whole one.
    pub within: bool,
    /// For [`Mode::Aspect`]: r1's relative change per unit of r2's (opposite in sign). Off
    /// the axis nothing makes the two principal directions deform equally; the variants
    /// take one to be twice or half the other, beside equal. For [`Mode::Common`] the same
    /// ratio of the same sign: the two principal stiffnesses differ (7), so a loosening
    /// swarm need not grow by the same share along both.
    pub ratio: f64,
    /// For [`Mode::StepFraction`]: the input changes whose transient the shape describes,
    /// per radius by the sign of the step of the steady map. A swarm need not form the same
    /// way when it grows (particles gathered from further out) as when it contracts.
    pub steps: Steps,
    /// For `StepFraction`: heights scaled by `|step| / size_mm` (a transient that grows with
    /// the step's size, not in proportion to it; the model file's `step_size_mm`); 0: off.
    pub size_mm: f64,
}

/// Which input changes a transient follows, per radius by the sign of its step: the model
/// file's own (a learned term carries it as is).
pub use magswarm_model::learned::LearnedSteps as Steps;

impl Family {
    /// r1's relative change per unit of r2's for the modes with one value for both radii
    /// as a relative change: the opposite of `ratio` for an aspect change, `ratio` itself
    /// for a common one; 1 otherwise. The design's columns and the written shape both use it.
    fn r1_share(&self) -> f64 {
        match self.mode {
            Mode::Aspect => -self.ratio,
            Mode::Common => self.ratio,
            _ => 1.0,
        }
    }

    /// A family acting on both radii, unscaled by the field, heights free at every knot.
    pub fn new(axis: Axis, mode: Mode, knots: Vec<f64>, smooth: f64) -> Family {
        Family {
            axis,
            mode,
            knots,
            pin_first: false,
            pin_last: false,
            smooth,
            amp: 0.0,
            axes: [true; 2],
            monotone: None,
            within: false,
            ratio: 1.0,
            steps: Steps::All,
            size_mm: 0.0,
        }
    }
}

/// A fitted shape.
#[derive(Debug, Clone, PartialEq)]
pub struct Shape {
    /// Its family.
    pub family: Family,
    /// Heights at the knots per axis (r1, r2).
    pub values: [Vec<f64>; 2],
    /// 1-SD uncertainty of the heights per axis.
    pub sd: [Vec<f64>; 2],
}

impl Shape {
    /// Value at `x` per axis (piecewise linear, flat beyond the ends).
    pub fn at(&self, x: f64) -> [f64; 2] {
        let h = hat(&self.family.knots, x);
        let mut out = [0.0; 2];
        for (a, o) in out.iter_mut().enumerate() {
            *o = h.iter().map(|&(j, w)| w * self.values[a][j]).sum();
        }
        out
    }
}

/// Hat-function weights of `x` on `knots`: at most two (index, weight) pairs.
pub fn hat(knots: &[f64], x: f64) -> Vec<(usize, f64)> {
    let k = knots.len();
    if k == 0 {
        return Vec::new();
    }
    if x <= knots[0] {
        return vec![(0, 1.0)];
    }
    if x >= knots[k - 1] {
        return vec![(k - 1, 1.0)];
    }
    let j = knots
        .partition_point(|&v| v <= x)
        .saturating_sub(1)
        .min(k - 2);
    let u = (x - knots[j]) / (knots[j + 1] - knots[j]);
    vec![(j, 1.0 - u), (j + 1, u)]
}

/// The finite values of `xs` in increasing order, values closer than `rel` (relative, plus
/// as much absolute) to the previous one kept once.
fn distinct(xs: &[f64], rel: f64) -> Vec<f64> {
    let mut v: Vec<f64> = xs.iter().copied().filter(|x| x.is_finite()).collect();
    v.sort_by(|a, b| a.total_cmp(b));
    v.dedup_by(|a, b| (*a - *b).abs() < rel * (1.0 + b.abs()));
    v
}

/// Up to `k` knots spread over the distinct values of `xs` (their quantiles, ends included).
pub fn knots_of(xs: &[f64], k: usize) -> Vec<f64> {
    let v = distinct(xs, 1e-9);
    if v.len() <= k {
        return v;
    }
    let n = v.len();
    let mut out: Vec<f64> = (0..k).map(|i| v[i * (n - 1) / (k - 1)]).collect();
    out.dedup();
    out
}

/// `k` knots (a few more where snapping merges targets) over a time since a change, spaced
/// evenly in its logarithm and each placed on a value the data have: a transient changes
/// fastest just after the change and slowly later, so knots at quantiles of the times (rows
/// streamed at a fixed rate, and the long times of visits that follow a pause) leave a
/// transient of a few seconds to a single hat. Times at or below 0 are shifted by the smallest
/// positive one before the logarithm.
pub fn log_knots_of(xs: &[f64], k: usize) -> Vec<f64> {
    // Times logged to the millisecond differ by rounding from visit to visit: one knot.
    let v = distinct(xs, 1e-3);
    if v.len() <= k {
        return v;
    }
    let Some(c) = v.iter().copied().find(|&x| x > 0.0) else {
        return knots_of(&v, k);
    };
    let shift = if v[0] <= 0.0 { 2.0 * c - v[0] } else { 0.0 };
    let u: Vec<f64> = v.iter().map(|&x| (x + shift).ln()).collect();
    let (lo, hi) = (u[0], u[u.len() - 1]);
    if hi <= lo {
        return knots_of(&v, k);
    }
    // Snapping to the data merges targets where rows are sparser than the spacing (the first
    // seconds of a 1 Hz stream): ask for more targets until k distinct knots come out.
    let mut out = Vec::new();
    for m in k..=4 * k {
        out.clear();
        let mut j = 0;
        for i in 0..m {
            let target = lo + (hi - lo) * i as f64 / (m - 1) as f64;
            while j + 1 < u.len() && (u[j + 1] - target).abs() <= (u[j] - target).abs() {
                j += 1;
            }
            if out.last() != Some(&v[j]) {
                out.push(v[j]);
            }
        }
        if out.len() >= k {
            break;
        }
    }
    out
}

/// Everything a shape needs to know of each row.
#[derive(Debug, Clone)]
pub struct RowCtx {
    /// Row weights per axis (1 / row SD).
    pub w: [f64; 2],
    /// z_m \[mm\] per row.
    pub z: Vec<f64>,
    /// f \[Hz\] per row.
    pub f: Vec<f64>,
    /// ln(B(z)/B_mid) per row.
    pub ln_b: Vec<f64>,
    /// Session time per row \[s\].
    pub t: Vec<f64>,
    /// Time since the visit's input change per row \[s\].
    pub since: Vec<f64>,
    /// The step of the current model's steady map at the row's visit's input change
    /// (0 for a session's first visit) \[mm\].
    pub delta: Vec<[f64; 2]>,
    /// The current model's prediction per row \[mm\].
    pub pred: Vec<[f64; 2]>,
    /// Sensitivity of the steady map to the drive frequency at each row's point [mm/Hz].
    pub dmap_df: Vec<[f64; 2]>,
    /// Visit of each row.
    pub visit: Vec<usize>,
    /// Nuisance columns (weighted, stacked rows) that only the shapes judged within the
    /// visits see beside the current design: the rig's own approach after a change at time
    /// scales a formation effect might have too, which only the row noise resolves (none:
    /// no column).
    pub within_nuisance: DMatrix<f64>,
}

impl RowCtx {
    /// From the data set, the current model's predictions and steady map at the points, the
    /// field at each row (ln B/B_mid) and the row weights.
    pub fn new(
        ds: &Dataset,
        pred: &[[f64; 2]],
        map: &[[f64; 2]],
        dmap_df: &[[f64; 2]],
        ln_b: Vec<f64>,
        w: [f64; 2],
    ) -> RowCtx {
        let delta = ds
            .rows
            .iter()
            .map(|r| match ds.visits[r.visit].prev {
                Some(pv) => {
                    let (a, b) = (map[r.point], map[ds.visits[pv].point]);
                    [a[0] - b[0], a[1] - b[1]]
                }
                None => [0.0; 2],
            })
            .collect();
        RowCtx {
            w,
            z: ds.rows.iter().map(|r| r.z).collect(),
            f: ds.rows.iter().map(|r| r.f).collect(),
            ln_b,
            t: ds.rows.iter().map(|r| r.t).collect(),
            since: ds.rows.iter().map(|r| r.since).collect(),
            delta,
            pred: pred.to_vec(),
            dmap_df: ds.rows.iter().map(|r| dmap_df[r.point]).collect(),
            visit: ds.rows.iter().map(|r| r.visit).collect(),
            within_nuisance: DMatrix::zeros(2 * ds.rows.len(), 0),
        }
    }

    /// Rows.
    pub fn len(&self) -> usize {
        self.z.len()
    }

    /// True without rows.
    pub fn is_empty(&self) -> bool {
        self.z.is_empty()
    }

    /// The axis variable at row i.
    pub fn x(&self, axis: Axis, i: usize) -> f64 {
        match axis {
            Axis::F { nu } => self.f[i] * (-nu * self.ln_b[i]).exp(),
            Axis::Z => self.z[i],
            Axis::T => self.t[i],
            Axis::Since => self.since[i],
        }
    }

    /// The axis variable at every row.
    pub fn xs(&self, axis: Axis) -> Vec<f64> {
        (0..self.len()).map(|i| self.x(axis, i)).collect()
    }

    /// Multiplier of a shape's value at row i on axis a (by the mode).
    fn gain(&self, f: &Family, i: usize, a: usize) -> f64 {
        let scale = if f.amp != 0.0 {
            (f.amp * self.ln_b[i]).exp()
        } else {
            1.0
        };
        scale
            * match f.mode {
                Mode::Add => 1.0,
                Mode::Relative => self.pred[i][a],
                Mode::Aspect | Mode::Common => {
                    self.pred[i][a] * if a == 0 { f.r1_share() } else { 1.0 }
                }
                Mode::StepFraction => {
                    let d = self.delta[i][a];
                    d * magswarm_model::learned::step_share(f.steps, f.size_mm, d)
                }
                Mode::Rate => -self.dmap_df[i][a],
            }
    }
}

/// Heights that are unknowns (all but pinned end knots).
pub fn free_knots(f: &Family) -> usize {
    f.knots.len() - usize::from(f.pin_first) - usize::from(f.pin_last)
}

/// One set of heights for both radii (a rate deficit acts on the whole swarm, an aspect change
/// and a change of the whole swarm on both principal radii at once).
fn shared(f: &Family) -> bool {
    matches!(f.mode, Mode::Rate | Mode::Aspect | Mode::Common)
}

/// The weighted columns of a family (stacked rows x 2 free-knot blocks, r1's then r2's) and
/// its roughness penalty, scaled to the columns' information.
pub fn columns(f: &Family, rc: &RowCtx) -> (DMatrix<f64>, DMatrix<f64>) {
    let k = free_knots(f);
    let first = usize::from(f.pin_first);
    let n = rc.len();
    let blocks = if shared(f) { 1 } else { 2 };
    let mut a = DMatrix::zeros(2 * n, blocks * k);
    for i in 0..n {
        for (j, wt) in hat(&f.knots, rc.x(f.axis, i)) {
            if j < first || j >= first + k {
                continue;
            }
            let j = j - first;
            for ax in 0..2 {
                if blocks == 2 && !f.axes[ax] {
                    continue;
                }
                let col = if blocks == 1 { j } else { ax * k + j };
                a[(2 * i + ax, col)] = wt * rc.gain(f, i, ax) * rc.w[ax];
            }
        }
    }
    if f.within {
        within_visits(&rc.visit, &mut a);
    }
    let info = column_info(&a).max(1e-12);
    let pen = linear::roughness(k, blocks, f.smooth * info, 1e-3 * info);
    (a, pen)
}

/// The mean squared norm of a design fragment's columns (0 without columns): the scale its
/// penalties are set relative to, so that a smoothing means the same whatever the units.
pub(crate) fn column_info(a: &DMatrix<f64>) -> f64 {
    (0..a.ncols())
        .map(|c| a.column(c).norm_squared())
        .sum::<f64>()
        / a.ncols().max(1) as f64
}

/// Takes each visit's mean per axis out of every column (stacked rows): what is left varies
/// within a visit.
pub fn within_visits(visit: &[usize], a: &mut DMatrix<f64>) {
    let nv = visit.iter().copied().max().map_or(0, |m| m + 1);
    for c in 0..a.ncols() {
        let mut sum = vec![[0.0f64; 2]; nv];
        let mut n = vec![0.0f64; nv];
        for (i, &v) in visit.iter().enumerate() {
            for ax in 0..2 {
                sum[v][ax] += a[(2 * i + ax, c)];
            }
            n[v] += 1.0;
        }
        for (i, &v) in visit.iter().enumerate() {
            for ax in 0..2 {
                a[(2 * i + ax, c)] -= sum[v][ax] / n[v].max(1.0);
            }
        }
    }
}

/// Design `d` as the shapes judged within the visits see it: with the within-only nuisance
/// columns, each visit's mean taken out of every column. Against `d`'s own columns, which
/// vary between visits (a time scale, the steady parameters), a within shape's refit would
/// move them, and the visits' offsets, several times the row noise, would pass into its
/// drop.
pub fn within_design(d: &Design, rc: &RowCtx) -> Design {
    let m = rc.within_nuisance.ncols();
    let mut out = if m > 0 {
        d.extend(
            &rc.within_nuisance,
            &(DMatrix::identity(m, m) * WITHIN_NUISANCE_RIDGE),
        )
    } else {
        d.clone()
    };
    within_visits(&rc.visit, &mut out.a);
    out
}

/// Ridge on the within-only nuisance's unit-norm columns.
const WITHIN_NUISANCE_RIDGE: f64 = 1e-2;

/// A transient whose course depends on the size of the step, judged within the visits
/// beside *any* course that is proportional to the step: (null, alternative) designs.
///
/// Why: a rig's own approach law is linear in the step however it is shaped (first or
/// second order, a time constant that changes with depth), so another lab's law, which
/// ODE (4) does not follow, leaves a residual `step x g(since, z_m)`. The null here takes
/// every such course: a free shape after each change (`fine`, per radius), and the same
/// coarse shape modulated by the centred depth and its square (a time scale that varies
/// with depth), on top of `base_within`, whose own transient column (ODE (4)'s replay less
/// its map, coefficient free) can take the baseline's nonlinear approach out altogether.
/// What the alternative adds, the coarse shape modulated by the step's centred size, only a
/// formation that is not linear in the step makes: a rate limit (a large change takes
/// longer, a small one not), a nucleation threshold. None where the steps are all of one
/// size or there is no change.
pub fn step_size_designs(
    base_within: &Design,
    fine: &Family,
    coarse: &Family,
    rc: &RowCtx,
) -> Option<(Design, Design)> {
    let n = rc.len();
    let after: Vec<[bool; 2]> = rc
        .delta
        .iter()
        .map(|d| [d[0] != 0.0, d[1] != 0.0])
        .collect();
    // A factor per row and axis, centred and scaled over the rows that follow a change.
    let standard = |x: &dyn Fn(usize, usize) -> f64| -> Option<Vec<[f64; 2]>> {
        let mut out = vec![[0.0; 2]; n];
        for ax in 0..2 {
            let v: Vec<f64> = (0..n).filter(|&i| after[i][ax]).map(|i| x(i, ax)).collect();
            if v.len() < 3 {
                return None;
            }
            let m = crate::stats::mean(&v);
            let sd = (v.iter().map(|a| (a - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt();
            if sd.is_nan() || sd <= 1e-9 * m.abs().max(1e-9) {
                return None;
            }
            for i in (0..n).filter(|&i| after[i][ax]) {
                out[i][ax] = (x(i, ax) - m) / sd;
            }
        }
        Some(out)
    };
    let size = standard(&|i, ax| rc.delta[i][ax].abs())?;
    let zc = standard(&|i, _| rc.z[i]).unwrap_or_else(|| vec![[0.0; 2]; n]);
    let zc2 = standard(&|i, _| {
        let z = rc.z[i];
        z * z
    })
    .unwrap_or_else(|| vec![[0.0; 2]; n]);
    let (raw, _) = columns(
        &Family {
            within: false,
            ..coarse.clone()
        },
        rc,
    );
    let k = free_knots(coarse);
    let modulated = |fac: &[[f64; 2]]| -> Option<(DMatrix<f64>, DMatrix<f64>)> {
        let mut a = raw.clone();
        for i in 0..n {
            for ax in 0..2 {
                a.row_mut(2 * i + ax).scale_mut(fac[i][ax]);
            }
        }
        within_visits(&rc.visit, &mut a);
        let info = column_info(&a);
        if info.is_nan() || info <= 1e-12 {
            return None;
        }
        let pen = linear::roughness(k, 2, coarse.smooth * info, 1e-3 * info);
        Some((a, pen))
    };
    let (g, gp) = columns(
        &Family {
            within: true,
            ..fine.clone()
        },
        rc,
    );
    let mut null = base_within.extend(&g, &gp);
    for fac in [&zc, &zc2] {
        if let Some((a, p)) = modulated(fac) {
            null = null.extend(&a, &p);
        }
    }
    let (h, hp) = modulated(&size)?;
    let alt = null.extend(&h, &hp);
    Some((null, alt))
}

/// The columns, penalty and monotone blocks of a family, as a design fragment.
pub fn design(f: &Family, rc: &RowCtx) -> Design {
    let (a, pen) = columns(f, rc);
    let mut d = Design::new(a, pen);
    if let Some(dir) = f.monotone {
        let k = free_knots(f);
        let blocks = if shared(f) { 1 } else { 2 };
        d.mono = (0..blocks)
            .map(|b| linear::MonoBlock {
                start: b * k,
                len: k,
                dir,
            })
            .collect();
    }
    d
}

/// The shape whose heights are `coef` (the family's free knots, r1's then r2's) with their
/// SDs, as a model term would carry it.
pub fn shape_of(f: &Family, coef: &[f64], sd: &[f64]) -> Shape {
    let k = free_knots(f);
    let one = shared(f);
    let take = |v: &[f64], a: usize| -> Vec<f64> {
        let b = if one { 0 } else { a };
        let mut out: Vec<f64> = Vec::with_capacity(f.knots.len());
        if f.pin_first {
            out.push(0.0);
        }
        out.extend_from_slice(&v[b * k..(b + 1) * k]);
        if f.pin_last {
            out.push(0.0);
        }
        out
    };
    let mut values = [take(coef, 0), take(coef, 1)];
    let mut sds = [take(sd, 0), take(sd, 1)];
    // A radius the shape does not act on is 0 by construction, with no uncertainty: its
    // heights carry no column of the design, and the penalty's prior SD there is no
    // statement about the swarm (it drew +/- 4 mm bands around an r2-only loosening's r1).
    for a in 0..2 {
        if !one && !f.axes[a] {
            values[a].iter_mut().for_each(|v| *v = 0.0);
            sds[a].iter_mut().for_each(|v| *v = 0.0);
        }
    }
    if matches!(f.mode, Mode::Aspect | Mode::Common) {
        // Per radius, as a relative change: r1's `ratio` times r2's, opposite in an aspect
        // change, alike in a common one.
        let k = f.r1_share();
        values[0].iter_mut().for_each(|v| *v *= k);
        sds[0].iter_mut().for_each(|v| *v *= k.abs());
    }
    Shape {
        family: f.clone(),
        values,
        sd: sds,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The step-size test's designs (`step_size_designs`) on visits of ten rows spread
    /// 0.6-30 s after changes of many sizes, at five depths. A rig whose own approach is
    /// linear in the step -- critically damped, with a time constant that grows 2.4 times
    /// with depth, where the baseline's transient is first order at 1 s -- leaves the
    /// alternative a drop of the order of its columns (chance), although that law's
    /// mismatch is far beyond the row noise; a rate limit on top of a first-order approach
    /// (1 mm/s, so the larger steps take longer) leaves it a drop far beyond.
    #[test]
    fn a_transient_growing_with_its_step_shows_beside_any_approach_linear_in_the_step() {
        use nalgebra::DVector;
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let mut g = || -> f64 { StandardNormal.sample(&mut rng) };
        let times = [0.6, 0.9, 1.4, 2.2, 3.4, 5.2, 8.0, 12.3, 19.0, 30.0];
        let nv = 60usize;
        let n = nv * times.len();
        let depth = |v: usize| 3.5 + 5.0 * (v % 5) as f64;
        let step: Vec<[f64; 2]> = (0..nv)
            .map(|v| {
                let a = 0.3 + 0.27 * ((v * 7) % 11) as f64;
                let s = if (v / 5) % 2 == 0 { 1.0 } else { -1.0 };
                [0.5 * s * a, s * a]
            })
            .collect();
        let (row_sd, w) = (0.05, 20.0);
        let rc = RowCtx {
            w: [w, w],
            z: (0..n).map(|i| depth(i / times.len())).collect(),
            f: vec![5.0; n],
            ln_b: vec![0.0; n],
            t: (0..n)
                .map(|i| 32.0 * (i / times.len()) as f64 + times[i % times.len()])
                .collect(),
            since: (0..n).map(|i| times[i % times.len()]).collect(),
            delta: (0..n).map(|i| step[i / times.len()]).collect(),
            pred: vec![[5.0, 8.0]; n],
            dmap_df: vec![[0.0; 2]; n],
            visit: (0..n).map(|i| i / times.len()).collect(),
            within_nuisance: DMatrix::zeros(2 * n, 0),
        };
        // The baseline: its own first-order transient at 1 s, per radius, coefficient free.
        let ode = |i: usize, ax: usize| rc.delta[i][ax] * (-rc.since[i]).exp();
        let base = Design::new(
            DMatrix::from_fn(
                2 * n,
                2,
                |s, c| if s % 2 == c { w * ode(s / 2, c) } else { 0.0 },
            ),
            DMatrix::identity(2, 2) * 1e-8,
        );
        let base_within = within_design(&base, &rc);
        let fine = crate::detect::since_family(&rc, 0.01, crate::detect::SINCE_FINE_KNOTS).unwrap();
        let coarse = crate::detect::since_family(&rc, 0.3, 6).unwrap();
        let (null, alt) = step_size_designs(&base_within, &fine, &coarse, &rc).unwrap();
        let one = vec![0usize; 2 * n];
        let (s0, s1) = (
            linear::Solver::new(&null, &one, 1).unwrap(),
            linear::Solver::new(&alt, &one, 1).unwrap(),
        );
        let noise: Vec<f64> = (0..2 * n).map(|_| g()).collect();
        let offsets: Vec<f64> = (0..2 * nv).map(|_| 6.0 * g()).collect();
        // Weighted residual: the measured missing part of the step less the baseline's, row
        // noise, and an offset per visit.
        let log = |missing: &dyn Fn(usize, usize) -> f64| {
            DVector::from_fn(2 * n, |s, _| {
                let (i, ax) = (s / 2, s % 2);
                w * (missing(i, ax) - ode(i, ax) + row_sd * noise[s])
                    + offsets[2 * rc.visit[i] + ax]
            })
        };
        let drop = |y: &DVector<f64>| {
            let sse = |e: DVector<f64>| e.norm_squared();
            sse(s0.residual(y)) - sse(s1.residual(y))
        };
        let critical = |i: usize, ax: usize| {
            let tau =
                0.4 * (1.0 + 1.2 * (rc.z[i] / 23.5).powi(2)) * if ax == 1 { 1.3 } else { 1.0 };
            let u = rc.since[i] / tau;
            rc.delta[i][ax] * (1.0 + u) * (-u).exp()
        };
        let (tau, vmax) = (0.5, 1.0);
        let limited = |i: usize, ax: usize| {
            let (d, s) = (rc.delta[i][ax], rc.since[i]);
            // |x| falls at vmax until the first-order rate drops below it (|x| = vmax tau).
            let t1 = ((d.abs() - vmax * tau) / vmax).max(0.0);
            let x = if s < t1 {
                d.abs() - vmax * s
            } else {
                d.abs().min(vmax * tau) * (-(s - t1) / tau).exp()
            };
            d.signum() * x
        };
        let mismatch = (0..n)
            .flat_map(|i| [0, 1].map(|ax| (w * (critical(i, ax) - ode(i, ax))).powi(2)))
            .sum::<f64>();
        let (linear_law, rate_limit) = (drop(&log(&critical)), drop(&log(&limited)));
        let dof = alt.a.ncols() - null.a.ncols();
        assert!(mismatch > 1e4, "the linear law's mismatch: {mismatch:.0}");
        assert!(
            linear_law < 3.0 * dof as f64,
            "a linear approach law: drop {linear_law:.1} ({dof} columns)"
        );
        assert!(
            rate_limit > 30.0 * dof as f64,
            "a rate limit: drop {rate_limit:.1} ({dof} columns)"
        );
    }

    #[test]
    fn a_radius_the_shape_does_not_act_on_is_zero_and_certain() {
        let f = Family {
            axes: [false, true],
            ..Family::new(Axis::Z, Mode::Add, vec![1.0, 2.0, 4.0], 1.0)
        };
        let k = free_knots(&f);
        let coef: Vec<f64> = (0..2 * k).map(|i| 0.1 * i as f64).collect();
        let sd = vec![2.0; 2 * k];
        let sh = shape_of(&f, &coef, &sd);
        assert!(
            sh.values[0].iter().chain(&sh.sd[0]).all(|&v| v == 0.0),
            "{sh:?}"
        );
        assert!(sh.sd[1].iter().all(|&v| v == 2.0), "{sh:?}");
        assert_eq!(sh.values[1], coef[k..].to_vec());
    }

    #[test]
    fn hats_interpolate_and_extrapolate_flat() {
        let k = [1.0, 2.0, 4.0];
        assert_eq!(hat(&k, 0.0), vec![(0, 1.0)]);
        assert_eq!(hat(&k, 5.0), vec![(2, 1.0)]);
        let h = hat(&k, 3.0);
        assert_eq!(h.len(), 2);
        assert_eq!((h[0].0, h[1].0), (1, 2));
        assert!((h[0].1 - 0.5).abs() < 1e-12 && (h[1].1 - 0.5).abs() < 1e-12);
        let s = Shape {
            family: Family {
                axis: Axis::Z,
                mode: Mode::Add,
                knots: k.to_vec(),
                pin_first: false,
                pin_last: false,
                amp: 0.0,
                axes: [true; 2],
                monotone: None,
                within: false,
                smooth: 0.0,
                ratio: 1.0,
                steps: Steps::All,
                size_mm: 0.0,
            },
            values: [vec![0.0, 1.0, 3.0], vec![0.0, 0.0, 0.0]],
            sd: [vec![0.0; 3], vec![0.0; 3]],
        };
        assert!((s.at(3.0)[0] - 2.0).abs() < 1e-12);
        assert!((s.at(9.0)[0] - 3.0).abs() < 1e-12);
    }

    /// An aspect change with r1's relative change twice r2's is written per radius with
    /// r1's heights (and their SDs) at -2 and 2 times r2's: what the model file carries.
    #[test]
    fn an_aspect_ratio_reaches_the_written_shape() {
        let f = Family {
            ratio: 2.0,
            pin_first: true,
            ..Family::new(Axis::F { nu: 0.0 }, Mode::Aspect, vec![1.0, 5.0, 10.0], 1.0)
        };
        let sh = shape_of(&f, &[0.01, 0.03], &[0.001, 0.002]);
        assert_eq!(sh.values[1], vec![0.0, 0.01, 0.03]);
        assert_eq!(sh.values[0], vec![-0.0, -0.02, -0.06]);
        assert_eq!(sh.sd[0], vec![0.0, 0.002, 0.004]);
        assert_eq!(sh.sd[1], vec![0.0, 0.001, 0.002]);
    }

    /// A loosening with r1's relative change half r2's is written per radius with r1's
    /// heights (and their SDs) at half r2's, of the same sign: both radii grow.
    #[test]
    fn a_common_ratio_reaches_the_written_shape() {
        let f = Family {
            ratio: 0.5,
            ..Family::new(Axis::Z, Mode::Common, vec![3.5, 13.5, 23.5], 0.1)
        };
        let sh = shape_of(&f, &[0.0, 0.02, 0.06], &[0.001, 0.002, 0.004]);
        assert_eq!(sh.values[1], vec![0.0, 0.02, 0.06]);
        assert_eq!(sh.values[0], vec![0.0, 0.01, 0.03]);
        assert_eq!(sh.sd[0], vec![0.0005, 0.001, 0.002]);
        // The design sees the same: r1's column is half r2's at every row.
        let rc = RowCtx {
            z: vec![8.5],
            f: vec![5.0],
            t: vec![1.0],
            since: vec![1.0],
            pred: vec![[9.0, 12.0]],
            delta: vec![[0.0, 0.0]],
            dmap_df: vec![[0.0, 0.0]],
            ln_b: vec![0.0],
            visit: vec![0],
            within_nuisance: DMatrix::zeros(2, 0),
            w: [1.0, 1.0],
        };
        assert_eq!(rc.gain(&f, 0, 0), 4.5);
        assert_eq!(rc.gain(&f, 0, 1), 12.0);
    }

    #[test]
    fn knots_span_the_values() {
        let xs: Vec<f64> = (0..100).map(|i| i as f64 * 0.5).collect();
        let k = knots_of(&xs, 6);
        assert_eq!(k.len(), 6);
        assert_eq!(k[0], 0.0);
        assert_eq!(*k.last().unwrap(), 49.5);
        assert_eq!(knots_of(&[3.0, 1.0, 3.0], 6), vec![1.0, 3.0]);
    }

    #[test]
    fn transient_knots_crowd_the_first_seconds_of_a_stream() {
        // Rows streamed at 1.5 Hz for 45 s after each change, times rounded to the
        // millisecond differently from visit to visit.
        let mut xs = Vec::new();
        for visit in 0..20 {
            for k in 1..=67 {
                xs.push(k as f64 / 1.5 + if visit % 2 == 0 { 1e-4 } else { -3e-4 });
            }
        }
        let lin = knots_of(&xs, 16);
        let log = log_knots_of(&xs, 16);
        // Quantile knots leave the first 3 s (a transient of a 0.5 s time scale) to one
        // knot; the logarithmic ones give it a knot per row there.
        assert_eq!(lin.iter().filter(|&&x| x < 3.0).count(), 1, "{lin:?}");
        assert!(log.iter().filter(|&&x| x < 3.0).count() >= 4, "{log:?}");
        // Every knot is a time the data have, distinct beyond the rounding, and they span
        // the data.
        assert!(log.len() >= 16 && log.len() <= 20, "{log:?}");
        assert!(log.windows(2).all(|w| w[1] - w[0] > 0.5), "{log:?}");
        assert!(log.iter().all(|k| xs.iter().any(|x| (x - k).abs() < 1e-12)));
        assert!((log[0] - 1.0 / 1.5).abs() < 1e-3 && (log[log.len() - 1] - 44.667).abs() < 1e-3);
        // Fewer distinct times than knots: all of them.
        assert_eq!(log_knots_of(&[2.0, 1.0, 2.0], 6), vec![1.0, 2.0]);
    }
}
