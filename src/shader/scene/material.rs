//! A material's function: the transfer-matrix model itself ([`crate::model::Material::evaluate`])
//! recorded ([`crate::fit::text::record`]) over the material's stack and flux model, then printed.
//! The view cosine is the recorded code's variable 0 and each table lookup the model makes is a
//! variable after it, printed as the read of the table the folder answers it with
//! ([`Generator::albedo`], [`Generator::tir`], [`Generator::gd`]). Everything the stack alone
//! decides (which layers count, every index, roughness and medium coefficient) was computed in
//! f64 while recording, as the CPU evaluator computes it, and is printed as a constant; what the
//! view decides is a `select`.

use std::cell::RefCell;

use super::super::{Expr, Function, Stmt, Ty, assign, call, f, func, let_, name, select, vec3};
use super::{Generator, ShaderMaterial};
use crate::error::{Error, Result};
use crate::fit::text::expr::BinOp;
use crate::fit::text::record::{Recorded, record};
use crate::fit::text::shader::{builtin, comparison};
use crate::fit::text::tape::{Ins, Scalar, Tape, reads};
use crate::model::{Evaluation, FluxModel, Lookup, Material, Quantity, Stack, Tables};

/// A material's model as recorded code: its evaluation at the view cosine (the tape's variable 0),
/// the lookups it reads (variable `1 + k` is lookup `k`), and the tape.
pub struct RecordedMaterial {
    pub evaluation: Evaluation<Recorded>,
    pub lookups: Vec<Lookup<Recorded>>,
    pub tape: Tape,
}

impl RecordedMaterial {
    /// The model of `stack` under `model`, recorded.
    pub fn of(model: FluxModel, stack: &Stack) -> Self {
        let material = Material::new(model, stack.clone());
        let lookups: RefCell<Vec<Lookup<Recorded>>> = RefCell::new(Vec::new());
        let tables = |lookup: &Lookup<Recorded>| {
            let mut lookups = lookups.borrow_mut();
            let k = lookups.iter().position(|l| l == lookup).unwrap_or_else(|| {
                lookups.push(*lookup);
                lookups.len() - 1
            });
            Recorded::variable(1 + k)
        };
        let (evaluation, tape) = record(|| material.evaluate(Recorded::variable(0), &tables as &dyn Tables<Recorded>));
        RecordedMaterial { evaluation, lookups: lookups.into_inner(), tape }
    }

    /// The recorded code run in `T` (f32 as a shader runs it) at view cosine `mu`, each lookup
    /// answered by `tables` at its coordinates in `T`: the albedo, and per lobe its energy,
    /// roughness and GD.
    pub fn run<T: Scalar>(&self, mu: T, tables: &dyn Tables) -> RunResult<T> {
        let mut values = Vec::with_capacity(self.tape.ins.len());
        self.tape.values_with(
            |k, values: &[T]| {
                if k == 0 {
                    return mu;
                }
                let l = &self.lookups[k - 1];
                let at = |r: Recorded| r.known_value().unwrap_or_else(|| values[r.instruction()].to_f64());
                let lookup = Lookup {
                    quantity: l.quantity,
                    site: l.site,
                    layer: l.layer,
                    channel: l.channel,
                    mu: at(l.mu),
                    alpha: at(l.alpha),
                    eta: at(l.eta),
                    kappa: at(l.kappa),
                };
                T::of(tables.value(&lookup))
            },
            &mut values,
        );
        let value = |r: Recorded| r.known_value().map_or_else(|| values[r.instruction()], T::of);
        let e = &self.evaluation;
        RunResult {
            albedo: e.albedo.map(value),
            lobes: e.lobes.iter().map(|l| (l.energy.map(value), value(l.roughness), value(l.gd))).collect(),
        }
    }
}

/// What [`RecordedMaterial::run`] computes.
#[derive(Debug, Clone, PartialEq)]
pub struct RunResult<T> {
    pub albedo: [T; 3],
    /// Per lobe: energy, roughness, GD.
    pub lobes: Vec<([T; 3], T, T)>,
}

