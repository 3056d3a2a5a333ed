//! `UpdaterParams`: every parameter of the updater in one struct, with the presets `paper` (§4
//! read fairly), `paper-strict` (§4 at its strictest), `authors` (the behaviour of the authors'
//! code), `mapkeeper` (this project's additions, each switchable) and its variants, the
//! `always-update` / `no-update` ablations and the naive log-odds baseline (paper §4 and its
//! parameter table; `docs/paper-vs-implementation.md` has one row per rule and one column per
//! preset).

use crate::UpdaterError;
use crate::additions::global_search::GlobalSearchParams;
use crate::additions::pose_tolerance::ToleranceParams;
use crate::additions::registration::RegistrationParams;
use crate::additions::shift_check::{ShiftCheckParams, ShiftWhen};
use crate::additions::structure_memory::MemoryParams;
use evidence::EvidenceParams;
use mapkeeper_common::ParamError;
use mapkeeper_grid::mapper::{MapperError, MapperParams};
use serde::{Deserialize, Serialize};

/// Which algorithm turns `M_{i-1}` into `M_i`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum UpdateMethod {
    /// The paper's method: beam classifier, localisation check, cell buffers (default).
    Stefanini,
    /// Naive baseline: plain log-odds occupancy mapping of every gated scan into `M_{i-1}` at the
    /// estimated pose, no localisation check, no buffers.
    LogOdds,
}

/// How the votes a cell got in one step become flags of its rolling buffer (§4.5 records "the
/// outcomes of the evaluator blocks at different time instants").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FlagRule {
    /// One flag per step: "changed" iff the step gave the cell at least as many "changed" as
    /// "unchanged" votes (`paper`, `mapkeeper`).
    StepMajority,
    /// One flag per kind per step: a "changed" flag if any vote was "changed", then an
    /// "unchanged" flag if any was "unchanged" (the authors' code).
    StepEachKind,
}

/// When a flipped cell of `M_i` returns to its `M_{i-1}` state (the paper never says).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RevertRule {
    /// Never within a run: a change, once confirmed, stays (`paper`).
    Never,
    /// As soon as the flip rule no longer holds: `M_i` follows the buffers (the authors' code
    /// rebuilds its map from the prior at every tick).
    BelowThreshold,
    /// Once the buffer holds `change_threshold` "unchanged" flags (`mapkeeper`): a hysteresis,
    /// which needs `change_threshold` > N_b / 2.
    UnchangedThreshold,
}

/// Which cells near the hit cell c(p_i) of a beam without detected change get an "unchanged"
/// vote (§4.4).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum UnchangedHitRule {
    /// §4.4: if c(p_i) is free in `M_{i-1}`, its non-free 8-neighbours ("adjacent"); otherwise
    /// c(p_i) itself (`paper`, `mapkeeper`).
    Adjacent8,
    /// c(p_i) and its 4-neighbours, each if non-free in `M_{i-1}` (the authors' code).
    Cross4,
}

/// Parameters of the pose-updating module (§4.6): ICP with several initial hypotheses and a
/// fitness gate.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PoseUpdatingParams {
    /// Run pose updating when the localisation check says Lost. Default `true`.
    pub enabled: bool,
    /// While Lost persists, pose updating is tried again at most this often (stamps of the
    /// scans), seconds; the first Lost step of an episode always tries. Default 0.5.
    pub retry_interval_s: f64,
    /// Use every k-th valid beam of the current scan as ICP source point. Default 2.
    pub source_beam_step: u32,
    /// Largest correspondence distance at the first ICP iteration, metres. Default 1.0.
    pub max_correspondence_m: f64,
    /// The correspondence distance shrinks by this factor per iteration… Default 0.8.
    pub correspondence_decay: f64,
    /// …down to this floor, metres. Default 0.25.
    pub min_correspondence_m: f64,
    /// Maximum ICP iterations per hypothesis. Default 40.
    pub max_iterations: u32,
    /// Converged when an iteration moves the pose less than this, metres. Default 1e-4.
    pub convergence_translation_m: f64,
    /// Converged when an iteration turns the pose less than this, radians. Default 1e-4.
    pub convergence_rotation_rad: f64,
    /// Yaw offsets tried as initial hypotheses around the predicted pose, radians.
    /// Default [0, ±0.2, ±0.4, ±0.8].
    pub yaw_offsets_rad: Vec<f64>,
    /// Position offsets tried along x and y (every combination) around the predicted pose,
    /// metres. Default [0, ±0.6].
    pub position_offsets_m: Vec<f64>,
    /// A source point is an inlier when its nearest expected point is closer than this, metres.
    /// Default 0.10.
    pub inlier_distance_m: f64,
    /// Fitness gate: smallest accepted inlier ratio (inliers / source points). Default 0.7.
    pub min_inlier_ratio: f64,
    /// Fitness gate: largest accepted RMSE over inliers, metres. Default 0.06.
    pub max_rmse_m: f64,
    /// Fewest source and expected points needed to try at all. Default 30.
    pub min_points: u32,
    /// Two converged hypotheses whose inlier ratios differ by less than this and whose poses are
    /// further apart than `ambiguity_distance_m` / `ambiguity_rotation_rad` make the result
    /// ambiguous, which is refused. Default 0.02.
    pub ambiguity_ratio_margin: f64,
    /// See `ambiguity_ratio_margin`, metres. Default 0.3.
    pub ambiguity_distance_m: f64,
    /// See `ambiguity_ratio_margin`, radians. Default 0.1.
    pub ambiguity_rotation_rad: f64,
    /// Correlative search when the hypotheses around the predicted pose find no accepted
    /// pose: every pose within this distance of the predicted one (in x and y) is scored
    /// against the occupied cells of `M_i`, metres; 0 = off. Default 2.0.
    pub search_radius_m: f64,
    /// …and within ±this yaw, radians. Default 0.8.
    pub search_yaw_rad: f64,
    /// Translation step of the search, metres (rounded to whole cells). Default 0.1.
    pub search_step_m: f64,
    /// Yaw step of the search, radians. Default 0.03.
    pub search_yaw_step_rad: f64,
    /// Best distinct poses of the search refined by ICP and checked. Default 6.
    pub search_candidates: u32,
}

