//! An occupancy map from scans at known poses, with the log-odds mapper of
//! `mapkeeper_grid::mapper`: from a recorded log at its true poses, or online from any source
//! ([`TruthMapper`], the exploration run that builds M_1).

use crate::HarnessError;
use crate::NoClock;
use crate::driver::Observer;
use crate::replay::LogSource;
use crate::session::{PoseSource, Session, SessionStep};
use crate::source::Step;
use mapkeeper_grid::mapper::{LogOddsMapper, MapperParams};
use mapkeeper_grid::{GridGeometry, OccupancyGrid, Point2, Pose2};
use mapkeeper_sensor::{BeamValidity, LaserScan, deskew_all};
use std::sync::mpsc::{SyncSender, sync_channel};
use std::thread::JoinHandle;

/// What one beam contributes to a map.
enum Beam {
    Hit(Point2),
    Clear(Point2),
    Ignore,
}

/// A valid return is a hit; a beam with no return (+inf, or at or beyond range_max) clears up
/// to min(range_max, `clear_m`); NaN, -inf and readings below range_min are ignored.
fn beam(scan: &LaserScan, lidar_in_map: &Pose2, i: usize, clear_m: f64) -> Beam {
    let r = scan.ranges_m.get(i).copied().unwrap_or(f32::NAN);
    let no_return = match scan.validity(i) {
        BeamValidity::Valid => return scan.hit_point(lidar_in_map, i).map_or(Beam::Ignore, Beam::Hit),
        BeamValidity::NotFinite => r == f32::INFINITY,
        BeamValidity::AtOrBeyondMax => true,
        BeamValidity::BelowMin => false,
    };
    let reach = clear_m.min(scan.range_max_m as f64);
    if !no_return || reach <= 0.0 {
        return Beam::Ignore;
    }
    let a = lidar_in_map.yaw + scan.beam_angle(i as f64);
    Beam::Clear(Point2::new(lidar_in_map.x + reach * a.cos(), lidar_in_map.y + reach * a.sin()))
}

/// Beams integrated into a map, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BeamCounts {
    /// Returns marked occupied (the cells before them cleared).
    pub hits: u64,
    /// No-return beams that cleared cells.
    pub clears: u64,
    /// Beams ignored.
    pub ignored: u64,
}

/// Integrates every beam of `scan`, seen from `lidar_in_map`, into `mapper`.
pub fn integrate_scan(
    mapper: &mut LogOddsMapper,
    scan: &LaserScan,
    lidar_in_map: &Pose2,
    clear_m: f64,
    counts: &mut BeamCounts,
) {
    let origin = lidar_in_map.position();
    for i in 0..scan.len() {
        match beam(scan, lidar_in_map, i, clear_m) {
            Beam::Hit(p) => {
                counts.hits += 1;
                mapper.integrate_ray(origin, p, true);
            }
            Beam::Clear(p) => {
                counts.clears += 1;
                mapper.integrate_ray(origin, p, false);
            }
            Beam::Ignore => counts.ignored += 1,
        }
    }
}

/// Integrates every scan of one step taken with the robot at `robot_in_map`; returns the number
/// of scans.
fn integrate_frame(
    mapper: &mut LogOddsMapper,
    scans: &[LaserScan],
    robot_in_map: &Pose2,
    clear_m: f64,
    counts: &mut BeamCounts,
) -> u64 {
    for scan in scans {
        integrate_scan(mapper, scan, &scan.lidar_in_map(robot_in_map), clear_m, counts);
    }
    scans.len() as u64
}

/// Maps every `stride`-th step the session processed at the pose the updater was given (the
/// localiser's estimate, or a recorded pose): the map a robot makes of one run without a prior,
/// e.g. the "fresh map" baseline of the validation. Steps without a pose are not counted.
#[derive(Debug)]
pub struct EstimateMapper {
    /// The mapper.
    pub mapper: LogOddsMapper,
    /// Integrate every this-many steps with a pose (≥ 1).
    pub stride: u64,
    /// Steps with a pose seen.
    pub steps: u64,
    /// Scans integrated.
    pub scans: u64,
    /// Beams integrated, by kind.
    pub beams: BeamCounts,
}

impl EstimateMapper {
    /// A mapper over `geometry`.
    pub fn new(geometry: GridGeometry, params: MapperParams, stride: u64) -> Result<Self, HarnessError> {
        let mapper = LogOddsMapper::new(geometry, params).map_err(|e| HarnessError::Invalid(format!("mapper: {e}")))?;
        Ok(Self { mapper, stride: stride.max(1), steps: 0, scans: 0, beams: BeamCounts::default() })
    }

    fn integrate(&mut self, scans: &[LaserScan], robot_in_map: &Pose2) {
        self.scans += integrate_frame(&mut self.mapper, scans, robot_in_map, 0.0, &mut self.beams);
    }
}

