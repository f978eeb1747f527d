//! RTDE client: handshake (protocol version 2), controller version, recipes, start/pause,
//! data packages; and [`UrLink`], the bridge's robot link (a reader thread keeping the latest
//! state, a writer for the z target and the heartbeat).

use std::io::{self, Write};
use std::net::{Shutdown, TcpStream, ToSocketAddrs};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use super::proto::{self, pkt, Value, VarType};

/// Errors of the RTDE client.
#[derive(Debug, thiserror::Error)]
pub enum RtdeError {
    /// Socket error.
    #[error("RTDE {host}:{port}: {what}: {source}")]
    Io {
        /// Host.
        host: String,
        /// Port.
        port: u16,
        /// What was being done.
        what: String,
        /// The error.
        source: io::Error,
    },
    /// The controller refused or answered out of protocol.
    #[error("RTDE {host}:{port}: {what}")]
    Protocol {
        /// Host.
        host: String,
        /// Port.
        port: u16,
        /// What went wrong.
        what: String,
    },
}

/// The controller's version.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ControllerVersion {
    /// Major (5 for e-Series, 3 for CB3).
    pub major: u32,
    /// Minor.
    pub minor: u32,
    /// Bugfix.
    pub bugfix: u32,
    /// Build.
    pub build: u32,
}

impl std::fmt::Display for ControllerVersion {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}.{}.{}.{}",
            self.major, self.minor, self.bugfix, self.build
        )
    }
}

/// A recipe the controller accepted.
#[derive(Debug, Clone, PartialEq)]
pub struct Recipe {
    /// Recipe id.
    pub id: u8,
    /// Variable names.
    pub names: Vec<String>,
    /// Their types.
    pub types: Vec<VarType>,
}

/// A synchronous RTDE connection (handshake and data).
pub struct RtdeClient {
    stream: TcpStream,
    host: String,
    port: u16,
    /// Text messages received from the controller (message, source, level).
    pub messages: Vec<(String, String, u8)>,
}

impl RtdeClient {
    /// Connect with a timeout (also used as the read timeout during the handshake).
    pub fn connect(host: &str, port: u16, timeout: Duration) -> Result<RtdeClient, RtdeError> {
        let io_err = |what: &str, e: io::Error| RtdeError::Io {
            host: host.into(),
            port,
            what: what.into(),
            source: e,
        };
        let addr = (host, port)
            .to_socket_addrs()
            .map_err(|e| io_err("resolving the address", e))?
            .next()
            .ok_or_else(|| RtdeError::Protocol {
                host: host.into(),
                port,
                what: "the address resolves to nothing".into(),
            })?;
        let stream =
            TcpStream::connect_timeout(&addr, timeout).map_err(|e| io_err("connecting", e))?;
        stream
            .set_nodelay(true)
            .map_err(|e| io_err("TCP_NODELAY", e))?;
        stream
            .set_read_timeout(Some(timeout))
            .map_err(|e| io_err("read timeout", e))?;
        Ok(RtdeClient {
            stream,
            host: host.into(),
            port,
            messages: Vec::new(),
        })
    }

    fn io(&self, what: &str, e: io::Error) -> RtdeError {
        RtdeError::Io {
            host: self.host.clone(),
            port: self.port,
            what: what.into(),
            source: e,
        }
    }

    fn proto(&self, what: impl Into<String>) -> RtdeError {
        RtdeError::Protocol {
            host: self.host.clone(),
            port: self.port,
            what: what.into(),
        }
    }

    fn send(&mut self, ty: u8, payload: &[u8]) -> Result<(), RtdeError> {
        proto::write_package(&mut self.stream, ty, payload)
            .map_err(|e| self.io(&format!("sending package '{}'", ty as char), e))
    }

    /// Read packages until one of type `ty` (text messages are kept, stray data packages
    /// skipped).
    fn expect(&mut self, ty: u8) -> Result<Vec<u8>, RtdeError> {
        loop {
            let (t, p) = proto::read_package(&mut self.stream)
                .map_err(|e| self.io(&format!("waiting for the reply '{}'", ty as char), e))?;
            if t == ty {
                return Ok(p);
            }
            match t {
                pkt::TEXT_MESSAGE => {
                    if let Some(m) = proto::decode_text_message(&p) {
                        self.messages.push(m);
                    }
                }
                pkt::DATA_PACKAGE => {}
                other => {
                    return Err(self.proto(format!(
                        "expected a reply '{}', got a package of type {other}",
                        ty as char
                    )))
                }
            }
        }
    }

