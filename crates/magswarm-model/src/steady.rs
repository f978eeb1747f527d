//! Stiffness (7), frequency term (6) and steady-state map (5), with their analytic Jacobian.
//!
//! Inputs are SI (z_m in m, omega_m in rad/s); radii are in mm, the unit of Table I's C_i.
//! The seed's |omega| is used throughout (5)-(7); the sign of omega only enters through the
//! chain rule (d|omega|/d omega), so effects that need the direction can be added on top.

use crate::envelope::Validity;
use crate::field::FieldAtSwarm;
use crate::Model;

/// Everything the steady map computes at one operating point.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SteadyPoint {
    /// Field quantities at the swarm (SI).
    pub field: FieldAtSwarm,
    /// Stiffness S_x (7), floored [-].
    pub s_x: f64,
    /// Stiffness S_y (7), floored [-].
    pub s_y: f64,
    /// Frequency term Phi (6) [-].
    pub phi: f64,
    /// Steady radius r1 (5) \[mm\].
    pub r1: f64,
    /// Steady radius r2 (5) \[mm\].
    pub r2: f64,
    /// d(S_x, S_y)/d(z_m, omega_m): rows S_x, S_y; columns [1/m, s/rad].
    pub ds: [[f64; 2]; 2],
    /// d(r1, r2)/d(z_m, omega_m): rows r1, r2; columns [mm/m, mm s/rad].
    pub jac: [[f64; 2]; 2],
    /// Where the evaluation stands relative to the validated envelope and the model's floors.
    pub validity: Validity,
}

impl SteadyPoint {
    /// Radii as an array \[mm\].
    pub fn radii(&self) -> [f64; 2] {
        [self.r1, self.r2]
    }
}

/// Normalised frequency w = |omega| / omega_ref and dw/domega.
pub(crate) fn norm_freq(model: &Model, omega: f64) -> (f64, f64) {
    norm_freq_with::<true>(model, omega)
}

/// [`norm_freq`], with dw/domega only `WITH_JACOBIAN` (else 0: one division less).
#[inline(always)]
pub(crate) fn norm_freq_with<const WITH_JACOBIAN: bool>(model: &Model, omega: f64) -> (f64, f64) {
    let omega_ref = std::f64::consts::TAU * model.steady.f_ref;
    let dw = if WITH_JACOBIAN {
        omega.signum() / omega_ref
    } else {
        0.0
    };
    (omega.abs() / omega_ref, dw)
}

/// The swarm's normalised rotation rate `(w_eff, dw_eff/domega, dw_eff/dz_m)`: w itself
/// unless the `phase_lag` effect makes the swarm step out.
#[inline]
pub(crate) fn swarm_rate(model: &Model, w: f64, dw: f64, field: &FieldAtSwarm) -> (f64, f64, f64) {
    match &model.effects.phase_lag {
        None => (w, dw, 0.0),
        Some(pl) => pl.effective(model, w, dw, field),
    }
}

/// The radii (5) r_i = C_i Phi / S_i^alpha_i and their Jacobian over (z_m, omega) from the
/// stiffnesses `s`, their derivatives `ds` and Phi with d ln Phi / d omega: the last step of
/// the map, shared by the exact evaluation and the map table (which must agree bit for bit
/// where it holds the same S and Phi). The Jacobian only `WITH_JACOBIAN` (else zero); the
/// radii are the same expressions either way. `s_alpha` is `[S_x^alpha_1, S_y^alpha_2]` ([`crate::fastpow`]'s powers; the map
/// table looks their tables up once, not per call).
#[inline(always)]
pub(crate) fn radii<const WITH_JACOBIAN: bool>(
    p: &crate::params::SteadyParams,
    s_alpha: [f64; 2],
    s: [f64; 2],
    ds: &[[f64; 2]; 2],
    phi: f64,
    dlnphi_dw: f64,
) -> ([f64; 2], [[f64; 2]; 2]) {
    let r1 = p.C_1 * phi / s_alpha[0];
    let r2 = p.C_2 * phi / s_alpha[1];
    if !WITH_JACOBIAN {
        return ([r1, r2], [[0.0; 2]; 2]);
    }
    let jac = [
        [
            -p.alpha_1 * r1 / s[0] * ds[0][0],
            r1 * (dlnphi_dw - p.alpha_1 / s[0] * ds[0][1]),
        ],
        [
            -p.alpha_2 * r2 / s[1] * ds[1][0],
            r2 * (dlnphi_dw - p.alpha_2 / s[1] * ds[1][1]),
        ],
    ];
    ([r1, r2], jac)
}

