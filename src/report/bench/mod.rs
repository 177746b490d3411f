//! `tmlut bench`: measurements printed as Markdown sections for `docs/benchmark.md`, one suite a
//! file:
//! - [`tables`]: each table's build time and error beside the per-cell method (the default);
//! - [`walk`]: the random walk's time per path on two stacks, at one thread and at all of them;
//! - [`furnace`]: the random walk of the furnace test over six materials, timed;
//! - [`quadrature`]: the exact integrals against Monte Carlo on the hardest lookups;
//! - [`bake`]: each material of some scenes baked, timed, and its baked values against its model.
//!
//! Timings on shared machines are noisy: every timing is a median of repeats, and each section
//! states the settings and the thread count it was measured with.

pub mod bake;
pub mod furnace;
pub mod quadrature;
pub mod tables;
pub mod walk;

pub use crate::stats::median;

/// Peak resident memory of this process so far, in bytes, where the system tells (Linux).
pub fn peak_memory_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kilobytes: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kilobytes * 1024)
}

/// Seconds elapsed while `work` ran, and what it returned.
fn timed<T>(work: impl FnOnce() -> T) -> (f64, T) {
    let started = std::time::Instant::now();
    let result = work();
    (started.elapsed().as_secs_f64(), result)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
    }
}
