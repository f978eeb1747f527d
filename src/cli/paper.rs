//! `magswarm paper`: its arguments and the run (the figures of [`magswarm::paper`], printed as a
//! table or JSON, and the plots of [`magswarm::report::paper`]).

use std::path::PathBuf;

use anyhow::Result;
use magswarm::model::Model;
use magswarm::paper::{paper_figures, render_table};

/// Arguments of `magswarm paper`.
#[derive(Debug, clap::Args)]
pub struct PaperArgs {
    /// Model JSON (default: the built-in paper model).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Write Fig. 4/5-style PNG plots into this directory.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// Print the figures as JSON (machine-readable) instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// Run `magswarm paper`.
pub fn run(a: &PaperArgs) -> Result<()> {
    let model = Model::load_or_paper(a.model.as_deref())?;
    let figures = paper_figures(&model);
    if a.json {
        println!("{}", serde_json::to_string_pretty(&figures)?);
    } else {
        print!("{}", render_table(&figures));
    }
    if let Some(dir) = &a.plots {
        let files = magswarm::report::paper::write_plots(&model, &figures, dir)?;
        if !a.json {
            println!("\nplots:");
            for f in files {
                println!("  {}", f.display());
            }
        }
    }
    Ok(())
}
