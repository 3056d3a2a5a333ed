//! The property of the `updater_params` fuzz target, shared with its replay test
//! (`crates/updater/tests/fuzz_corpus.rs` includes this file with `#[path]`), so both check the
//! same thing: the text is laid over each preset of `UpdaterParams` the way the CLI does it
//! (`mapkeeper_common::params_from_toml_str`, the in-memory half of `load_params`),
//! then validated.
//!
//! - A refusal names the place: a syntax error its line and column, a type error or an unknown
//!   key the key, a `validate()` error a field that exists.
//! - Accepted parameters build a `MapUpdater` on a 6 m × 4 m room and run eleven steps over
//!   it (an agreeing scan, seven of moved obstacles, a pose 0.6 m off, a crowd so the check
//!   says Lost and pose updating runs, two lidars with bad readings). Nothing may panic;
//!   reported changes stay inside the map and match it, recovered poses and their covariance
//!   are finite, and the updater's memory is bounded (`MAX_UPDATER_BYTES`).
//!
//! Deterministic: no clock, no randomness.

use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Pose2, RayStop, cast_ray};
use mapkeeper_sensor::LaserScan;
use mapkeeper_updater::{MapUpdater, PRESET_NAMES, PoseRecovery, StepReport, UpdaterParams, Verdict};

/// Bytes the updater may hold on the room of [`room`] (2,400 cells) after the steps: caches,
/// change state and scratch. A parameter that makes it allocate more is a finding.
pub const MAX_UPDATER_BYTES: usize = 64 << 20;

/// What one input did, summed over the presets.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Checked {
    /// Presets the text was accepted over.
    pub accepted: usize,
    /// Refused by the TOML parser (syntax): the message gives line and column.
    pub syntax: usize,
    /// Refused by deserialisation (wrong type, unknown key or variant): the message names the key.
    pub typed: usize,
    /// Refused by `validate()`: the message names the field.
    pub invalid: usize,
    /// Steps given the verdict Lost, over the accepted presets.
    pub lost: usize,
    /// Steps with a pose-updating attempt.
    pub recoveries: usize,
}

/// Which accepted presets [`check`] runs the updater with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Run {
    /// Every preset the text was accepted over (the replay test).
    All,
    /// One: the first accepted at or after a preset picked by a hash of the text (the fuzz
    /// target: a run with pose updating takes about 20 ms, so six per input would cut the
    /// executions sixfold; validation, which is cheap, still sees every preset).
    One,
}

/// Runs the property on `text`: laid over every preset and validated, then the updater run
/// with the accepted parameters of the presets `run` picks. Panics if the property fails.
pub fn check(text: &str, run: Run) -> Checked {
    let mut out = Checked::default();
    let mut accepted = Vec::new();
    for name in PRESET_NAMES {
        let preset = UpdaterParams::preset(name).expect("a listed preset");
        match mapkeeper_common::params_from_toml_str(preset.clone(), text, UpdaterParams::validate) {
            Ok(params) => {
                out.accepted += 1;
                accepted.push(Some(params));
            }
            Err(m) => {
                accepted.push(None);
                match classify_error(&m, &preset) {
                    Refusal::Syntax => out.syntax += 1,
                    Refusal::Typed => out.typed += 1,
                    Refusal::Invalid => out.invalid += 1,
                }
            }
        }
    }
    let n = accepted.len();
    // FNV-1a: any deterministic hash will do.
    let pick = text.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |h, b| (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3));
    let first = (pick % n as u64) as usize;
    for k in 0..n {
        if let Some(params) = accepted[(first + k) % n].take() {
            exercise(params, &mut out);
            if run == Run::One {
                break;
            }
        }
    }
    out
}

enum Refusal {
    Syntax,
    Typed,
    Invalid,
}

