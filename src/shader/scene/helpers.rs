//! The functions the materials' functions call: the conversions between GGX roughness and
//! Henyey-Greenstein asymmetry, Snell's law on cosines, the 2 x 2 transfer matrices of the 2-flux
//! model, texel filtering by hand, and, where a scene needs them, the 6 x 6 matrices and media of
//! the 6-flux model ([`six_flux`]).

use super::super::{Builtin, Expr, Item, Module, Stmt, Ty, assign, call, f, func, let_, name, select, vec3};
use super::v3;
use crate::model::tm2::SMALLEST_TRANSMISSION;

/// The helper functions every scene shader shares.
pub(super) fn common(module: &mut Module) {
    let (x, g, eta, t) = (name("x"), name("g"), name("eta"), name("t"));
    let matrix = Ty::Named("TmMatrix".into());
    module.push(Item::Struct {
        name: "TmMatrix".into(),
        fields: ["m11", "m12", "m21", "m22"].iter().map(|n| (n.to_string(), Ty::Vec(3))).collect(),
    });
    module.comment("Henyey-Greenstein asymmetry of a GGX lobe of roughness alpha (the reference's hg_from_ggx).");
    module.function(
        "tmh_ggx_to_hg",
        vec![("alpha", Ty::F32)],
        Ty::F32,
        vec![
            let_("a", Ty::F32, name("alpha").clamp(f(0.0), f(1.0))),
            Stmt::Return(
                (f(-0.085) + f(1.085) / (f(1.0) + func("pow", vec![name("a") / f(0.5), f(1.3)]))).clamp(f(0.0), f(1.0)),
            ),
        ],
    );
    module.comment("GGX roughness of an HG lobe: the inverse, g clamped to [0.2, 1], alpha to [1e-4, 1].");
    module.function(
        "tmh_hg_to_ggx",
        vec![("g_in", Ty::F32)],
        Ty::F32,
        vec![
            let_("g", Ty::F32, name("g_in").clamp(f(0.2), f(1.0))),
            let_("base", Ty::F32, (f(1.085) / (g.clone() + f(0.085)) - f(1.0)).max(f(0.0))),
            Stmt::Return((f(0.5) * func("pow", vec![name("base"), f((1.0 / 1.3) as f32)])).clamp(f(1e-4), f(1.0))),
        ],
    );
    module.comment("Asymmetry of a lobe refracted into relative index eta (the reference's hg_refract).");
    module.function(
        "tmh_hg_refract",
        vec![("g", Ty::F32), ("eta", Ty::F32)],
        Ty::F32,
        vec![Stmt::Return(
            (f(1.0) - (f(1.0) - g.clone() * g) * func("pow", vec![eta.clone(), f(0.75)]))
                .max(f(0.0))
                .sqrt()
                .min(f(1.0)),
        )],
    );
    module.comment("Snell's law on cosines; 0 where the direction is totally reflected.");
    module.function(
        "tmh_refracted_cosine",
        vec![("c", Ty::F32), ("eta", Ty::F32)],
        Ty::F32,
        vec![
            let_("sin2_in", Ty::F32, (f(1.0) - name("c")) * (f(1.0) + name("c"))),
            let_("cos2", Ty::F32, f(1.0) - name("sin2_in") / (eta.clone() * eta)),
            Stmt::Return(select(name("cos2").gt(f(0.0)), name("cos2").max(f(0.0)).sqrt(), f(0.0))),
        ],
    );
    module.comment(
        "Asymmetry of a transmission lobe whose roughness the refraction scales by |n / d| (the reference's\n\
         hg_from_ggx(0.5 s alpha), the ratio taken whole in abs); a mean direction at the horizon\n\
         (d = 0) gives the roughest lobe.",
    );
    module.function(
        "tmh_transmission_g",
        vec![("n", Ty::F32), ("d", Ty::F32), ("alpha", Ty::F32)],
        Ty::F32,
        vec![
            let_("scale", Ty::F32, (name("n") / select(name("d").ne(f(0.0)), name("d"), f(1.0))).abs()),
            Stmt::Return(select(
                name("d").ne(f(0.0)),
                func("tmh_ggx_to_hg", vec![f(0.5) * name("scale") * name("alpha")]),
                func("tmh_ggx_to_hg", vec![f(1.0)]),
            )),
        ],
    );
    module.function(
        "tmh_average",
        vec![("v", Ty::Vec(3))],
        Ty::F32,
        vec![Stmt::Return((name("v").member("x") + name("v").member("y") + name("v").member("z")) / f(3.0))],
    );
    module.comment("x where it is finite (a comparison: false for NaN and infinities), else the fallback.");
    module.function(
        "tmh_finite_or",
        vec![("x", Ty::F32), ("fallback", Ty::F32)],
        Ty::F32,
        vec![Stmt::Return(select(x.abs().le(f(f32::MAX)), name("x"), name("fallback")))],
    );
    let lane = |c: &str| func("tmh_finite_or", vec![name("v").member(c), name("fallback").member(c)]);
    module.function(
        "tmh_finite_or3",
        vec![("v", Ty::Vec(3)), ("fallback", Ty::Vec(3))],
        Ty::Vec(3),
        vec![Stmt::Return(vec3(lane("x"), lane("y"), lane("z")))],
    );
    module.function(
        "tmh_identity",
        vec![],
        matrix.clone(),
        vec![
            Stmt::Var { name: "m".into(), ty: matrix.clone(), value: None },
            assign(name("m").member("m11"), v3(f(1.0))),
            assign(name("m").member("m22"), v3(f(1.0))),
            Stmt::Return(name("m")),
        ],
    );
    module.comment(
        "m divided by its largest entry per channel: the reflectances are ratios of entries, so the\n\
         scale is free, and removing it keeps a product of many attenuating layers finite.",
    );
    let abs = |e: &str| name("m").member(e).abs();
    module.function(
        "tmh_normalised",
        vec![("m", matrix.clone())],
        matrix.clone(),
        vec![
            let_("largest", Ty::Vec(3), abs("m11").max(abs("m12")).max(abs("m21").max(abs("m22")))),
            let_("s", Ty::Vec(3), name("largest").max(v3(f(1e-30)))),
            Stmt::Var { name: "o".into(), ty: matrix.clone(), value: None },
            assign(name("o").member("m11"), name("m").member("m11") / name("s")),
            assign(name("o").member("m12"), name("m").member("m12") / name("s")),
            assign(name("o").member("m21"), name("m").member("m21") / name("s")),
            assign(name("o").member("m22"), name("m").member("m22") / name("s")),
            Stmt::Return(name("o")),
        ],
    );
    module.comment(
        "m times the transfer matrix of an interface, (1 / t) [[1, -rp], [r, t tp - r rp]], with t\n\
         floored so that a total reflection (t = 0) gives the limit where nothing crosses.",
    );
    let e = |a: &str, b: &str| name("m").member(a) * name(b);
    module.function(
        "tmh_then_interface",
        vec![("m", matrix.clone()), ("r", Ty::Vec(3)), ("t", Ty::Vec(3)), ("rp", Ty::Vec(3)), ("tp", Ty::Vec(3))],
        matrix.clone(),
        vec![
            let_("inverse", Ty::Vec(3), v3(f(1.0)) / t.clone().max(v3(f(SMALLEST_TRANSMISSION_F32)))),
            let_("e11", Ty::Vec(3), name("inverse")),
            let_("e12", Ty::Vec(3), -name("rp") * name("inverse")),
            let_("e21", Ty::Vec(3), name("r") * name("inverse")),
            let_("e22", Ty::Vec(3), (t * name("tp") - name("r") * name("rp")) * name("inverse")),
            Stmt::Var { name: "o".into(), ty: matrix.clone(), value: None },
            assign(name("o").member("m11"), e("m11", "e11") + e("m12", "e21")),
            assign(name("o").member("m12"), e("m11", "e12") + e("m12", "e22")),
            assign(name("o").member("m21"), e("m21", "e11") + e("m22", "e21")),
            assign(name("o").member("m22"), e("m21", "e12") + e("m22", "e22")),
            Stmt::Return(func("tmh_normalised", vec![name("o")])),
        ],
    );
    module.comment("m times a medium that only attenuates, by t each way: diag(1 / t, t).");
    module.function(
        "tmh_attenuate",
        vec![("m", matrix.clone()), ("t", Ty::Vec(3))],
        matrix.clone(),
        vec![
            let_("inverse", Ty::Vec(3), v3(f(1.0)) / name("t").max(v3(f(SMALLEST_TRANSMISSION_F32)))),
            Stmt::Var { name: "o".into(), ty: matrix.clone(), value: None },
            assign(name("o").member("m11"), name("m").member("m11") * name("inverse")),
            assign(name("o").member("m12"), name("m").member("m12") * name("t")),
            assign(name("o").member("m21"), name("m").member("m21") * name("inverse")),
            assign(name("o").member("m22"), name("m").member("m22") * name("t")),
            Stmt::Return(func("tmh_normalised", vec![name("o")])),
        ],
    );
    module.comment(
        "Channel c of a 2D table at texture coordinates (u, v), filtered by hand: clamp addressing,\n\
         cell-centred texels, weights in f32 (what the sampler computes, without its 8-bit weights).",
    );
    module.function(
        "tmh_bilinear",
        vec![
            ("tex", Ty::Texture { dims: 2, scalar: false }),
            ("u", Ty::F32),
            ("v", Ty::F32),
            ("width", Ty::F32),
            ("height", Ty::F32),
        ],
        Ty::Vec(4),
        bilinear_body(false),
    );
}

