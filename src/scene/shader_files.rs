//! `tmlut shader`: a scene's transfer-matrix shader ([`crate::shader::scene`]) over a built folder,
//! written as `<scene>.wgsl`, `<scene>.hlsl`, `<scene>.constants.bin` (the buffer the functions read) and `<scene>.shader.json` (what to bind), and on
//! request `<scene>.reference.json`: the CPU evaluator's lobes and albedo at evenly spaced views
//! and the model's stiff ones, the values the shader must reproduce (the GPU-API test holds it to
//! 1e-5).

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::Scene;
use crate::commit::{Move, OutputFolder};
use crate::error::{Error, Result};
use crate::formats::manifest::{MANIFEST_FILE, Manifest, SceneShaderFile, SceneShaderRecord, write_manifest};
use crate::formats::write_bytes_atomically;
use crate::loader::LutFolder;
use crate::model::folder::{FgdSource, LibraryTables};
use crate::model::{Evaluation, Material, STIFF_VIEWS};
use crate::shader::scene::{SceneShader, ShaderMaterial, generate, texts};

/// The scene's materials as the shader takes them (their nominal values).
pub fn shader_materials(scene: &Scene) -> Result<Vec<ShaderMaterial>> {
    scene
        .materials
        .iter()
        .map(|m| {
            Ok(ShaderMaterial {
                name: m.name.clone(),
                model: m.model,
                albedo: m.albedo,
                albedo_form: m.albedo_form.clone(),
                tir: m.tir,
                tir_form: m.tir_form.clone(),
                stack: m.stack()?,
            })
        })
        .collect()
}

/// The CPU evaluator's result for one material at one view.
#[derive(Debug, Clone, Serialize)]
pub struct ReferencePoint {
    pub material: String,
    pub function: String,
    pub evaluation: Evaluation,
}

/// The view cosines of a reference of `views` views: `k / (views - 1)` (the normal alone for one),
/// and the model's stiff views ([`STIFF_VIEWS`]: the horizon, 1e-7, 1e-3, 0.5, the normal), in
/// increasing order.
pub fn reference_views(views: usize) -> Vec<f64> {
    let mut mus: Vec<f64> =
        (0..views).map(|k| if views > 1 { k as f64 / (views - 1) as f64 } else { 1.0 }).chain(STIFF_VIEWS).collect();
    mus.sort_by(f64::total_cmp);
    mus.dedup();
    mus
}

/// The most evenly spaced views a reference takes per material.
pub const MAX_REFERENCE_VIEWS: usize = 1 << 16;
/// The most (material, view) points a reference holds: each is a whole evaluation (its lobes
/// included), all held in memory until the file is written.
pub const MAX_REFERENCE_POINTS: usize = 1 << 20;

/// Refuse a reference of `views` views per material of `materials` beyond [`MAX_REFERENCE_VIEWS`]
/// or [`MAX_REFERENCE_POINTS`], before anything is allocated.
pub fn check_reference_views(views: usize, materials: usize) -> Result<()> {
    if views > MAX_REFERENCE_VIEWS {
        return Err(Error::invalid(
            "--reference-views",
            format!("{views}; allowed: 0 (no reference) to {MAX_REFERENCE_VIEWS}"),
        ));
    }
    let points = (views + STIFF_VIEWS.len()).saturating_mul(materials);
    if views > 0 && points > MAX_REFERENCE_POINTS {
        return Err(Error::invalid(
            "--reference-views",
            format!(
                "{views} views for each of {materials} materials make {points} reference points; allowed: at most \
                 {MAX_REFERENCE_POINTS} (views, and the {} stiff ones, times materials)",
                STIFF_VIEWS.len()
            ),
        ));
    }
    Ok(())
}

/// The CPU evaluation of every material of `materials` at [`reference_views`]`(views)`, with the
/// tables of `folder` read as the shader reads them. Fails where the folder could not answer a
/// lookup (the shader would have been refused too).
pub fn reference(
    folder: &LutFolder,
    shader: &SceneShader,
    materials: &[ShaderMaterial],
    views: usize,
) -> Result<Vec<ReferencePoint>> {
    check_reference_views(views, materials.len())?;
    let library = LibraryTables::open(folder, FgdSource::Packing, materials.iter().map(ShaderMaterial::reads))?;
    let mut points = Vec::with_capacity(materials.len() * (views + STIFF_VIEWS.len()));
    for (index, (material, function)) in materials.iter().zip(&shader.materials).enumerate() {
        let tables = library.of(index);
        let model = Material::new(material.model, material.stack.clone());
        for mu in reference_views(views) {
            points.push(ReferencePoint {
                material: material.name.clone(),
                function: function.function.clone(),
                evaluation: model.evaluate(mu, tables),
            });
        }
        let (misses, _) = tables.take_counts();
        if misses.count > 0 {
            return Err(Error::invalid(
                format!("material `{}`", material.name),
                format!(
                    "{} lookup(s) the folder holds no table for, first: {}",
                    misses.count,
                    misses.first.unwrap_or_default()
                ),
            ));
        }
    }
    Ok(points)
}

