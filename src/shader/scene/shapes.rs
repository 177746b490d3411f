//! Materials of one stack shape share one function body. A material's function is its recorded
//! model with every constant the stack decides printed as a literal; two materials whose functions
//! differ in nothing but those literals (the same layers, flux model, lookups and tables, with other
//! indices, roughnesses and depths) have one shape. Each shape is one function, `tmh_shape<N>(base,
//! mu_in)`: a literal every material of the shape holds alike stays a literal, and one that differs
//! is read from the storage buffer `tmh_constants` at `base + k`, where `base` is the first of the
//! material's constants there. The slice choosers a material calls are shared the same way first
//! (`tmh_slices<N>(base, mu, alpha)`), a chooser's `base` a literal of its caller's. So the module
//! grows with the number of shapes, not of materials (docs/benchmark.md, "The library shader",
//! counts them for a generated library of 1,000), and a material's constants are data: `(shape,
//! base)` of material `i` are elements `2i` and `2i + 1` of the buffer, which `tm_material(index,
//! mu)` reads to call its shape.
//!
//! The shape function computes what the material's own function computes, in the same operations
//! and order, each literal read as the f32 it was printed as: the same bits (the emulator's
//! comparison of the two, `tests/integration/shader.rs`).

use std::collections::HashMap;

use super::super::{Expr, Function, Item, Lang, Module, Parens, Stmt, Ty, assign, name, var};
use crate::error::{Error, Result};

/// The storage buffer of the materials' constants.
pub const CONSTANTS: &str = "tmh_constants";
/// The function evaluating any material by its index.
pub const DISPATCH: &str = "tm_material";
/// Elements of the buffer's header per material: its shape and the first of its constants.
pub const HEADER_STRIDE: usize = 2;
/// A buffer index is stored in f32 (the header, a chooser's `base`), which holds every integer below
/// 2^24 exactly.
const MAX_ELEMENTS: usize = 1 << 24;
/// The parameter of a shared function: the first of its caller's constants in the buffer.
const BASE: &str = "base";

/// Functions that differ only in their literals, made one function per shape.
pub(super) struct Shared {
    /// One function per shape, in the order its first member came.
    pub functions: Vec<Function>,
    /// Per function shared, in the order given: its shape and the first of its constants.
    pub members: Vec<(usize, u32)>,
    /// Per shape: how many functions it replaced, and how many constants each stores.
    pub shapes: Vec<(usize, usize)>,
}

/// A literal where a function's structure has one.
#[derive(Debug, Clone, Copy)]
enum Literal {
    F32(f32),
    U32(u32),
}

impl Literal {
    /// Whether two literals are the same bits (`-0.0` is not `0.0`).
    fn same(self, other: Literal) -> bool {
        match (self, other) {
            (Literal::F32(a), Literal::F32(b)) => a.to_bits() == b.to_bits(),
            (Literal::U32(a), Literal::U32(b)) => a == b,
            _ => false,
        }
    }
}

