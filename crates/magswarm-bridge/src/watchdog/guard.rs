//! The watchdog's side of the link (the `magswarm-stepper-watchdog` program): open the module,
//! follow the bridge's messages, and stop the motor on end of file, on silence or on a signal.
//!
//! One thread: the link is polled with a timeout that is the nearest of the next speed poll,
//! the silence deadline and 50 ms (to see signal flags), so the end of the bridge is seen the
//! moment the kernel closes its socket, and the stop goes out as soon as any TMCL transaction
//! in flight has its reply (about 20 ms at 9600 baud).

use std::io::Read;
use std::os::fd::AsFd;
use std::os::unix::net::UnixStream;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
use nix::sys::socket::{send, MsgFlags};

use super::GuardSpec;
use crate::stepper::{self, Stepper, StepperError};

/// How the watchdog ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ended {
    /// The bridge said `bye` (a normal end): motor stopped.
    Bye,
    /// The bridge's end of the link closed without `bye` (killed, crashed): motor stopped.
    BridgeGone,
    /// `SIGTERM`, `SIGINT` or `SIGHUP`: motor stopped.
    Signal,
}

/// The fault name of a stepper error on the link (`err NAME TEXT`).
pub fn error_name(e: &StepperError) -> &'static str {
    match e {
        StepperError::Serial(_) => "serial_error",
        StepperError::BadReply(_) => "stepper_bad_reply",
        StepperError::Command(_) => "stepper_command",
        StepperError::Watchdog(_) => "stepper_watchdog",
    }
}

fn error_text(e: &StepperError) -> String {
    match e {
        StepperError::Serial(w)
        | StepperError::BadReply(w)
        | StepperError::Command(w)
        | StepperError::Watchdog(w) => w.replace('\n', " "),
    }
}

/// Write one line to the bridge. Never raises SIGPIPE (the bridge may be dead); a failure is
/// ignored: the watchdog's next read sees the end of the link and stops the motor.
pub fn say(link: &UnixStream, line: &str) {
    let mut b = line.replace('\n', " ").into_bytes();
    b.push(b'\n');
    let mut off = 0;
    while off < b.len() {
        match send(
            std::os::fd::AsRawFd::as_raw_fd(link),
            &b[off..],
            MsgFlags::MSG_NOSIGNAL,
        ) {
            Ok(n) => off += n,
            Err(nix::errno::Errno::EINTR) => {}
            Err(_) => return,
        }
    }
}

/// Open the module described by `spec`, stop it, announce it (`ready`), then [`serve`].
/// An error opening or preparing the module is sent as `err` and returned.
pub fn run(
    spec: &GuardSpec,
    link: &UnixStream,
    signal: &AtomicBool,
) -> Result<Ended, StepperError> {
    let prepared = (|| {
        let mut tm = stepper::open_serial(
            &spec.device,
            spec.baud,
            spec.address,
            spec.motor,
            spec.velocity_per_hz,
            spec.reply_timeout,
        )?;
        if let Some(a) = spec.max_acceleration {
            tm.set_max_acceleration(a)?;
        }
        tm.stop()?;
        let d = tm.describe()?;
        Ok((tm, d))
    })();
    let (mut tm, description) = match prepared {
        Ok(x) => x,
        Err(e) => {
            say(link, &format!("err {} {}", error_name(&e), error_text(&e)));
            return Err(e);
        }
    };
    say(link, &format!("ready {description}"));
    Ok(serve(&mut tm, spec, link, signal))
}

