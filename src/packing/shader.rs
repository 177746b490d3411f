//! The lookup of a packed texture as one function of the IR's shader description
//! ([`crate::shader`]): f32 locals, texture reads (filtered samples or texel loads), a returned
//! value. The IR prints it as HLSL and WGSL and as the manifest's statements, and runs it on the
//! CPU, lowered onto its tape ([`crate::shader::lower`]: the same bits as its interpreter,
//! [`crate::shader::eval`], at a fiftieth of the cost), with its reads answered by the
//! [`emulator`](super::emulator), so the shader text a renderer pastes is, operation for
//! operation, the code the tests and the error report run.
//!
//! Only operations that HLSL, WGSL and Rust's f32 define identically are used: `+ - *` (no
//! division: a compiler may turn `x / c` into `x * (1 / c)`, so the lookup multiplies by
//! reciprocal constants itself), `floor`, `min`, `max`, and `clamp` written as `min(max(x, lo), hi)`;
//! and `sqrt`, for axes spaced in a square root, which IEEE rounds correctly and a GPU to within
//! an ulp or two; and `log`, for axes spaced in `asinh`, which neither HLSL nor WGSL rounds
//! correctly (WGSL allows 2^-21 absolute error near 1, 3 ulps elsewhere): such an axis's node
//! index may differ from the emulator's by a few 1e-6 of a node.
//! Texel indices for loads are integers held exactly in f32 and converted with `int()`/`i32()`.

use super::emulator::{Filter, Texture3D};
use crate::error::{Error, Result};
use crate::shader::eval::Textures;
use crate::shader::lower::Lowered;
use crate::shader::{self, Expr, Function, Intrinsic, Lang, Parens, Stmt, Ty, float};

/// The packed texture's parameter name, and the sampler's of the lookups that filter.
const TEXTURE: &str = "tex";
const SAMPLER: &str = "linear_clamp";

/// `min(max(x, lo), hi)`; a NaN `x` becomes `lo` in Rust and in HLSL (IEEE maxNum).
pub fn clamp(x: Expr, lo: f32, hi: f32) -> Expr {
    x.max(float(lo)).min(float(hi))
}

/// The natural logarithm; Rust's f32 `ln` is within an ulp, a GPU within a few (see the module's
/// notes).
pub fn log(x: Expr) -> Expr {
    shader::call(Intrinsic::Log, vec![x])
}

/// `magnitude` with the sign of `sign`: negated where `sign` is below 0.
pub fn with_sign_of(magnitude: Expr, sign: Expr) -> Expr {
    shader::select(sign.lt(float(0.0)), -magnitude.clone(), magnitude)
}

/// `a + t * (b - a)`: HLSL's `lerp` as its documentation writes it, spelled out so that both
/// languages and the CPU compute the same operations.
pub fn lerp(a: Expr, b: Expr, t: Expr) -> Expr {
    a.clone() + t * (b - a)
}

/// A lookup being written: its locals in order, each a value or a texture read.
#[derive(Debug, Clone)]
pub struct ProgramBuilder {
    function: String,
    inputs: Vec<&'static str>,
    body: Vec<Stmt>,
    uses_sampler: bool,
}

impl ProgramBuilder {
    /// A lookup named `function` (a shader function's name) taking the f32 `inputs`.
    pub fn new(function: impl Into<String>, inputs: Vec<&'static str>) -> Self {
        ProgramBuilder { function: function.into(), inputs, body: Vec::new(), uses_sampler: false }
    }

    /// The expression that reads input `name` ([`ProgramBuilder::finish`] refuses one not declared).
    pub fn input(&self, name: &str) -> Expr {
        shader::name(name)
    }

    /// Add a local; `precise` in HLSL where it is a value (the exact weights need the
    /// compiler to keep its operations as written), not where it is a texture read.
    fn push(&mut self, name: &str, value: Expr, precise: bool) -> Expr {
        self.body.push(Stmt::Let { name: name.to_string(), ty: Ty::F32, value, typed: true, precise });
        shader::name(name)
    }

    /// Add a value local; returns the expression that reads it.
    pub fn local(&mut self, name: &str, value: Expr) -> Expr {
        self.push(name, value, true)
    }

    /// A trilinear `SampleLevel` at three normalised coordinates, with the linear clamp sampler.
    pub fn sample(&mut self, name: &str, coordinates: [&Expr; 3]) -> Expr {
        self.uses_sampler = true;
        let read = Expr::SampleLevel {
            texture: TEXTURE.into(),
            scalar_texture: true,
            sampler: SAMPLER.into(),
            coordinates: coordinates.map(Expr::clone).to_vec(),
            layer: None,
            swizzle: "r",
        };
        self.push(name, read, false)
    }

