//! `tmlut shader`: a scene's shader written as one set over a folder that matches its manifest, and
//! listed in that manifest.

use std::path::Path;

use super::{assert_clean_failure, build, scene_path, snapshot, stderr, stdout, tmlut, write_config};

use crate::common::SMALL_SET;
use tmlut::formats::manifest::{MANIFEST_FILE, Manifest};

#[test]
fn shader_refuses_a_folder_whose_tables_do_not_match_their_manifest() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let luts = dir.path().join("luts");
    let scene = scene_path("copper-pot");
    assert!(build(&config, &luts, &["--scene", &scene]).status.success());
    let shader = |out: &str| tmlut(&["shader", &scene, "--luts", luts.to_str().unwrap(), "--out", out]);
    let out = dir.path().join("shaders");
    assert!(shader(out.to_str().unwrap()).status.success());
    let slice = luts.join("fgd_varnished-copper_l2_from-above.dds");
    let original = std::fs::read(&slice).unwrap();
    let gd = luts.join("gd.dds");
    let gd_bytes = std::fs::read(&gd).unwrap();
    let mut other = gd_bytes.clone();
    let last = other.len() - 1;
    other[last] ^= 0x40;
    // Truncated, deleted, and a GD of other values: each refused, naming the file.
    for (file, damage, name) in [
        (&slice, Some(original[..original.len() - 8].to_vec()), "fgd_varnished-copper_l2_from-above.dds"),
        (&slice, None, "fgd_varnished-copper_l2_from-above.dds"),
        (&gd, Some(other), "gd.dds"),
    ] {
        match damage {
            Some(bytes) => std::fs::write(file, bytes).unwrap(),
            None => std::fs::remove_file(file).unwrap(),
        }
        let refused = dir.path().join("refused");
        let output = shader(refused.to_str().unwrap());
        assert!(!output.status.success(), "{name}: {}", stdout(&output));
        assert!(stderr(&output).contains(name), "{name}: {}", stderr(&output));
        assert!(!refused.join("copper_pot.wgsl").exists(), "{name}");
        std::fs::write(&slice, &original).unwrap();
        std::fs::write(&gd, &gd_bytes).unwrap();
    }
}

