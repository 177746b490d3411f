//! A form compiled for evaluation: its expressions as one list of instructions (a tape), each
//! reading earlier ones, so that a `let` binding used twice is computed once. Values are computed
//! in f32 (as a shader does) or f64 ([`Scalar`]); the gradient with respect to the parameters is
//! exact, by reverse-mode differentiation over the tape in f64: one backward pass per point costs
//! about one evaluation whatever the number of parameters, where forward-mode dual numbers would
//! carry one derivative per parameter through every operation.

use crate::text::{BinOp, Compare, Intrinsic};

/// One instruction; operands are indices of earlier instructions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Ins {
    Const(f64),
    /// The point's variable `k` (the table's lookup variables, in the form's order).
    Var(usize),
    /// The form's parameter `k`.
    Param(usize),
    Neg(usize),
    Bin(BinOp, usize, usize),
    /// `x ^ n` for an integer literal `n` (|n| <= [`MAX_INTEGER_POWER`]): repeated
    /// multiplication, defined for a negative base, as the shaders compute it.
    PowInt(usize, i32),
    Call(Intrinsic, [usize; 3]),
    Select {
        otherwise: usize,
        then: usize,
        compare: Compare,
        left: usize,
        right: usize,
    },
}

/// The largest integer exponent `^` computes by repeated multiplication; larger ones use `pow`.
pub const MAX_INTEGER_POWER: i32 = 16;

/// A compiled form: instructions and, per channel, the instruction that holds its value.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Tape {
    pub ins: Vec<Ins>,
    pub outputs: Vec<usize>,
}

/// The arithmetic of the evaluation, for f32 and f64 alike: each function with the meaning WGSL
/// gives it (`sign(0) = 0`, `fract(x) = x - floor(x)`, `clamp = min(max(x, lo), hi)`).
pub trait Scalar:
    Copy
    + PartialOrd
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::Div<Output = Self>
    + std::ops::Neg<Output = Self>
{
    fn of(v: f64) -> Self;
    fn to_f64(self) -> f64;
    fn unary(f: Intrinsic, x: Self) -> Self;
    fn powf(self, e: Self) -> Self;
    fn atan2(self, x: Self) -> Self;
    fn min(self, o: Self) -> Self;
    fn max(self, o: Self) -> Self;
}

macro_rules! scalar {
    ($t:ty) => {
        impl Scalar for $t {
            fn of(v: f64) -> Self {
                v as $t
            }
            fn to_f64(self) -> f64 {
                self as f64
            }
            fn unary(f: Intrinsic, x: Self) -> Self {
                match f {
                    Intrinsic::Abs => x.abs(),
                    Intrinsic::Sign => {
                        if x > 0.0 {
                            1.0
                        } else if x < 0.0 {
                            -1.0
                        } else {
                            0.0
                        }
                    }
                    Intrinsic::Saturate => x.max(0.0).min(1.0),
                    Intrinsic::Floor => x.floor(),
                    Intrinsic::Fract => x - x.floor(),
                    Intrinsic::Sqrt => x.sqrt(),
                    Intrinsic::InverseSqrt => 1.0 / x.sqrt(),
                    Intrinsic::Exp => x.exp(),
                    Intrinsic::Exp2 => x.exp2(),
                    Intrinsic::Log => x.ln(),
                    Intrinsic::Log2 => x.log2(),
                    Intrinsic::Sin => x.sin(),
                    Intrinsic::Cos => x.cos(),
                    Intrinsic::Tan => x.tan(),
                    Intrinsic::Asin => x.asin(),
                    Intrinsic::Acos => x.acos(),
                    Intrinsic::Atan => x.atan(),
                    Intrinsic::Sinh => x.sinh(),
                    Intrinsic::Cosh => x.cosh(),
                    Intrinsic::Tanh => x.tanh(),
                    // As the shaders compute it (`asinh_of`): HLSL has no asinh.
                    Intrinsic::Asinh => {
                        let a = x.abs();
                        let s = if x > 0.0 {
                            1.0
                        } else if x < 0.0 {
                            -1.0
                        } else {
                            0.0
                        };
                        s * (a + (a * a + 1.0).sqrt()).ln()
                    }
                    _ => <$t>::NAN,
                }
            }
            fn powf(self, e: Self) -> Self {
                // Undefined for a negative base in WGSL and HLSL (exp2(e * log2(x)) on GPUs).
                if self < 0.0 { <$t>::NAN } else { <$t>::powf(self, e) }
            }
            fn atan2(self, x: Self) -> Self {
                <$t>::atan2(self, x)
            }
            fn min(self, o: Self) -> Self {
                <$t>::min(self, o)
            }
            fn max(self, o: Self) -> Self {
                <$t>::max(self, o)
            }
        }
    };
}
scalar!(f32);
scalar!(f64);

