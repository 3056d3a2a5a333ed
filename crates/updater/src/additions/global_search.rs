//! Global pose search when Lost (a `mapkeeper` addition, issue 33): the paper's pose updating
//! (§4.6) registers the scan from the predicted pose, so a robot moved without its odometry
//! seeing it (a real kidnap, a wheel slip on a lift) is never found once the move leaves ICP's
//! basin. This search looks for the scan's pose over **the whole map and every heading**: a
//! branch and bound over a pyramid of the map's match score, as Cartographer's fast correlative
//! matcher does (Hess et al., ICRA 2016, §V), written from that description.
//!
//! - **Score**: each cell holds how close it lies to an occupied cell of `M_i` (255 on one,
//!   falling linearly to 0 at `tolerance_m`); a pose scores the sum over the scan's points.
//! - **Pyramid**: level L holds, for each cell, the largest score of the 2^L × 2^L block that
//!   starts there. Summed over the points, level L bounds from above every pose whose position
//!   lies in the block, so whole blocks of the map are dropped at once.
//! - **Branch and bound**: for each heading on a grid of `yaw_step_rad`, the map is cut into
//!   blocks of the top level; blocks are split best first and dropped when their bound cannot
//!   beat the `candidates`-th best distinct pose found so far (or `min_score` of the highest
//!   possible score). A pose counts only where `M_i` says the cell is free.
//!
//! It runs when the local search found no pose, or one that fits less well than
//! `confident_inlier_ratio` (then that pose competes with the search's). The search returns the
//! best distinct poses; it decides nothing. The updater hands them to pose updating's own check (each registered to the cloud expected from it, then the fitness
//! gate and the ambiguity test), so a symmetric scene gives "not recovered", never a guess.
//! The work is bounded: at most `max_nodes` blocks are scored per search (the best found by
//! then are returned, and the report says the budget ran out).

use crate::support::chessboard::chessboard_distance;
use mapkeeper_common::ParamError;
use mapkeeper_grid::geometry::floor_exact;
use mapkeeper_grid::{CellState, OccupancyGrid, Point2, Pose2, angle_diff, wrap_angle};
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// The global search's parameters (`UpdaterParams::global_search`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GlobalSearchParams {
    /// Search the whole map when pose updating's local search finds no pose, or finds one
    /// fitting less well than `confident_inlier_ratio`. Default `false` (`mapkeeper`: `true`).
    pub enabled: bool,
    /// A pose of the local search fitting at least this well (inlier ratio) is taken without a
    /// global search; one fitting less well competes with the global search's candidates (a
    /// corner of the map near the prediction can pass the fitness gate while the robot stands
    /// in another). Default 0.9.
    pub confident_inlier_ratio: f64,
    /// A point farther than this from every occupied cell scores 0, metres. Default 0.25.
    pub tolerance_m: f64,
    /// Heading step, radians (every heading of the circle is tried). Default 0.02 (1.15°):
    /// a point 12 m away moves 0.24 m per step, within `tolerance_m`.
    pub yaw_step_rad: f64,
    /// Scan points scored (every k-th of pose updating's source points). Default 120.
    pub max_points: usize,
    /// Pyramid levels above the map (the top block is 2^levels cells wide). Default 6.
    pub levels: u32,
    /// Best distinct poses handed to the check. Default 6.
    pub candidates: usize,
    /// A pose scoring below this share of the highest possible score is not a candidate.
    /// Default 0.45.
    pub min_score: f64,
    /// Most blocks scored per search (the cost bound). Default 400,000.
    pub max_nodes: usize,
    /// The fitness gate of the check of the search's candidates: smallest inlier ratio. Lower
    /// than pose updating's own (0.7): the robot is Lost because the map and the scan disagree,
    /// and in a stale world they disagree at the right pose too; what guards against a wrong
    /// pose is the margin below. Default 0.55.
    pub min_inlier_ratio: f64,
    /// The ambiguity margin of the check of the search's candidates: the best must fit better
    /// than every distinct runner-up by this much (inlier ratio), else not recovered. Larger
    /// than the local search's, as a wrong pose found across the map costs more. Default 0.08.
    pub ambiguity_ratio_margin: f64,
    /// Views compared per attempt, the current one included (`recovery_views` module): each
    /// candidate is scored by its inlier ratio pooled over the current scans and those of up to
    /// `views − 1` earlier attempts of the same Lost stretch, placed by odometry. 1: the current
    /// scans alone. Default 1 (`mapkeeper`: 4).
    pub views: u32,
    /// An attempt's scans are kept beside the newest kept view only when the robot moved this
    /// far since it (else they replace it), metres. Default 0.3.
    pub view_baseline_m: f64,
    /// …or turned this much, radians. Default 0.26 (15°).
    pub view_turn_rad: f64,
    /// Kept views older than this are dropped, seconds. Default 30.
    pub view_max_age_s: f64,
    /// The best distinct poses of a refused attempt checked again at the next one (moved on by
    /// odometry) beside the search's peaks. Default 0 (`mapkeeper`: 4).
    pub kept_candidates: u32,
}

