//! `tmlut furnace` end to end on the reduced CI scene set: the outputs, the budgets `tmlut check`
//! holds them to, determinism across thread counts, and bad input.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

fn tmlut(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tmlut")).args(args).output().expect("the tmlut binary runs")
}

fn repo(path: &str) -> String {
    format!("{}/{path}", env!("CARGO_MANIFEST_DIR"))
}

fn text(output: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr))
}

/// The CI scenes at 16 views: a 2-flux coat over a conductor, and the 6-flux scattering stack.
const VIEWS: &str = "16";

fn furnace(out: &Path, threads: &str) -> Output {
    tmlut(&[
        "furnace",
        &repo("luts/scenes/copper-pot.toml"),
        &repo("luts/scenes/scattering.toml"),
        "--out",
        out.to_str().unwrap(),
        "--views",
        VIEWS,
        "--threads",
        threads,
        "--quiet",
    ])
}

/// One run of the CI scenes, shared by the tests of this file.
fn ci_run() -> &'static Path {
    static RUN: OnceLock<(tempfile::TempDir, PathBuf, String)> = OnceLock::new();
    let (_, out, _) = RUN.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("furnace");
        let output = furnace(&out, "2");
        assert!(output.status.success(), "{}", text(&output));
        let printed = text(&output);
        (dir, out, printed)
    });
    out
}

fn report(out: &Path, scene: &str) -> serde_json::Value {
    let bytes = std::fs::read(out.join(scene).join("furnace.json")).unwrap();
    serde_json::from_slice(&bytes).unwrap()
}

#[test]
fn every_material_gets_its_curves_errors_and_pictures() {
    let out = ci_run();
    for (scene, material) in [("copper-pot", "varnished-copper"), ("scattering", "scattering-stack")] {
        let r = report(out, scene);
        let m = &r["materials"][0];
        assert_eq!(m["name"], material);
        for curve in ["mu", "albedo_tables", "albedo_exact", "albedo_walk", "walk_standard_error", "walk_paths"] {
            assert_eq!(m[curve].as_array().unwrap().len(), 16, "{scene}: {curve}");
        }
        // Grazing included, at the limit the tables take for mu = 0.
        assert_eq!(m["mu"][0].as_f64(), Some(1.0));
        assert_eq!(m["mu"][15].as_f64(), Some(1e-6));
        for key in ["table", "model", "total"] {
            let max = m["errors"][key]["max_all"].as_f64().unwrap();
            assert!(max.is_finite() && max >= 0.0, "{scene}: {key} {max}");
        }
        assert!(m["model_cost_ns"].as_f64().unwrap() > 0.0);
        assert!(!r["random_walk"].as_array().unwrap().is_empty());
        for file in m["files"].as_array().unwrap() {
            let path = out.join(scene).join(file.as_str().unwrap());
            assert!(std::fs::metadata(&path).unwrap().len() > 1000, "{}", path.display());
        }
        // The tables were built for the scene, with a manifest that records it.
        assert!(out.join(scene).join("luts/manifest.json").is_file());
    }
    let copper = report(out, "copper-pot");
    let png = image::open(out.join("copper-pot/varnished-copper_furnace.png")).unwrap();
    assert!(png.width() > 3 * 256 && png.height() > 256);
    // The model with the scene's tables against exact integrals: the tables' own error is small.
    assert!(copper["materials"][0]["errors"]["table"]["max_all"].as_f64().unwrap() < 1e-3);
}

