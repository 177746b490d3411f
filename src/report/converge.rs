//! `tmlut converge TABLE`: error against run time. On one fixed random subset of cells, three ways
//! to make the table are timed and their error measured against the exact integral (the
//! deterministic visible-normal quadrature at `reference_nodes` Gauss–Legendre nodes per panel):
//! the fast build of the whole table and the per-cell Monte Carlo method over a sweep of sample
//! counts (powers of two), and the per-cell quadrature over a sweep of node counts. Per-cell times
//! are measured on the subset and extrapolated to the whole table (the 64^4 table would take
//! hours per point), which the CSV says in its `wall` column. A fast build that is itself a
//! quadrature (TIR's) does not depend on samples: it is built and measured once.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;

use super::plot::{Series, loglog_labelled_png};
use crate::config::{Config, SamplingConfig, TableKind};
use crate::error::{Error, Result};
use crate::formats::write_bytes_atomically;
use crate::integrate::quadrature::{NODES, VisibleNormalQuadrature};
use crate::integrate::{Progress, estimate_cells};
use crate::recipes::{random_cells, table_points};
use crate::sampling::sequence::PointSet;
use crate::stats::ErrorSummary;

/// The fast build of the whole table.
pub const FAST: &str = "fast";
/// The per-cell Monte Carlo estimator, timed on the subset.
pub const PER_CELL: &str = "per-cell";
/// The per-cell quadrature at a node count, timed on the subset.
pub const QUADRATURE: &str = "quadrature";

/// The node counts a quadrature sweep takes between its ends: each power of two and the count
/// halfway to the next (1.5 times it), so that the sweep shows the rule's fast fall without a
/// point per integer.
pub const NODE_STEPS: [usize; 11] = [2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64];

/// The swept node counts from `from` to `to`: both ends, and the [`NODE_STEPS`] between them.
pub fn node_counts(from: usize, to: usize) -> Vec<usize> {
    let mut counts: Vec<usize> = NODE_STEPS.iter().copied().filter(|&n| n > from && n < to).collect();
    counts.push(from);
    counts.push(to);
    counts.sort_unstable();
    counts.dedup();
    counts
}

/// What to sweep.
#[derive(Debug, Clone)]
pub struct ConvergeSettings {
    /// Sample counts per cell, each a power of two.
    pub samples: Vec<u64>,
    /// Gauss–Legendre nodes per panel of the per-cell quadrature; each below `reference_nodes`.
    pub nodes: Vec<usize>,
    /// Cells of the fixed subset the error is measured on.
    pub cells: usize,
    /// Gauss–Legendre nodes per panel of each reference, the exact integral.
    pub reference_nodes: usize,
}

impl Default for ConvergeSettings {
    fn default() -> Self {
        ConvergeSettings {
            samples: (8..=16).map(|k| 1u64 << k).collect(),
            nodes: node_counts(2, 32),
            cells: 64,
            reference_nodes: *NODES.end(),
        }
    }
}

impl ConvergeSettings {
    /// Refuse a sweep that cannot be measured: node counts outside [`NODES`] or not below the
    /// references' (whose error against themselves is 0, which a log-log plot cannot draw).
    pub fn validate(&self) -> Result<()> {
        crate::recipes::settings::check_quadrature_nodes("--reference-nodes", self.reference_nodes)?;
        if let Some(&n) = self.nodes.iter().find(|&&n| !NODES.contains(&n) || n >= self.reference_nodes) {
            return Err(Error::invalid(
                "--nodes-from/--nodes-to",
                format!(
                    "{n} nodes per panel; allowed: {} to {} and below --reference-nodes ({})",
                    NODES.start(),
                    NODES.end(),
                    self.reference_nodes
                ),
            ));
        }
        Ok(())
    }
}

/// One point of the sweep.
#[derive(Debug, Clone)]
pub struct ConvergencePoint {
    /// [`FAST`], [`PER_CELL`] or [`QUADRATURE`].
    pub method: &'static str,
    /// Monte Carlo samples per cell; 0 for a quadrature.
    pub samples_per_cell: u64,
    /// Gauss–Legendre nodes per panel of the per-cell quadrature; 0 for the other methods.
    pub nodes_per_panel: usize,
    pub wall_s: f64,
    /// `measured` for the whole table, or how the per-cell time was extrapolated.
    pub wall_kind: String,
    pub error: ErrorSummary,
    /// RMS over the subset of the replicate standard error (0 for a quadrature).
    pub replicate_standard_error_rms: f64,
}