/// Which kind of refusal `m` is; panics if it names no place.
fn classify_error(m: &str, preset: &UpdaterParams) -> Refusal {
    assert!(!m.is_empty(), "an empty error");
    if let Some(rest) = m.strip_prefix("invalid updater parameter '") {
        let field = rest.split('\'').next().unwrap_or_default();
        assert!(field_exists(preset, field), "validate() names '{field}', which is no parameter: {m}");
        return Refusal::Invalid;
    }
    if m.starts_with("TOML parse error at line ") {
        assert!(m.contains(", column "), "a syntax error without its column: {m}");
        return Refusal::Syntax;
    }
    // serde's messages, with the key the toml crate appends ("in `a.b`"), or the unknown key.
    let names_key = m.contains("\nin `") || m.starts_with("unknown field `");
    assert!(names_key, "a refusal that names neither a line nor a key: {m}");
    Refusal::Typed
}

/// Whether the dotted path `field` leads to a value of the serialised `preset`.
fn field_exists(preset: &UpdaterParams, field: &str) -> bool {
    let mut v = serde_json::to_value(preset).expect("a preset serialises");
    for part in field.split('.') {
        match v.get(part) {
            Some(next) => v = next.clone(),
            None => return false,
        }
    }
    true
}

/// The test room: 6 m × 4 m at 0.1 m (60 × 40 cells), one-cell walls, a pillar the world of
/// the later steps lacks, and an unknown patch (border reconstruction, unknown-as-occupied).
pub fn room() -> OccupancyGrid {
    let g = GridGeometry::new(60, 40, 0.1, Pose2::IDENTITY).expect("a valid geometry");
    let mut m = OccupancyGrid::filled(g, CellState::Free);
    for x in 0..60 {
        m.set(CellCoord::new(x, 0), CellState::Occupied);
        m.set(CellCoord::new(x, 39), CellState::Occupied);
    }
    for y in 0..40 {
        m.set(CellCoord::new(0, y), CellState::Occupied);
        m.set(CellCoord::new(59, y), CellState::Occupied);
    }
    fill(&mut m, (30, 25), (33, 28), CellState::Occupied);
    fill(&mut m, (50, 30), (55, 36), CellState::Unknown);
    m
}

fn fill(m: &mut OccupancyGrid, (x0, y0): (i32, i32), (x1, y1): (i32, i32), state: CellState) {
    for x in x0..x1 {
        for y in y0..y1 {
            m.set(CellCoord::new(x, y), state);
        }
    }
}

/// A scan of `world` by a lidar mounted at `mount` on a robot at `robot`: `beams` beams from
/// `angle_min` every `increment`, ranges 5 mm beyond the cast, `+inf` for no hit.
fn scan(
    world: &OccupancyGrid,
    robot: Pose2,
    mount: Pose2,
    (angle_min, increment, beams): (f64, f64, usize),
    stamp_ns: u64,
) -> LaserScan {
    let lidar = robot.compose(&mount);
    let ranges_m = (0..beams)
        .map(|i| {
            let hit = cast_ray(world, lidar.position(), lidar.yaw + angle_min + i as f64 * increment, 30.0, true);
            match hit.stop {
                RayStop::Occupied | RayStop::Unknown => (hit.range_m + 0.005) as f32,
                RayStop::LeftGrid | RayStop::MaxRange => f32::INFINITY,
            }
        })
        .collect();
    LaserScan {
        stamp_ns,
        lidar_id: 0,
        lidar_in_robot: mount,
        angle_min_rad: angle_min,
        angle_increment_rad: increment,
        range_min_m: 0.05,
        range_max_m: 30.0,
        ranges_m,
        sweep: None,
    }
}

