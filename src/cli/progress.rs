//! The progress bar the program draws for the libraries' long work (identification, diagnosis):
//! the libraries count steps through [`magswarm_identify::Progress`], only the binary knows
//! about terminals and indicatif.

use std::io::IsTerminal;

/// A progress bar on stderr, drawn only when stderr is a terminal (a pipe or a CI log gets
/// nothing, not a stream of redraws).
pub struct Bar(indicatif::ProgressBar);

impl Bar {
    /// A bar labelled `msg` until the work names its first stage.
    pub fn new(msg: &str) -> Bar {
        if !std::io::stderr().is_terminal() {
            return Bar(indicatif::ProgressBar::hidden());
        }
        let pb = indicatif::ProgressBar::new(0);
        pb.set_style(
            indicatif::ProgressStyle::with_template("{msg:>12} [{bar:30}] {pos}/{len} {elapsed}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        pb.set_message(msg.to_string());
        Bar(pb)
    }
}

impl magswarm_identify::Progress for Bar {
    fn start(&self, total: u64) {
        self.0.set_length(total);
    }
    fn inc(&self, n: u64) {
        self.0.inc(n);
    }
    fn add_total(&self, n: u64) {
        self.0.inc_length(n);
    }
    fn stage(&self, name: &str) {
        self.0.set_message(name.to_string());
    }
    fn finish(&self) {
        self.0.finish_and_clear();
    }
}
