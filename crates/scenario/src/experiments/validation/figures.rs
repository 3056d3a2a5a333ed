//! The validation's figures, the analogs of the paper's Fig. 24-27 (§5.3.2), drawn from a
//! [`ValidationRecord`] (so a merged folder gets the same figures as a single run).
//!
//! Every figure plots one value per world i = 2 … N, the static map M_1 in blue and the
//! updated map M_i (M_{i-1} for the localiser) in red, as in the paper:
//!
//! | file stem | paper | what |
//! |---|---|---|
//! | `fig24a_cc`, `fig24b_ms`, `fig24c_opdf` | Fig. 24 (a-c) | CC, MS, OPDF of M_1/G_i and M_i/G_i |
//! | `fig25a_position_error` | Fig. 25 (a) | localiser position error, mean (± std over the route) |
//! | `fig25b_max_position_error` | Fig. 25 (b) | largest position error |
//! | `fig26a_trace` | Fig. 26 (a) | trace of the pose covariance P, mean ± std over the route |
//! | `fig26b_lambda_max` | Fig. 26 (b) | λmax(P), mean ± std over the route |
//! | `fig27a_updater_time` | Fig. 27 (a) (CPU) | median updater time per processed scan |
//! | `fig27b_updater_memory` | Fig. 27 (b) (memory) | largest updater change state (sparse cell buffers; the map-sized caches, constant per map, are in the caption) |
//!
//! With one seed the bands are the spread over the route within the world (the paper's
//! "(μ, σ)", clipped at 0); with several seeds a line is the mean over seeds of the per-world value and its
//! band the range (min-max) over seeds.

use crate::experiments::validation::{ValidationRecord, WorldRow};
use crate::results::ResultsError;
use mapkeeper_grid::StagedDir;
use mapkeeper_plot::{LineChart, Series};

pub use crate::results::PNG_SIZE_PX;

/// The folder of the figures inside a validation folder.
pub const PLOTS_DIR: &str = "plots";

/// One figure of a validation folder.
#[derive(Clone, Debug, PartialEq)]
pub struct Figure {
    /// File name without extension (`plots/<stem>.svg` and `.png`).
    pub stem: &'static str,
    /// The paper's figure it matches, e.g. "Fig. 24 (a)".
    pub paper: &'static str,
    /// One-line caption for the report.
    pub caption: String,
    /// The chart.
    pub chart: LineChart,
}

impl Figure {
    /// `plots/<stem>.svg`.
    pub fn svg_path(&self) -> String {
        format!("{PLOTS_DIR}/{}.svg", self.stem)
    }

    /// `plots/<stem>.png`.
    pub fn png_path(&self) -> String {
        format!("{PLOTS_DIR}/{}.png", self.stem)
    }
}

/// Per world i = 2 … N (in order), `f` of that world's row in every seed that has it.
fn per_world(record: &ValidationRecord, f: &dyn Fn(&WorldRow) -> f64) -> Vec<(f64, Vec<f64>)> {
    (2..=record.params.worlds)
        .map(|i| {
            let values =
                record.seeds.iter().filter_map(|s| s.rows.iter().find(|w| w.world == i)).map(f).collect::<Vec<_>>();
            (i as f64, values)
        })
        .filter(|(_, v)| !v.is_empty())
        .collect()
}

fn mean(v: &[f64]) -> f64 {
    crate::stats::mean(v.iter().copied())
}

fn min_max(v: &[f64]) -> (f64, f64) {
    v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| (lo.min(x), hi.max(x)))
}

/// A per-world value: with one seed the line alone, with several the mean and a min-max band.
fn value_series(name: &str, record: &ValidationRecord, f: &dyn Fn(&WorldRow) -> f64) -> Series {
    let data = per_world(record, f);
    let points = data.iter().map(|(x, v)| (*x, mean(v))).collect();
    let s = Series::new(name, points);
    if record.seeds.len() > 1 {
        s.with_band(data.iter().map(|(x, v)| (*x, min_max(v).0, min_max(v).1)).collect())
    } else {
        s
    }
}

/// A per-world mean of a non-negative quantity with a spread over the route: with one seed,
/// mean ± std (clipped at 0); with several, the mean over seeds of the per-world means and
/// their min-max band.
fn spread_series(
    name: &str,
    record: &ValidationRecord,
    mean_of: &dyn Fn(&WorldRow) -> f64,
    std_of: &dyn Fn(&WorldRow) -> f64,
) -> Series {
    if record.seeds.len() > 1 {
        return value_series(name, record, mean_of);
    }
    let m = per_world(record, mean_of);
    let sd = per_world(record, std_of);
    let points = m.iter().map(|(x, a)| (*x, mean(a))).collect();
    // The quantities are non-negative: the band is clipped at 0.
    let band =
        m.iter().zip(&sd).map(|((x, a), (_, b))| (*x, (mean(a) - mean(b)).max(0.0), mean(a) + mean(b))).collect();
    Series::new(name, points).with_band(band)
}

