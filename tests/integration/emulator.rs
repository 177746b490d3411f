//! A scene shader run on the CPU: its module's statements interpreted in f32 with WGSL's meaning,
//! each `textureLoad` reading the texels of the folder's file as stored, so that the generated
//! code (its coordinates, slice choosers, filtering and the recorded model) is compared with the
//! CPU evaluator on any machine, without a GPU API. What it checks that the GPU does not: a load
//! outside its texture is an error here, where a GPU would read some texel or 0.

use std::collections::HashMap;

use tmlut::ir::tape::Scalar;
use tmlut::loader::LutFolder;
use tmlut::shader::scene::SceneShader;
use tmlut::shader::{Builtin, Expr, Function, Intrinsic, Item, Op, Stmt, Ty};

/// A value of the shader's arithmetic.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    F(f32),
    I(i32),
    B(bool),
    /// A `vecN<f32>`.
    V(Vec<f32>),
    /// A texture, by the name of its binding.
    Texture(String),
    Struct(Vec<(String, Value)>),
    Array(Vec<Value>),
}

impl Value {
    pub fn f(&self) -> f32 {
        match self {
            Value::F(v) => *v,
            other => panic!("{other:?} where an f32 is expected"),
        }
    }

    pub fn v(&self) -> Vec<f32> {
        match self {
            Value::V(v) => v.clone(),
            Value::F(v) => vec![*v],
            other => panic!("{other:?} where a vector is expected"),
        }
    }

    /// Field `name` of a struct.
    pub fn field(&self, name: &str) -> &Value {
        match self {
            Value::Struct(fields) => {
                &fields.iter().find(|(n, _)| n == name).unwrap_or_else(|| panic!("no field {name}")).1
            }
            other => panic!("{other:?} has no field {name}"),
        }
    }
}

/// A texture's texels as stored (f16 widened exactly), channels interleaved, x fastest.
struct Texels {
    extent: [usize; 3],
    channels: usize,
    data: Vec<f32>,
}

pub struct Emulator<'a> {
    functions: HashMap<&'a str, &'a Function>,
    structs: HashMap<&'a str, &'a [(String, Ty)]>,
    textures: HashMap<String, Texels>,
}

impl<'a> Emulator<'a> {
    /// The emulator of `shader`, its textures read from `folder`.
    pub fn new(shader: &'a SceneShader, folder: &LutFolder) -> Self {
        let mut functions = HashMap::new();
        let mut structs = HashMap::new();
        for item in &shader.module.items {
            match item {
                Item::Function(function) => {
                    functions.insert(function.name.as_str(), function);
                }
                Item::Struct { name, fields } => {
                    structs.insert(name.as_str(), fields.as_slice());
                }
                _ => {}
            }
        }
        let textures = shader
            .textures
            .iter()
            .map(|binding| {
                let table = folder.load(&binding.file).unwrap();
                let extent = binding.extent;
                let channels = table.channel_count();
                assert_eq!(table.data.len(), extent.iter().product::<usize>() * channels, "{}", binding.file);
                (binding.variable.clone(), Texels { extent, channels, data: table.data })
            })
            .collect();
        Emulator { functions, structs, textures }
    }

    /// Function `name` called with `arguments`.
    pub fn call(&self, name: &str, arguments: Vec<Value>) -> Value {
        let function = self.functions.get(name).unwrap_or_else(|| panic!("no function {name}"));
        assert_eq!(function.params.len(), arguments.len(), "{name}");
        let mut scope: HashMap<String, Value> = function.params.iter().map(|(p, _)| p.clone()).zip(arguments).collect();
        self.run(&function.body, &mut scope).unwrap_or_else(|| panic!("{name} returned nothing"))
    }

    fn run(&self, body: &[Stmt], scope: &mut HashMap<String, Value>) -> Option<Value> {
        for statement in body {
            match statement {
                Stmt::Let { name, value, .. } | Stmt::Var { name, value: Some(value), .. } => {
                    let value = self.evaluate(value, scope);
                    scope.insert(name.clone(), value);
                }
                Stmt::Var { name, ty, value: None } => {
                    scope.insert(name.clone(), self.zero(ty));
                }
                Stmt::Assign(target, value) => {
                    let value = self.evaluate(value, scope);
                    self.assign(target, value, scope);
                }
                Stmt::If { condition, then, otherwise } => {
                    let branch = if self.evaluate(condition, scope) == Value::B(true) { then } else { otherwise };
                    if let Some(returned) = self.run(branch, scope) {
                        return Some(returned);
                    }
                }
                Stmt::Return(value) => return Some(self.evaluate(value, scope)),
                Stmt::Comment(_) => {}
            }
        }
        None
    }