/// Write the shader of `scene` over the folder `luts` into `out` (created; locked while written),
/// with `reference_views` CPU reference views per material (0: no reference file); refused where
/// it would bind more than `max_textures` textures, naming the lookups that read them. Returns the
/// paths written.
///
/// Into the folder of `luts` itself, the files are committed with its manifest, which lists them
/// (`scene_shader`: length and SHA-256 of each, as `tmlut check` verifies them) in place of the
/// scene shader it listed before; elsewhere the files are committed as one set, `.shader.json` last.
pub fn write_scene_shader(
    scene: &Scene,
    luts: &Path,
    out: &Path,
    reference_views: usize,
    max_textures: usize,
) -> Result<WrittenShader> {
    check_reference_views(reference_views, scene.materials.len())?;
    super::memory::check(
        &format!("scene `{}`", scene.name),
        &format!("the shader of its {} materials", scene.materials.len()),
        super::memory::BASE_BYTES + super::memory::SHADER_BYTES_PER_MATERIAL * scene.materials.len() as u128,
        "shade fewer materials in one scene",
    )?;
    std::fs::create_dir_all(out).map_err(|source| Error::io(out, source))?;
    // Taken before the tables are read: into the folder of `luts`, no build changes them between
    // the reading and the commit.
    let folder_lock =
        OutputFolder::take(out, |holder| eprintln!("waiting for {holder} to finish writing {}", out.display()))?;
    let folder = LutFolder::open(luts)?;
    let materials = shader_materials(scene)?;
    let shader = generate(&folder, &materials)?;
    shader.check_texture_count(&scene.name, max_textures)?;
    // A shader is only as right as the files it binds: each is verified against the manifest
    // (SHA-256, header against its description), as the furnace and the loader verify them, so
    // that a swapped, truncated or deleted table is refused here rather than bound.
    for texture in &shader.textures {
        folder.load(&texture.file)?;
    }
    let stem = crate::shader::scene::identifier(&scene.name);
    let functions: Vec<&str> = shader.materials.iter().map(|m| m.function.as_str()).collect();
    let mut files: Vec<(String, String, Vec<u8>)> = texts(&shader)
        .into_iter()
        .map(|(lang, text)| {
            let what = format!(
                "{}: the transfer-matrix evaluation of the scene's materials over this folder's tables, one function \
                 per stack shape ({} shapes), tm_material(index, mu) and one function per material ({}) returning \
                 TmResult; bound as {stem}.shader.json states",
                lang.extension().to_uppercase(),
                shader.shapes.len(),
                functions.join(", ")
            );
            (format!("{stem}.{}", lang.extension()), what, text.into_bytes())
        })
        .collect();
    let json = |v: &dyn erased::Json| v.bytes();
    let constants_file = format!("{stem}.constants.bin");
    files.push((
        constants_file.clone(),
        format!(
            "the constants buffer the shader's functions read ({} little-endian f32: each material's shape and first \
             constant, then the constants of its stack that its shape's function reads)",
            shader.constants.len()
        ),
        shader.constants_bytes(),
    ));
    files.push((
        format!("{stem}.shader.json"),
        "what the shader binds (one texture per table file: binding, file, extent, channels; the constants buffer), \
         the device limits it needs, the functions stack shapes share and each material's function"
            .into(),
        json(&shader.description(&constants_file)),
    ));
    // What every reader refuses is never written.
    if let Some((file, _, bytes)) =
        files.iter().find(|(_, _, b)| b.len() as u64 > crate::formats::MAX_SHADER_FILE_BYTES)
    {
        return Err(Error::invalid(
            format!("scene `{}`", scene.name),
            format!(
                "its shader file {file} would be {} bytes; tmlut's readers take at most {} bytes: shade fewer materials \
                 in one scene",
                bytes.len(),
                crate::formats::MAX_SHADER_FILE_BYTES
            ),
        ));
    }
    if reference_views > 0 {
        let points = reference(&folder, &shader, &materials, reference_views)?;
        let what = format!(
            "the CPU evaluator (tmlut::model) at {reference_views} evenly spaced view cosines per material: the \
             values the shader must reproduce"
        );
        files.push((format!("{stem}.reference.json"), what, json(&points)));
    }
    let files = if same_folder(luts, out) {
        commit_with_manifest(&folder_lock, scene, files)?
    } else {
        // Committed as one set, `.shader.json` (which describes the others) last: a failed or
        // killed run leaves the earlier set, or a journal the next run completes, never a new
        // `.hlsl` beside an old `.wgsl`.
        let last = format!("{stem}.shader.json");
        let mut staging = folder_lock.staging()?;
        let (mut moves, mut written) = (Vec::new(), Vec::new());
        for (file, _, bytes) in files {
            write_bytes_atomically(&staging.dir.join(&file), &bytes)?;
            if file != last {
                moves.push(Move { staged: file.clone(), destination: file.clone() });
            }
            written.push(out.join(file));
        }
        crate::commit::commit_set(&folder_lock, &mut staging, moves, Vec::new(), &last)?;
        written
    };
    Ok(WrittenShader { files, materials: shader.materials })
}

