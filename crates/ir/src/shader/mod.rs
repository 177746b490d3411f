//! One shader emitter: a small typed description of shader code (types, expressions, statements,
//! functions, structs, bindings) printed as HLSL, WGSL and GLSL. Every shader tmlut writes — the
//! lookups of the GPU packings, the fitted forms and the transfer-matrix evaluation of a scene
//! (all in `tmlut`) — is built as one [`Module`] and printed
//! in each language it ships in, so the languages cannot drift apart: a change is made once, in
//! the description.
//!
//! The description holds only what the languages spell the same way up to syntax: f32/i32/u32
//! arithmetic, comparisons, a fixed list of builtins ([`Builtin`]), vectors, structs, fixed-size
//! arrays and module constants of them, `select`, texel loads and filtered samples (of texture
//! arrays too). [`eval`] runs a module on the CPU with WGSL's meaning and counts what a function
//! costs ([`cost`]); [`Function::statements`] writes a function in no language, a line per
//! statement, for a manifest. Where they differ in meaning the emitter
//! does not paper over it: HLSL's `precise` has no WGSL counterpart (WGSL forbids reassociation
//! anyway), and WGSL has no `isnan`, so the evaluation code tests finiteness with comparisons.
//!
//! GLSL is printed for Vulkan (`#version 450`, which the module itself does not state: its text is
//! meant to be included): textures and samplers are separate objects, combined at each filtered
//! sample (`sampler2D(t, s)`), and a texel load reads the texture alone, which needs
//! `GL_EXT_samplerless_texture_functions` in the including shader.

use std::fmt::Write as _;

pub use crate::real::{Compare, Intrinsic};

/// A shading language the emitter prints.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Lang {
    Hlsl,
    Wgsl,
    /// GLSL 4.50 for Vulkan.
    Glsl,
}

impl Lang {
    pub fn extension(self) -> &'static str {
        match self {
            Lang::Hlsl => "hlsl",
            Lang::Wgsl => "wgsl",
            Lang::Glsl => "glsl",
        }
    }
}

/// A type.
#[derive(Debug, Clone, PartialEq)]
pub enum Ty {
    F32,
    I32,
    U32,
    Bool,
    /// `vecN<f32>` / `floatN`, N in 2..=4.
    Vec(u8),
    /// `vecN<i32>` / `intN`.
    IVec(u8),
    /// A struct declared in the module.
    Named(String),
    /// A fixed-size array (struct fields only).
    Array(Box<Ty>, usize),
    /// A sampled float texture of `dims` (2 or 3) dimensions; `scalar` makes HLSL's element type
    /// `float` (its loads and samples return a scalar) instead of `float4`.
    Texture {
        dims: u8,
        scalar: bool,
    },
    /// An array of 2D float textures of four channels, addressed by an integer layer.
    TextureArray,
    Sampler,
    /// A read-only storage buffer of f32 whose length the bound buffer gives (bindings only):
    /// WGSL `var<storage, read> name: array<f32>`, HLSL `StructuredBuffer<float>`, read with
    /// [`Expr::Element`].
    StorageArray,
}

impl Ty {
    fn text(&self, lang: Lang) -> String {
        match (self, lang) {
            (Ty::F32, Lang::Hlsl | Lang::Glsl) => "float".into(),
            (Ty::F32, Lang::Wgsl) => "f32".into(),
            (Ty::I32, Lang::Hlsl | Lang::Glsl) => "int".into(),
            (Ty::I32, Lang::Wgsl) => "i32".into(),
            (Ty::U32, Lang::Hlsl | Lang::Glsl) => "uint".into(),
            (Ty::U32, Lang::Wgsl) => "u32".into(),
            (Ty::Bool, _) => "bool".into(),
            (Ty::Vec(n), Lang::Hlsl) => format!("float{n}"),
            (Ty::Vec(n), Lang::Wgsl) => format!("vec{n}<f32>"),
            (Ty::Vec(n), Lang::Glsl) => format!("vec{n}"),
            (Ty::IVec(n), Lang::Hlsl) => format!("int{n}"),
            (Ty::IVec(n), Lang::Wgsl) => format!("vec{n}<i32>"),
            (Ty::IVec(n), Lang::Glsl) => format!("ivec{n}"),
            (Ty::Named(name), _) => name.clone(),
            (Ty::Array(t, n), Lang::Wgsl) => format!("array<{}, {n}>", t.text(lang)),
            (Ty::Array(t, _), Lang::Hlsl) => t.text(lang),
            // The type as a constructor names it (`float[2](a, b)`); a declaration puts the extent
            // after the name instead ([`Ty::declare`]).
            (Ty::Array(t, n), Lang::Glsl) => format!("{}[{n}]", t.text(lang)),
            (Ty::Texture { dims, scalar }, Lang::Hlsl) => {
                format!("Texture{dims}D<{}>", if *scalar { "float" } else { "float4" })
            }
            (Ty::Texture { dims, .. }, Lang::Wgsl) => format!("texture_{dims}d<f32>"),
            (Ty::Texture { dims, .. }, Lang::Glsl) => format!("texture{dims}D"),
            (Ty::TextureArray, Lang::Hlsl) => "Texture2DArray<float4>".into(),
            (Ty::TextureArray, Lang::Wgsl) => "texture_2d_array<f32>".into(),
            (Ty::TextureArray, Lang::Glsl) => "texture2DArray".into(),
            (Ty::Sampler, Lang::Hlsl) => "SamplerState".into(),
            (Ty::Sampler, Lang::Wgsl | Lang::Glsl) => "sampler".into(),
            (Ty::StorageArray, Lang::Hlsl) => "StructuredBuffer<float>".into(),
            (Ty::StorageArray, Lang::Wgsl) => "array<f32>".into(),
            (Ty::StorageArray, Lang::Glsl) => "float[]".into(),
        }
    }

    /// `TYPE name` (HLSL and GLSL, with an array's extent after the name) or `name: TYPE` (WGSL).
    fn declare(&self, name: &str, lang: Lang) -> String {
        match (lang, self) {
            (Lang::Hlsl, Ty::Array(_, n)) => format!("{} {name}[{n}]", self.text(lang)),
            (Lang::Glsl, Ty::Array(t, n)) => format!("{} {name}[{n}]", t.text(lang)),
            (Lang::Hlsl | Lang::Glsl, _) => format!("{} {name}", self.text(lang)),
            (Lang::Wgsl, _) => format!("{name}: {}", self.text(lang)),
        }
    }