impl ConvergencePoint {
    /// How the point's plot label and answers name its cost: `2^12` samples, `n = 8` nodes per
    /// panel, or `quadrature` for a fast build that takes no samples.
    pub fn label(&self) -> String {
        match (self.samples_per_cell, self.nodes_per_panel) {
            (0, 0) => "quadrature".into(),
            (0, n) => format!("n = {n}"),
            (samples, _) => power_of_two(samples),
        }
    }
}

/// Run the sweep for one table.
pub fn converge(
    config: &Config,
    table: &str,
    settings: &ConvergeSettings,
    progress: &dyn Progress,
) -> Result<Vec<ConvergencePoint>> {
    settings.validate()?;
    let mut config = config.clone();
    config.disable_reference_checks();
    let kind = TableKind::named(table).ok_or_else(|| {
        Error::invalid("TABLE", format!("unknown table `{table}`; known tables: {}", TableKind::names().join(", ")))
    })?;
    let recipe = config.recipe(kind);
    let axes = recipe.axes()?;
    let node_count: usize = axes.iter().map(|a| a.count).product();
    let shape = crate::table::Table::zeros("shape", axes, vec![crate::table::Channel::new("v", "")])?;
    let cells = random_cells(node_count, settings.cells, config.seed ^ 0xC0DE);
    let positions: Vec<Vec<f64>> = cells.iter().map(|&n| shape.node_position(&shape.node_index(n as usize))).collect();
    // Work lists run over positions in the subset, not node numbers.
    let subset: Vec<u64> = (0..cells.len() as u64).collect();
    let exact = VisibleNormalQuadrature::new(settings.reference_nodes)?;
    let reference: Vec<Vec<f64>> = estimate_cells(&subset, &format!("{table} references"), progress, |k| {
        recipe.exact_value(&exact, &positions[k as usize])
    });
    let errors_of = |values: &[Vec<f64>]| {
        ErrorSummary::of_differences(
            values.iter().zip(&reference).flat_map(|(v, r)| v.iter().zip(r).map(|(a, b)| a - b).collect::<Vec<_>>()),
        )
    };
    let extrapolated = format!("extrapolated from {} cells", cells.len());

    let mut points = Vec::new();
    let mut fast_takes_samples = true;
    for &samples in &settings.samples {
        let mut config = config.clone();
        let sampling = SamplingConfig { samples, replicates: recipe.sampling().replicates.min(samples as u32) };
        *config.recipe_mut(kind).sampling_mut() = sampling;
        let recipe = config.recipe(kind);
        sampling.validate(table)?;

        // The fast build of the whole table, once if it takes no samples.
        if fast_takes_samples {
            let started = Instant::now();
            let build = recipe.build(config.seed, progress)?;
            let wall_s = started.elapsed().as_secs_f64();
            fast_takes_samples = build.provenance.sampling.samples_per_cell != 0;
            let stored: Vec<Vec<f64>> = cells
                .iter()
                .map(|&n| build.table.node(&build.table.node_index(n as usize)).iter().map(|&v| f64::from(v)).collect())
                .collect();
            let subset_spread = build.provenance.standard_error.as_ref().map_or(
                build.provenance.error.replicate_standard_error.rms,
                |se| {
                    let channels = build.table.channel_count();
                    let values =
                        cells.iter().flat_map(|&n| se[n as usize * channels..(n as usize + 1) * channels].to_vec());
                    ErrorSummary::of_differences(values.map(f64::from)).rms
                },
            );
            points.push(ConvergencePoint {
                method: FAST,
                samples_per_cell: if fast_takes_samples { samples } else { 0 },
                nodes_per_panel: 0,
                wall_s,
                wall_kind: "measured on the whole table".into(),
                error: errors_of(&stored),
                replicate_standard_error_rms: if fast_takes_samples { subset_spread } else { 0.0 },
            });
        }

        // The per-cell method on the subset, extrapolated to the whole table.
        let table_points: PointSet = table_points(&sampling, config.seed)?;
        let started = Instant::now();
        let estimates = estimate_cells(&subset, &format!("{table} per-cell"), progress, |k| {
            recipe.estimate_node(&table_points, &positions[k as usize])
        });
        let per_cell_s = started.elapsed().as_secs_f64() / cells.len() as f64;
        let means: Vec<Vec<f64>> = estimates.iter().map(|e| e.mean.clone()).collect();
        let spread = ErrorSummary::of_differences(estimates.iter().flat_map(|e| e.standard_error.clone())).rms;
        points.push(ConvergencePoint {
            method: PER_CELL,
            samples_per_cell: samples,
            nodes_per_panel: 0,
            wall_s: per_cell_s * node_count as f64,
            wall_kind: extrapolated.clone(),
            error: errors_of(&means),
            replicate_standard_error_rms: spread,
        });
    }

    // The per-cell quadrature on the subset, extrapolated to the whole table.
    for &nodes in &settings.nodes {
        let quadrature = VisibleNormalQuadrature::new(nodes)?;
        let started = Instant::now();
        let values = estimate_cells(&subset, &format!("{table} quadrature, {nodes} nodes"), progress, |k| {
            recipe.exact_value(&quadrature, &positions[k as usize])
        });
        let per_cell_s = started.elapsed().as_secs_f64() / cells.len() as f64;
        points.push(ConvergencePoint {
            method: QUADRATURE,
            samples_per_cell: 0,
            nodes_per_panel: nodes,
            wall_s: per_cell_s * node_count as f64,
            wall_kind: extrapolated.clone(),
            error: errors_of(&values),
            replicate_standard_error_rms: 0.0,
        });
    }
    Ok(points)
}