#[test]
fn the_scene_shader_is_listed_in_the_manifest_and_checked() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let out = dir.path().join("luts");
    let out_arg = out.to_str().unwrap();
    let scene = scene_path("copper-pot");
    assert!(build(&config, &out, &["--scene", &scene]).status.success());
    let no_budgets = write_config(dir.path(), "");
    let check = || tmlut(&["check", out_arg, "--budgets", no_budgets.to_str().unwrap()]);

    // Listed with length and SHA-256, read back by the loader and verified by `check`.
    let listed = |out: &Path| -> Vec<String> {
        let manifest = Manifest::read(&out.join(MANIFEST_FILE)).unwrap();
        let record = manifest.scene_shader.expect("the scene shader is listed");
        assert_eq!(record.scene, "copper-pot");
        for f in &record.files {
            let bytes = std::fs::read(out.join(&f.file)).unwrap();
            assert_eq!(
                (f.bytes, f.sha256.as_str()),
                (bytes.len() as u64, tmlut::pipeline::sha256_hex(&bytes).as_str())
            );
        }
        record.files.into_iter().map(|f| f.file).collect()
    };
    assert_eq!(
        listed(&out),
        ["copper_pot.hlsl", "copper_pot.wgsl", "copper_pot.constants.bin", "copper_pot.shader.json"]
    );
    let shader = tmlut::loader::SceneShaderFiles::open(&out).unwrap();
    assert_eq!(shader.wgsl, std::fs::read_to_string(out.join("copper_pot.wgsl")).unwrap());
    let constants = std::fs::read(out.join("copper_pot.constants.bin")).unwrap();
    assert_eq!(shader.constants.len() * 4, constants.len());
    // The header: each material's shape, then the first of its constants.
    assert_eq!(shader.constants[0] as usize, shader.description.materials[0].shape);
    assert_eq!(shader.description.materials[0].function, "tm_varnished_copper");
    let output = check();
    assert!(output.status.success(), "{}{}", stdout(&output), stderr(&output));
    for line in ["ok   copper_pot.wgsl: shader length ", "ok   copper_pot.shader.json: shader sha256"] {
        assert!(stdout(&output).contains(line), "expected `{line}` in:\n{}", stdout(&output));
    }

    // A shader file changed after its build is found by both.
    let wgsl = out.join("copper_pot.wgsl");
    let original = std::fs::read(&wgsl).unwrap();
    std::fs::write(&wgsl, [original.as_slice(), b"\n"].concat()).unwrap();
    let output = check();
    assert!(!output.status.success());
    for line in ["FAIL copper_pot.wgsl: shader length", "FAIL copper_pot.wgsl: shader sha256"] {
        assert!(stdout(&output).contains(line), "expected `{line}` in:\n{}", stdout(&output));
    }
    let err = tmlut::loader::SceneShaderFiles::open(&out).unwrap_err().to_string();
    assert!(err.contains("copper_pot.wgsl") && err.contains("bytes, the manifest states"), "{err}");
    std::fs::write(&wgsl, &original).unwrap();

    // `tmlut shader` into the folder of its tables replaces the listing: the reference file is
    // listed while written, and removed with it.
    let shader_into_folder = |views: &str| {
        let output = tmlut(&["shader", &scene, "--luts", out_arg, "--out", out_arg, "--reference-views", views]);
        assert!(output.status.success(), "{}", stderr(&output));
    };
    shader_into_folder("3");
    assert!(listed(&out).contains(&"copper_pot.reference.json".to_string()));
    shader_into_folder("0");
    assert!(!listed(&out).contains(&"copper_pot.reference.json".to_string()));
    assert!(!out.join("copper_pot.reference.json").exists());
    assert!(check().status.success());

    // A build into the folder replaces the tables the shader was specialised to: the shader
    // leaves with them.
    assert!(build(&config, &out, &["--only", "gd"]).status.success());
    assert!(Manifest::read(&out.join(MANIFEST_FILE)).unwrap().scene_shader.is_none());
    assert!(!out.join("copper_pot.wgsl").exists());
}

#[test]
fn a_scene_shader_is_written_as_one_set_or_not_at_all() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene_path("copper-pot");
    // The same scene's tables as a file per slice and as texture arrays: their shaders differ.
    let luts = |layout: &str| {
        let luts = dir.path().join(layout);
        let args = ["build", "-q", "--scene", &scene, "--slice-checks", "none", "--slice-layout", layout, "--out"];
        let built = tmlut(&[&args[..], &[luts.to_str().unwrap()]].concat());
        assert!(built.status.success(), "{}", stderr(&built));
        luts
    };
    let (files, arrays) = (luts("files"), luts("arrays"));
    let out = dir.path().join("shader");
    let shader = |luts: &Path, views: &str| {
        let (luts, out) = (luts.to_str().unwrap(), out.to_str().unwrap());
        tmlut(&["shader", &scene, "--luts", luts, "--out", out, "--reference-views", views])
    };
    let first = shader(&files, "0");
    assert!(first.status.success(), "{}", stderr(&first));
    let before = snapshot(&out);
    assert_eq!(before.len(), 4, "{:?}", before.iter().map(|f| &f.0).collect::<Vec<_>>());
    // A second run whose last file cannot be put in place (a folder holds its name) fails and
    // changes nothing: not the shaders it would have written before that file.
    let hlsl = before.iter().find(|f| f.0.ends_with(".hlsl")).expect("the HLSL is written");
    let reference = hlsl.0.replace(".hlsl", ".reference.json");
    std::fs::create_dir(out.join(&reference)).unwrap();
    let failed = shader(&arrays, "3");
    assert_clean_failure(&failed, &[&reference]);
    std::fs::remove_dir(out.join(&reference)).unwrap();
    assert_eq!(snapshot(&out), before);
    // Without the obstacle the set is replaced whole, and no staging folder is left.
    assert!(shader(&arrays, "3").status.success());
    let after = snapshot(&out);
    assert_eq!(after.len(), 5);
    assert_ne!(after.iter().find(|f| f.0.ends_with(".wgsl")), before.iter().find(|f| f.0.ends_with(".wgsl")));
    assert!(std::fs::read_dir(&out).unwrap().flatten().all(|e| e.path().is_file()), "{after:?}");
}

