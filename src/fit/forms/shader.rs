//! A fitted form as shader code: one [`Module`] of the crate's emitter printed as WGSL, HLSL and
//! GLSL, and MSL written by naga's back end from that WGSL after naga has parsed and validated it.
//! The GLSL is an include file, the functions alone (no `#version`, no entry point); the
//! validation harness beside it is a GLSL 4.50 compute shader holding it and a `main` that calls
//! the form once, which naga's GLSL front end parses and validates.
//!
//! The function is [`Form::function_name`] (`[function] name`, or `tmlut_<form>`), of the
//! arguments [`Form::arguments`], returning `f32` for one channel and `vecN<f32>` for N, in the
//! table's channel order. Its body is the form's tape ([`Form::tape`], which the fit evaluates)
//! printed by the one tape printer ([`crate::ir::print`]) that prints the scene model, with the
//! form's names: each variable the argument carrying it; where an argument carries `roughness`,
//! the tape's `roughness = sqrt(alpha)` is that argument and `alpha`, where read, its square at the
//! top; the other derived variables it reads, each parameter as a local holding its fitted value
//! (f32, shortest round-trip text), each `let`, then the channels.

use super::form::{Form, ROUGHNESS, ShaderArgument};
use crate::error::{Error, Result};
use crate::ir::print::{Leaf, LeafPrinter, PrintedExprs, print};
use crate::ir::shader::validate;
use crate::ir::text::{Intrinsic, form_name};
use crate::shader::{Expr, Lang, Module, Parens, Stmt, Ty, call, float, func, let_, name};

/// The shading languages a fitted form is written in, with each file's extension.
pub const LANGUAGES: &[(&str, &str)] = &[("WGSL", "wgsl"), ("HLSL", "hlsl"), ("GLSL", "glsl"), ("MSL", "metal")];

/// The extension of the GLSL validation harness, `<form>.harness.comp` (glslang reads the stage
/// from `.comp`).
pub const GLSL_HARNESS_EXTENSION: &str = "harness.comp";

/// The shader function's name for `form` in the files `tmlut fit` writes.
pub fn function_name(form: &Form) -> String {
    form.function_name()
}

/// The name a scene shader calls `form` by ([`lookup_module`]): `tmlut_<form>`, whatever its
/// `[function]` declares.
pub fn lookup_function_name(form: &Form) -> String {
    format!("tmlut_{}", form.name)
}

const ASINH: &str = "tmlut_asinh";

fn power_helper(n: i32) -> String {
    if n < 0 { format!("tmlut_pow_m{}", n.unsigned_abs()) } else { format!("tmlut_pow_{n}") }
}

/// The leaves of a form's tape: its variables are the function's arguments (alpha the square of a
/// roughness argument), its parameters locals holding their fitted values, its derived variables
/// and `let` bindings named as written; and the helpers its expressions need: `asinh`, and `x ^ n`
/// multiplied out.
struct FormLeafPrinter<'a> {
    form: &'a Form,
    parameters: &'a [f64],
    arguments: &'a [ShaderArgument],
    asinh: bool,
    powers: Vec<i32>,
}

impl FormLeafPrinter<'_> {
    fn argument_carrying(&self, axis: &str) -> Option<&ShaderArgument> {
        self.arguments.iter().find(|a| a.axis == axis)
    }
}

impl LeafPrinter for FormLeafPrinter<'_> {
    fn leaf(&mut self, _: usize, leaf: Leaf, _: &PrintedExprs) -> Result<(Expr, Option<String>)> {
        Ok(match leaf {
            Leaf::Var(k) => {
                let variable = &self.form.variables[k];
                match (self.argument_carrying(variable), self.argument_carrying(ROUGHNESS)) {
                    (Some(argument), _) => (name(&argument.name), None),
                    (None, Some(roughness)) if variable == "alpha" => {
                        (name(&roughness.name) * name(&roughness.name), Some(variable.clone()))
                    }
                    _ => {
                        return Err(Error::invalid(
                            format!("form `{}`", self.form.name),
                            format!("no argument of its function carries `{variable}`"),
                        ));
                    }
                }
            }
            Leaf::Param(k) => (float(self.parameters[k] as f32), Some(self.form.parameters[k].name.clone())),
            Leaf::Const(v) => (float(v as f32), None),
        })
    }

    fn given(&self, i: usize) -> Option<Expr> {
        let roughness = self.argument_carrying(ROUGHNESS)?;
        let derived = self.form.derived.iter().find(|d| d.name == ROUGHNESS)?;
        (derived.slot == i).then(|| name(&roughness.name))
    }

    fn helper(&mut self, function: Intrinsic, args: Vec<Expr>) -> Result<Expr> {
        match function {
            Intrinsic::Asinh => {
                self.asinh = true;
                Ok(func(ASINH, args))
            }
            other => Err(Error::invalid(
                format!("form `{}`", self.form.name),
                format!("`{}` has no builtin and no helper", form_name(other)),
            )),
        }
    }

    fn power(&mut self, x: Expr, n: i32) -> Result<Expr> {
        if !self.powers.contains(&n) {
            self.powers.push(n);
        }
        Ok(func(&power_helper(n), vec![x]))
    }

    fn named(&self, i: usize) -> Option<String> {
        let form = self.form;
        form.derived.iter().chain(&form.lets).find(|b| b.slot == i).map(|b| b.name.clone())
    }

    fn out_of_order(&self, i: usize) -> Error {
        Error::invalid(format!("form `{}`", self.form.name), format!("its tape reads instruction {i} before it"))
    }
}

