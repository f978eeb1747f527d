//! Plots and reports: the one crate that draws (the only user of `plotters`).
//!
//! - [`plot`]: a small, generic layer over `plotters` (line, panel, error-bar,
//!   predicted-vs-measured and heatmap plots, one PNG each, bundled font);
//! - [`identify`]: `magswarm identify --report`'s markdown and figures, and its summary;
//! - [`paper`]: `magswarm paper --plots`' Fig. 4/5-style figures;
//! - [`residual`]: the residual map over the operating points (z_m, f) that reports share.
//!
//! Reports read the numbers of the crate that computed them (an [`magswarm_identify::Identification`],
//! a [`magswarm_paper::PaperFigures`]) and never recompute them.

mod error;
pub mod identify;
pub mod paper;
pub mod plot;
pub mod residual;

pub use error::{ReportError, Result};