/// The fields `docs/shaders.md` documents in the schema table under `heading`: each row's first
/// cell, a path such as `textures[].layered`.
fn documented_fields(heading: &str) -> std::collections::BTreeSet<String> {
    let docs = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/shaders.md")).unwrap();
    let section = docs.split_once(heading).unwrap_or_else(|| panic!("docs/shaders.md has no `{heading}`")).1;
    let table = section.lines().skip_while(|l| !l.starts_with("| field")).take_while(|l| l.starts_with('|'));
    table.filter_map(|row| row.strip_prefix("| `")?.split_once('`').map(|(field, _)| field.to_string())).collect()
}

/// Every field of a JSON value by path (`a.b`, `list[].c`), each element of an array of objects
/// required to have the same fields as the first, so that no element leaves one out.
fn written_fields(value: &serde_json::Value, path: &str, out: &mut std::collections::BTreeSet<String>) {
    let join = |key: &str| if path.is_empty() { key.to_string() } else { format!("{path}.{key}") };
    match value {
        serde_json::Value::Object(map) => {
            for (key, field) in map {
                out.insert(join(key));
                written_fields(field, &join(key), out);
            }
        }
        serde_json::Value::Array(elements) if elements.iter().any(|e| e.is_object()) => {
            let each: Vec<_> = elements
                .iter()
                .map(|e| {
                    let mut fields = Default::default();
                    written_fields(e, &format!("{path}[]"), &mut fields);
                    fields
                })
                .collect();
            assert!(each.iter().all(|f| f == &each[0]), "`{path}`: elements with different fields: {each:?}");
            out.extend(each.into_iter().next().unwrap_or_default());
        }
        _ => {}
    }
}

/// Every example scene built alone with the default slice layout binds at most the default
/// number of textures (with a file per slice `thesis/layers` bound 12 and `thesis/split-sum` 9:
/// their slices now go into arrays), and its `.shader.json` writes every field `docs/shaders.md`
/// documents, in every texture and material, and no other; its `limits` are those of its
/// bindings, within WebGPU's defaults.
#[test]
fn every_example_scene_binds_at_most_the_default_textures_and_describes_every_field() {
    use tmlut::loader::{DeviceLimits, SceneShaderFiles};
    use tmlut::shader::scene::{DEFAULT_MAX_TEXTURES, SHADER_DESCRIPTION_FORMAT};
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let documented = documented_fields("### `<scene>.shader.json`");
    let scenes_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("luts/scenes");
    let mut scenes: Vec<_> = walk_tomls(&scenes_dir);
    scenes.sort();
    assert!(scenes.len() >= 10, "{scenes:?}");
    let mut arrays = 0;
    for scene in &scenes {
        let name = scene.strip_prefix(&scenes_dir).unwrap().display().to_string();
        let out = dir.path().join(name.replace(['/', '.'], "-"));
        let output = build(&config, &out, &["--scene", scene.to_str().unwrap()]);
        assert!(output.status.success() && !stderr(&output).contains("no shader"), "{name}: {}", stderr(&output));
        let shader = SceneShaderFiles::open(&out).unwrap();
        let description = &shader.description;
        assert!(description.textures.len() <= DEFAULT_MAX_TEXTURES, "{name}: {:?}", description.textures);
        assert_eq!(description.format_version, SHADER_DESCRIPTION_FORMAT, "{name}");
        let constants_bytes = shader.constants.len() * 4;
        let limits = DeviceLimits::of(&description.textures, 0).with_storage_buffer(constants_bytes);
        assert_eq!(description.limits, limits, "{name}");
        assert!(description.limits.beyond(&DeviceLimits::WEBGPU_DEFAULTS).is_empty(), "{name}");
        arrays += description.textures.iter().filter(|t| t.layered).count();
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join(format!("{}.shader.json", shader.stem))).unwrap()).unwrap();
        let mut written = Default::default();
        written_fields(&json, "", &mut written);
        assert_eq!(written, documented, "{name}: the fields written against those docs/shaders.md documents");
    }
    assert!(arrays > 0, "some scene reads texture arrays");
}

