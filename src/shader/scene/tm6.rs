//! A material's function in the 6-flux model ([`crate::model::tm6`]): a primary flux as in the
//! 2-flux model and a secondary one, scattered by the media, split into forward and backward
//! parts. Energy and asymmetry matrices are kept per channel (the lanes of a `vec3` per entry);
//! after each component the stack's three reflectances give up to three lobes, as increments.

use super::super::{Expr, Function, Stmt, Ty, assign, f, func, let_, name, select, var};
use super::layers::{self, Component};
use super::{Generator, ShaderMaterial, v3};
use crate::error::Result;
use crate::model::tm6::Requested;
use crate::physics::ggx_to_hg;

/// The function of material `m` and its lobe count.
pub(super) fn function(g: &mut Generator, m: &ShaderMaterial) -> Result<(Function, usize)> {
    let (components, mut body) = layers::begin(g, m)?;
    let matrix = |n: &str| layers::identity_matrix(n, "TmMatrix6", "tm6_identity");
    let reflectances = |n: &str| Stmt::Var { name: n.into(), ty: Ty::Named("TmReflect6".into()), value: None };
    body.extend([
        Stmt::Comment(
            "The energy and asymmetry matrices (per channel, in the lanes), the reflectances above, and\n\
             the asymmetries of the primary and secondary lobes transmitted down."
                .into(),
        ),
        matrix("energy"),
        matrix("asym"),
        reflectances("r_above"),
        reflectances("g_above"),
        var("g_primary", Ty::F32, f(1.0)),
        var("g_secondary", Ty::F32, f(1.0)),
    ]);
    let mut requested = Requested::default();
    let mut lobes = 0usize;
    let mut top = None;
    for (index, component) in components.iter().enumerate() {
        let p = layers::prefix(index);
        let n = |s: &str| name(&format!("{p}{s}"));
        let mut top_reflection = None;
        let base: Option<(Expr, Expr)> = match *component {
            Component::Pass => continue,
            Component::Dielectric { eta, alpha } => {
                // The secondary factors start as copies of the primary ones and get their own
                // first-order asymmetries and TIR; a scattered lobe reflected below crosses the
                // media between twice.
                let below = layers::below(&components, index);
                let reflection_g = f(below.reflection_g as f32);
                body.extend(layers::transmission_asymmetries(
                    g,
                    m,
                    &p,
                    &p,
                    eta,
                    "g_primary",
                    reflection_g.clone(),
                    below.returns_light,
                )?);
                let media_g = below
                    .media
                    .iter()
                    .map(|&k| name(&format!("{}t_ff_g", layers::prefix(k))))
                    .reduce(|a, b| a * b)
                    .unwrap_or(f(1.0));
                let secondary = format!("{p}s_");
                body.extend(layers::transmission_asymmetries(
                    g,
                    m,
                    &p,
                    &secondary,
                    eta,
                    "g_secondary",
                    media_g.clone() * reflection_g * media_g,
                    below.returns_light,
                )?);
                requested.add_interface();
                let g_alpha = f(ggx_to_hg(alpha) as f32);
                let s = |x: &str| name(&format!("{secondary}{x}"));
                let interface = |entries: [Expr; 8]| func("tm6_interface", entries.into_iter().map(v3).collect());
                body.push(assign(
                    name("energy"),
                    func(
                        "tm6_then_interface",
                        vec![
                            name("energy"),
                            interface([n("r"), n("t"), n("rp"), n("tp"), s("r"), s("t"), s("rp"), s("tp")]),
                        ],
                    ),
                ));
                body.push(assign(
                    name("asym"),
                    func(
                        "tm6_then_interface",
                        vec![
                            name("asym"),
                            interface([
                                n("r") * g_alpha.clone(),
                                n("t") * n("t_g"),
                                n("rp") * g_alpha.clone(),
                                n("tp") * n("tp_g"),
                                s("r") * g_alpha.clone(),
                                s("t") * s("t_g"),
                                s("rp") * g_alpha,
                                s("tp") * s("tp_g"),
                            ]),
                        ],
                    ),
                ));
                top_reflection = Some(v3(n("albedo")));
                None
            }
            Component::Medium(_) => {
                requested.add_medium();
                let medium = |t: Expr, r_fb: Expr, t_ff: Expr| func("tm6_medium", vec![t, r_fb, t_ff]);
                body.push(assign(
                    name("energy"),
                    func("tm6_then_medium", vec![name("energy"), medium(n("t"), n("r_fb"), n("t_ff"))]),
                ));
                // The primary transmission keeps its asymmetry (g = 1).
                body.push(assign(
                    name("asym"),
                    func(
                        "tm6_then_medium",
                        vec![name("asym"), medium(n("t"), n("r_fb") * v3(n("r_fb_g")), n("t_ff") * v3(n("t_ff_g")))],
                    ),
                ));
                None
            }
            Component::Conductor { alpha, .. } => {
                requested.add_interface();
                top_reflection = Some(n("base"));
                Some((n("base"), n("base") * v3(f(ggx_to_hg(alpha) as f32))))
            }
        };
        // The stack's reflectances (`Matrix6::reflectances`): the requested ones, each falling back
        // to the one above where it is not finite (nothing crosses: 0 / 0); the others as above.
        for (total, matrix, above, base) in [
            ("r_total", "energy", "r_above", base.as_ref().map(|(e, _)| e.clone())),
            ("g_total", "asym", "g_above", base.as_ref().map(|(_, g)| g.clone())),
        ] {
            let raw = match base {
                Some(base) => func("tm6_reflectances_over", vec![name(matrix), base]),
                None => func("tm6_reflectances", vec![name(matrix)]),
            };
            let raw_name = format!("{p}{total}_raw");
            body.push(let_(&raw_name, Ty::Named("TmReflect6".into()), raw));
            body.push(var(&format!("{p}{total}"), Ty::Named("TmReflect6".into()), name(above)));
            for (kind, wanted) in requested.kinds() {
                if wanted {
                    body.push(assign(
                        n(total).member(kind),
                        func("tmh_finite_or3", vec![name(&raw_name).member(kind), name(above).member(kind)]),
                    ));
                }
            }
        }
        // A lobe per requested reflectance (`tm6::lobes`): its energy the increment, clamped at 0;
        // its asymmetry the channel mean of the asymmetry increment over the energy increment.
        for (kind, wanted) in requested.kinds() {
            if !wanted {
                continue;
            }
            let lp = format!("{p}{kind}_");
            let l = |s: &str| name(&format!("{lp}{s}"));
            body.push(Stmt::Comment(format!("Layer {}: the {kind} lobe.", index + 1)));
            body.push(let_(
                &format!("{lp}delta"),
                Ty::Vec(3),
                n("r_total").member(kind) - name("r_above").member(kind),
            ));
            body.push(let_(
                &format!("{lp}g_delta"),
                Ty::Vec(3),
                n("g_total").member(kind) - name("g_above").member(kind),
            ));
            let ratio = |c: &str| func("tmh_safe_ratio", vec![l("g_delta").member(c), l("delta").member(c)]);
            body.push(let_(&format!("{lp}g"), Ty::F32, (ratio("x") + ratio("y") + ratio("z")) / f(3.0)));
            body.push(let_(&format!("{lp}energy"), Ty::Vec(3), l("delta").max(v3(f(0.0)))));
            let is_top = index == 0 && kind == "primary";
            let (stored, _) = layers::store_lobe(g, m, &lp, lobes, l("g"), is_top)?;
            body.extend(stored);
            if is_top {
                // The top term is the interface's own albedo where its lobe carries energy.
                if let Some(reflection) = &top_reflection {
                    top = Some(select(layers::has_energy(l("energy")), reflection.clone(), v3(f(0.0))));
                }
            } else {
                // The 6-flux lobes are normalised by GD: their albedo is their energy.
                body.push(assign(name("result").member("albedo"), name("result").member("albedo") + l("energy")));
            }
            lobes += 1;
        }
        body.push(assign(name("r_above"), n("r_total")));
        body.push(assign(name("g_above"), n("g_total")));
    }
    Ok((layers::finish(m, body, top), lobes))
}
