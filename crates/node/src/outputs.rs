//! What the node publishes after each step, as an [`Observer`] of the session (it reads the
//! step and the map, and cannot change the run): `/updater/step`; for a step that changed cells,
//! the readiness barrier and then the changed cells' bounding box on `/map_updates`; the whole
//! map on `/map` (with `/updater/changes` against the map published before it) at most once per
//! period while it changes; `map → odom` on `/tf` when the node localises; a pose that pose
//! updating recovered on `/initialpose`.

use crate::msgs::{self, Header, OccupancyGrid as GridMsg, OccupancyGridUpdate, Time};
use mapkeeper_grid::{CellState, GridGeometry, OccupancyGrid, Pose2};
use mapkeeper_harness::mcap_out::{change_value, step_message};
use mapkeeper_harness::{Observer, Session, SessionStep, Step};
use mapkeeper_updater::PoseRecovery;

/// One thing to publish.
#[derive(Clone, Debug, PartialEq)]
pub enum Output {
    /// The whole map (`/map`).
    Map(GridMsg),
    /// A window of it (`/map_updates`).
    MapUpdate(OccupancyGridUpdate),
    /// The readiness barrier: a grid change stamped at or after this is coming.
    Barrier(Header),
    /// `/updater/step`.
    Step(msgs::UpdaterStep),
    /// `/updater/changes`: the cells changed since the previous `/map`.
    Changes(GridMsg),
    /// `/initialpose`: a pose pose updating recovered.
    InitialPose(msgs::PoseWithCovarianceStamped),
    /// `/tf`: `map → odom` from the node's localiser.
    Tf(msgs::TfMessage),
}

/// The value of a cell on the wire.
pub fn cell_value(s: CellState) -> i8 {
    match s {
        CellState::Free => 0,
        CellState::Occupied => 100,
        CellState::Unknown => -1,
    }
}

/// A map as `nav_msgs/OccupancyGrid` in `frame`, stamped `stamp_ns`.
pub fn grid_message(map: &OccupancyGrid, frame: &str, stamp_ns: u64) -> GridMsg {
    let data = map.cells().iter().map(|&c| cell_value(c)).collect();
    layer_message(map.geometry(), frame, stamp_ns, data)
}

fn layer_message(g: &GridGeometry, frame: &str, stamp_ns: u64, data: Vec<i8>) -> GridMsg {
    let o = g.origin();
    GridMsg {
        header: Header { stamp: Time::from_ns(stamp_ns), frame_id: frame.to_string() },
        info: msgs::MapMetaData {
            map_load_time: Time::from_ns(stamp_ns),
            resolution: g.resolution_m() as f32,
            width: g.width() as u32,
            height: g.height() as u32,
            origin: pose_message(o),
        },
        data,
    }
}

/// A planar pose as `geometry_msgs/Pose`.
pub fn pose_message(p: Pose2) -> msgs::Pose {
    msgs::Pose { position: msgs::Vector3 { x: p.x, y: p.y, z: 0.0 }, orientation: msgs::Quaternion::from_yaw(p.yaw) }
}

/// The publishing side of the node.
#[derive(Debug)]
pub struct Publisher {
    map_frame: String,
    odom_frame: String,
    barrier: bool,
    initialpose: bool,
    localises: bool,
    period_ns: u64,
    last_full_ns: Option<u64>,
    /// The map as last published on `/map`.
    published: OccupancyGrid,
    /// Whether the map changed since it was last published whole.
    pub dirty: bool,
    /// Whether a step was processed since the map was last published whole.
    pub stepped: bool,
    /// The outputs not yet taken.
    pub out: Vec<Output>,
    /// Cells changed since the start.
    pub cells_changed: u64,
}

impl Publisher {
    /// A publisher of `map` (published whole at once, stamped `stamp_ns`).
    pub fn new(map: &OccupancyGrid, p: &crate::config::NodeParams, stamp_ns: u64) -> Publisher {
        Publisher {
            map_frame: p.map_frame.clone(),
            odom_frame: p.odom_frame.clone(),
            barrier: !p.barrier_topic.is_empty(),
            initialpose: p.publish_initialpose && p.pose_source != crate::config::PoseFrom::Localiser,
            localises: p.pose_source == crate::config::PoseFrom::Localiser,
            period_ns: (p.map_publish_period_s * 1e9) as u64,
            last_full_ns: Some(stamp_ns),
            published: map.clone(),
            dirty: false,
            stepped: false,
            out: vec![Output::Map(grid_message(map, &p.map_frame, stamp_ns))],
            cells_changed: 0,
        }
    }