impl Default for PoseUpdatingParams {
    fn default() -> Self {
        Self {
            enabled: true,
            retry_interval_s: 0.5,
            source_beam_step: 2,
            max_correspondence_m: 1.0,
            correspondence_decay: 0.8,
            min_correspondence_m: 0.25,
            max_iterations: 40,
            convergence_translation_m: 1e-4,
            convergence_rotation_rad: 1e-4,
            yaw_offsets_rad: vec![0.0, 0.2, -0.2, 0.4, -0.4, 0.8, -0.8],
            position_offsets_m: vec![0.0, 0.6, -0.6],
            inlier_distance_m: 0.10,
            min_inlier_ratio: 0.7,
            max_rmse_m: 0.06,
            min_points: 30,
            ambiguity_ratio_margin: 0.02,
            ambiguity_distance_m: 0.3,
            ambiguity_rotation_rad: 0.1,
            search_radius_m: 2.0,
            search_yaw_rad: 0.8,
            search_step_m: 0.1,
            search_yaw_step_rad: 0.03,
            search_candidates: 6,
        }
    }
}

/// All parameters of the map updater. `Default` is the `paper` preset.
///
/// ```
/// use mapkeeper_updater::UpdaterParams;
/// let mut p = UpdaterParams::default();
/// assert_eq!(p.buffer_size, 10);
/// p.change_threshold = 8;
/// assert!(p.validate().is_ok());
/// let a = UpdaterParams::preset("authors").unwrap();
/// assert_eq!(a.max_range_m, 18.0);
/// assert!(UpdaterParams::preset("mapkeeper").unwrap().free_pass_votes);
/// ```
///
/// Serde reads and writes it field by field (unknown keys are errors), and also reads the flat
/// names the removal gates had before the `removal` section (`removal_hit_clearance_m`, …), so
/// older parameter files and records still load; they are written as the section.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(remote = "Self", default, deny_unknown_fields)]
pub struct UpdaterParams {
    /// Which algorithm runs. Default [`UpdateMethod::Stefanini`].
    pub method: UpdateMethod,

    // --- Update gating (§4.5) ---
    /// The cells update runs only after the robot moved at least this far since the last scan
    /// that updated the cells (odometry), metres. The localisation check runs on every scan.
    /// Default 0.05.
    pub gating_min_translation_m: f64,
    /// …or turned at least this much, radians. Default 20° (0.349).
    pub gating_min_rotation_rad: f64,
    /// …and at least this long after the last scan that updated the cells, seconds. Default 0
    /// (`authors` 0.3).
    pub gating_min_interval_s: f64,
    /// Pause the cells update after a rotation faster than this, rad/s (`inf` = never;
    /// `authors` 12°/s).
    #[serde(with = "inf_as_text")]
    pub fast_rotation_rad_s: f64,
    /// The pause lasts at least this long, seconds. Default 1.2 (only with `fast_rotation_rad_s`).
    pub fast_rotation_pause_s: f64,
    /// …and until the robot travelled at least this far, metres. Default 1.6.
    pub fast_rotation_pause_m: f64,

