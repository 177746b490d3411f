//! Candidate TIR forms judged in the material (`tmlut fit --scene`): the scene's materials are
//! measured in the furnace once with the TIR table and once per fitted form, every TIR lookup of
//! every material answered by that form, and the forms are ranked by the largest error of the
//! directional albedo against the model with exact integrals, over every material and view.
//!
//! The tables are built once (the run with the TIR table builds the scene's plan with every
//! material on the table path) and every form's run reads that folder; the random walk and the
//! pictures are left out (the table error needs neither). Each run integrates the scene's lookups
//! exactly again, so a ranking costs about one `tmlut furnace --walk none` per candidate, plus one.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::report::{FurnaceReport, file_stem};
use super::{FurnaceRequest, FurnaceSettings, Selection, run};
use crate::config::Config;
use crate::error::{Error, Result};
use crate::fit::FitSettings;
use crate::fit::forms::fitted::{FittedForm, FittedFormExt, TIR_TABLES};
use crate::fit::forms::fitting::FIT_FILE;
use crate::fit::forms::form::{distinct_form_names, form_files_for, form_name};
use crate::fit::forms::{FitOptions, FormFitRequest, FormReport, WeightsSpec, fit_form_file};
use crate::integrate::Progress;
use crate::model::TirPath;
use crate::scene::Scene;
use crate::table::TableKind;

/// The candidates of a ranking, fitted where they are form files: each path a form file (fitted
/// to the table `table` into `out/fits/<form>`, the table read once), a folder `tmlut fit --form`
/// wrote (or its `fit.json`), or a folder of TIR form files (each fitted). `fitted` hears of each
/// form file fitted, with its report. Two form files of one name are refused before any fit.
pub fn fitted_candidates(
    paths: &[PathBuf],
    table: &Path,
    out: &Path,
    settings: FitSettings,
    fitted: &mut dyn FnMut(&Path, &FormReport),
    skipped: &mut dyn FnMut(&str),
) -> Result<Vec<FittedForm>> {
    let mut candidates: Vec<PathBuf> = Vec::new();
    for path in paths {
        if path.is_dir() && !path.join(FIT_FILE).is_file() {
            let (files, notes) = form_files_for(path, TableKind::Tir.name())?;
            notes.iter().for_each(|note| skipped(note));
            candidates.extend(files);
        } else {
            candidates.push(path.clone());
        }
    }
    let is_form_file = |p: &PathBuf| p.extension().is_some_and(|e| e == "toml");
    // Each form file is fitted into `fits/<form>`: two files of one form name would share it.
    let form_files: Vec<PathBuf> = candidates.iter().filter(|p| is_form_file(p)).cloned().collect();
    distinct_form_names(&form_files)?;
    let mut table_read = None;
    let mut forms = Vec::with_capacity(candidates.len());
    for path in candidates {
        let folder = if is_form_file(&path) {
            let table_read = match &mut table_read {
                Some(read) => read,
                none => none.insert(crate::loader::load_table(table)?),
            };
            // Folders tmlut makes inside the given one: never a link planted there.
            let out = crate::formats::files::create_folders_inside(out, &Path::new("fits").join(form_name(&path)))?;
            let options = FitOptions {
                table: table.to_path_buf(),
                settings,
                certify: None,
                ranges: Vec::new(),
                weights: WeightsSpec::Uniform,
                scene: None,
                timing_runs: 0,
            };
            let request = FormFitRequest { form: path.clone(), out, options };
            let report = fit_form_file(table_read, &request)?;
            fitted(&path, &report);
            request.out
        } else {
            path
        };
        forms.push(FittedForm::read(&folder, &folder.display().to_string(), TIR_TABLES)?);
    }
    Ok(forms)
}

/// What `tmlut fit --scene` is asked.
pub struct FormRankRequest {
    pub scene: Scene,
    /// Where the scene came from, and its text (recorded in the furnace reports).
    pub source: String,
    pub text: String,
    /// The fitted forms to rank.
    pub forms: Vec<FittedForm>,
    pub out: PathBuf,
    pub config: Config,
    /// Views and exact samples; the walk and pictures are turned off.
    pub settings: FurnaceSettings,
}

/// One run's error in the material: the largest over materials, views and channels of
/// `|A(with the form or table) - A(exact)|`, where it is, and the RMS over all of them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InMaterial {
    /// `table`, or the form's name.
    pub tir: String,
    /// The path as given (`fit:PATH`), for a form.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
    pub max_error: f64,
    pub max_material: String,
    pub max_at_mu: f64,
    /// Root mean square over every material, view and channel.
    pub rms_error: f64,
    /// Per material, its largest error.
    pub materials: Vec<(String, f64)>,
    /// The furnace report of the run, relative to the ranking's folder.
    pub furnace: String,
}

/// `ranking.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FormRanking {
    pub scene: String,
    pub views: usize,
    pub exact_nodes: usize,
    /// The scene's materials with the TIR table.
    pub table: InMaterial,
    /// The forms, the smallest largest error first (then RMS, then name).
    pub forms: Vec<InMaterial>,
    pub rule: String,
}

