//! The magnet's stepper: a driver trait and its TMCL implementation (Trinamic modules over a
//! serial line: 9-byte frames with a checksum, replies with a status code).

use std::io::{Read, Write};
use std::time::Duration;

/// TMCL instruction numbers.
pub mod cmd {
    /// Rotate right at a velocity.
    pub const ROR: u8 = 1;
    /// Rotate left.
    pub const ROL: u8 = 2;
    /// Motor stop.
    pub const MST: u8 = 3;
    /// Set axis parameter.
    pub const SAP: u8 = 5;
    /// Get axis parameter.
    pub const GAP: u8 = 6;
    /// Firmware version.
    pub const GET_FIRMWARE_VERSION: u8 = 136;
}

/// Axis parameters used here.
pub mod axis {
    /// Target (maximum) velocity.
    pub const TARGET_SPEED: u8 = 2;
    /// Actual velocity.
    pub const ACTUAL_SPEED: u8 = 3;
    /// Maximum acceleration.
    pub const MAX_ACCELERATION: u8 = 5;
}

/// Reply status codes.
pub mod status {
    /// Success.
    pub const OK: u8 = 100;
    /// Command loaded into EEPROM (stand-alone mode).
    pub const LOADED: u8 = 101;
    /// Meaning of a status code.
    pub fn name(s: u8) -> &'static str {
        match s {
            100 => "success",
            101 => "command loaded",
            1 => "wrong checksum",
            2 => "invalid command",
            3 => "wrong type",
            4 => "invalid value",
            5 => "configuration EEPROM locked",
            6 => "command not available",
            _ => "unknown status",
        }
    }
}

/// Checksum of a frame: the sum of the first 8 bytes modulo 256.
pub fn checksum(b: &[u8]) -> u8 {
    b[..8].iter().fold(0u8, |a, x| a.wrapping_add(*x))
}

/// A request frame: address, instruction, type, motor/bank, value (big-endian), checksum.
pub fn request(address: u8, instruction: u8, typ: u8, motor: u8, value: i32) -> [u8; 9] {
    let v = value.to_be_bytes();
    let mut f = [address, instruction, typ, motor, v[0], v[1], v[2], v[3], 0];
    f[8] = checksum(&f);
    f
}

/// A reply frame: reply address, module address, status, instruction, value, checksum.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Reply {
    /// Host (reply) address.
    pub reply_address: u8,
    /// Module address.
    pub module_address: u8,
    /// Status code.
    pub status: u8,
    /// Instruction the reply answers.
    pub instruction: u8,
    /// Value.
    pub value: i32,
}

impl Reply {
    /// Encode (with checksum).
    pub fn encode(&self) -> [u8; 9] {
        let v = self.value.to_be_bytes();
        let mut f = [
            self.reply_address,
            self.module_address,
            self.status,
            self.instruction,
            v[0],
            v[1],
            v[2],
            v[3],
            0,
        ];
        f[8] = checksum(&f);
        f
    }

    /// Decode, checking the checksum.
    pub fn decode(f: &[u8; 9]) -> Result<Reply, StepperError> {
        if checksum(f) != f[8] {
            return Err(StepperError::BadReply(format!(
                "reply checksum {:#04x}, computed {:#04x} (frame {f:02x?})",
                f[8],
                checksum(f)
            )));
        }
        Ok(Reply {
            reply_address: f[0],
            module_address: f[1],
            status: f[2],
            instruction: f[3],
            value: i32::from_be_bytes([f[4], f[5], f[6], f[7]]),
        })
    }
}

/// Errors of a stepper driver.
#[derive(Debug, thiserror::Error)]
pub enum StepperError {
    /// The serial line failed (open, write, read, timeout).
    #[error("stepper serial error: {0}")]
    Serial(String),
    /// The module answered something wrong (checksum, status, other instruction).
    #[error("stepper bad reply: {0}")]
    BadReply(String),
    /// A command out of range.
    #[error("stepper command rejected: {0}")]
    Command(String),
    /// The stepper watchdog process is missing, died, or stopped the motor on silence.
    #[error("stepper watchdog: {0}")]
    Watchdog(String),
}

/// A driver that spins the magnet.
pub trait Stepper: Send {
    /// Rotate at `f_hz` magnet revolutions per second (0: stop).
    fn rotate_hz(&mut self, f_hz: f64) -> Result<(), StepperError>;
    /// Stop the motor.
    fn stop(&mut self) -> Result<(), StepperError>;
    /// Actual speed \[Hz\] as the driver reports it.
    fn actual_hz(&mut self) -> Result<f64, StepperError>;
    /// A line describing the device (firmware, address).
    fn describe(&mut self) -> Result<String, StepperError>;
}

/// TMCL over any byte stream (a serial port, a pty).
pub struct Tmcl<P: Read + Write + Send> {
    port: P,
    address: u8,
    motor: u8,
    velocity_per_hz: f64,
    last_velocity: Option<i32>,
    stopped: bool,
}

impl<P: Read + Write + Send> Tmcl<P> {
    /// Wrap a port. `velocity_per_hz`: TMCL velocity units per magnet revolution per second.
    pub fn new(port: P, address: u8, motor: u8, velocity_per_hz: f64) -> Tmcl<P> {
        Tmcl {
            port,
            address,
            motor,
            velocity_per_hz,
            last_velocity: None,
            stopped: true,
        }
    }

