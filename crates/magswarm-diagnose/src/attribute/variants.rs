//! The candidates and their variants: a learned shape along each effect's axis, the library
//! form's correction where an effect has no axis, and the local anomaly.

use super::*;

/// A candidate: an effect, or the local anomaly no effect describes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Cand {
    /// An effect.
    Effect(EffectKind),
    /// The strongest small box of operating points.
    Anomaly,
}

impl Cand {
    /// Name in tables and reports.
    pub(super) fn name(self) -> &'static str {
        match self {
            Cand::Effect(k) => k.name(),
            Cand::Anomaly => "local_anomaly",
        }
    }

    /// The effect, if one.
    pub(super) fn kind(self) -> Option<EffectKind> {
        match self {
            Cand::Effect(k) => Some(k),
            Cand::Anomaly => None,
        }
    }

    /// The gap-test families (`detect`) whose alternatives see this candidate's structure: a
    /// drift over session time, a formation after the input changes, every other candidate
    /// over the operating points (the surface over (z_m, f) or the point means).
    pub(super) fn seen_by(self) -> &'static [&'static str] {
        match self {
            Cand::Effect(EffectKind::ParticleDrift) => &["drift"],
            Cand::Effect(EffectKind::FormationLag) => &["formation"],
            _ => &["inputs", "lack_of_fit"],
        }
    }
}

