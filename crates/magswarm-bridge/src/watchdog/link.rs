//! The bridge's side of the link: [`StepperGuard`] starts the watchdog program, hands it the
//! frequency and the heartbeat, and reports what it says. A slow serial line (a TMCL
//! transaction takes about 20 ms at 9600 baud) never delays the control loop: `rotate_hz`
//! returns at once, errors come back later through `take_error`, `stop` stops the motor and
//! ends the watchdog.

use std::io::{BufRead, BufReader};
use std::os::fd::OwnedFd;
use std::os::unix::net::UnixStream;
use std::os::unix::process::CommandExt;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use super::guard::say;
use super::GuardSpec;
use crate::stepper::{self, Stepper as _, StepperError};

/// Heartbeats closer than this are not sent (the loop polls every few ms).
const BEAT_EVERY: Duration = Duration::from_millis(20);

enum Event {
    Ready(String),
    Stopped,
    Error,
    Closed,
}

/// A running stepper watchdog (see [`crate::watchdog`]).
pub struct StepperGuard {
    child: Option<Child>,
    link: UnixStream,
    error: Arc<Mutex<Option<StepperError>>>,
    events: Receiver<Event>,
    reader: Option<std::thread::JoinHandle<()>>,
    spec: GuardSpec,
    last_beat: Instant,
    ended: bool,
    /// What the module said it is (firmware, address).
    pub description: String,
}

fn parse_err(rest: &str) -> StepperError {
    let (name, text) = rest.split_once(' ').unwrap_or((rest, ""));
    let text = text.to_string();
    match name {
        "serial_error" => StepperError::Serial(text),
        "stepper_bad_reply" => StepperError::BadReply(text),
        "stepper_command" => StepperError::Command(text),
        _ => StepperError::Watchdog(format!("{name}: {text}")),
    }
}

impl StepperGuard {
    /// Start the watchdog program `exe` for the module of `spec` and wait until it has opened
    /// and stopped the module. `stderr`: where the watchdog's own messages go (the bridge's
    /// terminal; nowhere inside an FMU).
    pub fn spawn(
        exe: &Path,
        spec: &GuardSpec,
        stderr: Stdio,
    ) -> Result<StepperGuard, StepperError> {
        let werr = |w: String| StepperError::Watchdog(w);
        // Both ends are close-on-exec: only the watchdog (as its stdin) and this process hold
        // them, so the watchdog sees end of file exactly when this process is gone.
        let (ours, theirs) =
            UnixStream::pair().map_err(|e| werr(format!("creating the link: {e}")))?;
        let child = {
            let mut cmd = Command::new(exe);
            cmd.args(spec.to_args())
                .stdin(Stdio::from(OwnedFd::from(theirs)))
                .stdout(Stdio::null())
                .stderr(stderr)
                // Its own process group: a Ctrl-C at the terminal reaches the bridge only,
                // which then stops the motor in order.
                .process_group(0);
            cmd.spawn()
                .map_err(|e| werr(format!("starting {}: {e}", exe.display())))?
            // `cmd` (and with it our copy of the watchdog's end) is dropped here.
        };
        let error = Arc::new(Mutex::new(None::<StepperError>));
        let (tx, events) = std::sync::mpsc::channel();
        let reader_link = ours
            .try_clone()
            .map_err(|e| werr(format!("cloning the link: {e}")))?;
        let err2 = error.clone();
        let reader = std::thread::Builder::new()
            .name("stepper-watchdog-link".into())
            .spawn(move || {
                let set = |e: StepperError| {
                    if let Ok(mut g) = err2.lock() {
                        g.get_or_insert(e);
                    }
                };
                for line in BufReader::new(reader_link).lines() {
                    let Ok(line) = line else { break };
                    let (word, rest) = line.split_once(' ').unwrap_or((line.as_str(), ""));
                    let ev = match word {
                        "ready" => Event::Ready(rest.to_string()),
                        "stopped" => Event::Stopped,
                        "err" => {
                            set(parse_err(rest));
                            Event::Error
                        }
                        "silence" => {
                            set(StepperError::Watchdog(format!(
                                "the bridge sent nothing for {rest} ms: the watchdog stopped the motor"
                            )));
                            Event::Error
                        }
                        _ => continue,
                    };
                    let _ = tx.send(ev);
                }
                let _ = tx.send(Event::Closed);
            })
            .map_err(|e| werr(format!("spawning the link reader: {e}")))?;
        let mut g = StepperGuard {
            child: Some(child),
            link: ours,
            error,
            events,
            reader: Some(reader),
            spec: spec.clone(),
            last_beat: Instant::now(),
            ended: false,
            description: String::new(),
        };
        // Opening, SAP, MST, firmware and speed: a few transactions.
        let limit = Duration::from_secs(3) + spec.reply_timeout * 8;
        match g.events.recv_timeout(limit) {
            Ok(Event::Ready(d)) => {
                g.description = d;
                g.last_beat = Instant::now();
                Ok(g)
            }
            Ok(_) | Err(RecvTimeoutError::Disconnected) => {
                let e = g.take_error();
                g.ended = true;
                g.reap(Duration::from_secs(1));
                Err(e.unwrap_or_else(|| {
                    werr(format!(
                        "{} ended before the module was ready",
                        exe.display()
                    ))
                }))
            }
            Err(RecvTimeoutError::Timeout) => {
                g.ended = true;
                g.reap(Duration::ZERO);
                Err(werr(format!(
                    "{} did not report the module ready within {:.1} s",
                    exe.display(),
                    limit.as_secs_f64()
                )))
            }
        }
    }

