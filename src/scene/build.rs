//! `tmlut build --scene`: build exactly a scene's plan, and measure what specialising cost.
//!
//! Every slice table is compared, at random `(mu, alpha)` inside its range and every channel, with
//! the exact integral (a per-cell estimate with the reference sample count) and with what the full
//! table of the same configuration would have given there (multilinear interpolation across
//! `eta` and `kappa` included; its clamp at the range's end too). Both go into the slice's manifest
//! entry as accuracy reports.

use std::path::PathBuf;

use super::Scene;
use super::plan::{Plan, PlannedBuild, plan};
use crate::config::{Config, OutputConfig};
use crate::error::Result;
use crate::formats::manifest::SceneRecord;
use crate::integrate::{Progress, estimate_cells};
use crate::pipeline::{Job, WrittenFile, sha256_hex, write_jobs};
use crate::recipes::slices::{self, SliceOf, Slices};
use crate::recipes::{TableBuild, TableRecipe, reference_points};
use crate::sampling::sequence::scramble_seed;
use crate::stats::{AccuracyReport, ErrorSummary};
use crate::table::Table;

/// A scene build.
pub struct SceneBuildRequest {
    pub scene: Scene,
    /// Where the scene file was read from, and its text, recorded in the manifest.
    pub source: PathBuf,
    pub text: String,
    pub config: Config,
    pub out: PathBuf,
    pub error_maps: bool,
    /// Measure every slice against the exact integral and the full table (each full table the
    /// slices specialise is integrated once for it); the furnace, which measures the tables in
    /// the material itself, leaves this out.
    pub accuracy_reports: bool,
}

/// Build the plan of `request.scene`; returns the plan and the files written.
pub fn build_scene(request: &SceneBuildRequest, progress: &dyn Progress) -> Result<(Plan, Vec<WrittenFile>)> {
    let mut config = request.config.clone();
    if request.error_maps {
        config.fgd.replicate_error_columns = usize::MAX;
    }
    let plan = plan(&request.scene, &config)?;
    let seed = config.seed;
    // The full tables the slices are compared with, built once, without their own reference checks.
    let full_table = |settings: &dyn TableRecipe| -> Result<Table> { Ok(settings.build(seed, progress)?.table) };
    let has_slices_of = |fgd: bool| {
        request.accuracy_reports
            && plan
                .tables
                .iter()
                .any(|t| matches!(&t.build, PlannedBuild::Slices(s) if matches!(s.of, SliceOf::Fgd(_)) == fgd))
    };
    let full_fgd = if has_slices_of(true) {
        let mut settings = config.fgd.clone();
        settings.reference.cells = 0;
        settings.replicate_error_columns = 0;
        Some(full_table(&settings)?)
    } else {
        None
    };
    let full_tir = if has_slices_of(false) {
        let mut settings = config.tir.clone();
        settings.reference.cells = 0;
        Some(full_table(&settings)?)
    } else {
        None
    };

    let jobs: Vec<Job> = plan
        .tables
        .iter()
        .map(|planned| match &planned.build {
            PlannedBuild::Slices(slices) => {
                // Built above for every kind of slice planned, where accuracy is reported.
                let full = match slices.of {
                    SliceOf::Fgd(_) => full_fgd.as_ref(),
                    SliceOf::Tir(_) => full_tir.as_ref(),
                };
                Job {
                    run: Box::new(move |progress| {
                        let mut build = slices::build(slices, seed, progress)?;
                        if let Some(full) = full {
                            build.accuracy.extend(slice_accuracy(slices, &build, full, seed, progress)?);
                        }
                        Ok(build)
                    }),
                    output: slices.output(),
                    packings: Vec::new(),
                    fit_seed: None,
                }
            }
            other => {
                let recipe = other.recipe().expect("every other planned build is a full recipe");
                let packings = match other {
                    PlannedBuild::Fgd(settings) => settings.packings.clone(),
                    _ => Vec::new(),
                };
                // A TIR table over a sub-range is not what the analytic forms are fitted to: only
                // the full table of the fitted-form item is, and that table is not written.
                let (output, fit_seed) = match other {
                    PlannedBuild::TirFit(settings) => {
                        (OutputConfig { formats: Vec::new(), precision: settings.output.precision }, Some(seed))
                    }
                    _ => (recipe.output().clone(), None),
                };
                Job { run: Box::new(move |progress| recipe.build(seed, progress)), output, packings, fit_seed }
            }
        })
        .collect();
    let record = SceneRecord {
        name: request.scene.name.clone(),
        source: request.source.display().to_string(),
        sha256: sha256_hex(request.text.as_bytes()),
        text: request.text.clone(),
        plan: plan.record(),
    };
    let written = write_jobs(&request.out, jobs, request.error_maps, Some(record), progress)?;
    Ok((plan, written))
}