/// The fitted form as the module `tmlut fit` prints: helpers first, then the function of the
/// form's name and arguments ([`Form::function_name`], [`Form::arguments`]).
pub fn module(form: &Form, parameters: &[f64]) -> Result<Module> {
    module_with(form, parameters, &form.function_name(), &form.arguments)
}

/// The fitted form as a scene shader prints it: `tmlut_<form>` of the table's lookup variables,
/// as the model evaluates it and as the scene calls it, whatever its `[function]` declares.
pub fn lookup_module(form: &Form, parameters: &[f64]) -> Result<Module> {
    let arguments: Vec<ShaderArgument> = form.variables.iter().map(|v| ShaderArgument::new(v, v)).collect();
    module_with(form, parameters, &lookup_function_name(form), &arguments)
}

/// `arguments` in words, where a name does not say the quantity: `NoV is mu, roughness is
/// sqrt(alpha)`; `None` where every argument is the variable of its name.
fn arguments_in_words(form: &Form, arguments: &[ShaderArgument]) -> Option<String> {
    let plain = arguments.iter().all(|a| a.name == a.axis && form.variables.contains(&a.axis));
    let quantity = |a: &ShaderArgument| if a.axis == ROUGHNESS { "sqrt(alpha)".to_string() } else { a.axis.clone() };
    (!plain).then(|| arguments.iter().map(|a| format!("{} is {}", a.name, quantity(a))).collect::<Vec<_>>().join(", "))
}

fn module_with(form: &Form, parameters: &[f64], function: &str, arguments: &[ShaderArgument]) -> Result<Module> {
    let mut leaves = FormLeafPrinter { form, parameters, arguments, asinh: false, powers: Vec::new() };
    let mut body = Vec::new();
    let printed = print(&form.tape, &form.tape.outputs, &mut leaves, &mut body)?;
    let channels: Vec<Expr> = form
        .tape
        .outputs
        .iter()
        .map(|&k| printed.get(k).ok_or_else(|| leaves.out_of_order(k)))
        .collect::<Result<_>>()?;
    let returns = if channels.len() == 1 { Ty::F32 } else { Ty::Vec(channels.len() as u8) };
    let result = if channels.len() == 1 { channels[0].clone() } else { Expr::Construct(returns.clone(), channels) };
    body.push(Stmt::Return(result));

    let mut m = Module::new(Parens::Minimal);
    let mut header = format!(
        "Form file {} fitted to table '{}'; returns {} in that order.\n",
        form.path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
        form.table,
        form.channels.iter().map(|c| c.name.as_str()).collect::<Vec<_>>().join(", "),
    );
    if let Some(words) = arguments_in_words(form, arguments) {
        header.push_str(&format!("Arguments: {words}.\n"));
    }
    for line in form.definition() {
        header.push_str(&format!("  {line}\n"));
    }
    m.comment(header.trim_end());
    if leaves.asinh {
        // asinh(x) = sign(x) ln(|x| + sqrt(x^2 + 1)), odd by construction, so that large negative
        // arguments do not cancel.
        let x = name("x");
        let a = name("a");
        m.function(
            ASINH,
            vec![("x", Ty::F32)],
            Ty::F32,
            vec![
                let_("a", Ty::F32, x.clone().abs()),
                Stmt::Return(
                    call(Intrinsic::Sign, vec![x])
                        * call(Intrinsic::Log, vec![a.clone() + (a.clone() * a + float(1.0)).sqrt()]),
                ),
            ],
        );
    }
    leaves.powers.sort_unstable();
    for &n in &leaves.powers {
        let mut product = float(1.0);
        for k in 0..n.unsigned_abs() {
            product = if k == 0 { name("x") } else { product * name("x") };
        }
        let result = if n < 0 { float(1.0) / product } else { product };
        m.function(&power_helper(n), vec![("x", Ty::F32)], Ty::F32, vec![Stmt::Return(result)]);
    }
    let params: Vec<(&str, Ty)> = arguments.iter().map(|a| (a.name.as_str(), Ty::F32)).collect();
    m.function(function, params, returns, body);
    Ok(m)
}

