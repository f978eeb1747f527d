//! The RTDE wire format (Universal Robots Real-Time Data Exchange, protocol version 2).
//!
//! Every package is `uint16 size` (big-endian, header included), `uint8 type`, payload.
//! Values are big-endian. The package types and the variable table follow the controller's
//! documentation (as implemented by Universal_Robots_Client_Library and ur_rtde).

use std::io::{self, Read, Write};

/// The controller's RTDE port.
pub const RTDE_PORT: u16 = 30004;
/// The protocol version this crate speaks.
pub const PROTOCOL_VERSION: u16 = 2;

/// Package types (ASCII letters).
pub mod pkt {
    /// 'V': request protocol version (payload u16; reply u8 accepted).
    pub const REQUEST_PROTOCOL_VERSION: u8 = 86;
    /// 'v': get the controller version (reply 4 x u32: major, minor, bugfix, build).
    pub const GET_URCONTROL_VERSION: u8 = 118;
    /// 'M': text message.
    pub const TEXT_MESSAGE: u8 = 77;
    /// 'U': data package (u8 recipe id, values).
    pub const DATA_PACKAGE: u8 = 85;
    /// 'O': set up an output recipe (f64 frequency, names; reply u8 id, types).
    pub const SETUP_OUTPUTS: u8 = 79;
    /// 'I': set up an input recipe (names; reply u8 id, types).
    pub const SETUP_INPUTS: u8 = 73;
    /// 'S': start the data synchronisation (reply u8 accepted).
    pub const START: u8 = 83;
    /// 'P': pause the data synchronisation (reply u8 accepted).
    pub const PAUSE: u8 = 80;
}

/// Largest package (the size field is 16 bits).
pub const MAX_PACKAGE: usize = u16::MAX as usize;

/// Robot modes (`robot_mode`).
pub mod robot_mode {
    /// No controller.
    pub const NO_CONTROLLER: i32 = -1;
    /// Disconnected.
    pub const DISCONNECTED: i32 = 0;
    /// Confirm safety.
    pub const CONFIRM_SAFETY: i32 = 1;
    /// Booting.
    pub const BOOTING: i32 = 2;
    /// Power off.
    pub const POWER_OFF: i32 = 3;
    /// Power on.
    pub const POWER_ON: i32 = 4;
    /// Idle (powered, brakes engaged).
    pub const IDLE: i32 = 5;
    /// Backdrive.
    pub const BACKDRIVE: i32 = 6;
    /// Running (brakes released).
    pub const RUNNING: i32 = 7;
    /// Name of a robot mode.
    pub fn name(m: i32) -> &'static str {
        match m {
            -1 => "NO_CONTROLLER",
            0 => "DISCONNECTED",
            1 => "CONFIRM_SAFETY",
            2 => "BOOTING",
            3 => "POWER_OFF",
            4 => "POWER_ON",
            5 => "IDLE",
            6 => "BACKDRIVE",
            7 => "RUNNING",
            8 => "UPDATING_FIRMWARE",
            _ => "UNKNOWN",
        }
    }
}

/// Safety modes (`safety_mode`); anything but NORMAL is a fault for the bridge.
pub mod safety_mode {
    /// Normal.
    pub const NORMAL: i32 = 1;
    /// Reduced.
    pub const REDUCED: i32 = 2;
    /// Protective stop.
    pub const PROTECTIVE_STOP: i32 = 3;
    /// Name of a safety mode.
    pub fn name(m: i32) -> &'static str {
        match m {
            1 => "NORMAL",
            2 => "REDUCED",
            3 => "PROTECTIVE_STOP",
            4 => "RECOVERY",
            5 => "SAFEGUARD_STOP",
            6 => "SYSTEM_EMERGENCY_STOP",
            7 => "ROBOT_EMERGENCY_STOP",
            8 => "VIOLATION",
            9 => "FAULT",
            10 => "VALIDATE_JOINT_ID",
            11 => "UNDEFINED_SAFETY_MODE",
            12 => "AUTOMATIC_MODE_SAFEGUARD_STOP",
            13 => "SYSTEM_THREE_POSITION_ENABLING_STOP",
            _ => "UNKNOWN",
        }
    }
}

