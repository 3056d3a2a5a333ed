use super::*;
use crate::experiments::real_scans::splice;

const S: u64 = 1_000_000_000;

/// A reference along x at 1 m/s, a pose a second from 0 to 25 s, the robot moved from x = 10
/// to x = 12 between t = 10 s (the cut) and the next pose (as a spliced reference is: the jump
/// within the joint, 1 ns after the cut).
fn reference() -> Vec<StampedPose> {
    let mut r: Vec<StampedPose> =
        (0..=10).map(|k| StampedPose { stamp_ns: k * S, pose: Pose2::new(k as f64, 0.0, 0.0) }).collect();
    r.push(StampedPose { stamp_ns: 10 * S + 1, pose: Pose2::new(12.0, 0.0, 0.0) });
    r.extend((11..=25).map(|k| StampedPose { stamp_ns: k * S, pose: Pose2::new(k as f64 + 1.0, 0.0, 0.0) }));
    r
}

/// Estimates at each second: `off(k)` is the estimate's (x error, yaw error in degrees).
fn estimates(off: impl Fn(u64) -> (f64, f64)) -> Vec<StampedPose> {
    let r = reference();
    (0..=25)
        .map(|k| {
            let t = interpolate(&r, k * S).unwrap_or(Pose2::IDENTITY);
            let (dx, dyaw) = off(k);
            StampedPose { stamp_ns: k * S, pose: Pose2::new(t.x + dx, t.y, t.yaw + dyaw.to_radians()) }
        })
        .collect()
}

const CUT: u64 = 10 * S;

#[test]
fn recovered_within_the_window_and_to_the_end() {
    let p = RealKidnapParams::default();
    // Off by the jump for three scans after the cut, then right (0.1 m, 2°) to the end.
    let e = estimates(|k| if (11..=13).contains(&k) { (-2.0, 0.0) } else { (0.1, 2.0) });
    let r = classify_recovery(&e, &reference(), CUT, &p);
    assert!(r.recovered, "{r:?}");
    assert_eq!((r.recover_s, r.recover_scans, r.steps_after), (Some(4.0), Some(4), 15));
    assert!((r.first_error_m.unwrap_or(0.0) - 2.0).abs() < 1e-9);
    assert!((r.final_error_m.unwrap_or(1.0) - 0.1).abs() < 1e-9);
}

#[test]
fn recovered_too_late_never_recovered_and_recovered_then_lost_again_are_not_recovered() {
    let p = RealKidnapParams::default();
    // Right only from 12 s after the cut: outside the 10 s window.
    let late = classify_recovery(
        &estimates(|k| if k > 10 && k < 22 { (-2.0, 0.0) } else { (0.0, 0.0) }),
        &reference(),
        CUT,
        &p,
    );
    assert!(!late.recovered && late.recover_s == Some(12.0), "{late:?}");
    // The estimate that carries on with the odometry (the robot's motion, not the jump) stays
    // exactly the jump off: never recovered.
    let odometry = estimates(|k| if k > 10 { (-2.0, 0.0) } else { (0.0, 0.0) });
    let r = classify_recovery(&odometry, &reference(), CUT, &p);
    assert!(!r.recovered && r.recover_scans.is_none() && r.first_error_m.is_some_and(|e| e >= 0.5), "{r:?}");
    // Right at 2 s, lost again at 15 s (0.25 m: neither right nor wrong), right again at 18 s:
    // the good stretch starts at 18 s, 8 s after the cut: recovered then, not at 2 s.
    let back = estimates(|k| match k {
        11 => (1.0, 0.0),
        15..=17 => (0.25, 0.0),
        _ => (0.0, 0.0),
    });
    let r = classify_recovery(&back, &reference(), CUT, &p);
    assert!(r.recovered && r.recover_s == Some(8.0) && r.recover_scans == Some(8), "{r:?}");
    // Right, then lost again to the end (a heading 6° off): not recovered.
    let relost = estimates(|k| if k >= 16 { (0.0, 6.0) } else { (0.0, 0.0) });
    let r = classify_recovery(&relost, &reference(), CUT, &p);
    assert!(
        !r.recovered && r.recover_s.is_none() && (r.final_yaw_error_deg.unwrap_or(0.0) - 6.0).abs() < 1e-9,
        "{r:?}"
    );
    // Right just before the window closes (10 s after the cut) counts; just after does not.
    let edge = |from: u64| estimates(move |k| if k > 10 && k < from { (3.0, 0.0) } else { (0.0, 0.0) });
    assert!(classify_recovery(&edge(20), &reference(), CUT, &p).recovered);
    let p9 = RealKidnapParams { recovery_window_s: 9.0, ..RealKidnapParams::default() };
    assert!(!classify_recovery(&edge(20), &reference(), CUT, &p9).recovered);
    // No step after the cut: nothing to judge.
    let none = classify_recovery(&estimates(|_| (0.0, 0.0))[..=10], &reference(), CUT, &p);
    assert_eq!((none.recovered, none.steps_after, none.first_error_m), (false, 0, None));
}

