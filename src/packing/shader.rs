//! The lookup of a packed texture as one small program: f32 coordinate arithmetic, texture
//! fetches, one final lerp. The same program is printed as HLSL and WGSL and evaluated in Rust
//! through the [`emulator`](super::emulator), so the shader text a renderer pastes is, operation
//! for operation, the code the tests and the error report run.
//!
//! Only operations that HLSL, WGSL and Rust's f32 define identically are used: `+ - *` (no
//! division: a compiler may turn `x / c` into `x * (1 / c)`, so the program multiplies by
//! reciprocal constants itself), `floor`, `min`, `max`, and `clamp` written as `min(max(x, lo), hi)`.

use std::fmt::Write as _;

use super::emulator::{Filter, Texture3D};

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
        }
    }
}

/// An f32 literal both languages parse to the same value: Rust's shortest round-trip form, which
/// always has a `.` or an exponent (`63.0`, `0.0078125`, `1e-7`).
fn literal(v: f32) -> String {
    let text = format!("{v:?}");
    if text.contains('.') || text.contains('e') { text } else { format!("{text}.0") }
}

/// One `SampleLevel` of the packed texture at three locals `(u, v, w)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Fetch {
    pub name: String,
    pub coordinates: [usize; 3],
}

/// The lookup: locals in order, then fetches, then `result = a + t * (b - a)` of two fetches.
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    /// Name of the shader function, e.g. `fgd_lossless`.
    pub function: String,
    pub inputs: Vec<&'static str>,
    pub locals: Vec<(String, Expr)>,
    pub fetches: Vec<Fetch>,
    /// `(first fetch, second fetch, weight local)` of the final manual lerp.
    pub blend: (usize, usize, usize),
}

impl Program {
    pub fn new(function: impl Into<String>, inputs: Vec<&'static str>) -> Self {
        Program { function: function.into(), inputs, locals: Vec::new(), fetches: Vec::new(), blend: (0, 0, 0) }
    }

    pub fn input(&self, name: &str) -> Expr {
        Expr::Input(self.inputs.iter().position(|i| *i == name).expect("the program declares this input"))
    }

    /// Add a local; returns the expression that reads it.
    pub fn local(&mut self, name: &str, value: Expr) -> Expr {
        self.locals.push((name.to_string(), value));
        Expr::Local(self.locals.len() - 1)
    }

    pub fn fetch(&mut self, name: &str, [u, v, w]: [&Expr; 3]) -> usize {
        let index = |e: &Expr| match e {
            Expr::Local(i) => *i,
            _ => panic!("a fetch reads locals"),
        };
        self.fetches.push(Fetch { name: name.to_string(), coordinates: [index(u), index(v), index(w)] });
        self.fetches.len() - 1
    }

    /// Run the lookup through the emulator.
    pub fn evaluate(&self, inputs: &[f32], texture: &Texture3D, filter: Filter) -> f32 {
        let mut locals = Vec::with_capacity(self.locals.len());
        for (_, e) in &self.locals {
            let v = e.eval(inputs, &locals);
            locals.push(v);
        }
        let fetched: Vec<f32> = self
            .fetches
            .iter()
            .map(|f| {
                let [u, v, w] = f.coordinates.map(|i| locals[i]);
                texture.sample_trilinear(u, v, w, filter)
            })
            .collect();
        let (a, b, t) = self.blend;
        // HLSL `lerp(a, b, t)` is specified as `a + t * (b - a)`; WGSL's `mix` is printed the same way.
        fetched[a] + locals[t] * (fetched[b] - fetched[a])
    }

    /// The lookup's statements without language syntax, for the manifest and the docs.
    pub fn statements(&self) -> Vec<String> {
        let mut lines = Vec::new();
        for (name, e) in &self.locals {
            let mut text = String::new();
            e.print(self, &mut text);
            lines.push(format!("{name} = {text}"));
        }
        for f in &self.fetches {
            let [u, v, w] = f.coordinates.map(|i| self.locals[i].0.as_str());
            lines.push(format!("{} = sample_linear_clamp({u}, {v}, {w})", f.name));
        }
        let (a, b, t) = self.blend;
        let (a, b, t) = (&self.fetches[a].name, &self.fetches[b].name, &self.locals[t].0);
        lines.push(format!("result = {a} + {t} * ({b} - {a})"));
        lines
    }

