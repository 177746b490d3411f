//! `tmlut build --scene`: build exactly a scene's plan, and measure what specialising cost.
//!
//! Every slice table is checked as every full table is ([`crate::recipes::interpolation`]), at
//! random `(mu, alpha)` inside the ranges its lookups reach and every channel, against the exact
//! integral (the deterministic quadrature, at the reference nodes): the slice as written, read as a
//! renderer reads it, goes into its manifest entry's `error.interpolation`; what the full table of
//! the same configuration would have given at the same points (interpolated across `eta` and
//! `kappa` too, and clamped at its range's end) into its `accuracy`.

use std::path::{Path, PathBuf};

use super::Scene;
use super::cache::{CacheKey, SliceCache};
use super::plan::{Plan, PlannedBuild, plan};
use crate::config::{Config, OutputConfig};
use crate::error::{Error, Result};
use crate::formats::Precision;
use crate::formats::manifest::SceneRecord;
use crate::formats::slice_array::{self, SliceArrayEntry};
use crate::integrate::Progress;
use crate::pipeline::{Job, WrittenFile, sha256_hex, write_jobs};
use crate::recipes::driver::TableBuild;
use crate::recipes::interpolation::{self, Domain, ExactValues, InterpolationConfig};
use crate::recipes::slices::{SliceOf, Slices, integrate_batch_among};
use crate::recipes::{Companions, TableRecipe};
use crate::stats::AccuracyReport;
use crate::table::{Channel, Table, derived};

/// A scene build.
pub struct SceneBuildRequest {
    pub scene: Scene,
    /// Where the scene file was read from, and its text, recorded in the manifest.
    pub source: PathBuf,
    pub text: String,
    pub config: Config,
    pub out: PathBuf,
    pub error_maps: bool,
    pub slice_checks: SliceChecks,
    /// The table cache to read built tables from and store new ones in ([`super::cache`]).
    pub cache: Option<PathBuf>,
    pub slice_layout: SliceLayout,
    /// The most textures the scene's shader may bind: [`SliceLayout::Auto`] writes the slices as
    /// arrays where files of their own would make more, and a shader binding more is refused.
    pub max_textures: usize,
    /// Build only this shard's tables, into `cache`, and write no folder.
    pub shard: Option<Shard>,
    /// The shard folders a merge joins (`tmlut merge`): every table is read from them (verified),
    /// none integrated.
    pub merge_from: Vec<PathBuf>,
}

impl SceneBuildRequest {
    /// The key under which the table cache keeps this build whole ([`super::cache::store_build`]):
    /// the SHA-256 of everything its output folder's files depend on (the scenes as parsed, their
    /// sources and texts as the manifest records them, the configuration with its seed, its files'
    /// formats and precision among it, the options, the cache format and the version). None where
    /// a build is not kept whole: no cache, a shard or a merge, or error maps (files outside the
    /// manifest's list).
    pub fn whole_build_key(&self) -> Option<String> {
        if self.cache.is_none() || self.shard.is_some() || !self.merge_from.is_empty() || self.error_maps {
            return None;
        }
        let options = format!("{:?} {:?} {}", self.slice_checks, self.slice_layout, self.max_textures);
        Some(self.key_with(&self.config, options))
    }

    /// The key of the library a shard holds part of, which `tmlut merge` must be given again:
    /// the SHA-256 of the scenes as parsed and as written, the configuration with its seed as it
    /// integrates (its files' formats and precision are the merge's to choose, as its slice layout
    /// is), the slice checks (which decide what each slice's entry holds), the cache format and the
    /// version.
    pub fn library_key(&self) -> String {
        let mut integrated = self.config.clone();
        integrated.clear_written_settings();
        self.key_with(&integrated, format!("{:?}", self.slice_checks))
    }

    /// The SHA-256 of the scenes as parsed and as written, `config` with its seed, `options` (what
    /// of the request's options the key covers), the cache format and the version.
    fn key_with(&self, config: &Config, options: String) -> String {
        // A bake comes after the tables and is made again whole: its settings decide none of them.
        let config = Config { bake: Default::default(), ..config.clone() };
        let scene = format!("{:?}", self.scene);
        let source = self.source.display().to_string();
        let fields =
            (super::cache::CACHE_FORMAT, env!("CARGO_PKG_VERSION"), scene, source, &self.text, &config, options);
        sha256_hex(&serde_json::to_vec(&fields).expect("plain data"))
    }
}

/// One of `count` parts of a build (`--shard index/count`, `index` from 1; [`Shard::owned`] says
/// which tables). Every shard plans the whole library, so the shards of a plan partition its
/// tables, and checks drawn across the build's slices are drawn alike in every shard
/// ([`crate::recipes::slices::integrate_batch_among`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

