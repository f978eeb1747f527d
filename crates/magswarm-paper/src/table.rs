//! The printed table: one row per reported figure (seed value, model value, deviation),
//! grouped by section, and its text rendering.

use super::figures::{PaperFigures, Row};
use super::seed;

pub(super) fn pct(model: f64, seed: f64) -> String {
    format!("{:+.1} %", (model / seed - 1.0) * 100.0)
}

pub(super) fn yes_no(b: bool) -> &'static str {
    if b {
        "yes"
    } else {
        "no"
    }
}

/// Collects table rows under the current section.
pub(super) struct Table {
    section: String,
    rows: Vec<Row>,
}

impl Table {
    fn section(&mut self, s: &str) {
        self.section = s.to_string();
    }
    fn row(
        &mut self,
        figure: &str,
        seed: impl Into<String>,
        model: impl Into<String>,
        dev: impl Into<String>,
    ) {
        self.rows.push(Row {
            section: self.section.clone(),
            figure: figure.into(),
            seed: seed.into(),
            model: model.into(),
            deviation: dev.into(),
        });
    }
}

pub(super) fn rows(p: &PaperFigures) -> Vec<Row> {
    let mut t = Table {
        section: String::new(),
        rows: Vec::new(),
    };
    let g = &p.grid;
    t.section("seed grid (z_m 3.5..23.5 mm step 5 x f 1..10 Hz, 50 points)");
    t.row(
        "median S_x [-] (Table I)",
        format!("{}", seed::MEDIAN_S_X),
        format!("{:.3}", g.median_s_x),
        pct(g.median_s_x, seed::MEDIAN_S_X),
    );
    t.row(
        "median S_y [-] (Table I)",
        format!("{}", seed::MEDIAN_S_Y),
        format!("{:.3}", g.median_s_y),
        pct(g.median_s_y, seed::MEDIAN_S_Y),
    );
    t.row(
        "S_x/S_y, ratio of medians [-] (III-C d)",
        format!("~{}", seed::S_RATIO),
        format!("{:.3}", g.s_ratio),
        format!(
            "{} (pointwise median {:.3})",
            pct(g.s_ratio, seed::S_RATIO),
            g.median_pointwise_s_ratio
        ),
    );
    t.row(
        "median k_xx/k_yy [-] (III-C d)",
        format!("~{}", seed::K_RATIO),
        format!("{:.3}", g.median_k_ratio),
        pct(g.median_k_ratio, seed::K_RATIO),
    );
    t.row(
        "r1 range max-min [mm] (III-C d)",
        format!("{}", seed::R1_RANGE_MM),
        format!("{:.2}", g.r1_range_mm),
        format!(
            "{} (r1 {:.2}..{:.2} mm)",
            pct(g.r1_range_mm, seed::R1_RANGE_MM),
            g.r1_min_max_mm[0],
            g.r1_min_max_mm[1]
        ),
    );
    t.row(
        "r2 range max-min [mm] (III-C d)",
        format!("{}", seed::R2_RANGE_MM),
        format!("{:.2}", g.r2_range_mm),
        format!(
            "{} (r2 {:.2}..{:.2} mm)",
            pct(g.r2_range_mm, seed::R2_RANGE_MM),
            g.r2_min_max_mm[0],
            g.r2_min_max_mm[1]
        ),
    );
    t.row(
        "r2 > r1 everywhere (III-C a)",
        "yes",
        yes_no(g.r2_gt_r1_everywhere),
        format!(
            "worst margin {:.2} mm at z_m {} mm, f {} Hz",
            g.worst_r2_minus_r1_mm, g.worst_margin_at[0], g.worst_margin_at[1]
        ),
    );
    t.row(
        "radii grow with z_m at every f (III-C a-i)",
        "yes",
        yes_no(g.radii_grow_with_z),
        format!("smallest step {:.3} mm per 5 mm", g.min_z_increment_mm),
    );
    t.row(
        "radii fall then rise with f (III-C a-ii,iii)",
        "yes",
        yes_no(g.falling_then_rising_everywhere),
        "argmin over f per z_m below",
    );
    for fs in &g.frequency_shape {
        let where_ = |b: bool| if b { "interior" } else { "at edge" };
        t.row(
            &format!("  z_m {:>4.1} mm: argmin f of r1, r2 [Hz]", fs.z_m_mm),
            "interior",
            format!("{}, {}", fs.r1_argmin_f_hz, fs.r2_argmin_f_hz),
            format!(
                "r1 {}, r2 {}",
                where_(fs.r1_interior),
                where_(fs.r2_interior)
            ),
        );
    }
    let c = &p.collapse;
    t.row(
        "Fig. 5: max |median y_i/Phi - 1| per f bin (III-C c)",
        format!("5-{:.0} %", seed::COLLAPSE_TOL * 100.0),
        format!(
            "r1 {:.1} %, r2 {:.1} %",
            c.max_median_dev[0] * 100.0,
            c.max_median_dev[1] * 100.0
        ),
        format!(
            "synthetic: model + N(0, {}/{} mm), {} repeats",
            c.sigma_mm[0], c.sigma_mm[1], c.repeats
        ),
    );
    t.section("closed-loop model points (III-D a): nearest reachable (r1, r2) in the envelope");
    for cl in &p.closed_loop {
        t.row(
            "(r1, r2) [mm]",
            format!("({:.2}, {:.2})", cl.seed_mm[0], cl.seed_mm[1]),
            format!("({:.2}, {:.2})", cl.nearest_mm[0], cl.nearest_mm[1]),
            format!(
                "distance {:.3} mm at z_m {:.2} mm, f {:.2} Hz",
                cl.distance_mm, cl.z_m_mm, cl.f_hz
            ),
        );
    }
    let d = &p.dynamics;
    t.section(&format!(
        "dynamics: ODE (4) equilibrium vs map (5), {}x{} envelope grid",
        d.grid[0], d.grid[1]
    ));
    t.row(
        "scheduled K_b: max |r_eq - r_map|/r_map",
        "-",
        format!("{:.1e} %", d.max_rel_error * 100.0),
        "consistent by construction",
    );
    let cf = &p.constant_fit;
    for (name, fit) in [
        ("best constant K_b1, K_b2", &cf.kb_only),
        ("best constant K_b1, K_b2, K_tau, p", &cf.full),
    ] {
        t.row(
            &format!("{name}: max / RMS rel. error"),
            "-",
            format!(
                "{:.1} % / {:.1} %",
                fit.max_rel_error * 100.0,
                fit.rms_rel_error * 100.0
            ),
            format!(
                "K_b ({:.3e}, {:.3e}), K_tau {:.3e}, p {:.3}; worst at z_m {:.1} mm, f {:.1} Hz; {} bad points",
                fit.k_b[0], fit.k_b[1], fit.k_tau, fit.p, fit.worst_at[0], fit.worst_at[1], fit.bad_points
            ),
        );
    }
    t.row(
        "equilibria per point (min..max)",
        "-",
        format!(
            "{}..{}",
            d.equilibria_count_min_max[0], d.equilibria_count_min_max[1]
        ),
        format!("unique everywhere: {}", yes_no(d.unique_everywhere)),
    );
    t.row(
        "stable everywhere",
        "-",
        yes_no(d.stable_everywhere),
        format!("{} clamped gains", d.clamped_points),
    );
    t.row(
        "formation time constant [s]",
        "-",
        format!("{:.2}..{:.2}", d.time_constant_s[0], d.time_constant_s[1]),
        "slowest eigenvalue at the equilibrium",
    );
    t.row(
        "scheduled K_b1, K_b2 [mm^(1-beta)/s]",
        "-",
        format!(
            "{:.3e}..{:.3e}, {:.3e}..{:.3e}",
            d.k_b1_range[0], d.k_b1_range[1], d.k_b2_range[0], d.k_b2_range[1]
        ),
        "",
    );
    t.row(
        "r2 > r1 / radii grow with z_m (fine grid)",
        "yes / yes",
        format!(
            "{} / {}",
            yes_no(d.r2_gt_r1_fine),
            yes_no(d.grow_with_z_fine)
        ),
        format!("{} flagged points", d.flagged_points),
    );
    t.section("field at the swarm over the envelope (SI)");
    t.row(
        "B [T]",
        "-",
        format!("{:.4}..{:.4}", d.b_t[0], d.b_t[1]),
        "",
    );
    t.row(
        "g_z [T/m]",
        "-",
        format!("{:.3}..{:.3}", d.g_z_t_per_m[0], d.g_z_t_per_m[1]),
        "",
    );
    t.row(
        "k_xx [T^2/m^2]",
        "-",
        format!("{:.1}..{:.1}", d.k_xx_t2_per_m2[0], d.k_xx_t2_per_m2[1]),
        "",
    );
    t.row(
        "k_yy [T^2/m^2]",
        "-",
        format!("{:.1}..{:.1}", d.k_yy_t2_per_m2[0], d.k_yy_t2_per_m2[1]),
        "",
    );
    let m = &p.magnet;
    t.section("magnet (NdFeB sphere as a point dipole)");
    t.row("radius [mm] (III-A)", "20", format!("{}", m.radius_mm), "");
    t.row(
        "remanence B_r [T]",
        "not given",
        format!("{}", m.remanence_t),
        "reconstruction (N42)",
    );
    t.row(
        "dipole moment |m| [A m^2]",
        "fitted, not given",
        format!("{:.2}", m.dipole_moment_a_m2),
        format!("mu0 m/(4 pi) = {:.4e} T m^3", m.mu0_m_over_4pi_t_m3),
    );
    t.row(
        "z offset, lateral offset [mm]",
        "not given",
        format!("{:.3}, {:.3}", m.z_offset_mm, m.lateral_offset_mm),
        format!(
            "swarm {:.2}..{:.2} mm below the magnet centre",
            m.depth_range_mm[0], m.depth_range_mm[1]
        ),
    );
    t.rows
}

/// The printed table.
pub fn render_table(p: &PaperFigures) -> String {
    let w0 = p.table.iter().map(|r| r.figure.len()).max().unwrap_or(0);
    let w1 = p
        .table
        .iter()
        .map(|r| r.seed.len())
        .max()
        .unwrap_or(0)
        .max(4);
    let w2 = p
        .table
        .iter()
        .map(|r| r.model.len())
        .max()
        .unwrap_or(0)
        .max(5);
    let mut out = format!("magswarm paper: seed figures vs model '{}'\n", p.model_name);
    let mut section = "";
    for r in &p.table {
        if r.section != section {
            section = &r.section;
            out.push_str(&format!("\n## {section}\n"));
            out.push_str(&format!(
                "{:<w0$}  {:<w1$}  {:<w2$}  {}\n",
                "figure", "seed", "model", "deviation"
            ));
        }
        out.push_str(&format!(
            "{:<w0$}  {:<w1$}  {:<w2$}  {}\n",
            r.figure, r.seed, r.model, r.deviation
        ));
    }
    out
}
