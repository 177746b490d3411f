//! The shader description run on the CPU: a function of a [`Module`] interpreted in f32 with
//! WGSL's meaning, its texture reads answered by the caller ([`Textures`]), and what the run costs
//! a GPU counted as it goes ([`ShaderCost`]). A value the run cannot know (an argument given as
//! [`Value::Unknown`], a read no texels answer) is carried as unknown, so that the run of a
//! function with unknown arguments is the count of its cost ([`cost`]), with each branch that
//! constants decide followed as they decide it: a material's index passed as a literal picks its
//! row of a constant table, and the row the branches that material takes.
//!
//! What counts, once each time it is evaluated:
//! - a texture read: a texel load or a filtered sample;
//! - an operation: a binary operator (arithmetic, comparison, `&&`, `||`), a negation, a builtin
//!   call (whatever it computes: `clamp` is one, `dot` is one), a `select`, a scalar conversion
//!   (`i32(x)`, `f32(i)`).
//!
//! Free: literals, names, members, swizzles and indexing (a row of a constant table included),
//! vectors and structs built from their parts, assignments. A call of a module function counts its
//! body where it is called, as shader compilers inline it. Both values of a `select` count, as a
//! GPU computes both; so do both sides of `&&` and `||`. A branch counts its condition, then the
//! branch taken where constants decide the condition, else the larger count of the two branches,
//! of reads and of operations each.

use std::collections::HashMap;

use super::{Builtin, Expr, Function, Intrinsic, Item, Module, Op, Stmt, Ty};
use crate::tape::Scalar;
use tmlut_loader::error::{Error, Result};
pub use tmlut_loader::loader::shader::ShaderCost;

/// A value of the shader's arithmetic, or one the run cannot know.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// Not known to the run: an unknown argument, a read no texels answer, or computed from one.
    Unknown,
    F32(f32),
    I32(i32),
    U32(u32),
    Bool(bool),
    /// A `vecN<f32>`.
    Vector(Vec<f32>),
    Array(Vec<Value>),
    /// A struct's fields, in order.
    Struct(Vec<(String, Value)>),
    /// A texture or a sampler, by the name of its binding.
    Resource(String),
}

impl Value {
    /// Whether every part of it is known.
    pub fn is_known(&self) -> bool {
        match self {
            Value::Unknown => false,
            Value::Array(elements) => elements.iter().all(Value::is_known),
            Value::Struct(fields) => fields.iter().all(|(_, v)| v.is_known()),
            _ => true,
        }
    }

    /// An f32, or `None`.
    pub fn f32(&self) -> Option<f32> {
        match self {
            Value::F32(v) => Some(*v),
            _ => None,
        }
    }

    /// A vector's components (an f32 as one), or `None`.
    pub fn components(&self) -> Option<Vec<f32>> {
        match self {
            Value::Vector(v) => Some(v.clone()),
            Value::F32(v) => Some(vec![*v]),
            _ => None,
        }
    }

    /// Field `name` of a struct.
    pub fn field(&self, name: &str) -> Option<&Value> {
        match self {
            Value::Struct(fields) => fields.iter().find(|(n, _)| n == name).map(|(_, v)| v),
            _ => None,
        }
    }

    /// Element `k` of an array.
    pub fn element(&self, k: usize) -> Option<&Value> {
        match self {
            Value::Array(elements) => elements.get(k),
            _ => None,
        }
    }
}

/// The texels a run reads.
pub trait Textures {
    /// `textureLoad` of `texture` at integer coordinates `at` (a texture array's layer last): its
    /// four channels, or `None` where it is not known.
    fn load(&self, texture: &str, at: &[i32]) -> Result<Option<[f32; 4]>>;

    /// `textureSampleLevel(texture, sampler, coordinates[, layer], 0.0)`: four channels, or `None`
    /// where it is not known.
    fn sample(&self, texture: &str, sampler: &str, coordinates: &[f32], layer: Option<i32>)
    -> Result<Option<[f32; 4]>>;
}

/// No texels: every read is unknown, as [`cost`] runs.
pub struct NoTexels;

impl Textures for NoTexels {
    fn load(&self, _: &str, _: &[i32]) -> Result<Option<[f32; 4]>> {
        Ok(None)
    }
    fn sample(&self, _: &str, _: &str, _: &[f32], _: Option<i32>) -> Result<Option<[f32; 4]>> {
        Ok(None)
    }
}

/// What a run returned, and what it cost.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    pub value: Value,
    pub cost: ShaderCost,
}

/// Calls nested deeper than this are refused: shaders do not recurse, a module that does is wrong.
const MAX_DEPTH: usize = 64;

/// A module ready to run: its functions, structs, and constants evaluated.
pub struct Machine<'m> {
    functions: HashMap<&'m str, &'m Function>,
    structs: HashMap<&'m str, &'m [(String, Ty)]>,
    globals: HashMap<&'m str, Value>,
    /// The storage buffers the module binds, by name: their contents where the caller gave them
    /// ([`Machine::bind_buffer`]), else `None` and every read of them unknown.
    buffers: HashMap<&'m str, Option<Vec<f32>>>,
}

type Scope = HashMap<String, Value>;

/// One run's texels, count and call depth.
struct Context<'t> {
    textures: &'t dyn Textures,
    cost: ShaderCost,
    depth: usize,
}

impl Context<'_> {
    fn operation(&mut self) {
        self.cost.operations += 1;
    }
}

