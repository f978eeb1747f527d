//! The report's PNG figures: predicted against measured, residual maps over (z_m, f), the
//! collapse onto Phi(f) and the transient trace, drawn from the [`Identification`] as computed.

use crate::plot::{self, ErrorBar, ErrorSeries, Labels, Panel, Series};
use crate::residual::{levels, residual_map, ResidualMap};
use crate::Result;
use magswarm_identify::data::{self, OpPoint};
use magswarm_identify::Identification;
use magswarm_model::{hz_to_rad_s, steady};
use std::path::Path;

pub(super) fn plots(id: &Identification, dir: &Path) -> Result<Vec<(String, String)>> {
    let m = &id.model;
    let mut out = Vec::new();
    // Predicted vs measured.
    let pv = |pts: &[OpPoint], pred: &[[f64; 2]], a: usize| -> Vec<(f64, f64)> {
        pts.iter()
            .zip(pred)
            .map(|(p, r)| (p.mean[a], r[a]))
            .collect()
    };
    let mut series = vec![
        Series::points("r1 (fitted points)", pv(&id.points, &id.pred.points, 0)),
        Series::points("r2 (fitted points)", pv(&id.points, &id.pred.points, 1)),
    ];
    if !id.withheld.is_empty() {
        series.push(
            Series::new(
                "r1 (withheld)",
                pv(&id.withheld, &id.pred.withheld, 0),
                plot::Style::Points,
            )
            .with_color(plot::PALETTE[2]),
        );
        series.push(
            Series::new(
                "r2 (withheld)",
                pv(&id.withheld, &id.pred.withheld, 1),
                plot::Style::Points,
            )
            .with_color(plot::PALETTE[3]),
        );
    }
    plot::pred_vs_meas(
        &dir.join("pred_vs_meas.png"),
        &Labels {
            title: "Predicted vs measured radii (point means)",
            x: "measured [mm]",
            y: "predicted [mm]",
        },
        &series,
    )?;
    out.push((
        "pred_vs_meas.png".into(),
        "Predicted against measured point means".into(),
    ));

    // Residual maps over (z_m, f).
    let all: Vec<(&OpPoint, &[f64; 2])> = id
        .points
        .iter()
        .zip(&id.pred.points)
        .chain(id.withheld.iter().zip(&id.pred.withheld))
        .collect();
    let marks: Vec<(f64, f64)> = id.withheld.iter().map(|p| (p.z_mm, p.f_hz)).collect();
    for a in 0..2 {
        let points: Vec<(f64, f64, f64)> = all
            .iter()
            .map(|&(p, pred)| (p.z_mm, p.f_hz, pred[a] - p.mean[a]))
            .collect();
        let name = format!("residual_r{}.png", a + 1);
        let title = format!("Residual r{} (model - measured mean) over (z_m, f)", a + 1);
        let drawn = residual_map(
            &dir.join(&name),
            &ResidualMap {
                title: &title,
                points: &points,
                marks: &marks,
                marks_label: if marks.is_empty() { "" } else { "withheld" },
                half_range: None,
            },
        )?;
        if drawn {
            out.push((name, format!("Residual map of r{} over (z_m, f)", a + 1)));
        }
    }
    let fs = levels(all.iter().map(|p| p.0.f_hz));

    // Collapse plot (Fig. 5): y_i = r_i S_i^alpha_i / C_i against f, median +- MAD per bin.
    let s = &m.steady;
    let edges: Vec<f64> = if fs.len() <= 15 {
        fs.clone()
    } else {
        let (lo, hi) = (fs[0], fs[fs.len() - 1]);
        (0..10)
            .map(|k| lo + (hi - lo) * (k as f64 + 0.5) / 10.0)
            .collect()
    };
    let mut bins: Vec<[Vec<f64>; 2]> = vec![[Vec::new(), Vec::new()]; edges.len()];
    for (p, st) in id.points.iter().zip(&id.pred.stiffness) {
        let b = edges
            .iter()
            .enumerate()
            .min_by(|x, y| (x.1 - p.f_hz).abs().total_cmp(&(y.1 - p.f_hz).abs()))
            .map(|x| x.0)
            .unwrap_or(0);
        for smp in &p.samples {
            bins[b][0].push(smp[0] * st[0].powf(s.alpha_1) / s.C_1);
            bins[b][1].push(smp[1] * st[1].powf(s.alpha_2) / s.C_2);
        }
    }
    let width = if edges.len() > 1 {
        (edges[edges.len() - 1] - edges[0]) / (edges.len() - 1) as f64
    } else {
        1.0
    };
    let es: Vec<ErrorSeries> = (0..2)
        .map(|a| ErrorSeries {
            name: format!("r{} (median +- MAD)", a + 1),
            points: edges
                .iter()
                .zip(&bins)
                .filter(|(_, b)| !b[a].is_empty())
                .map(|(&f, b)| {
                    let (med, mad) = data::median_mad(&b[a]);
                    ErrorBar {
                        x: f + (a as f64 - 0.5) * 0.12 * width,
                        y: med,
                        lo: med - mad,
                        hi: med + mad,
                    }
                })
                .collect(),
            color: None,
        })
        .collect();
    let (f0, f1) = (
        fs[0].min(edges[0]),
        fs[fs.len() - 1].max(edges[edges.len() - 1]),
    );
    let phi: Vec<(f64, f64)> = (0..=200)
        .map(|k| {
            let f = f0 + (f1 - f0) * k as f64 / 200.0;
            (f, steady::phi(m, hz_to_rad_s(f)))
        })
        .collect();
    plot::scatter_with_errorbars(
        &dir.join("collapse.png"),
        &Labels {
            title: "Collapse (Fig. 5): y_i = r_i S_i^alpha_i / C_i against Phi(f)",
            x: "f [Hz]",
            y: "y_i [-]",
        },
        &es,
        &[Series::line("Phi(f) fitted", phi).with_color(plot::RGBColor(0, 0, 0))],
    )?;
    out.push((
        "collapse.png".into(),
        "Collapsed radii per frequency bin (median +- MAD) against the fitted Phi".into(),
    ));

    // Transients: the session with the most transient rows, measured vs replayed.
    if id.dynamics.is_some() {
        if let Some(fig) = transient_plot(id, dir)? {
            out.push(fig);
        }
    }
    Ok(out)
}

fn transient_plot(id: &Identification, dir: &Path) -> Result<Option<(String, String)>> {
    let Some(tr) = &id.trace else {
        return Ok(None);
    };
    let panels: Vec<Panel> = (0..2)
        .map(|a| Panel {
            y_label: format!("r{} [mm]", a + 1),
            series: vec![
                Series::points(
                    "measured",
                    tr.iter().filter_map(|x| x.2.map(|r| (x.0, r[a]))).collect(),
                ),
                Series::line(
                    "replayed (fitted model)",
                    tr.iter().map(|x| (x.0, x.1[a])).collect(),
                ),
            ],
        })
        .collect();
    plot::time_panels(
        &dir.join("transients.png"),
        "Transients: measured and replayed",
        "t [s]",
        &panels,
    )?;
    Ok(Some((
        "transients.png".into(),
        "Measured radii and the fitted model's replay around the largest input change".into(),
    )))
}
