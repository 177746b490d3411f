//! Fitting a form file to a table: the search ([`fit`], the same seeded multi-start L-BFGS as the
//! built-in forms, [`crate::fit::minimise`], with the gradient from the tape) and the files: one
//! form fitted into a set (`fit.json`, `report.md`, the shaders and the pictures, committed as one,
//! [`fit_form_file`]), and a folder of forms fitted and ranked (`forms.json`, [`fit_form_files`]).
//! The set is made of the data ([`super::data`]) prepared for the search ([`super::prepared`]),
//! the error figures ([`super::figures`]), which parameters the data leaves ill-determined
//! ([`super::identifiability`]), the certification against exact integrals ([`super::certify`])
//! and the reports ([`super::markdown`]).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::certify::{Certified, certify};
use super::cost::{Cost, operations, timing};
use super::data::FormData;
use super::figures::{ErrorFigures, ErrorsByChannel, figures_of, residuals, weighted_figures_of};
use super::form::{Form, MAX_FORM_BYTES, ShaderArgument};
use super::identifiability::{Identifiability, identifiability};
use super::markdown::markdown;
use super::pictures::{ERROR_MAP_FILE, RESIDUALS_FILE, write_pictures};
use super::prepared::SearchData;
use super::region::{Range, Region, SceneLookups, WeightsSpec};
use super::shader::{function_name, sources};
use crate::commit::{Move, OutputFolder, commit_set};
use crate::error::{Error, Result};
use crate::fit::{FitSettings, Minimum, minimise};
use crate::recipes::interpolation::ExactValues;
use crate::table::Table;

/// A form fitted to a table.
#[derive(Debug, Clone, PartialEq)]
pub struct FormFit {
    pub parameters: Vec<f64>,
    /// `None` when no search ran (`max_evaluations = 0`: the form at its start values).
    pub search: Option<Minimum>,
}

/// Fit `form` to `data`: the form's start and `settings.starts - 1` seeded uniform points in the
/// bounds, each searched by L-BFGS with the exact gradient; the best wins. `max_evaluations = 0`
/// evaluates the form at its start values.
pub fn fit(form: &Form, prepared: &SearchData, settings: &FitSettings) -> Result<FormFit> {
    let start: Vec<f64> = form.parameters.iter().map(|p| p.start).collect();
    // A form without parameters (a published baseline) has nothing to search.
    if settings.max_evaluations == 0 || start.is_empty() {
        return Ok(FormFit { parameters: start, search: None });
    }
    let lower: Vec<f64> = form.parameters.iter().map(|p| p.min).collect();
    let upper: Vec<f64> = form.parameters.iter().map(|p| p.max).collect();
    let objective = |x: &[f64], g: Option<&mut [f64]>| prepared.objective(x, g);
    let minimum = minimise(&objective, true, &start, &lower, &upper, settings)?;
    Ok(FormFit { parameters: minimum.parameters.clone(), search: Some(minimum) })
}

