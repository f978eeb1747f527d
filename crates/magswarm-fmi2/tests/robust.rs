//! The shell under a hostile importer: FMU states owned by their instance, the Error state
//! as the standard's table has it, resource locations that are garbage or missing, forged
//! serialized states, and panics that stay silent on the host's stderr.

mod toy;

use ciborium::Value;
use magswarm_fmi2::host::Host;
use magswarm_fmi2::magswarm_fmi_core::snapshot;
use magswarm_fmi2::{Fmi2Status, FmuModel, Mode};
use toy::*;

use Fmi2Status::{Error, Ok as OK, Warning};

type H = Host<Lag>;

fn host(name: &str) -> H {
    H::instantiate(name, Some(b"file:///tmp")).expect("instantiates")
}

#[test]
fn fmu_states_are_freed_with_their_instance() {
    let name = "states-freed-with-instance";
    {
        let f = host(name);
        assert_eq!(f.init(0.0), OK);
        for _ in 0..5 {
            let (s, _state) = f.get_state();
            assert_eq!(s, OK);
        }
        let (s, bytes) = {
            let (_, st) = f.get_state();
            (OK, unsafe { f.serialize(st) }.unwrap())
        };
        assert_eq!(s, OK);
        let (s, _restored) = f.deserialize(&bytes);
        assert_eq!(s, OK);
        assert_eq!(live(name), 1 + 5 + 1 + 1, "the instance and its 7 states");
    }
    assert_eq!(
        live(name),
        0,
        "fmi2FreeInstance frees the states the importer did not free"
    );
}

#[test]
fn a_state_belongs_to_the_instance_that_made_it() {
    let f = host("owner");
    let g = host("other");
    assert_eq!(f.init(0.0), OK);
    assert_eq!(g.init(0.0), OK);
    let (s, mut st) = f.get_state();
    assert_eq!(s, OK);
    unsafe {
        assert_eq!(g.free_state(&mut st), Error);
        assert!(!st.is_null(), "refused: the handle is untouched");
        assert!(g.log().has(Error, "not an FMU state of this instance"));
        assert_eq!(g.reset(), OK);
        assert_eq!(g.set_state(st), Error);
        assert_eq!(g.reset(), OK);
        assert!(g.serialize(st).is_err());
        // The owner still has it.
        assert_eq!(f.set_state(st), OK);
        assert_eq!(f.free_state(&mut st), OK);
        assert!(st.is_null());
        // Freed: a second free is refused (the importer's bug), not a double free.
        let stale = {
            let (_, s2) = f.get_state();
            let mut s3 = s2;
            assert_eq!(f.free_state(&mut s3), OK);
            s2
        };
        assert_eq!(f.set_state(stale), Error);
    }
}

#[test]
fn terminate_in_the_error_state_follows_the_standard() {
    let f = host("terminate-after-error");
    assert_eq!(f.init(0.0), OK);
    assert_eq!(f.step(5.0, 0.1), Error, "a non-contiguous step");
    assert_eq!(f.mode(), Mode::Error);
    f.log().clear();
    assert_eq!(f.terminate(), Error);
    let msgs = f.log().at_least(Error);
    let m = msgs.first().expect("a message");
    // The message lists what the table allows in Error, and fmi2Terminate is not among them.
    assert!(
        m.contains("fmi2Reset") && m.contains("fmi2FreeInstance"),
        "{m}"
    );
    assert!(
        !m.contains("fmi2Terminate,") && !m.contains("fmi2Terminate and"),
        "{m}"
    );
    // Getters are allowed in Error.
    assert_eq!(f.get_real(Y).0, OK);
    assert_eq!(f.reset(), OK);
    assert_eq!(f.mode(), Mode::Instantiated);
}

