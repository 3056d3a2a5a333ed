//! `--seeds` of `converge`: a range or a list of run seeds.

/// A parsed `--seeds`.
#[derive(Clone, Debug)]
pub struct SeedList(pub Vec<u64>);

/// Parses `A-B` (inclusive, A ≤ B) or `S1,S2,…` (no repeats), at most [`crate::cmd::MAX_SEEDS`]
/// seeds, each a whole number from 0 to 2^64 − 1.
pub fn parse_seeds(s: &str) -> Result<SeedList, String> {
    let num = |p: &str| crate::cmd::seed(p).map_err(|e| format!("'{p}': {e}"));
    let max = crate::cmd::MAX_SEEDS;
    let seeds: Vec<u64> = if let Some((a, b)) = s.split_once('-') {
        let (a, b) = (num(a)?, num(b)?);
        if a > b || b - a >= max as u64 {
            return Err(format!("range '{s}' must be A-B with A ≤ B and at most {max} seeds"));
        }
        (a..=b).collect()
    } else {
        let parts: Vec<&str> = s.split(',').collect();
        if parts.len() > max {
            return Err(format!("at most {max} seeds, got {}", parts.len()));
        }
        parts.into_iter().map(num).collect::<Result<_, _>>()?
    };
    let mut seen = std::collections::HashSet::with_capacity(seeds.len());
    if let Some((i, d)) = seeds.iter().enumerate().find(|&(_, d)| !seen.insert(*d)) {
        return Err(format!("seed {d} given twice (entry {})", i + 1));
    }
    Ok(SeedList(seeds))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeds_parse_as_ranges_and_lists() {
        assert_eq!(parse_seeds("1-3").unwrap().0, vec![1, 2, 3]);
        assert_eq!(parse_seeds("4,2").unwrap().0, vec![4, 2]);
        assert_eq!(parse_seeds("7").unwrap().0, vec![7]);
        assert_eq!(parse_seeds("0-99999").unwrap().0.len(), 100_000);
        for bad in ["3-1", "x", "1,1", "1-", "", "-1", "0-100000", "1e3", "18446744073709551616", "1,,2"] {
            assert!(parse_seeds(bad).is_err(), "{bad}");
        }
    }
}
