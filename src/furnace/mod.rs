//! The furnace test: every material of a scene under a uniform environment, its directional albedo
//! `A(mu)` three ways, so that what the tables cost and what the model costs are measured apart
//! (`docs/furnace.md`):
//! - the transfer-matrix model reading the scene's tables as a renderer does
//!   ([`crate::model::folder::FolderTables`]);
//! - the same model reading exact integrals instead ([`crate::exact::ExactTables`]);
//! - a random walk through the explicit stack, which shares none of the model's approximations
//!   ([`crate::random_walk`]).
//!
//! `table error = A(tables) - A(exact)`, `model error = A(exact) - A(walk)`, and their sum the
//! total. A uniform environment of radiance `L` seen at view cosine `mu` returns `L A(mu)`
//! (reciprocity), so a furnace sphere is `A` drawn over the sphere's view cosines ([`picture`]).

pub mod forms;
pub mod picture;
pub mod report;

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

use rayon::prelude::*;

use crate::commit::{Move, OutputFolder};
use crate::config::Config;
use crate::error::{Error, Result};
use crate::exact::ExactTables;
use crate::formats::baked::BakedErrors;
use crate::integrate::{GRAZING_COSINE, Progress};
use crate::loader::LutFolder;
use crate::model::folder::{FgdSource, FolderTables, LibraryTables, MaterialReads, Misses};
use crate::model::{Lookup, Material, Rgb, Tables};
use crate::random_walk::{self, WalkSettings};
use crate::scene::Scene;
use crate::scene::build::{SceneBuildRequest, SliceChecks, SliceLayout, build_scene};
pub use report::{ErrorFigures, FURNACE_FILE, FurnaceReport, MaterialReport, PhaseTimes};

/// Radiance of the uniform environment of the furnace pictures: the thesis's 0.42 (its §5.2), about
/// mid-way between no energy and all of it, so that both loss and gain show.
pub const ENVIRONMENT_RADIANCE: f64 = 0.42;

/// How a furnace run measures.
#[derive(Debug, Clone, PartialEq)]
pub struct FurnaceSettings {
    /// View cosines per material, uniform in angle from the normal to grazing (both included).
    pub views: usize,
    /// Gauss–Legendre nodes per panel of each exact integral's quadrature (in
    /// [`crate::integrate::quadrature::NODES`]).
    pub exact_nodes: usize,
    pub walk: WalkSettings,
    /// Which full FGD table the FGD path reads where a folder has two.
    pub fgd_source: FgdSource,
    /// Timed rounds of the model over every view (the median round is reported).
    pub timing_rounds: usize,
    /// Width and height of each sphere in the pictures, in pixels.
    pub picture_size: usize,
    /// The materials the random walk runs for. The table error needs none; the model error and
    /// the total are measured where it ran, and absent elsewhere.
    pub walk_materials: Selection,
    /// The materials drawn (furnace sphere and `A(mu)` plot).
    pub pictures: Selection,
}

/// Which materials of a run get something that costs time per material (the random walk,
/// pictures): all, none, or `sample:N`, N of them drawn from the walk's seed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Selection {
    All,
    None,
    Sample(usize),
}

/// Sample sizes of [`Selection::Sample`]: at least one, at most a library's materials.
pub const SAMPLE_SIZES: std::ops::RangeInclusive<usize> = 1..=crate::scene::library::MAX_LIBRARY_MATERIALS;

impl Selection {
    /// `all`, `none` or `sample:N`.
    pub fn parse(text: &str) -> std::result::Result<Self, String> {
        match text {
            "all" => Ok(Selection::All),
            "none" => Ok(Selection::None),
            _ => {
                let n = text
                    .strip_prefix("sample:")
                    .and_then(|n| n.parse::<usize>().ok())
                    .ok_or_else(|| format!("`{text}`; allowed: all, none, sample:N"))?;
                if !SAMPLE_SIZES.contains(&n) {
                    return Err(format!(
                        "`{text}`; allowed: sample:N with N from {} to {}",
                        SAMPLE_SIZES.start(),
                        SAMPLE_SIZES.end()
                    ));
                }
                Ok(Selection::Sample(n))
            }
        }
    }

