//! The lookup of a packed texture as one small program: f32 arithmetic, texture reads (filtered
//! samples or texel loads), a returned value. The same program is printed as HLSL and WGSL and
//! evaluated in Rust through the [`emulator`](super::emulator), so the shader text a renderer
//! pastes is, operation for operation, the code the tests and the error report run.
//!
//! Only operations that HLSL, WGSL and Rust's f32 define identically are used: `+ - *` (no
//! division: a compiler may turn `x / c` into `x * (1 / c)`, so the program multiplies by
//! reciprocal constants itself), `floor`, `min`, `max`, and `clamp` written as `min(max(x, lo), hi)`;
//! and `sqrt`, for axes spaced in a square root, which IEEE rounds correctly and a GPU to within
//! an ulp or two; and `log`, for axes spaced in `asinh`, which neither HLSL nor WGSL rounds
//! correctly (WGSL allows 2^-21 absolute error near 1, 3 ulps elsewhere): such an axis's node
//! index may differ from the emulator's by a few 1e-6 of a node.
//! Texel indices for loads are integers held exactly in f32 and converted with `int()`/`i32()`.

use std::fmt::Write as _;

use super::emulator::{Filter, Texture3D};
use crate::shader::{self, Lang, literal};

impl std::ops::Add for Expr {
    type Output = Expr;
    fn add(self, o: Expr) -> Expr {
        Expr::Add(Box::new(self), Box::new(o))
    }
}

impl std::ops::Sub for Expr {
    type Output = Expr;
    fn sub(self, o: Expr) -> Expr {
        Expr::Sub(Box::new(self), Box::new(o))
    }
}

impl std::ops::Mul for Expr {
    type Output = Expr;
    fn mul(self, o: Expr) -> Expr {
        Expr::Mul(Box::new(self), Box::new(o))
    }
}

/// An f32 expression over the inputs and earlier locals of a [`Program`].
#[derive(Debug, Clone, PartialEq)]
pub enum Expr {
    Input(usize),
    Local(usize),
    Const(f32),
    Add(Box<Expr>, Box<Expr>),
    Sub(Box<Expr>, Box<Expr>),
    Mul(Box<Expr>, Box<Expr>),
    Floor(Box<Expr>),
    Min(Box<Expr>, Box<Expr>),
    Max(Box<Expr>, Box<Expr>),
    /// IEEE square root, correctly rounded in Rust's f32; a GPU may differ by an ulp (Direct3D
    /// 11 allows it), which moves a node index by at most `(N - 1)` ulps of the axis coordinate.
    Sqrt(Box<Expr>),
    /// Natural logarithm; Rust's f32 `ln` is within an ulp, a GPU within a few (see the module's
    /// notes).
    Log(Box<Expr>),
    Abs(Box<Expr>),
    /// The first value with the sign of the second: negated where the second is below 0.
    WithSignOf(Box<Expr>, Box<Expr>),
}

impl Expr {
    pub fn c(v: f32) -> Expr {
        Expr::Const(v)
    }
    pub fn floor(self) -> Expr {
        Expr::Floor(Box::new(self))
    }
    pub fn min(self, o: Expr) -> Expr {
        Expr::Min(Box::new(self), Box::new(o))
    }
    pub fn max(self, o: Expr) -> Expr {
        Expr::Max(Box::new(self), Box::new(o))
    }
    pub fn sqrt(self) -> Expr {
        Expr::Sqrt(Box::new(self))
    }
    pub fn log(self) -> Expr {
        Expr::Log(Box::new(self))
    }
    pub fn abs(self) -> Expr {
        Expr::Abs(Box::new(self))
    }
    pub fn with_sign_of(self, sign: Expr) -> Expr {
        Expr::WithSignOf(Box::new(self), Box::new(sign))
    }
    /// `min(max(x, lo), hi)`; a NaN `x` becomes `lo` in Rust and in HLSL (IEEE maxNum).
    pub fn clamp(self, lo: f32, hi: f32) -> Expr {
        self.max(Expr::c(lo)).min(Expr::c(hi))
    }

    fn eval(&self, inputs: &[f32], locals: &[f32]) -> f32 {
        match self {
            Expr::Input(i) => inputs[*i],
            Expr::Local(i) => locals[*i],
            Expr::Const(v) => *v,
            Expr::Add(a, b) => a.eval(inputs, locals) + b.eval(inputs, locals),
            Expr::Sub(a, b) => a.eval(inputs, locals) - b.eval(inputs, locals),
            Expr::Mul(a, b) => a.eval(inputs, locals) * b.eval(inputs, locals),
            Expr::Floor(a) => a.eval(inputs, locals).floor(),
            Expr::Min(a, b) => a.eval(inputs, locals).min(b.eval(inputs, locals)),
            Expr::Max(a, b) => a.eval(inputs, locals).max(b.eval(inputs, locals)),
            Expr::Sqrt(a) => a.eval(inputs, locals).sqrt(),
            Expr::Log(a) => a.eval(inputs, locals).ln(),
            Expr::Abs(a) => a.eval(inputs, locals).abs(),
            Expr::WithSignOf(a, s) => {
                let a = a.eval(inputs, locals);
                if s.eval(inputs, locals) < 0.0 { -a } else { a }
            }
        }
    }

