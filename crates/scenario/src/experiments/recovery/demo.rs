//! The localisation-check demo: W_2 on M_1 with a 0.5 m start error; the updater should Suspend
//! until the localiser has converged, then Update.

use crate::experiments::ExperimentError;
use mapkeeper_closed_loop::controls::{Kidnap, TimelineSample, VerdictCounts};
use mapkeeper_closed_loop::setup::Setup;
use mapkeeper_updater::Verdict;
use serde::{Deserialize, Serialize};

use mapkeeper_closed_loop::setup::params::RecoveryParams;

/// Run-length segment of the verdict timeline.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct VerdictSegment {
    /// The verdict.
    pub verdict: Verdict,
    /// Time of its first step, seconds.
    pub from_s: f64,
    /// Time of its last step, seconds.
    pub to_s: f64,
    /// Processed steps.
    pub steps: u32,
}

/// The demo's outcome (`summary.json` `demo`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DemoSummary {
    /// i of W_i.
    pub world: usize,
    /// Initial error, metres.
    pub start_error_m: f64,
    /// Simulated time, seconds.
    pub duration_s: f64,
    /// Verdicts over the run.
    pub verdicts: VerdictCounts,
    /// First Suspend, seconds.
    pub first_suspend_s: Option<f64>,
    /// First Lost, seconds.
    pub first_lost_s: Option<f64>,
    /// First Update, seconds.
    pub first_update_s: Option<f64>,
    /// The chain localiser's position error at the first Update, metres.
    pub error_at_first_update_m: Option<f64>,
    /// Share of Update among the steps from the first Update on.
    pub update_share_after_first_update: f64,
    /// The chain localiser's error at the end, metres.
    pub final_error_m: Option<f64>,
    /// Cells changed in M_2 by the end.
    pub cells_changed: u64,
    /// The expected behaviour: updates suspended (Suspend before any Update), then resumed
    /// (Update, and at least 90 % of the steps after the first Update are Update).
    pub suspended_then_updated: bool,
    /// The verdicts as run-length segments.
    pub segments: Vec<VerdictSegment>,
}

fn segments(tl: &[TimelineSample]) -> Vec<VerdictSegment> {
    let mut out: Vec<VerdictSegment> = Vec::new();
    for s in tl {
        match out.last_mut() {
            Some(seg) if seg.verdict == s.verdict => {
                seg.to_s = s.t_s;
                seg.steps += 1;
            }
            _ => out.push(VerdictSegment { verdict: s.verdict, from_s: s.t_s, to_s: s.t_s, steps: 1 }),
        }
    }
    out
}

pub(super) fn counts(tl: &[TimelineSample]) -> VerdictCounts {
    let mut c = VerdictCounts::default();
    for s in tl {
        match s.verdict {
            Verdict::Update => c.update += 1,
            Verdict::Suspend => c.suspend += 1,
            Verdict::Lost => c.lost += 1,
        }
    }
    c
}

/// The demo: the summary and the full timeline of processed steps.
pub fn run_demo(
    setup: &Setup,
    params: &RecoveryParams,
    seed: u64,
) -> Result<(DemoSummary, Vec<TimelineSample>), ExperimentError> {
    let d = &params.demo;
    let map = setup.initial_map(params.initial_map);
    let drive = setup.drive(d.world, map, &params.tour, d.tour_position_m, params.tour.length_m())?;
    // To the right of the heading.
    let (s, c) = drive.start.yaw.sin_cos();
    let mut rp = params.runner.clone();
    rp.max_sim_time_s = d.duration_s;
    rp.record_timeline = true;
    rp.kidnap = Some(Kidnap {
        at_s: 0.0,
        dx_m: d.start_error_m * s,
        dy_m: -d.start_error_m * c,
        dyaw_rad: 0.0,
        sigma_xy_m: d.init_sigma_xy_m,
        sigma_yaw_rad: d.init_sigma_yaw_rad,
    });
    let run = drive.run(&rp, seed, "demo")?;
    let tl = run.timeline;
    let first = |v: Verdict| tl.iter().find(|s| s.verdict == v);
    let first_update = first(Verdict::Update);
    let after: Vec<&TimelineSample> =
        first_update.map(|f| tl.iter().filter(|s| s.t_s >= f.t_s).collect()).unwrap_or_default();
    let share = if after.is_empty() {
        0.0
    } else {
        after.iter().filter(|s| s.verdict == Verdict::Update).count() as f64 / after.len() as f64
    };
    let suspend_before = match (first(Verdict::Suspend), first_update) {
        (Some(s), Some(u)) => s.t_s < u.t_s,
        _ => false,
    };
    let summary = DemoSummary {
        world: d.world,
        start_error_m: d.start_error_m,
        duration_s: d.duration_s,
        verdicts: counts(&tl),
        first_suspend_s: first(Verdict::Suspend).map(|s| s.t_s),
        first_lost_s: first(Verdict::Lost).map(|s| s.t_s),
        first_update_s: first_update.map(|s| s.t_s),
        error_at_first_update_m: first_update.map(|s| s.error_m),
        update_share_after_first_update: share,
        final_error_m: run.kidnap.as_ref().and_then(|k| k.track.last()).map(|s| s.error_m),
        cells_changed: run.cells_changed,
        suspended_then_updated: suspend_before
            && tl.first().is_some_and(|s| s.verdict != Verdict::Update)
            && share >= 0.9,
        segments: segments(&tl),
    };
    Ok((summary, tl))
}
