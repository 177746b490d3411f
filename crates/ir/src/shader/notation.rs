//! A function of the shader description written in no shading language, a line per statement:
//! how a manifest states what a generated function computes (the FGD packings' lookups), each
//! operation and constant printed as the HLSL and WGSL printers print it.

use super::{Expr, Function, Lang, Parens, Printer, Stmt};

impl Function {
    /// The body as lines: `name = value` for a local or an assignment (a `var` without a value is
    /// its type's zero, `T()`), `result = value` for the return, `if condition {`, `} else {` and
    /// `}` around a branch's lines (indented four spaces), `switch selector {`, `case k:` and
    /// `default:` before each case's lines, `// text` for a comment.
    ///
    /// Expressions are parenthesised as `parens` says and name builtins, types and conversions as
    /// WGSL does (`min(a, b)`, `i32(x)`, `vec3<f32>(a, b, c)`); a selection reads `condition ?
    /// then : otherwise`, a texel load `load(texture, coordinates)`, a filtered sample
    /// `sample(texture, sampler, coordinates)`, a texture array's layer after the coordinates, and
    /// a read of a four-channel texture ends in its channels (`.rgb`).
    pub fn statements(&self, parens: Parens) -> Vec<String> {
        let printer = Printer { lang: Lang::Wgsl, parens, structs: Default::default(), notation: true };
        let mut lines = Vec::new();
        printer.notation_lines(&self.body, "", &mut lines);
        lines
    }
}

impl Printer {
    fn notation_lines(&self, body: &[Stmt], pad: &str, lines: &mut Vec<String>) {
        for statement in body {
            match statement {
                Stmt::Let { name, value, .. } | Stmt::Var { name, value: Some(value), .. } => {
                    lines.push(format!("{pad}{name} = {}", self.expr(value)));
                }
                Stmt::Var { name, ty, value: None } => lines.push(format!("{pad}{name} = {}()", ty.text(self.lang))),
                Stmt::Assign(target, value) => lines.push(format!("{pad}{} = {}", self.expr(target), self.expr(value))),
                Stmt::If { condition, then, otherwise } => {
                    let inner = format!("{pad}    ");
                    lines.push(format!("{pad}if {} {{", self.expr(condition)));
                    self.notation_lines(then, &inner, lines);
                    if !otherwise.is_empty() {
                        lines.push(format!("{pad}}} else {{"));
                        self.notation_lines(otherwise, &inner, lines);
                    }
                    lines.push(format!("{pad}}}"));
                }
                Stmt::Switch { selector, cases, default } => {
                    let inner = format!("{pad}    ");
                    lines.push(format!("{pad}switch {} {{", self.expr(selector)));
                    for (label, body) in cases.iter().map(|(k, body)| (format!("case {k}"), body)) {
                        lines.push(format!("{pad}{label}:"));
                        self.notation_lines(body, &inner, lines);
                    }
                    lines.push(format!("{pad}default:"));
                    self.notation_lines(default, &inner, lines);
                    lines.push(format!("{pad}}}"));
                }
                Stmt::Return(value) => lines.push(format!("{pad}result = {}", self.expr(value))),
                Stmt::Comment(text) => {
                    lines.extend(text.lines().map(|l| format!("{pad}// {l}").trim_end().to_string()))
                }
            }
        }
    }

    /// A texture read as the notation writes it.
    pub(super) fn write_read_in_notation(&self, e: &Expr, out: &mut String) {
        let (opening, coordinates, layer, scalar_texture, swizzle) = match e {
            Expr::Load { texture, scalar_texture, coordinates, layer, swizzle } => {
                (format!("load({texture}"), coordinates, layer, scalar_texture, swizzle)
            }
            Expr::SampleLevel { texture, scalar_texture, sampler, coordinates, layer, swizzle } => {
                (format!("sample({texture}, {sampler}"), coordinates, layer, scalar_texture, swizzle)
            }
            _ => unreachable!("write_read_in_notation is called with a texture read"),
        };
        out.push_str(&opening);
        for argument in coordinates.iter().chain(layer.as_deref()) {
            out.push_str(", ");
            self.write(argument, out);
        }
        out.push(')');
        if !scalar_texture {
            out.push('.');
            out.push_str(swizzle);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Item, Module, Ty, float, let_, name, select, var};
    use super::*;

    fn load(coordinates: Vec<Expr>) -> Expr {
        Expr::Load {
            texture: "tex".into(),
            scalar_texture: true,
            coordinates: coordinates.into_iter().map(|c| Expr::Construct(Ty::I32, vec![c])).collect(),
            layer: None,
            swizzle: "r",
        }
    }

    #[test]
    fn each_statement_is_a_line_with_the_printers_operations() {
        let sample = Expr::SampleLevel {
            texture: "slices".into(),
            scalar_texture: false,
            sampler: "linear".into(),
            coordinates: vec![name("u"), name("v")],
            layer: Some(Box::new(Expr::I32(3))),
            swizzle: "rgb",
        };
        let body = vec![
            let_("s", Ty::F32, select(name("y").lt(float(0.0)), -name("y").abs(), name("y").sqrt())),
            let_("t", Ty::F32, load(vec![name("x"), name("y") + float(1.0), float(2.0)])),
            var("c", Ty::Vec(3), sample),
            Stmt::Var { name: "k".into(), ty: Ty::I32, value: None },
            Stmt::Comment("the branch\nand its reason".into()),
            Stmt::If {
                condition: name("t").gt(float(0.5)),
                then: vec![Stmt::Assign(name("k"), Expr::I32(1))],
                otherwise: vec![Stmt::Assign(name("c").member("x"), float(0.0))],
            },
            Stmt::Return(name("s") * (name("t") + name("c").member("y"))),
        ];
        let function = Function { name: "f".into(), params: Vec::new(), returns: Ty::F32, body };
        assert_eq!(
            function.statements(Parens::Full),
            [
                "s = (y < 0.0) ? -abs(y) : sqrt(y)",
                "t = load(tex, i32(x), i32((y + 1.0)), i32(2.0))",
                "c = sample(slices, linear, u, v, 3).rgb",
                "k = i32()",
                "// the branch",
                "// and its reason",
                "if (t > 0.5) {",
                "    k = 1",
                "} else {",
                "    c.x = 0.0",
                "}",
                "result = (s * (t + c.y))",
            ]
        );
        assert_eq!(function.statements(Parens::Minimal).last().unwrap(), "result = s * (t + c.y)");
    }

    #[test]
    fn a_value_reads_as_the_hlsl_printer_writes_it() {
        // The manifest's lines of a lookup are, expression for expression, its HLSL.
        let value = select(name("y").lt(float(0.0)), -name("y"), name("y")) + name("y").floor().min(float(62.0));
        let body = vec![let_("a", Ty::F32, value), Stmt::Return(name("a"))];
        let function = Function { name: "f".into(), params: vec![("y".into(), Ty::F32)], returns: Ty::F32, body };
        let mut module = Module::new(Parens::Full);
        module.push(Item::Function(function.clone()));
        let line = &function.statements(Parens::Full)[0];
        let expression = line.strip_prefix("a = ").unwrap();
        assert!(module.print(Lang::Hlsl).contains(&format!("float a = {expression};")), "{line}");
        assert_eq!(expression, "(((y < 0.0) ? -y : y) + min(floor(y), 62.0))");
    }
}
