//! A fitted form as shader code: one [`Module`] of the crate's emitter printed as WGSL and HLSL,
//! and GLSL and MSL written by naga's back ends from that WGSL after naga has parsed and
//! validated it.
//!
//! The function is `tmlut_<form>(variables...)`, returning `f32` for one channel and `vecN<f32>`
//! for N, in the table's channel order. Its body is the form's tape ([`Form::tape`], which the fit
//! evaluates) printed by the one tape printer ([`crate::ir::print`]) that prints the scene
//! model, with the form's names: the derived variables it reads, each parameter as a local holding
//! its fitted value (f32, shortest round-trip text), each `let`, then the channels.

use super::form::Form;
use crate::error::{Error, Result};
use crate::ir::print::{Leaf, LeafPrinter, PrintedExprs, print};
use crate::ir::text::{Intrinsic, form_name};
use crate::shader::{Expr, Lang, Module, Parens, Stmt, Ty, call, float, func, let_, name};

/// The shading languages a fitted form is written in, with each file's extension.
pub const LANGUAGES: &[(&str, &str)] = &[("WGSL", "wgsl"), ("HLSL", "hlsl"), ("GLSL", "glsl"), ("MSL", "metal")];

/// The shader function's name for `form`.
pub fn function_name(form: &Form) -> String {
    format!("tmlut_{}", form.name)
}

const ASINH: &str = "tmlut_asinh";

fn power_helper(n: i32) -> String {
    if n < 0 { format!("tmlut_pow_m{}", n.unsigned_abs()) } else { format!("tmlut_pow_{n}") }
}

/// The leaves of a form's tape: its variables are the function's arguments, its parameters locals
/// holding their fitted values, its derived variables and `let` bindings named as written; and the
/// helpers its expressions need: `asinh`, and `x ^ n` multiplied out.
struct FormLeafPrinter<'a> {
    form: &'a Form,
    parameters: &'a [f64],
    asinh: bool,
    powers: Vec<i32>,
}

impl LeafPrinter for FormLeafPrinter<'_> {
    fn leaf(&mut self, _: usize, leaf: Leaf, _: &PrintedExprs) -> Result<(Expr, Option<String>)> {
        Ok(match leaf {
            Leaf::Var(k) => (name(&self.form.variables[k]), None),
            Leaf::Param(k) => (float(self.parameters[k] as f32), Some(self.form.parameters[k].name.clone())),
            Leaf::Const(v) => (float(v as f32), None),
        })
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

/// The fitted form as a module: helpers first, then `tmlut_<form>`.
pub fn module(form: &Form, parameters: &[f64]) -> Result<Module> {
    let mut leaves = FormLeafPrinter { form, parameters, asinh: false, powers: Vec::new() };
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
    let params: Vec<(&str, Ty)> = form.variables.iter().map(|v| (v.as_str(), Ty::F32)).collect();
    m.function(&function_name(form), params, returns, body);
    Ok(m)
}

/// The form's code in every language of [`LANGUAGES`], in that order. The WGSL is validated by
/// naga, and GLSL and MSL are naga's translations of the validated module; GLSL needs an entry
/// point, so its file is a compute shader whose `main` calls the function once.
pub fn sources(form: &Form, parameters: &[f64]) -> Result<Vec<String>> {
    let m = module(form, parameters)?;
    let (wgsl, hlsl) = (m.print(Lang::Wgsl), m.print(Lang::Hlsl));
    let refused = |what: &str, e: String| Error::invalid("form shader", format!("naga refused the {what}: {e}"));
    let arguments = vec!["0.5"; form.variables.len()].join(", ");
    let with_entry = format!(
        "{wgsl}\n@compute @workgroup_size(1)\nfn main() {{\n    _ = {}({arguments});\n}}\n",
        function_name(form)
    );
    let module =
        naga::front::wgsl::parse_str(&with_entry).map_err(|e| refused("WGSL", e.emit_to_string(&with_entry)))?;
    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .map_err(|e| refused("WGSL", e.emit_to_string(&with_entry)))?;

    let mut glsl = String::new();
    let options = naga::back::glsl::Options {
        version: naga::back::glsl::Version::Desktop(450),
        ..naga::back::glsl::Options::default()
    };
    let pipeline = naga::back::glsl::PipelineOptions {
        shader_stage: naga::ShaderStage::Compute,
        entry_point: "main".into(),
        multiview: None,
    };
    naga::back::glsl::Writer::new(&mut glsl, &module, &info, &options, &pipeline, Default::default())
        .and_then(|mut w| w.write().map(|_| ()))
        .map_err(|e| refused("GLSL translation", e.to_string()))?;
    let msl_options = naga::back::msl::Options { lang_version: (2, 1), ..naga::back::msl::Options::default() };
    let (msl, _) =
        naga::back::msl::write_string(&module, &info, &msl_options, &naga::back::msl::PipelineOptions::default())
            .map_err(|e| refused("MSL translation", e.to_string()))?;
    Ok(vec![wgsl, hlsl, glsl, msl])
}
