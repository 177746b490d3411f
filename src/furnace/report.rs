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

/// The errors of a material. The model error and the total need the random walk: where it did
/// not run for the material (`--walk`), they are absent, not zero.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Errors {
    /// `A(tables) - A(exact)`: what the tables cost.
    pub table: ErrorFigures,
    /// `A(exact) - A(walk)`: what the model costs (the walk's own noise included).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<ErrorFigures>,
    /// `A(tables) - A(walk)`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub total: Option<ErrorFigures>,
    /// Views where the model error exceeds three of the walk's standard errors, per channel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model_error_beyond_3_standard_errors: Option<[usize; 3]>,
    /// Where the folder holds a bake of the material (`tmlut bake`): its baked values, read as a
    /// GPU filters them, against the model with exact integrals, at every view of the run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub baked: Option<crate::formats::baked::BakedErrors>,
    /// `A(baked) - A(walk)`: what a baked material shows, bake and model together.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub baked_total: Option<ErrorFigures>,
}

/// One material's curves and errors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MaterialReport {
    pub name: String,
    /// In a library (`tmlut furnace --library`), the scene the material came from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scene: Option<String>,
    pub model: FluxModel,
    pub albedo_path: AlbedoPath,
    pub tir_path: TirPath,
    /// The fitted form read in place of the TIR table where `tir_path` is `form`: its name, the
    /// path the scene gives, its definition and fitted parameters.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tir_form: Option<crate::fit::forms::FittedForm>,
    /// The fitted form read in place of the albedo table (`albedo = "fit:PATH"`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub albedo_form: Option<crate::fit::forms::FittedForm>,
    /// The stack at the values evaluated (the scene's, or the middle of a range it varies).
    pub stack: Stack,
    /// View cosines, from the normal to grazing.
    pub mu: Vec<f64>,
    /// `A(mu)` per channel: the model with the scene's tables.
    pub albedo_tables: Vec<Rgb>,
    /// The model with exact integrals.
    pub albedo_exact: Vec<Rgb>,
    /// Whether the random walk ran for this material; the `walk` fields below are absent where
    /// it did not. (Defaults, here and in the run's lists, read reports written before runs could
    /// leave the walk out, so that a new run into their folder still removes their pictures.)
    #[serde(default)]
    pub walked: bool,
    /// The random walk, with its standard errors.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub albedo_walk: Option<Vec<Rgb>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub walk_standard_error: Option<Vec<Rgb>>,
    /// What the walk transmitted through the bottom, and what its interfaces' masking lost.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub walk_transmitted: Option<Vec<Rgb>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub walk_lost: Option<Vec<Rgb>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub walk_paths: Option<Vec<u64>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub walk_truncated_paths: Option<u64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub walk_per_channel: Option<bool>,
    /// Wall time of the material's random walk, in seconds (all threads).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub walk_wall_time_s: Option<f64>,
    /// `A(mu)` read from the folder's bake of the material, where it holds one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub albedo_baked: Option<Vec<Rgb>>,
    pub errors: Errors,
    /// One model evaluation with the scene's tables on one CPU core, every lookup included:
    /// nanoseconds, median of the timed rounds.
    pub model_cost_ns: f64,
    /// Lookups of the material's curve (every view once) answered by a table whose range does
    /// not hold them (read clamped), and the first.
    pub clamped_lookups: u64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub first_clamped_lookup: Option<String>,
    /// Files written for the material (its pictures, where `--pictures` chose it), relative to
    /// the run's output folder.
    pub files: Vec<String>,
}

/// Where a run's wall time goes, in seconds.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct PhaseTimes {
    /// Building the scene's tables (0 with `--luts`).
    pub tables: f64,
    /// Opening the folder, the model with the tables and its timing.
    pub model_with_tables: f64,
    /// The exact integrals and the model reading them.
    pub exact: f64,
    /// The random walks.
    pub walk: f64,
    /// Reading the folder's bake and measuring it (0 without one).
    #[serde(default)]
    pub baked: f64,
    /// Drawing the pictures and plots.
    pub pictures: f64,
}

