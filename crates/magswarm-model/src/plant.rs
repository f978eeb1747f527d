//! The plant as a stateful object: inputs (z_m, omega_m) in, radii out.
//!
//! This is what the FMU, the virtual lab and `predict` drive. Inputs are held between steps
//! (zero-order hold, as in FMI co-simulation); the input-dependent terms of (4) are recomputed
//! only when an input actually changes. `Plant` is `Clone` and holds no heap data on the hot
//! path, so saving and restoring an FMU state is a plain copy.

use crate::dynamics::{InputTerms, TermsId, TermsIds, KB_FLOOR};
use crate::integrate::{StepError, Stepper, Tolerances};
use crate::maptable::MapTable;
use crate::steady::SteadyPoint;
use crate::{Model, Validity};
use std::sync::Arc;

/// Inputs the model cannot evaluate at all (not merely outside the validated envelope):
/// non-finite values, or a z_m that puts the swarm plane inside the magnet sphere.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct InputError(pub String);

impl Model {
    /// The rule every caller of the model shares for z_m: below `-z_offset` the swarm plane
    /// would cut through the magnet sphere, where no extrapolation means anything, so it is
    /// bad input (like NaN), not extrapolation. The message names z_m, the limit and the
    /// validated envelope.
    #[inline]
    pub fn check_z_m(&self, z_m: f64) -> Result<(), InputError> {
        if self.z_m_allowed(z_m) {
            return Ok(());
        }
        Err(self.z_m_refused(z_m))
    }

    /// Whether [`Model::check_z_m`] accepts z_m (finite, the swarm plane outside the magnet),
    /// as one test for callers on a hot path.
    #[inline]
    pub fn z_m_allowed(&self, z_m: f64) -> bool {
        z_m > -self.magnet.z_offset_m && z_m.is_finite()
    }

    /// Why [`Model::check_z_m`] refuses z_m.
    #[cold]
    #[inline(never)]
    fn z_m_refused(&self, z_m: f64) -> InputError {
        let floor = -self.magnet.z_offset_m;
        if z_m.is_nan() {
            return InputError(format!("z_m = {z_m} is not a number"));
        }
        InputError(format!(
            "z_m = {:.3} mm would put the swarm inside the magnet (z_m must exceed \
             {:.3} mm; validated envelope {}-{} mm)",
            z_m * 1e3,
            floor * 1e3,
            self.envelope.z_min_m * 1e3,
            self.envelope.z_max_m * 1e3
        ))
    }

    /// Inputs the model can evaluate: z_m by [`Model::check_z_m`], omega finite.
    pub fn check_inputs(&self, z_m: f64, omega: f64) -> Result<(), InputError> {
        self.check_z_m(z_m)?;
        if !omega.is_finite() {
            return Err(InputError(format!(
                "omega_m = {omega} rad/s must be a finite number"
            )));
        }
        Ok(())
    }
}

/// The plant's state and its cached input terms.
#[derive(Debug, Clone, PartialEq)]
pub struct Plant {
    model: Model,
    /// The coefficients of (4) at the inputs, without their Jacobian parts (what stepping
    /// needs: [`InputTerms::values_with_map`]).
    terms: InputTerms,
    /// The same terms with their Jacobian, computed the first time something asks for it
    /// at these inputs ([`Plant::outputs`], the Jacobians; a cache, emptied whenever
    /// `terms` changes).
    full: FullTerms,
    /// Radii (r1, r2) [mm]: the state of ODE (4).
    r: [f64; 2],
    /// Simulation time [s].
    t: f64,
    stepper: Stepper,
    tol: Tolerances,
    /// Slow formation mode of the `formation_lag` effect, per axis (x, dx/dt) [mm, mm/s]:
    /// [x1, v1, x2, v2]. Unused (and kept on the map) when the effect is off.
    form: [f64; 4],
    /// The last input change for learned terms over the time since it: [time [s], step of
    /// the observed steady map r1, r2 [mm]] (a zero step before the first change).
    change: [f64; 3],
    /// `model.effects.is_empty()`, kept beside the model (the hot path asks it per call).
    plain: bool,
    /// The steady map from tables ([`Plant::use_map_table`]), if asked for and the model's
    /// map is tabulable.
    map: MapSlot,
    /// The ids of this plant's input terms (a block of its own, see `TermsIds`).
    ids: TermsIds,
}

