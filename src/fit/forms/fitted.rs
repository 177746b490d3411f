//! A fitted form as a scene names it in place of a table: `tir = "fit:PATH"` for the TIR table,
//! `albedo = "fit:PATH"` for an albedo table (Karis's split sum, or FGD), PATH the output folder of
//! `tmlut fit --form FILE --table TABLE` or its `fit.json`, which holds the form's text and its
//! fitted parameters ([`FittedForm`], a record of the manifest). The model evaluates it in f32 with
//! the parameters rounded to f32, as the scene shader computes it.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::form::{Form, TableShape};
use crate::error::{Error, Result};
pub use crate::formats::manifest::FittedForm;
pub use crate::ir::compile::FormEvaluator;

/// The file `tmlut fit --form` lists its set in.
pub const FIT_FILE: &str = "fit.json";

/// The table a scene's form replaces: TIR, its variables and its one channel.
pub fn tir_shape() -> TableShape {
    shape_of("tir").expect("a table a form replaces")
}

/// The tables a scene's `tir = "fit:PATH"` form may replace.
pub const TIR_TABLES: &[&str] = &["tir"];
/// The tables a scene's `albedo = "fit:PATH"` form may replace: Karis's split sum (its two
/// channels weighed by the interface's F0 as the table's are) and the 4D FGD table.
pub const ALBEDO_TABLES: &[&str] = &["karis", "fgd"];

/// The variables and channels of a table a scene's form may replace, in the order the model and
/// the scene shader pass and read them (the scene shader calls the form by them, whatever its
/// `[function]` declares: [`super::shader::lookup_module`]); `None` for another table.
pub fn shape_of(table: &str) -> Option<TableShape> {
    let (variables, channels): (&[&str], &[&str]) = match table {
        "tir" => (&["mu", "alpha", "eta"], &["tir"]),
        "karis" => (&["mu", "alpha"], &["scale", "bias"]),
        "fgd" => (&["mu", "alpha", "eta", "kappa"], &["fgd"]),
        _ => return None,
    };
    let strings = |v: &[&str]| v.iter().map(|s| s.to_string()).collect();
    Some(TableShape::of_variables(table, strings(variables), strings(channels)))
}

/// The name of the form a build fits (`[tir] fit = "best"`): its shader function is `tmlut_tir`,
/// the function `tir_fit.hlsl` and `.wgsl` hold and a scene shader calls.
pub const BUILD_FORM_NAME: &str = "tir";

/// What `tir = "fit:PATH"` and `albedo = "fit:PATH"` allow, in the words of the error messages.
pub const ALLOWED: &str = "\"fit:PATH\" with PATH (relative to the scene file) the output folder of \
    `tmlut fit --form FORM.toml --table TABLE --out PATH`, or the fit.json in it";

/// The parts of `fit.json` a scene reads.
#[derive(Deserialize)]
struct FitFile {
    form: String,
    table: String,
    definition: Vec<String>,
    #[serde(default)]
    form_text: String,
    parameters: BTreeMap<String, f64>,
    parameter_order: Vec<String>,
    /// `null` where no search ran (`--max-evaluations 0`).
    search: Option<serde::de::IgnoredAny>,
}

/// Reading, compiling and evaluating a fitted form: the generator's side of the manifest's
/// [`FittedForm`] record (the form language is not the loader's).
pub trait FittedFormExt: Sized {
    /// The fitted form at `path` (a folder holding `fit.json`, or the file), `source` being the
    /// path as the scene wrote it, fitted to one of `tables` ([`TIR_TABLES`], [`ALBEDO_TABLES`]).
    /// Refuses a missing file, a form of another table, a fit.json with no form text, and
    /// parameters no search fitted.
    fn read(path: &Path, source: &str, tables: &[&str]) -> Result<FittedForm>;

    /// A built folder's fitted form (its manifest's `fit`), held as a scene's fitted forms are,
    /// named [`BUILD_FORM_NAME`]. `None` for an entry without form text.
    fn of_build(fit: &crate::formats::manifest::FitEntry) -> Option<FittedForm>;

