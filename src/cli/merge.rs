//! `tmlut merge`: join the shards of a library build into one folder.

use std::path::PathBuf;

use clap::Args;

use tmlut::scene::build::{SceneBuildRequest, SliceChecks, SliceLayout};
use tmlut::scene::library;
use tmlut::shader::scene::DEFAULT_MAX_TEXTURES;

use super::build::{build_and_report, parse_slice_checks, parse_slice_layout};
use super::{ConfigArg, Context, ThreadsArg};

/// Join the shards of a scene build (`tmlut build --scene ... --shard I/N --cache SHARD_DIR`) into
/// one output folder, as one build of the whole library writes it: every entry of every shard
/// folder is verified by its SHA-256 first, every table is read from them and none integrated.
/// Give the scenes, configuration, seed and options the shards were built with.
#[derive(Args)]
pub struct MergeArgs {
    /// The shard folders (each the `--cache` folder of one `--shard I/N` build).
    #[arg(required = true)]
    shards: Vec<PathBuf>,
    /// The scene files or folders the shards were built for.
    #[arg(long, required = true)]
    scene: Vec<PathBuf>,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    config: ConfigArg,
    /// The seed the shards were built with, where it overrode the configuration's.
    #[arg(long)]
    seed: Option<u64>,
    /// As given to the shards' builds: `sampled` or `none` (`full` builds no shard).
    #[arg(long, value_parser = parse_slice_checks, default_value = "sampled")]
    slice_checks: SliceChecks,
    /// How the slices are written, as `tmlut build --slice-layout`.
    #[arg(long, value_parser = parse_slice_layout, default_value = "auto")]
    slice_layout: SliceLayout,
    /// The most textures the library's shader may bind, as `tmlut build --max-textures`.
    #[arg(long, default_value_t = DEFAULT_MAX_TEXTURES, value_parser = super::shader::parse_max_textures)]
    max_textures: usize,
    #[command(flatten)]
    threads: ThreadsArg,
}

pub fn exec(args: MergeArgs, context: &Context) -> tmlut::Result<()> {
    let mut config = args.config.load()?;
    if let Some(seed) = args.seed {
        config.seed = seed;
    }
    args.threads.apply()?;
    let files = library::read_scene_files(&args.scene)?;
    let request = SceneBuildRequest {
        slice_checks: args.slice_checks,
        slice_layout: args.slice_layout,
        max_textures: args.max_textures,
        merge_from: args.shards,
        ..library::build_request(&files, config, args.out)?
    };
    build_and_report(&request, context)
}
