//! Output digests of the updater over fixed scenarios built on the benchmark scene: every
//! step's report (verdict, n, n_dc, cell changes, pose recovery), the number of buffered cells
//! after each step, and the final map's cells. Speed work must leave them bit-identical
//! (tests/output_digest.rs pins them; the CPU-time example prints them).
#![allow(dead_code)]

use super::bench_scene::{route, warehouse};
use super::s300_pair;
use mapkeeper_common::seeds::Fnv1a64;
use mapkeeper_grid::RayCaster;
use mapkeeper_grid::{CellState, GridGeometry, OccupancyGrid, Pose2};
use mapkeeper_sensor::LaserScan;
use mapkeeper_updater::paper::beam_classifier::BeamClassifier;
use mapkeeper_updater::{MapUpdater, UpdaterParams};

/// One digest scenario: a preset, the map geometry's origin, how many steps of the route, and
/// whether the pose handed to the updater carries a deterministic error (with a large one every
/// 40th step, so that Lost and pose updating are exercised).
#[derive(Clone, Copy, Debug)]
pub struct Scenario {
    pub name: &'static str,
    pub preset: &'static str,
    pub map_origin: Pose2,
    pub steps: usize,
    pub pose_error: bool,
}

/// The pinned scenarios. The first five are those of the second release, with its `paper` and
/// `mapkeeper` presets under their names of today (`paper-strict`, `mapkeeper-no-registration`):
/// their digests did not change when the presets were renamed. The next three are the third
/// release's `paper` and `mapkeeper`, the last two issue 53's `mapkeeper-evidence`.
pub const SCENARIOS: [Scenario; 10] = [
    Scenario {
        name: "paper-strict, exact poses, one lap",
        preset: "paper-strict",
        map_origin: Pose2::IDENTITY,
        steps: 630,
        pose_error: false,
    },
    Scenario {
        name: "paper-strict, pose errors",
        preset: "paper-strict",
        map_origin: Pose2::IDENTITY,
        steps: 320,
        pose_error: true,
    },
    Scenario {
        name: "authors, pose errors",
        preset: "authors",
        map_origin: Pose2::IDENTITY,
        steps: 320,
        pose_error: true,
    },
    Scenario {
        name: "mapkeeper-no-registration, pose errors",
        preset: "mapkeeper-no-registration",
        map_origin: Pose2::IDENTITY,
        steps: 320,
        pose_error: true,
    },
    Scenario {
        name: "mapkeeper-no-registration, rotated map origin, pose errors",
        preset: "mapkeeper-no-registration",
        map_origin: Pose2::new(-3.0, 2.0, 0.3),
        steps: 320,
        pose_error: true,
    },
    Scenario { name: "paper, pose errors", preset: "paper", map_origin: Pose2::IDENTITY, steps: 320, pose_error: true },
    Scenario {
        name: "mapkeeper, pose errors",
        preset: "mapkeeper",
        map_origin: Pose2::IDENTITY,
        steps: 320,
        pose_error: true,
    },
    Scenario {
        name: "mapkeeper, rotated map origin, pose errors",
        preset: "mapkeeper",
        map_origin: Pose2::new(-3.0, 2.0, 0.3),
        steps: 320,
        pose_error: true,
    },
    Scenario {
        name: "mapkeeper-evidence, pose errors",
        preset: "mapkeeper-evidence",
        map_origin: Pose2::IDENTITY,
        steps: 320,
        pose_error: true,
    },
    Scenario {
        name: "mapkeeper-evidence, rotated map origin, pose errors",
        preset: "mapkeeper-evidence",
        map_origin: Pose2::new(-3.0, 2.0, 0.3),
        steps: 320,
        pose_error: true,
    },
];

/// `m` with its origin moved to `origin` (same cells: the map turned and shifted in the world).
pub fn moved(m: &OccupancyGrid, origin: Pose2) -> OccupancyGrid {
    let g = m.geometry();
    let mut out = OccupancyGrid::filled(
        GridGeometry::new(g.width(), g.height(), g.resolution_m(), origin).unwrap(),
        CellState::Free,
    );
    out.cells_mut().copy_from_slice(m.cells());
    out
}

/// The steps of a scenario: (true robot pose in the map, scans), in order.
pub fn scenario_steps(s: &Scenario) -> (OccupancyGrid, Vec<(Pose2, Vec<LaserScan>)>) {
    let (map, world) = warehouse();
    let (map, world) = (moved(&map, s.map_origin), moved(&world, s.map_origin));
    let poses = route();
    let steps = (0..s.steps)
        .map(|k| {
            let p = s.map_origin.compose(&poses[k % poses.len()]);
            (p, s300_pair(&world, p, k as u64 * 400_000_000))
        })
        .collect();
    (map, steps)
}

