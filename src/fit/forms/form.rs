//! Form files: a TOML file that names the table a form approximates, its parameters (start and
//! bounds), optional `let` bindings (in file order, each over the ones before it), one
//! expression per fitted channel ([`crate::ir::text`]) and, optionally, its shader function's
//! signature (`[function]`: its name and its arguments, each with the quantity it carries). Read
//! against a table, a form file becomes a [`Form`]: the expressions with every name resolved and
//! compiled ([`crate::ir::tape`]). Every mistake is an [`Error::At`] naming the file, line and
//! column.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use toml::Spanned;

use crate::error::{Error, Result};
pub use crate::formats::manifest::ShaderArgument;
use crate::ir::compile::Scope;
pub use crate::ir::compile::integer_exponent;
use crate::ir::tape::{Ins, Tape};
use crate::ir::text::{self, ExprError, Node};
use crate::table::{Mapping, Table, TableKind};

/// The variables a lookup passes, in this order where a table's axes depend on them.
pub const LOOKUP_VARIABLES: &[&str] = &["mu", "alpha", "eta", "kappa"];

/// Variables defined from the lookup variables, in the form language itself: name, definition,
/// the lookup variables it needs. `critical_angle_offset` is the angle by which the critical angle
/// of total internal reflection exceeds the view angle, as the TIR table's default axis defines
/// it (`crate::table::derived::CRITICAL_ANGLE_OFFSET_FORMULA`): 0 at the critical view,
/// positive inside the critical cone.
pub const DERIVED_VARIABLES: &[(&str, &str, &[&str])] = &[
    ("roughness", "sqrt(alpha)", &["alpha"]),
    ("critical_angle_offset", "asin(clamp(eta, 0.0, 1.0)) - acos(clamp(mu, 0.0, 1.0))", &["mu", "eta"]),
];

/// The largest form file read.
pub const MAX_FORM_BYTES: u64 = 1 << 20;

/// The most channels one form computes: a shader returns them as one `f32` or `vecN<f32>`.
pub const MAX_CHANNELS: usize = 4;

/// The most parameters one form fits. Published approximations of these tables have at most a
/// few dozen (EnvBRDFApprox 8); a fit's cost grows with the parameters times the points, and its
/// identifiability analysis with their cube.
pub const MAX_PARAMETERS: usize = 256;

/// A parameter as the file gives it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Parameter {
    pub name: String,
    pub start: f64,
    pub min: f64,
    pub max: f64,
}

/// A named expression: a derived variable, a `let` binding or a channel.
#[derive(Debug, Clone, PartialEq)]
pub struct Binding {
    pub name: String,
    pub text: String,
    pub node: Node,
    /// The instruction of [`Form::tape`] that holds its value.
    pub slot: usize,
}