/// x^e and d(x^e)/dx for x >= 0, finite at x = 0 (the derivative is then taken as 0 for
/// e < 1: the map is only used away from omega = 0, and a finite slope keeps Newton sane).
/// The power is [`crate::fastpow`]'s, within its proven relative bound (< 1e-13 for the
/// paper's exponents) of the exact one.
/// The derivative only `WITH_JACOBIAN` (else 0).
#[inline]
fn pow_d<const WITH_JACOBIAN: bool>(x: f64, e: f64) -> (f64, f64) {
    if x <= 0.0 {
        (if e == 0.0 { 1.0 } else { 0.0 }, 0.0)
    } else {
        let v = crate::fastpow::pow(x, e);
        (v, if WITH_JACOBIAN { e * v / x } else { 0.0 })
    }
}

/// Evaluate (5)-(7) and their Jacobian at (z_m \[m\], omega [rad/s]).
pub fn evaluate(model: &Model, z_m: f64, omega: f64) -> SteadyPoint {
    if model.effects.learned.iter().any(|t| t.on_steady_map()) {
        return with_learned(model, z_m, omega);
    }
    evaluate_core::<true>(model, z_m, omega)
}

/// [`evaluate`] without the Jacobian: the same values, bit for bit (the same expressions),
/// with `ds`, `jac` and the field's z-derivatives but `db_dz` left at 0. What an input
/// change needs to step ODE (4); a plant computes the Jacobian when asked for it
/// ([`crate::dynamics::InputTerms::with_jacobian`]). With an effect that acts on the map
/// (whose rate or centroid may read the field's derivatives) this is [`evaluate`] itself.
pub(crate) fn evaluate_values(model: &Model, z_m: f64, omega: f64) -> SteadyPoint {
    if !plain_map(model) {
        return evaluate(model, z_m, omega);
    }
    evaluate_core::<false>(model, z_m, omega)
}

/// Whether the map of `model` is the plain (5)-(7): no effect acts on it (no centroid offset,
/// phase lag, cohesion loss or learned term on the map). Then its values never read its
/// Jacobian (an input change of a plant skips it) and the map table can hold it.
pub fn plain_map(model: &Model) -> bool {
    let fx = &model.effects;
    fx.centroid_offset.is_none()
        && fx.phase_lag.is_none()
        && fx.cohesion_loss.is_none()
        && !fx.learned.iter().any(|t| t.on_steady_map())
}