/// The most shards a build is split into.
pub const MAX_SHARDS: usize = 4096;

impl Shard {
    /// `I/N` with `1 <= I <= N <= MAX_SHARDS`.
    pub fn parse(text: &str) -> std::result::Result<Shard, String> {
        let refuse = || format!("`{text}` is not a shard: give I/N, the I-th of N parts, 1 <= I <= N <= {MAX_SHARDS}");
        let (index, count) = text.split_once('/').ok_or_else(refuse)?;
        let (index, count) = (
            index.trim().parse::<usize>().map_err(|_| refuse())?,
            count.trim().parse::<usize>().map_err(|_| refuse())?,
        );
        if index == 0 || index > count || count > MAX_SHARDS {
            return Err(refuse());
        }
        Ok(Shard { index, count })
    }

    /// Whether each table of `plan` is this shard's. Slices are ordered by kind and where they lie
    /// on the lattice (`alpha`, then `mu`) and cut into `count` runs of equal length, so that the
    /// lattice nodes a shard integrates are mostly its own: slices of neighbouring roughness share
    /// nodes, and a node two shards hold is integrated by both. The other tables go round-robin.
    pub fn owned(&self, plan: &Plan) -> Vec<bool> {
        let mut slices: Vec<(usize, &Slices)> = plan
            .tables
            .iter()
            .enumerate()
            .filter_map(|(place, t)| match &t.build {
                PlannedBuild::Slices(slices) => Some((place, slices)),
                _ => None,
            })
            .collect();
        slices.sort_by(|(_, a), (_, b)| {
            (matches!(a.of, SliceOf::Tir(_)), a.alpha.start, a.mu.start, &a.name)
                .partial_cmp(&(matches!(b.of, SliceOf::Tir(_)), b.alpha.start, b.mu.start, &b.name))
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        let mut owned = vec![false; plan.tables.len()];
        let run = slices.len().div_ceil(self.count).max(1);
        for (rank, (place, _)) in slices.iter().enumerate() {
            owned[*place] = rank / run == self.index - 1;
        }
        let others = (0..plan.tables.len()).filter(|&p| !matches!(plan.tables[p].build, PlannedBuild::Slices(_)));
        for (rank, place) in others.enumerate() {
            owned[place] = rank % self.count == self.index - 1;
        }
        owned
    }
}

/// How the slices of a scene build are written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SliceLayout {
    /// A texture file per slice.
    Files,
    /// Texture arrays of slices ([`crate::formats::slice_array`]): a few files, whatever the
    /// number of materials.
    Arrays,
    /// A file per slice where the shader then binds at most the request's `max_textures`
    /// textures (the slices and the plan's other tables), arrays otherwise.
    Auto,
}

/// How the slices of a scene build are checked against the exact integral.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SliceChecks {
    /// Reference cells and interpolation points drawn at random across every slice of the build
    /// ([`crate::recipes::slices::integrate_batch`]): the cost of a few slices' checks, whatever
    /// the number of materials.
    Sampled,
    /// Every slice checked on its own, and against the full table of the same configuration
    /// (each full table the slices specialise is integrated once for it).
    Full,
    /// No checks: the furnace measures the tables in the material itself.
    None,
}

/// What a scene build did: its closing summary.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SceneBuildSummary {
    pub materials: usize,
    pub tables: usize,
    pub merged_slices: usize,
    pub slices: usize,
    pub slices_from_cache: usize,
    pub texel_bytes: u64,
    pub files: usize,
    pub file_bytes: u64,
    /// Wall time of each phase: planning; the slices (cache, integration, checks); the other
    /// tables, writing and the commit.
    pub plan_s: f64,
    pub slices_s: f64,
    pub rest_s: f64,
}

impl std::fmt::Display for SceneBuildSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let total = self.plan_s + self.slices_s + self.rest_s;
        write!(
            f,
            "{} materials: {} tables ({} slices, {} of them from the cache; {} identical slices merged), {} of texels in {} files ({}); \
             {:.2} s: plan {:.2} s, slices {:.2} s, other tables and writing {:.2} s ({:.1} materials per second)",
            self.materials,
            self.tables,
            self.slices,
            self.slices_from_cache,
            self.merged_slices,
            super::plan::human_bytes(self.texel_bytes),
            self.files,
            super::plan::human_bytes(self.file_bytes),
            total,
            self.plan_s,
            self.slices_s,
            self.rest_s,
            self.materials as f64 / total.max(1e-9)
        )
    }
}