impl Observer for EstimateMapper {
    fn on_step(&mut self, step: &Step, report: &SessionStep, _session: &Session<'_>) {
        let Some(pose) = report.pose_in_map else { return };
        if takes_step(&mut self.steps, self.stride) {
            self.integrate(&step.frame.scans, &pose);
        }
    }
}

/// An [`EstimateMapper`] on a thread of its own: the scans and pose of each step it integrates
/// are queued to the thread, which integrates them in the order they came, so the map and the
/// counts are those of the same [`EstimateMapper`] stepped inline, bit for bit
/// ([`Self::finish`] returns it). The loop's thread only counts steps and copies the scans of
/// the integrated ones.
#[derive(Debug)]
pub struct ThreadedEstimateMapper {
    /// The mapper's stride and its steps with a pose, counted on the loop's thread.
    stride: u64,
    steps: u64,
    tx: SyncSender<(Vec<LaserScan>, Pose2)>,
    worker: JoinHandle<EstimateMapper>,
}

/// Counts a step with a pose; whether its scans are integrated (every `stride`-th).
fn takes_step(steps: &mut u64, stride: u64) -> bool {
    *steps += 1;
    steps.is_multiple_of(stride)
}

impl ThreadedEstimateMapper {
    /// Moves `mapper` to a thread of its own.
    pub fn spawn(mapper: EstimateMapper) -> Self {
        let (stride, steps) = (mapper.stride, mapper.steps);
        let (tx, rx) = sync_channel::<(Vec<LaserScan>, Pose2)>(64);
        let worker = std::thread::spawn(move || {
            let mut m = mapper;
            for (scans, pose) in rx {
                m.integrate(&scans, &pose);
            }
            m
        });
        Self { stride, steps, tx, worker }
    }

    /// Waits for the queued steps and returns the mapper, its step count included.
    pub fn finish(self) -> Result<EstimateMapper, HarnessError> {
        drop(self.tx);
        let mut m = self.worker.join().map_err(|_| HarnessError::MapperPanicked)?;
        m.steps = self.steps;
        Ok(m)
    }
}

impl Observer for ThreadedEstimateMapper {
    fn on_step(&mut self, step: &Step, report: &SessionStep, _session: &Session<'_>) {
        let Some(pose) = report.pose_in_map else { return };
        if takes_step(&mut self.steps, self.stride) {
            // The worker stops only when the channel closes, so a send cannot fail while it lives.
            drop(self.tx.send((step.frame.scans.clone(), pose)));
        }
    }
}

/// Maps every `stride`-th step's scans at the true pose, as they come (the geometry is known).
#[derive(Debug)]
pub struct TruthMapper {
    /// The mapper.
    pub mapper: LogOddsMapper,
    /// Integrate every this-many steps with truth (≥ 1).
    pub stride: u64,
    /// Reach of a no-return beam's clearing, metres (0: no-return beams are ignored).
    pub clear_m: f64,
    /// Steps with truth seen.
    pub steps: u64,
    /// Scans integrated.
    pub scans: u64,
    /// Beams integrated, by kind.
    pub beams: BeamCounts,
    /// Whether scans with a sweep timing are deskewed by the true motion before they are
    /// integrated (default true; [`TruthMapper::with_deskew`]).
    pub deskew: bool,
    /// The last step's true pose and time (the motion over the next sweep).
    last_truth: Option<(u64, Pose2)>,
}

impl TruthMapper {
    /// A mapper over `geometry`.
    pub fn new(geometry: GridGeometry, params: MapperParams, stride: u64, clear_m: f64) -> Result<Self, HarnessError> {
        let mapper = LogOddsMapper::new(geometry, params).map_err(|e| HarnessError::Invalid(format!("mapper: {e}")))?;
        Ok(Self {
            mapper,
            stride: stride.max(1),
            clear_m,
            steps: 0,
            scans: 0,
            beams: BeamCounts::default(),
            deskew: true,
            last_truth: None,
        })
    }

    /// Whether timed scans (a moving lidar's sweep) are deskewed by the true motion between the
    /// last two steps (at constant velocity) before they are integrated, as a survey would.
    pub fn with_deskew(self, deskew: bool) -> Self {
        Self { deskew, ..self }
    }
}

