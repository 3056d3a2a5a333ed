//! The summary of an `experiment kidnap-robot` run (`summary.json` `kidnap_robot`): rates,
//! times, damage and the outcome by turn, displacement and world age.

use super::{KidnapMap, RobotKidnapTrial};
use crate::experiments::scores::Scores;
use crate::stats::{frac, mean, median, percentile};
use serde::{Deserialize, Serialize};

/// `summary.json` `kidnap_robot`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KidnapRobotSummary {
    /// Updater preset.
    pub preset: String,
    /// The map the robot localised on.
    #[serde(default = "super::first_world_map")]
    pub map: KidnapMap,
    /// Trials drawn.
    pub trials: usize,
    /// Trials in which the robot was moved (the rates are over these).
    pub applied: usize,
    /// Recovered within the window with a pose from pose updating.
    pub recovered_rate_pose_updating: f64,
    /// Recovered within the window by the filter alone.
    pub recovered_rate_filter: f64,
    /// Not recovered within the window.
    pub failed_rate: f64,
    /// Said Lost after the kidnap.
    pub detected_rate: f64,
    /// Reference runs (no kidnap) with any Lost.
    pub false_lost_rate: f64,
    /// Reference runs with a Lost while the localiser was right by the success criterion.
    #[serde(default)]
    pub false_lost_right_pose_rate: f64,
    /// Reference runs with a Lost while the localiser was well localised (within 0.05 m and
    /// 2° by default): the false Lost of a well-localised robot, the false alarm proper.
    #[serde(default)]
    pub false_lost_well_localised_rate: f64,
    /// Lost verdicts among all the checked steps of the runs without kidnap taken while the
    /// localiser was well localised (a per-step false-alarm rate, as `check-detection`'s);
    /// `None` without such a step.
    #[serde(default)]
    pub false_lost_well_localised_step_rate: Option<f64>,
    /// Share of the checked steps of the runs without kidnap taken while the localiser was
    /// well localised.
    #[serde(default)]
    pub reference_well_localised_share: Option<f64>,
    /// Median time from the kidnap to recovery, seconds.
    pub median_recovery_s: Option<f64>,
    /// Mean reference − kidnapped score against G_k, points (> 0: damage).
    pub map_damage: Scores,
    /// Largest OPDF damage of a trial, points.
    pub map_damage_opdf_max: f64,
    /// Poses from pose updating, and the wrong ones.
    pub pose_recoveries: usize,
    /// Wrong poses accepted.
    pub wrong_pose_recoveries: usize,
    /// Recovered with a pose from the global search (part of `recovered_rate_pose_updating`).
    #[serde(default)]
    pub recovered_rate_global_search: f64,
    /// Trials in which pose updating handed over at least one wrong pose.
    #[serde(default)]
    pub wrong_recovery_rate: f64,
    /// 90th percentile of the time from the kidnap to recovery, seconds.
    #[serde(default)]
    pub p90_recovery_s: Option<f64>,
    /// Trials in which pose updating handed over a right pose (whatever the localiser did
    /// with it afterwards).
    #[serde(default)]
    pub pose_found_rate: f64,
    /// …within 5 s of the robot stopping at the first Lost.
    #[serde(default)]
    pub pose_found_5s_rate: f64,
    /// Median and 90th percentile of the first Lost to the first right pose, seconds.
    #[serde(default)]
    pub median_pose_found_s: Option<f64>,
    /// See `median_pose_found_s`.
    #[serde(default)]
    pub p90_pose_found_s: Option<f64>,
    /// Reference runs (no kidnap) whose localiser ends farther off than the success criterion:
    /// a kidnapped run there cannot count as recovered whatever pose updating does.
    #[serde(default)]
    pub reference_off_rate: f64,
    /// Recovered (pose updating or filter) among the trials whose reference run ends under
    /// 0.2 m: recovery where the localiser can hold a right pose in that world at all.
    #[serde(default)]
    pub recovered_rate_reference_held: f64,
    /// Those trials.
    #[serde(default)]
    pub trials_reference_held: usize,
    /// Trials whose run without kidnap kept its localiser under the success criterion from the
    /// kidnap's time to the end: the localiser alone over that stretch (no handover, no hold).
    #[serde(default)]
    pub reference_held_rate: f64,
    /// Trials (robot moved) in which pose updating never handed over a right pose.
    #[serde(default)]
    pub never_found: usize,
    /// …of them with at least one attempt refused as ambiguous (two places fitted alike); the
    /// others' scans fitted no place well enough.
    #[serde(default)]
    pub never_found_ambiguous: usize,
    /// Right poses pose updating handed over after the kidnaps.
    #[serde(default)]
    pub handovers_right: usize,
    /// The share of them held: the localiser stayed under the success criterion from the
    /// handover to the end of the run. `None` without a right handover.
    #[serde(default)]
    pub handover_held_rate: Option<f64>,
    /// Recovered / wrong / not, by the turn of the kidnap (≤ 45°, 45-90°, > 90°).
    #[serde(default)]
    pub by_turn: Vec<KidnapBin>,
    /// …by the displacement (≤ 1.5 m, > 1.5 m).
    #[serde(default)]
    pub by_displacement: Vec<KidnapBin>,
    /// …by the age of the world (W_k, k in two halves of the drawn range).
    #[serde(default)]
    pub by_world: Vec<KidnapBin>,
}

