//! Holding a handed-over pose (issue 54 item 1, `mapkeeper_harness::HandoverHold`): a robot
//! kidnapped in W_69 while localising on W_1's map (68 worlds stale), found by the global
//! search at once. Without the hold, `amcl` re-seeded at the right pose drifts 0.28 m off along
//! the changed racks within ten seconds; with registration correcting it for 20 s after the
//! handover, it stays right to the end of the run.

use mapkeeper_localiser::FilterParams;
use mapkeeper_scenario::RecoveryParams;
use mapkeeper_scenario::experiments::kidnap_robot::{KidnapMap, KidnapRobotParams, RobotKidnapTrial, run_kidnap_robot};
use mapkeeper_sim::World;

fn trial(hold_s: f64) -> RobotKidnapTrial {
    let mut r = RecoveryParams::default();
    r.runner.localiser = "amcl".into();
    r.runner.filter = FilterParams::preset("amcl").expect("amcl");
    r.runner.handover_hold.hold_s = hold_s;
    let p =
        KidnapRobotParams { trials: 1, preset: "mapkeeper".into(), maps: vec![KidnapMap::W1], ..Default::default() };
    let out = run_kidnap_robot(&World::default_warehouse(), &r, &p, 40, &|| {}).expect("kidnap-robot");
    let t = out.trials.into_iter().next().expect("one trial");
    assert_eq!(t.draw.world, 69, "the draw of seed 40's trial 0 moved: {:?}", t.draw);
    assert!(t.applied && t.pose_found_s == Some(0.0), "found at the first Lost: {t:?}");
    assert_eq!((t.handovers_right, t.wrong_pose_recoveries), (1, 0), "{t:?}");
    t
}

#[test]
fn a_handover_is_held_through_a_stale_stretch_only_with_the_hold() {
    let off = trial(0.0);
    assert_eq!(off.handovers_held, 0, "without the hold the filter drifts off: {off:?}");
    let on = trial(20.0);
    assert_eq!(on.handovers_held, 1, "with the hold the handover holds to the end: {on:?}");
    assert!(on.recovered_pose_updating && on.recovery_s.is_some_and(|s| s < 1.0), "{on:?}");
}
