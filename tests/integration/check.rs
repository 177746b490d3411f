//! `tmlut check` against the reduced CI set: it passes on a good build, and fails, naming the
//! budget, the figure and the limit, on a tightened budget, an injected NaN and a missing file.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

fn tmlut(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tmlut")).args(args).output().expect("the tmlut binary runs")
}

fn repo(path: &str) -> String {
    format!("{}/{path}", env!("CARGO_MANIFEST_DIR"))
}

/// The reduced CI set, built once for all tests of this file.
fn ci_build() -> &'static Path {
    static BUILT: OnceLock<(tempfile::TempDir, PathBuf)> = OnceLock::new();
    let (_, out) = BUILT.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("luts");
        let output = tmlut(&["build", "--quiet", "--config", &repo("luts/ci.toml"), "--out", out.to_str().unwrap()]);
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        (dir, out)
    });
    out
}

/// A copy of the CI build that a test may damage.
fn copy_of_ci_build() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("luts");
    std::fs::create_dir(&out).unwrap();
    for entry in std::fs::read_dir(ci_build()).unwrap().flatten() {
        std::fs::copy(entry.path(), out.join(entry.file_name())).unwrap();
    }
    (dir, out)
}

fn check(dir: &Path, budgets: &str, extra: &[&str]) -> (bool, String) {
    let mut args = vec!["check", dir.to_str().unwrap(), "--budgets", budgets];
    args.extend_from_slice(extra);
    let output = tmlut(&args);
    let text = format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr));
    assert!(!text.contains("panicked"), "{text}");
    (output.status.success(), text)
}

/// The JSON report `check --json` prints on standard output (the text also holds standard error,
/// after it).
fn json_report(text: &str) -> serde_json::Value {
    let end = text.rfind("\n}").expect("a JSON object") + 2;
    serde_json::from_str(&text[..end]).unwrap()
}

#[test]
fn a_good_build_meets_the_ci_budgets() {
    let (pass, text) = check(ci_build(), &repo("luts/ci-budgets.toml"), &[]);
    assert!(pass, "{text}");
    assert!(text.contains(" passed, 0 failed"), "{text}");
    assert!(text.contains("fgd.exr: reference_rms"), "{text}");
    assert!(text.contains("tir.dds: interpolation_max (low roughness)"), "{text}");
}

