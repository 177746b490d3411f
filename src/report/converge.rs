//! `tmlut converge TABLE`: error against run time. For a sweep of sample counts (powers of two),
//! the fast build of the whole table and the per-cell method are timed and their error measured on
//! one fixed random subset of cells against high-sample per-cell references; the replicate spread
//! is recorded beside it. The per-cell method is timed on the subset and its whole-table time
//! extrapolated (the 64^4 table would take hours per point), which the CSV says in its `wall` column.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use super::plot::{Series, loglog_png};
use crate::config::{Config, SamplingConfig, TableKind};
use crate::error::{Error, Result};
use crate::formats::write_bytes_atomically;
use crate::integrate::{Progress, estimate_cells};
use crate::recipes::{random_cells, reference_points, table_points};
use crate::sampling::sequence::PointSet;
use crate::stats::ErrorSummary;

/// What to sweep.
#[derive(Debug, Clone)]
pub struct ConvergeSettings {
    /// Sample counts per cell, each a power of two.
    pub samples: Vec<u64>,
    /// Cells of the fixed subset the error is measured on.
    pub cells: usize,
    /// Samples of each reference cell.
    pub reference_samples: u64,
}

impl Default for ConvergeSettings {
    fn default() -> Self {
        ConvergeSettings { samples: (8..=16).map(|k| 1u64 << k).collect(), cells: 64, reference_samples: 1 << 20 }
    }
}

/// One point of the sweep.
#[derive(Debug, Clone)]
pub struct ConvergencePoint {
    pub method: &'static str,
    pub samples_per_cell: u64,
    pub wall_s: f64,
    /// `measured` for the whole table, or how the per-cell time was extrapolated.
    pub wall_kind: String,
    pub error: ErrorSummary,
    /// RMS over the subset of the replicate standard error.
    pub replicate_standard_error_rms: f64,
}

/// Run the sweep for one table.
pub fn converge(
    config: &Config,
    table: &str,
    settings: &ConvergeSettings,
    progress: &dyn Progress,
) -> Result<Vec<ConvergencePoint>> {
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
    let references = reference_points(settings.reference_samples, config.seed)?;
    // Work lists run over positions in the subset, not node numbers.
    let subset: Vec<u64> = (0..cells.len() as u64).collect();
    let reference: Vec<Vec<f64>> = estimate_cells(&subset, &format!("{table} references"), progress, |k| {
        recipe.estimate_node(&references, &positions[k as usize]).mean
    });

    let mut points = Vec::new();
    for &samples in &settings.samples {
        let mut config = config.clone();
        let sampling = SamplingConfig { samples, replicates: recipe.sampling().replicates.min(samples as u32) };
        *config.recipe_mut(kind).sampling_mut() = sampling;
        let recipe = config.recipe(kind);
        sampling.validate(table)?;

        // The fast build of the whole table.
        let started = Instant::now();
        let build = recipe.build(config.seed, progress)?;
        let wall_s = started.elapsed().as_secs_f64();
        let differences = cells.iter().zip(&reference).flat_map(|(&n, r)| {
            let stored = build.table.node(&build.table.node_index(n as usize)).to_vec();
            stored.into_iter().zip(r.clone()).map(|(s, r)| s as f64 - r).collect::<Vec<_>>()
        });
        let subset_spread = build.provenance.standard_error.as_ref().map_or(
            build.provenance.error.replicate_standard_error.rms,
            |se| {
                let channels = build.table.channel_count();
                let values =
                    cells.iter().flat_map(|&n| se[n as usize * channels..(n as usize + 1) * channels].to_vec());
                ErrorSummary::of_differences(values.map(|v| v as f64)).rms
            },
        );
        points.push(ConvergencePoint {
            method: "fast",
            samples_per_cell: samples,
            wall_s,
            wall_kind: "measured on the whole table".into(),
            error: ErrorSummary::of_differences(differences),
            replicate_standard_error_rms: subset_spread,
        });

        // The per-cell method on the subset, extrapolated to the whole table.
        let table_points: PointSet = table_points(&sampling, config.seed)?;
        let started = Instant::now();
        let estimates = estimate_cells(&subset, &format!("{table} per-cell"), progress, |k| {
            recipe.estimate_node(&table_points, &positions[k as usize])
        });
        let per_cell_s = started.elapsed().as_secs_f64() / cells.len() as f64;
        let differences = estimates
            .iter()
            .zip(&reference)
            .flat_map(|(e, r)| e.mean.iter().zip(r).map(|(a, b)| a - b).collect::<Vec<_>>());
        let spread = ErrorSummary::of_differences(estimates.iter().flat_map(|e| e.standard_error.clone())).rms;
        points.push(ConvergencePoint {
            method: "per-cell",
            samples_per_cell: samples,
            wall_s: per_cell_s * node_count as f64,
            wall_kind: format!("extrapolated from {} cells", cells.len()),
            error: ErrorSummary::of_differences(differences),
            replicate_standard_error_rms: spread,
        });
    }
    Ok(points)
}

