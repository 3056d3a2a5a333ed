//! One module per subcommand: its arguments and the glue that calls the libraries.

pub mod bench;
pub mod check;
pub mod converge;
pub mod convert;
pub mod experiment;
pub mod generate;
pub mod import_map;
pub mod localise;
pub mod log_input;
pub mod map;
pub mod merge;
pub mod metrics;
pub mod poses;
pub mod real_data;
pub mod realism;
pub mod recover;
pub mod render;
pub mod run;
pub mod sensor;
pub mod simulate;
pub mod sweep_progress;
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
        errln!("mapkeeper: note: {left}");
    }
    Ok(dir)
}

/// Largest |x| and |y| of a pose flag, metres: 1000 km, the side of the largest grid
/// ([`mapkeeper_grid::MAX_SIDE`] = 2^20 cells) at 1 m per cell.
pub const MAX_POSE_XY_M: f64 = 1e6;
/// Largest |yaw| of a pose flag, radians: a turn (2π) rounded up; a larger value is most
/// likely degrees.
pub const MAX_POSE_YAW_RAD: f64 = 6.3;
/// Largest `--jobs`: far more threads than any machine here has cores (each thread is an OS
/// thread; the work is split by seed or run, so more threads than jobs gain nothing).
pub const MAX_JOBS: usize = 1024;
/// Largest `--worlds` of `validate` and `generate`: 100 × the paper's hundred worlds (hours of
/// work per seed, and a ground-truth map per world on disk); larger values only hang.
pub const MAX_WORLDS: usize = 10_000;
/// Largest number of seeds of `validate --seeds` and `converge --seeds` (each seed is a full
/// run; the job list is held in memory).
pub const MAX_SEEDS: usize = 100_000;
/// The range of map resolutions, metres per cell: 5 mm is below the simulated lidars' 1 cm
/// range quantisation and 3 cm noise (the warehouse map then has ~13 M cells), 10 m leaves a
/// handful of cells per map.
pub const RESOLUTION_M: (f64, f64) = (0.005, 10.0);
/// Largest route length of `--route-length`, metres: 10 km, far more than the 72 m default
/// tour (a longer value drives the whole route).
pub const MAX_ROUTE_LENGTH_M: f64 = 10_000.0;
/// Largest start error, metres: larger than the warehouse (15 m × 22 m) many times over.
pub const MAX_START_ERROR_M: f64 = 100.0;

/// How a refused value is shown after "got".
fn shown(s: &str) -> String {
    if s.is_empty() { "an empty value".to_string() } else { s.to_string() }
}

/// A bound with its unit (`"m"`, `"s"` or none).
fn with_unit(v: f64, unit: &str) -> String {
    if unit.is_empty() { v.to_string() } else { format!("{v} {unit}") }
}

/// A value parser for a whole number in `lo..=hi` (counts: worlds, trials, jobs, …): refuses
/// signs, fractions, NaN, empty and out-of-range values with a message stating the range.
pub fn count_in(lo: usize, hi: usize) -> impl Fn(&str) -> Result<usize, String> + Clone + Send + Sync + 'static {
    move |s: &str| match s.trim().parse::<usize>() {
        Ok(v) if (lo..=hi).contains(&v) => Ok(v),
        _ => Err(format!("must be a whole number from {lo} to {hi}, got {}", shown(s))),
    }
}

/// A seed: any whole number from 0 to 2^64 − 1 (every seed is a valid stream).
pub fn seed(s: &str) -> Result<u64, String> {
    s.trim().parse::<u64>().map_err(|_| format!("must be a whole number from 0 to {}, got {}", u64::MAX, shown(s)))
}

/// A value parser for a finite number in `[lo, hi]` (`unit` is shown with the bounds).
pub fn real_in(lo: f64, hi: f64, unit: &'static str) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync {
    move |s: &str| match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && (lo..=hi).contains(&v) => Ok(v),
        _ => Err(format!(
            "must be a finite number from {} to {}, got {}",
            with_unit(lo, unit),
            with_unit(hi, unit),
            shown(s)
        )),
    }
}

/// A value parser for a finite number in `(0, hi]` (`unit` is shown with the bound).
pub fn positive_up_to(hi: f64, unit: &'static str) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync {
    move |s: &str| match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v <= hi => Ok(v),
        _ => Err(format!("must be a finite number > 0 and ≤ {}, got {}", with_unit(hi, unit), shown(s))),
    }
}

/// A map resolution in [`RESOLUTION_M`], metres per cell.
pub fn resolution(s: &str) -> Result<f64, String> {
    real_in(RESOLUTION_M.0, RESOLUTION_M.1, "m")(s)
}

