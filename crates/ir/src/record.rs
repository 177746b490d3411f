//! Code written over [`Real`] (the transfer-matrix model) recorded on a [`Tape`], the expression
//! representation forms are compiled to: each operation on a [`Recorded`] value appends an
//! instruction instead of computing a number. The tape is then printed as shader code (the scene
//! shader) or evaluated in f32 or f64 ([`Tape::values_with`]), so that what a shader computes is
//! checked on the CPU, without a GPU.
//!
//! What depends on constants alone (a material's indices, roughness, media) is computed at once in
//! f64, exactly as the CPU evaluator computes it, and reaches the tape as a constant; a branch on
//! such a value takes one side ([`Real::choose`]). Equal instructions are recorded once, so that a
//! value computed twice (a lookup the model makes on both sides of a branch) is one instruction.

use std::cell::RefCell;
use std::collections::HashMap;

use crate::real::{Compare, Real};
use crate::tape::{Ins, Tape};
use crate::text::{BinOp, Intrinsic};

/// The least transmission a shader's `1 / t` divides by: small enough to leave every physical
/// transmission as it is, large enough that `1 / t` and products with it stay finite in f32.
pub const SMALLEST_TRANSMISSION_F32: f32 = 1e-30;

/// A value of recorded code: a constant known now, or an instruction of the tape being recorded.
#[derive(Debug, Clone, Copy)]
pub struct Recorded {
    known: Option<f64>,
    at: usize,
}

impl PartialEq for Recorded {
    fn eq(&self, other: &Self) -> bool {
        match (self.known, other.known) {
            (Some(a), Some(b)) => a.to_bits() == b.to_bits(),
            (None, None) => self.at == other.at,
            _ => false,
        }
    }
}

/// The tape being recorded on this thread, with the instructions already on it.
#[derive(Default)]
struct Recording {
    tape: Tape,
    seen: HashMap<[u64; 6], usize>,
}

thread_local! {
    static RECORDING: RefCell<Option<Recording>> = const { RefCell::new(None) };
}

/// An instruction as a key: its kind and operands, constants by their bits.
fn key(ins: &Ins) -> [u64; 6] {
    let compare = |c: Compare| c as u64;
    match *ins {
        Ins::Const(v) => [0, v.to_bits(), 0, 0, 0, 0],
        Ins::Var(k) => [1, k as u64, 0, 0, 0, 0],
        Ins::Param(k) => [2, k as u64, 0, 0, 0, 0],
        Ins::Neg(a) => [3, a as u64, 0, 0, 0, 0],
        Ins::Bin(op, a, b) => [4, op as u64, a as u64, b as u64, 0, 0],
        Ins::PowInt(a, n) => [5, a as u64, n as u64, 0, 0, 0],
        Ins::Call(f, [a, b, c]) => [6 + ((f as u64) << 8), a as u64, b as u64, c as u64, 0, 0],
        Ins::Select { otherwise, then, compare: c, left, right } => {
            [7 + (compare(c) << 8), otherwise as u64, then as u64, left as u64, right as u64, 0]
        }
    }
}

/// Run `code` with a fresh tape recording every operation on [`Recorded`] values; return its result
/// and the tape (without outputs: the caller names them from the result).
pub fn record<T>(code: impl FnOnce() -> T) -> (T, Tape) {
    let previous = RECORDING.with(|r| r.borrow_mut().replace(Recording::default()));
    let result = code();
    let recording = RECORDING.with(|r| std::mem::replace(&mut *r.borrow_mut(), previous));
    (result, recording.map(|r| r.tape).unwrap_or_default())
}

fn push(ins: Ins) -> Recorded {
    let at = RECORDING.with(|r| {
        let mut r = r.borrow_mut();
        let recording = r.as_mut().expect("a recorded value is used only inside `record`");
        let key = key(&ins);
        if let Some(&at) = recording.seen.get(&key) {
            return at;
        }
        let at = recording.tape.push(ins);
        recording.seen.insert(key, at);
        at
    });
    Recorded { known: None, at }
}

impl Recorded {
    /// Variable `k` of the recorded code (its input, or a value it reads from outside).
    pub fn variable(k: usize) -> Self {
        push(Ins::Var(k))
    }

    /// The value, where it is known now.
    pub fn known_value(self) -> Option<f64> {
        self.known
    }

    /// Its instruction on the tape (a constant is put on the tape where first needed).
    pub fn instruction(self) -> usize {
        match self.known {
            Some(v) => push(Ins::Const(v)).at,
            None => self.at,
        }
    }

    /// `f` of `args`: computed now where every argument is known, else recorded (a known argument
    /// as a constant).
    fn call<const N: usize>(f: Intrinsic, args: [Self; N], compute: impl Fn([f64; N]) -> f64) -> Self {
        let known = args.map(|a| a.known);
        if known.iter().all(Option::is_some) {
            return Recorded::of(compute(known.map(Option::unwrap_or_default)));
        }
        let mut operands = [0; 3];
        for (operand, a) in operands.iter_mut().zip(args) {
            *operand = a.instruction();
        }
        push(Ins::Call(f, operands))
    }