    /// A texel `Load` at three integer texel indices held in f32.
    pub fn load(&mut self, name: &str, coordinates: [&Expr; 3]) -> Expr {
        let read = Expr::Load {
            texture: TEXTURE.into(),
            scalar_texture: true,
            coordinates: coordinates.map(|c| Expr::Construct(Ty::I32, vec![c.clone()])).to_vec(),
            layer: None,
            swizzle: "r",
        };
        self.push(name, read, false)
    }

    /// The lookup returning `result`: `float NAME(Texture3D<float> tex[, SamplerState
    /// linear_clamp], float mu, ...)` in HLSL, `fn NAME(tex: texture_3d<f32>[, linear_clamp:
    /// sampler], mu: f32, ...) -> f32` in WGSL. Refused where the IR cannot run it.
    pub fn finish(&self, result: Expr) -> Result<Program> {
        let mut params = vec![(TEXTURE.to_string(), Ty::Texture { dims: 3, scalar: true })];
        if self.uses_sampler {
            params.push((SAMPLER.to_string(), Ty::Sampler));
        }
        params.extend(self.inputs.iter().map(|&i| (i.to_string(), Ty::F32)));
        let mut body = self.body.clone();
        body.push(Stmt::Return(result));
        let function = Function { name: self.function.clone(), params, returns: Ty::F32, body };
        let mut module = shader::Module::new(Parens::Full);
        module.push(shader::Item::Function(function));
        let fetches = shader::cost(&module, &self.function)?.texture_reads as usize;
        let lowered = Lowered::new(&module, &self.function)?;
        Ok(Program { module, lowered, fetches })
    }
}

/// A packing's lookup: one function of the IR's shader description, fully parenthesised, so that
/// the order of the f32 operations is on the page.
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    /// A module of the lookup's function alone.
    module: shader::Module,
    /// The function on the IR's tape, as the CPU runs it.
    lowered: Lowered,
    fetches: usize,
}

thread_local! {
    /// A thread's values of its lookups' instructions, kept from run to run: the CPU model and the
    /// report run lookups by the million.
    static SCRATCH: std::cell::RefCell<Vec<f32>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// The packed texture and its filter, answering the reads of a lookup's run.
struct PackedTexels<'t> {
    texture: &'t Texture3D,
    filter: Filter,
}

fn refuse(reason: String) -> Error {
    Error::invalid("packing lookup", reason)
}

impl Textures for PackedTexels<'_> {
    fn load(&self, _: &str, at: &[i32]) -> Result<Option<[f32; 4]>> {
        let &[x, y, z] = at else { return Err(refuse(format!("a load at {at:?}, not three texel indices"))) };
        // Exact in f32 wherever it is inside the texture; anything else reads 0 either way.
        let texel = self.texture.load(x as f32, y as f32, z as f32);
        Ok(Some([texel, 0.0, 0.0, 1.0]))
    }

    fn sample(&self, _: &str, _: &str, at: &[f32], layer: Option<i32>) -> Result<Option<[f32; 4]>> {
        let (&[u, v, w], None) = (at, layer) else {
            return Err(refuse(format!("a sample at {at:?}, layer {layer:?}, not three coordinates of a volume")));
        };
        Ok(Some([self.texture.sample_trilinear(u, v, w, self.filter), 0.0, 0.0, 1.0]))
    }
}

impl Program {
    fn function(&self) -> &Function {
        match self.module.items.first() {
            Some(shader::Item::Function(function)) => function,
            _ => unreachable!("a program's module is its function"),
        }
    }

    /// Name of the shader function, e.g. `fgd_lossless`.
    pub fn name(&self) -> &str {
        &self.function().name
    }

    /// Texture reads per lookup (samples and loads alike: each is one texture instruction).
    pub fn fetch_count(&self) -> usize {
        self.fetches
    }

    /// Whether the lookup filters in hardware (and so takes a sampler).
    pub fn uses_sampler(&self) -> bool {
        self.function().params.iter().any(|(_, ty)| *ty == Ty::Sampler)
    }

    /// Run the lookup on the CPU at `inputs` (one per input of [`ProgramBuilder::new`]), its reads
    /// answered by the emulator.
    pub fn evaluate(&self, inputs: &[f32], texture: &Texture3D, filter: Filter) -> f32 {
        // The builder writes three coordinates per read and the emulator answers every read, so
        // the run fails only on a count of inputs other than the lookup's: the caller's mistake.
        SCRATCH.with_borrow_mut(|values| {
            self.lowered
                .run(inputs, &PackedTexels { texture, filter }, values)
                .unwrap_or_else(|error| panic!("the lookup `{}`: {error}", self.name()))
        })
    }