    // --- Beam classifier (§4.1, Appendix A.1) ---
    /// Beams at or beyond this range are invalid, metres; `inf` = each lidar's own maximum.
    /// Default `inf` (`authors` 18).
    #[serde(with = "inf_as_text")]
    pub max_range_m: f64,
    /// n_e: virtual rays on each side of a beam. Default 1.
    pub virtual_rays_each_side: u32,
    /// v: spacing of the virtual rays in units of the beam increment Δθ. Default 0.5 (Fig. 7).
    pub virtual_ray_spacing_beams: f64,
    /// If positive, n_e is derived per scan as ceil(window / (v·|Δθ|)) instead, radians.
    /// Default 0 (`authors` ±4° at v = 1).
    pub virtual_window_rad: f64,
    /// m_th of D_th(z) = min(m_th·z + q_th, D_max), metres per metre. Default 0.01327.
    pub change_slope: f64,
    /// q_th, metres. Default 0.1473.
    pub change_intercept_m: f64,
    /// D_max, metres. Default 0.30.
    pub change_max_m: f64,
    /// Outlier filter: detected-change beams count only in runs of at least this many adjacent
    /// beams of one lidar. Default 1 (no filter; `authors` 3).
    pub min_change_run: u32,

    // --- Localisation check (§4.2) ---
    /// Run the localisation check; `false` is the `always-update` ablation. Default `true`.
    pub localisation_check: bool,
    /// D_εmin of eq. 6-7. Default 0.75 (`authors` 0.58).
    pub d_eps_min: f64,
    /// D_εmax of eq. 7-8. Default 0.90 (`authors` 0.58: no Suspend band).
    pub d_eps_max: f64,
    /// A guard outside the algorithm (every preset): a step with fewer valid beams than this
    /// gets no verdict (no cells update, no pose updating): eq. 6-8 need a sample, and one valid
    /// beam that is a change would otherwise make the robot Lost. Default 20.
    pub min_valid_beams: u32,

    // --- Changed / unchanged cells evaluators (§4.3, §4.4) ---
    /// tol(z) = min(tol_slope·z + tol_intercept_m, tol_max_m): slope. Default 0.01.
    pub tol_slope: f64,
    /// tol intercept, metres. Default 0.10 (`authors` 0.15).
    pub tol_intercept_m: f64,
    /// tol cap, metres (`inf` = uncapped). Default 0.20 (`authors` `inf`).
    #[serde(with = "inf_as_text")]
    pub tol_max_m: f64,
    /// Final chunk skipped by the changed evaluator: max(slope·z, min); the slope is eq. 9's m.
    /// Default 0.02.
    pub skip_changed_slope: f64,
    /// …and its minimum, metres (not in eq. 9). Default 0 (`authors` 0.15).
    pub skip_changed_min_m: f64,
    /// Final chunk skipped by the unchanged evaluator: max(slope·z, min), slope. Default 0.02.
    pub skip_unchanged_slope: f64,
    /// …and its minimum, metres. Default 0.
    pub skip_unchanged_min_m: f64,
    /// Which cells around the hit cell of an agreeing beam get an "unchanged" vote. Default
    /// [`UnchangedHitRule::Adjacent8`] (`authors` [`UnchangedHitRule::Cross4`]).
    pub unchanged_hit: UnchangedHitRule,
    /// The unchanged evaluator votes only the cells along the ray that are free in `M_{i-1}`
    /// (`authors`); `false`: every cell up to p_th (§4.4). Default `false`.
    pub unchanged_ray_free_only: bool,
    /// Beams within ±this many beams of a detected change are not evaluated as unchanged.
    /// Default 0 (`authors` 2).
    pub skip_near_changes_beams: u32,
    /// The gates on the removal vote (`mapkeeper` additions; see the `removal_gates` module):
    /// hit clearance, grazing gate, ray core, shadow. Default: all off (`mapkeeper`: hit
    /// clearance 0.2 m, grazing gate 10°, shadow).
    pub removal: RemovalParams,
    /// Free-pass votes (a `mapkeeper` addition): cells free in `M_{i-1}` that a detected-change
    /// beam crossed before its final chunk (never its own hit cell) get an "unchanged" vote, as
    /// the unchanged evaluator gives them for agreeing beams (see the `free_pass` module).
    /// Default `false` (`mapkeeper` `true`).
    pub free_pass_votes: bool,

    // --- Cells update (§4.5) ---
    /// Run the map update at all; `false` is the `no-update` ablation (M_1 kept). Default `true`.
    pub map_update: bool,
    /// N_b: rolling buffer size, flags (1..=32). Default 10.
    pub buffer_size: u32,
    /// A cell flips when it holds at least this many "changed" flags (1..=N_b; with
    /// `revert = "unchanged-threshold"`, more than N_b / 2). Default 7.
    pub change_threshold: u32,
    /// How a step's votes on a cell become flags in its buffer. Default
    /// [`FlagRule::StepMajority`].
    pub flags: FlagRule,
    /// When a flipped cell returns to its `M_{i-1}` state. Default [`RevertRule::Never`]
    /// (`authors` [`RevertRule::BelowThreshold`], `mapkeeper` [`RevertRule::UnchangedThreshold`]).
    pub revert: RevertRule,
    /// `authors` rule: the count plus the number of 8-neighbours already at the threshold with
    /// the same initial state must reach the threshold. Default `false` (`authors` `true`).
    pub neighbour_support: bool,
    /// Set unknown 8-neighbours of a cell that became free to occupied (Fig. 14). Default `true`.
    pub border_reconstruction: bool,
    /// Border reconstruction only sets unknown cells that are an obstacle's interior in
    /// `M_{i-1}` (enclosed by occupied cells, see `cell_update`), not never-observed space
    /// (how Fig. 14 draws it). Default `true` (`paper` and `mapkeeper`; `paper-strict` and
    /// `authors` `false`).
    pub border_interior_only: bool,

