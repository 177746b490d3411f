//! A [`Tape`] printed as shader statements ([`crate::shader`]): the one printer of the recorded
//! scene model (`tmlut::shader::scene`) and of the fitted forms (`tmlut::fit::forms::shader`), so that the code a
//! shader runs is, instruction for instruction, the code [`Tape::values_with`] evaluates on the CPU.
//! What differs between the two is only how the tape's leaves (constants, variables, parameters)
//! and the functions a language lacks are printed: the [`LeafPrinter`] a caller passes.

use crate::shader::{Builtin, Expr, Op, Stmt, Ty, call, let_, name, select};
use crate::tape::{Ins, Tape, reads};
use crate::text::{BinOp, Intrinsic};
use tmlut_loader::error::{Error, Result};

/// How a tape's leaves are printed, and the calls it makes that have no builtin.
pub trait LeafPrinter {
    /// The instructions `i` reads: its operands ([`reads`]) unless a leaf reads more (a table
    /// lookup reads its coordinates).
    fn operands(&self, tape: &Tape, i: usize) -> Vec<usize> {
        reads(&tape.ins[i])
    }

    /// Leaf `i` as an expression over what is printed so far, and the name to bind it with `let`
    /// under, if any.
    fn leaf(&mut self, i: usize, leaf: Leaf, printed: &PrintedExprs) -> Result<(Expr, Option<String>)>;

    /// A call of `function`, which no shading language has as a builtin ([`builtin`]).
    fn helper(&mut self, function: Intrinsic, args: Vec<Expr>) -> Result<Expr>;

    /// `x ^ n` multiplied out (`Ins::PowInt`).
    fn power(&mut self, x: Expr, n: i32) -> Result<Expr>;

    /// Instruction `i` as a value the caller already holds, printed as that expression in place of
    /// what it computes, which is then not printed for it (a form's `roughness`, `sqrt(alpha)` on
    /// the tape, where the function is passed roughness itself).
    fn given(&self, _i: usize) -> Option<Expr> {
        None
    }

    /// The name instruction `i` is bound with, where the tape's author named it (a form's `let`);
    /// otherwise an instruction read more than once is bound as `v<i>`.
    fn named(&self, _i: usize) -> Option<String> {
        None
    }

    /// The error of an instruction read before it is printed, which a tape in order never holds.
    fn out_of_order(&self, i: usize) -> Error;
}

/// An instruction that reads no other: what [`LeafPrinter::leaf`] prints.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Leaf {
    Const(f64),
    /// The tape's variable `k`.
    Var(usize),
    /// The form's parameter `k`.
    Param(usize),
}

/// The instructions' expressions as printed: a name for each bound with `let`, the expression
/// itself for those used once, inline; `None` for what no root reads.
pub struct PrintedExprs {
    exprs: Vec<Option<Expr>>,
}

impl PrintedExprs {
    /// Instruction `k`, or `None` where it is not printed (yet).
    pub fn get(&self, k: usize) -> Option<Expr> {
        self.exprs.get(k).cloned().flatten()
    }
}

/// Print the instructions `roots` depend on into `body`, in the tape's order; `Ok` holds every
/// instruction's expression.
pub fn print(tape: &Tape, roots: &[usize], leaves: &mut dyn LeafPrinter, body: &mut Vec<Stmt>) -> Result<PrintedExprs> {
    let n = tape.ins.len();
    let mut uses = vec![0usize; n];
    let mut live = vec![false; n];
    for &r in roots {
        live[r] = true;
        uses[r] += 1;
    }
    for i in (0..n).rev() {
        if live[i] && leaves.given(i).is_none() {
            for k in leaves.operands(tape, i) {
                live[k] = true;
                uses[k] += 1;
            }
        }
    }
    // Which instructions are constants of the form's text: WGSL types an expression of literals
    // alone as an abstract float, which naga accepts only where it folds it (`3.0 + 4.0`, not
    // `mix(3.0, 4.0, 0.5)`); such a builtin call gets an f32 first argument.
    let mut constant = vec![false; n];
    for i in 0..n {
        constant[i] = match tape.ins[i] {
            Ins::Const(_) => true,
            Ins::Var(_) | Ins::Param(_) => false,
            _ => leaves.operands(tape, i).iter().all(|&k| constant[k]),
        };
    }
    let concrete = |mut args: Vec<Expr>, i: usize| {
        if constant[i]
            && let Some(first) = args.first_mut()
        {
            *first = Expr::Construct(Ty::F32, vec![first.clone()]);
        }
        args
    };
    let mut printed = PrintedExprs { exprs: vec![None; n] };
    for i in (0..n).filter(|&i| live[i]) {
        if let Some(given) = leaves.given(i) {
            printed.exprs[i] = Some(given);
            continue;
        }
        let x = |k: usize| printed.get(k).ok_or_else(|| leaves.out_of_order(i));
        let (expr, bound) = match tape.ins[i] {
            Ins::Const(v) => leaves.leaf(i, Leaf::Const(v), &printed)?,
            Ins::Var(k) => leaves.leaf(i, Leaf::Var(k), &printed)?,
            Ins::Param(k) => leaves.leaf(i, Leaf::Param(k), &printed)?,
            ref ins => {
                let expr = match *ins {
                    Ins::Neg(a) => -x(a)?,
                    Ins::Bin(op, a, b) => {
                        let (a, b) = (x(a)?, x(b)?);
                        match op {
                            BinOp::Add => a + b,
                            BinOp::Sub => a - b,
                            BinOp::Mul => a * b,
                            BinOp::Div => a / b,
                            BinOp::Pow => call(Intrinsic::Pow, concrete(vec![a, b], i)),
                        }
                    }
                    Ins::PowInt(a, n) => {
                        let a = x(a)?;
                        leaves.power(a, n)?
                    }
                    Ins::Call(function, _) => {
                        let args: Vec<Expr> = reads(ins).into_iter().map(x).collect::<Result<_>>()?;
                        match builtin(function) {
                            Some(b) => call(b, concrete(args, i)),
                            None => leaves.helper(function, args)?,
                        }
                    }
                    Ins::Select { otherwise, then, compare, left, right } => {
                        select(x(left)?.op(Op::Compare(compare), x(right)?), x(then)?, x(otherwise)?)
                    }
                    Ins::Const(_) | Ins::Var(_) | Ins::Param(_) => unreachable!("leaves matched above"),
                };
                let bound = leaves.named(i).or_else(|| (uses[i] > 1).then(|| format!("v{i}")));
                (expr, bound)
            }
        };
        printed.exprs[i] = Some(match bound {
            Some(variable) => {
                body.push(let_(&variable, Ty::F32, expr));
                name(&variable)
            }
            None => expr,
        });
    }
    Ok(printed)
}

