//! The clocks of `mapkeeper bench`: the thread's and the process's CPU time, and the fixed
//! reference workload every row is compared with.

use super::*;

/// CPU seconds of the calling thread (`CLOCK_THREAD_CPUTIME_ID`: exact, not the scheduler's
/// tick-stale /proc figure).
pub(crate) fn thread_cpu_s() -> f64 {
    let t = rustix::time::clock_gettime(rustix::time::ClockId::ThreadCPUTime);
    t.tv_sec as f64 + t.tv_nsec as f64 / 1e9
}

/// CPU seconds of the whole process, every thread (`CLOCK_PROCESS_CPUTIME_ID`).
pub(super) fn process_cpu_s() -> f64 {
    let t = rustix::time::clock_gettime(rustix::time::ClockId::ProcessCPUTime);
    t.tv_sec as f64 + t.tv_nsec as f64 / 1e9
}

/// Times `f` on the calling thread's CPU clock; returns (seconds, what `f` returned).
pub(super) fn timed<T>(f: impl FnOnce() -> T) -> (f64, T) {
    let t0 = thread_cpu_s();
    let out = f();
    (thread_cpu_s() - t0, out)
}

/// The reference: a fixed workload of integer sorting and dependent floating-point arithmetic,
/// independent of the project's code, so that its time tracks the machine and its load only.
pub(crate) fn reference_workload() -> f64 {
    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut v: Vec<u64> = (0..1 << 17)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        })
        .collect();
    v.sort_unstable();
    let mut acc = 0.0f64;
    for (i, &k) in v.iter().enumerate().step_by(4) {
        acc = (acc + (k >> 40) as f64).sqrt() + (i as f64).sin();
    }
    black_box(acc)
}
