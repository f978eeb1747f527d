//! The emulated UR controller: RTDE server, dashboard server and secondary interface (script
//! upload), around one simulated robot whose tool z follows the commanded register with a lag.
//!
//! The emulated program does what the bridge's URScript does: it reads the target from
//! `input_double_register_24`, clamps it to the z limits and rate limit it finds in the
//! uploaded script (or the config's when no script is uploaded), and stops when the heartbeat
//! register is not updated within the watchdog period. Cues raise a protective stop or drop
//! the link at given times after the first RTDE start.

use std::collections::HashMap;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use super::proto::{self, pkt, robot_mode, runtime_state, safety_mode, Value, VarType};

/// How the emulated robot behaves.
#[derive(Debug, Clone)]
pub struct RobotSimConfig {
    /// Tool pose at start (base frame; z \[m\]).
    pub start_pose: [f64; 6],
    /// First-order lag of the tool z behind the program's target \[s\].
    pub lag_s: f64,
    /// z limits of the tool \[m\] used when no script was uploaded (the program is already
    /// running).
    pub z_limits_m: [f64; 2],
    /// Rate limit [m/s] used when no script was uploaded.
    pub z_rate_m_s: f64,
    /// Watchdog frequency \[Hz\] used when no script was uploaded (0: none).
    pub watchdog_hz: f64,
    /// The program is already loaded and playing (no script upload expected).
    pub program_running: bool,
    /// The robot starts powered off (a dashboard client must power on and release brakes).
    pub start_powered_off: bool,
    /// Raise a protective stop this long after the first RTDE start \[s\].
    pub protective_stop_after_s: Option<f64>,
    /// Drop every RTDE connection (and refuse new ones) this long after the first start \[s\].
    pub drop_link_after_s: Option<f64>,
}

/// What the emulated robot saw (for tests and the emulator's report).
#[derive(Debug, Clone, Default)]
pub struct RobotRecord {
    /// Every `input_double_register_24` value received.
    pub targets: Vec<f64>,
    /// Dashboard commands received, in order.
    pub dashboard: Vec<String>,
    /// Scripts received on the secondary interface.
    pub scripts: Vec<String>,
    /// Heartbeats received.
    pub heartbeats: u64,
    /// Times the watchdog stopped the program.
    pub watchdog_stops: u32,
    /// The last time the watchdog fired: the heartbeat gap it saw then, and the gap at the
    /// check before (which did not fire), in seconds. So a test can see that it fired at its first
    /// check past the period, however late the checks ran on a loaded machine.
    pub watchdog_fired: Option<WatchdogFiring>,
}

/// Heartbeat gaps around a watchdog stop (see [`RobotRecord::watchdog_fired`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WatchdogFiring {
    /// Gap since the last heartbeat when the watchdog fired, in seconds (> the period).
    pub gap_s: f64,
    /// Gap at the previous check, in seconds (<= the period, or it would have fired then).
    pub previous_gap_s: f64,
}

struct Sim {
    cfg: RobotSimConfig,
    t0: Instant,
    pose: [f64; 6],
    z_cmd: f64,
    target_reg: Option<f64>,
    robot_mode: i32,
    safety_mode: i32,
    runtime_state: u32,
    program_loaded: bool,
    limits: [f64; 2],
    rate: f64,
    watchdog_hz: f64,
    last_heartbeat: Option<Instant>,
    /// Heartbeat gap at the watchdog's last check that did not fire, in seconds.
    last_watchdog_gap_s: f64,
    first_start: Option<Instant>,
    registers: HashMap<String, Value>,
    writers: HashMap<String, u64>,
    record: RobotRecord,
}