/// The outcome of the trials of one bin (robot moved only).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KidnapBin {
    /// What the bin holds, e.g. `turn > 90°`.
    pub label: String,
    /// Trials in the bin.
    pub trials: usize,
    /// Recovered within the window (pose updating or filter).
    pub recovered: usize,
    /// Trials with a wrong pose from pose updating.
    pub wrong: usize,
    /// Trials with a right pose handed over within 5 s of the robot stopping.
    #[serde(default)]
    pub handed_over_5s: usize,
    /// Right handovers in the bin's trials, and those held to the end.
    #[serde(default)]
    pub handovers_right: usize,
    /// See `handovers_right`.
    #[serde(default)]
    pub handovers_held: usize,
}

fn bins(a: &[&RobotKidnapTrial], edges: &[(String, f64, f64)], key: fn(&RobotKidnapTrial) -> f64) -> Vec<KidnapBin> {
    edges
        .iter()
        .map(|(label, lo, hi)| {
            let t: Vec<&&RobotKidnapTrial> = a.iter().filter(|t| key(t) > *lo && key(t) <= *hi).collect();
            KidnapBin {
                label: label.clone(),
                trials: t.len(),
                recovered: t.iter().filter(|t| t.recovered_pose_updating || t.recovered_filter).count(),
                wrong: t.iter().filter(|t| t.wrong_pose_recoveries > 0).count(),
                handed_over_5s: t.iter().filter(|t| t.pose_found_s.is_some_and(|s| s <= 5.0)).count(),
                handovers_right: t.iter().map(|t| t.handovers_right).sum(),
                handovers_held: t.iter().map(|t| t.handovers_held).sum(),
            }
        })
        .collect()
}

/// `a / b`, `None` when `b` is 0.
fn ratio(a: u64, b: u64) -> Option<f64> {
    (b > 0).then(|| a as f64 / b as f64)
}