/// `fit.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FormReport {
    pub form: String,
    pub form_file: String,
    pub table: String,
    pub table_file: String,
    pub variables: Vec<String>,
    pub channels: Vec<String>,
    /// The form statement by statement ([`Form::definition`]).
    pub definition: Vec<String>,
    /// The form file's text, as read: with `parameters`, what a scene's `tir = "fit:..."` reads
    /// ([`super::fitted`]). Empty in files written before it was recorded.
    #[serde(default)]
    pub form_text: String,
    pub parameters: BTreeMap<String, f64>,
    pub parameter_order: Vec<String>,
    pub start: BTreeMap<String, f64>,
    pub bounds: BTreeMap<String, [f64; 2]>,
    pub points: usize,
    pub points_are: String,
    /// `--range`: the box of the variables the points are kept in; empty for the whole table.
    #[serde(default)]
    pub ranges: Vec<Range>,
    /// `--weights`.
    #[serde(default)]
    pub weights: WeightsSpec,
    /// What the weights are, in words.
    #[serde(default)]
    pub weights_are: String,
    /// At the fitted parameters, the form in f32 against the table's values, every point counting
    /// once.
    pub figures: ErrorsByChannel,
    /// The same at the start values.
    pub start_figures: ErrorsByChannel,
    /// With weights other than uniform: the figures with each point counting its weight (the
    /// fit's objective is their RMS squared, in f64).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weighted_figures: Option<ErrorsByChannel>,
    /// The same at the start values.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weighted_start_figures: Option<ErrorsByChannel>,
    /// The form's operations, and its time per evaluation beside the table's lookup.
    #[serde(default)]
    pub cost: Option<Cost>,
    pub settings: FitSettings,
    pub search: Option<Minimum>,
    pub identifiability: Identifiability,
    /// Against exact integrals at random points, per check domain; empty when not asked for.
    pub certified: Vec<Certified>,
    pub shader_function: String,
    /// The shader function's arguments in order, each with the quantity it carries
    /// ([`Form::arguments`]). Empty in files written before it was recorded: the variables then.
    #[serde(default)]
    pub shader_arguments: Vec<ShaderArgument>,
    /// Every file of the set, `fit.json` and `report.md` included.
    pub files: Vec<String>,
}

/// The file that lists the set, moved into place last.
pub const FIT_FILE: &str = super::fitted::FIT_FILE;
pub const REPORT_FILE: &str = "report.md";

/// What `tmlut fit --form FILE` is asked: one form file, fitted into `out`.
pub struct FormFitRequest {
    pub form: PathBuf,
    pub out: PathBuf,
    pub options: FitOptions,
}

/// How a form is fitted and judged, the same for every form of a `--form DIR`.
#[derive(Clone)]
pub struct FitOptions {
    /// The table file, as the report names it.
    pub table: PathBuf,
    pub settings: FitSettings,
    /// The exact integrals to certify the form against (computed once for every form of a
    /// folder); `None` skips the certification.
    pub certify: Option<std::sync::Arc<Vec<ExactValues>>>,
    /// `--range`: only the points inside every range are fitted, judged, drawn and certified.
    pub ranges: Vec<Range>,
    /// `--weights`.
    pub weights: WeightsSpec,
    /// With `--weights SCENE.toml`: the scene's lookups of the table
    /// ([`crate::scene::lookups::table_lookups`]).
    pub scene: Option<SceneLookups>,
    /// Timed runs of the form and of the table's lookup ([`super::cost::timing`]); 0 times
    /// nothing (the file is then the same bytes on every run).
    pub timing_runs: usize,
}