/// The pose handed to the updater at step `k`.
pub fn estimate(s: &Scenario, k: usize, truth: Pose2) -> Pose2 {
    if !s.pose_error {
        return truth;
    }
    let kf = k as f64;
    let mut e = Pose2::new(0.03 * (0.7 * kf).sin(), 0.02 * (1.1 * kf).cos(), 0.012 * (0.37 * kf).sin());
    if k % 40 == 39 {
        e = Pose2::new(0.6, -0.4, 0.6);
    }
    truth.compose(&e)
}

/// The digest of one scenario and its number of processed steps.
pub fn scenario_digest(s: &Scenario) -> (u64, usize) {
    let (map, steps) = scenario_steps(s);
    let params = UpdaterParams::preset(s.preset).unwrap();
    // The classifier alone as well, so that each beam's class and hit point are pinned too.
    let caster = RayCaster::new(&map, true);
    let mut classifier = BeamClassifier::new();
    let mut up = MapUpdater::new(map, params.clone()).unwrap();
    let mut h = Fnv1a64::new();
    let mut processed = 0;
    for (k, (truth, scans)) in steps.iter().enumerate() {
        let odom = s.map_origin.inverse().compose(truth);
        let est = estimate(s, k, *truth);
        let counts = classifier.classify(&caster, &est, scans, &params, &mapkeeper_updater::StepTolerance::NONE);
        h.write(format!("{counts:?}").as_bytes());
        for b in &classifier.beams {
            h.write(&[b.class as u8]);
            h.write_u64(b.hit.x.to_bits());
            h.write_u64(b.hit.y.to_bits());
            h.write_u64(b.range_m.to_bits());
        }
        let r = up.process(est, odom, scans);
        if r.verdict.is_some() {
            processed += 1;
        }
        h.write(legacy(format!("{r:?}")).as_bytes());
        h.write_u64(up.buffered_cells() as u64);
    }
    h.write(&up.map().cells().iter().map(|&c| c as u8).collect::<Vec<_>>());
    h.write(legacy(format!("{:?}", up.stats())).as_bytes());
    (h.finish(), processed)
}

/// A report or the running totals as the second release printed them when registration and
/// the memory are off (their fields then hold their defaults and are left out), so that the
/// digests of the presets that did not change stay those pinned then. The fit's position sigma
/// (`xy_sigma_m`, reported since the tolerances that follow the pose uncertainty) is left out
/// too: it is a new figure of the same fit, not a change of what the updater does; so is the
/// paper's check's verdict before the shift check (`check_verdict`). A global search that did
/// not run (its report `None`, its counts 0) is left out as well, and the shift check's scores
/// (`shift_check`) always.
fn legacy(debug: String) -> String {
    const FIELD: &str = ", xy_sigma_m: ";
    let unused = format!(", registration: {:?}, heal_votes: 0", mapkeeper_updater::RegistrationStats::default());
    let mut out = debug
        .replace(", registration: None", "")
        .replace(&unused, "")
        .replace(", global_search: None", "")
        .replace(", global_searches: 0, global_recoveries: 0, global_nodes: 0", "");
    // Refusals were counted in an array then: `refused: [a, b, c, d]`.
    if let Some(at) = out.find("refused_too_few_points: ") {
        let end = out[at..].find(", writes_withheld").map_or(out.len(), |k| at + k);
        let counts: Vec<&str> = out[at..end].split(", ").filter_map(|f| f.split(": ").nth(1)).collect();
        out.replace_range(at..end, &format!("refused: [{}]", counts.join(", ")));
    }
    // The shift check's scores (reported since issue 33), a new figure of the same step: the
    // report's last field.
    if let Some(at) = out.find(", shift_check: ") {
        let end = out.rfind(" }").filter(|&e| e > at).unwrap_or(out.len());
        out.replace_range(at..end, "");
    }
    // The paper's check's own verdict (reported since the MCAP layer of the check's state): a new
    // figure of the same step, printed between `verdict` and `n_valid`.
    if let Some(at) = out.find(", check_verdict: ") {
        let end = out[at..].find(", n_valid").map_or(out.len(), |k| at + k);
        out.replace_range(at..end, "");
    }
    while let Some(at) = out.find(FIELD) {
        let value = at + FIELD.len();
        let end = out[value..].find([',', ' ', '}']).map_or(out.len(), |k| value + k);
        out.replace_range(at..end, "");
    }
    out
}