/// The cost of one call of `function` of `module` (the module docs state what counts), its
/// arguments unknown (a texture or sampler it takes is the one of its parameter's name, its
/// texels unknown too): the branches constants decide are followed, the others counted at their
/// larger branch.
pub fn cost(module: &Module, function: &str) -> Result<ShaderCost> {
    cost_on(&Machine::new(module)?, function)
}

/// [`cost`] of each of `functions`, the module's storage buffer `buffer` holding `values`: the
/// branches its contents decide are followed too.
pub fn costs_with_buffer(
    module: &Module,
    functions: &[&str],
    (buffer, values): (&str, Vec<f32>),
) -> Result<Vec<ShaderCost>> {
    let mut machine = Machine::new(module)?;
    machine.bind_buffer(buffer, values)?;
    functions.iter().map(|function| cost_on(&machine, function)).collect()
}

fn cost_on(machine: &Machine, function: &str) -> Result<ShaderCost> {
    let arguments = machine
        .function(function)?
        .params
        .iter()
        .map(|(name, ty)| match ty {
            Ty::Texture { .. } | Ty::TextureArray | Ty::Sampler => Value::Resource(name.clone()),
            _ => Value::Unknown,
        })
        .collect();
    Ok(machine.call(function, arguments, &NoTexels)?.cost)
}

fn refuse(reason: impl Into<String>) -> Error {
    Error::invalid("shader run", reason)
}

impl<'m> Machine<'m> {
    /// The machine of `module`, its constants evaluated (refused where one cannot be).
    pub fn new(module: &'m Module) -> Result<Self> {
        let mut machine = Machine {
            functions: HashMap::new(),
            structs: HashMap::new(),
            globals: HashMap::new(),
            buffers: HashMap::new(),
        };
        for item in &module.items {
            match item {
                Item::Function(function) => {
                    machine.functions.insert(function.name.as_str(), function);
                }
                Item::Struct { name, fields } => {
                    machine.structs.insert(name.as_str(), fields.as_slice());
                }
                Item::Binding { name, ty: Ty::StorageArray, .. } => {
                    machine.buffers.insert(name.as_str(), None);
                }
                Item::Binding { name, .. } => {
                    machine.globals.insert(name.as_str(), Value::Resource(name.clone()));
                }
                Item::Constant { name, value, .. } => {
                    let mut context = Context { textures: &NoTexels, cost: ShaderCost::default(), depth: 0 };
                    let value = machine.eval(value, &Scope::new(), &mut context)?;
                    machine.globals.insert(name.as_str(), value);
                }
                Item::Comment(_) | Item::Blank => {}
            }
        }
        Ok(machine)
    }

    /// Bind `values` as the contents of the module's storage buffer `name`, which runs then read
    /// (a read past its end refused, where a GPU would read some element or 0).
    pub fn bind_buffer(&mut self, name: &str, values: Vec<f32>) -> Result<()> {
        match self.buffers.get_mut(name) {
            Some(contents) => {
                *contents = Some(values);
                Ok(())
            }
            None => Err(refuse(format!("the module binds no storage buffer `{name}`"))),
        }
    }

    /// A module constant's value (a binding's is its name), or `None` where there is none.
    pub fn global(&self, name: &str) -> Option<&Value> {
        self.globals.get(name)
    }

