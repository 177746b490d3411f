//! Whole workflows of a scene that names a fitted form (`fit`, then `build`, `furnace`, `shader` and
//! `fit --scene`): what each command reads in place of a table.

use std::path::Path;
use std::process::Command;

use super::{
    build, copper_pot_with_tir, fit_form, fit_tir_logistic, scene_path, shader_functions, stderr, stdout, tmlut,
    write_config,
};
use crate::common;

use common::SMALL_SET;
use tmlut::formats::manifest::{MANIFEST_FILE, Manifest};
use tmlut::loader::LutFolder;

#[test]
fn a_scene_naming_a_fitted_form_is_built_furnaced_and_ranked_with_it() {
    use tmlut::fit::forms::FittedForm;
    use tmlut::fit::forms::fitted::FittedFormExt;
    use tmlut::furnace::report::FurnaceReport;
    use tmlut::model::folder::{FgdSource, FolderTables};
    use tmlut::model::{AlbedoPath, Lookup, Material, Quantity, Tables, TirPath};

    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    fit_tir_logistic(dir.path(), &config, "logistic", &["--max-evaluations", "300"]);
    let scene = copper_pot_with_tir(dir.path(), "pot", "fit:logistic");
    let luts = dir.path().join("luts");
    let output = build(&config, &luts, &["--scene", scene.to_str().unwrap()]);
    assert!(output.status.success(), "{}", stderr(&output));
    let out = dir.path().join("furnace");
    let (config_arg, out_arg) = (config.to_str().unwrap(), out.to_str().unwrap());
    let small = ["--views", "8", "--exact-nodes", "4"];
    let mut args = vec!["furnace", scene.to_str().unwrap(), "--config", config_arg, "--out", out_arg];
    args.extend(["--luts", luts.to_str().unwrap(), "--walk", "none", "--pictures", "none"]);
    args.extend(small);
    let output = tmlut(&args);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(stdout(&output).contains("fgd / fit:logistic"), "{}", stdout(&output));

    // The furnace's error in the material is the CPU model's with the form: every TIR lookup
    // answered by the form evaluated here, the others by the built folder.
    let report = FurnaceReport::read(&out.join("copper-pot").join("furnace.json")).unwrap();
    let m = &report.materials[0];
    assert!(m.errors.table.max_all.is_finite() && m.errors.table.max_all > 0.0, "{:?}", m.errors.table);
    let form =
        FittedForm::read(&dir.path().join("logistic"), "logistic", tmlut::fit::forms::fitted::TIR_TABLES).unwrap();
    assert_eq!(m.tir_form.as_ref(), Some(&form));
    let folder = LutFolder::open(&luts).unwrap();
    let others = FolderTables::open(&folder, AlbedoPath::Fgd, TirPath::Off, FgdSource::Packing).unwrap();
    let evaluator = form.evaluator().unwrap();
    let by_hand = |l: &Lookup| {
        if l.quantity == Quantity::Tir { evaluator.tir(l.mu, l.alpha, l.eta) } else { others.value(l) }
    };
    let model = Material::new(m.model, m.stack.clone());
    let curve: Vec<_> = m.mu.iter().map(|&mu| model.albedo(mu, &by_hand)).collect();
    assert_eq!(curve, m.albedo_tables);

    // The build records the form, writes no TIR table, and its scene shader calls the form.
    let manifest = Manifest::read(&luts.join(MANIFEST_FILE)).unwrap();
    let plan = &manifest.scene.as_ref().expect("the scene is recorded").plan;
    assert_eq!(plan.tir_forms, std::slice::from_ref(&form));
    assert!(manifest.files.keys().all(|f| !f.starts_with("tir")), "{:?}", manifest.files.keys());
    let wgsl = std::fs::read_to_string(luts.join("copper_pot.wgsl")).unwrap();
    assert!(wgsl.contains("fn tmlut_tir_logistic(mu: f32, alpha: f32, eta: f32) -> f32"), "{wgsl}");
    assert!(wgsl.contains(" = tmlut_tir_logistic("), "{wgsl}");
    assert!(common::validate_wgsl_files(&luts) >= 1);
    let hlsl = std::fs::read_to_string(luts.join("copper_pot.hlsl")).unwrap();
    assert!(hlsl.contains(" = tmlut_tir_logistic("), "{hlsl}");
    assert_eq!(shader_functions(&wgsl), shader_functions(&hlsl), "the two languages define different functions");
    // The shader run on the CPU reads the form as the CPU evaluator does.
    crate::shader::shader_against_the_cpu(&luts, std::slice::from_ref(&scene), 16).assert_agrees(&["tir form"]);

    // Ranked in the material: the same error for the form, the table's beside it.
    let ranked = dir.path().join("ranked");
    let mut args = vec!["fit", "--scene", scene.to_str().unwrap(), "--form", "logistic"];
    args.extend(["--config", config_arg, "--out", ranked.to_str().unwrap()]);
    args.extend(small);
    let output = Command::new(env!("CARGO_BIN_EXE_tmlut")).current_dir(dir.path()).args(&args).output().unwrap();
    assert!(output.status.success(), "{}", stderr(&output));
    let ranking: tmlut::furnace::forms::FormRanking =
        serde_json::from_slice(&std::fs::read(ranked.join("ranking.json")).unwrap()).unwrap();
    assert_eq!(ranking.forms.len(), 1);
    assert_eq!(ranking.forms[0].max_error, m.errors.table.max_all);
    assert!(ranking.table.max_error.is_finite() && ranking.table.max_error < ranking.forms[0].max_error);
    assert!(stdout(&output).contains("| 1 | `tir_logistic` (fit:logistic) |"), "{}", stdout(&output));
}