    /// Ask for protocol version 2.
    pub fn negotiate_protocol_version(&mut self) -> Result<(), RtdeError> {
        self.send(
            pkt::REQUEST_PROTOCOL_VERSION,
            &proto::PROTOCOL_VERSION.to_be_bytes(),
        )?;
        let p = self.expect(pkt::REQUEST_PROTOCOL_VERSION)?;
        match p.first() {
            Some(1) => Ok(()),
            Some(_) => Err(self.proto("the controller refused RTDE protocol version 2")),
            None => Err(self.proto("empty reply to the protocol version request")),
        }
    }

    /// The controller's version.
    pub fn controller_version(&mut self) -> Result<ControllerVersion, RtdeError> {
        self.send(pkt::GET_URCONTROL_VERSION, &[])?;
        let p = self.expect(pkt::GET_URCONTROL_VERSION)?;
        if p.len() < 16 {
            return Err(self.proto(format!(
                "controller version reply of {} bytes (16 expected)",
                p.len()
            )));
        }
        let u = |i: usize| u32::from_be_bytes(p[4 * i..4 * i + 4].try_into().unwrap());
        Ok(ControllerVersion {
            major: u(0),
            minor: u(1),
            bugfix: u(2),
            build: u(3),
        })
    }

    fn parse_recipe(&self, names: &[&str], p: &[u8], kind: &str) -> Result<Recipe, RtdeError> {
        let id = *p
            .first()
            .ok_or_else(|| self.proto(format!("empty {kind} recipe reply")))?;
        let types_s = String::from_utf8_lossy(&p[1..]).into_owned();
        let parts: Vec<&str> = types_s.split(',').collect();
        if parts.len() != names.len() {
            return Err(self.proto(format!(
                "{kind} recipe reply lists {} types for {} variables: {types_s:?}",
                parts.len(),
                names.len()
            )));
        }
        let mut types = Vec::new();
        for (n, t) in names.iter().zip(&parts) {
            match VarType::parse(t) {
                Some(v) => types.push(v),
                None => {
                    return Err(self.proto(format!(
                        "{kind} variable `{n}`: the controller answered {t} \
                         (NOT_FOUND: unknown name; IN_USE: another client writes it)"
                    )))
                }
            }
        }
        if id == 0 {
            return Err(self.proto(format!("{kind} recipe refused (id 0): {types_s}")));
        }
        Ok(Recipe {
            id,
            names: names.iter().map(|s| s.to_string()).collect(),
            types,
        })
    }

    /// Set up the output recipe at `frequency_hz`.
    pub fn setup_outputs(
        &mut self,
        frequency_hz: f64,
        names: &[&str],
    ) -> Result<Recipe, RtdeError> {
        let mut payload = frequency_hz.to_be_bytes().to_vec();
        payload.extend_from_slice(names.join(",").as_bytes());
        self.send(pkt::SETUP_OUTPUTS, &payload)?;
        let p = self.expect(pkt::SETUP_OUTPUTS)?;
        self.parse_recipe(names, &p, "output")
    }

    /// Set up an input recipe.
    pub fn setup_inputs(&mut self, names: &[&str]) -> Result<Recipe, RtdeError> {
        self.send(pkt::SETUP_INPUTS, names.join(",").as_bytes())?;
        let p = self.expect(pkt::SETUP_INPUTS)?;
        self.parse_recipe(names, &p, "input")
    }

    /// Start the data synchronisation.
    pub fn start(&mut self) -> Result<(), RtdeError> {
        self.send(pkt::START, &[])?;
        match self.expect(pkt::START)?.first() {
            Some(1) => Ok(()),
            _ => Err(self.proto("the controller refused to start the data synchronisation")),
        }
    }

    /// Pause the data synchronisation.
    pub fn pause(&mut self) -> Result<(), RtdeError> {
        self.send(pkt::PAUSE, &[])?;
        match self.expect(pkt::PAUSE)?.first() {
            Some(1) => Ok(()),
            _ => Err(self.proto("the controller refused to pause")),
        }
    }

    /// Send one input data package.
    pub fn send_inputs(&mut self, recipe: &Recipe, values: &[Value]) -> Result<(), RtdeError> {
        let buf = encode_inputs(recipe, values).map_err(|w| self.proto(w.to_string()))?;
        self.stream
            .write_all(&buf)
            .map_err(|e| self.io("sending inputs", e))
    }

