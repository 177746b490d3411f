//! A tape evaluated at many points at once: each instruction's values at up to [`LANES`] points
//! are one row of numbers (structure of arrays), so that an instruction is decoded once per row
//! instead of once per point and its arithmetic runs as a tight loop over the row. The reverse
//! sweep computes each instruction's derivatives from the rows as it goes, with no list of edges.
//!
//! Every number is computed by the same arithmetic, in the same order per point, as
//! [`Tape::forward`] and [`Tape::backward`] at one point ([`value_of`], [`partials`], an edge
//! skipped where its derivative or the adjoint is 0, a parameter's adjoints added point by point),
//! so values and gradients are the same to the bit, and a fit is the same whichever evaluates it.

use crate::ir::tape::{Ins, Scalar, Tape, operands, partials, pow_int, value_of};
use crate::ir::text::{BinOp, Intrinsic};

/// Points per row.
pub const LANES: usize = 128;

/// One thread's rows: values and adjoints, [`LANES`] per instruction.
#[derive(Debug, Default)]
pub struct Batch {
    values: Vec<f64>,
    adjoints: Vec<f64>,
    len: usize,
    /// The tape's parameter instructions `(instruction, parameter)`, last first.
    parameters: Vec<(usize, usize)>,
}

/// `slot += adjoint * d` where neither is 0 (the edges [`Tape::forward`] keeps and
/// [`Tape::backward`] follows); `d` not finite counts as 0, as in [`partials`].
#[inline(always)]
fn edge(slot: &mut f64, adjoint: f64, d: f64) {
    let d = if d.is_finite() { d } else { 0.0 };
    if adjoint != 0.0 && d != 0.0 {
        *slot += adjoint * d;
    }
}

