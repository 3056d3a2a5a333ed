//! The lifelong setting of `experiment kidnap-robot` (issue 54 item 3): the robot kidnapped
//! while localising on M_{k-1}, the map the preset's own updater kept through the chain.
//! The chain an experiment runs is the validation's (same worlds, routes, labels and M_1:
//! the same maps for the same runner), and a kidnap on it must be found.

use mapkeeper_closed_loop::NoClock;
use mapkeeper_closed_loop::setup::prepare;
use mapkeeper_scenario::experiments::kidnap_robot::{KidnapMap, KidnapRobotParams, run_kidnap_robot};
use mapkeeper_scenario::{RecoveryParams, ValidationParams, ValidationRun, run_seed};
use mapkeeper_sim::World;
use std::collections::BTreeSet;

#[test]
fn the_chain_an_experiment_runs_is_the_validations() {
    let mut v = ValidationParams::new(3, "mapkeeper").expect("valid params");
    v.route = ValidationParams::short_route(12.0);
    v.exploration_route = ValidationParams::short_route(20.0);
    v.saved_worlds = vec![2, 3];
    let run = run_seed(&v, 7, &ValidationRun::timed_by(&NoClock), &|_| {}).expect("validation");
    let mut r = RecoveryParams {
        tour: v.route.clone(),
        exploration_route: v.exploration_route.clone(),
        runner: v.runner.clone(),
        ..RecoveryParams::default()
    };
    r.kidnap.stale_max_world = 3;
    let setup = prepare(&World::default_warehouse(), &r, 7).expect("setup");
    assert_eq!(setup.m1, run.initial_map, "M_1 differs");
    let chain = setup.chain_maps(&v.runner, 7, &BTreeSet::from([1, 2, 3])).expect("chain");
    assert_eq!(chain[&1].map, run.initial_map);
    assert!(chain[&1].memory.is_empty(), "M_1 is a survey: nothing remembered");
    for saved in &run.saved {
        assert_eq!(chain[&saved.world].map, saved.map, "M_{} differs from the validation's", saved.world);
    }
    assert_ne!(chain[&3].map, chain[&1].map, "the updater changed nothing in two worlds");
    let e = setup.chain_maps(&v.runner, 7, &BTreeSet::from([4])).expect_err("W_4 was not generated");
    assert!(e.to_string().contains("W_4 was not generated"), "{e}");
}

#[test]
fn a_kidnap_on_the_kept_map_is_found_and_held() {
    let p = KidnapRobotParams {
        trials: 2,
        preset: "mapkeeper".into(),
        maps: vec![KidnapMap::Chain, KidnapMap::Truth],
        ..KidnapRobotParams::quick()
    };
    let r = run_kidnap_robot(&World::default_warehouse(), &RecoveryParams::default(), &p, 41, &|| {})
        .expect("kidnap-robot");
    assert_eq!(r.by_map.len(), 2);
    assert_eq!(r.by_map[0].map, KidnapMap::Chain);
    assert_eq!(r.kidnap_robot, r.by_map[0], "kidnap_robot is the first map's summary");
    assert_eq!(r.trials.len(), 4);
    for t in r.trials.iter().filter(|t| t.map == KidnapMap::Chain) {
        assert!(t.applied, "trial {}: the robot was not moved", t.draw.trial);
        assert!(t.recovered_pose_updating, "trial {} on M_{}: not recovered: {t:?}", t.draw.trial, t.draw.world - 1);
        assert_eq!(t.wrong_pose_recoveries, 0);
        assert!(t.handovers_right >= 1 && t.handovers_held == t.handovers_right, "{t:?}");
    }
    // The same draws on both maps.
    let draws = |m| r.trials.iter().filter(|t| t.map == m).map(|t| t.draw).collect::<Vec<_>>();
    assert_eq!(draws(KidnapMap::Chain), draws(KidnapMap::Truth));
}
