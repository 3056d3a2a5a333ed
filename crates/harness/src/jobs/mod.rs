//! Whole replay jobs over a recorded log, each one call for the command line: localise,
//! update, map; and the odometry a log with scans only lacks ([`scan_odometry`]). Each replay is a [`LogSource`](crate::LogSource), a session and observers run by
//! [`crate::run`].

pub mod localise;
pub mod map;
pub mod odometry_drift;
pub mod scan_odometry;
pub mod update;

/// The random stream of the chain localiser of a replay, named as the closed loop names its
/// streams (`chain/<world>`): the filter of `localise` and of `update --localise` draws from
/// `stream_seed(seed, "chain/replay")`, not from the raw seed, so that another stream added
/// to a replay shifts none of the others.
pub const CHAIN_STREAM: &str = "chain/replay";

/// The seed of the replay's chain localiser for the run seed `seed` ([`CHAIN_STREAM`]).
pub fn chain_seed(seed: u64) -> u64 {
    mapkeeper_common::stream_seed(seed, CHAIN_STREAM)
}

/// `ns` as seconds with 9 decimals, exactly (the time column of the jobs' tables).
pub fn seconds(ns: u64) -> String {
    format!("{}.{:09}", ns / 1_000_000_000, ns % 1_000_000_000)
}

#[cfg(test)]
mod tests {
    #[test]
    fn seconds_are_exact() {
        assert_eq!(super::seconds(0), "0.000000000");
        assert_eq!(super::seconds(12_000_000_345), "12.000000345");
    }
}
