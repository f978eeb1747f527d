//! GenICam cameras (USB3 Vision and GigE Vision) through the Aravis library (`aravis` feature;
//! needs `libaravis-dev` at build time and `libaravis-0.8-0` at run time).
//!
//! The camera is set to Mono8 and continuous acquisition; `buffers` frame buffers are queued on
//! the stream. A frame's t_s is the arrival time of the first frame relative to the start of the
//! run plus the camera's own timestamp deltas after it (the device clock, when it has one).

use crate::camera::{Camera, CameraError, Frame};
use crate::image::GrayImage;
use aravis::prelude::*;
use aravis::{AcquisitionMode, Buffer, BufferStatus, PixelFormat, Stream};
use std::time::{Duration, Instant};

/// The Aravis bindings, for callers that need more of the library (e.g. the fake cameras).
pub use aravis;

/// Makes Aravis' in-process fake camera (device id `Fake_1`, Mono8 test pattern) visible to
/// [`AravisCamera::open`]: a camera without hardware, for tests and demos.
pub fn enable_fake_interface() {
    // SAFETY: arv_enable_interface takes a NUL-terminated interface name and only flips a flag in
    // the library's interface table.
    unsafe { aravis_sys::arv_enable_interface(c"Fake".as_ptr()) }
}

/// How to open and set up the camera (`[camera]` keys for `kind = "aravis"`: `device`,
/// `exposure_us`, `fps`, `region = [x, y, w, h]`, `buffers`; other keys of the table are left to
/// the caller).
#[derive(Clone, Debug, PartialEq, Default, serde::Deserialize)]
#[serde(default)]
pub struct AravisConfig {
    /// Aravis device id, serial number or (GigE) IP address; the first camera found when `None`.
    pub device: Option<String>,
    /// Exposure time in microseconds (camera default when `None`).
    pub exposure_us: Option<f64>,
    /// Acquisition frame rate in frames per second (camera default when `None`).
    pub fps: Option<f64>,
    /// Sensor region `[x, y, w, h]` in pixels (full sensor when `None`).
    pub region: Option<[i32; 4]>,
    /// Frame buffers queued on the stream (default 8).
    pub buffers: usize,
}

fn dev_err(what: &str) -> impl FnOnce(aravis::glib::Error) -> CameraError + '_ {
    move |e| CameraError::Device(format!("aravis: {what}: {e}"))
}

/// Device ids of the cameras Aravis finds (USB3 Vision, GigE Vision on the local networks).
pub fn list_devices() -> Vec<String> {
    // SAFETY: the device list is global state of the library; it is only read here, and the
    // bridge enumerates from one thread.
    unsafe { aravis::get_device_list() }
        .into_iter()
        .map(|d| {
            format!(
                "{} ({} {}, {} at {})",
                d.id.to_string_lossy(),
                d.vendor.to_string_lossy(),
                d.model.to_string_lossy(),
                d.protocol.to_string_lossy(),
                d.address.to_string_lossy()
            )
        })
        .collect()
}

pub struct AravisCamera {
    camera: aravis::Camera,
    stream: Stream,
    payload: usize,
    description: String,
    t0: Option<Instant>,
    /// (device timestamp ns, t_s) of the first frame
    first: Option<(u64, f64)>,
    seq: u64,
}

// SAFETY: the Aravis camera and stream objects are owned by this struct alone and used only
// through `&mut self`, so from one thread at a time; GObject reference counting is atomic and
// the stream's own receiving thread is internal to Aravis.
unsafe impl Send for AravisCamera {}