/// The steady map with the learned terms that act on it (`effects.learned` along f or z_m):
/// a rate deficit re-evaluates the map at the slowed rotation, then added and relative
/// corrections follow in list order; the Jacobian by the chain rule.
fn with_learned(model: &Model, z_m: f64, omega: f64) -> SteadyPoint {
    use crate::learned::{LearnedAxis, LearnedMode, LearnedTerm};
    let tau = std::f64::consts::TAU;
    let sign = if omega < 0.0 { -1.0 } else { 1.0 };
    // The axis variable of a term and its derivatives (d/dz_m [1/m], d/domega [s/rad]), and
    // the amplitude (B/B_ref)^a with d/dz_m, at a field point.
    let arg = |t: &LearnedTerm, f_hz: f64, fl: &FieldAtSwarm| -> (f64, f64, f64, f64, f64) {
        let bn = (fl.b / model.steady.B_ref).max(1e-300);
        let dlnb = fl.db_dz / fl.b;
        let amp = bn.powf(t.amplitude_exponent);
        let damp = t.amplitude_exponent * amp * dlnb;
        match t.axis {
            LearnedAxis::FHz => {
                let sc = bn.powf(-t.field_exponent);
                let x = f_hz * sc;
                (x, -t.field_exponent * x * dlnb, sign * sc / tau, amp, damp)
            }
            _ => (z_m * 1e3, 1e3, 0.0, amp, damp),
        }
    };
    let steady_terms = || model.effects.learned.iter().filter(|t| t.on_steady_map());
    // Rate deficits first: the map at f - deficit.
    let f_hz = omega.abs() / tau;
    let field0 = match &model.effects.centroid_offset {
        None => model.magnet.at(z_m),
        Some(c) => c.magnet(&model.magnet).at(z_m),
    };
    let (mut def, mut ddef_dz, mut ddef_dw) = (0.0, 0.0, 0.0);
    for t in steady_terms().filter(|t| t.mode == LearnedMode::RateHz) {
        let (x, dxz, dxw, amp, damp) = arg(t, f_hz, &field0);
        let (v, s) = t.value(x);
        def += v[0] * amp;
        ddef_dz += s[0] * dxz * amp + v[0] * damp;
        ddef_dw += s[0] * dxw * amp;
    }
    let mut sp = if def != 0.0 || ddef_dz != 0.0 || ddef_dw != 0.0 {
        let f_e = (f_hz - def).max(1e-6);
        let clamped = f_hz - def < 1e-6;
        let omega_e = sign * tau * f_e;
        let mut sp = evaluate_core::<true>(model, z_m, omega_e);
        // d omega_e / d z_m and d omega_e / d omega.
        let (dwe_dz, dwe_dw) = if clamped {
            (0.0, 0.0)
        } else {
            (-sign * tau * ddef_dz, 1.0 - sign * tau * ddef_dw)
        };
        for i in 0..2 {
            let dr_dw = sp.jac[i][1];
            sp.jac[i][0] += dr_dw * dwe_dz;
            sp.jac[i][1] = dr_dw * dwe_dw;
            let ds_dw = sp.ds[i][1];
            sp.ds[i][0] += ds_dw * dwe_dz;
            sp.ds[i][1] = ds_dw * dwe_dw;
        }
        sp
    } else {
        evaluate_core::<true>(model, z_m, omega)
    };
    for t in steady_terms().filter(|t| t.mode != LearnedMode::RateHz) {
        let (x, dxz, dxw, amp, damp) = arg(t, f_hz, &sp.field);
        let (v, s) = t.value(x);
        let mut r = [sp.r1, sp.r2];
        for i in 0..2 {
            let c = v[i] * amp;
            let dc = [s[i] * dxz * amp + v[i] * damp, s[i] * dxw * amp];
            match t.mode {
                LearnedMode::Relative => {
                    let g = 1.0 + c;
                    for j in 0..2 {
                        sp.jac[i][j] = sp.jac[i][j] * g + r[i] * dc[j];
                    }
                    r[i] *= g;
                }
                _ => {
                    for j in 0..2 {
                        sp.jac[i][j] += dc[j];
                    }
                    r[i] += c;
                }
            }
        }
        sp.r1 = r[0];
        sp.r2 = r[1];
    }
    sp
}

