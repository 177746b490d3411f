//! `tmlut bake` and `tmlut build --scene --bake`: a scene's materials baked into the folder built
//! for it, read back by the loader as the model gives them, budgeted by `check`, and refused for a
//! folder built for another scene.

use super::{assert_clean_failure, build, scene_path, stdout, tmlut, write_config};

use crate::common::SMALL_SET;
use tmlut::exact::ExactTables;
use tmlut::loader::{BakedLut, LutFolder};
use tmlut::model::Material;
use tmlut::scene::Scene;

#[test]
fn a_baked_scene_reads_back_as_its_model_at_the_nodes_and_check_holds_its_error() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let luts = dir.path().join("luts");
    let scene_file = scene_path("copper-pot");
    let built = build(&config, &luts, &["--scene", &scene_file, "--bake"]);
    assert!(built.status.success(), "{}", super::stderr(&built));
    assert!(stdout(&built).contains("baked 1 material(s)"), "{}", stdout(&built));

    let folder = LutFolder::open(&luts).unwrap();
    let baked = BakedLut::from_folder(&folder).unwrap();
    assert_eq!(baked.file(), "baked.dds");
    let index = baked.material_index("varnished-copper").unwrap();
    let entry = baked.material(index).unwrap();
    assert_eq!((entry.lobes, entry.rows), (2, 5));
    assert!(entry.error.max() > 0.0 && entry.error.max() <= 1e-3, "{:?}", entry.error);
    // At the normal, a node, the array holds the model's values in f32.
    let (scene, _) = Scene::read(std::path::Path::new(&scene_file)).unwrap();
    let m = &scene.materials[0];
    let model = Material::new(m.model, m.stack().unwrap());
    let exact = ExactTables::new(&tmlut::config::Config::default(), 8).unwrap();
    let at_normal = model.evaluate(1.0, &exact);
    let read = baked.sample_gpu(index, 1.0);
    assert_eq!(read.len(), 18);
    for (c, (&read, exact)) in read.iter().zip(at_normal.albedo).enumerate() {
        assert!((read as f64 - exact).abs() < 1e-6, "albedo {c}: read {read}, the model {exact}");
    }
    assert!(baked.sample_gpu(index + 1, 0.5).is_empty(), "no material past the last");

    // The baked shader beside the array, listed with it, and verified by `check` below.
    let listed: Vec<&str> = baked.baked().shader_files.iter().map(|f| f.file.as_str()).collect();
    assert_eq!(listed, ["copper_pot.baked.hlsl", "copper_pot.baked.wgsl", "copper_pot.baked.shader.json"]);
    let wgsl = std::fs::read_to_string(luts.join("copper_pot.baked.wgsl")).unwrap();
    assert!(wgsl.contains("fn tm_varnished_copper(") && wgsl.contains("textureSampleLevel"), "{wgsl}");
    let description: tmlut::loader::shader::BakedShaderDescription =
        serde_json::from_slice(&std::fs::read(luts.join("copper_pot.baked.shader.json")).unwrap()).unwrap();
    assert_eq!(description.texture.file, "baked.dds");
    let cost = description.materials[0].cost;
    assert!(cost.texture_reads == 5 && cost.operations <= 40, "{cost:?}");

    // `check` holds every material to 1e-3 by default and to a stated budget.
    let no_budgets = write_config(dir.path(), "");
    let checked = tmlut(&["check", luts.to_str().unwrap(), "--budgets", no_budgets.to_str().unwrap()]);
    assert!(checked.status.success(), "{}", stdout(&checked));
    assert!(stdout(&checked).contains("baked.dds: max_baked_error"), "{}", stdout(&checked));
    let tight = dir.path().join("tight.toml");
    std::fs::write(&tight, "[baked]\nmax_baked_error = 1e-9\n").unwrap();
    let failed = tmlut(&["check", luts.to_str().unwrap(), "--budgets", tight.to_str().unwrap()]);
    assert_eq!(failed.status.code(), Some(1), "{}", stdout(&failed));
    assert!(stdout(&failed).contains("FAIL baked.dds: max_baked_error"), "{}", stdout(&failed));

    // The furnace measures the bake at its own views, and `check` holds it there too.
    let furnace_out = dir.path().join("furnace");
    let furnace = tmlut(&[
        "furnace",
        &scene_file,
        "--luts",
        luts.to_str().unwrap(),
        "--walk",
        "none",
        "--pictures",
        "none",
        "--quiet",
        "--out",
        furnace_out.to_str().unwrap(),
    ]);
    assert!(furnace.status.success(), "{}", super::stderr(&furnace));
    assert!(stdout(&furnace).contains("| baked error max |"), "{}", stdout(&furnace));
    let report = tmlut::furnace::report::FurnaceReport::read(&furnace_out.join("copper-pot/furnace.json")).unwrap();
    let measured = report.materials[0].errors.baked.as_ref().expect("the folder holds a bake of the material");
    assert!(measured.views > 0 && measured.max() <= 1e-3, "{measured:?}");
    assert_eq!(report.materials[0].albedo_baked.as_ref().map(Vec::len), Some(report.materials[0].mu.len()));
    std::fs::write(&tight, "[furnace_every_material]\nmax_baked_error = 1e-9\n").unwrap();
    let failed = tmlut(&["check", furnace_out.to_str().unwrap(), "--budgets", tight.to_str().unwrap()]);
    assert_eq!(failed.status.code(), Some(1), "{}", stdout(&failed));
    assert!(stdout(&failed).contains("varnished-copper: baked_error_max"), "{}", stdout(&failed));

    // A build of the scene again leaves no bake of the scene it replaced.
    assert!(build(&config, &luts, &["--scene", &scene_file]).status.success());
    assert!(!luts.join("baked.dds").exists() && !luts.join("copper_pot.baked.wgsl").exists());
    assert!(
        BakedLut::from_folder(&LutFolder::open(&luts).unwrap()).unwrap_err().to_string().contains("no baked array")
    );
}