impl AravisCamera {
    /// Opens and starts the camera.
    pub fn open(cfg: &AravisConfig) -> Result<Self, CameraError> {
        let camera = aravis::Camera::new(cfg.device.as_deref()).map_err(|e| {
            CameraError::Device(format!(
                "aravis: cannot open camera {}: {e} (cameras found: {:?})",
                cfg.device.as_deref().unwrap_or("(first found)"),
                list_devices()
            ))
        })?;
        camera
            .set_pixel_format(PixelFormat::MONO_8)
            .map_err(dev_err("set pixel format Mono8"))?;
        if let Some([x, y, w, h]) = cfg.region {
            camera
                .set_region(x, y, w, h)
                .map_err(dev_err("set region"))?;
        }
        if let Some(us) = cfg.exposure_us {
            camera
                .set_exposure_time(us)
                .map_err(dev_err("set exposure time"))?;
        }
        if let Some(fps) = cfg.fps {
            // (arv_camera_set_frame_rate also switches AcquisitionFrameRateEnable on where the
            // camera has it)
            camera
                .set_frame_rate(fps)
                .map_err(dev_err("set frame rate"))?;
        }
        camera
            .set_acquisition_mode(AcquisitionMode::Continuous)
            .map_err(dev_err("set continuous acquisition"))?;
        let payload = camera.payload().map_err(dev_err("read payload size"))? as usize;
        let stream = camera.create_stream().map_err(dev_err("create stream"))?;
        for _ in 0..cfg.buffers.max(2) {
            stream.push_buffer(Buffer::new_allocate(payload));
        }
        let vendor = camera
            .vendor_name()
            .map(|s| s.to_string())
            .unwrap_or_default();
        let model = camera
            .model_name()
            .map(|s| s.to_string())
            .unwrap_or_default();
        let id = camera
            .device_id()
            .map(|s| s.to_string())
            .unwrap_or_default();
        let (x, y, w, h) = camera.region().unwrap_or((0, 0, 0, 0));
        let description = format!(
            "aravis camera: {vendor} {model} (id {id}), region {w}x{h}+{x}+{y}, Mono8, payload {payload} B"
        );
        camera
            .start_acquisition()
            .map_err(dev_err("start acquisition"))?;
        Ok(AravisCamera {
            camera,
            stream,
            payload,
            description,
            t0: None,
            first: None,
            seq: 0,
        })
    }

    fn to_image(&self, buf: &Buffer) -> Result<GrayImage, String> {
        let w = buf.image_width().max(0) as usize;
        let h = buf.image_height().max(0) as usize;
        let fmt = buf.image_pixel_format();
        if fmt != PixelFormat::MONO_8 {
            return Err(format!("pixel format {fmt:?}, expected Mono8"));
        }
        let (ptr, len) = buf.data();
        if ptr.is_null() || w == 0 || h == 0 || len < w * h {
            return Err(format!("buffer of {len} B for a {w}x{h} image"));
        }
        // SAFETY: Aravis owns `len` readable bytes at `ptr` while `buf` is alive (it is, here).
        let data = unsafe { std::slice::from_raw_parts(ptr as *const u8, len) };
        // rows may be padded: spread the spare bytes evenly over the rows
        let stride = if h > 1 { (len / h).max(w) } else { w };
        let stride = if (h - 1) * stride + w <= len {
            stride
        } else {
            w
        };
        let mut out = Vec::with_capacity(w * h);
        for y in 0..h {
            out.extend_from_slice(&data[y * stride..y * stride + w]);
        }
        GrayImage::from_vec(w, h, out).ok_or_else(|| "image size mismatch".to_string())
    }
}

impl Camera for AravisCamera {
    fn start(&mut self, t0: Instant) -> Result<(), CameraError> {
        self.t0 = Some(t0);
        Ok(())
    }

    fn next_frame(&mut self, timeout: Duration) -> Result<Frame, CameraError> {
        let t0 = *self.t0.get_or_insert_with(Instant::now);
        let us = timeout.as_micros().min(u64::MAX as u128) as u64;
        let Some(buf) = self.stream.timeout_pop_buffer(us) else {
            return Err(CameraError::Timeout(timeout));
        };
        let arrived = Instant::now();
        let seq = self.seq;
        self.seq += 1;
        let status = buf.status();
        let result = if status != BufferStatus::Success {
            Err(format!("buffer status {status:?}"))
        } else {
            self.to_image(&buf)
        };
        let ts = buf.timestamp();
        let arrival_s = arrived.duration_since(t0).as_secs_f64();
        let t_s = match self.first {
            Some((ts0, t_first)) if ts > ts0 => t_first + (ts - ts0) as f64 * 1e-9,
            Some(_) => arrival_s,
            None => {
                self.first = Some((ts, arrival_s));
                arrival_s
            }
        };
        // give the buffer back to the stream for the next frames
        if buf.data().1 >= self.payload {
            self.stream.push_buffer(buf);
        } else {
            self.stream.push_buffer(Buffer::new_allocate(self.payload));
        }
        match result {
            Ok(image) => Ok(Frame {
                seq,
                t_s,
                arrived,
                image,
                name: None,
            }),
            Err(reason) => Err(CameraError::FrameLost { seq, t_s, reason }),
        }
    }

    fn describe(&self) -> String {
        self.description.clone()
    }
}

impl Drop for AravisCamera {
    fn drop(&mut self) {
        let _ = self.camera.stop_acquisition();
    }
}
