//! A material's layers as the shader generator sees them, and the code both flux models share:
//! each layer's transfer factors ([`crate::model::factors`]), the first-order transmission
//! asymmetries with the TIR correction ([`crate::model::tm2::transmission_asymmetries`]), and
//! what a function does with its lobes and its result.
//!
//! Which kind of component each layer is (passed over, dielectric, conductor, medium) depends on
//! the stack alone, not on the view, so it is decided here and the code is unrolled for it; the
//! factors, which depend on the view, are computed in the shader.

use super::super::{Expr, Function, Op, Stmt, Ty, assign, f, func, let_, name, select, var, vec3};
use super::{Generator, ShaderMaterial, v3};
use crate::error::Result;
use crate::model::factors::{EXPONENT_LIMIT, INDEX_MATCHED, NEARLY_INDEX_MATCHED};
use crate::model::{FluxModel, Layer, Medium};
use crate::physics::{ggx_to_hg, hg_backward_share};

/// What one layer is to the model (`model::factors::Component`), known before the view is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Component {
    /// An index-matched interface, or a medium that changes nothing.
    Pass,
    /// Relative index (channel mean) and roughness.
    Dielectric { eta: f64, alpha: f64 },
    /// Relative indices per channel and roughness.
    Conductor { eta: [f64; 3], kappa: [f64; 3], alpha: f64 },
    /// The medium as the model evaluates it: without scattering in the 2-flux model.
    Medium(Medium),
}

/// The components of `m`'s reachable layers, top first (`model::factors::components`).
pub(super) fn components(m: &ShaderMaterial) -> Vec<Component> {
    let scattering = m.model == FluxModel::SixFlux;
    let mut eta_above = [1.0f64; 3];
    m.stack
        .reachable_layers()
        .iter()
        .map(|layer| match layer {
            Layer::Interface(i) if i.is_conductor() => Component::Conductor {
                eta: std::array::from_fn(|c| i.eta[c] / eta_above[c]),
                kappa: std::array::from_fn(|c| i.kappa[c] / eta_above[c]),
                alpha: i.alpha,
            },
            Layer::Interface(i) => {
                let eta = (0..3).map(|c| i.eta[c] / eta_above[c]).sum::<f64>() / 3.0;
                eta_above = i.eta;
                if (eta - 1.0).abs() < INDEX_MATCHED {
                    Component::Pass
                } else {
                    Component::Dielectric { eta, alpha: i.alpha }
                }
            }
            Layer::Medium(md) => {
                let medium = Medium { sigma_s: if scattering { md.sigma_s } else { [0.0; 3] }, ..*md };
                let empty = medium.sigma_s.iter().chain(&medium.sigma_k).all(|&s| s == 0.0);
                if medium.depth == 0.0 || empty { Component::Pass } else { Component::Medium(medium) }
            }
        })
        .collect()
}

/// What a dielectric's first-order terms need of the components below it (`model::below`): the
/// asymmetry of the next reflecting interface (1 where none), the media crossed to reach it
/// (their forward asymmetries are computed in the shader), and whether anything below sends
/// light back up.
pub(super) struct Below {
    pub reflection_g: f64,
    pub media: Vec<usize>,
    pub returns_light: bool,
}

/// [`Below`] for component `index` of `components`. A medium sends light back where it scatters
/// backward in some channel (`sigma_s` times the backward share of its phase function above 0).
pub(super) fn below(components: &[Component], index: usize) -> Below {
    let mut media = Vec::new();
    let mut scatters = false;
    for (k, component) in components.iter().enumerate().skip(index + 1) {
        match component {
            Component::Pass => {}
            Component::Medium(md) => {
                media.push(k);
                scatters |= md.sigma_s.iter().any(|&s| s * hg_backward_share(md.g) > 0.0);
            }
            Component::Dielectric { alpha, .. } | Component::Conductor { alpha, .. } => {
                return Below { reflection_g: ggx_to_hg(*alpha), media, returns_light: true };
            }
        }
    }
    Below { reflection_g: 1.0, media, returns_light: scatters }
}

/// The variable prefix of component `index`'s values: `l<layer>_`.
pub(super) fn prefix(index: usize) -> String {
    format!("l{}_", index + 1)
}

/// The start of every material's function: the view cosine clamped, the cosine of the lobe
/// travelling down (`cos_in`, updated at each dielectric), and the zeroed result.
pub(super) fn prologue() -> Vec<Stmt> {
    vec![
        Stmt::Comment("The view cosine, clamped as the CPU evaluator clamps it.".into()),
        let_("mu", Ty::F32, name("mu_in").clamp(f(0.0), f(1.0))),
        var("cos_in", Ty::F32, name("mu")),
        Stmt::Var { name: "result".into(), ty: Ty::Named("TmResult".into()), value: None },
    ]
}