    fn function(&self, name: &str) -> Result<&'m Function> {
        self.functions.get(name).copied().ok_or_else(|| refuse(format!("the module has no function `{name}`")))
    }

    /// Function `name` called with `arguments`, its reads answered by `textures`.
    pub fn call(&self, name: &str, arguments: Vec<Value>, textures: &dyn Textures) -> Result<Run> {
        let mut context = Context { textures, cost: ShaderCost::default(), depth: 0 };
        let value = self.invoke(name, arguments, &mut context)?;
        Ok(Run { value, cost: context.cost })
    }

    fn invoke(&self, name: &str, arguments: Vec<Value>, cx: &mut Context) -> Result<Value> {
        let function = self.function(name)?;
        if function.params.len() != arguments.len() {
            return Err(refuse(format!(
                "`{name}` takes {} arguments, called with {}",
                function.params.len(),
                arguments.len()
            )));
        }
        if cx.depth == MAX_DEPTH {
            return Err(refuse(format!("calls nest deeper than {MAX_DEPTH} at `{name}`: does the module recurse?")));
        }
        cx.depth += 1;
        let mut scope: Scope = function.params.iter().map(|(p, _)| p.clone()).zip(arguments).collect();
        let returned = self.run(&function.body, &mut scope, cx)?;
        cx.depth -= 1;
        returned.ok_or_else(|| refuse(format!("`{name}` ends without returning")))
    }

    /// Runs `body`; `Some` of what it returns.
    fn run(&self, body: &[Stmt], scope: &mut Scope, cx: &mut Context) -> Result<Option<Value>> {
        for statement in body {
            match statement {
                Stmt::Let { name, value, .. } | Stmt::Var { name, value: Some(value), .. } => {
                    let value = self.eval(value, scope, cx)?;
                    scope.insert(name.clone(), value);
                }
                Stmt::Var { name, ty, value: None } => {
                    scope.insert(name.clone(), self.zero(ty)?);
                }
                Stmt::Assign(target, value) => {
                    let value = self.eval(value, scope, cx)?;
                    let path = self.path(target, scope, cx)?;
                    assign(scope, &path, value)?;
                }
                Stmt::If { condition, then, otherwise } => match self.eval(condition, scope, cx)? {
                    Value::Bool(holds) => {
                        if let Some(returned) = self.run(if holds { then } else { otherwise }, scope, cx)? {
                            return Ok(Some(returned));
                        }
                    }
                    Value::Unknown => self.either(&[then, otherwise], scope, cx)?,
                    other => return Err(refuse(format!("a branch on {other:?}, not a bool"))),
                },
                Stmt::Return(value) => return Ok(Some(self.eval(value, scope, cx)?)),
                Stmt::Switch { selector, cases, default } => {
                    let chosen = match self.eval(selector, scope, cx)? {
                        Value::U32(k) => Some(cases.iter().find(|(label, _)| *label == k).map_or(default, |(_, b)| b)),
                        Value::Unknown => None,
                        other => return Err(refuse(format!("a switch on {other:?}, not a u32"))),
                    };
                    match chosen {
                        Some(body) => {
                            if let Some(returned) = self.run(body, scope, cx)? {
                                return Ok(Some(returned));
                            }
                        }
                        None => {
                            let branches: Vec<&[Stmt]> =
                                cases.iter().map(|(_, b)| b.as_slice()).chain([default.as_slice()]).collect();
                            self.either(&branches, scope, cx)?;
                        }
                    }
                }
                Stmt::Comment(_) => {}
            }
        }
        Ok(None)
    }

    /// Branches no constant decides between: each run from `scope`, the largest count of them
    /// kept, and what they leave unlike unknown after them.
    fn either(&self, branches: &[&[Stmt]], scope: &mut Scope, cx: &mut Context) -> Result<()> {
        let before = cx.cost;
        let mut ends = Vec::new();
        for branch in branches {
            let mut inner = scope.clone();
            cx.cost = ShaderCost::default();
            if self.run(branch, &mut inner, cx)?.is_some() {
                return Err(refuse("a `return` in a branch whose condition no constant decides"));
            }
            ends.push((inner, cx.cost));
        }
        cx.cost = ShaderCost {
            texture_reads: before.texture_reads + ends.iter().map(|(_, c)| c.texture_reads).max().unwrap_or(0),
            operations: before.operations + ends.iter().map(|(_, c)| c.operations).max().unwrap_or(0),
        };
        for (name, value) in scope.iter_mut() {
            let mut after = ends.iter().map(|(end, _)| end.get(name));
            let first = after.next().flatten();
            *value = match first {
                Some(x) if after.all(|other| other == Some(x)) => x.clone(),
                _ => Value::Unknown,
            };
        }
        Ok(())
    }

    /// The zero value of `ty`, as WGSL zero-initialises a `var`.
    fn zero(&self, ty: &Ty) -> Result<Value> {
        Ok(match ty {
            Ty::F32 => Value::F32(0.0),
            Ty::I32 => Value::I32(0),
            Ty::U32 => Value::U32(0),
            Ty::Bool => Value::Bool(false),
            Ty::Vec(n) => Value::Vector(vec![0.0; *n as usize]),
            Ty::Array(element, n) => Value::Array(vec![self.zero(element)?; *n]),
            Ty::Named(name) => Value::Struct(
                self.fields(name)?.iter().map(|(f, ty)| Ok((f.clone(), self.zero(ty)?))).collect::<Result<_>>()?,
            ),
            other => return Err(refuse(format!("no zero value of {other:?}"))),
        })
    }

    fn fields(&self, name: &str) -> Result<&'m [(String, Ty)]> {
        self.structs.get(name).copied().ok_or_else(|| refuse(format!("the module has no struct `{name}`")))
    }

    /// The place `target` names: a local, then members and elements of it.
    fn path(&self, target: &Expr, scope: &Scope, cx: &mut Context) -> Result<(String, Vec<Step>)> {
        Ok(match target {
            Expr::Name(name) => (name.clone(), Vec::new()),
            Expr::Member(base, field) => {
                let (name, mut steps) = self.path(base, scope, cx)?;
                steps.push(Step::Field(field.clone()));
                (name, steps)
            }
            Expr::Index(base, k) => {
                let (name, mut steps) = self.path(base, scope, cx)?;
                steps.push(Step::At(Some(*k)));
                (name, steps)
            }
            Expr::Element(base, index) => {
                let (name, mut steps) = self.path(base, scope, cx)?;
                steps.push(Step::At(index_of(&self.eval(index, scope, cx)?)?));
                (name, steps)
            }
            other => return Err(refuse(format!("an assignment to {other:?}"))),
        })
    }

    fn eval(&self, e: &Expr, scope: &Scope, cx: &mut Context) -> Result<Value> {
        let all = |values: &[Expr], cx: &mut Context| -> Result<Vec<Value>> {
            values.iter().map(|v| self.eval(v, scope, cx)).collect()
        };
        Ok(match e {
            Expr::Name(name) => match scope.get(name).or_else(|| self.globals.get(name.as_str())) {
                Some(value) => value.clone(),
                None => return Err(refuse(format!("`{name}` is not declared"))),
            },
            Expr::F32(v) => Value::F32(*v),
            Expr::I32(v) => Value::I32(*v),
            Expr::U32(v) => Value::U32(*v),
            Expr::Paren(inner) => self.eval(inner, scope, cx)?,
            Expr::Neg(inner) => {
                cx.operation();
                match self.eval(inner, scope, cx)? {
                    Value::I32(v) => Value::I32(v.wrapping_neg()),
                    other => elementwise(&[other], |x| -x[0])?,
                }
            }
            Expr::Binary(op, a, b) => {
                cx.operation();
                let (a, b) = (self.eval(a, scope, cx)?, self.eval(b, scope, cx)?);
                binary(*op, a, b)?
            }
            Expr::Call(builtin, arguments) => {
                cx.operation();
                builtin_of(*builtin, &all(arguments, cx)?)?
            }
            Expr::Function(name, arguments) => {
                let arguments = all(arguments, cx)?;
                self.invoke(name, arguments, cx)?
            }
            Expr::Construct(ty, arguments) => {
                if matches!(ty, Ty::F32 | Ty::I32 | Ty::U32 | Ty::Bool) {
                    cx.operation();
                }
                construct(ty, all(arguments, cx)?)?
            }
            Expr::Aggregate(ty, parts) => {
                let parts = all(parts, cx)?;
                match ty {
                    Ty::Named(name) => {
                        let fields = self.fields(name)?;
                        if fields.len() != parts.len() {
                            return Err(refuse(format!(
                                "`{name}` of {} values for {} fields",
                                parts.len(),
                                fields.len()
                            )));
                        }
                        Value::Struct(fields.iter().map(|(f, _)| f.clone()).zip(parts).collect())
                    }
                    _ => Value::Array(parts),
                }
            }
            Expr::Member(base, field) => match self.eval(base, scope, cx)? {
                Value::Unknown => Value::Unknown,
                structure @ Value::Struct(_) => structure
                    .field(field)
                    .cloned()
                    .ok_or_else(|| refuse(format!("no field `{field}` in {structure:?}")))?,
                other => match other.components() {
                    Some(components) => swizzle(&components, field)?,
                    None => return Err(refuse(format!("member `{field}` of {other:?}"))),
                },
            },
            Expr::Index(base, k) => element(self.eval(base, scope, cx)?, Some(*k))?,
            Expr::Element(base, index) => match &**base {
                Expr::Name(buffer) if !scope.contains_key(buffer) && self.buffers.contains_key(buffer.as_str()) => {
                    let k = index_of(&self.eval(index, scope, cx)?)?;
                    match (&self.buffers[buffer.as_str()], k) {
                        (Some(values), Some(k)) => Value::F32(*values.get(k).ok_or_else(|| {
                            refuse(format!("element {k} of storage buffer `{buffer}` of {}", values.len()))
                        })?),
                        _ => Value::Unknown,
                    }
                }
                _ => {
                    let base = self.eval(base, scope, cx)?;
                    element(base, index_of(&self.eval(index, scope, cx)?)?)?
                }
            },
            Expr::Select { condition, then, otherwise } => {
                cx.operation();
                let condition = self.eval(condition, scope, cx)?;
                let (then, otherwise) = (self.eval(then, scope, cx)?, self.eval(otherwise, scope, cx)?);
                match condition {
                    Value::Bool(holds) => match holds {
                        true => then,
                        false => otherwise,
                    },
                    Value::Unknown if then == otherwise => then,
                    Value::Unknown => Value::Unknown,
                    other => return Err(refuse(format!("a select on {other:?}, not a bool"))),
                }
            }
            Expr::Load { texture, coordinates, layer, swizzle: channels, .. } => {
                cx.cost.texture_reads += 1;
                let texture = self.resource(texture, scope)?;
                let at: Vec<Option<i32>> = coordinates
                    .iter()
                    .chain(layer.as_deref())
                    .map(|c| integer(&self.eval(c, scope, cx)?))
                    .collect::<Result<_>>()?;
                match at.into_iter().collect::<Option<Vec<i32>>>() {
                    Some(at) => match cx.textures.load(&texture, &at)? {
                        Some(texel) => swizzle(&texel, channels)?,
                        None => Value::Unknown,
                    },
                    None => Value::Unknown,
                }
            }
            Expr::SampleLevel { texture, sampler, coordinates, layer, swizzle: channels, .. } => {
                cx.cost.texture_reads += 1;
                let (texture, sampler) = (self.resource(texture, scope)?, self.resource(sampler, scope)?);
                let at: Vec<Value> = all(coordinates, cx)?;
                let at: Option<Vec<f32>> =
                    at.iter().map(|c| c.components()).collect::<Option<Vec<_>>>().map(|c| c.concat());
                let layer = match layer {
                    Some(layer) => integer(&self.eval(layer, scope, cx)?)?.map(Some),
                    None => Some(None),
                };
                match (at, layer) {
                    (Some(at), Some(layer)) => match cx.textures.sample(&texture, &sampler, &at, layer)? {
                        Some(texel) => swizzle(&texel, channels)?,
                        None => Value::Unknown,
                    },
                    _ => Value::Unknown,
                }
            }
        })
    }

    /// The binding a texture or sampler name stands for (a helper's parameter, or the binding).
    fn resource(&self, name: &str, scope: &Scope) -> Result<String> {
        match scope.get(name).or_else(|| self.globals.get(name)) {
            Some(Value::Resource(binding)) => Ok(binding.clone()),
            other => Err(refuse(format!("`{name}` is {other:?}, not a texture or sampler"))),
        }
    }
}