/// Read the form against the table, fit it, and write `fit.json`, `report.md`, the shader
/// files and the GLSL validation harness into `out` as one set ([`commit_set`]: every file staged, `fit.json` moved last; files of
/// an earlier set that this one does not replace are removed with the commit).
pub fn fit_form_file(table: &Table, request: &FormFitRequest) -> Result<FormReport> {
    let form_text = crate::formats::read_text_at_most(&request.form, MAX_FORM_BYTES, "form file")?;
    let form = Form::parse(&request.form, &form_text, table)?;
    let region = Region::new(
        &request.options.ranges,
        &request.options.weights,
        request.options.scene.as_ref(),
        table,
        &form.variables,
    )?;
    let data = FormData::from_table_in(table, &form, &region)?;
    let start: Vec<f64> = form.parameters.iter().map(|p| p.start).collect();
    let start_residuals = residuals(&form, &data, &start)?;
    SearchData::check_memory(&form, &data)?;
    let prepared = SearchData::new(&form, &data);
    let fitted = fit(&form, &prepared, &request.options.settings)?;
    let fitted_residuals = residuals(&form, &data, &fitted.parameters)?;
    let fitted_figures = figures_of(&data, &fitted_residuals);
    let timed = match request.options.timing_runs {
        0 => None,
        runs => Some(timing(&form, &fitted.parameters, table, &data.coordinates, runs)?),
    };
    let shaders = sources(&form, &fitted.parameters)?;
    let shader_files = shaders.files(&form.name);
    let mut files: Vec<String> = shader_files.iter().map(|(file, _)| file.clone()).collect();
    files.extend([ERROR_MAP_FILE, RESIDUALS_FILE, REPORT_FILE, FIT_FILE].map(String::from));
    let names = form.parameter_names();
    let report = FormReport {
        form: form.name.clone(),
        form_file: request.form.display().to_string(),
        table: table.name.clone(),
        table_file: request.options.table.display().to_string(),
        variables: form.variables.clone(),
        channels: data.channels.clone(),
        definition: form.definition(),
        form_text,
        parameters: names.iter().cloned().zip(fitted.parameters.iter().copied()).collect(),
        parameter_order: names.clone(),
        start: form.parameters.iter().map(|p| (p.name.clone(), p.start)).collect(),
        bounds: form.parameters.iter().map(|p| (p.name.clone(), [p.min, p.max])).collect(),
        points: data.len(),
        points_are: data.description.clone(),
        ranges: request.options.ranges.clone(),
        weights: request.options.weights.clone(),
        weights_are: region.weights_description.clone(),
        figures: fitted_figures,
        start_figures: figures_of(&data, &start_residuals),
        weighted_figures: weighted_figures_of(&data, &fitted_residuals),
        weighted_start_figures: weighted_figures_of(&data, &start_residuals),
        cost: Some(Cost { operations: operations(&form.tape), timing: timed }),
        settings: request.options.settings,
        search: fitted.search,
        identifiability: identifiability(&form, &prepared, &fitted.parameters),
        certified: match &request.options.certify {
            Some(exact) => certify(&form, table, exact, (&start, &fitted.parameters), &region)?,
            None => Vec::new(),
        },
        shader_function: function_name(&form),
        shader_arguments: form.arguments.clone(),
        files,
    };
    let pictures = |dir: &Path| write_pictures(dir, &report.form, table, &data, &fitted_residuals, &report.figures);
    write_set(&request.out, &report, &shader_files, pictures)?;
    Ok(report)
}

/// The list `tmlut fit --form DIR` writes beside the fits' folders.
pub const FORMS_FILE: &str = "forms.json";

/// One form of a folder fitted to a table: where its set is, its figures and its cost.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RankedForm {
    pub form: String,
    pub form_file: String,
    /// The fit's folder (`fit.json` and the rest of its set), relative to `forms.json`.
    pub folder: String,
    pub parameters: usize,
    /// At the fitted parameters, all channels together (the form in f32 against the table), over
    /// the region's points, every point counting once.
    pub figures: ErrorFigures,
    /// With weights other than uniform: the same with each point counting its weight.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weighted_figures: Option<ErrorFigures>,
    /// The form's operations, and its time per evaluation beside the table's lookup where timed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cost: Option<Cost>,
}

impl RankedForm {
    /// The figures the ranking reads: the weighted ones where the points are weighted.
    pub fn ranked_by(&self) -> &ErrorFigures {
        self.weighted_figures.as_ref().unwrap_or(&self.figures)
    }
}

/// `forms.json`: the forms of a folder fitted to one table, ranked by max error (a formula in
/// place of a table shows its worst point as an artifact), then by RMS; with weights other than
/// uniform, by the weighted figures (the max over the points of positive weight, the weighted
/// RMS the fit minimised).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FolderFits {
    pub table: String,
    pub table_file: String,
    pub settings: FitSettings,
    /// `--range`: the box every form was fitted and judged in; empty for the whole table.
    #[serde(default)]
    pub ranges: Vec<Range>,
    /// `--weights`.
    #[serde(default)]
    pub weights: WeightsSpec,
    /// `--timing-runs` (0: no form was timed).
    #[serde(default)]
    pub timing_runs: usize,
    pub rule: String,
    pub forms: Vec<RankedForm>,
}

/// What `tmlut fit --form DIR` is asked: every form file of `files` fitted to the table with the
/// same options, each into `out/<form>/`.
pub struct FolderFitRequest {
    pub files: Vec<PathBuf>,
    pub out: PathBuf,
    pub options: FitOptions,
}