/// The transfer factors of every component at the view (`model::factors::components`), top
/// first, each in variables of its prefix: a dielectric's incident and refracted cosines
/// (`cos_in`, `cos_below`), its albedo and the asymmetries of its rough transmissions before
/// the first-order terms (`t_g0`, `tp_g0`); a conductor's albedo per channel (`base`); a medium's
/// factors ([`medium_factors`]).
/// What every material function starts with, whichever flux model: the stack's components, and
/// a body that clamps the view cosine and computes every component's factors.
pub(super) fn begin(g: &mut Generator, m: &ShaderMaterial) -> Result<(Vec<Component>, Vec<Stmt>)> {
    let components = components(m);
    let mut body = prologue();
    body.extend(factors(g, m, &components)?);
    Ok((components, body))
}

/// `var <name>: <matrix> = <identity>();`: a transfer matrix that starts as the identity.
pub(super) fn identity_matrix(name: &str, matrix: &str, identity: &str) -> Stmt {
    Stmt::Var { name: name.into(), ty: Ty::Named(matrix.into()), value: Some(func(identity, vec![])) }
}

pub(super) fn factors(g: &mut Generator, m: &ShaderMaterial, components: &[Component]) -> Result<Vec<Stmt>> {
    let mut body = Vec::new();
    for (index, component) in components.iter().enumerate() {
        let p = prefix(index);
        let n = |s: &str| name(&format!("{p}{s}"));
        match *component {
            Component::Pass => {}
            Component::Dielectric { eta, alpha } => {
                body.push(Stmt::Comment(format!("Layer {}: a dielectric interface, relative index {eta}.", index + 1)));
                body.push(let_(&format!("{p}cos_in"), Ty::F32, name("cos_in")));
                body.push(let_(
                    &format!("{p}cos_below"),
                    Ty::F32,
                    func("tmh_refracted_cosine", vec![name("cos_in"), f(eta as f32)]),
                ));
                let albedo = if (eta - 1.0).abs() < NEARLY_INDEX_MATCHED {
                    f(0.0)
                } else {
                    g.albedo(m, name("cos_in"), alpha, eta, 0.0)?
                };
                body.push(let_(&format!("{p}albedo"), Ty::F32, albedo));
                // Fake rough transmissions (`factors::dielectric`): the lobe's roughness scaled as a
                // refracted ray's angular spread.
                let (t_g, tp_g) = if alpha == 0.0 {
                    let g = f(ggx_to_hg(0.0) as f32);
                    (g.clone(), g)
                } else {
                    (
                        func(
                            "tmh_transmission_g",
                            vec![name("cos_in") / f(eta as f32) - n("cos_below"), n("cos_below"), f(alpha as f32)],
                        ),
                        func(
                            "tmh_transmission_g",
                            vec![name("cos_in") - f(eta as f32) * n("cos_below"), name("cos_in"), f(alpha as f32)],
                        ),
                    )
                };
                body.push(let_(&format!("{p}t_g0"), Ty::F32, t_g));
                body.push(let_(&format!("{p}tp_g0"), Ty::F32, tp_g));
                body.push(assign(name("cos_in"), n("cos_below")));
            }
            Component::Conductor { eta, kappa, alpha } => {
                body.push(Stmt::Comment(format!("Layer {}: a conductor.", index + 1)));
                let channels: Vec<Expr> =
                    (0..3).map(|c| g.albedo(m, name("cos_in"), alpha, eta[c], kappa[c])).collect::<Result<_>>()?;
                let [r, gr, b]: [Expr; 3] = channels.try_into().unwrap_or_else(|_| unreachable!("three channels"));
                body.push(let_(&format!("{p}base"), Ty::Vec(3), vec3(r, gr, b)));
            }
            Component::Medium(medium) => {
                body.push(Stmt::Comment(format!("Layer {}: a medium.", index + 1)));
                body.extend(medium_factors(&p, &medium, m.model == FluxModel::SixFlux));
            }
        }
    }
    Ok(body)
}