/// A form read against a table.
#[derive(Debug, Clone, PartialEq)]
pub struct Form {
    pub path: PathBuf,
    /// The file's stem: the name of its shader function and files.
    pub name: String,
    pub table: String,
    /// The lookup variables, the shader function's arguments and each point's coordinates.
    pub variables: Vec<String>,
    /// The derived variables the form reads, in [`DERIVED_VARIABLES`] order.
    pub derived: Vec<Binding>,
    pub parameters: Vec<Parameter>,
    pub lets: Vec<Binding>,
    /// In the table's channel order.
    pub channels: Vec<Binding>,
    pub tape: Tape,
    /// The shader function's name where `[function] name` gives one; otherwise it is
    /// `tmlut_<name>` ([`Form::function_name`]).
    pub function: Option<String>,
    /// The shader function's arguments in order (`[function] arguments`, or the table's
    /// [`TableShape::sampling`]): every variable carried by one, `alpha` possibly as `roughness`.
    pub arguments: Vec<ShaderArgument>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileText {
    table: Spanned<String>,
    parameters: BTreeMap<Spanned<String>, Spanned<ParameterText>>,
    #[serde(rename = "let", default)]
    lets: BTreeMap<Spanned<String>, Spanned<String>>,
    channels: BTreeMap<Spanned<String>, Spanned<String>>,
    function: Option<Spanned<FunctionText>>,
}

/// `[function]`: the shader function's name and arguments, each optional.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FunctionText {
    name: Option<Spanned<String>>,
    arguments: Option<Spanned<Vec<Spanned<ArgumentText>>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ArgumentText {
    name: Spanned<String>,
    axis: Spanned<String>,
}

/// The quantity an argument may carry besides the form's variables: perceptual roughness,
/// `sqrt(alpha)` (`DERIVED_VARIABLES`; the split-sum recipes' `roughness_axis = "perceptual"`
/// spaces their rows evenly in it, `crate::recipes::spacing::RoughnessAxis`).
pub const ROUGHNESS: &str = "roughness";

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ParameterText {
    start: Spanned<f64>,
    min: Spanned<f64>,
    max: Spanned<f64>,
}

/// What a form is read against: a table's name, its lookup variables ([`table_variables`]), its
/// channels' names, in order, and the arguments a form's shader function takes where its file
/// declares none ([`sampling_arguments`]).
#[derive(Debug, Clone, PartialEq)]
pub struct TableShape {
    pub name: String,
    pub variables: Vec<String>,
    pub channels: Vec<String>,
    pub sampling: Vec<ShaderArgument>,
}

impl TableShape {
    /// A table read by its lookup variables: the default function takes them as they are named.
    pub fn of_variables(name: &str, variables: Vec<String>, channels: Vec<String>) -> Self {
        let sampling = variables.iter().map(|v| ShaderArgument::new(v, v)).collect();
        TableShape { name: name.to_string(), variables, channels, sampling }
    }
}

/// What a renderer passes to look the table up, as the default arguments of a form's function. A
/// split-sum table (Karis, Belcour) is a texture sampled directly at `(NoV, roughness)`
/// (`docs/tables.md`; its recipes' `roughness_axis = "perceptual"`, the default, spaces its rows
/// evenly in `roughness = sqrt(alpha)`, `crate::recipes::split_sum::SplitSumSettings::layout_notes`),
/// or at `(NoV, alpha)` where `roughness_axis = "alpha"` spaces them in alpha. Every other table
/// (FGD, GD, TIR and their slices) is read through a lookup of its variables, `mu`, `alpha`,
/// `eta`, `kappa` (whatever its axes' spacing: GD's and TIR's alpha axes are spaced in
/// `sqrt(alpha)` too, and their lookups take alpha).
pub fn sampling_arguments(table: &Table, variables: &[String]) -> Vec<ShaderArgument> {
    let split_sum = matches!(TableKind::named(&table.name), Some(TableKind::Karis | TableKind::Belcour));
    let alpha_axis = table.axes.iter().find(|a| a.name == "alpha");
    match (split_sum, alpha_axis) {
        (true, Some(alpha)) if table.axes.len() == 2 && table.axes[0].name == "mu" => {
            let roughness = if alpha.mapping == Mapping::Sqrt { ROUGHNESS } else { "alpha" };
            vec![ShaderArgument::new("NoV", "mu"), ShaderArgument::new(roughness, roughness)]
        }
        _ => variables.iter().map(|v| ShaderArgument::new(v, v)).collect(),
    }
}

/// The lookup variables of a table: the quantities of [`LOOKUP_VARIABLES`] its axes are or are
/// derived from (`critical_angle_offset` and `critical_angle_fraction` axes from `mu` and `eta`).
pub fn table_variables(table: &Table) -> Result<Vec<String>> {
    let mut needed = Vec::new();
    for axis in &table.axes {
        let name = axis.name.as_str();
        if LOOKUP_VARIABLES.contains(&name) {
            needed.push(name);
        } else if crate::table::derived::definition(name).is_some() {
            needed.extend(["mu", "eta"]);
        } else {
            return Err(Error::invalid(
                "fit table",
                format!(
                    "axis `{name}` of table `{}` is no quantity a form can read; allowed axes: {}",
                    table.name,
                    LOOKUP_VARIABLES.join(", ")
                ),
            ));
        }
    }
    Ok(LOOKUP_VARIABLES.iter().filter(|v| needed.contains(v)).map(|v| v.to_string()).collect())
}

/// A form file being read: its text, for errors at a place, and the scope its expressions are
/// compiled in, names in the order the file may use them (variables, derived variables,
/// parameters, `let` bindings).
struct FormReader<'a> {
    path: &'a Path,
    text: &'a str,
    scope: Scope,
}

