//! The camera interface the bridge reads frames through, whatever the source.

use crate::folder::FolderError;
use crate::image::GrayImage;
use std::time::{Duration, Instant};

/// One frame as delivered by a source.
#[derive(Clone, Debug)]
pub struct Frame {
    /// 0-based count of frames delivered by this source (errors included).
    pub seq: u64,
    /// The source's timestamp: seconds from the start of the stream ([`Camera::start`]).
    pub t_s: f64,
    /// Host time at which the frame was handed over (for latency measurements).
    pub arrived: Instant,
    pub image: GrayImage,
    /// Replay: the file name in the frame folder.
    pub name: Option<String>,
}

/// Why no frame was delivered.
#[derive(Debug, thiserror::Error)]
pub enum CameraError {
    /// No frame within the timeout; the stream may go on.
    #[error("camera timeout: no frame within {0:?}")]
    Timeout(Duration),
    /// A replayed recording has delivered all its frames.
    #[error("end of recording: all {frames} frames of {dir} delivered")]
    EndOfStream { dir: String, frames: usize },
    /// One frame was lost (file missing, cannot be decoded, incomplete buffer); the stream goes
    /// on with the next frame.
    #[error("frame {seq} (t_s = {t_s}) lost: {reason}")]
    FrameLost { seq: u64, t_s: f64, reason: String },
    /// A replay folder that cannot be read (index missing or malformed).
    #[error("{0}")]
    Folder(#[from] FolderError),
    /// The device failed (opening, configuring, streaming).
    #[error("camera: {0}")]
    Device(String),
}

impl CameraError {
    /// True when later calls may deliver frames again (timeout, a lost frame).
    pub fn is_transient(&self) -> bool {
        matches!(
            self,
            CameraError::Timeout(_) | CameraError::FrameLost { .. }
        )
    }
}

/// A source of timestamped 8-bit grayscale frames.
pub trait Camera: Send {
    /// Sets t_s = 0 of the stream to `t0` (the start of the run). Without it the first
    /// [`Camera::next_frame`] starts the clock.
    fn start(&mut self, t0: Instant) -> Result<(), CameraError>;

    /// The next frame, waiting at most `timeout` for it.
    fn next_frame(&mut self, timeout: Duration) -> Result<Frame, CameraError>;

    /// One line saying what this source is (for `magswarm-bridge check`).
    fn describe(&self) -> String;
}

impl<C: Camera + ?Sized> Camera for Box<C> {
    fn start(&mut self, t0: Instant) -> Result<(), CameraError> {
        (**self).start(t0)
    }
    fn next_frame(&mut self, timeout: Duration) -> Result<Frame, CameraError> {
        (**self).next_frame(timeout)
    }
    fn describe(&self) -> String {
        (**self).describe()
    }
}

/// Sleeps until `when` (no-op if it has passed).
pub(crate) fn sleep_until(when: Instant) {
    let now = Instant::now();
    if when > now {
        std::thread::sleep(when - now);
    }
}
