//! What a furnace run writes: `furnace.json` with every curve and error, and the Markdown summary
//! printed to the terminal.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{FurnaceRequest, FurnaceSettings};
use crate::error::Result;
use crate::formats::write_bytes_atomically;
use crate::model::folder::Misses;
use crate::model::{AlbedoPath, FluxModel, Rgb, Stack, TirPath};
use crate::random_walk::WalkEstimate;

pub const FURNACE_FILE: &str = "furnace.json";

/// A difference between two albedo curves, over every view, per channel and in all.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorFigures {
    /// Root mean square over the views, per channel (R, G, B).
    pub rms: Rgb,
    /// Largest absolute difference over the views, per channel.
    pub max: Rgb,
    /// The view cosine of each channel's largest difference.
    pub max_at_mu: Rgb,
    /// The largest over the channels, with its view cosine and channel (0, 1, 2).
    pub max_all: f64,
    pub max_all_at_mu: f64,
    pub max_all_channel: usize,
    /// Root mean square over views and channels.
    pub rms_all: f64,
}

impl ErrorFigures {
    /// The figures of `a - b` over the views `mus`.
    pub fn of(mus: &[f64], a: &[Rgb], b: &[Rgb]) -> Self {
        let mut rms = [0.0; 3];
        let mut max = [0.0; 3];
        let mut max_at_mu = [mus[0]; 3];
        for ((&mu, a), b) in mus.iter().zip(a).zip(b) {
            for c in 0..3 {
                let d = a[c] - b[c];
                rms[c] += d * d;
                if d.abs() > max[c] {
                    max[c] = d.abs();
                    max_at_mu[c] = mu;
                }
            }
        }
        let n = mus.len() as f64;
        let rms_all = (rms.iter().sum::<f64>() / (3.0 * n)).sqrt();
        let rms = rms.map(|s| (s / n).sqrt());
        let channel = (0..3).max_by(|&i, &j| max[i].total_cmp(&max[j])).unwrap_or(0);
        ErrorFigures {
            rms,
            max,
            max_at_mu,
            max_all: max[channel],
            max_all_at_mu: max_at_mu[channel],
            max_all_channel: channel,
            rms_all,
        }
    }
}

/// The three errors of a material.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Errors {
    /// `A(tables) - A(exact)`: what the tables cost.
    pub table: ErrorFigures,
    /// `A(exact) - A(walk)`: what the model costs (the walk's own noise included).
    pub model: ErrorFigures,
    /// `A(tables) - A(walk)`.
    pub total: ErrorFigures,
    /// Views where the model error exceeds three of the walk's standard errors, per channel.
    pub model_error_beyond_3_standard_errors: [usize; 3],
}

/// One material's curves and errors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MaterialReport {
    pub name: String,
    pub model: FluxModel,
    pub albedo_path: AlbedoPath,
    pub tir_path: TirPath,
    /// The stack at the values evaluated (the scene's, or the middle of a range it varies).
    pub stack: Stack,
    /// View cosines, from the normal to grazing.
    pub mu: Vec<f64>,
    /// `A(mu)` per channel: the model with the scene's tables.
    pub albedo_tables: Vec<Rgb>,
    /// The model with exact integrals.
    pub albedo_exact: Vec<Rgb>,
    /// The random walk, with its standard errors.
    pub albedo_walk: Vec<Rgb>,
    pub walk_standard_error: Vec<Rgb>,
    /// What the walk transmitted through the bottom, and what its interfaces' masking lost.
    pub walk_transmitted: Vec<Rgb>,
    pub walk_lost: Vec<Rgb>,
    pub walk_paths: Vec<u64>,
    pub walk_truncated_paths: u64,
    pub walk_per_channel: bool,
    pub errors: Errors,
    /// One model evaluation with the scene's tables on one CPU core, every lookup included:
    /// nanoseconds, median of the timed rounds.
    pub model_cost_ns: f64,
    /// Lookups answered by a table whose range does not hold them (read clamped), and the first.
    pub clamped_lookups: u64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub first_clamped_lookup: Option<String>,
    /// Files written for the material, relative to the scene's output folder.
    pub files: Vec<String>,
    /// Wall time of the exact integrals and of the random walk, in seconds (all threads).
    pub wall_time_s: WallTimes,
}

/// Where a material's furnace time goes.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct WallTimes {
    pub exact: f64,
    pub walk: f64,
}

impl MaterialReport {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        material: &crate::scene::Material,
        mus: &[f64],
        albedo_tables: Vec<Rgb>,
        albedo_exact: Vec<Rgb>,
        walk: &[WalkEstimate],
        model_cost_ns: f64,
        clamped: Misses,
    ) -> Self {
        let albedo_walk: Vec<Rgb> = walk.iter().map(|w| w.reflected).collect();
        let walk_standard_error: Vec<Rgb> = walk.iter().map(|w| w.reflected_standard_error).collect();
        let mut beyond = [0; 3];
        for ((exact, w), se) in albedo_exact.iter().zip(&albedo_walk).zip(&walk_standard_error) {
            for c in 0..3 {
                if (exact[c] - w[c]).abs() > 3.0 * se[c] {
                    beyond[c] += 1;
                }
            }
        }
        let errors = Errors {
            table: ErrorFigures::of(mus, &albedo_tables, &albedo_exact),
            model: ErrorFigures::of(mus, &albedo_exact, &albedo_walk),
            total: ErrorFigures::of(mus, &albedo_tables, &albedo_walk),
            model_error_beyond_3_standard_errors: beyond,
        };
        let stem = file_stem(&material.name);
        MaterialReport {
            name: material.name.clone(),
            model: material.model,
            albedo_path: material.albedo,
            tir_path: material.tir,
            stack: material.stack().expect("evaluated above"),
            mu: mus.to_vec(),
            albedo_tables,
            albedo_exact,
            albedo_walk,
            walk_standard_error,
            walk_transmitted: walk.iter().map(|w| w.transmitted).collect(),
            walk_lost: walk.iter().map(|w| w.lost).collect(),
            walk_paths: walk.iter().map(|w| w.paths).collect(),
            walk_truncated_paths: walk.iter().map(|w| w.truncated_paths).sum(),
            walk_per_channel: walk.iter().any(|w| w.per_channel_walks),
            errors,
            model_cost_ns,
            clamped_lookups: clamped.count,
            first_clamped_lookup: clamped.first,
            files: vec![format!("{stem}_furnace.exr"), format!("{stem}_furnace.png"), format!("{stem}_albedo.png")],
            wall_time_s: WallTimes::default(),
        }
    }

    /// The largest standard error of the walk over views and channels.
    pub fn walk_standard_error_max(&self) -> f64 {
        self.walk_standard_error.iter().flatten().copied().fold(0.0, f64::max)
    }
}

