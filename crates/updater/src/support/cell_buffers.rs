//! Sparse rolling buffers B_{c_j} (introduced in §4 with Fig. 6, counted in §4.5): one compact
//! N_b-bit ring per cell that holds at least
//! one "changed" flag, created on the cell's first "changed" flag and dropped as soon as it
//! holds none. Memory is therefore proportional to the number of changed cells and N_b, not to
//! the map (the paper's claim, §6).
//!
//! A cell without a buffer that receives an "unchanged" flag would get a buffer with no
//! "changed" flag, to be dropped at once: so unchanged flags only matter for cells that already
//! have a buffer. To find those quickly along a ray, buffered cells are also marked in sparse
//! 16 × 16-cell tiles (a 256-bit mask per tile that holds a buffer); a ray looks its tile up
//! only when it enters a new tile.

use mapkeeper_grid::CellCoord;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// The last N_b flags of one cell (N_b ≤ 32), newest in bit 0; 1 = "changed".
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RollingBuffer {
    bits: u32,
    len: u8,
}

impl RollingBuffer {
    /// Pushes a flag, forgetting the oldest once `capacity` flags are held.
    #[inline]
    pub fn push(&mut self, changed: bool, capacity: u32) {
        let capacity = capacity.clamp(1, 32);
        let mask = if capacity == 32 { u32::MAX } else { (1u32 << capacity) - 1 };
        self.bits = ((self.bits << 1) | changed as u32) & mask;
        self.len = (self.len as u32 + 1).min(capacity) as u8;
    }

    /// n_c: "changed" flags held.
    #[inline]
    pub fn changed(&self) -> u32 {
        self.bits.count_ones()
    }

    /// "Unchanged" flags held.
    #[inline]
    pub fn unchanged(&self) -> u32 {
        self.len as u32 - self.changed()
    }

    /// Flags held.
    #[inline]
    pub fn len(&self) -> u32 {
        self.len as u32
    }

    /// Whether no flag is held.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// A multiplicative hasher for `u32` keys (cell indices, tile keys): deterministic and fast.
/// The maps using it are only looked up, never iterated into an output.
#[derive(Default, Clone, Copy)]
pub struct TileHasher(u64);

impl Hasher for TileHasher {
    fn finish(&self) -> u64 {
        self.0 ^ (self.0 >> 29)
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0.rotate_left(8) ^ b as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        }
    }
    fn write_u32(&mut self, i: u32) {
        self.0 = (self.0 ^ i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
}

/// Which cells of a 16 × 16 tile hold a buffer.
#[derive(Clone, Copy, Debug, Default)]
pub struct TileMask {
    bits: [u64; 4],
    count: u16,
}

impl TileMask {
    #[inline]
    fn bit(c: CellCoord) -> usize {
        (((c.iy & 15) << 4) | (c.ix & 15)) as usize
    }
    /// Whether `c` (a cell of this tile) holds a buffer.
    #[inline]
    pub fn contains(&self, c: CellCoord) -> bool {
        let b = Self::bit(c);
        self.bits[b >> 6] & (1u64 << (b & 63)) != 0
    }
}

#[inline]
fn tile_key(c: CellCoord) -> u32 {
    (((c.ix >> 4) as u32) << 16) | ((c.iy >> 4) as u32 & 0xffff)
}

type TileMap = HashMap<u32, TileMask, BuildHasherDefault<TileHasher>>;

/// The sparse buffers of all cells that hold a "changed" flag, keyed by the cell's linear index.
#[derive(Clone, Debug, Default)]
pub struct CellBuffers {
    buffers: HashMap<u32, RollingBuffer, BuildHasherDefault<TileHasher>>,
    tiles: TileMap,
}

/// Ray-coherent membership test: remembers the last tile looked up.
pub struct TileProbe<'a> {
    tiles: &'a TileMap,
    key: u32,
    mask: Option<&'a TileMask>,
}

impl<'a> TileProbe<'a> {
    /// Whether `c` holds a buffer.
    #[inline]
    pub fn contains(&mut self, c: CellCoord) -> bool {
        self.tile(c).is_some_and(|m| m.contains(c))
    }

    /// The mask of the tile that holds `c`, if any cell of that tile holds a buffer.
    #[inline]
    pub fn tile(&mut self, c: CellCoord) -> Option<&'a TileMask> {
        let key = tile_key(c);
        if key != self.key {
            self.key = key;
            self.mask = self.tiles.get(&key);
        }
        self.mask
    }
}

impl CellBuffers {
    /// No buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of buffered cells.
    pub fn len(&self) -> usize {
        self.buffers.len()
    }

    /// Whether no cell holds a buffer.
    pub fn is_empty(&self) -> bool {
        self.buffers.is_empty()
    }

    /// The buffer of the cell with linear index `index`.
    #[inline]
    pub fn get(&self, index: u32) -> Option<&RollingBuffer> {
        self.buffers.get(&index)
    }

