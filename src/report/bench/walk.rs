//! `tmlut bench walk`: the random walk's wall time per path on the two stacks `docs/random-walk.md`
//! quotes (a thin varnish over copper; a scattering coat over a conductor) at three view cosines,
//! on one thread and on several, with the standard error each run reaches and the paths the
//! furnace's stopping error would need.

use std::fmt::Write;

use super::{median, timed};
use crate::error::{Error, Result};
use crate::model::{Interface, Layer, Medium, Stack};
use crate::random_walk::{WalkEstimate, WalkSettings, directional_albedo};

/// The two-layer stack of the random walk's brief: a thin, nearly smooth varnish (eta 1.1) over a
/// coloured conductor (copper-like indices).
pub fn varnished_conductor() -> Result<Stack> {
    Stack::new(vec![
        Layer::Interface(Interface { eta: [1.1; 3], kappa: [0.0; 3], alpha: 0.01 }),
        Layer::Interface(Interface { eta: [0.1, 0.4, 1.6], kappa: [4.0, 2.4, 1.6], alpha: 0.01 }),
    ])
}

/// A rough coat over a scattering medium over a conductor: absorption differs between channels,
/// scattering does not.
pub fn scattering_coat() -> Result<Stack> {
    Stack::new(vec![
        Layer::Interface(Interface { eta: [1.5; 3], kappa: [0.0; 3], alpha: 0.4 }),
        Layer::Medium(Medium { sigma_s: [0.7; 3], sigma_k: [1.0, 0.2, 1.0], depth: 1.0, g: 0.9 }),
        Layer::Interface(Interface { eta: [0.1; 3], kappa: [3.8, 3.1, 2.1], alpha: 0.01 }),
    ])
}

/// The view cosines timed: normal, halfway, and near grazing, where paths bounce longest.
pub const VIEW_COSINES: [f64; 3] = [1.0, 0.5, 0.05];

/// What to measure.
#[derive(Debug, Clone)]
pub struct WalkBenchSettings {
    /// Paths of every run (rounded up to whole batches by the walk).
    pub paths: u64,
    /// Runs per stack, view and thread count; the median is reported.
    pub repeats: usize,
    /// Worker threads of each timing, in the order reported.
    pub thread_counts: Vec<usize>,
}

impl Default for WalkBenchSettings {
    fn default() -> Self {
        WalkBenchSettings { paths: 1 << 20, repeats: 5, thread_counts: vec![1, 2] }
    }
}

/// The runs of one stack at one view cosine and thread count.
#[derive(Debug, Clone)]
pub struct WalkTiming {
    pub stack: &'static str,
    pub mu: f64,
    pub threads: usize,
    /// Wall nanoseconds per path of each run, in the order run.
    pub nanoseconds_per_path: Vec<f64>,
    /// What the walk estimated (every run estimates the same: the walk is seeded per batch).
    pub estimate: WalkEstimate,
}

impl WalkTiming {
    pub fn median_nanoseconds_per_path(&self) -> f64 {
        median(&self.nanoseconds_per_path)
    }

    /// The largest standard error of the reflected albedo over the channels.
    pub fn largest_standard_error(&self) -> f64 {
        self.estimate.reflected_standard_error.iter().copied().fold(0.0, f64::max)
    }

    /// The paths this view needs for a standard error of `target` in every channel, from the
    /// standard error's `1 / sqrt(paths)` fall.
    pub fn paths_for_standard_error(&self, target: f64) -> f64 {
        self.estimate.paths as f64 * (self.largest_standard_error() / target).powi(2)
    }
}

/// Time the walk of both stacks at [`VIEW_COSINES`] under `settings`.
pub fn bench_walk(settings: &WalkBenchSettings) -> Result<Vec<WalkTiming>> {
    let walk = WalkSettings { min_paths: settings.paths, max_paths: settings.paths, ..WalkSettings::default() };
    let stacks = [("varnished conductor", varnished_conductor()?), ("scattering coat", scattering_coat()?)];
    let mut timings = Vec::new();
    for (name, stack) in &stacks {
        for &threads in &settings.thread_counts {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .map_err(|e| Error::invalid("threads", format!("{threads}: {e}")))?;
            for mu in VIEW_COSINES {
                let mut nanoseconds_per_path = Vec::new();
                let mut estimate = None;
                for _ in 0..settings.repeats.max(1) {
                    let (seconds, run) = timed(|| pool.install(|| directional_albedo(stack, mu, &walk)));
                    nanoseconds_per_path.push(seconds * 1e9 / run.paths as f64);
                    estimate = Some(run);
                }
                let estimate = estimate.expect("at least one run");
                timings.push(WalkTiming { stack: name, mu, threads, nanoseconds_per_path, estimate });
            }
        }
    }
    Ok(timings)
}

/// The timings as a Markdown section, with the settings they were measured under.
pub fn markdown(timings: &[WalkTiming], settings: &WalkBenchSettings) -> String {
    let target = WalkSettings::default().target_standard_error;
    let threads: Vec<String> = settings.thread_counts.iter().map(usize::to_string).collect();
    let mut out = String::new();
    let _ = writeln!(out, "## Random walk: time per path\n");
    let _ = writeln!(
        out,
        "Wall time per path of the random walk's directional albedo (default walk settings, {} paths per run), \
         median of {} runs on {} thread(s), for two stacks: the varnished conductor (eta 1.1, alpha 0.01, over \
         copper-like indices, alpha 0.01) and the scattering coat (eta 1.5, alpha 0.4, over a medium of sigma_s 0.7, \
         g 0.9, depth 1, over a conductor). A: the reflected albedo per channel; s.e.: its largest standard error \
         over the channels; the last column: paths for the furnace's stopping error {target:e} in every channel.\n",
        settings.paths,
        settings.repeats,
        threads.join(" and "),
    );
    let _ = writeln!(
        out,
        "| stack | mu | threads | ns/path (median) | ns/path (runs) | A (R, G, B) | s.e. | paths for s.e. {target:e} |"
    );
    let _ = writeln!(out, "|---|---:|---:|---:|---|---|---:|---:|");
    for t in timings {
        let runs: Vec<String> = t.nanoseconds_per_path.iter().map(|ns| format!("{ns:.0}")).collect();
        let albedo: Vec<String> = t.estimate.reflected.iter().map(|a| format!("{a:.4}")).collect();
        let _ = writeln!(
            out,
            "| {} | {} | {} | {:.0} | {} | {} | {:.1e} | {:.0} |",
            t.stack,
            t.mu,
            t.threads,
            t.median_nanoseconds_per_path(),
            runs.join(", "),
            albedo.join(", "),
            t.largest_standard_error(),
            t.paths_for_standard_error(target),
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_small_walk_bench_times_every_stack_view_and_thread_count() {
        let settings = WalkBenchSettings { paths: 1024, repeats: 2, thread_counts: vec![1, 2] };
        let timings = bench_walk(&settings).unwrap();
        assert_eq!(timings.len(), 2 * 2 * VIEW_COSINES.len());
        for t in &timings {
            assert_eq!(t.nanoseconds_per_path.len(), 2);
            assert!(t.median_nanoseconds_per_path() > 0.0 && t.estimate.paths == 1024, "{t:?}");
            // Twice the standard error needs a quarter of the paths.
            let se = t.largest_standard_error();
            assert!((t.paths_for_standard_error(2.0 * se) - 256.0).abs() < 1e-9, "{t:?}");
        }
        let text = markdown(&timings, &settings);
        assert!(text.starts_with("## Random walk: time per path"), "{text}");
        assert!(text.contains("| scattering coat | 0.05 | 2 |"), "{text}");
    }
}