/// A scene or material name as it may appear in a file name: the one mapping the scene parser
/// holds names apart by.
pub fn file_stem(name: &str) -> String {
    crate::scene::file_name_part(name)
}

/// The settings a run was made with, as recorded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SettingsRecord {
    pub views: usize,
    pub view_spacing: String,
    pub exact_samples: u64,
    pub exact_method: String,
    pub walk_seed: u64,
    pub walk_target_standard_error: f64,
    pub walk_min_paths: u64,
    pub walk_max_paths: u64,
    pub walk_masking: String,
    pub fgd_source: String,
    pub timing_rounds: usize,
    pub environment_radiance: f64,
}

impl SettingsRecord {
    fn of(settings: &FurnaceSettings, exact_samples: u64) -> Self {
        SettingsRecord {
            views: settings.views,
            view_spacing: "mu = cos(pi/2 k / (views - 1)), k = 0 .. views - 1: uniform in angle from the normal to grazing; the grazing view is evaluated at mu = 1e-6, as the tables take mu = 0".into(),
            exact_samples,
            exact_method: "per-cell f64 visible-normal estimates of the lookups' integrals (FGD, TIR's ratio, GD), Owen-scrambled Sobol points independent of the tables'".into(),
            walk_seed: settings.walk.seed,
            walk_target_standard_error: settings.walk.target_standard_error,
            walk_min_paths: settings.walk.min_paths,
            walk_max_paths: settings.walk.max_paths,
            walk_masking: settings.walk.masking.name().into(),
            fgd_source: match settings.fgd_source {
                crate::model::folder::FgdSource::Packing => "the lossless packing where the folder has it, else the 4D table (fgd.exr or fgd.bin)".into(),
                crate::model::folder::FgdSource::Table => "the 4D table (fgd.exr or fgd.bin), interpolated on the CPU".into(),
            },
            timing_rounds: settings.timing_rounds,
            environment_radiance: super::ENVIRONMENT_RADIANCE,
        }
    }
}

/// The furnace run of one scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FurnaceReport {
    pub generator: String,
    pub scene: String,
    pub source: String,
    /// The folder of tables the model read.
    pub luts: String,
    pub settings: SettingsRecord,
    /// How the random walk models the stack.
    pub random_walk: Vec<String>,
    pub materials: Vec<MaterialReport>,
}

impl FurnaceReport {
    pub fn new(request: &FurnaceRequest, luts: &Path, exact_samples: u64, materials: Vec<MaterialReport>) -> Self {
        FurnaceReport {
            generator: format!("tmlut {}", env!("CARGO_PKG_VERSION")),
            scene: request.scene.name.clone(),
            source: request.source.clone(),
            luts: luts.display().to_string(),
            settings: SettingsRecord::of(&request.settings, exact_samples),
            random_walk: crate::random_walk::modelling_choices(&request.settings.walk),
            materials,
        }
    }

    /// Write `furnace.json` into `dir` (atomically).
    pub fn write(&self, dir: &Path) -> Result<()> {
        let mut text = serde_json::to_string_pretty(self).expect("a furnace report is plain data");
        text.push('\n');
        write_bytes_atomically(&dir.join(FURNACE_FILE), text.as_bytes())
    }

    pub fn read(path: &Path) -> Result<Self> {
        let bytes = crate::formats::read_bytes_at_most(path, crate::formats::MAX_MANIFEST_BYTES, "a furnace report")?;
        serde_json::from_slice(&bytes)
            .map_err(|e| crate::error::Error::format(path, format!("not a tmlut furnace report: {e}")))
    }
}

/// The header of [`markdown_rows`].
pub const MARKDOWN_HEADER: &str = "| scene | material | model | albedo / TIR | table error max (RMS) | at mu | model error max (RMS) | total max | walk s.e. max | ns/eval |\n|---|---|---|---|---|---|---|---|---|---|\n";

/// One Markdown row per material of `report`.
pub fn markdown_rows(report: &FurnaceReport) -> String {
    let mut out = String::new();
    for m in &report.materials {
        let e = &m.errors;
        out.push_str(&format!(
            "| {} | {} | {} | {} / {} | {:.2e} ({:.1e}) | {:.3} | {:.2e} ({:.1e}) | {:.2e} | {:.1e} | {:.0} |\n",
            report.scene,
            m.name,
            m.model.name(),
            m.albedo_path.name(),
            m.tir_path.name(),
            e.table.max_all,
            e.table.rms_all,
            e.table.max_all_at_mu,
            e.model.max_all,
            e.model.rms_all,
            e.total.max_all,
            m.walk_standard_error_max(),
            m.model_cost_ns,
        ));
    }
    out
}