impl FormReader<'_> {
    /// The error at byte `offset` of the file.
    fn at(&self, offset: usize, reason: String) -> Error {
        Error::at(self.path, self.text, offset, reason)
    }

    /// An expression of the file, parsed and compiled in the scope so far.
    fn compile(&mut self, value: &Spanned<String>) -> Result<(Node, usize)> {
        let (start, exact) = text_start(self.text, value);
        let place = |e: ExprError| {
            let offset = if exact { start + e.at } else { start };
            Error::at(self.path, self.text, offset, e.message)
        };
        let node = text::parse(value.get_ref()).map_err(place)?;
        let slot = self.scope.compile(&node).map_err(place)?;
        Ok((node, slot))
    }

    /// The error at `key`'s place of the file.
    fn at_key<T>(&self, key: &Spanned<T>, reason: String) -> Error {
        self.at(key.span().start, reason)
    }

    /// `[function]`, read once every name of the form is known: its name where given, and its
    /// arguments (or the table's [`TableShape::sampling`]). Refused: a name that is no identifier
    /// of every shading language, two arguments of one name, a name the form defines for
    /// something else, an axis the table has not, an axis carried twice (`alpha` and `roughness`
    /// are one), a variable no argument carries.
    fn function(&self, file: &FileText, table: &TableShape) -> Result<(Option<String>, Vec<ShaderArgument>)> {
        let Some(function) = &file.function else {
            return Ok((None, table.sampling.clone()));
        };
        let function = function.get_ref();
        let mut axes: Vec<String> = table.variables.clone();
        if table.variables.iter().any(|v| v == "alpha") {
            axes.push(ROUGHNESS.into());
        }
        let arguments = match &function.arguments {
            None => table.sampling.clone(),
            Some(list) => {
                let mut arguments: Vec<ShaderArgument> = Vec::new();
                for (k, argument) in list.get_ref().iter().enumerate() {
                    let (key, axis) = (&argument.get_ref().name, &argument.get_ref().axis);
                    let which = format!("[function] argument {}", k + 1);
                    let name = key.get_ref();
                    text::check_identifier(name)
                        .map_err(|reason| self.at_key(key, format!("`name` of {which}: {reason}")))?;
                    if let Some(j) = arguments.iter().position(|a| a.name == *name) {
                        return Err(self.at_key(
                            key,
                            format!("`name` of {which}: `{name}` names argument {} too; each argument has a name of its own", j + 1),
                        ));
                    }
                    if !axes.contains(axis.get_ref()) {
                        return Err(self.at_key(
                            axis,
                            format!(
                                "`axis` of {which}: unknown axis `{}`; allowed for table `{}`: {}{}",
                                axis.get_ref(),
                                table.name,
                                axes.join(", "),
                                if axes.iter().any(|a| a == ROUGHNESS) { " (alpha = roughness^2)" } else { "" }
                            ),
                        ));
                    }
                    let quantity = |a: &str| if a == ROUGHNESS { "alpha".to_string() } else { a.to_string() };
                    if let Some(j) = arguments.iter().position(|a| quantity(&a.axis) == quantity(axis.get_ref())) {
                        return Err(self.at_key(
                            axis,
                            format!(
                                "`axis` of {which}: `{}` is what argument {} (`{}`) carries as `{}`; each axis has one argument{}",
                                axis.get_ref(),
                                j + 1,
                                arguments[j].name,
                                arguments[j].axis,
                                if quantity(axis.get_ref()) == "alpha" { " (alpha = roughness^2: give one of them)" } else { "" }
                            ),
                        ));
                    }
                    if self.scope.names.contains_key(name) && name != axis.get_ref() {
                        return Err(self.at_key(
                            key,
                            format!(
                                "`name` of {which}: `{name}` is a variable, parameter or binding of the form; an argument is                                  named after its own axis (`{}`) or by a name the form does not define",
                                axis.get_ref()
                            ),
                        ));
                    }
                    arguments.push(ShaderArgument::new(name, axis.get_ref()));
                }
                let carried = |v: &str| arguments.iter().any(|a| a.axis == v || (v == "alpha" && a.axis == ROUGHNESS));
                if let Some(missing) = table.variables.iter().find(|v| !carried(v)) {
                    return Err(self.at_key(
                        list,
                        format!(
                            "[function] arguments: no argument carries `{missing}`; every variable of table `{}` needs one: {}{}",
                            table.name,
                            table.variables.join(", "),
                            if missing == "alpha" { " (alpha may be passed as roughness)" } else { "" }
                        ),
                    ));
                }
                arguments
            }
        };
        let name = match &function.name {
            None => None,
            Some(key) => {
                let name = key.get_ref();
                text::check_identifier(name)
                    .map_err(|reason| self.at_key(key, format!("`name` of [function]: {reason}")))?;
                if self.scope.names.contains_key(name) || arguments.iter().any(|a| a.name == *name) {
                    return Err(self.at_key(
                        key,
                        format!(
                            "`name` of [function]: `{name}` is already a variable, parameter, binding or argument of the                              form; the function needs a name of its own"
                        ),
                    ));
                }
                Some(name.clone())
            }
        };
        Ok((name, arguments))
    }

    /// A new name, refused where it is not an identifier or is already defined.
    fn check_name(&self, key: &Spanned<String>) -> Result<()> {
        text::check_identifier(key.get_ref()).map_err(|reason| self.at(key.span().start, reason))?;
        if self.scope.names.contains_key(key.get_ref()) {
            return Err(self.at(
                key.span().start,
                format!("`{}` is already defined (a variable, parameter or binding)", key.get_ref()),
            ));
        }
        Ok(())
    }

    /// The derived variables the table's variables allow, as bindings of the language itself;
    /// those the form never reads are dropped from the shader later (the tape keeps their few
    /// instructions).
    fn derived_variables(&mut self, variables: &[String]) -> Result<Vec<Binding>> {
        let mut derived = Vec::new();
        for (name, definition, needs) in DERIVED_VARIABLES {
            if needs.iter().all(|n| variables.iter().any(|v| v == n)) {
                let node = text::parse(definition).map_err(|e| Error::invalid("derived variable", e.message))?;
                let slot = self.scope.compile(&node).map_err(|e| Error::invalid("derived variable", e.message))?;
                self.scope.names.insert(name.to_string(), slot);
                derived.push(Binding { name: name.to_string(), text: definition.to_string(), node, slot });
            }
        }
        Ok(derived)
    }

    /// `[parameters]` in the file's order, each with the byte its key starts at. An empty
    /// `[parameters]` is a form with nothing to fit (a published baseline, such as thesis eq.
    /// 5.6): it is measured at its definition, and the table is still required so that every form
    /// file has the same shape.
    fn parameters(&mut self, file: &FileText) -> Result<(Vec<Parameter>, Vec<usize>)> {
        let mut parameters = Vec::new();
        let mut parameter_keys = Vec::new();
        let mut entries: Vec<_> = file.parameters.iter().collect();
        entries.sort_by_key(|(k, _)| k.span().start);
        if let Some((key, _)) = entries.get(MAX_PARAMETERS) {
            return Err(self.at(
                key.span().start,
                format!("[parameters] holds {} parameters; allowed: at most {MAX_PARAMETERS}", entries.len()),
            ));
        }
        for (k, (key, value)) in entries.into_iter().enumerate() {
            self.check_name(key)?;
            let p = value.get_ref();
            let (start, min, max) = (*p.start.get_ref(), *p.min.get_ref(), *p.max.get_ref());
            for (what, v) in [("start", &p.start), ("min", &p.min), ("max", &p.max)] {
                if !v.get_ref().is_finite() {
                    return Err(self.at(
                        v.span().start,
                        format!("`{}`'s {what} is {}; allowed: a finite number", key.get_ref(), v.get_ref()),
                    ));
                }
            }
            if min >= max {
                return Err(
                    self.at(p.min.span().start, format!("`{}`: min {min} is not below max {max}", key.get_ref()))
                );
            }
            if !(min..=max).contains(&start) {
                return Err(self.at(
                    p.start.span().start,
                    format!("`{}`: the bounds [{min}, {max}] exclude its start {start}", key.get_ref()),
                ));
            }
            let slot = self.scope.tape.push(Ins::Param(k));
            self.scope.names.insert(key.get_ref().clone(), slot);
            parameters.push(Parameter { name: key.get_ref().clone(), start, min, max });
            parameter_keys.push(key.span().start);
        }
        Ok((parameters, parameter_keys))
    }

    /// `[let]` in the file's order, each binding in scope for the next, each with the byte its
    /// key starts at.
    fn lets(&mut self, file: &FileText) -> Result<(Vec<Binding>, Vec<usize>)> {
        let mut lets = Vec::new();
        let mut entries: Vec<_> = file.lets.iter().collect();
        entries.sort_by_key(|(k, _)| k.span().start);
        let mut let_keys = Vec::new();
        for (key, value) in entries {
            self.check_name(key)?;
            let (node, slot) = self.compile(value)?;
            self.scope.names.insert(key.get_ref().clone(), slot);
            lets.push(Binding { name: key.get_ref().clone(), text: value.get_ref().clone(), node, slot });
            let_keys.push(key.span().start);
        }
        Ok((lets, let_keys))
    }

    /// `[channels]` in the table's channel order: each a channel of the table, 1 to
    /// [`MAX_CHANNELS`] of them.
    fn channels(&mut self, file: &FileText, table: &TableShape) -> Result<Vec<Binding>> {
        let table_channels: Vec<&str> = table.channels.iter().map(String::as_str).collect();
        let mut channels: Vec<(usize, Binding)> = Vec::new();
        for (key, value) in &file.channels {
            let Some(index) = table_channels.iter().position(|c| c == key.get_ref()) else {
                return Err(self.at(
                    key.span().start,
                    format!(
                        "table `{}` has no channel `{}`; its channels: {}",
                        table.name,
                        key.get_ref(),
                        table_channels.join(", ")
                    ),
                ));
            };
            let (node, slot) = self.compile(value)?;
            channels.push((index, Binding { name: key.get_ref().clone(), text: value.get_ref().clone(), node, slot }));
        }
        if channels.is_empty() || channels.len() > MAX_CHANNELS {
            return Err(self.at(
                0,
                format!(
                    "[channels] names {} channels; allowed: 1 to {MAX_CHANNELS} of table `{}`'s: {}",
                    channels.len(),
                    table.name,
                    table_channels.join(", ")
                ),
            ));
        }
        channels.sort_by_key(|(index, ..)| *index);
        Ok(channels.into_iter().map(|(_, b)| b).collect())
    }
}