/// [`Plant::terms`] with their Jacobian parts, once asked for (see `Plant::full`). A cache
/// of a deterministic function of the plant's inputs, model and map: equality ignores it.
#[derive(Clone, Default)]
struct FullTerms(std::cell::OnceCell<InputTerms>);

impl PartialEq for FullTerms {
    fn eq(&self, _: &FullTerms) -> bool {
        true
    }
}

impl std::fmt::Debug for FullTerms {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "FullTerms {{ computed: {} }}", self.0.get().is_some())
    }
}

/// The plant's [`MapTable`], shared between clones. Whether a plant uses one is part of its
/// state (it decides the input terms, within the table's bound); the table itself is a
/// deterministic function of the model, so equality ignores it.
#[derive(Clone, Default)]
struct MapSlot {
    /// The table is in force (when the model's map is tabulable).
    wanted: bool,
    /// Input changes left before it comes into force (0: not scheduled).
    pending: u32,
    /// Built for, or adopted from a plant of, the current model; read only while `wanted`.
    table: Option<Arc<MapTable>>,
}

impl MapSlot {
    /// The table in force for the input terms.
    #[inline]
    fn in_force(&self) -> Option<&MapTable> {
        self.table.as_deref().filter(|_| self.wanted)
    }
}

impl PartialEq for MapSlot {
    fn eq(&self, o: &MapSlot) -> bool {
        (self.wanted, self.pending) == (o.wanted, o.pending)
    }
}

impl std::fmt::Debug for MapSlot {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "MapSlot {{ wanted: {}, built: {} }}",
            self.wanted,
            self.table.is_some()
        )
    }
}

/// Everything a [`Plant`] carries besides its model: enough to rebuild it bit-identically
/// with [`Plant::from_snapshot`]. Serialisable, for FMU states and controller states.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PlantSnapshot {
    /// Inputs in force (z_m \[m\], omega [rad/s]).
    pub inputs: [f64; 2],
    /// State (r1, r2) \[mm\].
    pub r: [f64; 2],
    /// Time \[s\].
    pub t: f64,
    /// Integrator step size to try next \[s\].
    pub h_next: f64,
    /// Accepted and rejected internal steps.
    pub steps: [u64; 2],
    /// Relative and absolute tolerance, largest internal step \[s\].
    pub tol: [f64; 3],
    /// Most internal steps per communication step.
    pub max_steps: u32,
    /// Slow formation mode of the `formation_lag` effect [x1, v1, x2, v2] (mm, mm/s).
    #[serde(default)]
    pub form: [f64; 4],
    /// The last input change [time s, step r1 mm, step r2 mm] for learned terms over the time
    /// since it (absent in a state written before them: no change).
    #[serde(default)]
    pub change: [f64; 3],
    /// The plant evaluates its steady map from tables ([`Plant::use_map_table`]; absent in a
    /// state written before them: no).
    #[serde(default)]
    pub map_table: bool,
    /// Input changes left before the tables come into force ([`Plant::use_map_table_after`];
    /// 0: none scheduled).
    #[serde(default)]
    pub map_pending: u32,
}

/// What the plant reports at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlantOutputs {
    /// Dynamic radius r1 \[mm\], as observed (ODE (4) plus the enabled effects).
    pub r1: f64,
    /// Dynamic radius r2 \[mm\], as observed (ODE (4) plus the enabled effects).
    pub r2: f64,
    /// The steady map at the current inputs (r1_ss, r2_ss, S, field, Jacobian), with the
    /// enabled effects (radii and Jacobian as observed at the current time).
    pub steady: SteadyPoint,
}

impl Plant {
    /// A plant at rest on the steady map of the given inputs (z_m \[m\], omega [rad/s]).
    pub fn new(model: Model, z_m: f64, omega: f64) -> Plant {
        let terms = InputTerms::values_with_map(&model, z_m, omega, None);
        let r = terms.steady.radii();
        let plain = model.effects.is_empty();
        Plant {
            model,
            terms,
            full: FullTerms::default(),
            r,
            t: 0.0,
            stepper: Stepper::default(),
            tol: Tolerances::default(),
            form: [r[0], 0.0, r[1], 0.0],
            change: [0.0; 3],
            plain,
            map: MapSlot::default(),
            ids: TermsIds::default(),
        }
    }