/// Query points of a slice's accuracy check: `count` `(mu, alpha)` uniform over the ranges its
/// lookups reach (a fixed roughness is queried at exactly that roughness).
fn query_points(slices: &Slices, count: usize, seed: u64) -> Vec<[f64; 2]> {
    let uniform = |stream: u64, k: usize| scramble_seed(seed, stream, k as u32) as f64 / 4_294_967_296.0;
    let ([mu_lo, mu_hi], [alpha_lo, alpha_hi]) = (slices.lookup_mu, slices.lookup_alpha);
    (0..count)
        .map(|k| {
            [mu_lo + uniform(0x5_11CE, k) * (mu_hi - mu_lo), alpha_lo + uniform(0x5_11CF, k) * (alpha_hi - alpha_lo)]
        })
        .collect()
}

/// The slice, and the full table at the same parameters, against the exact integral at random
/// points inside the slice's range.
pub fn slice_accuracy(
    slices: &Slices,
    build: &TableBuild,
    full: &Table,
    seed: u64,
    progress: &dyn Progress,
) -> Result<Vec<AccuracyReport>> {
    let reference = match &slices.of {
        SliceOf::Fgd(s) => s.reference,
        SliceOf::Tir(s) => s.reference,
    };
    let count = reference.cells.max(16);
    let queries = query_points(slices, count, seed ^ 0xACC0);
    let points = reference_points(reference.samples, seed ^ 0xACC1)?;
    let cells: Vec<u64> = (0..queries.len() as u64).collect();
    let exact = estimate_cells(&cells, &format!("{} accuracy", slices.name), progress, |k| {
        slices.estimate_node(&points, &queries[k as usize])
    });
    let mut slice_errors = Vec::new();
    let mut full_errors = Vec::new();
    let (mut worst_slice, mut worst_full) = ((0.0f64, String::new()), (0.0f64, String::new()));
    for (query, exact) in queries.iter().zip(&exact) {
        let stored = build.table.interpolate(query);
        for (k, channel) in slices.channels.iter().enumerate() {
            let full_point: Vec<f64> = match slices.of {
                SliceOf::Fgd(_) => vec![query[0], query[1], channel.eta, channel.kappa],
                SliceOf::Tir(_) => vec![query[0], query[1], channel.eta],
            };
            let full_value = full.interpolate(&full_point)[0];
            let at = format!(
                "mu {:.4}, alpha {:.4}, eta {:.4}, kappa {:.4}",
                query[0], query[1], channel.eta, channel.kappa
            );
            let (slice_error, full_error) = (stored[k] - exact.mean[k], full_value - exact.mean[k]);
            if slice_error.abs() >= worst_slice.0 {
                worst_slice = (slice_error.abs(), at.clone());
            }
            if full_error.abs() >= worst_full.0 {
                worst_full = (full_error.abs(), at);
            }
            slice_errors.push(slice_error);
            full_errors.push(full_error);
        }
    }
    let full_shape = full.axes.iter().map(|a| a.count.to_string()).collect::<Vec<_>>().join(" x ");
    let domain = format!(
        "{} random (mu, alpha) where its lookups are made x {} channel(s); exact: per-cell estimate, {} samples",
        queries.len(),
        slices.channels.len(),
        points.plan().total()
    );
    Ok(vec![
        AccuracyReport {
            what: format!("slice interpolated vs the exact integral; {domain}"),
            error: ErrorSummary::of_differences(slice_errors),
            worst_at: worst_slice.1,
        },
        AccuracyReport {
            what: format!("full {full_shape} table interpolated at the same points vs the exact integral; {domain}"),
            error: ErrorSummary::of_differences(full_errors),
            worst_at: worst_full.1,
        },
    ])
}