impl Default for GlobalSearchParams {
    fn default() -> Self {
        Self {
            enabled: false,
            confident_inlier_ratio: 0.9,
            tolerance_m: 0.25,
            yaw_step_rad: 0.02,
            max_points: 120,
            levels: 6,
            candidates: 6,
            min_score: 0.45,
            max_nodes: 400_000,
            min_inlier_ratio: 0.55,
            ambiguity_ratio_margin: 0.08,
            views: 1,
            view_baseline_m: 0.3,
            view_turn_rad: 0.26,
            view_max_age_s: 30.0,
            kept_candidates: 0,
        }
    }
}

impl GlobalSearchParams {
    /// `mapkeeper`'s: on, each attempt's candidates judged on up to four views of the Lost
    /// stretch, four candidates of a refused attempt kept.
    pub fn mapkeeper() -> Self {
        Self { enabled: true, views: 4, kept_candidates: 4, ..Self::default() }
    }

    /// Whether it is off with default values (then not written to files).
    pub fn is_default_off(&self) -> bool {
        *self == Self::default()
    }

    /// Checks every field; the first bad one is named `global_search.…`.
    pub fn validate(&self) -> Result<(), ParamError> {
        self.check_fields().map_err(|e| e.within("global_search"))
    }

    fn check_fields(&self) -> Result<(), ParamError> {
        fn check(name: &str, v: impl std::fmt::Display, ok: bool, requirement: &str) -> Result<(), ParamError> {
            if ok { Ok(()) } else { Err(ParamError::new(name, v, requirement)) }
        }
        let unit = |v: f64| v.is_finite() && (0.0..=1.0).contains(&v);
        let (t, yaw_step) = (self.tolerance_m, self.yaw_step_rad);
        check("tolerance_m", t, t.is_finite() && t > 0.0 && t <= 5.0, "must lie in (0, 5]")?;
        check(
            "yaw_step_rad",
            yaw_step,
            yaw_step.is_finite() && (1e-3..=1.0).contains(&yaw_step),
            "must lie in [0.001, 1]",
        )?;
        check("max_points", self.max_points, (10..=2_000).contains(&self.max_points), "must lie in 10..=2000")?;
        check("levels", self.levels, self.levels <= 10, "must lie in 0..=10")?;
        check("candidates", self.candidates, (1..=64).contains(&self.candidates), "must lie in 1..=64")?;
        let confident = self.confident_inlier_ratio;
        check("confident_inlier_ratio", confident, unit(confident), "must lie in [0, 1]")?;
        check("min_score", self.min_score, unit(self.min_score), "must lie in [0, 1]")?;
        let nodes = self.max_nodes;
        check("max_nodes", nodes, (1_000..=100_000_000).contains(&nodes), "must lie in 1000..=100000000")?;
        check("min_inlier_ratio", self.min_inlier_ratio, unit(self.min_inlier_ratio), "must lie in [0, 1]")?;
        let margin = self.ambiguity_ratio_margin;
        check("ambiguity_ratio_margin", margin, unit(margin), "must lie in [0, 1]")?;
        check("views", self.views, (1..=16).contains(&self.views), "must lie in 1..=16")?;
        let (b, t, age) = (self.view_baseline_m, self.view_turn_rad, self.view_max_age_s);
        check("view_baseline_m", b, b.is_finite() && b >= 0.0, "must be finite and ≥ 0")?;
        check("view_turn_rad", t, t.is_finite() && t >= 0.0, "must be finite and ≥ 0")?;
        check("view_max_age_s", age, age.is_finite() && age >= 0.0, "must be finite and ≥ 0")?;
        let kept = self.kept_candidates;
        check("kept_candidates", kept, kept <= 64, "must lie in 0..=64")
    }
}

/// What one search did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GlobalSearchReport {
    /// The best distinct poses, best first, with their share of the highest possible score.
    pub peaks: Vec<(Pose2, f64)>,
    /// Blocks scored (the search's work).
    pub nodes: usize,
    /// Headings tried.
    pub headings: usize,
    /// The node budget ran out before the search was complete.
    pub truncated: bool,
    /// The pose accepted on this step is one of the search's candidates (set by the updater;
    /// `false` when nothing was accepted or the local search's pose won).
    pub chosen: bool,
}