#[test]
fn bake_refuses_a_folder_built_for_another_scene_and_bad_options() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let luts = dir.path().join("luts");
    assert!(build(&config, &luts, &["--scene", &scene_path("copper-pot")]).status.success());
    let luts_arg = luts.to_str().unwrap();
    let other = tmlut(&["bake", &scene_path("textured"), "--luts", luts_arg]);
    assert_clean_failure(&other, &["was built for scene `copper-pot`", "textured"]);
    let nodes = tmlut(&["bake", &scene_path("copper-pot"), "--luts", luts_arg, "--bake-nodes", "3"]);
    assert_clean_failure(&nodes, &["bake.nodes", "9 to 8192"]);
    let format = tmlut(&["bake", &scene_path("copper-pot"), "--luts", luts_arg, "--bake-formats", "bin"]);
    assert!(!format.status.success());
    assert!(super::stderr(&format).contains("allowed: dds, ktx2, exr"), "{}", super::stderr(&format));
    assert!(!luts.join("baked.dds").exists(), "nothing written by a refused bake");

    // The configuration's [bake] section names its keys as any section does.
    let misspelt = dir.path().join("misspelt.toml");
    std::fs::write(&misspelt, "[bake]\nnode = 64\n").unwrap();
    let refused =
        tmlut(&["bake", &scene_path("copper-pot"), "--luts", luts_arg, "--config", misspelt.to_str().unwrap()]);
    assert_clean_failure(&refused, &["unknown key `bake.node`", "nodes, "]);

    // From the folder's own tables, in two containers at f16: one bake, listed twice. The source
    // and the containers come from the [bake] section, the precision from the option over it.
    let section = dir.path().join("bake.toml");
    std::fs::write(&section, "[bake]\nsource = \"tables\"\nformats = [\"dds\", \"ktx2\"]\nprecision = \"f32\"\n")
        .unwrap();
    let from_tables = tmlut(&[
        "bake",
        &scene_path("copper-pot"),
        "--luts",
        luts_arg,
        "--config",
        section.to_str().unwrap(),
        "--bake-precision",
        "f16",
        "--quiet",
    ]);
    assert!(from_tables.status.success(), "{}", super::stderr(&from_tables));
    assert!(stdout(&from_tables).contains("from the folder's tables"), "{}", stdout(&from_tables));
    let manifest = tmlut::formats::manifest::Manifest::read(&luts.join("manifest.json")).unwrap();
    for file in ["baked.dds", "baked.ktx2"] {
        assert_eq!(manifest.entry(file).unwrap().precision, tmlut::formats::Precision::F16, "{file}");
    }
    let [dds, ktx2] = ["baked.dds", "baked.ktx2"].map(|f| manifest.entry(f).unwrap().baked.clone().unwrap());
    assert_eq!(dds.materials.len(), 1);
    assert_eq!(dds.materials[0].segments, ktx2.materials[0].segments, "one placement in both files");
    // Measured against exact integrals all the same: the small test tables' own error shows.
    let error = &dds.materials[0].error;
    assert!(dds.source.contains("tables") && error.views > 0 && error.against.contains("exact"), "{dds:?}");
}

#[test]
fn a_material_a_texture_varies_is_left_out_of_the_bake_and_said_so() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let scene = dir.path().join("mixed.toml");
    let copper = std::fs::read_to_string(scene_path("copper-pot")).unwrap().replace("copper-pot", "mixed");
    let varied = "\n[[material]]\nname = \"rough-coat\"\n\n[[material.layer]]\ntype = \"interface\"\neta = 1.5\n\
                  alpha = 0.2\nvary = { alpha = [0.1, 0.3] }\n";
    std::fs::write(&scene, copper + varied).unwrap();
    let luts = dir.path().join("luts");
    let built = build(&config, &luts, &["--scene", scene.to_str().unwrap(), "--bake"]);
    assert!(built.status.success(), "{}", super::stderr(&built));
    assert!(stdout(&built).contains("not baked: material `rough-coat`"), "{}", stdout(&built));
    let baked = BakedLut::from_folder(&LutFolder::open(&luts).unwrap()).unwrap();
    assert_eq!(baked.baked().materials.len(), 1);
    assert!(baked.material_index("rough-coat").is_none());
    let left_out = &baked.baked().left_out;
    assert!(left_out.len() == 1 && left_out[0].reason.contains("layer 1 alpha in [0.1, 0.3]"), "{left_out:?}");

    // A scene of varied materials alone has nothing to bake: refused, naming each.
    let textured = dir.path().join("textured");
    assert!(build(&config, &textured, &["--scene", &scene_path("textured")]).status.success());
    let refused = tmlut(&["bake", &scene_path("textured"), "--luts", textured.to_str().unwrap()]);
    assert_clean_failure(&refused, &["has no material a bake can hold", "worn-gold", "glazed-ceramic"]);
}
