//! The expression language of form files: numbers, names, `+ - * / ^`, unary minus, and calls of
//! the functions WGSL and HLSL both have ([`Intrinsic`]); comparisons only as the condition of
//! `select(a, b, condition)`, which is `b` where the condition holds (WGSL's argument order), so
//! that every expression is a number and every condition a comparison, as in a shader.
//!
//! Precedence, loosest first: comparison (one per condition), `+ -`, `* /`, unary minus, `^`
//! (right-associative, so `-x^2` is `-(x^2)` and `2^-1` is one half). A hand-written recursive
//! descent: the grammar has five levels, and a parser of our own reports every error at the byte
//! it is about, which the form file turns into a line and a column.

use std::fmt;

/// A place in the expression's text: a byte range.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Span {
    pub start: usize,
    pub end: usize,
}

/// What is wrong, and the byte of the expression it is about.
#[derive(Debug, Clone, PartialEq)]
pub struct ExprError {
    pub at: usize,
    pub message: String,
}

fn error<T>(at: usize, message: impl Into<String>) -> Result<T, ExprError> {
    Err(ExprError { at, message: message.into() })
}

/// The functions of the language: the intrinsics both shading languages have, with the meaning
/// WGSL gives them ([`Intrinsic`]).
pub use crate::real::Intrinsic;

/// The one function that takes a condition: `select(a, b, condition)`.
pub const SELECT: &str = "select";

/// A function's name in a form: WGSL's, but `rsqrt` for `inverseSqrt` (HLSL's name, and the
/// shorter).
pub fn form_name(function: Intrinsic) -> &'static str {
    match function {
        Intrinsic::InverseSqrt => "rsqrt",
        other => other.wgsl_name(),
    }
}

/// Every function name the language knows, `select` included, for error messages.
pub fn function_names() -> String {
    let mut names: Vec<&str> = Intrinsic::ALL.iter().map(|&(f, ..)| form_name(f)).collect();
    names.push(SELECT);
    names.join(", ")
}

/// A comparison, the condition of a `select` (the model's branches use the same one).
pub use crate::real::Compare;

/// An arithmetic operator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BinOp {
    Add,
    Sub,
    Mul,
    Div,
    Pow,
}

/// A parsed expression; names are resolved later, against the form's parameters, its earlier
/// `let` bindings and the table's variables.
#[derive(Debug, Clone, PartialEq)]
pub enum Node {
    Number(f64),
    Name(String, Span),
    Neg(Box<Node>),
    Binary(BinOp, Box<Node>, Box<Node>),
    Call(Intrinsic, Vec<Node>),
    /// `select(otherwise, then, left compare right)`.
    Select {
        otherwise: Box<Node>,
        then: Box<Node>,
        compare: Compare,
        left: Box<Node>,
        right: Box<Node>,
    },
}