/// `--jobs`: 1 to [`MAX_JOBS`] threads (leave the flag out for all cores).
pub fn jobs(s: &str) -> Result<usize, String> {
    count_in(1, MAX_JOBS)(s).map_err(|e| format!("{e}; leave --jobs out for all cores"))
}

/// `--route-length`: (0, [`MAX_ROUTE_LENGTH_M`]] metres.
pub fn route_length(s: &str) -> Result<f64, String> {
    positive_up_to(MAX_ROUTE_LENGTH_M, "m")(s)
}

/// Parses `x,y,yaw`: three finite numbers, |x|, |y| ≤ [`MAX_POSE_XY_M`] metres and |yaw| ≤
/// [`MAX_POSE_YAW_RAD`] radians.
pub fn parse_pose(s: &str) -> Result<Pose2, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!("expected x,y,yaw (three comma-separated numbers), got {}", shown(s)));
    }
    let mut v = [0.0; 3];
    let limits = [("x", MAX_POSE_XY_M, "m"), ("y", MAX_POSE_XY_M, "m"), ("yaw", MAX_POSE_YAW_RAD, "rad")];
    for ((slot, p), (name, max, unit)) in v.iter_mut().zip(&parts).zip(limits) {
        *slot = real_in(-max, max, unit)(p).map_err(|e| format!("{name} {e}"))?;
    }
    Ok(Pose2::new(v[0], v[1], v[2]))
}

/// The default output folder of a command: `results/<stem>-NNN` with the first three-digit
/// counter from 001 whose folder does not exist yet.
pub fn numbered_out(stem: &str) -> std::path::PathBuf {
    (1..)
        .map(|k| std::path::PathBuf::from(format!("results/{stem}-{k:03}")))
        .find(|p| !p.exists())
        .unwrap_or_else(|| std::path::PathBuf::from(format!("results/{stem}")))
}

/// `--world` and `--route` of `validate`, `generate`, `recover`, `run` and the experiments: the world (an
/// embedded world's name, `warehouse` or `lab`, or a world file) with its scenario resolved
/// (storage areas and route from the file, derived or planned when absent; the route file
/// overrides the world's route), and the name it goes by in the outputs. `None` when neither
/// flag is given: the commands keep their defaults (the embedded warehouse, unchanged).
/// With `need_areas` (the commands that generate worlds), a world whose storage areas can be
/// neither read nor derived is refused.
pub fn load_site(
    world: Option<&Path>,
    route: Option<&Path>,
    need_areas: bool,
) -> anyhow::Result<Option<(String, mapkeeper_scenario::Site)>> {
    if world.is_none() && route.is_none() {
        return Ok(None);
    }
    let world_arg = world.unwrap_or(Path::new("warehouse"));
    let w = mapkeeper_sim::World::named_or_load(world_arg).context("--world")?;
    let name = world_arg.display().to_string();
    let origin = match world_arg.to_str() {
        Some(n) if mapkeeper_sim::EMBEDDED_WORLDS.contains(&n) => format!("world {n} (embedded)"),
        _ => name.clone(),
    };
    let route = route.map(|r| load_route(r, &w)).transpose()?;
    // Commands that do not generate worlds only drive the route (no exploration in W_1).
    let params = mapkeeper_scenario::SiteParams { check_exploration: need_areas, ..Default::default() };
    let site = mapkeeper_scenario::Site::resolve(&w, route.as_ref(), &origin, &params).context("--world")?;
    if need_areas {
        site.require_storage(&origin, &params).context("--world")?;
    }
    if site.planned_route {
        errln!(
            "mapkeeper: note: {origin} has no route: planned a {:.1} m patrol ({} waypoints)",
            site.route.length_m(),
            site.route.waypoints.len()
        );
    }
    if site.derived_areas {
        errln!("mapkeeper: note: {origin} has no storage areas: derived {}", site.storage.len());
    }
    Ok(Some((name, site)))
}