    /// The sampler type a GLSL texture of this type is combined into for a filtered sample.
    fn glsl_sampler(&self) -> String {
        match self {
            Ty::TextureArray => "sampler2DArray".into(),
            Ty::Texture { dims, .. } => format!("sampler{dims}D"),
            _ => "sampler2D".into(),
        }
    }
}

/// A builtin function both languages define with the same meaning: one of the intrinsics the
/// form language shares ([`Intrinsic`]), or `dot` of two vectors.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Builtin {
    Intrinsic(Intrinsic),
    Dot,
}

impl From<Intrinsic> for Builtin {
    fn from(intrinsic: Intrinsic) -> Self {
        Builtin::Intrinsic(intrinsic)
    }
}

impl Builtin {
    /// Its name in `lang`. HLSL has no `asinh`: the printers of tapes call a helper for it
    /// (`tmlut::shader::tape`), and a call of it here would print WGSL's name. GLSL has no
    /// `saturate`: the printer writes it as a `clamp` ([`Printer::write`]).
    fn name(self, lang: Lang) -> &'static str {
        match (self, lang) {
            (Builtin::Dot, _) => "dot",
            (Builtin::Intrinsic(Intrinsic::Fract), Lang::Hlsl) => "frac",
            (Builtin::Intrinsic(Intrinsic::InverseSqrt), Lang::Hlsl) => "rsqrt",
            (Builtin::Intrinsic(Intrinsic::Mix), Lang::Hlsl) => "lerp",
            (Builtin::Intrinsic(Intrinsic::InverseSqrt), Lang::Glsl) => "inversesqrt",
            (Builtin::Intrinsic(Intrinsic::Atan2), Lang::Glsl) => "atan",
            (Builtin::Intrinsic(intrinsic), _) => intrinsic.wgsl_name(),
        }
    }
}

/// A binary operator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Op {
    Add,
    Sub,
    Mul,
    Div,
    Compare(Compare),
    And,
    Or,
}

impl Op {
    fn text(self) -> &'static str {
        match self {
            Op::Add => "+",
            Op::Sub => "-",
            Op::Mul => "*",
            Op::Div => "/",
            Op::Compare(compare) => compare.text(),
            Op::And => "&&",
            Op::Or => "||",
        }
    }

    /// Binding strength, as C, HLSL and WGSL agree for the operators used here (WGSL refuses to
    /// mix `&&` with comparisons unparenthesised, which the printer never does: comparisons bind
    /// tighter and are parenthesised inside `&&` by [`Style::Minimal`] too).
    fn precedence(self) -> u8 {
        match self {
            Op::Or => 1,
            Op::And => 2,
            Op::Compare(_) => 3,
            Op::Add | Op::Sub => 4,
            Op::Mul | Op::Div => 5,
        }
    }
}

/// An expression.
#[derive(Debug, Clone, PartialEq)]
pub enum Expr {
    /// A parameter, local, global or constant by name.
    Name(String),
    F32(f32),
    I32(i32),
    /// A `u32` literal: `3u` in both languages.
    U32(u32),
    Binary(Op, Box<Expr>, Box<Expr>),
    Neg(Box<Expr>),
    Call(Builtin, Vec<Expr>),
    /// A function of the module.
    Function(String, Vec<Expr>),
    /// A vector or scalar constructor / conversion: `vec3<f32>(a, b, c)`, `float3(a, b, c)`,
    /// `i32(x)`, `int(x)`.
    Construct(Ty, Vec<Expr>),
    /// Parentheses the author wants for the reader, where precedence would not need them.
    Paren(Box<Expr>),
    /// A struct member or swizzle.
    Member(Box<Expr>, String),
    /// An array element at a constant index.
    Index(Box<Expr>, usize),
    /// An array element at an index computed in the shader (an `i32` or `u32`).
    Element(Box<Expr>, Box<Expr>),
    /// The value of a struct or an array from its fields or elements, in a module constant's
    /// initialiser only (HLSL's brace list is no expression elsewhere): `T(a, b)` /
    /// `array<T, N>(a, b)` in WGSL, `{a, b}` in HLSL.
    Aggregate(Ty, Vec<Expr>),
    /// `condition ? then : otherwise` / `select(otherwise, then, condition)`.
    Select {
        condition: Box<Expr>,
        then: Box<Expr>,
        otherwise: Box<Expr>,
    },
    /// One texel of mip level 0 at integer coordinates: `textureLoad(t, c, 0)` / `t.Load(intN(c, 0))`.
    /// `swizzle` is applied in WGSL always (whose loads return four channels) and in HLSL where
    /// the texture is declared with four channels.
    Load {
        texture: String,
        scalar_texture: bool,
        coordinates: Vec<Expr>,
        /// The layer of a texture array (an `i32`): `textureLoad(t, c, layer, 0)` /
        /// `t.Load(int4(c, layer, 0))`.
        layer: Option<Box<Expr>>,
        swizzle: &'static str,
    },
    /// A filtered sample at mip level 0: `textureSampleLevel(t, s, c, 0.0)` / `t.SampleLevel(s, c, 0)`.
    SampleLevel {
        texture: String,
        scalar_texture: bool,
        sampler: String,
        coordinates: Vec<Expr>,
        /// The layer of a texture array (an `i32` or `u32`): `textureSampleLevel(t, s, c, layer,
        /// 0.0)` / `t.SampleLevel(s, floatN(c, layer), 0)`.
        layer: Option<Box<Expr>>,
        swizzle: &'static str,
    },
}

/// Shorthands for building expressions.
pub fn name(n: &str) -> Expr {
    Expr::Name(n.to_string())
}
/// An f32 constant, as a shader can hold it: an infinity (a value past f32's range, folded from
/// f64) becomes the largest finite f32 of its sign, since neither language has an infinite
/// literal (naga refuses `inf`), and a subnormal becomes 0 of its sign, as GPUs that flush
/// subnormals read it anyway, so that the CPU side of a program (the packing's emulated lookup)
/// computes with the value the GPU sees.
pub fn float(v: f32) -> Expr {
    Expr::F32(representable(v))
}