fn clamp<T: Scalar>(x: T, lo: T, hi: T) -> T {
    x.max(lo).min(hi)
}

/// `x^n` by repeated multiplication, left to right, as the shader helper computes it.
pub fn pow_int<T: Scalar>(x: T, n: i32) -> T {
    let mut product = T::of(1.0);
    for k in 0..n.unsigned_abs() {
        product = if k == 0 { x } else { product * x };
    }
    if n < 0 { T::of(1.0) / product } else { product }
}

impl Tape {
    pub fn push(&mut self, ins: Ins) -> usize {
        self.ins.push(ins);
        self.ins.len() - 1
    }

    /// Every instruction's value at one point, into `values` (resized).
    pub fn values<T: Scalar>(&self, vars: &[T], params: &[T], values: &mut Vec<T>) {
        values.clear();
        for ins in &self.ins {
            let value = value_of(ins, |k| values[k], vars, params);
            values.push(value);
        }
    }

    /// Every instruction's value, each variable `Var(k)` answered by `variable(k, values so far)`:
    /// recorded code ([`super::record`]) reads values from outside, table lookups, whose
    /// coordinates are earlier instructions. It has no parameters.
    pub fn values_with<T: Scalar>(&self, mut variable: impl FnMut(usize, &[T]) -> T, values: &mut Vec<T>) {
        values.clear();
        for ins in &self.ins {
            let value = match *ins {
                Ins::Var(k) => variable(k, values),
                _ => value_of(ins, |k| values[k], &[], &[]),
            };
            values.push(value);
        }
    }

    /// The channels' values at one point.
    pub fn eval<T: Scalar>(&self, vars: &[T], params: &[T], scratch: &mut Vec<T>, out: &mut [T]) {
        self.values(vars, params, scratch);
        for (o, &k) in out.iter_mut().zip(&self.outputs) {
            *o = scratch[k];
        }
    }

    /// Values and each instruction's derivatives with respect to its operands, at one point: the
    /// derivatives kept as a flat list of `(operand, derivative)` edges per instruction, so that
    /// the backward sweep is one pass over numbers.
    pub fn forward(&self, vars: &[f64], params: &[f64], work: &mut EvaluationBuffers) {
        self.values(vars, params, &mut work.values);
        work.edges.clear();
        work.edge_end.clear();
        let values = &work.values;
        for (i, ins) in self.ins.iter().enumerate() {
            if let Ins::Param(k) = *ins {
                // A parameter's edge points at no instruction: its adjoint goes to the gradient.
                work.edges.push((usize::MAX - k, 1.0));
            } else {
                for (operand, d) in operands(ins).into_iter().zip(partials(ins, |k| values[k], values[i])) {
                    if let Some(operand) = operand
                        && d != 0.0
                    {
                        work.edges.push((operand, d));
                    }
                }
            }
            work.edge_end.push(work.edges.len() as u32);
        }
    }

    /// Add `seed[c] * d channel_c / d parameters` to `gradient`, after [`Tape::forward`] at the
    /// same point: one reverse sweep for every channel at once.
    pub fn backward(&self, work: &mut EvaluationBuffers, seeds: &[f64], gradient: &mut [f64]) {
        work.adjoints.clear();
        work.adjoints.resize(self.ins.len(), 0.0);
        for (&k, &s) in self.outputs.iter().zip(seeds) {
            work.adjoints[k] += s;
        }
        for i in (0..self.ins.len()).rev() {
            let adjoint = work.adjoints[i];
            if adjoint == 0.0 {
                continue;
            }
            let start = if i == 0 { 0 } else { work.edge_end[i - 1] as usize };
            for &(operand, d) in &work.edges[start..work.edge_end[i] as usize] {
                if operand >= self.ins.len() {
                    gradient[usize::MAX - operand] += adjoint;
                } else {
                    work.adjoints[operand] += adjoint * d;
                }
            }
        }
    }

