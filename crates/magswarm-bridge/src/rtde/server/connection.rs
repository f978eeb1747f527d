//! One RTDE connection of the emulated controller: protocol version 2, controller version,
//! output recipes (`NOT_FOUND` for unknown names) sent at their rate from their own thread,
//! input recipes (`IN_USE` for a register another connection writes), start and pause.

use std::io::Read;
use std::net::{Shutdown, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use super::sim::Sim;
use crate::rtde::proto::{self, pkt, Value, VarType};

/// Connections counter (for `IN_USE` bookkeeping).
static CONN_ID: AtomicU64 = AtomicU64::new(1);

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

pub(crate) fn rtde_connection(
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