/// What [`write_scene_shader`] wrote: its files, and each material's function as its
/// `.shader.json` describes it (what it costs among it).
#[derive(Debug)]
pub struct WrittenShader {
    pub files: Vec<PathBuf>,
    pub materials: Vec<crate::loader::MaterialFunction>,
}

/// Most materials [`cost_summary`] lists one by one.
const COSTS_LISTED: usize = 16;

/// What each material's function costs a GPU per call, in a few lines: the first materials one by
/// one, then the range over all of them.
pub fn cost_summary(materials: &[crate::loader::MaterialFunction]) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    for m in materials.iter().take(COSTS_LISTED) {
        let _ = writeln!(
            out,
            "  {}: {} lobe(s), {} texture reads, {} operations per call",
            m.function, m.lobes, m.cost.texture_reads, m.cost.operations
        );
    }
    if materials.len() > COSTS_LISTED {
        let range = |of: fn(&crate::loader::MaterialFunction) -> u32| {
            let values = materials.iter().map(of);
            (values.clone().min().unwrap_or(0), values.max().unwrap_or(0))
        };
        let (reads, operations) = (range(|m| m.cost.texture_reads), range(|m| m.cost.operations));
        let _ = writeln!(
            out,
            "  ... {} materials in all: {} to {} texture reads, {} to {} operations per call",
            materials.len(),
            reads.0,
            reads.1,
            operations.0,
            operations.1
        );
    }
    out
}

/// Whether two paths name one folder (both exist here: `luts` was opened, `out` created).
fn same_folder(a: &Path, b: &Path) -> bool {
    matches!((a.canonicalize(), b.canonicalize()), (Ok(a), Ok(b)) if a == b)
}

/// Stage `files` (name, what it is, bytes) and commit them with the folder's manifest listing
/// them; the files of the scene shader it listed before and no longer holds are removed.
fn commit_with_manifest(
    folder: &OutputFolder,
    scene: &Scene,
    files: Vec<(String, String, Vec<u8>)>,
) -> Result<Vec<PathBuf>> {
    let out = &folder.dir;
    let mut manifest = Manifest::read(&out.join(MANIFEST_FILE))?;
    let mut staging = folder.staging()?;
    let mut moves = Vec::new();
    let mut record = SceneShaderRecord::new(&scene.name);
    for (file, what, bytes) in files {
        write_bytes_atomically(&staging.dir.join(&file), &bytes)?;
        record.files.push(SceneShaderFile::new(&file, what, &bytes));
        moves.push(Move { staged: file.clone(), destination: file });
    }
    let removals = manifest
        .scene_shader
        .take()
        .into_iter()
        .flat_map(|old| old.files)
        .map(|f| f.file)
        .filter(|file| !moves.iter().any(|m| &m.destination == file))
        .collect();
    let written = record.files.iter().map(|f| out.join(&f.file)).collect();
    manifest.scene_shader = Some(record);
    write_manifest(&manifest, &staging.dir)?;
    crate::commit::commit(folder, &mut staging, moves, removals)?;
    Ok(written)
}

mod erased {
    /// Pretty JSON of any serialisable value, with a final newline.
    pub trait Json {
        fn bytes(&self) -> Vec<u8>;
    }
    impl<T: serde::Serialize> Json for T {
        fn bytes(&self) -> Vec<u8> {
            let mut text = serde_json::to_string_pretty(self).unwrap_or_else(|e| format!("\"unserialisable: {e}\""));
            text.push('\n');
            text.into_bytes()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reference_views_are_evenly_spaced_and_hold_the_stiff_views() {
        let views = reference_views(5);
        assert_eq!(views, vec![0.0, 1e-7, 1e-3, 0.25, 0.5, 0.75, 1.0]);
        assert_eq!(reference_views(1), vec![0.0, 1e-7, 1e-3, 0.5, 1.0]);
        let many = reference_views(2500);
        assert_eq!(many.len(), 2503, "0 and 1 are both among the evenly spaced views");
        assert!(many.windows(2).all(|w| w[0] < w[1]));
    }
}
