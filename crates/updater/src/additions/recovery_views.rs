//! Several views for pose recovery, and the candidates of an unresolved attempt kept alive (a
//! `mapkeeper` addition, issue 54 item 2).
//!
//! The global search answers each attempt from the scans of one step: where two places fit
//! those scans alike the attempt is refused as ambiguous, and the next attempt starts from
//! nothing. What a robot that stays Lost has is more than one view: the scans of its earlier
//! attempts, tied to the current ones by odometry (exact enough over the few metres a Lost
//! robot moves). This memory keeps them:
//!
//! - **Views.** The scans of up to `views − 1` earlier attempts of the same Lost stretch, each
//!   with its robot pose in the odometry frame and its points: the first view of the stretch
//!   and the newest ones. A candidate pose q of the current step puts an earlier view at
//!   q ∘ (odom_now⁻¹ ∘ odom_then); the view is scored against the cloud `M_i` predicts from
//!   there. Each view's inlier ratio is evidence of its own: the ambiguity test compares the
//!   candidates' **sums** of ratios (the current one and every view's), the fitness gate takes
//!   the current ratio and the mean. Two places that look alike from here but not from where
//!   the robot was are told apart; a pose that fits the current scans and none of the earlier
//!   ones loses its lead. Views from one place repeat the same evidence (summed, they would
//!   shrink the margin with the number of attempts instead of with what was seen): a view
//!   replaces the newest kept one unless the robot has moved `view_baseline_m` or turned
//!   `view_turn_rad` since it, and a kept view that close to the current step is not used. So
//!   a robot standing while Lost gains nothing; one that walks on (the loop's `lost_walk_s`)
//!   brings views from new places.
//! - **Kept candidates.** The `kept_candidates` best distinct poses of a refused attempt are
//!   moved on by odometry and checked again at the next attempt beside the search's own
//!   peaks, so the next scans decide between them even when the search ranks them lower.
//!
//! The memory is emptied by a step the localisation check passes (Update; a Suspend says the
//! pose is doubtful, not that it fits), by a recovered pose, by a handover from
//! outside ([`crate::MapUpdater::reset_reference_pose`]) and views older than `view_max_age_s`
//! are dropped: an odometry link across a kidnap would be wrong, and only a stretch the robot
//! spent Lost without a pose is linked. With `views` = 1 and `kept_candidates` = 0 (the
//! defaults) nothing is kept and the decision is the single-step one.

use crate::additions::global_search::GlobalSearchParams;
use crate::paper::icp::{PointGrid, fitness, icp_from};
use crate::paper::pose_updating::expected_grid;
use crate::params::PoseUpdatingParams;
use mapkeeper_grid::{OccupancyGrid, Point2, Pose2, angle_diff};
use mapkeeper_sensor::LaserScan;

/// An earlier view may move this far from where odometry puts it when registered to the cloud
/// expected there (odometry's own error over the few metres a Lost robot moves), metres…
const VIEW_SLACK_M: f64 = 0.25;
/// …and turn this much, radians.
const VIEW_SLACK_RAD: f64 = 0.05;

/// One earlier view: the robot's pose in the odometry frame, the step's stamp, its scans and
/// the points pose updating drew from them (robot frame).
#[derive(Clone, Debug)]
struct View {
    robot_in_odom: Pose2,
    stamp_ns: u64,
    scans: Vec<LaserScan>,
    points: Vec<Point2>,
}

/// An earlier view as the current step sees it: where the robot was relative to where it is
/// now (`odom_now⁻¹ ∘ odom_then`), its scans and its points.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PastView<'a> {
    /// The earlier robot pose in the current robot frame.
    pub offset: Pose2,
    /// The earlier step's scans.
    pub scans: &'a [LaserScan],
    /// The points pose updating drew from them, robot frame.
    pub points: &'a [Point2],
}

/// The views and kept candidates of the current Lost stretch.
#[derive(Clone, Debug, Default)]
pub(crate) struct ViewMemory {
    /// Oldest first.
    views: Vec<View>,
    /// (candidate robot pose in the map, robot pose in the odometry frame then).
    candidates: Vec<(Pose2, Pose2)>,
}