/// Program runtime states (`runtime_state`).
pub mod runtime_state {
    /// Stopping.
    pub const STOPPING: u32 = 0;
    /// Stopped.
    pub const STOPPED: u32 = 1;
    /// Playing.
    pub const PLAYING: u32 = 2;
    /// Pausing.
    pub const PAUSING: u32 = 3;
    /// Paused.
    pub const PAUSED: u32 = 4;
    /// Resuming.
    pub const RESUMING: u32 = 5;
    /// Name of a runtime state.
    pub fn name(s: u32) -> &'static str {
        match s {
            0 => "STOPPING",
            1 => "STOPPED",
            2 => "PLAYING",
            3 => "PAUSING",
            4 => "PAUSED",
            5 => "RESUMING",
            _ => "UNKNOWN",
        }
    }
}

/// Types of RTDE variables, with the names the controller uses in recipe replies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VarType {
    /// BOOL (1 byte).
    Bool,
    /// UINT8.
    Uint8,
    /// UINT32.
    Uint32,
    /// UINT64.
    Uint64,
    /// INT32.
    Int32,
    /// DOUBLE.
    Double,
    /// VECTOR3D.
    Vector3d,
    /// VECTOR6D.
    Vector6d,
    /// VECTOR6INT32.
    Vector6Int32,
    /// VECTOR6UINT32.
    Vector6Uint32,
}

impl VarType {
    /// The controller's name of the type.
    pub fn name(self) -> &'static str {
        match self {
            VarType::Bool => "BOOL",
            VarType::Uint8 => "UINT8",
            VarType::Uint32 => "UINT32",
            VarType::Uint64 => "UINT64",
            VarType::Int32 => "INT32",
            VarType::Double => "DOUBLE",
            VarType::Vector3d => "VECTOR3D",
            VarType::Vector6d => "VECTOR6D",
            VarType::Vector6Int32 => "VECTOR6INT32",
            VarType::Vector6Uint32 => "VECTOR6UINT32",
        }
    }

    /// Parse the controller's name of a type.
    pub fn parse(s: &str) -> Option<VarType> {
        Some(match s {
            "BOOL" => VarType::Bool,
            "UINT8" => VarType::Uint8,
            "UINT32" => VarType::Uint32,
            "UINT64" => VarType::Uint64,
            "INT32" => VarType::Int32,
            "DOUBLE" => VarType::Double,
            "VECTOR3D" => VarType::Vector3d,
            "VECTOR6D" => VarType::Vector6d,
            "VECTOR6INT32" => VarType::Vector6Int32,
            "VECTOR6UINT32" => VarType::Vector6Uint32,
            _ => return None,
        })
    }

    /// Encoded size \[bytes\].
    pub fn size(self) -> usize {
        match self {
            VarType::Bool | VarType::Uint8 => 1,
            VarType::Uint32 | VarType::Int32 => 4,
            VarType::Uint64 | VarType::Double => 8,
            VarType::Vector3d => 24,
            VarType::Vector6d => 48,
            VarType::Vector6Int32 | VarType::Vector6Uint32 => 24,
        }
    }

    /// The zero value of this type.
    pub fn zero(self) -> Value {
        match self {
            VarType::Bool => Value::Bool(false),
            VarType::Uint8 => Value::U8(0),
            VarType::Uint32 => Value::U32(0),
            VarType::Uint64 => Value::U64(0),
            VarType::Int32 => Value::I32(0),
            VarType::Double => Value::F64(0.0),
            VarType::Vector3d => Value::V3([0.0; 3]),
            VarType::Vector6d => Value::V6([0.0; 6]),
            VarType::Vector6Int32 => Value::V6I([0; 6]),
            VarType::Vector6Uint32 => Value::V6U([0; 6]),
        }
    }
}

/// One RTDE value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Value {
    /// BOOL.
    Bool(bool),
    /// UINT8.
    U8(u8),
    /// UINT32.
    U32(u32),
    /// UINT64.
    U64(u64),
    /// INT32.
    I32(i32),
    /// DOUBLE.
    F64(f64),
    /// VECTOR3D.
    V3([f64; 3]),
    /// VECTOR6D.
    V6([f64; 6]),
    /// VECTOR6INT32.
    V6I([i32; 6]),
    /// VECTOR6UINT32.
    V6U([u32; 6]),
}

