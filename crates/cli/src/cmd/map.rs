//! `mapkeeper map`: an occupancy map from a sensor log at the logged true poses, with the
//! log-odds mapper of `mapkeeper_grid::mapper`.

use super::metrics::load;
use anyhow::Context;
use mapkeeper_grid::mapper::{LogOddsMapper, MapperParams};
use mapkeeper_grid::{CellState, GridGeometry, Point2, Pose2, angle_diff, map_io, wrap_angle};
use mapkeeper_sensor::{BeamValidity, LaserScan, SensorLog, TruePose};
use std::path::{Path, PathBuf};

/// Arguments of `mapkeeper map`.
#[derive(clap::Args, Debug)]
#[command(
    long_about = "Build an occupancy map from a sensor log at the logged true poses (log-odds mapper).\n\n\
Reads DIR/log.jsonl (or --log FILE directly). Each scan is placed at the true robot pose at its \
timestamp: linearly interpolated between the truth records around it (yaw along the shorter arc) \
when they are at most 2 × --max-pose-gap-s apart, else the nearest truth record if it is within \
--max-pose-gap-s, else the scan is skipped. Beams start at the lidar (the scan's lidar_in_robot \
extrinsics). A valid return clears the cells before it and marks its cell occupied; a beam with \
no return (+inf, or a reading at or beyond range_max) clears the cells up to \
min(range_max, --no-return-clear-m); NaN, -inf and readings below range_min are ignored.\n\n\
The map covers every lidar position and beam end point plus --margin-m, on a grid of \
--resolution aligned to multiples of the resolution, unless --like MAP.yaml gives the geometry \
(size, resolution, origin) to reuse. Mapper parameters (l_occ, l_free, l_min, l_max, \
occ_threshold, free_threshold, prior_l) can be overridden by a TOML file. The result is written \
as ROS map_server YAML + trinary PGM.",
    after_help = "Examples:\n  mapkeeper map --log runs/explore --out maps/m1.yaml\n  \
mapkeeper map --log runs/explore --out m1.yaml --like worlds/g1.yaml --params mapper.toml"
)]
pub struct Args {
    /// Folder holding log.jsonl (or the log file itself).
    #[arg(long, value_name = "DIR")]
    pub log: PathBuf,
    /// Output map (ROS map_server YAML; the PGM is written beside it).
    #[arg(long, value_name = "MAP.yaml")]
    pub out: PathBuf,
    /// Cell side, metres (ignored with --like).
    #[arg(long, value_name = "R", default_value_t = 0.05)]
    pub resolution: f64,
    /// Reuse this map's geometry (size, resolution, origin) instead of fitting the observed area.
    #[arg(long, value_name = "MAP.yaml")]
    pub like: Option<PathBuf>,
    /// Mapper parameters (TOML; any subset of the fields of MapperParams).
    #[arg(long, value_name = "FILE.toml")]
    pub params: Option<PathBuf>,
    /// Beams with no return clear free space up to this range, metres (0 disables).
    #[arg(long, value_name = "M", default_value_t = 8.0)]
    pub no_return_clear_m: f64,
    /// Border added around the observed area when fitting the geometry, metres.
    #[arg(long, value_name = "M", default_value_t = 1.0)]
    pub margin_m: f64,
    /// Largest time from a scan to a usable true pose, seconds.
    #[arg(long, value_name = "S", default_value_t = 0.1)]
    pub max_pose_gap_s: f64,
}

