//! The Fig. 4/5-style PNGs of `magswarm paper --plots`.

use crate::{ReportError, Result};
use magswarm_model::{hz_to_rad_s, steady, Model};
use magswarm_paper::{bins, collapse, eval_mm, fine_grid, mad, median, seed_axes, PaperFigures};
use std::path::{Path, PathBuf};

use crate::plot::{self, ErrorBar, ErrorSeries, Heatmap, Labels, Series, Style};

/// Write the Fig. 4/5-style PNGs into `dir` for `model`, whose figures ([`magswarm_paper::paper_figures`])
/// are `figures`; returns the files written.
pub fn write_plots(model: &Model, figures: &PaperFigures, dir: &Path) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|err| ReportError::Io {
        what: "creating",
        path: dir.to_path_buf(),
        err,
    })?;
    let mut written = Vec::new();
    let (zs, fs) = fine_grid(model);
    // pts[j][i]: f index j, z index i (heatmap layout).
    let pts: Vec<Vec<steady::SteadyPoint>> = fs
        .iter()
        .map(|&f| zs.iter().map(|&z| eval_mm(model, z, f)).collect())
        .collect();
    let marks: Vec<(f64, f64)> = magswarm_model::seed_grid()
        .iter()
        .map(|&(z, f)| (z * 1e3, f))
        .collect();
    let (xl, yl) = ("z_m [mm]", "f [Hz]");
    type Getter = fn(&steady::SteadyPoint) -> f64;
    let maps: [(&str, &str, &str, Getter); 4] = [
        (
            "fig4a_r1.png",
            "Fig. 4a: steady radius r1 (5) over (z_m, f)",
            "r1 [mm]",
            |p| p.r1,
        ),
        (
            "fig4b_r2.png",
            "Fig. 4b: steady radius r2 (5) over (z_m, f)",
            "r2 [mm]",
            |p| p.r2,
        ),
        (
            "stiffness_s_x.png",
            "Stiffness S_x (7) over (z_m, f)",
            "S_x [-]",
            |p| p.s_x,
        ),
        (
            "stiffness_s_y.png",
            "Stiffness S_y (7) over (z_m, f)",
            "S_y [-]",
            |p| p.s_y,
        ),
    ];
    for (name, title, cb, g) in maps {
        let path = dir.join(name);
        let values: Vec<Vec<f64>> = pts.iter().map(|row| row.iter().map(g).collect()).collect();
        plot::heatmap(
            &path,
            &Labels {
                title,
                x: xl,
                y: yl,
            },
            &Heatmap {
                xs: &zs,
                ys: &fs,
                values: &values,
                colorbar_label: cb,
                marks: &marks,
                marks_label: "seed grid (50 points)",
                range: None,
            },
        )?;
        written.push(path);
    }

    // Radii against frequency at the seed's z_m (the non-monotonic frequency dependence).
    let (sz, _) = seed_axes();
    let fine_f: Vec<f64> = (0..=90).map(|j| 1.0 + 0.1 * j as f64).collect();
    let mut series = Vec::new();
    for (k, &z) in sz.iter().enumerate() {
        let c = plot::PALETTE[k % plot::PALETTE.len()];
        let r2: Vec<(f64, f64)> = fine_f
            .iter()
            .map(|&f| (f, eval_mm(model, z, f).r2))
            .collect();
        let r1: Vec<(f64, f64)> = fine_f
            .iter()
            .map(|&f| (f, eval_mm(model, z, f).r1))
            .collect();
        series.push(Series::line(format!("r2, z_m {z} mm"), r2).with_color(c));
        series.push(Series::new(format!("r1, z_m {z} mm"), r1, Style::Dashed).with_color(c));
    }
    let path = dir.join("radii_vs_f.png");
    plot::lines_sized(
        &path,
        &Labels {
            title: "Steady radii (5) against f at the seed's z_m (r2 solid, r1 dashed)",
            x: "f [Hz]",
            y: "radius [mm]",
        },
        &series,
        (1100, 760),
    )?;
    written.push(path);

    // Fig. 5: collapse.
    let col = collapse(model);
    let phi: Vec<(f64, f64)> = fine_f
        .iter()
        .map(|&f| (f, steady::phi(model, hz_to_rad_s(f))))
        .collect();
    let (mut y1, mut y2) = (Vec::new(), Vec::new());
    for (f, a, b) in bins(&col.samples) {
        let (m1, m2) = (median(&a), median(&b));
        let (d1, d2) = (mad(&a), mad(&b));
        y1.push(ErrorBar {
            x: f - 0.1,
            y: m1,
            lo: m1 - d1,
            hi: m1 + d1,
        });
        y2.push(ErrorBar {
            x: f + 0.1,
            y: m2,
            lo: m2 - d2,
            hi: m2 + d2,
        });
    }
    let exact1: Vec<(f64, f64)> = col.exact.iter().map(|e| (e.0, e.1)).collect();
    let exact2: Vec<(f64, f64)> = col.exact.iter().map(|e| (e.0, e.2)).collect();
    let path = dir.join("fig5_collapse.png");
    plot::scatter_with_errorbars(
        &path,
        &Labels {
            title: "Fig. 5: collapse y_i = r_i S_i^alpha_i / C_i against f",
            x: "f [Hz]",
            y: "y_i [-]",
        },
        &[
            ErrorSeries {
                name: format!(
                    "r1 + N(0, {} mm), {} repeats: median ± MAD (shifted -0.1 Hz)",
                    col.figures.sigma_mm[0], col.figures.repeats
                ),
                points: y1,
                color: Some(plot::PALETTE[0]),
            },
            ErrorSeries {
                name: format!(
                    "r2 + N(0, {} mm), {} repeats: median ± MAD (shifted +0.1 Hz)",
                    col.figures.sigma_mm[1], col.figures.repeats
                ),
                points: y2,
                color: Some(plot::PALETTE[1]),
            },
        ],
        &[
            Series::line("Phi(omega) (6)", phi).with_color(plot::RGBColor(0, 0, 0)),
            Series::points(
                "model y1, y2 without noise (on Phi)",
                [exact1, exact2].concat(),
            )
            .with_color(plot::PALETTE[2]),
        ],
    )?;
    written.push(path);

    // Formation time constant map.
    let path = dir.join("formation_time_constant.png");
    plot::heatmap(
        &path,
        &Labels {
            title: "Formation time constant of ODE (4) (slowest eigenvalue)",
            x: xl,
            y: yl,
        },
        &Heatmap {
            xs: &zs,
            ys: &fs,
            values: &figures.tau_map,
            colorbar_label: "tau [s]",
            marks: &marks,
            marks_label: "seed grid",
            range: None,
        },
    )?;
    written.push(path);

    // Where constant gains fail.
    let path = dir.join("constant_kb_error.png");
    plot::heatmap(
        &path,
        &Labels {
            title: "ODE (4) with the best constant K_b, K_tau, p: equilibrium error vs map",
            x: xl,
            y: yl,
        },
        &Heatmap {
            xs: &zs,
            ys: &fs,
            values: &figures.constant_fit.full.error_map_pct,
            colorbar_label: "max rel. error [%]",
            marks: &[],
            marks_label: "",
            range: None,
        },
    )?;
    written.push(path);
    Ok(written)
}
