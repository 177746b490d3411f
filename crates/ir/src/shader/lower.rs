//! A function of the shader description lowered onto the IR's tape ([`crate::tape`]), for runs at
//! many points: the FGD packings' lookups, which the CPU model and the packing report run millions
//! of times. [`super::eval`]'s interpreter walks the expressions and finds every local by its name
//! at each step, some 50 times the cost of the same f32 arithmetic on a tape (59 against 1.2 µs a
//! `lossless` FGD lookup, in the tests' build); the lowered function computes the same bits (its
//! operations are the tape's, which are the interpreter's: [`Scalar`](crate::tape::Scalar) for
//! both).
//!
//! What lowers: straight-line code of f32 values (`let` statements, then a `return`): parameters,
//! literals, `+ - * /`, negation, builtins of up to three arguments, `select` on a comparison, and
//! texture reads of one channel (a texel load at coordinates converted with `i32()`, a filtered
//! sample), answered by a [`Textures`] as the interpreter's are. Anything else is refused,
//! naming it, when the function is lowered.

use std::collections::HashMap;

use super::eval::Textures;
use super::{Builtin, Expr, Item, Module, Op, Stmt, Ty};
use crate::tape::{Ins, Tape};
use crate::text::BinOp;
use tmlut_loader::error::{Error, Result};

/// The most coordinates a read takes, a texture array's layer included.
const MAX_COORDINATES: usize = 4;

/// A texture read: the tape's variable past the arguments that holds its value.
#[derive(Debug, Clone, PartialEq)]
enum Read {
    /// A texel load at instructions converted to `i32`, its layer last.
    Load { texture: String, at: Vec<usize>, channel: usize },
    /// A filtered sample at instructions, and the instruction converted to `i32` that holds its layer.
    Sample { texture: String, sampler: String, at: Vec<usize>, layer: Option<usize>, channel: usize },
}

/// A function lowered onto a tape: its f32 parameters are the tape's first variables, its reads
/// the variables after them.
#[derive(Debug, Clone, PartialEq)]
pub struct Lowered {
    tape: Tape,
    /// The f32 parameters (a texture or sampler parameter is its own name to the reads).
    arguments: usize,
    reads: Vec<Read>,
    result: usize,
}

fn refuse(function: &str, what: impl std::fmt::Display) -> Error {
    Error::invalid("shader lowering", format!("`{function}`: {what} does not lower onto a tape"))
}

/// The lowering of one function: the tape so far and what its names hold.
struct Lowering<'m> {
    function: &'m str,
    tape: Tape,
    /// An f32 parameter's variable or a local's instruction.
    values: HashMap<&'m str, usize>,
    /// The texture and sampler parameters.
    resources: Vec<&'m str>,
    arguments: usize,
    reads: Vec<Read>,
}

impl Lowered {
    /// Function `name` of `module`, lowered; refused, naming the first construct that does not
    /// lower, where it is not straight-line code of f32 values.
    pub fn new(module: &Module, name: &str) -> Result<Self> {
        let function = module
            .items
            .iter()
            .find_map(|item| match item {
                Item::Function(f) if f.name == name => Some(f),
                _ => None,
            })
            .ok_or_else(|| Error::invalid("shader lowering", format!("the module has no function `{name}`")))?;
        let mut lowering = Lowering {
            function: name,
            tape: Tape::default(),
            values: HashMap::new(),
            resources: Vec::new(),
            arguments: 0,
            reads: Vec::new(),
        };
        for (parameter, ty) in &function.params {
            match ty {
                Ty::F32 => {
                    let variable = lowering.tape.push(Ins::Var(lowering.arguments));
                    lowering.values.insert(parameter, variable);
                    lowering.arguments += 1;
                }
                Ty::Texture { .. } | Ty::TextureArray | Ty::Sampler => lowering.resources.push(parameter),
                other => return Err(refuse(name, format!("parameter `{parameter}` of type {other:?}"))),
            }
        }
        if function.returns != Ty::F32 {
            return Err(refuse(name, format!("a result of type {:?}", function.returns)));
        }
        for statement in &function.body {
            match statement {
                Stmt::Let { name: local, ty: Ty::F32, value, .. } => {
                    let instruction = lowering.expr(value)?;
                    lowering.values.insert(local, instruction);
                }
                Stmt::Comment(_) => {}
                Stmt::Return(value) => {
                    let result = lowering.expr(value)?;
                    let Lowering { tape, arguments, reads, .. } = lowering;
                    return Ok(Lowered { tape, arguments, reads, result });
                }
                other => return Err(refuse(name, format!("the statement {other:?}"))),
            }
        }
        Err(refuse(name, "a body without a `return`"))
    }