/// A step from a local to the place an assignment writes: a field, or an element (`None` where
/// its index is unknown).
enum Step {
    Field(String),
    At(Option<usize>),
}

/// `value` stored at `path`; where the path passes an unknown value or index, what it would
/// write into becomes unknown.
fn assign(scope: &mut Scope, (name, steps): &(String, Vec<Step>), value: Value) -> Result<()> {
    let mut place = scope.get_mut(name).ok_or_else(|| refuse(format!("an assignment to undeclared `{name}`")))?;
    for step in steps {
        place = match (place, step) {
            (Value::Unknown, _) => return Ok(()),
            (Value::Struct(fields), Step::Field(field)) => match fields.iter_mut().find(|(n, _)| n == field) {
                Some((_, v)) => v,
                None => return Err(refuse(format!("an assignment to missing field `{field}`"))),
            },
            (Value::Array(elements), Step::At(Some(k))) => {
                let n = elements.len();
                elements.get_mut(*k).ok_or_else(|| refuse(format!("an assignment to element {k} of {n}")))?
            }
            (array @ Value::Array(_), Step::At(None)) => {
                *array = Value::Unknown;
                return Ok(());
            }
            (other, _) => return Err(refuse(format!("an assignment into {other:?}"))),
        };
    }
    *place = value;
    Ok(())
}

