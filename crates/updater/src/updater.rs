//! `MapUpdater`: the modules of Fig. 5 / Fig. 6 wired in the paper's order (gating, beam
//! classifier, localisation check, then on Update the evaluators and the cells update, on Lost
//! pose updating), with the project's additions where they act, and the memory accounting.

use crate::UpdaterError;
use crate::additions::free_pass::evaluate_free_pass;
use crate::additions::global_search::{GlobalSearch, GlobalSearchReport};
use crate::additions::log_odds_baseline::LogOddsBaseline;
use crate::additions::pose_tolerance::{PoseSigma, StepTolerance};
use crate::additions::recovery_views::{ViewMemory, ViewScratch};
use crate::additions::registration::{Refusal, Registrar, Registration};
use crate::additions::removal_gates::RemovalGates;
use crate::additions::shift_check::ShiftResult;
use crate::additions::structure_memory::StructureMemory;
use crate::additions::surface_evidence::SurfaceEvidence;
use crate::paper::beam_classifier::{BeamClass, BeamClassifier};
use crate::paper::cell_update::{CellChange, CellUpdater};
use crate::paper::changed_cells::evaluate_changed_beam_cast;
use crate::paper::gating::{GateReason, UpdateGate};
use crate::paper::localisation_check::{Verdict, localisation_check};
use crate::paper::pose_updating::{PoseRecovery, PoseUpdater};
use crate::paper::unchanged_cells::evaluate_unchanged_beam;
use crate::params::{UpdateMethod, UpdaterParams};
use crate::support::beam_walk::BeamGeometry;
use crate::support::cell_buffers::CellBuffers;
use crate::support::hit_index::HitIndex;
use crate::support::votes::{Vote, ensure_buffers, merge_sorted_tail};
use mapkeeper_grid::{OccupancyGrid, Pose2, RayCaster};
use mapkeeper_sensor::LaserScan;

/// What happened to one step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepOutcome {
    /// Checked: classified and given a verdict; on Update the cells update ran.
    Processed,
    /// Checked and given the verdict Update, but the update gating paced the cells update out
    /// (the robot has not moved enough since the last cells update). The localisation check
    /// runs on every scan; the gate only paces the cells update.
    Gated(GateReason),
    /// Skipped because no beam of any scan was valid.
    NoValidBeams,
    /// Skipped because fewer beams than `min_valid_beams` were valid: no verdict.
    TooFewBeams,
    /// Checked and given the verdict Update, but registration before writing refused the
    /// step's pose (poor or ambiguous fit, or too large a correction): nothing was written.
    Unregistered,
}

/// The result of [`MapUpdater::process`].
#[derive(Clone, Debug, PartialEq)]
pub struct StepReport {
    /// What happened to the step.
    pub outcome: StepOutcome,
    /// The localisation check's verdict (always `Update` with the check disabled), after the
    /// shift check when that is on; `None` if the step was not checked.
    pub verdict: Option<Verdict>,
    /// The paper's localisation check (§4.2) alone: differs from `verdict` where the shift
    /// check lifted a false alarm or raised one; `None` if the step was not checked.
    pub check_verdict: Option<Verdict>,
    /// n: valid beams over all lidars of the step.
    pub n_valid: usize,
    /// Invalid beams (bad readings, every beam of a scan whose header is invalid, and every
    /// beam of an occluded scan).
    pub n_invalid: usize,
    /// Scans whose header failed `LaserScan::validate`.
    pub invalid_scans: usize,
    /// Scans not used because their lidar lay in a non-free cell of `M_{i-1}`.
    pub occluded_scans: usize,
    /// n_dc: detected-change beams.
    pub n_dc: usize,
    /// Cells of `M_i` whose state changed during this step, in processing order.
    pub changed_cells: Vec<CellChange>,
    /// On Lost (with pose updating enabled, at most once per `pose_updating.retry_interval_s`):
    /// the recovered pose or why there is none; `None` between attempts.
    pub pose_recovery: Option<PoseRecovery>,
    /// Registration before writing (when enabled and the step had valid beams): the refined
    /// pose or why it was refused. A refused step writes nothing.
    pub registration: Option<Registration>,
    /// The global search, when it ran on this step (`global_search` on, and pose updating's
    /// local search found no pose or a weak one): its candidates and work. `pose_recovery` is
    /// then the answer of the check over its candidates and the local pose.
    pub global_search: Option<GlobalSearchReport>,
    /// The shift check's scores, when it ran on this step (`shift_check` on, and for
    /// `on_alarm` only on the steps the paper's check raised an alarm).
    pub shift_check: Option<ShiftResult>,
}