    /// The function at `arguments` (its f32 parameters, in order), its reads answered by
    /// `textures`; `values` is scratch space, reused from run to run.
    pub fn run(&self, arguments: &[f32], textures: &dyn Textures, values: &mut Vec<f32>) -> Result<f32> {
        if arguments.len() != self.arguments {
            return Err(Error::invalid(
                "shader run",
                format!("the lowered function takes {} f32 arguments, called with {}", self.arguments, arguments.len()),
            ));
        }
        let mut failure = None;
        self.tape.values_with(
            |k, earlier: &[f32]| match k.checked_sub(self.arguments) {
                None => arguments[k],
                Some(read) => match self.read(&self.reads[read], earlier, textures) {
                    Ok(value) => value,
                    Err(error) => {
                        failure.get_or_insert(error);
                        f32::NAN
                    }
                },
            },
            values,
        );
        match failure {
            Some(error) => Err(error),
            None => Ok(values[self.result]),
        }
    }

    /// One read at the values computed so far.
    fn read(&self, read: &Read, earlier: &[f32], textures: &dyn Textures) -> Result<f32> {
        // `i32(x)` as the interpreter converts: toward zero, saturating, NaN to 0.
        let integer = |k: usize| earlier[k] as i32;
        // A read has at most three coordinates and a layer (checked when lowered): gathered
        // without the heap, as the lookups read up to 16 times a run.
        let (texel, channel) = match read {
            Read::Load { texture, at, channel } => {
                let mut coordinates = [0; MAX_COORDINATES];
                for (c, &k) in coordinates.iter_mut().zip(at) {
                    *c = integer(k);
                }
                (textures.load(texture, &coordinates[..at.len()])?, *channel)
            }
            Read::Sample { texture, sampler, at, layer, channel } => {
                let mut coordinates = [0.0; MAX_COORDINATES];
                for (c, &k) in coordinates.iter_mut().zip(at) {
                    *c = earlier[k];
                }
                (textures.sample(texture, sampler, &coordinates[..at.len()], layer.map(integer))?, *channel)
            }
        };
        texel.map(|texel| texel[channel]).ok_or_else(|| {
            Error::invalid("shader run", format!("a read of {read:?} that no texels answer, in a lowered function"))
        })
    }
}

impl<'m> Lowering<'m> {
    fn push(&mut self, ins: Ins) -> usize {
        self.tape.push(ins)
    }

