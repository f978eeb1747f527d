//! The URScript servo program and its upload to the secondary interface (port 30002).

use std::io::Write;
use std::net::TcpStream;
use std::time::Duration;

use super::{connect, UrError};

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
    /// Standard digital output (0..=7) that enables the stepper driver: set high once the
    /// bridge heartbeats; PolyScope drops it when the program stops if the output's action
    /// is "Low when not running" (docs/bridge.md, wiring).
    pub enable_output: Option<u8>,
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
{enable}  while True:
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
            enable = match self.enable_output {
                Some(n) => format!(
                    "  # Stepper driver enable: low again whenever this program is not running.\n  set_standard_digital_out({n}, True)\n"
                ),
                None => String::new(),
            },
        )
    }
}

/// Send a program to the secondary interface.
pub fn upload_script(
    host: &str,
    port: u16,
    program: &str,
    timeout: Duration,
) -> Result<(), UrError> {
    let (mut s, addr): (TcpStream, String) = connect("secondary interface", host, port, timeout)?;
    s.write_all(program.as_bytes())
        .and_then(|_| s.write_all(b"\n"))
        .map_err(|e| UrError::Io {
            what: format!("secondary interface {addr}: sending the program"),
            source: e,
        })?;
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
            enable_output: Some(3),
        }
        .program();
        assert!(p.starts_with("def magswarm_servo():"));
        assert!(p.trim_end().ends_with("end"));
        assert!(p.contains("magswarm_z_min = 0.403500"));
        assert!(p.contains("magswarm_z_max = 0.423500"));
        assert!(p.contains("rtde_set_watchdog(\"input_int_register_24\", 10.000, \"stop\")"));
        assert!(p.contains("read_input_float_register(24)"));
        assert!(p.contains("  set_standard_digital_out(3, True)\n"));
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