/// An array index: `None` where unknown.
fn index_of(index: &Value) -> Result<Option<usize>> {
    Ok(match index {
        Value::U32(k) => Some(*k as usize),
        Value::I32(k) if *k >= 0 => Some(*k as usize),
        Value::Unknown => None,
        other => return Err(refuse(format!("an index of {other:?}"))),
    })
}

/// Element `k` of `base` (unknown where either is), refused past its end, where a GPU would read
/// some element or 0.
fn element(base: Value, k: Option<usize>) -> Result<Value> {
    match (base, k) {
        (Value::Unknown, _) | (Value::Array(_), None) => Ok(Value::Unknown),
        (Value::Array(elements), Some(k)) => {
            let n = elements.len();
            elements.into_iter().nth(k).ok_or_else(|| refuse(format!("element {k} of an array of {n}")))
        }
        (Value::Vector(components), Some(k)) => {
            components.get(k).map(|v| Value::F32(*v)).ok_or_else(|| refuse(format!("component {k} of {components:?}")))
        }
        (other, _) => Err(refuse(format!("an element of {other:?}"))),
    }
}

/// An i32 texel coordinate or layer (a u32 taken as one): `None` where unknown.
fn integer(value: &Value) -> Result<Option<i32>> {
    Ok(match value {
        Value::I32(v) => Some(*v),
        Value::U32(v) => Some(*v as i32),
        Value::Unknown => None,
        other => return Err(refuse(format!("{other:?} where an integer is expected"))),
    })
}

/// `f` applied to the arguments' components (a scalar broadcast over a vector's); unknown where an
/// argument is.
fn elementwise(values: &[Value], f: impl Fn(&[f32]) -> f32) -> Result<Value> {
    if values.contains(&Value::Unknown) {
        return Ok(Value::Unknown);
    }
    let components: Vec<Vec<f32>> = values
        .iter()
        .map(|v| v.components().ok_or_else(|| refuse(format!("{v:?} in f32 arithmetic"))))
        .collect::<Result<_>>()?;
    let width = components.iter().map(Vec::len).max().unwrap_or(1);
    let at = |k: usize| -> Vec<f32> { components.iter().map(|c| if c.len() == 1 { c[0] } else { c[k] }).collect() };
    Ok(match values.iter().any(|v| matches!(v, Value::Vector(_))) {
        true => Value::Vector((0..width).map(|k| f(&at(k))).collect()),
        false => Value::F32(f(&at(0))),
    })
}

fn binary(op: Op, a: Value, b: Value) -> Result<Value> {
    use Value::*;
    // Integer division as WGSL defines it: by zero (or i32::MIN by -1) is the dividend.
    Ok(match (op, &a, &b) {
        (_, Unknown, _) | (_, _, Unknown) => Unknown,
        (Op::And, Bool(x), Bool(y)) => Bool(*x && *y),
        (Op::Or, Bool(x), Bool(y)) => Bool(*x || *y),
        (Op::Compare(compare), F32(x), F32(y)) => Bool(compare.holds(*x as f64, *y as f64)),
        (Op::Compare(compare), I32(x), I32(y)) => Bool(compare.holds(*x as f64, *y as f64)),
        (Op::Compare(compare), U32(x), U32(y)) => Bool(compare.holds(*x as f64, *y as f64)),
        (Op::Add, I32(x), I32(y)) => I32(x.wrapping_add(*y)),
        (Op::Sub, I32(x), I32(y)) => I32(x.wrapping_sub(*y)),
        (Op::Mul, I32(x), I32(y)) => I32(x.wrapping_mul(*y)),
        (Op::Div, I32(x), I32(y)) => I32(x.checked_div(*y).unwrap_or(*x)),
        (Op::Add, U32(x), U32(y)) => U32(x.wrapping_add(*y)),
        (Op::Sub, U32(x), U32(y)) => U32(x.wrapping_sub(*y)),
        (Op::Mul, U32(x), U32(y)) => U32(x.wrapping_mul(*y)),
        (Op::Div, U32(x), U32(y)) => U32(x.checked_div(*y).unwrap_or(*x)),
        (Op::Add | Op::Sub | Op::Mul | Op::Div, F32(_) | Vector(_), F32(_) | Vector(_)) => {
            elementwise(&[a, b], |x| match op {
                Op::Add => x[0] + x[1],
                Op::Sub => x[0] - x[1],
                Op::Mul => x[0] * x[1],
                _ => x[0] / x[1],
            })?
        }
        _ => return Err(refuse(format!("{op:?} of {a:?} and {b:?}"))),
    })
}

