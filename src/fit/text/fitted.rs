//! A fitted TIR form as a scene names it: `tir = "fit:PATH"`, PATH the output folder of
//! `tmlut fit --form FILE --table TIR_TABLE` or its `fit.json`, which holds the form's text and
//! its fitted parameters ([`FittedForm`], a record of the manifest). The model evaluates it in
//! f32 with the parameters rounded to f32, as the scene shader computes it.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;

pub use super::compile::FormEvaluator;
use super::form::{Form, TableShape};
use crate::error::{Error, Result};
pub use crate::formats::manifest::FittedForm;

/// The file `tmlut fit --form` lists its set in.
pub const FIT_FILE: &str = "fit.json";

/// The table a scene's form replaces: TIR, its variables and its one channel.
pub fn tir_shape() -> TableShape {
    TableShape {
        name: "tir".to_string(),
        variables: ["mu", "alpha", "eta"].map(String::from).to_vec(),
        channels: vec!["tir".to_string()],
    }
}

/// The name of the form a build fits (`[tir] fit = "best"`): its shader function is `tmlut_tir`,
/// the function `tir_fit.hlsl` and `.wgsl` hold and a scene shader calls.
pub const BUILD_FORM_NAME: &str = "tir";

/// What `tir = "fit:PATH"` allows, in the words of the error messages.
pub const ALLOWED: &str = "\"fit:PATH\" with PATH (relative to the scene file) the output folder of \
    `tmlut fit --form FORM.toml --table TIR_TABLE --out PATH`, or the fit.json in it";

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

impl FittedForm {
    /// The fitted form at `path` (a folder holding `fit.json`, or the file), `source` being the
    /// path as the scene wrote it. Refuses a missing file, a form of another table, a fit.json
    /// with no form text, and parameters no search fitted.
    pub fn read(path: &Path, source: &str) -> Result<FittedForm> {
        let file: PathBuf = if path.is_dir() { path.join(FIT_FILE) } else { path.to_path_buf() };
        let refuse = |reason: String| Error::invalid(format!("fit:{source} ({})", file.display()), reason);
        if !file.is_file() {
            return Err(refuse(format!("no such file; allowed: {ALLOWED}")));
        }
        let text = crate::formats::read_text_at_most(&file, 1 << 24, "fit.json")?;
        let fit: FitFile = serde_json::from_str(&text)
            .map_err(|e| refuse(format!("is not the fit.json of `tmlut fit --form` ({e}); allowed: {ALLOWED}")))?;
        let shape = tir_shape();
        if fit.table != shape.name {
            return Err(refuse(format!(
                "holds form `{}` fitted to table `{}`; a scene's `tir` reads a form fitted to table `{}`",
                fit.form, fit.table, shape.name
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
        let fitted = FittedForm {
            name: fit.form,
            source: source.to_string(),
            form_text: fit.form_text,
            definition: fit.definition,
            parameter_order: fit.parameter_order,
            parameters,
        };
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

    /// A built folder's fitted form (its manifest's `fit`), held as a scene's fitted forms are,
    /// named [`BUILD_FORM_NAME`]. `None` for an entry without form text.
    pub fn of_build(fit: &crate::formats::manifest::FitEntry) -> Option<FittedForm> {
        (!fit.form_text.is_empty()).then(|| FittedForm {
            name: BUILD_FORM_NAME.into(),
            source: fit.form.clone(),
            form_text: fit.form_text.clone(),
            definition: fit.definition.clone(),
            parameter_order: fit.parameter_names.clone(),
            parameters: fit.parameters.clone(),
        })
    }

    /// The form, read from its text against the TIR table's shape.
    pub fn form(&self) -> Result<Form> {
        let path = PathBuf::from(format!("{}.toml", self.name));
        let mut form = Form::parse_for(&path, &self.form_text, &tir_shape())?;
        form.name = self.name.clone();
        Ok(form)
    }

    /// The form compiled for evaluation.
    pub fn evaluator(&self) -> Result<FormEvaluator> {
        let form = self.form()?;
        Ok(FormEvaluator::new(form.tape, form.variables, &self.parameters))
    }
}
