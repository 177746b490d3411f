//! `tmlut fit --form`: forms fitted to a table, over a region, weighted by a scene, certified, and
//! refused mistakes.

use std::path::Path;
use std::process::Command;

use super::{build, scene_path, stderr, tmlut, write_config};

use crate::common::SMALL_SET;

/// `tmlut fit --form`: the repository's EnvBRDFApprox form (UE4's mobile approximation of the
/// split-sum table) fitted to a small Karis table, against the same form at its published
/// coefficients; the set of files, valid WGSL, and the same bits from the same seed.
#[test]
fn fit_form_refits_the_env_brdf_approx_form_to_a_karis_table() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let luts = dir.path().join("luts");
    let output = build(&config, &luts, &["--only", "karis"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let form = Path::new(env!("CARGO_MANIFEST_DIR")).join("luts/forms/karis-env-brdf-approx.toml");
    let table = luts.join("karis.dds");
    let fit = |out: &Path, extra: &[&str]| {
        let mut args = vec!["fit", "--form", form.to_str().unwrap(), "--table", table.to_str().unwrap()];
        args.extend(["--out", out.to_str().unwrap(), "--starts", "3"]);
        args.extend_from_slice(extra);
        let output = tmlut(&args);
        assert!(output.status.success(), "{}", stderr(&output));
        let json: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("fit.json")).unwrap()).unwrap();
        json
    };
    let published = fit(&dir.path().join("published"), &["--max-evaluations", "0"]);
    let fitted = fit(&dir.path().join("fitted"), &["--certify", "--config", config.to_str().unwrap()]);
    let rms = |json: &serde_json::Value| json["figures"]["together"]["rms"].as_f64().unwrap();
    assert_eq!(published["parameters"]["c"].as_f64(), Some(-0.572));
    assert_eq!(published["start_figures"], fitted["start_figures"]);
    // The least-squares optimum of this form on the 32 x 24 table (docs/fit.md has the figures of
    // the default 512 x 512 table).
    assert!(
        rms(&fitted) <= 0.93 * rms(&published),
        "fitted RMS {} against published {}",
        rms(&fitted),
        rms(&published)
    );
    for name in ["a", "b", "c", "d", "e", "f", "g", "h"] {
        assert!(fitted["parameters"][name].as_f64().unwrap().is_finite(), "{name}");
    }
    // The constant term of `ry` (f) and the two channels' offsets (g, h) only enter as two sums,
    // as do b, c and d along roughness: two directions the data cannot fix.
    let id = &fitted["identifiability"];
    assert_eq!(id["ill_determined"].as_array().unwrap().len(), 2, "{id}");
    assert_eq!(id["ill_determined_parameters"], serde_json::json!(["b", "c", "d", "f", "g", "h"]), "{id}");
    // Certified against exact integrals at the random points of the table's interpolation check
    // (both of Karis's domains), beside the table's own error there.
    let certified = fitted["certified"].as_array().unwrap();
    assert_eq!(certified.len(), 2);
    for c in certified {
        let (form, table) =
            (c["form"]["together"]["rms"].as_f64().unwrap(), c["table"]["together"]["rms"].as_f64().unwrap());
        assert!(table > 0.0 && table < form && form < 0.1, "{c}");
    }
    // Over a region, weighted: each domain's points inside the region, and weighted figures beside
    // the plain ones (the whole domain loses the points of roughness above 0.5; the low-roughness
    // one loses none).
    let config_arg = config.to_str().unwrap();
    let region = fit(
        &dir.path().join("region"),
        &["--range", "roughness=0:0.5", "--weights", "cosine", "--certify", "--config", config_arg],
    );
    let in_region = region["certified"].as_array().unwrap();
    let points = |c: &serde_json::Value| c["points"].as_u64().unwrap();
    assert!(points(&in_region[0]) < points(&certified[0]), "{}", in_region[0]);
    assert_eq!(points(&in_region[1]), points(&certified[1]));
    assert!(in_region.iter().all(|c| c["form_weighted"]["together"]["rms"].is_number()), "{region}");
    assert!(fitted.get("weighted_figures").is_none() && region["weighted_figures"].is_object());
    let out = dir.path().join("fitted");
    let mut files: Vec<String> =
        std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    files.sort();
    let stem = "karis_env_brdf_approx";
    assert_eq!(
        files,
        [
            "error_map.png",
            "fit.json",
            &format!("{stem}.glsl"),
            &format!("{stem}.harness.comp"),
            &format!("{stem}.hlsl"),
            &format!("{stem}.metal"),
            &format!("{stem}.wgsl"),
            "report.md",
            "residuals.png"
        ]
    );
    // The two pictures decode as PNG, at the sizes the plots are drawn.
    for picture in ["error_map.png", "residuals.png"] {
        let image = image::open(out.join(picture)).unwrap_or_else(|e| panic!("{picture}: {e}"));
        assert!((400..=4000).contains(&image.width()) && (300..=4000).contains(&image.height()), "{picture}");
    }
    let wgsl = std::fs::read_to_string(out.join(format!("{stem}.wgsl"))).unwrap();
    let module = naga::front::wgsl::parse_str(&wgsl).unwrap_or_else(|e| panic!("{}", e.emit_to_string(&wgsl)));
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .unwrap();
    // No [function] in the form file: the table's sampling, (NoV, roughness) for the Karis table as
    // built (rows spaced in roughness), the form's `roughness` the argument itself.
    assert!(wgsl.contains("fn tmlut_karis_env_brdf_approx(NoV: f32, roughness: f32) -> vec2<f32>"), "{wgsl}");
    assert!(!wgsl.contains("let roughness"), "{wgsl}");
    let arguments = serde_json::json!([{ "name": "NoV", "axis": "mu" }, { "name": "roughness", "axis": "roughness" }]);
    assert_eq!(fitted["shader_arguments"], arguments);
    // The GLSL is the functions alone; the harness beside it holds them and calls the form.
    let glsl = std::fs::read_to_string(out.join(format!("{stem}.glsl"))).unwrap();
    assert!(glsl.contains("vec2 tmlut_karis_env_brdf_approx(float NoV, float roughness) {"), "{glsl}");
    assert!(!glsl.contains("#version") && !glsl.contains("main("), "{glsl}");
    let harness = std::fs::read_to_string(out.join(format!("{stem}.harness.comp"))).unwrap();
    assert!(harness.starts_with("#version 450\n") && harness.contains(&glsl), "{harness}");
    tmlut::ir::shader::validate::glsl(&harness, naga::ShaderStage::Compute).unwrap_or_else(|e| panic!("{e}"));
    // The same seed: the same bytes, on one thread as on all.
    let again = dir.path().join("again");
    let output = Command::new(env!("CARGO_BIN_EXE_tmlut"))
        .args(["fit", "--form", form.to_str().unwrap(), "--table", table.to_str().unwrap()])
        .args(["--out", again.to_str().unwrap(), "--starts", "3", "--certify", "--config", config.to_str().unwrap()])
        .env("RAYON_NUM_THREADS", "1")
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", stderr(&output));
    for file in ["fit.json", &format!("{stem}.wgsl"), &format!("{stem}.glsl"), &format!("{stem}.metal")] {
        let (a, b) =
            (std::fs::read_to_string(out.join(file)).unwrap(), std::fs::read_to_string(again.join(file)).unwrap());
        let (mut a, mut b) = (a.replace(out.to_str().unwrap(), ""), b.replace(again.to_str().unwrap(), ""));
        if file == "fit.json" {
            // The measured times differ from run to run; everything else is the same bytes.
            let untimed = |text: &str| {
                let mut json: serde_json::Value = serde_json::from_str(text).unwrap();
                assert!(json["cost"]["timing"]["form_ns"].is_number(), "{}", json["cost"]);
                json["cost"]["timing"] = serde_json::Value::Null;
                serde_json::to_string_pretty(&json).unwrap()
            };
            (a, b) = (untimed(&a), untimed(&b));
        }
        assert_eq!(a, b, "{file}");
    }
}