    /// The same channels as a tape over the variables and, after them, the values of some of
    /// this tape's instructions at the point (returned by index): every instruction that does not
    /// depend on the parameters is computed once per point instead of at every evaluation of a
    /// search, and instructions that reach no channel (derived variables the form never reads)
    /// are dropped. Evaluating the result at `(variables, values of the returned instructions)`
    /// gives this tape's channels to the bit.
    pub fn split(&self, variables: usize) -> (Tape, Vec<usize>) {
        let n = self.ins.len();
        let mut depends = vec![false; n];
        for i in 0..n {
            depends[i] = matches!(self.ins[i], Ins::Param(_)) || reads(&self.ins[i]).into_iter().any(|k| depends[k]);
        }
        let mut live = vec![false; n];
        for &k in &self.outputs {
            live[k] = true;
        }
        for i in (0..n).rev() {
            if live[i] && depends[i] {
                for k in reads(&self.ins[i]) {
                    live[k] = true;
                }
            }
        }
        let mut tape = Tape::default();
        let mut map = vec![usize::MAX; n];
        let mut inputs = Vec::new();
        let mut input = |k: usize, tape: &mut Tape, map: &mut Vec<usize>| -> usize {
            if map[k] == usize::MAX {
                map[k] = tape.push(Ins::Var(variables + inputs.len()));
                inputs.push(k);
            }
            map[k]
        };
        for i in 0..n {
            if !(live[i] && depends[i]) {
                continue;
            }
            let mut ins = self.ins[i];
            for slot in operand_slots(&mut ins) {
                *slot = input(*slot, &mut tape, &mut map);
            }
            map[i] = tape.push(ins);
        }
        tape.outputs =
            self.outputs.iter().map(|&k| if depends[k] { map[k] } else { input(k, &mut tape, &mut map) }).collect();
        (tape, inputs)
    }

    /// Whether each parameter reaches any channel.
    pub fn parameters_used(&self, count: usize) -> Vec<bool> {
        let mut reaches = vec![false; self.ins.len()];
        for &k in &self.outputs {
            reaches[k] = true;
        }
        let mut used = vec![false; count];
        for i in (0..self.ins.len()).rev() {
            if !reaches[i] {
                continue;
            }
            if let Ins::Param(k) = self.ins[i] {
                used[k] = true;
            }
            for operand in reads(&self.ins[i]) {
                reaches[operand] = true;
            }
        }
        used
    }
}

/// One instruction's value, given the values of earlier ones (`v(k)`), the point's variables and
/// the parameters: the arithmetic of [`Tape::values`], shared with the evaluation over many points
/// at once (`tmlut::fit::forms::batch`) so that both compute the same bits.
#[inline]
pub fn value_of<T: Scalar>(ins: &Ins, v: impl Fn(usize) -> T, vars: &[T], params: &[T]) -> T {
    match *ins {
        Ins::Const(c) => T::of(c),
        Ins::Var(k) => vars[k],
        Ins::Param(k) => params[k],
        Ins::Neg(a) => -v(a),
        Ins::Bin(op, a, b) => match op {
            BinOp::Add => v(a) + v(b),
            BinOp::Sub => v(a) - v(b),
            BinOp::Mul => v(a) * v(b),
            BinOp::Div => v(a) / v(b),
            BinOp::Pow => v(a).powf(v(b)),
        },
        Ins::PowInt(a, n) => pow_int(v(a), n),
        Ins::Call(f, [a, b, c]) => match f {
            Intrinsic::Min => v(a).min(v(b)),
            Intrinsic::Max => v(a).max(v(b)),
            Intrinsic::Pow => v(a).powf(v(b)),
            Intrinsic::Atan2 => v(a).atan2(v(b)),
            Intrinsic::Step => {
                if v(a) <= v(b) {
                    T::of(1.0)
                } else {
                    T::of(0.0)
                }
            }
            Intrinsic::Clamp => clamp(v(a), v(b), v(c)),
            Intrinsic::Mix => v(a) * (T::of(1.0) - v(c)) + v(b) * v(c),
            Intrinsic::Smoothstep => {
                let t = clamp((v(c) - v(a)) / (v(b) - v(a)), T::of(0.0), T::of(1.0));
                t * t * (T::of(3.0) - T::of(2.0) * t)
            }
            unary => T::unary(unary, v(a)),
        },
        Ins::Select { otherwise, then, compare, left, right } => {
            if compare.holds(v(left).to_f64(), v(right).to_f64()) {
                v(then)
            } else {
                v(otherwise)
            }
        }
    }
}