/// A medium's factors at the cosine `cos_in` of the lobe crossing it (`factors::medium`): the
/// primary flux's transmission `t = exp(-sigma_ext tau)`, `tau` the path along the lobe cut where
/// `sigma_ext tau` would pass the exponent limit; with `scattering` (6-flux) also the secondary
/// flux's backward reflection `r_fb` and forward transmission `t_ff` per channel and their
/// asymmetries `r_fb_g`, `t_ff_g` (channel means of the ratios of the asymmetry slab to the energy
/// slab). The coefficients are folded to constants.
fn medium_factors(p: &str, medium: &Medium, scattering: bool) -> Vec<Stmt> {
    let n = |s: &str| name(&format!("{p}{s}"));
    let (sigma_s, sigma_k, g) = (medium.sigma_s, medium.sigma_k, medium.g);
    let backward = hg_backward_share(g);
    let sigma_sb: [f64; 3] = std::array::from_fn(|c| sigma_s[c] * backward);
    let sigma_sf: [f64; 3] = std::array::from_fn(|c| sigma_s[c] - sigma_sb[c]);
    let sigma_ext: [f64; 3] = std::array::from_fn(|c| sigma_s[c] + sigma_k[c]);
    let gamma: [f64; 3] = std::array::from_fn(|c| (sigma_k[c] * (2.0 * sigma_sb[c] + sigma_k[c])).sqrt());
    let largest = |v: &[f64; 3]| v.iter().copied().fold(0.0, f64::max);
    let mut tau_limit = f64::INFINITY;
    for v in [&gamma, &sigma_ext] {
        if largest(v) > 0.0 {
            tau_limit = tau_limit.min(EXPONENT_LIMIT / largest(v));
        }
    }
    let limit = f(tau_limit as f32);
    let constant = |v: [f64; 3]| vec3(f(v[0] as f32), f(v[1] as f32), f(v[2] as f32));
    let mut body = vec![
        let_(
            &format!("{p}tau"),
            Ty::F32,
            select(name("cos_in").gt(f(0.0)), (f(medium.depth as f32) / name("cos_in")).min(limit.clone()), limit),
        ),
        let_(&format!("{p}t"), Ty::Vec(3), func("exp", vec![-constant(sigma_ext) * v3(n("tau"))])),
    ];
    if !scattering {
        return body;
    }
    let lanes = ["x", "y", "z"];
    for c in 0..3 {
        // Energy: a = sigma_sb + sigma_k, b = sigma_sb; asymmetry: a_g = sigma_ext - sigma_sf g,
        // b_g = -sigma_sb g, a_g^2 - b_g^2 given factored as in `factors::medium`.
        let product = (sigma_ext[c] - g * (sigma_sf[c] - sigma_sb[c])) * (sigma_ext[c] - g * sigma_s[c]);
        for (suffix, a, b, gamma) in [
            ("", sigma_sb[c] + sigma_k[c], sigma_sb[c], gamma[c]),
            ("g_", sigma_ext[c] - sigma_sf[c] * g, -sigma_sb[c] * g, product.max(0.0).sqrt()),
        ] {
            body.push(let_(
                &format!("{p}slab_{suffix}{}", lanes[c]),
                Ty::Vec(2),
                func("tmh_slab", vec![f(a as f32), f(b as f32), f(gamma as f32), n("tau")]),
            ));
        }
    }
    let per_lane = |component: &str| {
        vec3(n("slab_x").member(component), n("slab_y").member(component), n("slab_z").member(component))
    };
    let mean_ratio = |component: &str| {
        lanes
            .iter()
            .map(|c| {
                func(
                    "tmh_safe_ratio",
                    vec![n(&format!("slab_g_{c}")).member(component), n(&format!("slab_{c}")).member(component)],
                )
            })
            .reduce(|a, b| a + b)
            .expect("three lanes")
            / f(3.0)
    };
    body.extend([
        let_(&format!("{p}r_fb"), Ty::Vec(3), per_lane("x")),
        let_(&format!("{p}t_ff"), Ty::Vec(3), per_lane("y")),
        let_(&format!("{p}r_fb_g"), Ty::F32, mean_ratio("x")),
        let_(&format!("{p}t_ff_g"), Ty::F32, mean_ratio("y")),
    ]);
    body
}

