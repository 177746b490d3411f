//! A material's function: the transfer-matrix model itself ([`crate::model::Material::evaluate`])
//! recorded ([`crate::ir::record`]) over the material's stack and flux model, then printed.
//! The view cosine is the recorded code's variable 0 and each table lookup the model makes is a
//! variable after it, printed as the read of the table the folder answers it with
//! ([`Generator::read`]). Everything the stack alone
//! decides (which layers count, every index, roughness and medium coefficient) was computed in
//! f64 while recording, as the CPU evaluator computes it, and is printed as a constant; what the
//! view decides is a `select`.

use std::cell::RefCell;

use super::super::{Expr, Function, Stmt, Ty, assign, float, name, vec3};
use super::{Generator, ShaderMaterial};
use crate::error::{Error, Result};
use crate::ir::print::{Leaf, LeafPrinter, PrintedExprs, print};
use crate::ir::record::{Recorded, record};
use crate::ir::tape::{Ins, Tape, reads};
use crate::ir::text::Intrinsic;
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
    let unknown: Vec<usize> = roots.iter().filter(|r| r.known_value().is_none()).map(|r| r.instruction()).collect();
    let mut leaves = MaterialLeaves { generator: g, material: m, recorded: &recorded };
    let printed = print(&recorded.tape, &unknown, &mut leaves, &mut body)?;
    for (target, values) in &outputs {
        let v: Vec<Expr> = values.iter().map(|r| value(&printed, *r, &m.name)).collect::<Result<_>>()?;
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

/// Recorded value `r` as printed: a constant, or its instruction.
fn value(printed: &PrintedExprs, r: Recorded, material: &str) -> Result<Expr> {
    match r.known_value() {
        Some(v) => constant(v, material),
        None => printed.get(r.instruction()).ok_or_else(|| out_of_order(material, r.instruction())),
    }
}

fn out_of_order(material: &str, k: usize) -> Error {
    Error::invalid(
        format!("tmlut shader, material `{material}`"),
        format!("its recorded model reads instruction {k} before it is printed"),
    )
}

/// A constant as an f32 literal (past f32's range the largest finite f32, as [`float`] prints every
/// constant); refused where it is NaN, which no stack of valid layers gives.
fn constant(v: f64, material: &str) -> Result<Expr> {
    if v.is_nan() {
        return Err(Error::invalid(
            format!("tmlut shader, material `{material}`"),
            "its model computes NaN from the stack's constants alone",
        ));
    }
    Ok(float(v as f32))
}

/// The leaves of a material's recorded model: the view cosine `mu_in`, each lookup the read of
/// its table (bound with `let`, as a texture read is worth naming), constants as f32 literals.
struct MaterialLeaves<'a, 'g> {
    generator: &'a mut Generator<'g>,
    material: &'a ShaderMaterial,
    recorded: &'a RecordedMaterial,
}

impl LeafPrinter for MaterialLeaves<'_, '_> {
    /// A lookup reads its coordinates that depend on the view.
    fn operands(&self, tape: &Tape, i: usize) -> Vec<usize> {
        match tape.ins[i] {
            Ins::Var(k) if k > 0 => {
                let l = &self.recorded.lookups[k - 1];
                [l.mu, l.alpha, l.eta, l.kappa]
                    .iter()
                    .filter(|r| r.known_value().is_none())
                    .map(|r| r.instruction())
                    .collect()
            }
            ref ins => reads(ins),
        }
    }

    fn leaf(&mut self, i: usize, leaf: Leaf, printed: &PrintedExprs) -> Result<(Expr, Option<String>)> {
        let m = self.material;
        match leaf {
            Leaf::Const(v) => Ok((constant(v, &m.name)?, None)),
            Leaf::Var(0) => Ok((name("mu_in"), None)),
            Leaf::Var(k) => {
                Ok((lookup(self.generator, m, &self.recorded.lookups[k - 1], printed)?, Some(format!("v{i}"))))
            }
            Leaf::Param(_) => Err(self.generator.refuse(&m.name, "its recorded model holds a form's parameter".into())),
        }
    }

    fn helper(&mut self, function: Intrinsic, _: Vec<Expr>) -> Result<Expr> {
        let reason = format!("its model calls `{}`, which has no builtin", function.wgsl_name());
        Err(self.generator.refuse(&self.material.name, reason))
    }

    fn power(&mut self, _: Expr, _: i32) -> Result<Expr> {
        Err(self.generator.refuse(&self.material.name, "its recorded model holds a form's power".into()))
    }

    fn out_of_order(&self, i: usize) -> Error {
        out_of_order(&self.material.name, i)
    }
}

/// The read answering lookup `l`, its coordinates as printed so far. The index is the stack's,
/// and so is an interface's roughness for its albedo; a lobe's roughness may depend on the view.
fn lookup(g: &mut Generator, m: &ShaderMaterial, l: &Lookup<Recorded>, printed: &PrintedExprs) -> Result<Expr> {
    let baked = |v: Recorded, what: &str| {
        v.known_value()
            .ok_or_else(|| g.refuse(&m.name, format!("its model reads a table at a {what} that depends on the view")))
    };
    let (eta, kappa) = (baked(l.eta, "index")?, baked(l.kappa, "index")?);
    let known_alpha = match l.quantity {
        Quantity::Albedo => Some(baked(l.alpha, "roughness")?),
        Quantity::Tir | Quantity::Gd => None,
    };
    let at = |r: Recorded| value(printed, r, &m.name);
    g.read(m, l.quantity, (at(l.mu)?, at(l.alpha)?), known_alpha, (eta, kappa))
}

#[cfg(test)]
mod tests {
    use super::RecordedMaterial;
    use crate::ir::record::Recorded;
    use crate::ir::tape::Scalar;
    use crate::model::{FluxModel, Interface, Layer, Lookup, Material, Medium, Quantity, STIFF_VIEWS, Stack, Tables};
    use crate::physics::fresnel_reflectance;

    /// The recorded code run in `T` (f32 as a shader runs it) at view cosine `mu`, each lookup
    /// answered by `tables` at its coordinates in `T`: the albedo, and per lobe its energy,
    /// roughness and GD.
    fn run<T: Scalar>(recorded: &RecordedMaterial, mu: T, tables: &dyn Tables) -> RunResult<T> {
        let mut values = Vec::with_capacity(recorded.tape.ins.len());
        recorded.tape.values_with(
            |k, values: &[T]| {
                if k == 0 {
                    return mu;
                }
                let l = &recorded.lookups[k - 1];
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
        let e = &recorded.evaluation;
        RunResult {
            albedo: e.albedo.map(value),
            lobes: e.lobes.iter().map(|l| (l.energy.map(value), value(l.roughness), value(l.gd))).collect(),
        }
    }

    /// What [`run`] computes.
    #[derive(Debug, Clone, PartialEq)]
    struct RunResult<T> {
        albedo: [T; 3],
        /// Per lobe: energy, roughness, GD.
        lobes: Vec<([T; 3], T, T)>,
    }

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
    fn largest_differences<T: Scalar>() -> [(f64, String); 2] {
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
                    let run = run(&recorded, T::of(mu), &tables);
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