/// Buffers of one thread's evaluations, reused from point to point.
#[derive(Debug, Default)]
pub struct EvaluationBuffers {
    values: Vec<f64>,
    /// `(operand, derivative)`; a parameter `k`'s own edge is `(usize::MAX - k, 1)`.
    edges: Vec<(usize, f64)>,
    /// Where each instruction's edges end in `edges`.
    edge_end: Vec<u32>,
    adjoints: Vec<f64>,
}

impl EvaluationBuffers {
    pub fn value(&self, k: usize) -> f64 {
        self.values[k]
    }
}

/// Every instruction an instruction reads, a select's condition included, to rewrite them
/// ([`Tape::split`]).
fn operand_slots(ins: &mut Ins) -> Vec<&mut usize> {
    match ins {
        Ins::Const(_) | Ins::Var(_) | Ins::Param(_) => vec![],
        Ins::Neg(a) | Ins::PowInt(a, _) => vec![a],
        Ins::Bin(_, a, b) => vec![a, b],
        Ins::Call(f, [a, b, c]) => match f {
            Intrinsic::Clamp | Intrinsic::Mix | Intrinsic::Smoothstep => vec![a, b, c],
            Intrinsic::Min | Intrinsic::Max | Intrinsic::Pow | Intrinsic::Atan2 | Intrinsic::Step => vec![a, b],
            _ => vec![a],
        },
        Ins::Select { otherwise, then, left, right, .. } => vec![otherwise, then, left, right],
    }
}

/// Every instruction an instruction reads (`operand_slots`).
pub fn reads(ins: &Ins) -> Vec<usize> {
    let mut ins = *ins;
    operand_slots(&mut ins).into_iter().map(|k| *k).collect()
}

/// The operands of an instruction, in the order of [`partials`].
pub fn operands(ins: &Ins) -> [Option<usize>; 4] {
    match *ins {
        Ins::Const(_) | Ins::Var(_) | Ins::Param(_) => [None; 4],
        Ins::Neg(a) | Ins::PowInt(a, _) => [Some(a), None, None, None],
        Ins::Bin(_, a, b) => [Some(a), Some(b), None, None],
        Ins::Call(f, [a, b, c]) => match f {
            Intrinsic::Clamp | Intrinsic::Mix | Intrinsic::Smoothstep => [Some(a), Some(b), Some(c), None],
            Intrinsic::Min | Intrinsic::Max | Intrinsic::Pow | Intrinsic::Atan2 | Intrinsic::Step => {
                [Some(a), Some(b), None, None]
            }
            _ => [Some(a), None, None, None],
        },
        // The condition is piecewise constant: no derivative flows into it.
        Ins::Select { otherwise, then, .. } => [Some(otherwise), Some(then), None, None],
    }
}

