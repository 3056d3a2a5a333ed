//! The hook through which a removal vote of §4.3.1 may be withheld: the paper's changed cells
//! evaluator asks a [`RemovalFilter`] about every non-free cell a detected-change ray crosses.
//! The paper itself withholds nothing ([`PassAll`]); the project's gates
//! (the `mapkeeper` addition `additions::removal_gates`) plug in here.

use mapkeeper_grid::{CellCoord, Point2};

/// What a removal filter decides for one detected-change ray, fed the ray's non-free cells in
/// walk order.
pub trait RemovalFilter {
    /// Takes the next non-free cell `c` the ray visits and says whether it is hidden (no vote,
    /// nothing else asked).
    fn in_shadow(&mut self, c: CellCoord) -> bool;

    /// Whether the vote of cell `c` (centre `centre`), which passed the paper's own tests so far,
    /// passes the filter.
    fn passes(&mut self, c: CellCoord, centre: Point2) -> bool;
}

/// The paper's removal: every vote passes.
#[derive(Clone, Copy, Debug, Default)]
pub struct PassAll;

impl RemovalFilter for PassAll {
    #[inline]
    fn in_shadow(&mut self, _: CellCoord) -> bool {
        false
    }

    #[inline]
    fn passes(&mut self, _: CellCoord, _: Point2) -> bool {
        true
    }
}