/// Share `functions` (of `what`: `materials`, `slice choosers`) by shape: each shape's function
/// named `name(shape)`, taking the first of its constants in `constants` as a first parameter, the
/// constants that differ appended to `constants`.
pub(super) fn share(
    functions: Vec<Function>,
    what: &str,
    name: impl Fn(usize) -> String,
    constants: &mut Vec<f32>,
) -> Result<Shared> {
    let mut keys: HashMap<String, usize> = HashMap::new();
    // Per shape: its first member, and the members' literals.
    let mut shapes: Vec<(Function, Vec<Vec<Literal>>)> = Vec::new();
    let mut member_shapes = Vec::with_capacity(functions.len());
    for mut function in functions {
        number_locals(&mut function);
        let mut literals = Vec::new();
        let mut abstracted = function.clone();
        abstracted.name.clear();
        walk_stmts(&mut abstracted.body, &mut |e| match e {
            Expr::F32(v) => {
                literals.push(Literal::F32(*v));
                *v = 0.0;
            }
            Expr::U32(v) => {
                literals.push(Literal::U32(*v));
                *v = 0;
            }
            _ => {}
        });
        let key =
            Module { items: vec![Item::Function(abstracted)], parens: Parens::Minimal, hlsl_brace_on_next_line: false }
                .print(Lang::Wgsl);
        let next = shapes.len();
        let shape = *keys.entry(key).or_insert(next);
        if shape == next {
            function.name = name(shape);
            shapes.push((function, Vec::new()));
        }
        shapes[shape].1.push(literals);
        member_shapes.push(shape);
    }
    let mut shared = Shared { functions: Vec::new(), members: Vec::new(), shapes: Vec::new() };
    let mut bases: Vec<Vec<u32>> = Vec::new();
    for (mut function, members) in shapes {
        let first = &members[0];
        let varying: Vec<bool> =
            (0..first.len()).map(|j| members.iter().any(|literals| !literals[j].same(first[j]))).collect();
        let stored = varying.iter().filter(|&&v| v).count();
        let mut j = 0;
        let mut k = 0u32;
        walk_stmts(&mut function.body, &mut |e| {
            if matches!(e, Expr::F32(_) | Expr::U32(_)) {
                if varying[j] {
                    *e = read(e, k);
                    k += 1;
                }
                j += 1;
            }
        });
        if stored > 0 {
            function.body.insert(
                0,
                Stmt::Comment(format!(
                    "Shared by {} {what}: the {stored} constants that differ between them are read from\n\
                     {CONSTANTS}, the caller's from `{BASE}` on.",
                    members.len()
                )),
            );
        }
        function.params.insert(0, (BASE.into(), Ty::U32));
        let mut shape_bases = Vec::with_capacity(members.len());
        for literals in &members {
            let base = if stored > 0 { constants.len() } else { 0 };
            for (literal, _) in literals.iter().zip(&varying).filter(|(_, varies)| **varies) {
                constants.push(match *literal {
                    Literal::F32(v) => v,
                    Literal::U32(v) => exact(v as usize)?,
                });
            }
            shape_bases.push(index(base)?);
        }
        check_length(constants.len())?;
        shared.shapes.push((members.len(), stored));
        shared.functions.push(function);
        bases.push(shape_bases);
    }
    let mut next = vec![0usize; bases.len()];
    for shape in member_shapes {
        shared.members.push((shape, bases[shape][next[shape]]));
        next[shape] += 1;
    }
    Ok(shared)
}

/// The locals a recorded function names by their instruction on the tape (`v<instruction>`)
/// renumbered in the order they are defined, so that two functions whose tapes differ only in
/// instructions folded away while recording name their locals alike.
fn number_locals(function: &mut Function) {
    fn numbered(local: &str) -> bool {
        local.len() > 1 && local.starts_with('v') && local[1..].bytes().all(|b| b.is_ascii_digit())
    }
    fn rename_definitions(body: &mut [Stmt], renamed: &mut HashMap<String, String>) {
        for stmt in body {
            match stmt {
                Stmt::Let { name, .. } | Stmt::Var { name, .. } if numbered(name) => {
                    let next = format!("v{}", renamed.len());
                    *name = renamed.entry(std::mem::take(name)).or_insert(next).clone();
                }
                Stmt::If { then, otherwise, .. } => {
                    rename_definitions(then, renamed);
                    rename_definitions(otherwise, renamed);
                }
                Stmt::Switch { cases, default, .. } => {
                    for (_, case) in cases.iter_mut() {
                        rename_definitions(case, renamed);
                    }
                    rename_definitions(default, renamed);
                }
                _ => {}
            }
        }
    }
    let mut renamed = HashMap::new();
    rename_definitions(&mut function.body, &mut renamed);
    walk_stmts(&mut function.body, &mut |e| {
        if let Expr::Name(local) = e
            && let Some(new) = renamed.get(local.as_str())
        {
            *local = new.clone();
        }
    });
}

/// `literal`'s value as read from constant `k` of the caller's.
fn read(literal: &Expr, k: u32) -> Expr {
    let at = if k == 0 { name(BASE) } else { name(BASE) + Expr::U32(k) };
    let element = name(CONSTANTS).element(at);
    match literal {
        Expr::U32(_) => Expr::Construct(Ty::U32, vec![element]),
        _ => element,
    }
}

/// An index into the buffer as the shader's `u32`.
fn index(k: usize) -> Result<u32> {
    check_length(k)?;
    Ok(k as u32)
}

/// An index into the buffer as the f32 the buffer stores it in.
fn exact(k: usize) -> Result<f32> {
    check_length(k)?;
    Ok(k as f32)
}

fn check_length(elements: usize) -> Result<()> {
    if elements > MAX_ELEMENTS {
        return Err(Error::invalid(
            "tmlut shader",
            format!(
                "the materials' constants take {elements} elements of the buffer, more than the {MAX_ELEMENTS} whose \
                 indices f32 holds exactly: shade fewer materials in one scene"
            ),
        ));
    }
    Ok(())
}