#[test]
fn the_ci_budgets_hold_and_a_tightened_one_fails_naming_figure_and_limit() {
    let out = ci_run();
    let output = tmlut(&["check", out.to_str().unwrap(), "--budgets", &repo("luts/ci-budgets.toml")]);
    assert!(output.status.success(), "{}", text(&output));
    assert!(text(&output).contains("copper-pot/furnace.json: varnished-copper: table_error_max"), "{}", text(&output));

    let dir = tempfile::tempdir().unwrap();
    let tight = dir.path().join("tight.toml");
    std::fs::write(&tight, "[furnace.copper-pot]\nmax_table_error = 1e-9\n[furnace.scattering]\n").unwrap();
    let output = tmlut(&["check", out.to_str().unwrap(), "--budgets", tight.to_str().unwrap()]);
    assert!(!output.status.success());
    let said = text(&output);
    assert!(
        said.contains("FAIL copper-pot/furnace.json: varnished-copper: table_error_max")
            && said.contains("<= 1.000e-9"),
        "{said}"
    );

    // A budgeted scene that was not run fails too.
    std::fs::write(&tight, "[furnace.textured]\nmax_table_error = 1.0\n").unwrap();
    let output = tmlut(&["check", out.to_str().unwrap(), "--budgets", tight.to_str().unwrap()]);
    assert!(!output.status.success());
    assert!(text(&output).contains("furnace textured present"), "{}", text(&output));

    // Per channel, the total error against the walk, and one material's budget in place of its
    // scene's: a tight green channel and a tight total fail, each named; the material's own
    // budget lets the scene's tight table limit pass for it alone.
    std::fs::write(
        &tight,
        "[furnace.copper-pot]\nmax_table_error_per_channel = [1.0, 1e-12, 1.0]\nmax_total_error = 1e-9\n\
         [furnace.scattering]\nmax_table_error = 1e-12\n[furnace.scattering.materials.scattering-stack]\nmax_table_error = 1.0\n",
    )
    .unwrap();
    let output = tmlut(&["check", out.to_str().unwrap(), "--budgets", tight.to_str().unwrap()]);
    let said = text(&output);
    assert_eq!(output.status.code(), Some(1), "{said}");
    assert!(said.contains("FAIL copper-pot/furnace.json: varnished-copper: table_error_max (G)"), "{said}");
    assert!(said.contains("ok   copper-pot/furnace.json: varnished-copper: table_error_max (R)"), "{said}");
    assert!(said.contains("FAIL copper-pot/furnace.json: varnished-copper: total_error_max"), "{said}");
    let scattering_failures: Vec<&str> =
        said.lines().filter(|l| l.starts_with("FAIL scattering/furnace.json: ")).collect();
    assert!(!scattering_failures.iter().any(|l| l.contains("scattering-stack:")), "{said}");
    assert!(
        said.contains("ok   scattering/furnace.json: scattering-stack: table_error_max")
            && said.contains("(<= 1.000e0)"),
        "{said}"
    );

    // --strict: a scene with no budget fails instead of being reported unchecked.
    std::fs::write(&tight, "[furnace.copper-pot]\nmax_table_error = 1.0\n").unwrap();
    let lenient = tmlut(&["check", out.to_str().unwrap(), "--budgets", tight.to_str().unwrap()]);
    assert!(lenient.status.success(), "{}", text(&lenient));
    let strict = tmlut(&["check", out.to_str().unwrap(), "--budgets", tight.to_str().unwrap(), "--strict"]);
    assert_eq!(strict.status.code(), Some(1), "{}", text(&strict));
    assert!(
        text(&strict).contains("FAIL scattering/furnace.json: furnace budget is scene `scattering` has none"),
        "{}",
        text(&strict)
    );
}

#[test]
fn curves_do_not_depend_on_the_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let one = dir.path().join("one");
    let output = furnace(&one, "1");
    assert!(output.status.success(), "{}", text(&output));
    for scene in ["copper-pot", "scattering"] {
        let (a, b) = (report(ci_run(), scene), report(&one, scene));
        for curve in ["albedo_tables", "albedo_exact", "albedo_walk", "walk_standard_error", "walk_paths"] {
            assert_eq!(a["materials"][0][curve], b["materials"][0][curve], "{scene}: {curve}");
        }
    }
}