impl Observer for TruthMapper {
    fn on_step(&mut self, step: &Step, _report: &SessionStep, _session: &Session<'_>) {
        let Some(truth) = step.truth else { return };
        let now = (step.frame.stamp_ns, truth.pose_in_map);
        let before = self.last_truth.replace(now);
        self.steps += 1;
        if !self.steps.is_multiple_of(self.stride) {
            return;
        }
        let timed = self.deskew && step.frame.scans.iter().any(|s| s.sweep.is_some());
        let deskewed = before.filter(|_| timed).map(|before| deskew_all(&step.frame.scans, before, now));
        let scans = deskewed.as_deref().unwrap_or(&step.frame.scans);
        self.scans += integrate_frame(&mut self.mapper, scans, &truth.pose_in_map, self.clear_m, &mut self.beams);
    }
}

/// Collects every scan with its lidar pose at the true robot pose (for a geometry fitted
/// afterwards); counts the scans of steps without a true pose.
#[derive(Default)]
struct Placer {
    placed: Vec<(LaserScan, Pose2)>,
    skipped: u64,
}

impl Observer for Placer {
    fn on_step(&mut self, step: &Step, _report: &SessionStep, _session: &Session<'_>) {
        match step.truth {
            Some(t) => {
                self.placed.extend(step.frame.scans.iter().map(|s| (s.clone(), s.lidar_in_map(&t.pose_in_map))));
            }
            None => self.skipped += step.frame.scans.len() as u64,
        }
    }
}

/// How to map a log.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct MapLogParams {
    /// The mapper.
    pub mapper: MapperParams,
    /// Reach of a no-return beam's clearing, metres.
    pub no_return_clear_m: f64,
    /// With no geometry given: the fitted grid's resolution, metres.
    pub resolution_m: f64,
    /// With no geometry given: the margin around everything observed, metres.
    pub margin_m: f64,
}

/// A map built from a log.
#[derive(Clone, Debug, PartialEq)]
pub struct MapLogRun {
    /// The map.
    pub map: OccupancyGrid,
    /// Scans mapped.
    pub scans_mapped: u64,
    /// Scans without a true pose near enough, skipped.
    pub scans_skipped: u64,
    /// Beams, by kind.
    pub beams: BeamCounts,
}

/// Maps `source` at its true poses (the source's truth-gap rule decides which scans have one)
/// on `geometry`, or on the axis-aligned grid fitted to everything observed.
pub fn map_log(
    mut source: LogSource,
    geometry: Option<GridGeometry>,
    params: &MapLogParams,
) -> Result<MapLogRun, HarnessError> {
    if source.truth().is_empty() {
        return Err(HarnessError::Invalid(format!("{}: no truth records, cannot map at true poses", source.name())));
    }
    let mut session = Session::new(PoseSource::None, None, None, &NoClock);
    let mut placer = Placer::default();
    crate::run(&mut source, &mut session, &mut [], &mut [&mut placer])?;
    if placer.placed.is_empty() {
        return Err(HarnessError::Invalid(format!("{}: no scan has a true pose near enough", source.name())));
    }
    let geometry = match geometry {
        Some(g) => g,
        None => fit_geometry(&placer.placed, params.no_return_clear_m, params.resolution_m, params.margin_m)?,
    };
    let mut mapper =
        LogOddsMapper::new(geometry, params.mapper).map_err(|e| HarnessError::Invalid(format!("mapper: {e}")))?;
    let mut beams = BeamCounts::default();
    for (scan, lidar_in_map) in &placer.placed {
        integrate_scan(&mut mapper, scan, lidar_in_map, params.no_return_clear_m, &mut beams);
    }
    Ok(MapLogRun {
        map: mapper.to_grid(),
        scans_mapped: placer.placed.len() as u64,
        scans_skipped: placer.skipped,
        beams,
    })
}

