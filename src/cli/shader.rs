//! `tmlut shader`: a scene's transfer-matrix evaluation as WGSL and HLSL over a built folder.

use std::path::PathBuf;

use clap::Args;

use tmlut::scene::Scene;
use tmlut::shader::scene::DEFAULT_MAX_TEXTURES;

use super::Context;

/// Write a scene's transfer-matrix shader (WGSL and HLSL) over a built folder: one function per
/// material returning its lobes and directional albedo, reading the folder's tables with the
/// manifest's coordinates (docs/shaders.md).
#[derive(Args)]
pub struct ShaderArgs {
    /// Scene file (TOML; see luts/scenes/).
    scene: PathBuf,
    /// The folder built for the scene (tmlut build --scene), or one holding the tables it reads.
    #[arg(long)]
    luts: PathBuf,
    /// Output folder for <scene>.wgsl, <scene>.hlsl, <scene>.shader.json.
    #[arg(long)]
    out: PathBuf,
    /// Also write <scene>.reference.json: the CPU evaluator at this many views per material.
    #[arg(long, default_value_t = 0)]
    reference_views: usize,
    /// The most textures the shader may bind; more are refused, naming the lookups that read them.
    /// WebGPU binds 16 per shader stage unless a device asks for more; the default leaves a
    /// renderer half of them. The .shader.json states what the shader needs (`limits`).
    #[arg(long, default_value_t = DEFAULT_MAX_TEXTURES, value_parser = parse_max_textures)]
    max_textures: usize,
}

/// A count of textures: at least 1.
pub fn parse_max_textures(text: &str) -> Result<usize, String> {
    match text.trim().parse::<usize>() {
        Ok(n) if n >= 1 => Ok(n),
        _ => Err(format!("`{text}` is not a count of textures: give a whole number, at least 1")),
    }
}

pub fn exec(args: ShaderArgs, _: &Context) -> tmlut::Result<()> {
    // Bounded before the scene is read: a count past memory aborted on its allocation.
    tmlut::scene::shader_files::check_reference_views(args.reference_views, 1)?;
    let (scene, _) = Scene::read(&args.scene)?;
    let written = tmlut::scene::shader_files::write_scene_shader(
        &scene,
        &args.luts,
        &args.out,
        args.reference_views,
        args.max_textures,
    )?;
    for path in &written.files {
        println!("{}", path.display());
    }
    print!("{}", tmlut::scene::shader_files::cost_summary(&written.materials));
    Ok(())
}