/// `v` as [`float`] stores it.
pub fn representable(v: f32) -> f32 {
    if v.is_infinite() {
        f32::MAX.copysign(v)
    } else if v.is_subnormal() {
        0.0f32.copysign(v)
    } else {
        v
    }
}
pub fn call(b: impl Into<Builtin>, args: Vec<Expr>) -> Expr {
    Expr::Call(b.into(), args)
}
pub fn func(n: &str, args: Vec<Expr>) -> Expr {
    Expr::Function(n.to_string(), args)
}
pub fn vec3(a: Expr, b: Expr, c: Expr) -> Expr {
    Expr::Construct(Ty::Vec(3), vec![a, b, c])
}
pub fn splat3(a: Expr) -> Expr {
    Expr::Construct(Ty::Vec(3), vec![a])
}
pub fn select(condition: Expr, then: Expr, otherwise: Expr) -> Expr {
    Expr::Select { condition: Box::new(condition), then: Box::new(then), otherwise: Box::new(otherwise) }
}

macro_rules! binary_operator {
    ($trait:ident, $method:ident, $op:expr) => {
        impl std::ops::$trait for Expr {
            type Output = Expr;
            fn $method(self, o: Expr) -> Expr {
                Expr::Binary($op, Box::new(self), Box::new(o))
            }
        }
    };
}
binary_operator!(Add, add, Op::Add);
binary_operator!(Sub, sub, Op::Sub);
binary_operator!(Mul, mul, Op::Mul);
binary_operator!(Div, div, Op::Div);

impl std::ops::Neg for Expr {
    type Output = Expr;
    fn neg(self) -> Expr {
        Expr::Neg(Box::new(self))
    }
}

impl Expr {
    pub fn op(self, op: Op, o: Expr) -> Expr {
        Expr::Binary(op, Box::new(self), Box::new(o))
    }
    pub fn lt(self, o: Expr) -> Expr {
        self.op(Op::Compare(Compare::Lt), o)
    }
    pub fn gt(self, o: Expr) -> Expr {
        self.op(Op::Compare(Compare::Gt), o)
    }
    pub fn le(self, o: Expr) -> Expr {
        self.op(Op::Compare(Compare::Le), o)
    }
    pub fn ge(self, o: Expr) -> Expr {
        self.op(Op::Compare(Compare::Ge), o)
    }
    pub fn ne(self, o: Expr) -> Expr {
        self.op(Op::Compare(Compare::Ne), o)
    }
    pub fn and(self, o: Expr) -> Expr {
        self.op(Op::And, o)
    }
    pub fn min(self, o: Expr) -> Expr {
        call(Intrinsic::Min, vec![self, o])
    }
    pub fn max(self, o: Expr) -> Expr {
        call(Intrinsic::Max, vec![self, o])
    }
    pub fn clamp(self, lo: Expr, hi: Expr) -> Expr {
        call(Intrinsic::Clamp, vec![self, lo, hi])
    }
    pub fn sqrt(self) -> Expr {
        call(Intrinsic::Sqrt, vec![self])
    }
    pub fn abs(self) -> Expr {
        call(Intrinsic::Abs, vec![self])
    }
    pub fn floor(self) -> Expr {
        call(Intrinsic::Floor, vec![self])
    }
    pub fn member(self, m: &str) -> Expr {
        Expr::Member(Box::new(self), m.to_string())
    }
    pub fn index(self, i: usize) -> Expr {
        Expr::Index(Box::new(self), i)
    }
    pub fn element(self, i: Expr) -> Expr {
        Expr::Element(Box::new(self), Box::new(i))
    }

    fn precedence(&self) -> u8 {
        match self {
            Expr::Binary(op, ..) => op.precedence(),
            Expr::Select { .. } => 0,
            Expr::Neg(_) => 6,
            // A negative literal prints with its sign: it binds as a unary minus.
            Expr::F32(v) if v.is_sign_negative() => 6,
            Expr::I32(v) if *v < 0 => 6,
            _ => 7,
        }
    }
}

/// f32 literal text both languages parse to the same value: Rust's shortest round-trip form,
/// which always has a `.` or an exponent (`63.0`, `0.0078125`, `1e-7`).
pub fn literal(v: f32) -> String {
    let text = format!("{v:?}");
    if text.contains('.') || text.contains('e') || text.contains("inf") || text.contains("NaN") {
        text
    } else {
        format!("{text}.0")
    }
}

/// How binary expressions are parenthesised.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Parens {
    /// Every binary operation in parentheses: `(a + (b * c))`, so a reader sees the order of the
    /// f32 operations without knowing precedence (the packing lookups).
    Full,
    /// Only where precedence needs them: `a + b * c`.
    Minimal,
}

/// A statement.
#[derive(Debug, Clone, PartialEq)]
pub enum Stmt {
    /// An immutable local: WGSL `let name[: T] = v;`, HLSL `[precise ]T name = v;`.
    Let {
        name: String,
        ty: Ty,
        value: Expr,
        typed: bool,
        precise: bool,
    },
    /// A mutable local: WGSL `var name: T = v;` (or zero-initialised `var name: T;`), HLSL
    /// `T name = v;` (or `T name = (T)0;`).
    Var {
        name: String,
        ty: Ty,
        value: Option<Expr>,
    },
    /// `target = value;`
    Assign(Expr, Expr),
    If {
        condition: Expr,
        then: Vec<Stmt>,
        otherwise: Vec<Stmt>,
    },
    Return(Expr),
    /// `switch selector { case K: {...} ... default: {...} }` over a `u32` selector, no case falling
    /// through (HLSL's cases end in `break`).
    Switch {
        selector: Expr,
        cases: Vec<(u32, Vec<Stmt>)>,
        default: Vec<Stmt>,
    },
    Comment(String),
}