/// The true robot pose at `stamp_ns` from truth records sorted by time (see the command help).
fn pose_at(truth: &[TruePose], stamp_ns: u64, max_gap_ns: u64) -> Option<Pose2> {
    let after = truth.partition_point(|p| p.stamp_ns < stamp_ns);
    let next = truth.get(after);
    if let Some(n) = next
        && n.stamp_ns == stamp_ns
    {
        return Some(n.pose_in_map);
    }
    let prev = after.checked_sub(1).and_then(|i| truth.get(i));
    match (prev, next) {
        (Some(p), Some(n)) if n.stamp_ns - p.stamp_ns <= max_gap_ns.saturating_mul(2) => {
            let s = (stamp_ns - p.stamp_ns) as f64 / (n.stamp_ns - p.stamp_ns) as f64;
            let (a, b) = (p.pose_in_map, n.pose_in_map);
            Some(Pose2::new(
                a.x + s * (b.x - a.x),
                a.y + s * (b.y - a.y),
                wrap_angle(a.yaw + s * angle_diff(b.yaw, a.yaw)),
            ))
        }
        _ => {
            let gap = |t: u64| t.abs_diff(stamp_ns);
            [prev, next]
                .into_iter()
                .flatten()
                .filter(|p| gap(p.stamp_ns) <= max_gap_ns)
                .min_by_key(|p| gap(p.stamp_ns))
                .map(|p| p.pose_in_map)
        }
    }
}

/// What one beam contributes.
enum Beam {
    /// A return at this map point.
    Hit(Point2),
    /// No return: clear up to this map point.
    Clear(Point2),
    /// Nothing.
    Ignore,
}

/// Classifies beam `i` of `scan` seen from `lidar_in_map`.
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

/// The log file named by `--log`.
fn log_file(path: &Path) -> PathBuf {
    if path.is_dir() { path.join("log.jsonl") } else { path.to_path_buf() }
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.no_return_clear_m.is_finite() && args.no_return_clear_m >= 0.0,
        "--no-return-clear-m must be a finite number >= 0, got {}",
        args.no_return_clear_m
    );
    anyhow::ensure!(
        args.margin_m.is_finite() && args.margin_m >= 0.0,
        "--margin-m must be a finite number >= 0, got {}",
        args.margin_m
    );
    anyhow::ensure!(
        args.max_pose_gap_s.is_finite() && args.max_pose_gap_s >= 0.0,
        "--max-pose-gap-s must be a finite number >= 0, got {}",
        args.max_pose_gap_s
    );
    let params = match &args.params {
        None => MapperParams::default(),
        Some(p) => {
            let text = std::fs::read_to_string(p).with_context(|| format!("cannot read {}", p.display()))?;
            let params: MapperParams = toml::from_str(&text).with_context(|| format!("{}", p.display()))?;
            params.validate().with_context(|| format!("{}", p.display()))?;
            params
        }
    };
    let log_path = log_file(&args.log);
    let log = SensorLog::read(&log_path)?;
    let truth: Vec<TruePose> = log.truth().copied().collect();
    anyhow::ensure!(!truth.is_empty(), "{}: no truth records, cannot map at true poses", log_path.display());
    let max_gap_ns = (args.max_pose_gap_s * 1e9) as u64;

    // Place every scan once; remember the lidar poses.
    let mut placed: Vec<(&LaserScan, Pose2)> = Vec::new();
    let mut skipped = 0usize;
    for scan in log.scans() {
        match pose_at(&truth, scan.stamp_ns, max_gap_ns) {
            Some(robot_in_map) => placed.push((scan, scan.lidar_in_map(&robot_in_map))),
            None => skipped += 1,
        }
    }
    anyhow::ensure!(
        !placed.is_empty(),
        "{}: no scan has a true pose within {} s",
        log_path.display(),
        args.max_pose_gap_s
    );

    let geometry = match &args.like {
        Some(like) => *load(like)?.geometry(),
        None => fit_geometry(&placed, args.no_return_clear_m, args.resolution, args.margin_m)?,
    };
    let mut mapper = LogOddsMapper::new(geometry, params)?;
    let (mut hits, mut clears, mut ignored) = (0usize, 0usize, 0usize);
    for (scan, lidar_in_map) in &placed {
        let origin = lidar_in_map.position();
        for i in 0..scan.len() {
            match beam(scan, lidar_in_map, i, args.no_return_clear_m) {
                Beam::Hit(p) => {
                    hits += 1;
                    mapper.integrate_ray(origin, p, true);
                }
                Beam::Clear(p) => {
                    clears += 1;
                    mapper.integrate_ray(origin, p, false);
                }
                Beam::Ignore => ignored += 1,
            }
        }
    }
    let grid = mapper.to_grid();
    map_io::save_map(&grid, &args.out)?;
    let g = grid.geometry();
    println!("scans: {} mapped, {} skipped (no true pose within {} s)", placed.len(), skipped, args.max_pose_gap_s);
    println!("beams: {hits} returns, {clears} no-return cleared, {ignored} ignored");
    println!(
        "map: {} × {} cells at {} m, origin ({}, {}, {}); {} occupied, {} free, {} unknown",
        g.width(),
        g.height(),
        g.resolution_m(),
        g.origin().x,
        g.origin().y,
        g.origin().yaw,
        grid.count(CellState::Occupied),
        grid.count(CellState::Free),
        grid.count(CellState::Unknown)
    );
    println!("wrote {}", args.out.display());
    Ok(())
}

