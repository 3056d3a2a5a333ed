//! `mapkeeper map`: an occupancy map from a sensor log at the logged true poses, with the
//! log-odds mapper of `mapkeeper_grid::mapper`.

use super::metrics::load;
use super::{load_params, real_in};
use anyhow::Context;
use mapkeeper_grid::mapper::MapperParams;
use mapkeeper_grid::{CellState, map_io};
use mapkeeper_harness::jobs::map::{MapLogParams, map_log};
use mapkeeper_harness::{LogSource, ReplayOptions};
use std::path::PathBuf;

/// Arguments of `mapkeeper map`.
#[derive(clap::Args, Debug)]
#[command(
    long_about = "Build an occupancy map from a sensor log at the logged true poses (log-odds mapper).\n\n\
Reads --log (a folder holding log.jsonl, a .jsonl file, a ROS 2 MCAP bag, a ROS 1 bag or a CARMEN \
log with reference poses; docs/real-data.md). Each scan is placed at the true robot pose at its \
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
    /// The recorded log and how to read it.
    #[command(flatten)]
    pub input: super::log_input::LogInput,
    /// Output map (ROS map_server YAML; the PGM is written beside it).
    #[arg(long, value_name = "MAP.yaml")]
    pub out: PathBuf,
    /// Cell side, metres, 0.005 to 10 (ignored with --like).
    #[arg(long, value_name = "R", default_value_t = 0.05, value_parser = super::resolution, allow_hyphen_values = true)]
    pub resolution: f64,
    /// Reuse this map's geometry (size, resolution, origin) instead of fitting the observed area.
    #[arg(long, value_name = "MAP.yaml")]
    pub like: Option<PathBuf>,
    /// Mapper parameters (TOML; any subset of the fields of MapperParams).
    #[arg(long, value_name = "FILE.toml")]
    pub params: Option<PathBuf>,
    /// Beams with no return clear free space up to this range, metres, 0 (disables) to 1000
    /// (no lidar reaches further; the lidar's range_max caps it anyway).
    #[arg(long, value_name = "M", default_value_t = 8.0, value_parser = real_in(0.0, 1000.0, "m"), allow_hyphen_values = true)]
    pub no_return_clear_m: f64,
    /// Border added around the observed area when fitting the geometry, metres, 0 to 100 (a
    /// wider border only adds unknown cells).
    #[arg(long, value_name = "M", default_value_t = 1.0, value_parser = real_in(0.0, 100.0, "m"), allow_hyphen_values = true)]
    pub margin_m: f64,
    /// Largest time from a scan to a usable true pose, seconds, 0 to 3600 (an hour: poses
    /// further apart say nothing about the scan).
    #[arg(long, value_name = "S", default_value_t = 0.1, value_parser = real_in(0.0, 3600.0, "s"), allow_hyphen_values = true)]
    pub max_pose_gap_s: f64,
    /// Overwrite an existing output map.
    #[arg(long)]
    pub force: bool,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let params = load_params(MapperParams::default(), args.params.as_deref(), MapperParams::validate)?;
    mapkeeper_grid::check_output_file(&args.out, args.force)?;
    let (log, log_path) = args.input.read()?;
    let options = ReplayOptions { max_truth_gap_ns: (args.max_pose_gap_s * 1e9) as u64, ..ReplayOptions::default() };
    let source = LogSource::new(log, log_path.display().to_string(), options);
    let geometry = match &args.like {
        Some(like) => Some(*load(like)?.geometry()),
        None => None,
    };
    let job = MapLogParams {
        mapper: params,
        no_return_clear_m: args.no_return_clear_m,
        resolution_m: args.resolution,
        margin_m: args.margin_m,
    };
    let r = map_log(source, geometry, &job)
        .with_context(|| format!("mapping (true poses within {} s)", args.max_pose_gap_s))?;
    let grid = r.map;
    map_io::save_map(&grid, &args.out)?;
    let (b, placed, skipped) = (r.beams, r.scans_mapped, r.scans_skipped);
    outln!("scans: {placed} mapped, {skipped} skipped (no true pose within {} s)", args.max_pose_gap_s);
    outln!("beams: {} returns, {} no-return cleared, {} ignored", b.hits, b.clears, b.ignored);
    let g = grid.geometry();
    outln!(
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
    outln!("wrote {}", args.out.display());
    Ok(())
}