    // --- Pose updating (§4.6) ---
    /// Pose updating (ICP) parameters.
    pub pose_updating: PoseUpdatingParams,
    /// The shift check (a project addition to the localisation check; see the `shift_check`
    /// module): on every step in `mapkeeper-shift`, on alarm steps only in `mapkeeper`. Default
    /// off (not written when off with its defaults).
    #[serde(skip_serializing_if = "ShiftCheckParams::is_default_off")]
    pub shift_check: ShiftCheckParams,
    /// The global search when pose updating's local search finds no pose (a `mapkeeper`
    /// addition; see the `global_search` module). Default off (not written when off with its
    /// defaults).
    #[serde(skip_serializing_if = "GlobalSearchParams::is_default_off")]
    pub global_search: GlobalSearchParams,
    /// Registration before writing (a `mapkeeper` addition; see the `registration` module).
    /// Default off.
    pub registration: RegistrationParams,
    /// The cross-world memory (a `mapkeeper` addition; see the `structure_memory` module).
    /// Default off.
    pub memory: MemoryParams,
    /// Surface evidence across worlds (a `mapkeeper` addition, issue 53; see the
    /// `surface_evidence` module). Default off (not written when off with its defaults).
    #[serde(skip_serializing_if = "EvidenceParams::is_default_off")]
    pub evidence: EvidenceParams,
    /// Tolerances that follow the step's pose uncertainty (a `mapkeeper` addition; see the
    /// `pose_tolerance` module). Default off.
    pub tolerance: ToleranceParams,
    /// Log-odds baseline parameters (the grid crate's mapper; only with `method = "log-odds"`).
    pub log_odds: MapperParams,
}

impl Default for UpdaterParams {
    fn default() -> Self {
        Self::paper()
    }
}

impl Serialize for UpdaterParams {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        // The derived serialiser (`remote = "Self"` makes it an inherent function).
        UpdaterParams::serialize(self, s)
    }
}

impl<'de> Deserialize<'de> for UpdaterParams {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        legacy::deserialize(d)
    }
}

/// The names accepted by [`UpdaterParams::preset`].
pub const PRESET_NAMES: [&str; 10] = [
    "paper",
    "paper-strict",
    "authors",
    "mapkeeper",
    "mapkeeper-evidence",
    "mapkeeper-no-registration",
    "mapkeeper-shift",
    "always-update",
    "no-update",
    "log-odds",
];

impl UpdaterParams {
    /// §4 read fairly (`docs/paper-vs-implementation.md`, "Reading the paper"): `paper-strict`
    /// with the reading best supported by the text, its figures and its results at each of the
    /// five points where §4 is silent or ambiguous: the rolling buffer is a sliding window (a
    /// cell is changed while its last N_b flags hold more than the threshold, and returns to its
    /// `M_{i-1}` state when they no longer do); "exceeds 7" is > 7; the final chunk of eq. 9 is
    /// m·z floored at 0.15 m for both evaluators (its stated purpose is the localisation error,
    /// which does not shrink with range); the virtual rays fill the open interval between the
    /// neighbouring beams that §4.1 names (n_e = 3, v = Δθ/4; Fig. 7's v = Δθ/2 is "an
    /// example"); border reconstruction closes obstacle interiors, as Fig. 14 draws it.
    pub fn paper() -> Self {
        Self {
            revert: RevertRule::BelowThreshold,
            change_threshold: 8,
            skip_changed_min_m: 0.15,
            skip_unchanged_min_m: 0.15,
            virtual_rays_each_side: 3,
            virtual_ray_spacing_beams: 0.25,
            border_interior_only: true,
            ..Self::paper_strict()
        }
    }

