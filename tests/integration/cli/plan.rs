//! `tmlut plan`: the scene's plan printed, and scenes and names refused (by `build` alike).

use super::{
    assert_clean_failure, build, copper_pot_with_tir, fit_tir_logistic, scene_path, stderr, stdout, tmlut, write_config,
};

use crate::common::SMALL_SET;
use tmlut::formats::manifest::MANIFEST_FILE;

#[test]
fn plan_prints_the_tables_what_is_left_out_and_the_saving() {
    let output = tmlut(&["plan", &scene_path("profiling")]);
    assert!(output.status.success(), "{}", stderr(&output));
    let text = stdout(&output);
    for expected in [
        "Lookups the transfer-matrix model makes:",
        "coated-conductor, layer 2 from above",
        "fgd_coated-conductor_l1_from-above",
        "tir_coated-conductor_l1_up",
        "Left out:",
        "fgd (4D, 64.0 MiB): every FGD lookup is at fixed (eta, kappa)",
        "against 69.2 MiB (72531968 bytes) for the default set",
    ] {
        assert!(text.contains(expected), "expected `{expected}` in:\n{text}");
    }
}

#[test]
fn names_that_give_one_file_are_refused_by_plan_and_build_alike() {
    // `plan` passed names that `build` then refused ("a format listed twice", "file name too
    // long"), or that gave one shader function (`glass a`, `glass-a`): both now refuse them.
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let material = |name: &str| {
        format!("[[material]]\nname = \"{name}\"\n[[material.layer]]\ntype = \"interface\"\neta = 1.5\nalpha = 0.1\n")
    };
    let long = "x".repeat(300);
    for (text, expected) in [
        (material("glass a") + &material("glass-a"), &["material 2", "`glass-a`", "(`glass a`)"][..]),
        (material("Copper") + &material("copper"), &["material 2", "`copper`", "(`Copper`)"]),
        (material(&long), &["material 1: name", "300 characters", "allowed: 1 to 64"]),
    ] {
        let scene = dir.path().join("twins.toml");
        std::fs::write(&scene, text).unwrap();
        let output = tmlut(&["plan", scene.to_str().unwrap(), "--config", config.to_str().unwrap()]);
        assert_clean_failure(&output, expected);
        let out = dir.path().join("luts");
        let output = build(&config, &out, &["--scene", scene.to_str().unwrap()]);
        assert_clean_failure(&output, expected);
        assert!(!out.join(MANIFEST_FILE).exists());
    }
}

#[test]
fn bad_scenes_are_refused_naming_material_and_layer() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("bad.toml");
    std::fs::write(
        &scene,
        "[[material]]\nname = \"pot\"\n[[material.layer]]\ntype = \"interface\"\neta = 1.5\nalpha = 0.1\n\
         [[material.layer]]\ntype = \"medium\"\nsigma_k = 0.2\n",
    )
    .unwrap();
    let output = tmlut(&["plan", scene.to_str().unwrap()]);
    assert_clean_failure(&output, &["material 1 (`pot`), layer 2", "without `depth`"]);
    let out = dir.path().join("out");
    let output = tmlut(&["build", "-q", "--scene", scene.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_clean_failure(&output, &["material 1 (`pot`), layer 2"]);
    assert!(!out.join(MANIFEST_FILE).exists(), "nothing written for a bad scene");
    let output = tmlut(&["plan", dir.path().join("missing.toml").to_str().unwrap()]);
    assert_clean_failure(&output, &["missing.toml"]);
    let output = tmlut(&["build", "--scene", &scene_path("copper-pot"), "--only", "fgd"]);
    assert!(!output.status.success() && stderr(&output).contains("--only"), "{}", stderr(&output));
}

#[test]
fn a_scene_naming_a_form_that_cannot_serve_is_refused_with_what_is_allowed() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    fit_tir_logistic(dir.path(), &config, "unfitted", &["--max-evaluations", "0"]);
    let plan = |tir: &str| {
        let scene = copper_pot_with_tir(dir.path(), "pot", tir);
        let output = tmlut(&["plan", scene.to_str().unwrap(), "--config", config.to_str().unwrap()]);
        assert!(!output.status.success(), "{tir}: accepted");
        let message = stderr(&output);
        assert!(!message.contains("panicked"), "{message}");
        assert!(message.contains("pot.toml: tir: "), "{tir}: {message}");
        message
    };
    let missing = plan("fit:nowhere");
    assert!(missing.contains("tir: fit:nowhere (") && missing.contains("no such file"), "{missing}");
    assert!(missing.contains("allowed: \"fit:PATH\""), "{missing}");
    let unfitted = plan("fit:unfitted");
    assert!(unfitted.contains("unfitted") && unfitted.contains("--max-evaluations"), "{unfitted}");
    // A form fitted to another table: its fit.json as written, with the table renamed.
    let other = dir.path().join("other");
    std::fs::create_dir_all(&other).unwrap();
    let json = std::fs::read_to_string(dir.path().join("unfitted").join("fit.json")).unwrap();
    std::fs::write(other.join("fit.json"), json.replace("\"table\": \"tir\"", "\"table\": \"karis\"")).unwrap();
    let wrong = plan("fit:other/fit.json");
    assert!(wrong.contains("fitted to table `karis`") && wrong.contains("table `tir`"), "{wrong}");
    let bare = plan("fit:");
    assert!(bare.contains("names no form"), "{bare}");
    let path_only = plan("form");
    assert!(path_only.contains("names no form") && path_only.contains("\"fit:PATH\""), "{path_only}");
}
