//! The updater's reaction to a Lost step: pose updating (§4.6), then the global search and
//! the views kept while Lost (`mapkeeper` additions).

use super::MapUpdater;
use crate::additions::global_search::GlobalSearchReport;
use crate::additions::recovery_views::{keeps_anything, view_evidence};
use crate::paper::pose_updating::PoseRecovery;
use crate::params::PoseUpdatingParams;
use mapkeeper_grid::{Pose2, angle_diff};
use mapkeeper_sensor::LaserScan;

impl MapUpdater {
    /// Pose updating (§4.6) on a Lost step, if enabled and due (the first Lost step of an
    /// episode, then at most once per `retry_interval_s`); then the global search if it is on
    /// and the local search found no pose.
    pub(super) fn try_pose_updating(
        &mut self,
        robot_in_map: Pose2,
        robot_in_odom: Pose2,
        scans: &[LaserScan],
        stamp_ns: u64,
    ) -> (Option<PoseRecovery>, Option<GlobalSearchReport>) {
        let p = &self.params.pose_updating;
        if !p.enabled {
            return (None, None);
        }
        if let Some(last) = self.last_attempt_ns
            && (stamp_ns.saturating_sub(last) as f64) * 1e-9 < p.retry_interval_s
        {
            return (None, None);
        }
        self.last_attempt_ns = Some(stamp_ns);
        let predicted = match self.last_good {
            Some((good_in_map, good_in_odom)) => good_in_map.compose(&good_in_odom.between(&robot_in_odom)),
            None => robot_in_map,
        };
        let mut r = self.pose_updater.recover(&self.current, predicted, scans, self.params.max_range_m, p);
        let mut searched = None;
        let g = &self.params.global_search;
        let local = match &r {
            PoseRecovery::Recovered { pose_in_map, fitness, .. } => {
                (fitness.inlier_ratio < g.confident_inlier_ratio).then_some(Some(*pose_in_map))
            }
            PoseRecovery::NotRecovered { .. } => Some(None),
        };
        if g.enabled
            && let Some(local) = local
        {
            let (mut found, answer) = self.global_recovery(scans, local, robot_in_odom, stamp_ns);
            let p = &self.params.pose_updating;
            if let PoseRecovery::Recovered { pose_in_map: q, .. } = &answer
                && local.is_none_or(|l| {
                    l.distance(q) > p.ambiguity_distance_m || angle_diff(l.yaw, q.yaw).abs() > p.ambiguity_rotation_rad
                })
            {
                self.stats.global_recoveries += 1;
                found.chosen = true;
            }
            r = answer;
            searched = Some(found);
        }
        if let PoseRecovery::Recovered { pose_in_map, .. } = &r {
            self.stats.recoveries += 1;
            self.last_good = Some((*pose_in_map, robot_in_odom));
            // A new episode starts if the robot is still Lost at the recovered pose.
            self.last_attempt_ns = None;
            self.views.clear();
        } else {
            self.stats.failed_recoveries += 1;
        }
        (Some(r), searched)
    }

    /// The global search over `M_i` with the points of the pose updating just run, its
    /// candidates (and the local search's pose, if it found a weak one, and the candidates kept
    /// from the last refused attempt) checked as pose updating checks its own, with the search's
    /// ambiguity margin, over the current scans and the views kept (`recovery_views`). A refused
    /// attempt is remembered as a view, with its best candidates.
    fn global_recovery(
        &mut self,
        scans: &[LaserScan],
        local: Option<Pose2>,
        robot_in_odom: Pose2,
        stamp_ns: u64,
    ) -> (GlobalSearchReport, PoseRecovery) {
        let p = &self.params.pose_updating;
        let g = &self.params.global_search;
        let found = self.global.search(
            &self.current,
            self.pose_updater.source_points(),
            g,
            p.ambiguity_distance_m,
            p.ambiguity_rotation_rad,
        );
        self.stats.global_searches += 1;
        self.stats.global_nodes += found.nodes as u64;
        self.views.prune(stamp_ns, g);
        let mut poses: Vec<Pose2> = local.into_iter().chain(found.peaks.iter().map(|&(q, _)| q)).collect();
        poses.extend(self.views.candidates_now(robot_in_odom));
        let strict = PoseUpdatingParams {
            ambiguity_ratio_margin: g.ambiguity_ratio_margin.max(p.ambiguity_ratio_margin),
            min_inlier_ratio: g.min_inlier_ratio,
            ..p.clone()
        };
        let (map, max_range) = (&self.current, self.params.max_range_m);
        let past = self.views.past(&robot_in_odom, g);
        let scratch = &mut self.view_scratch;
        let answer = self.pose_updater.verify_with(map, &poses, scans, max_range, &strict, |q| {
            view_evidence(scratch, map, q, &past, max_range, &strict)
        });
        if keeps_anything(g) && !matches!(answer, PoseRecovery::Recovered { .. }) {
            let ranked = self.pose_updater.ranked_poses(g.kept_candidates as usize, &strict);
            let points = self.pose_updater.source_points();
            self.views.remember(stamp_ns, robot_in_odom, scans, points, &ranked, g);
        }
        (found, answer)
    }
}
