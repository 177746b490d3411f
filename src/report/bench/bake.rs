//! `tmlut bench bake`: what baking a scene's materials costs and how far the baked values are
//! from the model: the time to bake them all side by side from exact integrals (as a build would,
//! one set of integrals shared), per material its time baked alone (the first `alone`), the
//! breaks and jumps its nodes were placed on, the texel reads a baked shader makes, and the largest
//! error of each kind read through a GPU's filter (8-bit weights) against the model between the
//! nodes.

use std::fmt::Write;
use std::path::PathBuf;

use rayon::prelude::*;

use super::timed;
use crate::bake::{BakeSettings, BakedErrors, MaterialFamily, bake_material, bake_materials, baked_errors};
use crate::config::Config;
use crate::error::{Error, Result};
use crate::exact::ExactTables;
use crate::filter::Filter;
use crate::integrate::Progress;
use crate::model::Material;
use crate::scene::library::read_scene_files;

/// What to measure.
#[derive(Debug, Clone)]
pub struct BakeBenchSettings {
    /// Scene files, or folders of them (`library::read_scene_files`).
    pub scenes: Vec<PathBuf>,
    pub bake: BakeSettings,
    /// Views per node interval the errors are measured at.
    pub error_views_per_interval: usize,
    /// Gauss–Legendre nodes per panel of the exact integrals.
    pub exact_nodes: usize,
    /// Materials (the first ones) also baked alone, each with exact integrals of its own.
    pub alone: usize,
}

/// One material's figures.
#[derive(Debug, Clone)]
pub struct BakedMaterialFigures {
    pub name: String,
    pub lobes: usize,
    pub texel_reads: usize,
    pub breaks: usize,
    /// Jumps of the model its nodes were placed around (two breaks each).
    pub jumps: usize,
    /// Seconds to bake it alone, on the threads of the run, where it was.
    pub seconds: Option<f64>,
    pub errors: BakedErrors,
}

/// Every material's figures, and the whole bake's time.
#[derive(Debug, Clone)]
pub struct BakeBench {
    /// Scene files read.
    pub scene_files: usize,
    pub materials: Vec<BakedMaterialFigures>,
    /// Seconds to bake them all, materials side by side.
    pub all_seconds: f64,
}

/// Bake every material (at its scene's values; a range a scene varies at its middle) of the
/// scenes of `settings` side by side, timed, the first `alone` also alone, then measure each one's
/// errors.
pub fn bench_bake(config: &Config, settings: &BakeBenchSettings, progress: &dyn Progress) -> Result<BakeBench> {
    let files = read_scene_files(&settings.scenes)?;
    let mut materials: Vec<(String, Material)> = Vec::new();
    for scene in files.iter().map(|f| &f.scene) {
        for m in &scene.materials {
            materials.push((format!("{}/{}", scene.name, m.name), Material::new(m.model, m.stack()?)));
        }
    }
    if materials.is_empty() {
        return Err(Error::invalid("tmlut bench bake", "the scenes given hold no material"));
    }
    // Alone, each material's exact integrals are its own, so that its time is what baking it
    // alone costs; side by side they share one set, as a build would.
    let alone = settings.alone.min(materials.len());
    let mut seconds = Vec::with_capacity(alone);
    progress.start("bake, one material at a time", alone as u64);
    for (name, material) in &materials[..alone] {
        let exact = ExactTables::new(config, settings.exact_nodes)?;
        let (time, baked) = timed(|| bake_material(name, material, &exact, &settings.bake));
        baked?;
        seconds.push(time);
        progress.advance(1);
    }
    progress.finish();
    let exact = ExactTables::new(config, settings.exact_nodes)?;
    let families: Vec<MaterialFamily> = materials.iter().map(|(_, m)| MaterialFamily::fixed(m)).collect();
    let named: Vec<(&str, &MaterialFamily)> =
        materials.iter().zip(&families).map(|((name, _), family)| (name.as_str(), family)).collect();
    let (all_seconds, baked) = timed(|| bake_materials(&named, |_| &exact, &settings.bake, &()));
    let baked = baked?;
    progress.start("errors of the baked materials", materials.len() as u64);
    let figures = baked
        .par_iter()
        .zip(&materials)
        .enumerate()
        .map(|(k, (baked, (name, material)))| {
            let errors = baked_errors(
                baked,
                &MaterialFamily::fixed(material),
                &exact,
                settings.error_views_per_interval,
                Filter::QuantisedWeights { bits: 8 },
            )?;
            progress.advance(1);
            Ok(BakedMaterialFigures {
                name: name.clone(),
                lobes: baked.layout.lobes,
                texel_reads: baked.rows(),
                breaks: baked.placement.breaks().len(),
                jumps: baked.placement.segments().iter().filter(|s| s.jump).count(),
                seconds: seconds.get(k).copied(),
                errors,
            })
        })
        .collect::<Result<_>>()?;
    progress.finish();
    Ok(BakeBench { scene_files: files.len(), materials: figures, all_seconds })
}

/// The bench as a Markdown section.
pub fn markdown(bench: &BakeBench, settings: &BakeBenchSettings, threads: usize) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "## tmlut bench bake\n");
    let count = bench.materials.len();
    let _ = writeln!(
        out,
        "{count} materials of {} scene file(s), baked from exact integrals ({} Gauss–Legendre nodes per panel) at {} nodes \
         of mu with a break tolerance of {:.1e}, on {threads} thread(s): all side by side sharing one set of integrals, \
         and the first {} alone, each with its own. Errors: the baked rows read through a GPU's linear filter (8-bit \
         weights) against the model at {} views per node interval (a jump's interval at its two nodes alone); lobe \
         roughness, cosine and GD weighted by the lobe's largest energy.\n",
        bench.scene_files,
        settings.exact_nodes,
        settings.bake.nodes,
        settings.bake.tolerance,
        settings.alone.min(count),
        settings.error_views_per_interval,
    );
    let _ = writeln!(
        out,
        "| material | lobes | texel reads | breaks | jumps | bake alone (ms) | albedo | lobe energy | lobe roughness | lobe cos \
         | lobe GD |"
    );
    let _ = writeln!(out, "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for m in &bench.materials {
        let e = &m.errors;
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {} | {:.1e} | {:.1e} | {:.1e} | {:.1e} | {:.1e} |",
            m.name,
            m.lobes,
            m.texel_reads,
            m.breaks,
            m.jumps,
            m.seconds.map_or("–".to_string(), |s| format!("{:.1}", s * 1e3)),
            e.albedo.max,
            e.lobe_energy.max,
            e.lobe_roughness.max,
            e.lobe_cos.max,
            e.lobe_gd.max
        );
    }
    let worst = bench.materials.iter().max_by(|a, b| a.errors.max().total_cmp(&b.errors.max()));
    let times: Vec<f64> = bench.materials.iter().filter_map(|m| m.seconds).collect();
    let alone = if times.is_empty() {
        "none baked alone".to_string()
    } else {
        format!("alone: median {:.1} ms", crate::stats::median(&times) * 1e3)
    };
    let _ = writeln!(
        out,
        "\nLargest error: {}. Bake time per material, {alone}. All {count} side by side: {:.2} s ({:.1} ms per material).",
        worst.map_or("none".to_string(), |m| {
            let w = m.errors.worst();
            format!("{:.1e} ({}, {} at mu {:.4})", w.max, m.name, w.value, w.at_mu)
        }),
        bench.all_seconds,
        bench.all_seconds * 1e3 / count as f64,
    );
    out
}
