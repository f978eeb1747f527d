//! The report's figures: residual maps over (z_m, f) before and after the accepted effects on a
//! diverging colour map centred on zero, residuals over session time and after input changes.

use super::*;
use crate::{attribute, shapes};
use magswarm_model::effects::LearnedAxis;
use magswarm_report::residual::{residual_map, ResidualMap};

/// Mean visit residual per point (NaN where a point has no visit).
fn point_means(d: &Diagnosis, pred: &[[f64; 2]], a: usize) -> Vec<f64> {
    let vr = gap::visit_residuals(&d.ds, &d.ds.residuals(pred));
    let mut s = vec![(0.0, 0usize); d.ds.points.len()];
    for (v, e) in vr.e.iter().enumerate() {
        let p = d.ds.visits[v].point;
        s[p].0 += e[a];
        s[p].1 += 1;
    }
    s.iter()
        .map(|(x, n)| if *n > 0 { x / *n as f64 } else { f64::NAN })
        .collect()
}

pub(super) fn plots(d: &Diagnosis, dir: &Path) -> Result<Vec<(String, String)>> {
    let mut out = Vec::new();
    for a in 0..2 {
        let before = point_means(d, &d.attr.baseline.pred, a);
        let after = point_means(d, &d.attr.augmented.pred, a);
        let vmax = before
            .iter()
            .chain(&after)
            .filter(|v| v.is_finite())
            .fold(1e-9f64, |m, v| m.max(v.abs()));
        let in_region: Vec<(f64, f64)> =
            d.ds.points
                .iter()
                .enumerate()
                .filter(|(p, _)| {
                    d.regions.iter().any(|r| {
                        r.axis == a
                            && r.kind == Kind::Inputs
                            && r.visits.iter().any(|&v| d.ds.visits[v].point == *p)
                    })
                })
                .map(|(_, &x)| x)
                .collect();
        for (tag, vals, title) in [
            (
                "before",
                &before,
                format!("Residual r{} (measured - baseline) over (z_m, f)", a + 1),
            ),
            (
                "after",
                &after,
                format!("Residual r{} (measured - augmented) over (z_m, f)", a + 1),
            ),
        ] {
            let points: Vec<(f64, f64, f64)> =
                d.ds.points
                    .iter()
                    .zip(vals)
                    .map(|(&(z, f), &v)| (z, f, v))
                    .collect();
            let name = format!("residual_{tag}_r{}.png", a + 1);
            let drawn = residual_map(
                &dir.join(&name),
                &ResidualMap {
                    title: &title,
                    points: &points,
                    marks: if tag == "before" { &in_region } else { &[] },
                    marks_label: if tag == "before" && !in_region.is_empty() {
                        "in a significant region"
                    } else {
                        ""
                    },
                    half_range: Some(vmax),
                },
            )?;
            if drawn {
                out.push((
                    name,
                    format!(
                        "Mean residual of r{} per operating point {} the accepted effects (blue: model too large, red: too small){}",
                        a + 1,
                        if tag == "before" { "before" } else { "after" },
                        if tag == "before" && !in_region.is_empty() { "; circles: points in a significant region" } else { "" }
                    ),
                ));
            }
        }
    }
    // Residuals over session time.
    let vb = gap::visit_residuals(&d.ds, &d.ds.residuals(&d.attr.baseline.pred));
    let va = gap::visit_residuals(&d.ds, &d.ds.residuals(&d.attr.augmented.pred));
    let panels: Vec<Panel> = (0..2)
        .map(|a| Panel {
            y_label: format!("residual r{} [mm]", a + 1),
            series: vec![
                Series::points(
                    "baseline",
                    d.ds.visits
                        .iter()
                        .zip(&vb.e)
                        .map(|(v, e)| (v.t_mid, e[a]))
                        .collect(),
                ),
                Series::points(
                    "augmented",
                    d.ds.visits
                        .iter()
                        .zip(&va.e)
                        .map(|(v, e)| (v.t_mid, e[a]))
                        .collect(),
                ),
            ],
        })
        .collect();
    plot::time_panels(
        &dir.join("residuals_time.png"),
        "Visit residuals (measured - model) over session time",
        "session time [s]",
        &panels,
    )?;
    out.push((
        "residuals_time.png".into(),
        "Mean residual of each visit against session time, baseline and augmented".into(),
    ));
    // Residuals after input changes.
    let rows_since = |pred: &[[f64; 2]], a: usize| -> Vec<(f64, f64)> {
        d.ds.rows
            .iter()
            .zip(pred)
            .filter(|(r, _)| d.ds.visits[r.visit].prev.is_some())
            .map(|(r, p)| (r.since, r.r[a] - p[a]))
            .collect()
    };
    let panels: Vec<Panel> = (0..2)
        .map(|a| Panel {
            y_label: format!("residual r{} [mm]", a + 1),
            series: vec![
                Series::points("baseline", rows_since(&d.attr.baseline.pred, a)),
                Series::points("augmented", rows_since(&d.attr.augmented.pred, a)),
            ],
        })
        .collect();
    plot::time_panels(
        &dir.join("residuals_since_change.png"),
        "Row residuals (measured - model) against time since the input change",
        "time since the input change [s]",
        &panels,
    )?;
    out.push((
        "residuals_since_change.png".into(),
        "Row residuals against the time since the last input change".into(),
    ));
    out.extend(effect_figures(d, dir)?);
    Ok(out)
}

