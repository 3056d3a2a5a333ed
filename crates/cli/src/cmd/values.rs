//! The value parsers of the flags shared by every command: counts, seeds, bounded reals,
//! resolutions, poses, and the bounds they enforce.

use mapkeeper_grid::Pose2;

/// Largest |x| and |y| of a pose flag, metres: 1000 km, the side of the largest grid
/// ([`mapkeeper_grid::MAX_SIDE`] = 2^20 cells) at 1 m per cell.
pub const MAX_POSE_XY_M: f64 = 1e6;
/// Largest |yaw| of a pose flag, radians: a turn (2π) rounded up; a larger value is most
/// likely degrees.
pub const MAX_POSE_YAW_RAD: f64 = 6.3;
/// Largest `--jobs`: far more threads than any machine here has cores (each thread is an OS
/// thread; the work is split by seed or run, so more threads than jobs gain nothing).
pub const MAX_JOBS: usize = 1024;
/// Largest `--worlds` of `validate` and `generate`: 100 × the paper's hundred worlds (hours of
/// work per seed, and a ground-truth map per world on disk); larger values only hang.
pub const MAX_WORLDS: usize = 10_000;
/// Largest number of seeds of `validate --seeds` and `converge --seeds` (each seed is a full
/// run; the job list is held in memory).
pub const MAX_SEEDS: usize = 100_000;
/// The range of map resolutions, metres per cell: that of map files
/// ([`mapkeeper_grid::map_io::MAP_RESOLUTION_M`]; 5 mm is below the simulated lidars' 1 cm range
/// quantisation and 3 cm noise, 10 m leaves a handful of cells per map).
pub const RESOLUTION_M: (f64, f64) = mapkeeper_grid::map_io::MAP_RESOLUTION_M;
/// Largest route length of `--route-length`, metres: 10 km, far more than the 72 m default
/// tour (a longer value drives the whole route).
pub const MAX_ROUTE_LENGTH_M: f64 = 10_000.0;
/// Largest start error, metres: larger than the warehouse (15 m × 22 m) many times over.
pub const MAX_START_ERROR_M: f64 = 100.0;

/// How a refused value is shown after "got".
fn shown(s: &str) -> String {
    if s.is_empty() { "an empty value".to_string() } else { s.to_string() }
}

/// A bound with its unit (`"m"`, `"s"` or none).
fn with_unit(v: f64, unit: &str) -> String {
    if unit.is_empty() { v.to_string() } else { format!("{v} {unit}") }
}

/// A value parser for a whole number in `lo..=hi` (counts: worlds, trials, jobs, …): refuses
/// signs, fractions, NaN, empty and out-of-range values with a message stating the range.
pub fn count_in(lo: usize, hi: usize) -> impl Fn(&str) -> Result<usize, String> + Clone + Send + Sync + 'static {
    move |s: &str| match s.trim().parse::<usize>() {
        Ok(v) if (lo..=hi).contains(&v) => Ok(v),
        _ => Err(format!("must be a whole number from {lo} to {hi}, got {}", shown(s))),
    }
}

/// A seed: any whole number from 0 to 2^64 − 1 (every seed is a valid stream).
pub fn seed(s: &str) -> Result<u64, String> {
    s.trim().parse::<u64>().map_err(|_| format!("must be a whole number from 0 to {}, got {}", u64::MAX, shown(s)))
}

/// A value parser for a finite number in `[lo, hi]` (`unit` is shown with the bounds).
pub fn real_in(lo: f64, hi: f64, unit: &'static str) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync {
    move |s: &str| match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && (lo..=hi).contains(&v) => Ok(v),
        _ => Err(format!(
            "must be a finite number from {} to {}, got {}",
            with_unit(lo, unit),
            with_unit(hi, unit),
            shown(s)
        )),
    }
}

/// A value parser for a finite number in `(0, hi]` (`unit` is shown with the bound).
pub fn positive_up_to(hi: f64, unit: &'static str) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync {
    move |s: &str| match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v <= hi => Ok(v),
        _ => Err(format!("must be a finite number > 0 and ≤ {}, got {}", with_unit(hi, unit), shown(s))),
    }
}

