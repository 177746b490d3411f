//! Many scene files planned and built as one library: a level's scenes, or a studio's folder of
//! them. Their materials are planned together, so that a lookup two scenes share (a preset coat,
//! the same copper) is one table ([`super::plan`]), and they keep their names: a material name
//! may appear in one scene of a library only.

use std::path::{Path, PathBuf};

use super::{Scene, file_name_part};
use crate::error::{Error, Result};

/// Most materials one build plans: 40 scene files of the most a scene holds. Planning and the
/// manifest grow linearly with them; `docs/scenes.md` gives the measured cost per material.
pub const MAX_LIBRARY_MATERIALS: usize = 40 * super::MAX_MATERIALS;

/// The name of a library of more than one scene (a single scene keeps its own).
pub const LIBRARY_NAME: &str = "library";

/// One scene file of a library, as read.
#[derive(Debug, Clone)]
pub struct SceneFile {
    pub path: PathBuf,
    pub text: String,
    pub scene: Scene,
}

/// The scene files `paths` name: each a scene file, or a folder whose `.toml` files are scene
/// files (read in name order, not recursively).
pub fn read_scene_files(paths: &[PathBuf]) -> Result<Vec<SceneFile>> {
    let mut files = Vec::new();
    for path in paths {
        if path.is_dir() {
            let mut found: Vec<PathBuf> = std::fs::read_dir(path)
                .map_err(|source| Error::io(path, source))?
                .filter_map(|entry| entry.ok().map(|e| e.path()))
                .filter(|p| p.is_file() && p.extension().is_some_and(|e| e == "toml"))
                .collect();
            found.sort();
            if found.is_empty() {
                return Err(Error::invalid(path.display().to_string(), "a folder with no .toml scene file in it"));
            }
            files.extend(found);
        } else {
            files.push(path.clone());
        }
    }
    let mut scenes = Vec::with_capacity(files.len());
    for path in files {
        let (scene, text) = Scene::read(&path)?;
        scenes.push(SceneFile { path, text, scene });
    }
    Ok(scenes)
}

/// The scenes of `files` as one: their materials in order, under the library's name where there
/// is more than one. Refused, naming both places: a material name in two scenes, two scenes of one
/// name, scenes whose scene-wide options (`margin_nodes`) differ; and more than
/// [`MAX_LIBRARY_MATERIALS`] materials.
pub fn merge(files: &[SceneFile]) -> Result<Scene> {
    let Some(first) = files.first() else {
        return Err(Error::invalid("--scene", "no scene file given"));
    };
    if files.len() == 1 {
        return Ok(first.scene.clone());
    }
    let count: usize = files.iter().map(|f| f.scene.materials.len()).sum();
    if count > MAX_LIBRARY_MATERIALS {
        return Err(Error::invalid(
            "the scenes of this build",
            format!(
                "{count} materials in {} scene files; allowed: at most {MAX_LIBRARY_MATERIALS} in one build (split the library into builds)",
                files.len()
            ),
        ));
    }
    let mut library = Scene {
        name: LIBRARY_NAME.into(),
        materials: Vec::with_capacity(count),
        margin_nodes: first.scene.margin_nodes,
        warnings: Vec::new(),
    };
    // Names are compared as the files they become (`Copper` and `copper` are one file), as a
    // scene's own materials are.
    let mut material_at = FileNames::default();
    let mut scene_at = FileNames::default();
    for file in files {
        let scene = &file.scene;
        scene_at.claim(
            "scene",
            &scene.name,
            &file.path,
            "the scenes of one build must have names that differ as file names",
        )?;
        if scene.margin_nodes != library.margin_nodes {
            return Err(Error::invalid(
                file.path.display().to_string(),
                format!(
                    "margin_nodes = {} where {} has {}; scene-wide options must agree across the scenes of one build",
                    scene.margin_nodes,
                    first.path.display(),
                    library.margin_nodes
                ),
            ));
        }
        for material in &scene.materials {
            material_at.claim(
                "material",
                &material.name,
                &file.path,
                "a material name may appear in one scene of a build only (rename one)",
            )?;
            library.materials.push(material.clone());
        }
        library.warnings.extend(scene.warnings.iter().map(|w| format!("scene `{}`: {w}", scene.name)));
    }
    Ok(library)
}