impl Sim {
    fn output(&self, name: &str) -> Value {
        match name {
            "timestamp" => Value::F64(self.t0.elapsed().as_secs_f64()),
            "actual_TCP_pose" => Value::V6(self.pose),
            "target_TCP_pose" => {
                let mut p = self.pose;
                p[2] = self.z_cmd;
                Value::V6(p)
            }
            "robot_mode" => Value::I32(self.robot_mode),
            "safety_mode" | "safety_status" => Value::I32(self.safety_mode),
            "runtime_state" => Value::U32(self.runtime_state),
            "speed_scaling" | "target_speed_fraction" => Value::F64(1.0),
            "actual_main_voltage" | "actual_robot_voltage" => Value::F64(48.0),
            "joint_mode" => Value::V6I([253; 6]),
            _ => {
                if let Some(v) = self.registers.get(name) {
                    return *v;
                }
                proto::variable_type(name)
                    .map(|t| t.zero())
                    .unwrap_or(Value::U8(0))
            }
        }
    }

    fn tick(&mut self, dt: f64) {
        let now = Instant::now();
        if let (Some(t), Some(s)) = (self.first_start, self.cfg.protective_stop_after_s) {
            if self.safety_mode == safety_mode::NORMAL && t.elapsed().as_secs_f64() >= s {
                self.safety_mode = safety_mode::PROTECTIVE_STOP;
                if self.runtime_state == runtime_state::PLAYING {
                    self.runtime_state = runtime_state::PAUSED;
                }
            }
        }
        let playing = self.runtime_state == runtime_state::PLAYING
            && self.robot_mode == robot_mode::RUNNING
            && self.safety_mode == safety_mode::NORMAL;
        if playing && self.watchdog_hz > 0.0 {
            let period = Duration::from_secs_f64(1.0 / self.watchdog_hz);
            if let Some(h) = self.last_heartbeat {
                let gap = now.duration_since(h);
                if gap > period {
                    self.runtime_state = runtime_state::STOPPED;
                    self.record.watchdog_stops += 1;
                    self.record.watchdog_fired = Some(WatchdogFiring {
                        gap_s: gap.as_secs_f64(),
                        previous_gap_s: self.last_watchdog_gap_s,
                    });
                } else {
                    self.last_watchdog_gap_s = gap.as_secs_f64();
                }
            }
        }
        if self.runtime_state == runtime_state::PLAYING
            && self.robot_mode == robot_mode::RUNNING
            && self.safety_mode == safety_mode::NORMAL
        {
            // The program: hold until the first heartbeat, then clamp, rate limit, servo.
            if let (Some(target), Some(_)) = (self.target_reg, self.last_heartbeat) {
                let t = target.clamp(self.limits[0], self.limits[1]);
                let step = (t - self.z_cmd).clamp(-self.rate * dt, self.rate * dt);
                self.z_cmd += step;
            }
            let a = if self.cfg.lag_s > 0.0 {
                1.0 - (-dt / self.cfg.lag_s).exp()
            } else {
                1.0
            };
            self.pose[2] += a * (self.z_cmd - self.pose[2]);
        } else {
            // Stopped, paused or stopped by safety: the robot holds where it is.
            self.z_cmd = self.pose[2];
        }
    }

    fn load_script(&mut self, script: &str) {
        self.record.scripts.push(script.to_string());
        let num = |key: &str| -> Option<f64> {
            script.lines().find_map(|l| {
                let l = l.trim();
                let rest = l.strip_prefix(key)?.trim_start().strip_prefix('=')?;
                rest.trim().parse::<f64>().ok()
            })
        };
        if let (Some(lo), Some(hi)) = (num("magswarm_z_min"), num("magswarm_z_max")) {
            self.limits = [lo, hi];
        }
        if let Some(v) = num("magswarm_z_rate") {
            self.rate = v;
        }
        // rtde_set_watchdog("input_int_register_24", F, "stop")
        self.watchdog_hz = script
            .lines()
            .find_map(|l| {
                let l = l.trim();
                let args = l.strip_prefix("rtde_set_watchdog(")?;
                let mut it = args.split(',');
                let reg = it.next()?.trim().trim_matches('"');
                (reg == "input_int_register_24").then_some(())?;
                it.next()?.trim().parse::<f64>().ok()
            })
            .unwrap_or(0.0);
        self.program_loaded = true;
        if self.robot_mode == robot_mode::RUNNING && self.safety_mode == safety_mode::NORMAL {
            self.runtime_state = runtime_state::PLAYING;
            self.z_cmd = self.pose[2];
            self.last_heartbeat = None;
        }
    }