/// The sweep as CSV, one row per method and sample or node count.
pub fn csv(points: &[ConvergencePoint]) -> String {
    let mut out = String::from(
        "method,samples_per_cell,nodes_per_panel,wall_s,wall,rms_error,max_error,replicate_standard_error_rms\n",
    );
    for p in points {
        let _ = writeln!(
            out,
            "{},{},{},{:.6},{},{:.6e},{:.6e},{:.6e}",
            p.method,
            p.samples_per_cell,
            p.nodes_per_panel,
            p.wall_s,
            p.wall_kind,
            p.error.rms,
            p.error.max,
            p.replicate_standard_error_rms
        );
    }
    out
}

/// The option that sets the RMS error target, named in its errors.
pub const TARGET_OPTION: &str = "--target-error";

/// How many of the largest swept sample counts the extrapolation fits (fewer if fewer were swept).
pub const TARGET_FIT_POINTS: usize = 3;

/// Read `--target-error`: a positive, finite RMS error.
pub fn parse_target_error(text: &str) -> Result<f64> {
    const ALLOWED: &str = "allowed: a positive, finite RMS error such as 1e-4";
    match text.trim().parse::<f64>() {
        Ok(e) if e.is_finite() && e > 0.0 => Ok(e),
        Ok(_) => Err(Error::invalid(TARGET_OPTION, format!("`{text}` is not a positive, finite number; {ALLOWED}"))),
        Err(_) => Err(Error::invalid(TARGET_OPTION, format!("`{text}` is not a number; {ALLOWED}"))),
    }
}

/// How an answer to "how many samples per cell for RMS error E" was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum TargetStatus {
    /// A swept sample count measured at or below the target.
    Reached,
    /// No swept count reached it; the count comes from the log-log slope of the last points.
    Extrapolated,
    /// No swept count reached it and the last points give no count (see `note`).
    Unreachable,
}

/// The answer for one method to "how many samples per cell for RMS error `target_rms_error`".
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TargetAnswer {
    pub method: &'static str,
    pub target_rms_error: f64,
    pub status: TargetStatus,
    /// The smallest swept count that reached the target, or the extrapolated power of two.
    pub samples_per_cell: Option<u64>,
    pub log2_samples_per_cell: Option<u32>,
    /// For the per-cell quadrature: the smallest swept node count per panel that reached it.
    pub nodes_per_panel: Option<usize>,
    /// Measured at that count, or predicted by the fitted line.
    pub rms_error: Option<f64>,
    /// Wall time for the whole table at that count: measured (as in the CSV), or predicted from
    /// the log-log line of time against samples over the same points.
    pub wall_s: Option<f64>,
    pub wall: Option<String>,
    /// The swept sample counts the lines were fitted to (extrapolated and unreachable answers).
    pub fitted_samples_per_cell: Vec<u64>,
    /// Log-log slopes of RMS error and of wall time against samples per cell over those points.
    pub error_slope: Option<f64>,
    pub time_slope: Option<f64>,
    /// Why there is no count, or a caveat on the one given.
    pub note: Option<String>,
}

/// Least-squares line `log2 y = a + b log2 x` through the points: `(a, b)`.
fn loglog_line(points: &[(f64, f64)]) -> (f64, f64) {
    let n = points.len() as f64;
    let logs: Vec<(f64, f64)> = points.iter().map(|&(x, y)| (x.log2(), y.log2())).collect();
    let mx = logs.iter().map(|p| p.0).sum::<f64>() / n;
    let my = logs.iter().map(|p| p.1).sum::<f64>() / n;
    let sxy: f64 = logs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = logs.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let slope = sxy / sxx;
    (my - slope * mx, slope)
}