    /// Send one request and check the reply (checksum, status, instruction, address).
    pub fn transact(&mut self, instruction: u8, typ: u8, value: i32) -> Result<i32, StepperError> {
        let f = request(self.address, instruction, typ, self.motor, value);
        self.port
            .write_all(&f)
            .and_then(|_| self.port.flush())
            .map_err(|e| StepperError::Serial(format!("writing instruction {instruction}: {e}")))?;
        let mut r = [0u8; 9];
        self.port.read_exact(&mut r).map_err(|e| {
            StepperError::Serial(format!(
                "reading the reply to instruction {instruction}: {e}"
            ))
        })?;
        let rep = Reply::decode(&r)?;
        if rep.status != status::OK && rep.status != status::LOADED {
            return Err(StepperError::BadReply(format!(
                "instruction {instruction} type {typ} value {value}: status {} ({})",
                rep.status,
                status::name(rep.status)
            )));
        }
        if rep.instruction != instruction || rep.module_address != self.address {
            return Err(StepperError::BadReply(format!(
                "reply for instruction {} from module {}, expected instruction {instruction} from module {}",
                rep.instruction, rep.module_address, self.address
            )));
        }
        Ok(rep.value)
    }

    /// TMCL velocity of `f_hz` (`round(f_hz * velocity_per_hz)`).
    pub fn velocity(&self, f_hz: f64) -> Result<i32, StepperError> {
        if !f_hz.is_finite() {
            return Err(StepperError::Command(format!(
                "frequency {f_hz} Hz is not finite"
            )));
        }
        let v = (f_hz * self.velocity_per_hz).round();
        if v.abs() > i32::MAX as f64 {
            return Err(StepperError::Command(format!(
                "frequency {f_hz} Hz is {v} velocity units, beyond 32 bits"
            )));
        }
        Ok(v as i32)
    }

    /// Set the module's maximum acceleration (axis parameter 5).
    pub fn set_max_acceleration(&mut self, a: i32) -> Result<(), StepperError> {
        self.transact(cmd::SAP, axis::MAX_ACCELERATION, a)
            .map(|_| ())
    }
}

impl<P: Read + Write + Send> Stepper for Tmcl<P> {
    fn rotate_hz(&mut self, f_hz: f64) -> Result<(), StepperError> {
        let v = self.velocity(f_hz)?;
        if v == 0 {
            return self.stop();
        }
        if self.last_velocity == Some(v) && !self.stopped {
            return Ok(());
        }
        if v > 0 {
            self.transact(cmd::ROR, 0, v)?;
        } else {
            self.transact(cmd::ROL, 0, -v)?;
        }
        self.last_velocity = Some(v);
        self.stopped = false;
        Ok(())
    }

    fn stop(&mut self) -> Result<(), StepperError> {
        self.transact(cmd::MST, 0, 0)?;
        self.last_velocity = Some(0);
        self.stopped = true;
        Ok(())
    }

    fn actual_hz(&mut self) -> Result<f64, StepperError> {
        let v = self.transact(cmd::GAP, axis::ACTUAL_SPEED, 0)?;
        Ok(v as f64 / self.velocity_per_hz)
    }

    fn describe(&mut self) -> Result<String, StepperError> {
        let fw = self.transact(cmd::GET_FIRMWARE_VERSION, 1, 0)?;
        let speed = self.actual_hz()?;
        Ok(format!(
            "TMCL module {} motor {}: firmware {}.{} (type {}), actual speed {speed:.3} Hz",
            self.address,
            self.motor,
            (fw >> 8) & 0xff,
            fw & 0xff,
            (fw >> 16) & 0xffff
        ))
    }
}

impl<P: Read + Write + Send> Drop for Tmcl<P> {
    fn drop(&mut self) {
        // Stop on drop: a stepper never keeps spinning after its driver is gone.
        if !self.stopped {
            let _ = self.stop();
        }
    }
}

/// Open a TMCL module on a serial device.
pub fn open_serial(
    device: &str,
    baud: u32,
    address: u8,
    motor: u8,
    velocity_per_hz: f64,
    timeout: Duration,
) -> Result<Tmcl<Box<dyn serialport::SerialPort>>, StepperError> {
    let port = serialport::new(device, baud)
        .timeout(timeout)
        .open()
        .map_err(|e| StepperError::Serial(format!("opening {device} at {baud} baud: {e}")))?;
    let _ = port.clear(serialport::ClearBuffer::All);
    Ok(Tmcl::new(port, address, motor, velocity_per_hz))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_match_the_tmcl_layout() {
        // ROR motor 0 at 1000 on module 1: 01 01 00 00 00 00 03 E8, checksum 0xED.
        let f = request(1, cmd::ROR, 0, 0, 1000);
        assert_eq!(f, [1, 1, 0, 0, 0, 0, 0x03, 0xe8, 0xed]);
        let r = Reply {
            reply_address: 2,
            module_address: 1,
            status: 100,
            instruction: 1,
            value: 1000,
        };
        assert_eq!(Reply::decode(&r.encode()).unwrap(), r);
        let mut bad = r.encode();
        bad[8] ^= 1;
        assert!(matches!(
            Reply::decode(&bad),
            Err(StepperError::BadReply(_))
        ));
    }
}
