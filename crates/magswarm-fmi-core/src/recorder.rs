//! What an importer's logger received: the in-process hosts of both shells (tests, fuzz
//! targets, benchmarks) record every message an instance logs, to assert on it.

use std::sync::Mutex;

/// One message the FMU passed to the logger.
#[derive(Debug, Clone, PartialEq)]
pub struct LogEntry {
    /// Status of the message.
    pub status: i32,
    /// Category.
    pub category: String,
    /// Text.
    pub message: String,
}

/// Records what the FMU logs (passed as the `componentEnvironment`).
#[derive(Debug, Default)]
pub struct Recorder(Mutex<Vec<LogEntry>>);

impl Recorder {
    /// Record one message (what an importer's logger callback does with it).
    pub fn push(&self, status: i32, category: String, message: String) {
        if let Ok(mut v) = self.0.lock() {
            v.push(LogEntry {
                status,
                category,
                message,
            });
        }
    }
}

impl Recorder {
    /// Every message so far.
    pub fn entries(&self) -> Vec<LogEntry> {
        self.0.lock().map(|v| v.clone()).unwrap_or_default()
    }
    /// Forget the messages so far.
    pub fn clear(&self) {
        if let Ok(mut v) = self.0.lock() {
            v.clear()
        }
    }
    /// Number of messages so far.
    pub fn len(&self) -> usize {
        self.0.lock().map(|v| v.len()).unwrap_or(0)
    }
    /// Whether nothing was logged.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Messages with at least this status.
    pub fn at_least(&self, status: impl Into<i32>) -> Vec<String> {
        let status: i32 = status.into();
        self.entries()
            .into_iter()
            .filter(|e| e.status >= status)
            .map(|e| e.message)
            .collect()
    }
    /// Whether a message with at least `status` contains `needle`.
    pub fn has(&self, status: impl Into<i32>, needle: &str) -> bool {
        self.at_least(status).iter().any(|m| m.contains(needle))
    }
}
