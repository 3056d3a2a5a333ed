//! # mapkeeper-plot
//!
//! Small, deterministic charts for the validation reports (the analogs of the paper's
//! Fig. 24-27): [`LineChart`] (per-world metrics, localisation errors with a mean ± std band,
//! covariance figures) and [`BarChart`] (grouped bars: verdict counts, Table 1 comparisons).
//! Data in, file out: every chart writes an SVG ([`LineChart::write_svg`]) or a PNG of a
//! chosen size ([`LineChart::write_png`]), atomically (temporary file in the same folder,
//! then rename).
//!
//! Guarantees:
//! - Non-finite values are skipped (they break a line), empty charts are drawn with a
//!   "no data" note; bad input gives a [`PlotError`] naming the output file, never a panic.
//! - The same chart gives byte-identical files, on every run.
//! - Text is laid out, and rasterised in PNGs, with the bundled DejaVu Sans
//!   (`assets/DejaVuSans.ttf`, licence in `assets/DejaVuSans-LICENSE.txt`); no system font
//!   is used. SVG files only name the family `sans-serif`.
//!
//! This crate plots numbers: it depends on no other mapkeeper crate.
//!
//! ```
//! use mapkeeper_plot::{BarChart, LineChart, Series};
//! let dir = std::env::temp_dir().join(format!("mapkeeper-plot-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir).unwrap();
//!
//! // Fig. 24 (a): CC of the static map M_1 and of the updated map M_i against G_i.
//! let static_cc: Vec<(f64, f64)> = (2..=100).map(|i| (i as f64, 90.0 - 0.3 * i as f64)).collect();
//! let updated_cc: Vec<(f64, f64)> = (2..=100).map(|i| (i as f64, 95.0)).collect();
//! LineChart::new("Cross-correlation", "world i", "CC (%)")
//!     .with_series(Series::new("M_1 / G_i", static_cc))
//!     .with_series(Series::new("M_i / G_i", updated_cc))
//!     .with_y_range(0.0, 100.0)
//!     .write_svg(&dir.join("cc.svg"))
//!     .unwrap();
//!
//! // Fig. 25: position error per world, mean with a ± std band, from (x, mean, std).
//! let errors = [(2.0, 0.10, 0.02), (3.0, 0.12, 0.03), (4.0, 0.11, 0.02)];
//! LineChart::new("Position error", "world i", "error (m)")
//!     .with_series(Series::mean_std("static map M_1", &errors))
//!     .write_png(&dir.join("error.png"), 800, 500)
//!     .unwrap();
//!
//! // Verdict counts per preset.
//! BarChart::new("Localisation check", "scans", vec!["paper".into(), "reference".into()])
//!     .with_group("Update", vec![950.0, 980.0])
//!     .with_group("Suspend", vec![40.0, 15.0])
//!     .with_group("Lost", vec![10.0, 5.0])
//!     .write_svg(&dir.join("verdicts.svg"))
//!     .unwrap();
//!
//! let svg = std::fs::read_to_string(dir.join("cc.svg")).unwrap();
//! assert!(svg.contains("Cross-correlation") && svg.contains("M_i / G_i"));
//! std::fs::remove_dir_all(&dir).unwrap();
//! ```
#![warn(missing_docs)]

mod backend;
mod bar;
mod line;
mod render;

use std::path::PathBuf;

use plotters::style::RGBColor;

pub use bar::{BarChart, VALUE_LABEL_MAX_BARS};
pub use line::{LineChart, MARKER_MAX_POINTS, Series};
pub use render::{MAX_SIDE_PX, MIN_SIDE_PX, SVG_SIZE_PX};

/// Series and group colours, used in order and then again from the start (RGB). Blue then
/// red as in the paper's figures (M_1 blue, M_{i-1} red), then the Okabe–Ito colour-blind
/// safe set.
pub const PALETTE: [[u8; 3]; 8] = [
    [0, 114, 178],   // blue
    [213, 40, 30],   // red
    [0, 158, 115],   // bluish green
    [230, 159, 0],   // orange
    [204, 121, 167], // reddish purple
    [86, 180, 233],  // sky blue
    [90, 90, 90],    // dark grey
    [150, 100, 40],  // brown
];

/// The colour of series or group `i`.
fn colour(i: usize) -> RGBColor {
    let [r, g, b] = PALETTE[i % PALETTE.len()];
    RGBColor(r, g, b)
}

/// Everything that can go wrong while writing a chart; each error names the output file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlotError {
    /// Creating, writing or renaming the file failed.
    #[error("{}: cannot write the chart: {source}", path.display())]
    Io {
        /// The output file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A PNG side is outside `MIN_SIDE_PX..=MAX_SIDE_PX`.
    #[error("{}: image size {width} x {height} px is out of bounds (each side {MIN_SIDE_PX}..={MAX_SIDE_PX} px)", path.display())]
    InvalidSize {
        /// The output file.
        path: PathBuf,
        /// Requested width, px.
        width: u32,
        /// Requested height, px.
        height: u32,
    },
    /// A fixed axis range is not usable, or the data span cannot be represented.
    #[error("{}: {axis} range ({lo}, {hi}) is invalid: {reason}", path.display())]
    InvalidRange {
        /// The output file.
        path: PathBuf,
        /// `"x"` or `"y"`.
        axis: &'static str,
        /// Lower end.
        lo: f64,
        /// Upper end.
        hi: f64,
        /// What is wrong.
        reason: String,
    },
    /// A bar group does not hold exactly one value per category.
    #[error("{}: bar group '{group}' has {got} values for {expected} categories", path.display())]
    GroupLength {
        /// The output file.
        path: PathBuf,
        /// The group's name.
        group: String,
        /// Number of categories.
        expected: usize,
        /// Number of values in the group.
        got: usize,
    },
    /// The plotting library reported a failure.
    #[error("{}: drawing failed: {message}", path.display())]
    Draw {
        /// The output file.
        path: PathBuf,
        /// plotters' message.
        message: String,
    },
    /// PNG encoding failed.
    #[error("{}: PNG encoding failed: {source}", path.display())]
    Png {
        /// The output file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: png::EncodingError,
    },
}