    /// Read the next output data package of `recipe`.
    pub fn receive(&mut self, recipe: &Recipe) -> Result<Vec<Value>, RtdeError> {
        let p = self.expect(pkt::DATA_PACKAGE)?;
        decode_outputs(recipe, &p).map_err(|w| self.proto(w.to_string()))
    }

    /// Split into the stream (for a reader thread and a writer).
    pub fn into_stream(self) -> TcpStream {
        self.stream
    }
}

/// A data package that does not fit its recipe.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PackageError {
    /// As many values as the recipe has variables are needed.
    #[error("{given} values for an input recipe of {expected}")]
    Count {
        /// Values given.
        given: usize,
        /// Variables in the recipe.
        expected: usize,
    },
    /// A value of the wrong type.
    #[error("input `{name}` is {expected}, got {got}")]
    Type {
        /// The variable.
        name: String,
        /// Its type.
        expected: &'static str,
        /// The value given.
        got: String,
    },
    /// A package of another recipe.
    #[error("data package for recipe {got}, expected {expected}")]
    Recipe {
        /// Its recipe id.
        got: u8,
        /// The recipe's.
        expected: u8,
    },
    /// No recipe id.
    #[error("empty data package")]
    Empty,
    /// The payload's length does not match the recipe's types.
    #[error("data package of {len} bytes does not match the recipe {names:?}")]
    Size {
        /// Payload length.
        len: usize,
        /// The recipe's variables.
        names: Vec<String>,
    },
    /// Over the protocol's 16-bit package size.
    #[error("package of {0} bytes is too large for RTDE")]
    TooLarge(usize),
}

/// Encode a whole input data package (header included).
pub fn encode_inputs(recipe: &Recipe, values: &[Value]) -> Result<Vec<u8>, PackageError> {
    if values.len() != recipe.types.len() {
        return Err(PackageError::Count {
            given: values.len(),
            expected: recipe.types.len(),
        });
    }
    let mut payload = vec![recipe.id];
    for (v, (t, n)) in values.iter().zip(recipe.types.iter().zip(&recipe.names)) {
        if v.var_type() != *t {
            return Err(PackageError::Type {
                name: n.clone(),
                expected: t.name(),
                got: format!("{v:?}"),
            });
        }
        v.encode(&mut payload);
    }
    let mut buf = Vec::with_capacity(payload.len() + 3);
    proto::write_package(&mut buf, pkt::DATA_PACKAGE, &payload)
        .map_err(|_| PackageError::TooLarge(payload.len() + 3))?;
    Ok(buf)
}

/// Decode an output data package's payload for `recipe`.
pub fn decode_outputs(recipe: &Recipe, p: &[u8]) -> Result<Vec<Value>, PackageError> {
    match p.first() {
        Some(&id) if id == recipe.id => {}
        Some(&id) => {
            return Err(PackageError::Recipe {
                got: id,
                expected: recipe.id,
            })
        }
        None => return Err(PackageError::Empty),
    }
    proto::decode_values(&recipe.types, &p[1..]).ok_or_else(|| PackageError::Size {
        len: p.len(),
        names: recipe.names.clone(),
    })
}

/// What the bridge reads from the robot.
pub const OUTPUTS: [&str; 5] = [
    "timestamp",
    "actual_TCP_pose",
    "robot_mode",
    "safety_mode",
    "runtime_state",
];
/// What the bridge writes: the tool's target z \[m\] and the heartbeat counter.
pub const INPUTS: [&str; 2] = ["input_double_register_24", "input_int_register_24"];

/// The latest robot state the reader thread saw.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobotState {
    /// Controller timestamp \[s\].
    pub timestamp: f64,
    /// Tool pose in the base frame (x, y, z \[m\], rotation vector \[rad\]).
    pub tcp_pose: [f64; 6],
    /// `robot_mode`.
    pub robot_mode: i32,
    /// `safety_mode`.
    pub safety_mode: i32,
    /// `runtime_state`.
    pub runtime_state: u32,
    /// When this package arrived.
    pub received: Instant,
    /// Packages received so far.
    pub count: u64,
}

struct Shared {
    state: Option<RobotState>,
    /// Why the reader stopped (connection lost, protocol error).
    error: Option<String>,
}

/// The bridge's robot link: handshake done, a reader thread keeps the latest state.
pub struct UrLink {
    writer: TcpStream,
    input: Recipe,
    shared: Arc<Mutex<Shared>>,
    reader: Option<JoinHandle<()>>,
    /// Controller version.
    pub version: ControllerVersion,
    heartbeat: i32,
}