/// Calls of the functions `renamed` names, made calls of their shared function with their `base`
/// first.
pub(super) fn rename_calls(function: &mut Function, renamed: &HashMap<String, (String, u32)>) {
    walk_stmts(&mut function.body, &mut |e| {
        if let Expr::Function(called, arguments) = e
            && let Some((shared, base)) = renamed.get(called.as_str())
        {
            *called = shared.clone();
            arguments.insert(0, Expr::U32(*base));
        }
    });
}

/// The function of a material of a shared shape: its shape's function at its constants.
pub(super) fn material_function(function: &str, shape: &str, base: u32) -> Function {
    Function {
        name: function.into(),
        params: vec![("mu_in".into(), Ty::F32)],
        returns: Ty::Named(super::RESULT_STRUCT.into()),
        body: vec![Stmt::Return(Expr::Function(shape.into(), vec![Expr::U32(base), name("mu_in")]))],
    }
}

/// `tm_material(index, mu)`: material `index`'s shape function at its constants, both read from the
/// buffer's header; a `TmResult` of zeros for an index past the last material.
pub(super) fn dispatch_function(materials: usize, shapes: &[String]) -> Function {
    let header = |k: u32| {
        let at = Expr::U32(HEADER_STRIDE as u32) * name("index");
        let at = if k == 0 { at } else { at + Expr::U32(k) };
        Expr::Construct(Ty::U32, vec![name(CONSTANTS).element(at)])
    };
    let cases = shapes
        .iter()
        .enumerate()
        .map(|(k, shape)| {
            let call = Expr::Function(shape.clone(), vec![name("base"), name("mu")]);
            (k as u32, vec![assign(name("result"), call)])
        })
        .collect();
    Function {
        name: DISPATCH.into(),
        params: vec![("index".into(), Ty::U32), ("mu".into(), Ty::F32)],
        returns: Ty::Named(super::RESULT_STRUCT.into()),
        body: vec![
            Stmt::Comment(format!(
                "Any material by its index in the .shader.json's `materials`: elements {HEADER_STRIDE} index and \
                 {HEADER_STRIDE} index + 1\nof {CONSTANTS} are its shape and the first of its constants."
            )),
            Stmt::Var { name: "result".into(), ty: Ty::Named(super::RESULT_STRUCT.into()), value: None },
            Stmt::If {
                condition: name("index").lt(Expr::U32(materials as u32)),
                then: vec![
                    var("shape", Ty::U32, header(0)),
                    var("base", Ty::U32, header(1)),
                    Stmt::Switch { selector: name("shape"), cases, default: Vec::new() },
                ],
                otherwise: Vec::new(),
            },
            Stmt::Return(name("result")),
        ],
    }
}

/// `f` applied to every expression of `body`, each after the expressions inside it (so that what
/// `f` puts in place of a literal is not visited), in one order for every function of a shape.
fn walk_stmts(body: &mut [Stmt], f: &mut dyn FnMut(&mut Expr)) {
    for stmt in body {
        match stmt {
            Stmt::Let { value, .. } | Stmt::Var { value: Some(value), .. } | Stmt::Return(value) => walk(value, f),
            Stmt::Var { value: None, .. } | Stmt::Comment(_) => {}
            Stmt::Assign(target, value) => {
                walk(target, f);
                walk(value, f);
            }
            Stmt::If { condition, then, otherwise } => {
                walk(condition, f);
                walk_stmts(then, f);
                walk_stmts(otherwise, f);
            }
            Stmt::Switch { selector, cases, default } => {
                walk(selector, f);
                for (_, case) in cases {
                    walk_stmts(case, f);
                }
                walk_stmts(default, f);
            }
        }
    }
}

pub(super) fn walk(e: &mut Expr, f: &mut dyn FnMut(&mut Expr)) {
    match e {
        Expr::Name(_) | Expr::F32(_) | Expr::I32(_) | Expr::U32(_) => {}
        Expr::Binary(_, a, b) | Expr::Element(a, b) => {
            walk(a, f);
            walk(b, f);
        }
        Expr::Neg(a) | Expr::Paren(a) | Expr::Member(a, _) | Expr::Index(a, _) => walk(a, f),
        Expr::Call(_, arguments)
        | Expr::Function(_, arguments)
        | Expr::Construct(_, arguments)
        | Expr::Aggregate(_, arguments) => {
            for a in arguments {
                walk(a, f);
            }
        }
        Expr::Select { condition, then, otherwise } => {
            walk(condition, f);
            walk(then, f);
            walk(otherwise, f);
        }
        Expr::Load { coordinates, layer, .. } | Expr::SampleLevel { coordinates, layer, .. } => {
            for c in coordinates {
                walk(c, f);
            }
            if let Some(layer) = layer {
                walk(layer, f);
            }
        }
    }
    f(e);
}
