//! The identification report: `DIR/report.md` and its PNG figures, and the short summary
//! printed on stderr. Rendered from the [`Identification`] as computed (its predictions
//! included); nothing is refitted or re-predicted here except the smooth Phi(f) curve.

use crate::plot;
use crate::{ReportError, Result};
use magswarm_identify::data;
use magswarm_identify::{params, Collinear, Estimate, Identification};
use magswarm_model::registry;
use std::fmt::Write as _;
use std::path::Path;

mod plots;
use plots::plots;

fn g(v: f64) -> String {
    plot::fmt_g(v)
}

/// A few lines for the terminal.
pub fn summary(id: &Identification) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "identify: {} points ({} settled, {} transient rows), {} free steady parameter(s), \
         cond(J^T J, scaled) {:.3e}, {:.3} s",
        id.points.len(),
        id.counts.settled,
        id.counts.transient,
        id.steady.free.len(),
        id.steady.cov.cond_scaled,
        id.elapsed.as_secs_f64()
    );
    for e in id
        .steady
        .estimates
        .iter()
        .chain(id.dynamics.iter().flat_map(|d| d.estimates.iter()))
    {
        let _ = writeln!(
            s,
            "  {:<8} {:>11}  95% CI [{}, {}]{}",
            e.name,
            g(e.value),
            g(e.ci.0),
            g(e.ci.1),
            if e.at_bound { "  (at bound)" } else { "" }
        );
    }
    for a in &id.steady.auto_fixed {
        let _ = writeln!(
            s,
            "  {} fixed at {} (collinear: cond {:.2e})",
            a.name,
            g(a.value),
            a.cond
        );
    }
    let _ = writeln!(
        s,
        "  RMSE r1 {:.3} mm, r2 {:.3} mm; MAE r1 {:.2} %, r2 {:.2} %",
        id.train.rmse[0], id.train.rmse[1], id.train.mae_pct[0], id.train.mae_pct[1]
    );
    if let Some(h) = &id.heldout {
        let _ = writeln!(
            s,
            "  withheld ({} points): RMSE r1 {:.3} mm, r2 {:.3} mm",
            h.n, h.rmse[0], h.rmse[1]
        );
    }
    let _ = writeln!(s, "  dynamics: {}", id.dynamics_note);
    s
}

fn est_row(e: &Estimate, status: &str) -> String {
    let boot = match e.boot {
        Some(b) => format!(
            "[{}, {}] | {:.2}",
            g(b.lo),
            g(b.hi),
            if e.se > 0.0 { b.sd / e.se } else { f64::NAN }
        ),
        None => "- | -".into(),
    };
    format!(
        "| {} | {} | **{}** | {} | [{}, {}] | {} | {}{} |\n",
        e.name,
        g(e.prior),
        g(e.value),
        g(e.se),
        g(e.ci.0),
        g(e.ci.1),
        boot,
        status,
        if e.at_bound { ", at bound" } else { "" }
    )
}

fn find<'a>(id: &'a Identification, name: &str) -> Option<&'a Estimate> {
    id.steady.estimates.iter().find(|e| e.name == name)
}

/// "value [lo, hi]" for a free parameter, "value (fixed)" otherwise.
fn cell(id: &Identification, name: &str) -> String {
    match find(id, name) {
        Some(e) => format!("{} [{}, {}]", g(e.value), g(e.ci.0), g(e.ci.1)),
        None => format!("{} (fixed)", g(params::get(&id.model, name))),
    }
}

/// The rows of the report's Table I, from the parameter registry (the fittable parameters of
/// the steady map, in registry order): axis-specific pairs `X1`/`X2` or `X_1`/`X_2` as
/// (label, name of r1's, name of r2's), then the global parameters as (name, unit).
type TableI = (
    Vec<(String, &'static str, &'static str)>,
    Vec<(&'static str, &'static str)>,
);