/// The function of material `m` and its lobe count.
pub(super) fn function(g: &mut Generator, m: &ShaderMaterial) -> Result<(Function, usize)> {
    let recorded = RecordedMaterial::of(m.model, &m.stack);
    let e = &recorded.evaluation;
    let mut outputs: Vec<(Expr, Vec<Recorded>)> = Vec::new();
    let field = |f: &str| name("result").member(f);
    for (k, lobe) in e.lobes.iter().enumerate() {
        outputs.push((field("lobe_energy").index(k), lobe.energy.to_vec()));
        outputs.push((field("lobe_roughness").index(k), vec![lobe.roughness]));
        outputs.push((field("lobe_cos").index(k), vec![lobe.mean_direction[2]]));
        outputs.push((field("lobe_gd").index(k), vec![lobe.gd]));
    }
    outputs.push((field("top_albedo"), e.top_albedo.to_vec()));
    outputs.push((field("albedo"), e.albedo.to_vec()));
    let roots: Vec<Recorded> = outputs.iter().flat_map(|(_, values)| values.iter().copied()).collect();
    let mut body = vec![
        Stmt::Comment(format!(
            "The {} model of this stack, recorded from tmlut's CPU evaluator: constants are the stack's,\n\
             v0 is the view cosine, each texture read a lookup of the model.",
            m.model.name()
        )),
        Stmt::Var { name: "result".into(), ty: Ty::Named("TmResult".into()), value: None },
    ];
    let printed = print(g, m, &recorded, &roots, &mut body)?;
    let value = |r: &Recorded| printed.value(*r);
    for (target, values) in &outputs {
        let v: Vec<Expr> = values.iter().map(value).collect::<Result<_>>()?;
        let v = match <[Expr; 3]>::try_from(v) {
            Ok([x, y, z]) => vec3(x, y, z),
            Err(mut single) => single.remove(0),
        };
        body.push(assign(target.clone(), v));
    }
    body.push(Stmt::Return(name("result")));
    let function = Function {
        name: super::material_function(&m.name),
        params: vec![("mu_in".into(), Ty::F32)],
        returns: Ty::Named("TmResult".into()),
        body,
    };
    Ok((function, e.lobes.len()))
}

/// The instructions' expressions as printed: a name for each bound with `let`, the expression
/// itself for those used once, inline.
struct Printed {
    exprs: Vec<Option<Expr>>,
    material: String,
}

impl Printed {
    fn value(&self, r: Recorded) -> Result<Expr> {
        match r.known_value() {
            Some(v) => constant(v, &self.material),
            None => self.instruction(r.instruction()),
        }
    }

    /// Instruction `k`, printed before what reads it (the tape's order).
    fn instruction(&self, k: usize) -> Result<Expr> {
        self.exprs[k].clone().ok_or_else(|| {
            Error::invalid(
                format!("tmlut shader, material `{}`", self.material),
                format!("its recorded model reads instruction {k} before it is printed"),
            )
        })
    }
}

/// A constant as an f32 literal (past f32's range the largest finite f32, as [`f`] prints every
/// constant); refused where it is NaN, which no stack of valid layers gives.
fn constant(v: f64, material: &str) -> Result<Expr> {
    if v.is_nan() {
        return Err(Error::invalid(
            format!("tmlut shader, material `{material}`"),
            "its model computes NaN from the stack's constants alone",
        ));
    }
    Ok(f(v as f32))
}

