//! ROS map_server I/O: the YAML description plus a PGM (P5 or P2) or PNG image.
//!
//! Loading follows the map_server / Nav2 rules: a pixel's shade `v` (0-255; the mean of the
//! colour channels for a colour image) gives an occupancy probability `p = (255 − v) / 255`
//! (`p = v / 255` when `negate` is set); a cell is occupied when `p ≥ occupied_thresh`, free when
//! `p ≤ free_thresh`, unknown otherwise (modes `trinary` and `scale`; in `scale` a fully
//! transparent pixel is unknown). In `raw` mode the shade is the value itself: 0 free, 100
//! occupied, anything else unknown. Image row 0 is the top of the map, so rows are flipped: grid
//! row 0 is the bottom, and the YAML `origin` is the pose of the lower-left pixel's corner.
//!
//! Saving writes a trinary P5 PGM (254 free, 0 occupied, 205 unknown) and its YAML, each to a
//! temporary name first and then renamed, so an interrupted run never leaves a map that looks
//! complete.
//!
//! Every error names the file and the problem; nothing here panics on bad input, and image
//! sizes are checked against [`MAX_CELLS`] before anything is allocated.
//!
//! ```
//! use mapkeeper_grid::{map_io, CellState, GridGeometry, OccupancyGrid, Pose2};
//! let dir = std::env::temp_dir().join(format!("mapkeeper-doc-map-io-{}", std::process::id()));
//! std::fs::create_dir_all(&dir).unwrap();
//! let geometry = GridGeometry::new(3, 2, 0.05, Pose2::new(-1.0, -2.0, 0.0)).unwrap();
//! let map = OccupancyGrid::filled(geometry, CellState::Free);
//! map_io::save_map(&map, &dir.join("room.yaml")).unwrap();
//! let back = map_io::load_map(&dir.join("room.yaml")).unwrap();
//! assert_eq!(back, map);
//! ```

use crate::GridError;
use crate::grid::{CellState, GridGeometry, MAX_CELLS, MAX_SIDE, OccupancyGrid};
use crate::pose::Pose2;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// Largest YAML file read, bytes.
const MAX_YAML_BYTES: u64 = 1 << 20;
/// Largest image file read, bytes (a 16-bit RGBA image at the cell limit would not fit anyway).
const MAX_IMAGE_BYTES: u64 = 2 << 30;

/// Pixel values written for each state in a trinary PGM.
pub const PGM_FREE: u8 = 254;
/// Pixel value of an occupied cell in a trinary PGM.
pub const PGM_OCCUPIED: u8 = 0;
/// Pixel value of an unknown cell in a trinary PGM.
pub const PGM_UNKNOWN: u8 = 205;

/// What went wrong reading or writing a map. Each variant names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MapIoError {
    /// The file could not be opened, read, written or renamed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The YAML is malformed.
    #[error("{path}:{line}: {message}")]
    Yaml {
        /// The YAML file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A required key is missing from the YAML.
    #[error("{path}: missing key '{key}'")]
    MissingKey {
        /// The YAML file.
        path: PathBuf,
        /// The key.
        key: &'static str,
    },
    /// A key has a value of the wrong type or out of range.
    #[error("{path}:{line}: key '{key}': {message}")]
    BadValue {
        /// The YAML file.
        path: PathBuf,
        /// 1-based line of the key.
        line: usize,
        /// The key.
        key: &'static str,
        /// What is wrong.
        message: String,
    },
    /// The image is malformed, truncated, too large or of an unsupported kind.
    #[error("{path}: {message}")]
    Image {
        /// The image file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The geometry described by the file is invalid.
    #[error("{path}: {source}")]
    Geometry {
        /// The YAML file.
        path: PathBuf,
        /// The cause.
        source: GridError,
    },
}

/// The range of map resolutions accepted, metres per cell (a map file's `resolution`, and the
/// CLI's `--resolution`): 5 mm is finer than any 2-D lidar's noise (the paper's warehouse then
/// has ~13 M cells, and a scan matcher's window of ±0.3 m is 120 cells wide); 10 m leaves a
/// handful of cells per building. Finer maps would only make every per-cell loop (scan
/// matching, free-disc checks) slower without bound.
pub const MAP_RESOLUTION_M: (f64, f64) = (0.005, 10.0);

/// How pixel shades become cell states (map_server's `mode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapMode {
    /// Thresholds give occupied / free / unknown.
    Trinary,
    /// As trinary for this crate's trinary grids; transparent pixels are unknown.
    Scale,
    /// The shade is the value: 0 free, 100 occupied, anything else unknown.
    Raw,
}