pub const RANKING_FILE: &str = "ranking.json";

/// `scene` with every material reading TIR by `tir` (`form` where it is [`TirPath::Form`]).
fn with_tir(scene: &Scene, tir: TirPath, form: Option<&FittedForm>) -> Scene {
    let mut scene = scene.clone();
    for material in &mut scene.materials {
        material.tir = tir;
        material.tir_form = form.cloned();
    }
    scene
}

fn in_material(report: &FurnaceReport, tir: String, source: Option<String>, furnace: &Path) -> InMaterial {
    let mut worst = (0.0, String::new(), 0.0);
    let (mut squares, mut count) = (0.0, 0usize);
    let mut materials = Vec::with_capacity(report.materials.len());
    for m in &report.materials {
        let e = &m.errors.table;
        if e.max_all > worst.0 || worst.1.is_empty() {
            worst = (e.max_all, m.name.clone(), e.max_all_at_mu);
        }
        squares += e.rms_all * e.rms_all * (3 * m.mu.len()) as f64;
        count += 3 * m.mu.len();
        materials.push((m.name.clone(), e.max_all));
    }
    InMaterial {
        tir,
        source,
        max_error: worst.0,
        max_material: worst.1,
        max_at_mu: worst.2,
        rms_error: (squares / count.max(1) as f64).sqrt(),
        materials,
        furnace: furnace.display().to_string(),
    }
}

/// Measure the scene with the TIR table and with each form, rank the forms, and write
/// `ranking.json` into `request.out` (each run's furnace report in a folder of its own there).
pub fn rank_forms(request: &FormRankRequest, progress: &dyn Progress) -> Result<FormRanking> {
    if request.forms.is_empty() {
        return Err(Error::invalid("fit --scene", "no form to rank; give --form at least once"));
    }
    for (k, form) in request.forms.iter().enumerate() {
        if let Some(other) = request.forms[..k].iter().find(|f| file_stem(&f.name) == file_stem(&form.name)) {
            return Err(Error::invalid(
                format!("fit:{}", form.source),
                format!(
                    "holds form `{}`, whose run would write into the folder of form `{}` (fit:{}); rank forms of \
                     different names",
                    form.name, other.name, other.source
                ),
            ));
        }
    }
    let settings =
        FurnaceSettings { walk_materials: Selection::None, pictures: Selection::None, ..request.settings.clone() };
    let furnace = |scene: Scene, folder: &Path, luts: Option<PathBuf>| -> Result<FurnaceReport> {
        let furnace_request = FurnaceRequest {
            scene,
            material_scenes: None,
            source: request.source.clone(),
            text: request.text.clone(),
            luts,
            // Folders tmlut makes inside the given one: never a link planted there.
            out: crate::formats::files::create_folders_inside(&request.out, folder)?,
            config: request.config.clone(),
            settings: settings.clone(),
        };
        run(&furnace_request, progress)
    };
    let table_folder = PathBuf::from("table");
    progress.note("furnace with the TIR table (building the scene's tables)");
    let report = furnace(with_tir(&request.scene, TirPath::Table, None), &table_folder, None)?;
    let table = in_material(&report, "table".into(), None, &table_folder.join(super::report::FURNACE_FILE));
    let luts = request.out.join(&table_folder).join("luts");
    let mut forms = Vec::with_capacity(request.forms.len());
    for form in &request.forms {
        progress.note(&format!("furnace with form `{}` (fit:{})", form.name, form.source));
        let folder = PathBuf::from("forms").join(file_stem(&form.name));
        let report = furnace(with_tir(&request.scene, TirPath::Form, Some(form)), &folder, Some(luts.clone()))?;
        forms.push(in_material(
            &report,
            form.name.clone(),
            Some(format!("fit:{}", form.source)),
            &folder.join(super::report::FURNACE_FILE),
        ));
    }
    forms.sort_by(|a, b| {
        a.max_error.total_cmp(&b.max_error).then(a.rms_error.total_cmp(&b.rms_error)).then(a.tir.cmp(&b.tir))
    });
    let ranking = FormRanking {
        scene: request.scene.name.clone(),
        views: settings.views,
        exact_nodes: settings.exact_nodes,
        table,
        forms,
        rule: "every material reads TIR by the form (or the table); error = |A(mu) with it - A(mu) with exact \
               integrals| over the materials, views and channels; ranked by its max, then RMS"
            .into(),
    };
    let json = serde_json::to_string_pretty(&ranking).map_err(|e| Error::format(&request.out, e.to_string()))?;
    crate::formats::write_bytes_atomically(&request.out.join(RANKING_FILE), json.as_bytes())?;
    Ok(ranking)
}

