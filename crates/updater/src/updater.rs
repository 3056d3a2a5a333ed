//! `MapUpdater`: the modules of Fig. 5 / Fig. 6 wired in the paper's order.

use crate::UpdaterError;
use crate::additions::free_pass::evaluate_free_pass;
use crate::additions::hit_index::HitIndex;
use crate::additions::log_odds_baseline::LogOddsBaseline;
use crate::paper::beam_classifier::{BeamClass, BeamClassifier};
use crate::paper::cell_buffers::CellBuffers;
use crate::paper::cell_update::{CellChange, CellUpdater};
use crate::paper::changed_cells::evaluate_changed_beam_cast;
use crate::paper::gating::{GateReason, UpdateGate};
use crate::paper::localisation_check::{Verdict, localisation_check};
use crate::paper::pose_updating::{PoseRecovery, PoseUpdater};
use crate::paper::unchanged_cells::evaluate_unchanged_beam;
use crate::params::{UpdateMethod, UpdaterParams};
use crate::support::beam_walk::BeamGeometry;
use crate::support::votes::{Vote, ensure_buffers, merge_sorted_tail};
use mapkeeper_grid::{OccupancyGrid, Pose2, RayCaster};
use mapkeeper_sensor::LaserScan;

/// What happened to one step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepOutcome {
    /// Processed: classified, checked and (on Update) used to update the map.
    Processed,
    /// Not processed by the update gating.
    Gated(GateReason),
    /// Skipped because no beam of any scan was valid.
    NoValidBeams,
}

/// The result of [`MapUpdater::process`].
#[derive(Clone, Debug, PartialEq)]
pub struct StepReport {
    /// Whether the step was processed.
    pub outcome: StepOutcome,
    /// The localisation check's verdict (always `Update` with the check disabled); `None` if
    /// the step was not processed.
    pub verdict: Option<Verdict>,
    /// n: valid beams over all lidars of the step.
    pub n_valid: usize,
    /// Invalid beams (bad readings, and every beam of a scan whose header is invalid).
    pub n_invalid: usize,
    /// Scans whose header failed `LaserScan::validate`.
    pub invalid_scans: usize,
    /// n_dc: detected-change beams.
    pub n_dc: usize,
    /// Cells of `M_i` whose state changed during this step, in processing order.
    pub changed_cells: Vec<CellChange>,
    /// On Lost (with pose updating enabled): the recovered pose or why there is none.
    pub pose_recovery: Option<PoseRecovery>,
}

impl StepReport {
    fn empty(outcome: StepOutcome) -> Self {
        Self {
            outcome,
            verdict: None,
            n_valid: 0,
            n_invalid: 0,
            invalid_scans: 0,
            n_dc: 0,
            changed_cells: Vec::new(),
            pose_recovery: None,
        }
    }
}

/// Running totals over all steps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UpdaterStats {
    /// Calls to `process`.
    pub steps: u64,
    /// Steps processed.
    pub processed: u64,
    /// Steps stopped by the gating.
    pub gated: u64,
    /// Steps skipped for lack of a valid beam.
    pub skipped_no_valid_beam: u64,
    /// Invalid beams seen in processed or skipped steps.
    pub invalid_beams: u64,
    /// Invalid scans seen.
    pub invalid_scans: u64,
    /// Verdicts: Update.
    pub updates: u64,
    /// Verdicts: Suspend.
    pub suspends: u64,
    /// Verdicts: Lost.
    pub losts: u64,
    /// Pose recoveries that succeeded.
    pub recoveries: u64,
    /// Pose recoveries that were refused.
    pub failed_recoveries: u64,
    /// Cell state changes applied to `M_i`.
    pub cell_changes: u64,
}

/// The map updater. It never mutates `M_{i-1}` (given at construction) and owns `M_i`.
#[derive(Clone, Debug)]
pub struct MapUpdater {
    params: UpdaterParams,
    /// `M_{i-1}` with its clearance field for the classifier's ray casts.
    base: RayCaster,
    current: OccupancyGrid,
    gate: UpdateGate,
    classifier: BeamClassifier,
    buffers: CellBuffers,
    cell_updater: CellUpdater,
    votes: Vec<Vote>,
    /// Scratch of the vote sort.
    vote_scratch: Vec<Vote>,
    /// The step's measured hit points (hit clearance of the removal vote).
    hits: HitIndex,
    pose_updater: PoseUpdater,
    log_odds: Option<LogOddsBaseline>,
    /// (robot_in_map, robot_in_odom) at the last step that passed the localisation check.
    last_good: Option<(Pose2, Pose2)>,
    stats: UpdaterStats,
}