/// Where an expression's text starts in the file: inside its quotes, where the string has no
/// escapes (then every byte of the expression is the file's); otherwise at the string itself.
fn text_start(file: &str, value: &Spanned<String>) -> (usize, bool) {
    let span = value.span();
    let raw = file.get(span.clone()).unwrap_or_default();
    match raw.find(value.get_ref().as_str()) {
        Some(k) => (span.start + k, true),
        None => (span.start, false),
    }
}

/// The name of a form: its file's stem with every character a shader identifier cannot hold
/// replaced by `_` (`karis-env-brdf-approx.toml` is `karis_env_brdf_approx`).
pub fn form_name(path: &Path) -> String {
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let mut name = String::new();
    for c in stem.chars() {
        let c = if c.is_ascii_alphanumeric() { c } else { '_' };
        if !(c == '_' && (name.is_empty() || name.ends_with('_'))) {
            name.push(c);
        }
    }
    let name = name.trim_end_matches('_').to_string();
    if name.is_empty() { "form".into() } else { name }
}

/// The [`form_name`] of each of `files`, refused where two files give one name (`a-b.toml` and
/// `a_b.toml`, or names that differ only in case, one folder on a case-insensitive file system):
/// each form's files go into a folder of its name, and the second would replace the first's.
pub fn distinct_form_names(files: &[std::path::PathBuf]) -> Result<Vec<String>> {
    let names: Vec<String> = files.iter().map(|f| form_name(f)).collect();
    for (i, name) in names.iter().enumerate() {
        if let Some(j) = names[..i].iter().position(|other| other.eq_ignore_ascii_case(name)) {
            return Err(Error::invalid(
                "--form",
                format!(
                    "form files {} and {} are both form `{name}` (a name as a shader identifier holds only letters, \
                     digits and `_`, and a folder name is compared without case): rename one",
                    files[j].display(),
                    files[i].display()
                ),
            ));
        }
    }
    Ok(names)
}