/// Summary of the trials.
pub fn summarise_robot_kidnap(preset: &str, map: KidnapMap, trials: &[RobotKidnapTrial]) -> KidnapRobotSummary {
    let a: Vec<&RobotKidnapTrial> = trials.iter().filter(|t| t.applied).collect();
    let dmg = |f: fn(&Scores) -> f64| mean(a.iter().map(|t| f(&t.reference_scores) - f(&t.kidnap_scores)));
    let held: Vec<&&RobotKidnapTrial> =
        a.iter().filter(|t| t.reference_final_error_m.is_some_and(|e| e < 0.2)).collect();
    KidnapRobotSummary {
        preset: preset.to_string(),
        map,
        trials: trials.len(),
        applied: a.len(),
        recovered_rate_pose_updating: frac(a.iter().map(|t| t.recovered_pose_updating)),
        recovered_rate_filter: frac(a.iter().map(|t| t.recovered_filter)),
        failed_rate: frac(a.iter().map(|t| !t.recovered_pose_updating && !t.recovered_filter)),
        detected_rate: frac(a.iter().map(|t| t.detected)),
        false_lost_rate: frac(trials.iter().map(|t| t.reference_lost > 0)),
        false_lost_right_pose_rate: frac(trials.iter().map(|t| t.reference_lost_right_pose > 0)),
        false_lost_well_localised_rate: frac(trials.iter().map(|t| t.reference_lost_well_localised > 0)),
        false_lost_well_localised_step_rate: ratio(
            trials.iter().map(|t| t.reference_lost_well_localised).sum(),
            trials.iter().map(|t| t.reference_steps_well_localised).sum(),
        ),
        reference_well_localised_share: ratio(
            trials.iter().map(|t| t.reference_steps_well_localised).sum(),
            trials.iter().map(|t| t.reference_steps).sum(),
        ),
        median_recovery_s: median(
            a.iter().filter(|t| t.recovered_pose_updating || t.recovered_filter).filter_map(|t| t.recovery_s).collect(),
        ),
        map_damage: Scores { cc: dmg(|s| s.cc), ms: dmg(|s| s.ms), opdf: dmg(|s| s.opdf) },
        map_damage_opdf_max: a.iter().map(|t| t.reference_scores.opdf - t.kidnap_scores.opdf).fold(0.0, f64::max),
        pose_recoveries: a.iter().map(|t| t.pose_recoveries).sum(),
        wrong_pose_recoveries: a.iter().map(|t| t.wrong_pose_recoveries).sum(),
        recovered_rate_global_search: frac(a.iter().map(|t| t.recovered_global_search)),
        pose_found_rate: frac(a.iter().map(|t| t.pose_found_s.is_some())),
        pose_found_5s_rate: frac(a.iter().map(|t| t.pose_found_s.is_some_and(|s| s <= 5.0))),
        median_pose_found_s: median(a.iter().filter_map(|t| t.pose_found_s).collect()),
        p90_pose_found_s: percentile(a.iter().filter_map(|t| t.pose_found_s).collect(), 0.9),
        reference_off_rate: frac(a.iter().map(|t| t.reference_final_error_m.is_some_and(|e| e >= 0.2))),
        recovered_rate_reference_held: frac(held.iter().map(|t| t.recovered_pose_updating || t.recovered_filter)),
        trials_reference_held: held.len(),
        wrong_recovery_rate: frac(a.iter().map(|t| t.wrong_pose_recoveries > 0)),
        p90_recovery_s: percentile(
            a.iter().filter(|t| t.recovered_pose_updating || t.recovered_filter).filter_map(|t| t.recovery_s).collect(),
            0.9,
        ),
        never_found: a.iter().filter(|t| t.pose_found_s.is_none()).count(),
        never_found_ambiguous: a.iter().filter(|t| t.pose_found_s.is_none() && t.ambiguous_attempts > 0).count(),
        reference_held_rate: frac(a.iter().map(|t| t.reference_held == Some(true))),
        handovers_right: a.iter().map(|t| t.handovers_right).sum(),
        handover_held_rate: ratio(
            a.iter().map(|t| t.handovers_held as u64).sum(),
            a.iter().map(|t| t.handovers_right as u64).sum(),
        ),
        by_turn: bins(
            &a,
            &[
                ("turn ≤ 45°".into(), -1.0, 45.0),
                ("turn 45-90°".into(), 45.0, 90.0),
                ("turn > 90°".into(), 90.0, 360.0),
            ],
            |t| t.draw.yaw_rad.abs().to_degrees(),
        ),
        by_displacement: bins(
            &a,
            &[("moved ≤ 1.5 m".into(), -1.0, 1.5), ("moved > 1.5 m".into(), 1.5, f64::INFINITY)],
            |t| t.applied_displacement_m.unwrap_or(0.0),
        ),
        by_world: world_bins(&a),
    }
}

/// Two halves of the worlds the trials drew from.
fn world_bins(a: &[&RobotKidnapTrial]) -> Vec<KidnapBin> {
    let (lo, hi) = a.iter().fold((usize::MAX, 0), |(lo, hi), t| (lo.min(t.draw.world), hi.max(t.draw.world)));
    if a.is_empty() {
        return Vec::new();
    }
    let mid = lo + (hi - lo) / 2;
    let edges = [
        (format!("W_{lo}-W_{mid}"), lo as f64 - 0.5, mid as f64 + 0.5),
        (format!("W_{}-W_{hi}", mid + 1), mid as f64 + 0.5, hi as f64 + 0.5),
    ];
    bins(a, &edges, |t| t.draw.world as f64)
}
