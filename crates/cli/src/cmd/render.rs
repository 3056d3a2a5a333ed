//! `mapkeeper render`: a map, or the difference of two maps, as a PNG.

use super::metrics::{describe, load};
use mapkeeper_grid::render::{render_diff, render_map};
use std::path::PathBuf;

/// Arguments of `mapkeeper render`.
#[derive(clap::Args, Debug)]
#[command(
    long_about = "Render a ROS map_server map as an RGB PNG, one pixel per cell (times --scale), north up.\n\n\
Map colours: free white (255,255,255), occupied black (0,0,0), unknown grey (205,205,205).\n\
With --diff OTHER.yaml the image shows the change from MAP to OTHER: cells in the same state keep \
the map colours; added (occupied in OTHER, not in MAP) green (0,170,0); removed (occupied in MAP, \
not in OTHER) red (220,30,30); free ↔ unknown blue (90,140,255). Both maps must share size, \
resolution and origin. The PNG is written atomically (temporary file, then rename).",
    after_help = "Examples:\n  mapkeeper render m1.yaml -o m1.png --scale 2\n  mapkeeper render m1.yaml --diff m50.yaml -o change.png"
)]
pub struct Args {
    /// The map to render (ROS map_server YAML).
    #[arg(value_name = "MAP.yaml")]
    pub map: PathBuf,
    /// Output PNG file.
    #[arg(short = 'o', long, value_name = "OUT.png")]
    pub out: PathBuf,
    /// Render the difference from MAP to this map instead of MAP alone.
    #[arg(long, value_name = "OTHER.yaml")]
    pub diff: Option<PathBuf>,
    /// Integer enlargement: each cell becomes K × K pixels, 1 to 64 (the image is also limited
    /// to 2^28 pixels).
    #[arg(long, value_name = "K", default_value_t = 1, value_parser = super::count_in(1, 64), allow_hyphen_values = true)]
    pub scale: usize,
    /// Overwrite an existing output file.
    #[arg(long)]
    pub force: bool,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let map = load(&args.map)?;
    let image = match &args.diff {
        None => render_map(&map),
        Some(other_path) => {
            let other = load(other_path)?;
            if !map.geometry().same_as(other.geometry()) {
                anyhow::bail!(
                    "maps {} ({}) and {} ({}) differ in size, resolution or origin; cannot render their difference",
                    args.map.display(),
                    describe(map.geometry()),
                    other_path.display(),
                    describe(other.geometry()),
                );
            }
            render_diff(&map, &other)?
        }
    };
    let image = if args.scale > 1 { image.scaled(args.scale)? } else { image };
    mapkeeper_grid::check_output_file(&args.out, args.force)?;
    image.write_png(&args.out)?;
    outln!("wrote {} ({} × {} pixels)", args.out.display(), image.width(), image.height());
    Ok(())
}