/// The form files (`.toml`) of the folder `dir` for table `table`, in name order, and a note for
/// each file skipped as a form of another table (`luts/forms/` holds forms of several tables). A
/// file whose table cannot be read is kept, so that reading it names the mistake; a folder with
/// no form for the table is refused.
pub fn form_files_for(dir: &Path, table: &str) -> Result<(Vec<std::path::PathBuf>, Vec<String>)> {
    let mut files: Vec<std::path::PathBuf> = std::fs::read_dir(dir)
        .map_err(|source| Error::io(dir, source))?
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    let mut skipped = Vec::new();
    files.retain(|file| {
        let named = crate::formats::read_text_at_most(file, MAX_FORM_BYTES, "form file")
            .ok()
            .and_then(|text| text.parse::<toml::Table>().ok())
            .and_then(|t| t.get("table").and_then(|v| v.as_str().map(str::to_string)));
        match named.as_deref() {
            Some(other) if other != table => {
                skipped.push(format!("skipped {}: a form for table `{other}`, not `{table}`", file.display()));
                false
            }
            _ => true,
        }
    });
    if files.is_empty() {
        return Err(Error::invalid(
            format!("--form {}", dir.display()),
            format!("a folder with no form file (.toml) for table `{table}`"),
        ));
    }
    Ok((files, skipped))
}

