//! The furnace test: every material of a scene under a uniform environment, its directional albedo
//! `A(mu)` three ways, so that what the tables cost and what the model costs are measured apart
//! (`docs/furnace.md`):
//! - the transfer-matrix model reading the scene's tables as a renderer does
//!   ([`crate::model::folder::FolderTables`]);
//! - the same model reading exact integrals instead ([`exact::ExactTables`]);
//! - a random walk through the explicit stack, which shares none of the model's approximations
//!   ([`crate::random_walk`]).
//!
//! `table error = A(tables) - A(exact)`, `model error = A(exact) - A(walk)`, and their sum the
//! total. A uniform environment of radiance `L` seen at view cosine `mu` returns `L A(mu)`
//! (reciprocity), so a furnace sphere is `A` drawn over the sphere's view cosines ([`picture`]).

pub mod exact;
pub mod picture;
pub mod report;

use std::path::{Path, PathBuf};
use std::time::Instant;

use rayon::prelude::*;

use crate::config::Config;
use crate::error::{Error, Result};
use crate::integrate::{GRAZING_COSINE, Progress};
use crate::loader::LutFolder;
use crate::model::folder::{FgdSource, FolderTables};
use crate::model::{Material, Rgb, Tables};
use crate::random_walk::{self, WalkSettings};
use crate::scene::Scene;
use crate::scene::build::{SceneBuildRequest, SliceChecks, SliceLayout, build_scene};
use exact::ExactTables;
pub use report::{ErrorFigures, FurnaceReport, MaterialReport};

/// Radiance of the uniform environment of the furnace pictures: the thesis's 0.42 (its §5.2), about
/// mid-way between no energy and all of it, so that both loss and gain show.
pub const ENVIRONMENT_RADIANCE: f64 = 0.42;

/// How a furnace run measures.
#[derive(Debug, Clone, PartialEq)]
pub struct FurnaceSettings {
    /// View cosines per material, uniform in angle from the normal to grazing (both included).
    pub views: usize,
    /// Samples of each exact integral (a power of two).
    pub exact_samples: u64,
    pub walk: WalkSettings,
    /// Which full FGD table the FGD path reads where a folder has two.
    pub fgd_source: FgdSource,
    /// Timed rounds of the model over every view (the median round is reported).
    pub timing_rounds: usize,
    /// Width and height of each sphere in the pictures, in pixels.
    pub picture_size: usize,
}

impl Default for FurnaceSettings {
    fn default() -> Self {
        FurnaceSettings {
            views: 64,
            exact_samples: 1 << 16,
            walk: WalkSettings::default(),
            fgd_source: FgdSource::default(),
            timing_rounds: 21,
            picture_size: 256,
        }
    }
}

/// View cosines a furnace run allows per material.
pub const VIEWS: std::ops::RangeInclusive<usize> = 2..=4096;
/// Sphere sizes of the pictures, in pixels.
pub const PICTURE_SIZES: std::ops::RangeInclusive<usize> = 16..=4096;

impl FurnaceSettings {
    pub fn validate(&self) -> Result<()> {
        if !VIEWS.contains(&self.views) {
            return Err(Error::invalid(
                "views",
                format!("{}; allowed: {} to {}", self.views, VIEWS.start(), VIEWS.end()),
            ));
        }
        crate::sampling::sequence::SamplePlan::new(self.exact_samples, 1)
            .map_err(|e| Error::invalid("exact samples", e.to_string()))?;
        if !(self.walk.target_standard_error > 0.0 && self.walk.target_standard_error.is_finite()) {
            return Err(Error::invalid(
                "walk standard error",
                format!("{}; allowed: finite and > 0", self.walk.target_standard_error),
            ));
        }
        let max_paths = random_walk::MAX_PATHS;
        if self.walk.min_paths == 0 || self.walk.min_paths > self.walk.max_paths || self.walk.max_paths > max_paths {
            return Err(Error::invalid(
                "walk paths",
                format!(
                    "min {} and max {}; allowed: 1 <= min <= max <= 2^30 = {max_paths}",
                    self.walk.min_paths, self.walk.max_paths
                ),
            ));
        }
        if !PICTURE_SIZES.contains(&self.picture_size) {
            return Err(Error::invalid(
                "picture size",
                format!("{}; allowed: {} to {}", self.picture_size, PICTURE_SIZES.start(), PICTURE_SIZES.end()),
            ));
        }
        if self.timing_rounds == 0 {
            return Err(Error::invalid("timing rounds", "0; allowed: 1 or more"));
        }
        Ok(())
    }

    /// The view cosines: `cos(pi/2 k / (views - 1))`, the grazing one evaluated at its limit
    /// [`GRAZING_COSINE`], as the tables take `mu = 0`.
    pub fn view_cosines(&self) -> Vec<f64> {
        (0..self.views)
            .map(|k| {
                let theta = std::f64::consts::FRAC_PI_2 * k as f64 / (self.views - 1) as f64;
                if k + 1 == self.views { GRAZING_COSINE } else { theta.cos().max(GRAZING_COSINE) }
            })
            .collect()
    }
}

