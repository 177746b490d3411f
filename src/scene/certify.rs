//! The exact integrals `tmlut fit --certify` holds a form to: a full table's at random points of
//! its recipe's check domains, a scene's slice's at random points where the scene's lookups of it
//! are made. A slice has no recipe of its own in the configuration: its indices, ranges and
//! settings come from the plan of the scene its folder was built for, which the folder's manifest
//! records whole, so the slice is planned again from that record.

use std::path::{Path, PathBuf};

use super::Scene;
use super::build::lookup_exact_values;
use super::library::{SceneFile, merge};
use super::plan::{PlannedBuild, plan};
use crate::config::{Config, TableKind};
use crate::error::{Error, Result};
use crate::formats::manifest::SceneRecord;
use crate::integrate::Progress;
use crate::recipes::interpolation::{ExactValues, InterpolationConfig, exact_values_of};
use crate::recipes::slices::{SliceOf, Slices};

/// The exact values for table `table` read from `table_file`, integrated with `config` (the
/// configuration the table was built with) and `seed`: its recipe's, or for a slice, the scene's
/// recorded in the manifest beside the file.
pub fn exact_values_for(
    table_file: &Path,
    table: &str,
    config: &Config,
    seed: u64,
    progress: &dyn Progress,
) -> Result<Vec<ExactValues>> {
    if let Some(recipe) = config.recipe_named(table) {
        return exact_values_of(recipe, seed, progress);
    }
    let slices = recorded_slice(table_file, table, config)?;
    let full = config.recipe(match slices.of {
        SliceOf::Fgd(_) => TableKind::Fgd,
        SliceOf::Tir(_) => TableKind::Tir,
    });
    // As many points as a full table's check, each integrated as the slice's own check does.
    let points = InterpolationConfig { points: full.interpolation().points, nodes: slices.reference().nodes };
    // No points (the configuration turns the check off) certifies nothing, as for a full table.
    if points.points == 0 {
        return Ok(Vec::new());
    }
    Ok(vec![lookup_exact_values(&slices, &points, seed, progress)?])
}

/// The slice `table` of the scene recorded in the manifest beside `table_file`, planned again with
/// `config`.
pub fn recorded_slice(table_file: &Path, table: &str, config: &Config) -> Result<Slices> {
    let who = || format!("--certify {}", table_file.display());
    let beside = crate::loader::ManifestBeside::of(table_file)?;
    let Some(record) = beside.manifest.and_then(|m| m.scene) else {
        return Err(Error::invalid(
            who(),
            format!(
                "table `{table}` has no recipe to integrate exactly, and {} records no scene to plan it from; \
                 allowed: a table of the configuration ({}) or a slice of a `tmlut build --scene` folder",
                beside.manifest_path.display(),
                TableKind::names().join(", ")
            ),
        ));
    };
    let plan = plan(&recorded_scene(&record)?, config)?;
    plan.tables
        .into_iter()
        .find_map(|t| match t.build {
            PlannedBuild::Slices(slices) if slices.name == table => Some(slices),
            _ => None,
        })
        .ok_or_else(|| {
            Error::invalid(
                who(),
                format!(
                    "scene `{}` (recorded in {}) plans no slice `{table}` with this configuration; certify with \
                     the --config the folder was built with",
                    record.name,
                    beside.manifest_path.display()
                ),
            )
        })
}

/// The scene a manifest records, parsed again: one file's text, or a library's files, each after
/// the comment line naming it ([`super::library::recorded_text`]), merged as the build merged them.
fn recorded_scene(record: &SceneRecord) -> Result<Scene> {
    const FILE_LINE: &str = "# scene file: ";
    let sources: Vec<&str> = record.source.split(", ").collect();
    let origin = |source: &str| format!("the scene recorded from {source}");
    let parse = |text: &str, source: &str| {
        let path = Path::new(source);
        let stem = path.file_stem().map_or_else(|| record.name.clone(), |s| s.to_string_lossy().into_owned());
        Scene::from_toml_in(text, &origin(source), &stem, path.parent().unwrap_or(Path::new("")))
    };
    if sources.len() < 2 || !record.text.starts_with(FILE_LINE) {
        return parse(&record.text, &record.source);
    }
    let mut files = Vec::new();
    for part in record.text.split(FILE_LINE).skip(1) {
        let (source, text) = part.split_once('\n').unwrap_or((part, ""));
        files.push(SceneFile { path: PathBuf::from(source), text: text.to_string(), scene: parse(text, source)? });
    }
    merge(&files)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_table_without_a_recipe_or_a_recorded_scene_is_refused_naming_what_is_allowed() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("fgd_pot_l1_from-above.dds");
        let config = Config::default();
        let err = exact_values_for(&file, "fgd_pot_l1_from-above", &config, 1, &()).unwrap_err().to_string();
        assert!(err.contains("table `fgd_pot_l1_from-above` has no recipe to integrate exactly"), "{err}");
        assert!(err.contains("records no scene") && err.contains("allowed: a table of the configuration"), "{err}");
    }

    #[test]
    fn a_library_record_is_parsed_file_by_file_and_merged() {
        let scene = |name: &str, eta: f64| {
            format!(
                "name = \"{name}\"\n[[material]]\nname = \"{name}-m\"\n[[material.layer]]\ntype = \"interface\"\n\
                 eta = {eta}\nalpha = 0.1\n[[material.layer]]\ntype = \"interface\"\neta = 0.5\nkappa = 3.0\nalpha = 0.2\n"
            )
        };
        let files: Vec<SceneFile> = [("a", 1.5), ("b", 1.3)]
            .iter()
            .map(|&(name, eta)| {
                let text = scene(name, eta);
                let parsed = Scene::from_toml(&text, name, name).unwrap();
                SceneFile { path: PathBuf::from(format!("lib/{name}.toml")), text, scene: parsed }
            })
            .collect();
        let record = SceneRecord::new(
            "library",
            super::super::library::recorded_source(&files).display().to_string(),
            super::super::library::recorded_text(&files),
            crate::formats::manifest::PlanRecord::default(),
        );
        let parsed = recorded_scene(&record).unwrap();
        assert_eq!(parsed, merge(&files).unwrap());
        assert_eq!(parsed.materials.len(), 2);
    }
}
