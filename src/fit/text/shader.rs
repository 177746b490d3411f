//! A fitted form as shader code: one [`Module`] of the crate's emitter printed as WGSL and HLSL,
//! and GLSL and MSL written by naga's back ends from that WGSL after naga has parsed and
//! validated it.
//!
//! The function is `tmlut_<form>(variables...)`, returning `f32` for one channel and `vecN<f32>`
//! for N, in the table's channel order. Its body states the form as written: the derived
//! variables it reads, each parameter as a local holding its fitted value (f32, shortest
//! round-trip text), each `let`, then the channels.

use super::expr::{BinOp, Compare, Func, Node};
use super::form::{Form, integer_exponent};
use crate::error::{Error, Result};
use crate::shader::{Builtin, Expr, Lang, Module, Op, Parens, Stmt, Ty, call, f, func, let_, name, select};

/// The shading languages a fitted form is written in, with each file's extension.
pub const LANGUAGES: &[(&str, &str)] = &[("WGSL", "wgsl"), ("HLSL", "hlsl"), ("GLSL", "glsl"), ("MSL", "metal")];

/// The shader function's name for `form`.
pub fn function_name(form: &Form) -> String {
    format!("tmlut_{}", form.name)
}

/// The shader builtin of a function of the language; `None` for `asinh`, which HLSL lacks.
pub(crate) fn builtin(f: Func) -> Option<Builtin> {
    Some(match f {
        Func::Abs => Builtin::Abs,
        Func::Sign => Builtin::Sign,
        Func::Min => Builtin::Min,
        Func::Max => Builtin::Max,
        Func::Clamp => Builtin::Clamp,
        Func::Saturate => Builtin::Saturate,
        Func::Floor => Builtin::Floor,
        Func::Fract => Builtin::Fract,
        Func::Sqrt => Builtin::Sqrt,
        Func::Rsqrt => Builtin::InverseSqrt,
        Func::Exp => Builtin::Exp,
        Func::Exp2 => Builtin::Exp2,
        Func::Log => Builtin::Log,
        Func::Log2 => Builtin::Log2,
        Func::Pow => Builtin::Pow,
        Func::Sin => Builtin::Sin,
        Func::Cos => Builtin::Cos,
        Func::Tan => Builtin::Tan,
        Func::Asin => Builtin::Asin,
        Func::Acos => Builtin::Acos,
        Func::Atan => Builtin::Atan,
        Func::Atan2 => Builtin::Atan2,
        Func::Sinh => Builtin::Sinh,
        Func::Cosh => Builtin::Cosh,
        Func::Tanh => Builtin::Tanh,
        Func::Smoothstep => Builtin::Smoothstep,
        Func::Step => Builtin::Step,
        Func::Mix => Builtin::Mix,
        // HLSL has no asinh: a helper function of the module ([`ASINH`]).
        Func::Asinh => return None,
    })
}

/// The shader operator of a comparison.
pub(crate) fn comparison(compare: Compare) -> Op {
    match compare {
        Compare::Lt => Op::Lt,
        Compare::Le => Op::Le,
        Compare::Gt => Op::Gt,
        Compare::Ge => Op::Ge,
        Compare::Eq => Op::Eq,
        Compare::Ne => Op::Ne,
    }
}

const ASINH: &str = "tmlut_asinh";

fn power_helper(n: i32) -> String {
    if n < 0 { format!("tmlut_pow_m{}", n.unsigned_abs()) } else { format!("tmlut_pow_{n}") }
}

/// The helpers an expression needs: `asinh`, and `x ^ n` multiplied out.
#[derive(Default)]
struct Helpers {
    asinh: bool,
    powers: Vec<i32>,
}

fn translate(node: &Node, helpers: &mut Helpers) -> Expr {
    match node {
        Node::Number(v) => f(*v as f32),
        Node::Name(n, _) => name(n),
        Node::Neg(a) => -translate(a, helpers),
        Node::Binary(BinOp::Pow, a, b) => match integer_exponent(b) {
            Some(n) => {
                if !helpers.powers.contains(&n) {
                    helpers.powers.push(n);
                }
                func(&power_helper(n), vec![translate(a, helpers)])
            }
            None => call(Builtin::Pow, vec![translate(a, helpers), translate(b, helpers)]),
        },
        Node::Binary(op, a, b) => {
            let (a, b) = (translate(a, helpers), translate(b, helpers));
            match op {
                BinOp::Add => a + b,
                BinOp::Sub => a - b,
                BinOp::Mul => a * b,
                BinOp::Div => a / b,
                BinOp::Pow => unreachable!("handled above"),
            }
        }
        Node::Call(function, args) => {
            let args: Vec<Expr> = args.iter().map(|a| translate(a, helpers)).collect();
            match builtin(*function) {
                Some(b) => call(b, args),
                None => {
                    helpers.asinh = true;
                    func(ASINH, args)
                }
            }
        }
        Node::Select { otherwise, then, compare, left, right } => {
            let condition = translate(left, helpers).op(comparison(*compare), translate(right, helpers));
            select(condition, translate(then, helpers), translate(otherwise, helpers))
        }
    }
}

/// The fitted form as a module: helpers first, then `tmlut_<form>`.
pub fn module(form: &Form, parameters: &[f64]) -> Module {
    let mut helpers = Helpers::default();
    let mut body = Vec::new();
    for d in &form.derived {
        body.push(let_(&d.name, Ty::F32, translate(&d.node, &mut helpers)));
    }
    for (p, &v) in form.parameters.iter().zip(parameters) {
        body.push(let_(&p.name, Ty::F32, f(v as f32)));
    }
    for b in &form.lets {
        body.push(let_(&b.name, Ty::F32, translate(&b.node, &mut helpers)));
    }
    let channels: Vec<Expr> = form.channels.iter().map(|c| translate(&c.node, &mut helpers)).collect();
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
    if helpers.asinh {
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
                    call(Builtin::Sign, vec![x])
                        * call(Builtin::Log, vec![a.clone() + (a.clone() * a + f(1.0)).sqrt()]),
                ),
            ],
        );
    }
    helpers.powers.sort_unstable();
    for &n in &helpers.powers {
        let mut product = f(1.0);
        for k in 0..n.unsigned_abs() {
            product = if k == 0 { name("x") } else { product * name("x") };
        }
        let result = if n < 0 { f(1.0) / product } else { product };
        m.function(&power_helper(n), vec![("x", Ty::F32)], Ty::F32, vec![Stmt::Return(result)]);
    }
    let params: Vec<(&str, Ty)> = form.variables.iter().map(|v| (v.as_str(), Ty::F32)).collect();
    m.function(&function_name(form), params, returns, body);
    m
}

/// The form's code in every language of [`LANGUAGES`], in that order. The WGSL is validated by
/// naga, and GLSL and MSL are naga's translations of the validated module; GLSL needs an entry
/// point, so its file is a compute shader whose `main` calls the function once.
pub fn sources(form: &Form, parameters: &[f64]) -> Result<Vec<String>> {
    let m = module(form, parameters);
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