impl Node {
    /// Every name the expression reads, with where it is.
    pub fn names(&self, out: &mut Vec<(String, Span)>) {
        match self {
            Node::Number(_) => {}
            Node::Name(n, span) => out.push((n.clone(), *span)),
            Node::Neg(a) => a.names(out),
            Node::Binary(_, a, b) => {
                a.names(out);
                b.names(out);
            }
            Node::Call(_, args) => args.iter().for_each(|a| a.names(out)),
            Node::Select { otherwise, then, left, right, .. } => {
                for n in [otherwise, then, left, right] {
                    n.names(out);
                }
            }
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
enum Token {
    Number(f64),
    Name(String),
    Symbol(&'static str),
    End,
}

impl fmt::Display for Token {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Token::Number(v) => write!(f, "number {v}"),
            Token::Name(n) => write!(f, "`{n}`"),
            Token::Symbol(s) => write!(f, "`{s}`"),
            Token::End => write!(f, "the end of the expression"),
        }
    }
}

const SYMBOLS: &[&str] = &["<=", ">=", "==", "!=", "<", ">", "+", "-", "*", "/", "^", "(", ")", ","];

fn tokens(text: &str) -> Result<Vec<(Token, Span)>, ExprError> {
    let bytes = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let c = bytes[i];
        if c.is_ascii_whitespace() {
            i += 1;
            continue;
        }
        let start = i;
        if c.is_ascii_digit() || (c == b'.' && bytes.get(i + 1).is_some_and(u8::is_ascii_digit)) {
            while i < bytes.len() && (bytes[i].is_ascii_digit() || bytes[i] == b'.') {
                i += 1;
            }
            if i < bytes.len() && (bytes[i] == b'e' || bytes[i] == b'E') {
                let mut j = i + 1;
                if j < bytes.len() && (bytes[j] == b'+' || bytes[j] == b'-') {
                    j += 1;
                }
                if j < bytes.len() && bytes[j].is_ascii_digit() {
                    i = j;
                    while i < bytes.len() && bytes[i].is_ascii_digit() {
                        i += 1;
                    }
                }
            }
            let literal = &text[start..i];
            let value: f64 = match literal.parse() {
                Ok(v) => v,
                Err(_) => return error(start, format!("`{literal}` is not a number")),
            };
            if !value.is_finite() {
                return error(start, format!("`{literal}` is out of range"));
            }
            out.push((Token::Number(value), Span { start, end: i }));
        } else if c.is_ascii_alphabetic() || c == b'_' {
            while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
                i += 1;
            }
            out.push((Token::Name(text[start..i].to_string()), Span { start, end: i }));
        } else if let Some(symbol) = SYMBOLS.iter().find(|s| text[i..].starts_with(**s)) {
            i += symbol.len();
            out.push((Token::Symbol(symbol), Span { start, end: i }));
        } else {
            let ch = text[i..].chars().next().unwrap_or('?');
            return error(
                start,
                format!(
                    "unexpected character `{ch}`; allowed: numbers, names, + - * / ^, ( ) , and < <= > >= == != in a select's condition"
                ),
            );
        }
    }
    out.push((Token::End, Span { start: text.len(), end: text.len() }));
    Ok(out)
}

struct Parser {
    tokens: Vec<(Token, Span)>,
    next: usize,
    /// Nesting so far (parentheses, calls, unary minus): bounded, so that a pathological
    /// expression is refused instead of overflowing the stack of this recursive parser and of
    /// everything that walks its tree.
    depth: usize,
}

/// The deepest nesting an expression may have.
pub const MAX_DEPTH: usize = 200;

/// The most tokens one expression may have: a long chain like `x + x + ...` nests its tree as
/// deep as it is long, and the compiler and printers walk trees recursively.
pub const MAX_TOKENS: usize = 4096;

impl Parser {
    fn peek(&self) -> &(Token, Span) {
        &self.tokens[self.next]
    }

    fn take(&mut self) -> (Token, Span) {
        let t = self.tokens[self.next].clone();
        if self.next + 1 < self.tokens.len() {
            self.next += 1;
        }
        t
    }

    fn is(&self, symbol: &str) -> bool {
        matches!(&self.peek().0, Token::Symbol(s) if *s == symbol)
    }

    fn expect(&mut self, symbol: &str, context: &str) -> Result<Span, ExprError> {
        let (token, span) = self.take();
        if token == Token::Symbol(SYMBOLS.iter().find(|s| **s == symbol).copied().unwrap_or("?")) {
            Ok(span)
        } else {
            error(span.start, format!("expected `{symbol}` {context}, found {token}"))
        }
    }

    /// A number-valued expression; a comparison after it is refused here.
    fn expression(&mut self) -> Result<Node, ExprError> {
        let node = self.additive()?;
        if let (Token::Symbol(s), span) = self.peek()
            && comparison(s).is_some()
        {
            return error(
                span.start,
                format!("`{s}` compares, and a comparison is only allowed as the condition of select(a, b, condition)"),
            );
        }
        Ok(node)
    }

    /// One level of left-associative operators over the next level: `next (op next)*`.
    fn left_associative(
        &mut self,
        operators: &[(&str, BinOp)],
        next: fn(&mut Self) -> Result<Node, ExprError>,
    ) -> Result<Node, ExprError> {
        let mut node = next(self)?;
        while let Some(&(_, op)) = operators.iter().find(|(symbol, _)| self.is(symbol)) {
            self.take();
            node = Node::Binary(op, Box::new(node), Box::new(next(self)?));
        }
        Ok(node)
    }