impl MapUpdater {
    /// An updater for `initial_map` (`M_{i-1}`); `M_i` starts as a copy of it.
    pub fn new(initial_map: OccupancyGrid, params: UpdaterParams) -> Result<Self, UpdaterError> {
        params.validate()?;
        if initial_map.geometry().len() >= (1usize << 31) {
            return Err(UpdaterError::BadMap(format!("{} cells exceed the 2^31 limit", initial_map.geometry().len())));
        }
        let log_odds = if params.method == UpdateMethod::LogOdds {
            Some(
                LogOddsBaseline::from_grid(&initial_map, params.log_odds)
                    .map_err(|e| UpdaterError::InvalidParam { field: "log_odds", reason: e.to_string() })?,
            )
        } else {
            None
        };
        Ok(Self {
            current: initial_map.clone(),
            base: RayCaster::new(&initial_map, true),
            params,
            gate: UpdateGate::new(),
            classifier: BeamClassifier::new(),
            buffers: CellBuffers::new(),
            cell_updater: CellUpdater::new(&initial_map),
            votes: Vec::new(),
            vote_scratch: Vec::new(),
            hits: HitIndex::new(),
            pose_updater: PoseUpdater::new(),
            log_odds,
            last_good: None,
            stats: UpdaterStats::default(),
        })
    }

    /// The parameters in use.
    pub fn params(&self) -> &UpdaterParams {
        &self.params
    }

    /// `M_i`, the map being built.
    pub fn map(&self) -> &OccupancyGrid {
        &self.current
    }

    /// `M_{i-1}`, the map given at construction (never modified).
    pub fn initial_map(&self) -> &OccupancyGrid {
        self.base.map()
    }

    /// Running totals.
    pub fn stats(&self) -> UpdaterStats {
        self.stats
    }

    /// Number of cells that hold a rolling buffer.
    pub fn buffered_cells(&self) -> usize {
        self.buffers.len()
    }

    /// Bytes of the updater's own state: the sparse cell buffers (payload) plus the reusable
    /// per-step scratch (beams, votes, pose-updating clouds) and the struct itself. Excludes the
    /// two grids `M_{i-1}` and `M_i`, which scale with the map by definition. For the log-odds
    /// baseline it includes its map-sized log-odds array.
    pub fn state_bytes(&self) -> usize {
        size_of::<Self>() + self.buffers.state_bytes() + self.log_odds.as_ref().map_or(0, |l| l.state_bytes())
    }

    /// Bytes of reusable per-step scratch (grows with beams per step, never with the map).
    pub fn scratch_bytes(&self) -> usize {
        self.classifier.beams.capacity() * size_of::<crate::paper::beam_classifier::Beam>()
            + self.classifier.lidars.capacity() * size_of::<crate::paper::beam_classifier::LidarFrame>()
            + (self.votes.capacity() + self.vote_scratch.capacity()) * size_of::<Vote>()
            + self.classifier.hints.discs.scratch_bytes()
            + self.hits.capacity_bytes()
    }

    /// Tells the updater that the robot is at `robot_in_map` now (e.g. after the localiser was
    /// re-initialised): pose updating will predict from here.
    pub fn reset_reference_pose(&mut self, robot_in_map: Pose2, robot_in_odom: Pose2) {
        self.last_good = Some((robot_in_map, robot_in_odom));
    }