    pub fn name(&self) -> String {
        match self {
            Selection::All => "all".into(),
            Selection::None => "none".into(),
            Selection::Sample(n) => format!("sample:{n}"),
        }
    }

    /// Which of `count` materials are chosen. `sample:N` takes the first N of one order of the
    /// materials drawn from `seed` (every material once), so that a smaller sample lies inside a
    /// larger one of the same seed: the materials of `--pictures sample:8` are among those of
    /// `--walk sample:16`. N at least `count` chooses all.
    pub fn chosen(&self, count: usize, seed: u64) -> Vec<bool> {
        match *self {
            Selection::All => vec![true; count],
            Selection::None => vec![false; count],
            Selection::Sample(n) => {
                let mut order: Vec<(u32, usize)> = (0..count)
                    .map(|i| (crate::sampling::sequence::scramble_seed(seed, SAMPLE_STREAM, i as u32), i))
                    .collect();
                order.sort_unstable();
                let mut chosen = vec![false; count];
                for &(_, i) in order.iter().take(n) {
                    chosen[i] = true;
                }
                chosen
            }
        }
    }
}

/// The stream of the seed that orders materials for [`Selection::Sample`], apart from the walk's.
const SAMPLE_STREAM: u64 = 0x5A_3B1E;

/// The pictures a run draws by default: every material of a scene of up to 16 (every example
/// scene), 16 of a library, whose thousands of pictures would cost more than its table error.
pub const DEFAULT_PICTURES: Selection = Selection::Sample(16);