    /// §4 at its strictest, nothing added: eq. 2-9 with n_e = 1, v = Δθ/2, D_th(z) of A.1,
    /// tol(z), the final chunk m·z of eq. 9 (m = 0.02) with no floor, N_b = 10, "exceeds 7" read
    /// as ≥ 7, the 0.05 m / 20° gate, unknown treated as occupied, border reconstruction of every
    /// unknown 8-neighbour, no revert of a flip. Where the text gives no number (D_th, tol, m)
    /// the values are the spec's. This was the `paper` preset of the first two releases.
    pub fn paper_strict() -> Self {
        Self {
            method: UpdateMethod::Stefanini,
            gating_min_translation_m: 0.05,
            gating_min_rotation_rad: 20f64.to_radians(),
            gating_min_interval_s: 0.0,
            fast_rotation_rad_s: f64::INFINITY,
            fast_rotation_pause_s: 1.2,
            fast_rotation_pause_m: 1.6,
            max_range_m: f64::INFINITY,
            virtual_rays_each_side: 1,
            virtual_ray_spacing_beams: 0.5,
            virtual_window_rad: 0.0,
            change_slope: 0.01327,
            change_intercept_m: 0.1473,
            change_max_m: 0.30,
            min_change_run: 1,
            localisation_check: true,
            d_eps_min: 0.75,
            d_eps_max: 0.90,
            min_valid_beams: 20,
            tol_slope: 0.01,
            tol_intercept_m: 0.10,
            tol_max_m: 0.20,
            skip_changed_slope: 0.02,
            skip_changed_min_m: 0.0,
            skip_unchanged_slope: 0.02,
            skip_unchanged_min_m: 0.0,
            unchanged_hit: UnchangedHitRule::Adjacent8,
            unchanged_ray_free_only: false,
            skip_near_changes_beams: 0,
            removal: RemovalParams::default(),
            free_pass_votes: false,
            map_update: true,
            buffer_size: 10,
            change_threshold: 7,
            flags: FlagRule::StepMajority,
            revert: RevertRule::Never,
            neighbour_support: false,
            border_reconstruction: true,
            border_interior_only: false,
            pose_updating: PoseUpdatingParams::default(),
            shift_check: ShiftCheckParams::default(),
            global_search: GlobalSearchParams::default(),
            registration: RegistrationParams::default(),
            memory: MemoryParams::default(),
            evidence: EvidenceParams::default(),
            tolerance: ToleranceParams::default(),
            log_odds: MapperParams::default(),
        }
    }

    /// The project's recommended variant: [`UpdaterParams::mapkeeper_no_registration`] (the
    /// additions of the second release) plus registration before writing (each step's pose
    /// refined against `M_{i-1}` with its own scans, nothing written when the fit is poor or
    /// ambiguous) and the cross-world memory (established structure needs more evidence to go, a
    /// removed wall face hit again heals), and the shift check on alarm steps only (a Suspend or
    /// Lost of the change count is lifted when the scan fits `M_{i-1}` at the given pose and no
    /// nearby pose fits better: a right pose in a stale world), and when pose updating's local
    /// search finds no pose, a global search over the whole map and every heading, its
    /// candidates judged on up to four views of the Lost stretch (issue 54). Each is
    /// switchable by its own field; `tests/additions.rs` shows the failure each addition prevents.
    pub fn mapkeeper() -> Self {
        Self {
            registration: RegistrationParams { enabled: true, ..RegistrationParams::default() },
            memory: MemoryParams { enabled: true, ..MemoryParams::default() },
            shift_check: ShiftCheckParams { enabled: true, when: ShiftWhen::OnAlarm, ..ShiftCheckParams::default() },
            global_search: GlobalSearchParams::mapkeeper(),
            ..Self::mapkeeper_no_registration()
        }
    }

    /// `mapkeeper` with the surface evidence across worlds (issue 53: each cell within the last
    /// 0.15 m of a beam decided by the trust-weighted share of the beams that ended in it, over
    /// many passes and worlds) and registration scoring points against occupied cells' centres
    /// (the flat-bottomed cost left the pose free by a face's thickness, and the evidence wrote
    /// faces a cell off). Better than `mapkeeper` on every metric and change class in the
    /// simulator's hold-out, worse on the real logs' chains (`experiment real-scans`), so not the
    /// default: `docs/updater.md`, "Surface evidence".
    pub fn mapkeeper_evidence() -> Self {
        let m = Self::mapkeeper();
        Self {
            evidence: EvidenceParams { enabled: true, ..EvidenceParams::default() },
            registration: RegistrationParams { pull_to_centres: true, ..m.registration },
            ..m
        }
    }

    /// `mapkeeper` without registration before writing and without the cross-world memory:
    /// the additions of the second release alone, as tuned on seeds 1-3 (10 worlds each;
    /// `docs/paper-vs-implementation.md`, "Choosing mapkeeper"): `paper-strict` plus hit
    /// clearance 0.2 m, grazing gate 10°, shadow, free-pass votes, revert of flipped cells after
    /// 7 "unchanged" flags, border reconstruction of obstacle interiors only (the ray core and
    /// the 0.15 m minimum final chunk did not help there and are off).
    pub fn mapkeeper_no_registration() -> Self {
        Self {
            removal: RemovalParams::mapkeeper(),
            free_pass_votes: true,
            revert: RevertRule::UnchangedThreshold,
            border_interior_only: true,
            ..Self::paper_strict()
        }
    }

    /// `mapkeeper` with the shift check on (issue 12 item 5: a check that sees what the change
    /// count cannot; measured by `mapkeeper experiment check-detection`, `docs/recovery.md`).
    pub fn mapkeeper_shift() -> Self {
        Self { shift_check: ShiftCheckParams { enabled: true, ..ShiftCheckParams::default() }, ..Self::mapkeeper() }
    }