    /// Processes one time step: the robot pose from any localiser, the robot pose in the
    /// odometry frame (for the gating and for pose updating) and every scan of the step (one
    /// per lidar, each with its own mounting pose). Never panics on bad scans.
    pub fn process(&mut self, robot_in_map: Pose2, robot_in_odom: Pose2, scans: &[LaserScan]) -> StepReport {
        self.stats.steps += 1;
        let stamp_ns = scans.iter().map(|s| s.stamp_ns).max().unwrap_or(0);
        if let Some(reason) = self.gate.check(robot_in_odom, stamp_ns, &self.params) {
            self.stats.gated += 1;
            return StepReport::empty(StepOutcome::Gated(reason));
        }
        let counts = self.classifier.classify(&self.base, &robot_in_map, scans, &self.params);
        self.stats.invalid_beams += counts.n_invalid as u64;
        self.stats.invalid_scans += counts.invalid_scans as u64;
        let mut report = StepReport {
            n_valid: counts.n_valid,
            n_invalid: counts.n_invalid,
            invalid_scans: counts.invalid_scans,
            n_dc: counts.n_dc,
            ..StepReport::empty(StepOutcome::Processed)
        };
        if counts.n_valid == 0 {
            self.stats.skipped_no_valid_beam += 1;
            report.outcome = StepOutcome::NoValidBeams;
            return report;
        }
        self.gate.mark_processed(robot_in_odom, stamp_ns);
        self.stats.processed += 1;
        let verdict = if self.params.localisation_check {
            localisation_check(counts.n_valid, counts.n_dc, self.params.d_eps_min, self.params.d_eps_max)
        } else {
            Verdict::Update
        };
        report.verdict = Some(verdict);
        match verdict {
            Verdict::Update => {
                self.stats.updates += 1;
                self.last_good = Some((robot_in_map, robot_in_odom));
                if self.params.map_update {
                    self.update_cells(&mut report.changed_cells);
                }
            }
            Verdict::Suspend => self.stats.suspends += 1,
            Verdict::Lost => {
                self.stats.losts += 1;
                if self.params.pose_updating.enabled {
                    let predicted = match self.last_good {
                        Some((good_in_map, good_in_odom)) => good_in_map.compose(&good_in_odom.between(&robot_in_odom)),
                        None => robot_in_map,
                    };
                    let r = self.pose_updater.recover(
                        &self.current,
                        predicted,
                        scans,
                        self.params.max_range_m,
                        &self.params.pose_updating,
                    );
                    if let PoseRecovery::Recovered { pose_in_map, .. } = &r {
                        self.stats.recoveries += 1;
                        self.last_good = Some((*pose_in_map, robot_in_odom));
                    } else {
                        self.stats.failed_recoveries += 1;
                    }
                    report.pose_recovery = Some(r);
                }
            }
        }
        self.stats.cell_changes += report.changed_cells.len() as u64;
        report
    }

    /// Changed and unchanged cells evaluators, then the cells update, over the classified beams.
    fn update_cells(&mut self, changes: &mut Vec<CellChange>) {
        self.votes.clear();
        if let Some(lo) = self.log_odds.as_mut() {
            for b in &self.classifier.beams {
                if b.class != BeamClass::Invalid {
                    let origin = self.classifier.lidars[b.lidar as usize].origin;
                    lo.integrate_ray(&mut self.current, origin, b.hit, true, changes);
                }
            }
            return;
        }
        let beams = &self.classifier.beams;
        if self.params.removal_hit_clearance_m > 0.0 && beams.iter().any(|b| b.class == BeamClass::Changed) {
            let valid = beams.iter().filter(|b| b.class != BeamClass::Invalid).map(|b| b.hit);
            self.hits.rebuild(self.params.removal_hit_clearance_m, valid);
        } else {
            self.hits.rebuild(0.0, std::iter::empty());
        }
        for b in beams {
            if b.class == BeamClass::Changed {
                let origin = self.classifier.lidars[b.lidar as usize].origin;
                let beam = BeamGeometry::new(origin, b.hit, b.range_m);
                evaluate_changed_beam_cast(&self.base, &beam, &self.params, &self.hits, &mut self.votes);
            }
        }
        ensure_buffers(&mut self.votes, &mut self.vote_scratch, self.base.map().geometry().width(), &mut self.buffers);
        let n_changed_votes = self.votes.len();
        if !self.buffers.is_empty() {
            self.classifier.mark_near(
                self.base.map().geometry(),
                self.buffers.tile_origins(),
                CellBuffers::TILE_CELLS,
                self.buffers.tile_boxes(),
            );
            let mut probe = self.buffers.probe();
            for b in &self.classifier.beams {
                // Beams that agree with the map: the unchanged evaluator; detected changes: the
                // free-pass votes on the free cells they crossed. Both walk buffered cells only.
                let evaluate = match b.class {
                    BeamClass::Unchanged => evaluate_unchanged_beam,
                    BeamClass::Changed if self.params.free_pass_votes => evaluate_free_pass,
                    _ => continue,
                };
                if b.near_buffer_m.is_finite() {
                    let origin = self.classifier.lidars[b.lidar as usize].origin;
                    let beam = BeamGeometry::new(origin, b.hit, b.range_m);
                    evaluate(self.base.map(), &beam, &self.params, b.walk_from_m, &mut probe, &mut self.votes);
                }
            }
            // The cells update sorts the votes again: hand them over sorted, so that costs one
            // linear check.
            merge_sorted_tail(&mut self.votes, n_changed_votes, &mut self.vote_scratch);
        }
        self.cell_updater.apply(
            &mut self.votes,
            self.base.map(),
            &mut self.current,
            &mut self.buffers,
            &self.params,
            changes,
        );
    }
}
