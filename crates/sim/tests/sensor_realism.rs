//! Lidars as data and sensor realism (issue 13, items 4 and 5): upside-down lidars mirror the
//! scan but see the same points; each realism effect changes the scans, draws from its own
//! streams, and is deterministic; the ideal profile is the simulator as before, bit for bit.

use mapkeeper_grid::{Point2, Pose2};
use mapkeeper_sensor::LaserScan;
use mapkeeper_sim::{LidarNoise, Route, SensorEffect, SensorRealism, SimParams, Simulator, StepOutput, World};

/// FNV-1a over every scan, odometry and true pose of `outs`.
fn digest(outs: &[StepOutput]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |b: &[u8]| {
        for &x in b {
            h = (h ^ u64::from(x)).wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    for o in outs {
        eat(&o.tick.to_le_bytes());
        for s in &o.scans {
            eat(&s.stamp_ns.to_le_bytes());
            eat(&s.lidar_id.to_le_bytes());
            eat(&s.angle_min_rad.to_bits().to_le_bytes());
            eat(&s.angle_increment_rad.to_bits().to_le_bytes());
            for r in &s.ranges_m {
                eat(&r.to_bits().to_le_bytes());
            }
        }
        for p in [o.odometry.pose_in_odom, o.truth.pose_in_map] {
            for v in [p.x, p.y, p.yaw] {
                eat(&v.to_bits().to_le_bytes());
            }
        }
    }
    h
}

/// `seconds` of the default warehouse's route with `params`.
fn drive(params: SimParams, seed: u64, seconds: u64) -> Vec<StepOutput> {
    let w = World::default_warehouse();
    let mut sim = Simulator::new(&w, params, seed).expect("default world builds");
    sim.set_route(Route::default_warehouse().points());
    (0..seconds * 50).map(|_| sim.step()).collect()
}

fn with_realism(realism: SensorRealism) -> SimParams {
    SimParams { realism, ..SimParams::default() }
}

/// Digest of 10 s of the default run (seed 11) before lidars became data and realism existed
/// (commit f85c8e0): the defaults must still give exactly these bits.
const DEFAULT_DIGEST_10S: u64 = 0x7d82_c5e1_506b_29ac;

#[test]
fn default_and_ideal_outputs_are_bit_identical_to_before() {
    let d = digest(&drive(SimParams::default(), 11, 10));
    assert_eq!(d, DEFAULT_DIGEST_10S, "default outputs changed: digest {d:#018x}");
    let ideal = SensorRealism::profile("ideal").unwrap();
    assert_eq!(digest(&drive(with_realism(ideal), 11, 10)), d);
}

/// The hit points of every valid beam of `scan` from the robot at `robot`.
fn points(scan: &LaserScan, robot: &Pose2) -> Vec<Point2> {
    let lidar = scan.lidar_in_map(robot);
    (0..scan.len()).filter_map(|i| scan.hit_point(&lidar, i)).collect()
}

#[test]
fn upside_down_lidars_mirror_the_scan_and_see_the_same_points() {
    let mut upright = SimParams::default();
    for l in &mut upright.lidars {
        l.noise = LidarNoise::none();
    }
    let mut flipped = upright.clone();
    for l in &mut flipped.lidars {
        l.upside_down = true;
    }
    let (a, b) = (drive(upright, 3, 6), drive(flipped, 3, 6));
    let mut compared = 0;
    for (oa, ob) in a.iter().zip(&b) {
        assert_eq!(oa.truth, ob.truth, "the robot drives the same");
        for (sa, sb) in oa.scans.iter().zip(&ob.scans) {
            assert!(sa.angle_increment_rad > 0.0 && sb.angle_increment_rad < 0.0);
            assert_eq!(sb.angle_min_rad, -sa.angle_min_rad);
            assert_eq!(sa.lidar_in_robot, sb.lidar_in_robot);
            // A symmetric 270° field: the mirrored scan is the upright one backwards.
            let reversed: Vec<f32> = sb.ranges_m.iter().rev().copied().collect();
            for (x, y) in sa.ranges_m.iter().zip(&reversed) {
                assert!((x - y).abs() < 1e-5, "{x} vs {y}");
            }
            let (pa, mut pb) = (points(sa, &oa.truth.pose_in_map), points(sb, &ob.truth.pose_in_map));
            pb.reverse();
            assert_eq!(pa.len(), pb.len());
            for (p, q) in pa.iter().zip(&pb) {
                assert!(p.distance(*q) < 1e-5, "{p:?} vs {q:?}");
            }
            compared += pa.len();
        }
    }
    assert!(compared > 10_000, "{compared}");
}

#[test]
fn every_effect_changes_the_scans_and_is_deterministic() {
    let ideal = drive(SimParams::default(), 5, 20);
    for e in SensorEffect::ALL {
        let one = drive(with_realism(SensorRealism::with_effects(&[e])), 5, 20);
        assert_ne!(digest(&one), digest(&ideal), "{} changes nothing", e.name());
        let again = drive(with_realism(SensorRealism::with_effects(&[e])), 5, 20);
        assert_eq!(digest(&one), digest(&again), "{} is not deterministic", e.name());
    }
}

/// The beams that read +inf in each lidar's k-th scan (in the warehouse every beam hits a wall
/// within range, so these are the dropouts).
fn dropouts(outs: &[StepOutput]) -> Vec<(u32, Vec<usize>)> {
    let mut v: Vec<(u32, Vec<usize>)> = outs
        .iter()
        .flat_map(|o| &o.scans)
        .map(|s| (s.lidar_id, (0..s.len()).filter(|&i| s.ranges_m[i].is_infinite()).collect()))
        .collect();
    v.sort_by_key(|(id, _)| *id); // stable: scan order kept within a lidar
    v
}

#[test]
fn effects_draw_from_their_own_streams() {
    // Dropouts every 20th beam on average: the dropout stream must be untouched by any effect,
    // so each lidar's k-th scan drops the same beams whatever else is switched on.
    let mut base = SimParams::default();
    for l in &mut base.lidars {
        l.noise.dropout_probability = 0.05;
    }
    let reference = dropouts(&drive(base.clone(), 8, 4));
    assert!(reference.iter().map(|(_, d)| d.len()).sum::<usize>() > 1000);
    for effects in [SensorEffect::ALL.to_vec(), vec![SensorEffect::Unsync], vec![SensorEffect::MixedPixels]] {
        let p = SimParams { realism: SensorRealism::with_effects(&effects), ..base.clone() };
        let mut got = dropouts(&drive(p, 8, 4));
        let n = got.len().min(reference.len());
        assert!(n + 4 >= reference.len(), "about as many scans");
        got.truncate(n);
        let mut want = reference.clone();
        want.truncate(n);
        // The lists are per lidar in scan order; compare lidar by lidar.
        for id in [0, 1] {
            let a: Vec<_> = got.iter().filter(|x| x.0 == id).collect();
            let b: Vec<_> = want.iter().filter(|x| x.0 == id).collect();
            for (x, y) in a.iter().zip(&b) {
                assert_eq!(x.1, y.1, "{effects:?}: lidar {id} dropouts moved");
            }
        }
    }
}

#[test]
fn a_robot_at_rest_sees_no_motion_distortion_or_latency() {
    // Motion distortion and latency come from the robot's motion only: standing still (no
    // route), its scans are the ideal ones, bit for bit (the jitter has its own stream).
    let w = World::default_warehouse();
    let run = |realism: SensorRealism| {
        let mut sim = Simulator::new(&w, with_realism(realism), 2).unwrap();
        (0..100).map(|_| sim.step()).collect::<Vec<_>>()
    };
    let still = run(SensorRealism::default());
    let moving = run(SensorRealism::with_effects(&[SensorEffect::MotionDistortion, SensorEffect::Latency]));
    assert_eq!(digest(&still), digest(&moving));
}

/// 12 s of the route with noiseless lidars, without and with motion distortion (seed 4).
fn exact_and_distorted_drives() -> (Vec<StepOutput>, Vec<StepOutput>) {
    let mut exact = SimParams::default();
    for l in &mut exact.lidars {
        l.noise = LidarNoise::none();
    }
    let distorted =
        SimParams { realism: SensorRealism::with_effects(&[SensorEffect::MotionDistortion]), ..exact.clone() };
    (drive(exact, 4, 12), drive(distorted, 4, 12))
}

#[test]
fn motion_distortion_bends_the_scan_of_a_moving_robot() {
    // Along the route at speed, a distorted scan's hit points (placed with the stamp's pose, as
    // the estimators do) lie off the ideal ones by up to the distance driven in one sweep.
    let (a, b) = exact_and_distorted_drives();
    let mut largest: f64 = 0.0;
    for (oa, ob) in a.iter().zip(&b) {
        for (sa, sb) in oa.scans.iter().zip(&ob.scans) {
            let (pa, pb) = (sa.lidar_in_map(&oa.truth.pose_in_map), sb.lidar_in_map(&ob.truth.pose_in_map));
            // The last beam is cast at the stamp: no distortion there.
            let last = sa.len() - 1;
            if let (Some(p), Some(q)) = (sa.hit_point(&pa, last), sb.hit_point(&pb, last)) {
                assert!(p.distance(q) < 1e-4, "{p:?} {q:?}");
            }
            if let (Some(p), Some(q)) = (sa.hit_point(&pa, 0), sb.hit_point(&pb, 0)) {
                largest = largest.max(p.distance(q));
            }
        }
    }
    // 1.5 m/s × 60 ms of sweep ≈ 9 cm; turning moves far points more.
    assert!(largest > 0.02, "largest first-beam shift {largest}");
}

#[test]
fn a_distorted_scan_says_when_its_beams_were_measured_and_deskewing_undoes_the_bend() {
    // Issue 30 item 4: with motion distortion each scan carries its sweep timing (the last beam
    // at the stamp); deskewed by the robot's motion between steps (at constant velocity), its
    // ranges come back to the undistorted ones, but for the re-binning to the beam layout.
    let (a, b) = exact_and_distorted_drives();
    assert!(a.iter().flat_map(|o| &o.scans).all(|s| s.sweep.is_none()), "ideal scans are instantaneous");
    let (mut raw_err, mut fixed_err) = (Vec::new(), Vec::new());
    let mut before: Option<(u64, Pose2)> = None;
    for (oa, ob) in a.iter().zip(&b) {
        let now = (oa.truth.stamp_ns, ob.truth.pose_in_map);
        for (sa, sb) in oa.scans.iter().zip(&ob.scans) {
            let t = sb.sweep.expect("a distorted scan carries its timing");
            assert!(t.beam_offset_s(sb.len() - 1).abs() < 1e-12 && t.time_increment_s > 0.0, "{t:?}");
            let Some((before_ns, before_pose)) = before else { continue };
            let at = mapkeeper_sensor::constant_velocity(before_pose, before_ns, now.1, now.0, sb.stamp_ns).unwrap();
            let fixed = mapkeeper_sensor::deskew(sb, at);
            for i in 0..sa.len() {
                let (e, r, f) = (sa.ranges_m[i], sb.ranges_m[i], fixed.ranges_m[i]);
                if e.is_finite() && r.is_finite() && f.is_finite() && e < 10.0 {
                    raw_err.push((r - e).abs());
                    fixed_err.push((f - e).abs());
                }
            }
        }
        before = Some(now);
    }
    let mean = |v: &[f32]| v.iter().map(|&x| f64::from(x)).sum::<f64>() / v.len() as f64;
    let (raw, fixed) = (mean(&raw_err), mean(&fixed_err));
    assert!(raw_err.len() > 10_000, "{} beams compared", raw_err.len());
    assert!(fixed < 0.5 * raw, "mean range error {fixed:.4} m deskewed against {raw:.4} m raw");
}