/// A map resolution in [`RESOLUTION_M`], metres per cell.
pub fn resolution(s: &str) -> Result<f64, String> {
    real_in(RESOLUTION_M.0, RESOLUTION_M.1, "m")(s)
}

/// `--jobs`: 1 to [`MAX_JOBS`] threads (leave the flag out for all cores).
pub fn jobs(s: &str) -> Result<usize, String> {
    count_in(1, MAX_JOBS)(s).map_err(|e| format!("{e}; leave --jobs out for all cores"))
}

/// `--route-length`: (0, [`MAX_ROUTE_LENGTH_M`]] metres.
pub fn route_length(s: &str) -> Result<f64, String> {
    positive_up_to(MAX_ROUTE_LENGTH_M, "m")(s)
}

/// Parses `x,y,yaw`: three finite numbers, |x|, |y| ≤ [`MAX_POSE_XY_M`] metres and |yaw| ≤
/// [`MAX_POSE_YAW_RAD`] radians.
pub fn parse_pose(s: &str) -> Result<Pose2, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!("expected x,y,yaw (three comma-separated numbers), got {}", shown(s)));
    }
    let mut v = [0.0; 3];
    let limits = [("x", MAX_POSE_XY_M, "m"), ("y", MAX_POSE_XY_M, "m"), ("yaw", MAX_POSE_YAW_RAD, "rad")];
    for ((slot, p), (name, max, unit)) in v.iter_mut().zip(&parts).zip(limits) {
        *slot = real_in(-max, max, unit)(p).map_err(|e| format!("{name} {e}"))?;
    }
    Ok(Pose2::new(v[0], v[1], v[2]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_poses() {
        assert_eq!(parse_pose("1, -2.5,0.3"), Ok(Pose2::new(1.0, -2.5, 0.3)));
        assert!(parse_pose("1,2").is_err());
        assert!(parse_pose("1,x,3").is_err());
        assert!(parse_pose("1,NaN,3").is_err());
    }

    #[test]
    fn poses_are_bounded() {
        assert!(parse_pose("1e6,-1e6,6.3").is_ok());
        for bad in ["1e7,0,0", "0,0,7", "0,,0", "0,0,0,0", "", "inf,0,0"] {
            assert!(parse_pose(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn counts_are_whole_numbers_in_range() {
        let worlds = count_in(2, MAX_WORLDS);
        assert_eq!(worlds("2"), Ok(2));
        assert_eq!(worlds(" 10000 "), Ok(10_000));
        for bad in ["1", "10001", "-1", "2.5", "1e3", "NaN", "", "abc", "18446744073709551616"] {
            let e = worlds(bad).unwrap_err();
            assert!(e.contains("from 2 to 10000"), "{bad}: {e}");
        }
        assert_eq!(seed("0"), Ok(0));
        assert_eq!(seed("18446744073709551615"), Ok(u64::MAX));
        for bad in ["-1", "18446744073709551616", "1e3", "nan", ""] {
            assert!(seed(bad).is_err(), "{bad}");
        }
        assert!(jobs("0").unwrap_err().contains("leave --jobs out"));
    }

    #[test]
    fn reals_refuse_nan_infinite_and_out_of_range() {
        assert_eq!(resolution("0.05"), Ok(0.05));
        assert_eq!(real_in(0.0, 1.0, "")("0"), Ok(0.0));
        assert_eq!(positive_up_to(10.0, "s")("10"), Ok(10.0));
        for bad in ["NaN", "nan", "inf", "-inf", "-1", "0", "1e308", "abc", "", "1,2", "0.001", "11"] {
            assert!(resolution(bad).is_err(), "{bad}");
        }
        assert_eq!(positive_up_to(10.0, "s")("0").unwrap_err(), "must be a finite number > 0 and ≤ 10 s, got 0");
        assert_eq!(real_in(0.0, 1.0, "")("").unwrap_err(), "must be a finite number from 0 to 1, got an empty value");
    }
}