impl UrLink {
    /// Connect, negotiate, set up the recipes (output at `frequency_hz`) and start.
    pub fn connect(
        host: &str,
        port: u16,
        frequency_hz: f64,
        timeout: Duration,
    ) -> Result<UrLink, RtdeError> {
        let mut c = RtdeClient::connect(host, port, timeout)?;
        c.negotiate_protocol_version()?;
        let version = c.controller_version()?;
        let output = c.setup_outputs(frequency_hz, &OUTPUTS)?;
        let input = c.setup_inputs(&INPUTS)?;
        c.start()?;
        let (host_s, port_s) = (host.to_string(), port);
        let stream = c.into_stream();
        let writer = stream.try_clone().map_err(|e| RtdeError::Io {
            host: host_s.clone(),
            port: port_s,
            what: "cloning the socket".into(),
            source: e,
        })?;
        // The reader blocks; loss is detected by the bridge from the age of the last package.
        let _ = stream.set_read_timeout(Some(Duration::from_secs(5)));
        let shared = Arc::new(Mutex::new(Shared {
            state: None,
            error: None,
        }));
        let sh = shared.clone();
        let reader = std::thread::Builder::new()
            .name("rtde-reader".into())
            .spawn(move || reader_loop(stream, output, sh))
            .expect("spawn the RTDE reader thread");
        Ok(UrLink {
            writer,
            input,
            shared,
            reader: Some(reader),
            version,
            heartbeat: 0,
        })
    }

    /// The latest state, if any package arrived yet.
    pub fn state(&self) -> Option<RobotState> {
        self.shared.lock().map(|s| s.state).unwrap_or(None)
    }

    /// Why the reader stopped, if it did.
    pub fn error(&self) -> Option<String> {
        self.shared.lock().ok().and_then(|s| s.error.clone())
    }

    /// Wait for the first state (up to `timeout`).
    pub fn wait_state(&self, timeout: Duration) -> Option<RobotState> {
        let t0 = Instant::now();
        while t0.elapsed() < timeout {
            if let Some(s) = self.state() {
                return Some(s);
            }
            if self.error().is_some() {
                return None;
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        None
    }

    /// Write the tool's target z \[m\] and the next heartbeat. The caller has already clamped
    /// `tcp_z_m` to the envelope (the URScript clamps again).
    pub fn command(&mut self, tcp_z_m: f64) -> io::Result<()> {
        self.heartbeat = self.heartbeat.wrapping_add(1).max(1);
        let buf = encode_inputs(
            &self.input,
            &[Value::F64(tcp_z_m), Value::I32(self.heartbeat)],
        )
        .map_err(io::Error::other)?;
        self.writer.write_all(&buf)
    }

    /// The heartbeat last sent.
    pub fn heartbeat(&self) -> i32 {
        self.heartbeat
    }
}

impl Drop for UrLink {
    fn drop(&mut self) {
        let _ = self.writer.shutdown(Shutdown::Both);
        if let Some(h) = self.reader.take() {
            let _ = h.join();
        }
    }
}

fn reader_loop(mut stream: TcpStream, recipe: Recipe, shared: Arc<Mutex<Shared>>) {
    let mut count = 0u64;
    loop {
        let res = proto::read_package(&mut stream);
        let (t, p) = match res {
            Ok(x) => x,
            Err(e) => {
                if let Ok(mut s) = shared.lock() {
                    s.error = Some(format!("RTDE connection lost: {e}"));
                }
                return;
            }
        };
        if t != pkt::DATA_PACKAGE {
            continue;
        }
        match decode_outputs(&recipe, &p) {
            Ok(v) => {
                count += 1;
                let st = RobotState {
                    timestamp: v[0].as_f64().unwrap_or(f64::NAN),
                    tcp_pose: match v[1] {
                        Value::V6(p) => p,
                        _ => [f64::NAN; 6],
                    },
                    robot_mode: match v[2] {
                        Value::I32(m) => m,
                        _ => i32::MIN,
                    },
                    safety_mode: match v[3] {
                        Value::I32(m) => m,
                        _ => i32::MIN,
                    },
                    runtime_state: match v[4] {
                        Value::U32(m) => m,
                        _ => u32::MAX,
                    },
                    received: Instant::now(),
                    count,
                };
                if let Ok(mut s) = shared.lock() {
                    s.state = Some(st);
                }
            }
            Err(e) => {
                if let Ok(mut s) = shared.lock() {
                    s.error = Some(format!("RTDE protocol error: {e}"));
                }
                return;
            }
        }
    }
}
