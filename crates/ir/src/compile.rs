//! Expressions of the form language compiled into a [`Tape`], and a fitted form compiled from
//! the definition a manifest states ([`FormEvaluator::from_definition`]). Neither needs the
//! generator: a renderer built against the loader alone evaluates a built folder's fitted TIR
//! form from its `manifest.json`, exactly as the fit judged it (f32, parameters rounded to f32).

use std::collections::BTreeMap;

use crate::tape::{Ins, MAX_INTEGER_POWER, Scalar, Tape};
use crate::text::{self, BinOp, ExprError, Node};

/// The exponent of `x ^ n` when `n` is an integer literal small enough to multiply out.
pub fn integer_exponent(node: &Node) -> Option<i32> {
    match node {
        Node::Number(v) if v.fract() == 0.0 && v.abs() <= f64::from(MAX_INTEGER_POWER) => Some(*v as i32),
        _ => None,
    }
}

/// Everything resolved so far: the names an expression may read and the tape positions of their
/// values.
#[derive(Default)]
pub struct Scope {
    pub names: BTreeMap<String, usize>,
    pub tape: Tape,
}

impl Scope {
    /// Compile `node` onto the tape; its value is at the returned position.
    pub fn compile(&mut self, node: &Node) -> std::result::Result<usize, ExprError> {
        let ins = match node {
            Node::Number(v) => Ins::Const(*v),
            Node::Name(name, span) => {
                return self.names.get(name).copied().ok_or_else(|| ExprError {
                    at: span.start,
                    message: format!(
                        "unknown name `{name}`; allowed here: {}",
                        self.names.keys().cloned().collect::<Vec<_>>().join(", ")
                    ),
                });
            }
            Node::Neg(a) => Ins::Neg(self.compile(a)?),
            Node::Binary(BinOp::Pow, a, b) if integer_exponent(b).is_some() => {
                Ins::PowInt(self.compile(a)?, integer_exponent(b).unwrap_or(1))
            }
            Node::Binary(op, a, b) => Ins::Bin(*op, self.compile(a)?, self.compile(b)?),
            Node::Call(f, args) => {
                let mut operands = [0; 3];
                for (slot, arg) in operands.iter_mut().zip(args) {
                    *slot = self.compile(arg)?;
                }
                Ins::Call(*f, operands)
            }
            Node::Select { otherwise, then, compare, left, right } => Ins::Select {
                otherwise: self.compile(otherwise)?,
                then: self.compile(then)?,
                compare: *compare,
                left: self.compile(left)?,
                right: self.compile(right)?,
            },
        };
        Ok(self.tape.push(ins))
    }
}

/// The first line of a form's definition: `table = NAME, variables: a, b, c`
/// (`super::form::Form::definition`).
const TABLE_LINE: &str = "table = ";
/// A channel's line of a definition: `channel NAME = expression`.
const CHANNEL_LINE: &str = "channel ";

/// A fitted form compiled once, evaluated in f32 with its parameters rounded to f32 (what its
/// shader computes).
#[derive(Debug, Clone)]
pub struct FormEvaluator {
    pub(super) tape: Tape,
    pub(super) parameters: Vec<f32>,
    /// The lookup variables, in the order [`FormEvaluator::eval`] takes them.
    pub variables: Vec<String>,
}

impl FormEvaluator {
    /// A compiled form and its parameters (rounded to f32 here).
    pub fn new(tape: Tape, variables: Vec<String>, parameters: &[f64]) -> FormEvaluator {
        FormEvaluator { tape, parameters: parameters.iter().map(|&v| v as f32).collect(), variables }
    }

    /// The form a definition states statement by statement, as `Form::definition` writes it and
    /// a manifest's `fit` records it: `table = NAME, variables: ...`, then `name = expression` in
    /// order (derived variables and `let` bindings), then `channel NAME = expression` per channel.
    /// `parameter_names` are the names the expressions read the parameters by, in the order of
    /// `parameters`. The reason of an `Err` says which statement is wrong.
    pub fn from_definition(
        definition: &[String],
        parameter_names: &[String],
        parameters: &[f64],
    ) -> std::result::Result<FormEvaluator, String> {
        if parameter_names.len() != parameters.len() {
            return Err(format!("{} parameter names for {} parameters", parameter_names.len(), parameters.len()));
        }
        let (first, statements) = definition.split_first().ok_or("the definition is empty")?;
        let variables: Vec<String> = first
            .strip_prefix(TABLE_LINE)
            .and_then(|rest| rest.split_once(", variables: "))
            .map(|(_, v)| v.split(", ").map(String::from).collect())
            .ok_or_else(|| format!("its first statement `{first}` is not `table = NAME, variables: ...`"))?;
        let mut scope = Scope::default();
        let defined = |scope: &Scope, name: &str| {
            if scope.names.contains_key(name) { Err(format!("`{name}` is defined twice")) } else { Ok(()) }
        };
        for (k, v) in variables.iter().enumerate() {
            defined(&scope, v)?;
            let slot = scope.tape.push(Ins::Var(k));
            scope.names.insert(v.clone(), slot);
        }
        for (k, p) in parameter_names.iter().enumerate() {
            defined(&scope, p)?;
            let slot = scope.tape.push(Ins::Param(k));
            scope.names.insert(p.clone(), slot);
        }
        for statement in statements {
            let (channel, rest) = match statement.strip_prefix(CHANNEL_LINE) {
                Some(rest) => (true, rest),
                None => (false, statement.as_str()),
            };
            let (name, text) =
                rest.split_once(" = ").ok_or_else(|| format!("statement `{statement}` is not `name = expression`"))?;
            let compiled = text::parse(text).and_then(|node| scope.compile(&node));
            let slot = compiled.map_err(|e| format!("statement `{statement}`: {}", e.message))?;
            if channel {
                scope.tape.outputs.push(slot);
            } else {
                defined(&scope, name)?;
                scope.names.insert(name.to_string(), slot);
            }
        }
        if scope.tape.outputs.is_empty() {
            return Err("the definition states no channel".into());
        }
        Ok(FormEvaluator::new(scope.tape, variables, parameters))
    }

    /// Every channel at one point, in the definition's channel order, the variables in
    /// [`FormEvaluator::variables`] order, computed in `T` with the parameters as the shader holds
    /// them (rounded to f32): in f32 the shader's own operations in its order, in f64 a reference
    /// for them.
    pub fn channels<T: Scalar>(&self, point: &[T]) -> Vec<T> {
        let mut scratch = Vec::with_capacity(self.tape.ins.len());
        let mut out = vec![T::of(0.0); self.tape.outputs.len()];
        let parameters: Vec<T> = self.parameters.iter().map(|&v| T::of(f64::from(v))).collect();
        self.tape.eval(point, &parameters, &mut scratch, &mut out);
        out
    }

    /// The first channel at one point in f32, the variables in [`FormEvaluator::variables`] order.
    pub fn eval(&self, point: &[f64]) -> f64 {
        let point: Vec<f32> = point.iter().map(|&v| v as f32).collect();
        f64::from(self.channels(&point)[0])
    }

    /// The first channel at one point evaluated in f64 ([`FormEvaluator::channels`]).
    pub fn eval_f64(&self, point: &[f64]) -> f64 {
        self.channels(point)[0]
    }

    /// `TIR(mu, alpha, eta)` of a form of the TIR table's variables.
    pub fn tir(&self, mu: f64, alpha: f64, eta: f64) -> f64 {
        self.eval(&[mu, alpha, eta])
    }
}