    fn dashboard(&mut self, cmd: &str) -> (String, bool) {
        self.record.dashboard.push(cmd.to_string());
        let r = match cmd {
            "power on" => {
                if self.robot_mode == robot_mode::POWER_OFF {
                    self.robot_mode = robot_mode::IDLE;
                }
                "Powering on".to_string()
            }
            "power off" => {
                self.robot_mode = robot_mode::POWER_OFF;
                self.runtime_state = runtime_state::STOPPED;
                "Powering off".to_string()
            }
            "brake release" => {
                if self.robot_mode == robot_mode::IDLE {
                    self.robot_mode = robot_mode::RUNNING;
                }
                "Brake releasing".to_string()
            }
            "play" => {
                if self.program_loaded
                    && self.robot_mode == robot_mode::RUNNING
                    && self.safety_mode == safety_mode::NORMAL
                {
                    self.runtime_state = runtime_state::PLAYING;
                    "Starting program".to_string()
                } else {
                    "Failed to execute: Play".to_string()
                }
            }
            "stop" => {
                self.runtime_state = runtime_state::STOPPED;
                "Stopped".to_string()
            }
            "pause" => {
                if self.runtime_state == runtime_state::PLAYING {
                    self.runtime_state = runtime_state::PAUSED;
                }
                "Pausing program".to_string()
            }
            "robotmode" => format!("Robotmode: {}", robot_mode::name(self.robot_mode)),
            "safetystatus" => format!("Safetystatus: {}", safety_mode::name(self.safety_mode)),
            "safetymode" => format!("Safetymode: {}", safety_mode::name(self.safety_mode)),
            "programState" => format!(
                "{} magswarm_servo.urp",
                runtime_state::name(self.runtime_state)
            ),
            "PolyscopeVersion" => "URSoftware 5.11.0.108249 (emulated)".to_string(),
            "unlock protective stop" => {
                if self.safety_mode == safety_mode::PROTECTIVE_STOP {
                    self.safety_mode = safety_mode::NORMAL;
                }
                "Protective stop releasing".to_string()
            }
            "close popup" | "close safety popup" => "closing popup".to_string(),
            "quit" => return ("Disconnected".to_string(), true),
            other => format!("Could not understand: '{other}'"),
        };
        (r, false)
    }
}

/// A running emulated UR controller.
pub struct UrEmulator {
    sim: Arc<Mutex<Sim>>,
    stop: Arc<AtomicBool>,
    link_down: Arc<AtomicBool>,
    threads: Vec<std::thread::JoinHandle<()>>,
    /// RTDE address.
    pub rtde: SocketAddr,
    /// Dashboard address (None: not served).
    pub dashboard: Option<SocketAddr>,
    /// Secondary interface address (None: not served).
    pub secondary: Option<SocketAddr>,
}

/// Connections counter (for `IN_USE` bookkeeping).
static CONN_ID: AtomicU64 = AtomicU64::new(1);

