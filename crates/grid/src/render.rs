//! Rendering maps, and the difference of two maps, as RGB images written to PNG.
//!
//! Image row 0 is the top of the map (the grid's last row), so a PNG looks like the map seen from
//! above with y pointing up. Colours:
//!
//! | map cell | colour |
//! |---|---|
//! | free | [`FREE`] white (255, 255, 255) |
//! | occupied | [`OCCUPIED`] black (0, 0, 0) |
//! | unknown | [`UNKNOWN`] grey (205, 205, 205), as ROS map_server's 205 |
//!
//! | diff of `a` → `b` | colour |
//! |---|---|
//! | same state | the map colour above |
//! | added: occupied in `b`, not in `a` | [`ADDED`] green (0, 170, 0) |
//! | removed: occupied in `a`, not in `b` | [`REMOVED`] red (220, 30, 30) |
//! | free ↔ unknown | [`UNKNOWN_CHANGED`] blue (90, 140, 255) |
//!
//! | errors of a map against its ground truth | colour |
//! |---|---|
//! | right (the same state) | the map colour above |
//! | wrongly free: occupied in the truth, free in the map | [`WRONGLY_FREE`] red (220, 30, 30) |
//! | wrongly occupied: free or unknown in the truth, occupied in the map | [`WRONGLY_OCCUPIED`] orange (255, 150, 0) |
//! | missing: known in the truth, unknown in the map | [`MISSING`] blue (90, 140, 255) |
//! | free in the map where the truth is unknown | [`UNKNOWN`] grey, as unknown |
//!
//! ```
//! use mapkeeper_grid::render::{render_map, OCCUPIED, UNKNOWN};
//! use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Pose2};
//! let g = GridGeometry::new(3, 2, 0.05, Pose2::IDENTITY).unwrap();
//! let mut map = OccupancyGrid::filled(g, CellState::Unknown);
//! map.set(CellCoord::new(0, 0), CellState::Occupied); // bottom-left cell
//! let image = render_map(&map);
//! assert_eq!(image.pixel(0, 1), Some(OCCUPIED)); // bottom-left pixel
//! assert_eq!(image.pixel(0, 0), Some(UNKNOWN));
//! ```

use crate::GridError;
use crate::grid::{CellState, OccupancyGrid};
use std::path::{Path, PathBuf};

/// An RGB colour.
pub type Rgb = [u8; 3];

/// Free cells.
pub const FREE: Rgb = [255, 255, 255];
/// Occupied cells.
pub const OCCUPIED: Rgb = [0, 0, 0];
/// Unknown cells.
pub const UNKNOWN: Rgb = [205, 205, 205];
/// Diff: occupied in the second map, not in the first.
pub const ADDED: Rgb = [0, 170, 0];
/// Diff: occupied in the first map, not in the second.
pub const REMOVED: Rgb = [220, 30, 30];
/// Diff: free in one map, unknown in the other.
pub const UNKNOWN_CHANGED: Rgb = [90, 140, 255];

/// Errors: occupied in the truth, free in the map (a wall the map lost).
pub const WRONGLY_FREE: Rgb = REMOVED;
/// Errors: occupied in the map, not in the truth (a wall the map keeps or invents).
pub const WRONGLY_OCCUPIED: Rgb = [255, 150, 0];
/// Errors: known in the truth, unknown in the map.
pub const MISSING: Rgb = UNKNOWN_CHANGED;

/// The largest image accepted, in pixels (after scaling).
pub const MAX_PIXELS: usize = 1 << 28;

/// Errors of rendering and writing images.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RenderError {
    /// The scale factor is zero or the scaled image would exceed [`MAX_PIXELS`].
    #[error(
        "cannot scale a {width} × {height} image by {scale}: scale must be ≥ 1 and the result at most {MAX_PIXELS} pixels"
    )]
    BadScale {
        /// Image width, pixels.
        width: usize,
        /// Image height, pixels.
        height: usize,
        /// The factor asked for.
        scale: usize,
    },
    /// Writing the file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// PNG encoding failed.
    #[error("{path}: PNG encoding failed: {message}")]
    Encode {
        /// The file.
        path: PathBuf,
        /// The encoder's message.
        message: String,
    },
}