/// One level of the pyramid: for each cell (u, v), u ≥ −pad, v ≥ −pad, the largest score of
/// the block [u, u + 2^L) × [v, v + 2^L) of the map (0 outside it).
#[derive(Clone, Debug, Default)]
struct Level {
    pad: i64,
    stride: usize,
    rows: usize,
    data: Vec<u8>,
}

impl Level {
    fn at(&self, u: i64, v: i64) -> u8 {
        let (x, y) = (u + self.pad, v + self.pad);
        if x < 0 || y < 0 || x as usize >= self.stride || y as usize >= self.rows {
            return 0;
        }
        self.data[y as usize * self.stride + x as usize]
    }
}

/// A block of robot positions [a, a + 2^level) × [b, b + 2^level) at one heading.
#[derive(Clone, Copy, Debug)]
struct Node {
    bound: u32,
    heading: u32,
    a: i64,
    b: i64,
    level: u32,
}

/// The search with its reusable buffers (the pyramid is rebuilt for each search: the map may
/// have changed since).
#[derive(Clone, Debug, Default)]
pub struct GlobalSearch {
    levels: Vec<Level>,
    /// Per heading, the cell offset of each point from the robot's cell.
    offsets: Vec<Vec<(i64, i64)>>,
    stack: Vec<Node>,
    peaks: Vec<(u32, Pose2)>,
}

impl GlobalSearch {
    /// Empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// Heap bytes of the pyramid and the buffers (the pyramid is map-sized).
    pub fn heap_bytes(&self) -> usize {
        self.levels.iter().map(|l| l.data.capacity()).sum::<usize>()
            + self.offsets.iter().map(|o| o.capacity() * size_of::<(i64, i64)>()).sum::<usize>()
            + self.stack.capacity() * size_of::<Node>()
            + self.peaks.capacity() * size_of::<(u32, Pose2)>()
    }

    /// The best distinct poses of `points` (robot frame) in `map`: two poses are the same when
    /// closer than `same_m` and `same_rad`.
    pub fn search(
        &mut self,
        map: &OccupancyGrid,
        points: &[Point2],
        p: &GlobalSearchParams,
        same_m: f64,
        same_rad: f64,
    ) -> GlobalSearchReport {
        self.peaks.clear();
        self.stack.clear();
        let mut report = GlobalSearchReport::default();
        let k = points.len().div_ceil(p.max_points.max(1)).max(1);
        let pts: Vec<Point2> =
            points.iter().step_by(k).copied().filter(|q| q.x.is_finite() && q.y.is_finite()).collect();
        if pts.is_empty() || map.geometry().width() == 0 || map.geometry().height() == 0 {
            return report;
        }
        self.build_pyramid(map, p);
        self.build_offsets(map, &pts, p);
        report.headings = self.offsets.len();
        let top = self.levels.len() as u32 - 1;
        let min_score = (p.min_score * 255.0 * pts.len() as f64).ceil() as u32;
        let g = map.geometry();
        let side = 1i64 << top;
        let (w, h) = (g.width() as i64, g.height() as i64);
        for heading in 0..self.offsets.len() as u32 {
            for b in (0..h).step_by(side as usize) {
                for a in (0..w).step_by(side as usize) {
                    let bound = self.bound(heading, a, b, top);
                    report.nodes += 1;
                    if bound >= min_score {
                        self.stack.push(Node { bound, heading, a, b, level: top });
                    }
                }
            }
        }
        // Best last, so the stack pops the best block first.
        self.stack.sort_by(|x, y| x.bound.cmp(&y.bound).then(y.heading.cmp(&x.heading)));
        let same = |q: &Pose2, r: &Pose2| q.distance(r) <= same_m && angle_diff(q.yaw, r.yaw).abs() <= same_rad;
        while let Some(node) = self.stack.pop() {
            let floor = match self.peaks.get(p.candidates.saturating_sub(1)) {
                Some(&(s, _)) => s.max(min_score),
                None => min_score,
            };
            if node.bound < floor || (self.peaks.len() >= p.candidates && node.bound <= floor) {
                continue;
            }
            if node.level == 0 {
                if map.cells()[(node.b * w + node.a) as usize] == CellState::Free {
                    let c = g.grid_to_world(node.a as f64 + 0.5, node.b as f64 + 0.5);
                    let yaw = wrap_angle(node.heading as f64 * p.yaw_step_rad);
                    self.insert_peak(node.bound, Pose2::new(c.x, c.y, yaw), p.candidates, &same);
                }
                continue;
            }
            if report.nodes >= p.max_nodes {
                report.truncated = true;
                break;
            }
            let half = 1i64 << (node.level - 1);
            let mut children = [None; 4];
            for (i, (da, db)) in [(0, 0), (half, 0), (0, half), (half, half)].into_iter().enumerate() {
                let (a, b) = (node.a + da, node.b + db);
                if a >= w || b >= h {
                    continue;
                }
                let bound = self.bound(node.heading, a, b, node.level - 1);
                report.nodes += 1;
                if bound >= floor {
                    children[i] = Some(Node { bound, heading: node.heading, a, b, level: node.level - 1 });
                }
            }
            // Push the best child last (explored first); ties in a fixed order (a stable sort of
            // the four slots, no allocation per block).
            children.sort_by_key(|c| c.map_or(0, |n| n.bound));
            self.stack.extend(children.into_iter().flatten());
        }
        let full = 255.0 * pts.len() as f64;
        report.peaks = self.peaks.iter().map(|&(s, pose)| (pose, f64::from(s) / full)).collect();
        report
    }