    /// The form, read from its text against the shape of the table it replaces.
    fn form(&self) -> Result<Form>;

    /// The form compiled for evaluation.
    fn evaluator(&self) -> Result<FormEvaluator>;
}

impl FittedFormExt for FittedForm {
    fn read(path: &Path, source: &str, tables: &[&str]) -> Result<FittedForm> {
        let file: PathBuf = if path.is_dir() { path.join(FIT_FILE) } else { path.to_path_buf() };
        let refuse = |reason: String| Error::invalid(format!("fit:{source} ({})", file.display()), reason);
        if !file.is_file() {
            return Err(refuse(format!("no such file; allowed: {ALLOWED}")));
        }
        let text = crate::formats::read_text_at_most(&file, 1 << 24, "fit.json")?;
        let fit: FitFile = serde_json::from_str(&text)
            .map_err(|e| refuse(format!("is not the fit.json of `tmlut fit --form` ({e}); allowed: {ALLOWED}")))?;
        if !tables.contains(&fit.table.as_str()) {
            let key = if tables == TIR_TABLES { "tir" } else { "albedo" };
            return Err(refuse(format!(
                "holds form `{}` fitted to table `{}`; a scene's `{key}` reads a form fitted to table `{}`",
                fit.form,
                fit.table,
                tables.join("` or `")
            )));
        }
        if fit.form_text.is_empty() {
            return Err(refuse(
                "records no form text (written before fit.json recorded it); fit the form again with tmlut fit --form"
                    .into(),
            ));
        }
        // A form without parameters has nothing to search: its definition is its fit.
        if fit.search.is_none() && !fit.parameter_order.is_empty() {
            return Err(refuse(format!(
                "holds form `{}` at its start values (fitted with --max-evaluations 0): its parameters are unfitted; \
                 fit it with a search (--max-evaluations above 0)",
                fit.form
            )));
        }
        let mut parameters = Vec::with_capacity(fit.parameter_order.len());
        for name in &fit.parameter_order {
            match fit.parameters.get(name) {
                Some(v) if v.is_finite() => parameters.push(*v),
                Some(v) => return Err(refuse(format!("parameter `{name}` is {v}; allowed: a finite number"))),
                None => return Err(refuse(format!("lists parameter `{name}` and gives no value for it"))),
            }
        }
        let fitted = FittedForm::new(
            fit.form,
            fit.table,
            source,
            fit.form_text,
            fit.definition,
            fit.parameter_order,
            parameters,
        );
        let form = fitted.form().map_err(|e| refuse(e.to_string()))?;
        if form.parameter_names() != fitted.parameter_order {
            return Err(refuse(format!(
                "lists parameters {}, and its form text declares {}",
                fitted.parameter_order.join(", "),
                form.parameter_names().join(", ")
            )));
        }
        Ok(fitted)
    }

    fn of_build(fit: &crate::formats::manifest::FitEntry) -> Option<FittedForm> {
        (!fit.form_text.is_empty()).then(|| {
            FittedForm::new(
                BUILD_FORM_NAME,
                "tir",
                fit.form.clone(),
                fit.form_text.clone(),
                fit.definition.clone(),
                fit.parameter_names.clone(),
                fit.parameters.clone(),
            )
        })
    }

    fn form(&self) -> Result<Form> {
        let path = PathBuf::from(format!("{}.toml", self.name));
        let shape = shape_of(&self.table).ok_or_else(|| {
            Error::invalid(
                format!("form `{}`", self.name),
                format!("replaces table `{}`; allowed: tir, {}", self.table, ALBEDO_TABLES.join(", ")),
            )
        })?;
        let mut form = Form::parse_for(&path, &self.form_text, &shape)?;
        form.name = self.name.clone();
        Ok(form)
    }

    fn evaluator(&self) -> Result<FormEvaluator> {
        let form = self.form()?;
        Ok(FormEvaluator::new(form.tape, form.variables, &self.parameters))
    }
}
