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
    let read = baked.sample_gpu(index, 1.0, &[]);
    assert_eq!(read.len(), 18);
    for (c, (&read, exact)) in read.iter().zip(at_normal.albedo).enumerate() {
        assert!((read as f64 - exact).abs() < 1e-6, "albedo {c}: read {read}, the model {exact}");
    }
    assert!(baked.sample_gpu(index + 1, 0.5, &[]).is_empty(), "no material past the last");

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

    // Baked from the folder's tables, each material's error is measured against those tables, and
    // the summary, the manifest and `check` say so (the furnace above measures against exact
    // integrals whatever the source).
    let from_tables = tmlut(&["bake", &scene_file, "--luts", luts.to_str().unwrap(), "--bake-source", "tables"]);
    assert!(from_tables.status.success(), "{}", super::stderr(&from_tables));
    assert!(stdout(&from_tables).contains(&format!("errors against {}", tmlut::bake::TABLES_REFERENCE)));
    let folder = LutFolder::open(&luts).unwrap();
    let baked = BakedLut::from_folder(&folder).unwrap();
    let entry = baked.material(baked.material_index("varnished-copper").unwrap()).unwrap();
    assert!(entry.error.against.starts_with(tmlut::bake::TABLES_REFERENCE), "{}", entry.error.against);
    assert!(entry.error.max() > 0.0, "{:?}", entry.error);
    let checked = tmlut(&["check", luts.to_str().unwrap(), "--budgets", no_budgets.to_str().unwrap()]);
    assert!(stdout(&checked).contains("baked.dds: max_baked_error (against its tables)"), "{}", stdout(&checked));

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
fn a_material_a_texture_varies_is_baked_across_its_range_and_one_beyond_the_limits_left_out() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let scene = dir.path().join("mixed.toml");
    let copper = std::fs::read_to_string(scene_path("copper-pot")).unwrap().replace("copper-pot", "mixed");
    let glaze = "\n[[material]]\nname = \"glaze\"\n\n[[material.layer]]\ntype = \"interface\"\nalpha = 0.2\n\
                 vary = { eta = [1.4, 1.7] }\n";
    let three = "\n[[material]]\nname = \"three-maps\"\n\n[[material.layer]]\ntype = \"interface\"\n\
                 vary = { eta = [1.4, 1.6], alpha = [0.1, 0.2] }\n[[material.layer]]\ntype = \"interface\"\n\
                 eta = 2.0\nvary = { alpha = [0.1, 0.3] }\n";
    std::fs::write(&scene, copper + glaze + three).unwrap();
    let luts = dir.path().join("luts");
    let built = build(&config, &luts, &["--scene", scene.to_str().unwrap(), "--bake"]);
    assert!(built.status.success(), "{}", super::stderr(&built));
    assert!(stdout(&built).contains("baked 2 material(s)"), "{}", stdout(&built));
    assert!(stdout(&built).contains("not baked: material `three-maps`"), "{}", stdout(&built));

    let baked = BakedLut::from_folder(&LutFolder::open(&luts).unwrap()).unwrap();
    let index = baked.material_index("glaze").expect("the glaze is baked across its index");
    let entry = baked.material(index).unwrap();
    let axis = &entry.varied[0];
    assert_eq!((entry.varied.len(), axis.parameter.as_str(), axis.range), (1, "layer 1 eta", [1.4, 1.7]));
    assert_eq!((axis.spacing.as_str(), axis.nominal), ("uniform", 0.5 * (1.4 + 1.7)), "the range's middle");
    assert!(axis.nodes > 2 && entry.error.max() > 0.0 && entry.error.max() <= 1e-3, "{entry:?}");
    assert!(baked.baked().lookup.contains("varied"), "{}", baked.baked().lookup);
    // The worst error is where the parameter lies between nodes or on one, within its range.
    let at = &entry.error.worst().at_varied;
    assert!(at.len() == 1 && (1.4..=1.7).contains(&at[0]), "{:?}", entry.error);
    // At the normal, a node along mu, and at each end of the range, the array holds the model there.
    let (scene_read, _) = Scene::read(&scene).unwrap();
    let glaze_material = scene_read.materials.iter().find(|m| m.name == "glaze").unwrap();
    let exact = ExactTables::new(&tmlut::config::Config::default(), 8).unwrap();
    for eta in [1.4, 1.7] {
        let model = Material::new(glaze_material.model, glaze_material.stack_at(&[eta]).unwrap());
        let albedo = model.evaluate(1.0, &exact).albedo;
        let read = baked.sample_gpu(index, 1.0, &[eta as f32]);
        for (c, (&read, exact)) in read.iter().zip(albedo).enumerate() {
            assert!((read as f64 - exact).abs() < 1e-6, "eta {eta}, albedo {c}: read {read}, the model {exact}");
        }
    }
    let nominal = [axis.nominal as f32];
    assert_eq!(baked.sample_gpu(index, 0.4, &[]), baked.sample_gpu(index, 0.4, &nominal), "none given: the nominal");

    // The material of three varied parameters, named with them and the size it would take.
    let left_out = &baked.baked().left_out;
    assert_eq!(left_out.len(), 1, "{left_out:?}");
    for says in ["layer 1 eta in [1.4, 1.6]", "layer 1 alpha in [0.1, 0.2]", "layer 2 alpha in [0.1, 0.3]", "8 blocks"]
    {
        assert!(left_out[0].reason.contains(says), "{says}: {}", left_out[0].reason);
    }

    // The baked shader takes the glaze's index by name, and says what it costs.
    let wgsl = std::fs::read_to_string(luts.join("mixed.baked.wgsl")).unwrap();
    assert!(wgsl.contains("fn tm_glaze(mu: f32, layer_1_eta: f32) -> TmResult"), "{wgsl}");
    assert!(wgsl.contains("fn tm_varnished_copper(mu: f32) -> TmResult"), "{wgsl}");
    let description: tmlut::loader::shader::BakedShaderDescription =
        serde_json::from_slice(&std::fs::read(luts.join("mixed.baked.shader.json")).unwrap()).unwrap();
    let glaze_cost = description.materials.iter().find(|m| m.material == "glaze").unwrap().cost;
    assert_eq!(glaze_cost.texture_reads, 2 * entry.rows, "{glaze_cost:?}");

    // `check` holds the varied material to 1e-3 as any other; the furnace reads it at its nominal.
    let no_budgets = write_config(dir.path(), "");
    let checked = tmlut(&["check", luts.to_str().unwrap(), "--budgets", no_budgets.to_str().unwrap()]);
    assert!(checked.status.success(), "{}", stdout(&checked));
    let furnace_out = dir.path().join("furnace");
    let furnace = tmlut(&[
        "furnace",
        scene.to_str().unwrap(),
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
    let report = tmlut::furnace::report::FurnaceReport::read(&furnace_out.join("mixed/furnace.json")).unwrap();
    let glaze_report = report.materials.iter().find(|m| m.name == "glaze").unwrap();
    let measured = glaze_report.errors.baked.as_ref().expect("the folder holds a bake of the glaze");
    assert!(measured.views > 0 && measured.max() <= 1e-3, "{measured:?}");
    let three_report = report.materials.iter().find(|m| m.name == "three-maps").unwrap();
    assert!(three_report.errors.baked.is_none(), "a material left out has no baked error");

    // A scene of such materials alone has nothing to bake: refused, naming each.
    let alone = dir.path().join("alone.toml");
    std::fs::write(&alone, format!("name = \"alone\"\n{three}")).unwrap();
    let alone_luts = dir.path().join("alone");
    assert!(build(&config, &alone_luts, &["--scene", alone.to_str().unwrap()]).status.success());
    let refused = tmlut(&["bake", alone.to_str().unwrap(), "--luts", alone_luts.to_str().unwrap()]);
    assert_clean_failure(&refused, &["has no material a bake can hold", "three-maps", "at most 2"]);
}

/// A material whose model kinks across its parameter (the textured scene's worn gold: a lobe's
/// roughness reaching its clamp of 1 somewhere in its roughness maps' ranges, at a place that moves
/// with the view) errs in proportion to the parameter's node spacing: beyond 1e-3 at the most
/// nodes a baked material takes, it is left out naming its parameters, its size and its error.
#[test]
fn a_varied_material_that_errs_beyond_the_limit_at_the_most_nodes_is_left_out_saying_so() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let textured = dir.path().join("textured");
    let built = build(&config, &textured, &["--scene", &scene_path("textured"), "--bake"]);
    assert!(built.status.success(), "{}", super::stderr(&built));
    let baked = BakedLut::from_folder(&LutFolder::open(&textured).unwrap()).unwrap();
    assert!(baked.material_index("glazed-ceramic").is_some());
    assert!(baked.material_index("worn-gold").is_none());
    let left_out = &baked.baked().left_out;
    assert!(left_out.len() == 1 && left_out[0].what == "material `worn-gold`", "{left_out:?}");
    for says in
        ["layer 1 alpha in [0.1, 0.4]", "layer 2 alpha in [0.05, 0.3]", "blocks of 5 rows", "errs by", "held to"]
    {
        assert!(left_out[0].reason.contains(says), "{says}: {}", left_out[0].reason);
    }
    assert!(stdout(&built).contains("not baked: material `worn-gold`"), "{}", stdout(&built));
}