    /// Evaluate the steady map from a [`MapTable`] (`on`) or exactly (the default). The table
    /// answers within its proven bound (below 1e-9 mm over the envelope, docs/performance.md)
    /// at a fraction of the cost of an input change; its cells are built the first time an
    /// input falls in them (about 5 us each in a release build), so it pays for plants that see many input
    /// changes (an FMU, a controller's model).
    /// Ignored (exact) while the model has an effect that acts on the map. The input terms in
    /// force are recomputed either way, so the plant's behaviour depends on the setting only.
    pub fn use_map_table(&mut self, on: bool) {
        self.map.wanted = on;
        self.map.pending = 0;
        self.refresh_map(None);
    }

    /// The map table from the `n`-th input change on (`n` = 0: now), so that a plant that
    /// sees few changes never pays for building it. `table`, if it was built for this
    /// plant's model (one kept from an earlier plant), is adopted then instead of taking the
    /// process's table of that model ([`MapTable::shared`], whose cells the plants of one
    /// map build once between them); it does not change when the table comes into force,
    /// so the plant's behaviour depends on `n` and its inputs only.
    pub fn use_map_table_after(&mut self, n: u32, table: Option<&Arc<MapTable>>) {
        if let Some(t) = table.filter(|t| t.answers_for(&self.model)) {
            self.map.table = Some(t.clone());
        }
        self.map.wanted = n == 0;
        self.map.pending = n;
        self.refresh_map(None);
    }

    /// The table built or adopted for this plant's model, if any (to hand to a later plant
    /// of the same model).
    pub fn map_table(&self) -> Option<&Arc<MapTable>> {
        self.map.table.as_ref()
    }

    /// The table in force for the input terms.
    fn map_in_force(&self) -> Option<&MapTable> {
        self.map.in_force()
    }

    /// Make the table match the wish and the model, and recompute the input terms.
    fn refresh_map(&mut self, candidate: Option<&Arc<MapTable>>) {
        let fits = |t: &Arc<MapTable>| t.answers_for(&self.model);
        let kept = self.map.table.as_ref().filter(|t| fits(t)).cloned();
        let needed = self.map.wanted && crate::maptable::tabulable(&self.model);
        self.map.table = if !needed || kept.is_some() {
            kept
        } else if let Some(t) = candidate.filter(|t| fits(t)) {
            Some(t.clone())
        } else {
            MapTable::shared(&self.model)
        };
        let (z_m, omega) = (self.terms.z_m, self.terms.omega);
        let id = self.ids.take();
        InputTerms::values_into(
            &mut self.terms,
            &self.model,
            z_m,
            omega,
            self.map.in_force(),
            id,
        );
        self.full = FullTerms::default();
    }

    /// The input terms with their Jacobian parts (computed now if nothing asked for them
    /// since the inputs last changed; their values are `self.terms` bit for bit).
    fn full_terms(&self) -> &InputTerms {
        self.full
            .0
            .get_or_init(|| self.terms.with_jacobian(&self.model, self.map_in_force()))
    }

    /// Replace the model, keeping the state, the time and the inputs (the coefficients of
    /// (4) are recomputed). For a plant whose parameters change during a run (a lab truth
    /// with a moving centroid, a shadow model updated by identification).
    pub fn set_model(&mut self, model: Model) {
        self.plain = model.effects.is_empty();
        self.model = model;
        self.refresh_map(None);
    }

    /// The model in use.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// Current inputs (z_m \[m\], omega [rad/s]).
    pub fn inputs(&self) -> (f64, f64) {
        (self.terms.z_m, self.terms.omega)
    }

    /// Change the inputs after checking them with [`Model::check_inputs`]; refused inputs
    /// leave the plant as it was. Every caller that takes inputs from outside (the FMU, the
    /// closed-loop driver, a rig's shadow model) should use this.
    pub fn try_set_inputs(&mut self, z_m: f64, omega: f64) -> Result<(), InputError> {
        self.model.check_inputs(z_m, omega)?;
        self.set_inputs(z_m, omega);
        Ok(())
    }