impl StepReport {
    fn empty(outcome: StepOutcome) -> Self {
        Self {
            outcome,
            verdict: None,
            check_verdict: None,
            n_valid: 0,
            n_invalid: 0,
            invalid_scans: 0,
            occluded_scans: 0,
            n_dc: 0,
            changed_cells: Vec::new(),
            pose_recovery: None,
            registration: None,
            global_search: None,
            shift_check: None,
        }
    }
}

/// Registration before writing over a run: how often it refined or refused, and how far it
/// moved the poses it accepted (histograms; bin edges in [`RegistrationStats::SHIFT_EDGES_M`] and
/// [`RegistrationStats::TURN_EDGES_RAD`]). Serialised with these names in run records.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct RegistrationStats {
    /// Steps whose refined pose was accepted.
    pub accepted: u64,
    /// Steps refused: too few points near the map.
    pub refused_too_few_points: u64,
    /// Steps refused: poor fit.
    pub refused_poor_fit: u64,
    /// Steps refused: degenerate (a direction unconstrained).
    pub refused_degenerate: u64,
    /// Steps refused: correction too large.
    pub refused_too_far: u64,
    /// Steps with the verdict Update that wrote nothing because registration refused.
    pub writes_withheld: u64,
    /// Accepted position corrections: counts below each edge of `SHIFT_EDGES_M`, the last bin
    /// above the last edge.
    pub shift_histogram: [u64; 7],
    /// Accepted yaw corrections (absolute): counts per bin of `TURN_EDGES_RAD`.
    pub turn_histogram: [u64; 7],
    /// Sum of the accepted position corrections, micrometres.
    pub shift_sum_um: u64,
    /// Sum of the accepted absolute yaw corrections, microradians.
    pub turn_sum_urad: u64,
}

impl RegistrationStats {
    /// Upper edges of the shift bins, metres: 0.5, 1, 2, 5, 10, 20 cm (and above).
    pub const SHIFT_EDGES_M: [f64; 6] = [0.005, 0.01, 0.02, 0.05, 0.10, 0.20];
    /// Upper edges of the yaw bins, radians: 0.05°, 0.1°, 0.25°, 0.5°, 1°, 2° (and above).
    pub const TURN_EDGES_RAD: [f64; 6] = [
        0.05 * std::f64::consts::PI / 180.0,
        0.1 * std::f64::consts::PI / 180.0,
        0.25 * std::f64::consts::PI / 180.0,
        0.5 * std::f64::consts::PI / 180.0,
        std::f64::consts::PI / 180.0,
        2.0 * std::f64::consts::PI / 180.0,
    ];

    fn record(&mut self, r: &Registration) {
        match r.refused {
            None => {
                self.accepted += 1;
                let bin = |edges: &[f64; 6], v: f64| edges.iter().position(|&e| v < e).unwrap_or(6);
                self.shift_histogram[bin(&Self::SHIFT_EDGES_M, r.shift_m)] += 1;
                self.turn_histogram[bin(&Self::TURN_EDGES_RAD, r.turn_rad.abs())] += 1;
                self.shift_sum_um += (r.shift_m * 1e6).round() as u64;
                self.turn_sum_urad += (r.turn_rad.abs() * 1e6).round() as u64;
            }
            Some(Refusal::TooFewPoints) => self.refused_too_few_points += 1,
            Some(Refusal::PoorFit) => self.refused_poor_fit += 1,
            Some(Refusal::Degenerate) => self.refused_degenerate += 1,
            Some(Refusal::TooFar) => self.refused_too_far += 1,
        }
    }