/// The first-order transmission asymmetries of dielectric `p` for one flux (prefix `q`) and its
/// TIR correction (`tm2::transmission_asymmetries`): declares `{q}r`, `{q}t`, `{q}rp`, `{q}tp`
/// (energies), `{q}t_g`, `{q}tp_g` (the transmissions' asymmetry ratios), and sets the variable
/// `g_arriving` to the asymmetry of the lobe transmitted below. `g_next` is the asymmetry a lobe
/// keeps when reflected below.
#[allow(clippy::too_many_arguments)]
pub(super) fn transmission_asymmetries(
    g: &mut Generator,
    m: &ShaderMaterial,
    p: &str,
    q: &str,
    eta: f64,
    g_arriving: &str,
    g_next: Expr,
    light_returns: bool,
) -> Result<Vec<Stmt>> {
    let n = |s: &str| name(&format!("{p}{s}"));
    let o = |s: &str| name(&format!("{q}{s}"));
    let declare = |s: &str| format!("{q}{s}");
    let mut body = vec![
        var(&declare("r"), Ty::F32, n("albedo")),
        var(&declare("t"), Ty::F32, f(1.0) - n("albedo")),
        var(&declare("rp"), Ty::F32, n("albedo")),
        var(&declare("tp"), Ty::F32, f(1.0) - n("albedo")),
        let_(
            &declare("g_below"),
            Ty::F32,
            func("tmh_hg_refract", vec![name(g_arriving), f((1.0 / eta) as f32)]) * n("t_g0"),
        ),
        let_(&declare("g_reflected_below"), Ty::F32, o("g_below") * g_next),
        let_(
            &declare("g_back_up"),
            Ty::F32,
            func("tmh_hg_refract", vec![o("g_reflected_below"), f(eta as f32)]) * n("tp_g0"),
        ),
        let_(&declare("t_g"), Ty::F32, select(name(g_arriving).ne(f(0.0)), o("g_below") / name(g_arriving), f(0.0))),
        let_(
            &declare("tp_g"),
            Ty::F32,
            select(o("g_reflected_below").ne(f(0.0)), o("g_back_up") / o("g_reflected_below"), f(0.0)),
        ),
    ];
    // The share of the transmitted lobe past the critical angle moves from transmission to
    // reflection on the side toward the lower index.
    let crossing = if eta < 1.0 {
        Some((n("cos_in"), name(g_arriving), eta, "r", "t"))
    } else if light_returns {
        Some((n("cos_below"), o("g_reflected_below"), 1.0 / eta, "rp", "tp"))
    } else {
        None
    };
    if let Some((mu, g_lobe, eta_crossed, r, t)) = crossing {
        let share = g.tir(m, mu, func("tmh_hg_to_ggx", vec![g_lobe]), eta_crossed)?;
        body.push(let_(&declare(&format!("moved_{t}")), Ty::F32, share * o(t)));
        body.push(assign(o(r), o(r) + o(&format!("moved_{t}"))));
        body.push(assign(o(t), o(t) - o(&format!("moved_{t}"))));
    }
    body.push(assign(name(g_arriving), o("g_below")));
    Ok(body)
}

/// Store lobe `k`, whose energy the caller declared as `{lp}energy`: the energy, the GGX roughness
/// of its asymmetry, its cosine (the view's: a lobe's mean direction is the mirror of the view, or
/// of its mirror image). Every lobe but the top one reads GD at its roughness where it carries
/// energy (`Material::evaluate`); returns the statements and the variable holding that GD (0 for
/// the top lobe).
pub(super) fn store_lobe(
    g: &mut Generator,
    m: &ShaderMaterial,
    lp: &str,
    k: usize,
    asymmetry: Expr,
    is_top: bool,
) -> Result<(Vec<Stmt>, Expr)> {
    let n = |s: &str| name(&format!("{lp}{s}"));
    let mut body = vec![
        let_(&format!("{lp}roughness"), Ty::F32, func("tmh_hg_to_ggx", vec![asymmetry])),
        assign(name("result").member("lobe_energy").index(k), n("energy")),
        assign(name("result").member("lobe_roughness").index(k), n("roughness")),
        assign(name("result").member("lobe_cos").index(k), name("mu")),
    ];
    if is_top {
        return Ok((body, f(0.0)));
    }
    let gd = g.gd(m, name("mu"), n("roughness"))?;
    body.push(let_(&format!("{lp}gd"), Ty::F32, select(has_energy(n("energy")), gd, f(0.0))));
    body.push(assign(name("result").member("lobe_gd").index(k), n("gd")));
    Ok((body, n("gd")))
}

/// Whether any channel of `energy` is not 0.
pub(super) fn has_energy(energy: Expr) -> Expr {
    energy
        .clone()
        .member("x")
        .ne(f(0.0))
        .op(Op::Or, energy.clone().member("y").ne(f(0.0)))
        .op(Op::Or, energy.member("z").ne(f(0.0)))
}

/// Material `m`'s function, `tm_<material>(mu_in) -> TmResult`, from its body and its top
/// term's albedo ([`epilogue`]).
pub(super) fn finish(m: &ShaderMaterial, mut body: Vec<Stmt>, top: Option<Expr>) -> Function {
    body.extend(epilogue(top));
    Function {
        name: super::material_function(&m.name),
        params: vec![("mu_in".into(), Ty::F32)],
        returns: Ty::Named("TmResult".into()),
        body,
    }
}

/// The end of every material's function: the top term's albedo (`top`, where the top interface
/// reflects) added to the lobes' in `result.albedo`.
pub(super) fn epilogue(top: Option<Expr>) -> Vec<Stmt> {
    let mut body = Vec::new();
    if let Some(top) = top {
        body.push(assign(name("result").member("top_albedo"), top));
        body.push(assign(
            name("result").member("albedo"),
            name("result").member("albedo") + name("result").member("top_albedo"),
        ));
    }
    body.push(Stmt::Return(name("result")));
    body
}
