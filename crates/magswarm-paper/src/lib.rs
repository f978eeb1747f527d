//! The seed's figures beside the model's (`magswarm paper`).
//!
//! [`paper_figures`] computes every figure the seed reports (Table I, Sec. III-C, Sec. III-D)
//! from a [`Model`] on the seed's 50-point grid, the consistency of ODE (4) with the map over a
//! fine envelope grid, and the best *constant*-gain fit of (4) (whether constant gains could
//! stand in for the scheduled ones). The result is a plain serialisable struct
//! ([`PaperFigures`]) so the CLI, the FMU tests and the docs all quote the same numbers;
//! [`render_table`] turns it into the printed table, and the report crate
//! (`magswarm-report`) draws the Fig. 4/5-style PNGs from it.
//!
//! One job per module: [`seed`] (the seed's reported values), `figures` (the result structs and
//! the seed-grid figures), `grid` (the shared grids and statistics), `dynamics` (ODE (4) against the map), `closed_loop` (the Sec. III-D
//! operating points), `collapse` (Fig. 5), [`constant_fit`], `table`.
//!
//! Units: z_m in mm and f in Hz in everything printed (the model itself is SI at its inputs),
//! radii in mm, field quantities in SI.

mod closed_loop;
mod collapse;
pub mod constant_fit;
mod dynamics;
mod figures;
mod grid;
pub mod seed;
mod table;

pub use collapse::{bins, collapse};
pub use figures::{
    ClosedLoopPoint, CollapseFigures, DynamicsFigures, FreqShape, GridFigures, MagnetFigures,
    PaperFigures, Row,
};
pub use grid::{eval_mm, fine_grid, mad, median, seed_axes};
pub use table::render_table;

use magswarm_model::Model;

/// Compute every figure `magswarm paper` reports for `model`.
pub fn paper_figures(model: &Model) -> PaperFigures {
    let sweep = dynamics::dynamics_sweep(model);
    let mut pf = PaperFigures {
        model_name: model.name.clone(),
        magnet: figures::magnet_figures(model),
        grid: figures::grid_figures(model),
        closed_loop: closed_loop::closed_loop(model),
        dynamics: sweep.figures,
        tau_map: sweep.tau,
        constant_fit: constant_fit::fit(model),
        collapse: collapse::collapse(model).figures,
        table: Vec::new(),
    };
    pf.table = table::rows(&pf);
    pf
}