impl Value {
    /// The type of this value.
    pub fn var_type(&self) -> VarType {
        match self {
            Value::Bool(_) => VarType::Bool,
            Value::U8(_) => VarType::Uint8,
            Value::U32(_) => VarType::Uint32,
            Value::U64(_) => VarType::Uint64,
            Value::I32(_) => VarType::Int32,
            Value::F64(_) => VarType::Double,
            Value::V3(_) => VarType::Vector3d,
            Value::V6(_) => VarType::Vector6d,
            Value::V6I(_) => VarType::Vector6Int32,
            Value::V6U(_) => VarType::Vector6Uint32,
        }
    }

    /// Append the big-endian encoding.
    pub fn encode(&self, out: &mut Vec<u8>) {
        match self {
            Value::Bool(b) => out.push(*b as u8),
            Value::U8(v) => out.push(*v),
            Value::U32(v) => out.extend_from_slice(&v.to_be_bytes()),
            Value::U64(v) => out.extend_from_slice(&v.to_be_bytes()),
            Value::I32(v) => out.extend_from_slice(&v.to_be_bytes()),
            Value::F64(v) => out.extend_from_slice(&v.to_be_bytes()),
            Value::V3(v) => v
                .iter()
                .for_each(|x| out.extend_from_slice(&x.to_be_bytes())),
            Value::V6(v) => v
                .iter()
                .for_each(|x| out.extend_from_slice(&x.to_be_bytes())),
            Value::V6I(v) => v
                .iter()
                .for_each(|x| out.extend_from_slice(&x.to_be_bytes())),
            Value::V6U(v) => v
                .iter()
                .for_each(|x| out.extend_from_slice(&x.to_be_bytes())),
        }
    }

    /// Decode one value of type `ty` from the front of `buf`.
    pub fn decode(ty: VarType, buf: &[u8]) -> Option<Value> {
        if buf.len() < ty.size() {
            return None;
        }
        let f = |i: usize| f64::from_be_bytes(buf[8 * i..8 * i + 8].try_into().unwrap());
        let i4 = |i: usize| i32::from_be_bytes(buf[4 * i..4 * i + 4].try_into().unwrap());
        let u4 = |i: usize| u32::from_be_bytes(buf[4 * i..4 * i + 4].try_into().unwrap());
        Some(match ty {
            VarType::Bool => Value::Bool(buf[0] != 0),
            VarType::Uint8 => Value::U8(buf[0]),
            VarType::Uint32 => Value::U32(u4(0)),
            VarType::Uint64 => Value::U64(u64::from_be_bytes(buf[..8].try_into().unwrap())),
            VarType::Int32 => Value::I32(i4(0)),
            VarType::Double => Value::F64(f(0)),
            VarType::Vector3d => Value::V3([f(0), f(1), f(2)]),
            VarType::Vector6d => Value::V6([f(0), f(1), f(2), f(3), f(4), f(5)]),
            VarType::Vector6Int32 => Value::V6I([i4(0), i4(1), i4(2), i4(3), i4(4), i4(5)]),
            VarType::Vector6Uint32 => Value::V6U([u4(0), u4(1), u4(2), u4(3), u4(4), u4(5)]),
        })
    }

    /// As f64 (numbers only).
    pub fn as_f64(&self) -> Option<f64> {
        Some(match self {
            Value::Bool(b) => *b as u8 as f64,
            Value::U8(v) => *v as f64,
            Value::U32(v) => *v as f64,
            Value::U64(v) => *v as f64,
            Value::I32(v) => *v as f64,
            Value::F64(v) => *v,
            _ => return None,
        })
    }
}

/// Decode a list of values of the given types (the body of a data package after its recipe
/// id). Fails when the body is too short or too long.
pub fn decode_values(types: &[VarType], mut buf: &[u8]) -> Option<Vec<Value>> {
    let mut out = Vec::with_capacity(types.len());
    for &t in types {
        out.push(Value::decode(t, buf)?);
        buf = &buf[t.size()..];
    }
    buf.is_empty().then_some(out)
}

