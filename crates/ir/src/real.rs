//! The number type the transfer-matrix model is written over, so that one piece of code serves
//! both as the CPU evaluator (`f64`) and as the source of the scene shader (the generator's
//! recorder, which writes each operation into an expression instead of computing it).
//!
//! A branch whose condition depends on the view is written as a [`Real::choose`]: `f64` takes one
//! side, as an `if` would; a recorder, which cannot know the side, records a `select` of both.
//! A condition on a material's constants (its indices, roughness, depth) is known to a recorder
//! too ([`Real::known`]), so the recorded code keeps only the side the material takes, as the
//! CPU evaluator does.

use std::ops::{Add, Div, Mul, Neg, Sub};

/// A comparison, the condition of a [`Real::choose`] (and of a `select` in a shader).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Compare {
    Lt,
    Le,
    Gt,
    Ge,
    Eq,
    Ne,
}

impl Compare {
    pub const ALL: [Compare; 6] = [Compare::Lt, Compare::Le, Compare::Gt, Compare::Ge, Compare::Eq, Compare::Ne];

    /// Whether `a <compare> b` holds, with IEEE semantics (every comparison with NaN is false but
    /// `!=`).
    #[inline(always)]
    pub fn holds(self, a: f64, b: f64) -> bool {
        match self {
            Compare::Lt => a < b,
            Compare::Le => a <= b,
            Compare::Gt => a > b,
            Compare::Ge => a >= b,
            Compare::Eq => a == b,
            Compare::Ne => a != b,
        }
    }

    /// The operator as the shading languages and the form language write it.
    pub fn text(self) -> &'static str {
        match self {
            Compare::Lt => "<",
            Compare::Le => "<=",
            Compare::Gt => ">",
            Compare::Ge => ">=",
            Compare::Eq => "==",
            Compare::Ne => "!=",
        }
    }
}

/// The functions the shading languages and the form language both call, each with the meaning
/// WGSL gives it: one list for the shader printer (`shader::Builtin`), the form language's parser,
/// its evaluator and its recorder. HLSL has the same functions (spelling `fract`, `inverseSqrt`
/// and `mix` as `frac`, `rsqrt` and `lerp`) but for `asinh`, which the printers of tapes write as a
/// helper function in both languages.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Intrinsic {
    Abs,
    Sign,
    Min,
    Max,
    Clamp,
    Saturate,
    Floor,
    Fract,
    Sqrt,
    InverseSqrt,
    Exp,
    Exp2,
    Log,
    Log2,
    Pow,
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Atan2,
    Sinh,
    Cosh,
    Tanh,
    Asinh,
    Smoothstep,
    Step,
    Mix,
}

impl Intrinsic {
    /// Every function with its WGSL name and its argument count.
    pub const ALL: [(Intrinsic, &'static str, usize); 29] = [
        (Intrinsic::Abs, "abs", 1),
        (Intrinsic::Sign, "sign", 1),
        (Intrinsic::Min, "min", 2),
        (Intrinsic::Max, "max", 2),
        (Intrinsic::Clamp, "clamp", 3),
        (Intrinsic::Saturate, "saturate", 1),
        (Intrinsic::Floor, "floor", 1),
        (Intrinsic::Fract, "fract", 1),
        (Intrinsic::Sqrt, "sqrt", 1),
        (Intrinsic::InverseSqrt, "inverseSqrt", 1),
        (Intrinsic::Exp, "exp", 1),
        (Intrinsic::Exp2, "exp2", 1),
        (Intrinsic::Log, "log", 1),
        (Intrinsic::Log2, "log2", 1),
        (Intrinsic::Pow, "pow", 2),
        (Intrinsic::Sin, "sin", 1),
        (Intrinsic::Cos, "cos", 1),
        (Intrinsic::Tan, "tan", 1),
        (Intrinsic::Asin, "asin", 1),
        (Intrinsic::Acos, "acos", 1),
        (Intrinsic::Atan, "atan", 1),
        (Intrinsic::Atan2, "atan2", 2),
        (Intrinsic::Sinh, "sinh", 1),
        (Intrinsic::Cosh, "cosh", 1),
        (Intrinsic::Tanh, "tanh", 1),
        (Intrinsic::Asinh, "asinh", 1),
        (Intrinsic::Smoothstep, "smoothstep", 3),
        (Intrinsic::Step, "step", 2),
        (Intrinsic::Mix, "mix", 3),
    ];

    /// Its name in WGSL.
    pub fn wgsl_name(self) -> &'static str {
        Intrinsic::ALL.iter().find(|(f, ..)| *f == self).map_or("?", |(_, name, _)| name)
    }

    /// How many arguments it takes.
    pub fn arity(self) -> usize {
        Intrinsic::ALL.iter().find(|(f, ..)| *f == self).map_or(0, |(.., arity)| *arity)
    }
}