    fn binary(self, op: BinOp, other: Self) -> Self {
        let compute = |a: f64, b: f64| match op {
            BinOp::Add => a + b,
            BinOp::Sub => a - b,
            BinOp::Mul => a * b,
            BinOp::Div => a / b,
            BinOp::Pow => a.powf(b),
        };
        // Identities that keep the recorded code free of the zeros and ones of identity matrices.
        // `x * 1`, `x / 1`, `x - 0` and `-0 + x` are exact for every value; `x * 0 = 0`, `0 / x = 0`
        // and `x + 0 = x` for every finite non-zero `x`, but for the sign of a zero, which no result
        // of the model depends on (a non-finite value there is one the model guards already, and
        // the model divides 0 only by denominators of at least 1). They also keep `0 / x` out of
        // the printed code, where a compiler's folding would make `(0 / x) / (0 / x)` a NaN literal.
        let is = |v: Option<f64>, unit: f64| v.is_some_and(|v| v == unit);
        match (self.known, other.known, op) {
            (Some(a), Some(b), _) => Recorded::of(compute(a, b)),
            (_, _, BinOp::Mul | BinOp::Div) if is(other.known, 1.0) => self,
            (_, _, BinOp::Mul) if is(self.known, 1.0) => other,
            (_, _, BinOp::Mul) if is(self.known, 0.0) || is(other.known, 0.0) => Recorded::of(0.0),
            (_, _, BinOp::Div) if is(self.known, 0.0) => Recorded::of(0.0),
            (_, _, BinOp::Add | BinOp::Sub) if is(other.known, 0.0) => self,
            (_, _, BinOp::Add) if is(self.known, 0.0) => other,
            _ => push(Ins::Bin(op, self.instruction(), other.instruction())),
        }
    }
}

macro_rules! operators {
    ($($trait:ident $method:ident $op:ident),*) => {$(
        impl std::ops::$trait for Recorded {
            type Output = Recorded;
            fn $method(self, other: Recorded) -> Recorded {
                self.binary(BinOp::$op, other)
            }
        }
        impl std::ops::$trait<f64> for Recorded {
            type Output = Recorded;
            fn $method(self, other: f64) -> Recorded {
                self.binary(BinOp::$op, Recorded::of(other))
            }
        }
    )*};
}
operators!(Add add Add, Sub sub Sub, Mul mul Mul, Div div Div);

impl std::ops::Neg for Recorded {
    type Output = Recorded;
    fn neg(self) -> Recorded {
        match self.known {
            Some(v) => Recorded::of(-v),
            None => push(Ins::Neg(self.at)),
        }
    }
}

impl Real for Recorded {
    fn of(value: f64) -> Self {
        Recorded { known: Some(value), at: usize::MAX }
    }

    fn known(self) -> Option<f64> {
        self.known
    }

    fn smallest_transmission() -> Self {
        Recorded::of(f64::from(SMALLEST_TRANSMISSION_F32))
    }

    fn largest_finite() -> Self {
        Recorded::of(f64::from(f32::MAX))
    }

    fn sqrt(self) -> Self {
        Self::call(Intrinsic::Sqrt, [self], |[x]| x.sqrt())
    }

    fn exp(self) -> Self {
        Self::call(Intrinsic::Exp, [self], |[x]| x.exp())
    }

    fn sinh(self) -> Self {
        Self::call(Intrinsic::Sinh, [self], |[x]| x.sinh())
    }

    fn abs(self) -> Self {
        Self::call(Intrinsic::Abs, [self], |[x]| x.abs())
    }

    fn powf(self, exponent: Self) -> Self {
        Self::call(Intrinsic::Pow, [self, exponent], |[x, e]| x.powf(e))
    }

    fn min(self, other: Self) -> Self {
        Self::call(Intrinsic::Min, [self, other], |[x, y]| x.min(y))
    }

    fn max(self, other: Self) -> Self {
        Self::call(Intrinsic::Max, [self, other], |[x, y]| x.max(y))
    }

    fn clamp(self, lo: f64, hi: f64) -> Self {
        Self::call(Intrinsic::Clamp, [self, Recorded::of(lo), Recorded::of(hi)], |[x, lo, hi]| x.clamp(lo, hi))
    }

    fn select(compare: Compare, left: Self, right: Self, then: Self, otherwise: Self) -> Self {
        if let Some(holds) = Self::decided(compare, left, right) {
            return if holds { then } else { otherwise };
        }
        if then == otherwise {
            return then;
        }
        push(Ins::Select {
            otherwise: otherwise.instruction(),
            then: then.instruction(),
            compare,
            left: left.instruction(),
            right: right.instruction(),
        })
    }
}