pub fn let_(n: &str, ty: Ty, value: Expr) -> Stmt {
    Stmt::Let { name: n.to_string(), ty, value, typed: true, precise: false }
}
pub fn var(n: &str, ty: Ty, value: Expr) -> Stmt {
    Stmt::Var { name: n.to_string(), ty, value: Some(value) }
}
pub fn assign(target: Expr, value: Expr) -> Stmt {
    Stmt::Assign(target, value)
}

/// A function.
#[derive(Debug, Clone, PartialEq)]
pub struct Function {
    pub name: String,
    pub params: Vec<(String, Ty)>,
    pub returns: Ty,
    pub body: Vec<Stmt>,
}

/// A top-level item.
#[derive(Debug, Clone, PartialEq)]
pub enum Item {
    /// Comment lines (`// ` prefixed; an empty line prints as `//`).
    Comment(String),
    Function(Function),
    Struct {
        name: String,
        fields: Vec<(String, Ty)>,
    },
    /// A module constant: WGSL `const name: T = value;`, HLSL `static const T name = value;`.
    Constant {
        name: String,
        ty: Ty,
        value: Expr,
    },
    /// A resource: WGSL `@group(G) @binding(B) var name: T;`, HLSL `T name : register(tB[, spaceG]);`.
    Binding {
        group: u32,
        binding: u32,
        name: String,
        ty: Ty,
    },
    /// A blank line.
    Blank,
}

/// A module: items printed in order.
#[derive(Debug, Clone, PartialEq)]
pub struct Module {
    pub items: Vec<Item>,
    pub parens: Parens,
    /// HLSL functions open their brace on the line after the signature (the packing lookups'
    /// layout); otherwise on the same line.
    pub hlsl_brace_on_next_line: bool,
}

impl Module {
    pub fn new(parens: Parens) -> Self {
        Module { items: Vec::new(), parens, hlsl_brace_on_next_line: false }
    }

    pub fn push(&mut self, item: Item) {
        self.items.push(item);
    }

    pub fn function(&mut self, name: &str, params: Vec<(&str, Ty)>, returns: Ty, body: Vec<Stmt>) {
        self.items.push(Item::Function(Function {
            name: name.to_string(),
            params: params.into_iter().map(|(n, t)| (n.to_string(), t)).collect(),
            returns,
            body,
        }));
    }

    pub fn comment(&mut self, text: &str) {
        self.items.push(Item::Comment(text.to_string()));
    }

    /// The module's text in `lang`.
    pub fn print(&self, lang: Lang) -> String {
        let p = Printer { lang, parens: self.parens, structs: self.structs(), notation: false };
        let mut s = String::new();
        for item in &self.items {
            match item {
                Item::Comment(text) => s.push_str(&comment_block("//", text)),
                Item::Blank => s.push('\n'),
                Item::Struct { name, fields } => {
                    let _ = writeln!(s, "struct {name} {{");
                    for (field, ty) in fields {
                        let _ = match lang {
                            Lang::Hlsl | Lang::Glsl => writeln!(s, "    {};", ty.declare(field, lang)),
                            Lang::Wgsl => writeln!(s, "    {},", ty.declare(field, lang)),
                        };
                    }
                    s.push_str(if lang == Lang::Wgsl { "}\n" } else { "};\n" });
                }
                Item::Constant { name, ty, value } => {
                    let _ = match lang {
                        Lang::Wgsl => writeln!(s, "const {name}: {} = {};", ty.text(lang), p.expr(value)),
                        Lang::Hlsl => writeln!(s, "static const {} = {};", ty.declare(name, lang), p.expr(value)),
                        Lang::Glsl => writeln!(s, "const {} = {};", ty.declare(name, lang), p.expr(value)),
                    };
                }
                Item::Binding { group, binding, name, ty } => {
                    let _ = match lang {
                        Lang::Wgsl => {
                            let space = if *ty == Ty::StorageArray { "<storage, read>" } else { "" };
                            writeln!(s, "@group({group}) @binding({binding}) var{space} {name}: {};", ty.text(lang))
                        }
                        Lang::Hlsl => {
                            let register = if *ty == Ty::Sampler { 's' } else { 't' };
                            let space = if *group == 0 { String::new() } else { format!(", space{group}") };
                            writeln!(s, "{} : register({register}{binding}{space});", ty.declare(name, lang))
                        }
                        // A storage buffer is a block in GLSL; declared without an instance
                        // name, its array reads by the binding's name as in WGSL and HLSL.
                        Lang::Glsl if *ty == Ty::StorageArray => writeln!(
                            s,
                            "layout(std430, set = {group}, binding = {binding}) readonly buffer {name}_block {{ float \
                             {name}[]; }};"
                        ),
                        Lang::Glsl => writeln!(
                            s,
                            "layout(set = {group}, binding = {binding}) uniform {};",
                            ty.declare(name, lang)
                        ),
                    };
                }
                Item::Function(function) => {
                    let params: Vec<String> = function.params.iter().map(|(n, t)| t.declare(n, lang)).collect();
                    let _ = match lang {
                        Lang::Hlsl | Lang::Glsl => {
                            let next_line = self.hlsl_brace_on_next_line && lang == Lang::Hlsl;
                            let brace = if next_line { "\n{" } else { " {" };
                            writeln!(
                                s,
                                "{} {}({}){brace}",
                                function.returns.text(lang),
                                function.name,
                                params.join(", ")
                            )
                        }
                        Lang::Wgsl => writeln!(
                            s,
                            "fn {}({}) -> {} {{",
                            function.name,
                            params.join(", "),
                            function.returns.text(lang)
                        ),
                    };
                    for stmt in &function.body {
                        p.stmt(stmt, 1, &mut s);
                    }
                    s.push_str("}\n");
                }
            }
        }
        s
    }
}

impl Module {
    /// The fields of each struct the module declares, by name: what a GLSL zero value spells out.
    fn structs(&self) -> std::collections::BTreeMap<String, Vec<Ty>> {
        let declared = self.items.iter().filter_map(|item| match item {
            Item::Struct { name, fields } => Some((name.clone(), fields.iter().map(|(_, ty)| ty.clone()).collect())),
            _ => None,
        });
        declared.collect()
    }
}

