use super::*;

fn err(text: &str) -> ExprError {
    parse(text).expect_err(text)
}

#[test]
fn precedence_and_associativity_follow_the_documented_grammar() {
    // -x^2 is -(x^2); ^ is right-associative; * binds tighter than +.
    let n = parse("-x ^ 2 ^ 3 + 2 * y").unwrap();
    let Node::Binary(BinOp::Add, left, right) = n else { panic!("{n:?}") };
    let Node::Neg(power) = *left else { panic!() };
    let Node::Binary(BinOp::Pow, _, exponent) = *power else { panic!() };
    assert!(matches!(*exponent, Node::Binary(BinOp::Pow, ..)));
    assert!(matches!(*right, Node::Binary(BinOp::Mul, ..)));
    // A negative literal exponent stays a number.
    assert!(matches!(parse("x ^ -2").unwrap(), Node::Binary(BinOp::Pow, _, e) if *e == Node::Number(-2.0)));
    assert_eq!(parse("1.5e-3").unwrap(), Node::Number(1.5e-3));
    assert_eq!(parse(".5").unwrap(), Node::Number(0.5));
}

#[test]
fn select_takes_a_comparison_as_its_third_argument_and_nowhere_else() {
    let n = parse("select(a, b, x <= 1)").unwrap();
    assert!(matches!(n, Node::Select { compare: Compare::Le, .. }));
    let e = err("a < b");
    assert_eq!(e.at, 2);
    assert!(e.message.contains("only allowed as the condition of select"), "{}", e.message);
    let e = err("select(a, b, c)");
    assert!(e.message.contains("expected a comparison"), "{}", e.message);
    let e = err("select(a, b < c, c < d)");
    assert_eq!(e.at, 12);
}

#[test]
fn errors_point_at_the_offending_byte() {
    let e = err("1 + * 2");
    assert_eq!((e.at, e.message.contains("expected a number")), (4, true), "{}", e.message);
    let e = err("sqrt(x");
    assert_eq!(e.at, 6);
    let e = err("foo(x)");
    assert_eq!(e.at, 0);
    assert!(e.message.contains("unknown function `foo`") && e.message.contains("smoothstep"), "{}", e.message);
    let e = err("x + clamp(x, 1)");
    assert_eq!(e.at, 4);
    assert!(e.message.contains("2 arguments") && e.message.contains("takes 3"), "{}", e.message);
    let e = err("x $ 2");
    assert_eq!(e.at, 2);
    assert!(err("").message.contains("empty"));
    let e = err("x y");
    assert_eq!(e.at, 2);
}

#[test]
fn every_function_parses_with_its_argument_count() {
    for (function, _, arity) in Intrinsic::ALL {
        let name = form_name(function);
        let args = vec!["x"; arity].join(", ");
        assert!(matches!(parse(&format!("{name}({args})")).unwrap(), Node::Call(..)), "{name}");
        let wrong = vec!["x"; arity + 1].join(", ");
        assert!(parse(&format!("{name}({wrong})")).is_err(), "{name} with {} arguments", arity + 1);
    }
}

#[test]
fn names_that_shaders_refuse_are_refused() {
    assert!(check_identifier("rx").is_ok());
    assert!(check_identifier("a004").is_ok());
    for bad in ["let", "float", "min", "select", "2x", "x__y", "tmlut_x", "_x", "frac", "gl_x", "inversesqrt", "layout"]
    {
        assert!(check_identifier(bad).is_err(), "{bad}");
    }
}

#[test]
fn deep_nesting_is_refused_not_a_stack_overflow() {
    let deep = format!("{}x{}", "(".repeat(1000), ")".repeat(1000));
    assert!(err(&deep).message.contains("nests deeper than"));
    assert!(err(&format!("{}x", "-".repeat(1000))).message.contains("nests deeper than"));
    assert!(err(&vec!["x"; 100_000].join(" + ")).message.contains("more than 4096 tokens"));
    let fine = format!("{}x{}", "(".repeat(50), ")".repeat(50));
    assert!(parse(&fine).is_ok());
}
