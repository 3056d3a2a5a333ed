//! The reaction to Lost in the closed loop (`LostPolicy`): on Lost the robot stops at once and
//! stands still until pose updating returns a pose, the check clears, or `lost_wait_s` passes;
//! every episode, attempt, recovery, give-up and the time stopped are counted.

use mapkeeper_closed_loop::setup::tour_from;
use mapkeeper_closed_loop::{
    Execution, Kidnap, LostEnd, NoClock, RunInputs, RunOptions, RunnerParams, WorldRun, run_world_with,
};
use mapkeeper_sim::{StartPose, World, ground_truth_map};

/// A run of 14 s down the west aisle on the world's own map, the estimate kidnapped by
/// (`dx_m`, `dy_m`) at 3 s; with `refuse`, pose updating's fitness gate accepts no fit.
fn kidnapped_run(dx_m: f64, dy_m: f64, refuse: bool) -> (WorldRun, RunnerParams) {
    kidnapped_run_with(dx_m, dy_m, refuse, RunOptions::default())
}

/// [`kidnapped_run`] with the threads of `options` (the simulator ahead of the estimators).
fn kidnapped_run_with(dx_m: f64, dy_m: f64, refuse: bool, options: RunOptions) -> (WorldRun, RunnerParams) {
    let world = World::default_warehouse();
    let g = ground_truth_map(&world, &world.default_map_geometry(0.05).expect("geometry"));
    let (start, route) = tour_from(&mapkeeper_sim::Route::default_warehouse(), 0.5, 30.0);
    let mut w = world.clone();
    w.robot_start = StartPose { x: start.x, y: start.y, yaw_deg: start.yaw.to_degrees() };
    let kidnap = Kidnap { at_s: 3.0, dx_m, dy_m, dyaw_rad: 10f64.to_radians(), sigma_xy_m: 0.1, sigma_yaw_rad: 0.05 };
    let mut p = RunnerParams {
        start_error_m: 0.0,
        start_error_yaw_rad: 0.0,
        run_baseline: false,
        max_sim_time_s: 14.0,
        kidnap: Some(kidnap),
        record_trajectories: true,
        ..RunnerParams::default()
    };
    if refuse {
        p.updater.pose_updating.max_rmse_m = 1e-9;
    }
    let inputs = RunInputs { world: &w, route: &route, prev_map: &g, baseline_map: &g, prev_memory: None };
    let exec = Execution { options, clock: &NoClock };
    (run_world_with(&inputs, p.checked().expect("valid"), 5, "lost-test", &exec, &mut []).expect("run"), p)
}

/// The counters agree with the episodes and with the updater's own statistics, and the robot's
/// true pose does not move from the Lost step that stopped it to the step that resumed it.
fn check_episodes(run: &WorldRun, p: &RunnerParams) {
    let (c, eps) = (&run.lost, &run.lost_episodes);
    assert!(c.episodes >= 1, "no Lost episode: {c:?}");
    assert_eq!(eps.len() as u64, c.episodes);
    let ended = |e: LostEnd| eps.iter().filter(|ep| ep.end == e).count() as u64;
    assert_eq!(
        (ended(LostEnd::Recovered), ended(LostEnd::Cleared), ended(LostEnd::GaveUp)),
        (c.recoveries, c.cleared, c.give_ups)
    );
    assert!(ended(LostEnd::RunEnded) <= 1 && eps[..eps.len() - 1].iter().all(|e| e.end != LostEnd::RunEnded));
    assert_eq!(c.attempts, eps.iter().map(|e| e.attempts).sum::<u64>());
    // Every attempt of pose updating happens inside an episode, every recovered pose ends one.
    assert_eq!(c.attempts, run.updater.recovered + run.updater.not_recovered, "{c:?} vs {:?}", run.updater);
    assert_eq!(c.recoveries, run.updater.recovered);
    assert_eq!(c.stopped_ns, eps.iter().filter(|e| e.stopped).map(|e| e.end_ns - e.start_ns).sum::<u64>());
    let wait_ns = (p.lost_wait_s * 1e9) as u64;
    let truth = &run.trajectories.as_ref().expect("trajectories").truth;
    for (k, e) in eps.iter().enumerate() {
        assert!(e.stopped, "episode {k} did not stop the robot");
        assert!(e.start_ns <= e.end_ns && eps.get(k + 1).is_none_or(|n| n.start_ns > e.end_ns));
        if e.end == LostEnd::GaveUp {
            assert!(e.end_ns - e.start_ns >= wait_ns && e.end_ns - e.start_ns < wait_ns + 200_000_000, "{e:?}");
        }
        // The true pose at every step of the episode is the one of the step that stopped it.
        let during: Vec<_> = truth.iter().filter(|t| t.stamp_ns >= e.start_ns && t.stamp_ns <= e.end_ns).collect();
        assert_eq!(during.first().map(|t| t.stamp_ns), Some(e.start_ns));
        for t in &during {
            assert!(t.pose.distance(&during[0].pose) < 1e-9, "episode {k}: the robot moved while stopped: {t:?}");
        }
    }
    assert!(run.distance_m > 1.0, "the robot drove on after the episodes");
}

/// Pose updating refuses every fit: the robot stands for `lost_wait_s`, resumes without a pose
/// (a give-up), and the next Lost stops it again.
#[test]
fn refused_recoveries_stop_the_robot_until_the_wait_runs_out() {
    let (run, p) = kidnapped_run(0.6, -0.8, true);
    check_episodes(&run, &p);
    let c = run.lost;
    assert!(c.give_ups >= 1, "{c:?} {:?}", run.lost_episodes);
    assert!(c.stopped_s() >= p.lost_wait_s * c.give_ups as f64, "{c:?}");
    assert_eq!(c.recoveries, 0);
    eprintln!("{c:?}");
}

/// 1 m off: pose updating hands the true pose back; the episode ends with a recovery.
#[test]
fn a_near_kidnap_is_recovered_and_the_robot_resumes() {
    let (run, p) = kidnapped_run(0.6, -0.8, false);
    check_episodes(&run, &p);
    let c = run.lost;
    assert!(c.recoveries >= 1, "{c:?} {:?}", run.lost_episodes);
    assert_eq!(run.lost_episodes.iter().find(|e| e.end == LostEnd::Recovered).map(|e| e.stopped), Some(true));
    eprintln!("{c:?}");
}

/// The simulator run ahead on its own thread gives the same run bit for bit, also when the
/// estimate is kidnapped, Lost stops the robot, a give-up or a recovery resumes it and a
/// recovered pose re-initialises the localiser (the simulator goes back to its copy after the
/// step that stopped it): maps, trajectories, episodes, every statistic.
#[test]
fn the_simulator_run_ahead_gives_the_same_run_through_stops_and_resumes() {
    let sim_ahead = RunOptions { simulate_ahead: true, ..RunOptions::default() };
    for refuse in [true, false] {
        let (inline, _) = kidnapped_run_with(0.6, -0.8, refuse, RunOptions::default());
        assert!(inline.lost.episodes >= 1, "the run must stop the robot to test the rewinds");
        let (ahead, p) = kidnapped_run_with(0.6, -0.8, refuse, sim_ahead);
        check_episodes(&ahead, &p);
        assert_eq!(inline, ahead, "refuse {refuse}: the run ahead differs");
    }
}