/// Print the instructions `roots` depend on into `body`, in the tape's order: a lookup and an
/// instruction read more than once as `let v<i>`, the others inline where they are read.
fn print(
    g: &mut Generator,
    m: &ShaderMaterial,
    recorded: &RecordedMaterial,
    roots: &[Recorded],
    body: &mut Vec<Stmt>,
) -> Result<Printed> {
    let tape = &recorded.tape;
    let n = tape.ins.len();
    // What an instruction reads: a lookup, its coordinates that depend on the view.
    let operands = |i: usize| -> Vec<usize> {
        match tape.ins[i] {
            Ins::Var(k) if k > 0 => {
                let l = &recorded.lookups[k - 1];
                [l.mu, l.alpha, l.eta, l.kappa]
                    .iter()
                    .filter(|r| r.known_value().is_none())
                    .map(|r| r.instruction())
                    .collect()
            }
            ref ins => reads(ins),
        }
    };
    // Which instructions are read, and how often.
    let mut uses = vec![0usize; n];
    let mut live = vec![false; n];
    for r in roots.iter().filter(|r| r.known_value().is_none()) {
        live[r.instruction()] = true;
        uses[r.instruction()] += 1;
    }
    for i in (0..n).rev() {
        if live[i] {
            for k in operands(i) {
                live[k] = true;
                uses[k] += 1;
            }
        }
    }
    let mut printed = Printed { exprs: vec![None; n], material: m.name.clone() };
    for i in 0..n {
        if !live[i] {
            continue;
        }
        let x = |k: usize| printed.instruction(k);
        let (expr, bind) = match tape.ins[i] {
            Ins::Const(v) => (constant(v, &m.name)?, false),
            Ins::Var(0) => (name("mu_in"), false),
            Ins::Var(k) => (lookup(g, m, &recorded.lookups[k - 1], &printed)?, true),
            Ins::Neg(a) => (-x(a)?, uses[i] > 1),
            Ins::Bin(op, a, b) => {
                let (a, b) = (x(a)?, x(b)?);
                let e = match op {
                    BinOp::Add => a + b,
                    BinOp::Sub => a - b,
                    BinOp::Mul => a * b,
                    BinOp::Div => a / b,
                    BinOp::Pow => func("pow", vec![a, b]),
                };
                (e, uses[i] > 1)
            }
            Ins::Call(function, _) => {
                let args: Vec<Expr> = operands(i).into_iter().map(x).collect::<Result<_>>()?;
                let Some(b) = builtin(function) else {
                    return Err(
                        g.refuse(&m.name, format!("its model calls `{}`, which has no builtin", function.name()))
                    );
                };
                (call(b, args), uses[i] > 1)
            }
            Ins::Select { otherwise, then, compare, left, right } => {
                (select(x(left)?.op(comparison(compare), x(right)?), x(then)?, x(otherwise)?), uses[i] > 1)
            }
            Ins::Param(_) | Ins::PowInt(..) => {
                return Err(g.refuse(&m.name, "its recorded model holds a form's instruction".into()));
            }
        };
        printed.exprs[i] = Some(if bind {
            let variable = format!("v{i}");
            body.push(let_(&variable, Ty::F32, expr));
            name(&variable)
        } else {
            expr
        });
    }
    Ok(printed)
}

/// The read answering lookup `l`, its coordinates as printed so far.
fn lookup(g: &mut Generator, m: &ShaderMaterial, l: &Lookup<Recorded>, printed: &Printed) -> Result<Expr> {
    let baked = |v: Recorded, what: &str| {
        v.known_value()
            .ok_or_else(|| g.refuse(&m.name, format!("its model reads a table at a {what} that depends on the view")))
    };
    match l.quantity {
        Quantity::Albedo => {
            let (alpha, eta, kappa) = (baked(l.alpha, "roughness")?, baked(l.eta, "index")?, baked(l.kappa, "index")?);
            g.albedo(m, printed.value(l.mu)?, alpha, eta, kappa)
        }
        Quantity::Tir => {
            let eta = baked(l.eta, "index")?;
            g.tir(m, printed.value(l.mu)?, printed.value(l.alpha)?, eta)
        }
        Quantity::Gd => g.gd(m, printed.value(l.mu)?, printed.value(l.alpha)?),
    }
}

#[cfg(test)]
mod tests {
    use super::RecordedMaterial;
    use crate::model::{FluxModel, Interface, Layer, Lookup, Material, Medium, Quantity, STIFF_VIEWS, Stack};
    use crate::physics::fresnel_reflectance;

    /// Smooth tables with every quantity in [0, 1] and depending on every coordinate.
    fn tables(l: &Lookup) -> f64 {
        match l.quantity {
            Quantity::Albedo => fresnel_reflectance(l.mu, l.eta, l.kappa) * (1.0 - 0.5 * l.alpha) + 0.05 * l.alpha,
            Quantity::Tir => ((1.0 - l.eta).max(0.0) * (1.0 - l.mu) * (0.5 + l.alpha)).clamp(0.0, 1.0),
            Quantity::Gd => 1.0 - 0.3 * l.alpha * (1.0 - l.mu),
        }
    }