/// One variant of a candidate: its columns (and penalty), or a box found per log.
#[derive(Debug, Clone)]
pub(super) enum Variant {
    Shape(Family),
    Column(&'static str, DMatrix<f64>),
    Columns(&'static str, DMatrix<f64>, DMatrix<f64>),
    Anomaly,
    /// The strongest band over f at every z_m, found on each residual (real or simulated):
    /// heights free over the band's frequencies, pinned at 0 at the levels beside it.
    Band,
}

/// The candidates and their variants.
pub(super) fn variants(lin: &Linear) -> Vec<(Cand, Vec<Variant>)> {
    let ds = lin.ds;
    let (zs, fs) = ds.levels();
    let rc = &lin.rc;
    let smooths = [0.01, 0.1, 1.0];
    let mut out: Vec<(Cand, Vec<Variant>)> = Vec::new();
    // Effects on the steady map act in mm or in proportion to the radius (a change of Phi
    // (6) or of the stiffness scales the radii): both modes are variants. A step-out is above
    // all a deficit of the swarm's rotation rate, acting through the map's own sensitivity to
    // the drive (one deficit for both radii).
    let mut v = Vec::new();
    // Every variant widens the candidate's null: the phase lag's forms are searched at two
    // smoothings only, and the onset that moves with the field (nu = 1, the step-out's
    // physics) only as a rate deficit; bands and roll-offs in mm or in proportion to the
    // radius run over the drive frequency itself.
    for (nu, modes) in [
        (0.0, &[Mode::Rate, Mode::Add, Mode::Relative][..]),
        (1.0, &[Mode::Rate][..]),
    ] {
        let xs = rc.xs(Axis::F { nu });
        for &mode in modes {
            for s in [0.1, 1.0] {
                let knots = shapes::knots_of(&xs, fs.len().clamp(2, 10));
                // No lag at the lowest frequency: the swarm follows a slow field. A height
                // there would trade with the baseline's gains and with Phi (6) over every
                // frequency, and the written model would carry that trade between the
                // measured frequencies.
                v.push(Variant::Shape(Family {
                    pin_first: true,
                    ..Family::new(Axis::F { nu }, mode, knots, s)
                }));
            }
        }
    }
    // A step-out band: a run of frequencies where the swarm departs from the map at every
    // z_m, with edges sharper than a smoothed shape over the whole range allows.
    v.push(Variant::Band);
    out.push((Cand::Effect(EffectKind::PhaseLag), v));
    // A cohesion loss loosens the whole swarm: both radii grow together past an onset (a
    // relative change shared by both radii), or it shows in one radius only. It never
    // stretches one principal radius while squeezing the other: that is an aspect change,
    // the signature of an off-axis swarm, and a cohesion shape free per radius would take
    // it from `centroid_offset`.
    let mut v = Vec::new();
    let kz = shapes::knots_of(&zs, 8);
    for s in smooths {
        v.push(Variant::Shape(Family::new(
            Axis::Z,
            Mode::Common,
            kz.clone(),
            s,
        )));
    }
    // The two principal stiffnesses of (7) differ, so a loosening swarm need not grow by
    // the same share along both principal directions: besides equal, r1's share half or
    // twice r2's (at one smoothing: every variant widens the candidate's null). Still both
    // radii the same way, never the aspect change of an off-axis swarm.
    for ratio in [0.5, 2.0] {
        v.push(Variant::Shape(Family {
            ratio,
            ..Family::new(Axis::Z, Mode::Common, kz.clone(), 0.1)
        }));
    }
    for axes in [[true, false], [false, true]] {
        for s in [0.1, 1.0] {
            v.push(Variant::Shape(Family {
                axes,
                ..Family::new(Axis::Z, Mode::Add, kz.clone(), s)
            }));
        }
    }
    // Chains break where the viscous torque of the rotating field outgrows the magnetic
    // attraction that holds them: the Mason number, Mn ~ f / B^2. A loosening past an onset
    // in Mn sets in earlier (at a smaller z_m) the faster the field turns, which no shape
    // over z_m alone follows on a design that spreads f at each depth. A shape over
    // f (B/B_mid)^-2, held at 0 at the lowest Mn (below the onset nothing loosens; a height
    // there would trade with the baseline's gains): both radii together, or r2 alone (the
    // chains along the long axis), at one smoothing each.
    let xm = rc.xs(Axis::F { nu: 2.0 });
    let km = shapes::knots_of(&xm, 8);
    for (mode, axes) in [(Mode::Common, [true, true]), (Mode::Add, [false, true])] {
        v.push(Variant::Shape(Family {
            axes,
            pin_first: true,
            ..Family::new(Axis::F { nu: 2.0 }, mode, km.clone(), 1.0)
        }));
    }
    out.push((Cand::Effect(EffectKind::CohesionLoss), v));
    if let Some(f) = detect::since_family(rc, 0.1, 6) {
        let mut v: Vec<Variant> = smooths
            .iter()
            .map(|&s| {
                Variant::Shape(Family {
                    smooth: s,
                    ..f.clone()
                })
            })
            .collect();
        // A swarm that forms one way when it grows and another when it contracts: the
        // transient after the changes that make a radius grow only, or shrink only.
        for steps in [Steps::Growing, Steps::Shrinking] {
            v.push(Variant::Shape(Family {
                smooth: 1.0,
                steps,
                ..f.clone()
            }));
        }
        // A transient that grows with the step's size, not in proportion to it (a rate
        // limit: a large change takes longer, a small one hardly longer than the rig's own
        // approach). No approach law of a rig that is linear in the step makes it, which is
        // why the gap tests judge it beside every such course (`since_size_within`). Heights
        // relative to the mean step's size. Named on what varies within the visits only (the
        // whole shape enters the model): as a shape that also moves the visits' means it
        // widened the null of every such formation shape (a slow growth at 2x lost its name,
        // p 0.008 -> 0.02).
        let sizes: Vec<f64> = rc
            .delta
            .iter()
            .flat_map(|d| d.iter().copied())
            .filter(|d| *d != 0.0)
            .map(f64::abs)
            .collect();
        if !sizes.is_empty() {
            let mean = crate::stats::mean(&sizes);
            if mean > 0.0 && mean.is_finite() {
                v.push(Variant::Shape(Family {
                    smooth: 1.0,
                    size_mm: mean,
                    within: true,
                    ..f.clone()
                }));
            }
        }
        // The same within each visit: once the baseline's time scale has taken the average
        // approach, what is left of a one-sided transient is small beside the visits' offsets
        // and plain beside the row noise.
        for steps in [Steps::Growing, Steps::Shrinking] {
            v.push(Variant::Shape(Family {
                smooth: 1.0,
                steps,
                within: true,
                ..f.clone()
            }));
        }
        // Any stable transient, an underdamped one included: knots as dense as the rows'
        // times since a change allow, where they resolve more than the coarse family does.
        if let Some(fine) = detect::since_family(rc, 0.01, detect::SINCE_FINE_KNOTS)
            .filter(|g| g.knots.len() > f.knots.len())
        {
            // Named also on what varies within each visit alone (judged against the row
            // noise, not the visits' offsets); the whole shape enters the model.
            v.push(Variant::Shape(Family {
                within: true,
                ..fine.clone()
            }));
            v.push(Variant::Shape(fine));
        }
        out.push((Cand::Effect(EffectKind::FormationLag), v));
    }
    out.push((
        Cand::Effect(EffectKind::ParticleDrift),
        smooths
            .iter()
            .map(|&s| {
                Variant::Shape(Family {
                    monotone: Some(Monotone::Either),
                    ..Family::new(Axis::T, Mode::Relative, shapes::knots_of(&rc.t, 8), s)
                })
            })
            .collect(),
    ));
    // Centroid offset: off the field's axis the swarm sees another curvature along its two
    // principal directions, so its aspect changes with depth (stretched along one, squeezed
    // along the other; a learned shape over z_m, one value for both radii), and the
    // correction its library form makes at a few distances (amplitude free), each a column.
    // The two principal directions need not deform equally: besides equal (at two
    // smoothings), one twice the other, either way (at one smoothing: every variant widens
    // the candidate's null). The knots are cohesion_loss's, on the same axis.
    let mut cv = Vec::new();
    for (ratio, s) in [(1.0, 0.1), (1.0, 1.0), (0.5, 1.0), (2.0, 1.0)] {
        cv.push(Variant::Shape(Family {
            ratio,
            ..Family::new(Axis::Z, Mode::Aspect, kz.clone(), s)
        }));
    }
    // Off the axis the field the swarm sees is no longer symmetric about it, and whatever
    // that does to the swarm (a tilted rotation plane that drives it unevenly over a turn,
    // split curvatures) enters at second order in the swarm's angular offset, (rho/d)^2:
    // the field's expansion about its axis is even in rho. So an aspect change whose size
    // goes with the drive frequency is the same shape over f at every depth, scaled by
    // d^-2, i.e. by (B/B_mid)^(2/3) for the dipole's B ~ d^-3: strongest next to the magnet.
    // A step-out runs the other way (a strong field keeps the swarm in step longer). Unlike
    // a lag, the shape is not held at 0 at the lowest frequency: an uneven drive over a turn
    // acts at any rate, in proportion to it, and the slowest measured field is not a still
    // one; with its d^-2 amplitude a height there is no trade with the baseline's gains.
    let xf = rc.xs(Axis::F { nu: 0.0 });
    for ratio in [0.5, 1.0, 2.0] {
        cv.push(Variant::Shape(Family {
            amp: 2.0 / 3.0,
            ratio,
            ..Family::new(
                Axis::F { nu: 0.0 },
                Mode::Aspect,
                shapes::knots_of(&xf, fs.len().clamp(2, 10)),
                1.0,
            )
        }));
    }
    for o in [3.0, 8.0, 16.0] {
        let mut a = lin.base.clone();
        a.effects.push((EffectKind::CentroidOffset, vec![o]));
        let p = candidates::predict(&a, ds);
        let col = DMatrix::from_fn(2 * ds.rows.len(), 1, |s, _| {
            let (i, ax) = (s / 2, s % 2);
            let d = rc.w[ax] * (p[i][ax] - lin.p0[i][ax]);
            if d.is_finite() {
                d
            } else {
                0.0
            }
        });
        if col.norm() > 1e-9 {
            // The same correction with an amplitude that may vary over z_m (an axis that is
            // not parallel to the field's: the swarm further off it at some depths than at
            // others), in the library form's own ratio of r1 to r2.
            let kz = shapes::knots_of(&rc.z, 6);
            if kz.len() >= 2 {
                let k = kz.len();
                let mut a = DMatrix::zeros(2 * ds.rows.len(), k);
                for i in 0..ds.rows.len() {
                    for (j, wt) in shapes::hat(&kz, rc.z[i]) {
                        for ax in 0..2 {
                            a[(2 * i + ax, j)] = wt * col[(2 * i + ax, 0)];
                        }
                    }
                }
                let info = shapes::column_info(&a);
                let info = info.max(1e-12);
                let pen = crate::linear::roughness(k, 1, 0.3 * info, 1e-3 * info);
                cv.push(Variant::Columns("offset, amplitude over z_m", a, pen));
            }
            cv.push(Variant::Column("offset", col));
        }
    }
    if !cv.is_empty() {
        out.push((Cand::Effect(EffectKind::CentroidOffset), cv));
    }
    out.push((
        Cand::Effect(EffectKind::CameraBias),
        vec![Variant::Column(
            "offset",
            DMatrix::from_fn(2 * ds.rows.len(), 1, |s, _| rc.w[s % 2]),
        )],
    ));
    out.push((Cand::Anomaly, vec![Variant::Anomaly]));
    out.retain(|(_, v)| {
        v.iter()
            .all(|x| !matches!(x, Variant::Shape(f) if f.knots.len() < 2))
    });
    out
}

/// Columns, penalty and monotone blocks of a fixed variant.
pub(super) fn columns_of(v: &Variant, rc: &RowCtx) -> Option<Design> {
    match v {
        Variant::Shape(f) => Some(shapes::design(f, rc)),
        Variant::Column(_, c) => Some(Design::new(
            c.clone(),
            DMatrix::identity(c.ncols(), c.ncols()) * 1e-8,
        )),
        Variant::Columns(_, c, p) => Some(Design::new(c.clone(), p.clone())),
        Variant::Anomaly | Variant::Band => None,
    }
}

/// The strongest box among `boxes` of the in-sample residual `e0` (weighted, stacked), per
/// radius, against the visit noise that residual shows.
fn strongest(
    lin: &Linear,
    e0: &DVector<f64>,
    boxes: detect::Boxes,
) -> (f64, usize, (usize, usize), (usize, usize)) {
    let r0 = detect::unweight(e0, lin.rc.w);
    let sd = noise::Roughness::new(lin.ds)
        .visit_sd(&r0)
        .unwrap_or(lin.noise.visit);
    detect::box_scan(lin.ds, &r0, sd, boxes, false)
}

/// The indicator columns (one per axis) of the strongest small box of the in-sample
/// residual `e0` (weighted, stacked).
pub(super) fn anomaly_columns(lin: &Linear, e0: &DVector<f64>) -> (DMatrix<f64>, DMatrix<f64>) {
    let ds = lin.ds;
    let (_, _, zr, fr) = strongest(lin, e0, detect::Boxes::Local);
    let (cell, _, _) = noise::cells(ds);
    let n = ds.rows.len();
    let mut a = DMatrix::zeros(2 * n, 2);
    for (i, r) in ds.rows.iter().enumerate() {
        let (zi, fi) = cell[r.visit];
        if zi >= zr.0 && zi <= zr.1 && fi >= fr.0 && fi <= fr.1 {
            for ax in 0..2 {
                a[(2 * i + ax, ax)] = lin.rc.w[ax];
            }
        }
    }
    (a, DMatrix::identity(2, 2) * 1e-8)
}

/// The strongest band over f at every z_m of the in-sample residual `e0` (weighted,
/// stacked), as a shape over f in mm: heights free at the band's frequency levels (at most
/// 6 knots), pinned at 0 at the levels on either side of it, flat beyond the data. None
/// without a band (fewer than two frequency levels).
pub(super) fn band_family(lin: &Linear, e0: &DVector<f64>) -> Option<Family> {
    let ds = lin.ds;
    let (stat, _, _, fr) = strongest(lin, e0, detect::Boxes::BandsF);
    if stat <= 0.0 {
        return None;
    }
    let (_, fs) = ds.levels();
    let bins = crate::data::level_bins(&fs, 10);
    let (lo, hi) = (bins.get(fr.0)?.0, bins.get(fr.1)?.1);
    let inside: Vec<f64> = fs
        .iter()
        .copied()
        .filter(|&f| f >= lo - 1e-9 && f <= hi + 1e-9)
        .collect();
    let mut knots = shapes::knots_of(&inside, 6);
    let pin_first = fr.0 > 0;
    let pin_last = fr.1 + 1 < bins.len();
    if pin_first {
        knots.insert(0, bins[fr.0 - 1].1);
    }
    if pin_last {
        knots.push(bins[fr.1 + 1].0);
    }
    if knots.windows(2).any(|w| w[1] <= w[0]) {
        return None;
    }
    Some(Family {
        pin_first,
        pin_last,
        ..Family::new(Axis::F { nu: 0.0 }, Mode::Add, knots, 0.1)
    })
}

pub(super) fn describe(v: &Variant) -> String {
    match v {
        Variant::Shape(f) => {
            let mut extra = String::new();
            if f.mode == Mode::Aspect && f.ratio != 1.0 {
                extra += &format!(", r1's relative change {} times r2's", f.ratio);
            }
            if f.mode == Mode::Common && f.ratio != 1.0 {
                extra += &format!(
                    ", both radii growing together, r1's relative change {} times r2's",
                    f.ratio
                );
            }
            if f.amp != 0.0 {
                extra += &format!(", amplitude (B/B_mid)^{:.3}", f.amp);
            }
            match f.steps {
                Steps::All => {}
                Steps::Growing => extra += ", after the changes that make a radius grow",
                Steps::Shrinking => extra += ", after the changes that make a radius shrink",
            }
            if f.size_mm > 0.0 {
                extra += &format!(
                    ", growing with the step's size (x |step| / {:.3} mm)",
                    f.size_mm
                );
            }
            format!(
                "learned shape over {} ({} knots, smoothing {}{extra})",
                f.axis.label(),
                f.knots.len(),
                f.smooth
            )
        }
        Variant::Column(n, _) => format!("library form's {n} (amplitude free)"),
        Variant::Columns(n, ..) => format!("library form's {n}"),
        Variant::Anomaly => "strongest small box of operating points".into(),
        Variant::Band => "strongest band over f at every z_m (mm)".into(),
    }
}