/// The contents of a map_server YAML file.
#[derive(Clone, Debug, PartialEq)]
pub struct MapYaml {
    /// Image path as written in the file (relative paths are relative to the YAML's folder).
    pub image: String,
    /// Metres per cell.
    pub resolution_m: f64,
    /// Pose of the lower-left pixel's corner in the map frame.
    pub origin: Pose2,
    /// Whether white means occupied.
    pub negate: bool,
    /// Occupancy probability at or above which a cell is occupied.
    pub occupied_thresh: f64,
    /// Occupancy probability at or below which a cell is free.
    pub free_thresh: f64,
    /// How shades are interpreted.
    pub mode: MapMode,
}

/// Loads a map_server map: the YAML at `yaml_path` and the image it names.
pub fn load_map(yaml_path: &Path) -> Result<OccupancyGrid, MapIoError> {
    let text = read_limited(yaml_path, MAX_YAML_BYTES)?;
    let text = String::from_utf8(text).map_err(|e| MapIoError::Yaml {
        path: yaml_path.to_path_buf(),
        line: line_of_offset(e.as_bytes(), e.utf8_error().valid_up_to()),
        message: "not valid UTF-8".into(),
    })?;
    let meta = parse_map_yaml(&text, yaml_path)?;
    let image_path = resolve_image_path(yaml_path, &meta.image);
    let bytes = read_limited(&image_path, MAX_IMAGE_BYTES)?;
    map_from_image_bytes(&meta, &bytes, &image_path, yaml_path)
}

/// Builds a map from a parsed YAML description and the bytes of its image (PGM or PNG, told by
/// the magic number), as [`load_map`] does after reading the files; nothing is read from disk.
/// `image_path` and `yaml_path` are used in error messages only.
///
/// ```
/// use mapkeeper_grid::{CellState, map_io};
/// use std::path::Path;
/// let yaml = "image: m.pgm\nresolution: 0.5\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";
/// let meta = map_io::parse_map_yaml(yaml, Path::new("m.yaml")).unwrap();
/// let map = map_io::map_from_image_bytes(&meta, b"P2\n2 1\n255\n0 254\n", Path::new("m.pgm"), Path::new("m.yaml")).unwrap();
/// assert_eq!(map.cells(), &[CellState::Occupied, CellState::Free]);
/// ```
pub fn map_from_image_bytes(
    meta: &MapYaml,
    image_bytes: &[u8],
    image_path: &Path,
    yaml_path: &Path,
) -> Result<OccupancyGrid, MapIoError> {
    let image = decode_image(image_bytes, image_path)?;
    let geometry = GridGeometry::new(image.width, image.height, meta.resolution_m, meta.origin)
        .map_err(|source| MapIoError::Geometry { path: yaml_path.to_path_buf(), source })?;
    let mut cells = vec![CellState::Unknown; geometry.len()];
    for row in 0..image.height {
        // Image row 0 is the top of the map.
        let iy = image.height - 1 - row;
        for ix in 0..image.width {
            let px = image.pixels[row * image.width + ix];
            cells[iy * image.width + ix] = classify(px, meta);
        }
    }
    OccupancyGrid::from_cells(geometry, cells)
        .map_err(|source| MapIoError::Geometry { path: yaml_path.to_path_buf(), source })
}

/// Saves `grid` as `yaml_path` plus a trinary PGM beside it with the same stem
/// (`maps/m1.yaml` → `maps/m1.pgm`), each written atomically.
pub fn save_map(grid: &OccupancyGrid, yaml_path: &Path) -> Result<(), MapIoError> {
    let g = grid.geometry();
    let stem = yaml_path.file_stem().map(|s| s.to_string_lossy().into_owned()).ok_or_else(|| MapIoError::Io {
        path: yaml_path.to_path_buf(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidInput, "map path has no file name"),
    })?;
    let pgm_name = format!("{stem}.pgm");
    let pgm_path = yaml_path.with_file_name(&pgm_name);

    let mut pgm = Vec::with_capacity(g.len() + 32);
    let _ = write!(pgm, "P5\n{} {}\n255\n", g.width(), g.height());
    for row in 0..g.height() {
        let iy = g.height() - 1 - row;
        pgm.extend(grid.cells()[iy * g.width()..(iy + 1) * g.width()].iter().map(|s| match s {
            CellState::Free => PGM_FREE,
            CellState::Occupied => PGM_OCCUPIED,
            CellState::Unknown => PGM_UNKNOWN,
        }));
    }
    let o = g.origin();
    let mut yaml = String::new();
    let _ = writeln!(yaml, "image: {pgm_name}");
    let _ = writeln!(yaml, "mode: trinary");
    let _ = writeln!(yaml, "resolution: {}", g.resolution_m());
    let _ = writeln!(yaml, "origin: [{}, {}, {}]", o.x, o.y, o.yaw);
    let _ = writeln!(yaml, "negate: 0");
    let _ = writeln!(yaml, "occupied_thresh: 0.65");
    let _ = writeln!(yaml, "free_thresh: 0.196");
    // The image first, the YAML last: a YAML that exists names a complete image.
    write_atomic(&pgm_path, &pgm)?;
    write_atomic(yaml_path, yaml.as_bytes())
}

