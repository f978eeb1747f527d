//! `magswarm predict`: replay a log's commanded inputs through a model, dynamics included.
//!
//! Semantics (the same as the virtual lab's and the FMU's zero-order hold):
//!
//! - Each session (one `session` value; the whole file when there is no such column) starts
//!   with the plant at rest on the steady map of its first row's inputs (formation complete).
//! - The inputs of a row are the ones in force while its measurement formed, held over the
//!   interval since the previous row of its session (docs/log-format.md): between two rows the
//!   plant integrates ODE (4) under the *later* row's inputs, and the prediction of a row is
//!   the state at its time. A log that records only measurements (change the inputs, wait,
//!   measure) is thus replayed with its waiting time, and magswarm's own streamed logs
//!   (co-simulation, lab, bridge) are written in exactly this convention. `identify` dates
//!   input changes the same way.
//! - Rows of different sessions may interleave in the file; each session has its own plant.
//! - Every row gets a prediction, `valid` = 0 rows included.
//!
//! Output: every input column is kept (same order, unknown columns included); `r1_mm`,
//! `r2_mm` hold the prediction (added if absent). When the input had radii, the measured
//! values move to `r1_meas_mm`, `r2_meas_mm`; `r1_ss_mm`, `r2_ss_mm` carry the steady map at
//! the row's inputs (what the swarm would settle to).

use crate::PredictError;
use magswarm_log::{Column, Layout, Log, LogRow};
use magswarm_model::{hz_to_rad_s, Model, Plant};
use std::collections::HashMap;

/// One input sample of a replay.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InputRow {
    /// Time within the session \[s\] (non-decreasing).
    pub t: f64,
    /// Commanded z_m \[mm\].
    pub z_mm: f64,
    /// Commanded frequency \[Hz\].
    pub f_hz: f64,
}

/// Relative/absolute tolerance of the replay integrator (radii in mm).
pub const REPLAY_RTOL: f64 = 1e-7;

/// Replay one session: the observed radii \[mm\] (ODE (4) plus the model's effects) at each row (see the module docs for the semantics).
/// `rtol` sets the integrator's relative and absolute (mm) tolerance.
pub fn replay(model: &Model, rows: &[InputRow], rtol: f64) -> Result<Vec<[f64; 2]>, PredictError> {
    let Some(first) = rows.first() else {
        return Ok(Vec::new());
    };
    let mut plant = Plant::new(model.clone(), first.z_mm * 1e-3, hz_to_rad_s(first.f_hz));
    // The plant's clock is the session time (effects such as particle drift depend on it).
    plant.set_time(first.t);
    {
        let tol = plant.tolerances_mut();
        tol.rtol = rtol;
        tol.atol = rtol;
    }
    let mut out = Vec::with_capacity(rows.len());
    let mut t_prev = first.t;
    for r in rows {
        // The model's input rule (the swarm plane outside the magnet), per row.
        plant
            .try_set_inputs(r.z_mm * 1e-3, hz_to_rad_s(r.f_hz))
            .map_err(|err| PredictError::Input {
                at: String::new(),
                t: r.t,
                err,
            })?;
        let h = r.t - t_prev;
        if h > 0.0 {
            step_robust(&mut plant, h).map_err(|err| PredictError::Integrate {
                at: String::new(),
                from: t_prev,
                to: r.t,
                z_mm: r.z_mm,
                f_hz: r.f_hz,
                err,
            })?;
        }
        t_prev = r.t;
        out.push(plant.observed_radii());
    }
    Ok(out)
}

/// Step, retrying in smaller pieces once if the integrator gives up.
fn step_robust(plant: &mut Plant, h: f64) -> Result<(), magswarm_model::StepError> {
    if plant.step(h).is_ok() {
        return Ok(());
    }
    let n = 64;
    for _ in 0..n {
        plant.step(h / n as f64)?;
    }
    Ok(())
}

/// One row's replay: (the prediction, the observed steady map at its inputs) \[mm\].
pub type RowPrediction = ([f64; 2], [f64; 2]);

/// Predict every row of a log: (prediction, steady map) per row, in file order.
pub fn predict_log(model: &Model, log: &Log) -> Result<Vec<RowPrediction>, PredictError> {
    let mut by: HashMap<&str, Vec<usize>> = HashMap::new();
    for (i, r) in log.rows.iter().enumerate() {
        by.entry(r.session.as_str()).or_default().push(i);
    }
    let mut out = vec![([f64::NAN; 2], [f64::NAN; 2]); log.rows.len()];
    for (name, idx) in by {
        let rows: Vec<InputRow> = idx
            .iter()
            .map(|&i| InputRow {
                t: log.rows[i].t_s,
                z_mm: log.rows[i].z_m_mm,
                f_hz: log.rows[i].f_hz,
            })
            .collect();
        let pred = replay(model, &rows, REPLAY_RTOL).map_err(|e| {
            e.within(&if name.is_empty() {
                log.source.clone()
            } else {
                format!("{} session {name:?}", log.source)
            })
        })?;
        for (k, &i) in idx.iter().enumerate() {
            let sp = magswarm_model::effects::observed_steady(
                model,
                rows[k].z_mm * 1e-3,
                hz_to_rad_s(rows[k].f_hz),
                rows[k].t,
            );
            out[i] = (pred[k], [sp.r1, sp.r2]);
        }
    }
    Ok(out)
}

/// The output log of a replay: every input column kept, `r1_mm`, `r2_mm` the prediction,
/// measured radii moved to `r1_meas_mm`, `r2_meas_mm`, and the steady map in `r1_ss_mm`,
/// `r2_ss_mm` (the module docs). `pred` is [`predict_log`]'s.
pub fn output_rows(log: &Log, pred: &[RowPrediction]) -> (Layout, Vec<LogRow>) {
    let had_radii = log.has_radii();
    let mut layout = log.layout.clone();
    let (r1m, r2m) = if had_radii {
        (
            Some(layout.add_extra("r1_meas_mm")),
            Some(layout.add_extra("r2_meas_mm")),
        )
    } else {
        layout.ensure(Column::R1);
        layout.ensure(Column::R2);
        (None, None)
    };
    let r1s = layout.add_extra("r1_ss_mm");
    let r2s = layout.add_extra("r2_ss_mm");
    let rows = log
        .rows
        .iter()
        .zip(pred)
        .map(|(row, (p, ss))| {
            let mut o: LogRow = row.clone();
            o.extra.resize(layout.extra_columns.len(), String::new());
            let cell = |v: Option<f64>| v.map(|x| format!("{x}")).unwrap_or_default();
            if let (Some(i1), Some(i2)) = (r1m, r2m) {
                o.extra[i1] = cell(row.r1_mm);
                o.extra[i2] = cell(row.r2_mm);
            }
            o.extra[r1s] = cell(Some(ss[0]));
            o.extra[r2s] = cell(Some(ss[1]));
            o.r1_mm = Some(p[0]);
            o.r2_mm = Some(p[1]);
            o
        })
        .collect();
    (layout, rows)
}