/// The shader builtin of a function of the language; `None` for `asinh`, which HLSL lacks.
pub fn builtin(f: Intrinsic) -> Option<Builtin> {
    (f != Intrinsic::Asinh).then_some(Builtin::Intrinsic(f))
}

#[cfg(test)]
mod tests {
    use super::{Leaf, LeafPrinter, PrintedExprs, print};
    use crate::shader::{Expr, Lang, Module, Parens, Stmt, Ty, float, func, name};
    use crate::tape::{Ins, Tape};
    use crate::text::{BinOp, Compare, Intrinsic};
    use tmlut_loader::error::{Error, Result};

    /// Variables `x0, x1, ...`, instruction 3 named `named`, helpers as plain calls.
    struct Plain;

    impl LeafPrinter for Plain {
        fn leaf(&mut self, _: usize, leaf: Leaf, _: &PrintedExprs) -> Result<(Expr, Option<String>)> {
            Ok(match leaf {
                Leaf::Var(k) => (name(&format!("x{k}")), None),
                Leaf::Const(v) => (float(v as f32), None),
                Leaf::Param(_) => return Err(Error::invalid("test tape", "a parameter")),
            })
        }
        fn helper(&mut self, function: Intrinsic, args: Vec<Expr>) -> Result<Expr> {
            Ok(func(function.wgsl_name(), args))
        }
        fn power(&mut self, x: Expr, n: i32) -> Result<Expr> {
            Ok(func(&format!("pow_{n}"), vec![x]))
        }
        fn named(&self, i: usize) -> Option<String> {
            (i == 3).then(|| "named".into())
        }
        fn out_of_order(&self, i: usize) -> Error {
            Error::invalid("test tape", format!("instruction {i}"))
        }
    }

    #[test]
    fn what_is_read_twice_or_named_is_bound_once_and_what_no_root_reads_is_not_printed() {
        let mut tape = Tape::default();
        let x = tape.push(Ins::Var(0));
        let y = tape.push(Ins::Var(1));
        let sum = tape.push(Ins::Bin(BinOp::Add, x, y)); // read twice: `v2`
        let named = tape.push(Ins::PowInt(sum, 3)); // named by the caller
        let _dead = tape.push(Ins::Call(Intrinsic::Asinh, [x, 0, 0]));
        let half = tape.push(Ins::Const(0.5));
        let choice =
            tape.push(Ins::Select { otherwise: sum, then: named, compare: Compare::Gt, left: sum, right: half });
        let mut body = Vec::new();
        let printed = print(&tape, &[choice], &mut Plain, &mut body).expect("an ordered tape prints");
        body.push(Stmt::Return(printed.get(choice).expect("the root is printed")));
        let mut module = Module::new(Parens::Minimal);
        module.function("f", vec![("x0", Ty::F32), ("x1", Ty::F32)], Ty::F32, body);
        let wgsl = module.print(Lang::Wgsl);
        assert!(wgsl.contains("let v2: f32 = x0 + x1;"), "{wgsl}");
        assert!(wgsl.contains("let named: f32 = pow_3(v2);"), "{wgsl}");
        assert!(wgsl.contains("return select(v2, named, v2 > 0.5);"), "{wgsl}");
        assert!(!wgsl.contains("asinh"), "an instruction no root reads is printed: {wgsl}");
        assert!(printed.get(4).is_none());
    }
}