/// Writes `bytes` to `path` atomically ([`crate::write_atomic`]), naming the file on error.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), MapIoError> {
    crate::write_atomic(path, bytes).map_err(|source| MapIoError::Io { path: path.to_path_buf(), source })
}

fn classify(px: Pixel, meta: &MapYaml) -> CellState {
    match meta.mode {
        MapMode::Raw => match px.shade {
            0 => CellState::Free,
            100 => CellState::Occupied,
            _ => CellState::Unknown,
        },
        MapMode::Trinary | MapMode::Scale => {
            if meta.mode == MapMode::Scale && px.alpha == 0 {
                return CellState::Unknown;
            }
            let v = px.shade as f64;
            let p = if meta.negate { v / 255.0 } else { (255.0 - v) / 255.0 };
            if p >= meta.occupied_thresh {
                CellState::Occupied
            } else if p <= meta.free_thresh {
                CellState::Free
            } else {
                CellState::Unknown
            }
        }
    }
}

fn resolve_image_path(yaml_path: &Path, image: &str) -> PathBuf {
    let p = Path::new(image);
    if p.is_absolute() { p.to_path_buf() } else { yaml_path.parent().unwrap_or(Path::new("")).join(p) }
}

fn read_limited(path: &Path, max: u64) -> Result<Vec<u8>, MapIoError> {
    use std::io::Read as _;
    let io = |source| MapIoError::Io { path: path.to_path_buf(), source };
    let f = std::fs::File::open(path).map_err(io)?;
    let mut buf = Vec::new();
    f.take(max + 1).read_to_end(&mut buf).map_err(io)?;
    if buf.len() as u64 > max {
        return Err(MapIoError::Io {
            path: path.to_path_buf(),
            source: std::io::Error::new(std::io::ErrorKind::InvalidData, format!("file larger than {max} bytes")),
        });
    }
    Ok(buf)
}

fn line_of_offset(bytes: &[u8], offset: usize) -> usize {
    1 + bytes[..offset.min(bytes.len())].iter().filter(|&&b| b == b'\n').count()
}

// ---------------------------------------------------------------------------------------------
// YAML: the flat subset map_server files use (scalars, flow or block lists of numbers, comments).

/// A YAML value of the subset map files use.
#[derive(Clone, Debug, PartialEq)]
enum Value {
    Scalar(String),
    List(Vec<String>),
}

/// The `key: value` entries of a map_server YAML file (scalars, flow lists `[a, b]` and block
/// lists), each with its line; no key twice.
fn yaml_entries(text: &str, path: &Path) -> Result<Vec<(String, Value, usize)>, MapIoError> {
    let err = |line: usize, message: String| MapIoError::Yaml { path: path.to_path_buf(), line, message };
    let mut entries: Vec<(String, Value, usize)> = Vec::new();
    let lines: Vec<&str> = text.lines().collect();
    let mut i = 0;
    while i < lines.len() {
        let line_no = i + 1;
        let line = strip_comment(lines[i]);
        i += 1;
        let trimmed = line.trim();
        if trimmed.is_empty() || trimmed == "---" || trimmed == "..." {
            continue;
        }
        if line.starts_with([' ', '\t']) {
            return Err(err(line_no, format!("unexpected indented line '{trimmed}'")));
        }
        let Some((key, rest)) = trimmed.split_once(':') else {
            return Err(err(line_no, format!("expected 'key: value', found '{trimmed}'")));
        };
        let key = unquote(key.trim());
        if key.is_empty() {
            return Err(err(line_no, "empty key".into()));
        }
        if entries.iter().any(|(k, _, _)| *k == key) {
            return Err(err(line_no, format!("duplicate key '{key}'")));
        }
        let rest = rest.trim();
        let value = if rest.is_empty() {
            // A block list may follow.
            let mut items = Vec::new();
            while i < lines.len() {
                let l = strip_comment(lines[i]);
                let t = l.trim();
                if t.is_empty() {
                    i += 1;
                    continue;
                }
                match t.strip_prefix('-') {
                    Some(item) if l.starts_with([' ', '\t', '-']) => {
                        items.push(unquote(item.trim()));
                        i += 1;
                    }
                    _ => break,
                }
            }
            if items.is_empty() {
                return Err(err(line_no, format!("key '{key}' has no value")));
            }
            Value::List(items)
        } else if let Some(inner) = rest.strip_prefix('[') {
            let Some(inner) = inner.strip_suffix(']') else {
                return Err(err(line_no, format!("unterminated list for key '{key}'")));
            };
            if inner.trim().is_empty() {
                Value::List(Vec::new())
            } else {
                Value::List(inner.split(',').map(|s| unquote(s.trim())).collect())
            }
        } else {
            Value::Scalar(unquote(rest))
        };
        entries.push((key, value, line_no));
    }
    Ok(entries)
}