    /// The zero value of `ty`, as WGSL zero-initialises a `var`.
    fn zero(&self, ty: &Ty) -> Value {
        match ty {
            Ty::F32 => Value::F(0.0),
            Ty::I32 => Value::I(0),
            Ty::Bool => Value::B(false),
            Ty::Vec(n) => Value::V(vec![0.0; *n as usize]),
            Ty::Array(element, n) => Value::Array(vec![self.zero(element); *n]),
            Ty::Named(name) => Value::Struct(
                self.structs[name.as_str()].iter().map(|(field, ty)| (field.clone(), self.zero(ty))).collect(),
            ),
            other => panic!("no zero value of {other:?}"),
        }
    }

    /// `target = value`, where the target is a local, a member or an element of one.
    fn assign(&self, target: &Expr, value: Value, scope: &mut HashMap<String, Value>) {
        fn place<'v>(target: &Expr, scope: &'v mut HashMap<String, Value>) -> &'v mut Value {
            match target {
                Expr::Name(name) => scope.get_mut(name).unwrap_or_else(|| panic!("assignment to undeclared {name}")),
                Expr::Member(base, field) => match place(base, scope) {
                    Value::Struct(fields) => &mut fields.iter_mut().find(|(n, _)| n == field).expect("a field").1,
                    other => panic!("assignment to member {field} of {other:?}"),
                },
                Expr::Index(base, k) => match place(base, scope) {
                    Value::Array(elements) => &mut elements[*k],
                    other => panic!("assignment to element {k} of {other:?}"),
                },
                other => panic!("assignment to {other:?}"),
            }
        }
        *place(target, scope) = value;
    }

    fn evaluate(&self, e: &Expr, scope: &HashMap<String, Value>) -> Value {
        match e {
            Expr::Name(name) => match scope.get(name) {
                Some(value) => value.clone(),
                None if self.textures.contains_key(name) => Value::Texture(name.clone()),
                None => panic!("{name} is not declared"),
            },
            Expr::F32(v) => Value::F(*v),
            Expr::I32(v) => Value::I(*v),
            Expr::Paren(inner) => self.evaluate(inner, scope),
            Expr::Neg(inner) => elementwise(&[self.evaluate(inner, scope)], |x| -x[0]),
            Expr::Binary(op, a, b) => binary(*op, self.evaluate(a, scope), self.evaluate(b, scope)),
            Expr::Select { condition, then, otherwise } => match self.evaluate(condition, scope) {
                Value::B(true) => self.evaluate(then, scope),
                Value::B(false) => self.evaluate(otherwise, scope),
                other => panic!("select on {other:?}"),
            },
            Expr::Call(Builtin::Dot, arguments) => {
                let [a, b] = [0, 1].map(|k| self.evaluate(&arguments[k], scope).v());
                assert_eq!(a.len(), b.len(), "dot of vectors of unlike lengths");
                // In order, as the CPU sums a split sum's channels.
                Value::F(a.iter().zip(&b).fold(0.0, |sum, (x, y)| sum + x * y))
            }
            Expr::Call(Builtin::Intrinsic(intrinsic), arguments) => {
                let values: Vec<Value> = arguments.iter().map(|a| self.evaluate(a, scope)).collect();
                elementwise(&values, |x| intrinsic_of(*intrinsic, x))
            }
            Expr::Function(name, arguments) => {
                self.call(name, arguments.iter().map(|a| self.evaluate(a, scope)).collect())
            }
            Expr::Construct(ty, arguments) => {
                let values: Vec<Value> = arguments.iter().map(|a| self.evaluate(a, scope)).collect();
                construct(ty, values)
            }
            Expr::Member(base, field) => match self.evaluate(base, scope) {
                structure @ Value::Struct(_) => structure.field(field).clone(),
                vector => swizzle(&vector.v(), field),
            },
            Expr::Index(base, k) => match self.evaluate(base, scope) {
                Value::Array(elements) => elements[*k].clone(),
                other => panic!("index {k} of {other:?}"),
            },
            Expr::Load { texture, coordinates, layer, swizzle: channels, .. } => {
                let Value::Texture(texture) = self.evaluate(&Expr::Name(texture.clone()), scope) else {
                    panic!("{texture} is not a texture")
                };
                let mut at: Vec<i32> = coordinates.iter().map(|c| integer(&self.evaluate(c, scope))).collect();
                if let Some(layer) = layer {
                    at.push(integer(&self.evaluate(layer, scope)));
                }
                swizzle(&self.load(&texture, &at), channels)
            }
            Expr::SampleLevel { .. } => panic!("a scene shader filters by hand: no sampler reads"),
        }
    }

    /// The texel at `at` of `texture` as WGSL's `textureLoad` returns it: four channels, a
    /// missing one 0 (alpha 1).
    fn load(&self, texture: &str, at: &[i32]) -> Vec<f32> {
        let texels = &self.textures[texture];
        let mut index = 0;
        for d in (0..3).rev() {
            let x = at.get(d).copied().unwrap_or(0);
            assert!(
                x >= 0 && (x as usize) < texels.extent[d],
                "a load of {texture} at {at:?}, outside its extent {:?}",
                texels.extent
            );
            index = index * texels.extent[d] + x as usize;
        }
        let first = index * texels.channels;
        (0..4)
            .map(|c| match texels.data.get(first + c).filter(|_| c < texels.channels) {
                Some(&value) => value,
                None if c == 3 => 1.0,
                None => 0.0,
            })
            .collect()
    }
}

