//! The functions the materials' functions call to read their tables: texel filtering by hand
//! (bilinear, from a texture array's layer, trilinear), and the `asinh` and `acos` an axis's
//! coordinate needs. The model's own arithmetic is recorded inline ([`super::material`]).
//!
//! The filters are the CPU's own ([`crate::filter`]'s `linear_taps_in`, `bilinear` and
//! `trilinear`, generic over their arithmetic), printed through [`InShader`]: the CPU evaluator's
//! sampler runs them in f32 on the same texels. A 2D table is filtered by `bilinear`, the plane
//! the CPU's `trilinear` reads a 2D texture in (a volume one texel deep, whose z weight is 0).

use super::super::{Expr, Intrinsic, Module, Stmt, Ty, call, float, let_, name, select};
use super::reads::InShader;
use crate::filter::{self, bilinear, linear_taps_in};

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

/// Four texels around `(u, v)` of `tex` (of layer `layer` where `layered`), weighed bilinearly
/// ([`crate::filter::bilinear`], the CPU's filter).
fn bilinear_body(layered: bool) -> Vec<Stmt> {
    let load = |x: Expr, y: Expr| {
        InShader(Expr::Load {
            texture: "tex".into(),
            scalar_texture: false,
            coordinates: vec![x, y],
            layer: layered.then(|| Box::new(name("layer"))),
            swizzle: "xyzw",
        })
    };
    let mut body = Vec::new();
    let taps = [taps(&mut body, "u", "width"), taps(&mut body, "v", "height")];
    body.push(Stmt::Return(bilinear(taps, load).0));
    body
}

/// The taps of the CPU's linear filter along one axis ([`linear_taps_in`]), printed: for the
/// texture coordinate `c` in `[0, 1]` over `n` texels, its texel-space position `a{c}`, lower
/// texel `i{c}` and weight `f{c}` of the upper one, and the two texels `{c}0` and `{c}1` (i32).
fn taps(body: &mut Vec<Stmt>, c: &str, n: &str) -> (Expr, Expr, InShader) {
    let (lower, upper, weight) = linear_taps_in(InShader(name(c)), InShader(name(n)), |part, value| {
        let variable = format!("{part}{c}");
        body.push(let_(&variable, Ty::F32, value.0));
        InShader(name(&variable))
    });
    let mut texel = |k: usize, value: InShader| {
        let variable = format!("{c}{k}");
        body.push(let_(&variable, Ty::I32, Expr::Construct(Ty::I32, vec![value.0])));
        name(&variable)
    };
    (texel(0, lower), texel(1, upper), weight)
}

/// The 3D table read: trilinear filtering by hand of a one-channel volume
/// ([`crate::filter::trilinear`], the CPU's filter: x, then y, then z).
pub(super) fn trilinear(module: &mut Module) {
    module.comment("The single channel of a 3D table at texture coordinates (u, v, w), filtered by hand.");
    let load = |x: Expr, y: Expr, z: Expr| {
        InShader(Expr::Load {
            texture: "tex".into(),
            scalar_texture: true,
            coordinates: vec![x, y, z],
            layer: None,
            swizzle: "x",
        })
    };
    let mut body = Vec::new();
    let taps = [taps(&mut body, "u", "width"), taps(&mut body, "v", "height"), taps(&mut body, "w", "depth")];
    body.push(Stmt::Return(filter::trilinear(taps, load).0));
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
            let_("r", Ty::F32, call(Intrinsic::Log, vec![a.clone() + (a.clone() * a + float(1.0)).sqrt()])),
            Stmt::Return(select(name("x").lt(float(0.0)), -name("r"), name("r"))),
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
    let polynomial = A[..7].iter().rev().fold(float(A[7] as f32), |p, &a| float(a as f32) + x.clone() * p);
    module.function(
        "tmh_acos",
        vec![("x", Ty::F32)],
        Ty::F32,
        vec![Stmt::Return((float(1.0) - x.clone()).max(float(0.0)).sqrt() * polynomial)],
    );
}