    /// The behaviour of the authors' published code, as the product specification lists it (the
    /// departures from it that remain are listed in `docs/paper-vs-implementation.md`).
    pub fn authors() -> Self {
        Self {
            gating_min_interval_s: 0.3,
            fast_rotation_rad_s: 12f64.to_radians(),
            max_range_m: 18.0,
            virtual_ray_spacing_beams: 1.0,
            virtual_window_rad: 4f64.to_radians(),
            change_slope: 0.013265,
            change_intercept_m: 0.14735,
            min_change_run: 3,
            d_eps_min: 0.58,
            d_eps_max: 0.58,
            tol_slope: 0.013,
            tol_intercept_m: 0.15,
            tol_max_m: f64::INFINITY,
            skip_changed_min_m: 0.15,
            skip_near_changes_beams: 2,
            unchanged_hit: UnchangedHitRule::Cross4,
            unchanged_ray_free_only: true,
            flags: FlagRule::StepEachKind,
            revert: RevertRule::BelowThreshold,
            neighbour_support: true,
            ..Self::paper_strict()
        }
    }

    /// The paper's "old approach" (Table 1): the localisation check is off, every scan that
    /// passes the gate updates the map.
    pub fn always_update() -> Self {
        Self { localisation_check: false, ..Self::paper() }
    }

    /// The static-map baseline: scans are classified and checked but `M_1` is kept.
    pub fn no_update() -> Self {
        Self { map_update: false, ..Self::paper() }
    }

    /// The naive log-odds baseline.
    pub fn log_odds() -> Self {
        Self { method: UpdateMethod::LogOdds, localisation_check: false, ..Self::paper() }
    }

    /// A preset by name (one of [`PRESET_NAMES`]).
    pub fn preset(name: &str) -> Result<Self, UpdaterError> {
        match name {
            "paper" => Ok(Self::paper()),
            "paper-strict" => Ok(Self::paper_strict()),
            "mapkeeper-no-registration" => Ok(Self::mapkeeper_no_registration()),
            "authors" => Ok(Self::authors()),
            "mapkeeper" => Ok(Self::mapkeeper()),
            "mapkeeper-evidence" => Ok(Self::mapkeeper_evidence()),
            "mapkeeper-shift" => Ok(Self::mapkeeper_shift()),
            "always-update" => Ok(Self::always_update()),
            "no-update" => Ok(Self::no_update()),
            "log-odds" => Ok(Self::log_odds()),
            other => Err(UpdaterError::UnknownPreset { name: other.to_string(), known: PRESET_NAMES.join(", ") }),
        }
    }
    /// D_th(z) (Appendix A.1), metres.
    #[inline]
    pub fn change_distance_m(&self, z: f64) -> f64 {
        (self.change_slope * z + self.change_intercept_m).min(self.change_max_m)
    }

    /// tol(z) (§4.3.2), metres.
    #[inline]
    pub fn tol_m(&self, z: f64) -> f64 {
        (self.tol_slope * z + self.tol_intercept_m).min(self.tol_max_m)
    }

    /// Length of the final chunk skipped by the changed evaluator (eq. 9), metres.
    #[inline]
    pub fn skip_changed_m(&self, z: f64) -> f64 {
        (self.skip_changed_slope * z).max(self.skip_changed_min_m)
    }

    /// Length of the final chunk skipped by the unchanged evaluator, metres.
    #[inline]
    pub fn skip_unchanged_m(&self, z: f64) -> f64 {
        (self.skip_unchanged_slope * z).max(self.skip_unchanged_min_m)
    }

    /// Checks every field; called once by [`crate::MapUpdater::new`]. Reports the first bad
    /// field found.
    pub fn validate(&self) -> Result<(), UpdaterError> {
        self.validate_gating_and_removal()?;
        self.validate_classifier_and_check()?;
        self.validate_evaluators_and_cells()?;
        self.pose_updating.validate()?;
        self.shift_check.validate()?;
        self.global_search.validate()?;
        self.registration.validate()?;
        self.memory.validate(self.buffer_size, self.change_threshold)?;
        self.evidence.validate()?;
        self.tolerance.validate()?;
        self.log_odds.validate().map_err(log_odds_refusal)?;
        Ok(())
    }

    /// Update gating and the removal-vote additions.
    fn validate_gating_and_removal(&self) -> Result<(), UpdaterError> {
        non_neg_finite("gating_min_translation_m", self.gating_min_translation_m)?;
        self.removal.validate()?;
        non_neg_finite("gating_min_rotation_rad", self.gating_min_rotation_rad)?;
        non_neg_finite("gating_min_interval_s", self.gating_min_interval_s)?;
        positive("fast_rotation_rad_s", self.fast_rotation_rad_s)?;
        non_neg_finite("fast_rotation_pause_s", self.fast_rotation_pause_s)?;
        non_neg_finite("fast_rotation_pause_m", self.fast_rotation_pause_m)?;
        positive("max_range_m", self.max_range_m)?;
        Ok(())
    }

