//! The camera side of the bridge: the sources of `magswarm_vision` (replay of a frame folder,
//! emulated camera, Aravis with that crate's feature) run on their own thread behind
//! [`Threaded`], so decoding or rendering never delays the control loop; each frame is
//! measured with `magswarm_vision` (threshold, largest component, second moments).
//!
//! The emulated camera films the swarm of a model plant driven by what the devices report:
//! the robot's measured tool z (RTDE `actual_TCP_pose`) and the stepper's frequency, so an
//! emulated run closes the loop through the emulated devices.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use magswarm_model::{Model, Plant};
pub use magswarm_vision::camera::{Camera, CameraError, Frame};
use magswarm_vision::emulated::{EmulatedCamera, EmulatorConfig, SwarmState};
use magswarm_vision::{GrayImage, Vision, VisionConfig};

/// A camera running on its own thread; frames are handed over through a short queue (a full
/// queue drops the newest frame, as a camera driver does when its consumer is late).
pub struct Threaded {
    rx: std::sync::mpsc::Receiver<Result<Frame, CameraError>>,
    stop: Arc<AtomicBool>,
    handle: Option<std::thread::JoinHandle<()>>,
    desc: String,
}

impl Threaded {
    /// Start `cam` with t_s = 0 at `t0`. `stop_after_s`: deliver nothing from that camera
    /// time on (an emulated camera that dies, for tests).
    pub fn spawn(
        mut cam: Box<dyn Camera>,
        t0: Instant,
        stop_after_s: Option<f64>,
    ) -> Result<Threaded, CameraError> {
        cam.start(t0)?;
        let desc = cam.describe();
        let (tx, rx) = std::sync::mpsc::sync_channel(4);
        let stop = Arc::new(AtomicBool::new(false));
        let st = stop.clone();
        let handle = std::thread::Builder::new()
            .name("camera".into())
            .spawn(move || {
                while !st.load(Ordering::SeqCst) {
                    match cam.next_frame(Duration::from_millis(20)) {
                        Ok(f) => {
                            if stop_after_s.is_some_and(|d| f.t_s >= d) {
                                // Dead camera: keep the thread, deliver nothing.
                                while !st.load(Ordering::SeqCst) {
                                    std::thread::sleep(Duration::from_millis(10));
                                }
                                return;
                            }
                            let _ = tx.try_send(Ok(f));
                        }
                        Err(CameraError::Timeout(_)) => {}
                        Err(e) => {
                            let end = !e.is_transient();
                            if tx.send(Err(e)).is_err() || end {
                                return;
                            }
                        }
                    }
                }
            })
            .map_err(|e| CameraError::Device(format!("spawning the camera thread: {e}")))?;
        Ok(Threaded {
            rx,
            stop,
            handle: Some(handle),
            desc,
        })
    }

    /// The next frame within `timeout` (`Ok(None)`: none yet). `arrived` is the handover.
    pub fn next(&mut self, timeout: Duration) -> Result<Option<Frame>, CameraError> {
        match self.rx.recv_timeout(timeout) {
            Ok(Ok(mut f)) => {
                f.arrived = Instant::now();
                Ok(Some(f))
            }
            Ok(Err(e)) => Err(e),
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => Ok(None),
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                Err(CameraError::Device("the camera thread ended".into()))
            }
        }
    }

    /// What the source is.
    pub fn describe(&self) -> &str {
        &self.desc
    }
}

impl Drop for Threaded {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        // Unblock a sender waiting on a full queue.
        while self.rx.try_recv().is_ok() {}
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}

/// What drives the emulated swarm: the inputs the devices report (z_m \[mm\], f \[Hz\]).
pub type InputProbe = Arc<dyn Fn() -> Option<(f64, f64)> + Send + Sync>;

/// The cell the loop writes the devices' inputs into.
pub type InputCell = Arc<Mutex<Option<(f64, f64)>>>;

/// Shared latest inputs, written by the loop and read by the emulated camera.
pub fn command_probe() -> (InputCell, InputProbe) {
    let cell: InputCell = Arc::new(Mutex::new(None));
    let c2 = cell.clone();
    (cell, Arc::new(move || c2.lock().ok().and_then(|g| *g)))
}