/// The x-axis label, saying what the bands are.
fn x_label(record: &ValidationRecord, spread_within_world: bool) -> String {
    let n = record.seeds.len();
    if n > 1 {
        format!("world i  (mean over {n} seeds, band: min-max over seeds)")
    } else if spread_within_world {
        "world i  (band: ± std over the route)".to_owned()
    } else {
        "world i".to_owned()
    }
}

/// Standard deviation of the position error over a world's localiser updates, from its mean
/// and RMSE (σ² = RMSE² − mean²).
fn error_std(mean_m: f64, rmse_m: f64) -> f64 {
    (rmse_m * rmse_m - mean_m * mean_m).max(0.0).sqrt()
}

/// A map metric of a world: (M_1/G_i, M_i/G_i).
type StaticAndUpdated = fn(&WorldRow) -> (f64, f64);

const STATIC_MAP: &str = "M_1 / G_i (static)";
const UPDATED_MAP: &str = "M_i / G_i (updated)";
const ON_STATIC: &str = "localiser on M_1 (static)";
const ON_UPDATED: &str = "localiser on M_i-1 (updated)";

/// The figures of a validation record, in report order.
pub fn figures(record: &ValidationRecord) -> Vec<Figure> {
    let x1 = x_label(record, false);
    let xs = x_label(record, true);
    let mut out = Vec::new();
    let maps: [(&'static str, &'static str, &str, &str, StaticAndUpdated); 3] = [
        ("fig24a_cc", "Fig. 24 (a)", "Cross-correlation", "CC (%)", |w| (w.static_map.cc, w.updated_map.cc)),
        ("fig24b_ms", "Fig. 24 (b)", "Map score", "MS (%)", |w| (w.static_map.ms, w.updated_map.ms)),
        ("fig24c_opdf", "Fig. 24 (c)", "Occupied picture-distance function", "OPDF (%)", |w| {
            (w.static_map.opdf, w.updated_map.opdf)
        }),
    ];
    for (stem, paper, title, y, f) in maps {
        let chart = LineChart::new(format!("{paper} {title}"), x1.as_str(), y)
            .with_series(value_series(STATIC_MAP, record, &|w| f(w).0))
            .with_series(value_series(UPDATED_MAP, record, &|w| f(w).1));
        let caption = format!("{title} ({y}) of the static map M_1 and the updated map M_i against G_i, per world");
        out.push(Figure { stem, paper, caption, chart: chart.with_integer_x() });
    }
    out.extend(localisation_figures(record, &x1, &xs));
    out.extend(updater_figures(record, &x1));
    out
}

/// Fig. 25-26: the localisers' errors and uncertainty.
fn localisation_figures(record: &ValidationRecord, x1: &str, xs: &str) -> Vec<Figure> {
    let mut out = Vec::new();
    let chart = LineChart::new("Fig. 25 (a) Position error", xs, "position error (m)")
        .with_series(spread_series(ON_STATIC, record, &|w| w.loc_static.mean_error_m, &|w| {
            error_std(w.loc_static.mean_error_m, w.loc_static.rmse_m)
        }))
        .with_series(spread_series(ON_UPDATED, record, &|w| w.loc_updated.mean_error_m, &|w| {
            error_std(w.loc_updated.mean_error_m, w.loc_updated.rmse_m)
        }));
    out.push(Figure {
        stem: "fig25a_position_error",
        paper: "Fig. 25 (a)",
        caption: "Mean position error of the localiser on M_1 and on M_{i-1}, per world".into(),
        chart: chart.with_integer_x(),
    });
    let chart = LineChart::new("Fig. 25 (b) Largest position error", x1, "max position error (m)")
        .with_series(value_series(ON_STATIC, record, &|w| w.loc_static.max_error_m))
        .with_series(value_series(ON_UPDATED, record, &|w| w.loc_updated.max_error_m));
    out.push(Figure {
        stem: "fig25b_max_position_error",
        paper: "Fig. 25 (b)",
        caption: "Largest position error of the localiser on M_1 and on M_{i-1}, per world".into(),
        chart: chart.with_integer_x(),
    });
    let chart = LineChart::new("Fig. 26 (a) Trace of the pose covariance P", xs, "trace(P) (m² + rad²)")
        .with_series(spread_series(ON_STATIC, record, &|w| w.loc_static.mean_trace, &|w| w.loc_static.std_trace))
        .with_series(spread_series(ON_UPDATED, record, &|w| w.loc_updated.mean_trace, &|w| w.loc_updated.std_trace));
    out.push(Figure {
        stem: "fig26a_trace",
        paper: "Fig. 26 (a)",
        caption: "Mean trace of the pose covariance P on M_1 and on M_{i-1}, per world".into(),
        chart: chart.with_integer_x(),
    });
    let chart = LineChart::new("Fig. 26 (b) Largest eigenvalue of P", xs, "λmax(P)")
        .with_series(spread_series(ON_STATIC, record, &|w| w.loc_static.mean_lambda_max, &|w| {
            w.loc_static.std_lambda_max
        }))
        .with_series(spread_series(ON_UPDATED, record, &|w| w.loc_updated.mean_lambda_max, &|w| {
            w.loc_updated.std_lambda_max
        }));
    out.push(Figure {
        stem: "fig26b_lambda_max",
        paper: "Fig. 26 (b)",
        caption: "Mean largest eigenvalue λmax of P on M_1 and on M_{i-1}, per world".into(),
        chart: chart.with_integer_x(),
    });
    out
}