#[test]
fn a_pose_handed_over_is_wrong_at_a_third_of_a_metre_or_five_degrees() {
    let p = RealKidnapParams::default();
    let r = reference();
    let at = |k: u64, dx: f64, dyaw_deg: f64| StampedPose {
        stamp_ns: k * S,
        pose: {
            let t = interpolate(&r, k * S).unwrap_or(Pose2::IDENTITY);
            Pose2::new(t.x + dx, t.y, t.yaw + dyaw_deg.to_radians())
        },
    };
    // Right; 0.25 m (neither right nor wrong); 0.3 m; 5°; the pose before the jump, after it.
    let handed = [at(11, 0.05, 1.0), at(12, 0.25, 0.0), at(13, 0.3, 0.0), at(14, 0.0, 5.0), at(15, -2.0, 0.0)];
    assert_eq!(wrong_poses(&handed, &r, &p), 3);
    assert_eq!(wrong_poses(&handed[..2], &r, &p), 0);
}

#[test]
fn a_trial_ends_recovered_or_with_the_first_reason_it_did_not() {
    let p = RealKidnapParams::default();
    let judge = |off: &dyn Fn(u64) -> (f64, f64)| classify_recovery(&estimates(off), &reference(), CUT, &p);
    let recovered = judge(&|k| if k == 11 { (2.0, 0.0) } else { (0.0, 0.0) });
    let late = judge(&|k| if k > 10 && k < 22 { (2.0, 0.0) } else { (0.0, 0.0) });
    let never = judge(&|k| if k > 10 { (2.0, 0.0) } else { (0.0, 0.0) });
    assert_eq!(KidnapEnd::of(&recovered, true, 1, 0), KidnapEnd::Recovered);
    assert_eq!(KidnapEnd::of(&late, true, 1, 0), KidnapEnd::Late);
    assert_eq!(KidnapEnd::of(&never, true, 2, 1), KidnapEnd::WrongPose);
    assert_eq!(KidnapEnd::of(&never, false, 0, 0), KidnapEnd::NeverLost);
    assert_eq!(KidnapEnd::of(&never, true, 0, 0), KidnapEnd::Refused);
    assert_eq!(KidnapEnd::of(&never, true, 1, 0), KidnapEnd::NotHeld);
    assert_eq!(serde_json::to_string(&KidnapEnd::NeverLost).ok().as_deref(), Some("\"never-lost\""));
    assert_eq!(KidnapEnd::WrongPose.name(), "wrong-pose");
}

#[test]
fn steps_after_the_cut_are_counted_by_outcome_and_verdict() {
    let csv = "time_s,outcome,verdict,n,n_invalid,n_dc,cells_changed,recovery,microseconds\n\
9.999999999,processed,lost,10,0,9,0,,0.0\n10.000000000,processed,update,10,0,0,0,,0.0\n\
10.000000001,no_valid_beams,,0,180,0,0,,0.0\n11.5,processed,lost,10,0,9,0,not_recovered,0.0\n\
12.000000000,no_valid_beams,,0,180,0,0,,0.0\n";
    let m = outcomes_after(csv, CUT);
    assert_eq!(m, BTreeMap::from([("no_valid_beams".to_string(), 2), ("processed/lost".to_string(), 1)]));
    // 11.5 is 11.5 s, after a cut at 11.4 s.
    let m = outcomes_after(csv, 11_400_000_000);
    assert_eq!(m, BTreeMap::from([("no_valid_beams".to_string(), 1), ("processed/lost".to_string(), 1)]));
}