    /// An HLSL function `float NAME(Texture3D<float> tex, SamplerState linear_clamp, float mu, ...)`.
    pub fn hlsl(&self, header: &str) -> String {
        let mut s = comment_block("//", header);
        let params: Vec<String> = self.inputs.iter().map(|i| format!("float {i}")).collect();
        let _ = writeln!(
            s,
            "float {}(Texture3D<float> tex, SamplerState linear_clamp, {})\n{{",
            self.function,
            params.join(", ")
        );
        for (name, e) in &self.locals {
            let mut text = String::new();
            e.print(self, &mut text);
            let _ = writeln!(s, "    float {name} = {text};");
        }
        for f in &self.fetches {
            let [u, v, w] = f.coordinates.map(|i| self.locals[i].0.as_str());
            let _ = writeln!(s, "    float {} = tex.SampleLevel(linear_clamp, float3({u}, {v}, {w}), 0);", f.name);
        }
        let (a, b, t) = self.blend;
        let (a, b, t) = (&self.fetches[a].name, &self.fetches[b].name, &self.locals[t].0);
        let _ = writeln!(s, "    return {a} + {t} * ({b} - {a});\n}}");
        s
    }

    /// A WGSL function `fn NAME(tex: texture_3d<f32>, linear_clamp: sampler, mu: f32, ...) -> f32`.
    pub fn wgsl(&self, header: &str) -> String {
        let mut s = comment_block("//", header);
        let params: Vec<String> = self.inputs.iter().map(|i| format!("{i}: f32")).collect();
        let _ = writeln!(
            s,
            "fn {}(tex: texture_3d<f32>, linear_clamp: sampler, {}) -> f32 {{",
            self.function,
            params.join(", ")
        );
        for (name, e) in &self.locals {
            let mut text = String::new();
            e.print(self, &mut text);
            let _ = writeln!(s, "    let {name}: f32 = {text};");
        }
        for f in &self.fetches {
            let [u, v, w] = f.coordinates.map(|i| self.locals[i].0.as_str());
            let _ = writeln!(
                s,
                "    let {}: f32 = textureSampleLevel(tex, linear_clamp, vec3<f32>({u}, {v}, {w}), 0.0).r;",
                f.name
            );
        }
        let (a, b, t) = self.blend;
        let (a, b, t) = (&self.fetches[a].name, &self.fetches[b].name, &self.locals[t].0);
        let _ = writeln!(s, "    return {a} + {t} * ({b} - {a});\n}}");
        s
    }
}

fn comment_block(prefix: &str, text: &str) -> String {
    text.lines().map(|l| if l.is_empty() { format!("{prefix}\n") } else { format!("{prefix} {l}\n") }).collect()
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
        let _t = p.local("t", a.sub(b));
        let texture = Texture3D { width: 1, height: 1, depth: 1, texels: vec![0.0] };
        let mut q = p.clone();
        let zero = q.local("zero", Expr::c(0.5));
        q.fetch("v0", [&zero, &zero, &zero]);
        q.fetch("v1", [&zero, &zero, &zero]);
        q.blend = (0, 1, 2);
        assert_eq!(q.evaluate(&[0.5], &texture, Filter::Exact), 0.0);
        let lines = q.statements();
        assert_eq!(lines[0], "a = (min(max(x, 0.0), 1.0) * 63.0)");
        assert_eq!(lines[1], "b = min(floor(a), 62.0)");
        assert!(q.hlsl("h").contains("float t = (a - b);"));
        assert!(q.wgsl("h").contains("let t: f32 = (a - b);"));
    }
}