/// Build the plan of `request.scene`; returns the plan, the files written and a summary.
///
/// The steps, in order: the options checked, the plan made and its memory checked, the full
/// tables the slices are compared with built (`--slice-checks full`), the cache or the shards
/// opened, the slices read from them or integrated together, then either a shard's tables stored
/// in its folder, or every table written into the output folder as one commit.
pub fn build_scene(
    request: &SceneBuildRequest,
    progress: &dyn Progress,
) -> Result<(Plan, Vec<WrittenFile>, SceneBuildSummary)> {
    let started = std::time::Instant::now();
    check_options(request)?;
    let config = planning_config(request);
    let plan = plan(&request.scene, &config)?;
    check_memory(request, &plan)?;
    let plan_s = started.elapsed().as_secs_f64();
    let seed = config.seed;
    let full = FullTables::build(request, &plan, &config, progress)?;
    let cache = open_cache(request)?;
    let owned = request.shard.map(|shard| shard.owned(&plan));
    let build = SceneBuild { request, plan: &plan, seed, owned, cache, progress };

    // Every slice of the plan in one pass over the nodes they share, unless each is checked alone.
    let all_slices = build.slices(|_| true);
    let own_slices = build.slices(|place| build.owns(place));
    let slices_started = std::time::Instant::now();
    let (mut batch, slices_from_cache) = build.read_or_integrate(&own_slices, &all_slices)?;
    if let Some(shard) = request.shard {
        let mut summary = build.store_shard(shard, &own_slices, slices_from_cache)?;
        summary.plan_s = plan_s;
        summary.slices_s = slices_started.elapsed().as_secs_f64();
        return Ok((plan, Vec::new(), summary));
    }
    let arrays = match request.slice_layout {
        SliceLayout::Files => false,
        SliceLayout::Arrays => !all_slices.is_empty(),
        SliceLayout::Auto => !all_slices.is_empty() && textures_with_slice_files(&plan) > request.max_textures,
    };
    if arrays && request.slice_checks == SliceChecks::Full {
        // An array is written from all its slices at once: each is built and checked on its own first.
        for slices in &all_slices {
            batch.insert(slices.name.clone(), checked_slice(slices, full.of(slices), seed, progress)?);
        }
    }
    let array_jobs = if arrays { slice_array_jobs(&all_slices, &batch)? } else { Vec::new() };
    let slices_s = slices_started.elapsed().as_secs_f64();
    let rest_started = std::time::Instant::now();

    let (batch, full) = (&batch, &full);
    let jobs: Vec<Job> = array_jobs
        .into_iter()
        .chain(plan.tables.iter().filter(|t| !(arrays && matches!(t.build, PlannedBuild::Slices(_)))).map(|planned| {
            match &planned.build {
                PlannedBuild::Slices(slices) => slice_job(slices, batch, full.of(slices), seed),
                other => build.table_job(other),
            }
        }))
        .collect();
    let record =
        SceneRecord::new(&request.scene.name, request.source.display().to_string(), &request.text, plan.record());
    let written = write_jobs(&request.out, jobs, request.error_maps, Some(record), progress)?;
    if let Some(cache) = &build.cache {
        progress.note(&format!(
            "table cache {}: {} of {} tables read from it",
            cache.dir.display(),
            cache.hits(),
            plan.tables.iter().filter(|t| !matches!(t.build, PlannedBuild::TirFit(_))).count()
        ));
        for warning in cache.warnings() {
            progress.note(&format!("warning: {warning}"));
        }
    }
    let summary = SceneBuildSummary {
        materials: request.scene.materials.len(),
        tables: plan.tables.len(),
        merged_slices: plan.merged_slices,
        slices: all_slices.len(),
        slices_from_cache,
        texel_bytes: plan.bytes,
        files: written.len(),
        file_bytes: written.iter().map(|w| w.entry.bytes).sum(),
        plan_s,
        slices_s,
        rest_s: rest_started.elapsed().as_secs_f64(),
    };
    Ok((plan, written, summary))
}

/// The textures a scene shader binds at most over the plan's tables with a file per slice: each
/// slice, and each other table but the fitted TIR form (a function, not a texture; the 4D FGD
/// table is bound as its packing).
fn textures_with_slice_files(plan: &Plan) -> usize {
    plan.tables.iter().filter(|t| !matches!(t.build, PlannedBuild::TirFit(_))).count()
}

/// The options a scene build refuses together, before it plans anything.
fn check_options(request: &SceneBuildRequest) -> Result<()> {
    let merging = !request.merge_from.is_empty();
    if (request.shard.is_some() || merging) && request.slice_checks == SliceChecks::Full {
        return Err(Error::invalid(
            "--slice-checks full",
            "checks each slice against the full table, which a shard or a merge does not build; allowed with --shard and merge: sampled, none",
        ));
    }
    if request.shard.is_some() && request.cache.is_none() {
        return Err(Error::invalid("--shard", "a shard writes its tables into a cache folder: give --cache DIR"));
    }
    Ok(())
}

