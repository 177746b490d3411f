//! `tmlut bench bake`: what baking a scene's materials costs and how far the baked values are
//! from the model: per material its bake time from exact integrals, the breaks its nodes were
//! placed on, the texel reads a baked shader makes, and the largest error of each kind read
//! through a GPU's filter (8-bit weights) against the model between the nodes.

use std::fmt::Write;
use std::path::PathBuf;

use rayon::prelude::*;

use super::timed;
use crate::bake::{BakeSettings, BakedErrors, bake_material, baked_errors};
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
}

/// One material's figures.
#[derive(Debug, Clone)]
pub struct BakedMaterialFigures {
    pub name: String,
    pub lobes: usize,
    pub texel_reads: usize,
    pub breaks: usize,
    /// Seconds to bake it alone, on the threads of the run.
    pub seconds: f64,
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
/// scenes of `settings`, timed, then measure each one's errors.
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
    // Each material's exact integrals are its own, so that its time is what baking it alone
    // costs; the run over all of them shares one set, as a build would.
    let mut figures = Vec::with_capacity(materials.len());
    progress.start("bake, one material at a time", materials.len() as u64);
    for (name, material) in &materials {
        let exact = ExactTables::new(config, settings.exact_nodes)?;
        let (seconds, baked) = timed(|| bake_material(name, material, &exact, &settings.bake));
        let baked = baked?;
        let errors = baked_errors(
            &baked,
            material,
            &exact,
            settings.error_views_per_interval,
            Filter::QuantisedWeights { bits: 8 },
        );
        figures.push(BakedMaterialFigures {
            name: name.clone(),
            lobes: baked.layout.lobes,
            texel_reads: baked.rows(),
            breaks: baked.placement.breaks().len(),
            seconds,
            errors,
        });
        progress.advance(1);
    }
    progress.finish();
    let exact = ExactTables::new(config, settings.exact_nodes)?;
    let (all_seconds, baked) = timed(|| {
        materials.par_iter().map(|(name, m)| bake_material(name, m, &exact, &settings.bake)).collect::<Result<Vec<_>>>()
    });
    baked?;
    Ok(BakeBench { scene_files: files.len(), materials: figures, all_seconds })
}

/// The bench as a Markdown section.
pub fn markdown(bench: &BakeBench, settings: &BakeBenchSettings, threads: usize) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "## tmlut bench bake\n");
    let _ = writeln!(
        out,
        "{} materials of {} scene file(s), baked from exact integrals ({} Gauss–Legendre nodes per panel) at {} nodes of \
         mu with a break tolerance of {:.1e}, on {threads} thread(s). Errors: the baked rows read through a GPU's linear \
         filter (8-bit weights) against the model at {} views per node interval; lobe roughness, cosine and GD weighted by \
         the lobe's largest energy.\n",
        bench.materials.len(),
        bench.scene_files,
        settings.exact_nodes,
        settings.bake.nodes,
        settings.bake.tolerance,
        settings.error_views_per_interval,
    );
    let _ = writeln!(
        out,
        "| material | lobes | texel reads | breaks | bake (ms) | albedo | lobe energy | lobe roughness | lobe cos | lobe GD |"
    );
    let _ = writeln!(out, "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for m in &bench.materials {
        let e = &m.errors;
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {:.1} | {:.1e} | {:.1e} | {:.1e} | {:.1e} | {:.1e} |",
            m.name,
            m.lobes,
            m.texel_reads,
            m.breaks,
            m.seconds * 1e3,
            e.albedo.max,
            e.lobe_energy.max,
            e.lobe_roughness.max,
            e.lobe_cos.max,
            e.lobe_gd.max
        );
    }
    let worst = bench.materials.iter().max_by(|a, b| a.errors.max().total_cmp(&b.errors.max()));
    let times: Vec<f64> = bench.materials.iter().map(|m| m.seconds).collect();
    let _ = writeln!(
        out,
        "\nLargest error: {}. Bake time per material, alone: median {:.1} ms. All {} side by side: {:.2} s.",
        worst.map_or("none".to_string(), |m| {
            let w = m.errors.worst();
            format!("{:.1e} ({}, {} at mu {:.4})", w.max, m.name, w.value, w.at_mu)
        }),
        crate::stats::median(&times) * 1e3,
        bench.materials.len(),
        bench.all_seconds
    );
    out
}