#[test]
fn refusals_are_counted_by_reason() {
    let csv = format!(
        "{}1.0,lost,refused,,,,poor_fit: best inlier ratio 0.2; rmse 0.1 m (3 of 9 points)\n\
2.0,lost,recovered,1.0,2.0,0.3,\n3.0,lost,refused,,,,poor_fit: x\n4.0,lost,refused,,,,ambiguous: (1 2 3) and (4 5 6) fit alike\n",
        mapkeeper_harness::jobs::update::RECOVERIES_CSV_HEADER
    );
    let r = refusals(&csv);
    assert_eq!(r, BTreeMap::from([("ambiguous".to_string(), 1), ("poor_fit".to_string(), 2)]));
}

fn trial(recovered: bool, wrong: usize, false_lost: u64, recover_s: f64) -> KidnapTrial {
    KidnapTrial {
        cut: 0,
        seed: 1,
        map: "truth".into(),
        localiser: "mapkeeper-real".into(),
        preset: "paper".into(),
        jump_m: 1.0,
        turn_deg: 10.0,
        recovery: Recovery {
            recovered,
            recover_s: Some(recover_s),
            recover_scans: Some(recover_s as usize),
            steps_after: 10,
            first_error_m: Some(1.0),
            final_error_m: Some(0.05),
            final_yaw_error_deg: Some(1.0),
        },
        detected: true,
        lost_delay_s: Some(1.0),
        lost_episodes: 1,
        lost_before_cut: 0,
        pose_recoveries: 1 + wrong,
        wrong_poses: wrong,
        recovered_by_pose_updating: recovered,
        refusals: BTreeMap::from([("poor_fit".to_string(), 1)]),
        end: if recovered { KidnapEnd::Recovered } else { KidnapEnd::Refused },
        steps_after_cut: BTreeMap::new(),
        steps: 20,
        unspliced_lost_episodes: false_lost,
        unspliced_first_lost_error_m: None,
        unspliced_wrong_poses: 0,
        unspliced_max_error_m: 0.1,
        unspliced_steps: 20,
    }
}

#[test]
fn the_summary_counts_rates_times_and_targets() {
    let p = RealKidnapParams::default();
    let mut t: Vec<KidnapTrial> = (0..10).map(|k| trial(true, 0, 0, k as f64 + 1.0)).collect();
    let refs: Vec<&KidnapTrial> = t.iter().collect();
    let s = summarise("truth", "mapkeeper-real", "paper", &refs, &p);
    assert_eq!((s.trials, s.recovered_rate, s.wrong_rate, s.false_lost_rate), (10, 1.0, 0.0, 0.0));
    assert_eq!((s.median_recover_s, s.p90_recover_s), (Some(5.5), Some(9.0)));
    assert_eq!(s.refusals.get("poor_fit"), Some(&10));
    assert!(s.targets_met);
    t[0] = trial(false, 1, 1, 30.0);
    t[1] = trial(false, 0, 0, 30.0);
    let refs: Vec<&KidnapTrial> = t.iter().collect();
    let s = summarise("truth", "mapkeeper-real", "paper", &refs, &p);
    assert_eq!((s.recovered_rate, s.wrong_rate, s.false_lost_rate, s.wrong_poses), (0.8, 0.1, 0.1, 1));
    assert_eq!(s.median_recover_s, Some(6.5), "over the recovered trials only");
    assert_eq!(s.ends, BTreeMap::from([("recovered".to_string(), 8), ("refused".to_string(), 2)]));
    assert!(!s.targets_met);
    assert!(serde_json::to_string(&s).is_ok_and(|j| j.contains("\"recovered_rate\":0.8")));
}

