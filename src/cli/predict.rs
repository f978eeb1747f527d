//! `magswarm predict`: its arguments and the run (read the log, replay it with
//! [`magswarm::predict::predict_log`], write the output log).

use std::path::PathBuf;

use anyhow::{Context, Result};
use magswarm::log::{Log, LogWriter};
use magswarm::model::Model;
use magswarm::predict;

/// Arguments of `magswarm predict`.
#[derive(Debug, clap::Args)]
pub struct PredictArgs {
    /// Model JSON (default: the built-in paper model).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Input log (docs/log-format.md format; needs t_s, z_m_mm, f_hz).
    #[arg(long)]
    pub log: PathBuf,
    /// Output log with predicted r1_mm, r2_mm.
    #[arg(long)]
    pub out: PathBuf,
}

/// Run `magswarm predict`.
pub fn run(a: &PredictArgs) -> Result<()> {
    let model = Model::load_or_paper(a.model.as_deref())?;
    let log = Log::read(&a.log)?;
    if log.rows.is_empty() {
        anyhow::bail!("{}: the log has no rows to replay", a.log.display());
    }
    let pred = predict::predict_log(&model, &log)?;
    let (layout, rows) = predict::output_rows(&log, &pred);
    let mut w = LogWriter::create(&a.out, layout)
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    for o in &rows {
        w.write_row(o)
            .with_context(|| format!("cannot write {}", a.out.display()))?;
    }
    w.finish()
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    eprintln!(
        "predict: {} rows of {} replayed through {} -> {}",
        log.rows.len(),
        a.log.display(),
        a.model
            .as_ref()
            .map(|p| p.display().to_string())
            .unwrap_or_else(|| "the paper model".into()),
        a.out.display()
    );
    Ok(())
}