/// An 8-bit RGB image, rows top first.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RgbImage {
    width: usize,
    height: usize,
    data: Vec<u8>,
}

impl RgbImage {
    /// Width, pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height, pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Raw RGB bytes, rows top first, 3 bytes per pixel.
    pub fn data(&self) -> &[u8] {
        &self.data
    }

    /// The colour at column `x`, row `y` (row 0 at the top), `None` outside.
    pub fn pixel(&self, x: usize, y: usize) -> Option<Rgb> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let i = 3 * (y * self.width + x);
        Some([self.data[i], self.data[i + 1], self.data[i + 2]])
    }

    /// The image enlarged `scale` times (each pixel becomes a `scale × scale` block).
    pub fn scaled(&self, scale: usize) -> Result<RgbImage, RenderError> {
        let bad = || RenderError::BadScale { width: self.width, height: self.height, scale };
        if scale == 0 {
            return Err(bad());
        }
        let width = self.width.checked_mul(scale).ok_or_else(bad)?;
        let height = self.height.checked_mul(scale).ok_or_else(bad)?;
        if width.checked_mul(height).is_none_or(|n| n > MAX_PIXELS) || width > u32::MAX as usize {
            return Err(bad());
        }
        let mut data = Vec::with_capacity(3 * width * height);
        for row in self.data.chunks_exact(3 * self.width) {
            let start = data.len();
            for px in row.chunks_exact(3) {
                for _ in 0..scale {
                    data.extend_from_slice(px);
                }
            }
            for _ in 1..scale {
                data.extend_from_within(start..start + 3 * width);
            }
        }
        Ok(RgbImage { width, height, data })
    }

    /// The image encoded as PNG bytes (8-bit RGB).
    pub fn encode_png(&self) -> Result<Vec<u8>, png::EncodingError> {
        let mut out = Vec::new();
        {
            let mut encoder = png::Encoder::new(&mut out, self.width as u32, self.height as u32);
            encoder.set_color(png::ColorType::Rgb);
            encoder.set_depth(png::BitDepth::Eight);
            let mut writer = encoder.write_header()?;
            writer.write_image_data(&self.data)?;
            writer.finish()?;
        }
        Ok(out)
    }

    /// Writes the image as a PNG file, atomically: to a temporary file beside `path`, then
    /// renamed over it, so a reader never sees a partial file.
    pub fn write_png(&self, path: &Path) -> Result<(), RenderError> {
        let bytes =
            self.encode_png().map_err(|e| RenderError::Encode { path: path.to_path_buf(), message: e.to_string() })?;
        write_atomically(path, &bytes)
    }

    fn from_cells(grid: &OccupancyGrid, colour: impl Fn(usize) -> Rgb) -> RgbImage {
        let (width, height) = (grid.geometry().width(), grid.geometry().height());
        let mut data = Vec::with_capacity(3 * width * height);
        for row in (0..height).rev() {
            for col in 0..width {
                data.extend_from_slice(&colour(row * width + col));
            }
        }
        RgbImage { width, height, data }
    }
}

/// The colour of one map cell.
pub fn cell_colour(state: CellState) -> Rgb {
    match state {
        CellState::Free => FREE,
        CellState::Occupied => OCCUPIED,
        CellState::Unknown => UNKNOWN,
    }
}

/// The colour of a cell that is `a` in the first map and `b` in the second.
pub fn diff_colour(a: CellState, b: CellState) -> Rgb {
    match crate::grid::ChangeKind::of(a, b) {
        crate::grid::ChangeKind::Same => cell_colour(a),
        crate::grid::ChangeKind::Added => ADDED,
        crate::grid::ChangeKind::Removed => REMOVED,
        crate::grid::ChangeKind::Other => UNKNOWN_CHANGED,
    }
}