/// Fig. 27: the updater's time and memory.
fn updater_figures(record: &ValidationRecord, x1: &str) -> Vec<Figure> {
    let mut out = Vec::new();
    let (title, time) = if record.timing {
        ("Fig. 27 (a) Updater time per processed scan (median)", value_series("updater", record, &|w| w.median_scan_us))
    } else {
        ("Fig. 27 (a) Updater time per scan: not measured", Series::new("updater (not timed)", Vec::new()))
    };
    let from_zero = |chart: LineChart| {
        let points = chart.series.iter().flat_map(|s| s.points.iter().map(|p| p.1));
        let bands = chart.series.iter().flat_map(|s| s.band.iter().flatten().map(|b| b.2));
        let hi = points.chain(bands).filter(|v| v.is_finite()).fold(0.0, f64::max);
        if hi > 0.0 { chart.with_y_range(0.0, hi * 1.08) } else { chart }
    };
    out.push(Figure {
        stem: "fig27a_updater_time",
        paper: "Fig. 27 (a)",
        caption: "Median updater time per processed scan (µs, wall clock, one core), per world (the paper: CPU %)"
            .into(),
        chart: from_zero(LineChart::new(title, x1, "time per scan (µs)").with_series(time).with_integer_x()),
    });
    let chart = LineChart::new("Fig. 27 (b) Updater change state (largest)", x1, "change state (kB)")
        .with_series(value_series("updater", record, &|w| w.updater.max_state_bytes as f64 / 1000.0));
    let chart = from_zero(chart);
    out.push(Figure {
        stem: "fig27b_updater_memory",
        paper: "Fig. 27 (b)",
        caption: format!(
            "Largest updater change state (sparse cell buffers, kB), per world; not shown: the map-sized caches \
             (both grids, clearance field, interior mask, score grid), {:.0} kB, constant for a map (the paper: node \
             memory, MB)",
            record.seeds.iter().flat_map(|s| &s.rows).map(|w| w.updater.cache_bytes).max().unwrap_or(0) as f64 / 1000.0
        ),
        chart: chart.with_integer_x(),
    });
    out
}

/// Writes every figure as `plots/<stem>.svg` and `plots/<stem>.png` ([`PNG_SIZE_PX`]) into
/// `dir` and returns them.
pub fn write_figures(dir: &StagedDir, record: &ValidationRecord) -> Result<Vec<Figure>, ResultsError> {
    let figs = figures(record);
    for f in &figs {
        f.chart.write_svg(&dir.file(&f.svg_path())?)?;
        f.chart.write_png(&dir.file(&f.png_path())?, PNG_SIZE_PX.0, PNG_SIZE_PX.1)?;
    }
    Ok(figs)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_std_comes_from_mean_and_rmse() {
        // Errors 1 and 3: mean 2, RMSE √5, std 1.
        assert!((error_std(2.0, 5f64.sqrt()) - 1.0).abs() < 1e-12);
        assert_eq!(error_std(0.5, 0.5), 0.0);
        assert_eq!(error_std(0.5, 0.49), 0.0, "rounding never gives NaN");
    }
}