/// The names given so far as the files they become, each with the file that gave it.
#[derive(Default)]
struct FileNames<'a>(std::collections::HashMap<String, (&'a str, &'a Path)>);

impl<'a> FileNames<'a> {
    /// Take the file name of `name` (a `kind` of `path`), refused where another name took it, with
    /// `rule` saying why.
    fn claim(&mut self, kind: &str, name: &'a str, path: &'a Path, rule: &str) -> Result<()> {
        if let Some((other_name, other)) = self.0.insert(file_name_part(name), (name, path)) {
            return Err(Error::invalid(
                path.display().to_string(),
                format!("{kind} `{name}` and {kind} `{other_name}` of {} give one file name; {rule}", other.display()),
            ));
        }
        Ok(())
    }
}

/// The text a build records of its scenes: the one file as it is, or every file after a comment
/// line naming it.
pub fn recorded_text(files: &[SceneFile]) -> String {
    match files {
        [one] => one.text.clone(),
        _ => files.iter().map(|f| format!("# scene file: {}\n{}\n", f.path.display(), f.text)).collect(),
    }
}

/// Where a build's scenes were read from, as the manifest records it.
pub fn recorded_source(files: &[SceneFile]) -> PathBuf {
    PathBuf::from(files.iter().map(|f| f.path.display().to_string()).collect::<Vec<_>>().join(", "))
}

/// The build of the scenes of `files` (a library where there are several) into `out`, with the
/// defaults of `tmlut build --scene`: sampled checks, the slice layout chosen by count, no cache,
/// no shard, no error maps.
pub fn build_request(
    files: &[SceneFile],
    config: crate::config::Config,
    out: std::path::PathBuf,
) -> Result<super::build::SceneBuildRequest> {
    use super::build::{SceneBuildRequest, SliceChecks, SliceLayout};
    Ok(SceneBuildRequest {
        scene: merge(files)?,
        source: recorded_source(files),
        text: recorded_text(files),
        config,
        out,
        error_maps: false,
        slice_checks: SliceChecks::Sampled,
        cache: None,
        slice_layout: SliceLayout::Auto,
        max_textures: crate::shader::scene::DEFAULT_MAX_TEXTURES,
        shard: None,
        merge_from: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(name: &str, text: &str) -> SceneFile {
        let scene = Scene::from_toml(text, name, name).unwrap();
        SceneFile { path: PathBuf::from(format!("{name}.toml")), text: text.into(), scene }
    }

    const COPPER: &str = "[[material]]\nname = \"copper\"\n[[material.layer]]\ntype = \"interface\"\neta = [0.27, 0.68, 1.22]\nkappa = [3.61, 2.63, 2.29]\nalpha = 0.1\n";

    #[test]
    fn scenes_merge_in_order_and_names_that_collide_are_refused_naming_both() {
        let glass =
            "[[material]]\nname = \"glass\"\n[[material.layer]]\ntype = \"interface\"\neta = 1.5\nalpha = 0.05\n";
        let library = merge(&[file("a", COPPER), file("b", glass)]).unwrap();
        assert_eq!(library.name, LIBRARY_NAME);
        assert_eq!(library.materials.iter().map(|m| m.name.as_str()).collect::<Vec<_>>(), ["copper", "glass"]);

        let error = merge(&[file("a", COPPER), file("b", COPPER)]).unwrap_err().to_string();
        assert!(error.contains("copper") && error.contains("a.toml") && error.contains("b.toml"), "{error}");
        // Names that differ only as file names do not: they would share files.
        let capital = COPPER.replace("\"copper\"", "\"Copper\"");
        let error = merge(&[file("a", COPPER), file("b", &capital)]).unwrap_err().to_string();
        assert!(error.contains("Copper") && error.contains("give one file name"), "{error}");

        let margin = format!("margin_nodes = 2\n{glass}");
        let error = merge(&[file("a", COPPER), file("b", &margin)]).unwrap_err().to_string();
        assert!(error.contains("margin_nodes") && error.contains("a.toml"), "{error}");

        let mut same_name = file("b", glass);
        same_name.scene.name = "a".into();
        let error = merge(&[file("a", COPPER), same_name]).unwrap_err().to_string();
        assert!(error.contains("scene `a`"), "{error}");
    }
}