    /// Change the inputs, unchecked (for inputs known to be sane, e.g. from a log that was
    /// read with its rules); the coefficients of (4) are recomputed only if they differ.
    #[inline]
    pub fn set_inputs(&mut self, z_m: f64, omega: f64) {
        if z_m != self.terms.z_m || omega != self.terms.omega {
            self.change_inputs(z_m, omega);
        }
    }

    /// The work of an input change, out of line: the hot path of [`Plant::set_inputs`] (the
    /// inputs did not change) is two comparisons.
    #[inline(never)]
    fn change_inputs(&mut self, z_m: f64, omega: f64) {
        if self.map.pending > 0 {
            self.count_down_map();
        }
        self.full = FullTerms::default();
        let id = self.ids.take();
        if self.plain {
            // No effect: the map is one the table may answer and no term tracks changes
            // (what `values_into` and `tracks_changes` would find out first).
            let map = self.map.in_force();
            InputTerms::plain_values_into(&mut self.terms, &self.model, z_m, omega, map, id);
            return;
        }
        if self.model.effects.tracks_changes() {
            return self.change_inputs_tracked(z_m, omega, id);
        }
        let map = self.map.in_force();
        InputTerms::values_into(&mut self.terms, &self.model, z_m, omega, map, id);
    }

    /// One input change fewer before the map table comes into force (out of line: the
    /// first changes of a plant only).
    #[inline(never)]
    fn count_down_map(&mut self) {
        self.map.pending -= 1;
        if self.map.pending == 0 {
            self.map.wanted = true;
            self.refresh_map(None);
        }
    }

    /// [`Plant::change_inputs`] with effects that track input changes (learned terms over
    /// the time since the last change), out of line so that the plain change is a short
    /// function.
    #[inline(never)]
    fn change_inputs_tracked(&mut self, z_m: f64, omega: f64, id: TermsId) {
        let map = self.map.in_force();
        let before = self.terms.steady;
        InputTerms::values_into(&mut self.terms, &self.model, z_m, omega, map, id);
        // The step of the observed steady map this change makes, for the learned terms over
        // the time since it.
        let fx = &self.model.effects;
        let a = fx.observe_steady(&before, self.t);
        let b = fx.observe_steady(&self.terms.steady, self.t);
        self.change = [self.t, b.r1 - a.r1, b.r2 - a.r2];
    }

    /// Put the state on the steady map of the current inputs (formation complete).
    pub fn settle(&mut self) {
        self.r = self.terms.steady.radii();
        self.form = [self.r[0], 0.0, self.r[1], 0.0];
    }

    /// Set the state directly \[mm\] (the slow formation mode, if any, starts there at rest).
    pub fn set_state(&mut self, r: [f64; 2]) {
        self.r = r;
        self.form = [r[0], 0.0, r[1], 0.0];
    }

    /// Set the radii of ODE (4) \[mm\] and nothing else (the slow formation mode keeps its
    /// value): what an importer's integrator does in FMI Model Exchange.
    pub fn set_radii(&mut self, r: [f64; 2]) {
        self.r = r;
    }

    /// d(r1, r2)/dt of ODE (4) at the current state and inputs \[mm/s\] (the right-hand side
    /// an importer's integrator needs in FMI Model Exchange).
    pub fn derivatives(&self) -> [f64; 2] {
        self.terms.rhs(&self.model, self.r)
    }

    /// The slow formation mode of the `formation_lag` effect, per axis (x, dx/dt):
    /// `[x1, v1, x2, v2]` \[mm, mm/s\]. Without the effect it stays where it was set (on the
    /// map at the start) and nothing reads it.
    pub fn formation(&self) -> [f64; 4] {
        self.form
    }

    /// Set the slow formation mode `[x1, v1, x2, v2]` \[mm, mm/s\] and nothing else: what an
    /// importer's integrator does with those states in FMI Model Exchange.
    pub fn set_formation(&mut self, form: [f64; 4]) {
        self.form = form;
    }