/// The steady map (5)-(7) with the parametric effects (no learned terms); its Jacobian only
/// `WITH_JACOBIAN` (the values are the same expressions either way, so they agree bit for
/// bit). Without it, only for a map no effect acts on ([`evaluate_values`]).
fn evaluate_core<const WITH_JACOBIAN: bool>(model: &Model, z_m: f64, omega: f64) -> SteadyPoint {
    let p = &model.steady;
    let c = &model.conventions;
    let mut validity = model.envelope.classify(z_m, omega);
    let fx = &model.effects;
    let field = match &fx.centroid_offset {
        None => model.magnet.at_with::<WITH_JACOBIAN>(z_m),
        Some(c) => c.magnet(&model.magnet).at(z_m),
    };
    let (w, dw) = norm_freq_with::<WITH_JACOBIAN>(model, omega);

    // Curvature terms a_K |k / unit|^gamma.
    let kx = field.k_xx.abs() / c.k_unit_t2_per_m2;
    let ky = field.k_yy.abs() / c.k_unit_t2_per_m2;
    let (kx_g, kx_gd) = pow_d::<WITH_JACOBIAN>(kx, p.gamma_1);
    let (ky_g, ky_gd) = pow_d::<WITH_JACOBIAN>(ky, p.gamma_2);

    // Gradient term a_G (g_z / unit)^rho.
    let g = field.g_z / c.g_unit_t_per_m;
    let (g_r, g_rd) = pow_d::<WITH_JACOBIAN>(g, p.rho);

    // The swarm's rotation rate: |omega| unless the `phase_lag` effect makes it step out.
    // It drives Phi (6) and the particle interaction term of (7) (the particles' own
    // rotation sets their hydrodynamic interaction); without the effect it is w itself.
    let (wf, dwf, dwf_dz) = swarm_rate(model, w, dw, &field);

    // Particle term a_P (B/B_ref)^mu_P [1 + log(1 + c_P w^q_P)].
    let bn = field.b / p.B_ref;
    let (b_mu, b_mud) = pow_d::<WITH_JACOBIAN>(bn, p.mu_P);
    let (w_qp, w_qpd) = pow_d::<WITH_JACOBIAN>(wf, p.q_P);
    let mut arg = 1.0 + p.c_P * w_qp;
    let mut darg_dw = p.c_P * w_qpd;
    if arg < c.log_arg_floor {
        arg = c.log_arg_floor;
        darg_dw = 0.0;
        validity.log_clamped = true;
    }
    let l = 1.0 + c.log_base.log(arg);
    let part = p.a_P * b_mu * l;
    let common = p.s_0 + p.a_G * g_r + part;
    let raw_x = common + p.a_K1 * kx_g;
    let raw_y = common + p.a_K2 * ky_g;
    let mut ds = [[0.0; 2]; 2];
    if WITH_JACOBIAN {
        let dkx_dz = field.k_xx.signum() * field.dk_xx_dz / c.k_unit_t2_per_m2;
        let dky_dz = field.k_yy.signum() * field.dk_yy_dz / c.k_unit_t2_per_m2;
        let dg_dz = field.dg_z_dz / c.g_unit_t_per_m;
        let dl_dw = c.log_base.dlog(arg) * darg_dw;
        let mut dpart_dz = p.a_P * b_mud * (field.db_dz / p.B_ref) * l;
        if dwf_dz != 0.0 {
            dpart_dz += p.a_P * b_mu * dl_dw * dwf_dz;
        }
        let dpart_dw = p.a_P * b_mu * dl_dw * dwf;
        let dcommon_dz = p.a_G * g_rd * dg_dz + dpart_dz;
        ds = [
            [dcommon_dz + p.a_K1 * kx_gd * dkx_dz, dpart_dw],
            [dcommon_dz + p.a_K2 * ky_gd * dky_dz, dpart_dw],
        ];
    }
    let s_x = if raw_x < c.s_floor {
        validity.s_floored = true;
        ds[0] = [0.0, 0.0];
        c.s_floor
    } else {
        raw_x
    };
    let s_y = if raw_y < c.s_floor {
        validity.s_floored = true;
        ds[1] = [0.0, 0.0];
        c.s_floor
    } else {
        raw_y
    };
    let (s_x, s_y) = match &fx.cohesion_loss {
        None => (s_x, s_y),
        Some(cl) => {
            // Confinement fading past z_c: S_i c(z).
            let (f, df) = cl.factor(z_m);
            let s = [s_x, s_y];
            for i in 0..2 {
                ds[i] = [f * ds[i][0] + s[i] * df, f * ds[i][1]];
            }
            (s_x * f, s_y * f)
        }
    };

    // Phi (6), at the swarm's rotation rate.
    let (w_q, w_qd) = pow_d::<WITH_JACOBIAN>(wf, p.q);
    let phi = (p.N * (w_q - 1.0)).exp();
    let dlnphi_dw = p.N * w_qd * dwf;

    let s_alpha = [
        crate::fastpow::pow(s_x, p.alpha_1),
        crate::fastpow::pow(s_y, p.alpha_2),
    ];
    let ([r1, r2], mut jac) = radii::<WITH_JACOBIAN>(p, s_alpha, [s_x, s_y], &ds, phi, dlnphi_dw);
    if WITH_JACOBIAN && dwf_dz != 0.0 {
        let dlnphi_dz = p.N * w_qd * dwf_dz;
        jac[0][0] += r1 * dlnphi_dz;
        jac[1][0] += r2 * dlnphi_dz;
    }
    SteadyPoint {
        field,
        s_x,
        s_y,
        phi,
        r1,
        r2,
        ds,
        jac,
        validity,
    }
}