/// Parses the text of a map_server YAML file. `path` is used in error messages only.
pub fn parse_map_yaml(text: &str, path: &Path) -> Result<MapYaml, MapIoError> {
    let entries = yaml_entries(text, path)?;
    let get = |key: &str| entries.iter().find(|(k, _, _)| k == key).map(|(_, v, _)| v);
    // Every bad value belongs to a key that is present: its line names the place.
    let line_of = |key: &str| entries.iter().find(|(k, _, _)| k == key).map_or(0, |(_, _, l)| *l);
    let bad = |key: &'static str, message: String| MapIoError::BadValue {
        path: path.to_path_buf(),
        line: line_of(key),
        key,
        message,
    };
    let missing = |key: &'static str| MapIoError::MissingKey { path: path.to_path_buf(), key };
    let scalar = |key: &'static str| -> Result<Option<&str>, MapIoError> {
        match get(key) {
            None => Ok(None),
            Some(Value::Scalar(s)) => Ok(Some(s.as_str())),
            Some(Value::List(_)) => Err(bad(key, "expected a single value, found a list".into())),
        }
    };
    let number = |key: &'static str| -> Result<Option<f64>, MapIoError> {
        scalar(key)?
            .map(|s| {
                s.parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| bad(key, format!("expected a finite number, found '{s}'")))
            })
            .transpose()
    };

    let image = scalar("image")?.ok_or_else(|| missing("image"))?.to_string();
    if image.is_empty() {
        return Err(bad("image", "empty image path".into()));
    }
    let resolution_m = number("resolution")?.ok_or_else(|| missing("resolution"))?;
    let (min_res, max_res) = MAP_RESOLUTION_M;
    if !(min_res..=max_res).contains(&resolution_m) {
        return Err(bad("resolution", format!("must lie in [{min_res}, {max_res}] m per cell, found {resolution_m}")));
    }
    let origin = match get("origin") {
        None => return Err(missing("origin")),
        Some(Value::Scalar(s)) => return Err(bad("origin", format!("expected a list [x, y, yaw], found '{s}'"))),
        Some(Value::List(items)) => {
            if items.len() != 3 {
                return Err(bad("origin", format!("expected 3 numbers [x, y, yaw], found {}", items.len())));
            }
            let mut v = [0.0; 3];
            for (slot, s) in v.iter_mut().zip(items) {
                *slot = s
                    .parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| bad("origin", format!("expected a finite number, found '{s}'")))?;
            }
            Pose2::new(v[0], v[1], v[2])
        }
    };
    let negate = match scalar("negate")? {
        None => false,
        Some("0" | "false" | "False" | "FALSE") => false,
        Some("1" | "true" | "True" | "TRUE") => true,
        Some(s) => return Err(bad("negate", format!("expected 0 or 1, found '{s}'"))),
    };
    let occupied_thresh = number("occupied_thresh")?.ok_or_else(|| missing("occupied_thresh"))?;
    let free_thresh = number("free_thresh")?.ok_or_else(|| missing("free_thresh"))?;
    if !(0.0..=1.0).contains(&occupied_thresh) {
        return Err(bad("occupied_thresh", format!("must lie in [0, 1], found {occupied_thresh}")));
    }
    if !(0.0..=1.0).contains(&free_thresh) {
        return Err(bad("free_thresh", format!("must lie in [0, 1], found {free_thresh}")));
    }
    if free_thresh >= occupied_thresh {
        return Err(bad("free_thresh", format!("must be below occupied_thresh ({free_thresh} >= {occupied_thresh})")));
    }
    let mode = match scalar("mode")? {
        None | Some("trinary") => MapMode::Trinary,
        Some("scale") => MapMode::Scale,
        Some("raw") => MapMode::Raw,
        Some(s) => return Err(bad("mode", format!("expected trinary, scale or raw, found '{s}'"))),
    };
    Ok(MapYaml { image, resolution_m, origin, negate, occupied_thresh, free_thresh, mode })
}