/// The axis a named effect is shown along: its learned shape's, else its physical one.
fn effect_axis(kind: EffectKind, form: &attribute::Form) -> shapes::Axis {
    match form {
        attribute::Form::Learned(sh) => sh.family.axis,
        attribute::Form::Parametric => match kind.axis() {
            LearnedAxis::FHz => shapes::Axis::F { nu: 0.0 },
            LearnedAxis::TS => shapes::Axis::T,
            LearnedAxis::SinceChangeS => shapes::Axis::Since,
            LearnedAxis::ZmMm => shapes::Axis::Z,
        },
    }
}

/// For each named effect: the baseline's residual along the effect's axis, with what the
/// learned shape and the library form add to the baseline over it, and the learned shape's
/// heights with a 2-SD band where it acts in mm: why the effect was named, and why in that
/// form.
fn effect_figures(d: &Diagnosis, dir: &Path) -> Result<Vec<(String, String)>> {
    let mut out = Vec::new();
    let ds = &d.ds;
    let base = &d.attr.baseline.pred;
    for e in d.attr.evals.iter().filter(|e| e.accepted) {
        let Some((lib, learned)) = &e.curves else {
            continue;
        };
        let axis = effect_axis(e.kind, &e.form);
        let b_mid = d.ctx.b_mid;
        let x_of = |i: usize| -> f64 {
            let r = &ds.rows[i];
            match axis {
                shapes::Axis::F { nu } => {
                    let b = candidates::field_b(&d.ident.model, r.z) / b_mid;
                    r.f * b.max(1e-300).powf(-nu)
                }
                shapes::Axis::Z => r.z,
                shapes::Axis::T => r.t,
                shapes::Axis::Since => r.since,
            }
        };
        // Visit means (rows for the time since a change, where the shape lives within visits).
        let series = |vals: &dyn Fn(usize, usize) -> f64, a: usize| -> Vec<(f64, f64)> {
            if axis == shapes::Axis::Since {
                return (0..ds.rows.len())
                    .filter(|&i| ds.visits[ds.rows[i].visit].prev.is_some())
                    .map(|i| (x_of(i), vals(i, a)))
                    .collect();
            }
            ds.visits
                .iter()
                .filter(|v| !v.rows.is_empty())
                .map(|v| {
                    let n = v.rows.len() as f64;
                    let x = v.rows.iter().map(|&i| x_of(i)).sum::<f64>() / n;
                    let y = v.rows.iter().map(|&i| vals(i, a)).sum::<f64>() / n;
                    (x, y)
                })
                .collect()
        };
        let mut panels: Vec<Panel> = (0..2)
            .map(|a| {
                let mut s = vec![Series::points(
                    "baseline residual",
                    series(&|i, a| ds.rows[i].r[a] - base[i][a], a),
                )
                .with_color(plot::RGBColor(150, 150, 150))];
                if !learned.is_empty() {
                    s.push(
                        Series::points(
                            "learned shape adds",
                            series(&|i, a| learned[i][a] - base[i][a], a),
                        )
                        .with_color(plot::RGBColor(213, 94, 0)),
                    );
                }
                s.push(
                    Series::points(
                        "library form adds",
                        series(&|i, a| lib[i][a] - base[i][a], a),
                    )
                    .with_color(plot::RGBColor(0, 158, 115)),
                );
                if let attribute::Form::Learned(sh) = &e.form {
                    if sh.family.mode == shapes::Mode::Add && sh.family.amp == 0.0 {
                        let k = &sh.family.knots;
                        let line = |f: f64| -> Vec<(f64, f64)> {
                            k.iter()
                                .enumerate()
                                .map(|(j, &x)| (x, sh.values[a][j] + f * sh.sd[a][j]))
                                .collect()
                        };
                        s.push(Series::line("learned shape [mm]", line(0.0)));
                        s.push(Series::dashed("+/- 2 SD", line(2.0)));
                        s.push(Series::dashed("", line(-2.0)));
                    }
                }
                Panel {
                    y_label: format!("r{} [mm]", a + 1),
                    series: s,
                }
            })
            .collect();
        // A learned shape that does not act in mm (a relative change, a rate deficit, the
        // share of a step still missing, or mm scaled by the field): its heights in their own
        // unit with a 2-SD band, in a panel of its own, over the range of the data.
        if let attribute::Form::Learned(sh) = &e.form {
            if let Some(p) = shape_panel(
                sh,
                (0..ds.rows.len())
                    .map(x_of)
                    .fold(f64::NEG_INFINITY, f64::max),
            ) {
                panels.push(p);
            }
        }
        let file = format!("effect_{}.png", e.name);
        let form = match &e.form {
            attribute::Form::Learned(sh) => format!("learned, {}", sh.family.mode.key()),
            attribute::Form::Parametric => "library form".into(),
        };
        plot::time_panels(
            &dir.join(&file),
            &format!("{}: baseline residual and the effect ({form})", e.name),
            &axis.label(),
            &panels,
        )?;
        out.push((
            file,
            format!(
                "{}: the baseline's residual along {} with what the learned shape and the library form add to the baseline",
                e.name,
                axis.label()
            ),
        ));
    }
    Ok(out)
}