fn builtin_of(builtin: Builtin, values: &[Value]) -> Result<Value> {
    match builtin {
        Builtin::Dot => match (values.first().and_then(Value::components), values.get(1).and_then(Value::components)) {
            // In order, as the CPU sums a split sum's channels.
            (Some(a), Some(b)) if a.len() == b.len() => {
                Ok(Value::F32(a.iter().zip(&b).fold(0.0, |sum, (x, y)| sum + x * y)))
            }
            _ if values.contains(&Value::Unknown) => Ok(Value::Unknown),
            _ => Err(refuse(format!("dot of {values:?}"))),
        },
        Builtin::Intrinsic(intrinsic) => elementwise(values, |x| intrinsic_of(intrinsic, x)),
    }
}

/// A builtin function of f32 arguments, with WGSL's meaning (the form language's evaluator's).
fn intrinsic_of(f: Intrinsic, x: &[f32]) -> f32 {
    let clamp = |v: f32, lo: f32, hi: f32| Scalar::min(Scalar::max(v, lo), hi);
    match f {
        Intrinsic::Min => Scalar::min(x[0], x[1]),
        Intrinsic::Max => Scalar::max(x[0], x[1]),
        Intrinsic::Clamp => clamp(x[0], x[1], x[2]),
        Intrinsic::Pow => Scalar::powf(x[0], x[1]),
        Intrinsic::Atan2 => Scalar::atan2(x[0], x[1]),
        Intrinsic::Step => (x[0] <= x[1]) as u8 as f32,
        Intrinsic::Mix => x[0] * (1.0 - x[2]) + x[1] * x[2],
        Intrinsic::Smoothstep => {
            let t = clamp((x[2] - x[0]) / (x[1] - x[0]), 0.0, 1.0);
            t * t * (3.0 - 2.0 * t)
        }
        unary => <f32 as Scalar>::unary(unary, x[0]),
    }
}

/// A constructor or conversion: `vecN(x)` splats, `vecN(a, b, ...)` gathers, `i32(x)` and `u32(x)`
/// truncate toward zero (saturating, as WGSL converts), `f32(i)` converts.
fn construct(ty: &Ty, values: Vec<Value>) -> Result<Value> {
    use Value::*;
    if values.contains(&Unknown) {
        return Ok(Unknown);
    }
    Ok(match (ty, &values[..]) {
        (Ty::I32, [F32(x)]) => I32(*x as i32),
        (Ty::I32, [I32(x)]) => I32(*x),
        (Ty::I32, [U32(x)]) => I32(*x as i32),
        (Ty::U32, [F32(x)]) => U32(*x as u32),
        (Ty::U32, [I32(x)]) => U32(*x as u32),
        (Ty::U32, [U32(x)]) => U32(*x),
        (Ty::F32, [F32(x)]) => F32(*x),
        (Ty::F32, [I32(x)]) => F32(*x as f32),
        (Ty::F32, [U32(x)]) => F32(*x as f32),
        (Ty::Vec(n), _) => {
            let components: Vec<f32> = values
                .iter()
                .map(|v| v.components().ok_or_else(|| refuse(format!("{v:?} in a vector"))))
                .collect::<Result<Vec<_>>>()?
                .concat();
            match components.len() {
                1 => Vector(vec![components[0]; *n as usize]),
                k if k == *n as usize => Vector(components),
                k => return Err(refuse(format!("vec{n} of {k} components"))),
            }
        }
        _ => return Err(refuse(format!("a constructor of {ty:?} from {values:?}"))),
    })
}

/// Components `names` (`xyzw` or `rgba`) of `vector`: a scalar for one.
fn swizzle(vector: &[f32], names: &str) -> Result<Value> {
    let picked: Vec<f32> = names
        .chars()
        .map(|c| {
            let k = "xyzw".find(c).or_else(|| "rgba".find(c));
            k.and_then(|k| vector.get(k).copied()).ok_or_else(|| refuse(format!("swizzle `{names}` of {vector:?}")))
        })
        .collect::<Result<_>>()?;
    Ok(match picked[..] {
        [single] => Value::F32(single),
        _ => Value::Vector(picked),
    })
}

#[cfg(test)]
mod tests {
    use super::super::{Lang, Parens, call, float, func, let_, name, select, var};
    use super::*;

    /// `helper(x) = sqrt(x) * 2` and `f(x) = select(helper(x), -x, x < 0) + 1`.
    fn module() -> Module {
        let mut m = Module::new(Parens::Minimal);
        m.function("helper", vec![("x", Ty::F32)], Ty::F32, vec![Stmt::Return(name("x").sqrt() * float(2.0))]);
        let chosen = select(name("x").lt(float(0.0)), -name("x"), func("helper", vec![name("x")]));
        m.function("f", vec![("x", Ty::F32)], Ty::F32, vec![Stmt::Return(chosen + float(1.0))]);
        m
    }