impl UrEmulator {
    /// Bind and start serving. A port 0 picks a free port (see the returned addresses);
    /// `dashboard_port`/`script_port` `None` do not serve that interface.
    pub fn start(
        host: &str,
        rtde_port: u16,
        dashboard_port: Option<u16>,
        script_port: Option<u16>,
        cfg: RobotSimConfig,
    ) -> std::io::Result<UrEmulator> {
        let sim = Arc::new(Mutex::new(Sim {
            t0: Instant::now(),
            pose: cfg.start_pose,
            z_cmd: cfg.start_pose[2],
            target_reg: None,
            robot_mode: if cfg.start_powered_off {
                robot_mode::POWER_OFF
            } else {
                robot_mode::RUNNING
            },
            safety_mode: safety_mode::NORMAL,
            runtime_state: if cfg.program_running {
                runtime_state::PLAYING
            } else {
                runtime_state::STOPPED
            },
            program_loaded: cfg.program_running,
            limits: cfg.z_limits_m,
            rate: cfg.z_rate_m_s,
            watchdog_hz: cfg.watchdog_hz,
            last_heartbeat: None,
            last_watchdog_gap_s: 0.0,
            first_start: None,
            registers: HashMap::new(),
            writers: HashMap::new(),
            record: RobotRecord::default(),
            cfg,
        }));
        let stop = Arc::new(AtomicBool::new(false));
        let link_down = Arc::new(AtomicBool::new(false));
        let mut threads = Vec::new();

        let rl = TcpListener::bind((host, rtde_port))?;
        let rtde = rl.local_addr()?;
        rl.set_nonblocking(true)?;
        {
            let (sim, stop, down) = (sim.clone(), stop.clone(), link_down.clone());
            threads.push(std::thread::spawn(move || {
                accept_loop(rl, stop.clone(), move |s| {
                    let (sim, stop, down) = (sim.clone(), stop.clone(), down.clone());
                    if down.load(Ordering::SeqCst) {
                        let _ = s.shutdown(Shutdown::Both);
                        return;
                    }
                    std::thread::spawn(move || rtde_connection(s, sim, stop, down));
                })
            }));
        }
        let dashboard = dashboard_port
            .map(|p| serve(host, p, &sim, &stop, &mut threads, dashboard_connection))
            .transpose()?;
        let secondary = script_port
            .map(|p| serve(host, p, &sim, &stop, &mut threads, script_connection))
            .transpose()?;
        {
            // Physics at 500 Hz, on the wall clock: each pass integrates the time that really
            // passed (in steps of at most 2 ms), so the robot moves at its rate and its lag
            // however late a loaded machine runs this thread.
            let (sim, stop, down) = (sim.clone(), stop.clone(), link_down.clone());
            threads.push(std::thread::spawn(move || {
                let dt = 0.002;
                let mut last = Instant::now();
                while !stop.load(Ordering::SeqCst) {
                    if let Ok(mut s) = sim.lock() {
                        let now = Instant::now();
                        let mut left = now.duration_since(last).as_secs_f64();
                        last = now;
                        while left > 0.0 {
                            let h = left.min(dt);
                            s.tick(h);
                            left -= h;
                        }
                        if let (Some(t), Some(d)) = (s.first_start, s.cfg.drop_link_after_s) {
                            if t.elapsed().as_secs_f64() >= d {
                                down.store(true, Ordering::SeqCst);
                            }
                        }
                    }
                    std::thread::sleep(Duration::from_secs_f64(dt));
                }
            }));
        }
        Ok(UrEmulator {
            sim,
            stop,
            link_down,
            threads,
            rtde,
            dashboard,
            secondary,
        })
    }

    /// What the robot saw so far.
    pub fn record(&self) -> RobotRecord {
        self.sim
            .lock()
            .map(|s| s.record.clone())
            .unwrap_or_default()
    }

    /// Current tool z \[m\].
    pub fn tool_z(&self) -> f64 {
        self.sim.lock().map(|s| s.pose[2]).unwrap_or(f64::NAN)
    }

    /// (robot_mode, safety_mode, runtime_state).
    pub fn modes(&self) -> (i32, i32, u32) {
        self.sim
            .lock()
            .map(|s| (s.robot_mode, s.safety_mode, s.runtime_state))
            .unwrap_or((0, 0, 0))
    }

    /// Raise a protective stop now.
    pub fn protective_stop(&self) {
        if let Ok(mut s) = self.sim.lock() {
            s.safety_mode = safety_mode::PROTECTIVE_STOP;
            if s.runtime_state == runtime_state::PLAYING {
                s.runtime_state = runtime_state::PAUSED;
            }
        }
    }

    /// Drop every RTDE connection now and refuse new ones.
    pub fn drop_link(&self) {
        self.link_down.store(true, Ordering::SeqCst);
    }
}

impl Drop for UrEmulator {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

fn accept_loop(l: TcpListener, stop: Arc<AtomicBool>, mut on: impl FnMut(TcpStream)) {
    while !stop.load(Ordering::SeqCst) {
        match l.accept() {
            Ok((s, _)) => {
                let _ = s.set_nonblocking(false);
                let _ = s.set_nodelay(true);
                on(s)
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(5))
            }
            Err(_) => std::thread::sleep(Duration::from_millis(5)),
        }
    }
}

