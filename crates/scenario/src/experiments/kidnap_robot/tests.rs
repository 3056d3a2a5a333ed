//! Unit tests of `kidnap_robot`.

use super::*;
use mapkeeper_grid::GridGeometry;

#[test]
fn the_target_is_free_and_the_drawn_direction_comes_first() {
    let geo = GridGeometry::new(100, 100, 0.1, Pose2::IDENTITY).unwrap_or_else(|e| panic!("{e}"));
    let mut g = OccupancyGrid::filled(geo, CellState::Free);
    // A wall along x = 5 m.
    for y in 0..100 {
        g.cells_mut()[y * 100 + 50] = CellState::Occupied;
    }
    let d = RobotKidnapDraw {
        trial: 0,
        world: 50,
        tour_position_m: 0.0,
        kidnap_s: 3.0,
        displacement_m: 2.0,
        direction_rad: 0.0,
        yaw_rad: 1.0,
    };
    let from = Pose2::new(2.0, 5.0, 0.0);
    let t = kidnap_target(&g, from, &d, 0.5, 0.5).unwrap_or_else(|| panic!("no target"));
    assert!((t.x - 4.0).abs() < 1e-9 && (t.y - 5.0).abs() < 1e-9 && (t.yaw - 1.0).abs() < 1e-9);
    // Towards the wall: another direction is taken, never a pose within 0.5 m of it.
    let from = Pose2::new(3.6, 5.0, 0.0);
    let t = kidnap_target(&g, from, &d, 0.5, 0.5).unwrap_or_else(|| panic!("no target"));
    assert!(t.x < 4.5 && (t.x - from.x).hypot(t.y - from.y) > 0.49, "{t:?}");
    assert!(free_disc(&g, Point2::new(t.x, t.y), 0.5));
    assert_eq!(
        draw_robot_kidnap(&KidnapRobotParams::default(), 70.0, 1, 3),
        draw_robot_kidnap(&KidnapRobotParams::default(), 70.0, 1, 3)
    );
    let dr = draw_robot_kidnap(&KidnapRobotParams::default(), 70.0, 1, 3);
    assert!((50..=100).contains(&dr.world) && (0.5..=3.0).contains(&dr.displacement_m));
}

/// A turn wider than π (its draw's range would be of infinite width at 1e308) and a free
/// disc too large for the check's cell loop to finish are refused by name.
#[test]
fn a_huge_turn_or_free_disc_is_refused_by_name() {
    let mut p = KidnapRobotParams { max_yaw_rad: 1e308, ..KidnapRobotParams::default() };
    let e = p.validate().expect_err("refused").to_string();
    assert!(e.contains("kidnap_robot.max_yaw_rad") && e.contains("at most 2π (a full turn), got 1e308"), "{e}");
    p.max_yaw_rad = PI + 1e-4;
    p.validate().expect("π rounded up is accepted (angles wrap)");
    p.free_radius_m = 1e6;
    let e = p.validate().expect_err("refused").to_string();
    assert!(e.contains("kidnap_robot.free_radius_m") && e.contains("at most 5 m"), "{e}");
}

#[test]
fn lost_is_split_by_how_far_off_the_localiser_was_then() {
    let at = |verdict, error_m, yaw_deg: f64| TimelineSample {
        t_s: 0.0,
        verdict,
        n_valid: 100,
        n_dc: 95,
        error_m,
        yaw_error_rad: yaw_deg.to_radians(),
        recovered: None,
    };
    use mapkeeper_updater::Verdict::{Lost, Suspend};
    // A drifted localiser (0.15 m, 3.7°: right by the success criterion, not well
    // localised), a well-localised one, one 0.3 m off, and a Suspend at a right pose.
    let t = [at(Lost, 0.15, 3.7), at(Lost, 0.04, 1.5), at(Lost, 0.3, 0.5), at(Suspend, 0.01, 0.0)];
    let p = KidnapRobotParams::default();
    let c = mapkeeper_closed_loop::setup::params::SuccessCriterion::default();
    assert_eq!(lost_where(&t, |s| s.error_m < c.max_error_m && s.yaw_error_rad < c.max_yaw_error_rad), 2);
    let well = |s: &TimelineSample| {
        s.error_m <= p.well_localised_max_error_m && s.yaw_error_rad <= p.well_localised_max_yaw_rad
    };
    assert_eq!(lost_where(&t, well), 1);
    assert_eq!(lost_where(&t[..1], well), 0);
}

