//! `tmlut furnace`: the furnace test of scenes' materials.

use std::path::PathBuf;

use clap::Args;

use tmlut::model::folder::FgdSource;
use tmlut::random_walk::{Masking, WalkSettings};
use tmlut::scene::Scene;

use super::{ConfigArg, Context, ThreadsArg, check_count, check_sample_count, one_of};

/// The furnace test of a scene's materials: the directional albedo A(mu) of the transfer-matrix
/// model with the scene's tables, with exact integrals, and from a random walk through the
/// explicit stack, so that the tables' error and the model's are measured apart. Writes
/// <out>/<scene>/furnace.json and per material a furnace sphere (.exr, .png) and an A(mu)
/// plot; prints a Markdown summary.
#[derive(Args)]
pub struct FurnaceArgs {
    /// Scene files (default: every scene of luts/scenes/).
    scenes: Vec<PathBuf>,
    /// A folder built for the scene (tmlut build --scene), or the default set; default: build
    /// the scene's plan into <out>/<scene>/luts first.
    #[arg(long)]
    luts: Option<PathBuf>,
    /// Output folder; each scene writes into a subfolder named after it.
    #[arg(long, default_value = "furnace")]
    out: PathBuf,
    #[command(flatten)]
    config: ConfigArg,
    /// View cosines per material, uniform in angle, grazing included.
    #[arg(long, default_value_t = 64)]
    views: usize,
    /// Samples of each exact integral (a power of two).
    #[arg(long, default_value_t = 1 << 16)]
    exact_samples: u64,
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

fn parse_fgd_source(text: &str) -> Result<FgdSource, String> {
    one_of(text, &[("packing", FgdSource::Packing), ("table", FgdSource::Table)])
}

pub fn exec(args: FurnaceArgs, context: &Context) -> tmlut::Result<()> {
    // The library bounds these too (`FurnaceSettings::validate`); here the error names the option.
    check_count("--views", args.views, tmlut::furnace::VIEWS)?;
    check_sample_count("--exact-samples", args.exact_samples)?;
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
    if args.luts.is_some() && scenes.len() > 1 {
        return Err(tmlut::Error::invalid(
            "--luts",
            format!("given with {} scenes; a folder of tables serves one scene", scenes.len()),
        ));
    }
    let settings = tmlut::furnace::FurnaceSettings {
        views: args.views,
        exact_samples: args.exact_samples,
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
        ..Default::default()
    };
    settings.validate()?;
    // Every scene is read before any runs: each writes into a folder named after it, and two
    // names that give one folder (`copper-pot` and `copper pot`) would overwrite each other.
    let mut read: Vec<(PathBuf, Scene, String)> = Vec::new();
    for path in scenes {
        let (scene, text) = Scene::read(&path)?;
        let stem = tmlut::furnace::report::file_stem(&scene.name);
        if let Some((other, _, _)) = read.iter().find(|(_, s, _)| tmlut::furnace::report::file_stem(&s.name) == stem) {
            return Err(tmlut::Error::invalid(
                path.display().to_string(),
                format!(
                    "scene `{}` writes into the folder `{stem}`, as scene {} does; scenes run together need names \
                     that differ in more than case and punctuation",
                    scene.name,
                    other.display()
                ),
            ));
        }
        read.push((path, scene, text));
    }
    let progress = context.progress();
    let mut summary = String::from(tmlut::furnace::report::MARKDOWN_HEADER);
    for (path, scene, text) in read {
        for warning in &scene.warnings {
            eprintln!("warning: {warning}");
        }
        let request = tmlut::furnace::FurnaceRequest {
            out: args.out.join(tmlut::furnace::report::file_stem(&scene.name)),
            scene,
            source: path.display().to_string(),
            text,
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
