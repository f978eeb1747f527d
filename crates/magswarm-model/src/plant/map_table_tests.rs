use super::*;
use crate::hz_to_rad_s as hz;

fn sweep(p: &mut Plant, from: usize, to: usize) {
    for k in from..to {
        let s = (k as f64 * 0.013).sin();
        p.set_inputs(0.0085 + 0.004 * s, hz(5.0 + 3.0 * s));
        p.step(0.01).unwrap();
    }
}

/// A plant with the map table follows the exact one within a nanometre through a sweep
/// of both inputs, and its snapshots (taken before and after the table comes into force)
/// replay it bit for bit.
#[test]
fn table_plant_tracks_the_exact_plant_and_replays_from_snapshots() {
    let mut exact = Plant::new(Model::paper(), 0.0085, hz(4.0));
    let mut fast = exact.clone();
    fast.use_map_table_after(50, None);
    assert!(fast.map_table().is_none(), "built before it is needed");
    sweep(&mut exact, 0, 30);
    sweep(&mut fast, 0, 30);
    let early = fast.snapshot();
    assert_eq!(early.map_pending, 20);
    sweep(&mut exact, 30, 400);
    sweep(&mut fast, 30, 400);
    assert!(fast.map_table().is_some());
    let late = fast.snapshot();
    let (a, b) = (exact.state(), fast.state());
    assert!(
        (a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9,
        "{a:?} {b:?}"
    );
    // Replays: from the early snapshot (the table comes into force on the way) and from
    // the late one (adopting the table already built).
    let mut from_early = Plant::from_snapshot(Model::paper(), &early);
    sweep(&mut from_early, 30, 400);
    assert_eq!(from_early.state(), fast.state());
    let mut from_late = Plant::from_snapshot_sharing(Model::paper(), &late, fast.map_table());
    let mut again = fast.clone();
    sweep(&mut from_late, 400, 600);
    sweep(&mut again, 400, 600);
    assert_eq!(from_late, again);
    assert_eq!(from_late.state(), again.state());
    // With an effect on the map the setting is kept but the map stays exact.
    let mut m = Model::paper();
    m.effects.cohesion_loss = Some(crate::effects::CohesionLoss {
        z_c_mm: 15.0,
        k_per_mm2: 0.01,
    });
    let mut p = Plant::new(m, 0.0085, hz(4.0));
    p.use_map_table(true);
    assert!(p.map_table().is_none() && p.snapshot().map_table);
}

/// Plants of the same map parameters share one table (its cells are built once per
/// process), a plant of another map gets its own, and a plant on the shared table (cells
/// built by another plant, in another thread) is bit for bit the plant on a table of its
/// own: who built a cell changes no value.
#[test]
fn plants_of_one_map_share_the_table_and_it_changes_no_value() {
    let mut a = Plant::new(Model::paper(), 0.0085, hz(4.0));
    a.use_map_table_after(0, None);
    let mut b = Plant::new(Model::paper(), 0.0085, hz(4.0));
    b.use_map_table_after(0, None);
    let (ta, tb) = (a.map_table().unwrap(), b.map_table().unwrap());
    assert!(Arc::ptr_eq(ta, tb), "same map, one table");
    let mut other = Model::paper();
    other.steady.C_1 *= 1.01;
    let mut c = Plant::new(other, 0.0085, hz(4.0));
    c.use_map_table_after(0, None);
    assert!(
        !Arc::ptr_eq(ta, c.map_table().unwrap()),
        "another map, another table"
    );
    // Warm the shared cells from another thread, then compare with a private table.
    std::thread::spawn(move || sweep(&mut a, 0, 300))
        .join()
        .unwrap();
    let private = Arc::new(MapTable::new(&Model::paper()).unwrap());
    let mut own = Plant::new(Model::paper(), 0.0085, hz(4.0));
    own.use_map_table_after(0, Some(&private));
    assert!(Arc::ptr_eq(own.map_table().unwrap(), &private));
    sweep(&mut b, 0, 300);
    sweep(&mut own, 0, 300);
    assert_eq!(b.state(), own.state());
    assert_eq!(b.snapshot(), own.snapshot());
}
