//! `tmlut build`: integrate tables, or a scene's plan, into a folder with its manifest.

use std::path::PathBuf;

use clap::Args;

use tmlut::integrate::Method;
use tmlut::pipeline::{self, BuildRequest};
use tmlut::scene::Scene;
use tmlut::scene::build::{SceneBuildRequest, Shard, SliceChecks, SliceLayout, build_scene};
use tmlut::scene::library;
use tmlut::scene::{cache, plan::human_bytes};
use tmlut::shader::scene::DEFAULT_MAX_TEXTURES;

use super::{ConfigArg, Context, ThreadsArg, one_of};

/// Integrate tables and write them, with a manifest.json, into a folder.
#[derive(Args)]
pub struct BuildArgs {
    #[command(flatten)]
    config: ConfigArg,
    /// Comma-separated tables to build (default: all). See `tmlut list`.
    #[arg(long, value_delimiter = ',')]
    only: Option<Vec<String>>,
    /// Build an engine's tables with its conventions and write its own file beside them: a preset
    /// of luts/presets/ by name (`tmlut list`), or the path of a preset file (`.toml`). See
    /// docs/engines.md.
    #[arg(long, conflicts_with_all = ["config", "only", "scene", "error_maps"])]
    preset: Option<String>,
    /// Output folder.
    #[arg(long, default_value = "out/luts")]
    out: PathBuf,
    #[command(flatten)]
    threads: ThreadsArg,
    /// Seed of the Monte Carlo estimates, overriding the configuration's.
    #[arg(long)]
    seed: Option<u64>,
    /// Integration method of every table, overriding the configuration's: `fast` (one
    /// measure per (mu, alpha)) or `per-cell` (every cell on its own; slow, for cross-checks).
    #[arg(long, value_parser = parse_method)]
    method: Option<Method>,
    /// Also write each table's error map: maps/<table>_error.exr (every node's replicate
    /// standard error) and maps/<table>_error.png (heatmaps with a colour bar).
    #[arg(long)]
    error_maps: bool,
    /// Build only what this scene's materials need (see `tmlut plan`); the configuration
    /// still sets samples, masking and precision. Records the scene and plan in the manifest.
    /// Given more than once, or a folder of scene files, every material of every scene is planned
    /// together as one library: identical lookups are built once.
    #[arg(long, conflicts_with = "only")]
    scene: Vec<PathBuf>,
    /// How a scene's slices are checked against the exact integral: `sampled` (reference cells
    /// and interpolation points drawn across every slice of the build; the default), `full`
    /// (every slice on its own, and against the full table) or `none` (no check of the tables:
    /// the furnace measures them in the material).
    #[arg(long, value_parser = parse_slice_checks, default_value = "sampled", requires = "scene")]
    slice_checks: SliceChecks,
    /// Read the tables of a scene build from this content-addressed cache and store new ones in
    /// it, shared by every build, folder and scene that names it (see `tmlut cache`). Alone,
    /// `--cache` uses the default folder: $XDG_CACHE_HOME/tmlut, else ~/.cache/tmlut. Without it,
    /// nothing outside the output folder is touched.
    #[arg(long, num_args = 0..=1, default_missing_value = "", requires = "scene")]
    cache: Option<PathBuf>,
    /// How a scene's slices are written: `arrays` (a few texture arrays, each slice a region of a
    /// layer, listed in the array's manifest entry), `files` (a texture file per slice) or `auto`
    /// (arrays where files of their own would make the shader bind more than --max-textures).
    #[arg(long, value_parser = parse_slice_layout, default_value = "auto", requires = "scene")]
    slice_layout: SliceLayout,
    /// The most textures the scene's shader may bind; a shader binding more is not written (a note
    /// names the lookups that read them). WebGPU binds 16 per shader stage unless a device asks for
    /// more; the default leaves a renderer half of them.
    #[arg(long, default_value_t = DEFAULT_MAX_TEXTURES, value_parser = super::shader::parse_max_textures, requires = "scene")]
    max_textures: usize,
    /// Build only part I of N of the scene's tables (I from 1), into the cache folder (`--cache
    /// DIR`, required), and write no output folder; `tmlut merge` joins the shards' folders.
    /// Every shard plans the whole library, so the same scenes, configuration and seed must be
    /// given to each.
    #[arg(long, value_parser = Shard::parse, requires = "cache")]
    shard: Option<Shard>,
    /// After the build, bake every material of the scene into the folder (as `tmlut bake` does,
    /// with the --bake-* options).
    #[arg(long, requires = "scene", conflicts_with = "shard")]
    bake: bool,
    #[command(flatten)]
    bake_options: super::bake::BakeOptions,
}

pub fn parse_slice_layout(text: &str) -> Result<SliceLayout, String> {
    one_of(text, &[("auto", SliceLayout::Auto), ("arrays", SliceLayout::Arrays), ("files", SliceLayout::Files)])
}

/// The cache folder `--cache` names: its value, or the default folder for `--cache` alone.
pub fn cache_folder(cache: Option<PathBuf>) -> tmlut::Result<Option<PathBuf>> {
    match cache {
        Some(dir) if dir.as_os_str().is_empty() => tmlut::scene::cache::default_dir().map(Some).ok_or_else(|| {
            tmlut::Error::invalid(
                "--cache",
                "no default cache folder: neither XDG_CACHE_HOME nor HOME is set; name one (--cache DIR)",
            )
        }),
        other => Ok(other),
    }
}

/// The most files a scene build lists one by one.
const MAX_FILES_LISTED: usize = 64;