/// The read of a slice in a texture array: [`common`]'s `tmh_bilinear` on one layer. The
/// coordinates are clamped to the slice's nodes by the caller, so the filter reaches at most the
/// slice's gutter, which repeats its edge (`formats::slice_array`).
pub(super) fn bilinear_layer(module: &mut Module) {
    module.comment("tmh_bilinear on layer `layer` of a texture array of slices.");
    module.function(
        "tmh_bilinear_layer",
        vec![
            ("tex", Ty::TextureArray),
            ("u", Ty::F32),
            ("v", Ty::F32),
            ("width", Ty::F32),
            ("height", Ty::F32),
            ("layer", Ty::I32),
        ],
        Ty::Vec(4),
        bilinear_body(true),
    );
}

/// Four texels around `(u, v)` of `tex` (of layer `layer` where `layered`), weighed bilinearly.
fn bilinear_body(layered: bool) -> Vec<Stmt> {
    let load = |x: &str, y: &str| Expr::Load {
        texture: "tex".into(),
        scalar_texture: false,
        coordinates: vec![name(x), name(y)],
        layer: layered.then(|| Box::new(name("layer"))),
        swizzle: "xyzw",
    };
    let lerp4 = |a: Expr, b: Expr, w: &str| (v4(f(1.0)) - v4(name(w))) * a + v4(name(w)) * b;
    let mut body = taps("u", "width");
    body.extend(taps("v", "height"));
    body.push(let_("row0", Ty::Vec(4), lerp4(load("u0", "v0"), load("u1", "v0"), "fu")));
    body.push(let_("row1", Ty::Vec(4), lerp4(load("u0", "v1"), load("u1", "v1"), "fu")));
    body.push(Stmt::Return(lerp4(name("row0"), name("row1"), "fv")));
    body
}

