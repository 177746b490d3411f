//! `tmlut furnace`: the furnace test of scenes' materials.

use std::path::PathBuf;

use clap::Args;

use tmlut::furnace::Selection;
use tmlut::model::folder::FgdSource;
use tmlut::random_walk::{Masking, WalkSettings};
use tmlut::scene::library::{self, SceneFile};

use super::{ConfigArg, Context, ThreadsArg, check_count, one_of};

/// The furnace test of a scene's materials: the directional albedo A(mu) of the transfer-matrix
/// model with the scene's tables, with exact integrals, and from a random walk through the
/// explicit stack, so that the tables' error and the model's are measured apart. Commits
/// <out>/<scene>/furnace.json and, per material pictured, a furnace sphere (.exr, .png) and an
/// A(mu) plot as one set; prints a Markdown summary.
#[derive(Args)]
pub struct FurnaceArgs {
    /// Scene files, or folders of them (default: every scene of luts/scenes/), each measured on
    /// its own unless --library.
    scenes: Vec<PathBuf>,
    /// Measure every scene given as one library, planned together as `tmlut build --scene` plans
    /// several scenes: one folder of tables, one report in <out>/library (one scene keeps its
    /// name), each material recording its scene.
    #[arg(long)]
    library: bool,
    /// A folder built for the scene or library (tmlut build --scene), or the default set;
    /// default: build the plan into <out>/<scene>/luts first.
    #[arg(long)]
    luts: Option<PathBuf>,
    /// The materials the random walk runs for: all, none or sample:N (N drawn from --seed). The
    /// table error needs no walk; the model error and the total are absent where it did not run.
    #[arg(long, default_value = "all", value_parser = parse_selection)]
    walk: Selection,
    /// The materials drawn (furnace sphere and A(mu) plot): all, none or sample:N (N drawn from
    /// --seed, the first of the walk's order: every material of a scene of up to 16).
    #[arg(long, default_value = "sample:16", value_parser = parse_selection)]
    pictures: Selection,
    /// Output folder; each scene writes into a subfolder named after it.
    #[arg(long, default_value = "furnace")]
    out: PathBuf,
    #[command(flatten)]
    config: ConfigArg,
    /// View cosines per material, uniform in angle, grazing included.
    #[arg(long, default_value_t = 64)]
    views: usize,
    /// Gauss–Legendre nodes per panel of each exact integral's quadrature.
    #[arg(long, default_value_t = tmlut::exact::DEFAULT_NODES)]
    exact_nodes: usize,
    /// The random walk stops at this standard error of A in every channel ...
    #[arg(long, default_value_t = WalkSettings::default().target_standard_error)]
    walk_standard_error: f64,
    /// ... after at least this many paths per view ...
    #[arg(long, default_value_t = WalkSettings::default().min_paths)]
    walk_min_paths: u64,
    /// ... and at most this many.
    #[arg(long, default_value_t = WalkSettings::default().max_paths)]
    walk_max_paths: u64,
    /// Masking of the random walk's interfaces: smith-separable (as the tables) or
    /// smith-height-correlated.
    #[arg(long, default_value = "smith-separable", value_parser = parse_walk_masking)]
    walk_masking: Masking,
    /// The full FGD table read where a folder has both: packing (fgd_lossless.dds through its
    /// shader) or table (fgd.bin, 4D CPU interpolation).
    #[arg(long, default_value = "packing", value_parser = parse_fgd_source)]
    fgd_source: FgdSource,
    /// Seed of the random walk (the exact integrals use the configuration's seed).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Sphere size of the pictures, in pixels.
    #[arg(long, default_value_t = 256)]
    picture_size: usize,
    #[command(flatten)]
    threads: ThreadsArg,
}

fn parse_walk_masking(text: &str) -> Result<Masking, String> {
    let choices = [Masking::Separable, Masking::HeightCorrelated].map(|m| (m.name(), m));
    one_of(text, &choices)
}

fn parse_selection(text: &str) -> Result<Selection, String> {
    Selection::parse(text)
}

fn parse_fgd_source(text: &str) -> Result<FgdSource, String> {
    one_of(text, &[("packing", FgdSource::Packing), ("table", FgdSource::Table)])
}

