//! `magswarm paper`: the seed's figures beside the model's.
//!
//! [`paper_figures`] computes every figure the seed reports (Table I, Sec. III-C, Sec. III-D)
//! from a [`Model`] on the seed's 50-point grid, the consistency of ODE (4) with the map over a
//! fine envelope grid, and the best *constant*-gain fit of (4) (whether constant gains could
//! stand in for the scheduled ones). The result is a plain serialisable struct
//! ([`PaperFigures`]) so the CLI, the FMU tests and the docs all quote the same numbers;
//! [`render_table`] turns it into the printed table and [`write_plots`] draws the
//! Fig. 4/5-style PNGs.
//!
//! One job per module: [`seed`] (the seed's reported values), `figures` (the result struct and
//! the seed-grid figures), `dynamics` (ODE (4) against the map), `closed_loop` (the Sec. III-D
//! operating points), `collapse` (Fig. 5), [`constant_fit`], `table`, `plots`. The command's
//! arguments are in [`crate::cli`].
//!
//! Units: z_m in mm and f in Hz in everything printed (the model itself is SI at its inputs),
//! radii in mm, field quantities in SI.

mod closed_loop;
mod collapse;
pub mod constant_fit;
mod dynamics;
mod figures;
mod plots;
pub mod seed;
mod table;

pub use crate::cli::PaperArgs;
pub use figures::{
    fine_grid, mad, median, paper_figures, ClosedLoopPoint, CollapseFigures, DynamicsFigures,
    FreqShape, GridFigures, MagnetFigures, PaperFigures,
};
pub use plots::write_plots;
pub use table::{render_table, Row};

use anyhow::{Context, Result};
use magswarm_model::Model;

/// Run the command.
pub fn run(a: &PaperArgs) -> Result<()> {
    let model = match &a.model {
        Some(p) => Model::load(p).with_context(|| format!("loading model {}", p.display()))?,
        None => Model::paper(),
    };
    let figures = paper_figures(&model);
    if a.json {
        println!("{}", serde_json::to_string_pretty(&figures)?);
    } else {
        print!("{}", render_table(&figures));
    }
    if let Some(dir) = &a.plots {
        let files = write_plots(&model, &figures, dir)?;
        if !a.json {
            println!("\nplots:");
            for f in files {
                println!("  {}", f.display());
            }
        }
    }
    Ok(())
}
