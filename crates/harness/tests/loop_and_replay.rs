//! The loop's contract on tiny hand-built logs: how a log becomes steps (grouping by stamp, the
//! odometry and truth rules), the order in which controls and observers see a step, and the
//! replay jobs end to end on a hand-built map.
#![allow(clippy::unwrap_used)]

use mapkeeper_grid::Pose2;
use mapkeeper_harness::jobs::localise::{InitFrom, localise_log};
use mapkeeper_harness::jobs::update::{PoseInput, update_log};
use mapkeeper_harness::{
    Control, HarnessError, LogSource, NoClock, Observer, OdometryAt, PoseSource, ReplayOptions, RobotControl,
    SensorSource, Session, SessionStep, Step, run,
};
use mapkeeper_localiser::FilterParams;
use mapkeeper_sensor::{LaserScan, LogHeader, LogRecord, OdometryReading, SensorLog, TruePose};
use mapkeeper_testkit::rooms::ten_by_ten_centred;
use mapkeeper_updater::UpdaterParams;
use std::cell::RefCell;

fn scan(stamp_ns: u64, lidar_id: u32) -> LaserScan {
    LaserScan {
        stamp_ns,
        lidar_id,
        lidar_in_robot: Pose2::IDENTITY,
        angle_min_rad: -1.5,
        angle_increment_rad: 0.01,
        range_min_m: 0.05,
        range_max_m: 20.0,
        ranges_m: vec![2.0; 301],
        sweep: None,
    }
}

fn log(records: Vec<LogRecord>) -> SensorLog {
    SensorLog { header: LogHeader::new(Default::default()), records }
}

fn odom(stamp_ns: u64, x: f64) -> LogRecord {
    LogRecord::Odom(OdometryReading { stamp_ns, pose_in_odom: Pose2::new(x, 0.0, 0.0) })
}

fn truth(stamp_ns: u64, x: f64) -> LogRecord {
    LogRecord::Truth(TruePose { stamp_ns, pose_in_map: Pose2::new(x, 0.0, 0.0) })
}

#[test]
fn scans_with_one_stamp_form_one_step_and_odometry_follows_the_chosen_rule() {
    let records = vec![
        odom(100, 0.0),
        scan_rec(50, 0),
        scan_rec(150, 0),
        scan_rec(150, 1),
        odom(200, 1.0),
        scan_rec(300, 1),
        truth(140, 5.0),
        truth(160, 7.0),
    ];
    let steps = |options| {
        let mut s = LogSource::new(log(records.clone()), "test", options);
        let mut out = Vec::new();
        while let Some(step) = s.next_step().unwrap() {
            out.push(step);
        }
        out
    };
    let latest = steps(ReplayOptions::default());
    assert_eq!(
        latest.iter().map(|s| (s.frame.stamp_ns, s.frame.scans.len())).collect::<Vec<_>>(),
        [(50, 1), (150, 2), (300, 1)]
    );
    // Latest at or before: none before the first reading, then the reading at 100, then 200.
    let xs: Vec<Option<f64>> = latest.iter().map(|s| s.frame.odometry.map(|p| p.x)).collect();
    assert_eq!(xs, [None, Some(0.0), Some(1.0)]);
    // Interpolated, clamped outside the records.
    let interp = steps(ReplayOptions { odometry_at: OdometryAt::Interpolated, ..ReplayOptions::default() });
    let xs: Vec<Option<f64>> = interp.iter().map(|s| s.frame.odometry.map(|p| p.x)).collect();
    assert_eq!(xs, [Some(0.0), Some(0.5), Some(1.0)]);
    // Truth: interpolated at 150 (6.0); with a 20 ns gap limit, 50 and 300 have none.
    assert_eq!(latest[1].truth.unwrap().pose_in_map.x, 6.0);
    let gapped = steps(ReplayOptions { max_truth_gap_ns: 20, ..ReplayOptions::default() });
    let t: Vec<Option<f64>> = gapped.iter().map(|s| s.truth.map(|t| t.pose_in_map.x)).collect();
    assert_eq!(t, [None, Some(6.0), None]);
}