/// Answer "how many samples per cell for RMS error `target`" for `method` from the sweep: the
/// smallest swept count whose RMS error is at most `target`; failing that, the smallest power of
/// two above the sweep at which the least-squares log-log line through the last
/// [`TARGET_FIT_POINTS`] points reaches it, with the wall time predicted by the same kind of line
/// of time against samples. A method that takes no samples (the per-cell quadrature, or a fast
/// build that is a quadrature) is answered by the smallest swept node count that reached it, and
/// never extrapolated: Gauss–Legendre's error falls by no fixed slope.
pub fn target_answer(points: &[ConvergencePoint], method: &'static str, target: f64) -> TargetAnswer {
    let mut swept: Vec<&ConvergencePoint> = points.iter().filter(|p| p.method == method).collect();
    swept.sort_by_key(|p| (p.samples_per_cell, p.nodes_per_panel));
    let mut answer = TargetAnswer {
        method,
        target_rms_error: target,
        status: TargetStatus::Unreachable,
        samples_per_cell: None,
        log2_samples_per_cell: None,
        nodes_per_panel: None,
        rms_error: None,
        wall_s: None,
        wall: None,
        fitted_samples_per_cell: Vec::new(),
        error_slope: None,
        time_slope: None,
        note: None,
    };
    if let Some(p) = swept.iter().find(|p| p.error.rms <= target) {
        answer.status = TargetStatus::Reached;
        if p.samples_per_cell > 0 {
            answer.samples_per_cell = Some(p.samples_per_cell);
            answer.log2_samples_per_cell = Some(p.samples_per_cell.trailing_zeros());
        }
        answer.nodes_per_panel = (p.nodes_per_panel > 0).then_some(p.nodes_per_panel);
        answer.rms_error = Some(p.error.rms);
        answer.wall_s = Some(p.wall_s);
        answer.wall = Some(p.wall_kind.clone());
        return answer;
    }
    if let Some(last) = swept.last().filter(|p| p.samples_per_cell == 0) {
        answer.note = Some(match last.nodes_per_panel {
            0 => format!(
                "the fast build is a quadrature, whose error does not fall with samples: measured RMS {:.3e}",
                last.error.rms
            ),
            n => format!(
                "no swept node count reaches it (RMS {:.3e} at n = {n}); sweep more with --nodes-to, below \
                 --reference-nodes",
                last.error.rms
            ),
        });
        return answer;
    }
    let mut tail: Vec<&ConvergencePoint> =
        swept.iter().rev().filter(|p| p.error.rms > 0.0 && p.wall_s > 0.0).take(TARGET_FIT_POINTS).copied().collect();
    tail.reverse();
    answer.fitted_samples_per_cell = tail.iter().map(|p| p.samples_per_cell).collect();
    if tail.len() < 2 {
        answer.note = Some(format!(
            "not reached, and {} swept point(s) with a positive error and time: sweep at least two sample \
             counts to extrapolate",
            tail.len()
        ));
        return answer;
    }
    let (a, slope) = loglog_line(&tail.iter().map(|p| (p.samples_per_cell as f64, p.error.rms)).collect::<Vec<_>>());
    answer.error_slope = Some(slope);
    if slope.is_nan() || slope >= 0.0 {
        answer.note = Some(format!(
            "not reached, and the RMS error does not fall with samples over the last points (log-log slope \
             {slope:.2}): no count can be extrapolated"
        ));
        return answer;
    }
    let last = tail.last().expect("two points").samples_per_cell.trailing_zeros();
    let needed = (target.log2() - a) / slope;
    // A power of two, and above the sweep: every swept count was measured short of the target.
    let k = needed.ceil().max(f64::from(last + 1));
    if k > 63.0 {
        answer.note = Some(format!(
            "not reached; the log-log slope {slope:.2} of the last points needs about 2^{needed:.1} samples per \
             cell, beyond 2^63"
        ));
        return answer;
    }
    let k = k as u32;
    let (b, time_slope) = loglog_line(&tail.iter().map(|p| (p.samples_per_cell as f64, p.wall_s)).collect::<Vec<_>>());
    answer.status = TargetStatus::Extrapolated;
    answer.samples_per_cell = Some(1u64 << k);
    answer.log2_samples_per_cell = Some(k);
    answer.rms_error = Some((a + slope * f64::from(k)).exp2());
    answer.wall_s = Some((b + time_slope * f64::from(k)).exp2());
    answer.time_slope = Some(time_slope);
    answer.wall = Some(format!(
        "predicted along the log-log time slope of the fitted points; swept times {}",
        tail.last().expect("two points").wall_kind
    ));
    answer
}

/// The answers of every method the sweep measured, fast build first.
pub fn target_answers(points: &[ConvergencePoint], target: f64) -> Vec<TargetAnswer> {
    [FAST, PER_CELL, QUADRATURE]
        .into_iter()
        .filter(|m| points.iter().any(|p| p.method == *m))
        .map(|m| target_answer(points, m, target))
        .collect()
}