/// Whether two robot poses (odometry frame) are views apart: moved `view_baseline_m` or
/// turned `view_turn_rad`.
fn apart(a: &Pose2, b: &Pose2, g: &GlobalSearchParams) -> bool {
    a.distance(b) >= g.view_baseline_m || angle_diff(a.yaw, b.yaw).abs() >= g.view_turn_rad
}

/// Reusable buffers of [`view_evidence`].
#[derive(Clone, Debug, Default)]
pub(crate) struct ViewScratch {
    cloud: Vec<Point2>,
    grid: PointGrid,
}

impl ViewScratch {
    /// Heap bytes of the buffers.
    pub fn heap_bytes(&self) -> usize {
        self.cloud.capacity() * size_of::<Point2>() + self.grid.heap_bytes()
    }
}

/// The sum of the views' inlier ratios with the robot at `robot_in_map` now, and how many
/// views: each view is placed by odometry (`robot_in_map ∘ view.offset`), registered to the
/// cloud `map` predicts from there (kept where odometry put it unless registration lands within
/// [`VIEW_SLACK_M`] / [`VIEW_SLACK_RAD`]), and its points scored there with pose updating's
/// inlier distance.
pub(crate) fn view_evidence(
    s: &mut ViewScratch,
    map: &OccupancyGrid,
    robot_in_map: Pose2,
    views: &[PastView<'_>],
    max_range_m: f64,
    p: &PoseUpdatingParams,
) -> (f64, usize) {
    let sum = views.iter().map(|v| view_ratio(s, map, robot_in_map.compose(&v.offset), v, max_range_m, p)).sum();
    (sum, views.len())
}

fn view_ratio(
    s: &mut ViewScratch,
    map: &OccupancyGrid,
    at: Pose2,
    v: &PastView<'_>,
    max_range_m: f64,
    p: &PoseUpdatingParams,
) -> f64 {
    if v.points.len() < 3 || !expected_grid(map, &at, v.scans, max_range_m, p, &mut s.cloud, &mut s.grid) {
        return 0.0;
    }
    let d0 = VIEW_SLACK_M.min(p.max_correspondence_m).max(p.min_correspondence_m);
    let (run, _) = icp_from(v.points, &s.grid, at, p, d0, p.max_iterations);
    let within = run.pose.is_finite()
        && run.pose.distance(&at) <= VIEW_SLACK_M
        && angle_diff(run.pose.yaw, at.yaw).abs() <= VIEW_SLACK_RAD;
    let pose = if within { run.pose } else { at };
    if pose != at && !expected_grid(map, &pose, v.scans, max_range_m, p, &mut s.cloud, &mut s.grid) {
        return 0.0;
    }
    fitness(v.points, &s.grid, &pose, p.inlier_distance_m).0.inlier_ratio
}

/// Whether `g` keeps anything at all (more than the current view, or candidates).
pub(crate) fn keeps_anything(g: &GlobalSearchParams) -> bool {
    g.views > 1 || g.kept_candidates > 0
}

impl ViewMemory {
    /// Forgets every view and candidate.
    pub fn clear(&mut self) {
        self.views.clear();
        self.candidates.clear();
    }

    /// Drops views older than `max_age_s` at `stamp_ns`.
    pub fn prune(&mut self, stamp_ns: u64, g: &GlobalSearchParams) {
        let max_ns = (g.view_max_age_s * 1e9).min(u64::MAX as f64) as u64;
        self.views.retain(|v| stamp_ns.saturating_sub(v.stamp_ns) <= max_ns);
    }

    /// The kept views as the step at `robot_in_odom` sees them, oldest first, but those taken
    /// within `view_baseline_m` and `view_turn_rad` of here: they repeat the current scans'
    /// evidence and would count it twice.
    pub fn past(&self, robot_in_odom: &Pose2, g: &GlobalSearchParams) -> Vec<PastView<'_>> {
        self.views
            .iter()
            .filter(|v| apart(&v.robot_in_odom, robot_in_odom, g))
            .map(|v| PastView { offset: robot_in_odom.between(&v.robot_in_odom), scans: &v.scans, points: &v.points })
            .collect()
    }

    /// The kept candidates moved on by odometry to the step at `robot_in_odom`.
    pub fn candidates_now(&self, robot_in_odom: Pose2) -> impl Iterator<Item = Pose2> + '_ {
        self.candidates.iter().map(move |(in_map, odom_then)| in_map.compose(&odom_then.between(&robot_in_odom)))
    }

    /// After a refused attempt: keeps this step as a view (beside the others if the robot has
    /// moved or turned enough since the newest, else in its place; beyond `views − 1` the
    /// second oldest goes, so that the first view of the stretch stays) and `candidates` (best first, the first `kept_candidates`) in place of the
    /// earlier ones.
    pub fn remember(
        &mut self,
        stamp_ns: u64,
        robot_in_odom: Pose2,
        scans: &[LaserScan],
        points: &[Point2],
        candidates: &[Pose2],
        g: &GlobalSearchParams,
    ) {
        self.candidates.clear();
        self.candidates.extend(candidates.iter().take(g.kept_candidates as usize).map(|&c| (c, robot_in_odom)));
        let keep = g.views.saturating_sub(1) as usize;
        if keep == 0 {
            self.views.clear();
            return;
        }
        let view = View { robot_in_odom, stamp_ns, scans: scans.to_vec(), points: points.to_vec() };
        match self.views.last_mut() {
            Some(newest) if !apart(&newest.robot_in_odom, &robot_in_odom, g) => *newest = view,
            _ => self.views.push(view),
        }
        // The first view of the stretch stays (the earliest evidence: it tells apart places
        // the newest views, all from near here, cannot); the ones after it are the newest.
        while self.views.len() > keep {
            self.views.remove(usize::from(keep >= 2));
        }
    }

    /// Views kept.
    #[cfg(test)]
    pub fn len(&self) -> usize {
        self.views.len()
    }

    /// Heap bytes of the kept views and candidates.
    pub fn heap_bytes(&self) -> usize {
        self.views
            .iter()
            .map(|v| {
                size_of::<View>()
                    + v.points.capacity() * size_of::<Point2>()
                    + v.scans.iter().map(|s| size_of::<LaserScan>() + s.ranges_m.capacity() * 4).sum::<usize>()
            })
            .sum::<usize>()
            + self.candidates.capacity() * size_of::<(Pose2, Pose2)>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::paper::pose_updating::{PoseRecovery, PoseUpdater, RecoveryFailure};
    use mapkeeper_grid::{CellState, RayStop, cast_ray};
    use mapkeeper_testkit::rooms::{fill_rect, walled};

    /// Scans reach 2.5 m: each view sees a few metres of the corridor.
    const RANGE_M: f64 = 2.5;

    /// A 30 m × 4 m corridor with a block on its lower wall at x = 3 and a slightly narrower one
    /// at x = 13 (seen from x = 3, 5 % of the points fit x = 13 worse: within the 0.08 margin,
    /// twice that is not), and a pillar near its upper wall at x = 7 and x = 23 (alike). From
    /// x = 3 the robot cannot tell x = 3 from x = 13; 4 m on, it cannot tell x = 7 from x = 23;
    /// only x = 3 then x = 7 fits both views.
    fn corridor() -> mapkeeper_grid::OccupancyGrid {
        let mut m = walled(30.0, 4.0, 0.05);
        for (x, half_width) in [(3.0, 0.75), (13.0, 0.55)] {
            fill_rect(&mut m, x - half_width, 0.0, x + half_width, 1.0, CellState::Occupied);
        }
        for x in [7.0, 23.0] {
            fill_rect(&mut m, x - 0.5, 2.6, x + 0.5, 3.2, CellState::Occupied);
        }
        m
    }

    fn scan(map: &mapkeeper_grid::OccupancyGrid, pose: Pose2) -> LaserScan {
        let n = 720;
        let inc = std::f64::consts::TAU / n as f64;
        let ranges = (0..n)
            .map(|i| {
                let e = cast_ray(map, pose.position(), pose.yaw - std::f64::consts::PI + i as f64 * inc, RANGE_M, true);
                if matches!(e.stop, RayStop::Occupied | RayStop::Unknown) { e.range_m as f32 } else { RANGE_M as f32 }
            })
            .collect();
        LaserScan {
            stamp_ns: 0,
            lidar_id: 0,
            lidar_in_robot: Pose2::IDENTITY,
            angle_min_rad: -std::f64::consts::PI,
            angle_increment_rad: inc,
            range_min_m: 0.05,
            range_max_m: RANGE_M as f32,
            ranges_m: ranges,
            sweep: None,
        }
    }

    /// `mapkeeper`'s check of the global search's candidates (gate 0.55, margin 0.08).
    fn strict() -> PoseUpdatingParams {
        let g = GlobalSearchParams::default();
        PoseUpdatingParams {
            min_inlier_ratio: g.min_inlier_ratio,
            ambiguity_ratio_margin: g.ambiguity_ratio_margin,
            search_radius_m: 0.0,
            ..PoseUpdatingParams::default()
        }
    }

    /// The step's candidates checked on its own scans and with the kept views.
    fn attempt(
        pu: &mut PoseUpdater,
        mem: &ViewMemory,
        map: &mapkeeper_grid::OccupancyGrid,
        scans: &[LaserScan],
        odom: Pose2,
        candidates: &[Pose2],
    ) -> (PoseRecovery, PoseRecovery) {
        let p = strict();
        pu.recover(map, candidates[0], scans, RANGE_M, &p);
        let mut all = candidates.to_vec();
        all.extend(mem.candidates_now(odom));
        let alone = pu.verify(map, &all, scans, RANGE_M, &p);
        let past = mem.past(&odom, &GlobalSearchParams::mapkeeper());
        let mut s = ViewScratch::default();
        let pooled =
            pu.verify_with(map, &all, scans, RANGE_M, &p, |q| view_evidence(&mut s, map, q, &past, RANGE_M, &p));
        (alone, pooled)
    }

    /// Two places fit the first scans alike (refused), two others fit the scans 4 m on alike
    /// (refused on their own); the first view placed by odometry tells them apart: the right
    /// pose is recovered. Standing still instead, the repeated view decides nothing.
    #[test]
    fn two_candidates_are_resolved_by_the_next_scans() {
        let map = corridor();
        let l = GlobalSearchParams::mapkeeper();
        let mut pu = PoseUpdater::new();
        let mut mem = ViewMemory::default();
        let (a1, b1) = (Pose2::new(3.0, 2.0, 0.0), Pose2::new(13.0, 2.0, 0.0));
        let odom1 = Pose2::new(-1.0, 0.5, 0.3);
        let scans1 = [scan(&map, a1)];
        let (alone, pooled) = attempt(&mut pu, &mem, &map, &scans1, odom1, &[a1, b1]);
        assert!(matches!(alone, PoseRecovery::NotRecovered { reason: RecoveryFailure::Ambiguous { .. } }), "{alone:?}");
        assert_eq!(alone, pooled, "no view kept yet: the same decision");
        let ranked = pu.ranked_poses(l.kept_candidates as usize, &strict());
        assert_eq!(ranked.len(), 2, "{ranked:?}");
        mem.remember(0, odom1, &scans1, pu.source_points(), &ranked, &l);

        // Standing: the same view again decides nothing (it replaces the kept one, and a view
        // from here is not compared: counted twice, the 5 % would pass the 8 % margin).
        let (alone, pooled) = attempt(&mut pu, &mem, &map, &scans1, odom1, &[a1, b1]);
        assert!(matches!(alone, PoseRecovery::NotRecovered { reason: RecoveryFailure::Ambiguous { .. } }), "{alone:?}");
        assert!(
            matches!(pooled, PoseRecovery::NotRecovered { reason: RecoveryFailure::Ambiguous { .. } }),
            "{pooled:?}"
        );
        mem.remember(500_000_000, odom1, &scans1, pu.source_points(), &pu.ranked_poses(4, &strict()), &l);
        assert_eq!(mem.len(), 1);

        // 4 m on (odometry turned 0.3 rad from the map): the pillar twins.
        let (a2, c2) = (Pose2::new(7.0, 2.0, 0.0), Pose2::new(23.0, 2.0, 0.0));
        let odom2 = odom1.compose(&a1.between(&a2));
        let scans2 = [scan(&map, a2)];
        let (alone, pooled) = attempt(&mut pu, &mem, &map, &scans2, odom2, &[c2, a2]);
        assert!(matches!(alone, PoseRecovery::NotRecovered { reason: RecoveryFailure::Ambiguous { .. } }), "{alone:?}");
        match pooled {
            PoseRecovery::Recovered { pose_in_map, .. } => {
                assert!(
                    pose_in_map.distance(&a2) < 0.05 && angle_diff(pose_in_map.yaw, 0.0).abs() < 0.02,
                    "{pose_in_map:?}"
                )
            }
            other => panic!("{other:?}"),
        }
    }

    fn limits() -> GlobalSearchParams {
        GlobalSearchParams { views: 3, view_max_age_s: 10.0, kept_candidates: 2, ..GlobalSearchParams::default() }
    }

    fn remember(m: &mut ViewMemory, t_s: f64, at: Pose2) {
        let cand = [Pose2::new(5.0, 1.0, 0.0), Pose2::new(9.0, 1.0, 0.0), Pose2::new(1.0, 1.0, 0.0)];
        m.remember((t_s * 1e9) as u64, at, &[], &[Point2::new(at.x, 0.0)], &cand, &limits());
    }

    /// Views from one place repeat the same evidence: the newest replaces the last; a view
    /// from a place the robot moved to is kept beside it; beyond `views − 1` the first view of
    /// the stretch stays and the one after it goes.
    #[test]
    fn views_from_one_place_replace_each_other_and_views_apart_are_kept() {
        let mut m = ViewMemory::default();
        remember(&mut m, 0.0, Pose2::new(0.0, 0.0, 0.0));
        remember(&mut m, 0.5, Pose2::new(0.05, 0.0, 0.0));
        assert_eq!(m.len(), 1);
        assert_eq!(m.views[0].points[0].x, 0.05, "the newest view replaced the one from the same place");
        remember(&mut m, 1.0, Pose2::new(0.5, 0.0, 0.0));
        assert_eq!(m.len(), 2);
        remember(&mut m, 1.5, Pose2::new(0.5, 0.0, 0.5));
        assert_eq!(m.len(), 2, "views − 1 = 2 kept");
        assert_eq!((m.views[0].stamp_ns, m.views[1].stamp_ns), (500_000_000, 1_500_000_000), "the first stays");
        m.prune((11.2 * 1e9) as u64, &limits());
        assert_eq!(m.len(), 1, "at t = 11.2 s the view of t = 0.5 s is older than 10 s, that of t = 1.5 s not");
        m.clear();
        assert_eq!((m.len(), m.candidates_now(Pose2::IDENTITY).count()), (0, 0));
    }

    /// Kept candidates move with the robot: a robot 1 m further along its heading in the
    /// odometry frame is 1 m further along each candidate's heading in the map.
    #[test]
    fn kept_candidates_move_on_by_odometry_and_are_capped() {
        let mut m = ViewMemory::default();
        let cand = [Pose2::new(5.0, 1.0, std::f64::consts::FRAC_PI_2), Pose2::new(9.0, 1.0, 0.0), Pose2::IDENTITY];
        m.remember(0, Pose2::new(2.0, 3.0, 0.0), &[], &[], &cand, &limits());
        let now: Vec<Pose2> = m.candidates_now(Pose2::new(3.0, 3.0, 0.0)).collect();
        assert_eq!(now.len(), 2, "kept_candidates = 2");
        assert!(now[0].distance(&Pose2::new(5.0, 2.0, std::f64::consts::FRAC_PI_2)) < 1e-12, "{:?}", now[0]);
        assert!(now[1].distance(&Pose2::new(10.0, 1.0, 0.0)) < 1e-12, "{:?}", now[1]);
        let past = m.past(&Pose2::new(3.0, 3.0, 0.0), &limits());
        assert!(m.past(&Pose2::new(2.1, 3.0, 0.1), &limits()).is_empty(), "a view from here repeats the current scans");
        assert_eq!(past.len(), 1);
        assert!(past[0].offset.distance(&Pose2::new(-1.0, 0.0, 0.0)) < 1e-12, "{:?}", past[0].offset);
    }
}