struct Printer {
    /// The language whose names the expressions take; in the notation WGSL's.
    lang: Lang,
    parens: Parens,
    /// The module's structs' field types ([`Module::structs`]).
    structs: std::collections::BTreeMap<String, Vec<Ty>>,
    /// Printing [`Function::statements`]' notation, not a shading language.
    notation: bool,
}

impl Printer {
    fn stmt(&self, stmt: &Stmt, depth: usize, s: &mut String) {
        let pad = "    ".repeat(depth);
        let lang = self.lang;
        match stmt {
            Stmt::Let { name, ty, value, typed, precise } => {
                let value = self.expr(value);
                let _ = match lang {
                    // GLSL 4.00 and later have HLSL's `precise`, with the same meaning.
                    Lang::Hlsl | Lang::Glsl => {
                        let precise = if *precise { "precise " } else { "" };
                        writeln!(s, "{pad}{precise}{} = {value};", ty.declare(name, lang))
                    }
                    Lang::Wgsl if *typed => writeln!(s, "{pad}let {name}: {} = {value};", ty.text(lang)),
                    Lang::Wgsl => writeln!(s, "{pad}let {name} = {value};"),
                };
            }
            Stmt::Var { name, ty, value } => {
                let _ = match (lang, value) {
                    (Lang::Hlsl, Some(v)) => writeln!(s, "{pad}{} = {};", ty.declare(name, lang), self.expr(v)),
                    (Lang::Hlsl, None) => {
                        writeln!(s, "{pad}{} = ({})0;", ty.declare(name, lang), ty.text(lang))
                    }
                    (Lang::Wgsl, Some(v)) => writeln!(s, "{pad}var {name}: {} = {};", ty.text(lang), self.expr(v)),
                    (Lang::Wgsl, None) => writeln!(s, "{pad}var {name}: {};", ty.text(lang)),
                    (Lang::Glsl, Some(v)) => writeln!(s, "{pad}{} = {};", ty.declare(name, lang), self.expr(v)),
                    // GLSL leaves a local without an initialiser undefined, where WGSL and HLSL
                    // zero it: the zero value is spelt out.
                    (Lang::Glsl, None) => writeln!(s, "{pad}{} = {};", ty.declare(name, lang), self.glsl_zero(ty)),
                };
            }
            Stmt::Assign(target, value) => {
                let _ = writeln!(s, "{pad}{} = {};", self.expr(target), self.expr(value));
            }
            Stmt::If { condition, then, otherwise } => {
                let _ = writeln!(s, "{pad}if ({}) {{", self.expr(condition));
                for t in then {
                    self.stmt(t, depth + 1, s);
                }
                if otherwise.is_empty() {
                    let _ = writeln!(s, "{pad}}}");
                } else {
                    let _ = writeln!(s, "{pad}}} else {{");
                    for t in otherwise {
                        self.stmt(t, depth + 1, s);
                    }
                    let _ = writeln!(s, "{pad}}}");
                }
            }
            Stmt::Return(e) => {
                let _ = writeln!(s, "{pad}return {};", self.expr(e));
            }
            Stmt::Switch { selector, cases, default } => {
                let selector = self.expr(selector);
                let _ = match lang {
                    Lang::Wgsl => writeln!(s, "{pad}switch {selector} {{"),
                    Lang::Hlsl | Lang::Glsl => writeln!(s, "{pad}switch ({selector}) {{"),
                };
                let labelled = cases.iter().map(|(k, body)| {
                    let label = match lang {
                        Lang::Wgsl | Lang::Glsl => format!("case {k}u"),
                        Lang::Hlsl => format!("case {k}"),
                    };
                    (label, body)
                });
                for (label, body) in labelled.chain(std::iter::once(("default".to_string(), default))) {
                    let _ = writeln!(s, "{pad}    {label}: {{");
                    for t in body {
                        self.stmt(t, depth + 2, s);
                    }
                    if lang != Lang::Wgsl {
                        let _ = writeln!(s, "{pad}        break;");
                    }
                    let _ = writeln!(s, "{pad}    }}");
                }
                let _ = writeln!(s, "{pad}}}");
            }
            Stmt::Comment(text) => s.push_str(&comment_block(&format!("{pad}//"), text)),
        }
    }

    /// The zero value of `ty` as a GLSL expression: what WGSL's `var x: T;` and HLSL's `(T)0`
    /// hold.
    fn glsl_zero(&self, ty: &Ty) -> String {
        match ty {
            Ty::F32 => "0.0".into(),
            Ty::I32 => "0".into(),
            Ty::U32 => "0u".into(),
            Ty::Bool => "false".into(),
            Ty::Vec(n) => format!("vec{n}(0.0)"),
            Ty::IVec(n) => format!("ivec{n}(0)"),
            Ty::Array(t, n) => {
                let zero = self.glsl_zero(t);
                format!("{}({})", ty.text(Lang::Glsl), vec![zero; *n].join(", "))
            }
            Ty::Named(name) => {
                let fields = self.structs.get(name).map(Vec::as_slice).unwrap_or_default();
                let zeros: Vec<String> = fields.iter().map(|t| self.glsl_zero(t)).collect();
                format!("{name}({})", zeros.join(", "))
            }
            // Opaque types are never locals.
            Ty::Texture { .. } | Ty::TextureArray | Ty::Sampler | Ty::StorageArray => ty.text(Lang::Glsl),
        }
    }

    fn expr(&self, e: &Expr) -> String {
        let mut out = String::new();
        self.write(e, &mut out);
        out
    }

    fn list(&self, args: &[Expr]) -> String {
        args.iter().map(|a| self.expr(a)).collect::<Vec<_>>().join(", ")
    }

    /// `e` as an operand of an operator of precedence `outer`; `right` marks the right operand,
    /// which needs parentheses at equal precedence (`a - (b - c)`).
    fn operand(&self, e: &Expr, outer: u8, right: bool, out: &mut String) {
        let inner = e.precedence();
        // A comparison inside `&&`/`||` is parenthesised: WGSL requires it for mixed operators.
        let needs = match self.parens {
            Parens::Minimal => inner < outer || (right && inner == outer) || (outer <= 2 && inner == 3),
            // Binary operations carry their own parentheses; a selection still needs them.
            Parens::Full => inner == 0,
        };
        if needs {
            out.push('(');
            self.write(e, out);
            out.push(')');
        } else {
            self.write(e, out);
        }
    }

