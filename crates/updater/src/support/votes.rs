//! Votes of one step: one `u32` per (cell, flag) vote, packed as `index << 1 | changed`, so a
//! plain sort groups a cell's votes and the cells update (§4.5) reduces them in one pass. Shared
//! by the evaluators of §4.3 and §4.4, the free-pass votes and the cells update.

use crate::support::cell_buffers::CellBuffers;
use mapkeeper_grid::CellCoord;

/// A vote of one beam on one cell during a step, packed as `index << 1 | changed`.
pub type Vote = u32;

/// Packs a vote.
#[inline]
pub fn vote(index: usize, changed: bool) -> Vote {
    ((index as u32) << 1) | changed as u32
}

/// Sorts `votes` (the same order as `sort_unstable`, by an LSD radix sort with 11-bit digits:
/// two passes for maps up to 2^21 cells) and creates a buffer for every cell with a "changed"
/// vote. `scratch` is reusable memory (its contents are overwritten; after the call it may hold
/// the allocation `votes` had).
pub fn ensure_buffers(votes: &mut Vec<Vote>, scratch: &mut Vec<Vote>, width: usize, buffers: &mut CellBuffers) {
    sort_votes(votes, scratch);
    let mut last = u32::MAX;
    for &v in votes.iter() {
        if v & 1 == 1 && v != last {
            last = v;
            let i = (v >> 1) as usize;
            buffers.ensure(i as u32, CellCoord::new((i % width) as i32, (i / width) as i32));
        }
    }
}

/// Sorts `votes` ascending; the result equals `votes.sort_unstable()` (a sorted `u32` sequence is
/// unique). Long inputs go through an LSD radix sort using `scratch`.
pub fn sort_votes(votes: &mut Vec<Vote>, scratch: &mut Vec<Vote>) {
    const BITS: u32 = 11;
    const MASK: u32 = (1 << BITS) - 1;
    if votes.len() < 256 {
        votes.sort_unstable();
        return;
    }
    let max = votes.iter().copied().max().unwrap_or(0);
    let bits = u32::BITS - max.leading_zeros();
    scratch.clear();
    scratch.resize(votes.len(), 0);
    let mut shift = 0;
    while shift < bits {
        let mut start = [0u32; 1 << BITS];
        for &v in votes.iter() {
            start[((v >> shift) & MASK) as usize] += 1;
        }
        let mut sum = 0;
        for c in start.iter_mut() {
            let n = *c;
            *c = sum;
            sum += n;
        }
        for &v in votes.iter() {
            let d = ((v >> shift) & MASK) as usize;
            scratch[start[d] as usize] = v;
            start[d] += 1;
        }
        std::mem::swap(votes, scratch);
        shift += BITS;
    }
}

/// Makes `votes` sorted when `votes[..split]` already is: sorts the tail and merges it in
/// (linear in the elements moved), using `scratch` for the tail.
pub fn merge_sorted_tail(votes: &mut [Vote], split: usize, scratch: &mut Vec<Vote>) {
    let split = split.min(votes.len());
    if split == votes.len() {
        return;
    }
    votes[split..].sort_unstable();
    if split == 0 || votes[split - 1] <= votes[split] {
        return;
    }
    scratch.clear();
    scratch.extend_from_slice(&votes[split..]);
    // Merge from the back: the largest remaining element goes to the end.
    let (mut i, mut j, mut k) = (split, scratch.len(), votes.len());
    while j > 0 {
        k -= 1;
        if i > 0 && votes[i - 1] > scratch[j - 1] {
            votes[k] = votes[i - 1];
            i -= 1;
        } else {
            votes[k] = scratch[j - 1];
            j -= 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vote_sorting_equals_sort_unstable() {
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let mut scratch = Vec::new();
        for (n, max) in [(0usize, 10u64), (5, 1 << 20), (300, 1 << 8), (3000, 1 << 19), (3000, 1 << 32), (700, 1 << 12)]
        {
            let v: Vec<Vote> = (0..n).map(|_| (next() % max) as Vote).collect();
            let mut want = v.clone();
            want.sort_unstable();
            let mut got = v.clone();
            sort_votes(&mut got, &mut scratch);
            assert_eq!(got, want, "n={n} max={max}");
            // Sorted prefix + unsorted tail, merged.
            for split in [0, n / 2, n.saturating_sub(7), n] {
                let mut m = v.clone();
                m[..split].sort_unstable();
                merge_sorted_tail(&mut m, split, &mut scratch);
                assert_eq!(m, want, "n={n} split={split}");
            }
        }
    }
}