/// The emulated camera of the config: `magswarm_vision`'s camera filming a model plant that
/// starts at equilibrium at `start` (z_m \[mm\], f \[Hz\]) and follows `probe`.
#[allow(clippy::too_many_arguments)]
pub fn emulated(
    model: Model,
    start: (f64, f64),
    probe: InputProbe,
    fps: f64,
    width: usize,
    height: usize,
    mm_per_px: f64,
    noise: f64,
) -> Box<dyn Camera> {
    let mut plant = Plant::new(model, start.0 * 1e-3, magswarm_model::hz_to_rad_s(start.1));
    let mut last = start;
    let source = move |t: f64| {
        let (z, f) = probe().unwrap_or(last);
        // The model's envelope; the bridge's own clamps keep the rig inside it anyway.
        let (z, f) = (z.clamp(3.5, 23.5), f.clamp(1.0, 10.0));
        last = (z, f);
        let w = magswarm_model::hz_to_rad_s(f);
        let dt = t - plant.time();
        if dt > 0.0 {
            plant.set_inputs(z * 1e-3, w);
            if plant.step(dt).is_err() {
                // Keep the last state: the frame shows the swarm as it was.
                plant.set_time(t);
            }
        }
        // What a camera sees: the observed radii (formation mode, drift and camera bias of
        // the model applied), not the ODE state.
        let [r1_mm, r2_mm] = plant.observed_radii();
        SwarmState {
            r1_mm,
            r2_mm,
            omega_rad_s: w,
        }
    };
    let cfg = EmulatorConfig {
        width,
        height,
        mm_per_px,
        fps,
        realtime: true,
        noise_sigma: noise,
        ..EmulatorConfig::default()
    };
    Box::new(EmulatedCamera::new(cfg, source))
}

/// Radii of a frame \[mm\], or why not.
#[derive(Debug, Clone, PartialEq)]
pub struct Radii {
    /// r1 \[mm\] (the smaller).
    pub r1_mm: f64,
    /// r2 \[mm\].
    pub r2_mm: f64,
    /// Orientation \[deg\].
    pub angle_deg: f64,
    /// Centroid \[px\].
    pub cx_px: f64,
    /// Centroid \[px\].
    pub cy_px: f64,
    /// Why the frame is invalid.
    pub invalid: Option<String>,
}

/// A camera (or its measurement) that cannot be set up from the config.
#[derive(Debug, thiserror::Error)]
pub enum CameraSetupError {
    /// `[vision]` does not describe a vision configuration.
    #[error("[vision]: {0}")]
    Vision(#[from] toml::de::Error),
    /// A model file of the config (the emulated camera's).
    #[error(transparent)]
    Config(#[from] crate::config::ConfigError),
    /// A replay without a folder.
    #[error("[camera] dir: a replay needs a frame folder")]
    NoFolder,
    /// The camera (or the frame folder) cannot be opened.
    #[error("[camera] {0}")]
    Open(#[from] CameraError),
    /// A kind this build does not have.
    #[error(
        "[camera] kind {0:?}: not available in this build (\"aravis\" needs `--features aravis` and libaravis-dev)"
    )]
    Unavailable(String),
}

/// The `[vision]` table as the vision crate's config.
pub fn vision_config(vision: Option<&toml::Table>) -> Result<VisionConfig, CameraSetupError> {
    Ok(match vision {
        Some(t) => t.clone().try_into::<VisionConfig>()?,
        None => VisionConfig::default(),
    })
}

/// Measures frames (keeps the vision buffers between frames).
pub struct Measurer {
    vision: Vision,
    cfg: VisionConfig,
    mm_per_px: f64,
}

impl Measurer {
    /// A measurer with the `[vision]` table of the config (default: Otsu, dark swarm).
    pub fn new(vision: Option<&toml::Table>, mm_per_px: f64) -> Result<Measurer, CameraSetupError> {
        Ok(Measurer {
            vision: Vision::new(),
            cfg: vision_config(vision)?,
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

/// The camera the config describes (`[camera] kind`): replay, emulated (driven by `probe`,
/// starting at equilibrium at `start`), or Aravis (with the `aravis` feature).
pub fn from_config(
    cfg: &crate::config::RigConfig,
    start: (f64, f64),
    probe: InputProbe,
) -> Result<Box<dyn Camera>, CameraSetupError> {
    let c = &cfg.camera;
    match c.kind.as_str() {
        "replay" => {
            let dir = cfg.resolve(c.dir.as_ref().ok_or(CameraSetupError::NoFolder)?);
            Ok(Box::new(
                magswarm_vision::replay::ReplayCamera::open(&dir).map_err(CameraError::from)?,
            ))
        }
        "emulated" => {
            let model = cfg.model("camera.model", c.model.as_ref())?;
            Ok(emulated(
                model,
                start,
                probe,
                c.fps,
                c.width as usize,
                c.height as usize,
                c.mm_per_px,
                c.noise,
            ))
        }
        #[cfg(feature = "aravis")]
        "aravis" => {
            use magswarm_vision::aravis_camera::{AravisCamera, AravisConfig};
            let a = AravisConfig {
                device: c.device.clone(),
                exposure_us: c.exposure_us,
                fps: Some(c.fps),
                region: c.region,
                buffers: 8,
            };
            Ok(Box::new(AravisCamera::open(&a)?))
        }
        k => Err(CameraSetupError::Unavailable(k.to_string())),
    }
}