    /// Every continuous state of the plant, as FMI Model Exchange exposes them:
    /// `[r1, r2, x1, v1, x2, v2]` \[mm, mm/s\] (ODE (4), then the formation mode).
    pub fn continuous_state(&self) -> [f64; 6] {
        let f = self.form;
        [self.r[0], self.r[1], f[0], f[1], f[2], f[3]]
    }

    /// Set every continuous state, in the order of [`Plant::continuous_state`].
    pub fn set_continuous_state(&mut self, x: [f64; 6]) {
        self.r = [x[0], x[1]];
        self.form = [x[2], x[3], x[4], x[5]];
    }

    /// The time derivative of [`Plant::continuous_state`] \[mm/s, mm/s^2\]: ODE (4) for the
    /// radii and, with `formation_lag`, the slow mode
    /// `x'' + 2 zeta x'/tau + (x - r_ss)/tau^2 = 0` toward the (unobserved) steady map; zero
    /// without the effect, as [`Plant::step`] leaves the mode alone then.
    pub fn continuous_derivatives(&self) -> [f64; 6] {
        let dr = self.derivatives();
        let [x1, v1, x2, v2] = self.form;
        match &self.model.effects.formation_lag {
            None => [dr[0], dr[1], 0.0, 0.0, 0.0, 0.0],
            Some(fl) => {
                let target = self.terms.steady.radii();
                let wn = 1.0 / fl.tau_s;
                let acc = |x: f64, v: f64, r: f64| -wn * wn * (x - r) - 2.0 * fl.zeta * wn * v;
                [
                    dr[0],
                    dr[1],
                    v1,
                    acc(x1, v1, target[0]),
                    v2,
                    acc(x2, v2, target[1]),
                ]
            }
        }
    }

    /// d(continuous_derivatives)/d(z_m \[m\], omega \[rad/s\], continuous_state) at the current
    /// point, row per derivative: 8 columns (2 inputs, 6 states) in the units of
    /// [`Plant::continuous_derivatives`] per unit of the known.
    pub fn continuous_jacobian(&self) -> [[f64; 8]; 6] {
        let mut j = [[0.0; 8]; 6];
        let js = self.jac_state();
        let ju = self.jac_input();
        for i in 0..2 {
            j[i][0] = ju[i][0];
            j[i][1] = ju[i][1];
            j[i][2] = js[i][0];
            j[i][3] = js[i][1];
        }
        if let Some(fl) = &self.model.effects.formation_lag {
            let wn = 1.0 / fl.tau_s;
            let jac = self.full_terms().steady.jac;
            for axis in 0..2 {
                let (x, v) = (2 + 2 * axis, 3 + 2 * axis);
                // dx/dt = v
                j[x][2 + v] = 1.0;
                // dv/dt = -wn^2 (x - r_ss(u)) - 2 zeta wn v
                j[v][2 + x] = -wn * wn;
                j[v][2 + v] = -2.0 * fl.zeta * wn;
                j[v][0] = wn * wn * jac[axis][0];
                j[v][1] = wn * wn * jac[axis][1];
            }
        }
        j
    }

    /// Radii state \[mm\].
    pub fn state(&self) -> [f64; 2] {
        self.r
    }

    /// Simulation time \[s\].
    pub fn time(&self) -> f64 {
        self.t
    }

    /// Set the simulation time \[s\] (FMI setup).
    pub fn set_time(&mut self, t: f64) {
        self.t = t;
    }

    /// Integrator tolerances.
    pub fn tolerances_mut(&mut self) -> &mut Tolerances {
        &mut self.tol
    }

    /// The coefficients of (4) at the current inputs, with their Jacobian parts (computed
    /// on the first call after an input change).
    pub fn terms(&self) -> &InputTerms {
        self.full_terms()
    }

    /// The plant's state without its model (see [`PlantSnapshot`]).
    pub fn snapshot(&self) -> PlantSnapshot {
        PlantSnapshot {
            inputs: [self.terms.z_m, self.terms.omega],
            r: self.r,
            t: self.t,
            h_next: self.stepper.h_next,
            steps: [self.stepper.steps, self.stepper.rejected],
            tol: [self.tol.rtol, self.tol.atol, self.tol.h_max],
            max_steps: self.tol.max_steps,
            form: self.form,
            change: self.change,
            map_table: self.map.wanted,
            map_pending: self.map.pending,
        }
    }