/// `--route FILE`, loaded and checked against `world` by the one rule of every command that
/// takes it (`validate`, `generate`, `recover`, `run`, `simulate`): every waypoint inside the
/// world and every leg, from the robot's start on, clear of its walls, columns, racks and items
/// by the route clearance (`SiteParams::route_clearance_m`). A refusal names `--route`, the file,
/// the waypoint and what is in the way.
pub fn load_route(path: &Path, world: &mapkeeper_sim::World) -> anyhow::Result<mapkeeper_sim::Route> {
    let route = mapkeeper_sim::Route::load(path).context("--route")?;
    let clearance = mapkeeper_scenario::SiteParams::default().route_clearance_m;
    mapkeeper_scenario::worlds::site::check_route(world, &route, &path.display().to_string(), "waypoints", clearance)
        .map_err(|e| match e {
            // The message names the file and the waypoint; the generator's prefix says nothing here.
            mapkeeper_scenario::WorldsError::Generator(m) => anyhow::anyhow!(m),
            other => other.into(),
        })
        .context("--route")?;
    Ok(route)
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

/// The progress of a long command: a bar on a terminal, and on any stderr (CI logs too) a line
/// at the first unit done and at each tenth, with the time left at this run's own rate so far
/// (its units are alike: trials, runs, drives; `validate`, whose worlds are not, has its own,
/// `sweep_progress`).
pub struct Progress {
    bar: ProgressBar,
    what: String,
    unit: String,
    total: u64,
    start: std::time::Instant,
    /// Units done, and the next tenth at which a line is printed.
    state: std::sync::Mutex<(u64, u64)>,
}

impl Progress {
    /// One unit done.
    pub fn inc(&self, n: u64) {
        self.bar.inc(n);
        let mut s = match self.state.lock() {
            Ok(s) => s,
            Err(p) => p.into_inner(),
        };
        let first = s.0 == 0;
        s.0 += n;
        let (done, total) = (s.0, self.total.max(1));
        if (first || done * 10 >= s.1 * total) && done < total {
            while done * 10 >= s.1 * total {
                s.1 += 1;
            }
            let elapsed = self.start.elapsed().as_secs_f64();
            let left = elapsed / done as f64 * (total - done) as f64;
            let line = format!(
                "{}: {done}/{total} {} after {}; about {} left (at this run's rate so far)",
                self.what,
                self.unit,
                mapkeeper_scenario::experiments::eta::human_duration(elapsed),
                mapkeeper_scenario::experiments::eta::human_duration(left)
            );
            self.bar.suspend(|| errln!("{line}"));
        }
    }

    /// Removes the bar.
    pub fn finish_and_clear(&self) {
        self.bar.finish_and_clear();
    }
}

/// The progress of `what` (the command's name) over `len` `unit`s, writing `out` (see
/// [`Progress`]); prints first what it runs and where it writes.
pub fn progress_bar(what: &str, len: u64, unit: &str, out: &Path) -> Progress {
    errln!(
        "{what}: {len} {unit} to run, on {} thread(s); writing {}; Ctrl-C stops it as a kill does (nothing left that looks complete)",
        rayon::current_num_threads(),
        out.display()
    );
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
    Progress {
        bar,
        what: what.to_string(),
        unit: unit.to_string(),
        total: len,
        start: std::time::Instant::now(),
        state: std::sync::Mutex::new((0, 1)),
    }
}

/// A rayon pool of `jobs` threads (default: all cores; `--jobs` is bounded by [`jobs`]).
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
    fn poses_are_bounded() {
        assert!(parse_pose("1e6,-1e6,6.3").is_ok());
        for bad in ["1e7,0,0", "0,0,7", "0,,0", "0,0,0,0", "", "inf,0,0"] {
            assert!(parse_pose(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn counts_are_whole_numbers_in_range() {
        let worlds = count_in(2, MAX_WORLDS);
        assert_eq!(worlds("2"), Ok(2));
        assert_eq!(worlds(" 10000 "), Ok(10_000));
        for bad in ["1", "10001", "-1", "2.5", "1e3", "NaN", "", "abc", "18446744073709551616"] {
            let e = worlds(bad).unwrap_err();
            assert!(e.contains("from 2 to 10000"), "{bad}: {e}");
        }
        assert_eq!(seed("0"), Ok(0));
        assert_eq!(seed("18446744073709551615"), Ok(u64::MAX));
        for bad in ["-1", "18446744073709551616", "1e3", "nan", ""] {
            assert!(seed(bad).is_err(), "{bad}");
        }
        assert!(jobs("0").unwrap_err().contains("leave --jobs out"));
    }

    #[test]
    fn reals_refuse_nan_infinite_and_out_of_range() {
        assert_eq!(resolution("0.05"), Ok(0.05));
        assert_eq!(real_in(0.0, 1.0, "")("0"), Ok(0.0));
        assert_eq!(positive_up_to(10.0, "s")("10"), Ok(10.0));
        for bad in ["NaN", "nan", "inf", "-inf", "-1", "0", "1e308", "abc", "", "1,2", "0.001", "11"] {
            assert!(resolution(bad).is_err(), "{bad}");
        }
        assert_eq!(positive_up_to(10.0, "s")("0").unwrap_err(), "must be a finite number > 0 and ≤ 10 s, got 0");
        assert_eq!(real_in(0.0, 1.0, "")("").unwrap_err(), "must be a finite number from 0 to 1, got an empty value");
    }
}
