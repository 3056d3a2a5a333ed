//! One module per subcommand: its arguments and the glue that calls the libraries.

pub mod converge;
pub mod generate;
pub mod localise;
pub mod map;
pub mod merge;
pub mod metrics;
pub mod recover;
pub mod render;
pub mod run;
pub mod simulate;
pub mod update;
pub mod validate;

use anyhow::Context;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use mapkeeper_grid::{Pose2, StagedDir};
use std::io::IsTerminal;
use std::path::Path;
use std::time::Instant;

/// Every parameter file of every command: `base` (a preset or the defaults), overridden key by
/// key by the TOML file if one is given, then validated once.
pub fn load_params<T, E>(base: T, file: Option<&Path>, validate: impl FnOnce(&T) -> Result<(), E>) -> anyhow::Result<T>
where
    T: serde::Serialize + serde::de::DeserializeOwned,
    E: std::fmt::Display,
{
    Ok(mapkeeper_harness::config::load_params(base, file, validate)?)
}

/// Starts writing the output folder `out` (a hidden staging folder renamed into place at the
/// end, see [`StagedDir`]), saying on stderr what an interrupted earlier run had left there and
/// was removed.
pub fn output_dir(out: &Path, force: bool) -> anyhow::Result<StagedDir> {
    let dir = StagedDir::create(out, force)?;
    if let Some(left) = dir.leftover() {
        eprintln!("mapkeeper: note: {left}");
    }
    Ok(dir)
}

/// Parses `x,y,yaw` (three finite numbers).
pub fn parse_pose(s: &str) -> Result<Pose2, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!("expected x,y,yaw (three comma-separated numbers), got '{s}'"));
    }
    let mut v = [0.0; 3];
    for (slot, p) in v.iter_mut().zip(&parts) {
        *slot = p.parse::<f64>().map_err(|e| format!("'{p}' is not a number: {e}"))?;
        if !slot.is_finite() {
            return Err(format!("'{p}' is not finite"));
        }
    }
    Ok(Pose2::new(v[0], v[1], v[2]))
}

/// A finite number ≥ 0 (a flag's value parser).
pub fn non_negative(s: &str) -> Result<f64, String> {
    let v: f64 = s.trim().parse().map_err(|e| format!("'{s}' is not a number: {e}"))?;
    if v.is_finite() && v >= 0.0 { Ok(v) } else { Err(format!("must be a finite number ≥ 0, got {s}")) }
}

/// A finite number > 0 (a flag's value parser).
pub fn positive(s: &str) -> Result<f64, String> {
    let v = non_negative(s).map_err(|_| format!("must be a finite number > 0, got {s}"))?;
    if v > 0.0 { Ok(v) } else { Err(format!("must be a finite number > 0, got {s}")) }
}

/// The wall clock the libraries get injected (they read none themselves).
pub struct Wall(pub Instant);

impl Wall {
    /// A clock starting now.
    pub fn start() -> Self {
        Wall(Instant::now())
    }
}

impl mapkeeper_harness::Clock for Wall {
    fn now_ns(&self) -> u64 {
        u64::try_from(self.0.elapsed().as_nanos()).unwrap_or(u64::MAX).max(1)
    }
}

/// A progress bar of `len` `unit`s on a terminal's stderr, hidden otherwise.
pub fn progress_bar(len: u64, unit: &str) -> ProgressBar {
    let bar = ProgressBar::new(len);
    if std::io::stderr().is_terminal() {
        bar.set_style(
            ProgressStyle::with_template(&format!(
                "{{elapsed_precise}} [{{bar:40}}] {{pos}}/{{len}} {unit}, eta {{eta}}"
            ))
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
    } else {
        bar.set_draw_target(ProgressDrawTarget::hidden());
    }
    bar
}

/// A rayon pool of `jobs` threads (default: all cores).
pub fn thread_pool(jobs: Option<usize>) -> anyhow::Result<rayon::ThreadPool> {
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(j) = jobs {
        builder = builder.num_threads(j.max(1));
    }
    builder.build().context("thread pool")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_poses() {
        assert_eq!(parse_pose("1, -2.5,0.3"), Ok(Pose2::new(1.0, -2.5, 0.3)));
        assert!(parse_pose("1,2").is_err());
        assert!(parse_pose("1,x,3").is_err());
        assert!(parse_pose("1,NaN,3").is_err());
    }

    #[test]
    fn number_flags_refuse_nan_negative_and_infinite() {
        assert_eq!(non_negative("0"), Ok(0.0));
        assert_eq!(positive("0.5"), Ok(0.5));
        for bad in ["NaN", "-1", "inf", "x", ""] {
            assert!(non_negative(bad).is_err() && positive(bad).is_err(), "{bad}");
        }
        assert!(positive("0").is_err());
    }
}
