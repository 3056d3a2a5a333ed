//! Real scans, known truth (issue 52): the updater and pose recovery judged on real logs with
//! reference poses. G is the map at the reference poses; a seeded edit generator makes a stale
//! map M_1 of the real place ([`edits`]); the log replayed again and again is the chain of worlds
//! W_2 … W_K, each pass localising on M_{k-1} and updating it into M_k ([`chain`]); and a log
//! spliced so that the odometry carries no motion across a cut is a real kidnap ([`splice`],
//! [`kidnap`]).

pub mod chain;
pub mod edits;
pub mod kidnap;
pub mod splice;
#[cfg(test)]
mod test_logs;