pub fn exec(args: FurnaceArgs, context: &Context) -> tmlut::Result<()> {
    // The library bounds these too (`FurnaceSettings::validate`); here the error names the option.
    check_count("--views", args.views, tmlut::furnace::VIEWS)?;
    check_count("--exact-nodes", args.exact_nodes, tmlut::integrate::quadrature::NODES)?;
    check_count("--walk-min-paths", args.walk_min_paths, 1..=tmlut::random_walk::MAX_PATHS)?;
    check_count("--walk-max-paths", args.walk_max_paths, 1..=tmlut::random_walk::MAX_PATHS)?;
    check_count("--picture-size", args.picture_size, tmlut::furnace::PICTURE_SIZES)?;
    let config = args.config.load()?;
    args.threads.apply()?;
    let scenes = if args.scenes.is_empty() {
        let examples = std::path::Path::new("luts/scenes");
        if !examples.is_dir() {
            return Err(tmlut::Error::invalid(
                "furnace",
                "no scene given, and no luts/scenes/ here to take the example scenes from; give scene files, or run from the repository's root",
            ));
        }
        tmlut::furnace::scene_files(examples)?
    } else {
        args.scenes
    };
    let files = library::read_scene_files(&scenes)?;
    if args.luts.is_some() && files.len() > 1 && !args.library {
        return Err(tmlut::Error::invalid(
            "--luts",
            format!(
                "given with {} scenes; a folder of tables serves one run: one scene, or the scenes of a --library",
                files.len()
            ),
        ));
    }
    let settings = tmlut::furnace::FurnaceSettings {
        views: args.views,
        exact_nodes: args.exact_nodes,
        walk: WalkSettings {
            seed: args.seed,
            target_standard_error: args.walk_standard_error,
            min_paths: args.walk_min_paths,
            max_paths: args.walk_max_paths,
            masking: args.walk_masking,
            ..Default::default()
        },
        fgd_source: args.fgd_source,
        picture_size: args.picture_size,
        walk_materials: args.walk,
        pictures: args.pictures,
        ..Default::default()
    };
    settings.validate()?;
    let runs = if args.library { vec![library_run(&files)?] } else { separate_runs(files)? };
    let progress = context.progress();
    let mut summary = String::from(tmlut::furnace::report::MARKDOWN_HEADER);
    for run in runs {
        for warning in &run.scene.warnings {
            eprintln!("warning: {warning}");
        }
        // Each scene's folder is one tmlut makes inside the given one: never a link planted there.
        let stem = tmlut::furnace::report::file_stem(&run.scene.name);
        let out = tmlut::formats::files::create_folders_inside(&args.out, std::path::Path::new(&stem))?;
        let request = tmlut::furnace::FurnaceRequest {
            out,
            scene: run.scene,
            material_scenes: run.material_scenes,
            source: run.source,
            text: run.text,
            luts: args.luts.clone(),
            config: config.clone(),
            settings: settings.clone(),
        };
        let report = tmlut::furnace::run(&request, &progress)?;
        summary.push_str(&tmlut::furnace::report::markdown_rows(&report));
        eprintln!("wrote {}", request.out.join(tmlut::furnace::report::FURNACE_FILE).display());
    }
    print!("{summary}");
    Ok(())
}

/// What one furnace run measures.
struct Run {
    scene: tmlut::scene::Scene,
    material_scenes: Option<Vec<String>>,
    source: String,
    text: String,
}

/// Every scene file on its own. Every scene is read before any runs: each writes into a folder
/// named after it, and two names that give one folder (`copper-pot` and `Copper pot`) would
/// overwrite each other.
fn separate_runs(files: Vec<SceneFile>) -> tmlut::Result<Vec<Run>> {
    let mut runs: Vec<(std::path::PathBuf, Run)> = Vec::new();
    for file in files {
        let stem = tmlut::furnace::report::file_stem(&file.scene.name);
        if let Some((other, run)) =
            runs.iter().find(|(_, run)| tmlut::furnace::report::file_stem(&run.scene.name) == stem)
        {
            return Err(tmlut::Error::invalid(
                file.path.display().to_string(),
                format!(
                    "scene `{}` writes into the folder `{stem}`, as scene `{}` of {} does; scenes run together need \
                     names that differ in more than case and punctuation",
                    file.scene.name,
                    run.scene.name,
                    other.display()
                ),
            ));
        }
        let run =
            Run { source: file.path.display().to_string(), text: file.text, scene: file.scene, material_scenes: None };
        runs.push((file.path, run));
    }
    Ok(runs.into_iter().map(|(_, run)| run).collect())
}

/// Every scene file as one library, merged as `tmlut build --scene` merges them (names that give
/// one file are refused there, naming both scenes).
fn library_run(files: &[SceneFile]) -> tmlut::Result<Run> {
    let scene = library::merge(files)?;
    let material_scenes = (files.len() > 1)
        .then(|| files.iter().flat_map(|f| f.scene.materials.iter().map(|_| f.scene.name.clone())).collect());
    Ok(Run {
        scene,
        material_scenes,
        source: library::recorded_source(files).display().to_string(),
        text: library::recorded_text(files),
    })
}
