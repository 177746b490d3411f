//! The transfer-matrix model and its random walk at the stiff stacks of the evaluator: index-matched
//! layers, a lower index below (TIR), huge kappa, empty and very thick media, media that do not
//! scatter or scatter almost straight on or back, smooth and fully rough interfaces, grazing and
//! normal views, and one to eight layers. Every lobe and albedo must be finite, and no stack may
//! create energy: the model's `A(mu)` at most 1, the random walk's within three standard errors
//! of 1.

use super::properties::{Check, at_most, finite, within};
use super::{Case, Report};
use crate::exact::ExactTables;
use crate::model::{FluxModel, Interface, Layer, Lookup, Material, Medium, Quantity, Stack, Tables};
use crate::random_walk::{WalkSettings, directional_albedo};

/// View cosines: the horizon, a rounding step above it, grazing, middle, the normal.
const VIEWS: [f64; 5] = crate::model::STIFF_VIEWS;

fn dielectric(eta: f64, alpha: f64) -> Layer {
    Layer::Interface(Interface { eta: [eta; 3], kappa: [0.0; 3], alpha })
}

fn conductor(eta: f64, kappa: f64, alpha: f64) -> Layer {
    Layer::Interface(Interface { eta: [eta; 3], kappa: [kappa, 0.5 * kappa, 0.1 * kappa], alpha })
}

fn medium(sigma_s: f64, sigma_k: f64, depth: f64, g: f64) -> Layer {
    Layer::Medium(Medium { sigma_s: [sigma_s; 3], sigma_k: [sigma_k, 2.0 * sigma_k, 0.0], depth, g })
}

/// The stiff stacks, named.
pub fn stacks() -> Vec<(&'static str, Vec<Layer>)> {
    let copper = conductor(0.2, 3.0, 0.1);
    vec![
        ("a bare conductor", vec![copper]),
        ("an index-matched coat", vec![dielectric(1.0, 0.3), copper]),
        ("a coat of index 1 + 1e-6", vec![dielectric(1.0 + 1e-6, 0.3), copper]),
        ("a lower index below (TIR going down)", vec![dielectric(0.5, 0.2), conductor(0.3, 2.0, 0.2)]),
        ("a huge kappa", vec![dielectric(1.5, 0.2), conductor(1.0, 1e4, 0.0)]),
        ("smooth interfaces", vec![dielectric(1.5, 0.0), dielectric(2.0, 0.0), conductor(0.2, 3.0, 0.0)]),
        ("fully rough interfaces", vec![dielectric(1.5, 1.0), conductor(0.2, 3.0, 1.0)]),
        ("an empty medium", vec![dielectric(1.5, 0.1), medium(0.0, 0.0, 1.0, 0.0), copper]),
        ("a medium of depth 0", vec![dielectric(1.5, 0.1), medium(1.0, 1.0, 0.0, 0.5), copper]),
        ("a very thick absorbing medium", vec![dielectric(1.5, 0.1), medium(0.0, 1.0, 1e6, 0.0), copper]),
        ("a very thick scattering medium", vec![dielectric(1.5, 0.1), medium(1.0, 1e-3, 1e6, 0.5), copper]),
        ("a medium that only scatters", vec![dielectric(1.5, 0.1), medium(2.0, 0.0, 1.0, 0.3), copper]),
        ("g = 0.999", vec![dielectric(1.5, 0.2), medium(1.0, 0.1, 1.0, 0.999), copper]),
        ("g = -0.999", vec![dielectric(1.5, 0.2), medium(1.0, 0.1, 1.0, -0.999), copper]),
        (
            "no conductor (light leaves below)",
            vec![dielectric(1.5, 0.3), medium(0.5, 0.1, 1.0, 0.5), dielectric(1.2, 0.1)],
        ),
        ("8 layers", {
            let mut layers: Vec<Layer> =
                (0..7).map(|k| dielectric(if k % 2 == 0 { 1.5 } else { 1.2 }, 0.02 * k as f64)).collect();
            layers.push(copper);
            layers
        }),
    ]
}

/// Tables at the edges of what they can answer: every TIR 1 (nothing crosses toward a lower index),
/// every albedo 1 or 0, GD 0 or 1.
fn stiff_tables(albedo: f64, tir: f64, gd: f64) -> impl Fn(&Lookup) -> f64 {
    move |lookup: &Lookup| match lookup.quantity {
        Quantity::Albedo => albedo,
        Quantity::Tir => tir,
        Quantity::Gd => gd,
    }
}