    #[test]
    fn a_run_computes_in_f32_and_counts_each_operation_and_the_helpers_where_called() {
        let module = module();
        let machine = Machine::new(&module).unwrap();
        let run = machine.call("f", vec![Value::F32(2.25)], &NoTexels).unwrap();
        assert_eq!(run.value, Value::F32(4.0));
        // `<`, negation, select, `+`, and the helper's sqrt and `*`: both values of the select.
        assert_eq!(run.cost, ShaderCost { texture_reads: 0, operations: 6 });
        assert_eq!(cost(&module, "f").unwrap(), run.cost, "the count does not depend on the values");
        assert_eq!(machine.call("f", vec![Value::Unknown], &NoTexels).unwrap().value, Value::Unknown);
    }

    /// `h(k, x)`: `x`, times `x * x` more where `k > 1`; called with `k` a literal by `low` and
    /// `high`.
    fn branching() -> Module {
        let mut m = Module::new(Parens::Minimal);
        let body = vec![
            var("r", Ty::F32, name("x")),
            Stmt::If {
                condition: name("k").gt(Expr::U32(1)),
                then: vec![super::super::assign(name("r"), name("r") * name("x") * name("x"))],
                otherwise: Vec::new(),
            },
            Stmt::Return(name("r")),
        ];
        m.function("h", vec![("k", Ty::U32), ("x", Ty::F32)], Ty::F32, body);
        for (caller, k) in [("low", 0), ("high", 2)] {
            m.function(
                caller,
                vec![("x", Ty::F32)],
                Ty::F32,
                vec![Stmt::Return(func("h", vec![Expr::U32(k), name("x")]))],
            );
        }
        m
    }

    #[test]
    fn a_branch_constants_decide_counts_the_branch_taken_and_another_the_larger() {
        let module = branching();
        let ops = |f: &str| cost(&module, f).unwrap().operations;
        assert_eq!((ops("low"), ops("high"), ops("h")), (1, 3, 3));
        let machine = Machine::new(&module).unwrap();
        let run = machine.call("h", vec![Value::Unknown, Value::F32(3.0)], &NoTexels).unwrap();
        assert_eq!(run.value, Value::Unknown, "the branches leave r unlike");
        assert_eq!(machine.call("high", vec![Value::F32(3.0)], &NoTexels).unwrap().value, Value::F32(27.0));
    }

    /// A table of two rows, a texture array and a sampler, read at a row the index picks.
    #[test]
    fn a_sample_reads_the_texels_the_caller_answers_at_the_coordinates_computed() {
        struct Answer;
        impl Textures for Answer {
            fn load(&self, _: &str, _: &[i32]) -> Result<Option<[f32; 4]>> {
                Ok(None)
            }
            fn sample(&self, t: &str, s: &str, at: &[f32], layer: Option<i32>) -> Result<Option<[f32; 4]>> {
                assert_eq!((t, s), ("tex", "smp"));
                Ok(Some([at[0], at[1], layer.unwrap() as f32, 0.5]))
            }
        }
        let mut m = Module::new(Parens::Minimal);
        m.push(Item::Struct { name: "Row".into(), fields: vec![("layer".into(), Ty::U32), ("y".into(), Ty::F32)] });
        let row = |layer: u32, y: f32| Expr::Aggregate(Ty::Named("Row".into()), vec![Expr::U32(layer), float(y)]);
        let table = Ty::Array(Box::new(Ty::Named("Row".into())), 2);
        m.push(Item::Constant {
            name: "rows".into(),
            ty: table.clone(),
            value: Expr::Aggregate(table, vec![row(3, 0.25), row(5, 0.75)]),
        });
        m.push(Item::Binding { group: 0, binding: 0, name: "tex".into(), ty: Ty::TextureArray });
        m.push(Item::Binding { group: 0, binding: 1, name: "smp".into(), ty: Ty::Sampler });
        let sample = Expr::SampleLevel {
            texture: "tex".into(),
            scalar_texture: false,
            sampler: "smp".into(),
            coordinates: vec![name("x"), name("r").member("y")],
            layer: Some(Box::new(name("r").member("layer"))),
            swizzle: "zyx",
        };
        let body = vec![let_("r", Ty::Named("Row".into()), name("rows").element(name("i"))), Stmt::Return(sample)];
        m.function("f", vec![("i", Ty::U32), ("x", Ty::F32)], Ty::Vec(3), body);
        let run = Machine::new(&m).unwrap().call("f", vec![Value::U32(1), Value::F32(0.5)], &Answer).unwrap();
        assert_eq!(run.value, Value::Vector(vec![5.0, 0.75, 0.5]));
        assert_eq!(run.cost, ShaderCost { texture_reads: 1, operations: 0 });
        let past = Machine::new(&m).unwrap().call("f", vec![Value::U32(2), Value::F32(0.5)], &Answer);
        assert!(past.unwrap_err().to_string().contains("element 2 of an array of 2"));
        let wgsl = m.print(Lang::Wgsl);
        assert!(
            wgsl.contains("const rows: array<Row, 2> = array<Row, 2>(\n    Row(3u, 0.25),\n    Row(5u, 0.75)\n);"),
            "{wgsl}"
        );
        assert!(wgsl.contains("textureSampleLevel(tex, smp, vec2<f32>(x, r.y), r.layer, 0.0).zyx"), "{wgsl}");
        assert!(wgsl.contains("let r: Row = rows[i];"), "{wgsl}");
        super::super::validate::wgsl(&wgsl).unwrap_or_else(|e| panic!("{e}\n{wgsl}"));
        let hlsl = m.print(Lang::Hlsl);
        assert!(hlsl.contains("static const Row rows[2] = {\n    {3u, 0.25},\n    {5u, 0.75}\n};"), "{hlsl}");
        assert!(hlsl.contains("tex.SampleLevel(smp, float3(x, r.y, r.layer), 0).zyx"), "{hlsl}");
        assert!(hlsl.contains("float3 f(uint i, float x) {"), "{hlsl}");
    }