impl MaterialReport {
    /// Record the folder's bake of the material: its errors against the model with exact
    /// integrals, its albedo curve at the run's views, and that curve against the walk where the
    /// walk ran.
    pub fn add_baked(&mut self, errors: crate::formats::baked::BakedErrors, albedo_baked: Vec<Rgb>) {
        if let Some(walk) = &self.albedo_walk {
            self.errors.baked_total = Some(ErrorFigures::of(&self.mu, &albedo_baked, walk));
        }
        self.errors.baked = Some(errors);
        self.albedo_baked = Some(albedo_baked);
    }

    /// The TIR path as the scene writes it: `fit:PATH` for a named form.
    pub fn tir_label(&self) -> String {
        match &self.tir_form {
            Some(form) => format!("fit:{}", form.source),
            None => self.tir_path.name().to_string(),
        }
    }

    /// The albedo path as the scene writes it: `fit:PATH` for a named form.
    pub fn albedo_label(&self) -> String {
        match &self.albedo_form {
            Some(form) => format!("fit:{}", form.source),
            None => self.albedo_path.name().to_string(),
        }
    }

    /// `walk`: the random walk's curve and its wall time, where it ran.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        material: &crate::scene::SceneMaterial,
        scene: Option<String>,
        mus: &[f64],
        albedo_tables: Vec<Rgb>,
        albedo_exact: Vec<Rgb>,
        walk: Option<(Vec<WalkEstimate>, f64)>,
        model_cost_ns: f64,
        clamped: Misses,
    ) -> Self {
        let table = ErrorFigures::of(mus, &albedo_tables, &albedo_exact);
        let mut report = MaterialReport {
            name: material.name.clone(),
            scene,
            model: material.model,
            albedo_path: material.albedo,
            tir_path: material.tir,
            tir_form: material.tir_form.clone(),
            albedo_form: material.albedo_form.clone(),
            stack: material.stack().expect("evaluated above"),
            mu: mus.to_vec(),
            albedo_tables,
            albedo_exact,
            walked: false,
            albedo_walk: None,
            walk_standard_error: None,
            walk_transmitted: None,
            walk_lost: None,
            walk_paths: None,
            walk_truncated_paths: None,
            walk_per_channel: None,
            walk_wall_time_s: None,
            albedo_baked: None,
            errors: Errors {
                table,
                model: None,
                total: None,
                model_error_beyond_3_standard_errors: None,
                baked: None,
                baked_total: None,
            },
            model_cost_ns,
            clamped_lookups: clamped.count,
            first_clamped_lookup: clamped.first,
            files: Vec::new(),
        };
        if let Some((walk, wall_time_s)) = walk {
            let albedo_walk: Vec<Rgb> = walk.iter().map(|w| w.reflected).collect();
            let walk_standard_error: Vec<Rgb> = walk.iter().map(|w| w.reflected_standard_error).collect();
            let mut beyond = [0; 3];
            for ((exact, w), se) in report.albedo_exact.iter().zip(&albedo_walk).zip(&walk_standard_error) {
                for c in 0..3 {
                    if (exact[c] - w[c]).abs() > 3.0 * se[c] {
                        beyond[c] += 1;
                    }
                }
            }
            report.errors.model = Some(ErrorFigures::of(mus, &report.albedo_exact, &albedo_walk));
            report.errors.total = Some(ErrorFigures::of(mus, &report.albedo_tables, &albedo_walk));
            report.errors.model_error_beyond_3_standard_errors = Some(beyond);
            report.walked = true;
            report.albedo_walk = Some(albedo_walk);
            report.walk_standard_error = Some(walk_standard_error);
            report.walk_transmitted = Some(walk.iter().map(|w| w.transmitted).collect());
            report.walk_lost = Some(walk.iter().map(|w| w.lost).collect());
            report.walk_paths = Some(walk.iter().map(|w| w.paths).collect());
            report.walk_truncated_paths = Some(walk.iter().map(|w| w.truncated_paths).sum());
            report.walk_per_channel = Some(walk.iter().any(|w| w.per_channel_walks));
            report.walk_wall_time_s = Some(wall_time_s);
        }
        report
    }

    /// The largest standard error of the walk over views and channels, where it ran.
    pub fn walk_standard_error_max(&self) -> Option<f64> {
        self.walk_standard_error.as_ref().map(|se| se.iter().flatten().copied().fold(0.0, f64::max))
    }

    /// The scene whose budget holds the material: its own in a library, else the report's.
    pub fn scene_or<'a>(&'a self, report_scene: &'a str) -> &'a str {
        self.scene.as_deref().unwrap_or(report_scene)
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
    pub exact_nodes: usize,
    pub exact_method: String,
    pub walk_seed: u64,
    pub walk_target_standard_error: f64,
    pub walk_min_paths: u64,
    pub walk_max_paths: u64,
    pub walk_masking: String,
    pub fgd_source: String,
    pub timing_rounds: usize,
    pub environment_radiance: f64,
    /// `--walk` and `--pictures`: all, none or sample:N (N drawn from the walk's seed).
    #[serde(default)]
    pub walk: String,
    #[serde(default)]
    pub pictures: String,
    #[serde(default)]
    pub picture_size: usize,
}