fn scan_rec(stamp_ns: u64, lidar_id: u32) -> LogRecord {
    LogRecord::Scan(scan(stamp_ns, lidar_id))
}

/// Records the order of the hooks it sees.
struct Trace<'a>(&'a RefCell<Vec<String>>, &'static str);

impl Control for Trace<'_> {
    fn before_step(
        &mut self,
        s: &Step,
        _: &mut Session<'_>,
        _: Option<&mut dyn RobotControl>,
    ) -> Result<(), HarnessError> {
        self.0.borrow_mut().push(format!("{} before {}", self.1, s.frame.stamp_ns));
        Ok(())
    }

    fn after_step(
        &mut self,
        s: &Step,
        _: &SessionStep,
        _: &mut Session<'_>,
        _: Option<&mut dyn RobotControl>,
    ) -> Result<(), HarnessError> {
        self.0.borrow_mut().push(format!("{} after {}", self.1, s.frame.stamp_ns));
        Ok(())
    }
}

impl Observer for Trace<'_> {
    fn on_step(&mut self, s: &Step, _: &SessionStep, _session: &Session<'_>) {
        self.0.borrow_mut().push(format!("{} observe {}", self.1, s.frame.stamp_ns));
    }
}

#[test]
fn controls_act_before_and_after_the_session_and_observers_see_each_step_in_between() {
    let trace = RefCell::new(Vec::new());
    let mut source = LogSource::new(log(vec![scan_rec(1, 0), scan_rec(2, 0)]), "t", ReplayOptions::default());
    let mut session = Session::new(PoseSource::None, None, None, &NoClock);
    let (mut a, mut b, mut o) = (Trace(&trace, "a"), Trace(&trace, "b"), Trace(&trace, "o"));
    let n = run(&mut source, &mut session, &mut [&mut a, &mut b], &mut [&mut o]).unwrap();
    assert_eq!(n, 2);
    let want: Vec<String> = [1, 2]
        .iter()
        .flat_map(|t| {
            [
                format!("a before {t}"),
                format!("b before {t}"),
                format!("o observe {t}"),
                format!("a after {t}"),
                format!("b after {t}"),
            ]
        })
        .collect();
    assert_eq!(*trace.borrow(), want);
}

#[test]
fn replay_jobs_localise_and_update_a_hand_built_log() {
    // A robot standing at the room's centre, two lidars, odometry and truth at every step.
    let mut records = Vec::new();
    for k in 0..20u64 {
        let t = 1_000_000 * (k + 1);
        records.extend([odom(t, 0.0), truth(t, 0.0), scan_rec(t, 0), scan_rec(t, 1)]);
    }
    let (r, init) = localise_log(
        LogSource::new(log(records.clone()), "t", ReplayOptions::default()),
        &ten_by_ten_centred(),
        FilterParams::default(),
        None,
        3,
        &mut [],
    )
    .unwrap();
    assert!(matches!(init, InitFrom::LoggedTruth(p) if p == Pose2::IDENTITY));
    assert_eq!((r.updates, r.no_odometry, r.estimates.len()), (20, 0, 20));
    assert_eq!(r.covariance_csv.lines().count(), 21);
    assert!(r.rmse.is_some_and(|(pos, _, n)| pos.is_finite() && n == 20));
    let options = ReplayOptions { odometry_at: OdometryAt::Interpolated, ..ReplayOptions::default() };
    let u = update_log(
        LogSource::new(log(records), "t", options),
        ten_by_ten_centred(),
        UpdaterParams::paper(),
        PoseInput::LoggedTruth,
        &NoClock,
        &mut [],
    )
    .unwrap();
    // The robot never moves, and its 2 m ranges do not match the room (walls ~4.9 m away):
    // every step is checked (the gate only paces cells updates) and every one is Lost.
    assert_eq!((u.stats.steps, u.stats.processed, u.stats.losts, u.stats.cells_updates), (20, 20, 20, 0));
    assert_eq!(u.steps_csv.lines().count(), 21);
    // No scans, no job.
    let e = update_log(
        LogSource::new(log(vec![odom(1, 0.0)]), "empty.jsonl", options),
        ten_by_ten_centred(),
        UpdaterParams::paper(),
        PoseInput::AlignedOdometry,
        &NoClock,
        &mut [],
    )
    .unwrap_err();
    assert!(e.to_string().contains("empty.jsonl"), "{e}");
}

