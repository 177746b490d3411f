//! `tmlut bake`: a scene's materials baked into the folder built for it, as one texture array of
//! rows along the view cosine (docs/bake.md); `tmlut build --scene --bake` does it after the build.

use std::path::{Path, PathBuf};

use clap::Args;

use tmlut::bake::{BakeConfig, BakeSource};
use tmlut::formats::{FileFormat, Precision};
use tmlut::scene::Scene;
use tmlut::scene::bake_files::write_baked;
use tmlut::scene::library;

use super::{ConfigArg, Context, ThreadsArg, one_of};

/// Bake every material of a scene (or library) into the folder built for it: its whole
/// transfer-matrix result tabulated along the view cosine, all materials as rows of one RGBA
/// texture array (baked.dds), each material's error against its model with exact integrals in the
/// manifest (docs/bake.md).
#[derive(Args)]
pub struct BakeArgs {
    /// Scene files, or folders of them, as the folder was built for (tmlut build --scene).
    #[arg(required = true)]
    scene: Vec<PathBuf>,
    /// The folder built for the scene.
    #[arg(long)]
    luts: PathBuf,
    #[command(flatten)]
    options: BakeOptions,
    #[command(flatten)]
    config: ConfigArg,
    #[command(flatten)]
    threads: ThreadsArg,
}

/// How a bake is made: the options `tmlut bake` and `tmlut build --scene --bake` share. Each one
/// given overrides the configuration's `[bake]` key of its name (docs/bake.md); the defaults
/// below are the section's.
#[derive(Args, Clone)]
pub struct BakeOptions {
    /// What the model reads its integrals from: `exact` (quadrature; the bake's error replaces the
    /// tables') or `tables` (the folder's own, as the scene shader reads them; each material's
    /// error is then measured against them, and `tmlut furnace` measures it against exact
    /// integrals). [default: exact]
    #[arg(long, value_parser = parse_source)]
    bake_source: Option<BakeSource>,
    /// Nodes of mu per material (9 to 8192). [default: 64]
    #[arg(long)]
    bake_nodes: Option<usize>,
    /// The interpolation error a kink or a segment's curvature may be estimated to cause before
    /// nodes are placed on it. [default: 2.5e-4]
    #[arg(long)]
    bake_tolerance: Option<f64>,
    /// Comma-separated files of the array: dds, ktx2, exr. [default: dds]
    #[arg(long, value_delimiter = ',', value_parser = parse_format)]
    bake_formats: Option<Vec<FileFormat>>,
    /// Storage precision of the array: f32 or f16 (f16 adds up to 2.4e-4 near 1). [default: f32]
    #[arg(long, value_parser = parse_precision)]
    bake_precision: Option<Precision>,
}

impl BakeOptions {
    /// `section` with every option given in its place.
    fn over(&self, section: &BakeConfig) -> BakeConfig {
        let mut bake = section.clone();
        bake.source = self.bake_source.unwrap_or(bake.source);
        bake.nodes = self.bake_nodes.unwrap_or(bake.nodes);
        bake.tolerance = self.bake_tolerance.unwrap_or(bake.tolerance);
        bake.formats = self.bake_formats.clone().unwrap_or(bake.formats);
        bake.precision = self.bake_precision.unwrap_or(bake.precision);
        bake
    }
}

fn parse_source(text: &str) -> Result<BakeSource, String> {
    one_of(text, &[("exact", BakeSource::Exact), ("tables", BakeSource::Tables)])
}

fn parse_format(text: &str) -> Result<FileFormat, String> {
    one_of(text, &[("dds", FileFormat::Dds), ("ktx2", FileFormat::Ktx2), ("exr", FileFormat::Exr)])
}

fn parse_precision(text: &str) -> Result<Precision, String> {
    one_of(text, &[("f32", Precision::F32), ("f16", Precision::F16)])
}

pub fn exec(args: BakeArgs, context: &Context) -> tmlut::Result<()> {
    let config = args.config.load()?;
    args.threads.apply()?;
    let files = library::read_scene_files(&args.scene)?;
    let scene = library::merge(&files)?;
    bake_and_report(&scene, &args.luts, &config, &args.options, context)
}

/// Bake `scene` into `luts` and print the files and each material's largest error.
pub fn bake_and_report(
    scene: &Scene,
    luts: &Path,
    config: &tmlut::config::Config,
    options: &BakeOptions,
    context: &Context,
) -> tmlut::Result<()> {
    let written = write_baked(scene, luts, config, &options.over(&config.bake), &context.progress())?;
    for file in &written.files {
        println!("{}", file.path.display());
    }
    let Some(baked) = written.files.first().and_then(|f| f.entry.baked.as_ref()) else { return Ok(()) };
    print!("{}", tmlut::bake::array::summary(baked));
    // What the baked shader costs per call, as the description the bake just wrote states it.
    if let Some((path, description)) = &written.shader {
        println!("{}", path.display());
        print!("{}", tmlut::shader::baked::cost_summary(description));
    }
    Ok(())
}