/// Phi (6) alone at |omega| (without effects), for the collapse plot (Fig. 5).
pub fn phi(model: &Model, omega: f64) -> f64 {
    let (w, _) = norm_freq(model, omega);
    (model.steady.N * (w.powf(model.steady.q) - 1.0)).exp()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hz_to_rad_s as hz;

    #[test]
    fn equations_match_hand_computation() {
        let m = Model::paper();
        let (z, f) = (0.0085, 4.0);
        let sp = evaluate(&m, z, hz(f));
        let p = m.steady;
        let c = m.conventions;
        let fl = m.magnet.at(z);
        let w: f64 = f / p.f_ref;
        let l = 1.0 + c.log_base.log(1.0 + p.c_P * w.powf(p.q_P));
        let part = p.a_P * (fl.b / p.B_ref).powf(p.mu_P) * l;
        let grad = p.a_G * (fl.g_z / c.g_unit_t_per_m).powf(p.rho);
        let sx =
            p.s_0 + p.a_K1 * (fl.k_xx.abs() / c.k_unit_t2_per_m2).powf(p.gamma_1) + grad + part;
        let sy =
            p.s_0 + p.a_K2 * (fl.k_yy.abs() / c.k_unit_t2_per_m2).powf(p.gamma_2) + grad + part;
        let phi = (p.N * (w.powf(p.q) - 1.0)).exp();
        assert!((sp.s_x - sx).abs() < 1e-12 && (sp.s_y - sy).abs() < 1e-12);
        assert!((sp.phi - phi).abs() < 1e-14);
        assert!((sp.r1 - p.C_1 * phi / sx.powf(p.alpha_1)).abs() < 1e-12);
        assert!((sp.r2 - p.C_2 * phi / sy.powf(p.alpha_2)).abs() < 1e-12);
        // Phi is 1 at the reference frequency by construction.
        assert!((super::phi(&m, hz(p.f_ref)) - 1.0).abs() < 1e-15);
    }

    /// The map with crate::fastpow's powers stays within 1e-12 (relative) of the same
    /// equations with libm's `powf`, over the whole envelope: the stated tolerance of the
    /// speed-up (each power is within 5e-14, docs/performance.md).
    #[test]
    fn the_fast_powers_change_the_map_by_less_than_1e_12() {
        let m = Model::paper();
        let p = m.steady;
        let c = m.conventions;
        let mut worst: f64 = 0.0;
        for i in 0..=40 {
            for j in 0..=36 {
                let z = 0.0035 + 0.0005 * i as f64;
                let f = 1.0 + 0.25 * j as f64;
                let sp = evaluate(&m, z, hz(f));
                let fl = m.magnet.at(z);
                let w: f64 = f / p.f_ref;
                let l = 1.0 + c.log_base.log(1.0 + p.c_P * w.powf(p.q_P));
                let part = p.a_P * (fl.b / p.B_ref).powf(p.mu_P) * l;
                let grad = p.a_G * (fl.g_z / c.g_unit_t_per_m).powf(p.rho);
                let k = |x: f64, e: f64| (x.abs() / c.k_unit_t2_per_m2).powf(e);
                let sx = (p.s_0 + p.a_K1 * k(fl.k_xx, p.gamma_1) + grad + part).max(c.s_floor);
                let sy = (p.s_0 + p.a_K2 * k(fl.k_yy, p.gamma_2) + grad + part).max(c.s_floor);
                let phi = (p.N * (w.powf(p.q) - 1.0)).exp();
                let r1 = p.C_1 * phi / sx.powf(p.alpha_1);
                let r2 = p.C_2 * phi / sy.powf(p.alpha_2);
                worst = worst
                    .max(((sp.r1 - r1) / r1).abs())
                    .max(((sp.r2 - r2) / r2).abs());
            }
        }
        assert!(worst < 1e-12, "relative difference {worst:e}");
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let m = Model::paper();
        for &z in &[0.0035, 0.0085, 0.0185, 0.0235] {
            for &f in &[1.0, 3.0, 6.0, 9.5] {
                let om = hz(f);
                let sp = evaluate(&m, z, om);
                let (hz_, ho) = (1e-7, 1e-5);
                let (zp, zm) = (evaluate(&m, z + hz_, om), evaluate(&m, z - hz_, om));
                let (op, omn) = (evaluate(&m, z, om + ho), evaluate(&m, z, om - ho));
                let fd = [
                    [(zp.r1 - zm.r1) / (2.0 * hz_), (op.r1 - omn.r1) / (2.0 * ho)],
                    [(zp.r2 - zm.r2) / (2.0 * hz_), (op.r2 - omn.r2) / (2.0 * ho)],
                ];
                for i in 0..2 {
                    for j in 0..2 {
                        let (a, b) = (sp.jac[i][j], fd[i][j]);
                        assert!(
                            (a - b).abs() <= 1e-5 * b.abs().max(1e-3),
                            "z {z} f {f} J[{i}][{j}] analytic {a} fd {b}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn negative_omega_gives_same_radii_and_mirrored_slope() {
        let m = Model::paper();
        let a = evaluate(&m, 0.01, hz(5.0));
        let b = evaluate(&m, 0.01, -hz(5.0));
        assert_eq!(a.r1, b.r1);
        assert_eq!(a.jac[0][1], -b.jac[0][1]);
    }
}