/// The two taps of a clamp-addressed linear filter along one axis: the texel coordinate of `c` in
/// `[0, 1]` over `n` texels, its lower and upper texel (`{c}0`, `{c}1`) and the weight `f{c}` of
/// the upper one, as [`crate::packing::emulator`] computes them.
fn taps(c: &str, n: &str) -> Vec<Stmt> {
    let a = format!("a{c}");
    vec![
        let_(&a, Ty::F32, name(c) * name(n) - f(0.5)),
        let_(&format!("i{c}"), Ty::F32, name(&a).floor()),
        let_(&format!("f{c}"), Ty::F32, name(&a) - name(&format!("i{c}"))),
        let_(
            &format!("{c}0"),
            Ty::I32,
            Expr::Construct(Ty::I32, vec![name(&format!("i{c}")).clamp(f(0.0), name(n) - f(1.0))]),
        ),
        let_(
            &format!("{c}1"),
            Ty::I32,
            Expr::Construct(Ty::I32, vec![(name(&format!("i{c}")) + f(1.0)).clamp(f(0.0), name(n) - f(1.0))]),
        ),
    ]
}

/// `(1 - w) a + w b`, the emulator's lerp.
fn lerp(a: Expr, b: Expr, w: Expr) -> Expr {
    (f(1.0) - w.clone()) * a + w * b
}