#[test]
fn garbage_resource_locations_are_warnings_not_panics() {
    for loc in [
        &b"\xff\xfe\xfd\xfc\xfb"[..],
        "éééé".as_bytes(),
        "file:\u{e9}\u{e9}".as_bytes(),
        b"\xc3",
        b"file:///%ff%fe/x",
        b"file://\xff/x",
    ] {
        let h = H::instantiate("garbage-uri", Some(loc));
        let log = match &h {
            Ok(h) => h.log().entries(),
            Err(l) => l.clone(),
        };
        assert!(
            !log.iter().any(|e| e.message.contains("panicked")),
            "{loc:?}: {log:?}"
        );
        assert!(h.is_ok(), "{loc:?}: {log:?}");
    }
}

#[test]
fn a_resource_location_that_does_not_exist_is_a_warning() {
    let h = H::instantiate(
        "missing-resources",
        Some(b"file:///nonexistent/magswarm/resources"),
    )
    .expect("the toy has no baked resources, so it still instantiates");
    let w = h.log().at_least(Warning);
    assert!(
        w.iter()
            .any(|m| m.contains("/nonexistent/magswarm/resources") && m.contains("does not exist")),
        "{w:?}"
    );
}

/// Serialized state of an initialised instance.
fn serialized() -> Vec<u8> {
    let f = host("forger");
    assert_eq!(f.init(0.0), OK);
    assert_eq!(f.step(0.0, 0.5), OK);
    let (_, st) = f.get_state();
    unsafe { f.serialize(st) }.unwrap()
}

fn guid() -> u128 {
    magswarm_fmi2::guid::guid_u128(<Lag as FmuModel>::model_info())
}

/// Edit the decoded payload of a genuine state and seal it again: a forger who knows the
/// format, so every frame check passes and only the content checks can refuse it.
fn forge(good: &[u8], edit: impl FnOnce(&mut Value)) -> Vec<u8> {
    let payload = snapshot::unframe(guid(), 1, good).expect("genuine frame");
    let mut v: Value = ciborium::from_reader(payload).unwrap();
    edit(&mut v);
    let mut out = Vec::new();
    ciborium::into_writer(&v, &mut out).unwrap();
    snapshot::frame(guid(), 1, &out)
}

/// The field `key` of the CBOR map `v`.
fn field<'a>(v: &'a mut Value, key: &str) -> &'a mut Value {
    let Value::Map(m) = v else {
        panic!("not a map: {v:?}")
    };
    &mut m
        .iter_mut()
        .find(|(k, _)| k.as_text() == Some(key))
        .unwrap_or_else(|| panic!("no field {key}"))
        .1
}

fn deserialize_fails(g: &H, what: &str, bytes: &[u8], message: &str) {
    g.log().clear();
    let (s, st) = g.deserialize(bytes);
    assert_eq!(s, Error, "{what}");
    assert!(st.is_null(), "{what}");
    assert!(
        g.log().has(Error, message),
        "{what}: expected {message:?} in {:?}",
        g.log().entries()
    );
    assert!(!g.log().has(Error, "panicked"), "{what}");
    assert_eq!(g.reset(), OK);
}

#[test]
fn forged_states_with_a_valid_checksum_are_validated() {
    let good = serialized();
    let g = host("victim");
    assert_eq!(g.deserialize(&good).0, OK, "the genuine state is accepted");
    let fatal = forge(&good, |v| {
        *field(field(v, "shell"), "mode") = Value::Integer(Mode::Fatal.to_byte().into())
    });
    deserialize_fails(&g, "mode Fatal", &fatal, "mode Fatal");
    let early = forge(&good, |v| {
        *field(field(v, "shell"), "time") = Value::Float(-1.0)
    });
    deserialize_fails(&g, "before the start", &early, "before the start time");
    let inf = forge(&good, |v| {
        *field(field(v, "shell"), "start_time") = Value::Float(f64::INFINITY)
    });
    deserialize_fails(&g, "non-finite", &inf, "non-finite");
    let tau = forge(&good, |v| {
        *field(field(v, "model"), "tau") = Value::Float(-1.0)
    });
    deserialize_fails(&g, "model value", &tau, "the model refused it: tau = -1");
    let extra = forge(&good, |v| {
        let Value::Map(m) = field(v, "model") else {
            panic!()
        };
        m.push((Value::Text("gain".into()), Value::Float(1.0)));
    });
    deserialize_fails(&g, "unknown field", &extra, "does not decode");
    let wrong_type = forge(&good, |v| {
        *field(field(v, "model"), "label") = Value::Float(1.0)
    });
    deserialize_fails(&g, "wrong type", &wrong_type, "does not decode");
}

