//! The camera seam of the bridge: a frame source (replay of a frame folder, or an emulated
//! camera rendering a virtual swarm) and the measurement of each frame with
//! `magswarm_vision` (threshold, largest component, second moments).
//!
//! The emulated camera renders the swarm of a model plant driven by what the devices report:
//! the robot's measured tool z (RTDE `actual_TCP_pose`) and the stepper's frequency, so an
//! emulated run closes the loop through the emulated devices.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use magswarm_model::{Model, Plant};
use magswarm_vision::folder;
use magswarm_vision::synth::{ellipse_frame, EllipseSpec};
use magswarm_vision::{GrayImage, Vision, VisionConfig};

/// One frame.
pub struct Frame {
    /// Camera time since the start of the run [s].
    pub t_s: f64,
    /// When the bridge received it.
    pub arrived: Instant,
    /// The image.
    pub image: GrayImage,
    /// Its file name (replay) or a generated name.
    pub name: String,
}

/// A camera.
pub trait FrameSource: Send {
    /// The next frame, waiting at most `timeout`; `Ok(None)` when none arrived in time;
    /// `Err` when the source failed or ended (`Ended`).
    fn next_frame(&mut self, timeout: Duration) -> Result<Option<Frame>, CameraError>;
    /// A line describing the source.
    fn describe(&self) -> String;
}

/// Camera errors.
#[derive(Debug, thiserror::Error)]
pub enum CameraError {
    /// A replay ran out of frames.
    #[error("the frame folder has no more frames")]
    Ended,
    /// Anything else.
    #[error("{0}")]
    Failed(String),
}

/// Replays a frame folder at the `t_s` of its index, from the start of the run.
pub struct Replay {
    dir: PathBuf,
    entries: Vec<folder::IndexEntry>,
    next: usize,
    t0: Instant,
}

impl Replay {
    /// Open a folder (reads `index.csv`; frames are decoded when due).
    pub fn open(dir: &Path, t0: Instant) -> Result<Replay, CameraError> {
        let entries = folder::read_index(dir)
            .map_err(|e| CameraError::Failed(format!("frame folder {}: {e}", dir.display())))?;
        Ok(Replay {
            dir: dir.into(),
            entries,
            next: 0,
            t0,
        })
    }
}

impl FrameSource for Replay {
    fn next_frame(&mut self, timeout: Duration) -> Result<Option<Frame>, CameraError> {
        let Some(e) = self.entries.get(self.next) else {
            return Err(CameraError::Ended);
        };
        let due = self.t0 + Duration::from_secs_f64(e.t_s.max(0.0));
        let now = Instant::now();
        if due > now + timeout {
            std::thread::sleep(timeout);
            return Ok(None);
        }
        if due > now {
            std::thread::sleep(due - now);
        }
        let path = self.dir.join(&e.file);
        let image = folder::read_png(&path)
            .map_err(|err| CameraError::Failed(format!("{}: {err}", path.display())))?;
        self.next += 1;
        Ok(Some(Frame {
            t_s: e.t_s,
            arrived: Instant::now(),
            image,
            name: e.file.clone(),
        }))
    }

    fn describe(&self) -> String {
        format!(
            "replay of {} ({} frames)",
            self.dir.display(),
            self.entries.len()
        )
    }
}

/// What drives the emulated swarm: the inputs the devices report (z_m [mm], f [Hz]).
pub type InputProbe = Arc<dyn Fn() -> Option<(f64, f64)> + Send + Sync>;

/// An emulated camera: a model plant under the devices' inputs, imaged as a dark filled
/// ellipse (with blur and noise) on a light background. Frames are rendered on the camera's
/// own thread and delivered through a queue, as a real camera's driver would.
pub struct Emulated {
    rx: std::sync::mpsc::Receiver<Result<Frame, String>>,
    stop: Arc<std::sync::atomic::AtomicBool>,
    handle: Option<std::thread::JoinHandle<()>>,
    desc: String,
}

struct Renderer {
    plant: Plant,
    probe: InputProbe,
    fps: f64,
    width: usize,
    height: usize,
    mm_per_px: f64,
    noise: f64,
    t0: Instant,
    die_after_s: Option<f64>,
    last_inputs: (f64, f64),
}

impl Renderer {
    fn frame(&mut self, n: u64) -> Result<Frame, String> {
        let t = n as f64 / self.fps;
        // Advance the swarm to t under the inputs in force, then image it.
        let (z, f) = (self.probe)().unwrap_or(self.last_inputs);
        let (z, f) = (z.clamp(3.5, 23.5), f.clamp(1.0, 10.0));
        self.last_inputs = (z, f);
        let dt = t - self.plant.time();
        if dt > 0.0 {
            self.plant
                .set_inputs(z * 1e-3, magswarm_model::hz_to_rad_s(f));
            self.plant
                .step(dt)
                .map_err(|e| format!("emulated swarm: {e}"))?;
        }
        let r = self.plant.state();
        let spec = EllipseSpec {
            cx: self.width as f64 / 2.0,
            cy: self.height as f64 / 2.0,
            r1: r[0] / self.mm_per_px,
            r2: r[1] / self.mm_per_px,
            angle_deg: 0.0,
            swarm: 40,
            background: 200,
            blur_sigma_px: 1.0,
            noise_sigma: self.noise,
        };
        let image = ellipse_frame(self.width, self.height, &spec, n);
        Ok(Frame {
            t_s: t,
            arrived: Instant::now(),
            image,
            name: format!("frame_{n:06}.png"),
        })
    }
}