/// The memory the plan's build needs, checked before it allocates: the slices' builds are held
/// until the arrays are written, and the scene's shader follows a build that is not a shard.
fn check_memory(request: &SceneBuildRequest, plan: &Plan) -> Result<()> {
    let slice_count = plan.tables.iter().filter(|t| matches!(t.build, PlannedBuild::Slices(_))).count();
    let shader = if request.shard.is_none() { request.scene.materials.len() as u128 } else { 0 };
    super::memory::check(
        &format!("scene `{}`", request.scene.name),
        &format!("building its {slice_count} slices and the shader of its {} materials", request.scene.materials.len()),
        super::memory::BASE_BYTES
            + super::memory::BYTES_PER_SLICE * slice_count as u128
            + super::memory::SHADER_BYTES_PER_MATERIAL * shader,
        "build fewer materials at a time (split the library, or --shard)",
    )
}

/// The full FGD and TIR tables slices are compared with under `--slice-checks full`, each built
/// once where the plan has slices of it, without its own reference checks.
struct FullTables {
    fgd: Option<Table>,
    tir: Option<Table>,
}

impl FullTables {
    fn build(request: &SceneBuildRequest, plan: &Plan, config: &Config, progress: &dyn Progress) -> Result<Self> {
        let has_slices_of = |fgd: bool| {
            request.slice_checks == SliceChecks::Full
                && plan
                    .tables
                    .iter()
                    .any(|t| matches!(&t.build, PlannedBuild::Slices(s) if matches!(s.of, SliceOf::Fgd(_)) == fgd))
        };
        let full_table =
            |settings: &dyn TableRecipe| -> Result<Table> { Ok(settings.build(config.seed, progress)?.table) };
        let fgd = if has_slices_of(true) {
            let mut settings = config.fgd.clone();
            settings.shared.reference.cells = 0;
            settings.shared.interpolation.points = 0;
            settings.replicate_error_columns = 0;
            Some(full_table(&settings)?)
        } else {
            None
        };
        let tir = if has_slices_of(false) {
            let mut settings = config.tir.clone();
            settings.shared.reference.cells = 0;
            settings.shared.interpolation.points = 0;
            Some(full_table(&settings)?)
        } else {
            None
        };
        Ok(FullTables { fgd, tir })
    }

    /// The full table `slices` specialise, where it was built.
    fn of(&self, slices: &Slices) -> Option<&Table> {
        match slices.of {
            SliceOf::Fgd(_) => self.fgd.as_ref(),
            SliceOf::Tir(_) => self.tir.as_ref(),
        }
    }
}

/// The cache a build reads and stores tables in: the shard folders a merge joins, or `--cache`.
/// A shard's folder that cannot be used fails the shard at once.
fn open_cache(request: &SceneBuildRequest) -> Result<Option<SliceCache>> {
    let cache = if !request.merge_from.is_empty() {
        Some(SliceCache::shards(&request.merge_from, &request.library_key())?)
    } else {
        request.cache.as_deref().map(SliceCache::open).transpose()?
    };
    if let (Some(_), Some(cache)) = (request.shard, &cache)
        && cache.failed()
    {
        return Err(shard_folder_failed(cache));
    }
    Ok(cache)
}

fn shard_folder_failed(cache: &SliceCache) -> Error {
    Error::invalid("--shard", format!("the shard's folder is incomplete: {}", cache.warnings().join("; ")))
}

/// One scene build under way: what its steps after planning share.
struct SceneBuild<'a> {
    request: &'a SceneBuildRequest,
    plan: &'a Plan,
    seed: u64,
    /// Which of the plan's tables a shard integrates; `None` for every table.
    owned: Option<Vec<bool>>,
    cache: Option<SliceCache>,
    progress: &'a dyn Progress,
}

impl<'a> SceneBuild<'a> {
    fn merging(&self) -> bool {
        !self.request.merge_from.is_empty()
    }

    fn owns(&self, place: usize) -> bool {
        self.owned.as_ref().is_none_or(|o| o[place])
    }