pub fn parse_slice_checks(text: &str) -> Result<SliceChecks, String> {
    one_of(text, &[("sampled", SliceChecks::Sampled), ("full", SliceChecks::Full), ("none", SliceChecks::None)])
}

fn parse_method(text: &str) -> Result<Method, String> {
    one_of(text, &[("fast", Method::Fast), ("per-cell", Method::PerCell)])
}

pub fn exec(args: BuildArgs, context: &Context) -> tmlut::Result<()> {
    if let Some(name) = &args.preset {
        return build_preset(name, &args, context);
    }
    let mut config = args.config.load()?;
    if let Some(seed) = args.seed {
        config.seed = seed;
    }
    if let Some(method) = args.method {
        config.set_method(method);
    }
    args.threads.apply()?;
    let progress = context.progress();
    let written = match args.scene.is_empty() {
        false => {
            let files = library::read_scene_files(&args.scene)?;
            let request = SceneBuildRequest {
                error_maps: args.error_maps,
                slice_checks: args.slice_checks,
                cache: cache_folder(args.cache)?,
                slice_layout: args.slice_layout,
                max_textures: args.max_textures,
                shard: args.shard,
                ..library::build_request(&files, config, args.out)?
            };
            build_and_report(&request, context)?;
            if args.bake {
                let scene = &request.scene;
                super::bake::bake_and_report(scene, &request.out, &request.config, &args.bake_options, context)?;
            }
            return Ok(());
        }
        true => {
            let request = BuildRequest { config, only: args.only, out: args.out, error_maps: args.error_maps };
            pipeline::build(&request, &progress)?
        }
    };
    print!("{}", pipeline::summary(&written));
    Ok(())
}

/// `--preset`: the preset's tables and its engine's file, with `--seed`, `--method` and `--threads`.
fn build_preset(name: &str, args: &BuildArgs, context: &Context) -> tmlut::Result<()> {
    let mut preset = tmlut::presets::Preset::load(name)?;
    // A misspelt budget would otherwise surface only when `check` reads it, after the build.
    tmlut::report::check::Budgets::of_preset(&preset)?;
    if let Some(seed) = args.seed {
        preset.config.seed = seed;
    }
    if let Some(method) = args.method {
        preset.config.set_method(method);
    }
    args.threads.apply()?;
    let (written, drop_ins) = pipeline::build_preset(preset, &args.out, &context.progress())?;
    print!("{}", pipeline::summary(&written));
    for path in drop_ins {
        println!("{}  (engine file; see the manifest's drop_ins)", path.display());
    }
    Ok(())
}

/// Build a scene's plan (or a shard of it, or merge shards) and print what it did: the plan's
/// summary and warnings, the files (listed where few), the closing summary; the scene's shader is
/// written beside a folder's tables.
pub fn build_and_report(request: &SceneBuildRequest, context: &Context) -> tmlut::Result<()> {
    let progress = context.progress();
    // An unchanged build is restored whole from the cache: nothing planned, integrated or read.
    let whole = request.whole_build_key().zip(request.cache.as_deref());
    if let Some((key, cache)) = &whole {
        let started = std::time::Instant::now();
        let verify = |staged: &std::path::Path| tmlut::scene::build::verify_restored(request, staged);
        match cache::restore_build(cache, key, &request.out, |message| eprintln!("{message}"), verify)? {
            Ok(restored) => {
                // The scene's own warnings, which a planned build prints with its plan.
                for warning in &request.scene.warnings {
                    eprintln!("warning: {warning}");
                }
                println!(
                    "{} materials: restored whole from the table cache {} (build {}): {} files ({}), every one verified by its SHA-256 and every table at {} nodes against the exact integral; {:.2} s",
                    request.scene.materials.len(),
                    cache.display(),
                    &key[..12],
                    restored.files,
                    human_bytes(restored.bytes),
                    cache::VERIFIED_NODES,
                    started.elapsed().as_secs_f64()
                );
                return Ok(());
            }
            // No record yet is the common case; anything else is worth a word.
            Err(why) if why != cache::NO_RECORD => eprintln!("note: not restored whole from the cache: {why}"),
            Err(_) => {}
        }
    }
    let (plan, written, summary) = build_scene(request, &progress)?;
    println!("{}", plan.summary());
    for warning in &plan.warnings {
        eprintln!("warning: {warning}");
    }
    if request.shard.is_none() {
        write_scene_shader(&request.scene, &request.out, request.max_textures);
        if let Some((key, cache)) = &whole
            && let Err(e) = cache::store_build(cache, key, &request.out)
        {
            eprintln!("warning: the build is not kept whole in the table cache: {e}");
        }
        // A library's files are listed in its manifest; one line per file would bury the summary.
        if written.len() <= MAX_FILES_LISTED {
            print!("{}", pipeline::summary(&written));
        } else {
            println!("{} files, each described in {}", written.len(), request.out.join("manifest.json").display());
        }
    }
    println!("{summary}");
    Ok(())
}

/// The scene's shader beside its tables, where the shader covers the scene; a note where it does
/// not (the tables are built either way).
fn write_scene_shader(scene: &Scene, out: &std::path::Path, max_textures: usize) {
    match tmlut::scene::shader_files::write_scene_shader(scene, out, out, 0, max_textures) {
        Ok(written) => {
            for path in written.files {
                println!("{}", path.display());
            }
        }
        Err(e) => eprintln!("note: no shader written for scene `{}`: {e}", scene.name),
    }
}