#[test]
fn the_ci_budgets_hold_for_other_seeds() {
    // Seed 2 failed the budgets set from one run of seed 7; 100003 lies outside the seeds 1..64 the
    // budgets were derived from (scripts/ci-budgets).
    let mut maxima: Vec<Vec<(String, f64, f64)>> = Vec::new();
    for seed in ["2", "100003"] {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("luts");
        let output = tmlut(&[
            "build",
            "--quiet",
            "--config",
            &repo("luts/ci.toml"),
            "--seed",
            seed,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        let (pass, text) = check(&out, &repo("luts/ci-budgets.toml"), &[]);
        assert!(pass, "seed {seed}:\n{text}");
        maxima.push(interpolation_maxima(&out));
    }
    // Where the maximum is found at the points placed where the error peaks (above every random
    // point at both seeds), it is the same for every seed but for the noise of the exact integrals.
    // On this coarse set random points still beat them in TIR's whole domain (rough lobes).
    let mut compared = 0;
    for ((name, a, a_random), (_, b, b_random)) in maxima[0].iter().zip(&maxima[1]) {
        if a > a_random && b > b_random {
            assert!((a - b).abs() <= 0.05 * a.max(*b) + 1e-3, "{name}: {a} and {b} at two seeds");
            compared += 1;
        }
    }
    assert!(
        compared * 10 >= maxima[0].len() * 9,
        "{compared} of {} maxima found where the error peaks",
        maxima[0].len()
    );
}

/// `(file: domain, max, max over the random points)` of every interpolation figure of a build's
/// manifest that has points placed where the error peaks (a table over `mu` and `alpha`; not
/// `ggx_e_avg`, over `alpha` alone), in manifest order.
fn interpolation_maxima(out: &Path) -> Vec<(String, f64, f64)> {
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    let mut maxima = Vec::new();
    for (file, entry) in manifest["files"].as_object().unwrap() {
        let figures = entry["error"]["interpolation"].as_array().into_iter().flatten();
        for figure in figures.filter(|f| f["points"].as_str().unwrap().contains("where the error peaks")) {
            let max = figure["max"].as_f64().unwrap();
            maxima.push((format!("{file}: {}", figure["domain"]), max, figure["random_max"].as_f64().unwrap()));
        }
    }
    maxima
}

#[test]
fn a_tightened_budget_fails_naming_figure_and_limit() {
    let dir = tempfile::tempdir().unwrap();
    let budgets = dir.path().join("tight.toml");
    std::fs::write(&budgets, "[fgd]\nmax_reference_rms = 1e-9\n[karis]\nmax_replicate_max = 1e-9\n").unwrap();
    let (pass, text) = check(ci_build(), budgets.to_str().unwrap(), &[]);
    assert!(!pass, "{text}");
    assert!(text.contains("FAIL fgd.exr: reference_rms is ") && text.contains("budget <= 1.000e-9"), "{text}");
    // The packed FGD texture carries FGD's error, so FGD's budget holds it too.
    assert!(text.contains("FAIL fgd_lossless.dds: reference_rms"), "{text}");
    assert!(text.contains("FAIL karis.dds: replicate_max") && text.contains("FAIL karis.exr: replicate_max"), "{text}");
    assert!(text.contains("4 failed"), "{text}");
    assert!(text.contains("error: ") && text.contains("4 budget(s) exceeded"), "{text}");
}

#[test]
fn an_injected_nan_and_a_changed_file_fail() {
    let (_dir, out) = copy_of_ci_build();
    // gd.dds: a 148-byte header (magic, DDS_HEADER, DX10 header), then the R32_FLOAT texels;
    // poison the fifth value.
    let path = out.join("gd.dds");
    let mut bytes = std::fs::read(&path).unwrap();
    let offset = 148 + 4 * 4;
    bytes[offset..offset + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    std::fs::write(&path, bytes).unwrap();
    let (pass, text) = check(&out, &repo("luts/ci-budgets.toml"), &["--json"]);
    assert!(!pass, "{text}");
    let report = json_report(&text);
    let failed: Vec<(String, String)> = report["findings"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|f| f["pass"] == false)
        .map(|f| (f["file"].as_str().unwrap().to_string(), f["check"].as_str().unwrap().to_string()))
        .collect();
    // The changed bytes, the manifest's NaN count and range that no longer describe the file, and
    // the NaN budget.
    let expected = [("gd.dds", "sha256"), ("gd.dds", "manifest"), ("gd.dds", "nan_count")];
    assert_eq!(failed, expected.map(|(f, c)| (f.to_string(), c.to_string())));
}

/// The CI build's manifest, edited by `edit`, written back into a copy of the build.
fn copy_with_manifest(edit: impl FnOnce(&mut serde_json::Value)) -> (tempfile::TempDir, PathBuf) {
    let (dir, out) = copy_of_ci_build();
    let path = out.join("manifest.json");
    let mut manifest: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    edit(&mut manifest);
    std::fs::write(&path, serde_json::to_vec_pretty(&manifest).unwrap()).unwrap();
    (dir, out)
}

/// The failed findings of `check` on `dir`, as (file, check, value).
fn failures(dir: &Path) -> Vec<(String, String, String)> {
    let (pass, text) = check(dir, &repo("luts/ci-budgets.toml"), &["--json"]);
    assert!(!pass, "{text}");
    json_report(&text)["findings"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|f| f["pass"] == false)
        .map(|f| {
            let field = |k: &str| f[k].as_str().unwrap().to_string();
            (field("file"), field("check"), field("value"))
        })
        .collect()
}

#[test]
fn tampered_emptied_and_deleted_shaders_fail() {
    for (shader, damage) in
        [("fgd_lossless.hlsl", "tamper"), ("fgd_lossless.wgsl", "empty"), ("tir_fit.hlsl", "delete")]
    {
        let (_dir, out) = copy_of_ci_build();
        let path = out.join(shader);
        match damage {
            "tamper" => {
                let mut text = std::fs::read_to_string(&path).unwrap();
                text = text.replacen("0.5", "0.25", 1);
                std::fs::write(&path, text).unwrap();
            }
            "empty" => std::fs::write(&path, b"").unwrap(),
            _ => std::fs::remove_file(&path).unwrap(),
        }
        let failed = failures(&out);
        assert_eq!(failed.len(), 1, "{damage} {shader}: {failed:?}");
        assert_eq!((failed[0].0.as_str(), failed[0].1.as_str()), (shader, "shader sha256"), "{failed:?}");
    }
}

#[test]
fn a_shader_misstated_by_one_of_two_entries_that_list_it_fails() {
    // A packing written as DDS and KTX2 lists its shaders in both entries; here a second entry
    // (a copy of the DDS file) states a wrong SHA-256 for one of them, the first the right one.
    let (_dir, out) = copy_with_manifest(|m| {
        let mut twin = m["files"]["fgd_lossless.dds"].clone();
        twin["packing"]["shaders"][0]["sha256"] = "0".repeat(64).into();
        m["files"]["twin.dds"] = twin;
    });
    std::fs::copy(out.join("fgd_lossless.dds"), out.join("twin.dds")).unwrap();
    let failed = failures(&out);
    // The shader's hash, and the twin's entry, which no longer holds what the build sealed.
    let failed: Vec<(&str, &str)> = failed.iter().map(|(f, c, _)| (f.as_str(), c.as_str())).collect();
    assert_eq!(failed, [("twin.dds", "claims"), ("fgd_lossless.hlsl", "shader sha256")], "{failed:?}");
}

#[test]
fn claims_a_file_cannot_state_are_held_to_the_seal_of_the_build() {
    // Each was passed by `check` before entries were sealed: a DDS file stores no axes, and a fit's
    // parameters and a packing's lookup live in the manifest alone.
    type Edit = fn(&mut serde_json::Value);
    let edits: [(&str, &str, Edit); 4] = [
        ("gd.dds", "an axis start", |e| e["axes"][0]["start"] = 0.5.into()),
        ("tir.dds", "a fitted parameter", |e| e["fit"]["parameters"][0] = 0.25.into()),
        ("fgd_lossless.dds", "a lookup statement", |e| e["packing"]["lookup"][0] = "c_mu = mu".into()),
        ("karis.dds", "a texture coordinate", |e| e["axes"][1]["texture_coordinate"] = "v".into()),
    ];
    for (file, what, edit) in edits {
        let (_dir, out) = copy_with_manifest(|m| edit(&mut m["files"][file]));
        let failed = failures(&out);
        assert!(failed.iter().any(|(f, check, _)| f == file && check == "claims"), "{what} of {file}: {failed:?}");
        assert!(failed.iter().all(|(f, ..)| f == file), "{what}: {failed:?}");
    }
    // The same manifest rewritten with other whitespace and key order keeps every seal.
    let (_dir, out) = copy_with_manifest(|m| {
        let files = m["files"].as_object_mut().unwrap();
        let reordered: serde_json::Map<String, serde_json::Value> = std::mem::take(files).into_iter().rev().collect();
        *files = reordered;
    });
    let (pass, text) = check(&out, &repo("luts/ci-budgets.toml"), &[]);
    assert!(pass, "{text}");
    assert!(text.contains("claims"), "{text}");
}

#[test]
fn a_manifest_that_misstates_a_file_fails() {
    // Each lie in the manifest's description of a file, with the SHA-256 left right.
    type Lie = fn(&mut serde_json::Value);
    let lies: [(&str, &str, Lie); 6] = [
        ("karis.dds", "NaN count", |e| e["nan_count"] = 3.into()),
        ("karis.dds", "value range", |e| e["value_range"][1] = 0.5.into()),
        ("karis.dds", "axis count", |e| e["axes"][0]["count"] = (1u64 << 40).into()),
        ("fgd.exr", "orientation", |e| {
            let axis = &mut e["axes"][1];
            let (start, end) = (axis["start"].clone(), axis["end"].clone());
            axis["start"] = end;
            axis["end"] = start;
        }),
        ("karis.exr", "channel count", |e| {
            e["channels"].as_array_mut().unwrap().pop();
        }),
        // An R32_FLOAT texture holds one channel.
        ("gd.dds", "channel count", |e| {
            let extra = serde_json::json!({"name": "extra", "meaning": "a lie"});
            e["channels"].as_array_mut().unwrap().push(extra);
        }),
    ];
    for (file, lie, edit) in lies {
        let (_dir, out) = copy_with_manifest(|m| edit(&mut m["files"][file]));
        let failed = failures(&out);
        // A DDS file's node counts are checked as it is decoded with the manifest's axes.
        assert!(
            failed.iter().any(|(f, check, _)| f == file && (check == "manifest" || check == "readable")),
            "{lie} of {file} not caught: {failed:?}"
        );
        assert!(failed.iter().all(|(f, ..)| f == file), "{lie}: {failed:?}");
    }
}

#[test]
fn manifest_paths_outside_the_folder_are_refused_not_followed() {
    let outside = std::env::temp_dir().join("tmlut-check-outside.bin");
    std::fs::write(&outside, b"not a table").unwrap();
    for name in ["/etc/hostname", "../../x", "../tmlut-check-outside.bin", outside.to_str().unwrap()] {
        let (_dir, out) = copy_with_manifest(|m| {
            let entry = m["files"]["gd.dds"].clone();
            m["files"].as_object_mut().unwrap().insert(name.to_string(), entry);
        });
        let failed = failures(&out);
        assert_eq!(failed.len(), 1, "{name}: {failed:?}");
        let (file, check, value) = &failed[0];
        assert_eq!((file.as_str(), check.as_str()), (name, "path"), "{failed:?}");
        assert!(value.contains("not a file name inside the folder"), "{value}");
    }
    let (_dir, out) = copy_with_manifest(|m| {
        m["files"]["fgd_lossless.dds"]["packing"]["shaders"][0]["file"] = "../../etc/passwd".into();
    });
    let failed = failures(&out);
    assert!(failed.iter().any(|(f, c, _)| f == "../../etc/passwd" && c == "shader sha256"), "{failed:?}");
}

#[test]
fn inspect_refuses_a_manifest_axis_that_the_texture_does_not_have() {
    let (_dir, out) = copy_with_manifest(|m| m["files"]["karis.dds"]["axes"][0]["count"] = (1u64 << 40).into());
    let output = tmlut(&["inspect", out.join("karis.dds").to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stdout}{stderr}");
    assert!(stdout.contains("DIFFERS:") && stdout.contains("1099511627776"), "{stdout}");
    assert!(stderr.starts_with("error: ") && stderr.contains("karis.dds") && !stderr.contains("panicked"), "{stderr}");
}

#[test]
fn a_missing_file_or_table_fails() {
    let (_dir, out) = copy_of_ci_build();
    std::fs::remove_file(out.join("tir.dds")).unwrap();
    let (pass, text) = check(&out, &repo("luts/ci-budgets.toml"), &[]);
    assert!(!pass && text.contains("FAIL tir.dds: file is unreadable"), "{text}");

    let dir = tempfile::tempdir().unwrap();
    let budgets = dir.path().join("extra.toml");
    std::fs::write(&budgets, "[fgd]\n[scene_specific]\nmax_nan = 0\n").unwrap();
    let (pass, text) = check(ci_build(), budgets.to_str().unwrap(), &[]);
    assert!(!pass && text.contains("scene_specific present"), "{text}");
}

#[test]
fn a_table_outside_the_default_set_is_held_to_its_budget_where_a_build_made_it() {
    // The CI set builds the engines' tables (build = "always"); a build that names no tables with
    // the defaults does not, and its folder passes the budgets that hold them where they are built.
    let engine_tables = ["ggx_e", "ggx_e_avg", "karis_multiscatter"];
    let (_dir, out) = copy_with_manifest(|manifest| {
        let files = manifest["files"].as_object_mut().unwrap();
        files.retain(|_, entry| !engine_tables.contains(&entry["table"].as_str().unwrap()));
    });
    for file in ["ggx_e.dds", "ggx_e_avg.exr", "karis_multiscatter.dds"] {
        std::fs::remove_file(out.join(file)).unwrap();
    }
    let (pass, text) = check(&out, &repo("luts/ci-budgets.toml"), &[]);
    assert!(pass && !text.contains("ggx_e") && !text.contains("multiscatter"), "{text}");
    // A table of the default set is still required.
    let (_dir, without_gd) = copy_with_manifest(|manifest| {
        manifest["files"].as_object_mut().unwrap().retain(|_, entry| entry["table"] != "gd");
    });
    std::fs::remove_file(without_gd.join("gd.dds")).unwrap();
    let (pass, text) = check(&without_gd, &repo("luts/ci-budgets.toml"), &[]);
    assert!(!pass && text.contains("gd present"), "{text}");
}

#[test]
fn the_default_budgets_are_the_committed_file() {
    // `tmlut check` without --budgets uses the committed budgets.toml, written for the default set:
    // the reduced set misses some of them (fewer samples), and the failures say so.
    let output = tmlut(&["check", ci_build().to_str().unwrap()]);
    let text = String::from_utf8_lossy(&output.stdout);
    assert!(!output.status.success());
    assert!(text.contains("FAIL fgd.exr: replicate_max"), "{text}");
}

#[test]
fn exit_status_tells_a_budget_exceeded_from_a_check_that_could_not_run() {
    // CI needs 0 every budget held, 1 a budget exceeded, 2 the tool could not run: a broken job is
    // not a worse table.
    let status = |args: &[&str]| {
        let output = tmlut(args);
        let text = format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr));
        assert!(!text.contains("panicked"), "{text}");
        (output.status.code(), text)
    };
    let ci = ci_build().to_str().unwrap();
    let ci_budgets = repo("luts/ci-budgets.toml");
    assert_eq!(status(&["check", ci, "--budgets", &ci_budgets]).0, Some(0));

    let dir = tempfile::tempdir().unwrap();
    let tight = dir.path().join("tight.toml");
    std::fs::write(&tight, "[fgd]\nmax_reference_rms = 1e-9\n").unwrap();
    let (code, text) = status(&["check", ci, "--budgets", tight.to_str().unwrap()]);
    assert_eq!(code, Some(1), "{text}");

    let missing = dir.path().join("no-such-folder");
    let (code, text) = status(&["check", missing.to_str().unwrap(), "--budgets", &ci_budgets]);
    assert_eq!(code, Some(2), "{text}");
    assert!(text.contains("no-such-folder"), "{text}");

    let typo = dir.path().join("typo.toml");
    std::fs::write(&typo, "[fgd]\nmax_referenc_rms = 1e-3\n").unwrap();
    let (code, text) = status(&["check", ci, "--budgets", typo.to_str().unwrap()]);
    assert_eq!(code, Some(2), "{text}");
    assert!(text.contains("max_referenc_rms"), "{text}");

    let (_copy, out) = copy_of_ci_build();
    std::fs::write(out.join("manifest.json"), "{ not a manifest").unwrap();
    let (code, text) = status(&["check", out.to_str().unwrap(), "--budgets", &ci_budgets]);
    assert_eq!(code, Some(2), "{text}");
    assert!(text.contains("manifest.json"), "{text}");
}

#[test]
fn ci_formats_state_numbers_as_numbers_and_report_even_a_folder_that_cannot_be_checked() {
    let ci_budgets = repo("luts/ci-budgets.toml");
    // A held build: status, summary and numeric figures.
    let output = tmlut(&["check", ci_build().to_str().unwrap(), "--budgets", &ci_budgets, "--format", "json"]);
    assert_eq!(output.status.code(), Some(0));
    let report: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(report["status"], "passed");
    let summary = &report["summary"];
    assert_eq!(summary["failed"], 0);
    assert_eq!(summary["checks"], summary["passed"]);
    assert_eq!(summary["checks"].as_u64().unwrap() as usize, report["findings"].as_array().unwrap().len());
    let reference = report["findings"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["file"] == "fgd.exr" && f["check"] == "reference_rms")
        .expect("the FGD reference budget");
    assert!(reference["measured"].as_f64().unwrap() <= reference["at_most"].as_f64().unwrap(), "{reference}");

    // A budget exceeded: exit 1, one JUnit failure and one GitHub error annotation per failed finding.
    let (_copy, out) = copy_of_ci_build();
    std::fs::remove_file(out.join("gd.dds")).unwrap();
    let junit = out.parent().unwrap().join("check.xml");
    let output = tmlut(&[
        "check",
        out.to_str().unwrap(),
        "--budgets",
        &ci_budgets,
        "--format",
        "github",
        "--junit",
        junit.to_str().unwrap(),
    ]);
    assert_eq!(output.status.code(), Some(1));
    let annotations = String::from_utf8_lossy(&output.stdout);
    let errors = annotations.lines().filter(|l| l.starts_with("::error title=tmlut check%3A gd.dds file::")).count();
    assert_eq!(errors, 1, "{annotations}");
    assert!(annotations.lines().last().unwrap().starts_with("::notice "), "{annotations}");
    let xml = std::fs::read_to_string(&junit).unwrap();
    let failed = annotations.lines().filter(|l| l.starts_with("::error ")).count();
    assert_eq!(xml.matches("<failure ").count(), failed, "{xml}");
    assert!(xml.contains(&format!("failures=\"{failed}\"")), "{xml}");
    assert!(xml.contains("classname=\"gd.dds\" name=\"file\""), "{xml}");

    // A folder that cannot be checked: exit 2, and still a JSON report and a JUnit error case.
    let missing = out.parent().unwrap().join("no such folder");
    let junit = out.parent().unwrap().join("error.xml");
    let output = tmlut(&["check", missing.to_str().unwrap(), "--json", "--junit", junit.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(2));
    let report: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(report["status"], "error");
    assert!(report["error"].as_str().unwrap().contains("no such folder"), "{report}");
    let xml = std::fs::read_to_string(&junit).unwrap();
    assert!(xml.contains("errors=\"1\"") && xml.contains("<error message="), "{xml}");
}

#[test]
fn fits_and_every_slice_of_a_kind_are_budgeted_and_strict_mode_fails_what_no_budget_holds() {
    let dir = tempfile::tempdir().unwrap();
    let budgets = dir.path().join("budgets.toml");
    // The CI build's TIR table states its fitted form: its figures are held, and a fit budget on
    // a table with no fit fails.
    std::fs::write(&budgets, "[tir]\nmax_fit_rmse = 1e-9\nmax_fit_max = 1.0\n[gd]\nmax_fit_max = 1.0\n").unwrap();
    let (pass, text) = check(ci_build(), budgets.to_str().unwrap(), &[]);
    assert!(!pass, "{text}");
    assert!(text.contains("FAIL tir.dds: fit_rmse is ") && text.contains("ok   tir.dds: fit_max"), "{text}");
    assert!(text.contains("FAIL -: gd fit present"), "{text}");

    // A scene's slices are named per material; [fgd_slice] holds every FGD slice.
    let out = dir.path().join("scene");
    let scene = repo("luts/scenes/copper-pot.toml");
    let output =
        tmlut(&["build", "--quiet", "--scene", &scene, "--slice-checks", "none", "--out", out.to_str().unwrap()]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    std::fs::write(&budgets, "[fgd_slice]\nmax_replicate_max = 1e-15\n").unwrap();
    let (pass, text) = check(&out, budgets.to_str().unwrap(), &[]);
    assert!(!pass, "{text}");
    let failed: Vec<&str> = text.lines().filter(|l| l.starts_with("FAIL ")).collect();
    assert!(
        !failed.is_empty() && failed.iter().all(|l| l.starts_with("FAIL fgd_") && l.contains(": replicate_max is ")),
        "{text}"
    );
    assert!(!text.contains("fgd_slice present"), "{text}");

    // --strict: every file that no section holds fails; without it they are checked unbudgeted.
    std::fs::write(&budgets, "[fgd_slice]\n[tir_slice]\n").unwrap();
    let (pass, text) = check(&out, budgets.to_str().unwrap(), &[]);
    assert!(pass, "{text}");
    let (pass, text) = check(&out, budgets.to_str().unwrap(), &["--strict"]);
    assert!(!pass, "{text}");
    assert!(text.contains("FAIL gd.dds: budget is no [gd] section"), "{text}");
    assert!(!text.lines().any(|l| l.starts_with("FAIL fgd_") || l.starts_with("FAIL tir_")), "{text}");
}

#[test]
fn a_preset_folder_is_held_to_the_presets_budgets() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("threejs");
    let output = tmlut(&["build", "--quiet", "--preset", "threejs", "--out", out.to_str().unwrap()]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let folder = out.to_str().unwrap();

    // The manifest names the preset, and check finds its budgets by that name.
    let passed = tmlut(&["check", folder, "--json"]);
    let report = json_report(&String::from_utf8_lossy(&passed.stdout));
    assert_eq!(passed.status.code(), Some(0), "{report}");
    let budgeted = report["findings"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|f| f["check"].as_str().is_some_and(|c| c.starts_with("interpolation_rms")));
    assert_eq!(budgeted.count(), 4, "both karis files, both domains: {report}");

    // The default set's budgets are a 512 x 512 table's: the 16 x 16 one fails them by name.
    let (held, text) = check(&out, &repo("budgets.toml"), &[]);
    assert!(!held && text.contains("FAIL karis.dds: interpolation_rms (whole domain)"), "{text}");

    // An edited preset is recorded by its file's stem, which check cannot look up: it says so
    // (exit 2), and holds the folder to the file's budgets when given it.
    let edited = dir.path().join("my-threejs.toml");
    let text = std::fs::read_to_string(repo("luts/presets/threejs.toml")).unwrap();
    std::fs::write(&edited, text.replace("max_reference_rms = 1e-5", "max_reference_rms = 1e-7")).unwrap();
    let mine = dir.path().join("mine");
    let output = tmlut(&["build", "-q", "--preset", edited.to_str().unwrap(), "--out", mine.to_str().unwrap()]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let unknown = tmlut(&["check", mine.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&unknown.stderr);
    assert_eq!(unknown.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("edited preset `my-threejs`") && stderr.contains("--preset FILE.toml"), "{stderr}");
    let tightened = tmlut(&["check", mine.to_str().unwrap(), "--preset", edited.to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&tightened.stdout);
    assert_eq!(tightened.status.code(), Some(1), "{stdout}");
    assert!(stdout.contains("FAIL karis.dds: reference_rms") && stdout.contains("budget <= 1.000e-7"), "{stdout}");

    // A misspelt budget is refused before the build, by its key.
    std::fs::write(&edited, text.replace("max_reference_rms = 1e-5", "max_refrence_rms = 1e-5")).unwrap();
    let misspelt = dir.path().join("misspelt");
    let output = tmlut(&["build", "-q", "--preset", edited.to_str().unwrap(), "--out", misspelt.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success() && stderr.contains("max_refrence_rms"), "{stderr}");
    assert!(!misspelt.exists());

    // A manifest naming a path as its built-in preset is refused by name, the path never read.
    let manifest_path = out.join("manifest.json");
    let manifest = std::fs::read_to_string(&manifest_path).unwrap();
    let outside = edited.to_str().unwrap().replace('\\', "/");
    std::fs::write(&manifest_path, manifest.replace("\"name\": \"threejs\"", &format!("\"name\": \"{outside}\"")))
        .unwrap();
    let refused = tmlut(&["check", folder]);
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert_eq!(refused.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("unknown preset"), "{stderr}");
    std::fs::write(&manifest_path, manifest).unwrap();

    // A build of another configuration into the folder makes it no preset's any more.
    let output = tmlut(&["build", "-q", "--config", &repo("luts/ci.toml"), "--only", "karis", "--out", folder]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let manifest = std::fs::read_to_string(out.join("manifest.json")).unwrap();
    assert!(!manifest.contains("\"preset\""), "{manifest}");
}