/// The ranking as a Markdown table.
pub fn markdown(ranking: &FormRanking) -> String {
    let mut s = format!(
        "Scene `{}`: error in the material, |A(mu) - A(mu) with exact integrals| over every material, {} views and \
         the three channels (exact integrals with {} Gauss–Legendre nodes per panel).\n\n| rank | TIR | max error | material | at mu | RMS |\n\
         |---|---|---:|---|---:|---:|\n",
        ranking.scene, ranking.views, ranking.exact_nodes
    );
    let row = |rank: String, e: &InMaterial| {
        let name = match &e.source {
            Some(source) => format!("`{}` ({source})", e.tir),
            None => e.tir.clone(),
        };
        format!(
            "| {rank} | {name} | {:.3e} | {} | {:.3} | {:.3e} |\n",
            e.max_error, e.max_material, e.max_at_mu, e.rms_error
        )
    };
    for (k, form) in ranking.forms.iter().enumerate() {
        s.push_str(&row((k + 1).to_string(), form));
    }
    s.push_str(&row("-".into(), &ranking.table));
    s
}

#[cfg(test)]
mod tests {
    use std::cell::Cell;

    use super::*;
    use crate::fit::forms::fitted::FittedFormExt;
    use crate::loader::LutFolder;
    use crate::model::folder::{FgdSource, FolderTables};
    use crate::model::{AlbedoPath, Lookup, Material, Quantity, Tables};

    /// A varnish over copper: its TIR lookups are the varnish's upward crossings.
    const SCENE: &str = "name = \"pot\"\n[[material]]\nname = \"varnished\"\n\
        [[material.layer]]\ntype = \"interface\"\neta = 1.5\nalpha = 0.2\n\
        [[material.layer]]\ntype = \"interface\"\neta = [0.2, 0.9, 1.1]\nkappa = [3.0, 2.5, 2.0]\nalpha = 0.3\n";

    /// The repository's logistic TIR form at the given parameters (as if fitted).
    fn logistic(name: &str, scale: f64) -> FittedForm {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/luts/forms/tir-logistic.toml");
        let form_text = std::fs::read_to_string(path).unwrap();
        let mut fitted =
            FittedForm::new(name, "tir", format!("{name}/fit.json"), form_text, Vec::new(), Vec::new(), Vec::new());
        let form = fitted.form().unwrap();
        fitted.definition = form.definition();
        fitted.parameter_order = form.parameter_names();
        fitted.parameters = form.parameters.iter().map(|p| (p.start + 0.1) * scale).collect();
        fitted
    }

    fn request(forms: Vec<FittedForm>, out: &Path) -> FormRankRequest {
        FormRankRequest {
            scene: Scene::from_toml(SCENE, "test", "pot").unwrap(),
            source: "test".into(),
            text: SCENE.into(),
            forms,
            out: out.to_path_buf(),
            config: Config::default(),
            settings: FurnaceSettings { views: 6, exact_nodes: 4, timing_rounds: 1, ..Default::default() },
        }
    }

    #[test]
    fn the_model_reads_the_forms_value_where_the_table_would_be_and_forms_rank_by_their_error() {
        let dir = tempfile::tempdir().unwrap();
        let (wide, narrow) = (logistic("wide", 3.0), logistic("narrow", 1.0));
        let ranking = rank_forms(&request(vec![wide.clone(), narrow.clone()], dir.path()), &()).unwrap();
        assert_eq!(ranking.forms.len(), 2);
        assert!(ranking.forms[0].max_error <= ranking.forms[1].max_error, "{ranking:?}");
        assert!(ranking.table.max_error.is_finite() && ranking.table.max_error < ranking.forms[0].max_error);

        // Each form's run: the model over the run's folder, every TIR lookup answered by the form
        // evaluated here (no other path to it), the rest by the folder; the same curve, bit for bit.
        let folder = LutFolder::open(dir.path().join("table").join("luts")).unwrap();
        let others = FolderTables::open(&folder, AlbedoPath::Fgd, TirPath::Off, FgdSource::Packing).unwrap();
        for form in [&wide, &narrow] {
            let entry = ranking.forms.iter().find(|e| e.tir == form.name).unwrap();
            let report = FurnaceReport::read(&dir.path().join(&entry.furnace)).unwrap();
            let m = &report.materials[0];
            assert_eq!(m.tir_label(), format!("fit:{}", form.source));
            let evaluator = form.evaluator().unwrap();
            let tir_lookups = Cell::new(0);
            let by_hand = |l: &Lookup| {
                if l.quantity == Quantity::Tir {
                    tir_lookups.set(tir_lookups.get() + 1);
                    evaluator.tir(l.mu, l.alpha, l.eta)
                } else {
                    others.value(l)
                }
            };
            let model = Material::new(m.model, m.stack.clone());
            let curve: Vec<_> = m.mu.iter().map(|&mu| model.albedo(mu, &by_hand)).collect();
            assert_eq!(curve, m.albedo_tables, "{}", form.name);
            assert!(tir_lookups.get() >= m.mu.len(), "the varnish reads TIR at every view");
            assert_eq!(entry.max_error, m.errors.table.max_all);
        }
        // The two forms answer differently, so their materials differ.
        assert_ne!(ranking.forms[0].max_error, ranking.forms[1].max_error);
        // The ranking file holds what was returned.
        let read: FormRanking = serde_json::from_slice(&std::fs::read(dir.path().join(RANKING_FILE)).unwrap()).unwrap();
        assert_eq!(read, ranking);
    }
}