    /// The instruction that holds `e`'s value.
    fn expr(&mut self, e: &'m Expr) -> Result<usize> {
        Ok(match e {
            Expr::Name(name) => match self.values.get(name.as_str()) {
                Some(&instruction) => instruction,
                None => return Err(refuse(self.function, format!("`{name}`, not an f32 parameter or local,"))),
            },
            Expr::F32(v) => self.push(Ins::Const(f64::from(*v))),
            Expr::Paren(inner) => self.expr(inner)?,
            Expr::Neg(inner) => {
                let a = self.expr(inner)?;
                self.push(Ins::Neg(a))
            }
            Expr::Binary(op @ (Op::Add | Op::Sub | Op::Mul | Op::Div), a, b) => {
                let op = match op {
                    Op::Add => BinOp::Add,
                    Op::Sub => BinOp::Sub,
                    Op::Mul => BinOp::Mul,
                    _ => BinOp::Div,
                };
                let (a, b) = (self.expr(a)?, self.expr(b)?);
                self.push(Ins::Bin(op, a, b))
            }
            Expr::Call(Builtin::Intrinsic(intrinsic), arguments) if (1..=3).contains(&arguments.len()) => {
                let mut operands = [0; 3];
                for (k, argument) in arguments.iter().enumerate() {
                    operands[k] = self.expr(argument)?;
                }
                // Unused operand slots repeat the first: the tape reads only its intrinsic's.
                for k in arguments.len()..3 {
                    operands[k] = operands[0];
                }
                self.push(Ins::Call(*intrinsic, operands))
            }
            Expr::Select { condition, then, otherwise } => match &**condition {
                Expr::Binary(Op::Compare(compare), left, right) => {
                    let (left, right) = (self.expr(left)?, self.expr(right)?);
                    let (then, otherwise) = (self.expr(then)?, self.expr(otherwise)?);
                    self.push(Ins::Select { otherwise, then, compare: *compare, left, right })
                }
                other => return Err(refuse(self.function, format!("a select on {other:?}"))),
            },
            Expr::Load { coordinates, layer, .. } | Expr::SampleLevel { coordinates, layer, .. }
                if coordinates.len() + usize::from(layer.is_some()) > MAX_COORDINATES =>
            {
                return Err(refuse(self.function, format!("a read at {} coordinates", coordinates.len())));
            }
            Expr::Load { texture, coordinates, layer, swizzle, .. } => {
                let texture = self.resource(texture)?;
                let mut at = Vec::with_capacity(coordinates.len() + 1);
                for coordinate in coordinates.iter().chain(layer.as_deref()) {
                    at.push(self.conversion(coordinate)?);
                }
                let channel = self.channel(swizzle)?;
                self.read(Read::Load { texture, at, channel })
            }
            Expr::SampleLevel { texture, sampler, coordinates, layer, swizzle, .. } => {
                let (texture, sampler) = (self.resource(texture)?, self.resource(sampler)?);
                let at = coordinates.iter().map(|c| self.expr(c)).collect::<Result<Vec<_>>>()?;
                let layer = layer.as_deref().map(|l| self.conversion(l)).transpose()?;
                let channel = self.channel(swizzle)?;
                self.read(Read::Sample { texture, sampler, at, layer, channel })
            }
            other => return Err(refuse(self.function, format!("the expression {other:?}"))),
        })
    }

    /// `i32(x)` of an f32 `x`: the instruction of `x`, which the read converts.
    fn conversion(&mut self, e: &'m Expr) -> Result<usize> {
        match e {
            Expr::Construct(Ty::I32, arguments) if arguments.len() == 1 => self.expr(&arguments[0]),
            other => Err(refuse(self.function, format!("the integer coordinate {other:?} (only `i32(x)` of an f32)"))),
        }
    }

    fn resource(&self, name: &str) -> Result<String> {
        match self.resources.contains(&name) {
            true => Ok(name.to_string()),
            false => Err(refuse(self.function, format!("`{name}`, not a texture or sampler parameter,"))),
        }
    }

    fn channel(&self, swizzle: &str) -> Result<usize> {
        match swizzle {
            "r" | "x" => Ok(0),
            "g" | "y" => Ok(1),
            "b" | "z" => Ok(2),
            "a" | "w" => Ok(3),
            other => Err(refuse(self.function, format!("the swizzle `.{other}` (one channel only)"))),
        }
    }

    /// A read, as the variable after the arguments and the reads before it.
    fn read(&mut self, read: Read) -> usize {
        let variable = self.arguments + self.reads.len();
        self.reads.push(read);
        self.push(Ins::Var(variable))
    }
}

#[cfg(test)]
mod tests {
    use super::super::eval::{Machine, Value};
    use super::super::{Intrinsic, Parens, call, float, let_, name, select, var};
    use super::*;

    /// Texel `(x, y)` of a 4 x 4 texture holds `x + 4 y + 0.5`, a sample the sum of its coordinates.
    struct Ramp;
    impl Textures for Ramp {
        fn load(&self, texture: &str, at: &[i32]) -> Result<Option<[f32; 4]>> {
            assert_eq!(texture, "t");
            let inside = at.iter().all(|&c| (0..4).contains(&c));
            Ok(Some([if inside { at[0] as f32 + 4.0 * at[1] as f32 + 0.5 } else { 0.0 }, 0.0, 0.0, 1.0]))
        }
        fn sample(&self, t: &str, s: &str, at: &[f32], layer: Option<i32>) -> Result<Option<[f32; 4]>> {
            assert_eq!((t, s, layer), ("t", "s", None));
            Ok(Some([0.0, at.iter().sum(), 0.0, 1.0]))
        }
    }