    fn additive(&mut self) -> Result<Node, ExprError> {
        self.left_associative(&[("+", BinOp::Add), ("-", BinOp::Sub)], Self::multiplicative)
    }

    fn multiplicative(&mut self) -> Result<Node, ExprError> {
        self.left_associative(&[("*", BinOp::Mul), ("/", BinOp::Div)], Self::unary)
    }

    fn unary(&mut self) -> Result<Node, ExprError> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return error(self.peek().1.start, format!("the expression nests deeper than {MAX_DEPTH} levels"));
        }
        let node = self.unary_inner();
        self.depth -= 1;
        node
    }

    fn unary_inner(&mut self) -> Result<Node, ExprError> {
        if self.is("-") {
            self.take();
            return Ok(match self.unary()? {
                // A negative literal is a number, so that `x ^ -2` keeps an integer exponent.
                Node::Number(v) => Node::Number(-v),
                node => Node::Neg(Box::new(node)),
            });
        }
        self.power()
    }

    fn power(&mut self) -> Result<Node, ExprError> {
        let base = self.primary()?;
        if self.is("^") {
            self.take();
            return Ok(Node::Binary(BinOp::Pow, Box::new(base), Box::new(self.unary()?)));
        }
        Ok(base)
    }

    fn primary(&mut self) -> Result<Node, ExprError> {
        let (token, span) = self.take();
        match token {
            Token::Number(v) => Ok(Node::Number(v)),
            Token::Symbol("(") => {
                let node = self.expression()?;
                self.expect(")", "to close the parenthesis")?;
                Ok(node)
            }
            Token::Name(name) if self.is("(") => self.call(name, span),
            Token::Name(name) => Ok(Node::Name(name, span)),
            other => error(span.start, format!("expected a number, a name or `(`, found {other}")),
        }
    }

    fn call(&mut self, name: String, span: Span) -> Result<Node, ExprError> {
        self.take();
        let is_select = name == SELECT;
        let func = Intrinsic::ALL.iter().map(|&(f, ..)| f).find(|&f| form_name(f) == name);
        if func.is_none() && !is_select {
            return error(span.start, format!("unknown function `{name}`; allowed: {}", function_names()));
        }
        let mut args = Vec::new();
        let mut condition = None;
        if !self.is(")") {
            loop {
                if is_select && args.len() == 2 {
                    condition = Some(self.condition()?);
                } else {
                    args.push(self.expression()?);
                }
                if self.is(",") {
                    self.take();
                } else {
                    break;
                }
            }
        }
        self.expect(")", &format!("or `,` in the arguments of `{name}`"))?;
        let (given, wanted) = (args.len() + usize::from(condition.is_some()), func.map_or(3, Intrinsic::arity));
        if given != wanted {
            let signature =
                if is_select { "select(a, b, condition)".to_string() } else { format!("{name} takes {wanted}") };
            return error(span.start, format!("`{name}` called with {given} arguments; {signature}"));
        }
        match (func, condition) {
            (Some(f), _) => Ok(Node::Call(f, args)),
            (None, Some((compare, left, right))) => {
                let then = args.pop().expect("two arguments");
                let otherwise = args.pop().expect("two arguments");
                Ok(Node::Select {
                    otherwise: Box::new(otherwise),
                    then: Box::new(then),
                    compare,
                    left: Box::new(left),
                    right: Box::new(right),
                })
            }
            (None, None) => error(span.start, "select takes a condition as its third argument"),
        }
    }

    /// `a < b`: one comparison of two numbers.
    fn condition(&mut self) -> Result<(Compare, Node, Node), ExprError> {
        let left = self.additive()?;
        let (token, span) = self.take();
        let compare = match &token {
            Token::Symbol(s) => comparison(s),
            _ => None,
        };
        let Some(compare) = compare else {
            return error(
                span.start,
                format!("expected a comparison (< <= > >= == !=) in select's condition, found {token}"),
            );
        };
        Ok((compare, left, self.expression()?))
    }
}

fn comparison(symbol: &str) -> Option<Compare> {
    Compare::ALL.into_iter().find(|compare| compare.text() == symbol)
}