impl Emulated {
    /// A camera at `fps` whose swarm starts at equilibrium at `start` (z_m [mm], f [Hz]);
    /// `die_after_s`: stop delivering frames after that camera time (a camera that dies).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        model: Model,
        start: (f64, f64),
        probe: InputProbe,
        fps: f64,
        width: usize,
        height: usize,
        mm_per_px: f64,
        noise: f64,
        t0: Instant,
        die_after_s: Option<f64>,
    ) -> Emulated {
        let plant = Plant::new(model, start.0 * 1e-3, magswarm_model::hz_to_rad_s(start.1));
        let mut r = Renderer {
            plant,
            probe,
            fps,
            width,
            height,
            mm_per_px,
            noise,
            t0,
            die_after_s,
            last_inputs: start,
        };
        let desc = format!(
            "emulated camera {width}x{height} at {fps} fps, {mm_per_px} mm/px (virtual swarm of the model)"
        );
        let (tx, rx) = std::sync::mpsc::sync_channel(4);
        let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
        let st = stop.clone();
        let handle = std::thread::Builder::new()
            .name("emulated-camera".into())
            .spawn(move || {
                let mut n = 0u64;
                while !st.load(std::sync::atomic::Ordering::SeqCst) {
                    let t = n as f64 / r.fps;
                    if r.die_after_s.is_some_and(|d| t >= d) {
                        std::thread::sleep(Duration::from_millis(10));
                        continue;
                    }
                    let due = r.t0 + Duration::from_secs_f64(t);
                    let now = Instant::now();
                    if due > now {
                        std::thread::sleep((due - now).min(Duration::from_millis(20)));
                        continue;
                    }
                    let f = r.frame(n);
                    n += 1;
                    let failed = f.is_err();
                    // A full queue drops the frame (the consumer is late), like a camera.
                    let _ = tx.try_send(f);
                    if failed {
                        return;
                    }
                }
            })
            .expect("spawn the emulated camera");
        Emulated {
            rx,
            stop,
            handle: Some(handle),
            desc,
        }
    }
}

impl Drop for Emulated {
    fn drop(&mut self) {
        self.stop.store(true, std::sync::atomic::Ordering::SeqCst);
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}

impl FrameSource for Emulated {
    fn next_frame(&mut self, timeout: Duration) -> Result<Option<Frame>, CameraError> {
        match self.rx.recv_timeout(timeout) {
            Ok(Ok(mut f)) => {
                f.arrived = Instant::now();
                Ok(Some(f))
            }
            Ok(Err(e)) => Err(CameraError::Failed(e)),
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => Ok(None),
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                Err(CameraError::Failed("the emulated camera stopped".into()))
            }
        }
    }

    fn describe(&self) -> String {
        self.desc.clone()
    }
}

/// Radii of a frame [mm], or why not.
#[derive(Debug, Clone, PartialEq)]
pub struct Radii {
    /// r1 [mm] (the smaller).
    pub r1_mm: f64,
    /// r2 [mm].
    pub r2_mm: f64,
    /// Orientation [deg].
    pub angle_deg: f64,
    /// Centroid [px].
    pub cx_px: f64,
    /// Centroid [px].
    pub cy_px: f64,
    /// Why the frame is invalid.
    pub invalid: Option<String>,
}

/// Measures frames (keeps the vision buffers between frames).
pub struct Measurer {
    vision: Vision,
    cfg: VisionConfig,
    mm_per_px: f64,
}

impl Measurer {
    /// A measurer with the `[vision]` table of the config (default: Otsu, dark swarm).
    pub fn new(vision: Option<&toml::Table>, mm_per_px: f64) -> Result<Measurer, String> {
        let cfg = match vision {
            Some(t) => t
                .clone()
                .try_into::<VisionConfig>()
                .map_err(|e| format!("[vision]: {e}"))?,
            None => VisionConfig::default(),
        };
        Ok(Measurer {
            vision: Vision::new(),
            cfg,
            mm_per_px,
        })
    }

    /// Measure one image.
    pub fn measure(&mut self, img: &GrayImage) -> Radii {
        let m = self.vision.measure(img.view(), &self.cfg);
        Radii {
            r1_mm: m.r1_px * self.mm_per_px,
            r2_mm: m.r2_px * self.mm_per_px,
            angle_deg: m.angle_deg,
            cx_px: m.cx_px,
            cy_px: m.cy_px,
            invalid: m.invalid.map(|i| i.to_string()),
        }
    }
}

/// Shared latest inputs, written by the loop and read by an emulated camera in dry runs.
pub fn command_probe() -> (Arc<Mutex<Option<(f64, f64)>>>, InputProbe) {
    let cell: Arc<Mutex<Option<(f64, f64)>>> = Arc::new(Mutex::new(None));
    let c2 = cell.clone();
    (cell, Arc::new(move || c2.lock().ok().and_then(|g| *g)))
}