/// A fitted form's shader files' texts.
pub struct FormSources {
    pub wgsl: String,
    pub hlsl: String,
    /// The include file: the functions alone.
    pub glsl: String,
    /// The compute shader that holds [`FormSources::glsl`] and calls the form: what naga
    /// validated, and what glslang compiles (`scripts/gpu-check`).
    pub glsl_harness: String,
    pub msl: String,
}

impl FormSources {
    /// Each file of the set, named for form `form_name`: `<form>.<extension>` in [`LANGUAGES`]
    /// order, then the harness, `<form>.harness.comp`.
    pub fn files(&self, form_name: &str) -> Vec<(String, &str)> {
        let texts = [&self.wgsl, &self.hlsl, &self.glsl, &self.msl];
        let mut files: Vec<(String, &str)> =
            LANGUAGES.iter().zip(texts).map(|((_, ext), text)| (format!("{form_name}.{ext}"), text.as_str())).collect();
        files.push((format!("{form_name}.{GLSL_HARNESS_EXTENSION}"), &self.glsl_harness));
        files
    }

    /// The text of the file in `language` ([`LANGUAGES`]' extension).
    pub fn text(&self, extension: &str) -> Option<&str> {
        Some(match extension {
            "wgsl" => &self.wgsl,
            "hlsl" => &self.hlsl,
            "glsl" => &self.glsl,
            "metal" => &self.msl,
            _ => return None,
        })
    }
}

/// The GLSL validation harness: `#version 450`, the include file's text where `#include
/// "<include>"` would put it, then a compute `main` calling `function` once at 0.5 for each of its
/// `arguments`.
fn glsl_harness(include: &str, glsl: &str, function: &str, arguments: usize, channels: usize) -> String {
    let returns = if channels == 1 { "float".to_string() } else { format!("vec{channels}") };
    let call = vec!["0.5"; arguments].join(", ");
    format!(
        "#version 450\n// The validation harness of {include}: its text below, as `#include \"{include}\"` puts it, then a\n\
         // compute entry point calling {function} once.\n{glsl}\nlayout(local_size_x = 1) in;\nvoid main() {{\n    \
         {returns} value = {function}({call});\n}}\n"
    )
}

/// The form's code in every language of [`LANGUAGES`] and the GLSL harness. The WGSL (with a
/// compute entry point calling the function once) and the GLSL harness are validated by naga;
/// MSL is naga's translation of the validated WGSL module.
pub fn sources(form: &Form, parameters: &[f64]) -> Result<FormSources> {
    let m = module(form, parameters)?;
    let function = form.function_name();
    let (wgsl, hlsl, glsl) = (m.print(Lang::Wgsl), m.print(Lang::Hlsl), m.print(Lang::Glsl));
    let refused = |what: &str, e: String| Error::invalid("form shader", format!("naga refused the {what}: {e}"));
    let arguments = vec!["0.5"; form.arguments.len()].join(", ");
    let with_entry =
        format!("{wgsl}\n@compute @workgroup_size(1)\nfn main() {{\n    _ = {function}({arguments});\n}}\n");
    let (module, info) = validate::wgsl(&with_entry).map_err(|e| refused("WGSL", e))?;
    let include = format!("{}.glsl", form.name);
    let glsl_harness = glsl_harness(&include, &glsl, &function, form.arguments.len(), form.channels.len());
    validate::glsl(&glsl_harness, naga::ShaderStage::Compute).map_err(|e| refused("GLSL", e))?;
    let msl_options = naga::back::msl::Options { lang_version: (2, 1), ..naga::back::msl::Options::default() };
    let (msl, _) =
        naga::back::msl::write_string(&module, &info, &msl_options, &naga::back::msl::PipelineOptions::default())
            .map_err(|e| refused("MSL translation", e.to_string()))?;
    Ok(FormSources { wgsl, hlsl, glsl, glsl_harness, msl })
}