/// The panel of a learned shape's heights in their own unit with a 2-SD band (None for a
/// shape in plain mm, drawn over the radii already).
fn shape_panel(sh: &shapes::Shape, x_max: f64) -> Option<Panel> {
    use shapes::Mode;
    let f = &sh.family;
    let (label, scale) = match f.mode {
        Mode::Add if f.amp == 0.0 => return None,
        Mode::Add => ("learned shape [mm at B_mid]", 1.0),
        Mode::Relative | Mode::Common => ("learned change [%]", 100.0),
        Mode::Aspect => ("learned aspect change [%]", 100.0),
        Mode::Rate => ("rate deficit [Hz]", 1.0),
        Mode::StepFraction => ("step still missing [%]", 100.0),
    };
    // One value for both radii where the mode shares it.
    let shared = matches!(f.mode, Mode::Rate | Mode::Aspect | Mode::Common);
    let radii: Vec<usize> = (0..2)
        .filter(|&a| f.axes[a] && !(shared && a == 1))
        .collect();
    let mut series = Vec::new();
    for a in radii {
        let name = if shared {
            "learned shape".to_string()
        } else {
            format!("learned shape, r{}", a + 1)
        };
        let line = |k: f64| -> Vec<(f64, f64)> {
            f.knots
                .iter()
                .enumerate()
                .filter(|(j, &x)| x <= x_max || *j == 0)
                .map(|(j, &x)| (x, scale * (sh.values[a][j] + k * sh.sd[a][j])))
                .collect()
        };
        let color = if a == 0 {
            plot::RGBColor(0, 114, 178)
        } else {
            plot::RGBColor(213, 94, 0)
        };
        series.push(Series::line(&name, line(0.0)).with_color(color));
        series.push(Series::dashed("+/- 2 SD", line(2.0)).with_color(color));
        series.push(Series::dashed("", line(-2.0)).with_color(color));
    }
    (!series.is_empty()).then(|| Panel {
        y_label: label.to_string(),
        series,
    })
}