    fn print(&self, program: &Program, out: &mut String) {
        let binary = |op: &str, a: &Expr, b: &Expr, out: &mut String| {
            out.push('(');
            a.print(program, out);
            let _ = write!(out, " {op} ");
            b.print(program, out);
            out.push(')');
        };
        let call = |f: &str, args: &[&Expr], out: &mut String| {
            let _ = write!(out, "{f}(");
            for (k, a) in args.iter().enumerate() {
                if k > 0 {
                    out.push_str(", ");
                }
                a.print(program, out);
            }
            out.push(')');
        };
        match self {
            Expr::Input(i) => out.push_str(program.inputs[*i]),
            Expr::Local(i) => out.push_str(&program.locals[*i].0),
            Expr::Const(v) => out.push_str(&literal(*v)),
            Expr::Add(a, b) => binary("+", a, b, out),
            Expr::Sub(a, b) => binary("-", a, b, out),
            Expr::Mul(a, b) => binary("*", a, b, out),
            Expr::Floor(a) => call("floor", &[a], out),
            Expr::Min(a, b) => call("min", &[a, b], out),
            Expr::Max(a, b) => call("max", &[a, b], out),
            Expr::Sqrt(a) => call("sqrt", &[a], out),
            Expr::Log(a) => call("log", &[a], out),
            Expr::Abs(a) => call("abs", &[a], out),
            Expr::WithSignOf(a, s) => {
                out.push('(');
                s.print(program, out);
                out.push_str(" < 0 ? -");
                a.print(program, out);
                out.push_str(" : ");
                a.print(program, out);
                out.push(')');
            }
        }
    }
}

/// One statement of a [`Program`]: an f32 value, or a read of the packed texture.
#[derive(Debug, Clone, PartialEq)]
pub enum Step {
    /// An f32 value computed from inputs and earlier locals.
    Value(Expr),
    /// `SampleLevel` with the linear clamp sampler at three locals holding normalised
    /// coordinates: the hardware filters (trilinear).
    Sample([usize; 3]),
    /// `Load` of one texel at three locals holding integer texel indices (exact in f32): no
    /// sampler, no filtering, the texel as stored.
    Load([usize; 3]),
}

/// The lookup: named locals in order (values and texture reads), then the result.
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    /// Name of the shader function, e.g. `fgd_lossless`.
    pub function: String,
    pub inputs: Vec<&'static str>,
    pub locals: Vec<(String, Step)>,
    /// The returned value.
    pub result: Expr,
}

impl Program {
    pub fn new(function: impl Into<String>, inputs: Vec<&'static str>) -> Self {
        Program { function: function.into(), inputs, locals: Vec::new(), result: Expr::c(0.0) }
    }

    pub fn input(&self, name: &str) -> Expr {
        Expr::Input(self.inputs.iter().position(|i| *i == name).expect("the program declares this input"))
    }

    fn push(&mut self, name: &str, step: Step) -> Expr {
        self.locals.push((name.to_string(), step));
        Expr::Local(self.locals.len() - 1)
    }

    /// Add a value local; returns the expression that reads it.
    pub fn local(&mut self, name: &str, value: Expr) -> Expr {
        self.push(name, Step::Value(value))
    }

    /// A trilinear `SampleLevel` at three locals (normalised coordinates).
    pub fn sample(&mut self, name: &str, coordinates: [&Expr; 3]) -> Expr {
        self.push(name, Step::Sample(coordinates.map(local_index)))
    }

    /// A texel `Load` at three locals (integer texel indices).
    pub fn load(&mut self, name: &str, coordinates: [&Expr; 3]) -> Expr {
        self.push(name, Step::Load(coordinates.map(local_index)))
    }

    /// Texture reads per lookup (samples and loads alike: each is one texture instruction).
    pub fn fetch_count(&self) -> usize {
        self.locals.iter().filter(|(_, s)| !matches!(s, Step::Value(_))).count()
    }

    /// Whether the lookup filters in hardware (and so takes a sampler).
    pub fn uses_sampler(&self) -> bool {
        self.locals.iter().any(|(_, s)| matches!(s, Step::Sample(_)))
    }

