//! The limit and calibration parameters against the rig config.
//!
//! Limits may be narrowed by the importer (a controller designer may keep the magnet in a
//! smaller envelope), never widened: the config's `[limits]` are the operator's. The
//! calibration (`z_tcp_at_zero`, `pixel_size`, `velocity_per_hz`) is read-only: it is shown
//! so a model can use it, and a value other than the config's is refused (a wrong `z_m = 0`
//! moves a magnet into a tank). Values set before initialisation are kept and checked when
//! the rig is opened, against the config in force then (`config_file` may change after them).

use std::collections::BTreeMap;

use magswarm_bridge::config::RigConfig;

use crate::table::{start_values, vr};

/// The config's value of a limit or calibration parameter (SI).
pub fn config_value(cfg: &RigConfig, vr: u32) -> Option<f64> {
    start_values(cfg).into_iter().find_map(|(v, s)| match s {
        magswarm_fmi2::Start::Real(x) if v == vr && v >= vr::Z_M_MIN => Some(x),
        _ => None,
    })
}

/// Whether `vr` is one of the parameters checked here.
pub fn is_rig_parameter(vr: u32) -> bool {
    (vr::Z_M_MIN..=vr::OMEGA_M_RATE_MAX).contains(&vr)
        || (vr::Z_TCP_AT_ZERO..=vr::VELOCITY_PER_HZ).contains(&vr)
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1e-12)
}

/// `cfg` with the importer's values `set` (value reference -> SI value) applied to its
/// limits, or the first value that is not allowed, naming its variable.
pub fn apply(
    cfg: &RigConfig,
    set: &BTreeMap<u32, f64>,
    name: impl Fn(u32) -> &'static str,
) -> Result<RigConfig, String> {
    let mut out = cfg.clone();
    let tau = std::f64::consts::TAU;
    for (&v, &x) in set {
        let c = config_value(cfg, v)
            .ok_or_else(|| format!("value reference {v} is not a rig parameter"))?;
        let n = name(v);
        let (lower_bound, what) = match v {
            vr::Z_M_MIN | vr::OMEGA_M_MIN => (true, "may narrow the config's limit, not widen it"),
            vr::Z_M_MAX | vr::OMEGA_M_MAX | vr::Z_M_RATE_MAX | vr::OMEGA_M_RATE_MAX => {
                (false, "may narrow the config's limit, not widen it")
            }
            _ => {
                if !close(x, c) {
                    return Err(format!(
                        "{n} = {x:e} differs from the rig config's {c:e}: calibration is \
                         read-only here (edit the rig config, or point config_file at another)"
                    ));
                }
                continue;
            }
        };
        let widens = if lower_bound {
            x < c && !close(x, c)
        } else {
            x > c && !close(x, c)
        };
        if widens || !(x.is_finite() && x > 0.0) {
            return Err(format!("{n} = {x:e} {what} ({c:e})"));
        }
        let l = &mut out.limits;
        match v {
            vr::Z_M_MIN => l.z_m_mm[0] = x * 1e3,
            vr::Z_M_MAX => l.z_m_mm[1] = x * 1e3,
            vr::OMEGA_M_MIN => l.f_hz[0] = x / tau,
            vr::OMEGA_M_MAX => l.f_hz[1] = x / tau,
            vr::Z_M_RATE_MAX => l.z_rate_mm_s = x * 1e3,
            _ => l.f_rate_hz_s = x / tau,
        }
    }
    let l = &out.limits;
    if l.z_m_mm[0] >= l.z_m_mm[1] {
        return Err(format!(
            "z_m_min ({} mm) must be below z_m_max ({} mm)",
            l.z_m_mm[0], l.z_m_mm[1]
        ));
    }
    if l.f_hz[0] >= l.f_hz[1] {
        return Err(format!(
            "omega_m_min ({} Hz) must be below omega_m_max ({} Hz)",
            l.f_hz[0], l.f_hz[1]
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg() -> RigConfig {
        RigConfig::parse(
            r#"
[robot]
host = "127.0.0.1"
z_tcp_at_zero_m = 0.4
[stepper]
device = "/dev/null"
velocity_per_hz = 51200.0
[camera]
kind = "emulated"
mm_per_px = 0.05
[limits]
z_m_mm = [3.5, 23.5]
f_hz = [1.0, 10.0]
z_rate_mm_s = 10.0
f_rate_hz_s = 2.0
"#,
            std::path::Path::new("rig.toml"),
        )
        .unwrap()
    }

    fn name(v: u32) -> &'static str {
        crate::table::model_info()
            .variables
            .iter()
            .find(|x| x.vr == v)
            .map_or("?", |x| x.name)
    }

    #[test]
    fn limits_narrow_and_never_widen() {
        let c = cfg();
        let set = BTreeMap::from([
            (vr::Z_M_MIN, 0.005),
            (vr::OMEGA_M_MAX, 6.0 * std::f64::consts::TAU),
        ]);
        let n = apply(&c, &set, name).unwrap();
        assert!((n.limits.z_m_mm[0] - 5.0).abs() < 1e-9);
        assert!((n.limits.f_hz[1] - 6.0).abs() < 1e-9);
        assert_eq!(n.limits.z_m_mm[1], 23.5);
        // The config's own values (what a tool writes back from the XML) are accepted.
        let same = BTreeMap::from([(vr::Z_M_MAX, 0.0235), (vr::Z_M_RATE_MAX, 0.01)]);
        assert!(apply(&c, &same, name).is_ok());
        let e = apply(&c, &BTreeMap::from([(vr::Z_M_MAX, 0.030)]), name).unwrap_err();
        assert!(e.contains("z_m_max") && e.contains("not widen"), "{e}");
        let e = apply(&c, &BTreeMap::from([(vr::Z_M_RATE_MAX, 0.02)]), name).unwrap_err();
        assert!(e.contains("z_m_rate_max"), "{e}");
        let e = apply(
            &c,
            &BTreeMap::from([(vr::Z_M_MIN, 0.02), (vr::Z_M_MAX, 0.01)]),
            name,
        )
        .unwrap_err();
        assert!(e.contains("below"), "{e}");
    }

    #[test]
    fn calibration_is_read_only() {
        let c = cfg();
        assert!(apply(&c, &BTreeMap::from([(vr::Z_TCP_AT_ZERO, 0.4)]), name).is_ok());
        let e = apply(&c, &BTreeMap::from([(vr::Z_TCP_AT_ZERO, 0.35)]), name).unwrap_err();
        assert!(
            e.contains("z_tcp_at_zero") && e.contains("read-only"),
            "{e}"
        );
        let e = apply(&c, &BTreeMap::from([(vr::PIXEL_SIZE, 1e-4)]), name).unwrap_err();
        assert!(e.contains("pixel_size"), "{e}");
    }
}