#[test]
fn a_scene_naming_an_albedo_form_reads_it_in_place_of_the_karis_table() {
    use tmlut::fit::forms::FittedForm;
    use tmlut::fit::forms::fitted::FittedFormExt;
    use tmlut::furnace::report::FurnaceReport;
    use tmlut::model::folder::{FgdSource, FolderTables};
    use tmlut::model::{AlbedoPath, Lookup, Material, Quantity, Tables, TirPath};

    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let karis = dir.path().join("karis");
    let output = build(&config, &karis, &["--only", "karis"]);
    assert!(output.status.success(), "{}", stderr(&output));
    // UE4's mobile approximation of the split sum, fitted to the Karis table.
    let form = Path::new(env!("CARGO_MANIFEST_DIR")).join("luts/forms/karis-env-brdf-approx.toml");
    let fitted = dir.path().join("env-brdf");
    fit_form(&form, &karis.join("karis.dds"), &fitted, &["--max-evaluations", "300", "--timing-runs", "0"]);
    let pot = |name: &str, albedo: &str| {
        let scene = dir.path().join(format!("{name}.toml"));
        let text = std::fs::read_to_string(scene_path("copper-pot")).unwrap();
        std::fs::write(&scene, text.replace("albedo = \"fgd\"", &format!("albedo = \"{albedo}\""))).unwrap();
        scene
    };
    let (with_form, with_table) = (pot("form-pot", "fit:env-brdf"), pot("table-pot", "karis"));
    let config_arg = config.to_str().unwrap();
    let furnace = |scene: &Path, name: &str| {
        let luts = dir.path().join(format!("{name}-luts"));
        let output = build(&config, &luts, &["--scene", scene.to_str().unwrap()]);
        assert!(output.status.success(), "{}", stderr(&output));
        let out = dir.path().join(format!("{name}-furnace"));
        let mut args = vec!["furnace", scene.to_str().unwrap(), "--config", config_arg, "--out", out.to_str().unwrap()];
        args.extend(["--luts", luts.to_str().unwrap(), "--walk", "none", "--pictures", "none"]);
        args.extend(["--views", "8", "--exact-nodes", "4"]);
        let output = tmlut(&args);
        assert!(output.status.success(), "{}", stderr(&output));
        (luts, FurnaceReport::read(&out.join("copper-pot").join("furnace.json")).unwrap(), stdout(&output))
    };
    let (luts, report, printed) = furnace(&with_form, "form");
    assert!(printed.contains("fit:env-brdf / table"), "{printed}");
    // The shader run on the CPU reads the form as the CPU evaluator does.
    crate::shader::shader_against_the_cpu(&luts, std::slice::from_ref(&with_form), 16).assert_agrees(&["albedo form"]);

    // The furnace reads the form for every albedo lookup (F0 scale + bias, in f32 as the shader
    // computes it) and the folder for the rest.
    let m = &report.materials[0];
    let form = FittedForm::read(&fitted, "env-brdf", tmlut::fit::forms::fitted::ALBEDO_TABLES).unwrap();
    assert_eq!((m.albedo_form.as_ref(), m.albedo_path), (Some(&form), AlbedoPath::Karis));
    let folder = LutFolder::open(&luts).unwrap();
    let others = FolderTables::open(&folder, AlbedoPath::Karis, TirPath::Table, FgdSource::Packing).unwrap();
    let evaluator = form.evaluator().unwrap();
    let by_hand = |l: &Lookup| match l.quantity {
        Quantity::Albedo => {
            let v = evaluator.channels(&[l.mu as f32, l.alpha as f32]);
            let f0 = tmlut::physics::normal_incidence_reflectance(l.eta, l.kappa);
            f0 * f64::from(v[0]) + f64::from(v[1])
        }
        _ => others.value(l),
    };
    let model = Material::new(m.model, m.stack.clone());
    let curve: Vec<_> = m.mu.iter().map(|&mu| model.albedo(mu, &by_hand)).collect();
    assert_eq!(curve, m.albedo_tables);
    // Read in place of the table: another curve. Both carry the split sum's own error (Schlick's
    // F0 weighting against the copper's exact FGD), which dominates either's.
    let (_, table_report, _) = furnace(&with_table, "table");
    let table_material = &table_report.materials[0];
    assert_ne!(m.albedo_tables, table_material.albedo_tables);
    let (form_error, table_error) = (m.errors.table.max_all, table_material.errors.table.max_all);
    assert!(form_error.is_finite() && form_error > 0.0 && table_error > 0.0, "form {form_error}, table {table_error}");

    // The build records the form and writes no albedo table; its scene shader calls the form.
    let manifest = Manifest::read(&luts.join(MANIFEST_FILE)).unwrap();
    let plan = &manifest.scene.as_ref().expect("the scene is recorded").plan;
    assert_eq!(plan.albedo_forms, std::slice::from_ref(&form));
    assert!(plan.tir_forms.is_empty());
    assert!(
        manifest.files.keys().all(|f| !f.starts_with("karis") && !f.starts_with("fgd")),
        "{:?}",
        manifest.files.keys()
    );
    let wgsl = std::fs::read_to_string(luts.join("copper_pot.wgsl")).unwrap();
    assert!(wgsl.contains("fn tmlut_karis_env_brdf_approx(mu: f32, alpha: f32) -> vec2<f32>"), "{wgsl}");
    // F0 scale + bias: the form's two channels weighed as the table's are.
    assert!(wgsl.contains("dot(vec2<f32>(0.0022675737, 1.0), tmlut_karis_env_brdf_approx(v"), "{wgsl}");
    assert!(common::validate_wgsl_files(&luts) >= 1);
    let hlsl = std::fs::read_to_string(luts.join("copper_pot.hlsl")).unwrap();
    assert_eq!(shader_functions(&wgsl), shader_functions(&hlsl), "the two languages define different functions");

    // A form fitted to the 4D FGD table reads every albedo lookup at the interface's own indices.
    let fgd = dir.path().join("fgd");
    let output = build(&config, &fgd, &["--only", "fgd"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let schlick = dir.path().join("fgd-schlick.toml");
    std::fs::write(
        &schlick,
        "table = \"fgd\"\n[parameters]\np = { start = 1.0, min = 0.0, max = 2.0 }\n[let]\n\
         f0 = \"((eta - 1)^2 + kappa^2) / ((eta + 1)^2 + kappa^2)\"\n[channels]\nfgd = \"f0 + (1 - f0) * (1 - mu)^5 * p\"\n",
    )
    .unwrap();
    fit_form(&schlick, &fgd.join("fgd.exr"), &dir.path().join("schlick"), &["--timing-runs", "0"]);
    let schlick_pot = pot("schlick-pot", "fit:schlick");
    let (luts, report, printed) = furnace(&schlick_pot, "schlick");
    assert!(printed.contains("fit:schlick / table"), "{printed}");
    crate::shader::shader_against_the_cpu(&luts, std::slice::from_ref(&schlick_pot), 16)
        .assert_agrees(&["albedo form"]);
    let m = &report.materials[0];
    assert_eq!(m.albedo_path, AlbedoPath::Fgd);
    assert!(m.errors.table.max_all.is_finite() && m.errors.table.max_all > 0.0, "{:?}", m.errors.table);
    let wgsl = std::fs::read_to_string(luts.join("copper_pot.wgsl")).unwrap();
    assert!(wgsl.contains("fn tmlut_fgd_schlick(mu: f32, alpha: f32, eta: f32, kappa: f32) -> f32"), "{wgsl}");
    // Read at the view-dependent cosine of the top interface (a `let` of the recorded model), at
    // that interface's constant roughness and indices.
    let call = wgsl.split("= tmlut_fgd_schlick(v").nth(1).expect("the form is read").lines().next().unwrap();
    assert!(call.ends_with(", 0.01, 1.1, 0.0);"), "{call}");
    assert!(common::validate_wgsl_files(&luts) >= 1);
    let manifest = Manifest::read(&luts.join(MANIFEST_FILE)).unwrap();
    assert!(manifest.files.keys().all(|f| !f.starts_with("fgd")), "{:?}", manifest.files.keys());

    // A TIR form is no albedo form.
    fit_tir_logistic(dir.path(), &config, "logistic", &["--max-evaluations", "10"]);
    let scene = pot("tir-pot", "fit:logistic");
    let output = tmlut(&["plan", scene.to_str().unwrap(), "--config", config_arg]);
    assert!(!output.status.success());
    let message = stderr(&output);
    assert!(message.contains("fitted to table `tir`") && message.contains("`karis` or `fgd`"), "{message}");
}