impl Batch {
    /// Values of every instruction of `tape` at `len <= LANES` points: `column(k)` holds variable
    /// `k` at those points (at least `len` of them).
    pub fn forward<'c>(&mut self, tape: &Tape, column: impl Fn(usize) -> &'c [f64], params: &[f64], len: usize) {
        assert!(len <= LANES, "a batch holds at most {LANES} points, asked for {len}");
        self.len = len;
        self.values.resize(tape.ins.len() * LANES, 0.0);
        for (i, ins) in tape.ins.iter().enumerate() {
            let (done, rest) = self.values.split_at_mut(i * LANES);
            let out = &mut rest[..len];
            let x = |k: usize| &done[k * LANES..k * LANES + len];
            let unary = |out: &mut [f64], a: usize, f: fn(f64) -> f64| {
                for (o, &a) in out.iter_mut().zip(x(a)) {
                    *o = f(a);
                }
            };
            let binary = |out: &mut [f64], a: usize, b: usize, f: fn(f64, f64) -> f64| {
                for ((o, &a), &b) in out.iter_mut().zip(x(a)).zip(x(b)) {
                    *o = f(a, b);
                }
            };
            match *ins {
                Ins::Const(c) => out.fill(c),
                Ins::Var(k) => out.copy_from_slice(&column(k)[..len]),
                Ins::Param(k) => out.fill(params[k]),
                Ins::Neg(a) => unary(out, a, |a| -a),
                Ins::Bin(BinOp::Add, a, b) => binary(out, a, b, |a, b| a + b),
                Ins::Bin(BinOp::Sub, a, b) => binary(out, a, b, |a, b| a - b),
                Ins::Bin(BinOp::Mul, a, b) => binary(out, a, b, |a, b| a * b),
                Ins::Bin(BinOp::Div, a, b) => binary(out, a, b, |a, b| a / b),
                Ins::PowInt(a, n) => {
                    for (o, &a) in out.iter_mut().zip(x(a)) {
                        *o = pow_int(a, n);
                    }
                }
                Ins::Call(Intrinsic::Min, [a, b, _]) => binary(out, a, b, <f64 as Scalar>::min),
                Ins::Call(Intrinsic::Max, [a, b, _]) => binary(out, a, b, <f64 as Scalar>::max),
                Ins::Call(Intrinsic::Exp, [a, _, _]) => unary(out, a, f64::exp),
                Ins::Call(Intrinsic::Sqrt, [a, _, _]) => unary(out, a, f64::sqrt),
                Ins::Call(Intrinsic::Abs, [a, _, _]) => unary(out, a, f64::abs),
                _ => {
                    for (l, o) in out.iter_mut().enumerate() {
                        *o = value_of(ins, |k| done[k * LANES + l], &[], params);
                    }
                }
            }
        }
    }

    /// Instruction `k`'s value at point `lane` of the last [`Batch::forward`].
    pub fn value(&self, k: usize, lane: usize) -> f64 {
        self.values[k * LANES + lane]
    }

    /// Every adjoint to 0, before seeding the channels ([`Batch::seed`]).
    pub fn clear_adjoints(&mut self, tape: &Tape) {
        self.adjoints.clear();
        self.adjoints.resize(tape.ins.len() * LANES, 0.0);
    }

    /// Add `seed` to instruction `k`'s adjoint at point `lane` (a channel's `d objective / d value`).
    pub fn seed(&mut self, k: usize, lane: usize, seed: f64) {
        self.adjoints[k * LANES + lane] += seed;
    }

    /// The reverse sweep after [`Batch::forward`] and the seeds: adds the seeded combination of
    /// the channels' derivatives with respect to the parameters, point after point, to `gradient`.
    pub fn backward(&mut self, tape: &Tape, gradient: &mut [f64]) {
        let len = self.len;
        let values = &self.values;
        let x = |k: usize, l: usize| values[k * LANES + l];
        for (i, ins) in tape.ins.iter().enumerate().rev() {
            let (lower, upper) = self.adjoints.split_at_mut(i * LANES);
            let adjoint = &upper[..len];
            let v = &values[i * LANES..i * LANES + len];
            match *ins {
                Ins::Const(_) | Ins::Var(_) | Ins::Param(_) => {}
                Ins::Neg(a) => {
                    for (l, &s) in adjoint.iter().enumerate() {
                        edge(&mut lower[a * LANES + l], s, -1.0);
                    }
                }
                Ins::Bin(BinOp::Add, a, b) => {
                    for (l, &s) in adjoint.iter().enumerate() {
                        edge(&mut lower[a * LANES + l], s, 1.0);
                        edge(&mut lower[b * LANES + l], s, 1.0);
                    }
                }
                Ins::Bin(BinOp::Sub, a, b) => {
                    for (l, &s) in adjoint.iter().enumerate() {
                        edge(&mut lower[a * LANES + l], s, 1.0);
                        edge(&mut lower[b * LANES + l], s, -1.0);
                    }
                }
                Ins::Bin(BinOp::Mul, a, b) => {
                    for (l, &s) in adjoint.iter().enumerate() {
                        edge(&mut lower[a * LANES + l], s, x(b, l));
                        edge(&mut lower[b * LANES + l], s, x(a, l));
                    }
                }
                Ins::Bin(BinOp::Div, a, b) => {
                    for (l, &s) in adjoint.iter().enumerate() {
                        edge(&mut lower[a * LANES + l], s, 1.0 / x(b, l));
                        edge(&mut lower[b * LANES + l], s, -v[l] / x(b, l));
                    }
                }
                Ins::PowInt(a, n) => {
                    for (l, &s) in adjoint.iter().enumerate() {
                        edge(&mut lower[a * LANES + l], s, f64::from(n) * pow_int(x(a, l), n - 1));
                    }
                }
                Ins::Call(Intrinsic::Exp, [a, _, _]) => {
                    for (l, &s) in adjoint.iter().enumerate() {
                        edge(&mut lower[a * LANES + l], s, v[l]);
                    }
                }
                Ins::Call(Intrinsic::Min, [a, b, _]) => {
                    for (l, &s) in adjoint.iter().enumerate() {
                        let to = if x(b, l) < x(a, l) { b } else { a };
                        edge(&mut lower[to * LANES + l], s, 1.0);
                    }
                }
                Ins::Call(Intrinsic::Max, [a, b, _]) => {
                    for (l, &s) in adjoint.iter().enumerate() {
                        let to = if x(b, l) > x(a, l) { b } else { a };
                        edge(&mut lower[to * LANES + l], s, 1.0);
                    }
                }
                Ins::Call(Intrinsic::Sqrt, [a, _, _]) => {
                    for (l, &s) in adjoint.iter().enumerate() {
                        edge(&mut lower[a * LANES + l], s, if v[l] > 0.0 { 0.5 / v[l] } else { 0.0 });
                    }
                }
                Ins::Select { otherwise, then, compare, left, right } => {
                    for (l, &s) in adjoint.iter().enumerate() {
                        let to = if compare.holds(x(left, l), x(right, l)) { then } else { otherwise };
                        edge(&mut lower[to * LANES + l], s, 1.0);
                    }
                }
                _ => {
                    let reads = operands(ins);
                    for (l, &s) in adjoint.iter().enumerate() {
                        if s == 0.0 {
                            continue;
                        }
                        let d = partials(ins, |k| x(k, l), v[l]);
                        for (operand, d) in reads.iter().zip(d) {
                            if let Some(operand) = *operand {
                                edge(&mut lower[operand * LANES + l], s, d);
                            }
                        }
                    }
                }
            }
        }
        // A parameter's adjoints into the gradient point by point, each point's in the order of
        // the reverse sweep.
        self.parameters.clear();
        self.parameters.extend(
            tape.ins
                .iter()
                .enumerate()
                .rev()
                .filter_map(|(i, ins)| if let Ins::Param(k) = *ins { Some((i, k)) } else { None }),
        );
        for l in 0..len {
            for &(i, k) in &self.parameters {
                let s = self.adjoints[i * LANES + l];
                if s != 0.0 {
                    gradient[k] += s;
                }
            }
        }
    }
}
