//! Every fitted form's manifest `definition`, run by a small interpreter written here, against the
//! form's own WGSL and HLSL shader text run by the same interpreter and against the Rust form:
//! a reader who implements the form from the manifest alone gets what the shader computes.
//!
//! The interpreter knows just enough: statements `name = e` and helper functions
//! `name(a, b) = e` (the definition), `fn`/`float` functions with `let`/`float` locals and
//! `return` (the shaders); `+ - * / ^`, comparisons, `c ? a : b`, `select`, pairs
//! (`vec2<f32>(a, b)`, `float2(a, b)`, `.x`, `.y`) and the builtins the texts call. It evaluates in
//! f64, so that the three agree to rounding whatever their statement order.

use std::collections::HashMap;

use super::*;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Value {
    Scalar(f64),
    Pair(f64, f64),
}

impl Value {
    fn scalar(self) -> f64 {
        match self {
            Value::Scalar(v) => v,
            Value::Pair(..) => panic!("a pair where a number is expected"),
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
enum Token {
    Number(f64),
    Name(String),
    Symbol(&'static str),
}

fn tokens(text: &str) -> Vec<Token> {
    let text: String = text.lines().map(|l| l.split("//").next().unwrap_or_default()).collect::<Vec<_>>().join("\n");
    let chars: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c.is_whitespace() {
            i += 1;
        } else if c.is_ascii_digit() || (c == '.' && chars.get(i + 1).is_some_and(|d| d.is_ascii_digit())) {
            let start = i;
            while i < chars.len()
                && (chars[i].is_ascii_alphanumeric()
                    || chars[i] == '.'
                    || ((chars[i] == '-' || chars[i] == '+') && matches!(chars[i - 1], 'e' | 'E')))
            {
                i += 1;
            }
            let literal: String = chars[start..i].iter().collect();
            out.push(Token::Number(
                literal.trim_end_matches('f').parse().unwrap_or_else(|_| panic!("number {literal}")),
            ));
        } else if c.is_alphabetic() || c == '_' {
            let start = i;
            while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            out.push(Token::Name(chars[start..i].iter().collect()));
        } else {
            let two: String = chars[i..(i + 2).min(chars.len())].iter().collect();
            let symbol = ["->", ">=", "<=", "=="]
                .into_iter()
                .find(|s| *s == two)
                .or_else(|| {
                    ["+", "-", "*", "/", "^", "(", ")", ",", "?", ":", ">", "<", ".", ";", "{", "}", "="]
                        .into_iter()
                        .find(|s| s.starts_with(c))
                })
                .unwrap_or_else(|| panic!("unexpected `{c}`"));
            i += symbol.len();
            out.push(Token::Symbol(symbol));
        }
    }
    out
}

#[derive(Debug, Clone)]
enum Expr {
    Number(f64),
    Variable(String),
    Call(String, Vec<Expr>),
    Member(Box<Expr>, char),
    Binary(&'static str, Box<Expr>, Box<Expr>),
    Negate(Box<Expr>),
    Select(Box<Expr>, Box<Expr>, Box<Expr>),
}

struct Parser {
    tokens: Vec<Token>,
    at: usize,
}

impl Parser {
    fn peek(&self) -> Option<&Token> {
        self.tokens.get(self.at)
    }
    fn is(&self, symbol: &str) -> bool {
        matches!(self.peek(), Some(Token::Symbol(s)) if *s == symbol)
    }
    fn eat(&mut self, symbol: &str) -> bool {
        let found = self.is(symbol);
        if found {
            self.at += 1;
        }
        found
    }
    fn expect(&mut self, symbol: &str) {
        assert!(self.eat(symbol), "expected `{symbol}` at {:?}", self.peek());
    }
    fn name(&mut self) -> String {
        match self.tokens.get(self.at).cloned() {
            Some(Token::Name(n)) => {
                self.at += 1;
                n
            }
            other => panic!("expected a name, found {other:?}"),
        }
    }
    /// `vec2<f32>` and `f32` type annotations: skipped.
    fn skip_type(&mut self) {
        self.name();
        if self.eat("<") {
            self.name();
            self.expect(">");
        }
    }

    fn expression(&mut self) -> Expr {
        let condition = self.comparison();
        if self.eat("?") {
            let then = self.expression();
            self.expect(":");
            let otherwise = self.expression();
            return Expr::Select(Box::new(condition), Box::new(then), Box::new(otherwise));
        }
        condition
    }
    fn comparison(&mut self) -> Expr {
        let left = self.sum();
        for op in [">=", "<=", ">", "<"] {
            if self.eat(op) {
                return Expr::Binary(op, Box::new(left), Box::new(self.sum()));
            }
        }
        left
    }
    fn sum(&mut self) -> Expr {
        let mut left = self.product();
        loop {
            let op = if self.eat("+") {
                "+"
            } else if self.eat("-") {
                "-"
            } else {
                return left;
            };
            left = Expr::Binary(op, Box::new(left), Box::new(self.product()));
        }
    }
    fn product(&mut self) -> Expr {
        let mut left = self.unary();
        loop {
            let op = if self.eat("*") {
                "*"
            } else if self.eat("/") {
                "/"
            } else {
                return left;
            };
            left = Expr::Binary(op, Box::new(left), Box::new(self.unary()));
        }
    }
    fn unary(&mut self) -> Expr {
        if self.eat("-") { Expr::Negate(Box::new(self.unary())) } else { self.power() }
    }
    fn power(&mut self) -> Expr {
        let base = self.postfix();
        if self.eat("^") { Expr::Binary("^", Box::new(base), Box::new(self.unary())) } else { base }
    }
    fn postfix(&mut self) -> Expr {
        let mut e = self.primary();
        while self.eat(".") {
            let member = self.name();
            e = Expr::Member(Box::new(e), member.chars().next().unwrap());
        }
        e
    }
    fn primary(&mut self) -> Expr {
        match self.tokens.get(self.at).cloned() {
            Some(Token::Number(v)) => {
                self.at += 1;
                Expr::Number(v)
            }
            Some(Token::Symbol("(")) => {
                self.at += 1;
                let e = self.expression();
                self.expect(")");
                e
            }
            Some(Token::Name(_)) => {
                let mut name = self.name();
                // `vec2<f32>(a, b)`: a pair constructor.
                if name == "vec2" && self.eat("<") {
                    self.name();
                    self.expect(">");
                    name = "pair".into();
                }
                if name == "float2" {
                    name = "pair".into();
                }
                if self.eat("(") {
                    let mut arguments = Vec::new();
                    while !self.eat(")") {
                        arguments.push(self.expression());
                        self.eat(",");
                    }
                    Expr::Call(name, arguments)
                } else {
                    Expr::Variable(name)
                }
            }
            other => panic!("unexpected {other:?}"),
        }
    }
}

/// A helper function: parameter names and either one expression (a definition) or a body of
/// local bindings and a returned expression (a shader).
#[derive(Debug, Clone)]
struct Function {
    parameters: Vec<String>,
    body: Vec<(String, Expr)>,
    result: Expr,
}

/// The statements of a definition, in order, and its helper functions.
fn parse_definition(lines: &[String]) -> (Vec<(String, Expr)>, HashMap<String, Function>) {
    let (mut statements, mut functions) = (Vec::new(), HashMap::new());
    for line in lines {
        let mut p = Parser { tokens: tokens(line), at: 0 };
        let name = p.name();
        if p.eat("(") {
            let mut parameters = Vec::new();
            while !p.eat(")") {
                parameters.push(p.name());
                p.eat(",");
            }
            p.expect("=");
            functions.insert(name, Function { parameters, body: Vec::new(), result: p.expression() });
        } else {
            p.expect("=");
            statements.push((name, p.expression()));
        }
        assert!(p.peek().is_none(), "trailing text in `{line}`");
    }
    (statements, functions)
}

/// The functions of a shader (WGSL `fn name(a: T) -> T { let x: T = e; return e; }` or HLSL
/// `T name(T a) { precise? T x = e; return e; }`).
fn parse_shader(text: &str) -> HashMap<String, Function> {
    let mut p = Parser { tokens: tokens(text), at: 0 };
    let mut functions = HashMap::new();
    while p.peek().is_some() {
        let first = p.name();
        let wgsl = first == "fn";
        let name = p.name();
        p.expect("(");
        let mut parameters = Vec::new();
        while !p.eat(")") {
            if wgsl {
                parameters.push(p.name());
                p.expect(":");
                p.skip_type();
            } else {
                p.skip_type();
                parameters.push(p.name());
            }
            p.eat(",");
        }
        if p.eat("->") {
            p.skip_type();
        }
        p.expect("{");
        let mut body = Vec::new();
        let result = loop {
            let word = p.name();
            if word == "return" {
                let e = p.expression();
                p.expect(";");
                p.expect("}");
                break e;
            }
            // `let x: T = e;` (WGSL) or `[precise] T x = e;` (HLSL).
            let local = if word == "let" {
                let local = p.name();
                if p.eat(":") {
                    p.skip_type();
                }
                local
            } else {
                if word == "precise" {
                    p.name();
                }
                p.name()
            };
            p.expect("=");
            body.push((local, p.expression()));
            p.expect(";");
        };
        functions.insert(name, Function { parameters, body, result });
    }
    functions
}

fn evaluate(e: &Expr, scope: &HashMap<String, Value>, functions: &HashMap<String, Function>) -> Value {
    let value = |e: &Expr| evaluate(e, scope, functions);
    let number = |e: &Expr| value(e).scalar();
    match e {
        Expr::Number(v) => Value::Scalar(*v),
        Expr::Variable(n) => *scope.get(n).unwrap_or_else(|| panic!("`{n}` is not defined")),
        Expr::Member(e, m) => match (value(e), m) {
            (Value::Pair(x, _), 'x') => Value::Scalar(x),
            (Value::Pair(_, y), 'y') => Value::Scalar(y),
            other => panic!("member {other:?}"),
        },
        Expr::Negate(e) => Value::Scalar(-number(e)),
        Expr::Select(c, a, b) => {
            if number(c) != 0.0 {
                value(a)
            } else {
                value(b)
            }
        }
        Expr::Binary(op, a, b) => {
            let (a, b) = (number(a), number(b));
            Value::Scalar(match *op {
                "+" => a + b,
                "-" => a - b,
                "*" => a * b,
                "/" => a / b,
                "^" => a.powf(b),
                ">" => (a > b) as u8 as f64,
                "<" => (a < b) as u8 as f64,
                ">=" => (a >= b) as u8 as f64,
                "<=" => (a <= b) as u8 as f64,
                _ => unreachable!(),
            })
        }
        Expr::Call(name, arguments) => {
            let a: Vec<Value> = arguments.iter().map(value).collect();
            let x = |k: usize| a[k].scalar();
            Value::Scalar(match name.as_str() {
                "pair" => return Value::Pair(x(0), x(1)),
                "sqrt" => x(0).sqrt(),
                "abs" => x(0).abs(),
                "exp" => x(0).exp(),
                "ln" | "log" => x(0).ln(),
                "min" => x(0).min(x(1)),
                "max" => x(0).max(x(1)),
                "pow" => x(0).powf(x(1)),
                "clamp" => x(0).max(x(1)).min(x(2)),
                // WGSL's select(if_false, if_true, condition).
                "select" => return if x(2) != 0.0 { a[1] } else { a[0] },
                "smoothstep" => {
                    let t = ((x(2) - x(0)) / (x(1) - x(0))).clamp(0.0, 1.0);
                    t * t * (3.0 - 2.0 * t)
                }
                _ => {
                    let f = functions.get(name).unwrap_or_else(|| panic!("no function `{name}`"));
                    return call(f, &a, scope, functions);
                }
            })
        }
    }
}

/// A helper function sees its arguments, and (a definition's helpers) the statements before it.
fn call(
    f: &Function,
    arguments: &[Value],
    outer: &HashMap<String, Value>,
    functions: &HashMap<String, Function>,
) -> Value {
    let mut scope = outer.clone();
    for (name, &value) in f.parameters.iter().zip(arguments) {
        scope.insert(name.clone(), value);
    }
    for (name, e) in &f.body {
        let v = evaluate(e, &scope, functions);
        scope.insert(name.clone(), v);
    }
    evaluate(&f.result, &scope, functions)
}

pub(crate) fn run_definition(lines: &[String], parameters: &[f64], [mu, alpha, eta]: [f64; 3]) -> f64 {
    let (statements, functions) = parse_definition(lines);
    let mut scope: HashMap<String, Value> = [("mu", mu), ("alpha", alpha), ("eta", eta)]
        .into_iter()
        .map(|(n, v)| (n.to_string(), Value::Scalar(v)))
        .collect();
    for (k, &c) in parameters.iter().enumerate() {
        scope.insert(format!("c{k}"), Value::Scalar(c));
    }
    for (name, e) in &statements {
        let v = evaluate(e, &scope, &functions);
        scope.insert(name.clone(), v);
    }
    assert_eq!(statements.last().map(|s| s.0.as_str()), Some("TIR"), "the result comes last");
    scope["TIR"].scalar()
}

pub(crate) fn run_shader(text: &str, [mu, alpha, eta]: [f64; 3]) -> f64 {
    let functions = parse_shader(text);
    let arguments = [mu, alpha, eta].map(Value::Scalar);
    call(&functions["tmlut_tir"], &arguments, &HashMap::new(), &functions).scalar()
}

#[test]
fn every_fitted_forms_definition_computes_what_its_shaders_compute() {
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let mut uniform = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut checked = 0;
    for form in ALL_FORMS.into_iter().filter(|f| !f.parameters().is_empty()) {
        let definition = form.definition();
        assert!(!definition.is_empty(), "{}", form.name());
        let (start, lower, upper) = form.start_and_bounds();
        for trial in 0..4 {
            // The form's start, then random points of its bounds; each as the shader prints it (the
            // shortest text of its f32), so that all three take the same constants.
            let parameters: Vec<f64> = (0..start.len())
                .map(|k| if trial == 0 { start[k] } else { lower[k] + uniform() * (upper[k] - lower[k]) })
                .map(|v| format!("{:?}", v as f32).parse().unwrap())
                .collect();
            let wgsl = shader(form, &parameters, ShaderLanguage::Wgsl).unwrap();
            let hlsl = shader(form, &parameters, ShaderLanguage::Hlsl).unwrap();
            crate::shader::validate::wgsl(&wgsl).unwrap_or_else(|e| panic!("{}: {e}", form.name()));
            let edges = [0.0, 1e-4, 0.5, 1.0];
            let points: Vec<[f64; 3]> = (0..300)
                .map(|n| {
                    if n < 64 {
                        [edges[n % 4], edges[n / 4 % 4], edges[n / 16 % 4]]
                    } else {
                        [uniform(), uniform() * uniform(), uniform()]
                    }
                })
                .collect();
            for point in points {
                let [mu, alpha, eta] = point;
                let from_definition = run_definition(&definition, &parameters, point);
                let from_wgsl = run_shader(&wgsl, point);
                let from_hlsl = run_shader(&hlsl, point);
                let from_rust = form.eval(&parameters, mu, alpha, eta);
                let at = format!("{} {parameters:?} at {point:?}", form.name());
                assert!(from_definition.is_finite(), "{at}: {from_definition}");
                // The same constants, the same statements in another order: agreement to f64
                // rounding, far below what any missing term, floor or clamp would change.
                let tolerance = 1e-9;
                assert!(
                    (from_definition - from_wgsl).abs() <= tolerance,
                    "{at}: definition {from_definition}, WGSL {from_wgsl}"
                );
                assert!(
                    (from_definition - from_hlsl).abs() <= tolerance,
                    "{at}: definition {from_definition}, HLSL {from_hlsl}"
                );
                assert!(
                    (from_definition - from_rust).abs() <= 1e-9,
                    "{at}: definition {from_definition}, Rust {from_rust}"
                );
                checked += 1;
            }
        }
    }
    // Every point of every trial of every fitted form was compared (none skipped).
    let fitted = ALL_FORMS.into_iter().filter(|f| !f.parameters().is_empty()).count();
    assert!(fitted >= 6, "{fitted} fitted forms");
    assert_eq!(checked, fitted * 4 * 300);
}

#[test]
fn the_interpreter_reads_what_it_is_given() {
    // So that agreement above is not the interpreter ignoring what it reads.
    let lines = vec![
        "f(a) = a > 1 ? 2 * a : -a^2".to_string(),
        "x = f(mu) + clamp(eta, 0, 0.25)".into(),
        "TIR = x / c0".into(),
    ];
    assert_eq!(run_definition(&lines, &[2.0], [3.0, 0.0, 0.5]), (6.0 + 0.25) / 2.0);
    assert_eq!(run_definition(&lines, &[1.0], [0.5, 0.0, -1.0]), -0.25);
    let wgsl = "fn h(u: f32) -> vec2<f32> { return vec2<f32>(u, 2.0 * u); }\n\
                fn tmlut_tir(mu: f32, alpha: f32, eta: f32) -> f32 { let p: vec2<f32> = h(mu); return select(p.x, p.y, eta > 0.0) + alpha; }";
    assert_eq!(run_shader(wgsl, [1.5, 0.25, 1.0]), 3.25);
    assert_eq!(run_shader(wgsl, [1.5, 0.25, -1.0]), 1.75);
}