#[test]
fn parameters_are_checked_with_their_names() {
    let bad = [
        (RealKidnapParams { seeds_per_cut: 0, ..RealKidnapParams::default() }, "seeds_per_cut"),
        (RealKidnapParams { presets: vec![], ..RealKidnapParams::default() }, "presets"),
        (RealKidnapParams { localisers: vec!["nope".into()], ..RealKidnapParams::default() }, "localisers"),
        (RealKidnapParams { recovery_window_s: 0.0, ..RealKidnapParams::default() }, "recovery_window_s"),
        (RealKidnapParams { wrong_min_yaw_deg: f64::NAN, ..RealKidnapParams::default() }, "wrong_min_yaw_deg"),
        (
            RealKidnapParams {
                cuts: CutParams { min_jump_m: 0.0, ..CutParams::default() },
                ..RealKidnapParams::default()
            },
            "cuts.min_jump_m",
        ),
    ];
    for (p, name) in bad {
        assert_eq!(p.validate().map_err(|e| e.name), Err(name.to_string()));
    }
    let toml = "seeds_per_cut = 2\n[cuts]\ncount = 3\n";
    let p: RealKidnapParams = toml::from_str(toml).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((p.seeds_per_cut, p.cuts.count, p.cuts.min_jump_m), (2, 3, 0.5));
    assert!(toml::from_str::<RealKidnapParams>("cut = 3\n").is_err(), "unknown keys are refused");
}

/// G at the reference poses of `log` up to `end_ns`, with real-data's mapper parameters.
fn map_up_to(log: &SensorLog, end_ns: u64) -> OccupancyGrid {
    let part = splice::window(log, 0, end_ns);
    let options = ReplayOptions { max_truth_gap_ns: splice::REFERENCE_GAP_NS, ..ReplayOptions::default() };
    let mapper = mapkeeper_harness::jobs::map::MapLogParams {
        mapper: mapkeeper_grid::mapper::MapperParams::default(),
        no_return_clear_m: 0.0,
        resolution_m: 0.05,
        margin_m: 1.0,
    };
    mapkeeper_harness::jobs::map::map_log(LogSource::new(part, "intel", options), None, &mapper)
        .unwrap_or_else(|e| panic!("{e}"))
        .map
}

/// `g` with every tenth occupied cell made free: a stale map of the place.
fn erase_every_tenth_wall_cell(g: &OccupancyGrid) -> OccupancyGrid {
    use mapkeeper_grid::CellState::{Free, Occupied};
    let mut stale = g.clone();
    let occupied: Vec<usize> = (0..g.cells().len()).filter(|&i| g.cells()[i] == Occupied).step_by(10).collect();
    for &i in &occupied {
        stale.cells_mut()[i] = Free;
    }
    assert!(!occupied.is_empty() && stale != *g);
    stale
}

/// The largest disagreement between the odometry increment and the reference increment over
/// consecutive scans of `log`, metres, and the stamp of the scan it starts from.
fn worst_odometry_gap(log: &SensorLog) -> (f64, u64) {
    let mut steps: Vec<u64> = log.scans().map(|s| s.stamp_ns).collect();
    steps.dedup();
    let r = reference_of(log);
    let odo: Vec<StampedPose> =
        log.odometry().map(|o| StampedPose { stamp_ns: o.stamp_ns, pose: o.pose_in_odom }).collect();
    let mut worst = (0.0f64, 0u64);
    for w in steps.windows(2) {
        if let (Some(r0), Some(r1), Some(o0), Some(o1)) =
            (interpolate(&r, w[0]), interpolate(&r, w[1]), interpolate(&odo, w[0]), interpolate(&odo, w[1]))
        {
            let (dr, dodo) = (r0.between(&r1), o0.between(&o1));
            let gap = (dr.x - dodo.x).hypot(dr.y - dodo.y);
            if gap > worst.0 {
                worst = (gap, w[0]);
            }
        }
    }
    worst
}

