//! End-to-end tests of the `tmlut` command: what a user runs, what lands on disk, and how bad
//! input is refused. One file per command, named as the command's own file in `src/cli/`, and
//! `workflows.rs` for tests that run several commands with none dominating; here the helpers the
//! files share (those the whole binary shares are in `common.rs`).

mod audit;
mod bake;
mod bench;
mod build;
mod converge;
mod fit;
mod inspect;
mod list;
mod merge;
mod plan;
mod shader;
mod workflows;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use crate::common::SMALL_SET;

pub(super) fn tmlut(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tmlut")).args(args).output().expect("the tmlut binary runs")
}

pub(super) fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

pub(super) fn stdout(output: &Output) -> String {
    String::from_utf8_lossy(&output.stdout).into_owned()
}

pub(super) fn write_config(dir: &Path, text: &str) -> PathBuf {
    let path = dir.join("config.toml");
    std::fs::write(&path, text).unwrap();
    path
}

pub(super) fn build(config: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["build", "--quiet", "--config", config.to_str().unwrap(), "--out", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    tmlut(&args)
}

/// Every file of a folder with its bytes, sorted by name.
pub(super) fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| (e.file_name().to_string_lossy().into_owned(), std::fs::read(e.path()).unwrap_or_default()))
        .collect();
    files.sort();
    files
}

pub(super) fn assert_clean_failure(output: &Output, expected: &[&str]) {
    let err = stderr(output);
    assert_eq!(output.status.code(), Some(1), "exit status {:?}; stderr: {err}", output.status);
    assert!(err.starts_with("error: "), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    for e in expected {
        assert!(err.contains(e), "expected `{e}` in: {err}");
    }
}

pub(super) fn scene_path(name: &str) -> String {
    format!("{}/luts/scenes/{name}.toml", env!("CARGO_MANIFEST_DIR"))
}

/// The names of the functions a shader defines: `fn name(` in WGSL, `TYPE name(...) {` in HLSL.
pub(super) fn shader_functions(text: &str) -> Vec<String> {
    let mut names: Vec<String> = text
        .lines()
        .filter(|line| !line.starts_with([' ', '/', '@', '}']) && line.trim_end().ends_with('{') && line.contains('('))
        .filter_map(|line| line.split('(').next()?.split_whitespace().last().map(str::to_string))
        .collect();
    names.sort();
    names
}

/// Builds the small set's TIR table into `dir/tables` and fits the repository's logistic TIR
/// form to it into `dir/<out>` with `extra` options; returns the fit's folder.
pub(super) fn fit_tir_logistic(dir: &Path, config: &Path, out: &str, extra: &[&str]) -> PathBuf {
    let tables = dir.join("tables");
    if !tables.join("tir.dds").is_file() {
        let output = build(config, &tables, &["--only", "tir"]);
        assert!(output.status.success(), "{}", stderr(&output));
    }
    let form = Path::new(env!("CARGO_MANIFEST_DIR")).join("luts/forms/tir-logistic.toml");
    fit_form(&form, &tables.join("tir.dds"), &dir.join(out), extra)
}

/// `tmlut fit --form FORM --table TABLE --out OUT --starts 1` with `extra`, which must succeed;
/// returns `OUT`.
pub(super) fn fit_form(form: &Path, table: &Path, out: &Path, extra: &[&str]) -> PathBuf {
    let mut args = vec!["fit", "--form", form.to_str().unwrap(), "--table", table.to_str().unwrap()];
    args.extend(["--out", out.to_str().unwrap(), "--starts", "1"]);
    args.extend_from_slice(extra);
    let output = tmlut(&args);
    assert!(output.status.success(), "{}", stderr(&output));
    out.to_path_buf()
}

/// The copper pot with `tir = TIR`, written into `dir/name.toml`.
pub(super) fn copper_pot_with_tir(dir: &Path, name: &str, tir: &str) -> PathBuf {
    let scene = dir.join(format!("{name}.toml"));
    let text = std::fs::read_to_string(scene_path("copper-pot")).unwrap();
    std::fs::write(&scene, text.replace("tir = \"table\"", &format!("tir = \"{tir}\""))).unwrap();
    scene
}

/// `SMALL_SET` with every texture a scene build writes in `container`, at `precision`.
pub(super) fn small_set_written_as(container: &str, precision: &str) -> String {
    let mut text = SMALL_SET.replacen("[fgd]\n", &format!("[fgd]\npacking_formats = [\"{container}\"]\n"), 1);
    text.push_str(&format!("[fgd.output]\nformats = [\"exr\"]\nprecision = \"{precision}\"\n"));
    for table in ["gd", "tir", "fgd_rarer"] {
        text.push_str(&format!("[{table}.output]\nformats = [\"{container}\"]\nprecision = \"{precision}\"\n"));
    }
    text
}

/// The scenes of a small library: slices in texture arrays, full and sub-range tables, packings.
pub(super) fn small_library_args() -> Vec<String> {
    ["copper-pot", "gpu-check/varied-coats", "gpu-check/stiff-stacks"]
        .iter()
        .flat_map(|scene| ["--scene".to_string(), scene_path(scene)])
        .collect()
}
