//! The chessboard (8-neighbour) distance transform of a raster in two passes, shared by pose
//! updating's score grid and the global search's pyramid.

/// A cell value of the transform: a distance that saturates instead of overflowing.
pub trait Distance: Copy + Ord {
    /// One more, saturating.
    fn step(self) -> Self;
}

impl Distance for u8 {
    fn step(self) -> Self {
        self.saturating_add(1)
    }
}

impl Distance for u16 {
    fn step(self) -> Self {
        self.saturating_add(1)
    }
}

/// In place: every cell of the `w` × `h` raster `d` (row-major) becomes the smallest of its own
/// value and, for every other cell, that cell's value plus its chessboard distance. Seed the
/// sources with 0 and every other cell with a cap to get the chessboard distance to the nearest
/// source, capped.
pub fn chessboard_distance<T: Distance>(d: &mut [T], w: usize, h: usize) {
    debug_assert_eq!(d.len(), w * h);
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let mut m = d[i];
            if x > 0 {
                m = m.min(d[i - 1].step());
            }
            if y > 0 {
                let up = i - w;
                m = m.min(d[up].step());
                if x > 0 {
                    m = m.min(d[up - 1].step());
                }
                if x + 1 < w {
                    m = m.min(d[up + 1].step());
                }
            }
            d[i] = m;
        }
    }
    for y in (0..h).rev() {
        for x in (0..w).rev() {
            let i = y * w + x;
            let mut m = d[i];
            if x + 1 < w {
                m = m.min(d[i + 1].step());
            }
            if y + 1 < h {
                let down = i + w;
                m = m.min(d[down].step());
                if x > 0 {
                    m = m.min(d[down - 1].step());
                }
                if x + 1 < w {
                    m = m.min(d[down + 1].step());
                }
            }
            d[i] = m;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against the definition: the distance to the nearest source is max(|dx|, |dy|).
    #[test]
    fn matches_the_brute_force_chessboard_distance_with_a_cap() {
        let (w, h) = (23, 17);
        let sources = [(3usize, 4usize), (19, 2), (11, 15), (0, 16)];
        for cap in [3u16, 7, 40] {
            let mut d = vec![cap; w * h];
            for &(x, y) in &sources {
                d[y * w + x] = 0;
            }
            chessboard_distance(&mut d, w, h);
            for y in 0..h {
                for x in 0..w {
                    let want = sources
                        .iter()
                        .map(|&(sx, sy)| x.abs_diff(sx).max(y.abs_diff(sy)) as u16)
                        .min()
                        .unwrap_or(cap)
                        .min(cap);
                    assert_eq!(d[y * w + x], want, "({x}, {y}), cap {cap}");
                }
            }
        }
        // u8 saturates instead of overflowing.
        let mut d = vec![255u8; 9];
        d[0] = 0;
        chessboard_distance(&mut d, 9, 1);
        assert_eq!(d, [0, 1, 2, 3, 4, 5, 6, 7, 8]);
    }
}