fn integer(value: &Value) -> i32 {
    match value {
        Value::I(i) => *i,
        other => panic!("{other:?} where an i32 is expected"),
    }
}

/// `f` applied to the arguments' components (a scalar broadcast over a vector's).
fn elementwise(values: &[Value], f: impl Fn(&[f32]) -> f32) -> Value {
    let width = values.iter().map(|v| if let Value::V(c) = v { c.len() } else { 1 }).max().unwrap_or(1);
    let component = |k: usize| -> Vec<f32> {
        values
            .iter()
            .map(|v| match v {
                Value::V(c) => c[k],
                Value::F(x) => *x,
                other => panic!("{other:?} in arithmetic"),
            })
            .collect()
    };
    match values.iter().any(|v| matches!(v, Value::V(_))) {
        true => Value::V((0..width).map(|k| f(&component(k))).collect()),
        false => Value::F(f(&component(0))),
    }
}

fn binary(op: Op, a: Value, b: Value) -> Value {
    match (op, &a, &b) {
        (Op::And, Value::B(x), Value::B(y)) => Value::B(*x && *y),
        (Op::Or, Value::B(x), Value::B(y)) => Value::B(*x || *y),
        (Op::Compare(compare), Value::F(x), Value::F(y)) => Value::B(compare.holds(*x as f64, *y as f64)),
        (Op::Compare(compare), Value::I(x), Value::I(y)) => Value::B(compare.holds(*x as f64, *y as f64)),
        (Op::Add, Value::I(x), Value::I(y)) => Value::I(x.wrapping_add(*y)),
        (Op::Sub, Value::I(x), Value::I(y)) => Value::I(x.wrapping_sub(*y)),
        _ => elementwise(&[a, b], |x| match op {
            Op::Add => x[0] + x[1],
            Op::Sub => x[0] - x[1],
            Op::Mul => x[0] * x[1],
            Op::Div => x[0] / x[1],
            other => panic!("{other:?} of numbers"),
        }),
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

/// A constructor or conversion: `vecN(x)` splats, `vecN(a, b, ...)` gathers, `i32(x)` truncates
/// toward zero (saturating, as WGSL converts), `f32(i)` converts.
fn construct(ty: &Ty, values: Vec<Value>) -> Value {
    match ty {
        Ty::I32 => match &values[..] {
            [Value::F(x)] => Value::I(*x as i32),
            [Value::I(x)] => Value::I(*x),
            other => panic!("i32 of {other:?}"),
        },
        Ty::F32 => match &values[..] {
            [Value::F(x)] => Value::F(*x),
            [Value::I(x)] => Value::F(*x as f32),
            other => panic!("f32 of {other:?}"),
        },
        Ty::Vec(n) => {
            let components: Vec<f32> = values.iter().flat_map(Value::v).collect();
            match components.len() {
                1 => Value::V(vec![components[0]; *n as usize]),
                k if k == *n as usize => Value::V(components),
                k => panic!("vec{n} of {k} components"),
            }
        }
        other => panic!("a constructor of {other:?}"),
    }
}

/// Components `names` (`xyzw` or `rgba`) of `vector`: a scalar for one.
fn swizzle(vector: &[f32], names: &str) -> Value {
    let picked: Vec<f32> = names
        .chars()
        .map(|c| vector["xyzw".find(c).or_else(|| "rgba".find(c)).unwrap_or_else(|| panic!("swizzle {c}"))])
        .collect();
    match picked[..] {
        [single] => Value::F(single),
        _ => Value::V(picked),
    }
}
