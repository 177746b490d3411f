//! The functions the materials' functions call to read their tables: texel filtering by hand
//! (bilinear, from a texture array's layer, trilinear), and the `asinh` and `acos` an axis's
//! coordinate needs. The model's own arithmetic is recorded inline ([`super::material`]).

use super::super::{Expr, Intrinsic, Module, Stmt, Ty, call, f, let_, name, select};

/// The helper functions every scene shader shares: the bilinear read of a 2D table.
pub(super) fn common(module: &mut Module) {
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
            let_("r", Ty::F32, call(Intrinsic::Log, vec![a.clone() + (a.clone() * a + f(1.0)).sqrt()])),
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

fn v4(e: Expr) -> Expr {
    Expr::Construct(Ty::Vec(4), vec![e])
}