/// Fit every form file of the request to `table` ([`fit_form_file`], each into `out/<form>/`),
/// rank them by max error then RMS (weighted, where the weights are not uniform) and write
/// [`FORMS_FILE`] into `out`.
pub fn fit_form_files(table: &Table, request: &FolderFitRequest) -> Result<FolderFits> {
    let mut forms = Vec::with_capacity(request.files.len());
    let folders = super::form::distinct_form_names(&request.files)?;
    for (file, folder) in request.files.iter().zip(folders) {
        // Each form's folder is one tmlut makes inside the given one: never a link planted there.
        crate::formats::files::create_folders_inside(&request.out, Path::new(&folder))?;
        let one =
            FormFitRequest { form: file.clone(), out: request.out.join(&folder), options: request.options.clone() };
        let report = fit_form_file(table, &one)?;
        forms.push(RankedForm {
            form: report.form,
            form_file: report.form_file,
            folder,
            parameters: report.parameter_order.len(),
            figures: report.figures.together,
            weighted_figures: report.weighted_figures.map(|w| w.together),
            cost: report.cost,
        });
    }
    forms.sort_by(|a, b| {
        let (a, b) = (a.ranked_by(), b.ranked_by());
        a.max.total_cmp(&b.max).then(a.rms.total_cmp(&b.rms))
    });
    let weighted = forms.iter().any(|f| f.weighted_figures.is_some());
    let ranking = FolderFits {
        table: table.name.clone(),
        table_file: request.options.table.display().to_string(),
        settings: request.options.settings,
        ranges: request.options.ranges.clone(),
        weights: request.options.weights.clone(),
        timing_runs: request.options.timing_runs,
        rule: if weighted {
            "by the weighted figures: max |form - table| over the points of positive weight, then by the weighted RMS"
                .into()
        } else {
            "by max |form - table| over the points, then by RMS".into()
        },
        forms,
    };
    let json = serde_json::to_string_pretty(&ranking).map_err(|e| Error::invalid("forms.json", e.to_string()))?;
    crate::formats::write_bytes_atomically(&request.out.join(FORMS_FILE), json.as_bytes())?;
    Ok(ranking)
}

/// Stage every file (`pictures` draws [`ERROR_MAP_FILE`] and [`RESIDUALS_FILE`] into the folder
/// it is given) and commit them as one set.
fn write_set(
    out: &Path,
    report: &FormReport,
    shader_files: &[(String, &str)],
    pictures: impl FnOnce(&Path) -> Result<()>,
) -> Result<()> {
    let folder = OutputFolder::take(out, |_| {})?;
    let staging = &mut folder.staging()?;
    pictures(&staging.dir)?;
    let json = serde_json::to_string_pretty(report).map_err(|e| Error::format(out, e.to_string()))?;
    let mut texts: Vec<(&str, String)> =
        shader_files.iter().map(|(file, text)| (file.as_str(), text.to_string())).collect();
    texts.push((REPORT_FILE, markdown(report)));
    texts.push((FIT_FILE, json));
    for (file, text) in &texts {
        crate::formats::write_bytes_atomically(&staging.dir.join(file), text.as_bytes())?;
    }
    let moves: Vec<Move> = [ERROR_MAP_FILE, RESIDUALS_FILE]
        .into_iter()
        .chain(texts[..texts.len() - 1].iter().map(|(file, _)| *file))
        .map(|file| Move { staged: file.to_string(), destination: file.to_string() })
        .collect();
    // An earlier set's files this one does not replace (a form of another name).
    let removals = crate::formats::read_text_at_most(&out.join(FIT_FILE), 1 << 24, "fit.json")
        .ok()
        .and_then(|text| serde_json::from_str::<FormReport>(&text).ok())
        .map(|old| old.files.into_iter().filter(|f| !report.files.contains(f)).collect())
        .unwrap_or_default();
    commit_set(&folder, staging, moves, removals, FIT_FILE)
}
