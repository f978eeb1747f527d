//! `magswarm-bridge check`: probe each device and print what it found (moves nothing).

use std::time::{Duration, Instant};

use crate::camera::{self, Measurer};
use crate::config::RigConfig;
use crate::rtde::proto::{robot_mode, runtime_state, safety_mode};
use crate::rtde::RtdeClient;
use crate::stepper::{self, Stepper as _};
use crate::ur::Dashboard;

/// Why a probe failed (its text is the probe's detail).
#[derive(Debug, thiserror::Error)]
enum ProbeError {
    #[error(transparent)]
    Rtde(#[from] crate::rtde::RtdeError),
    #[error("{0}: safety_mode is not NORMAL (operator must clear it)")]
    NotNormal(String),
    #[error(transparent)]
    Setup(#[from] camera::CameraSetupError),
    #[error(transparent)]
    Camera(#[from] camera::CameraError),
    #[error("{desc}: no frame within {wait:.1} s")]
    NoFrame { desc: String, wait: f64 },
}

/// One probe's outcome.
#[derive(Debug, Clone)]
pub struct Probe {
    /// Device.
    pub device: &'static str,
    /// Fine.
    pub ok: bool,
    /// What was found.
    pub detail: String,
}

/// Probe the robot (RTDE, dashboard, secondary interface), the stepper and the camera.
pub fn check(cfg: &RigConfig) -> Vec<Probe> {
    let mut out = Vec::new();
    let r = &cfg.robot;
    let to = Duration::from_secs(2);
    // RTDE: handshake and one state. The input recipe is not set up (nothing is written).
    let rtde = (|| -> Result<String, ProbeError> {
        let link_probe = RtdeClient::connect(&r.host, r.rtde_port, to).and_then(|mut c| {
            c.negotiate_protocol_version()?;
            let v = c.controller_version()?;
            let rec = c.setup_outputs(r.frequency_hz.min(125.0), &crate::rtde::client::OUTPUTS)?;
            c.start()?;
            let vals = c.receive(&rec)?;
            let _ = c.pause();
            Ok((v, vals))
        })?;
        let (v, vals) = link_probe;
        let pose = match vals[1] {
            crate::rtde::proto::Value::V6(p) => p,
            _ => [f64::NAN; 6],
        };
        let (rm, sm, rs) = (
            vals[2].as_f64().unwrap_or(f64::NAN) as i32,
            vals[3].as_f64().unwrap_or(f64::NAN) as i32,
            vals[4].as_f64().unwrap_or(f64::NAN) as u32,
        );
        let detail = format!(
            "controller {v}, tool z {:.4} m (z_m {:.2} mm), robot_mode {}, safety_mode {}, runtime_state {}",
            pose[2],
            (pose[2] - r.z_tcp_at_zero_m) * 1e3,
            robot_mode::name(rm),
            safety_mode::name(sm),
            runtime_state::name(rs)
        );
        if sm != safety_mode::NORMAL {
            return Err(ProbeError::NotNormal(detail));
        }
        Ok(detail)
    })();
    out.push(match rtde {
        Ok(d) => Probe {
            device: "robot rtde",
            ok: true,
            detail: format!("{}:{}: {d}", r.host, r.rtde_port),
        },
        Err(e) => Probe {
            device: "robot rtde",
            ok: false,
            detail: e.to_string(),
        },
    });
    if r.dashboard_port != 0 {
        out.push(
            match Dashboard::connect(&r.host, r.dashboard_port, to).and_then(|mut d| {
                let m = d.robot_mode()?;
                let s = d.safety_status()?;
                Ok(format!("{} | robotmode {m} | safetystatus {s}", d.greeting))
            }) {
                Ok(d) => Probe {
                    device: "robot dashboard",
                    ok: true,
                    detail: format!("{}:{}: {d}", r.host, r.dashboard_port),
                },
                Err(e) => Probe {
                    device: "robot dashboard",
                    ok: false,
                    detail: e.to_string(),
                },
            },
        );
    }
    if r.script_port != 0 {
        // Only a connection: no program is sent by check.
        let addr = format!("{}:{}", r.host, r.script_port);
        let res = std::net::ToSocketAddrs::to_socket_addrs(&addr)
            .map_err(|e| e.to_string())
            .and_then(|mut a| a.next().ok_or_else(|| "no address".to_string()))
            .and_then(|a| std::net::TcpStream::connect_timeout(&a, to).map_err(|e| e.to_string()));
        out.push(Probe {
            device: "robot secondary",
            ok: res.is_ok(),
            detail: match res {
                Ok(_) => format!("{addr}: accepts connections (the servo program is sent by run)"),
                Err(e) => format!("{addr}: {e}"),
            },
        });
    }
    // Stepper: firmware and actual speed (no motion).
    let s = &cfg.stepper;
    out.push(
        match stepper::open_serial(
            &s.device,
            s.baud,
            s.module_address,
            s.motor,
            s.velocity_per_hz,
            Duration::from_secs_f64(s.reply_timeout_s),
        )
        .and_then(|mut t| t.describe())
        {
            Ok(d) => Probe {
                device: "stepper",
                ok: true,
                detail: format!("{} at {} baud: {d}", s.device, s.baud),
            },
            Err(e) => Probe {
                device: "stepper",
                ok: false,
                detail: format!("{}: {e}", s.device),
            },
        },
    );
    // Camera: one frame, measured.
    let c = &cfg.camera;
    let cam = (|| -> Result<String, ProbeError> {
        let t0 = Instant::now();
        let src = camera::from_config(cfg, (8.5, 4.0), std::sync::Arc::new(|| None))?;
        let mut src = camera::Threaded::spawn(src, t0, None)?;
        let desc = src.describe().to_string();
        let wait = c.timeout_s.max(1.0);
        let deadline = Instant::now() + Duration::from_secs_f64(wait);
        loop {
            match src.next(Duration::from_millis(50))? {
                Some(f) => {
                    let mut m = Measurer::new(cfg.vision.as_ref(), c.mm_per_px)?;
                    let r = m.measure(&f.image);
                    let what = match r.invalid {
                        None => format!("r1 {:.2} mm, r2 {:.2} mm", r.r1_mm, r.r2_mm),
                        Some(w) => format!("no valid swarm: {w}"),
                    };
                    return Ok(format!(
                        "{desc}: first frame {}x{} (t_s {}): {what}",
                        f.image.width(),
                        f.image.height(),
                        f.t_s
                    ));
                }
                None if Instant::now() > deadline => {
                    return Err(ProbeError::NoFrame { desc, wait })
                }
                None => {}
            }
        }
    })();
    out.push(match cam {
        Ok(d) => Probe {
            device: "camera",
            ok: true,
            detail: d,
        },
        Err(e) => Probe {
            device: "camera",
            ok: false,
            detail: e.to_string(),
        },
    });
    out
}
