//! What `mapkeeper update` takes from its flags: the updater's parameters, the synchronisation
//! window and the pose the updater is given.

use super::Args;
use crate::cmd::load_params;
use anyhow::Context;
use mapkeeper_harness::jobs::update::PoseInput;
use mapkeeper_harness::{OdometryAt, ReplayOptions};
use mapkeeper_sensor::read_tum;
use mapkeeper_updater::{PRESET_NAMES, UpdaterParams};
use std::path::Path;

/// The preset, overridden by the TOML file if any, validated.
pub fn load_updater_params(preset: &str, file: Option<&Path>) -> anyhow::Result<UpdaterParams> {
    let params =
        UpdaterParams::preset(preset).with_context(|| format!("--preset (known: {})", PRESET_NAMES.join(", ")))?;
    load_params(params, file, UpdaterParams::validate).with_context(|| format!("preset {preset}"))
}

/// Largest `--sync-window-s`, seconds.
pub(super) const MAX_SYNC_WINDOW_S: f64 = 10.0;

/// The synchronisation window in nanoseconds, checked.
pub(super) fn sync_window_ns(seconds: f64) -> anyhow::Result<u64> {
    anyhow::ensure!(
        seconds.is_finite() && (0.0..=MAX_SYNC_WINDOW_S).contains(&seconds),
        "--sync-window-s: must be a finite number from 0 s to {MAX_SYNC_WINDOW_S} s, got {seconds}"
    );
    Ok((seconds * 1e9).round() as u64)
}

/// The pose input of `--poses`, `--true-poses`, `--localise` (the localiser resolved for an
/// imported log or not) or, without any, the aligned odometry.
pub(super) fn pose_input(args: &Args, imported: bool) -> anyhow::Result<PoseInput> {
    Ok(match (&args.poses, args.true_poses) {
        (Some(p), _) => {
            let track = read_tum(p)?;
            anyhow::ensure!(!track.is_empty(), "{}: no poses", p.display());
            PoseInput::Track(track)
        }
        (None, true) => PoseInput::LoggedTruth,
        (None, false) if args.localise => {
            let localiser = crate::cmd::log_input::resolve_localiser(&args.localiser, imported);
            let preset = mapkeeper_localiser::FilterParams::preset(localiser).context("--localiser")?;
            errln!("localiser: {localiser}");
            let params =
                load_params(preset, args.localiser_params.as_deref(), mapkeeper_localiser::FilterParams::validate)?;
            PoseInput::Localise { params: Box::new(params), seed: args.seed, init: None }
        }
        (None, false) => PoseInput::AlignedOdometry,
    })
}

/// How the log is replayed: odometry interpolated at each step, scans within `--sync-window-s`
/// of a step's first one joined, deskewed unless `--no-deskew`.
pub(super) fn replay_options(args: &Args) -> anyhow::Result<ReplayOptions> {
    Ok(ReplayOptions {
        odometry_at: OdometryAt::Interpolated,
        sync_window_ns: sync_window_ns(args.sync_window_s)?,
        deskew: !args.no_deskew,
        ..ReplayOptions::default()
    })
}
