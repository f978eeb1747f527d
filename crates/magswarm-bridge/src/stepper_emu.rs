//! An emulated TMCL stepper module on a pseudo-terminal pair: the bridge opens the slave
//! path like a serial device; the emulator answers on the master side.

use std::os::fd::{AsFd, AsRawFd, OwnedFd};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
use nix::pty::openpty;
use nix::sys::termios;

use crate::stepper::{axis, cmd, request, Reply};

/// The emulated module could not be started.
#[derive(Debug, thiserror::Error)]
pub enum PtyError {
    /// A pseudo-terminal call failed.
    #[error("{call}: {source}")]
    Call {
        /// The call.
        call: &'static str,
        /// Its error.
        source: nix::Error,
    },
    /// The serving thread could not be started.
    #[error("starting the emulator's thread: {0}")]
    Thread(std::io::Error),
}

/// How the emulated module misbehaves, if at all.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepperFault {
    /// Replies with status 2 (invalid command).
    Status,
    /// Replies with a wrong checksum.
    Checksum,
    /// Stops answering.
    Silent,
}

/// Emulated module settings.
#[derive(Debug, Clone, Copy)]
pub struct StepperSimConfig {
    /// Module address.
    pub address: u8,
    /// Host (reply) address.
    pub reply_address: u8,
    /// Acceleration of the actual speed toward the target [velocity units/s].
    pub acceleration: f64,
    /// Misbehave this long after the first rotation command \[s\].
    pub fault_after_s: Option<f64>,
    /// How.
    pub fault: StepperFault,
}

impl Default for StepperSimConfig {
    fn default() -> Self {
        StepperSimConfig {
            address: 1,
            reply_address: 2,
            acceleration: 1e9,
            fault_after_s: None,
            fault: StepperFault::Status,
        }
    }
}

/// One instruction the module received.
#[derive(Debug, Clone, Copy)]
pub struct Received {
    /// When.
    pub at: Instant,
    /// Instruction.
    pub instruction: u8,
    /// Type.
    pub typ: u8,
    /// Value.
    pub value: i32,
}

#[derive(Default)]
struct State {
    target: f64,
    actual: f64,
    max_acc: Option<i32>,
    received: Vec<Received>,
    first_rotation: Option<Instant>,
}

/// A running emulated module.
pub struct StepperEmulator {
    /// The slave path to open as the serial device.
    pub path: String,
    state: Arc<Mutex<State>>,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
    _slave: OwnedFd,
}

impl StepperEmulator {
    /// Open a pty pair and serve.
    pub fn start(cfg: StepperSimConfig) -> Result<StepperEmulator, PtyError> {
        let err = |call: &'static str| move |source| PtyError::Call { call, source };
        let pty = openpty(None, None).map_err(err("openpty"))?;
        let mut t = termios::tcgetattr(pty.slave.as_fd()).map_err(err("tcgetattr"))?;
        termios::cfmakeraw(&mut t);
        termios::tcsetattr(pty.slave.as_fd(), termios::SetArg::TCSANOW, &t)
            .map_err(err("tcsetattr"))?;
        let mut tm = termios::tcgetattr(pty.master.as_fd()).map_err(err("tcgetattr"))?;
        termios::cfmakeraw(&mut tm);
        let _ = termios::tcsetattr(pty.master.as_fd(), termios::SetArg::TCSANOW, &tm);
        let path = nix::unistd::ttyname(pty.slave.as_fd())
            .map_err(err("ttyname"))?
            .to_string_lossy()
            .into_owned();
        let state = Arc::new(Mutex::new(State::default()));
        let stop = Arc::new(AtomicBool::new(false));
        let (st, sp) = (state.clone(), stop.clone());
        let master = pty.master;
        let thread = std::thread::Builder::new()
            .name("tmcl-emulator".into())
            .spawn(move || serve(master, cfg, st, sp))
            .map_err(PtyError::Thread)?;
        Ok(StepperEmulator {
            path,
            state,
            stop,
            thread: Some(thread),
            _slave: pty.slave,
        })
    }

    /// Instructions received so far.
    pub fn received(&self) -> Vec<Received> {
        self.state
            .lock()
            .map(|s| s.received.clone())
            .unwrap_or_default()
    }

    /// (target, actual) velocity [TMCL units].
    pub fn velocity(&self) -> (f64, f64) {
        self.state
            .lock()
            .map(|s| (s.target, s.actual))
            .unwrap_or((f64::NAN, f64::NAN))
    }