#[test]
fn scans_within_the_sync_window_form_one_step_with_at_most_one_scan_per_lidar() {
    // Two unsynchronised lidars; lidar 0 twice within the window at 300 and 310.
    let records = vec![
        odom(0, 0.0),
        scan_rec(100, 0),
        scan_rec(120, 1),
        odom(125, 1.0),
        scan_rec(200, 0),
        scan_rec(230, 1),
        scan_rec(300, 0),
        scan_rec(310, 0),
        scan_rec(400, 1),
        odom(500, 2.0),
    ];
    let steps = |sync_window_ns| {
        let options = ReplayOptions { sync_window_ns, ..ReplayOptions::default() };
        let mut s = LogSource::new(log(records.clone()), "t", options);
        let mut out = Vec::new();
        while let Some(step) = s.next_step().unwrap() {
            let lidars: Vec<u32> = step.frame.scans.iter().map(|s| s.lidar_id).collect();
            out.push((step.frame.stamp_ns, lidars, step.frame.odometry.map(|p| p.x)));
        }
        out
    };
    // Window 50 ns: pairs stamped with their latest scan (odometry looked up there: at 120 the
    // reading at 0, at 230 the one at 125); the second scan of lidar 0 starts a new step.
    assert_eq!(
        steps(50),
        [
            (120, vec![0, 1], Some(0.0)),
            (230, vec![0, 1], Some(1.0)),
            (300, vec![0], Some(1.0)),
            (310, vec![0], Some(1.0)),
            (400, vec![1], Some(1.0)),
        ]
    );
    // The window is measured from the step's first scan: 100 ns holds 300, 310 apart (same
    // lidar) but joins 310 and 400.
    assert_eq!(steps(100)[2..], [(300, vec![0], Some(1.0)), (400, vec![0, 1], Some(1.0))]);
    // 0: exact stamps only, every scan its own step (the default).
    assert_eq!(steps(0).len(), 7);
    assert_eq!(ReplayOptions::default().sync_window_ns, 0);
}

/// Ranges of a scan from `robot` (lidar at the robot's centre) in `ten_by_ten_centred()`: the inner faces of
/// its walls are at ±4.9 m.
fn room_ranges(robot: Pose2, s: &LaserScan) -> Vec<f32> {
    (0..s.ranges_m.len())
        .map(|k| {
            let a = robot.yaw + s.angle_min_rad + k as f64 * s.angle_increment_rad;
            let (dx, dy) = (a.cos(), a.sin());
            let tx = if dx > 0.0 { (4.9 - robot.x) / dx } else { (-4.9 - robot.x) / dx };
            let ty = if dy > 0.0 { (4.9 - robot.y) / dy } else { (-4.9 - robot.y) / dy };
            tx.min(ty) as f32
        })
        .collect()
}