fn table_i_rows() -> TableI {
    let rows: Vec<&registry::Param> = registry::group(registry::Group::Steady)
        .filter(|p| p.fit.is_some())
        .collect();
    let unit = |p: &registry::Param| p.unit.unwrap_or("-");
    let mut pairs = Vec::new();
    let mut globals = Vec::new();
    let mut paired = std::collections::HashSet::new();
    for p in &rows {
        let Some(stem) = p.name.strip_suffix('1') else {
            continue;
        };
        let second = format!("{stem}2");
        if let Some(q) = rows.iter().find(|q| q.name == second) {
            let label = if stem.ends_with('_') {
                format!("{stem}i [{}]", unit(p))
            } else {
                format!("{stem},i [{}]", unit(p))
            };
            pairs.push((label, p.name, q.name));
            paired.insert(p.name);
            paired.insert(q.name);
        }
    }
    for p in &rows {
        if !paired.contains(p.name) {
            globals.push((p.name, unit(p)));
        }
    }
    (pairs, globals)
}

/// Write `dir/report.md` and the PNGs.
pub fn write(id: &Identification, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|err| ReportError::Io {
        what: "cannot create",
        path: dir.to_path_buf(),
        err,
    })?;
    let figs = plots(id, dir)?;
    let mut md = String::new();
    let w = &mut md;
    let _ = writeln!(w, "# Identification report\n");
    let _ = writeln!(w, "Logs: {}  ", id.sources.join(", "));
    let _ = writeln!(
        w,
        "Prior model: `{}`. Wall time {:.3} s.\n",
        id.prior.name,
        id.elapsed.as_secs_f64()
    );
    let effects = id.model.effects.enabled();
    if !effects.is_empty() {
        // Without this line a reader cannot tell that the fitted values are conditional on
        // the effects (a drift or camera bias absorbed by the base parameters otherwise).
        let _ = writeln!(
            w,
            "Effects switched on in the model: {}. The fit compares the measurements with the \
             observed steady map (every effect acting, drift at each row's session time, \
             camera terms on the reading); effect parameters not freed keep the prior's \
             values.\n",
            effects
                .iter()
                .map(|k| k.name())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let c = &id.counts;
    let _ = writeln!(w, "## Data\n");
    let _ = writeln!(
        w,
        "{} rows in {} session(s), {} visit(s) (runs of constant commanded inputs); {} settled, \
         {} transient, {} invalid or without radii. {} operating point(s) ({} fitted, {} \
         withheld).\n",
        c.rows,
        c.sessions,
        c.visits,
        c.settled,
        c.transient,
        c.invalid,
        c.points,
        id.points.len(),
        id.withheld.len()
    );
    let _ = writeln!(
        w,
        "Settle rule: {}. A row's inputs are the ones in force since the previous row (docs/log-format.md), \
         so a change is dated at the last row with the old inputs; the first visit of a session counts from \
         the session's first row.\n",
        id.settle.describe()
    );
    let sd1: Vec<f64> = id.points.iter().map(|p| p.sd[0]).collect();
    let sd2: Vec<f64> = id.points.iter().map(|p| p.sd[1]).collect();
    let mad1: Vec<f64> = id.points.iter().map(|p| p.mad[0]).collect();
    let mad2: Vec<f64> = id.points.iter().map(|p| p.mad[1]).collect();
    let _ = writeln!(
        w,
        "Repeat variability (settled rows per point): median SD r1 {} mm, r2 {} mm; median MAD \
         r1 {} mm, r2 {} mm; pooled SD r1 {} mm, r2 {} mm.\n",
        g(data::median_mad(&sd1).0),
        g(data::median_mad(&sd2).0),
        g(data::median_mad(&mad1).0),
        g(data::median_mad(&mad2).0),
        g(id.weighting.pooled_sd[0]),
        g(id.weighting.pooled_sd[1])
    );
    let _ = writeln!(
        w,
        "Weights: {}.\n",
        if id.weighting.from_repeats {
            format!(
                "1/SE^2 of each point mean, the repeat variance shrunk toward the pooled \
                 variance with {} prior degrees of freedom",
                data::SHRINK_DOF
            )
        } else {
            "no point has repeats: unit weights (covariance scaled by the residual variance)".into()
        }
    );

    let _ = writeln!(w, "## Table I (identified, 95 % CI)\n");
    let _ = writeln!(w, "| Axis-specific parameters | r_1 | r_2 |\n|---|---|---|");
    let (pairs, globals) = table_i_rows();
    for (lab, a, b) in &pairs {
        let _ = writeln!(w, "| {lab} | {} | {} |", cell(id, a), cell(id, b));
    }
    let _ = writeln!(w, "\n| Global parameters | value |\n|---|---|");
    for (n, unit) in &globals {
        let _ = writeln!(w, "| {n} [{unit}] | {} |", cell(id, n));
    }
    let _ = writeln!(w, "| f_ref [Hz] | {} (fixed) |", g(id.model.steady.f_ref));
    let _ = writeln!(w, "\n| Validation errors | r_1 | r_2 |\n|---|---|---|");
    let t = &id.train;
    let _ = writeln!(w, "| RMSE [mm] | {:.3} | {:.3} |", t.rmse[0], t.rmse[1]);
    let _ = writeln!(w, "| MAE [%] | {:.2} | {:.2} |", t.mae_pct[0], t.mae_pct[1]);
    if let Some(h) = &id.heldout {
        let _ = writeln!(
            w,
            "| withheld RMSE [mm] ({} points) | {:.3} | {:.3} |",
            h.n, h.rmse[0], h.rmse[1]
        );
        let _ = writeln!(
            w,
            "| withheld MAE [%] | {:.2} | {:.2} |",
            h.mae_pct[0], h.mae_pct[1]
        );
    }
    let _ = writeln!(w, "\n| Median stiffness | S_x | S_y |\n|---|---|---|");
    let _ = writeln!(
        w,
        "| value [-] | {} | {} |\n",
        g(id.median_s[0]),
        g(id.median_s[1])
    );
    let _ = writeln!(
        w,
        "RMSE and MAE are over the fitted operating-point means (as the seed's Table I); MAE is \
         relative to the measured mean. The CIs are t({}) x SE from the Jacobian covariance \
         scaled by the reduced chi^2 ({}).\n",
        id.steady.cov.dof,
        g(id.steady.cov.s2)
    );

    let _ = writeln!(w, "## All estimates\n");
    let _ = writeln!(
        w,
        "| parameter | prior | fitted | SE | 95 % CI (Jacobian) | 95 % CI (bootstrap) | boot SD / SE | status |\n|---|---|---|---|---|---|---|---|"
    );
    for e in &id.steady.estimates {
        w.push_str(&est_row(e, "free (steady)"));
    }
    if let Some(d) = &id.dynamics {
        for e in &d.estimates {
            w.push_str(&est_row(e, "free (dynamics)"));
        }
    }
    for a in &id.steady.auto_fixed {
        let _ = writeln!(
            w,
            "| {} | {} | {} | - | - | - | - | fixed by the collinearity policy |",
            a.name,
            g(a.value),
            g(a.value)
        );
    }
    if id.steady.boot_ok > 0 {
        let _ = writeln!(
            w,
            "\nBootstrap: {} replicate(s) over operating points (resampled with replacement within \
             each z_m level, each refitted from the solution). A ratio boot SD / SE near 1 confirms the Jacobian CI; \
             well above 1 means the linearisation understates the uncertainty.\n",
            id.steady.boot_ok
        );
    }

    let _ = writeln!(w, "## Collinearity\n");
    let cov = &id.steady.cov;
    let names: Vec<&str> = id.steady.free.iter().map(|f| f.name()).collect();
    let _ = writeln!(
        w,
        "Condition number of J^T J: {:.3e} with columns scaled to unit diagonal (the \
         identifiability measure), {:.3e} raw.\n",
        cov.cond_scaled, cov.cond_raw
    );
    match id.steady.policy {
        Collinear::Fix { cond_max } => {
            if let Some((n0, c0)) = &id.steady.cov_initial {
                let _ = writeln!(
                    w,
                    "Policy **fix**: with all of {} free the scaled condition number was {:.3e} \
                     (> {:.1e}); the stiffness terms are power laws of the same distance and the \
                     data cannot tell them apart. Fixed at the prior value, one at a time (the \
                     parameter with the largest share of the weakest direction):\n",
                    n0.join(", "),
                    c0.cond_scaled,
                    cond_max
                );
                for a in &id.steady.auto_fixed {
                    let _ = writeln!(
                        w,
                        "- {} = {} (cond {:.3e} before)",
                        a.name,
                        g(a.value),
                        a.cond
                    );
                }
                let _ = writeln!(w);
            } else {
                let _ = writeln!(
                    w,
                    "Policy **fix** (threshold {cond_max:.1e}): not triggered, no parameter was \
                     fixed.\n"
                );
            }
        }
        Collinear::Ridge { lambda } => {
            let _ = writeln!(
                w,
                "Policy **ridge**: the free stiffness terms are regularised toward the prior \
                 with lambda = {lambda} (scale max(|prior|, 0.1)); the covariance includes the \
                 ridge.\n"
            );
        }
        Collinear::Report => {
            let _ = writeln!(w, "Policy **report**: nothing fixed or regularised.\n");
        }
    }
    let mut strong = Vec::new();
    let _ = write!(w, "| corr |");
    for n in &names {
        let _ = write!(w, " {n} |");
    }
    let _ = write!(w, "\n|---|");
    for _ in &names {
        let _ = write!(w, "---|");
    }
    let _ = writeln!(w);
    for (i, a) in names.iter().enumerate() {
        let _ = write!(w, "| {a} |");
        for (j, b) in names.iter().enumerate() {
            let r = cov.corr[(i, j)];
            let _ = write!(w, " {r:.2} |");
            if j > i && r.abs() > 0.95 {
                strong.push(format!("{a}/{b} ({r:.3})"));
            }
        }
        let _ = writeln!(w);
    }
    let _ = writeln!(
        w,
        "\nStrongly correlated pairs (|r| > 0.95): {}.\n",
        if strong.is_empty() {
            "none".into()
        } else {
            strong.join(", ")
        }
    );

    let _ = writeln!(w, "## Multi-start\n\n| start | cost (chi^2) | converged | termination | evaluations |\n|---|---|---|---|---|");
    for (k, r) in id.steady.runs.iter().enumerate() {
        let _ = writeln!(
            w,
            "| {} | {} | {} | {} | {} |",
            k + 1,
            g(r.cost),
            r.converged,
            r.termination,
            r.evals
        );
    }
    let best = id.steady.runs.first().map(|r| r.cost).unwrap_or(f64::NAN);
    let same = id
        .steady
        .runs
        .iter()
        .filter(|r| (r.cost - best).abs() <= 1e-6 * best.max(1e-12) + 1e-9)
        .count();
    let _ = writeln!(
        w,
        "\n{same} of {} start(s) reached the best cost (sorted best first).\n",
        id.steady.runs.len()
    );

    let _ = writeln!(w, "## Dynamics (ODE (4))\n\n{}.\n", id.dynamics_note);
    if let Some(d) = &id.dynamics {
        let _ = writeln!(
            w,
            "Transient residual RMS: r1 {:.3} -> {:.3} mm, r2 {:.3} -> {:.3} mm (prior -> \
             fitted time scales); condition number (scaled) {:.3e}; LM: {}.\n",
            d.rms_before[0],
            d.rms_after[0],
            d.rms_before[1],
            d.rms_after[1],
            d.cov.cond_scaled,
            d.run.termination
        );
    }

    let _ = writeln!(w, "## Figures\n");
    for (f, cap) in &figs {
        let _ = writeln!(w, "![{cap}]({f})\n\n*{cap}*\n");
    }
    std::fs::write(dir.join("report.md"), md).map_err(|err| ReportError::Io {
        what: "cannot write",
        path: dir.join("report.md"),
        err,
    })?;
    Ok(())
}