/// The 3D table read: trilinear filtering by hand of a one-channel volume (x, then y, then z, as
/// the emulator filters).
pub(super) fn trilinear(module: &mut Module) {
    module.comment("The single channel of a 3D table at texture coordinates (u, v, w), filtered by hand.");
    let load = |x: &str, y: &str, z: &str| Expr::Load {
        texture: "tex".into(),
        scalar_texture: true,
        coordinates: vec![name(x), name(y), name(z)],
        layer: None,
        swizzle: "x",
    };
    let mut body = taps("u", "width");
    body.extend(taps("v", "height"));
    body.extend(taps("w", "depth"));
    for z in ["w0", "w1"] {
        let row = |y: &str| lerp(load("u0", y, z), load("u1", y, z), name("fu"));
        body.push(let_(&format!("plane_{z}"), Ty::F32, lerp(row("v0"), row("v1"), name("fv"))));
    }
    body.push(Stmt::Return(lerp(name("plane_w0"), name("plane_w1"), name("fw"))));
    module.function(
        "tmh_trilinear",
        vec![
            ("tex", Ty::Texture { dims: 3, scalar: true }),
            ("u", Ty::F32),
            ("v", Ty::F32),
            ("w", Ty::F32),
            ("width", Ty::F32),
            ("height", Ty::F32),
            ("depth", Ty::F32),
        ],
        Ty::F32,
        body,
    );
}

/// `asinh`, which HLSL has no builtin for: `sign(x) log(|x| + sqrt(x^2 + 1))`, an axis's mapping.
pub(super) fn asinh(module: &mut Module) {
    module.comment("asinh(x), odd, without HLSL's missing builtin: an axis spaced in asinh.");
    let a = name("a");
    module.function(
        "tmh_asinh",
        vec![("x", Ty::F32)],
        Ty::F32,
        vec![
            let_("a", Ty::F32, name("x").abs()),
            let_("r", Ty::F32, call(Builtin::Log, vec![a.clone() + (a.clone() * a + f(1.0)).sqrt()])),
            Stmt::Return(select(name("x").lt(f(0.0)), -name("r"), name("r"))),
        ],
    );
}

/// `acos(x)` for `x` in [0, 1] to 2e-8 before rounding (Abramowitz & Stegun, Handbook of
/// Mathematical Functions, 4.4.46): `sqrt(1 - x)` times a polynomial of degree 7. Vulkan allows the
/// builtin `acos` an error inherited from `atan2`'s 4096 ulp, and Mesa's lavapipe (LLVM 15) is off
/// by up to 1.6e-4 rad (median 6e-5 over 2^20 cosines), which the critical-angle axis (spaced in
/// `asinh(offset / 0.001)`) turned into TIR errors of 1e-4; this one is within 2.4e-7 in f32.
pub(super) fn acos(module: &mut Module) {
    module.comment("acos(x) on [0, 1] to 2e-8 (Abramowitz & Stegun 4.4.46), a polynomial in x times sqrt(1 - x).");
    const A: [f64; 8] = [
        1.5707963050,
        -0.2145988016,
        0.0889789874,
        -0.0501743046,
        0.0308918810,
        -0.0170881256,
        0.0066700901,
        -0.0012624911,
    ];
    // Horner's scheme from the highest coefficient.
    let x = name("x");
    let polynomial = A[..7].iter().rev().fold(f(A[7] as f32), |p, &a| f(a as f32) + x.clone() * p);
    module.function(
        "tmh_acos",
        vec![("x", Ty::F32)],
        Ty::F32,
        vec![Stmt::Return((f(1.0) - x.clone()).max(f(0.0)).sqrt() * polynomial)],
    );
}

