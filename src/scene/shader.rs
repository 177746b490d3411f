//! `tmlut shader`: a scene's transfer-matrix shader ([`crate::shader::scene`]) over a built folder,
//! written as `<scene>.wgsl`, `<scene>.hlsl` and `<scene>.shader.json` (what to bind), and on
//! request `<scene>.reference.json`: the CPU evaluator's lobes and albedo at evenly spaced views
//! and the model's stiff ones, the values the shader must reproduce (the GPU-API test holds it to
//! 1e-5).

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::Scene;
use crate::commit::OutputFolder;
use crate::error::{Error, Result};
use crate::formats::write_bytes_atomically;
use crate::loader::LutFolder;
use crate::model::folder::{FgdSource, FolderTables};
use crate::model::{Evaluation, Material, STIFF_VIEWS};
use crate::shader::scene::{SceneShader, ShaderMaterial, generate, texts};

/// The scene's materials as the shader takes them (their nominal values).
pub fn shader_materials(scene: &Scene) -> Result<Vec<ShaderMaterial>> {
    scene
        .materials
        .iter()
        .map(|m| {
            Ok(ShaderMaterial { name: m.name.clone(), model: m.model, albedo: m.albedo, tir: m.tir, stack: m.stack()? })
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

/// The CPU evaluation of every material of `materials` at [`reference_views`]`(views)`, with the
/// tables of `folder` read as the shader reads them. Fails where the folder could not answer a
/// lookup (the shader would have been refused too).
pub fn reference(
    folder: &LutFolder,
    shader: &SceneShader,
    materials: &[ShaderMaterial],
    views: usize,
) -> Result<Vec<ReferencePoint>> {
    let mut points = Vec::with_capacity(materials.len() * views);
    for (material, function) in materials.iter().zip(&shader.materials) {
        let tables = FolderTables::open(folder, material.albedo, material.tir, FgdSource::Packing)?;
        let model = Material::new(material.model, material.stack.clone());
        for mu in reference_views(views) {
            points.push(ReferencePoint {
                material: material.name.clone(),
                function: function.function.clone(),
                evaluation: model.evaluate(mu, &tables),
            });
        }
        let misses = tables.misses();
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

/// Write the shader of `scene` over the folder `luts` into `out` (created; locked while written;
/// each file replaced atomically), with `reference_views` CPU reference views per material (0: no
/// reference file). Returns the paths written.
pub fn write_scene_shader(scene: &Scene, luts: &Path, out: &Path, reference_views: usize) -> Result<Vec<PathBuf>> {
    let folder = LutFolder::open(luts)?;
    let materials = shader_materials(scene)?;
    let shader = generate(&folder, &materials)?;
    let stem = crate::shader::scene::identifier(&scene.name);
    let mut files: Vec<(String, Vec<u8>)> = texts(&shader)
        .into_iter()
        .map(|(lang, text)| (format!("{stem}.{}", lang.extension()), text.into_bytes()))
        .collect();
    let json = |v: &dyn erased::Json| v.bytes();
    files.push((format!("{stem}.shader.json"), json(&shader.description())));
    if reference_views > 0 {
        let points = reference(&folder, &shader, &materials, reference_views)?;
        files.push((format!("{stem}.reference.json"), json(&points)));
    }
    std::fs::create_dir_all(out).map_err(|source| Error::io(out, source))?;
    let _lock =
        OutputFolder::take(out, |holder| eprintln!("waiting for {holder} to finish writing {}", out.display()))?;
    let mut written = Vec::new();
    for (file, bytes) in files {
        let path = out.join(file);
        write_bytes_atomically(&path, &bytes)?;
        written.push(path);
    }
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
