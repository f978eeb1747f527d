//! The emulated controller's text interfaces: the dashboard server (one command per line)
//! and the secondary interface (a URScript program per connection).

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use super::sim::Sim;

pub(crate) fn dashboard_connection(s: TcpStream, sim: Arc<Mutex<Sim>>) {
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

pub(crate) fn script_connection(mut s: TcpStream, sim: Arc<Mutex<Sim>>) {
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