/// Listen on `host:port` and run `connection` on its own thread for every client (the
/// dashboard and the secondary interface); the accept loop joins `threads`.
fn serve(
    host: &str,
    port: u16,
    sim: &Arc<Mutex<Sim>>,
    stop: &Arc<AtomicBool>,
    threads: &mut Vec<std::thread::JoinHandle<()>>,
    connection: fn(TcpStream, Arc<Mutex<Sim>>),
) -> std::io::Result<SocketAddr> {
    let l = TcpListener::bind((host, port))?;
    let a = l.local_addr()?;
    l.set_nonblocking(true)?;
    let (sim, stop) = (sim.clone(), stop.clone());
    threads.push(std::thread::spawn(move || {
        accept_loop(l, stop, move |s| {
            let sim = sim.clone();
            std::thread::spawn(move || connection(s, sim));
        })
    }));
    Ok(a)
}

/// An output recipe: its id, variable names and the period of its data packages.
#[derive(Clone)]
struct OutRecipe {
    id: u8,
    names: Vec<String>,
    period: Duration,
}

/// The variable names of a recipe request: comma-separated, trimmed; empty entries are
/// dropped (ur_rtde ends the list with a comma, which the controller ignores).
fn recipe_names(bytes: &[u8]) -> Vec<String> {
    String::from_utf8_lossy(bytes)
        .split(',')
        .map(|x| x.trim().to_string())
        .filter(|x| !x.is_empty())
        .collect()
}

