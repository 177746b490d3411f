//! The TIR form the default build fits (`[tir] fit = "best"`): the form file
//! `luts/forms/tir-cauchy-slope.toml`, embedded so that the binary needs no file at run time,
//! fitted to the TIR table just built by [`super::fitting`] and printed by [`super::shader`] as
//! `tir_fit.hlsl` and `tir_fit.wgsl`, holding `tmlut_tir(mu, alpha, eta)`. The manifest entry
//! states the form's text, its definition statement by statement and its fitted parameters; the
//! model evaluates that definition ([`crate::ir::compile::FormEvaluator::from_definition`]).

use std::path::{Path, PathBuf};

use super::data::FormData;
use super::figures::{figures_of, residuals};
use super::fitted::tir_shape;
use super::fitting::fit;
use super::form::Form;
use super::prepared::SearchData;
use crate::error::Result;
use crate::fit::FitSettings;
use crate::formats::manifest::{ErrorFigures, FitEntry, ShaderFile};
use crate::table::Table;

/// The build form's file, as `luts/forms/` holds it.
pub const BUILD_FORM_FILE: &str = "tir-cauchy-slope.toml";

/// The build form's text: the most accurate form measured no costlier than thesis eq. 5.6
/// (`docs/fit.md`, "Forms").
pub const BUILD_FORM_TEXT: &str = include_str!("../../../luts/forms/tir-cauchy-slope.toml");

/// The form's name in the build: its shader function is `tmlut_tir`, the function
/// `tir_fit.hlsl` and `.wgsl` have always held and a scene shader calls.
pub const BUILD_FORM_NAME: &str = "tir";

/// Starts of the build's fit: the form's own start only. Six starts give the same minimum on the
/// default table (`docs/fit.md`) at six times the time.
pub const BUILD_STARTS: usize = 1;

/// The build fits on every third point along each variable of the fit grid (22^3 of the 64^3,
/// each variable's last point kept) and reports its figures over every point.
pub const BUILD_NODE_STRIDE: usize = 3;

/// Why the build fits this form, for the manifest.
const CHOSEN_BY: &str = "tir.fit = \"best\": the most accurate form measured no costlier than thesis eq. 5.6 \
    (docs/fit.md), the form file luts/forms/tir-cauchy-slope.toml";

/// The build form read against the TIR table's shape, named [`BUILD_FORM_NAME`].
pub fn build_form() -> Result<Form> {
    let mut form = Form::parse_for(Path::new(BUILD_FORM_FILE), BUILD_FORM_TEXT, &tir_shape())?;
    form.name = BUILD_FORM_NAME.into();
    Ok(form)
}

/// The form file's leading comment, the form in words.
fn formula(text: &str) -> String {
    let words: Vec<&str> =
        text.lines().map_while(|l| l.strip_prefix('#')).map(str::trim).filter(|l| !l.is_empty()).collect();
    words.join(" ")
}

/// Fit the build form to the TIR `table` with one start and `seed`, write `tir_fit.hlsl` and
/// `tir_fit.wgsl` into `dir`, and return the manifest entry and the files written.
pub fn fit_for_build(table: &Table, seed: u64, dir: &Path) -> Result<(FitEntry, Vec<PathBuf>)> {
    let form = Form::parse(Path::new(BUILD_FORM_FILE), BUILD_FORM_TEXT, table)?;
    let form = Form { name: BUILD_FORM_NAME.into(), ..form };
    let data = FormData::from_table(table, &form)?;
    let settings = FitSettings { starts: BUILD_STARTS, seed, ..FitSettings::default() };
    // Fitted on every third point (a 27th of them), judged on all of them.
    let coarse = data.every(table, BUILD_NODE_STRIDE);
    let fitted = fit(&form, &SearchData::new(&form, &coarse), &settings)?;
    let set = figures_of(&data, &residuals(&form, &data, &fitted.parameters)?);
    let at = |v: &str| set.together.max_at.get(v).copied().unwrap_or(f64::NAN);
    let figures = ErrorFigures::new(
        set.together.rms,
        set.together.rms * set.together.rms,
        set.together.max,
        [at("mu"), at("alpha"), at("eta")],
        data.len(),
    );
    let sources = super::shader::sources(&form, &fitted.parameters)?;
    let mut shaders = Vec::new();
    let mut paths = Vec::new();
    for extension in ["hlsl", "wgsl"] {
        let text = sources.text(extension).unwrap_or_default();
        let file = format!("tir_fit.{extension}");
        let path = dir.join(&file);
        crate::formats::write_bytes_atomically(&path, text.as_bytes())?;
        shaders.push(ShaderFile::new(extension, file, super::shader::function_name(&form), text.as_bytes()));
        paths.push(path);
    }
    let mut entry = FitEntry::new(
        form_stem(),
        formula(BUILD_FORM_TEXT),
        CHOSEN_BY,
        form.parameter_names(),
        fitted.parameters,
        figures,
    );
    entry.form_text = BUILD_FORM_TEXT.into();
    entry.definition = form.definition();
    entry.search = fitted.search;
    entry.shaders = shaders;
    entry.shader_arguments = form.arguments.clone();
    Ok((entry, paths))
}

/// The build form's file stem, the manifest's `form`.
fn form_stem() -> String {
    BUILD_FORM_FILE.trim_end_matches(".toml").to_string()
}