    /// The plan's slices at the places `keep` accepts, in plan order.
    fn slices(&self, keep: impl Fn(usize) -> bool) -> Vec<&'a Slices> {
        let plan: &'a Plan = self.plan;
        plan.tables
            .iter()
            .enumerate()
            .filter_map(|(place, t)| match &t.build {
                PlannedBuild::Slices(slices) if keep(place) => Some(slices),
                _ => None,
            })
            .collect()
    }

    /// The error of a merge that finds no entry for `table`: the first entry a shard held but
    /// that was refused (its values, its inputs) where there is one, since a merge integrates
    /// nothing.
    fn not_in_shards(&self, table: &str) -> Error {
        if let Some(refused) = self.cache.as_ref().and_then(|c| c.warnings().into_iter().next()) {
            return Error::invalid("tmlut merge", format!("{refused}: rebuild the shard that holds it"));
        }
        Error::invalid(
            "tmlut merge",
            format!(
                "table `{table}` is in none of the {} shard folder(s): run every shard (`tmlut build --shard I/N` for I = 1 to N) \
                 with the same scenes, configuration and seed",
                self.request.merge_from.len()
            ),
        )
    }

    /// The builds of `own` (this build's slices among `all`, the plan's), unless each is checked
    /// alone: those an earlier build stored read back from the cache, the others integrated (and
    /// checked) together, then stored. Returns them by name, and how many came from the cache.
    fn read_or_integrate(
        &self,
        own: &[&Slices],
        all: &[&Slices],
    ) -> Result<(std::collections::HashMap<String, TableBuild>, usize)> {
        let mut batch = std::collections::HashMap::new();
        if self.request.slice_checks == SliceChecks::Full || all.is_empty() {
            return Ok((batch, 0));
        }
        let (cache, seed) = (&self.cache, self.seed);
        // Entries are read and verified in parallel: a library's thousands take a while.
        use rayon::prelude::*;
        let cached: Vec<Option<TableBuild>> =
            own.par_iter().map(|slices| cache.as_ref().and_then(|c| c.get(slices, seed))).collect();
        let mut missing: Vec<&Slices> = Vec::new();
        for (slices, cached) in own.iter().zip(cached) {
            match cached {
                Some(build) => {
                    batch.insert(slices.name.clone(), build);
                }
                None => missing.push(slices),
            }
        }
        if let (true, Some(first)) = (self.merging(), missing.first()) {
            return Err(self.not_in_shards(&first.name));
        }
        if !missing.is_empty() {
            // Checks are drawn across every slice of the plan, whichever of them are integrated here.
            let builds = integrate_batch_among(&missing, all, seed, self.progress)?;
            let exact = match self.request.slice_checks {
                SliceChecks::Sampled => sampled_exact_values(&missing, all, seed, self.progress)?,
                _ => vec![None; missing.len()],
            };
            for ((slices, mut build), exact) in missing.iter().zip(builds).zip(exact) {
                build.provenance.interpolation.extend(exact);
                if let Some(cache) = cache {
                    cache.put(slices, seed, &build);
                }
                batch.insert(slices.name.clone(), build);
            }
        }
        Ok((batch, own.len() - missing.len()))
    }

    /// A shard's other tables integrated into its cache folder (those not there already) and its
    /// record written: the folder is the shard's only output, so a table it could not keep fails
    /// the shard. Returns the summary without its times.
    fn store_shard(&self, shard: Shard, own_slices: &[&Slices], slices_from_cache: usize) -> Result<SceneBuildSummary> {
        let cache = self.cache.as_ref().expect("a shard has a cache folder (check_options)");
        let mut tables = own_slices.len();
        for (place, planned) in self.plan.tables.iter().enumerate() {
            let Some(key) = table_key(&planned.build, self.seed).filter(|_| self.owns(place)) else { continue };
            let recipe = planned.build.recipe().expect("a full table");
            if cache.get_by_key(&key, recipe).is_none() {
                cache.put_by_key(&key, &recipe.build(self.seed, self.progress)?);
            }
            tables += 1;
        }
        // Which library and part the folder holds, for the merge to hold it to.
        if let Err(e) = cache.put_shard_record(&self.request.library_key(), shard) {
            return Err(Error::invalid("--shard", format!("the shard's folder is incomplete: {e}")));
        }
        if cache.failed() {
            return Err(shard_folder_failed(cache));
        }
        for warning in cache.warnings() {
            self.progress.note(&format!("warning: {warning}"));
        }
        self.progress.note(&format!(
            "shard {}/{}: {tables} of the plan's {} tables in {} ({} slices from it already)",
            shard.index,
            shard.count,
            self.plan.tables.len(),
            cache.dir.display(),
            slices_from_cache
        ));
        Ok(SceneBuildSummary {
            materials: self.request.scene.materials.len(),
            tables,
            merged_slices: self.plan.merged_slices,
            slices: own_slices.len(),
            slices_from_cache,
            ..SceneBuildSummary::default()
        })
    }

    /// The job of a planned full table (or the fitted TIR form's table): read from the cache
    /// where it holds it, integrated otherwise (and stored), never integrated in a merge.
    fn table_job(&self, planned: &'a PlannedBuild) -> Job<'_> {
        let seed = self.seed;
        let recipe = planned.recipe().expect("every other planned build is a full recipe");
        let Companions { packings, packing_formats, .. } = recipe.companions();
        // A TIR table over a sub-range is not what the analytic forms are fitted to: only the full
        // table of the fitted-form item is, and that table is not written.
        let (output, fit_seed) = match planned {
            PlannedBuild::TirFit(settings) => {
                (OutputConfig { formats: Vec::new(), precision: settings.shared.output.precision }, Some(seed))
            }
            _ => (recipe.output().clone(), None),
        };
        // A full table is kept in the cache too (GD, read by every 6-flux library, and the
        // sub-range tables): a build of an unchanged library then integrates nothing.
        let key = self.cache.as_ref().and(table_key(planned, seed));
        Job {
            run: Box::new(move |progress| {
                let (Some(cache), Some(key)) = (&self.cache, &key) else { return recipe.build(seed, progress) };
                if let Some(build) = cache.get_by_key(key, recipe) {
                    return Ok(build);
                }
                if self.merging() {
                    return Err(self.not_in_shards(recipe.name()));
                }
                let build = recipe.build(seed, progress)?;
                cache.put_by_key(key, &build);
                Ok(build)
            }),
            output,
            packings,
            packing_formats,
            fit_seed,
            slice_array: None,
            preset: None,
        }
    }
}