impl Form {
    /// Read the form file at `path` against `table` (the table file it is fitted to).
    pub fn read(path: &Path, table: &Table) -> Result<Form> {
        let text = crate::formats::read_text_at_most(path, MAX_FORM_BYTES, "form file")?;
        Form::parse(path, &text, table)
    }

    /// A form file's text, `path` naming it in errors.
    pub fn parse(path: &Path, text: &str, table: &Table) -> Result<Form> {
        let variables = table_variables(table)?;
        let shape = TableShape {
            name: table.name.clone(),
            sampling: sampling_arguments(table, &variables),
            variables,
            channels: table.channels.iter().map(|c| c.name.clone()).collect(),
        };
        Form::parse_for(path, text, &shape)
    }

    /// A form file's text read against a table's shape alone (no table file at hand: a scene's
    /// fitted TIR form), `path` naming it in errors.
    pub fn parse_for(path: &Path, text: &str, table: &TableShape) -> Result<Form> {
        let mut reader = FormReader { path, text, scope: Scope { names: BTreeMap::new(), tape: Tape::default() } };
        let file: FileText = toml::from_str(text).map_err(|e| {
            reader.at(
                e.span().map_or(0, |s| s.start),
                format!(
                    "{} (a form file has `table`, [parameters], optional [let], [channels], optional [function] with \
                     optional `name` and `arguments = [{{ name = \"...\", axis = \"...\" }}, ...]`)",
                    e.message().trim()
                ),
            )
        })?;
        if *file.table.get_ref() != table.name {
            return Err(reader.at(
                file.table.span().start,
                format!("the form is for table `{}`, and the table file holds `{}`", file.table.get_ref(), table.name),
            ));
        }
        let variables = table.variables.clone();
        for (k, v) in variables.iter().enumerate() {
            let slot = reader.scope.tape.push(Ins::Var(k));
            reader.scope.names.insert(v.clone(), slot);
        }
        let derived_all = reader.derived_variables(&variables)?;
        let (parameters, parameter_keys) = reader.parameters(&file)?;
        let (lets, let_keys) = reader.lets(&file)?;
        let channels = reader.channels(&file, table)?;
        reader.scope.tape.outputs = channels.iter().map(|b| b.slot).collect();

        for (k, used) in reader.scope.tape.parameters_used(parameters.len()).into_iter().enumerate() {
            if !used {
                return Err(reader.at(
                    parameter_keys[k],
                    format!("parameter `{}` is never used by a channel; remove it or use it", parameters[k].name),
                ));
            }
        }
        // The names any binding or channel reads: a binding none reads is a mistake (a channel
        // that was meant to use it), as an unused parameter is.
        let mut read = Vec::new();
        for binding in lets.iter().chain(&channels) {
            binding.node.names(&mut read);
        }
        for (binding, &key) in lets.iter().zip(&let_keys) {
            if !read.iter().any(|(n, _)| *n == binding.name) {
                return Err(reader.at(
                    key,
                    format!(
                        "`{}` in [let] is never used by a channel or a later binding; remove it or use it",
                        binding.name
                    ),
                ));
            }
        }
        // The derived variables any binding or channel reads.
        let derived = derived_all.into_iter().filter(|d| read.iter().any(|(n, _)| *n == d.name)).collect();
        let (function, arguments) = reader.function(&file, table)?;

        Ok(Form {
            path: path.to_path_buf(),
            name: form_name(path),
            table: table.name.clone(),
            variables,
            derived,
            parameters,
            lets,
            channels,
            tape: reader.scope.tape,
            function,
            arguments,
        })
    }

    /// The shader function's name: `[function] name`, or `tmlut_<name>`.
    pub fn function_name(&self) -> String {
        self.function.clone().unwrap_or_else(|| format!("tmlut_{}", self.name))
    }

    /// The form as text, one statement a line: what the manifest and `fit.json` state as its
    /// definition.
    pub fn definition(&self) -> Vec<String> {
        let mut lines = vec![format!("table = {}, variables: {}", self.table, self.variables.join(", "))];
        lines.extend(self.derived.iter().map(|d| format!("{} = {}", d.name, d.text)));
        lines.extend(self.lets.iter().map(|b| format!("{} = {}", b.name, b.text)));
        lines.extend(self.channels.iter().map(|b| format!("channel {} = {}", b.name, b.text)));
        lines
    }

    pub fn parameter_names(&self) -> Vec<String> {
        self.parameters.iter().map(|p| p.name.clone()).collect()
    }
}