fn rtde_connection(
    s: TcpStream,
    sim: Arc<Mutex<Sim>>,
    stop: Arc<AtomicBool>,
    down: Arc<AtomicBool>,
) {
    let conn = CONN_ID.fetch_add(1, Ordering::SeqCst);
    let _ = s.set_read_timeout(Some(Duration::from_millis(20)));
    let mut reader = match s.try_clone() {
        Ok(r) => r,
        Err(_) => return,
    };
    let writer = Arc::new(Mutex::new(s));
    let mut version_ok = false;
    let mut outputs: Vec<OutRecipe> = Vec::new();
    let mut inputs: Vec<(u8, Vec<String>, Vec<VarType>)> = Vec::new();
    let started = Arc::new(AtomicBool::new(false));
    let mut sender: Option<std::thread::JoinHandle<()>> = None;
    let conn_stop = Arc::new(AtomicBool::new(false));
    let send = |ty: u8, p: &[u8]| -> bool {
        writer
            .lock()
            .map(|mut w| proto::write_package(&mut *w, ty, p).is_ok())
            .unwrap_or(false)
    };
    // Partial reads with a timeout: keep a buffer.
    let mut buf: Vec<u8> = Vec::new();
    let mut chunk = [0u8; 4096];
    'conn: loop {
        if stop.load(Ordering::SeqCst) || down.load(Ordering::SeqCst) {
            break;
        }
        match reader.read(&mut chunk) {
            Ok(0) => break,
            Ok(n) => buf.extend_from_slice(&chunk[..n]),
            Err(e)
                if e.kind() == std::io::ErrorKind::WouldBlock
                    || e.kind() == std::io::ErrorKind::TimedOut =>
            {
                continue
            }
            Err(_) => break,
        }
        while buf.len() >= 3 {
            let size = u16::from_be_bytes([buf[0], buf[1]]) as usize;
            if size < 3 {
                break 'conn;
            }
            if buf.len() < size {
                break;
            }
            let ty = buf[2];
            let p: Vec<u8> = buf[3..size].to_vec();
            buf.drain(..size);
            match ty {
                pkt::REQUEST_PROTOCOL_VERSION => {
                    let v = if p.len() >= 2 {
                        u16::from_be_bytes([p[0], p[1]])
                    } else {
                        0
                    };
                    version_ok = v == 2;
                    if !send(ty, &[version_ok as u8]) {
                        break 'conn;
                    }
                }
                pkt::GET_URCONTROL_VERSION => {
                    let mut r = Vec::new();
                    for x in [5u32, 11, 0, 108249] {
                        r.extend_from_slice(&x.to_be_bytes());
                    }
                    if !send(ty, &r) {
                        break 'conn;
                    }
                }
                pkt::SETUP_OUTPUTS => {
                    if p.len() < 8 || !version_ok {
                        send(ty, &[0]);
                        continue;
                    }
                    let freq = f64::from_be_bytes(p[..8].try_into().unwrap());
                    let names = recipe_names(&p[8..]);
                    let types: Vec<String> = names
                        .iter()
                        .map(|n| {
                            proto::variable_type(n)
                                .map(|t| t.name().to_string())
                                .unwrap_or_else(|| "NOT_FOUND".into())
                        })
                        .collect();
                    let ok = types.iter().all(|t| t != "NOT_FOUND") && freq > 0.0 && freq <= 500.0;
                    // Output ids are 1..=255: a recipe past the last id is refused (id 0).
                    let id = match u8::try_from(outputs.len() + 1) {
                        Ok(id) if ok => id,
                        _ => 0,
                    };
                    if id != 0 {
                        outputs.push(OutRecipe {
                            id,
                            names,
                            period: Duration::from_secs_f64(1.0 / freq),
                        });
                    }
                    let mut r = vec![id];
                    r.extend_from_slice(types.join(",").as_bytes());
                    if !send(ty, &r) {
                        break 'conn;
                    }
                }
                pkt::SETUP_INPUTS => {
                    let names = recipe_names(&p);
                    let mut types = Vec::new();
                    let mut reply = Vec::new();
                    // Checked and claimed under one lock, so two clients cannot both get a
                    // register.
                    let id = {
                        let mut s = sim.lock().unwrap();
                        for n in &names {
                            let t = proto::variable_type(n).filter(|_| proto::is_input(n));
                            match t {
                                None => reply.push("NOT_FOUND".to_string()),
                                Some(_) if s.writers.get(n).is_some_and(|c| *c != conn) => {
                                    reply.push("IN_USE".to_string())
                                }
                                Some(t) => {
                                    reply.push(t.name().to_string());
                                    types.push(t)
                                }
                            }
                        }
                        // Input ids are 100..=255: a recipe past the last id is refused (0).
                        let id = match u8::try_from(100 + inputs.len()) {
                            Ok(id) if types.len() == names.len() => id,
                            _ => 0,
                        };
                        if id != 0 {
                            for n in &names {
                                s.writers.insert(n.clone(), conn);
                            }
                        }
                        id
                    };
                    if id != 0 {
                        inputs.push((id, names, types));
                    }
                    let mut r = vec![id];
                    r.extend_from_slice(reply.join(",").as_bytes());
                    if !send(ty, &r) {
                        break 'conn;
                    }
                }
                pkt::START => {
                    let ok = !outputs.is_empty() || !inputs.is_empty();
                    if ok && !started.swap(true, Ordering::SeqCst) {
                        if let Ok(mut s) = sim.lock() {
                            s.first_start.get_or_insert(Instant::now());
                        }
                        let recipes = outputs.clone();
                        let (w, sim2, st, cs, dn) = (
                            writer.clone(),
                            sim.clone(),
                            started.clone(),
                            conn_stop.clone(),
                            down.clone(),
                        );
                        sender = Some(std::thread::spawn(move || {
                            output_loop(w, sim2, recipes, st, cs, dn)
                        }));
                    }
                    if !send(ty, &[ok as u8]) {
                        break 'conn;
                    }
                }
                pkt::PAUSE => {
                    started.store(false, Ordering::SeqCst);
                    if let Some(h) = sender.take() {
                        let _ = h.join();
                    }
                    if !send(ty, &[1]) {
                        break 'conn;
                    }
                }
                pkt::DATA_PACKAGE => {
                    let Some(&id) = p.first() else { continue };
                    let Some((_, names, types)) = inputs.iter().find(|(i, _, _)| *i == id) else {
                        send(
                            pkt::TEXT_MESSAGE,
                            &proto::encode_text_message(
                                &format!("data package for unknown input recipe {id}"),
                                "RTDE",
                                1,
                            ),
                        );
                        continue;
                    };
                    let Some(vals) = proto::decode_values(types, &p[1..]) else {
                        send(
                            pkt::TEXT_MESSAGE,
                            &proto::encode_text_message("malformed input data package", "RTDE", 1),
                        );
                        continue;
                    };
                    let mut s = sim.lock().unwrap();
                    for (n, v) in names.iter().zip(vals) {
                        if n == "input_double_register_24" {
                            if let Value::F64(z) = v {
                                s.target_reg = Some(z);
                                s.record.targets.push(z);
                            }
                        }
                        if n == "input_int_register_24" {
                            s.last_heartbeat = Some(Instant::now());
                            s.record.heartbeats += 1;
                        }
                        s.registers.insert(n.clone(), v);
                    }
                }
                _ => {
                    send(
                        pkt::TEXT_MESSAGE,
                        &proto::encode_text_message(
                            &format!("unknown package type {ty}"),
                            "RTDE",
                            1,
                        ),
                    );
                }
            }
        }
    }
    conn_stop.store(true, Ordering::SeqCst);
    if let Ok(w) = writer.lock() {
        let _ = w.shutdown(Shutdown::Both);
    }
    if let Some(h) = sender {
        let _ = h.join();
    }
    if let Ok(mut s) = sim.lock() {
        s.writers.retain(|_, c| *c != conn);
    }
}