/// The job of a slice written as a file of its own: its build from the batch where it is there,
/// otherwise built and checked on its own (against `full`, the full table it specialises, where
/// that was built).
fn slice_job<'a>(
    slices: &'a Slices,
    batch: &'a std::collections::HashMap<String, TableBuild>,
    full: Option<&'a Table>,
    seed: u64,
) -> Job<'a> {
    let run: crate::pipeline::Integration<'a> = match batch.get(&slices.name) {
        Some(build) => Box::new(move |_| Ok(build.clone())),
        None => Box::new(move |progress| checked_slice(slices, full, seed, progress)),
    };
    Job {
        run,
        output: slices.output(),
        packings: Vec::new(),
        packing_formats: Vec::new(),
        fit_seed: None,
        slice_array: None,
        preset: None,
    }
}

/// A slice built on its own, and with `full` given, checked against the exact integral where its
/// lookups are made and compared with that full table ([`slice_accuracy`]).
fn checked_slice(slices: &Slices, full: Option<&Table>, seed: u64, progress: &dyn Progress) -> Result<TableBuild> {
    let mut build = crate::recipes::driver::build(slices, seed, progress)?;
    if let Some(full) = full {
        let (exact, full_accuracy) = slice_accuracy(slices, full, seed, progress)?;
        build.provenance.interpolation.push(exact);
        build.provenance.accuracy.push(full_accuracy);
    }
    Ok(build)
}

/// The texture arrays holding `slices` (built in `builds`, by name): one per kind (FGD, TIR),
/// stored channel count and output, in plan order, split where one would exceed
/// [`slice_array::MAX_LAYERS`]. Named `<kind>_array_<channels>` (`fgd_array_r`, `tir_array_rgba`),
/// with `_2`, `_3`, ... after the first of a split.
fn slice_array_jobs<'a>(
    slices: &[&'a Slices],
    builds: &std::collections::HashMap<String, TableBuild>,
) -> Result<Vec<Job<'a>>> {
    let mut groups: Vec<(String, OutputConfig, Vec<&Slices>)> = Vec::new();
    for &s in slices {
        let kind = match s.of {
            SliceOf::Fgd(_) => "fgd",
            SliceOf::Tir(_) => "tir",
        };
        let name = format!("{kind}_array_{}", ["r", "rg", "rgb", "rgba"][s.stored_channel_count() - 1]);
        let output = s.output();
        match groups.iter_mut().find(|(n, o, _)| *n == name && *o == output) {
            Some((_, _, members)) => members.push(s),
            None => groups.push((name, output, vec![s])),
        }
    }
    let mut jobs = Vec::new();
    for (name, output, members) in groups {
        let extents: Vec<[usize; 2]> = members.iter().map(|s| [s.mu.count, s.alpha.count]).collect();
        let parts = slice_array::layout(&extents).layers.div_ceil(slice_array::MAX_LAYERS).max(1);
        // Shelves fill layers about evenly, so equal counts of slices need about equal layers; a
        // part that still needs too many is split once more.
        let mut chunk = members.len().div_ceil(parts);
        while members.chunks(chunk).any(|c| {
            slice_array::layout(&c.iter().map(|s| [s.mu.count, s.alpha.count]).collect::<Vec<_>>()).layers
                > slice_array::MAX_LAYERS
        }) {
            chunk = chunk.div_ceil(2);
        }
        for (k, part) in members.chunks(chunk).enumerate() {
            let name = if k == 0 { name.clone() } else { format!("{name}_{}", k + 1) };
            let parts: Vec<&TableBuild> = part.iter().map(|s| &builds[&s.name]).collect();
            let (build, entry) = slice_array_build(&name, &parts, output.precision)?;
            jobs.push(Job {
                run: Box::new(move |_| Ok(build.clone())),
                output: output.clone(),
                packings: Vec::new(),
                packing_formats: Vec::new(),
                fit_seed: None,
                slice_array: Some(entry),
                preset: None,
            });
        }
    }
    Ok(jobs)
}

