//! An independent TMCL module on a pseudo-terminal, for the tests: written from the TMCL
//! frame layout (9-byte request: address, instruction, type, motor, value big-endian,
//! checksum = sum of the first 8 bytes mod 256; 9-byte reply: reply address, module address,
//! status, instruction, value, checksum) without any of the bridge's TMCL code, so a mistake
//! shared by the bridge and its own emulator cannot hide here. It records every instruction
//! with the instant it was read.

use std::os::fd::{AsFd, OwnedFd};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
use nix::sys::termios;

/// TMCL instruction numbers used in the assertions.
pub const ROR: u8 = 1;
pub const MST: u8 = 3;

#[derive(Debug, Clone, Copy)]
pub struct Seen {
    pub at: Instant,
    pub instruction: u8,
    pub value: i32,
}

pub struct TmclPeer {
    /// The path to open as the serial device.
    pub path: String,
    seen: Arc<Mutex<Vec<Seen>>>,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
    _slave: OwnedFd,
}

fn sum8(b: &[u8]) -> u8 {
    (b.iter().take(8).map(|&x| x as u32).sum::<u32>() & 0xff) as u8
}

impl TmclPeer {
    pub fn start(address: u8) -> TmclPeer {
        let pty = nix::pty::openpty(None, None).expect("openpty");
        for fd in [pty.master.as_fd(), pty.slave.as_fd()] {
            let mut t = termios::tcgetattr(fd).expect("tcgetattr");
            termios::cfmakeraw(&mut t);
            termios::tcsetattr(fd, termios::SetArg::TCSANOW, &t).expect("tcsetattr");
        }
        let path = nix::unistd::ttyname(pty.slave.as_fd())
            .expect("ttyname")
            .to_string_lossy()
            .into_owned();
        let seen = Arc::new(Mutex::new(Vec::new()));
        let stop = Arc::new(AtomicBool::new(false));
        let (seen2, stop2, master) = (seen.clone(), stop.clone(), pty.master);
        let thread = std::thread::spawn(move || {
            let mut velocity: i32 = 0;
            let mut pending: Vec<u8> = Vec::new();
            while !stop2.load(Ordering::SeqCst) {
                let mut fds = [PollFd::new(master.as_fd(), PollFlags::POLLIN)];
                if poll(&mut fds, PollTimeout::from(5u8)).unwrap_or(0) == 0 {
                    continue;
                }
                let mut chunk = [0u8; 64];
                let n = match nix::unistd::read(&master, &mut chunk) {
                    Ok(n) => n,
                    Err(_) => {
                        // No one has the device open right now.
                        std::thread::sleep(Duration::from_millis(2));
                        continue;
                    }
                };
                let at = Instant::now();
                pending.extend_from_slice(&chunk[..n]);
                while pending.len() >= 9 {
                    let f: Vec<u8> = pending.drain(..9).collect();
                    if f[0] != address || sum8(&f) != f[8] {
                        continue;
                    }
                    let value = i32::from_be_bytes([f[4], f[5], f[6], f[7]]);
                    seen2.lock().unwrap().push(Seen {
                        at,
                        instruction: f[1],
                        value,
                    });
                    let answer = match f[1] {
                        ROR => {
                            velocity = value;
                            value
                        }
                        MST => {
                            velocity = 0;
                            0
                        }
                        6 => velocity,                      // GAP: actual speed
                        136 => (1160 << 16) | (1 << 8) | 9, // firmware version
                        _ => 0,
                    };
                    let mut r = [2u8, address, 100, f[1], 0, 0, 0, 0, 0];
                    r[4..8].copy_from_slice(&answer.to_be_bytes());
                    r[8] = sum8(&r);
                    let _ = nix::unistd::write(&master, &r);
                }
            }
        });
        TmclPeer {
            path,
            seen,
            stop,
            thread: Some(thread),
            _slave: pty.slave,
        }
    }

    pub fn seen(&self) -> Vec<Seen> {
        self.seen.lock().unwrap().clone()
    }

    /// The first instruction `instruction` read at or after `after`.
    pub fn first_after(&self, instruction: u8, after: Instant) -> Option<Seen> {
        self.seen()
            .into_iter()
            .find(|s| s.at >= after && s.instruction == instruction)
    }

    /// Wait up to `limit` for an instruction `instruction` at or after `after`.
    pub fn wait_for(&self, instruction: u8, after: Instant, limit: Duration) -> Option<Seen> {
        let t0 = Instant::now();
        loop {
            if let Some(s) = self.first_after(instruction, after) {
                return Some(s);
            }
            if t0.elapsed() > limit {
                return None;
            }
            std::thread::sleep(Duration::from_millis(2));
        }
    }
}

impl Drop for TmclPeer {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