/// Parse one expression.
pub fn parse(text: &str) -> Result<Node, ExprError> {
    let tokens = tokens(text)?;
    if tokens.len() > MAX_TOKENS {
        return error(
            tokens[MAX_TOKENS].1.start,
            format!("the expression has more than {MAX_TOKENS} tokens; split it with `let` bindings"),
        );
    }
    let mut parser = Parser { tokens, next: 0, depth: 0 };
    if parser.peek().0 == Token::End {
        return error(0, "empty expression");
    }
    let node = parser.expression()?;
    let (token, span) = parser.take();
    if token != Token::End {
        return error(span.start, format!("expected an operator or the end of the expression, found {token}"));
    }
    Ok(node)
}

/// Whether `name` can name a parameter or a binding: an identifier every shading language takes
/// as it is.
pub fn check_identifier(name: &str) -> Result<(), String> {
    let mut chars = name.chars();
    let valid = chars.next().is_some_and(|c| c.is_ascii_alphabetic())
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
        && !name.contains("__");
    if !valid {
        return Err(format!("`{name}` is not a name: a letter, then letters, digits or single underscores"));
    }
    if Intrinsic::ALL.iter().any(|&(f, ..)| form_name(f) == name) || name == SELECT {
        return Err(format!("`{name}` is a function of the language"));
    }
    // GLSL reserves every name that starts with `gl_`.
    if RESERVED.contains(&name) || name.starts_with("tmlut") || name.starts_with("gl_") {
        return Err(format!("`{name}` is reserved in a shading language (or by tmlut's shaders)"));
    }
    Ok(())
}

/// Words WGSL, HLSL, GLSL or MSL reserve that a short parameter name might collide with (the
/// shader printers write names as they are).
const RESERVED: &[&str] = &[
    "as",
    "asm",
    "bool",
    "break",
    "case",
    "cast",
    "char",
    "const",
    "continue",
    "default",
    "discard",
    "do",
    "double",
    "else",
    "enum",
    "false",
    "float",
    "fn",
    "for",
    "half",
    "if",
    "in",
    "inline",
    "inout",
    "int",
    "let",
    "loop",
    "main",
    "matrix",
    "out",
    "precise",
    "return",
    "sample",
    "self",
    "static",
    "struct",
    "switch",
    "true",
    "type",
    "uint",
    "uniform",
    "var",
    "vector",
    "void",
    "while",
    "f16",
    "f32",
    "f64",
    "i32",
    "u32",
    "vec2",
    "vec3",
    "vec4",
    "float2",
    "float3",
    "float4",
    "mat2",
    "mat3",
    "mat4",
    "fma",
    "frac",
    "lerp",
    "length",
    "dot",
    "cross",
    "normalize",
    "mod",
    "fmod",
    "ldexp",
    "round",
    "trunc",
    "ceil",
    "degrees",
    "radians",
    "distance",
    "ddx",
    "ddy",
    "inverseSqrt",
    "texture",
    "sampler",
    "buffer",
    "shared",
    "private",
    "public",
    "signed",
    "unsigned",
    "long",
    "short",
    "auto",
    "new",
    "delete",
    "this",
    "template",
    "typename",
    "using",
    "namespace",
    "kernel",
    "device",
    "constant",
    "thread",
    "threadgroup",
    "attribute",
    "varying",
    "highp",
    "mediump",
    "lowp",
    "precision",
    // GLSL's own, since its text is printed as it is (no longer translated by naga, which renamed).
    "layout",
    "invariant",
    "centroid",
    "flat",
    "smooth",
    "noperspective",
    "patch",
    "subroutine",
    "coherent",
    "volatile",
    "restrict",
    "readonly",
    "writeonly",
    "common",
    "partition",
    "active",
    "filter",
    "sizeof",
    "input",
    "output",
    "superp",
    "external",
    "interface",
    "goto",
    "extern",
    "union",
    "class",
    "inversesqrt",
    "ivec2",
    "ivec3",
    "ivec4",
    "uvec2",
    "uvec3",
    "uvec4",
    "bvec2",
    "bvec3",
    "bvec4",
    "dvec2",
    "dvec3",
    "dvec4",
    "texelFetch",
    "textureLod",
    "texture2D",
    "texture3D",
    "texture2DArray",
    "sampler2D",
    "sampler3D",
    "sampler2DArray",
];

#[cfg(test)]
#[path = "text_tests.rs"]
mod tests;
