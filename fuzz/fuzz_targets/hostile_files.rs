//! Everything magswarm reads from disk, fed garbage: model JSON, measurement logs and
//! serialized FMU states. Each must be accepted or refused with an error, never a panic.
//! States come twice: as raw bytes (refused by the frame's checks: magic, lengths, CRC) and
//! as a payload sealed in a valid frame, so the fuzzer reaches the CBOR decoding and the
//! models' own validation behind the checksum.
#![no_main]
use magswarm_fmi::fmi2::host::Host;
use magswarm_fmi::fmi2::{guid::guid_u128, snapshot, FmuModel};

/// `payload` in a genuine frame of model `M` (right GUID, state version and CRC).
fn sealed<M: FmuModel>(payload: &[u8]) -> Vec<u8> {
    snapshot::frame(guid_u128(M::model_info()), M::STATE_VERSION, payload)
}

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let Some((&kind, rest)) = data.split_first() else {
        return;
    };
    match kind % 6 {
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
        3 => {
            let h = Host::<magswarm_pid_fmu::MagSwarmPid>::instantiate("f", None).unwrap();
            let _ = h.deserialize(rest);
            assert!(!h.log().entries().iter().any(|e| e.message.contains("panicked")));
        }
        4 => {
            let h = Host::<magswarm_fmu::MagSwarm>::instantiate("f", None).unwrap();
            let _ = h.deserialize(&sealed::<magswarm_fmu::MagSwarm>(rest));
            assert!(!h.log().entries().iter().any(|e| e.message.contains("panicked")));
        }
        _ => {
            type Pid = magswarm_pid_fmu::MagSwarmPid;
            let h = Host::<Pid>::instantiate("f", None).unwrap();
            let _ = h.deserialize(&sealed::<Pid>(rest));
            assert!(!h.log().entries().iter().any(|e| e.message.contains("panicked")));
        }
    }
});
