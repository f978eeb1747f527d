//! MagSwarm.fmu driven through the shell's C entry points by a hostile importer: absurd but
//! finite inputs, forged states, resources that are not where the FMU was packaged with them.

use magswarm_fmi::fmi2::host::Host;
use magswarm_fmi::fmi2::{Fmi2Status, FmuModel, Mode};
use magswarm_fmu::{vr, MagSwarm, MagSwarmState};

use Fmi2Status::{Error, Ok as OK};

type H = Host<MagSwarm>;

fn host() -> H {
    H::instantiate("plant", None).expect("instantiates")
}

fn checked(h: &H, f: impl FnOnce(&H) -> Fmi2Status) -> Fmi2Status {
    let before = h.log().len();
    let s = f(h);
    h.check(s, before).unwrap_or_else(|e| panic!("{e}"));
    s
}

#[test]
fn a_huge_input_before_initialization_is_an_error_not_nan_outputs() {
    let h = host();
    // Refused when set, or at the latest when initialising: never a Warning and NaN.
    let s = checked(&h, |h| h.set_real(vr::Z_M, 1e308));
    let s = if s <= Fmi2Status::Warning {
        checked(&h, |h| h.init(0.0))
    } else {
        s
    };
    assert_eq!(s, Error, "{:?}", h.log().entries());
    assert!(h.log().has(Error, "z_m"), "{:?}", h.log().entries());
}

#[test]
fn every_absurd_finite_input_keeps_outputs_finite() {
    for (input, value) in [
        (vr::Z_M, 1e308),
        (vr::Z_M, 1e3),
        (vr::Z_M, 0.9),
        (vr::Z_M, 5e-324),
        (vr::OMEGA_M, 1e308),
        (vr::OMEGA_M, -1e308),
        (vr::OMEGA_M, 0.0),
        (vr::OMEGA_M, 5e-324),
    ] {
        for before_init in [true, false] {
            let h = host();
            if before_init {
                checked(&h, |h| h.set_real(input, value));
                checked(&h, |h| h.init(0.0));
            } else {
                assert_eq!(h.init(0.0), OK);
                checked(&h, |h| h.set_real(input, value));
            }
            for k in 0..3 {
                if h.mode() != Mode::StepComplete {
                    break;
                }
                checked(&h, |h| h.step(k as f64 * 0.05, 0.05));
            }
        }
    }
}

/// A state with one field replaced by a value the FMU would refuse if it were set.
fn forged(good: &MagSwarmState, field: &str, value: f64) -> MagSwarmState {
    let mut s = good.clone();
    let plant = s.plant.as_mut().expect("the plant runs");
    match field {
        "z_m" => s.z_m = value,
        "r1_start" => s.r_start[0] = value,
        "rtol" => s.rtol = Some(value),
        "plant.r" => plant.r = [value, value],
        "plant.h_next" => plant.h_next = value,
        "model.C_1" => s.model.steady.C_1 = value,
        _ => unreachable!(),
    }
    s
}

#[test]
fn forged_states_are_validated_like_set_values() {
    let mut m = MagSwarm::new(None).unwrap();
    let mut ctx = magswarm_fmi::fmi2::Ctx::silent();
    m.exit_initialization_mode(&mut ctx).unwrap();
    m.step(&mut ctx, 0.0, 0.1).unwrap();
    let good = m.save_state().unwrap();
    assert!(m.clone().restore_state(good.clone()).is_ok());
    for (field, value) in [
        ("z_m", -1.0),
        ("r1_start", -1.0),
        ("rtol", 5.0),
        ("plant.r", -1e300),
        ("plant.h_next", -1.0),
        ("model.C_1", f64::NAN),
    ] {
        let mut victim = m.clone();
        let r = victim.restore_state(forged(&good, field, value));
        assert!(r.is_err(), "{field} = {value} accepted");
        assert_eq!(
            victim.model(),
            m.model(),
            "refused without a half-restored instance"
        );
    }
}

#[test]
fn a_packaged_model_missing_from_the_resource_location_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let packaged = dir.path().join("fmu/resources");
    std::fs::create_dir_all(&packaged).unwrap();
    std::fs::write(
        packaged.join("model.json"),
        magswarm_model::Model::paper().to_json().unwrap(),
    )
    .unwrap();
    let elsewhere = dir.path().join("elsewhere");
    std::fs::create_dir_all(&elsewhere).unwrap();
    let e = MagSwarm::with_resources(Some(&elsewhere), Some(&packaged)).unwrap_err();
    assert!(
        e.message.contains("packaged with") && e.message.contains("elsewhere"),
        "{}",
        e.message
    );
    assert!(MagSwarm::with_resources(None, Some(&packaged)).is_err());
    assert!(MagSwarm::with_resources(Some(&packaged), Some(&packaged)).is_ok());
    assert!(MagSwarm::with_resources(Some(&elsewhere), None).is_ok());
}

/// The plant's state through the C API: it replays bit-identically in another instance,
/// and damaged or foreign bytes are refused with the failed check named in the log.
#[test]
fn serialized_plant_states_replay_and_damaged_ones_are_refused() {
    let a = host();
    assert_eq!(a.init(0.0), OK);
    assert_eq!(a.set_real(vr::Z_M, 0.0135), OK);
    assert_eq!(a.step(0.0, 0.3), OK);
    let (_, st) = a.get_state();
    // SAFETY: `st` was handed out by `a` and not freed.
    let bytes = unsafe { a.serialize(st) }.unwrap();
    let b = host();
    let (s, restored) = b.deserialize(&bytes);
    assert_eq!(s, OK, "{:?}", b.log().entries());
    // SAFETY: `restored` was handed out by `b`.
    assert_eq!(unsafe { b.set_state(restored) }, OK);
    assert_eq!(a.step(0.3, 0.2), OK);
    assert_eq!(b.step(0.3, 0.2), OK);
    assert_eq!(
        a.get_real(vr::R1).1.to_bits(),
        b.get_real(vr::R1).1.to_bits()
    );
    let guid = magswarm_fmi::fmi2::guid::guid_u128(MagSwarm::model_info());
    let payload = magswarm_fmi::snapshot::unframe(guid, MagSwarm::STATE_VERSION, &bytes)
        .unwrap()
        .to_vec();
    let mut flipped = bytes.clone();
    let mid = bytes.len() / 2;
    flipped[mid] ^= 1;
    for (what, bad, message) in [
        ("truncated", bytes[..bytes.len() - 1].to_vec(), "truncated"),
        ("bit flip", flipped, "CRC-32 checksum mismatch"),
        (
            "another FMU",
            magswarm_fmi::snapshot::frame(!guid, MagSwarm::STATE_VERSION, &payload),
            "different FMU",
        ),
        (
            "another state version",
            magswarm_fmi::snapshot::frame(guid, MagSwarm::STATE_VERSION + 1, &payload),
            "this build of the FMU reads version",
        ),
    ] {
        b.log().clear();
        let (s, st) = b.deserialize(&bad);
        assert_eq!(s, Error, "{what}");
        assert!(st.is_null(), "{what}");
        assert!(
            b.log().has(Error, message),
            "{what}: {:?}",
            b.log().entries()
        );
    }
}