    fn write(&self, e: &Expr, out: &mut String) {
        let lang = self.lang;
        match e {
            Expr::Name(n) => out.push_str(n),
            Expr::F32(v) => out.push_str(&literal(*v)),
            Expr::I32(v) => {
                let _ = write!(out, "{v}");
            }
            Expr::U32(v) => {
                let _ = write!(out, "{v}u");
            }
            Expr::Binary(op, a, b) => {
                let full = self.parens == Parens::Full;
                if full {
                    out.push('(');
                }
                self.operand(a, op.precedence(), false, out);
                let _ = write!(out, " {} ", op.text());
                self.operand(b, op.precedence(), true, out);
                if full {
                    out.push(')');
                }
            }
            Expr::Neg(a) => {
                out.push('-');
                self.operand(a, 6, true, out);
            }
            Expr::Call(Builtin::Intrinsic(Intrinsic::Saturate), args) if lang == Lang::Glsl => {
                let _ = write!(out, "clamp({}, 0.0, 1.0)", self.list(args));
            }
            Expr::Call(b, args) => {
                let _ = write!(out, "{}({})", b.name(lang), self.list(args));
            }
            Expr::Function(n, args) => {
                let _ = write!(out, "{n}({})", self.list(args));
            }
            Expr::Construct(ty, args) => {
                // HLSL has no splat constructor: `float3(x)` is written `(float3)x`... which is
                // also a cast; spell the splat out instead.
                let args = if lang == Lang::Hlsl && args.len() == 1 {
                    match ty {
                        Ty::Vec(n) | Ty::IVec(n) => vec![args[0].clone(); *n as usize],
                        _ => args.clone(),
                    }
                } else {
                    args.clone()
                };
                let _ = write!(out, "{}({})", ty.text(lang), self.list(&args));
            }
            Expr::Paren(a) => {
                out.push('(');
                self.write(a, out);
                out.push(')');
            }
            Expr::Member(a, m) => {
                self.operand(a, 7, false, out);
                let _ = write!(out, ".{m}");
            }
            Expr::Index(a, i) => {
                self.operand(a, 7, false, out);
                let _ = write!(out, "[{i}]");
            }
            Expr::Element(a, i) => {
                self.operand(a, 7, false, out);
                let _ = write!(out, "[{}]", self.expr(i));
            }
            Expr::Aggregate(ty, parts) => {
                // An aggregate of aggregates (a table of structs) puts each on a line of its own.
                let nested = parts.iter().all(|p| matches!(p, Expr::Aggregate(..))) && !parts.is_empty();
                let list = match nested {
                    true => {
                        format!("\n    {}\n", parts.iter().map(|p| self.expr(p)).collect::<Vec<_>>().join(",\n    "))
                    }
                    false => self.list(parts),
                };
                let _ = match lang {
                    Lang::Wgsl | Lang::Glsl => write!(out, "{}({list})", ty.text(lang)),
                    Lang::Hlsl => write!(out, "{{{list}}}"),
                };
            }
            // The notation takes C's conditional, which reads in the order it chooses.
            Expr::Select { condition, then, otherwise } => match lang {
                Lang::Wgsl if !self.notation => {
                    let _ =
                        write!(out, "select({}, {}, {})", self.expr(otherwise), self.expr(then), self.expr(condition));
                }
                Lang::Wgsl | Lang::Hlsl | Lang::Glsl => {
                    let _ = write!(out, "{} ? {} : {}", self.expr(condition), self.expr(then), self.expr(otherwise));
                }
            },
            Expr::Load { .. } | Expr::SampleLevel { .. } if self.notation => self.write_read_in_notation(e, out),
            Expr::Load { .. } | Expr::SampleLevel { .. } => self.write_texture_read(e, out),
        }
    }

    /// A texture read: a texel load or a filtered sample at mip level 0.
    fn write_texture_read(&self, e: &Expr, out: &mut String) {
        let lang = self.lang;
        match e {
            Expr::Load { texture, scalar_texture, coordinates, layer, swizzle } => {
                let n = coordinates.len() as u8;
                match lang {
                    Lang::Wgsl => {
                        let layer = layer
                            .as_ref()
                            .map(|l| format!("{}, ", self.list(std::slice::from_ref(l))))
                            .unwrap_or_default();
                        let _ = write!(
                            out,
                            "textureLoad({texture}, {}({}), {layer}0).{swizzle}",
                            Ty::IVec(n).text(lang),
                            self.list(coordinates)
                        );
                    }
                    Lang::Hlsl => {
                        let all = with_layer(coordinates, layer);
                        let _ = write!(
                            out,
                            "{texture}.Load({}({}, 0))",
                            Ty::IVec(all.len() as u8 + 1).text(lang),
                            self.list(&all)
                        );
                        if !scalar_texture {
                            let _ = write!(out, ".{swizzle}");
                        }
                    }
                    // A texture read without a sampler (GL_EXT_samplerless_texture_functions);
                    // like WGSL's, the load returns four channels.
                    Lang::Glsl => {
                        let all = with_layer(coordinates, layer);
                        let _ = write!(
                            out,
                            "texelFetch({texture}, {}({}), 0).{swizzle}",
                            Ty::IVec(all.len() as u8).text(lang),
                            self.list(&all)
                        );
                    }
                }
            }
            Expr::SampleLevel { texture, scalar_texture, sampler, coordinates, layer, swizzle } => {
                let n = coordinates.len() as u8;
                match lang {
                    Lang::Wgsl => {
                        let layer = layer.as_ref().map(|l| format!("{}, ", self.expr(l))).unwrap_or_default();
                        let _ = write!(
                            out,
                            "textureSampleLevel({texture}, {sampler}, {}({}), {layer}0.0).{swizzle}",
                            Ty::Vec(n).text(lang),
                            self.list(coordinates)
                        );
                    }
                    Lang::Hlsl => {
                        // A texture array's layer is the coordinate after the others, as a float.
                        let all = with_layer(coordinates, layer);
                        let _ = write!(
                            out,
                            "{texture}.SampleLevel({sampler}, {}({}), 0)",
                            Ty::Vec(all.len() as u8).text(lang),
                            self.list(&all)
                        );
                        if !scalar_texture {
                            let _ = write!(out, ".{swizzle}");
                        }
                    }
                    // The texture and the sampler combined at the read; a texture array's layer is
                    // the coordinate after the others, as a float (as HLSL's).
                    Lang::Glsl => {
                        let mut all = coordinates.clone();
                        all.extend(layer.iter().map(|l| Expr::Construct(Ty::F32, vec![(**l).clone()])));
                        let combined = match (&layer, n) {
                            (Some(_), _) => Ty::TextureArray,
                            (None, dims) => Ty::Texture { dims, scalar: false },
                        };
                        let _ = write!(
                            out,
                            "textureLod({}({texture}, {sampler}), {}({}), 0.0).{swizzle}",
                            combined.glsl_sampler(),
                            Ty::Vec(all.len() as u8).text(lang),
                            self.list(&all)
                        );
                    }
                }
            }
            _ => unreachable!("write_texture_read is called with a texture read"),
        }
    }
}

