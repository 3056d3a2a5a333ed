//! `mapkeeper import-map`: a ROS map (map_server YAML + PGM/PNG) as a world file with its
//! storage areas derived and a patrol route planned, ready for `validate --world`.

use anyhow::Context;
use mapkeeper_closed_loop::{Site, SiteParams};
use mapkeeper_grid::map_io::load_map;
use mapkeeper_sim::World;
use std::path::PathBuf;

/// Arguments of `mapkeeper import-map`.
#[derive(clap::Args, Debug)]
#[command(after_help = "The map's occupied cells become static walls (merged into rectangles); every \
unknown cell next to a free cell, and every free cell on the map's border, is sealed (made a wall too), \
so the robot and its lidars stay inside what the map saw. The robot starts at the free cell farthest \
from any obstacle. Storage areas are derived and a patrol route is planned as for any world without \
them (docs/world-format.md); the world file holds both, so it can be edited and passed to validate, \
generate, recover, run or experiment with --world.\n\nExample:\n  mapkeeper import-map site/map.yaml --out site.toml\n  \
mapkeeper validate --world site.toml --preset paper --worlds 10 --seeds 1")]
pub struct Args {
    /// The map (ROS map_server YAML; its image PGM or PNG, trinary, scale or raw).
    #[arg(value_name = "MAP.yaml")]
    pub map: PathBuf,
    /// The world file to write (TOML).
    #[arg(long, value_name = "WORLD.toml")]
    pub out: PathBuf,
    /// Name of the world (default: the map file's stem).
    #[arg(long, value_name = "NAME")]
    pub name: Option<String>,
    /// Seed of the planned patrol (any whole number from 0 to 2^64 − 1).
    #[arg(long, value_name = "S", default_value_t = 0, value_parser = super::seed, allow_hyphen_values = true)]
    pub route_seed: u64,
    /// Overwrite an existing output file.
    #[arg(long)]
    pub force: bool,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let grid = load_map(&args.map)?;
    let name = match &args.name {
        Some(n) if n.trim().is_empty() => anyhow::bail!("--name must not be empty"),
        Some(n) => n.clone(),
        None => args.map.file_stem().map_or_else(|| "imported-map".into(), |s| s.to_string_lossy().into_owned()),
    };
    let world = World::from_ros_map(&grid, &name);
    let origin = args.map.display().to_string();
    let params = SiteParams { seed: args.route_seed, ..SiteParams::default() };
    let site = Site::resolve(&world, None, &origin, &params).context("import-map")?;
    site.require_storage(&origin, &params)?;
    mapkeeper_grid::check_output_file(&args.out, args.force)?;
    let text = format!(
        "# Imported by `mapkeeper import-map` from {} (docs/world-format.md).\n{}",
        args.map.file_name().map_or_else(String::new, |f| f.to_string_lossy().into_owned()),
        site.world.to_toml_string()?
    );
    // Read back before writing: the file must load as it is.
    World::from_toml_str(&text, &args.out.display().to_string()).context("the imported world")?;
    mapkeeper_grid::write_atomic(&args.out, text.as_bytes()).with_context(|| format!("{}", args.out.display()))?;
    outln!(
        "wrote {}: {} walls, {} storage areas, a {:.1} m patrol of {} waypoints, start ({:.2}, {:.2})",
        args.out.display(),
        site.world.walls.len(),
        site.storage.len(),
        site.route.length_m(),
        site.route.waypoints.len(),
        site.world.robot_start.x,
        site.world.robot_start.y
    );
    Ok(())
}
