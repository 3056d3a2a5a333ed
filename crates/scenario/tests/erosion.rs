//! Structure retention and change classes on a short validation (3 worlds, a 12 m route): the
//! figures are there in every row, M*_i keeps all structure and gets every class right (by
//! construction: it takes G_i's state wherever the route looks), shares lie in [0, 100], and
//! the summary holds them.

use mapkeeper_closed_loop::NoClock;
use mapkeeper_scenario::{ValidationParams, ValidationRun, run_seed, summarise};

#[test]
fn every_row_has_retention_and_change_classes_and_the_best_map_scores_100() {
    let mut p = ValidationParams::new(3, "paper").expect("valid params");
    p.route = ValidationParams::short_route(12.0);
    p.exploration_route = ValidationParams::short_route(20.0);
    p.saved_worlds = vec![];
    let run = run_seed(&p, 5, &ValidationRun::timed_by(&NoClock), &|_| {}).expect("run");
    for w in &run.rows {
        let r = w.retention.expect("retention in every new row");
        let c = w.change_classes.expect("change classes in every new row");
        eprintln!("W_{}: {r:?}\n  {c:?}", w.world);
        assert!(r.structure_cells > 0, "W_{}: no structure", w.world);
        assert_eq!(r.best_map, 100.0, "W_{}", w.world);
        for v in [r.updated_map, r.fresh_map] {
            assert!((0.0..=100.0).contains(&v), "W_{}: {v}", w.world);
        }
        for k in [c.added, c.removed, c.moved, c.initial_errors] {
            assert_eq!(k.best_map, (k.cells > 0).then_some(100.0), "W_{}: {k:?}", w.world);
            assert_eq!(k.updated_map.is_some(), k.cells > 0);
            assert!(k.updated_map.is_none_or(|v| (0.0..=100.0).contains(&v)));
        }
    }
    let s = summarise(&p, std::slice::from_ref(&run), 0.0);
    let r = s.retention.expect("summary retention");
    assert_eq!((r.rows, r.best_mean, r.target_last), (2, 100.0, 99.0));
    assert_eq!(r.updated_w2, run.rows[0].retention.expect("W_2").updated_map);
    assert_eq!(r.updated_last, run.rows[1].retention.expect("W_3").updated_map);
    assert_eq!(s.change_classes.expect("summary classes").rows, 2);
}