/// The axis-aligned geometry covering every lidar position and beam end point, plus `margin_m`,
/// with its origin on a multiple of the resolution.
fn fit_geometry(
    placed: &[(&LaserScan, Pose2)],
    clear_m: f64,
    resolution_m: f64,
    margin_m: f64,
) -> anyhow::Result<GridGeometry> {
    anyhow::ensure!(
        resolution_m.is_finite() && resolution_m > 0.0,
        "--resolution must be a finite positive number of metres, got {resolution_m}"
    );
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    let mut add = |p: Point2| {
        lo = [lo[0].min(p.x), lo[1].min(p.y)];
        hi = [hi[0].max(p.x), hi[1].max(p.y)];
    };
    for (scan, lidar_in_map) in placed {
        add(lidar_in_map.position());
        for i in 0..scan.len() {
            match beam(scan, lidar_in_map, i, clear_m) {
                Beam::Hit(p) | Beam::Clear(p) => add(p),
                Beam::Ignore => {}
            }
        }
    }
    let x0 = ((lo[0] - margin_m) / resolution_m).floor() * resolution_m;
    let y0 = ((lo[1] - margin_m) / resolution_m).floor() * resolution_m;
    let w = ((hi[0] + margin_m - x0) / resolution_m).ceil().max(1.0);
    let h = ((hi[1] + margin_m - y0) / resolution_m).ceil().max(1.0);
    anyhow::ensure!(
        w.is_finite() && h.is_finite() && w < 1e9 && h < 1e9,
        "observed area is not finite or too large for resolution {resolution_m} m"
    );
    GridGeometry::new(w as usize, h as usize, resolution_m, Pose2::new(x0, y0, 0.0))
        .context("the observed area does not fit a grid; use a coarser --resolution or --like")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tp(t: u64, x: f64, yaw: f64) -> TruePose {
        TruePose { stamp_ns: t, pose_in_map: Pose2::new(x, 0.0, yaw) }
    }

    #[test]
    fn pose_interpolation_and_gaps() {
        let truth = [tp(100, 0.0, 3.0), tp(200, 1.0, -3.0), tp(1000, 5.0, 0.0)];
        // Exact.
        assert_eq!(pose_at(&truth, 200, 50), Some(truth[1].pose_in_map));
        // Interpolated; yaw across ±π along the short arc: 3.0 → −3.0 passes through π.
        let p = pose_at(&truth, 150, 50).unwrap();
        assert!((p.x - 0.5).abs() < 1e-12);
        let expected_yaw = wrap_angle(3.0 + 0.5 * angle_diff(-3.0, 3.0));
        assert!((p.yaw - expected_yaw).abs() < 1e-12 && p.yaw.abs() > 3.0, "{}", p.yaw);
        // Bracket too wide (800 ns > 2 × 50): nearest within 50, else none.
        assert_eq!(pose_at(&truth, 240, 50), Some(truth[1].pose_in_map));
        assert_eq!(pose_at(&truth, 600, 50), None);
        // Before the first / after the last record.
        assert_eq!(pose_at(&truth, 60, 50), Some(truth[0].pose_in_map));
        assert_eq!(pose_at(&truth, 10, 50), None);
        assert_eq!(pose_at(&truth, 1040, 50), Some(truth[2].pose_in_map));
    }
}