/// Removes a `#` comment that is not inside quotes.
fn strip_comment(line: &str) -> &str {
    let mut quote = None;
    for (i, c) in line.char_indices() {
        match (quote, c) {
            (None, '"' | '\'') => quote = Some(c),
            (Some(q), c) if c == q => quote = None,
            (None, '#') if i == 0 || line[..i].ends_with([' ', '\t']) => return &line[..i],
            _ => {}
        }
    }
    line
}

fn unquote(s: &str) -> String {
    let b = s.as_bytes();
    if b.len() >= 2 && ((b[0] == b'"' && b[b.len() - 1] == b'"') || (b[0] == b'\'' && b[b.len() - 1] == b'\'')) {
        s[1..s.len() - 1].to_string()
    } else {
        s.to_string()
    }
}

// ---------------------------------------------------------------------------------------------
// Images.

#[derive(Clone, Copy, Debug, PartialEq)]
struct Pixel {
    shade: u8,
    alpha: u8,
}

struct Image {
    width: usize,
    height: usize,
    pixels: Vec<Pixel>,
}

fn check_size(path: &Path, width: usize, height: usize) -> Result<(), MapIoError> {
    if width == 0 || height == 0 {
        return Err(MapIoError::Image {
            path: path.to_path_buf(),
            message: format!("zero-size image ({width} × {height})"),
        });
    }
    if width > MAX_SIDE || height > MAX_SIDE || width.saturating_mul(height) > MAX_CELLS {
        return Err(MapIoError::Image {
            path: path.to_path_buf(),
            message: format!("image of {width} × {height} pixels exceeds the limit of {MAX_CELLS} cells"),
        });
    }
    Ok(())
}

fn decode_image(bytes: &[u8], path: &Path) -> Result<Image, MapIoError> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        decode_png(bytes, path)
    } else if bytes.starts_with(b"P5") || bytes.starts_with(b"P2") {
        decode_pgm(bytes, path)
    } else {
        Err(MapIoError::Image {
            path: path.to_path_buf(),
            message: "not a PGM (P5/P2) or PNG image (unrecognised magic number)".into(),
        })
    }
}