    /// Run the lookup through the emulator.
    pub fn evaluate(&self, inputs: &[f32], texture: &Texture3D, filter: Filter) -> f32 {
        let mut locals: Vec<f32> = Vec::with_capacity(self.locals.len());
        for (_, step) in &self.locals {
            let v = match step {
                Step::Value(e) => e.eval(inputs, &locals),
                Step::Sample(c) => {
                    let [u, v, w] = c.map(|i| locals[i]);
                    texture.sample_trilinear(u, v, w, filter)
                }
                Step::Load(c) => {
                    let [x, y, z] = c.map(|i| locals[i]);
                    texture.load(x, y, z)
                }
            };
            locals.push(v);
        }
        self.result.eval(inputs, &locals)
    }

    fn text(&self, e: &Expr) -> String {
        let mut text = String::new();
        e.print(self, &mut text);
        text
    }

    fn names(&self, c: &[usize; 3]) -> [&str; 3] {
        c.map(|i| self.locals[i].0.as_str())
    }

    /// The lookup's statements without language syntax, for the manifest and the docs.
    pub fn statements(&self) -> Vec<String> {
        let mut lines: Vec<String> = self
            .locals
            .iter()
            .map(|(name, step)| match step {
                Step::Value(e) => format!("{name} = {}", self.text(e)),
                Step::Sample(c) => {
                    let [u, v, w] = self.names(c);
                    format!("{name} = sample_linear_clamp({u}, {v}, {w})")
                }
                Step::Load(c) => {
                    let [x, y, z] = self.names(c);
                    format!("{name} = load_texel({x}, {y}, {z})")
                }
            })
            .collect();
        lines.push(format!("result = {}", self.text(&self.result)));
        lines
    }

    /// The lookup as one function of the shader emitter: `float NAME(Texture3D<float> tex[,
    /// SamplerState linear_clamp], float mu, ...)` in HLSL, `fn NAME(tex: texture_3d<f32>[,
    /// linear_clamp: sampler], mu: f32, ...) -> f32` in WGSL. Every value is fully parenthesised,
    /// so the order of the f32 operations is on the page; HLSL value locals are `precise`: the
    /// compiler must evaluate them as written (no reassociation), which the exact interpolation
    /// weights rely on (WGSL forbids reassociation without being asked).
    pub fn module(&self, header: &str) -> shader::Module {
        use shader::{Stmt, Ty};
        let mut module = shader::Module::new(shader::Parens::Full);
        module.hlsl_brace_on_next_line = true;
        module.comment(header);
        let mut params = vec![("tex", Ty::Texture { dims: 3, scalar: true })];
        if self.uses_sampler() {
            params.push(("linear_clamp", Ty::Sampler));
        }
        params.extend(self.inputs.iter().map(|&i| (i, Ty::F32)));
        let local = |i: usize| shader::name(&self.locals[i].0);
        let mut body: Vec<Stmt> = self
            .locals
            .iter()
            .map(|(name, step)| {
                let (value, precise) = match step {
                    Step::Value(e) => (self.emitted(e), true),
                    Step::Sample(c) => (
                        shader::Expr::SampleLevel {
                            texture: "tex".into(),
                            scalar_texture: true,
                            sampler: "linear_clamp".into(),
                            coordinates: c.iter().map(|&i| local(i)).collect(),
                            layer: None,
                            swizzle: "r",
                        },
                        false,
                    ),
                    Step::Load(c) => (
                        shader::Expr::Load {
                            texture: "tex".into(),
                            scalar_texture: true,
                            coordinates: c.iter().map(|&i| shader::Expr::Construct(Ty::I32, vec![local(i)])).collect(),
                            layer: None,
                            swizzle: "r",
                        },
                        false,
                    ),
                };
                Stmt::Let { name: name.clone(), ty: Ty::F32, value, typed: true, precise }
            })
            .collect();
        body.push(Stmt::Return(self.emitted(&self.result)));
        module.function(&self.function, params, Ty::F32, body);
        module
    }

    /// `e` as an expression of the shader emitter.
    pub fn emitted(&self, e: &Expr) -> shader::Expr {
        use shader::Intrinsic;
        let two = |a: &Expr, b: &Expr| vec![self.emitted(a), self.emitted(b)];
        match e {
            Expr::Input(i) => shader::name(self.inputs[*i]),
            Expr::Local(i) => shader::name(&self.locals[*i].0),
            Expr::Const(v) => shader::float(*v),
            Expr::Add(a, b) => self.emitted(a) + self.emitted(b),
            Expr::Sub(a, b) => self.emitted(a) - self.emitted(b),
            Expr::Mul(a, b) => self.emitted(a) * self.emitted(b),
            Expr::Floor(a) => shader::call(Intrinsic::Floor, vec![self.emitted(a)]),
            Expr::Min(a, b) => shader::call(Intrinsic::Min, two(a, b)),
            Expr::Max(a, b) => shader::call(Intrinsic::Max, two(a, b)),
            Expr::Sqrt(a) => shader::call(Intrinsic::Sqrt, vec![self.emitted(a)]),
            Expr::Log(a) => shader::call(Intrinsic::Log, vec![self.emitted(a)]),
            Expr::Abs(a) => shader::call(Intrinsic::Abs, vec![self.emitted(a)]),
            Expr::WithSignOf(a, s) => {
                let negative = self.emitted(s).lt(shader::float(0.0));
                shader::select(negative, -self.emitted(a), self.emitted(a))
            }
        }
    }

