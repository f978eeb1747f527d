//! Replay source: a recorded frame folder delivered as a camera would, each frame at its `t_s`
//! from the start of the run (never earlier; late consumers get every frame, in order).
//! A background thread reads and decodes a few frames ahead, so decoding does not add latency.

use crate::camera::{sleep_until, Camera, CameraError, Frame};
use crate::folder::{read_index, read_png, FolderError, IndexEntry};
use crate::image::GrayImage;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{sync_channel, Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

/// Frames decoded ahead of time.
const READ_AHEAD: usize = 4;

type Decoded = Result<GrayImage, FolderError>;

pub struct ReplayCamera {
    dir: PathBuf,
    entries: Vec<IndexEntry>,
    rx: Receiver<Decoded>,
    next: usize,
    t0: Option<Instant>,
}

impl ReplayCamera {
    /// Opens `dir` (reads and checks `index.csv`; errors name the file and line).
    pub fn open(dir: &Path) -> Result<Self, FolderError> {
        let entries = read_index(dir)?;
        let (tx, rx) = sync_channel::<Decoded>(READ_AHEAD);
        let paths: Vec<PathBuf> = entries.iter().map(|e| dir.join(&e.file)).collect();
        std::thread::Builder::new()
            .name("replay-decode".into())
            .spawn(move || {
                for p in paths {
                    if tx.send(read_png(&p)).is_err() {
                        return; // camera dropped
                    }
                }
            })
            .map_err(|source| FolderError::Io {
                path: dir.to_path_buf(),
                source,
            })?;
        Ok(ReplayCamera {
            dir: dir.to_path_buf(),
            entries,
            rx,
            next: 0,
            t0: None,
        })
    }

    /// The frames listed in the index.
    pub fn entries(&self) -> &[IndexEntry] {
        &self.entries
    }

    /// Duration of the recording (t_s of the last frame).
    pub fn duration_s(&self) -> f64 {
        self.entries.last().map(|e| e.t_s).unwrap_or(0.0)
    }
}

impl Camera for ReplayCamera {
    fn start(&mut self, t0: Instant) -> Result<(), CameraError> {
        self.t0 = Some(t0);
        Ok(())
    }

    fn next_frame(&mut self, timeout: Duration) -> Result<Frame, CameraError> {
        let Some(entry) = self.entries.get(self.next) else {
            return Err(CameraError::EndOfStream {
                dir: self.dir.display().to_string(),
                frames: self.entries.len(),
            });
        };
        let now = Instant::now();
        let t0 = *self.t0.get_or_insert(now);
        let deadline = now + timeout;
        let due = t0 + Duration::from_secs_f64(entry.t_s);
        if due > deadline {
            sleep_until(deadline);
            return Err(CameraError::Timeout(timeout));
        }
        let wait = deadline.saturating_duration_since(Instant::now());
        let decoded = match self.rx.recv_timeout(wait) {
            Ok(d) => d,
            Err(RecvTimeoutError::Timeout) => return Err(CameraError::Timeout(timeout)),
            Err(RecvTimeoutError::Disconnected) => {
                return Err(CameraError::Device(format!(
                    "replay of {}: the decoding thread stopped",
                    self.dir.display()
                )))
            }
        };
        sleep_until(due);
        let seq = self.next as u64;
        self.next += 1;
        match decoded {
            Ok(image) => Ok(Frame {
                seq,
                t_s: entry.t_s,
                arrived: Instant::now(),
                image,
                name: Some(entry.file.clone()),
            }),
            Err(e) => Err(CameraError::FrameLost {
                seq,
                t_s: entry.t_s,
                reason: e.to_string(),
            }),
        }
    }

    fn describe(&self) -> String {
        format!(
            "replay camera: {} ({} frames over {:.3} s)",
            self.dir.display(),
            self.entries.len(),
            self.duration_s()
        )
    }
}