    /// A membership probe for walking along a ray.
    pub fn probe(&self) -> TileProbe<'_> {
        TileProbe { tiles: &self.tiles, key: u32::MAX, mask: None }
    }

    /// Side of a tile, cells.
    pub const TILE_CELLS: i32 = 16;

    /// The lower-left cell of every tile that holds at least one buffer (unordered; callers
    /// must not let this order reach an output).
    pub fn tile_origins(&self) -> impl Iterator<Item = CellCoord> + Clone + '_ {
        self.tiles.keys().map(|&k| CellCoord::new(((k >> 16) as i32) << 4, ((k & 0xffff) as i32) << 4))
    }

    /// For every tile that holds a buffer, the lowest and the highest cell (inclusive) of the
    /// bounding box of its buffered cells (unordered, like [`CellBuffers::tile_origins`]).
    pub fn tile_boxes(&self) -> impl Iterator<Item = (CellCoord, CellCoord)> + Clone + '_ {
        self.tiles.iter().map(|(&k, m)| {
            let (x0, y0) = (((k >> 16) as i32) << 4, ((k & 0xffff) as i32) << 4);
            // Rows: 16 bits each, four to a word.
            let row = |y: usize| (m.bits[y / 4] >> ((y % 4) * 16)) as u16;
            let (mut cols, mut y_lo, mut y_hi) = (0u16, 16, 0);
            for y in 0..16 {
                let bits = row(y);
                if bits != 0 {
                    cols |= bits;
                    y_lo = y_lo.min(y);
                    y_hi = y;
                }
            }
            let (x_lo, x_hi) = (cols.trailing_zeros() as i32, 15 - cols.leading_zeros() as i32);
            (CellCoord::new(x0 + x_lo, y0 + y_lo as i32), CellCoord::new(x0 + x_hi, y0 + y_hi as i32))
        })
    }

    /// Creates an empty buffer for the cell if it has none.
    pub fn ensure(&mut self, index: u32, cell: CellCoord) {
        if let std::collections::hash_map::Entry::Vacant(e) = self.buffers.entry(index) {
            e.insert(RollingBuffer::default());
            let t = self.tiles.entry(tile_key(cell)).or_default();
            let b = TileMask::bit(cell);
            t.bits[b >> 6] |= 1u64 << (b & 63);
            t.count += 1;
        }
    }

    /// Pushes a flag into the cell's buffer (creating it for a "changed" flag), returns the
    /// buffer after the push, and drops it if it holds no "changed" flag any more (then the
    /// returned copy is the last state).
    pub fn push(&mut self, index: u32, cell: CellCoord, changed: bool, capacity: u32) -> Option<RollingBuffer> {
        if changed {
            self.ensure(index, cell);
        }
        let b = self.buffers.get_mut(&index)?;
        b.push(changed, capacity);
        let out = *b;
        if out.changed() == 0 {
            self.remove(index, cell);
        }
        Some(out)
    }

    /// Drops the cell's buffer.
    pub fn remove(&mut self, index: u32, cell: CellCoord) {
        if self.buffers.remove(&index).is_some() {
            let key = tile_key(cell);
            if let Some(t) = self.tiles.get_mut(&key) {
                let b = TileMask::bit(cell);
                t.bits[b >> 6] &= !(1u64 << (b & 63));
                t.count = t.count.saturating_sub(1);
                if t.count == 0 {
                    self.tiles.remove(&key);
                }
            }
        }
    }

    /// Payload bytes of the sparse state: keys and values of the buffers and the tile masks.
    /// Depends only on how many cells (and tiles) hold a buffer, never on the map size.
    pub fn state_bytes(&self) -> usize {
        self.buffers.len() * (size_of::<u32>() + size_of::<RollingBuffer>())
            + self.tiles.len() * (size_of::<u32>() + size_of::<TileMask>())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ring_forgets_oldest_and_counts() {
        let mut b = RollingBuffer::default();
        for _ in 0..7 {
            b.push(true, 10);
        }
        assert_eq!((b.changed(), b.unchanged(), b.len()), (7, 0, 7));
        for _ in 0..3 {
            b.push(false, 10);
        }
        assert_eq!((b.changed(), b.unchanged(), b.len()), (7, 3, 10));
        b.push(false, 10); // the first "changed" falls out
        assert_eq!((b.changed(), b.unchanged(), b.len()), (6, 4, 10));
        let mut full = RollingBuffer::default();
        for _ in 0..40 {
            full.push(true, 32);
        }
        assert_eq!(full.changed(), 32);
    }

    #[test]
    fn tile_boxes_bound_the_buffered_cells() {
        let mut bufs = CellBuffers::new();
        for (i, c) in [
            (1, CellCoord::new(17, 33)),
            (2, CellCoord::new(20, 40)),
            (3, CellCoord::new(18, 35)),
            (4, CellCoord::new(3, 2)),
        ] {
            bufs.ensure(i, c);
        }
        let mut boxes: Vec<_> = bufs.tile_boxes().collect();
        boxes.sort();
        assert_eq!(
            boxes,
            vec![(CellCoord::new(3, 2), CellCoord::new(3, 2)), (CellCoord::new(17, 33), CellCoord::new(20, 40)),]
        );
    }

    #[test]
    fn created_on_changed_dropped_without_changed() {
        let mut bufs = CellBuffers::new();
        let c = CellCoord::new(17, 33);
        assert!(bufs.push(5, c, false, 10).is_none());
        assert!(bufs.is_empty());
        bufs.push(5, c, true, 10);
        assert_eq!(bufs.len(), 1);
        assert!(bufs.probe().contains(c));
        assert!(!bufs.probe().contains(CellCoord::new(18, 33)));
        for _ in 0..9 {
            bufs.push(5, c, false, 10);
        }
        assert_eq!(bufs.len(), 1);
        bufs.push(5, c, false, 10);
        assert!(bufs.is_empty());
        assert!(!bufs.probe().contains(c));
        assert_eq!(bufs.state_bytes(), 0);
    }
}