    /// Steps refused for any reason.
    pub fn refused_total(&self) -> u64 {
        self.refused_too_few_points + self.refused_poor_fit + self.refused_degenerate + self.refused_too_far
    }

    /// Adds another run's counts (totals over runs).
    pub fn add(&mut self, o: &RegistrationStats) {
        self.accepted += o.accepted;
        self.refused_too_few_points += o.refused_too_few_points;
        self.refused_poor_fit += o.refused_poor_fit;
        self.refused_degenerate += o.refused_degenerate;
        self.refused_too_far += o.refused_too_far;
        self.writes_withheld += o.writes_withheld;
        for k in 0..7 {
            self.shift_histogram[k] += o.shift_histogram[k];
            self.turn_histogram[k] += o.turn_histogram[k];
        }
        self.shift_sum_um += o.shift_sum_um;
        self.turn_sum_urad += o.turn_sum_urad;
    }
}

/// Running totals over all steps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UpdaterStats {
    /// Calls to `process`.
    pub steps: u64,
    /// Steps checked (given a verdict).
    pub processed: u64,
    /// Steps with the verdict Update whose cells update the gating paced out.
    pub gated: u64,
    /// Steps whose cells update ran.
    pub cells_updates: u64,
    /// Steps skipped for lack of a valid beam.
    pub skipped_no_valid_beam: u64,
    /// Steps skipped with fewer than `min_valid_beams` valid beams.
    pub skipped_too_few_beams: u64,
    /// Invalid beams seen.
    pub invalid_beams: u64,
    /// Invalid scans seen.
    pub invalid_scans: u64,
    /// Scans not used because their lidar lay in a non-free cell of `M_{i-1}`.
    pub occluded_scans: u64,
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
    /// Global searches run (pose updating's local search had found no pose).
    pub global_searches: u64,
    /// …of which found a pose that passed the check where the local search had none or another
    /// (counted in `recoveries` too).
    pub global_recoveries: u64,
    /// Blocks the global searches scored (their work).
    pub global_nodes: u64,
    /// Cell state changes applied to `M_i`.
    pub cell_changes: u64,
    /// Registration before writing.
    pub registration: RegistrationStats,
    /// "Changed" votes cast by the memory's healing rule (a hit in a scarred cell).
    pub heal_votes: u64,
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
    /// The global search when Lost (when on).
    global: GlobalSearch,
    /// The views and kept candidates of the current Lost stretch (`global_search.views`,
    /// `global_search.kept_candidates`).
    views: ViewMemory,
    view_scratch: ViewScratch,
    /// `M_{i-1}`'s distance field, for the shift check (when on).
    shift_field: Option<mapkeeper_grid::DistanceField>,
    /// Registration before writing (when on).
    registrar: Option<Registrar>,
    /// The cross-world memory of `M_{i-1}` (empty: every occupied cell established).
    memory: StructureMemory,
    /// The surface evidence, carried in with the memory and updated by each written step (when
    /// on).
    evidence: SurfaceEvidence,
    /// The pose spread of the step being processed (σ_xy m, σ_yaw rad), as the surface evidence
    /// weighs it: registration's fit when it accepted, else the caller's, else unknown (+∞, or 0
    /// with `evidence.trust_unreported_pose`).
    step_spread: (f64, f64),
    /// The pose uncertainty the caller handed over for the next step (the localiser's).
    pose_sigma: Option<PoseSigma>,
    /// The margins of the step being processed.
    step_tol: StepTolerance,
    log_odds: Option<LogOddsBaseline>,
    /// (robot_in_map, robot_in_odom) at the last step that passed the localisation check.
    last_good: Option<(Pose2, Pose2)>,
    /// Stamp of the last pose-updating attempt of the current Lost episode.
    last_attempt_ns: Option<u64>,
    stats: UpdaterStats,
}

