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

#[test]
fn a_good_build_meets_the_ci_budgets() {
    let (pass, text) = check(ci_build(), &repo("luts/ci-budgets.toml"), &[]);
    assert!(pass, "{text}");
    assert!(text.contains(" passed, 0 failed"), "{text}");
    assert!(text.contains("fgd.exr: reference_rms"), "{text}");
    assert!(text.contains("tir.dds: interpolation_max (low roughness)"), "{text}");
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
    let json_end = text.rfind(']').unwrap() + 1;
    let findings: serde_json::Value = serde_json::from_str(&text[..json_end]).unwrap();
    let failed: Vec<(String, String)> = findings
        .as_array()
        .unwrap()
        .iter()
        .filter(|f| f["pass"] == false)
        .map(|f| (f["file"].as_str().unwrap().to_string(), f["check"].as_str().unwrap().to_string()))
        .collect();
    assert_eq!(failed, [("gd.dds".to_string(), "sha256".to_string()), ("gd.dds".to_string(), "nan_count".to_string())]);
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
fn the_default_budgets_are_the_committed_file() {
    // `tmlut check` without --budgets uses the committed budgets.toml, written for the default set:
    // the reduced set misses some of them (fewer samples), and the failures say so.
    let output = tmlut(&["check", ci_build().to_str().unwrap()]);
    let text = String::from_utf8_lossy(&output.stdout);
    assert!(!output.status.success());
    assert!(text.contains("FAIL fgd.exr: replicate_max"), "{text}");
}