/// Decodes a binary (P5) or ASCII (P2) PGM, with `#` comments in the header.
fn decode_pgm(bytes: &[u8], path: &Path) -> Result<Image, MapIoError> {
    let err = |message: String| MapIoError::Image { path: path.to_path_buf(), message };
    let ascii = bytes.starts_with(b"P2");
    let mut pos = 2;
    // Reads the next whitespace-separated header token, skipping comments.
    let next_token = |pos: &mut usize, what: &str| -> Result<u64, MapIoError> {
        loop {
            match bytes.get(*pos) {
                Some(b) if b.is_ascii_whitespace() => *pos += 1,
                Some(b'#') => {
                    while bytes.get(*pos).is_some_and(|&b| b != b'\n') {
                        *pos += 1;
                    }
                }
                Some(_) => break,
                None => return Err(err(format!("truncated PGM header: missing {what}"))),
            }
        }
        let start = *pos;
        while bytes.get(*pos).is_some_and(|b| b.is_ascii_digit()) {
            *pos += 1;
        }
        if start == *pos {
            return Err(err(format!("bad PGM header: expected {what} as a number")));
        }
        std::str::from_utf8(&bytes[start..*pos])
            .ok()
            .and_then(|s| s.parse::<u64>().ok())
            .ok_or_else(|| err(format!("bad PGM header: {what} is too large")))
    };
    let width = next_token(&mut pos, "width")?;
    let height = next_token(&mut pos, "height")?;
    let maxval = next_token(&mut pos, "maxval")?;
    let (width, height) = (usize::try_from(width).unwrap_or(usize::MAX), usize::try_from(height).unwrap_or(usize::MAX));
    check_size(path, width, height)?;
    if maxval == 0 || maxval > 65535 {
        return Err(err(format!("PGM maxval must be 1-65535, found {maxval}")));
    }
    let n = width * height;
    let scale = |v: u64| -> u8 { ((v * 255 + maxval / 2) / maxval) as u8 };
    if ascii && n > bytes.len().saturating_sub(pos).div_ceil(2) {
        // Each P2 value takes a digit and a separator: a header promising more pixels than the
        // file can hold is refused before the raster is allocated.
        return Err(err(format!(
            "truncated P2 data: {} bytes after the header cannot hold {width} × {height} pixel values",
            bytes.len().saturating_sub(pos)
        )));
    }
    let mut pixels = Vec::with_capacity(n);
    if ascii {
        let mut p = pos;
        for k in 0..n {
            let v = next_token(&mut p, "pixel value")
                .map_err(|_| err(format!("truncated or malformed P2 data: {k} of {n} pixel values readable")))?;
            if v > maxval {
                return Err(err(over_maxval(k, width, &format!("the value ending before byte {p}"), v, maxval)));
            }
            pixels.push(Pixel { shade: scale(v), alpha: 255 });
        }
    } else {
        // Exactly one whitespace byte separates the header from the raster.
        match bytes.get(pos) {
            Some(b) if b.is_ascii_whitespace() => pos += 1,
            _ => return Err(err("truncated PGM: no raster after the header".into())),
        }
        let bytes_per = if maxval < 256 { 1 } else { 2 };
        let data = &bytes[pos..];
        if data.len() < n * bytes_per {
            return Err(err(format!(
                "truncated PGM raster: {} bytes for {width} × {height} pixels at {bytes_per} byte(s) each (need {})",
                data.len(),
                n * bytes_per
            )));
        }
        for k in 0..n {
            let v = if bytes_per == 1 { data[k] as u64 } else { ((data[2 * k] as u64) << 8) | data[2 * k + 1] as u64 };
            if v > maxval {
                return Err(err(over_maxval(k, width, &format!("byte {}", pos + k * bytes_per), v, maxval)));
            }
            pixels.push(Pixel { shade: scale(v), alpha: 255 });
        }
    }
    Ok(Image { width, height, pixels })
}

/// The message for pixel `k` of an image `width` wide whose value `v` (found at `place`)
/// exceeds `maxval`.
fn over_maxval(k: usize, width: usize, place: &str, v: u64, maxval: u64) -> String {
    format!("pixel {k} (image row {}, column {}; {place}): value {v} exceeds maxval {maxval}", k / width, k % width)
}

fn decode_png(bytes: &[u8], path: &Path) -> Result<Image, MapIoError> {
    let err = |message: String| MapIoError::Image { path: path.to_path_buf(), message };
    let mut decoder = png::Decoder::new_with_limits(std::io::Cursor::new(bytes), png::Limits { bytes: 64 << 20 });
    decoder.set_transformations(png::Transformations::normalize_to_color8());
    let header = decoder.read_header_info().map_err(|e| err(format!("bad PNG: {e}")))?;
    let (width, height) = (header.width as usize, header.height as usize);
    check_size(path, width, height)?;
    let mut reader = decoder.read_info().map_err(|e| err(format!("bad PNG: {e}")))?;
    let size = reader.output_buffer_size().ok_or_else(|| err("PNG too large".into()))?;
    let mut buf = vec![0u8; size];
    let frame = reader.next_frame(&mut buf).map_err(|e| err(format!("bad PNG data: {e}")))?;
    let (color, _) = reader.output_color_type();
    let channels = color.samples();
    let line = frame.line_size;
    if frame.width as usize != width || frame.height as usize != height || line < width * channels {
        return Err(err("PNG frame does not match its header".into()));
    }
    let mut pixels = Vec::with_capacity(width * height);
    for row in 0..height {
        let r = &buf[row * line..row * line + width * channels];
        for px in r.chunks_exact(channels) {
            let (shade, alpha) = match px {
                [g] => (*g, 255),
                [g, a] => (*g, *a),
                [r, g, b] => (((*r as u16 + *g as u16 + *b as u16) / 3) as u8, 255),
                [r, g, b, a] => (((*r as u16 + *g as u16 + *b as u16) / 3) as u8, *a),
                _ => return Err(err(format!("unsupported PNG colour type {color:?}"))),
            };
            pixels.push(Pixel { shade, alpha });
        }
    }
    Ok(Image { width, height, pixels })
}

#[cfg(test)]
mod tests;
