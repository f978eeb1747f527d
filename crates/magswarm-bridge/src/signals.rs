//! The operator's stop: SIGINT and SIGTERM set flags that the run loop and the rig's session
//! check on every poll (a handler does nothing else, so it is async-signal-safe).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use crate::safety::Fault;

/// SIGINT / SIGTERM flags.
#[derive(Clone, Default)]
pub struct Signals {
    /// SIGINT seen.
    pub int: Arc<AtomicBool>,
    /// SIGTERM seen.
    pub term: Arc<AtomicBool>,
}

impl Signals {
    /// Register the handlers (the flags are set; the loop notices within one poll).
    pub fn install() -> std::io::Result<Signals> {
        let s = Signals::default();
        signal_hook::flag::register(signal_hook::consts::SIGINT, s.int.clone())?;
        signal_hook::flag::register(signal_hook::consts::SIGTERM, s.term.clone())?;
        Ok(s)
    }

    pub(crate) fn check(&self) -> Result<(), Fault> {
        if self.int.load(Ordering::SeqCst) {
            return Err(Fault::Signal("SIGINT".into()));
        }
        if self.term.load(Ordering::SeqCst) {
            return Err(Fault::Signal("SIGTERM".into()));
        }
        Ok(())
    }
}