#[test]
fn update_writes_every_pose_recovery_with_its_pose_or_refusal_reason() {
    // Two lidars 10 ms apart (one step with the default window), a whole turn of beams. Step 1:
    // the scans fit the room at the true pose, the given pose is about 1.6 m and 0.6 rad off → Lost,
    // and pose updating finds the true pose. Step 2 (after 0.2 m of odometry): every beam hits
    // something 2 m away, which nothing in the room explains → Lost, refused.
    let truth_pose = Pose2::new(1.0, 0.5, 0.0);
    let given = Pose2::new(2.2, -0.4, 0.6);
    let turn = |stamp_ns, lidar_id, ranges: Option<Vec<f32>>| {
        let mut s = scan(stamp_ns, lidar_id);
        s.angle_min_rad = -std::f64::consts::PI;
        s.angle_increment_rad = 2.0 * std::f64::consts::PI / 360.0;
        s.ranges_m = vec![0.0; 360];
        s.ranges_m = ranges.unwrap_or_else(|| room_ranges(truth_pose, &s));
        LogRecord::Scan(s)
    };
    let (t1, t2) = (1_000_000_000u64, 2_000_000_000u64);
    let records = vec![
        odom(t1, 0.0),
        turn(t1, 0, None),
        turn(t1 + 10_000_000, 1, None),
        odom(t2, 0.2),
        turn(t2, 0, Some(vec![2.0; 360])),
        turn(t2 + 10_000_000, 1, Some(vec![2.0; 360])),
    ];
    let track = vec![
        mapkeeper_sensor::StampedPose { stamp_ns: t1, pose: given },
        mapkeeper_sensor::StampedPose { stamp_ns: t2 + 10_000_000, pose: given },
    ];
    let options = ReplayOptions {
        odometry_at: OdometryAt::Interpolated,
        sync_window_ns: mapkeeper_harness::DEFAULT_SYNC_WINDOW_NS,
        ..ReplayOptions::default()
    };
    let u = update_log(
        LogSource::new(log(records), "t", options),
        ten_by_ten_centred(),
        UpdaterParams::paper(),
        PoseInput::Track(track),
        &NoClock,
        &mut [],
    )
    .unwrap();
    assert_eq!((u.stats.steps, u.stats.processed, u.stats.losts), (2, 2, 2), "{}", u.steps_csv);
    let rows: Vec<Vec<&str>> = u.recoveries_csv.lines().map(|l| l.split(',').collect()).collect();
    assert_eq!(rows[0], ["time_s", "verdict", "result", "x_m", "y_m", "yaw_rad", "reason"]);
    assert_eq!(rows.len(), 3, "{}", u.recoveries_csv);
    // Stamped with the step's latest scan.
    assert_eq!(rows[1][..3], ["1.010000000", "lost", "recovered"]);
    let xyz: Vec<f64> = rows[1][3..6].iter().map(|v| v.parse().unwrap()).collect();
    assert!(
        (xyz[0] - truth_pose.x).abs() < 0.05 && (xyz[1] - truth_pose.y).abs() < 0.05 && xyz[2].abs() < 0.02,
        "{xyz:?}"
    );
    assert_eq!(rows[1][6], "");
    assert_eq!(u.recovered_poses.len(), 1);
    assert_eq!(rows[2][..6], ["2.010000000", "lost", "refused", "", "", ""]);
    assert!(!rows[2][6].is_empty(), "a refusal names its reason: {:?}", rows[2]);
}

#[test]
fn a_pose_bias_moves_the_pose_the_updater_sees_and_a_new_estimate_removes_it() {
    use mapkeeper_harness::PoseBias;
    use mapkeeper_localiser::Localiser;
    let frame = |t: u64| mapkeeper_harness::SensorFrame {
        stamp_ns: t,
        odometry: Some(Pose2::IDENTITY),
        scans: vec![scan(t, 0)],
    };
    let mut loc = Localiser::new(&ten_by_ten_centred(), FilterParams::default(), 7).unwrap();
    loc.init_pose(Pose2::IDENTITY, [[1e-4, 0.0, 0.0], [0.0, 1e-4, 0.0], [0.0, 0.0, 1e-4]]).unwrap();
    let mut session = Session::new(PoseSource::Localiser(Box::new(loc)), None, None, &NoClock);
    let plain = session.process(&frame(1)).pose_in_map.unwrap();
    let bias = PoseBias { dx_m: 0.5, dy_m: -0.25, dyaw_rad: 0.1 };
    session.set_pose_bias(Some(bias));
    assert_eq!(session.pose_bias(), Some(bias));
    let r = session.process(&frame(2));
    let (biased, est) = (r.pose_in_map.unwrap(), r.localiser.unwrap().estimate.pose_in_map);
    // The localiser itself is not moved: the report's pose is its estimate plus the bias.
    assert!((biased.x - est.x - 0.5).abs() < 1e-12 && (biased.y - est.y + 0.25).abs() < 1e-12);
    assert!((biased.yaw - est.yaw - 0.1).abs() < 1e-12);
    assert!(est.distance(&plain) < 0.2, "{est:?} vs {plain:?}");
    session.set_estimate(Pose2::IDENTITY, [[1e-4, 0.0, 0.0], [0.0, 1e-4, 0.0], [0.0, 0.0, 1e-4]]).unwrap();
    assert_eq!(session.pose_bias(), None);
    let r = session.process(&frame(3));
    assert_eq!(r.pose_in_map, Some(r.localiser.unwrap().estimate.pose_in_map));
}