    /// The largest differences between the recorded model run in `T` and the CPU evaluator, over
    /// every stiff stack of the stability matrix and thick scattering media, both flux models, and
    /// views from the horizon to the normal: of the albedo and lobe energies, and of the lobes'
    /// roughness and GD weighed by their energy (a lobe's shape is a ratio of its energy's
    /// increments, ill-conditioned where it carries almost nothing, and then it weighs almost
    /// nothing).
    fn largest_differences<T: crate::fit::text::tape::Scalar>() -> [(f64, String); 2] {
        let mut worst = [(0.0f64, String::new()), (0.0f64, String::new())];
        let views: Vec<f64> = STIFF_VIEWS.iter().copied().chain((1..20).map(|k| k as f64 / 20.0)).collect();
        let mut stacks = crate::stability::model::stacks();
        // Thick media whose slabs reach the exponent limit, the asymmetry's slab twice it.
        let coat = Layer::Interface(Interface { eta: [1.5; 3], kappa: [0.0; 3], alpha: 0.2 });
        let copper = Layer::Interface(Interface { eta: [0.2, 0.9, 1.1], kappa: [3.0, 2.6, 2.3], alpha: 0.1 });
        for g in [-0.999, -0.5, -0.3, 0.0, 0.9] {
            let thick = Layer::Medium(Medium { sigma_s: [2.0, 1.0, 0.5], sigma_k: [0.05, 0.1, 0.0], depth: 100.0, g });
            stacks.push(("a thick scattering medium", vec![coat, thick, copper]));
        }
        for (name, layers) in stacks {
            let stack = Stack::new(layers).expect("a valid stack");
            for model in [FluxModel::TwoFlux, FluxModel::SixFlux] {
                let recorded = RecordedMaterial::of(model, &stack);
                let cpu = Material::new(model, stack.clone());
                for &mu in &views {
                    let expected = cpu.evaluate(mu, &tables);
                    let run = recorded.run(T::of(mu), &tables);
                    assert_eq!(run.lobes.len(), expected.lobes.len(), "{name}, {}", model.name());
                    let mut pairs: Vec<(usize, f64, f64)> =
                        expected.albedo.iter().zip(&run.albedo).map(|(&e, r)| (0, e, r.to_f64())).collect();
                    for (lobe, (energy, roughness, gd)) in expected.lobes.iter().zip(&run.lobes) {
                        pairs.extend(lobe.energy.iter().zip(energy).map(|(&e, r)| (0, e, r.to_f64())));
                        let weight = lobe.energy.iter().fold(0.0f64, |a, &e| a.max(e.abs())).min(1.0);
                        pairs.push((1, lobe.roughness * weight, roughness.to_f64() * weight));
                        pairs.push((1, lobe.gd * weight, gd.to_f64() * weight));
                    }
                    for (k, (kind, e, r)) in pairs.into_iter().enumerate() {
                        assert!(r.is_finite(), "{name}, {}, mu = {mu}: {r}", model.name());
                        if (e - r).abs() > worst[kind].0 {
                            let at = format!("{name}, {}, mu = {mu}, value {k}: {e} against {r}", model.name());
                            worst[kind] = ((e - r).abs(), at);
                        }
                    }
                }
            }
        }
        worst
    }

    #[test]
    fn the_recorded_model_run_in_f64_is_the_cpu_evaluator() {
        for (difference, at) in largest_differences::<f64>() {
            assert!(difference <= 1e-12, "{difference} at {at}");
        }
    }

    #[test]
    fn the_recorded_model_run_in_f32_as_a_shader_runs_it_stays_within_f32_rounding_of_the_cpu_evaluator() {
        let [(energy, energy_at), (shape, shape_at)] = largest_differences::<f32>();
        eprintln!("largest differences in f32: energy {energy} at {energy_at}; shape {shape} at {shape_at}");
        // Measured: energy 6.7e-6 (a very thick scattering medium at mu = 0.001); shape 3.5e-4 (a
        // lobe of energy 1e-3 under a thick scattering medium at the horizon).
        assert!(energy <= 5e-5, "{energy} at {energy_at}");
        assert!(shape <= 2e-3, "{shape} at {shape_at}");
    }
}