    /// Beam classifier and localisation check.
    fn validate_classifier_and_check(&self) -> Result<(), UpdaterError> {
        if self.virtual_rays_each_side > 64 {
            return Err(bad("virtual_rays_each_side", "", "must be at most 64"));
        }
        if !(self.virtual_ray_spacing_beams.is_finite() && self.virtual_ray_spacing_beams > 0.0) {
            return Err(bad("virtual_ray_spacing_beams", "", "must be finite and > 0"));
        }
        non_neg_finite("virtual_window_rad", self.virtual_window_rad)?;
        non_neg_finite("change_slope", self.change_slope)?;
        non_neg_finite("change_intercept_m", self.change_intercept_m)?;
        positive("change_max_m", self.change_max_m)?;
        if self.min_change_run == 0 {
            return Err(bad("min_change_run", "", "must be >= 1 (1 = no outlier filter)"));
        }
        for (field, v) in [("d_eps_min", self.d_eps_min), ("d_eps_max", self.d_eps_max)] {
            if !(0.0..=1.0).contains(&v) {
                return Err(bad(field, v, "must lie in [0, 1]"));
            }
        }
        if self.d_eps_min > self.d_eps_max {
            let requirement = format!("must not exceed d_eps_max ({} > {})", self.d_eps_min, self.d_eps_max);
            return Err(bad("d_eps_min", "", requirement));
        }
        Ok(())
    }

    /// Changed / unchanged cells evaluators and cells update.
    fn validate_evaluators_and_cells(&self) -> Result<(), UpdaterError> {
        non_neg_finite("tol_slope", self.tol_slope)?;
        non_neg_finite("tol_intercept_m", self.tol_intercept_m)?;
        positive("tol_max_m", self.tol_max_m)?;
        non_neg_finite("skip_changed_slope", self.skip_changed_slope)?;
        non_neg_finite("skip_changed_min_m", self.skip_changed_min_m)?;
        non_neg_finite("skip_unchanged_slope", self.skip_unchanged_slope)?;
        non_neg_finite("skip_unchanged_min_m", self.skip_unchanged_min_m)?;
        for (field, v) in
            [("skip_changed_slope", self.skip_changed_slope), ("skip_unchanged_slope", self.skip_unchanged_slope)]
        {
            if v >= 1.0 {
                return Err(bad(field, v, "must be < 1"));
            }
        }
        if !(1..=32).contains(&self.buffer_size) {
            return Err(bad("buffer_size", self.buffer_size, "must lie in 1..=32"));
        }
        if !(1..=self.buffer_size).contains(&self.change_threshold) {
            return Err(bad("change_threshold", self.change_threshold, "must lie in 1..=buffer_size"));
        }
        if self.revert == RevertRule::UnchangedThreshold && 2 * self.change_threshold <= self.buffer_size {
            let requirement = format!(
                "with revert = \"unchanged-threshold\" it must exceed buffer_size / 2 ({} <= {} / 2): a buffer could then hold \
                 enough flags to flip and to flip back at once",
                self.change_threshold, self.buffer_size
            );
            return Err(bad("change_threshold", "", requirement));
        }
        if self.min_valid_beams == 0 {
            return Err(bad("min_valid_beams", "", "must be >= 1"));
        }
        Ok(())
    }
}

/// The log-odds mapper's refusal of its parameters, named `log_odds.…`.
pub(crate) fn log_odds_refusal(e: MapperError) -> ParamError {
    match e {
        MapperError::InvalidParam(p) => p.within("log_odds"),
        other => ParamError::new("log_odds", "", other.to_string()),
    }
}

/// `field` holds `value` (`""`: the message gives none), which is not as `requirement` says.
fn bad(field: &str, value: impl std::fmt::Display, requirement: impl Into<String>) -> UpdaterError {
    ParamError::new(field, value, requirement).into()
}

fn non_neg_finite(field: &str, v: f64) -> Result<(), UpdaterError> {
    if v.is_finite() && v >= 0.0 { Ok(()) } else { Err(bad(field, v, "must be finite and >= 0")) }
}

fn positive(field: &str, v: f64) -> Result<(), UpdaterError> {
    if v > 0.0 && !v.is_nan() { Ok(()) } else { Err(bad(field, v, "must be > 0")) }
}

