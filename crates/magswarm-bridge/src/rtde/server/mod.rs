//! The emulated UR controller: RTDE server, dashboard server and secondary interface (script
//! upload), around one simulated robot whose tool z follows the commanded register with a lag.
//!
//! The emulated program does what the bridge's URScript does: it reads the target from
//! `input_double_register_24`, clamps it to the z limits and rate limit it finds in the
//! uploaded script (or the config's when no script is uploaded), and stops when the heartbeat
//! register is not updated within the watchdog period. Cues raise a protective stop or drop
//! the link at given times after the first RTDE start.

mod connection;
mod interfaces;
mod sim;

use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use super::proto::{runtime_state, safety_mode};
use connection::rtde_connection;
use interfaces::{dashboard_connection, script_connection};
use sim::Sim;
pub use sim::{RobotRecord, RobotSimConfig, WatchdogFiring};

/// A running emulated UR controller.
pub struct UrEmulator {
    sim: Arc<Mutex<Sim>>,
    stop: Arc<AtomicBool>,
    link_down: Arc<AtomicBool>,
    threads: Vec<std::thread::JoinHandle<()>>,
    /// RTDE address.
    pub rtde: SocketAddr,
    /// Dashboard address (None: not served).
    pub dashboard: Option<SocketAddr>,
    /// Secondary interface address (None: not served).
    pub secondary: Option<SocketAddr>,
}

impl UrEmulator {
    /// Bind and start serving. A port 0 picks a free port (see the returned addresses);
    /// `dashboard_port`/`script_port` `None` do not serve that interface.
    pub fn start(
        host: &str,
        rtde_port: u16,
        dashboard_port: Option<u16>,
        script_port: Option<u16>,
        cfg: RobotSimConfig,
    ) -> std::io::Result<UrEmulator> {
        let sim = Arc::new(Mutex::new(Sim::new(cfg)));
        let stop = Arc::new(AtomicBool::new(false));
        let link_down = Arc::new(AtomicBool::new(false));
        let mut threads = Vec::new();

        let rl = TcpListener::bind((host, rtde_port))?;
        let rtde = rl.local_addr()?;
        rl.set_nonblocking(true)?;
        {
            let (sim, stop, down) = (sim.clone(), stop.clone(), link_down.clone());
            threads.push(std::thread::spawn(move || {
                accept_loop(rl, stop.clone(), move |s| {
                    let (sim, stop, down) = (sim.clone(), stop.clone(), down.clone());
                    if down.load(Ordering::SeqCst) {
                        let _ = s.shutdown(Shutdown::Both);
                        return;
                    }
                    std::thread::spawn(move || rtde_connection(s, sim, stop, down));
                })
            }));
        }
        let dashboard = dashboard_port
            .map(|p| serve(host, p, &sim, &stop, &mut threads, dashboard_connection))
            .transpose()?;
        let secondary = script_port
            .map(|p| serve(host, p, &sim, &stop, &mut threads, script_connection))
            .transpose()?;
        {
            // Physics at 500 Hz, on the wall clock: each pass integrates the time that really
            // passed (in steps of at most 2 ms), so the robot moves at its rate and its lag
            // however late a loaded machine runs this thread.
            let (sim, stop, down) = (sim.clone(), stop.clone(), link_down.clone());
            threads.push(std::thread::spawn(move || {
                let dt = 0.002;
                let mut last = Instant::now();
                while !stop.load(Ordering::SeqCst) {
                    if let Ok(mut s) = sim.lock() {
                        let now = Instant::now();
                        let mut left = now.duration_since(last).as_secs_f64();
                        last = now;
                        while left > 0.0 {
                            let h = left.min(dt);
                            s.tick(h);
                            left -= h;
                        }
                        if let (Some(t), Some(d)) = (s.first_start, s.cfg.drop_link_after_s) {
                            if t.elapsed().as_secs_f64() >= d {
                                down.store(true, Ordering::SeqCst);
                            }
                        }
                    }
                    std::thread::sleep(Duration::from_secs_f64(dt));
                }
            }));
        }
        Ok(UrEmulator {
            sim,
            stop,
            link_down,
            threads,
            rtde,
            dashboard,
            secondary,
        })
    }

    /// What the robot saw so far.
    pub fn record(&self) -> RobotRecord {
        self.sim
            .lock()
            .map(|s| s.record.clone())
            .unwrap_or_default()
    }

    /// Current tool z \[m\].
    pub fn tool_z(&self) -> f64 {
        self.sim.lock().map(|s| s.pose[2]).unwrap_or(f64::NAN)
    }

    /// (robot_mode, safety_mode, runtime_state).
    pub fn modes(&self) -> (i32, i32, u32) {
        self.sim
            .lock()
            .map(|s| (s.robot_mode, s.safety_mode, s.runtime_state))
            .unwrap_or((0, 0, 0))
    }

    /// Raise a protective stop now.
    pub fn protective_stop(&self) {
        if let Ok(mut s) = self.sim.lock() {
            s.safety_mode = safety_mode::PROTECTIVE_STOP;
            if s.runtime_state == runtime_state::PLAYING {
                s.runtime_state = runtime_state::PAUSED;
            }
        }
    }

    /// The level of standard digital output `n` (0..=7): the servo program sets its stepper
    /// enable output high once the bridge heartbeats, and it drops whenever the program is
    /// not running (as PolyScope does with the output's action "Low when not running").
    pub fn digital_out(&self, n: u8) -> bool {
        self.sim
            .lock()
            .map(|s| s.digital_out.get(n as usize).copied().unwrap_or(false))
            .unwrap_or(false)
    }

    /// Drop every RTDE connection now and refuse new ones.
    pub fn drop_link(&self) {
        self.link_down.store(true, Ordering::SeqCst);
    }
}

impl Drop for UrEmulator {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

fn accept_loop(l: TcpListener, stop: Arc<AtomicBool>, mut on: impl FnMut(TcpStream)) {
    while !stop.load(Ordering::SeqCst) {
        match l.accept() {
            Ok((s, _)) => {
                let _ = s.set_nonblocking(false);
                let _ = s.set_nodelay(true);
                on(s)
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(5))
            }
            Err(_) => std::thread::sleep(Duration::from_millis(5)),
        }
    }
}

/// Listen on `host:port` and run `connection` on its own thread for every client (the
/// dashboard and the secondary interface); the accept loop joins `threads`.
fn serve(
    host: &str,
    port: u16,
    sim: &Arc<Mutex<Sim>>,
    stop: &Arc<AtomicBool>,
    threads: &mut Vec<std::thread::JoinHandle<()>>,
    connection: fn(TcpStream, Arc<Mutex<Sim>>),
) -> std::io::Result<SocketAddr> {
    let l = TcpListener::bind((host, port))?;
    let a = l.local_addr()?;
    l.set_nonblocking(true)?;
    let (sim, stop) = (sim.clone(), stop.clone());
    threads.push(std::thread::spawn(move || {
        accept_loop(l, stop, move |s| {
            let sim = sim.clone();
            std::thread::spawn(move || connection(s, sim));
        })
    }));
    Ok(a)
}