/// Type of a controller variable, by name (outputs of the controller and input registers).
/// `None`: the controller does not know it (it answers `NOT_FOUND`).
pub fn variable_type(name: &str) -> Option<VarType> {
    use VarType::*;
    let reg = |prefix: &str, max: u32| -> bool {
        name.strip_prefix(prefix)
            .and_then(|n| n.parse::<u32>().ok())
            .is_some_and(|n| n <= max)
    };
    for dir in ["input", "output"] {
        if reg(&format!("{dir}_int_register_"), 47) {
            return Some(Int32);
        }
        if reg(&format!("{dir}_double_register_"), 47) {
            return Some(Double);
        }
        if reg(&format!("{dir}_bit_register_"), 127) {
            return Some(Bool);
        }
        if name == format!("{dir}_bit_registers0_to_31")
            || name == format!("{dir}_bit_registers32_to_63")
        {
            return Some(Uint32);
        }
    }
    Some(match name {
        "timestamp"
        | "actual_execution_time"
        | "target_execution_time"
        | "speed_scaling"
        | "target_speed_fraction"
        | "actual_momentum"
        | "actual_main_voltage"
        | "actual_robot_voltage"
        | "actual_robot_current"
        | "standard_analog_input0"
        | "standard_analog_input1"
        | "standard_analog_output0"
        | "standard_analog_output1"
        | "io_current"
        | "tool_analog_input0"
        | "tool_analog_input1"
        | "tool_output_current"
        | "tool_temperature"
        | "tcp_force_scalar"
        | "payload"
        | "speed_slider_fraction"
        | "standard_analog_output_0"
        | "standard_analog_output_1"
        | "actual_robot_energy_consumed"
        | "actual_robot_braking_energy_dissipated"
        | "euromap67_24V_voltage"
        | "euromap67_24V_current"
        | "joint_position_deviation_ratio"
        | "collision_detection_ratio" => Double,
        "target_q"
        | "target_qd"
        | "target_qdd"
        | "target_current"
        | "target_moment"
        | "actual_q"
        | "actual_qd"
        | "actual_current"
        | "actual_current_window"
        | "actual_current_as_torque"
        | "joint_control_output"
        | "actual_TCP_pose"
        | "actual_TCP_speed"
        | "actual_TCP_force"
        | "target_TCP_pose"
        | "target_TCP_speed"
        | "tcp_offset"
        | "joint_temperatures"
        | "actual_joint_voltage"
        | "ft_raw_wrench"
        | "payload_inertia"
        | "external_force_torque"
        | "actual_TCP_acceleration"
        | "target_TCP_acceleration"
        | "wrench_calc_from_currents"
        | "target_base_acceleration"
        | "target_base_wrench" => Vector6d,
        "actual_tool_accelerometer"
        | "elbow_position"
        | "elbow_velocity"
        | "payload_cog"
        | "target_gravity" => Vector3d,
        "actual_digital_input_bits"
        | "actual_digital_output_bits"
        | "actual_configurable_digital_input_bits"
        | "actual_configurable_digital_output_bits"
        | "control_step" => Uint64,
        "robot_mode"
        | "safety_mode"
        | "safety_status"
        | "tool_output_voltage"
        | "encoder0_raw"
        | "encoder1_raw"
        | "time_scale_source" => Int32,
        "runtime_state"
        | "robot_status_bits"
        | "safety_status_bits"
        | "analog_io_types"
        | "tool_mode"
        | "tool_analog_input_types"
        | "speed_slider_mask"
        | "euromap67_input_bits"
        | "euromap67_output_bits"
        | "script_control_line" => Uint32,
        "joint_mode" => Vector6Int32,
        "tool_output_mode"
        | "tool_digital_output0_mode"
        | "tool_digital_output1_mode"
        | "standard_digital_output_mask"
        | "standard_digital_output"
        | "configurable_digital_output_mask"
        | "configurable_digital_output"
        | "standard_analog_output_mask"
        | "standard_analog_output_type"
        | "tool_digital_output_mask"
        | "tool_digital_output" => Uint8,
        _ => return None,
    })
}

/// Whether a controller variable may be written by a client (an input recipe).
pub fn is_input(name: &str) -> bool {
    name.starts_with("input_")
        || name.starts_with("speed_slider")
        || name.starts_with("standard_digital_output")
        || name.starts_with("configurable_digital_output")
        || name.starts_with("standard_analog_output")
        || name.starts_with("tool_digital_output")
        || name == "external_force_torque"
}