    /// Publishes `map` whole (with the changes since the last time) if it changed since, or,
    /// with `after_steps`, if a step was processed since (the end of a drive: a late subscriber
    /// and the drive's player see the map as it ended).
    pub fn full_map(&mut self, map: &OccupancyGrid, stamp_ns: u64, after_steps: bool) {
        if !(self.dirty || after_steps && self.stepped) {
            return;
        }
        let values: Vec<i8> =
            self.published.cells().iter().zip(map.cells()).map(|(&a, &b)| change_value(a, b)).collect();
        self.out.push(Output::Map(grid_message(map, &self.map_frame, stamp_ns)));
        self.out.push(Output::Changes(layer_message(map.geometry(), &self.map_frame, stamp_ns, values)));
        self.published.clone_from(map);
        self.last_full_ns = Some(stamp_ns);
        self.dirty = false;
        self.stepped = false;
    }

    fn update_window(&mut self, map: &OccupancyGrid, cells: impl Iterator<Item = (usize, usize)>, stamp_ns: u64) {
        let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0, 0);
        for (x, y) in cells {
            (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
        }
        if x0 > x1 {
            return;
        }
        let w = map.geometry().width();
        let mut data = Vec::with_capacity((x1 - x0 + 1) * (y1 - y0 + 1));
        for y in y0..=y1 {
            data.extend(map.cells()[y * w + x0..=y * w + x1].iter().map(|&c| cell_value(c)));
        }
        let header = Header { stamp: Time::from_ns(stamp_ns), frame_id: self.map_frame.clone() };
        if self.barrier {
            self.out.push(Output::Barrier(header.clone()));
        }
        self.out.push(Output::MapUpdate(OccupancyGridUpdate {
            header,
            x: x0 as i32,
            y: y0 as i32,
            width: (x1 - x0 + 1) as u32,
            height: (y1 - y0 + 1) as u32,
            data,
        }));
    }

    fn pose_outputs(&mut self, step: &Step, report: &SessionStep) {
        let stamp = Time::from_ns(step.frame.stamp_ns);
        if let (true, Some(p), Some(o)) = (self.localises, report.pose_in_map, step.frame.odometry) {
            let map_odom = p.compose(&o.inverse());
            self.out.push(Output::Tf(msgs::TfMessage {
                transforms: vec![msgs::TransformStamped {
                    header: Header { stamp, frame_id: self.map_frame.clone() },
                    child_frame_id: self.odom_frame.clone(),
                    transform: pose_message(map_odom),
                }],
            }));
        }
        let recovered = report.updater.as_ref().and_then(|u| match &u.pose_recovery {
            Some(PoseRecovery::Recovered { pose_in_map, covariance, .. }) => Some((*pose_in_map, *covariance)),
            _ => None,
        });
        if let (true, Some((p, c))) = (self.initialpose, recovered) {
            let mut cov = [0.0; 36];
            for (i, a) in [0usize, 1, 5].into_iter().enumerate() {
                for (j, b) in [0usize, 1, 5].into_iter().enumerate() {
                    cov[a * 6 + b] = c[i][j];
                }
            }
            self.out.push(Output::InitialPose(msgs::PoseWithCovarianceStamped {
                header: Header { stamp, frame_id: self.map_frame.clone() },
                pose: msgs::PoseWithCovariance { pose: pose_message(p), covariance: msgs::Cov36(cov) },
            }));
        }
    }
}

impl Observer for Publisher {
    fn on_step(&mut self, step: &Step, report: &SessionStep, session: &Session<'_>) {
        let t = step.frame.stamp_ns;
        self.stepped = true;
        if let Some(u) = &report.updater {
            let m = step_message(u);
            let share =
                if m.valid_beams == 0 { 0.0 } else { f64::from(m.detected_change_beams) / f64::from(m.valid_beams) };
            let (ran, (accepted, shift, turn)) =
                (m.registration.is_some(), m.registration.unwrap_or((false, 0.0, 0.0)));
            self.out.push(Output::Step(msgs::UpdaterStep {
                header: Header { stamp: Time::from_ns(t), frame_id: String::new() },
                verdict: m.verdict,
                check_verdict: m.check_verdict,
                outcome: m.outcome,
                valid_beams: m.valid_beams,
                detected_change_beams: m.detected_change_beams,
                detected_share: share,
                cells_added: m.cells_added,
                cells_removed: m.cells_removed,
                cells_other: m.cells_other,
                registration_ran: ran,
                registration_accepted: accepted,
                registration_shift_m: shift,
                registration_turn_deg: turn.to_degrees(),
                pose_recovery: m.pose_recovery,
            }));
            if let (false, Some(map)) = (u.changed_cells.is_empty(), session.map()) {
                self.cells_changed += u.changed_cells.len() as u64;
                self.dirty = true;
                self.update_window(map, u.changed_cells.iter().map(|c| (c.cell.ix as usize, c.cell.iy as usize)), t);
            }
        }
        self.pose_outputs(step, report);
        let due = self.last_full_ns.is_none_or(|last| t >= last.saturating_add(self.period_ns) || t < last);
        if let (true, Some(map)) = (due && self.dirty, session.map()) {
            self.full_map(map, t, false);
        }
    }
}