/// Follow the bridge on an opened module until the bridge says `bye`, its end of the link
/// closes, or `signal` is set; the motor is stopped in every case.
pub fn serve(
    dev: &mut dyn Stepper,
    spec: &GuardSpec,
    link: &UnixStream,
    signal: &AtomicBool,
) -> Ended {
    let mut buf: Vec<u8> = Vec::new();
    let mut last_msg = Instant::now();
    let mut want: Option<f64> = None;
    let mut sent: Option<f64> = None;
    let mut next_poll = Instant::now() + spec.poll;
    // Rotation refused after a silence or a stepper fault (the bridge must start anew).
    let mut refused = false;
    loop {
        if signal.load(Ordering::SeqCst) {
            let _ = dev.stop();
            return Ended::Signal;
        }
        let now = Instant::now();
        let mut wake = next_poll.min(now + Duration::from_millis(50));
        if !refused {
            wake = wake.min(last_msg + spec.silence_timeout);
        }
        let wait = wake.saturating_duration_since(now);
        let timeout = PollTimeout::try_from(wait).unwrap_or(PollTimeout::from(50u8));
        let mut fds = [PollFd::new(link.as_fd(), PollFlags::POLLIN)];
        let ready = match poll(&mut fds, timeout) {
            Ok(n) => n > 0,
            Err(nix::errno::Errno::EINTR) => continue,
            Err(_) => true, // let the read below decide
        };
        if ready {
            let mut chunk = [0u8; 512];
            match (&*link).read(&mut chunk) {
                Ok(0) => {
                    let _ = dev.stop();
                    return Ended::BridgeGone;
                }
                Ok(n) => buf.extend_from_slice(&chunk[..n]),
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {}
                Err(_) => {
                    let _ = dev.stop();
                    return Ended::BridgeGone;
                }
            }
            while let Some(i) = buf.iter().position(|&b| b == b'\n') {
                let line: Vec<u8> = buf.drain(..=i).collect();
                let line = String::from_utf8_lossy(&line);
                let line = line.trim();
                last_msg = Instant::now();
                if line == "bye" {
                    match dev.stop() {
                        Ok(()) => say(link, "stopped"),
                        Err(e) => say(link, &format!("err {} {}", error_name(&e), error_text(&e))),
                    }
                    return Ended::Bye;
                } else if let Some(f) = line.strip_prefix("hz ") {
                    match f.trim().parse::<f64>() {
                        Ok(f) if f.is_finite() => want = Some(f),
                        _ => {
                            // A bridge that sends garbage is not one to follow.
                            let _ = dev.stop();
                            refused = true;
                            say(
                                link,
                                &format!("err stepper_command frequency {f:?} is not a number"),
                            );
                        }
                    }
                }
                // "beat" and anything else: a sign of life only.
            }
        }
        if !refused && last_msg.elapsed() > spec.silence_timeout {
            let quiet = last_msg.elapsed();
            let r = dev.stop();
            refused = true;
            sent = None;
            say(link, &format!("silence {}", quiet.as_millis()));
            if let Err(e) = r {
                say(link, &format!("err {} {}", error_name(&e), error_text(&e)));
            }
            continue;
        }
        if refused {
            continue;
        }
        let r = match want {
            Some(f) if sent != Some(f) => dev.rotate_hz(f).map(|_| sent = Some(f)),
            _ if Instant::now() >= next_poll => {
                next_poll = Instant::now() + spec.poll;
                dev.actual_hz().map(|_| ())
            }
            _ => Ok(()),
        };
        if let Err(e) = r {
            say(link, &format!("err {} {}", error_name(&e), error_text(&e)));
            let _ = dev.stop();
            refused = true;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{BufRead, BufReader, Write};
    use std::sync::{Arc, Mutex};

    /// A stepper that records what it was asked.
    #[derive(Clone, Default)]
    struct Fake(Arc<Mutex<Vec<(Instant, String)>>>);

    impl Stepper for Fake {
        fn rotate_hz(&mut self, f: f64) -> Result<(), StepperError> {
            self.0
                .lock()
                .unwrap()
                .push((Instant::now(), format!("ror {f}")));
            Ok(())
        }
        fn stop(&mut self) -> Result<(), StepperError> {
            self.0.lock().unwrap().push((Instant::now(), "mst".into()));
            Ok(())
        }
        fn actual_hz(&mut self) -> Result<f64, StepperError> {
            Ok(0.0)
        }
        fn describe(&mut self) -> Result<String, StepperError> {
            Ok("fake".into())
        }
    }

    fn spec(silence_ms: u64) -> GuardSpec {
        GuardSpec {
            device: "fake".into(),
            baud: 9600,
            address: 1,
            motor: 0,
            velocity_per_hz: 1.0,
            max_acceleration: None,
            reply_timeout: Duration::from_millis(100),
            silence_timeout: Duration::from_millis(silence_ms),
            poll: Duration::from_millis(100),
        }
    }

    fn start(silence_ms: u64) -> (UnixStream, Fake, std::thread::JoinHandle<Ended>) {
        let (bridge, guard) = UnixStream::pair().unwrap();
        let fake = Fake::default();
        let mut dev = fake.clone();
        let h = std::thread::spawn(move || {
            serve(&mut dev, &spec(silence_ms), &guard, &AtomicBool::new(false))
        });
        (bridge, fake, h)
    }

    #[test]
    fn end_of_file_stops_the_motor() {
        let (mut bridge, fake, h) = start(10_000);
        bridge.write_all(b"hz 4.5\n").unwrap();
        std::thread::sleep(Duration::from_millis(50));
        let closed = Instant::now();
        drop(bridge);
        assert_eq!(h.join().unwrap(), Ended::BridgeGone);
        let log = fake.0.lock().unwrap().clone();
        assert_eq!(log[0].1, "ror 4.5");
        let (at, what) = log.last().unwrap();
        assert_eq!(what, "mst");
        assert!(*at >= closed);
    }

    #[test]
    fn silence_stops_the_motor_and_refuses_rotation() {
        let (mut bridge, fake, h) = start(100);
        bridge.write_all(b"hz 3\n").unwrap();
        let mut r = BufReader::new(bridge.try_clone().unwrap());
        let mut line = String::new();
        r.read_line(&mut line).unwrap();
        assert!(line.starts_with("silence "), "{line}");
        bridge.write_all(b"hz 5\nbye\n").unwrap();
        assert_eq!(h.join().unwrap(), Ended::Bye);
        let log: Vec<String> = fake.0.lock().unwrap().iter().map(|x| x.1.clone()).collect();
        assert_eq!(log, ["ror 3", "mst", "mst"]);
    }

    #[test]
    fn bye_answers_stopped() {
        let (mut bridge, fake, h) = start(10_000);
        bridge.write_all(b"beat\nhz 2\nbye\n").unwrap();
        let mut line = String::new();
        BufReader::new(bridge).read_line(&mut line).unwrap();
        assert_eq!(line, "stopped\n");
        assert_eq!(h.join().unwrap(), Ended::Bye);
        let log: Vec<String> = fake.0.lock().unwrap().iter().map(|x| x.1.clone()).collect();
        assert_eq!(log.last().unwrap(), "mst");
    }
}