/// A texture read's coordinates, then its layer where it reads an array.
fn with_layer(coordinates: &[Expr], layer: &Option<Box<Expr>>) -> Vec<Expr> {
    coordinates.iter().cloned().chain(layer.iter().map(|l| (**l).clone())).collect()
}

/// `text` as comment lines with `prefix`; an empty line prints as the bare prefix.
pub fn comment_block(prefix: &str, text: &str) -> String {
    text.lines().map(|l| if l.is_empty() { format!("{prefix}\n") } else { format!("{prefix} {l}\n") }).collect()
}

pub mod eval;
pub use eval::{ShaderCost, cost, costs_with_buffer};
pub mod lower;
mod notation;

// The tests of every crate that emits shaders validate them, and so does `tmlut fit` its forms'
// (tmlut's through the `validate` feature).
#[cfg(any(test, feature = "validate"))]
pub mod validate;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn minimal_parentheses_follow_precedence() {
        let mut m = Module::new(Parens::Minimal);
        let (a, b, c) = (name("a"), name("b"), name("c"));
        let e = a.clone() * (b.clone() + c.clone()) - (a.clone() - b.clone() * c.clone());
        m.function("g", vec![("a", Ty::F32), ("b", Ty::F32), ("c", Ty::F32)], Ty::F32, vec![Stmt::Return(e)]);
        let wgsl = m.print(Lang::Wgsl);
        assert!(wgsl.contains("return a * (b + c) - (a - b * c);"), "{wgsl}");
        let hlsl = m.print(Lang::Hlsl);
        assert!(hlsl.starts_with("float g(float a, float b, float c) {\n"), "{hlsl}");
        let glsl = m.print(Lang::Glsl);
        assert!(glsl.starts_with("float g(float a, float b, float c) {\n"), "{glsl}");
        assert!(glsl.contains("return a * (b + c) - (a - b * c);"), "{glsl}");
    }

    #[test]
    fn selects_and_splats_print_in_each_language() {
        let e = select(name("x").gt(float(0.0)).and(name("y").lt(float(1.0))), splat3(float(1.0)), splat3(float(-2.0)));
        let p = |lang| Printer { lang, parens: Parens::Minimal, structs: Default::default(), notation: false }.expr(&e);
        assert_eq!(p(Lang::Wgsl), "select(vec3<f32>(-2.0), vec3<f32>(1.0), (x > 0.0) && (y < 1.0))");
        assert_eq!(p(Lang::Hlsl), "(x > 0.0) && (y < 1.0) ? float3(1.0, 1.0, 1.0) : float3(-2.0, -2.0, -2.0)");
        assert_eq!(p(Lang::Glsl), "(x > 0.0) && (y < 1.0) ? vec3(1.0) : vec3(-2.0)");
    }

    /// A GLSL module inside the compute shader that includes it, as a renderer's would.
    fn glsl_shader(module: &str, main_body: &str) -> String {
        format!(
            "#version 450\n#extension GL_EXT_samplerless_texture_functions : require\n{module}\n\
             layout(local_size_x = 1) in;\nvoid main() {{\n{main_body}\n}}\n"
        )
    }

    #[test]
    fn glsl_spells_what_wgsl_spells_differently() {
        let mut m = Module::new(Parens::Minimal);
        let x = name("x");
        let body = vec![
            let_("a", Ty::F32, call(Intrinsic::Saturate, vec![x.clone()])),
            let_("b", Ty::F32, call(Intrinsic::InverseSqrt, vec![x.clone() + float(1.0)])),
            let_("c", Ty::F32, call(Intrinsic::Atan2, vec![x.clone(), float(2.0)])),
            let_("d", Ty::F32, call(Intrinsic::Mix, vec![name("a"), name("b"), name("c")])),
            Stmt::Return(call(Intrinsic::Fract, vec![name("d")])),
        ];
        m.function("f", vec![("x", Ty::F32)], Ty::F32, body);
        let glsl = m.print(Lang::Glsl);
        for line in [
            "    float a = clamp(x, 0.0, 1.0);",
            "    float b = inversesqrt(x + 1.0);",
            "    float c = atan(x, 2.0);",
            "    float d = mix(a, b, c);",
            "    return fract(d);",
        ] {
            assert!(glsl.contains(line), "{line} in {glsl}");
        }
        let shader = glsl_shader(&glsl, "    float r = f(0.5);");
        super::validate::glsl(&shader, naga::ShaderStage::Compute).unwrap_or_else(|e| panic!("{e}\n{shader}"));
        // GLSL 4.00 has HLSL's `precise` (glslang takes it; naga's GLSL front end does not know it).
        let precise = Stmt::Let { name: "p".into(), ty: Ty::F32, value: name("x"), typed: true, precise: true };
        let mut s = String::new();
        Printer { lang: Lang::Glsl, parens: Parens::Minimal, structs: Default::default(), notation: false }
            .stmt(&precise, 0, &mut s);
        assert_eq!(s, "precise float p = x;\n");
    }

    #[test]
    fn structs_bindings_and_vars_print_in_each_language() {
        let mut m = Module::new(Parens::Minimal);
        m.push(Item::Struct {
            name: "S".into(),
            fields: vec![("a".into(), Ty::Vec(3)), ("b".into(), Ty::Array(Box::new(Ty::F32), 2))],
        });
        m.push(Item::Binding { group: 0, binding: 3, name: "t".into(), ty: Ty::Texture { dims: 2, scalar: false } });
        m.function(
            "h",
            vec![],
            Ty::Named("S".into()),
            vec![
                Stmt::Var { name: "s".into(), ty: Ty::Named("S".into()), value: None },
                assign(name("s").member("b").index(1), float(2.0)),
                Stmt::Return(name("s")),
            ],
        );
        let wgsl = m.print(Lang::Wgsl);
        assert!(wgsl.contains("struct S {\n    a: vec3<f32>,\n    b: array<f32, 2>,\n}\n"), "{wgsl}");
        assert!(wgsl.contains("@group(0) @binding(3) var t: texture_2d<f32>;"), "{wgsl}");
        assert!(wgsl.contains("    var s: S;\n    s.b[1] = 2.0;\n"), "{wgsl}");
        let hlsl = m.print(Lang::Hlsl);
        assert!(hlsl.contains("struct S {\n    float3 a;\n    float b[2];\n};\n"), "{hlsl}");
        assert!(hlsl.contains("Texture2D<float4> t : register(t3);"), "{hlsl}");
        assert!(hlsl.contains("    S s = (S)0;\n"), "{hlsl}");
        super::validate::wgsl(&wgsl).unwrap();
        let glsl = m.print(Lang::Glsl);
        assert!(glsl.contains("struct S {\n    vec3 a;\n    float b[2];\n};\n"), "{glsl}");
        assert!(glsl.contains("layout(set = 0, binding = 3) uniform texture2D t;"), "{glsl}");
        // GLSL leaves an uninitialised local undefined: the zero WGSL and HLSL give is spelt out.
        assert!(glsl.contains("    S s = S(vec3(0.0), float[2](0.0, 0.0));\n    s.b[1] = 2.0;\n"), "{glsl}");
        // naga's GLSL front end refuses a struct constructed with an array member (it types the
        // member apart from the array constructed), which glslang takes: validated without one.
        let mut plain = Module::new(Parens::Minimal);
        plain.push(Item::Struct { name: "P".into(), fields: vec![("a".into(), Ty::Vec(3)), ("n".into(), Ty::I32)] });
        let zeroed = Stmt::Var { name: "p".into(), ty: Ty::Named("P".into()), value: None };
        plain.function("z", vec![], Ty::Named("P".into()), vec![zeroed, Stmt::Return(name("p"))]);
        let glsl = plain.print(Lang::Glsl);
        assert!(glsl.contains("    P p = P(vec3(0.0), 0);\n"), "{glsl}");
        let shader = glsl_shader(&glsl, "    P p = z();");
        super::validate::glsl(&shader, naga::ShaderStage::Compute).unwrap_or_else(|e| panic!("{e}\n{shader}"));
    }

    #[test]
    fn texture_reads_print_in_glsl_with_textures_and_samplers_apart() {
        let mut m = Module::new(Parens::Minimal);
        m.push(Item::Binding { group: 0, binding: 0, name: "t".into(), ty: Ty::Texture { dims: 2, scalar: false } });
        m.push(Item::Binding { group: 0, binding: 1, name: "a".into(), ty: Ty::TextureArray });
        m.push(Item::Binding { group: 0, binding: 2, name: "s".into(), ty: Ty::Sampler });
        let load = Expr::Load {
            texture: "t".into(),
            scalar_texture: false,
            coordinates: vec![Expr::I32(1), Expr::I32(2)],
            layer: None,
            swizzle: "x",
        };
        let sample = Expr::SampleLevel {
            texture: "a".into(),
            scalar_texture: false,
            sampler: "s".into(),
            coordinates: vec![name("u"), float(0.5)],
            layer: Some(Box::new(Expr::I32(3))),
            swizzle: "xy",
        };
        m.function(
            "r",
            vec![("u", Ty::F32)],
            Ty::Vec(2),
            vec![Stmt::Return(sample + Expr::Construct(Ty::Vec(2), vec![load]))],
        );
        let glsl = m.print(Lang::Glsl);
        assert!(glsl.contains("textureLod(sampler2DArray(a, s), vec3(u, 0.5, float(3)), 0.0).xy"), "{glsl}");
        assert!(glsl.contains("texelFetch(t, ivec2(1, 2), 0).x"), "{glsl}");
        assert!(glsl.contains("layout(set = 0, binding = 2) uniform sampler s;"), "{glsl}");
        let shader = glsl_shader(&glsl, "    vec2 v = r(0.25);");
        super::validate::glsl(&shader, naga::ShaderStage::Compute).unwrap_or_else(|e| panic!("{e}\n{shader}"));
        super::validate::wgsl(&m.print(Lang::Wgsl)).unwrap();
    }

    #[test]
    fn constants_past_f32_print_as_values_a_shader_holds() {
        // Folded from f64 (a medium's depth of 3.4e38, a tau limit of 45 / 1e-40), these printed
        // `inf` (no such literal in WGSL or HLSL) or a subnormal a GPU flushes behind the CPU's back.
        let mut m = Module::new(Parens::Minimal);
        let values = [1e39f64 as f32, -1e39f64 as f32, 1e-40f64 as f32, -1e-45f64 as f32, 3.4e38f32];
        let body = values.iter().enumerate().map(|(k, &v)| let_(&format!("v{k}"), Ty::F32, float(v))).collect();
        m.function("h", vec![], Ty::F32, [body, vec![Stmt::Return(float(0.0))]].concat());
        let wgsl = m.print(Lang::Wgsl);
        for text in ["inf", "e-40", "e-45"] {
            assert!(!wgsl.contains(text), "{text} in {wgsl}");
        }
        assert!(wgsl.contains("3.4028235e38") && wgsl.contains("-3.4028235e38") && wgsl.contains("-0.0"), "{wgsl}");
        super::validate::wgsl(&wgsl).unwrap_or_else(|e| panic!("{e}\n{wgsl}"));
    }
}
