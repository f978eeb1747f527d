//! MagSwarm.fmu driven through the shell's C entry points by a hostile importer: absurd but
//! finite inputs, forged states, resources that are not where the FMU was packaged with them.

use magswarm_fmi2::host::Host;
use magswarm_fmi2::{Fmi2Status, FmuModel, Mode};
use magswarm_fmu::{vr, MagSwarm};

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

/// The payload of a serialized state with one field replaced (layout of `serialize_state`).
fn forged(good: &[u8], field: &str, value: f64) -> Vec<u8> {
    use magswarm_fmi2::bytes::{ByteReader, PutBytes};
    let mut r = ByteReader::new(good);
    let json = r.str().unwrap().to_string();
    let file = r.str().unwrap().to_string();
    let mut xs = [0.0; 2];
    for x in &mut xs {
        *x = r.f64().unwrap();
    }
    let settle = r.bool().unwrap();
    let mut rs = [r.f64().unwrap(), r.f64().unwrap()];
    let _has_rtol = r.bool().unwrap();
    let mut rtol = r.f64().unwrap();
    let outside = r.bool().unwrap();
    let has_plant = r.bool().unwrap();
    let mut snap: serde_json::Value = if has_plant {
        serde_json::from_str(r.str().unwrap()).unwrap()
    } else {
        serde_json::Value::Null
    };
    match field {
        "z_m" => xs[0] = value,
        "r1_start" => rs[0] = value,
        "rtol" => rtol = value,
        "plant.r" => snap["r"] = serde_json::json!([value, value]),
        "plant.h_next" => snap["h_next"] = serde_json::json!(value),
        _ => unreachable!(),
    }
    let mut out = Vec::new();
    out.put_str(&json);
    out.put_str(&file);
    out.put_f64(xs[0]);
    out.put_f64(xs[1]);
    out.put_bool(settle);
    out.put_f64(rs[0]);
    out.put_f64(rs[1]);
    out.put_bool(field == "rtol");
    out.put_f64(rtol);
    out.put_bool(outside);
    out.put_bool(has_plant);
    if has_plant {
        out.put_str(&snap.to_string());
    }
    out
}

#[test]
fn forged_states_are_validated_like_set_values() {
    let mut m = MagSwarm::new(None).unwrap();
    let mut ctx = magswarm_fmi2::Ctx::silent();
    m.exit_initialization_mode(&mut ctx).unwrap();
    m.do_step(&mut ctx, 0.0, 0.1).unwrap();
    let mut good = Vec::new();
    m.serialize_state(&mut good).unwrap();
    assert!(m.clone().deserialize_state(&good).is_ok());
    for (field, value) in [
        ("z_m", -1.0),
        ("r1_start", -1.0),
        ("rtol", 5.0),
        ("plant.r", -1e300),
        ("plant.h_next", -1.0),
    ] {
        let mut victim = m.clone();
        let r = victim.deserialize_state(&forged(&good, field, value));
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