impl PoseUpdatingParams {
    /// Checks every field (called by [`UpdaterParams::validate`]); field names in errors are
    /// prefixed `pose_updating.`.
    pub fn validate(&self) -> Result<(), UpdaterError> {
        let p = self;
        non_neg_finite("pose_updating.retry_interval_s", p.retry_interval_s)?;
        if p.source_beam_step == 0 {
            return Err(bad("pose_updating.source_beam_step", "", "must be >= 1"));
        }
        positive("pose_updating.max_correspondence_m", p.max_correspondence_m)?;
        positive("pose_updating.min_correspondence_m", p.min_correspondence_m)?;
        if !p.max_correspondence_m.is_finite() || p.min_correspondence_m > p.max_correspondence_m {
            return Err(bad("pose_updating.min_correspondence_m", "", "must be finite and <= max_correspondence_m"));
        }
        if !(p.correspondence_decay > 0.0 && p.correspondence_decay <= 1.0) {
            return Err(bad("pose_updating.correspondence_decay", "", "must lie in (0, 1]"));
        }
        if p.max_iterations == 0 || p.max_iterations > 1000 {
            return Err(bad("pose_updating.max_iterations", "", "must lie in 1..=1000"));
        }
        non_neg_finite("pose_updating.convergence_translation_m", p.convergence_translation_m)?;
        non_neg_finite("pose_updating.convergence_rotation_rad", p.convergence_rotation_rad)?;
        if p.yaw_offsets_rad.is_empty() || p.yaw_offsets_rad.iter().any(|v| !v.is_finite()) {
            return Err(bad("pose_updating.yaw_offsets_rad", "", "must be non-empty and finite"));
        }
        if p.position_offsets_m.is_empty() || p.position_offsets_m.iter().any(|v| !v.is_finite()) {
            return Err(bad("pose_updating.position_offsets_m", "", "must be non-empty and finite"));
        }
        let hypotheses = p.yaw_offsets_rad.len().saturating_mul(p.position_offsets_m.len().saturating_pow(2));
        if hypotheses > 4096 {
            let requirement =
                format!("with position_offsets_m, {hypotheses} hypotheses (yaws × positions²): at most 4096");
            return Err(bad("pose_updating.yaw_offsets_rad", "", requirement));
        }
        positive("pose_updating.inlier_distance_m", p.inlier_distance_m)?;
        if !p.inlier_distance_m.is_finite() {
            return Err(bad("pose_updating.inlier_distance_m", "", "must be finite"));
        }
        if !(0.0..=1.0).contains(&p.min_inlier_ratio) {
            return Err(bad("pose_updating.min_inlier_ratio", "", "must lie in [0, 1]"));
        }
        positive("pose_updating.max_rmse_m", p.max_rmse_m)?;
        non_neg_finite("pose_updating.ambiguity_ratio_margin", p.ambiguity_ratio_margin)?;
        non_neg_finite("pose_updating.ambiguity_distance_m", p.ambiguity_distance_m)?;
        non_neg_finite("pose_updating.ambiguity_rotation_rad", p.ambiguity_rotation_rad)?;
        non_neg_finite("pose_updating.search_radius_m", p.search_radius_m)?;
        non_neg_finite("pose_updating.search_yaw_rad", p.search_yaw_rad)?;
        positive("pose_updating.search_step_m", p.search_step_m)?;
        positive("pose_updating.search_yaw_step_rad", p.search_yaw_step_rad)?;
        let steps = |range: f64, step: f64| 2.0 * (range / step).floor() + 1.0;
        let poses = steps(p.search_radius_m, p.search_step_m).powi(2) * steps(p.search_yaw_rad, p.search_yaw_step_rad);
        if poses > 2e6 {
            let requirement = format!(
                "with search_step_m, search_yaw_rad and search_yaw_step_rad, the search has {poses:.3e} poses: at most \
                 2,000,000"
            );
            return Err(bad("pose_updating.search_radius_m", "", requirement));
        }
        if p.search_candidates == 0 || p.search_candidates > 64 {
            return Err(bad("pose_updating.search_candidates", "", "must lie in 1..=64"));
        }
        Ok(())
    }
}

/// Serde of a limit where `inf` means "none": JSON has no infinity (serde_json would write
/// `null` and could not read it back), so `inf` is written as the string `"inf"`; read back
/// are numbers (TOML's `inf` too), `"inf"` / `"infinity"` (any case) and `null`. Every field
/// that may hold `inf` carries `#[serde(with = "inf_as_text")]` (the test
/// `infinite_limits_survive_json` catches one that does not, in any preset).
pub mod inf_as_text {
    use serde::{Deserialize, Deserializer, Serializer};

    /// Writes `inf` as `"inf"`, any other value as a number.
    pub fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
        if *v == f64::INFINITY { s.serialize_str("inf") } else { s.serialize_f64(*v) }
    }

    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Repr {
        Number(f64),
        Text(String),
    }

    /// Reads a number, `"inf"` / `"infinity"` (any case) or `null` (= `inf`).
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        match Option::<Repr>::deserialize(d)? {
            Some(Repr::Number(v)) => Ok(v),
            None => Ok(f64::INFINITY),
            Some(Repr::Text(t)) if t.eq_ignore_ascii_case("inf") || t.eq_ignore_ascii_case("infinity") => {
                Ok(f64::INFINITY)
            }
            Some(Repr::Text(t)) => Err(serde::de::Error::custom(format!("expected a number or \"inf\", got \"{t}\""))),
        }
    }
}

pub(crate) mod evidence;
mod legacy;
mod removal;
pub use removal::RemovalParams;
#[cfg(test)]
mod tests;
