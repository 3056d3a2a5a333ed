//! The `mapkeeper` preset's additions to the paper (docs/paper-vs-implementation.md): the hit
//! clearance, grazing gate, ray core and shadow of the removal vote, the free-pass votes, the
//! minimum final chunk, the revert of flipped cells and border reconstruction of interiors
//! only. Each test shows the failure an addition prevents: the `paper-strict` preset (or
//! `mapkeeper-no-registration` with that one addition switched off) has it, `mapkeeper` does
//! not.
#![allow(clippy::unwrap_used)]

mod common;

use common::{Lidar, fill_rect, room, synth_scan};
use mapkeeper_grid::{CellCoord, CellState, OccupancyGrid, Pose2};
use mapkeeper_sensor::LaserScan;
use mapkeeper_updater::{MapUpdater, UpdaterParams, Verdict};

/// Deterministic N(0, sigma²)-ish noise (sum of uniforms) from a splitmix64 stream.
struct Noise(u64);

impl Noise {
    fn next_u(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn gauss(&mut self, sigma: f64) -> f64 {
        (0..12).map(|_| self.next_u()).sum::<f64>().mul_add(sigma, -6.0 * sigma)
    }
}

fn scan(world: &OccupancyGrid, truth: Pose2, k: usize, noise: &mut Noise, sigma: f64) -> LaserScan {
    let inc = std::f64::consts::PI / 360.0;
    let lidar = Lidar::centred(-std::f64::consts::PI, inc, 720);
    let mut s = synth_scan(world, truth, &lidar, k as u64 * 100_000_000);
    for r in &mut s.ranges_m {
        if r.is_finite() {
            *r += noise.gauss(sigma) as f32;
        }
    }
    s
}

/// Drives along +x at 6 cm per step; the estimate is the truth composed with `error`.
fn drive(up: &mut MapUpdater, world: &OccupancyGrid, start: Pose2, steps: usize, error: Pose2, sigma: f64) {
    let mut noise = Noise(7);
    for k in 0..steps {
        let truth = Pose2::new(start.x + 0.06 * k as f64, start.y, start.yaw);
        let s = scan(world, truth, k, &mut noise, sigma);
        let r = up.process(truth.compose(&error), truth, &[s]);
        assert_eq!(r.verdict, Some(Verdict::Update), "step {k}");
    }
}

/// §4 at its strictest (the additions of the second release were made against it).
fn without_additions() -> UpdaterParams {
    UpdaterParams::paper_strict()
}

/// The second release's additions alone (registration and the memory have tests of their own,
/// `tests/registration_and_memory.rs`): with registration on, the pose errors these scenes use
/// would simply be corrected.
fn mapkeeper() -> UpdaterParams {
    UpdaterParams::mapkeeper_no_registration()
}

fn changed_cells(a: &OccupancyGrid, b: &OccupancyGrid) -> Vec<(CellCoord, CellState, CellState)> {
    let g = a.geometry();
    (0..g.len()).filter(|&i| a.cells()[i] != b.cells()[i]).map(|i| (g.coord(i), a.cells()[i], b.cells()[i])).collect()
}

/// A robot driving along a wall 0.5 m away, its estimate 2 cm off towards the wall and 0.3°
/// turned: the rays that graze the wall cross its cells in the map far from where they end.
/// Without the additions (`paper`) the wall erodes; with them (`mapkeeper`) the map is unchanged.
#[test]
fn driving_along_a_wall_with_a_small_pose_error_does_not_erode_it() {
    let world = room(10.0, 4.0, 0.05);
    let start = Pose2::new(1.0, 0.55, 0.0);
    let error = Pose2::new(0.0, -0.02, 0.3f64.to_radians());
    let mut plain = MapUpdater::new(world.clone(), without_additions()).unwrap();
    drive(&mut plain, &world, start, 120, error, 0.01);
    let eroded = changed_cells(&world, plain.map());
    assert!(
        eroded.iter().filter(|(_, from, to)| *from == CellState::Occupied && *to == CellState::Free).count() >= 5,
        "the scenario must show the erosion without the additions: {eroded:?}"
    );
    let mut keeper = MapUpdater::new(world.clone(), mapkeeper()).unwrap();
    drive(&mut keeper, &world, start, 120, error, 0.01);
    assert_eq!(changed_cells(&world, keeper.map()), vec![], "the mapkeeper preset must leave the map unchanged");
}

/// A box added in front of the robot, seen with 3 cm range noise and an estimate 3 cm short of the truth: its
/// face enters the map, and with free-pass votes no cell in front of the face (free in the
/// world) becomes occupied.
#[test]
fn added_box_face_is_not_smeared_towards_the_robot() {
    let base = room(8.0, 4.0, 0.05);
    let mut world = base.clone();
    fill_rect(&mut world, 6.0, 1.5, 6.5, 2.5, CellState::Occupied);
    let in_front = |m: &OccupancyGrid| {
        changed_cells(&base, m)
            .into_iter()
            .filter(|(c, _, to)| *to == CellState::Occupied && m.geometry().cell_center(*c).x < 5.95)
            .count()
    };
    let face =
        |m: &OccupancyGrid| (30..50).filter(|&iy| m.get(CellCoord::new(120, iy)) == Some(CellState::Occupied)).count();
    let start = Pose2::new(1.0, 2.0, 0.0);
    let error = Pose2::new(-0.03, 0.0, 0.0);
    let mut plain = MapUpdater::new(base.clone(), without_additions()).unwrap();
    drive(&mut plain, &world, start, 60, error, 0.03);
    let mut keeper = MapUpdater::new(base.clone(), mapkeeper()).unwrap();
    drive(&mut keeper, &world, start, 60, error, 0.03);
    assert!(in_front(plain.map()) >= 5, "without free-pass votes the face smears: {}", in_front(plain.map()));
    assert_eq!(in_front(keeper.map()), 0);
    assert!(face(keeper.map()) >= 15, "the face is in the map: {} of 20 cells", face(keeper.map()));
    // The free-pass votes alone make the difference.
    let mut no_pass = MapUpdater::new(base.clone(), UpdaterParams { free_pass_votes: false, ..mapkeeper() }).unwrap();
    drive(&mut no_pass, &world, start, 60, error, 0.03);
    assert!(in_front(no_pass.map()) >= 5, "mapkeeper without free-pass: {}", in_front(no_pass.map()));
}

/// The shadow of a withheld vote: a ray that enters a box through its corner while skimming
/// the box's side (the grazing gate withholds the corner's vote) gives no vote to the box's
/// inside, nor, across a one-cell gap, to a box stacked on it (entered through its face, not a
/// corner); a gap of three free cells ends the shadow.
#[test]
fn a_withheld_vote_shadows_the_obstacle_behind_it() {
    use mapkeeper_grid::{GridGeometry, Point2};
    use mapkeeper_updater::StepTolerance;
    use mapkeeper_updater::additions::removal_gates::RemovalGates;
    use mapkeeper_updater::paper::changed_cells::evaluate_changed_beam;
    use mapkeeper_updater::support::beam_walk::BeamGeometry;
    use mapkeeper_updater::support::hit_index::HitIndex;
    for (gap, expect_votes_in_b) in [(1, false), (3, true)] {
        let g = GridGeometry::new(40, 80, 0.05, Pose2::IDENTITY).unwrap();
        let mut base = OccupancyGrid::filled(g, CellState::Free);
        // Box A: cells x 10..=20, y 20..=35; box B, wider (x 10..=26), above it after `gap` free
        // rows.
        let b0 = 36 + gap;
        let mut put_box = |x0: i32, x1: i32, y0: i32, y1: i32| {
            for x in x0..=x1 {
                for y in y0..=y1 {
                    let edge = x == x0 || x == x1 || y == y0 || y == y1;
                    base.set(CellCoord::new(x, y), if edge { CellState::Occupied } else { CellState::Unknown });
                }
            }
        };
        put_box(10, 20, 20, 35);
        put_box(10, 26, b0, b0 + 15);
        // Nearly vertical, inside the right column of both boxes' outlines (x = 20 is the right
        // face; the ray runs in x ∈ [1.0, 1.05), entering A at its bottom-right corner cell).
        let origin = Point2::new(1.03, 0.2);
        let hit = Point2::new(1.02, 3.9);
        let z = origin.distance(hit);
        let mut votes = Vec::new();
        let hits = HitIndex::new();
        evaluate_changed_beam(
            &base,
            &BeamGeometry::new(origin, hit, z),
            (&mapkeeper(), &StepTolerance::NONE),
            |b| RemovalGates::new(&base, &mapkeeper().removal, &hits, b),
            &mut votes,
        );
        let voted: Vec<CellCoord> = votes.iter().map(|v| g.coord((v >> 1) as usize)).collect();
        assert!(!voted.iter().any(|c| (20..=35).contains(&c.iy)), "gap {gap}: box A voted: {voted:?}");
        let in_b = voted.iter().any(|c| (b0..=b0 + 15).contains(&c.iy));
        assert_eq!(in_b, expect_votes_in_b, "gap {gap}: {voted:?}");
        // Without the shadow, box B is voted across a one-cell gap too (the grazing gate alone
        // withholds box A's right face).
        votes.clear();
        let mut unshadowed = mapkeeper();
        unshadowed.removal.shadow = false;
        evaluate_changed_beam(
            &base,
            &BeamGeometry::new(origin, hit, z),
            (&unshadowed, &StepTolerance::NONE),
            |b| RemovalGates::new(&base, &unshadowed.removal, &hits, b),
            &mut votes,
        );
        assert!(votes.iter().any(|v| (b0..=b0 + 15).contains(&g.coord((v >> 1) as usize).iy)), "gap {gap}");
        // Without the additions the ray votes box A's cells.
        votes.clear();
        evaluate_changed_beam(
            &base,
            &BeamGeometry::new(origin, hit, z),
            (&without_additions(), &StepTolerance::NONE),
            |b| RemovalGates::new(&base, &without_additions().removal, &hits, b),
            &mut votes,
        );
        assert!(votes.iter().any(|v| (20..=35).contains(&g.coord((v >> 1) as usize).iy)));
    }
}