/// The arithmetic the model needs. Every method has the meaning `f64`'s method of that name has.
pub trait Real:
    Copy
    + std::fmt::Debug
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Add<f64, Output = Self>
    + Sub<f64, Output = Self>
    + Mul<f64, Output = Self>
    + Div<f64, Output = Self>
{
    /// A constant.
    fn of(value: f64) -> Self;
    /// The value, where it is known now: always for `f64`; for a recorder, where it depends on
    /// constants alone.
    fn known(self) -> Option<f64>;
    /// The least transmission `1 / t` divides by: the largest reciprocal that stays finite with
    /// headroom in this type's precision (f32 in a shader).
    fn smallest_transmission() -> Self;
    /// The largest finite value of this type's precision.
    fn largest_finite() -> Self;

    fn sqrt(self) -> Self;
    fn exp(self) -> Self;
    fn sinh(self) -> Self;
    fn abs(self) -> Self;
    fn powf(self, exponent: Self) -> Self;
    fn min(self, other: Self) -> Self;
    fn max(self, other: Self) -> Self;
    /// `f64::clamp`: NaN stays NaN.
    fn clamp(self, lo: f64, hi: f64) -> Self;

    /// `then` where `left <compare> right`, else `otherwise`, both given.
    fn select(compare: Compare, left: Self, right: Self, then: Self, otherwise: Self) -> Self;

    /// Whether `left <compare> right` holds, where both are known now ([`Real::known`]).
    #[inline(always)]
    fn decided(compare: Compare, left: Self, right: Self) -> Option<bool> {
        Some(compare.holds(left.known()?, right.known()?))
    }

    /// `then()` where `left <compare> right` holds, else `otherwise()`: only the side taken is
    /// computed where the condition is [`Real::decided`], both otherwise.
    #[inline(always)]
    fn choose(
        compare: Compare,
        left: Self,
        right: Self,
        then: impl FnOnce() -> Self,
        otherwise: impl FnOnce() -> Self,
    ) -> Self {
        match Self::decided(compare, left, right) {
            Some(true) => then(),
            Some(false) => otherwise(),
            None => Self::select(compare, left, right, then(), otherwise()),
        }
    }

    /// [`Real::choose`] of a pair: `then()` where `left <compare> right` holds, else
    /// `otherwise()`, each side computed once.
    #[inline(always)]
    fn choose_pair(
        compare: Compare,
        left: Self,
        right: Self,
        then: impl FnOnce() -> (Self, Self),
        otherwise: impl FnOnce() -> (Self, Self),
    ) -> (Self, Self) {
        match Self::decided(compare, left, right) {
            Some(true) => then(),
            Some(false) => otherwise(),
            None => {
                let ((a, b), (c, d)) = (then(), otherwise());
                (Self::select(compare, left, right, a, c), Self::select(compare, left, right, b, d))
            }
        }
    }

    /// `self` where it is finite, else `fallback` (NaN included).
    fn finite_or(self, fallback: Self) -> Self {
        Self::choose(Compare::Le, self.abs(), Self::largest_finite(), || self, || fallback)
    }

    /// `self` where it is not NaN, else `fallback`.
    fn or_if_nan(self, fallback: f64) -> Self {
        Self::choose(Compare::Ne, self, self, || Self::of(fallback), || self)
    }
}

/// `then()` where any of `values` is not 0, else `otherwise()` (a lobe that carries energy in some
/// channel).
#[inline(always)]
pub fn choose_if_any_nonzero<R: Real>(values: [R; 3], then: impl Fn() -> R, otherwise: impl Fn() -> R) -> R {
    let zero = R::of(0.0);
    R::choose(Compare::Ne, values[0], zero, &then, || {
        R::choose(Compare::Ne, values[1], zero, &then, || R::choose(Compare::Ne, values[2], zero, &then, &otherwise))
    })
}

impl Real for f64 {
    #[inline(always)]
    fn of(value: f64) -> Self {
        value
    }

    #[inline(always)]
    fn known(self) -> Option<f64> {
        Some(self)
    }

    #[inline(always)]
    fn smallest_transmission() -> Self {
        1e-150
    }

    #[inline(always)]
    fn largest_finite() -> Self {
        f64::MAX
    }

    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }

    #[inline(always)]
    fn exp(self) -> Self {
        f64::exp(self)
    }

    #[inline(always)]
    fn sinh(self) -> Self {
        f64::sinh(self)
    }

    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }

    #[inline(always)]
    fn powf(self, exponent: Self) -> Self {
        f64::powf(self, exponent)
    }

    #[inline(always)]
    fn min(self, other: Self) -> Self {
        f64::min(self, other)
    }

    #[inline(always)]
    fn max(self, other: Self) -> Self {
        f64::max(self, other)
    }

    #[inline(always)]
    fn clamp(self, lo: f64, hi: f64) -> Self {
        f64::clamp(self, lo, hi)
    }

    #[inline(always)]
    fn select(compare: Compare, left: Self, right: Self, then: Self, otherwise: Self) -> Self {
        if compare.holds(left, right) { then } else { otherwise }
    }

    #[inline(always)]
    fn finite_or(self, fallback: Self) -> Self {
        if self.is_finite() { self } else { fallback }
    }

    #[inline(always)]
    fn or_if_nan(self, fallback: f64) -> Self {
        if self.is_nan() { fallback } else { self }
    }
}