/// The colour of a cell that is `map` in a map and `truth` in its ground truth.
pub fn error_colour(map: CellState, truth: CellState) -> Rgb {
    match (map, truth) {
        _ if map == truth => cell_colour(map),
        (CellState::Occupied, _) => WRONGLY_OCCUPIED,
        (CellState::Free, CellState::Occupied) => WRONGLY_FREE,
        (CellState::Unknown, _) => MISSING,
        (CellState::Free, _) => UNKNOWN,
    }
}

/// The errors of `map` against `truth` as an image (colours in the module docs); the maps must
/// share a geometry.
pub fn render_errors(map: &OccupancyGrid, truth: &OccupancyGrid) -> Result<RgbImage, GridError> {
    if !map.geometry().same_as(truth.geometry()) {
        return Err(GridError::GeometryMismatch);
    }
    let (cm, ct) = (map.cells(), truth.cells());
    Ok(RgbImage::from_cells(map, |i| error_colour(cm[i], ct[i])))
}

/// The map as an image, one pixel per cell, top row first.
pub fn render_map(grid: &OccupancyGrid) -> RgbImage {
    let cells = grid.cells();
    RgbImage::from_cells(grid, |i| cell_colour(cells[i]))
}

/// The difference from `a` to `b` as an image (colours in the module docs); the maps must share
/// a geometry.
pub fn render_diff(a: &OccupancyGrid, b: &OccupancyGrid) -> Result<RgbImage, GridError> {
    if !a.geometry().same_as(b.geometry()) {
        return Err(GridError::GeometryMismatch);
    }
    let (ca, cb) = (a.cells(), b.cells());
    Ok(RgbImage::from_cells(a, |i| diff_colour(ca[i], cb[i])))
}