#[test]
fn a_replayed_log_hands_a_recovered_pose_back_to_the_localiser() {
    // The robot drives backwards along x in the room, 0.25 m between steps, both lidars seeing the walls
    // from the true pose. The localiser starts 1.6 m and 0.6 rad off with a tight cloud, so it
    // cannot find the room on its own: the first step says Lost, pose updating recovers the true
    // pose, and the Lost policy hands it to the localiser, whose later estimates follow the truth.
    let start = Pose2::new(1.0, 0.5, 0.0);
    let given = Pose2::new(2.2, -0.4, 0.6);
    let step_m = -0.25;
    let mut records = Vec::new();
    for k in 0..6u64 {
        let t = 1_000_000_000 + k * 500_000_000;
        let at = Pose2::new(start.x + k as f64 * step_m, start.y, 0.0);
        records.push(odom(t, k as f64 * step_m));
        records.push(truth(t, at.x));
        for lidar in 0..2 {
            let mut s = scan(t + lidar as u64 * 10_000_000, lidar);
            s.angle_min_rad = -std::f64::consts::PI;
            s.angle_increment_rad = 2.0 * std::f64::consts::PI / 360.0;
            s.ranges_m = vec![0.0; 360];
            s.ranges_m = room_ranges(at, &s);
            records.push(LogRecord::Scan(s));
        }
    }
    let options = ReplayOptions {
        odometry_at: OdometryAt::Interpolated,
        sync_window_ns: mapkeeper_harness::DEFAULT_SYNC_WINDOW_NS,
        ..ReplayOptions::default()
    };
    let mut params = FilterParams::default();
    (params.initial_cov_xx_m2, params.initial_cov_yy_m2, params.initial_cov_aa_rad2) =
        (0.05f64.powi(2), 0.05f64.powi(2), 0.02f64.powi(2));
    let u = update_log(
        LogSource::new(log(records), "t", options),
        ten_by_ten_centred(),
        UpdaterParams::paper(),
        PoseInput::Localise { params: Box::new(params), seed: 3, init: Some(given) },
        &NoClock,
        &mut [],
    )
    .unwrap();
    assert_eq!(u.stats.steps, 6, "{}", u.steps_csv);
    assert_eq!((u.lost.episodes, u.lost.recoveries), (1, 1), "{:?}\n{}", u.lost, u.steps_csv);
    assert_eq!(u.lost_episodes.len(), 1);
    assert_eq!(u.lost_episodes[0].end, mapkeeper_harness::LostEnd::Recovered);
    // No robot to stop in a log.
    assert!(!u.lost_episodes[0].stopped && u.lost.stopped_ns == 0);
    let last = u.poses.last().unwrap();
    let truth_x = start.x + 5.0 * step_m;
    assert!(
        (last.pose.x - truth_x).abs() < 0.05 && (last.pose.y - start.y).abs() < 0.05 && last.pose.yaw.abs() < 0.03,
        "the localiser should follow the recovered pose: {:?}",
        last.pose
    );
    assert!(u.steps_csv.lines().last().unwrap().contains(",update,"), "{}", u.steps_csv);
}