/// `2^k = n`, as the answers and the plot write sample counts.
fn power_of_two(samples: u64) -> String {
    format!("2^{}", samples.trailing_zeros())
}

impl TargetAnswer {
    /// One line a person reads: the count, how it was found, and the wall time.
    pub fn line(&self) -> String {
        let head = format!("{}: RMS error <= {:e}", self.method, self.target_rms_error);
        let counts = |v: &[u64]| v.iter().map(|&n| power_of_two(n)).collect::<Vec<_>>().join(", ");
        let measured = format!(
            "measured RMS {:.3e}; wall time {:.3} s, {}",
            self.rms_error.unwrap_or(f64::NAN),
            self.wall_s.unwrap_or(f64::NAN),
            self.wall.as_deref().unwrap_or("")
        );
        let mut line = match (self.status, self.samples_per_cell) {
            (TargetStatus::Reached, None) => match self.nodes_per_panel {
                Some(n) => format!("{head} at n = {n} Gauss–Legendre nodes per panel ({measured})"),
                None => format!("{head} by the fast build's quadrature, which takes no samples ({measured})"),
            },
            (TargetStatus::Reached, Some(n)) => format!(
                "{head} at {} = {n} samples per cell (measured RMS {:.3e}; wall time {:.3} s, {})",
                power_of_two(n),
                self.rms_error.unwrap_or(f64::NAN),
                self.wall_s.unwrap_or(f64::NAN),
                self.wall.as_deref().unwrap_or("")
            ),
            (TargetStatus::Extrapolated, Some(n)) => format!(
                "{head} needs {} = {n} samples per cell, EXTRAPOLATED (not measured) from {} (log-log error \
                 slope {:.2}; predicted RMS {:.3e}); predicted wall time {:.3} s (log-log time slope {:.2})",
                power_of_two(n),
                counts(&self.fitted_samples_per_cell),
                self.error_slope.unwrap_or(f64::NAN),
                self.rms_error.unwrap_or(f64::NAN),
                self.wall_s.unwrap_or(f64::NAN),
                self.time_slope.unwrap_or(f64::NAN),
            ),
            _ if self.method == QUADRATURE => format!("{head}: no node count"),
            _ => format!("{head}: no sample count"),
        };
        if let Some(note) = &self.note {
            let _ = write!(line, "; {note}");
        }
        line
    }
}

/// The companion of the CSV with the target's answers: `converge_<table>.json`.
pub fn target_json(table: &str, settings: &ConvergeSettings, answers: &[TargetAnswer]) -> String {
    let value = serde_json::json!({
        "table": table,
        "target_rms_error": answers.first().map(|a| a.target_rms_error),
        "cells": settings.cells,
        "reference_nodes_per_panel": settings.reference_nodes,
        "swept_samples_per_cell": settings.samples,
        "swept_nodes_per_panel": settings.nodes,
        "fit_points": TARGET_FIT_POINTS,
        "answers": answers.iter().map(|a| {
            let mut v = serde_json::to_value(a).expect("answers serialise");
            v["summary"] = a.line().into();
            v
        }).collect::<Vec<_>>(),
    });
    serde_json::to_string_pretty(&value).expect("answers serialise") + "\n"
}

