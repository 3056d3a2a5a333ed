//! Time spent by the estimators is measured only through an injected [`Clock`]: library code
//! reads no wall clock, so outputs stay bit-identical unless the caller asks for timings.

/// A monotonic clock in nanoseconds, injected by the caller (library code reads no clock).
pub trait Clock: Sync {
    /// Nanoseconds since an arbitrary origin; 0 means "no clock".
    fn now_ns(&self) -> u64;
}

/// The clock that always says 0: timings come out as 0 and outputs stay bit-identical.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoClock;

impl Clock for NoClock {
    fn now_ns(&self) -> u64 {
        0
    }
}