#[test]
fn the_summary_counts_recoveries_where_the_reference_held_and_false_lost_three_ways() {
    let sc = Scores { cc: 80.0, ms: 70.0, opdf: 90.0 };
    let trial = |k: usize, recovered: bool, reference_final_error_m: f64, lost: [u64; 3]| RobotKidnapTrial {
        draw: draw_robot_kidnap(&KidnapRobotParams::default(), 70.0, 1, k),
        map: KidnapMap::Chain,
        applied: true,
        applied_displacement_m: Some(1.0),
        detected: true,
        detection_delay_s: Some(0.1),
        recovered_pose_updating: recovered,
        recovered_filter: false,
        recovered_global_search: recovered,
        recovery_s: recovered.then_some(2.0),
        pose_found_s: recovered.then_some(1.0),
        reference_final_error_m: Some(reference_final_error_m),
        reference_held: Some(reference_final_error_m < 0.2),
        handovers_right: usize::from(recovered) + 1,
        handovers_held: usize::from(recovered),
        refused_attempts: 0,
        ambiguous_attempts: 0,
        pose_recoveries: usize::from(recovered),
        wrong_pose_recoveries: 0,
        final_error_m: Some(0.05),
        reference_lost: lost[0],
        reference_lost_right_pose: lost[1],
        reference_lost_well_localised: lost[2],
        reference_steps: 100,
        reference_steps_well_localised: 40,
        reference_scores: sc,
        kidnap_scores: sc,
    };
    // Four trials: two whose reference run holds (< 0.2 m at its end), one recovered; two
    // whose reference ends 0.3 m off, one recovered anyway. Lost without kidnap: one run at
    // a well-localised step, one while 0.15 m off, one while 0.5 m off.
    let t = [
        trial(0, true, 0.05, [3, 3, 1]),
        trial(1, false, 0.1, [0, 0, 0]),
        trial(2, true, 0.3, [5, 2, 0]),
        trial(3, false, 0.3, [4, 0, 0]),
    ];
    let s = summarise_robot_kidnap("mapkeeper", KidnapMap::Chain, &t);
    assert_eq!(s.map, KidnapMap::Chain);
    assert_eq!(s.trials_reference_held, 2);
    assert!((s.reference_held_rate - 0.5).abs() < 1e-12);
    // Six right handovers, two held.
    assert_eq!((s.handovers_right, s.handover_held_rate), (6, Some(2.0 / 6.0)));
    let held: usize = s.by_turn.iter().map(|b| b.handovers_held).sum();
    assert_eq!(held, 2);
    assert!((s.recovered_rate_reference_held - 0.5).abs() < 1e-12);
    assert!((s.reference_off_rate - 0.5).abs() < 1e-12);
    assert!((s.false_lost_rate - 0.75).abs() < 1e-12);
    assert!((s.false_lost_right_pose_rate - 0.5).abs() < 1e-12);
    assert!((s.false_lost_well_localised_rate - 0.25).abs() < 1e-12);
    // One Lost step among 4 × 40 well-localised steps of 4 × 100.
    assert_eq!(s.false_lost_well_localised_step_rate, Some(1.0 / 160.0));
    assert_eq!(s.reference_well_localised_share, Some(0.4));
}

#[test]
fn a_handover_is_held_only_if_the_localiser_stays_right_to_the_end() {
    let c = SuccessCriterion::default();
    let s = |t_s: f64, error_m: f64| TrackSample { t_s, error_m, yaw_error_rad: 0.0 };
    // Handed over right at 2 s and at 6 s; wrong at 4 s; the localiser drifts off at 5 s.
    let recoveries = [s(2.0, 0.05), s(4.0, 0.8), s(6.0, 0.05)];
    let track: Vec<TrackSample> = (0..20)
        .map(|i| {
            let t = f64::from(i) * 0.5;
            s(t, if t < 2.0 || (5.0..=6.0).contains(&t) { 1.0 } else { 0.1 })
        })
        .collect();
    // Right: 2 s and 6 s. Held: only 6 s (the track is bad at 5-6 s, after the first).
    assert_eq!(handovers(&recoveries, &track, &c), (2, 1));
    // The handover's own tick carries the estimate before it: not held against it.
    let good_after: Vec<TrackSample> = track.iter().map(|x| s(x.t_s, if x.t_s <= 2.0 { 1.0 } else { 0.1 })).collect();
    assert_eq!(handovers(&recoveries[..1], &good_after, &c), (1, 1));
    assert_eq!(handovers(&[], &track, &c), (0, 0));
}

#[test]
fn maps_are_parsed_and_checked_by_name() {
    assert_eq!(KidnapMap::parse_list("w1, chain,truth"), Ok(KidnapMap::ALL.to_vec()));
    assert!(KidnapMap::parse_list("chain,map").unwrap_err().contains("unknown map \"map\""));
    assert!(KidnapMap::parse_list("truth,truth").unwrap_err().contains("given twice"));
    let p = KidnapRobotParams { maps: vec![], ..KidnapRobotParams::default() };
    assert!(p.validate().unwrap_err().to_string().contains("kidnap_robot.maps"));
    let p = KidnapRobotParams { maps: vec![KidnapMap::Chain, KidnapMap::Chain], ..KidnapRobotParams::default() };
    let e = p.validate().unwrap_err().to_string();
    assert!(e.contains("kidnap_robot.maps") && e.contains("\"chain\" given twice"), "{e}");
    let names: Vec<String> = KidnapMap::ALL.iter().map(|m| serde_json::to_string(m).unwrap()).collect();
    assert_eq!(names, ["\"w1\"", "\"chain\"", "\"truth\""]);
}

#[test]
fn the_reference_holds_only_if_every_pose_from_the_kidnap_on_is_right() {
    use mapkeeper_sensor::StampedPose;
    let c = SuccessCriterion::default();
    let at = |t: u64, x: f64, yaw: f64| StampedPose { stamp_ns: t * 100_000_000, pose: Pose2::new(x, 0.0, yaw) };
    let truth: Vec<StampedPose> = (0..10).map(|t| at(t, 0.1 * t as f64, 0.0)).collect();
    // Off by 0.5 m before 0.3 s, right after it, then 6° off at 0.8 s.
    let chain: Vec<StampedPose> = (0..10)
        .map(|t| {
            let x = 0.1 * t as f64 + if t < 3 { 0.5 } else { 0.05 };
            at(t, x, if t == 8 { 6f64.to_radians() } else { 0.0 })
        })
        .collect();
    let tr = mapkeeper_harness::Trajectories { truth, chain, baseline: Vec::new() };
    assert_eq!(held_from(Some(&tr), 300_000_000, &c), Some(false), "the 6° pose at 0.8 s");
    assert_eq!(held_from(Some(&tr), 900_000_000, &c), Some(true));
    assert_eq!(held_from(Some(&tr), 2_000_000_000, &c), None, "no pose after the end");
    assert_eq!(held_from(None, 0, &c), None);
}