fn output_loop(
    w: Arc<Mutex<TcpStream>>,
    sim: Arc<Mutex<Sim>>,
    recipes: Vec<OutRecipe>,
    started: Arc<AtomicBool>,
    conn_stop: Arc<AtomicBool>,
    down: Arc<AtomicBool>,
) {
    let mut next: Vec<Instant> = recipes.iter().map(|_| Instant::now()).collect();
    while started.load(Ordering::SeqCst) && !conn_stop.load(Ordering::SeqCst) {
        if down.load(Ordering::SeqCst) {
            if let Ok(w) = w.lock() {
                let _ = w.shutdown(Shutdown::Both);
            }
            return;
        }
        let now = Instant::now();
        for (k, r) in recipes.iter().enumerate() {
            if now >= next[k] {
                next[k] += r.period;
                if next[k] < now {
                    next[k] = now + r.period;
                }
                let mut p = vec![r.id];
                if let Ok(s) = sim.lock() {
                    for n in &r.names {
                        s.output(n).encode(&mut p);
                    }
                }
                let ok = w
                    .lock()
                    .map(|mut w| proto::write_package(&mut *w, pkt::DATA_PACKAGE, &p).is_ok())
                    .unwrap_or(false);
                if !ok {
                    return;
                }
            }
        }
        let wake = next
            .iter()
            .min()
            .copied()
            .unwrap_or(now + Duration::from_millis(2));
        let d = wake.saturating_duration_since(Instant::now());
        std::thread::sleep(d.min(Duration::from_millis(2)));
    }
}

fn dashboard_connection(s: TcpStream, sim: Arc<Mutex<Sim>>) {
    let mut w = match s.try_clone() {
        Ok(w) => w,
        Err(_) => return,
    };
    if w.write_all(b"Connected: Universal Robots Dashboard Server\n")
        .is_err()
    {
        return;
    }
    let r = BufReader::new(s);
    for line in r.lines() {
        let Ok(line) = line else { return };
        let cmd = line.trim();
        if cmd.is_empty() {
            continue;
        }
        let (reply, quit) = sim.lock().unwrap().dashboard(cmd);
        if w.write_all(format!("{reply}\n").as_bytes()).is_err() || quit {
            return;
        }
    }
}

fn script_connection(mut s: TcpStream, sim: Arc<Mutex<Sim>>) {
    let _ = s.set_read_timeout(Some(Duration::from_millis(200)));
    let mut text = Vec::new();
    let mut chunk = [0u8; 4096];
    loop {
        match s.read(&mut chunk) {
            Ok(0) => break,
            Ok(n) => text.extend_from_slice(&chunk[..n]),
            Err(_) => break,
        }
    }
    let script = String::from_utf8_lossy(&text).into_owned();
    if script.trim_start().starts_with("def ") && script.trim_end().ends_with("end") {
        sim.lock().unwrap().load_script(&script);
    }
}
