//! The report's figures: residual maps over (z_m, f) before and after the accepted effects on a
//! diverging colour map centred on zero, residuals over session time and after input changes.

use super::*;

/// Mean visit residual per point (NaN where a point has no visit).
fn point_means(d: &Diagnosis, pred: &[[f64; 2]], a: usize) -> Vec<f64> {
    let res: Vec<[f64; 2]> =
        d.ds.rows
            .iter()
            .zip(pred)
            .map(|(r, p)| [r.r[0] - p[0], r.r[1] - p[1]])
            .collect();
    let vr = gap::visit_residuals(&d.ds, &res);
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
    let (zs, fs) = d.ds.levels();
    let grid_ok = zs.len() >= 2 && fs.len() >= 2 && zs.len() * fs.len() <= 40_000;
    if grid_ok {
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
                let mut grid = vec![vec![f64::NAN; zs.len()]; fs.len()];
                for (p, &(z, f)) in d.ds.points.iter().enumerate() {
                    let i = zs.iter().position(|x| (x - z).abs() < 1e-6).unwrap_or(0);
                    let j = fs.iter().position(|x| (x - f).abs() < 1e-6).unwrap_or(0);
                    grid[j][i] = vals[p];
                }
                let name = format!("residual_{tag}_r{}.png", a + 1);
                plot::heatmap_diverging(
                    &dir.join(&name),
                    &Labels {
                        title: &title,
                        x: "z_m [mm]",
                        y: "f [Hz]",
                    },
                    &Heatmap {
                        xs: &zs,
                        ys: &fs,
                        values: &grid,
                        colorbar_label: "residual [mm]",
                        marks: if tag == "before" { &in_region } else { &[] },
                        marks_label: if tag == "before" && !in_region.is_empty() {
                            "in a significant region"
                        } else {
                            ""
                        },
                        range: Some((-vmax, vmax)),
                    },
                )?;
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
    let vb = gap::visit_residuals(
        &d.ds,
        &d.ds
            .rows
            .iter()
            .zip(&d.attr.baseline.pred)
            .map(|(r, p)| [r.r[0] - p[0], r.r[1] - p[1]])
            .collect::<Vec<_>>(),
    );
    let va = gap::visit_residuals(
        &d.ds,
        &d.ds
            .rows
            .iter()
            .zip(&d.attr.augmented.pred)
            .map(|(r, p)| [r.r[0] - p[0], r.r[1] - p[1]])
            .collect::<Vec<_>>(),
    );
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
    Ok(out)
}
