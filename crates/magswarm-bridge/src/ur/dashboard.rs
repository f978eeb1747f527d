//! The dashboard server client (port 29999): one command per line, one reply line each.

use std::io::{BufRead, BufReader, Write};
use std::net::TcpStream;
use std::time::Duration;

use super::{connect, UrError};

/// A dashboard server connection.
pub struct Dashboard {
    stream: TcpStream,
    reader: BufReader<TcpStream>,
    /// The server's greeting.
    pub greeting: String,
    addr: String,
}

impl Dashboard {
    /// Connect and read the greeting.
    pub fn connect(host: &str, port: u16, timeout: Duration) -> Result<Dashboard, UrError> {
        let (stream, addr) = connect("dashboard", host, port, timeout)?;
        let io = |what: &str, e: std::io::Error| UrError::Io {
            what: format!("dashboard {addr}: {what}"),
            source: e,
        };
        stream
            .set_read_timeout(Some(timeout))
            .map_err(|e| io("setting the read timeout", e))?;
        let mut reader = BufReader::new(stream.try_clone().map_err(|e| io("cloning", e))?);
        let mut greeting = String::new();
        reader
            .read_line(&mut greeting)
            .map_err(|e| io("reading the greeting", e))?;
        Ok(Dashboard {
            stream,
            reader,
            greeting: greeting.trim().to_string(),
            addr,
        })
    }

    /// Send one command and return the reply line.
    pub fn command(&mut self, cmd: &str) -> Result<String, UrError> {
        // The bridge never unlocks a protective stop: that is the operator's decision.
        if cmd.trim() == "unlock protective stop" {
            return Err(UrError::Refused(
                "the bridge does not unlock protective stops (operator only)".into(),
            ));
        }
        let io = |what: String, e: std::io::Error| UrError::Io {
            what: format!("dashboard {}: {what}", self.addr),
            source: e,
        };
        self.stream
            .write_all(format!("{cmd}\n").as_bytes())
            .map_err(|e| io(format!("sending {cmd:?}"), e))?;
        let mut line = String::new();
        self.reader
            .read_line(&mut line)
            .map_err(|e| io(format!("reply to {cmd:?}"), e))?;
        if line.is_empty() {
            return Err(UrError::Closed {
                addr: self.addr.clone(),
                on: cmd.to_string(),
            });
        }
        Ok(line.trim().to_string())
    }

    /// `robotmode` -> the mode's name.
    pub fn robot_mode(&mut self) -> Result<String, UrError> {
        let r = self.command("robotmode")?;
        Ok(r.trim_start_matches("Robotmode:").trim().to_string())
    }

    /// `safetystatus` -> the status's name.
    pub fn safety_status(&mut self) -> Result<String, UrError> {
        let r = self.command("safetystatus")?;
        Ok(r.trim_start_matches("Safetystatus:").trim().to_string())
    }

    /// Power on and release the brakes if needed, waiting up to `timeout` for RUNNING.
    pub fn bring_up(&mut self, timeout: Duration) -> Result<(), UrError> {
        let t0 = std::time::Instant::now();
        loop {
            let mode = self.robot_mode()?;
            match mode.as_str() {
                "RUNNING" => return Ok(()),
                "POWER_OFF" => {
                    self.command("power on")?;
                }
                "IDLE" => {
                    self.command("brake release")?;
                }
                _ => {}
            }
            if t0.elapsed() > timeout {
                return Err(UrError::NotReady(format!(
                    "dashboard {}: robot not RUNNING after {:.1} s (robot mode {mode})",
                    self.addr,
                    timeout.as_secs_f64()
                )));
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}
