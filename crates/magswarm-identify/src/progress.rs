//! Progress of a long identification, reported to whoever shows it: the library counts steps
//! (LM starts, bootstrap replicates), the program draws them (a progress bar on a terminal).

/// Receives the progress of [`crate::identify_with_progress`]. Called from worker threads
/// too (the bootstrap runs in parallel), hence `Sync`.
pub trait Progress: Sync {
    /// The work starts with `total` steps.
    fn start(&self, total: u64) {
        let _ = total;
    }
    /// `n` more steps are done.
    fn inc(&self, n: u64) {
        let _ = n;
    }
    /// `n` more steps were added to the total (a refit after fixing a parameter).
    fn add_total(&self, n: u64) {
        let _ = n;
    }
    /// A new stage of the work begins (a name a person reads: "baseline", "gap tests").
    fn stage(&self, name: &str) {
        let _ = name;
    }
    /// The work is over.
    fn finish(&self) {}
}

/// Progress that nobody watches.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;

impl Progress for Silent {}