/// One texture array of slice `builds`: the array as a table with the provenance of its slices
/// (their integral and sampling, errors pooled, wall times summed), and its manifest record.
fn slice_array_build(
    name: &str,
    builds: &[&TableBuild],
    precision: Precision,
) -> Result<(TableBuild, SliceArrayEntry)> {
    let tables: Vec<&Table> = builds.iter().map(|b| &b.table).collect();
    let channels = (0..tables[0].channel_count())
        .map(|c| {
            Channel::new(format!("c{c}"), format!("channel {c} of each slice: slice_array.slices[].channels[{c}]"))
        })
        .collect();
    let (table, layout) = slice_array::pack(name, &tables, channels)?;
    let slices = builds
        .iter()
        .zip(&layout.slots)
        .map(|(build, &slot)| crate::pipeline::array_slice_record(build, precision, slot, layout.layer_extent))
        .collect::<Result<Vec<_>>>()?;
    let mut provenance = builds[0].provenance.of_derived_table();
    for build in &builds[1..] {
        provenance.error = provenance.error.pooled(&build.provenance.error);
    }
    // Slices integrated together each state the batch's wall time: the array took that long, not their sum.
    provenance.wall_time_s = builds.iter().map(|b| b.provenance.wall_time_s).fold(0.0, f64::max);
    provenance.metadata.notes.push(format!(
        "A texture array of {} slices: each slice's own axes, channels, layer, texel origin and error are in \
         slice_array.slices; error here pools them.",
        builds.len()
    ));
    let entry = SliceArrayEntry::new(layout.layer_extent.map(|e| e as u32), layout.layers as u32, slices);
    Ok((TableBuild { table, provenance }, entry))
}

/// The configuration a request's plan is made with: its own, with what its options change.
fn planning_config(request: &SceneBuildRequest) -> Config {
    let mut config = request.config.clone();
    if request.error_maps {
        config.fgd.replicate_error_columns = usize::MAX;
    }
    if request.slice_checks == SliceChecks::None {
        config.disable_interpolation_checks();
    }
    config
}

/// Verify the folder `staged` that the table cache restores whole for `request`
/// ([`super::cache::restore_build`]) as its entries are verified: every table the request's plan
/// holds (every slice, unpacked from its texture array, and every full table) compared with the
/// exact integral at [`super::cache::VERIFIED_NODES`] nodes no one can predict. A restored folder
/// is otherwise taken on the word of the record and files in the cache.
pub fn verify_restored(request: &SceneBuildRequest, staged: &Path) -> std::result::Result<(), String> {
    use rayon::prelude::*;
    let plan = plan(&request.scene, &planning_config(request)).map_err(|e| e.to_string())?;
    let folder = crate::loader::LutFolder::open(staged).map_err(|e| e.to_string())?;
    let slices: std::collections::HashMap<String, Table> = folder
        .scene_slices(|_| true)
        .map_err(|e| e.to_string())?
        .into_iter()
        .map(|slice| (slice.entry.table, slice.table))
        .collect();
    plan.tables.par_iter().try_for_each(|planned| {
        let refused = |why: String| format!("table `{}` of the restored folder: {why}", planned.record.name);
        match &planned.build {
            PlannedBuild::Slices(kernel) => {
                let table = slices.get(&kernel.name).ok_or_else(|| refused("not in the folder".into()))?;
                super::cache::verify_values(kernel, table).map_err(refused)
            }
            PlannedBuild::Table(settings) => {
                let name = settings.kind().name();
                let (file, _) = folder
                    .manifest()
                    .files
                    .iter()
                    .find(|(_, entry)| entry.table == name)
                    .ok_or_else(|| refused("not in the folder".into()))?;
                let table = folder.load(file).map_err(|e| refused(e.to_string()))?;
                super::cache::verify_values(settings.recipe(), &table).map_err(refused)
            }
            // A fitted form is a least-squares fit, not an integral: the build fits it again.
            PlannedBuild::TirFit(_) => Ok(()),
        }
    })
}

