//! Everything magswarm reads from disk, fed garbage: model JSON, measurement logs and
//! serialized FMU states. Each must be accepted or refused with an error, never a panic.
#![no_main]
use magswarm_fmi2::host::Host;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let Some((&kind, rest)) = data.split_first() else {
        return;
    };
    match kind % 4 {
        0 => {
            let text = String::from_utf8_lossy(rest);
            if let Ok(m) = magswarm_model::Model::from_json_str(&text, "fuzz") {
                // Accepted models round-trip.
                let again = m.to_json().expect("an accepted model serializes");
                magswarm_model::Model::from_json_str(&again, "again").expect("and reads back");
            }
        }
        1 => {
            let _ = magswarm_log::Log::from_reader(rest, "fuzz.csv", Default::default());
        }
        2 => {
            let h = Host::<magswarm_fmu::MagSwarm>::instantiate("f", None).unwrap();
            let _ = h.deserialize(rest);
            assert!(!h.log().entries().iter().any(|e| e.message.contains("panicked")));
        }
        _ => {
            let h = Host::<magswarm_pid_fmu::MagSwarmPid>::instantiate("f", None).unwrap();
            let _ = h.deserialize(rest);
            assert!(!h.log().entries().iter().any(|e| e.message.contains("panicked")));
        }
    }
});