    fn module() -> Module {
        let load = |x: Expr, y: Expr| Expr::Load {
            texture: "t".into(),
            scalar_texture: true,
            coordinates: vec![Expr::Construct(Ty::I32, vec![x]), Expr::Construct(Ty::I32, vec![y])],
            layer: None,
            swizzle: "r",
        };
        let sample = Expr::SampleLevel {
            texture: "t".into(),
            scalar_texture: false,
            sampler: "s".into(),
            coordinates: vec![name("a"), name("b")],
            layer: None,
            swizzle: "g",
        };
        let body = vec![
            let_("a", Ty::F32, call(Intrinsic::Clamp, vec![name("x") * float(3.0), float(0.0), float(3.0)])),
            let_(
                "b",
                Ty::F32,
                select(name("y").lt(float(0.0)), -name("y").sqrt(), call(Intrinsic::Log, vec![name("y")])),
            ),
            let_("c", Ty::F32, load(name("a"), name("a").floor().min(float(2.0)) + float(1.0))),
            let_("d", Ty::F32, sample),
            Stmt::Comment("the result".into()),
            Stmt::Return(Expr::Paren(Box::new(name("c") - name("d") / float(7.0))) * name("b").abs().max(name("x"))),
        ];
        let mut m = Module::new(Parens::Full);
        let params =
            vec![("t", Ty::Texture { dims: 2, scalar: true }), ("s", Ty::Sampler), ("x", Ty::F32), ("y", Ty::F32)];
        m.function("f", params, Ty::F32, body);
        m
    }

    #[test]
    fn a_lowered_function_computes_the_interpreters_bits() {
        let module = module();
        let (lowered, machine) = (Lowered::new(&module, "f").unwrap(), Machine::new(&module).unwrap());
        let mut values = Vec::new();
        let mut runs = 0;
        for x in [-0.3f32, 0.0, 0.2, 0.7, 1.1, 1e-30, f32::NAN] {
            for y in [-2.5f32, -0.0, 0.3, 1.7, 1e20, f32::INFINITY, f32::NAN] {
                let resources = [Value::Resource("t".into()), Value::Resource("s".into())];
                let arguments = resources.into_iter().chain([Value::F32(x), Value::F32(y)]).collect();
                let interpreted = machine.call("f", arguments, &Ramp).unwrap().value.f32().unwrap();
                let on_tape = lowered.run(&[x, y], &Ramp, &mut values).unwrap();
                assert_eq!(on_tape.to_bits(), interpreted.to_bits(), "x {x}, y {y}: {on_tape} vs {interpreted}");
                runs += usize::from(interpreted.is_finite() && interpreted != 0.0);
            }
        }
        assert!(runs > 20, "most points give a finite value that is not 0: {runs}");
    }

    #[test]
    fn what_does_not_lower_is_refused_by_name() {
        let refused = |body: Vec<Stmt>| {
            let mut m = Module::new(Parens::Full);
            m.function("g", vec![("x", Ty::F32)], Ty::F32, body);
            Lowered::new(&m, "g").unwrap_err().to_string()
        };
        let error = refused(vec![var("v", Ty::F32, name("x")), Stmt::Return(name("v"))]);
        assert!(error.contains("`g`") && error.contains("Var"), "{error}");
        let error = refused(vec![Stmt::Return(name("y"))]);
        assert!(error.contains("`y`, not an f32 parameter or local"), "{error}");
        let error = refused(vec![Stmt::Return(call(Builtin::Dot, vec![name("x"), name("x")]))]);
        assert!(error.contains("Dot"), "{error}");
        let error = refused(vec![let_("a", Ty::F32, name("x"))]);
        assert!(error.contains("without a `return`"), "{error}");
        let wrong_arguments = Lowered::new(&module(), "f").unwrap().run(&[1.0], &Ramp, &mut Vec::new());
        assert!(wrong_arguments.unwrap_err().to_string().contains("takes 2 f32 arguments, called with 1"));
        assert!(Lowered::new(&module(), "h").unwrap_err().to_string().contains("no function `h`"));
    }
}