#[test]
fn corrupted_truncated_and_foreign_states_name_the_failed_check() {
    let good = serialized();
    let g = host("frames");
    assert_eq!(g.deserialize(&good).0, OK);
    let n = good.len();
    // Every single-bit flip anywhere is caught (by the check guarding that byte).
    for i in 0..n {
        let mut b = good.clone();
        b[i] ^= 0x10;
        let (s, st) = g.deserialize(&b);
        assert!(s == Error && st.is_null(), "flip at byte {i} accepted");
        assert_eq!(g.reset(), OK);
    }
    let mut b = good.clone();
    b[n - 3] ^= 0xff;
    deserialize_fails(&g, "payload byte", &b, "CRC-32 checksum mismatch");
    deserialize_fails(&g, "truncated", &good[..n - 5], "is truncated");
    deserialize_fails(&g, "header only", &good[..20], "is truncated");
    deserialize_fails(&g, "empty", &[], "is truncated");
    let mut b = good.clone();
    b.extend_from_slice(&[0, 0]);
    deserialize_fails(&g, "trailing", &b, "2 unexpected bytes");
    let mut b = good.clone();
    b[0] = b'X';
    deserialize_fails(&g, "magic", &b, "bad magic bytes");
    let payload = snapshot::unframe(guid(), 1, &good).unwrap();
    let b = snapshot::frame(guid() ^ 1, 1, payload);
    deserialize_fails(&g, "GUID", &b, "different FMU");
    let b = snapshot::frame(guid(), 2, payload);
    deserialize_fails(&g, "state version", &b, "state has version 2");
    let mut b = good.clone();
    b[8..12].copy_from_slice(&1u32.to_le_bytes());
    deserialize_fails(&g, "layout version", &b, "frame layout version 1");
    let b = snapshot::frame(guid(), 1, b"not CBOR at all");
    deserialize_fails(&g, "garbage payload", &b, "does not decode");
    let mut p = payload.to_vec();
    p.push(0);
    let b = snapshot::frame(guid(), 1, &p);
    deserialize_fails(&g, "left over", &b, "left over");
    assert_eq!(
        g.deserialize(&good).0,
        OK,
        "still accepts the genuine state"
    );
}

/// Runs in a child process (see below): a panic inside the model, caught by the shell.
#[test]
#[ignore = "run by panics_write_nothing_to_the_hosts_stderr in a child process"]
fn child_panics_inside_the_fmu() {
    if std::env::var_os("MAGSWARM_PANIC_CHILD").is_none() {
        return;
    }
    let f = host("panicky");
    assert_eq!(f.init(0.0), OK);
    assert_eq!(f.set_boolean(PANIC_NOW, true), OK);
    assert_eq!(f.step(0.0, 0.1), Error);
    assert!(f.log().has(Error, "do_step asked to panic"));
    assert!(H::instantiate("panic-in-constructor", None).is_err());
    // A panic of the host's own code still reaches the host's panic hook.
    let r = std::panic::catch_unwind(|| panic!("host's own panic"));
    assert!(r.is_err());
}

#[test]
fn panics_write_nothing_to_the_hosts_stderr() {
    let exe = std::env::current_exe().unwrap();
    let out = std::process::Command::new(exe)
        .args([
            "--exact",
            "child_panics_inside_the_fmu",
            "--include-ignored",
            "--nocapture",
            "--test-threads=1",
        ])
        .env("MAGSWARM_PANIC_CHILD", "1")
        .env("RUST_BACKTRACE", "1")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("1 passed"), "{stdout}");
    assert!(
        !stderr.contains("asked to panic") && !stdout.contains("asked to panic"),
        "a panic inside the FMU reached the host's stderr:\n{stderr}"
    );
    assert!(
        stderr.contains("host's own panic"),
        "the host's own panics still reach its hook:\n{stderr}"
    );
}