/// One scene's furnace run.
pub struct FurnaceRequest {
    pub scene: Scene,
    /// Where the scene came from, and its text (recorded in the output).
    pub source: String,
    pub text: String,
    /// A folder built for the scene (or the default set); `None` builds the scene's plan into
    /// `<out>/luts` first.
    pub luts: Option<PathBuf>,
    /// The scene's output folder.
    pub out: PathBuf,
    /// The table settings a missing folder is built with.
    pub config: Config,
    pub settings: FurnaceSettings,
}

/// Run the furnace on every material of a scene and write its outputs into `request.out`:
/// `furnace.json`, and per material `<material>_furnace.exr`, `.png` and `<material>_albedo.png`.
pub fn run(request: &FurnaceRequest, progress: &dyn Progress) -> Result<FurnaceReport> {
    request.settings.validate()?;
    std::fs::create_dir_all(&request.out).map_err(|source| Error::io(&request.out, source))?;
    let luts = match &request.luts {
        Some(dir) => dir.clone(),
        None => {
            let dir = request.out.join("luts");
            // The furnace measures the tables in the material itself: the tables' own reference
            // checks and the slices' accuracy reports would only repeat it, slower.
            let mut config = request.config.clone();
            config.disable_reference_checks();
            let build = SceneBuildRequest {
                scene: request.scene.clone(),
                source: PathBuf::from(&request.source),
                text: request.text.clone(),
                config,
                out: dir.clone(),
                error_maps: false,
                slice_checks: SliceChecks::None,
                cache: None,
                slice_layout: SliceLayout::Auto,
                shard: None,
                merge_from: Vec::new(),
            };
            build_scene(&build, progress)?;
            dir
        }
    };
    let folder = LutFolder::open(&luts)?;
    let exact = ExactTables::new(&request.config, request.settings.exact_samples, request.config.seed)?;
    let mus = request.settings.view_cosines();
    let mut materials = Vec::new();
    for (index, material) in request.scene.materials.iter().enumerate() {
        let model = Material::new(material.model, material.stack()?);
        let tables = FolderTables::open(&folder, material.albedo, material.tir, request.settings.fgd_source)
            .map_err(|e| Error::invalid(format!("material `{}`", material.name), e.to_string()))?;
        let with_tables: Vec<Rgb> = mus.iter().map(|&mu| model.albedo(mu, &tables)).collect();
        let misses = tables.misses();
        if let Some(first) = misses.first {
            return Err(Error::invalid(
                format!("material `{}`", material.name),
                format!(
                    "{} has no table for {} lookup(s), the first: {first}; build the scene's tables into it (tmlut build --scene) or leave out --luts",
                    luts.display(),
                    misses.count
                ),
            ));
        }
        let started = Instant::now();
        progress.start(&format!("{} exact", material.name), mus.len() as u64);
        let with_exact: Vec<Rgb> = mus
            .par_iter()
            .map(|&mu| {
                let a = model.albedo(mu, &exact);
                progress.advance(1);
                a
            })
            .collect();
        progress.finish();
        let exact_s = started.elapsed().as_secs_f64();
        let walk_settings =
            WalkSettings { seed: walk_seed(request.settings.walk.seed, index), ..request.settings.walk };
        let started = Instant::now();
        let walk = random_walk::directional_albedo_curve(&model.stack, &mus, &walk_settings, progress);
        let walk_s = started.elapsed().as_secs_f64();
        let cost_ns = time_model(&model, &tables, &mus, request.settings.timing_rounds);
        let mut report = MaterialReport::new(material, &mus, with_tables, with_exact, &walk, cost_ns, tables.clamped());
        report.wall_time_s = report::WallTimes { exact: exact_s, walk: walk_s };
        picture::write_material_pictures(&request.out, &report, request.settings.picture_size)?;
        materials.push(report);
    }
    let report = FurnaceReport::new(request, &luts, exact.samples(), materials);
    report.write(&request.out)?;
    Ok(report)
}

/// The walk seed of material `index`: independent streams per material, from one seed.
fn walk_seed(seed: u64, index: usize) -> u64 {
    crate::sampling::sequence::scramble_seed(seed, 0xF0_2ACE, index as u32) as u64 | (seed << 32)
}

/// Nanoseconds per model evaluation with `tables` (every lookup included), on this thread: the
/// median over `rounds` of the mean over every view of a round.
pub fn time_model(model: &Material, tables: &dyn Tables, mus: &[f64], rounds: usize) -> f64 {
    let mut per_round = Vec::with_capacity(rounds);
    // One round to warm caches.
    for round in 0..=rounds {
        let started = Instant::now();
        for &mu in mus {
            std::hint::black_box(model.albedo(std::hint::black_box(mu), tables));
        }
        if round > 0 {
            per_round.push(started.elapsed().as_secs_f64() * 1e9 / mus.len() as f64);
        }
    }
    crate::stats::median(&per_round)
}

/// The scenes of `dir` (`*.toml`, sorted by file name), for `tmlut furnace` without a scene.
pub fn scene_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let entries = std::fs::read_dir(dir).map_err(|source| Error::io(dir, source))?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "toml") && p.is_file())
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(Error::invalid(dir.display().to_string(), "holds no scene (*.toml)"));
    }
    Ok(files)
}