    /// `pick(k, x)`: the shape `u32(c[k])` of a storage buffer `c` picks `x * c[2]`, `x + c[3]`,
    /// or 0.
    fn switching() -> Module {
        let mut m = Module::new(Parens::Minimal);
        m.push(Item::Binding { group: 0, binding: 4, name: "c".into(), ty: Ty::StorageArray });
        let read = |k: Expr| name("c").element(k);
        let body = vec![
            var("r", Ty::F32, float(0.0)),
            Stmt::Switch {
                selector: Expr::Construct(Ty::U32, vec![read(name("k"))]),
                cases: vec![
                    (0, vec![super::super::assign(name("r"), name("x") * read(Expr::U32(2)))]),
                    (1, vec![super::super::assign(name("r"), name("x") + read(Expr::U32(3)) * name("x"))]),
                ],
                default: Vec::new(),
            },
            Stmt::Return(name("r")),
        ];
        m.function("pick", vec![("k", Ty::U32), ("x", Ty::F32)], Ty::F32, body);
        m
    }

    #[test]
    fn a_switch_on_a_storage_buffer_runs_the_case_its_contents_choose() {
        let module = switching();
        let mut machine = Machine::new(&module).unwrap();
        let unbound = machine.call("pick", vec![Value::U32(0), Value::F32(2.0)], &NoTexels).unwrap();
        assert_eq!(unbound.value, Value::Unknown, "an unbound buffer reads unknown");
        // The conversion, then the larger case: `+` and `*`.
        assert_eq!(unbound.cost, ShaderCost { texture_reads: 0, operations: 3 });
        machine.bind_buffer("c", vec![1.0, 0.0, 3.0, 0.5, 7.0]).unwrap();
        let at = |k: u32| machine.call("pick", vec![Value::U32(k), Value::F32(2.0)], &NoTexels).unwrap().value;
        assert_eq!((at(0), at(1), at(4)), (Value::F32(3.0), Value::F32(6.0), Value::F32(0.0)));
        let past = machine.call("pick", vec![Value::U32(5), Value::F32(2.0)], &NoTexels).unwrap_err().to_string();
        assert!(past.contains("element 5 of storage buffer `c` of 5"), "{past}");
        assert!(machine.bind_buffer("d", Vec::new()).unwrap_err().to_string().contains("no storage buffer `d`"));
        let wgsl = module.print(Lang::Wgsl);
        assert!(wgsl.contains("@group(0) @binding(4) var<storage, read> c: array<f32>;"), "{wgsl}");
        assert!(
            wgsl.contains("    switch u32(c[k]) {\n        case 0u: {\n            r = x * c[2u];\n        }\n"),
            "{wgsl}"
        );
        assert!(wgsl.contains("        default: {\n        }\n    }\n"), "{wgsl}");
        super::super::validate::wgsl(&wgsl).unwrap_or_else(|e| panic!("{e}\n{wgsl}"));
        let hlsl = module.print(Lang::Hlsl);
        assert!(hlsl.contains("StructuredBuffer<float> c : register(t4);"), "{hlsl}");
        assert!(hlsl.contains("    switch (uint(c[k])) {\n        case 0: {"), "{hlsl}");
        assert!(
            hlsl.contains("        case 1: {\n            r = x + c[3u] * x;\n            break;\n        }\n"),
            "{hlsl}"
        );
        let glsl = module.print(Lang::Glsl);
        assert!(
            glsl.contains("layout(std430, set = 0, binding = 4) readonly buffer c_block { float c[]; };"),
            "{glsl}"
        );
        assert!(glsl.contains("    switch (uint(c[k])) {\n        case 0u: {"), "{glsl}");
        let shader = format!(
            "#version 450\n{glsl}\nlayout(local_size_x = 1) in;\nvoid main() {{\n    float r = pick(1u, 2.0);\n}}\n"
        );
        super::super::validate::glsl(&shader, naga::ShaderStage::Compute).unwrap_or_else(|e| panic!("{e}\n{shader}"));
    }

    #[test]
    fn the_cost_of_a_function_taking_its_texture_counts_its_reads() {
        let mut m = Module::new(Parens::Minimal);
        let load = |x: i32| Expr::Load {
            texture: "t".into(),
            scalar_texture: true,
            coordinates: vec![Expr::I32(x), name("k")],
            layer: None,
            swizzle: "r",
        };
        let params = vec![("t", Ty::Texture { dims: 2, scalar: true }), ("k", Ty::I32)];
        m.function("f", params, Ty::F32, vec![Stmt::Return(load(0) + load(1))]);
        assert_eq!(cost(&m, "f").unwrap(), ShaderCost { texture_reads: 2, operations: 1 });
    }

    #[test]
    fn a_module_that_recurses_is_refused() {
        let mut m = Module::new(Parens::Minimal);
        m.function(
            "f",
            vec![("x", Ty::F32)],
            Ty::F32,
            vec![Stmt::Return(func("f", vec![call(Intrinsic::Abs, vec![name("x")])]))],
        );
        let error = cost(&m, "f").unwrap_err().to_string();
        assert!(error.contains("recurse"), "{error}");
        assert!(cost(&m, "g").unwrap_err().to_string().contains("no function `g`"));
    }
}