impl SettingsRecord {
    fn of(settings: &FurnaceSettings, exact_nodes: usize) -> Self {
        SettingsRecord {
            views: settings.views,
            view_spacing: "mu = cos(pi/2 k / (views - 1)), k = 0 .. views - 1: uniform in angle from the normal to grazing; the grazing view is evaluated at mu = 1e-6, as the tables take mu = 0".into(),
            exact_nodes,
            exact_method: "f64 product Gauss-Legendre quadrature of the lookups' integrals (FGD, TIR's ratio, GD) over the visible normals in (theta_h, phi_h), exact_nodes per panel, every jump and kink (horizon, critical angle) a panel edge; independent of the tables' samples".into(),
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
            walk: settings.walk_materials.name(),
            pictures: settings.pictures.name(),
            picture_size: settings.picture_size,
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
    /// The materials the random walk ran for, and those drawn, by name.
    #[serde(default)]
    pub walked_materials: Vec<String>,
    #[serde(default)]
    pub pictured_materials: Vec<String>,
    /// Where the run's wall time went.
    #[serde(default)]
    pub wall_time_s: PhaseTimes,
    pub materials: Vec<MaterialReport>,
}

impl FurnaceReport {
    pub fn new(
        request: &FurnaceRequest,
        luts: &Path,
        exact_nodes: usize,
        materials: Vec<MaterialReport>,
        wall_time_s: PhaseTimes,
    ) -> Self {
        FurnaceReport {
            walked_materials: materials.iter().filter(|m| m.walked).map(|m| m.name.clone()).collect(),
            pictured_materials: materials.iter().filter(|m| !m.files.is_empty()).map(|m| m.name.clone()).collect(),
            wall_time_s,
            generator: format!("tmlut {}", env!("CARGO_PKG_VERSION")),
            scene: request.scene.name.clone(),
            source: request.source.clone(),
            luts: luts.display().to_string(),
            settings: SettingsRecord::of(&request.settings, exact_nodes),
            random_walk: crate::random_walk::modelling_choices(&request.settings.walk),
            materials,
        }
    }

    /// Write `furnace.json` into `dir` (atomically; a run writes it into its staging folder, and
    /// commits it with the pictures it lists).
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
pub const MARKDOWN_HEADER: &str = "| scene | material | model | albedo / TIR | table error max (RMS) | at mu | model error max (RMS) | total max | walk s.e. max | baked error max | ns/eval |\n|---|---|---|---|---|---|---|---|---|---|---|\n";

/// One Markdown row per material of `report`; the model error, the total and the walk's
/// standard error read `not walked` where the random walk did not run, the baked error `not
/// baked` where the folder holds no bake of the material.
pub fn markdown_rows(report: &FurnaceReport) -> String {
    let mut out = String::new();
    for m in &report.materials {
        let e = &m.errors;
        let (model, total, walk_se) = match (&e.model, &e.total, m.walk_standard_error_max()) {
            (Some(model), Some(total), Some(se)) => (
                format!("{:.2e} ({:.1e})", model.max_all, model.rms_all),
                format!("{:.2e}", total.max_all),
                format!("{se:.1e}"),
            ),
            _ => ("not walked".into(), "not walked".into(), "not walked".into()),
        };
        let baked = e.baked.as_ref().map_or("not baked".into(), |b| format!("{:.2e}", b.max()));
        out.push_str(&format!(
            "| {} | {} | {} | {} / {} | {:.2e} ({:.1e}) | {:.3} | {model} | {total} | {walk_se} | {baked} | {:.0} |\n",
            m.scene_or(&report.scene),
            m.name,
            m.model.name(),
            m.albedo_label(),
            m.tir_label(),
            e.table.max_all,
            e.table.rms_all,
            e.table.max_all_at_mu,
            m.model_cost_ns,
        ));
    }
    out
}