/// Evaluate the model at every stiff stack, view and flux model, with exact integrals and with
/// tables at their edges; and the random walk (with few paths) at every stack and view.
pub fn run(report: &mut Report) -> crate::error::Result<()> {
    let exact = ExactTables::new(&crate::config::Config::default(), crate::exact::DEFAULT_NODES)?;
    let edges: [(&str, Box<dyn Tables>); 3] = [
        ("TIR = 1, FGD = 1, GD = 0", Box::new(stiff_tables(1.0, 1.0, 0.0))),
        ("TIR = 1, FGD = 0, GD = 1", Box::new(stiff_tables(0.0, 1.0, 1.0))),
        ("TIR = 0, FGD = 1, GD = 1", Box::new(stiff_tables(1.0, 0.0, 1.0))),
    ];
    let walk = WalkSettings { min_paths: 2048, max_paths: 4096, ..WalkSettings::default() };
    for (name, layers) in stacks() {
        let stack = Stack::new(layers).expect("the stiff stacks are valid");
        for model in [FluxModel::TwoFlux, FluxModel::SixFlux] {
            let material = Material::new(model, stack.clone());
            for mu in VIEWS {
                let parameters = format!("{name}, mu={mu}");
                let evaluation = material.evaluate(mu, &exact);
                let mut case = Case::new(
                    format!("model {} (exact integrals)", model.name()),
                    parameters.clone(),
                    format!("A = {:?}", evaluation.albedo),
                );
                case = with_finite_lobes(case, &evaluation);
                for a in evaluation.albedo {
                    case = case.with(at_most("no energy created", a, 1.0, 1e-9)).with(within("A >= 0", a, -1e-9, 2.0));
                }
                report.cases.push(case);
                for (tables, answers) in &edges {
                    let evaluation = material.evaluate(mu, answers.as_ref());
                    let case = Case::new(
                        format!("model {} ({tables})", model.name()),
                        parameters.clone(),
                        format!("A = {:?}", evaluation.albedo),
                    );
                    report.cases.push(with_finite_lobes(case, &evaluation));
                }
            }
        }
        for mu in VIEWS {
            let estimate = directional_albedo(&stack, mu, &walk);
            let mut case = Case::new(
                "random walk",
                format!("{name}, mu={mu}"),
                format!(
                    "A = {:?} ± {:?} ({} paths)",
                    estimate.reflected, estimate.reflected_standard_error, estimate.paths
                ),
            );
            for (a, se) in estimate.reflected.iter().zip(estimate.reflected_standard_error) {
                case = case.with(finite(*a)).with(at_most("no energy created (3 s.e.)", *a, 1.0, 3.0 * se + 1e-12));
            }
            report.cases.push(case);
        }
    }
    Ok(())
}

fn with_finite_lobes(case: Case, evaluation: &crate::model::Evaluation) -> Case {
    let values =
        evaluation.albedo.iter().copied().chain(
            evaluation.lobes.iter().flat_map(|l| l.energy.iter().copied().chain([l.asymmetry, l.roughness, l.gd])),
        );
    let bad = values.clone().filter(|v| !v.is_finite()).count();
    let count = values.count();
    case.with(Check::new("finite", bad == 0, format!("{bad} of {count} lobe and albedo values not finite")))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `luts/scenes/gpu-check/stiff-stacks.toml`, which `scripts/gpu-check` runs on the GPU API,
    /// holds these stacks in both flux models, in order, but for the two values a scene does not
    /// admit: kappas scaled to at most 100 (the matrix's huge kappa is 1e4), a depth of 1e-30 for
    /// its 0.
    #[test]
    fn the_gpu_checks_stiff_scene_holds_the_stiff_stacks() {
        let text = include_str!("../../luts/scenes/gpu-check/stiff-stacks.toml");
        let scene = crate::scene::Scene::from_toml(text, "stiff-stacks.toml", "stiff-stacks").unwrap();
        let as_a_scene_admits = |layer: &Layer| match *layer {
            Layer::Interface(i) => {
                let scale = (100.0 / i.kappa.iter().copied().fold(0.0, f64::max)).min(1.0);
                Layer::Interface(Interface { kappa: i.kappa.map(|k| k * scale), ..i })
            }
            Layer::Medium(m) => Layer::Medium(Medium { depth: if m.depth == 0.0 { 1e-30 } else { m.depth }, ..m }),
        };
        let mut expected = Vec::new();
        for model in [FluxModel::TwoFlux, FluxModel::SixFlux] {
            for (_, layers) in stacks() {
                expected.push((model, layers.iter().map(as_a_scene_admits).collect::<Vec<_>>()));
            }
        }
        let found: Vec<(FluxModel, Vec<Layer>)> =
            scene.materials.iter().map(|m| (m.model, m.stack().unwrap().layers().to_vec())).collect();
        assert_eq!(found, expected);
    }
}