/// The Intel log's window around one cut, end to end: the spliced run and its pair, on G and on
/// a stale G, for `paper` and `mapkeeper`, the same on one thread and on two.
#[test]
fn an_intel_cut_runs_end_to_end_paired_with_its_unspliced_window() {
    let Some(path) = mapkeeper_common::shared_data::path(
        "data/carmen/intel-corrected.log.gz",
        "an_intel_cut_runs_end_to_end_paired_with_its_unspliced_window",
    ) else {
        return;
    };
    let imported = mapkeeper_logs::read_log(&path, None, &mapkeeper_logs::ImportOptions::default())
        .unwrap_or_else(|e| panic!("{e}"));
    let dataset = Dataset { name: "intel".into(), source: path.display().to_string(), log: imported.log };
    let cuts =
        CutParams { count: 1, before_scans: 3, after_scans: 4, before_s: 5.0, after_s: 12.0, ..CutParams::default() };
    let p = RealKidnapParams { cuts, presets: vec!["paper".into(), "mapkeeper".into()], ..RealKidnapParams::default() };
    let draws = draw_cuts(&dataset.log, "intel", &p.cuts, 3).unwrap_or_else(|e| panic!("{e}"));
    let d = draws[0];
    assert!(d.jump_m >= 0.5, "the robot is moved: {d:?}");
    // G from the log up to a minute past the window only: a fraction of the cost.
    let g = map_up_to(&dataset.log, d.window_end_ns + 60 * S);
    let stale = erase_every_tenth_wall_cell(&g);
    let maps = [("stale", &stale), ("truth", &g)];
    // The same results on one thread and on two (the trials run in any order).
    let on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap_or_else(|e| panic!("{e}"));
        pool.install(|| run_real_kidnap(&dataset, &maps, &p, 3, &|| {})).unwrap_or_else(|e| panic!("{e}"))
    };
    let results = on(1);
    assert_eq!(on(2), results);
    assert_eq!((results.cuts.as_slice(), results.trials.len(), results.summaries.len()), (draws.as_slice(), 4, 4));
    for t in &results.trials {
        println!("{} {}: {:?}, {:?}; steps after the cut {:?}", t.map, t.preset, t.end, t.recovery, t.steps_after_cut);
        assert!(t.steps > 0 && t.unspliced_steps > 0 && t.recovery.steps_after >= p.cuts.after_scans, "{t:?}");
        assert_eq!(t.lost_before_cut, 0, "no Lost before the cut on the first seconds of a window: {t:?}");
    }
    // The pair, directly: the same run up to the cut. The spliced odometry stands still where
    // the reference jumps; the unspliced odometry follows its reference (no kidnap).
    let trials = RealKidnapTrials {
        dataset: &dataset,
        maps: &maps,
        p: &p,
        seed: 3,
        cuts: draws,
        reference: reference_of(&dataset.log),
    };
    let job = KidnapJob { cut: 0, seed: 0, map: 1, localiser: 0, preset: 0 };
    let init = interpolate(&trials.reference, d.window_start_ns).unwrap_or(Pose2::IDENTITY);
    let (spliced, unspliced) = (d.spliced(&dataset.log).unwrap_or_else(|e| panic!("{e}")), d.unspliced(&dataset.log));
    let a = trials.run_one(spliced.clone(), &job, init).unwrap_or_else(|e| panic!("{e}"));
    let b = trials.run_one(unspliced.clone(), &job, init).unwrap_or_else(|e| panic!("{e}"));
    let before = |r: &UpdateRun| r.poses.iter().filter(|e| e.stamp_ns <= d.cut.start_ns).copied().collect::<Vec<_>>();
    assert!(!before(&a).is_empty() && before(&a) == before(&b));
    let (gap, at) = worst_odometry_gap(&spliced);
    assert!(gap >= 0.5 && at == d.cut.start_ns, "the spliced log's odometry misses the jump: {gap} m at {at}");
    let (gap, _) = worst_odometry_gap(&unspliced);
    assert!(gap < 0.3, "the unspliced log has no kidnap: odometry and reference agree within {gap} m");
}
