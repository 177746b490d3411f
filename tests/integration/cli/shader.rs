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
    assert_eq!(listed(&out), ["copper_pot.hlsl", "copper_pot.wgsl", "copper_pot.shader.json"]);
    let shader = tmlut::loader::SceneShaderFiles::open(&out).unwrap();
    assert_eq!(shader.wgsl, std::fs::read_to_string(out.join("copper_pot.wgsl")).unwrap());
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
    assert_eq!(before.len(), 3, "{:?}", before.iter().map(|f| &f.0).collect::<Vec<_>>());
    // A second run whose last file cannot be put in place (a folder holds its name) fails and
    // changes nothing: not the shaders it would have written before that file.
    let reference = before[0].0.replace(".hlsl", ".reference.json");
    std::fs::create_dir(out.join(&reference)).unwrap();
    let failed = shader(&arrays, "3");
    assert_clean_failure(&failed, &[&reference]);
    std::fs::remove_dir(out.join(&reference)).unwrap();
    assert_eq!(snapshot(&out), before);
    // Without the obstacle the set is replaced whole, and no staging folder is left.
    assert!(shader(&arrays, "3").status.success());
    let after = snapshot(&out);
    assert_eq!(after.len(), 4);
    assert_ne!(after.iter().find(|f| f.0.ends_with(".wgsl")), before.iter().find(|f| f.0.ends_with(".wgsl")));
    assert!(std::fs::read_dir(&out).unwrap().flatten().all(|e| e.path().is_file()), "{after:?}");
}