/// Writes `bytes` to `path` atomically ([`crate::write_atomic`]), naming the file on error.
fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), RenderError> {
    crate::write_atomic(path, bytes).map_err(|source| RenderError::Io { path: path.to_path_buf(), source })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{CellCoord, GridGeometry};
    use crate::pose::Pose2;

    /// Decodes a PNG file into (width, height, RGB bytes).
    fn decode(path: &Path) -> (u32, u32, Vec<u8>) {
        let file = std::io::BufReader::new(std::fs::File::open(path).unwrap());
        let mut reader = png::Decoder::new(file).read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!(info.color_type, png::ColorType::Rgb);
        assert_eq!(info.bit_depth, png::BitDepth::Eight);
        buf.truncate(info.buffer_size());
        (info.width, info.height, buf)
    }

    fn px(data: &[u8], width: u32, x: u32, y: u32) -> Rgb {
        let i = 3 * (y * width + x) as usize;
        [data[i], data[i + 1], data[i + 2]]
    }

    fn tmp_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("mapkeeper-render-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn map_png_round_trip_with_flip() {
        // 3 × 2: bottom row O F U, top row F F O.
        let g = GridGeometry::new(3, 2, 0.05, Pose2::IDENTITY).unwrap();
        let mut m = OccupancyGrid::filled(g, CellState::Free);
        m.set(CellCoord::new(0, 0), CellState::Occupied);
        m.set(CellCoord::new(2, 0), CellState::Unknown);
        m.set(CellCoord::new(2, 1), CellState::Occupied);
        let dir = tmp_dir("map");
        let path = dir.join("m.png");
        render_map(&m).write_png(&path).unwrap();
        let (w, h, data) = decode(&path);
        assert_eq!((w, h), (3, 2));
        // Image row 0 is grid row 1.
        assert_eq!(px(&data, w, 0, 0), FREE);
        assert_eq!(px(&data, w, 2, 0), OCCUPIED);
        assert_eq!(px(&data, w, 0, 1), OCCUPIED);
        assert_eq!(px(&data, w, 1, 1), FREE);
        assert_eq!(px(&data, w, 2, 1), UNKNOWN);
        // No temporary left behind.
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn diff_colours_and_scale() {
        // 4 × 1: a = O O F F, b = O F O U → same(black), removed, added, unknown-changed.
        let g = GridGeometry::new(4, 1, 0.05, Pose2::IDENTITY).unwrap();
        let a = OccupancyGrid::from_cells(
            g,
            vec![CellState::Occupied, CellState::Occupied, CellState::Free, CellState::Free],
        )
        .unwrap();
        let b = OccupancyGrid::from_cells(
            g,
            vec![CellState::Occupied, CellState::Free, CellState::Occupied, CellState::Unknown],
        )
        .unwrap();
        let image = render_diff(&a, &b).unwrap().scaled(2).unwrap();
        let dir = tmp_dir("diff");
        let path = dir.join("d.png");
        image.write_png(&path).unwrap();
        let (w, h, data) = decode(&path);
        assert_eq!((w, h), (8, 2));
        for y in 0..2 {
            assert_eq!(px(&data, w, 0, y), OCCUPIED);
            assert_eq!(px(&data, w, 1, y), OCCUPIED);
            assert_eq!(px(&data, w, 2, y), REMOVED);
            assert_eq!(px(&data, w, 3, y), REMOVED);
            assert_eq!(px(&data, w, 4, y), ADDED);
            assert_eq!(px(&data, w, 6, y), UNKNOWN_CHANGED);
            assert_eq!(px(&data, w, 7, y), UNKNOWN_CHANGED);
        }
        // Unknown → occupied counts as added; occupied → unknown as removed.
        assert_eq!(diff_colour(CellState::Unknown, CellState::Occupied), ADDED);
        assert_eq!(diff_colour(CellState::Occupied, CellState::Unknown), REMOVED);
        assert_eq!(diff_colour(CellState::Unknown, CellState::Unknown), UNKNOWN);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn error_colours_of_every_pair() {
        use CellState::{Free as F, Occupied as O, Unknown as U};
        // (map, truth) → colour, all nine pairs.
        let want = [
            ((F, F), FREE),
            ((O, O), OCCUPIED),
            ((U, U), UNKNOWN),
            ((F, O), WRONGLY_FREE),
            ((O, F), WRONGLY_OCCUPIED),
            ((O, U), WRONGLY_OCCUPIED),
            ((U, F), MISSING),
            ((U, O), MISSING),
            ((F, U), UNKNOWN),
        ];
        for ((m, t), c) in want {
            assert_eq!(error_colour(m, t), c, "map {m:?}, truth {t:?}");
        }
        let g = GridGeometry::new(3, 1, 0.05, Pose2::IDENTITY).unwrap();
        let map = OccupancyGrid::from_cells(g, vec![F, O, U]).unwrap();
        let truth = OccupancyGrid::from_cells(g, vec![O, O, F]).unwrap();
        let image = render_errors(&map, &truth).unwrap();
        assert_eq!(image.pixel(0, 0), Some(WRONGLY_FREE));
        assert_eq!(image.pixel(1, 0), Some(OCCUPIED));
        assert_eq!(image.pixel(2, 0), Some(MISSING));
        let other = OccupancyGrid::filled(GridGeometry::new(2, 1, 0.05, Pose2::IDENTITY).unwrap(), F);
        assert_eq!(render_errors(&map, &other), Err(GridError::GeometryMismatch));
    }

    #[test]
    fn refusals() {
        let g = GridGeometry::new(2, 2, 0.05, Pose2::IDENTITY).unwrap();
        let h = GridGeometry::new(2, 3, 0.05, Pose2::IDENTITY).unwrap();
        let a = OccupancyGrid::filled(g, CellState::Free);
        let b = OccupancyGrid::filled(h, CellState::Free);
        assert_eq!(render_diff(&a, &b), Err(GridError::GeometryMismatch));
        assert!(matches!(render_map(&a).scaled(0), Err(RenderError::BadScale { .. })));
        assert!(matches!(render_map(&a).scaled(1 << 20), Err(RenderError::BadScale { .. })));
        let e = render_map(&a).write_png(Path::new("/nonexistent-dir/x.png")).unwrap_err();
        assert!(e.to_string().contains("/nonexistent-dir/x.png"), "{e}");
    }
}