    /// Rebuild a plant from its model and a [`PlantSnapshot`]; stepping it continues exactly
    /// as the original would (the input terms are recomputed, deterministically).
    pub fn from_snapshot(model: Model, s: &PlantSnapshot) -> Plant {
        Self::from_snapshot_sharing(model, s, None)
    }

    /// As [`Plant::from_snapshot`], adopting `table` (if it was built for `model`) when the
    /// snapshot uses a map table, instead of building one.
    pub fn from_snapshot_sharing(
        model: Model,
        s: &PlantSnapshot,
        table: Option<&Arc<MapTable>>,
    ) -> Plant {
        let mut p = Plant::new(model, s.inputs[0], s.inputs[1]);
        if let Some(t) = table.filter(|t| t.answers_for(&p.model)) {
            p.map.table = Some(t.clone());
        }
        p.map.wanted = s.map_table;
        p.map.pending = s.map_pending;
        if s.map_table {
            p.refresh_map(None);
        }
        p.r = s.r;
        p.t = s.t;
        p.form = s.form;
        p.change = s.change;
        p.stepper = Stepper {
            h_next: s.h_next,
            steps: s.steps[0],
            rejected: s.steps[1],
            ..Stepper::default()
        };
        p.tol = Tolerances {
            rtol: s.tol[0],
            atol: s.tol[1],
            h_max: s.tol[2],
            max_steps: s.max_steps,
        };
        p
    }

    /// Integrator memory (step size to try next, step counts), for exact save/restore.
    pub fn stepper(&self) -> Stepper {
        self.stepper
    }

    /// Restore the integrator memory saved with [`Plant::stepper`].
    pub fn set_stepper(&mut self, s: Stepper) {
        self.stepper = s;
    }

    /// Integrator tolerances.
    pub fn tolerances(&self) -> Tolerances {
        self.tol
    }

    /// Internal integrator statistics (accepted, rejected steps).
    pub fn step_counts(&self) -> (u64, u64) {
        (self.stepper.steps, self.stepper.rejected)
    }

    /// Advance the state by `h` seconds under the current inputs. On error the state is left
    /// as it was, so a caller may retry with a smaller step.
    #[inline]
    pub fn step(&mut self, h: f64) -> Result<(), StepError> {
        // A formed swarm at rest: the whole step replayed in O(1), inlined into the caller.
        if self.stepper.replay(&self.terms, &self.r, h, &self.tol) {
            self.t += h;
            if self.model.effects.formation_lag.is_some() {
                self.propagate_formation(h);
            }
            return Ok(());
        }
        self.integrate(h)
    }

    /// [`Plant::step`] when the step has to be integrated.
    #[inline(never)]
    fn integrate(&mut self, h: f64) -> Result<(), StepError> {
        let mut y = self.r;
        // Only these three change on a failed step (the rest memo holds facts either way);
        // saving them instead of the whole stepper keeps the hot path free of copies.
        let saved = (
            self.stepper.h_next,
            self.stepper.steps,
            self.stepper.rejected,
        );
        if let Err(e) = self
            .stepper
            .advance(&self.model, &self.terms, &mut y, self.t, h, &self.tol)
        {
            (
                self.stepper.h_next,
                self.stepper.steps,
                self.stepper.rejected,
            ) = saved;
            return Err(e);
        }
        self.r = y;
        self.t += h;
        self.propagate_formation(h);
        Ok(())
    }

    /// Advance the slow formation mode of `formation_lag` (if on) by `h` seconds.
    fn propagate_formation(&mut self, h: f64) {
        if let Some(fl) = &self.model.effects.formation_lag {
            let target = self.terms.steady.radii();
            let a = fl.propagate([self.form[0], self.form[1]], target[0], h);
            let b = fl.propagate([self.form[2], self.form[3]], target[1], h);
            self.form = [a[0], a[1], b[0], b[1]];
        }
    }

    /// Physical footprint radii \[mm\] before the measurement effects: the ODE (4) state, or,
    /// with `formation_lag`, its blend with the slow formation mode.
    pub fn footprint(&self) -> [f64; 2] {
        match &self.model.effects.formation_lag {
            None => self.r,
            Some(fl) => [
                fl.blend(self.r[0], self.form[0]),
                fl.blend(self.r[1], self.form[2]),
            ],
        }
    }