impl Default for FurnaceSettings {
    fn default() -> Self {
        FurnaceSettings {
            views: 64,
            exact_nodes: crate::exact::DEFAULT_NODES,
            walk: WalkSettings::default(),
            fgd_source: FgdSource::default(),
            timing_rounds: 21,
            picture_size: 256,
            walk_materials: Selection::All,
            pictures: DEFAULT_PICTURES,
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
        crate::recipes::settings::check_quadrature_nodes("exact nodes", self.exact_nodes)?;
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
        for (what, selection) in [("walk", self.walk_materials), ("pictures", self.pictures)] {
            if let Selection::Sample(n) = selection
                && !SAMPLE_SIZES.contains(&n)
            {
                return Err(Error::invalid(
                    what,
                    format!(
                        "sample:{n}; allowed: sample:N with N from {} to {}",
                        SAMPLE_SIZES.start(),
                        SAMPLE_SIZES.end()
                    ),
                ));
            }
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

/// One furnace run: a scene, or a library of scenes planned as one (`tmlut furnace --library`).
pub struct FurnaceRequest {
    pub scene: Scene,
    /// For a library, the scene each material came from (recorded per material, and the budget
    /// `tmlut check` holds it to); `None` for one scene.
    pub material_scenes: Option<Vec<String>>,
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

/// Passes of the model over every material that collect the lookups not yet integrated, before
/// the last pass reads them all (`exact_curves`). A lookup's parameters can depend on the values of
/// earlier lookups (a lobe's roughness on the energies above it), so a pass can find lookups the one
/// before could not see; each pass integrates at least one new lookup, and past this many, the last
/// pass integrates what is left one lookup at a time (the same bits, only slower).
const EXACT_PASSES: usize = 8;

/// Run the furnace on every material of a scene and commit its outputs into `request.out` as one
/// set (`crate::commit`): `furnace.json`, and per material pictured `<material>_furnace.exr`,
/// `.png` and `<material>_albedo.png`. A failed or killed run leaves the previous set as it was.
pub fn run(request: &FurnaceRequest, progress: &dyn Progress) -> Result<FurnaceReport> {
    check_request(request)?;
    let count = request.scene.materials.len();
    // Taken before anything is read or built: a second run into the folder waits, and what an
    // interrupted run left (a commit half done, staging folders) is completed or removed first.
    let folder_lock = OutputFolder::take(&request.out, |message| progress.note(message))?;
    let mut times = PhaseTimes::default();
    let started = Instant::now();
    let luts = tables_folder(request, progress)?;
    times.tables = started.elapsed().as_secs_f64();

    let started = Instant::now();
    let folder = LutFolder::open(&luts)?;
    let exact = ExactTables::new(&request.config, request.settings.exact_nodes)?;
    let mus = request.settings.view_cosines();
    let models: Vec<Material> =
        request.scene.materials.iter().map(|m| Ok(Material::new(m.model, m.stack()?))).collect::<Result<_>>()?;
    // A material's own forms (`tir = "fit:PATH"`, `albedo = "fit:PATH"`) answer its TIR or albedo
    // lookups in place of the folder.
    let reads = request.scene.materials.iter().map(|m| MaterialReads {
        name: &m.name,
        albedo: m.albedo,
        tir: m.tir,
        tir_form: m.tir_form.as_ref(),
        albedo_form: m.albedo_form.as_ref(),
    });
    let library = LibraryTables::open(&folder, request.settings.fgd_source, reads)?;
    let with_tables = curves_with_tables(request, &models, &library, &mus, &luts)?;
    // Each material's cost timed on one thread, materials side by side: a library's thousands of
    // timings would otherwise be the run's longest phase on one core.
    let costs: Vec<f64> = models
        .par_iter()
        .enumerate()
        .map(|(index, model)| time_model(model, library.of(index), &mus, request.settings.timing_rounds))
        .collect();
    times.model_with_tables = started.elapsed().as_secs_f64();

    let started = Instant::now();
    let proxies: Vec<&FolderTables> = (0..count).map(|index| library.of(index)).collect();
    let with_exact = exact_curves(&models, &proxies, &mus, &exact, progress);
    times.exact = started.elapsed().as_secs_f64();

    let started = Instant::now();
    let walks = walk_curves(request, &models, &mus, progress);
    times.walk = started.elapsed().as_secs_f64();

    let started = Instant::now();
    let baked = baked_curves(&folder, &request.scene, &models, &mus, &exact)?;
    times.baked = started.elapsed().as_secs_f64();

    let mut materials: Vec<MaterialReport> = request
        .scene
        .materials
        .iter()
        .zip(with_tables)
        .zip(costs)
        .zip(with_exact)
        .zip(walks)
        .enumerate()
        .map(|(index, ((((material, (curve, clamped)), cost_ns), exact_curve), walk))| {
            let scene = request.material_scenes.as_ref().map(|s| s[index].clone());
            MaterialReport::new(material, scene, &mus, curve, exact_curve, walk, cost_ns, clamped)
        })
        .collect();
    for (report, baked) in materials.iter_mut().zip(baked) {
        if let Some((errors, albedo)) = baked {
            report.add_baked(errors, albedo);
        }
    }
    commit_report(request, &folder_lock, &luts, exact.nodes(), materials, times)
}

/// A baked material's errors against its model and its baked albedo curve.
type BakedCurve = (BakedErrors, Vec<Rgb>);

/// Where `folder` holds a bake of `scene` (`tmlut bake`): each baked material's values at `mus`,
/// read as a GPU filters them, against its model with `exact` integrals, and its baked albedo
/// curve; `None` for a material the bake does not hold. A bake of another scene, or one whose
/// material no longer returns the lobes it was baked with, is refused: it is stale.
fn baked_curves(
    folder: &LutFolder,
    scene: &crate::scene::Scene,
    models: &[Material],
    mus: &[f64],
    exact: &ExactTables,
) -> Result<Vec<Option<BakedCurve>>> {
    if !folder.manifest().files.values().any(|e| e.baked.is_some()) {
        return Ok(vec![None; models.len()]);
    }
    let baked = crate::loader::BakedLut::from_folder(folder)?;
    let stale = |what: String| {
        Error::invalid(
            format!("the bake in {}", folder.dir().display()),
            format!("{what}; bake the scene again (tmlut bake, or tmlut build --scene --bake)"),
        )
    };
    if baked.baked().scene != scene.name {
        return Err(stale(format!("is of scene `{}`, not `{}`", baked.baked().scene, scene.name)));
    }
    let against = "the model with exact integrals, at the furnace's views; the bake read as stored through a linear \
                   filter with 8-bit weights; lobe roughness, cosine and GD weighted by the lobe's largest energy";
    scene
        .materials
        .par_iter()
        .zip(models)
        .map(|(material, model)| {
            let Some(index) = baked.material_index(&material.name) else { return Ok(None) };
            let lobes = model.evaluate(1.0, exact).lobes.len();
            let entry = baked.material(index).expect("indexed above");
            if entry.lobes as usize != lobes {
                return Err(stale(format!(
                    "holds material `{}` with {} lobes, where its model returns {lobes}",
                    material.name, entry.lobes
                )));
            }
            let layout = crate::bake::BakeLayout { lobes };
            let read = |mu: f32| baked.sample_gpu(index, mu);
            let errors = crate::bake::errors::reading_errors(&layout, mus, model, exact, read);
            let albedo = mus
                .iter()
                .map(|&mu| {
                    let values = read(mu as f32);
                    [values[0], values[1], values[2]].map(f64::from)
                })
                .collect();
            Ok(Some((BakedErrors { against: against.into(), ..errors }, albedo)))
        })
        .collect()
}

/// What a furnace run refuses before it takes its folder: its settings, a scene name per
/// material where names are given, and the memory its materials need.
fn check_request(request: &FurnaceRequest) -> Result<()> {
    request.settings.validate()?;
    let count = request.scene.materials.len();
    if let Some(scenes) = &request.material_scenes
        && scenes.len() != count
    {
        return Err(Error::invalid(
            "furnace request",
            format!("{} scene names for {count} materials; one per material", scenes.len()),
        ));
    }
    crate::scene::memory::check(
        &format!("scene `{}`", request.scene.name),
        &format!("the furnace of its {count} materials"),
        crate::scene::memory::BASE_BYTES + crate::scene::memory::FURNACE_BYTES_PER_MATERIAL * count as u128,
        "measure fewer materials at a time",
    )
}

/// The folder of tables the model reads: `--luts` as given, or the scene's tables built into
/// `OUT/luts` without their own checks (the furnace measures the tables in the material itself:
/// the tables' reference checks and the slices' accuracy reports would only repeat it, slower).
fn tables_folder(request: &FurnaceRequest, progress: &dyn Progress) -> Result<PathBuf> {
    if let Some(dir) = &request.luts {
        return Ok(dir.clone());
    }
    let dir = crate::formats::files::create_folders_inside(&request.out, Path::new("luts"))?;
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
        max_textures: crate::shader::scene::DEFAULT_MAX_TEXTURES,
        shard: None,
        merge_from: Vec::new(),
    };
    build_scene(&build, progress)?;
    Ok(dir)
}

/// Every material's `A(mu)` with the tables of `luts`, and its clamped lookups, material after
/// material: each material's misses and clamped lookups are its own (the counts are taken after
/// it). A lookup the folder cannot answer is refused, naming the material.
fn curves_with_tables(
    request: &FurnaceRequest,
    models: &[Material],
    library: &LibraryTables,
    mus: &[f64],
    luts: &Path,
) -> Result<Vec<(Vec<Rgb>, Misses)>> {
    let mut with_tables = Vec::with_capacity(models.len());
    for (index, (material, model)) in request.scene.materials.iter().zip(models).enumerate() {
        let tables = library.of(index);
        tables.take_counts();
        let curve: Vec<Rgb> = mus.iter().map(|&mu| model.albedo(mu, tables)).collect();
        let (misses, clamped) = tables.take_counts();
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
        with_tables.push((curve, clamped));
    }
    Ok(with_tables)
}

/// The random walk's `A(mu)` of the materials the settings choose, each with its wall time;
/// `None` for the others.
fn walk_curves(
    request: &FurnaceRequest,
    models: &[Material],
    mus: &[f64],
    progress: &dyn Progress,
) -> Vec<Option<(Vec<random_walk::WalkEstimate>, f64)>> {
    let walked = request.settings.walk_materials.chosen(models.len(), request.settings.walk.seed);
    let mut walks = Vec::with_capacity(models.len());
    for (index, model) in models.iter().enumerate() {
        if !walked[index] {
            walks.push(None);
            continue;
        }
        let walk_settings =
            WalkSettings { seed: walk_seed(request.settings.walk.seed, index), ..request.settings.walk };
        let started = Instant::now();
        let walk = random_walk::directional_albedo_curve(&model.stack, mus, &walk_settings, progress);
        walks.push(Some((walk, started.elapsed().as_secs_f64())));
    }
    walks
}

/// The pictures and `furnace.json` written into a staging folder and committed as one set, the
/// files of the set the folder held before that this one does not replace (a material renamed or
/// no longer pictured) removed with the commit, so that no picture outlives its report.
fn commit_report(
    request: &FurnaceRequest,
    folder_lock: &OutputFolder,
    luts: &Path,
    exact_nodes: usize,
    mut materials: Vec<MaterialReport>,
    mut times: PhaseTimes,
) -> Result<FurnaceReport> {
    let started = Instant::now();
    let mut staging = folder_lock.staging()?;
    let count = materials.len();
    let pictured = request.settings.pictures.chosen(count, request.settings.walk.seed);
    materials
        .par_iter_mut()
        .zip(&pictured)
        .filter(|(_, pictured)| **pictured)
        .map(|(report, _)| {
            report.files = picture::write_material_pictures(&staging.dir, report, request.settings.picture_size)?;
            Ok(())
        })
        .collect::<Result<Vec<()>>>()?;
    times.pictures = started.elapsed().as_secs_f64();

    let report = FurnaceReport::new(request, luts, exact_nodes, materials, times);
    report.write(&staging.dir)?;
    let moves: Vec<Move> = report
        .materials
        .iter()
        .flat_map(|m| &m.files)
        .map(|file| Move { staged: file.clone(), destination: file.clone() })
        .collect();
    let removals = match FurnaceReport::read(&request.out.join(FURNACE_FILE)) {
        Ok(old) => old
            .materials
            .iter()
            .flat_map(|m| m.files.iter().cloned())
            .filter(|file| !moves.iter().any(|m| &m.destination == file))
            .collect(),
        Err(_) => Vec::new(),
    };
    crate::commit::commit_set(folder_lock, &mut staging, moves, removals, FURNACE_FILE)?;
    Ok(report)
}

/// `A(mu)` of every material at every view with exact integrals. The lookups of every material
/// are collected first, by passes of the model that read a lookup not yet integrated from the
/// material's tables (`proxies`), and integrated together ([`ExactTables::integrate_all`]: in
/// parallel, albedos of one `(mu, alpha)` sharing a pass, across materials and channels); the
/// last pass reads exact integrals only. The curves are those of the model reading
/// [`ExactTables`] alone, to the bit: every lookup's answer is its own integral, however it was
/// batched.
fn exact_curves(
    models: &[Material],
    proxies: &[&FolderTables],
    mus: &[f64],
    exact: &ExactTables,
    progress: &dyn Progress,
) -> Vec<Vec<Rgb>> {
    progress.start("exact integrals, passes", EXACT_PASSES as u64);
    for _ in 0..EXACT_PASSES {
        let missing: Vec<Lookup> = models
            .par_iter()
            .zip(proxies)
            .flat_map_iter(|(model, proxy)| {
                let recording = Recording { exact, proxy, missing: Mutex::new(Vec::new()) };
                for &mu in mus {
                    model.albedo(mu, &recording);
                }
                recording.missing.into_inner().unwrap_or_else(|p| p.into_inner())
            })
            .collect();
        progress.advance(1);
        if missing.is_empty() {
            break;
        }
        exact.integrate_all(&missing);
    }
    progress.finish();
    models.par_iter().map(|model| mus.iter().map(|&mu| model.albedo(mu, exact)).collect()).collect()
}

/// Exact integrals where known; elsewhere the lookup is recorded for the next batch and answered
/// by the material's tables, so that the lookups after it are asked at nearly the parameters
/// the exact pass will ask them at.
struct Recording<'a> {
    exact: &'a ExactTables,
    proxy: &'a FolderTables,
    missing: Mutex<Vec<Lookup>>,
}

impl Tables for Recording<'_> {
    fn value(&self, lookup: &Lookup) -> f64 {
        if self.exact.knows(lookup) {
            return self.exact.value(lookup);
        }
        self.missing.lock().unwrap_or_else(|p| p.into_inner()).push(*lookup);
        self.proxy.value(lookup)
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::commit::faults::{FAIL_AT, PASSED};
    use crate::formats::manifest::pending_commit;
    use crate::report::check::{Budgets, check_folder};

    #[test]
    fn selections_parse_and_samples_are_drawn_from_the_seed_nested() {
        assert_eq!(Selection::parse("all"), Ok(Selection::All));
        assert_eq!(Selection::parse("none"), Ok(Selection::None));
        assert_eq!(Selection::parse("sample:3"), Ok(Selection::Sample(3)));
        for bad in ["sample:0", "sample:", "sample:-1", "some", "sample:99999999"] {
            let error = Selection::parse(bad).unwrap_err();
            assert!(error.contains("allowed"), "{bad}: {error}");
        }
        let count = 50;
        let three = Selection::Sample(3).chosen(count, 7);
        assert_eq!(three.iter().filter(|&&c| c).count(), 3);
        assert_eq!(three, Selection::Sample(3).chosen(count, 7), "the same seed draws the same materials");
        assert_ne!(three, Selection::Sample(3).chosen(count, 8), "another seed draws others");
        let ten = Selection::Sample(10).chosen(count, 7);
        assert!(three.iter().zip(&ten).all(|(&a, &b)| !a || b), "a smaller sample lies inside a larger one");
        assert!(Selection::Sample(60).chosen(count, 7).iter().all(|&c| c));
        assert!(Selection::None.chosen(count, 7).iter().all(|&c| !c));
    }

    const SCENE: &str = "name = \"set\"\n\
        [[material]]\nname = \"bare-conductor\"\n[[material.layer]]\ntype = \"interface\"\n\
        eta = [0.2, 0.9, 1.1]\nkappa = [3.0, 2.5, 2.0]\nalpha = 0.2\n\
        [[material]]\nname = \"glass\"\n[[material.layer]]\ntype = \"interface\"\neta = 1.5\nalpha = 0.2\n";

    /// A run of `scene` into `out`: 4 views, small integrals, no walk, every material pictured.
    fn request(scene: &str, luts: Option<PathBuf>, out: &Path) -> FurnaceRequest {
        let settings = FurnaceSettings {
            views: 4,
            exact_nodes: 6,
            walk_materials: Selection::None,
            pictures: Selection::All,
            picture_size: 16,
            timing_rounds: 1,
            ..Default::default()
        };
        FurnaceRequest {
            scene: Scene::from_toml(scene, "test", "set").unwrap(),
            material_scenes: None,
            source: "test".into(),
            text: scene.into(),
            luts,
            out: out.to_path_buf(),
            config: Config::default(),
            settings,
        }
    }

    /// The folder holds `furnace.json` and exactly the files it lists (besides the tables'
    /// folder), and nothing half-written.
    fn assert_one_set(out: &Path) -> Vec<String> {
        let report = FurnaceReport::read(&out.join(FURNACE_FILE)).unwrap();
        let mut listed: Vec<String> = report.materials.iter().flat_map(|m| m.files.clone()).collect();
        listed.push(FURNACE_FILE.into());
        listed.sort();
        let mut present: Vec<String> = std::fs::read_dir(out)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n != "luts")
            .collect();
        present.sort();
        assert_eq!(present, listed, "the files of one run, and only those");
        listed
    }

    #[test]
    fn a_run_commits_its_report_and_pictures_as_one_set_whatever_fails() {
        let base = tempfile::tempdir().unwrap();
        let first = run(&request(SCENE, None, base.path()), &()).unwrap();
        assert_eq!(first.pictured_materials, ["bare-conductor", "glass"]);
        assert!(first.walked_materials.is_empty());
        assert!(first.materials.iter().all(|m| m.errors.model.is_none() && m.albedo_walk.is_none()));
        let luts = Some(base.path().join("luts"));
        // The second set: one material fewer, so the first set's pictures of it must go.
        let glass_only = SCENE[SCENE.find("[[material]]\nname = \"glass\"").unwrap()..].to_string();
        let glass_only = format!("name = \"set\"\n{glass_only}");

        let dir = tempfile::tempdir().unwrap();
        run(&request(SCENE, luts.clone(), dir.path()), &()).unwrap();
        PASSED.with(|p| p.set(0));
        run(&request(&glass_only, luts.clone(), dir.path()), &()).unwrap();
        let points = PASSED.with(|p| p.get());
        assert!(points >= 8, "{points} fault points");
        let files = assert_one_set(dir.path());
        assert!(files.iter().all(|f| !f.starts_with("bare-conductor")), "{files:?}");

        let (mut old, mut journal) = (0, 0);
        for fail_at in 0..points {
            let dir = tempfile::tempdir().unwrap();
            let out = dir.path();
            run(&request(SCENE, luts.clone(), out), &()).unwrap();
            let before = std::fs::read(out.join(FURNACE_FILE)).unwrap();
            FAIL_AT.with(|f| f.set(Some(fail_at)));
            PASSED.with(|p| p.set(0));
            let failed = run(&request(&glass_only, luts.clone(), out), &());
            FAIL_AT.with(|f| f.set(None));
            let error = failed.expect_err("the injected fault fails the run").to_string();
            assert!(error.contains("injected fault"), "{error}");
            if pending_commit(out).is_some() {
                // Committed but not wholly in place: check says so, and the next run completes it.
                journal += 1;
                let findings = check_folder(out, &Budgets::default()).unwrap();
                assert!(findings.iter().any(|f| f.check == "commit" && !f.pass), "fault {fail_at}: {findings:?}");
            } else {
                // Wholly the earlier set: its report, every picture it lists, nothing else.
                old += 1;
                assert_eq!(std::fs::read(out.join(FURNACE_FILE)).unwrap(), before, "fault {fail_at}");
                assert_eq!(assert_one_set(out).len(), 7, "fault {fail_at}");
            }
            run(&request(&glass_only, luts.clone(), out), &()).unwrap();
            assert_eq!(assert_one_set(out), files, "fault {fail_at}");
        }
        assert_eq!((old, journal), (1, points - 1), "{old} wholly old, {journal} with a journal, of {points}");
    }

    #[test]
    fn exact_curves_batched_are_the_curves_of_exact_integrals_alone() {
        let base = tempfile::tempdir().unwrap();
        let request = request(SCENE, None, base.path());
        let report = run(&request, &()).unwrap();
        let alone = ExactTables::new(&request.config, request.settings.exact_nodes).unwrap();
        for (material, measured) in request.scene.materials.iter().zip(&report.materials) {
            let model = Material::new(material.model, material.stack().unwrap());
            let curve: Vec<Rgb> = measured.mu.iter().map(|&mu| model.albedo(mu, &alone)).collect();
            assert_eq!(curve, measured.albedo_exact, "{}", material.name);
        }
    }
}
