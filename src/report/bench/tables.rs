//! `tmlut bench` (the `tables` suite, the default): for each table, the fast build's wall time (median of repeats) and throughput,
//! its error at random nodes against the exact integral (the deterministic quadrature), and the
//! per-cell method on the same nodes with the same samples per cell, for a side-by-side ratio at
//! equal error.
//!
//! Timings on shared machines are noisy: every figure here comes from one run, side by side, and
//! the build time is a median.

use std::fmt::Write;
use std::time::Instant;

use crate::config::{Config, TableKind};
use crate::error::Result;
use crate::integrate::quadrature::VisibleNormalQuadrature;
use crate::integrate::{Progress, estimate_cells};
use crate::recipes::driver::TableBuild;
use crate::recipes::{TableRecipe, random_cells, table_points};
use crate::stats::{ErrorSummary, median};

/// What to measure.
#[derive(Debug, Clone)]
pub struct BenchSettings {
    /// Fast builds per table; the median wall time is reported.
    pub repeats: usize,
    /// Random nodes (with `mu` and `alpha` at least [`BenchSettings::min_mu_alpha`]) compared with
    /// references.
    pub nodes: usize,
    /// Gauss–Legendre nodes per panel of each reference node's exact integral.
    pub reference_nodes: usize,
    /// Nodes the per-cell method runs on: the first of the compared nodes (all of them by default,
    /// so that both methods' errors are measured on the same nodes).
    pub per_cell_nodes: usize,
    /// Nodes closer to grazing or to a smooth surface than this are left out of the comparison.
    pub min_mu_alpha: f64,
}

impl Default for BenchSettings {
    fn default() -> Self {
        BenchSettings { repeats: 3, nodes: 300, reference_nodes: 64, per_cell_nodes: 300, min_mu_alpha: 0.05 }
    }
}

/// The figures of one table.
#[derive(Debug, Clone)]
pub struct BenchRow {
    pub table: String,
    pub nodes: usize,
    /// Points per sampled cell of the fast build; 0 where it integrates by quadrature (TIR).
    pub samples_per_cell: u64,
    /// Cells that are sampled (`(mu, alpha)` pairs for the fast path).
    pub sampled_cells: usize,
    pub fast_seconds: Vec<f64>,
    pub fast_error: ErrorSummary,
    /// The fast build's error on the nodes the per-cell method ran on, for a like-for-like column.
    pub fast_error_on_timed: ErrorSummary,
    pub per_cell_seconds_per_node: f64,
    pub per_cell_error: ErrorSummary,
    pub reference_nodes: usize,
}

impl BenchRow {
    pub fn fast_median_s(&self) -> f64 {
        median(&self.fast_seconds)
    }

    /// Visible-normal samples per second of the fast build.
    pub fn fast_samples_per_s(&self) -> f64 {
        self.sampled_cells as f64 * self.samples_per_cell as f64 / self.fast_median_s()
    }

    /// The per-cell method's time for the whole table, from its time per node.
    pub fn per_cell_extrapolated_s(&self) -> f64 {
        self.per_cell_seconds_per_node * self.nodes as f64
    }

    pub fn ratio(&self) -> f64 {
        self.per_cell_extrapolated_s() / self.fast_median_s()
    }
}

/// Benchmark one table. The recipe's own reference checks run as part of each timed build, so the
/// caller normally disables them ([`Config::disable_reference_checks`]).
pub fn bench_table(
    recipe: &dyn TableRecipe,
    seed: u64,
    settings: &BenchSettings,
    progress: &dyn Progress,
) -> Result<BenchRow> {
    let mut fast_seconds = Vec::new();
    let mut last: Option<TableBuild> = None;
    for _ in 0..settings.repeats.max(1) {
        // Every build from scratch: FGD and fgd_rarer would otherwise take the measures the last
        // build kept.
        crate::recipes::fgd::forget_kept_measures();
        let started = Instant::now();
        let build = recipe.build(seed, progress)?;
        fast_seconds.push(started.elapsed().as_secs_f64());
        last = Some(build);
    }
    let TableBuild { table, provenance } = last.expect("at least one build");

    // Nodes away from grazing and from a smooth surface, drawn reproducibly.
    let mut nodes: Vec<u64> = Vec::new();
    for n in random_cells(table.node_count(), settings.nodes * 8, seed ^ 0xBE4C) {
        let p = table.node_position(&table.node_index(n as usize));
        if p[0] >= settings.min_mu_alpha && p[1] >= settings.min_mu_alpha {
            nodes.push(n);
        }
    }
    // Spread the kept nodes over the drawn ones rather than keeping the lowest numbers.
    let stride = (nodes.len() / settings.nodes.max(1)).max(1);
    let nodes: Vec<u64> = nodes.into_iter().step_by(stride).take(settings.nodes).collect();

    let exact = VisibleNormalQuadrature::new(settings.reference_nodes)?;
    let reference: Vec<Vec<f64>> = estimate_cells(&nodes, &format!("{} references", recipe.name()), progress, |n| {
        recipe.exact_value(&exact, &table.node_position(&table.node_index(n as usize)))
    });
    let stored = |n: u64| table.node(&table.node_index(n as usize)).iter().map(|&v| v as f64).collect::<Vec<f64>>();
    let fast_error = ErrorSummary::of_differences(
        nodes
            .iter()
            .zip(&reference)
            .flat_map(|(&n, r)| stored(n).into_iter().zip(r).map(|(s, r)| s - r).collect::<Vec<_>>()),
    );
    let fast_error_on_timed = ErrorSummary::of_differences(
        nodes
            .iter()
            .zip(&reference)
            .take(settings.per_cell_nodes)
            .flat_map(|(&n, r)| stored(n).into_iter().zip(r).map(|(s, r)| s - r).collect::<Vec<_>>()),
    );

    // The per-cell method, with the table's own points, on the first nodes, one thread at a time
    // per node as it would run over a whole table.
    let points = table_points(&recipe.sampling(), seed)?;
    let timed: Vec<u64> = nodes.iter().copied().take(settings.per_cell_nodes).collect();
    let started = Instant::now();
    let per_cell: Vec<Vec<f64>> = estimate_cells(&timed, &format!("{} per-cell", recipe.name()), progress, |n| {
        recipe.estimate_node(&points, &table.node_position(&table.node_index(n as usize))).mean
    });
    let elapsed = started.elapsed().as_secs_f64();
    let per_cell_seconds_per_node = elapsed / timed.len().max(1) as f64;
    let per_cell_error = ErrorSummary::of_differences(
        per_cell.iter().zip(&reference).flat_map(|(p, r)| p.iter().zip(r).map(|(p, r)| p - r).collect::<Vec<_>>()),
    );

    Ok(BenchRow {
        table: recipe.name().to_string(),
        nodes: table.node_count(),
        samples_per_cell: provenance.sampling.samples_per_cell,
        sampled_cells: table.axes[0].count * table.axes[1].count,
        fast_seconds,
        fast_error,
        fast_error_on_timed,
        per_cell_seconds_per_node,
        per_cell_error,
        reference_nodes: settings.reference_nodes,
    })
}