/// The sweep as CSV, one row per method and sample count.
pub fn csv(points: &[ConvergencePoint]) -> String {
    let mut out =
        String::from("method,samples_per_cell,wall_s,wall,rms_error,max_error,replicate_standard_error_rms\n");
    for p in points {
        let _ = writeln!(
            out,
            "{},{},{:.6},{},{:.6e},{:.6e},{:.6e}",
            p.method,
            p.samples_per_cell,
            p.wall_s,
            p.wall_kind,
            p.error.rms,
            p.error.max,
            p.replicate_standard_error_rms
        );
    }
    out
}

/// Write `converge_<table>.csv` and `converge_<table>.png` into `dir`.
pub fn write(
    dir: &Path,
    table: &str,
    points: &[ConvergencePoint],
    settings: &ConvergeSettings,
) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|source| Error::io(dir, source))?;
    let csv_path = dir.join(format!("converge_{table}.csv"));
    write_bytes_atomically(&csv_path, csv(points).as_bytes())?;
    let series = |method: &str, max: bool| Series {
        name: format!("{method}, {} error", if max { "max" } else { "RMS" }),
        points: points
            .iter()
            .filter(|p| p.method == method)
            .map(|p| (p.wall_s, if max { p.error.max } else { p.error.rms }))
            .collect(),
    };
    let png_path = dir.join(format!("converge_{table}.png"));
    loglog_png(
        &png_path,
        &format!(
            "{table}: error against run time ({} cells vs {}-sample references; per-cell time extrapolated)",
            settings.cells, settings.reference_samples
        ),
        "wall time for the whole table (s)",
        "absolute error",
        &[series("fast", false), series("fast", true), series("per-cell", false), series("per-cell", true)],
    )?;
    Ok(vec![csv_path, png_path])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_small_sweep_converges_and_writes_csv_and_plot() {
        let config = Config::from_toml("[gd]\nmu_count = 8\nalpha_count = 8\n", "test").unwrap();
        let settings = ConvergeSettings { samples: vec![256, 4096], cells: 16, reference_samples: 1 << 18 };
        let points = converge(&config, "gd", &settings, &()).unwrap();
        assert_eq!(points.len(), 4);
        let fast: Vec<&ConvergencePoint> = points.iter().filter(|p| p.method == "fast").collect();
        assert!(fast[1].error.rms < fast[0].error.rms, "more samples, less error: {fast:?}");
        assert!(points.iter().all(|p| p.wall_s > 0.0 && p.error.count == 16));
        let dir = tempfile::tempdir().unwrap();
        let written = write(dir.path(), "gd", &points, &settings).unwrap();
        let text = std::fs::read_to_string(&written[0]).unwrap();
        assert_eq!(text.lines().count(), 5);
        assert!(text.starts_with("method,samples_per_cell,wall_s,"));
        assert!(text.lines().all(|l| l.split(',').count() == 7), "{text}");
        assert!(image::open(&written[1]).is_ok());
        let err = converge(&config, "gf", &settings, &()).unwrap_err().to_string();
        assert!(err.contains("unknown table `gf`"), "{err}");
    }
}