/// The scene files under `dir`, recursively.
fn walk_tomls(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap().flatten() {
        let path = entry.path();
        if path.is_dir() {
            found.extend(walk_tomls(&path));
        } else if path.extension().is_some_and(|e| e == "toml") {
            found.push(path);
        }
    }
    found
}

/// More textures than `--max-textures` allows are refused, naming each texture and the lookups
/// that read it: by `tmlut shader`, and by `tmlut build --scene` as a note, with no shader
/// written; the build's default layout stays within the limit by writing arrays.
#[test]
fn a_shader_binding_more_textures_than_allowed_is_refused_naming_the_lookups() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let scene = scene_path("thesis/layers");
    let files = dir.path().join("files");
    let built = build(&config, &files, &["--scene", &scene, "--slice-layout", "files"]);
    assert!(built.status.success(), "{}", stderr(&built));
    // A file per slice: 11 slices and GD, more than the default 8; the build says so and names
    // the way out.
    assert!(stderr(&built).contains("note: no shader written for scene `thesis-layers`"), "{}", stderr(&built));
    for text in ["binds 12 textures, more than --max-textures 8", "11 of them are slices", "--slice-layout arrays"] {
        assert!(stderr(&built).contains(text), "expected `{text}` in {}", stderr(&built));
    }
    assert!(!files.join("thesis_layers.wgsl").exists());
    let shader = |max: &str| {
        let (luts, out) = (files.to_str().unwrap(), dir.path().join("shader"));
        tmlut(&["shader", &scene, "--luts", luts, "--out", out.to_str().unwrap(), "--max-textures", max])
    };
    let refused = shader("11");
    assert!(!refused.status.success());
    for text in
        ["more than --max-textures 11", "fgd_copper-bare_l1_from-above.dds (FGD of `copper-bare`)", "gd.dds (GD of"]
    {
        assert!(stderr(&refused).contains(text), "expected `{text}` in {}", stderr(&refused));
    }
    assert!(!dir.path().join("shader/thesis_layers.wgsl").exists());
    // Allowed as many, it is written and states what it needs.
    assert!(shader("12").status.success());
    let written = tmlut::loader::SceneShaderFiles::open(dir.path().join("shader")).unwrap();
    assert_eq!(written.description.limits.max_sampled_textures_per_shader_stage, 12);
    let zero = shader("0");
    assert!(!zero.status.success() && stderr(&zero).contains("at least 1"), "{}", stderr(&zero));
    // The default layout puts the slices in arrays: within the default limit.
    let auto = dir.path().join("auto");
    let built = build(&config, &auto, &["--scene", &scene]);
    assert!(built.status.success() && !stderr(&built).contains("no shader"), "{}", stderr(&built));
    let written = tmlut::loader::SceneShaderFiles::open(&auto).unwrap();
    assert!(written.description.textures.iter().any(|t| t.layered), "{:?}", written.description.textures);
    assert!(written.description.textures.len() <= 8);
}