/// The axis-aligned geometry covering every lidar position and beam end point, plus
/// `margin_m`, with its origin on a multiple of the resolution.
fn fit_geometry(
    placed: &[(LaserScan, Pose2)],
    clear_m: f64,
    resolution_m: f64,
    margin_m: f64,
) -> Result<GridGeometry, HarnessError> {
    let invalid = |m: String| Err(HarnessError::Invalid(m));
    if !(resolution_m.is_finite() && resolution_m > 0.0) {
        return invalid(format!("--resolution must be a finite positive number of metres, got {resolution_m}"));
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    let mut add = |p: Point2| {
        lo = [lo[0].min(p.x), lo[1].min(p.y)];
        hi = [hi[0].max(p.x), hi[1].max(p.y)];
    };
    for (scan, lidar_in_map) in placed {
        add(lidar_in_map.position());
        for i in 0..scan.len() {
            if let Beam::Hit(p) | Beam::Clear(p) = beam(scan, lidar_in_map, i, clear_m) {
                add(p);
            }
        }
    }
    let x0 = ((lo[0] - margin_m) / resolution_m).floor() * resolution_m;
    let y0 = ((lo[1] - margin_m) / resolution_m).floor() * resolution_m;
    let w = ((hi[0] + margin_m - x0) / resolution_m).ceil().max(1.0);
    let h = ((hi[1] + margin_m - y0) / resolution_m).ceil().max(1.0);
    if !(w.is_finite() && h.is_finite() && w < 1e9 && h < 1e9) {
        return invalid(format!("observed area is not finite or too large for resolution {resolution_m} m"));
    }
    GridGeometry::new(w as usize, h as usize, resolution_m, Pose2::new(x0, y0, 0.0)).map_err(|e| {
        HarnessError::Invalid(format!(
            "the observed area does not fit a grid ({e}); use a coarser --resolution or --like"
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::source::{SensorFrame, Truth};

    fn scan(ranges: Vec<f32>) -> LaserScan {
        LaserScan {
            stamp_ns: 0,
            lidar_id: 0,
            lidar_in_robot: Pose2::new(0.1, 0.0, 0.0),
            angle_min_rad: -0.5,
            angle_increment_rad: 0.05,
            range_min_m: 0.05,
            range_max_m: 10.0,
            ranges_m: ranges,
            sweep: None,
        }
    }

    fn report(pose: Option<Pose2>) -> SessionStep {
        SessionStep {
            stamp_ns: 0,
            pose_in_map: pose,
            localiser: None,
            updater: None,
            updater_ns: None,
            updater_state_bytes: 0,
            skipped: None,
        }
    }

    /// Fed its own poses as the estimate, the estimate mapper makes the truth mapper's map; it
    /// counts only steps with a pose and maps every `stride`-th of them.
    #[test]
    fn estimate_mapper_at_true_poses_makes_the_truth_mappers_map() {
        let g = GridGeometry::new(80, 60, 0.1, Pose2::new(-1.0, -3.0, 0.0)).unwrap();
        let mut truth = TruthMapper::new(g, MapperParams::default(), 2, 0.0).unwrap();
        let mut est = EstimateMapper::new(g, MapperParams::default(), 2).unwrap();
        let session = crate::Session::new(crate::PoseSource::None, None, None, &crate::NoClock);
        for k in 0..9 {
            let pose = Pose2::new(0.2 * f64::from(k), 0.1, 0.05 * f64::from(k));
            let ranges = (0..21).map(|i| 3.0 + 0.1 * (i as f32) + 0.05 * k as f32).collect();
            let step = Step {
                frame: SensorFrame { stamp_ns: k as u64, odometry: None, scans: vec![scan(ranges)] },
                truth: Some(Truth { pose_in_map: pose, distance_m: 0.0 }),
            };
            truth.on_step(&step, &report(None), &session);
            est.on_step(&step, &report(Some(pose)), &session);
            // A step without a pose (skipped by the session) is not counted.
            est.on_step(&step, &report(None), &session);
        }
        assert_eq!((est.steps, est.scans), (9, 4));
        assert_eq!((truth.steps, truth.scans), (9, 4));
        assert_eq!(est.beams, truth.beams);
        assert_eq!(est.mapper.to_grid(), truth.mapper.to_grid());
        assert!(est.mapper.to_grid().count(mapkeeper_grid::CellState::Occupied) > 0);
    }

    #[test]
    fn the_threaded_estimate_mapper_makes_the_inline_ones_map_and_counts() {
        let g = GridGeometry::new(80, 60, 0.1, Pose2::new(-1.0, -3.0, 0.0)).unwrap();
        let mut inline = EstimateMapper::new(g, MapperParams::default(), 3).unwrap();
        let mut threaded = ThreadedEstimateMapper::spawn(EstimateMapper::new(g, MapperParams::default(), 3).unwrap());
        let session = crate::Session::new(crate::PoseSource::None, None, None, &crate::NoClock);
        for k in 0..40 {
            let pose = Pose2::new(0.1 * f64::from(k), 0.05 * f64::from(k % 7), 0.03 * f64::from(k));
            let ranges = (0..21).map(|i| 2.0 + 0.13 * (i as f32) + 0.07 * (k % 5) as f32).collect();
            let step = Step {
                frame: SensorFrame { stamp_ns: k as u64, odometry: None, scans: vec![scan(ranges)] },
                truth: None,
            };
            let r = report(if k % 4 == 1 { None } else { Some(pose) });
            inline.on_step(&step, &r, &session);
            threaded.on_step(&step, &r, &session);
        }
        let threaded = threaded.finish().unwrap();
        assert_eq!((threaded.steps, threaded.scans), (inline.steps, inline.scans));
        assert_eq!((inline.steps, inline.scans), (30, 10));
        assert_eq!(threaded.beams, inline.beams);
        assert_eq!(threaded.mapper.to_grid(), inline.mapper.to_grid());
        assert!(inline.mapper.to_grid().count(mapkeeper_grid::CellState::Occupied) > 0);
    }
}