/// The cache key of a planned full (or sub-range) table; `None` for the fitted form, whose fit
/// the cache does not keep.
fn table_key(build: &PlannedBuild, seed: u64) -> Option<CacheKey> {
    match build {
        PlannedBuild::Table(settings) => Some(CacheKey::of_table(settings, seed)),
        PlannedBuild::TirFit(_) | PlannedBuild::Slices(_) => None,
    }
}

/// Points of the interpolation check drawn across every slice of a build ([`SliceChecks::Sampled`]):
/// each channel's exact integral by the quadrature takes about 0.1 ms, so 256 points cost a
/// fraction of a second of a library's build.
pub const SAMPLED_INTERPOLATION_POINTS: usize = 256;

/// The exact integral at [`SAMPLED_INTERPOLATION_POINTS`] random points drawn across `population`,
/// for the slices of `slices` that drew any: each point picks a slice at random, then a point where that slice's lookups are made, as
/// [`slice_accuracy`] draws them. Slices that drew no point get `None`.
pub fn sampled_exact_values(
    slices: &[&Slices],
    population: &[&Slices],
    seed: u64,
    progress: &dyn Progress,
) -> Result<Vec<Option<ExactValues>>> {
    // Drawn across the population (the build's slices), so that a slice draws the same points
    // whichever others are integrated with it (a shard, or a build reading the rest from a cache).
    let mut drawn: std::collections::HashMap<&str, usize> = std::collections::HashMap::new();
    for draw in 0..SAMPLED_INTERPOLATION_POINTS as u32 {
        let hash = crate::sampling::sequence::scramble_seed(seed, 0x5A3D, draw) as usize;
        *drawn.entry(population[hash % population.len()].name.as_str()).or_default() += 1;
    }
    // Most slices draw one point or none: the slices run in parallel, not each one's points.
    use rayon::prelude::*;
    slices
        .par_iter()
        .map(|slices| (slices, drawn.get(slices.name.as_str()).copied().unwrap_or(0)))
        .map(|(slices, points)| {
            if points == 0 {
                return Ok(None);
            }
            let config = InterpolationConfig { points, nodes: slices.reference().nodes };
            Ok(Some(lookup_exact_values(slices, &config, seed, progress)?))
        })
        .collect()
}

/// The exact integral at `config.points` random points where a slice's lookups are made.
pub fn lookup_exact_values(
    slices: &Slices,
    config: &InterpolationConfig,
    seed: u64,
    progress: &dyn Progress,
) -> Result<ExactValues> {
    let domain = Domain {
        name: "where the slice's lookups are made".into(),
        parameters: vec!["mu".into(), "alpha".into()],
        ranges: vec![slices.lookup_mu, slices.lookup_alpha],
    };
    Ok(interpolation::exact_values(
        &slices.name,
        vec![domain],
        config,
        seed ^ 0xACC0,
        progress,
        // A slice's lookups are sampled where its materials make them; no peak search.
        |_| Vec::new(),
        |lookup| lookup.to_vec(),
        |quadrature, position| slices.exact_value(quadrature, position),
    )?
    .remove(0))
}

/// The exact integral at random points where a slice's lookups are made (`(mu, alpha)` uniform
/// over the ranges they reach; a fixed roughness is queried at exactly that roughness), and the
/// full table of the same configuration read at the same points against it (`eta` and `kappa` of
/// each channel; a TIR table's third axis as its manifest states it).
pub fn slice_accuracy(
    slices: &Slices,
    full: &Table,
    seed: u64,
    progress: &dyn Progress,
) -> Result<(ExactValues, AccuracyReport)> {
    let reference = slices.reference();
    let config = InterpolationConfig { points: reference.cells.max(16), nodes: reference.nodes };
    let exact = lookup_exact_values(slices, &config, seed, progress)?;
    let channels: Vec<String> =
        slices.channels.iter().map(|c| format!("eta {:.4}, kappa {:.4}", c.eta, c.kappa)).collect();
    let full_shape = full.axes.iter().map(|a| a.count.to_string()).collect::<Vec<_>>().join(" x ");
    let compared = interpolation::compare(&exact, "the full table interpolated (Table::interpolate)", &channels, |p| {
        slices
            .channels
            .iter()
            .map(|c| {
                let point =
                    derived::point_of(&full.axes, p[0], p[1], c.eta, c.kappa).expect("full tables of known axes");
                full.interpolate(&point)[0]
            })
            .collect()
    });
    let report = AccuracyReport::new(
        format!(
            "full {full_shape} table interpolated at the points of error.interpolation vs the exact integral ({}; exact: quadrature, {} Gauss–Legendre nodes per panel)",
            compared.points, compared.exact_nodes
        ),
        compared.error,
        compared.worst_at,
    );
    Ok((exact, report))
}