    /// Σ over the points of level `level` at the block (a, b) of heading `heading`.
    fn bound(&self, heading: u32, a: i64, b: i64, level: u32) -> u32 {
        let l = &self.levels[level as usize];
        self.offsets[heading as usize].iter().map(|&(du, dv)| u32::from(l.at(a + du, b + dv))).sum()
    }

    /// Keeps the `keep` best distinct peaks, best first.
    fn insert_peak(&mut self, s: u32, pose: Pose2, keep: usize, same: &dyn Fn(&Pose2, &Pose2) -> bool) {
        if self.peaks.iter().any(|(t, q)| *t >= s && same(q, &pose)) {
            return;
        }
        self.peaks.retain(|(_, q)| !same(q, &pose));
        let at = self.peaks.iter().position(|(t, _)| *t < s).unwrap_or(self.peaks.len());
        self.peaks.insert(at, (s, pose));
        self.peaks.truncate(keep);
    }

    /// Per heading, the offset from the robot's cell to the cell of each point.
    fn build_offsets(&mut self, map: &OccupancyGrid, pts: &[Point2], p: &GlobalSearchParams) {
        let g = map.geometry();
        let n = ((TAU / p.yaw_step_rad).ceil() as usize).max(1);
        self.offsets.resize_with(n, Vec::new);
        self.offsets.truncate(n);
        let anchor = g.grid_to_world(0.5, 0.5);
        for (j, cells) in self.offsets.iter_mut().enumerate() {
            cells.clear();
            let robot = Pose2::new(anchor.x, anchor.y, j as f64 * p.yaw_step_rad);
            for q in pts {
                let (u, v) = g.world_to_grid(robot.transform_point(*q));
                if u.is_finite() && v.is_finite() && u.abs() < 1e9 && v.abs() < 1e9 {
                    cells.push((floor_exact(u) as i64, floor_exact(v) as i64));
                }
            }
        }
    }