/// Benchmark the named tables, their builds timed without their own reference checks.
pub fn bench(
    config: &Config,
    only: &[TableKind],
    settings: &BenchSettings,
    progress: &dyn Progress,
) -> Result<Vec<BenchRow>> {
    let mut config = config.clone();
    config.disable_reference_checks();
    only.iter().map(|&kind| bench_table(config.recipe(kind), config.seed, settings, progress)).collect()
}

/// The rows as a Markdown table, with the settings they were measured under.
pub fn markdown(rows: &[BenchRow], settings: &BenchSettings, threads: usize) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "Fast build: median of {} builds, {threads} threads, no reference checks. Error: stored f32 values against \
         the exact integral (the quadrature, {} Gauss–Legendre nodes per panel) at up to {} random nodes with mu, alpha \
         >= {}. Per-cell: the f64 per-cell method with the table's own samples per cell, run and timed on {} of those \
         nodes, extrapolated to the whole table.\n",
        settings.repeats, settings.reference_nodes, settings.nodes, settings.min_mu_alpha, settings.per_cell_nodes,
    );
    let _ = writeln!(
        out,
        "| table | nodes | samples/cell | fast build (s) | samples/s | fast error RMS / max | per-cell error RMS / max (same nodes) | per-cell, whole table (s) | ratio |"
    );
    let _ = writeln!(out, "|---|---:|---:|---:|---:|---|---|---:|---:|");
    for r in rows {
        let (samples, rate) = match r.samples_per_cell {
            0 => ("quadrature".to_string(), "-".to_string()),
            samples => (samples.to_string(), format!("{:.2e}", r.fast_samples_per_s())),
        };
        let _ = writeln!(
            out,
            "| {} | {} | {samples} | {:.2} | {rate} | {:.1e} / {:.1e} ({} values) | {:.1e} / {:.1e} (fast: {:.1e} / {:.1e}, {} values) | {:.0} | {:.0}x |",
            r.table,
            r.nodes,
            r.fast_median_s(),
            r.fast_error.rms,
            r.fast_error.max,
            r.fast_error.count,
            r.per_cell_error.rms,
            r.per_cell_error.max,
            r.fast_error_on_timed.rms,
            r.fast_error_on_timed.max,
            r.fast_error_on_timed.count,
            r.per_cell_extrapolated_s(),
            r.ratio(),
        );
    }
    let total: f64 = rows.iter().map(BenchRow::fast_median_s).sum();
    let _ = writeln!(out, "\nSum of the fast builds' medians: {total:.2} s.");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_small_bench_measures_error_and_ratio() {
        let config = Config::from_toml(
            "[gd]\nmu_count = 16\nalpha_count = 16\n[gd.sampling]\nsamples = 4096\nreplicates = 4\n",
            "test",
        )
        .unwrap();
        let settings =
            BenchSettings { repeats: 1, nodes: 20, reference_nodes: 32, per_cell_nodes: 4, min_mu_alpha: 0.05 };
        let row = bench(&config, &[crate::config::TableKind::Gd], &settings, &()).unwrap().remove(0);
        assert_eq!(row.fast_error.count, 20);
        assert!(row.fast_error.max < 1e-3 && row.per_cell_error.max < 1e-3, "{row:?}");
        assert!(row.per_cell_seconds_per_node > 0.0 && row.fast_median_s() > 0.0);
        assert!(markdown(&[row], &settings, 1).contains("| gd | 256 | 4096 |"));
    }
}
