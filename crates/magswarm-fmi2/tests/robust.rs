//! The shell under a hostile importer: FMU states owned by their instance, the Error state
//! as the standard's table has it, resource locations that are garbage or missing, forged
//! serialized states, and panics that stay silent on the host's stderr.

mod toy;

use magswarm_fmi2::guid::fnv1a_64;
use magswarm_fmi2::host::Host;
use magswarm_fmi2::{Fmi2Status, Mode};
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

/// Serialized state of an initialised instance, and a function that re-computes its
/// checksum after an edit (a forger who knows the format).
fn serialized() -> Vec<u8> {
    let f = host("forger");
    assert_eq!(f.init(0.0), OK);
    assert_eq!(f.step(0.0, 0.5), OK);
    let (_, st) = f.get_state();
    unsafe { f.serialize(st) }.unwrap()
}

fn reseal(mut b: Vec<u8>) -> Vec<u8> {
    let n = b.len() - 8;
    let sum = fnv1a_64(&b[..n]);
    b[n..].copy_from_slice(&sum.to_le_bytes());
    b
}

// Offsets of the shell's header (see `snapshot`): magic 8, version 4, GUID 16, then mode.
const MODE: usize = 28;
const TIME: usize = 29;
const START: usize = 37;

#[test]
fn forged_states_with_a_valid_checksum_are_validated() {
    let good = serialized();
    let g = host("victim");
    assert_eq!(g.deserialize(&good).0, OK, "the genuine state is accepted");
    let mut cases: Vec<(&str, Vec<u8>)> = Vec::new();
    let mut b = good.clone();
    b[MODE] = 7; // Fatal
    cases.push(("Fatal", reseal(b)));
    let mut b = good.clone();
    b[TIME..TIME + 8].copy_from_slice(&(-1.0f64).to_le_bytes());
    cases.push(("before the start time", reseal(b)));
    let mut b = good.clone();
    b[START..START + 8].copy_from_slice(&f64::INFINITY.to_le_bytes());
    cases.push(("non-finite", reseal(b)));
    for (what, b) in cases {
        g.log().clear();
        let (s, st) = g.deserialize(&b);
        assert_eq!(s, Error, "{what}");
        assert!(st.is_null(), "{what}");
        assert!(!g.log().at_least(Error).is_empty(), "{what}");
        assert_eq!(g.reset(), OK);
    }
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