    /// The maximum acceleration set with SAP 5, if any.
    pub fn max_acceleration(&self) -> Option<i32> {
        self.state.lock().ok().and_then(|s| s.max_acc)
    }
}

impl Drop for StepperEmulator {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn serve(master: OwnedFd, cfg: StepperSimConfig, state: Arc<Mutex<State>>, stop: Arc<AtomicBool>) {
    let fd = master.as_raw_fd();
    let mut buf: Vec<u8> = Vec::new();
    let mut last = Instant::now();
    while !stop.load(Ordering::SeqCst) {
        let mut fds = [PollFd::new(master.as_fd(), PollFlags::POLLIN)];
        let ready = poll(&mut fds, PollTimeout::from(10u8)).unwrap_or(0);
        // Integrate the speed ramp.
        {
            let now = Instant::now();
            let dt = now.duration_since(last).as_secs_f64();
            last = now;
            if let Ok(mut s) = state.lock() {
                let dv = (s.target - s.actual).clamp(-cfg.acceleration * dt, cfg.acceleration * dt);
                s.actual += dv;
            }
        }
        if ready == 0 {
            continue;
        }
        let mut chunk = [0u8; 256];
        let n = match nix::unistd::read(&master, &mut chunk) {
            Ok(n) => n,
            Err(nix::errno::Errno::EAGAIN) | Err(nix::errno::Errno::EINTR) => continue,
            // EIO: no slave open right now (between bridge sessions).
            Err(_) => {
                std::thread::sleep(Duration::from_millis(10));
                continue;
            }
        };
        buf.extend_from_slice(&chunk[..n]);
        while buf.len() >= 9 {
            let f: [u8; 9] = buf[..9].try_into().unwrap();
            buf.drain(..9);
            let reply = handle(&f, &cfg, &state);
            if let Some(r) = reply {
                let _ = nix::unistd::write(&master, &r);
            }
        }
    }
    let _ = fd;
}

fn handle(f: &[u8; 9], cfg: &StepperSimConfig, state: &Arc<Mutex<State>>) -> Option<[u8; 9]> {
    let mut s = state.lock().ok()?;
    let (addr, ins, typ, _motor) = (f[0], f[1], f[2], f[3]);
    let value = i32::from_be_bytes([f[4], f[5], f[6], f[7]]);
    let mut rep = Reply {
        reply_address: cfg.reply_address,
        module_address: cfg.address,
        status: 100,
        instruction: ins,
        value: 0,
    };
    if addr != cfg.address {
        return None; // another module's frame
    }
    let faulty = match (s.first_rotation, cfg.fault_after_s) {
        (Some(t), Some(after)) => t.elapsed().as_secs_f64() >= after,
        _ => false,
    };
    if faulty {
        // The module still sees the instruction; its reply is what goes wrong.
        s.received.push(Received {
            at: Instant::now(),
            instruction: ins,
            typ,
            value,
        });
        match cfg.fault {
            StepperFault::Silent => return None,
            StepperFault::Status => {
                rep.status = 2;
                return Some(rep.encode());
            }
            StepperFault::Checksum => {
                let mut e = rep.encode();
                e[8] = e[8].wrapping_add(1);
                return Some(e);
            }
        }
    }
    if request(f[0], f[1], f[2], f[3], value)[8] != f[8] {
        rep.status = 1;
        return Some(rep.encode());
    }
    s.received.push(Received {
        at: Instant::now(),
        instruction: ins,
        typ,
        value,
    });
    match ins {
        cmd::ROR => {
            s.target = value as f64;
            s.first_rotation.get_or_insert(Instant::now());
        }
        cmd::ROL => {
            s.target = -(value as f64);
            s.first_rotation.get_or_insert(Instant::now());
        }
        cmd::MST => {
            s.target = 0.0;
            s.actual = 0.0;
        }
        cmd::SAP => match typ {
            axis::MAX_ACCELERATION => s.max_acc = Some(value),
            axis::TARGET_SPEED => s.target = value as f64,
            _ => rep.status = 3,
        },
        cmd::GAP => {
            rep.value = match typ {
                axis::TARGET_SPEED => s.target.round() as i32,
                axis::ACTUAL_SPEED => s.actual.round() as i32,
                axis::MAX_ACCELERATION => s.max_acc.unwrap_or(0),
                _ => {
                    rep.status = 3;
                    0
                }
            }
        }
        cmd::GET_FIRMWARE_VERSION => rep.value = (1160 << 16) | (1 << 8) | 44,
        _ => rep.status = 2,
    }
    Some(rep.encode())
}