/// The entries of a 6-flux transfer matrix that are ever non-zero ([`crate::model::tm6::Matrix6`]).
pub(super) const MATRIX6: [&str; 20] = [
    "m11", "m12", "m21", "m22", "m31", "m32", "m33", "m34", "m35", "m36", "m41", "m42", "m43", "m44", "m45", "m46",
    "m51", "m52", "m61", "m62",
];

/// The 6-flux model's functions ([`crate::model::tm6`]): its sparse 6 x 6 matrices, one per
/// channel in the lanes of a `vec3` per entry, their products by an interface and by a medium,
/// the three reflectances of a stack, and a medium's two-flux slab solution.
pub(super) fn six_flux(module: &mut Module) {
    let matrix = Ty::Named("TmMatrix6".into());
    let reflect = Ty::Named("TmReflect6".into());
    module.push(Item::Struct {
        name: "TmMatrix6".into(),
        fields: MATRIX6.iter().map(|n| (n.to_string(), Ty::Vec(3))).collect(),
    });
    module.push(Item::Struct {
        name: "TmReflect6".into(),
        fields: ["primary", "forward", "backward"].iter().map(|n| (n.to_string(), Ty::Vec(3))).collect(),
    });
    let m = |e: &str| name("m").member(e);
    let e = |x: &str| name("e").member(x);
    let zero = || Stmt::Var { name: "o".into(), ty: matrix.clone(), value: None };
    let set = |entry: &str, value: Expr| assign(name("o").member(entry), value);
    module.function(
        "tm6_identity",
        vec![],
        matrix.clone(),
        vec![
            zero(),
            set("m11", v3(f(1.0))),
            set("m22", v3(f(1.0))),
            set("m33", v3(f(1.0))),
            set("m44", v3(f(1.0))),
            Stmt::Return(name("o")),
        ],
    );
    let inverse = |t: &str| v3(f(1.0)) / name(t).max(v3(f(SMALLEST_TRANSMISSION_F32)));
    module.comment(
        "An interface's matrix from its primary (r, t, rp, tp) and secondary (forward-scattered) factors\n\
         (the reference's energy_matrix of a dielectric interface); t floored in 1 / t as in the 2-flux model.",
    );
    let v = |n: &'static str| (n, Ty::Vec(3));
    module.function(
        "tm6_interface",
        vec![v("r"), v("t"), v("rp"), v("tp"), v("r_ff"), v("t_ff"), v("rp_ff"), v("tp_ff")],
        matrix.clone(),
        vec![
            zero(),
            set("m11", inverse("t")),
            set("m12", -name("rp") * name("o").member("m11")),
            set("m21", name("r") * name("o").member("m11")),
            set("m22", -name("r") * name("rp") * name("o").member("m11") + name("tp")),
            set("m33", inverse("t_ff")),
            set("m34", -name("rp_ff") * name("o").member("m33")),
            set("m43", name("r_ff") * name("o").member("m33")),
            set("m44", -name("r_ff") * name("rp_ff") * name("o").member("m33") + name("tp_ff")),
            Stmt::Return(name("o")),
        ],
    );
    module.comment(
        "A medium's matrix from its primary transmission t, and the secondary flux's backward\n\
         reflection r_fb and forward transmission t_ff (the reference's energy_matrix of a homogeneous medium).",
    );
    let o = |x: &str| name("o").member(x);
    module.function(
        "tm6_medium",
        vec![v("t"), v("r_fb"), v("t_ff")],
        matrix.clone(),
        vec![
            zero(),
            set("m11", inverse("t")),
            set("m22", name("t")),
            set("m33", inverse("t_ff")),
            set("m44", -(name("r_fb") * name("r_fb")) * o("m33") + name("t_ff")),
            set("m36", -name("r_fb") * o("m33")),
            set("m52", o("m36")),
            set("m31", o("m33") - o("m11")),
            set("m42", o("m44") - name("t")),
            set("m61", -o("m36")),
            set("m45", -o("m36")),
            Stmt::Return(name("o")),
        ],
    );
    let sum = |terms: &[(&str, &str)], by: &dyn Fn(&str) -> Expr| {
        terms.iter().map(|(a, b)| m(a) * by(b)).reduce(|x, y| x + y).expect("terms")
    };
    let product = |entries: &[(&str, Vec<(&str, &str)>)]| -> Vec<Stmt> {
        let mut body = vec![zero()];
        body.extend(entries.iter().map(|(entry, terms)| set(entry, sum(terms, &e))));
        body.push(Stmt::Return(func("tm6_normalised", vec![name("o")])));
        body
    };
    module.comment(
        "m divided by its largest entry per channel (tm6.rs, normalised): the reflectances are ratios of\n\
         products of equal degree in the entries, so the scale is free.",
    );
    let largest = MATRIX6.iter().map(|x| m(x).abs()).reduce(|a, b| a.max(b)).expect("entries");
    let lane = |c: &str| {
        let l = name("largest").member(c);
        select(l.clone().gt(f(0.0)).and(l.clone().le(f(f32::MAX))), l, f(1.0))
    };
    let mut body = vec![
        let_("largest", Ty::Vec(3), largest),
        let_("s", Ty::Vec(3), vec3(lane("x"), lane("y"), lane("z"))),
        zero(),
    ];
    body.extend(MATRIX6.iter().map(|x| set(x, m(x) / name("s"))));
    body.push(Stmt::Return(name("o")));
    module.function("tm6_normalised", vec![("m", matrix.clone())], matrix.clone(), body);
    module.comment("m times an interface's matrix e (tm6.rs, then_interface).");
    let t = |a: &'static str, b: &'static str| (a, b);
    module.function(
        "tm6_then_interface",
        vec![("m", matrix.clone()), ("e", matrix.clone())],
        matrix.clone(),
        product(&[
            ("m11", vec![t("m11", "m11"), t("m12", "m21")]),
            ("m12", vec![t("m11", "m12"), t("m12", "m22")]),
            ("m21", vec![t("m21", "m11"), t("m22", "m21")]),
            ("m22", vec![t("m21", "m12"), t("m22", "m22")]),
            ("m31", vec![t("m31", "m11"), t("m32", "m21")]),
            ("m32", vec![t("m31", "m12"), t("m32", "m22")]),
            ("m33", vec![t("m33", "m33"), t("m34", "m43")]),
            ("m34", vec![t("m33", "m34"), t("m34", "m44")]),
            ("m35", vec![t("m35", "m33"), t("m36", "m43")]),
            ("m36", vec![t("m35", "m34"), t("m36", "m44")]),
            ("m41", vec![t("m41", "m11"), t("m42", "m21")]),
            ("m42", vec![t("m41", "m12"), t("m42", "m22")]),
            ("m43", vec![t("m43", "m33"), t("m44", "m43")]),
            ("m44", vec![t("m43", "m34"), t("m44", "m44")]),
            ("m45", vec![t("m45", "m33"), t("m46", "m43")]),
            ("m46", vec![t("m45", "m34"), t("m46", "m44")]),
            ("m51", vec![t("m51", "m11"), t("m52", "m21")]),
            ("m52", vec![t("m51", "m12"), t("m52", "m22")]),
            ("m61", vec![t("m61", "m11"), t("m62", "m21")]),
            ("m62", vec![t("m61", "m12"), t("m62", "m22")]),
        ]),
    );
    module.comment("m times a medium's matrix e (tm6.rs, then_medium).");
    let mut body = vec![zero()];
    let mm = |a: &str, b: &str| m(a) * e(b);
    for (entry, value) in [
        ("m11", mm("m11", "m11")),
        ("m12", mm("m12", "m22")),
        ("m21", mm("m21", "m11")),
        ("m22", mm("m22", "m22")),
        ("m31", mm("m31", "m11") + mm("m33", "m31") - mm("m36", "m36")),
        ("m32", mm("m32", "m22") + mm("m34", "m42") + mm("m35", "m36")),
        ("m33", mm("m33", "m33") - mm("m36", "m36")),
        ("m34", mm("m34", "m44") + mm("m35", "m36")),
        ("m35", -mm("m34", "m36") + mm("m35", "m33")),
        ("m36", mm("m33", "m36") + mm("m36", "m44")),
        ("m41", mm("m41", "m11") + mm("m43", "m31") - mm("m46", "m36")),
        ("m42", mm("m42", "m22") + mm("m44", "m42") + mm("m45", "m36")),
        ("m43", mm("m43", "m33") - mm("m46", "m36")),
        ("m44", mm("m44", "m44") + mm("m45", "m36")),
        ("m45", -mm("m44", "m36") + mm("m45", "m33")),
        ("m46", mm("m43", "m36") + mm("m46", "m44")),
        ("m51", -mm("m34", "m36") + mm("m35", "m31") + mm("m51", "m11")),
        ("m52", mm("m33", "m36") + mm("m36", "m42") + mm("m52", "m22")),
        ("m61", -mm("m44", "m36") + mm("m45", "m31") + mm("m61", "m11")),
        ("m62", mm("m43", "m36") + mm("m46", "m42") + mm("m62", "m22")),
    ] {
        body.push(set(entry, value));
    }
    body.push(Stmt::Return(func("tm6_normalised", vec![name("o")])));
    module.function("tm6_then_medium", vec![("m", matrix.clone()), ("e", matrix.clone())], matrix.clone(), body);
    let x = |k: u8| name(&format!("x{k}"));
    let l = |n: &str, value: Expr| let_(n, Ty::Vec(3), value);
    let out = || Stmt::Var { name: "r".into(), ty: reflect.clone(), value: None };
    let put = |field: &str, value: Expr| assign(name("r").member(field), value);
    module.comment("The reflectances of a stack over nothing (the reference's factors without a base).");
    module.function(
        "tm6_reflectances",
        vec![("m", matrix.clone())],
        reflect.clone(),
        vec![
            l("x0", v3(f(1.0)) / m("m11")),
            l("x1", -m("m31") * m("m33") + m("m35") * m("m51")),
            l("x2", m("m31") * m("m35") - m("m33") * m("m51")),
            l("x3", x(0) / (m("m33") * m("m33") - m("m35") * m("m35"))),
            l("x4", m("m43") * x(3)),
            l("x5", m("m45") * x(3)),
            out(),
            put("backward", m("m61") * x(0) + x(1) * x(5) + x(4) * x(2)),
            put("forward", m("m41") * x(0) + x(1) * x(4) + x(2) * x(5)),
            put("primary", m("m21") * x(0)),
            Stmt::Return(name("r")),
        ],
    );
    module.comment(
        "The reflectances of a stack over a conductor of reflectance rc (the reference's factors with a base).",
    );
    let over = |a: &str, b: &str| m(a) + m(b) * name("rc");
    module.function(
        "tm6_reflectances_over",
        vec![("m", matrix.clone()), ("rc", Ty::Vec(3))],
        reflect.clone(),
        vec![
            l("x0", v3(f(1.0)) / over("m11", "m12")),
            l("x1", over("m45", "m46")),
            l("x2", over("m31", "m32")),
            l("x3", over("m35", "m36")),
            l("x4", over("m33", "m34")),
            l("x5", over("m51", "m52")),
            l("x6", x(0) / (-x(3) * x(3) + x(4) * x(4))),
            l("x7", x(6) * (x(2) * x(3) - x(4) * x(5))),
            l("x8", over("m43", "m44")),
            l("x9", x(6) * (x(2) * x(4) - x(3) * x(5))),
            out(),
            put("backward", x(0) * over("m61", "m62") - x(1) * x(9) + x(7) * x(8)),
            put("forward", x(0) * over("m41", "m42") + x(1) * x(7) - x(8) * x(9)),
            put("primary", x(0) * over("m21", "m22")),
            Stmt::Return(name("r")),
        ],
    );
    module.comment("n / d, or 0 where |d| <= 1e-7 (the reference's safe_div).");
    module.function(
        "tmh_safe_ratio",
        vec![("n", Ty::F32), ("d", Ty::F32)],
        Ty::F32,
        vec![Stmt::Return(select(name("d").abs().gt(f(1e-7)), name("n") / name("d"), f(0.0)))],
    );
    module.comment(
        "The two-flux solution of a slab (factors.rs, slab): attenuation a, coupling b, gamma =\n\
         sqrt(a^2 - b^2), optical path tau; returns (reflected, transmitted). r = S b / (C gamma + S a),\n\
         t = gamma / (C gamma + S a) with S = sinh(gamma tau), C = sqrt(1 + S^2), divided through by S /\n\
         gamma, so that no term overflows f32 where gamma tau is large: with q = gamma / S,\n\
         r = b / (sqrt(q^2 + gamma^2) + a), t = q / (sqrt(q^2 + gamma^2) + a). q is 1 / (tau sinhc) by\n\
         its series below gamma tau = 0.5 (exact to 1e-8 there; the limit 1 / tau at gamma = 0), and\n\
         2 gamma e^-x / (1 - e^-2x) above.",
    );
    let (xx, ee) = (name("x2"), name("ex"));
    let series = f(1.0)
        + xx.clone() / f(6.0)
            * (f(1.0) + xx.clone() / f(20.0) * (f(1.0) + xx.clone() / f(42.0) * (f(1.0) + xx / f(72.0))));
    module.function(
        "tmh_slab",
        vec![("a", Ty::F32), ("b", Ty::F32), ("gamma", Ty::F32), ("tau", Ty::F32)],
        Ty::Vec(2),
        vec![
            let_("x", Ty::F32, name("gamma") * name("tau")),
            let_("x2", Ty::F32, name("x") * name("x")),
            let_("ex", Ty::F32, call(Builtin::Exp, vec![-name("x")])),
            let_(
                "q",
                Ty::F32,
                select(
                    name("x").lt(f(0.5)),
                    f(1.0) / (name("tau") * series),
                    f(2.0) * name("gamma") * ee.clone() / (f(1.0) - ee.clone() * ee),
                ),
            ),
            let_("big", Ty::F32, name("q").max(name("gamma"))),
            let_("small", Ty::F32, name("q").min(name("gamma"))),
            let_("ratio", Ty::F32, select(name("big").gt(f(0.0)), name("small") / name("big"), f(0.0))),
            let_("d", Ty::F32, name("big") * (f(1.0) + name("ratio") * name("ratio")).sqrt() + name("a")),
            Stmt::Return(Expr::Construct(Ty::Vec(2), vec![name("b") / name("d"), name("q") / name("d")])),
        ],
    );
}

/// The f32 floor of a transmission in `1 / t`: [`SMALLEST_TRANSMISSION`] is below the f32 range;
/// this keeps `1 / t` at most 1e30, so that a product with an entry of at most 1 stays finite.
pub const SMALLEST_TRANSMISSION_F32: f32 = 1e-30;
const _: () = assert!(SMALLEST_TRANSMISSION < SMALLEST_TRANSMISSION_F32 as f64);

fn v4(e: Expr) -> Expr {
    Expr::Construct(Ty::Vec(4), vec![e])
}