/// Builds the updater with `params` (accepted by `validate()`, so `MapUpdater::new` must
/// accept them too) and runs the eleven steps.
fn exercise(params: UpdaterParams, out: &mut Checked) {
    let map = room();
    let mut world = map.clone();
    fill(&mut world, (30, 25), (33, 28), CellState::Free);
    fill(&mut world, (40, 10), (44, 14), CellState::Occupied);
    let mut up = match MapUpdater::new(map.clone(), params) {
        Ok(up) => up,
        Err(e) => panic!("validate() accepted parameters MapUpdater::new refuses: {e}"),
    };
    let full = (0.0, 5f64.to_radians(), 72);
    let step_ns = 100_000_000;
    // 1: the scan agrees with the map.
    let a = Pose2::new(1.5, 2.0, 0.0);
    let r = up.process(a, a, &[scan(&map, a, Pose2::IDENTITY, full, 0)]);
    after_step(&up, &r, out);
    // 2-8: the pillar is gone, a box is new; seven scans of it flip cells at the presets'
    // threshold of 7.
    for k in 1..8 {
        let b = Pose2::new(1.5 + 0.1 * k as f64, 2.0, 0.05 * k as f64);
        let r = up.process(b, b, &[scan(&world, b, Pose2::IDENTITY, full, k * step_ns)]);
        after_step(&up, &r, out);
    }
    // 9: the estimate is 0.6 m and 0.8 rad off the truth (the odometry is right): Suspend or
    // Lost, as D_eps says.
    let c = Pose2::new(2.5, 2.1, 0.8);
    let c_est = Pose2::new(3.0, 1.7, 1.6);
    let r = up.process(c_est, c, &[scan(&world, c, Pose2::IDENTITY, full, 8 * step_ns)]);
    after_step(&up, &r, out);
    // 10: a crowd round the robot, every beam short: Lost, and pose updating runs.
    let crowd = LaserScan { ranges_m: vec![0.25; 72], ..scan(&world, c, Pose2::IDENTITY, full, 9 * step_ns) };
    let r = up.process(c, c, &[crowd]);
    after_step(&up, &r, out);
    // 11: two lidars, one mirrored and off-centre, with bad readings.
    let d = Pose2::new(3.0, 2.0, 1.2);
    let mut front = scan(&world, d, Pose2::new(0.2, -0.1, -0.5), (1.5, -2f64.to_radians(), 135), 10 * step_ns);
    for (k, r) in [f32::NAN, f32::NEG_INFINITY, -1.0, 0.0, 0.01, 31.0].into_iter().enumerate() {
        front.ranges_m[k * 7] = r;
    }
    let back = LaserScan { lidar_id: 1, ..scan(&world, d, Pose2::new(-0.2, 0.1, 3.0), full, 10 * step_ns + 1_000) };
    let r = up.process(d, d, &[front, back]);
    after_step(&up, &r, out);
}

/// What must hold after every step.
fn after_step(up: &MapUpdater, r: &StepReport, out: &mut Checked) {
    // A cell may change more than once in a step (the log-odds baseline re-thresholds ray by
    // ray): the changes of a cell chain, and the last one is the cell's state in M_i.
    let g = up.map().geometry();
    let mut last = std::collections::BTreeMap::new();
    for c in &r.changed_cells {
        assert!(g.contains(c.cell), "changed cell {:?} outside the map", c.cell);
        if let Some(to) = last.insert((c.cell.ix, c.cell.iy), c.to) {
            assert_eq!(to, c.from, "changes of cell {:?} that do not chain", c.cell);
        }
    }
    for ((ix, iy), to) in last {
        assert_eq!(up.map().get(CellCoord::new(ix, iy)), Some(to), "a reported change that is not in M_i");
    }
    assert!(r.n_dc <= r.n_valid, "{} detected changes of {} valid beams", r.n_dc, r.n_valid);
    if r.verdict == Some(Verdict::Lost) {
        out.lost += 1;
    }
    match &r.pose_recovery {
        Some(PoseRecovery::Recovered { pose_in_map, covariance, fitness }) => {
            out.recoveries += 1;
            assert!(pose_in_map.is_finite(), "a recovered pose that is not finite: {pose_in_map:?}");
            assert!(
                covariance.iter().flatten().all(|v| v.is_finite()),
                "a recovered pose with covariance {covariance:?}"
            );
            assert!((0.0..=1.0).contains(&fitness.inlier_ratio), "inlier ratio {}", fitness.inlier_ratio);
        }
        Some(PoseRecovery::NotRecovered { .. }) => out.recoveries += 1,
        None => {}
    }
    let bytes = up.cache_bytes() + up.change_state_bytes() + up.scratch_bytes();
    assert!(bytes <= MAX_UPDATER_BYTES, "the updater holds {bytes} bytes on a 2,400-cell map");
}