    /// The observed radii r1, r2 \[mm\] alone (what [`Plant::outputs`] reports, without
    /// copying the steady point): the state of ODE (4) when no effect is on.
    #[inline]
    pub fn observed_radii(&self) -> [f64; 2] {
        if self.plain {
            return self.r;
        }
        self.observe_radii()
    }

    /// The radii with every enabled effect applied (the radii of [`Plant::outputs`]).
    fn observe_radii(&self) -> [f64; 2] {
        let fx = &self.model.effects;
        let mut r = fx.observe(self.footprint(), self.t);
        if fx.tracks_changes() {
            let c = fx.since_change(self.t - self.change[0], [self.change[1], self.change[2]]);
            r = [r[0] + c[0], r[1] + c[1]];
        }
        r
    }

    /// Whether every number of [`Plant::outputs`] that an FMU reports (radii, steady radii,
    /// stiffness, field) is finite, without copying the steady point when no effect is on
    /// (the check of every input change).
    #[inline]
    pub fn outputs_finite(&self) -> bool {
        let probe = |r: [f64; 2], sp: &SteadyPoint| {
            // x * 0 is 0 for every finite x and NaN otherwise: one sum, no branches.
            [
                r[0],
                r[1],
                sp.r1,
                sp.r2,
                sp.s_x,
                sp.s_y,
                sp.field.b,
                sp.field.g_z,
                sp.field.k_xx,
                sp.field.k_yy,
            ]
            .iter()
            .map(|x| x * 0.0)
            .sum::<f64>()
                == 0.0
        };
        if self.plain {
            return probe(self.r, &self.terms.steady);
        }
        // The values of the observed steady point do not read its Jacobian.
        let observed = self
            .model
            .effects
            .observe_steady(&self.terms.steady, self.t);
        probe(self.observe_radii(), &observed)
    }

    /// Outputs at the current instant (every enabled effect applied). The steady point's
    /// Jacobian is computed on the first call after an input change (callers that want the
    /// radii alone: [`Plant::observed_radii`]).
    pub fn outputs(&self) -> PlantOutputs {
        let fx = &self.model.effects;
        let steady = &self.full_terms().steady;
        if self.plain {
            return PlantOutputs {
                r1: self.r[0],
                r2: self.r[1],
                steady: *steady,
            };
        }
        let r = self.observe_radii();
        PlantOutputs {
            r1: r[0],
            r2: r[1],
            steady: fx.observe_steady(steady, self.t),
        }
    }

    /// Validity flags of the current inputs.
    pub fn validity(&self) -> Validity {
        self.terms.steady.validity
    }

    /// Where the inputs in force stand against the validated envelope: exactly
    /// `model.envelope.classify(z_m, omega)` (the other flags false). Without effects the
    /// steady map classified these very inputs first thing, so its flags are taken (no
    /// second division); an effect may evaluate the map at other inputs (a slowed rotation),
    /// so then they are classified here.
    #[inline]
    pub fn envelope_validity(&self) -> Validity {
        if !self.plain {
            return self
                .model
                .envelope
                .classify(self.terms.z_m, self.terms.omega);
        }
        let v = self.terms.steady.validity;
        Validity {
            z_below: v.z_below,
            z_above: v.z_above,
            f_below: v.f_below,
            f_above: v.f_above,
            ..Validity::default()
        }
    }

    /// d(dr/dt)/dr at the current state [1/s].
    pub fn jac_state(&self) -> [[f64; 2]; 2] {
        self.terms.jac_state(&self.model, self.r)
    }

    /// d(dr/dt)/d(z_m, omega) at the current state.
    pub fn jac_input(&self) -> [[f64; 2]; 2] {
        self.full_terms().jac_input(&self.model, self.r)
    }

    /// Smallest confinement gain allowed when scheduling (re-exported for reports).
    pub const KB_FLOOR: f64 = KB_FLOOR;
}

#[cfg(test)]
mod lazy_jacobian_tests;
#[cfg(test)]
mod map_table_tests;
#[cfg(test)]
mod rest_memo_tests;
#[cfg(test)]
mod tests;