    /// Level 0: 255 on an occupied cell falling linearly to 0 at `tolerance_m` (chessboard
    /// distance, two raster passes); level L from level L − 1 by the maximum of four.
    fn build_pyramid(&mut self, map: &OccupancyGrid, p: &GlobalSearchParams) {
        let g = map.geometry();
        let (w, h) = (g.width(), g.height());
        let reach = (p.tolerance_m / g.resolution_m()).ceil().clamp(1.0, 250.0) as u16;
        let mut d: Vec<u16> =
            map.cells().iter().map(|&c| if c == CellState::Occupied { 0 } else { reach + 1 }).collect();
        chessboard_distance(&mut d, w, h);
        let base: Vec<u8> = d
            .iter()
            .map(|&x| if x > reach { 0 } else { (255 * u32::from(reach + 1 - x) / u32::from(reach + 1)) as u8 })
            .collect();
        self.levels.clear();
        self.levels.push(Level { pad: 0, stride: w, rows: h, data: base });
        for level in 1..=p.levels {
            let prev = &self.levels[level as usize - 1];
            let half = 1i64 << (level - 1);
            let pad = (1i64 << level) - 1;
            let (stride, rows) = (w + pad as usize, h + pad as usize);
            let mut data = vec![0u8; stride * rows];
            for y in 0..rows {
                let v = y as i64 - pad;
                for x in 0..stride {
                    let u = x as i64 - pad;
                    data[y * stride + x] = prev
                        .at(u, v)
                        .max(prev.at(u + half, v))
                        .max(prev.at(u, v + half))
                        .max(prev.at(u + half, v + half));
                }
            }
            self.levels.push(Level { pad, stride, rows, data });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mapkeeper_grid::CellCoord;
    use mapkeeper_testkit::rooms::{fill_cells, walled_cells};

    /// A 10 m × 6 m walled room at 0.05 m with a post and a bar.
    fn room_with_posts() -> OccupancyGrid {
        let mut m = walled_cells(200, 120, 0.05, Pose2::IDENTITY);
        fill_cells(&mut m, 40..48, 30..38, CellState::Occupied);
        fill_cells(&mut m, 120..170, 80..84, CellState::Occupied);
        m
    }

    /// Points a lidar at `pose` would see: the occupied cells' centres within 6 m, thinned.
    fn seen_from(map: &OccupancyGrid, pose: Pose2) -> Vec<Point2> {
        let g = map.geometry();
        let inv = pose.inverse();
        let mut out = Vec::new();
        for y in 0..g.height() {
            for x in 0..g.width() {
                let cell = CellCoord { ix: x as i32, iy: y as i32 };
                if map.get(cell) == Some(CellState::Occupied) && (x + y) % 3 == 0 {
                    let c = g.grid_to_world(x as f64 + 0.5, y as f64 + 0.5);
                    if pose.position().distance(c) < 6.0 {
                        out.push(inv.transform_point(c));
                    }
                }
            }
        }
        out
    }

    #[test]
    fn finds_a_pose_anywhere_at_any_heading() {
        let map = room_with_posts();
        let p = GlobalSearchParams { enabled: true, ..GlobalSearchParams::default() };
        for truth in [Pose2::new(3.1, 2.4, 2.7), Pose2::new(8.2, 1.3, -1.9), Pose2::new(6.0, 5.0, 0.4)] {
            let pts = seen_from(&map, truth);
            let r = GlobalSearch::new().search(&map, &pts, &p, 0.3, 0.1);
            let (best, share) = r.peaks[0];
            assert!(best.distance(&truth) < 0.1, "{best:?} for {truth:?}: {r:?}");
            assert!(angle_diff(best.yaw, truth.yaw).abs() < 0.03, "{best:?} for {truth:?}");
            assert!(share > 0.8 && !r.truncated);
        }
    }

    #[test]
    fn the_bound_is_never_below_a_pose_it_covers() {
        let map = room_with_posts();
        let p = GlobalSearchParams::default();
        let mut s = GlobalSearch::new();
        let pts = seen_from(&map, Pose2::new(4.0, 3.0, 0.3));
        s.build_pyramid(&map, &p);
        s.build_offsets(&map, &pts, &p);
        for heading in [0u32, 17, 150] {
            for (a, b) in [(0i64, 0i64), (64, 0), (128, 64), (37, 90)] {
                for level in 1..=p.levels {
                    let side = 1i64 << level;
                    let top = s.bound(heading, a, b, level);
                    for (da, db) in [(0, 0), (side - 1, 0), (0, side - 1), (side / 2, side / 3)] {
                        assert!(s.bound(heading, a + da, b + db, 0) <= top);
                    }
                }
            }
        }
    }

    #[test]
    fn a_budget_bounds_the_work() {
        let map = room_with_posts();
        let p = GlobalSearchParams { max_nodes: 1_000, ..GlobalSearchParams::default() };
        let pts = seen_from(&map, Pose2::new(3.1, 2.4, 2.7));
        let r = GlobalSearch::new().search(&map, &pts, &p, 0.3, 0.1);
        assert!(r.truncated);
        assert!(r.nodes < 1_000 + 4 * 400, "{}", r.nodes);
    }

    #[test]
    fn nothing_to_match_gives_no_peak() {
        let map = room_with_posts();
        let r = GlobalSearch::new().search(&map, &[], &GlobalSearchParams::default(), 0.3, 0.1);
        assert!(r.peaks.is_empty());
        let far = vec![Point2::new(1e12, 0.0); 50];
        let r = GlobalSearch::new().search(&map, &far, &GlobalSearchParams::default(), 0.3, 0.1);
        assert!(r.peaks.is_empty());
    }

    #[test]
    fn validation_names_the_field() {
        let bad = GlobalSearchParams { yaw_step_rad: 0.0, ..GlobalSearchParams::default() };
        let e = bad.validate().unwrap_err();
        assert_eq!(e, ParamError::new("global_search.yaw_step_rad", 0, "must lie in [0.001, 1]"));
        let bad = GlobalSearchParams { candidates: 0, ..GlobalSearchParams::default() };
        assert_eq!(bad.validate().unwrap_err().to_string(), "global_search.candidates must lie in 1..=64, got 0");
        assert!(GlobalSearchParams::default().validate().is_ok());
    }
}
