//! A material's function in the 2-flux model ([`crate::model::tm2`]): one 2 x 2 energy matrix per
//! channel (the lanes of a `vec3` per entry) and one asymmetry matrix, multiplied down the stack,
//! and a lobe per reflecting component as the increment of the cumulative reflectance.

use super::super::{Function, Stmt, Ty, assign, f, func, let_, name, select, var};
use super::layers::{self, Component};
use super::{Generator, ShaderMaterial, v3};
use crate::error::Result;
use crate::physics::ggx_to_hg;

/// The function of material `m` and its lobe count.
pub(super) fn function(g: &mut Generator, m: &ShaderMaterial) -> Result<(Function, usize)> {
    let (components, mut body) = layers::begin(g, m)?;
    let matrix = |n: &str| layers::identity_matrix(n, "TmMatrix", "tmh_identity");
    body.extend([
        Stmt::Comment(
            "The energy matrices (one 2x2 per channel, entrywise in a vec3), the asymmetry matrix (the\n\
             same in all three lanes), what was reflected above, and the asymmetry of the lobe\n\
             transmitted down."
                .into(),
        ),
        matrix("energy"),
        matrix("asym"),
        var("r_above", Ty::Vec(3), v3(f(0.0))),
        var("g_above", Ty::F32, f(0.0)),
        var("g_transmitted", Ty::F32, f(1.0)),
    ]);
    let mut lobes = 0usize;
    let mut top = None;
    for (index, component) in components.iter().enumerate() {
        let p = layers::prefix(index);
        let n = |s: &str| name(&format!("{p}{s}"));
        let (r_total, g_total) = match *component {
            Component::Pass => continue,
            Component::Medium(_) => {
                // An attenuator leaves the reflectance above it as it is: no lobe of its own.
                body.push(assign(name("energy"), func("tmh_attenuate", vec![name("energy"), n("t")])));
                body.push(assign(
                    name("asym"),
                    func("tmh_attenuate", vec![name("asym"), v3(func("tmh_average", vec![n("t")]))]),
                ));
                continue;
            }
            Component::Dielectric { eta, alpha } => {
                let below = layers::below(&components, index);
                body.extend(layers::transmission_asymmetries(
                    g,
                    m,
                    &p,
                    &p,
                    eta,
                    "g_transmitted",
                    f(below.reflection_g as f32),
                    below.returns_light,
                )?);
                let g_alpha = f(ggx_to_hg(alpha) as f32);
                body.push(assign(
                    name("energy"),
                    func("tmh_then_interface", vec![name("energy"), v3(n("r")), v3(n("t")), v3(n("rp")), v3(n("tp"))]),
                ));
                body.push(assign(
                    name("asym"),
                    func(
                        "tmh_then_interface",
                        vec![
                            name("asym"),
                            v3(n("r") * g_alpha.clone()),
                            v3(n("t") * n("t_g")),
                            v3(n("rp") * g_alpha),
                            v3(n("tp") * n("tp_g")),
                        ],
                    ),
                ));
                if index == 0 {
                    top = Some(v3(n("albedo")));
                }
                (
                    name("energy").member("m21") / name("energy").member("m11"),
                    (name("asym").member("m21") / name("asym").member("m11")).member("x"),
                )
            }
            Component::Conductor { alpha, .. } => {
                if index == 0 {
                    top = Some(n("base"));
                }
                let over = |m: &str, base: super::super::Expr| {
                    let m = name(m);
                    (m.clone().member("m21") + m.clone().member("m22") * base.clone())
                        / (m.clone().member("m11") + m.member("m12") * base)
                };
                let g_alpha = f(ggx_to_hg(alpha) as f32);
                (
                    over("energy", n("base")),
                    over("asym", v3(func("tmh_average", vec![n("base")]) * g_alpha)).member("x"),
                )
            }
        };
        // The lobe: the increment of the cumulative reflectance (`tm2::lobes`); where nothing
        // crosses (0 / 0) the limit adds nothing to what was reflected above.
        body.extend([
            let_(&format!("{p}r_total"), Ty::Vec(3), func("tmh_finite_or3", vec![r_total, name("r_above")])),
            let_(&format!("{p}g_total"), Ty::F32, func("tmh_finite_or", vec![g_total, name("g_above")])),
            let_(&format!("{p}energy"), Ty::Vec(3), n("r_total") - name("r_above")),
            let_(&format!("{p}mean"), Ty::F32, func("tmh_average", vec![n("energy")])),
            let_(
                &format!("{p}g"),
                Ty::F32,
                select(n("mean").gt(f(0.0)), ((n("g_total") - name("g_above")) / n("mean")).min(f(1.0)), f(0.0)),
            ),
            assign(name("r_above"), n("r_total")),
            assign(name("g_above"), n("g_total")),
        ]);
        let (stored, gd) = layers::store_lobe(g, m, &p, lobes, n("g"), index == 0)?;
        body.extend(stored);
        if index != 0 {
            // The lobe's albedo is its energy times GD.
            body.push(assign(name("result").member("albedo"), name("result").member("albedo") + n("energy") * v3(gd)));
        }
        lobes += 1;
    }
    Ok((layers::finish(m, body, top), lobes))
}