    /// The lookup as an HLSL function (see [`Program::module`]).
    pub fn hlsl(&self, header: &str) -> String {
        self.module(header).print(Lang::Hlsl)
    }

    /// The lookup as a WGSL function (see [`Program::module`]).
    pub fn wgsl(&self, header: &str) -> String {
        self.module(header).print(Lang::Wgsl)
    }
}

fn local_index(e: &Expr) -> usize {
    match e {
        Expr::Local(i) => *i,
        _ => panic!("a texture read takes locals as coordinates"),
    }
}

/// `a + t * (b - a)`: HLSL's `lerp` as its documentation writes it, spelled out so that both
/// languages and the emulator compute the same operations.
pub fn lerp(a: Expr, b: Expr, t: Expr) -> Expr {
    a.clone() + t * (b - a)
}

#[cfg(test)]
mod tests {
    use std::ops::{Mul, Sub};

    use super::*;

    #[test]
    fn literals_keep_a_decimal_point_and_round_trip() {
        assert_eq!(literal(63.0), "63.0");
        assert_eq!(literal(0.5), "0.5");
        for v in [1.0 / 3.0f32, 1.0 / 63.0, 1e-7, 2047.0] {
            assert_eq!(literal(v).parse::<f32>().unwrap(), v);
        }
    }

    #[test]
    fn evaluation_follows_the_printed_expression() {
        let mut p = Program::new("f", vec!["x"]);
        let x = p.input("x");
        let a = p.local("a", x.clamp(0.0, 1.0).mul(Expr::c(63.0)));
        let b = p.local("b", a.clone().floor().min(Expr::c(62.0)));
        let t = p.local("t", a.sub(b));
        let texture = Texture3D { width: 2, height: 1, depth: 1, texels: vec![1.0, 3.0] };
        let (one, half, quarter) =
            (p.local("one", Expr::c(1.0)), p.local("half", Expr::c(0.5)), p.local("q", Expr::c(0.25)));
        let v0 = p.load("v0", [&one, &half, &half]);
        let v1 = p.sample("v1", [&quarter, &half, &half]);
        p.result = lerp(v0, v1, t);
        // x = 0.5: a = 31.5, b = 31, t = 0.5; v0 = texel 1 (0.5 truncates to 0) = 3; v1 = texel 0 = 1.
        assert_eq!(p.evaluate(&[0.5], &texture, Filter::Exact), 2.0);
        assert_eq!(p.fetch_count(), 2);
        let lines = p.statements();
        assert_eq!(lines[0], "a = (min(max(x, 0.0), 1.0) * 63.0)");
        assert_eq!(lines[1], "b = min(floor(a), 62.0)");
        assert_eq!(lines[6], "v0 = load_texel(one, half, half)");
        assert_eq!(lines[8], "result = (v0 + (t * (v1 - v0)))");
        let hlsl = p.hlsl("h");
        assert!(hlsl.contains("precise float t = (a - b);"), "{hlsl}");
        assert!(hlsl.contains("float f(Texture3D<float> tex, SamplerState linear_clamp, float x)"), "{hlsl}");
        assert!(hlsl.contains("float v0 = tex.Load(int4(int(one), int(half), int(half), 0));"), "{hlsl}");
        assert!(hlsl.contains("return (v0 + (t * (v1 - v0)));"), "{hlsl}");
        let wgsl = p.wgsl("h");
        assert!(wgsl.contains("let t: f32 = (a - b);"), "{wgsl}");
        assert!(wgsl.contains("textureLoad(tex, vec3<i32>(i32(one), i32(half), i32(half)), 0).r;"), "{wgsl}");
    }

    #[test]
    fn a_lookup_without_samples_takes_no_sampler() {
        let mut p = Program::new("g", vec!["x"]);
        let zero = p.local("zero", Expr::c(0.0));
        p.result = p.load("v", [&zero, &zero, &zero]);
        assert!(!p.uses_sampler());
        assert!(p.hlsl("h").contains("float g(Texture3D<float> tex, float x)"));
        assert!(p.wgsl("h").contains("fn g(tex: texture_3d<f32>, x: f32) -> f32 {"));
    }
}