/// `tmlut fit --form` on a scene's tables: a form fitted to the scene's FGD slice (2D, one
/// channel per relative index, named as the slice names them), and to its GD table with the
/// scene's weights, a range and a bad range.
#[test]
fn fit_form_fits_a_scene_slice_and_weighs_a_table_by_the_scene() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let luts = dir.path().join("luts");
    let scene = scene_path("copper-pot");
    let output = build(&config, &luts, &["--scene", &scene]);
    assert!(output.status.success(), "{}", stderr(&output));
    let slice = "fgd_varnished-copper_l1_from-above";
    let form = dir.path().join("slice.toml");
    std::fs::write(
        &form,
        format!(
            "table = \"{slice}\"\n[parameters]\nf0 = {{ start = 0.05, min = 0.0, max = 1.0 }}\n\
             p = {{ start = 5.0, min = 0.5, max = 10.0 }}\n[channels]\nfgd0 = \"f0 + (1 - f0) * (1 - mu)^5 * p / 5\"\n"
        ),
    )
    .unwrap();
    let fit = |form: &Path, table: &str, out: &str, extra: &[&str]| {
        let table = luts.join(table);
        let out = dir.path().join(out);
        let mut args = vec!["fit", "--form", form.to_str().unwrap(), "--table", table.to_str().unwrap()];
        args.extend(["--out", out.to_str().unwrap(), "--starts", "2", "--timing-runs", "3"]);
        args.extend_from_slice(extra);
        let output = tmlut(&args);
        let json = std::fs::read(out.join("fit.json"))
            .ok()
            .map(|bytes| serde_json::from_slice::<serde_json::Value>(&bytes).unwrap());
        (output, json)
    };
    let (output, json) = fit(&form, &format!("{slice}.dds"), "slice", &[]);
    assert!(output.status.success(), "{}", stderr(&output));
    let json = json.unwrap();
    let rms = |json: &serde_json::Value, figures: &str| json[figures]["together"]["rms"].as_f64().unwrap();
    assert!(rms(&json, "figures") < 0.5 * rms(&json, "start_figures"), "{json}");
    assert_eq!(json["channels"], serde_json::json!(["fgd0"]));
    assert!(json["cost"]["operations"]["arithmetic"].as_u64().unwrap() > 0, "{}", json["cost"]);
    assert_eq!(json["certified"], serde_json::json!([]), "no certification unless asked");

    // Certified where the scene's lookups of the slice are made: the slice planned again from the
    // scene the folder's manifest records, the form's error beside the slice's own.
    let config_arg = config.to_str().unwrap();
    let (output, certified) =
        fit(&form, &format!("{slice}.dds"), "slice-certified", &["--certify", "--config", config_arg]);
    assert!(output.status.success(), "{}", stderr(&output));
    let certified = certified.unwrap();
    let domains = certified["certified"].as_array().unwrap();
    assert_eq!(domains.len(), 1, "{certified}");
    assert!(domains[0]["domain"].as_str().unwrap().starts_with("uniform over mu ["), "{certified}");
    let together = |set: &str| domains[0][set]["together"]["rms"].as_f64().unwrap();
    // The fitted Schlick-like form is within a few percent; the slice's interpolation far closer.
    assert!(together("form") < 0.1 && together("form") < together("form_at_start"), "{certified}");
    assert!(together("table") < 1e-3 && together("table") < together("form"), "{certified}");

    // One constant `c` for a table whose one channel is named as the table.
    let constant_form = |table: &str| {
        let path = dir.path().join(format!("{table}-constant.toml"));
        let text = format!(
            "table = \"{table}\"\n[parameters]\nc = {{ start = 0.5, min = 0.0, max = 2.0 }}\n[channels]\n{table} = \"c + 0 * mu\"\n"
        );
        std::fs::write(&path, text).unwrap();
        path
    };
    let constant = constant_form("gd");
    let (output, uniform) = fit(&constant, "gd.dds", "gd-uniform", &[]);
    assert!(output.status.success(), "{}", stderr(&output));
    let uniform = uniform.unwrap();
    assert!(uniform.get("weighted_figures").is_none());

    // The pot reads TIR only inside its varnish (eta = 1/1.1), at views above its critical
    // cosine (0.42), where little is lost: a constant weighted by the scene sits far below the
    // table's mean over every eta in [0, 1]. The table is built beside the scene's set, which a
    // build into the same folder would replace.
    let output = build(&config, &dir.path().join("tir-luts"), &["--only", "tir"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let tir_constant = constant_form("tir");
    let (output, tir_uniform) = fit(&tir_constant, "../tir-luts/tir.dds", "tir-uniform", &[]);
    assert!(output.status.success(), "{}", stderr(&output));
    let (output, tir_weighted) = fit(&tir_constant, "../tir-luts/tir.dds", "tir-scene", &["--weights", &scene]);
    assert!(output.status.success(), "{}", stderr(&output));
    let (tir_uniform, tir_weighted) = (tir_uniform.unwrap(), tir_weighted.unwrap());
    let c = |json: &serde_json::Value| json["parameters"]["c"].as_f64().unwrap();
    assert!(
        c(&tir_weighted) < 0.5 * c(&tir_uniform),
        "scene-weighted {} against uniform {}",
        c(&tir_weighted),
        c(&tir_uniform)
    );
    assert!(
        tir_weighted["weights_are"].as_str().unwrap().contains("varnished-copper"),
        "{}",
        tir_weighted["weights_are"]
    );
    assert!(tir_weighted["weighted_figures"]["together"]["rms"].is_number(), "{tir_weighted}");

    // A range is recorded, and shrinks the points.
    let (output, ranged) = fit(&constant, "gd.dds", "gd-range", &["--range", "roughness=0:0.5"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let ranged = ranged.unwrap();
    assert_eq!(ranged["ranges"], serde_json::json!([{ "variable": "roughness", "lo": 0.0, "hi": 0.5 }]));
    assert!(ranged["points"].as_u64() < uniform["points"].as_u64(), "{ranged}");
    let report = std::fs::read_to_string(dir.path().join("gd-range").join("report.md")).unwrap();
    assert!(report.contains("Region: roughness in [0, 0.5]"), "{report}");

    // A variable the table does not have is refused, naming those it has; nothing is written.
    let (output, json) = fit(&constant, "gd.dds", "gd-bad", &["--range", "eta=0:1"]);
    assert!(!output.status.success() && json.is_none());
    assert!(
        stderr(&output).contains("unknown variable `eta`; allowed for table `gd`: mu, alpha, roughness"),
        "{}",
        stderr(&output)
    );
    let (output, _) = fit(&constant, "gd.dds", "gd-bad", &["--weights", "cosines"]);
    assert!(stderr(&output).contains("allowed: uniform, cosine, or a scene file SCENE.toml"), "{}", stderr(&output));

    // A folder of forms: every form fitted over the region with the weights and timed, each
    // form's fit.json and forms.json recording them.
    let forms = dir.path().join("gd-forms");
    std::fs::create_dir(&forms).unwrap();
    std::fs::copy(&constant, forms.join("constant.toml")).unwrap();
    let linear = "table = \"gd\"\n[parameters]\nc = { start = 0.5, min = 0.0, max = 2.0 }\n\
                  d = { start = 0.0, min = -2.0, max = 2.0 }\n[channels]\ngd = \"c + d * mu\"\n";
    std::fs::write(forms.join("linear.toml"), linear).unwrap();
    let (output, _) = fit(&forms, "gd.dds", "gd-folder", &["--range", "roughness=0:0.5", "--weights", "cosine"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let ranking: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("gd-folder/forms.json")).unwrap()).unwrap();
    assert_eq!(ranking["ranges"], ranged["ranges"], "{ranking}");
    assert_eq!((ranking["weights"].as_str(), ranking["timing_runs"].as_u64()), (Some("cosine"), Some(3)), "{ranking}");
    let ranked = ranking["forms"].as_array().unwrap();
    assert_eq!(ranked.len(), 2, "{ranking}");
    for form in ranked {
        let folder = dir.path().join("gd-folder").join(form["folder"].as_str().unwrap());
        let json: serde_json::Value = serde_json::from_slice(&std::fs::read(folder.join("fit.json")).unwrap()).unwrap();
        assert_eq!(
            (&json["ranges"], &json["weights"], &json["points"]),
            (&ranged["ranges"], &ranking["weights"], &ranged["points"])
        );
        assert_eq!(json["weighted_figures"]["together"], form["weighted_figures"], "{json}");
        assert_eq!(json["cost"]["timing"]["runs"].as_u64(), Some(3), "{json}");
    }
}

#[test]
fn fit_form_refuses_a_mistake_naming_file_line_and_column_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let luts = dir.path().join("luts");
    assert!(build(&config, &luts, &["--only", "karis"]).status.success());
    let form = dir.path().join("bad.toml");
    std::fs::write(
        &form,
        "table = \"karis\"\n[parameters]\na = { start = 1.0, min = 0.0, max = 2.0 }\n[channels]\nscale = \"a * rougness\"\n",
    )
    .unwrap();
    let out = dir.path().join("fit");
    let output = tmlut(&[
        "fit",
        "--form",
        form.to_str().unwrap(),
        "--table",
        luts.join("karis.dds").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!output.status.success());
    let message = stderr(&output);
    assert!(
        message.contains("bad.toml:5:14: unknown name `rougness`; allowed here: a, alpha, mu, roughness"),
        "{message}"
    );
    assert!(!out.exists(), "nothing written for a refused form");
    // There is no `tmlut fit tir`: every form is a form file, and the argument parser says so.
    let output = tmlut(&["fit", "tir", "--form", form.to_str().unwrap()]);
    assert!(!output.status.success() && stderr(&output).contains("--form"), "{}", stderr(&output));
}
