//! `mapkeeper metrics`: CC, MS and OPDF (paper §5.1) between two ROS map_server maps.

use anyhow::Context;
use mapkeeper_grid::metrics::{MetricParams, map_metrics, resample_onto};
use mapkeeper_grid::{GridGeometry, map_io};
use std::path::{Path, PathBuf};

/// Arguments of `mapkeeper metrics`.
#[derive(clap::Args, Debug)]
#[command(
    long_about = "CC, MS and OPDF (Stefanini et al. 2023, §5.1) between two ROS map_server maps, in percent.\n\n\
Cells are 1 occupied, 0 free, --unknown-value unknown. CC is the Pearson correlation over all cells \
(× 100); MS is 100·(1 − mean squared difference) over the cells occupied in at least one map; OPDF \
is the mean of both directions of 100·(1 − Σd/(ν·r)), d the Manhattan distance in cells from each \
occupied cell to the nearest occupied cell of the other map, capped at r = √(w² + h²) for a \
W × W metre window. Degenerate cases and open choices: docs/metrics.md.\n\n\
Both maps must have the same size, resolution and origin, unless --resample is given.",
    after_help = "Examples:\n  mapkeeper metrics m1.yaml g1.yaml\n  mapkeeper metrics m1.yaml g1.yaml --json\n  \
mapkeeper metrics slam.yaml truth.yaml --resample --opdf-window-m 2"
)]
pub struct Args {
    /// First map M (ROS map_server YAML).
    #[arg(value_name = "A.yaml")]
    pub a: PathBuf,
    /// Second map M~ (ROS map_server YAML).
    #[arg(value_name = "B.yaml")]
    pub b: PathBuf,
    /// If the maps' geometries differ, resample B onto A's grid (each A cell takes the B cell
    /// containing its centre; cells outside B are unknown) instead of failing.
    #[arg(long)]
    pub resample: bool,
    /// Occupancy value of unknown cells in CC and MS, in [0, 1].
    #[arg(long, value_name = "V", default_value_t = MetricParams::default().unknown_value, value_parser = super::real_in(0.0, 1.0, ""), allow_hyphen_values = true)]
    pub unknown_value: f64,
    /// Side of the square OPDF search window, metres (r = √2·W / resolution cells), > 0 and ≤
    /// 1000 m (wider than any map here: the cap then never binds).
    #[arg(long, value_name = "W", default_value_t = MetricParams::default().opdf_window_m.0, value_parser = super::positive_up_to(1000.0, "m"), allow_hyphen_values = true)]
    pub opdf_window_m: f64,
    /// Print exactly one JSON object {"cc": …, "ms": …, "opdf": …} (percent) on stdout.
    #[arg(long)]
    pub json: bool,
}

/// One-line description of a geometry for error messages.
pub(crate) fn describe(g: &GridGeometry) -> String {
    let o = g.origin();
    format!("{} × {} cells at {} m, origin ({}, {}, {})", g.width(), g.height(), g.resolution_m(), o.x, o.y, o.yaw)
}

/// Loads a map, naming the file on error.
pub(crate) fn load(path: &Path) -> anyhow::Result<mapkeeper_grid::OccupancyGrid> {
    map_io::load_map(path).with_context(|| format!("cannot load map {}", path.display()))
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let params =
        MetricParams { unknown_value: args.unknown_value, opdf_window_m: (args.opdf_window_m, args.opdf_window_m) };
    params.validate()?;
    let a = load(&args.a)?;
    let mut b = load(&args.b)?;
    let mut resampled = false;
    if !a.geometry().same_as(b.geometry()) {
        if !args.resample {
            anyhow::bail!(
                "maps {} ({}) and {} ({}) differ in size, resolution or origin; pass --resample to resample the second onto the first",
                args.a.display(),
                describe(a.geometry()),
                args.b.display(),
                describe(b.geometry()),
            );
        }
        b = resample_onto(&b, a.geometry());
        resampled = true;
    }
    let m = map_metrics(&a, &b, &params)
        .with_context(|| format!("metrics of {} and {}", args.a.display(), args.b.display()))?;
    if args.json {
        let object = serde_json::json!({ "cc": m.cc, "ms": m.ms, "opdf": m.opdf });
        outln!("{object}");
        return Ok(());
    }
    outln!("A: {} ({})", args.a.display(), describe(a.geometry()));
    outln!("B: {}{}", args.b.display(), if resampled { " (resampled onto A)" } else { "" });
    outln!(
        "cells {}, occupied in A {}, in B {}, in either {}; unknown value {}, OPDF window {} m (r = {:.2} cells)",
        m.cells,
        m.occupied_a,
        m.occupied_b,
        m.union_occupied,
        params.unknown_value,
        args.opdf_window_m,
        m.opdf_radius_cells
    );
    outln!();
    outln!("{:<12} {:>9}", "metric", "%");
    outln!(
        "{:<12} {:>9.2}{}",
        "CC",
        m.cc,
        if m.cc_degenerate { "  (constant map: rule, see docs/metrics.md)" } else { "" }
    );
    outln!("{:<12} {:>9.2}", "MS", m.ms);
    outln!("{:<12} {:>9.2}", "OPDF", m.opdf);
    outln!("{:<12} {:>9.2}", "  OPDF A→B", m.opdf_ab);
    outln!("{:<12} {:>9.2}", "  OPDF B→A", m.opdf_ba);
    Ok(())
}