/// Write one package.
pub fn write_package<W: Write>(w: &mut W, ty: u8, payload: &[u8]) -> io::Result<()> {
    let size = payload.len() + 3;
    if size > MAX_PACKAGE {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            "RTDE package too large",
        ));
    }
    let mut buf = Vec::with_capacity(size);
    buf.extend_from_slice(&(size as u16).to_be_bytes());
    buf.push(ty);
    buf.extend_from_slice(payload);
    w.write_all(&buf)
}

/// Read one package: (type, payload).
pub fn read_package<R: Read>(r: &mut R) -> io::Result<(u8, Vec<u8>)> {
    let mut head = [0u8; 3];
    r.read_exact(&mut head)?;
    let size = u16::from_be_bytes([head[0], head[1]]) as usize;
    if size < 3 {
        return Err(io::Error::new(
            io::ErrorKind::InvalidData,
            format!("RTDE package with size {size} (< 3, the header's own size)"),
        ));
    }
    let mut payload = vec![0u8; size - 3];
    r.read_exact(&mut payload)?;
    Ok((head[2], payload))
}

/// A text message (protocol version 2): message, source, level.
pub fn encode_text_message(message: &str, source: &str, level: u8) -> Vec<u8> {
    let m = &message.as_bytes()[..message.len().min(255)];
    let s = &source.as_bytes()[..source.len().min(255)];
    let mut out = vec![m.len() as u8];
    out.extend_from_slice(m);
    out.push(s.len() as u8);
    out.extend_from_slice(s);
    out.push(level);
    out
}

/// Decode a text message (protocol version 2) into (message, source, level).
pub fn decode_text_message(p: &[u8]) -> Option<(String, String, u8)> {
    let ml = *p.first()? as usize;
    let m = p.get(1..1 + ml)?;
    let sl = *p.get(1 + ml)? as usize;
    let s = p.get(2 + ml..2 + ml + sl)?;
    let level = *p.get(2 + ml + sl)?;
    Some((
        String::from_utf8_lossy(m).into_owned(),
        String::from_utf8_lossy(s).into_owned(),
        level,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_round_trip_big_endian() {
        let vals = [
            Value::F64(0.4085),
            Value::I32(-7),
            Value::U32(2),
            Value::V6([1.0, 2.0, 3.0, 4.0, 5.0, 6.0]),
            Value::Bool(true),
        ];
        let mut buf = Vec::new();
        vals.iter().for_each(|v| v.encode(&mut buf));
        assert_eq!(&buf[..8], &0.4085f64.to_be_bytes());
        assert_eq!(&buf[8..12], &[0xff, 0xff, 0xff, 0xf9]);
        let types: Vec<VarType> = vals.iter().map(|v| v.var_type()).collect();
        assert_eq!(decode_values(&types, &buf).unwrap(), vals);
        assert!(decode_values(&types, &buf[..buf.len() - 1]).is_none());
    }

    #[test]
    fn table_types() {
        assert_eq!(variable_type("actual_TCP_pose"), Some(VarType::Vector6d));
        assert_eq!(variable_type("runtime_state"), Some(VarType::Uint32));
        assert_eq!(
            variable_type("input_double_register_24"),
            Some(VarType::Double)
        );
        assert_eq!(variable_type("input_int_register_24"), Some(VarType::Int32));
        assert_eq!(variable_type("input_int_register_48"), None);
        assert_eq!(variable_type("no_such_thing"), None);
    }

    #[test]
    fn package_header_counts_itself() {
        let mut buf = Vec::new();
        write_package(&mut buf, pkt::REQUEST_PROTOCOL_VERSION, &2u16.to_be_bytes()).unwrap();
        assert_eq!(buf, [0, 5, 86, 0, 2]);
        let (t, p) = read_package(&mut &buf[..]).unwrap();
        assert_eq!((t, p), (86, vec![0, 2]));
        let msg = encode_text_message("hello", "src", 3);
        assert_eq!(
            decode_text_message(&msg).unwrap(),
            ("hello".into(), "src".into(), 3)
        );
    }
}