impl MapUpdater {
    /// An updater for `initial_map` (`M_{i-1}`); `M_i` starts as a copy of it. With the memory
    /// on, every occupied cell of `initial_map` counts as established (a surveyed map); use
    /// [`MapUpdater::with_memory`] to carry a memory from world to world.
    pub fn new(initial_map: OccupancyGrid, params: UpdaterParams) -> Result<Self, UpdaterError> {
        Self::with_memory(initial_map, params, StructureMemory::default())
    }

    /// An updater for `initial_map` (`M_{i-1}`) and the memory that came with it (from
    /// [`MapUpdater::next_memory`] of the run that made it). The memory is ignored unless
    /// `params.memory.enabled`.
    pub fn with_memory(
        initial_map: OccupancyGrid,
        params: UpdaterParams,
        memory: StructureMemory,
    ) -> Result<Self, UpdaterError> {
        params.validate()?;
        if initial_map.geometry().len() >= (1usize << 31) {
            return Err(UpdaterError::BadMap(format!("{} cells exceed the 2^31 limit", initial_map.geometry().len())));
        }
        if let Some(k) = memory.max_index()
            && k as usize >= initial_map.geometry().len()
        {
            return Err(UpdaterError::BadMap(format!(
                "the memory records cell {k}, outside the map's {} cells: it belongs to another map",
                initial_map.geometry().len()
            )));
        }
        let evidence = if params.evidence.enabled {
            SurfaceEvidence::from_records(memory.evidence())
        } else {
            SurfaceEvidence::default()
        };
        let memory = if params.memory.enabled { memory } else { StructureMemory::default() };
        let registrar = params.registration.enabled.then(|| Registrar::new(&initial_map, &params.registration));
        let log_odds = if params.method == UpdateMethod::LogOdds {
            Some(LogOddsBaseline::from_grid(&initial_map, params.log_odds).map_err(crate::params::log_odds_refusal)?)
        } else {
            None
        };
        let shift_field = params
            .shift_check
            .enabled
            .then(|| mapkeeper_grid::DistanceField::to_occupied(&initial_map, params.shift_check.truncate_m + 0.05));
        Ok(Self {
            shift_field,
            registrar,
            memory,
            evidence,
            step_spread: (f64::INFINITY, f64::INFINITY),
            pose_sigma: None,
            step_tol: StepTolerance::NONE,
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
            global: GlobalSearch::new(),
            views: ViewMemory::default(),
            view_scratch: ViewScratch::default(),
            log_odds,
            last_good: None,
            last_attempt_ns: None,
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

    /// The cross-world memory this run started from.
    pub fn memory(&self) -> &StructureMemory {
        &self.memory
    }

    /// The memory to hand to the next world together with [`MapUpdater::map`] (empty when the
    /// memory is off).
    pub fn next_memory(&self) -> StructureMemory {
        let memory = if self.params.memory.enabled {
            self.memory.next(self.base.map(), &self.current, &self.params.memory)
        } else {
            StructureMemory::default()
        };
        if self.params.evidence.enabled { memory.with_evidence(self.evidence.records()) } else { memory }
    }

    /// Cells holding surface evidence (0 when that addition is off).
    pub fn evidence_cells(&self) -> usize {
        self.evidence.len()
    }

    /// Number of cells that hold a rolling buffer.
    pub fn buffered_cells(&self) -> usize {
        self.buffers.len()
    }

    /// Bytes of the change state: what grows with the cells the updater has touched. That is
    /// the struct itself plus the payload of the sparse cell buffers (4-byte key and 8-byte ring
    /// per buffered cell) and of the tile masks (4-byte key and 40-byte mask per 16 × 16 tile
    /// holding a buffer). For the same changes it is the same in a small and a large map. The
    /// log-odds baseline (`method = "log-odds"`) has no sparse state: its change state is its
    /// dense log-odds array (4 bytes per cell), counted here. Excludes the map-sized caches
    /// ([`MapUpdater::cache_bytes`]) and the per-step scratch ([`MapUpdater::scratch_bytes`]).
    pub fn change_state_bytes(&self) -> usize {
        size_of::<Self>()
            + self.buffers.state_bytes()
            + self.memory.state_bytes()
            + self.evidence.state_bytes()
            + self.log_odds.as_ref().map_or(0, |l| l.state_bytes())
    }

    /// The same as [`MapUpdater::change_state_bytes`] (the name the validation's
    /// `max_state_bytes` is recorded under).
    pub fn state_bytes(&self) -> usize {
        self.change_state_bytes()
    }

    /// Bytes of the map-sized data: everything allocated per map cell, **including both maps**.
    /// `M_{i-1}` (the classifier's copy, one byte per cell) with its clearance field (one `f32`
    /// per cell), `M_i` (one byte per cell), the obstacle-interior mask of border reconstruction
    /// (one byte per cell) and, once pose updating has run a correlative search, its score grid
    /// (one byte per cell): 7 bytes per cell, 8 after a search. It grows with the map's area,
    /// never with the scans processed. The log-odds baseline's array is in
    /// [`MapUpdater::change_state_bytes`], not here.
    pub fn cache_bytes(&self) -> usize {
        let base = self.base.map().cells();
        // The caster holds one f32 clearance per cell of M_{i-1} (`RayCaster::new`).
        size_of_val(base)
            + base.len() * size_of::<f32>()
            + size_of_val(self.current.cells())
            + self.cell_updater.cache_bytes()
            + self.pose_updater.cache_bytes()
            + self.global.heap_bytes()
            + self.registrar.as_ref().map_or(0, Registrar::cache_bytes)
    }

    /// Bytes of reusable per-step scratch (grows with beams per step, never with the map): beams,
    /// lidar frames, votes and their sort buffer, the classifier's free discs, the hit index, the
    /// cells flagged by the last step, and pose updating's clouds and candidates.
    pub fn scratch_bytes(&self) -> usize {
        self.classifier.beams.capacity() * size_of::<crate::paper::beam_classifier::Beam>()
            + self.classifier.lidars.capacity() * size_of::<crate::paper::beam_classifier::LidarFrame>()
            + (self.votes.capacity() + self.vote_scratch.capacity()) * size_of::<Vote>()
            + self.classifier.hints.discs.scratch_bytes()
            + self.hits.capacity_bytes()
            + self.cell_updater.scratch_bytes()
            + self.pose_updater.scratch_bytes()
            + self.registrar.as_ref().map_or(0, Registrar::scratch_bytes)
            + self.evidence.scratch_bytes()
            + self.views.heap_bytes()
            + self.view_scratch.heap_bytes()
    }

    /// Tells the updater that the robot is at `robot_in_map` now (e.g. after the localiser was
    /// re-initialised): pose updating will predict from here.
    pub fn reset_reference_pose(&mut self, robot_in_map: Pose2, robot_in_odom: Pose2) {
        self.last_good = Some((robot_in_map, robot_in_odom));
        self.views.clear();
    }

    /// Processes one time step: the robot pose from any localiser, the robot pose in the
    /// odometry frame (for the gating and for pose updating) and every scan of the step (one
    /// per lidar, each with its own mounting pose). Every step with enough valid beams is
    /// classified and checked; the update gating only paces the cells update. Never panics on
    /// bad scans.
    pub fn process(&mut self, robot_in_map: Pose2, robot_in_odom: Pose2, scans: &[LaserScan]) -> StepReport {
        self.stats.steps += 1;
        let stamp_ns = scans.iter().map(|s| s.stamp_ns).max().unwrap_or(0);
        let gate = self.gate.check(robot_in_odom, stamp_ns, &self.params);
        let registration = self.register(robot_in_map, scans);
        // The pose the step is classified, checked and written at: the refined one if accepted.
        let pose = registration.filter(Registration::accepted).map_or(robot_in_map, |r| r.pose);
        let sigma = self.step_sigma(registration.as_ref());
        self.step_tol = StepTolerance::new(sigma, &self.params.tolerance);
        let unreported = if self.params.evidence.trust_unreported_pose { 0.0 } else { f64::INFINITY };
        self.step_spread = sigma.map_or((unreported, unreported), |s| (s.xy_m, s.yaw_rad));
        let counts = self.classifier.classify(&self.base, &pose, scans, &self.params, &self.step_tol);
        self.stats.invalid_beams += counts.n_invalid as u64;
        self.stats.invalid_scans += counts.invalid_scans as u64;
        self.stats.occluded_scans += counts.occluded_scans as u64;
        let mut report = StepReport {
            n_valid: counts.n_valid,
            n_invalid: counts.n_invalid,
            invalid_scans: counts.invalid_scans,
            occluded_scans: counts.occluded_scans,
            n_dc: counts.n_dc,
            registration,
            ..StepReport::empty(StepOutcome::Processed)
        };
        if counts.n_valid == 0 {
            self.stats.skipped_no_valid_beam += 1;
            report.outcome = StepOutcome::NoValidBeams;
            return report;
        }
        if counts.n_valid < self.params.min_valid_beams as usize {
            self.stats.skipped_too_few_beams += 1;
            report.outcome = StepOutcome::TooFewBeams;
            return report;
        }
        self.stats.processed += 1;
        if let Some(r) = &registration {
            self.stats.registration.record(r);
        }
        let (check_verdict, verdict, shift) = self.verdict(counts.n_valid, counts.n_dc, pose, scans);
        report.shift_check = shift;
        report.check_verdict = Some(check_verdict);
        report.verdict = Some(verdict);
        if verdict != Verdict::Lost {
            self.last_attempt_ns = None;
        }
        if verdict == Verdict::Update {
            // The pose fits again: the Lost stretch the views belong to is over.
            self.views.clear();
        }
        match verdict {
            Verdict::Update => {
                self.stats.updates += 1;
                self.last_good = Some((pose, robot_in_odom));
                if let Some(reason) = gate {
                    self.stats.gated += 1;
                    report.outcome = StepOutcome::Gated(reason);
                } else if registration.is_some_and(|r| !r.accepted()) {
                    self.stats.registration.writes_withheld += 1;
                    report.outcome = StepOutcome::Unregistered;
                } else {
                    self.gate.mark_processed(robot_in_odom, stamp_ns);
                    if self.params.map_update {
                        self.stats.cells_updates += 1;
                        self.update_cells(&mut report.changed_cells);
                    }
                }
            }
            Verdict::Suspend => self.stats.suspends += 1,
            Verdict::Lost => {
                self.stats.losts += 1;
                (report.pose_recovery, report.global_search) =
                    self.try_pose_updating(robot_in_map, robot_in_odom, scans, stamp_ns);
            }
        }
        self.stats.cell_changes += report.changed_cells.len() as u64;
        report
    }

    /// Hands over the uncertainty of the pose of the next [`MapUpdater::process`] call (e.g.
    /// the localiser's covariance, [`PoseSigma::from_covariance`]); `None`: unknown. Used by
    /// the tolerances that follow the pose uncertainty (`params.tolerance`) when registration
    /// is off or refused the step; kept until changed.
    pub fn set_pose_sigma(&mut self, sigma: Option<PoseSigma>) {
        self.pose_sigma = sigma;
    }

    /// The margins of the last step processed ([`StepTolerance::NONE`] when the tolerances are
    /// off).
    pub fn step_tolerance(&self) -> StepTolerance {
        self.step_tol
    }

    /// The pose uncertainty of a step: registration's fit when it accepted, else what the
    /// caller handed over.
    fn step_sigma(&self, registration: Option<&Registration>) -> Option<PoseSigma> {
        match registration {
            Some(r) if r.accepted() => Some(PoseSigma { xy_m: r.xy_sigma_m, yaw_rad: r.yaw_sigma_rad }),
            _ => self.pose_sigma,
        }
    }

    /// Registration before writing, when on (see the `registration` module).
    fn register(&mut self, robot_in_map: Pose2, scans: &[LaserScan]) -> Option<Registration> {
        let registrar = self.registrar.as_mut()?;
        Some(registrar.register(robot_in_map, scans, self.params.max_range_m, &self.params.registration))
    }

    /// The localisation check (§4.2) alone, and with the shift check when on.
    fn verdict(
        &self,
        n_valid: usize,
        n_dc: usize,
        pose: Pose2,
        scans: &[LaserScan],
    ) -> (Verdict, Verdict, Option<ShiftResult>) {
        let check = if self.params.localisation_check {
            localisation_check(n_valid, n_dc, self.params.d_eps_min, self.params.d_eps_max)
        } else {
            Verdict::Update
        };
        let mut verdict = check;
        let mut shift = None;
        if let Some(field) = &self.shift_field
            && self.params.shift_check.when.runs_on(verdict)
        {
            let p = &self.params.shift_check;
            shift = crate::additions::shift_check::search(field, pose, scans, p);
            if let Some(r) = &shift {
                verdict = crate::additions::shift_check::combine(verdict, r, p);
            }
        }
        (check, verdict, shift)
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
        if self.params.removal.hit_clearance_m > 0.0 && beams.iter().any(|b| b.class == BeamClass::Changed) {
            let valid = beams.iter().filter(|b| b.class != BeamClass::Invalid).map(|b| b.hit);
            self.hits.rebuild(self.params.removal.hit_clearance_m, valid);
        } else {
            self.hits.rebuild(0.0, std::iter::empty());
        }
        for b in beams {
            if b.class == BeamClass::Changed {
                let origin = self.classifier.lidars[b.lidar as usize].origin;
                let beam = BeamGeometry::new(origin, b.hit, b.range_m);
                let how = (&self.params, &self.step_tol);
                let (map, params, hits) = (self.base.map(), &self.params, &self.hits);
                let gates = |b: &BeamGeometry| RemovalGates::new(map, &params.removal, hits, b);
                evaluate_changed_beam_cast(&self.base, &beam, how, gates, &mut self.votes);
            }
        }
        if !self.memory.is_empty() && !self.params.evidence.enabled {
            self.stats.heal_votes += self.heal_votes() as u64;
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
            (&self.params, &|index| self.memory.is_established(index)),
            changes,
        );
        if self.params.evidence.enabled {
            let (beams, lidars) = (&self.classifier.beams, &self.classifier.lidars);
            let spread = self.step_spread;
            let maps = (self.base.map(), &mut self.current);
            let memory = &self.memory;
            let established = |index| memory.is_established(index);
            let rules: (_, &dyn Fn(u32) -> bool) = (&self.params.evidence, &established);
            self.evidence.step(beams, lidars, spread, maps, rules, changes);
        }
    }

    /// The memory's healing rule: a beam without detected change whose hit point falls in a
    /// scarred cell (free in `M_{i-1}`) votes it "changed" (occupied again). Returns the votes
    /// cast.
    fn heal_votes(&mut self) -> usize {
        let map = self.base.map();
        let g = map.geometry();
        let before = self.votes.len();
        for b in &self.classifier.beams {
            if b.class != BeamClass::Unchanged {
                continue;
            }
            if let Some(i) = g.world_to_cell(b.hit).and_then(|c| g.index(c))
                && map.cells()[i] == mapkeeper_grid::CellState::Free
                && self.memory.is_scar(i as u32)
            {
                self.votes.push(crate::support::votes::vote(i, true));
            }
        }
        self.votes.len() - before
    }
}

mod lost;
#[cfg(test)]
mod tests;