/// The derivatives of one instruction with respect to its operands ([`operands`]), given the
/// values of all earlier instructions (`x(k)`) and its own `v`. At the kinks of `abs`, `min`, `max`,
/// `clamp` the derivative of the side the value comes from; where a derivative is infinite
/// (`sqrt` at 0) or the value is not a number, 0, so that the search is never handed a NaN slope.
pub fn partials(ins: &Ins, x: impl Fn(usize) -> f64, v: f64) -> [f64; 4] {
    let d = match *ins {
        Ins::Const(_) | Ins::Var(_) | Ins::Param(_) => [0.0; 4],
        Ins::Neg(_) => [-1.0, 0.0, 0.0, 0.0],
        Ins::Bin(op, a, b) => match op {
            BinOp::Add => [1.0, 1.0, 0.0, 0.0],
            BinOp::Sub => [1.0, -1.0, 0.0, 0.0],
            BinOp::Mul => [x(b), x(a), 0.0, 0.0],
            BinOp::Div => [1.0 / x(b), -v / x(b), 0.0, 0.0],
            BinOp::Pow => pow_partials(x(a), x(b), v),
        },
        Ins::PowInt(a, n) => [f64::from(n) * pow_int(x(a), n - 1), 0.0, 0.0, 0.0],
        Ins::Call(f, [a, b, c]) => {
            let (a, b, c) = (x(a), x(b), x(c));
            let one = |d: f64| [d, 0.0, 0.0, 0.0];
            match f {
                Intrinsic::Abs => one(if a > 0.0 {
                    1.0
                } else if a < 0.0 {
                    -1.0
                } else {
                    0.0
                }),
                Intrinsic::Sign | Intrinsic::Floor => one(0.0),
                Intrinsic::Fract => one(1.0),
                Intrinsic::Saturate => one(if (0.0..=1.0).contains(&a) { 1.0 } else { 0.0 }),
                Intrinsic::Sqrt => one(if v > 0.0 { 0.5 / v } else { 0.0 }),
                Intrinsic::InverseSqrt => one(-0.5 * v * v * v),
                Intrinsic::Exp => one(v),
                Intrinsic::Exp2 => one(v * std::f64::consts::LN_2),
                Intrinsic::Log => one(1.0 / a),
                Intrinsic::Log2 => one(1.0 / (a * std::f64::consts::LN_2)),
                Intrinsic::Sin => one(a.cos()),
                Intrinsic::Cos => one(-a.sin()),
                Intrinsic::Tan => one(1.0 + v * v),
                Intrinsic::Asin => one(1.0 / (1.0 - a * a).sqrt()),
                Intrinsic::Acos => one(-1.0 / (1.0 - a * a).sqrt()),
                Intrinsic::Atan => one(1.0 / (1.0 + a * a)),
                Intrinsic::Sinh => one(a.cosh()),
                Intrinsic::Cosh => one(a.sinh()),
                Intrinsic::Tanh => one(1.0 - v * v),
                Intrinsic::Asinh => one(1.0 / (a * a + 1.0).sqrt()),
                Intrinsic::Min => {
                    if b < a {
                        [0.0, 1.0, 0.0, 0.0]
                    } else {
                        [1.0, 0.0, 0.0, 0.0]
                    }
                }
                Intrinsic::Max => {
                    if b > a {
                        [0.0, 1.0, 0.0, 0.0]
                    } else {
                        [1.0, 0.0, 0.0, 0.0]
                    }
                }
                Intrinsic::Pow => pow_partials(a, b, v),
                // atan2(y, x): d/dy = x / r^2, d/dx = -y / r^2.
                Intrinsic::Atan2 => {
                    let r2 = a * a + b * b;
                    [b / r2, -a / r2, 0.0, 0.0]
                }
                Intrinsic::Step => [0.0; 4],
                Intrinsic::Clamp => {
                    if a.max(b) > c {
                        [0.0, 0.0, 1.0, 0.0]
                    } else if b > a {
                        [0.0, 1.0, 0.0, 0.0]
                    } else {
                        [1.0, 0.0, 0.0, 0.0]
                    }
                }
                Intrinsic::Mix => [1.0 - c, c, b - a, 0.0],
                // smoothstep(e0, e1, x) = s(t), t = (x - e0) / (e1 - e0), s = t^2 (3 - 2t) inside
                // [0, 1], constant outside.
                Intrinsic::Smoothstep => {
                    let width = b - a;
                    let t = (c - a) / width;
                    if (0.0..=1.0).contains(&t) {
                        let ds = 6.0 * t * (1.0 - t);
                        [ds * (c - b) / (width * width), ds * -(c - a) / (width * width), ds / width, 0.0]
                    } else {
                        [0.0; 4]
                    }
                }
            }
        }
        Ins::Select { compare, left, right, .. } => {
            if compare.holds(x(left), x(right)) {
                [0.0, 1.0, 0.0, 0.0]
            } else {
                [1.0, 0.0, 0.0, 0.0]
            }
        }
    };
    d.map(|d| if d.is_finite() { d } else { 0.0 })
}

/// `d x^e / dx = e x^(e - 1)` and `d x^e / de = x^e ln x`; both 0 where the value is 0.
fn pow_partials(x: f64, e: f64, v: f64) -> [f64; 4] {
    if v == 0.0 || x <= 0.0 {
        return [0.0; 4];
    }
    [e * v / x, v * x.ln(), 0.0, 0.0]
}
