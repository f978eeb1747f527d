//! Dashboard client (port 29999) and the URScript servo program sent to the secondary
//! interface (port 30002).

use std::io::{BufRead, BufReader, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::time::Duration;

/// A dashboard server connection (one command per line, one reply line each).
pub struct Dashboard {
    stream: TcpStream,
    reader: BufReader<TcpStream>,
    /// The server's greeting.
    pub greeting: String,
    addr: String,
}

impl Dashboard {
    /// Connect and read the greeting.
    pub fn connect(host: &str, port: u16, timeout: Duration) -> Result<Dashboard, String> {
        let addr = format!("{host}:{port}");
        let sa = addr
            .to_socket_addrs()
            .map_err(|e| format!("dashboard {addr}: {e}"))?
            .next()
            .ok_or_else(|| format!("dashboard {addr}: no address"))?;
        let stream = TcpStream::connect_timeout(&sa, timeout)
            .map_err(|e| format!("dashboard {addr}: connecting: {e}"))?;
        stream
            .set_read_timeout(Some(timeout))
            .map_err(|e| format!("dashboard {addr}: {e}"))?;
        let mut reader = BufReader::new(
            stream
                .try_clone()
                .map_err(|e| format!("dashboard {addr}: {e}"))?,
        );
        let mut greeting = String::new();
        reader
            .read_line(&mut greeting)
            .map_err(|e| format!("dashboard {addr}: reading the greeting: {e}"))?;
        Ok(Dashboard {
            stream,
            reader,
            greeting: greeting.trim().to_string(),
            addr,
        })
    }

    /// Send one command and return the reply line.
    pub fn command(&mut self, cmd: &str) -> Result<String, String> {
        // The bridge never unlocks a protective stop: that is the operator's decision.
        if cmd.trim() == "unlock protective stop" {
            return Err("the bridge does not unlock protective stops (operator only)".into());
        }
        self.stream
            .write_all(format!("{cmd}\n").as_bytes())
            .map_err(|e| format!("dashboard {}: sending {cmd:?}: {e}", self.addr))?;
        let mut line = String::new();
        self.reader
            .read_line(&mut line)
            .map_err(|e| format!("dashboard {}: reply to {cmd:?}: {e}", self.addr))?;
        if line.is_empty() {
            return Err(format!("dashboard {}: closed on {cmd:?}", self.addr));
        }
        Ok(line.trim().to_string())
    }

    /// `robotmode` -> the mode's name.
    pub fn robot_mode(&mut self) -> Result<String, String> {
        let r = self.command("robotmode")?;
        Ok(r.trim_start_matches("Robotmode:").trim().to_string())
    }

    /// `safetystatus` -> the status's name.
    pub fn safety_status(&mut self) -> Result<String, String> {
        let r = self.command("safetystatus")?;
        Ok(r.trim_start_matches("Safetystatus:").trim().to_string())
    }

    /// Power on and release the brakes if needed, waiting up to `timeout` for RUNNING.
    pub fn bring_up(&mut self, timeout: Duration) -> Result<(), String> {
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
                return Err(format!(
                    "dashboard {}: robot not RUNNING after {:.1} s (robot mode {mode})",
                    self.addr,
                    timeout.as_secs_f64()
                ));
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

/// Parameters of the servo program.
#[derive(Debug, Clone, Copy)]
pub struct ServoScript {
    /// Tool z limits \[m\] (base frame): `z_tcp_at_zero_m + z_m` limits.
    pub z_min_m: f64,
    /// Upper limit \[m\].
    pub z_max_m: f64,
    /// Rate limit [m/s].
    pub z_rate_m_s: f64,
    /// Watchdog frequency on the heartbeat register \[Hz\].
    pub watchdog_hz: f64,
}

impl ServoScript {
    /// The URScript program: waits for the first heartbeat, then servoes the tool's z to
    /// `input_double_register_24`, clamped to the limits and rate limited; the RTDE watchdog
    /// stops it when `input_int_register_24` is not updated within 1/watchdog_hz.
    pub fn program(&self) -> String {
        format!(
            r#"def magswarm_servo():
  # magswarm-bridge servo program: tool z follows input_double_register_24.
  magswarm_z_min = {zmin:.6}
  magswarm_z_max = {zmax:.6}
  magswarm_z_rate = {rate:.6}
  rtde_set_watchdog("input_int_register_24", {wd:.3}, "stop")
  textmsg("magswarm_servo: z in [", magswarm_z_min)
  dt = get_steptime()
  p0 = get_actual_tcp_pose()
  z = p0[2]
  # Hold until the bridge has sent a first heartbeat (and with it a target).
  while read_input_integer_register(24) == 0:
    servoj(get_inverse_kin(p0), 0, 0, dt, 0.1, 300)
  end
  while True:
    target = read_input_float_register(24)
    if target < magswarm_z_min:
      target = magswarm_z_min
    end
    if target > magswarm_z_max:
      target = magswarm_z_max
    end
    step = target - z
    if step > magswarm_z_rate * dt:
      step = magswarm_z_rate * dt
    end
    if step < -magswarm_z_rate * dt:
      step = -magswarm_z_rate * dt
    end
    z = z + step
    p = p[p0[0], p0[1], z, p0[3], p0[4], p0[5]]
    servoj(get_inverse_kin(p), 0, 0, dt, 0.1, 300)
  end
end
"#,
            zmin = self.z_min_m,
            zmax = self.z_max_m,
            rate = self.z_rate_m_s,
            wd = self.watchdog_hz,
        )
    }
}

/// Send a program to the secondary interface.
pub fn upload_script(
    host: &str,
    port: u16,
    program: &str,
    timeout: Duration,
) -> Result<(), String> {
    let addr = format!("{host}:{port}");
    let sa = addr
        .to_socket_addrs()
        .map_err(|e| format!("secondary interface {addr}: {e}"))?
        .next()
        .ok_or_else(|| format!("secondary interface {addr}: no address"))?;
    let mut s = TcpStream::connect_timeout(&sa, timeout)
        .map_err(|e| format!("secondary interface {addr}: connecting: {e}"))?;
    s.write_all(program.as_bytes())
        .and_then(|_| s.write_all(b"\n"))
        .map_err(|e| format!("secondary interface {addr}: sending the program: {e}"))?;
    let _ = s.shutdown(std::net::Shutdown::Write);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn program_clamps_and_sets_the_watchdog() {
        let p = ServoScript {
            z_min_m: 0.4035,
            z_max_m: 0.4235,
            z_rate_m_s: 0.01,
            watchdog_hz: 10.0,
        }
        .program();
        assert!(p.starts_with("def magswarm_servo():"));
        assert!(p.trim_end().ends_with("end"));
        assert!(p.contains("magswarm_z_min = 0.403500"));
        assert!(p.contains("magswarm_z_max = 0.423500"));
        assert!(p.contains("rtde_set_watchdog(\"input_int_register_24\", 10.000, \"stop\")"));
        assert!(p.contains("read_input_float_register(24)"));
        // Balanced blocks: every def/while/if has its end.
        let opens = p
            .lines()
            .filter(|l| {
                let t = l.trim_start();
                t.starts_with("def ") || t.starts_with("while ") || t.starts_with("if ")
            })
            .count();
        let ends = p.lines().filter(|l| l.trim() == "end").count();
        assert_eq!(opens, ends);
    }
}