    /// The watchdog's process id.
    pub fn pid(&self) -> Option<u32> {
        self.child.as_ref().map(Child::id)
    }

    fn send(&mut self, line: &str) {
        if self.ended {
            return;
        }
        say(&self.link, line);
        self.last_beat = Instant::now();
    }

    /// Ask for a frequency \[Hz\] (returns at once; the watchdog sends ROR).
    pub fn rotate_hz(&mut self, f_hz: f64) {
        self.send(&format!("hz {f_hz:?}"));
    }

    /// A heartbeat, unless one went out in the last 20 ms.
    pub fn beat(&mut self) {
        if self.last_beat.elapsed() >= BEAT_EVERY {
            self.send("beat");
        }
    }

    /// The first error the watchdog reported (taken: reported once), or its unexpected end.
    pub fn take_error(&mut self) -> Option<StepperError> {
        if let Some(e) = self.error.lock().ok().and_then(|mut g| g.take()) {
            return Some(e);
        }
        if !self.ended {
            if let Some(st) = self
                .child
                .as_mut()
                .and_then(|c| c.try_wait().ok().flatten())
            {
                self.ended = true;
                return Some(StepperError::Watchdog(format!(
                    "the watchdog process ended ({st}); the motor may still turn"
                )));
            }
        }
        None
    }

    fn reap(&mut self, grace: Duration) {
        if let Some(mut c) = self.child.take() {
            let t0 = Instant::now();
            loop {
                match c.try_wait() {
                    Ok(Some(_)) => break,
                    Ok(None) if t0.elapsed() < grace => {
                        std::thread::sleep(Duration::from_millis(2))
                    }
                    _ => {
                        let _ = c.kill();
                        let _ = c.wait();
                        break;
                    }
                }
            }
        }
        let _ = self.link.shutdown(std::net::Shutdown::Both);
        if let Some(h) = self.reader.take() {
            let _ = h.join();
        }
    }

    /// Stop the motor (MST) and end the watchdog. When the watchdog cannot confirm the stop
    /// (it died), the serial line is opened here and MST sent directly.
    pub fn stop(&mut self) -> Result<(), StepperError> {
        if self.ended && self.child.is_none() {
            return Ok(());
        }
        let was_running = !self.ended;
        self.send("bye");
        self.ended = true;
        let mut confirmed = false;
        if was_running {
            let limit = Duration::from_millis(500) + self.spec.reply_timeout * 3;
            let t0 = Instant::now();
            while let Some(left) = limit.checked_sub(t0.elapsed()) {
                match self.events.recv_timeout(left) {
                    Ok(Event::Stopped) => {
                        confirmed = true;
                        break;
                    }
                    Ok(Event::Closed) | Err(_) => break,
                    Ok(_) => {}
                }
            }
        }
        self.reap(Duration::from_secs(1));
        if confirmed {
            return Ok(());
        }
        // The watchdog is gone without confirming: send the stop ourselves.
        let s = &self.spec;
        stepper::open_serial(
            &s.device,
            s.baud,
            s.address,
            s.motor,
            s.velocity_per_hz,
            s.reply_timeout,
        )
        .and_then(|mut t| t.stop())
    }
}

impl Drop for StepperGuard {
    fn drop(&mut self) {
        let _ = self.stop();
    }
}