#[test]
fn bad_input_is_refused_with_what_is_allowed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x");
    let scene = repo("luts/scenes/copper-pot.toml");
    let cases: [(&[&str], &str); 7] = [
        (&["--views", "1"], "views: 1; allowed: 2 to 4096"),
        (&["--exact-nodes", "1"], "--exact-nodes: 1; allowed: 2 to 64"),
        (&["--walk-masking", "ggx"], "allowed: smith-separable, smith-height-correlated"),
        (&["--luts", "/nonexistent", &repo("luts/scenes/profiling.toml")], "a folder of tables serves one run"),
        (&["--walk", "sample:0"], "allowed: sample:N with N from 1 to 10240"),
        (&["--walk", "some"], "allowed: all, none, sample:N"),
        (&["--pictures", "sample:99999"], "allowed: sample:N with N from 1 to 10240"),
    ];
    for (extra, says) in cases {
        let mut args = vec!["furnace", &scene, "--out", out.to_str().unwrap(), "--quiet"];
        args.extend_from_slice(extra);
        let output = tmlut(&args);
        assert!(!output.status.success(), "{extra:?}");
        assert!(text(&output).contains(says), "{extra:?}: {}", text(&output));
        assert!(!text(&output).contains("panicked"));
    }
    // A folder built for another scene has no table for these lookups: refused, naming one and
    // what the folder lacks for it.
    let output = tmlut(&[
        "furnace",
        &repo("luts/scenes/profiling.toml"),
        "--luts",
        ci_run().join("copper-pot/luts").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(!output.status.success());
    let said = text(&output);
    assert!(said.contains("has no table for") && said.contains("FGD of layer 1"), "{said}");
    assert!(said.contains("the folder lists no FGD slice at (eta, kappa)"), "{said}");
}

#[test]
fn scenes_whose_plan_needs_no_tir_table_are_measured() {
    // A bare conductor, one glass interface, an index-matched coat and a 6-flux material without
    // a medium make no TIR lookup, so their plan builds no TIR table; the furnace refused the folder
    // it had just built for them ("lists no TIR table").
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("no-tir.toml");
    let interface = |eta: &str, kappa: &str| {
        format!("[[material.layer]]\ntype = \"interface\"\neta = {eta}\nkappa = {kappa}\nalpha = 0.2\n")
    };
    let conductor = interface("[0.2, 0.9, 1.1]", "[3.0, 2.5, 2.0]");
    let scene_text = [
        format!("[[material]]\nname = \"bare-conductor\"\n{conductor}"),
        format!("[[material]]\nname = \"glass\"\n{}", interface("1.5", "0.0")),
        format!("[[material]]\nname = \"matched-coat\"\n{}{conductor}", interface("1.0", "0.0")),
        format!("[[material]]\nname = \"six-flux\"\nmodel = \"6-flux\"\n{conductor}"),
    ]
    .concat();
    std::fs::write(&scene, scene_text).unwrap();
    let out = dir.path().join("furnace");
    let output = tmlut(&[
        "furnace",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--views",
        "4",
        "--exact-nodes",
        "6",
        "--walk-min-paths",
        "1024",
        "--walk-max-paths",
        "4096",
        "--picture-size",
        "16",
        "--quiet",
    ]);
    assert!(output.status.success(), "{}", text(&output));
    let manifest = std::fs::read_to_string(out.join("no-tir").join("luts").join("manifest.json")).unwrap();
    assert!(!manifest.contains("\"tir_"), "the plan built a TIR table after all");
    let report = report(&out, "no-tir");
    assert_eq!(report["materials"].as_array().unwrap().len(), 4);
}

#[test]
fn scenes_whose_names_give_one_folder_are_refused_before_either_runs() {
    let dir = tempfile::tempdir().unwrap();
    let copper = std::fs::read_to_string(repo("luts/scenes/copper-pot.toml")).unwrap();
    let twin = dir.path().join("twin.toml");
    std::fs::write(&twin, copper.replace("name = \"copper-pot\"", "name = \"Copper Pot\"")).unwrap();
    let out = dir.path().join("furnace");
    let output = tmlut(&[
        "furnace",
        &repo("luts/scenes/copper-pot.toml"),
        twin.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(output.status.code(), Some(1), "{}", text(&output));
    assert!(text(&output).contains("`Copper Pot`") && text(&output).contains("copper-pot"), "{}", text(&output));
    assert!(!out.exists(), "nothing is written");
}

/// The CI scenes as one library at 4 views, small integrals and walks, with the given `--walk`.
fn library_run(out: &Path, walk: &str) -> Output {
    tmlut(&[
        "furnace",
        &repo("luts/scenes/copper-pot.toml"),
        &repo("luts/scenes/scattering.toml"),
        "--library",
        "--out",
        out.to_str().unwrap(),
        "--views",
        "4",
        "--exact-nodes",
        "6",
        "--walk",
        walk,
        "--walk-min-paths",
        "1024",
        "--walk-max-paths",
        "4096",
        "--pictures",
        "none",
        "--quiet",
    ])
}

#[test]
fn without_the_walk_the_table_error_is_measured_and_the_model_error_is_absent() {
    let dir = tempfile::tempdir().unwrap();
    let none = dir.path().join("none");
    let output = library_run(&none, "none");
    assert!(output.status.success(), "{}", text(&output));
    assert!(text(&output).contains("| copper-pot | varnished-copper |") && text(&output).contains("not walked"));
    let measured = report(&none, "library");
    assert_eq!(measured["walked_materials"].as_array().unwrap().len(), 0);
    assert_eq!(measured["settings"]["walk"], "none");
    let materials = measured["materials"].as_array().unwrap();
    assert_eq!(materials.len(), 2);
    for (m, scene) in materials.iter().zip(["copper-pot", "scattering"]) {
        assert_eq!(m["scene"], scene, "each material of a library records its scene");
        assert_eq!(m["walked"], false);
        assert!(m["errors"]["table"]["max_all"].as_f64().unwrap() > 0.0);
        // Absent, not zero and not NaN.
        for key in ["model", "total", "model_error_beyond_3_standard_errors"] {
            assert!(m["errors"].get(key).is_none(), "{key}: {}", m["errors"]);
        }
        for key in ["albedo_walk", "walk_standard_error", "walk_paths"] {
            assert!(m.get(key).is_none(), "{key}");
        }
        assert_eq!(m["files"].as_array().unwrap().len(), 0, "--pictures none draws nothing");
    }
    let written: Vec<String> = std::fs::read_dir(none.join("library"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(written.iter().all(|n| n == "furnace.json" || n == "luts"), "{written:?}");

    // One material walked, drawn from the seed: the same table and exact curves, and the model
    // error where the walk ran only.
    let sample = dir.path().join("sample");
    let output = library_run(&sample, "sample:1");
    assert!(output.status.success(), "{}", text(&output));
    let sampled = report(&sample, "library");
    assert_eq!(sampled["walked_materials"].as_array().unwrap().len(), 1);
    for (a, b) in sampled["materials"].as_array().unwrap().iter().zip(materials) {
        assert_eq!(a["albedo_tables"], b["albedo_tables"]);
        assert_eq!(a["albedo_exact"], b["albedo_exact"]);
        let walked = a["walked"].as_bool().unwrap();
        assert_eq!(a["errors"].get("model").is_some(), walked);
        assert_eq!(a.get("albedo_walk").is_some(), walked);
    }

    // check: a material whose scene has no budget is held to [furnace_every_material]; the worst
    // are named; a model-error budget on a material not walked is not held, and says why.
    let budgets = dir.path().join("every.toml");
    std::fs::write(&budgets, "[furnace_every_material]\nmax_table_error = 1e-9\n").unwrap();
    let output = tmlut(&["check", none.to_str().unwrap(), "--budgets", budgets.to_str().unwrap()]);
    let said = text(&output);
    assert_eq!(output.status.code(), Some(1), "{said}");
    for material in ["varnished-copper", "scattering-stack"] {
        assert!(said.contains(&format!("FAIL library/furnace.json: {material}: table_error_max")), "{said}");
    }
    assert!(said.contains("table_error_worst 2 of 2 materials: "), "{said}");
    // (1,024 samples per exact integral leave it noisy at the 1e-3 level: a looser limit holds.)
    std::fs::write(&budgets, "[furnace_every_material]\nmax_table_error = 5e-2\n").unwrap();
    let output = tmlut(&["check", none.to_str().unwrap(), "--budgets", budgets.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output));
    std::fs::write(&budgets, "[furnace.copper-pot]\nmax_model_error = 1.0\n").unwrap();
    let output = tmlut(&["check", none.to_str().unwrap(), "--budgets", budgets.to_str().unwrap()]);
    let said = text(&output);
    assert_eq!(output.status.code(), Some(1), "{said}");
    assert!(said.contains("varnished-copper: model_error_max is not measured"), "{said}");
}

#[test]
fn a_library_whose_names_collide_as_files_is_refused_before_it_runs() {
    let dir = tempfile::tempdir().unwrap();
    let copper = std::fs::read_to_string(repo("luts/scenes/copper-pot.toml")).unwrap();
    let twin = dir.path().join("twin.toml");
    std::fs::write(
        &twin,
        copper
            .replace("name = \"copper-pot\"", "name = \"twin\"")
            .replace("\"varnished-copper\"", "\"Varnished Copper\""),
    )
    .unwrap();
    let out = dir.path().join("furnace");
    let output = tmlut(&[
        "furnace",
        &repo("luts/scenes/copper-pot.toml"),
        twin.to_str().unwrap(),
        "--library",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(output.status.code(), Some(1), "{}", text(&output));
    assert!(text(&output).contains("give one file name"), "{}", text(&output));
    assert!(!out.exists(), "nothing is written");
}
