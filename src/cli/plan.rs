//! `tmlut plan`: the tables a scene needs, and why.

use std::path::PathBuf;

use clap::Args;

use tmlut::scene::library;

use super::{ConfigArg, Context};

/// Print the build plan of a scene: the lookups its materials make, each table built with its
/// size and reason, each table or range left out with its reason, and the total bytes against
/// the default set. Integrates nothing.
#[derive(Args)]
pub struct PlanArgs {
    /// Scene files (TOML; see luts/scenes/ and docs/scenes.md), or folders of them: more than
    /// one is planned as one library, as `tmlut build --scene A --scene B` builds it.
    #[arg(required = true)]
    scenes: Vec<PathBuf>,
    #[command(flatten)]
    config: ConfigArg,
}

pub fn exec(args: PlanArgs, _: &Context) -> tmlut::Result<()> {
    let config = args.config.load()?;
    let scene = library::merge(&library::read_scene_files(&args.scenes)?)?;
    print!("{}", tmlut::scene::plan::plan(&scene, &config)?);
    Ok(())
}