/// Write `converge_<table>.csv` and `converge_<table>.png` into `dir`, and with `answers` (from
/// `--target-error`) `converge_<table>.json`, the target drawn on the plot as a dashed line.
/// Without answers a `converge_<table>.json` left by an earlier run is removed, so the folder never
/// pairs this sweep with another's answers.
pub fn write(
    dir: &Path,
    table: &str,
    points: &[ConvergencePoint],
    settings: &ConvergeSettings,
    answers: &[TargetAnswer],
) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|source| Error::io(dir, source))?;
    let csv_path = dir.join(format!("converge_{table}.csv"));
    write_bytes_atomically(&csv_path, csv(points).as_bytes())?;
    let json_path = dir.join(format!("converge_{table}.json"));
    let mut written = vec![csv_path];
    if answers.is_empty() {
        match std::fs::remove_file(&json_path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(Error::io(&json_path, e)),
            _ => {}
        }
    } else {
        write_bytes_atomically(&json_path, target_json(table, settings, answers).as_bytes())?;
        written.push(json_path);
    }
    let methods: Vec<&str> =
        [FAST, PER_CELL, QUADRATURE].into_iter().filter(|m| points.iter().any(|p| p.method == *m)).collect();
    let mut series = Vec::new();
    // Every point labelled with its cost (samples per cell or nodes per panel), in the same order
    // as the series' points.
    let mut labels = Vec::new();
    for method in methods {
        let swept: Vec<&ConvergencePoint> = points.iter().filter(|p| p.method == method).collect();
        for max in [false, true] {
            series.push(Series {
                name: format!("{method}, {} error", if max { "max" } else { "RMS" }),
                points: swept.iter().map(|p| (p.wall_s, if max { p.error.max } else { p.error.rms })).collect(),
            });
            labels.push(swept.iter().map(|p| p.label()).collect::<Vec<_>>());
        }
    }
    let png_path = dir.join(format!("converge_{table}.png"));
    let guide_name = answers.first().map(|a| format!("target RMS error {:e}", a.target_rms_error));
    loglog_labelled_png(
        &png_path,
        &format!(
            "{table}: error against run time ({} cells; exact: {} nodes per panel)",
            settings.cells, settings.reference_nodes
        ),
        "wall time for the whole table (s; per-cell methods extrapolated); labels: samples per cell, n = nodes per panel",
        "absolute error",
        &series,
        &labels,
        answers.first().map(|a| a.target_rms_error).zip(guide_name.as_deref()),
    )?;
    written.push(png_path);
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_small_sweep_converges_and_writes_csv_and_plot() {
        let config = Config::from_toml("[gd]\nmu_count = 8\nalpha_count = 8\n", "test").unwrap();
        let settings = ConvergeSettings { samples: vec![256, 4096], nodes: vec![2, 8], cells: 16, reference_nodes: 32 };
        let points = converge(&config, "gd", &settings, &()).unwrap();
        assert_eq!(points.len(), 6);
        for method in [FAST, PER_CELL, QUADRATURE] {
            let swept: Vec<&ConvergencePoint> = points.iter().filter(|p| p.method == method).collect();
            assert_eq!(swept.len(), 2, "{points:?}");
            assert!(swept[1].error.rms < swept[0].error.rms, "more samples or nodes, less error: {swept:?}");
        }
        // Against the exact integral, the quadrature at 8 nodes is far closer than 4096 samples.
        let (quadrature, fast) = (&points[5], &points[2]);
        assert_eq!(
            (quadrature.nodes_per_panel, quadrature.samples_per_cell, quadrature.label()),
            (8, 0, "n = 8".into())
        );
        assert!(quadrature.error.rms < 0.1 * fast.error.rms, "{points:?}");
        assert!(points.iter().all(|p| p.wall_s > 0.0 && p.error.count == 16));
        let dir = tempfile::tempdir().unwrap();
        let written = write(dir.path(), "gd", &points, &settings, &[]).unwrap();
        let text = std::fs::read_to_string(&written[0]).unwrap();
        assert_eq!(text.lines().count(), 7);
        assert!(text.starts_with("method,samples_per_cell,nodes_per_panel,wall_s,"));
        assert!(text.lines().all(|l| l.split(',').count() == 8), "{text}");
        assert!(text.contains("\nquadrature,0,8,"), "{text}");
        assert!(image::open(&written[1]).is_ok());
        let err = converge(&config, "gf", &settings, &()).unwrap_err().to_string();
        assert!(err.contains("unknown table `gf`"), "{err}");
    }

    #[test]
    fn a_fast_build_that_is_a_quadrature_is_measured_once() {
        let config = Config::from_toml("[tir]\nmu_count = 8\nalpha_count = 4\neta_count = 4\n", "test").unwrap();
        let settings = ConvergeSettings { samples: vec![256, 1024], nodes: vec![4], cells: 8, reference_nodes: 32 };
        let points = converge(&config, "tir", &settings, &()).unwrap();
        let fast: Vec<&ConvergencePoint> = points.iter().filter(|p| p.method == FAST).collect();
        assert_eq!(fast.len(), 1, "{points:?}");
        assert_eq!((fast[0].samples_per_cell, fast[0].label()), (0, "quadrature".into()));
        assert!(fast[0].error.max < 1e-5, "{fast:?}");
        assert_eq!(points.iter().filter(|p| p.method == PER_CELL).count(), 2);
        let answers = target_answers(&points, 1e-4);
        assert_eq!(answers[0].status, TargetStatus::Reached, "{answers:?}");
        assert!(answers[0].line().contains("by the fast build's quadrature, which takes no samples"), "{answers:?}");
        // Below what the quadrature reaches: no count, and why.
        let below = target_answer(&points, FAST, fast[0].error.rms / 2.0);
        assert_eq!(below.status, TargetStatus::Unreachable);
        assert!(below.note.as_deref().unwrap().contains("does not fall with samples"), "{below:?}");
    }

    #[test]
    fn node_counts_must_lie_below_the_references() {
        assert_eq!(node_counts(2, 32), vec![2, 3, 4, 6, 8, 12, 16, 24, 32]);
        assert_eq!(node_counts(5, 7), vec![5, 6, 7]);
        assert_eq!(node_counts(5, 5), vec![5]);
        let settings =
            |nodes: Vec<usize>, reference_nodes| ConvergeSettings { nodes, reference_nodes, ..Default::default() };
        assert!(settings(vec![2, 48], 64).validate().is_ok());
        let err = settings(vec![2, 64], 64).validate().unwrap_err().to_string();
        assert!(err.contains("64 nodes per panel") && err.contains("below --reference-nodes (64)"), "{err}");
        let err = settings(vec![1], 64).validate().unwrap_err().to_string();
        assert!(err.contains("allowed: 2 to 64"), "{err}");
        let err = settings(vec![2], 65).validate().unwrap_err().to_string();
        assert!(err.starts_with("--reference-nodes: 65; allowed: 2 to 64"), "{err}");
    }

    #[test]
    fn a_quadrature_target_is_the_smallest_swept_node_count_that_reaches_it() {
        let points: Vec<ConvergencePoint> = [(2, 1e-2), (4, 1e-4), (8, 1e-9)]
            .into_iter()
            .map(|(n, rms)| ConvergencePoint {
                method: QUADRATURE,
                samples_per_cell: 0,
                nodes_per_panel: n,
                wall_s: 1e-3 * n as f64,
                wall_kind: "extrapolated from 16 cells".into(),
                error: ErrorSummary::new(16, rms, 2.0 * rms),
                replicate_standard_error_rms: 0.0,
            })
            .collect();
        let answer = target_answer(&points, QUADRATURE, 1e-3);
        assert_eq!(
            (answer.status, answer.nodes_per_panel, answer.samples_per_cell),
            (TargetStatus::Reached, Some(4), None)
        );
        assert!(
            answer.line().contains("at n = 4 Gauss–Legendre nodes per panel (measured RMS 1.000e-4"),
            "{}",
            answer.line()
        );
        let answer = target_answer(&points, QUADRATURE, 1e-12);
        assert_eq!((answer.status, answer.nodes_per_panel), (TargetStatus::Unreachable, None));
        assert!(answer.line().contains("no node count") && answer.line().contains("--nodes-to"), "{}", answer.line());
    }

    /// A sweep of `method` over 2^8..=2^12 with RMS error `N^slope` and wall time `1e-6 N` s.
    fn synthetic(method: &'static str, slope: f64) -> Vec<ConvergencePoint> {
        (8..=12)
            .map(|k| {
                let n = 1u64 << k;
                ConvergencePoint {
                    method,
                    samples_per_cell: n,
                    nodes_per_panel: 0,
                    wall_s: 1e-6 * n as f64,
                    wall_kind: "measured on the whole table".into(),
                    error: ErrorSummary::new(16, (n as f64).powf(slope), 3.0 * (n as f64).powf(slope)),
                    replicate_standard_error_rms: 0.0,
                }
            })
            .collect()
    }

    #[test]
    fn a_target_the_sweep_reaches_is_the_smallest_swept_count_at_or_below_it() {
        let points = synthetic("fast", -0.5);
        // RMS 2^-4, 2^-4.5, 2^-5, 2^-5.5, 2^-6 at 2^8..2^12.
        let answer = target_answer(&points, "fast", 0.03);
        assert_eq!(answer.status, TargetStatus::Reached);
        assert_eq!((answer.samples_per_cell, answer.log2_samples_per_cell), (Some(2048), Some(11)));
        assert_eq!(answer.rms_error, Some(2f64.powf(-5.5)));
        assert_eq!(answer.wall_s, Some(1e-6 * 2048.0));
        assert!(answer.error_slope.is_none() && answer.note.is_none(), "{answer:?}");
        // At or below: equal to a measured error counts.
        assert_eq!(target_answer(&points, "fast", 2f64.powi(-5)).samples_per_cell, Some(1024));
        let line = answer.line();
        assert!(line.starts_with("fast: RMS error <= 3e-2 at 2^11 = 2048 samples per cell (measured"), "{line}");
        assert!(!line.contains("EXTRAPOLATED"), "{line}");
    }

    #[test]
    fn a_target_beyond_the_sweep_is_extrapolated_from_the_last_points_slope() {
        let mut points = synthetic("per-cell", -0.5);
        // Outside the last three points, so ignored by the fit (it would pull the slope to -1.3).
        points[0].error.rms = 1.0;
        points[0].wall_s = 1.0;
        // log2 N = log2(1e-3) / -0.5 = 19.93: 2^20, where the line predicts 2^-10 and 1e-6 * 2^20 s.
        let answer = target_answer(&points, "per-cell", 1e-3);
        assert_eq!(answer.status, TargetStatus::Extrapolated);
        assert_eq!((answer.samples_per_cell, answer.log2_samples_per_cell), (Some(1 << 20), Some(20)));
        assert_eq!(answer.fitted_samples_per_cell, vec![1024, 2048, 4096]);
        assert!((answer.error_slope.unwrap() + 0.5).abs() < 1e-12, "{answer:?}");
        assert!((answer.time_slope.unwrap() - 1.0).abs() < 1e-12, "{answer:?}");
        assert!((answer.rms_error.unwrap() / 2f64.powi(-10) - 1.0).abs() < 1e-9, "{answer:?}");
        assert!((answer.wall_s.unwrap() / (1e-6 * 1048576.0) - 1.0).abs() < 1e-9, "{answer:?}");
        assert!(answer.note.is_none(), "{answer:?}");
        let line = answer.line();
        assert!(line.contains("needs 2^20 = 1048576 samples per cell, EXTRAPOLATED"), "{line}");
        assert!(line.contains("from 2^10, 2^11, 2^12 (log-log error slope -0.50"), "{line}");
        assert!(line.contains("predicted wall time 1.049 s (log-log time slope 1.00)"), "{line}");
        // Just past the last point: the next power of two, never a swept one.
        let answer = target_answer(&points, "per-cell", 0.0155);
        assert_eq!((answer.status, answer.samples_per_cell), (TargetStatus::Extrapolated, Some(8192)));
        assert!(answer.note.is_none(), "{answer:?}");
        // Only the named method's points count.
        assert_eq!(target_answer(&points, "fast", 1e-3).status, TargetStatus::Unreachable);
    }

    #[test]
    fn no_count_when_the_error_does_not_fall_or_one_point_was_swept() {
        let flat = synthetic("fast", 0.0);
        let answer = target_answer(&flat, "fast", 0.5);
        assert_eq!((answer.status, answer.samples_per_cell), (TargetStatus::Unreachable, None));
        assert!(answer.note.as_deref().unwrap().contains("does not fall with samples"), "{answer:?}");
        assert!(answer.line().contains("no sample count"), "{}", answer.line());
        let one = &synthetic("fast", -0.5)[4..];
        let answer = target_answer(one, "fast", 1e-3);
        assert_eq!(answer.status, TargetStatus::Unreachable);
        assert!(answer.note.as_deref().unwrap().contains("sweep at least two"), "{answer:?}");
    }

    #[test]
    fn the_target_must_be_a_positive_finite_number() {
        assert_eq!(parse_target_error("1e-4").unwrap(), 1e-4);
        assert_eq!(parse_target_error(" 0.002 ").unwrap(), 0.002);
        for bad in ["0", "-1e-4", "NaN", "inf", "abc", "", "1e-4x"] {
            let err = parse_target_error(bad).unwrap_err().to_string();
            assert!(err.starts_with("--target-error: `"), "{bad}: {err}");
            assert!(err.contains("allowed: a positive, finite RMS error"), "{bad}: {err}");
        }
        assert!(parse_target_error("abc").unwrap_err().to_string().contains("not a number"));
        assert!(parse_target_error("-1").unwrap_err().to_string().contains("not a positive, finite number"));
    }

    #[test]
    fn the_answers_are_written_beside_the_csv_and_a_stale_file_is_removed() {
        let mut points = synthetic("fast", -0.5);
        points.extend(synthetic("per-cell", -0.5));
        let settings = ConvergeSettings {
            samples: (8..=12).map(|k| 1 << k).collect(),
            nodes: Vec::new(),
            cells: 16,
            reference_nodes: 64,
        };
        let answers = target_answers(&points, 1e-3);
        assert_eq!(answers.iter().map(|a| a.method).collect::<Vec<_>>(), ["fast", "per-cell"]);
        let dir = tempfile::tempdir().unwrap();
        let written = write(dir.path(), "gd", &points, &settings, &answers).unwrap();
        assert_eq!(written.len(), 3);
        let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&written[1]).unwrap()).unwrap();
        assert_eq!(json["target_rms_error"], 1e-3);
        assert_eq!(json["answers"][1]["method"], "per-cell");
        assert_eq!(json["answers"][1]["status"], "extrapolated");
        assert_eq!(json["answers"][1]["samples_per_cell"], 1 << 20);
        assert!(json["answers"][0]["summary"].as_str().unwrap().contains("EXTRAPOLATED"), "{json}");
        assert!(image::open(&written[2]).is_ok());
        // A run without a target leaves no answers of another sweep behind.
        let written = write(dir.path(), "gd", &points, &settings, &[]).unwrap();
        assert_eq!(written.len(), 2);
        assert!(!dir.path().join("converge_gd.json").exists());
    }
}