    /// The lookup run by the IR's interpreter instead of its tape, to hold the two to the same bits.
    #[cfg(test)]
    pub(super) fn interpret(&self, inputs: &[f32], texture: &Texture3D, filter: Filter) -> Result<f32> {
        use crate::shader::eval::{Machine, Value};
        let arguments = [Value::Resource(TEXTURE.into())]
            .into_iter()
            .chain(self.uses_sampler().then(|| Value::Resource(SAMPLER.into())))
            .chain(inputs.iter().map(|&v| Value::F32(v)))
            .collect();
        let run = Machine::new(&self.module)?.call(self.name(), arguments, &PackedTexels { texture, filter })?;
        run.value.f32().ok_or_else(|| refuse(format!("`{}` returned {:?}, not an f32", self.name(), run.value)))
    }

    /// The lookup's statements without language syntax, for the manifest and the docs
    /// ([`Function::statements`]).
    pub fn statements(&self) -> Vec<String> {
        self.function().statements(Parens::Full)
    }

    /// The lookup as a module of the shader description with `header` as its comment: HLSL
    /// value locals are `precise`: the compiler must evaluate them as written (no
    /// reassociation), which the exact interpolation weights rely on (WGSL forbids reassociation
    /// without being asked).
    pub fn module(&self, header: &str) -> shader::Module {
        let mut module = shader::Module::new(Parens::Full);
        module.hlsl_brace_on_next_line = true;
        module.comment(header);
        module.items.extend(self.module.items.iter().cloned());
        module
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn literals_keep_a_decimal_point_and_round_trip() {
        use crate::shader::literal;
        assert_eq!(literal(63.0), "63.0");
        assert_eq!(literal(0.5), "0.5");
        for v in [1.0 / 3.0f32, 1.0 / 63.0, 1e-7, 2047.0] {
            assert_eq!(literal(v).parse::<f32>().unwrap(), v);
        }
    }

    #[test]
    fn evaluation_follows_the_printed_expression() {
        let mut p = ProgramBuilder::new("f", vec!["x"]);
        let x = p.input("x");
        let a = p.local("a", clamp(x, 0.0, 1.0) * float(63.0));
        let b = p.local("b", a.clone().floor().min(float(62.0)));
        let t = p.local("t", a - b);
        let texture = Texture3D { width: 2, height: 1, depth: 1, texels: vec![1.0, 3.0] };
        let (one, half, quarter) = (p.local("one", float(1.0)), p.local("half", float(0.5)), p.local("q", float(0.25)));
        let v0 = p.load("v0", [&one, &half, &half]);
        let v1 = p.sample("v1", [&quarter, &half, &half]);
        let p = p.finish(lerp(v0, v1, t)).unwrap();
        // x = 0.5: a = 31.5, b = 31, t = 0.5; v0 = texel 1 (0.5 truncates to 0) = 3; v1 = texel 0 = 1.
        assert_eq!(p.evaluate(&[0.5], &texture, Filter::Exact), 2.0);
        assert_eq!(p.fetch_count(), 2);
        let lines = p.statements();
        assert_eq!(lines[0], "a = (min(max(x, 0.0), 1.0) * 63.0)");
        assert_eq!(lines[1], "b = min(floor(a), 62.0)");
        assert_eq!(lines[6], "v0 = load(tex, i32(one), i32(half), i32(half))");
        assert_eq!(lines[7], "v1 = sample(tex, linear_clamp, q, half, half)");
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
        let mut p = ProgramBuilder::new("g", vec!["x"]);
        let zero = p.local("zero", float(0.0));
        let v = p.load("v", [&zero, &zero, &zero]);
        let p = p.finish(v).unwrap();
        assert!(!p.uses_sampler());
        assert!(p.hlsl("h").contains("float g(Texture3D<float> tex, float x)"));
        assert!(p.wgsl("h").contains("fn g(tex: texture_3d<f32>, x: f32) -> f32 {"));
    }

    #[test]
    fn a_lookup_the_ir_cannot_run_is_refused_when_built() {
        let p = ProgramBuilder::new("h", vec!["x"]);
        let error = p.finish(shader::name("y")).unwrap_err().to_string();
        assert!(error.contains("`y`"), "{error}");
    }
}
