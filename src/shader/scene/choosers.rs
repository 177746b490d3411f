//! The functions choosing among a lookup's slice candidates (`reads.rs`, [`super::Generator`]'s
//! `slice`), printed in one of two ways.
//!
//! A material's own function ([`super::per_material_module`]) reads every candidate and keeps the
//! value of the nearest. The scene shader ([`super::generate`]) shares its functions by shape
//! (`shapes.rs`), and two functions are one shape only where they call one chooser shape: there
//! every lookup of slices goes through a chooser (one slice included), and choosers whose candidates
//! differ only in their constants (the same texture, channel and axis formulas) are printed alike, padded
//! to the most candidates any of them has. A padding candidate repeats the first, and the chooser
//! compares only its own `count` (a constant of its own, so read from the buffer once shared): a
//! padding candidate is neither computed nor chosen. Such a chooser compares the distances first
//! and keeps the constants of the nearest candidate's read (the texture coordinates' origins,
//! extents and layer), then reads that one slice: the same operations on the same values as
//! reading it among all of them, one texture read instead of one per candidate.

use std::collections::HashMap;

use super::super::{Expr, Function, Stmt, Ty, assign, let_, name, var};
use super::shapes::walk;

/// One chooser: its function's name and its candidates in the order chosen among.
pub(super) struct Chooser {
    pub name: String,
    pub candidates: Vec<Candidate>,
}

/// A slice candidate: its [`crate::model::folder::slice_choice_distance`] at `(mu, alpha)` and its
/// value there, both printed over the chooser's parameters `mu` and `alpha`.
#[derive(Clone)]
pub(super) struct Candidate {
    pub distance: Expr,
    pub value: Expr,
}

const PARAMS: [&str; 2] = ["mu", "alpha"];
/// The local holding how many of a padded chooser's candidates are its own.
const COUNT: &str = "count";

fn function(name: &str, body: Vec<Stmt>) -> Function {
    Function {
        name: name.into(),
        params: PARAMS.iter().map(|p| (p.to_string(), Ty::F32)).collect(),
        returns: Ty::F32,
        body,
    }
}

/// Each chooser reading every candidate, the first of the nearest kept.
pub(super) fn reading_each(choosers: &[Chooser]) -> Vec<Function> {
    choosers
        .iter()
        .map(|chooser| {
            let mut body = Vec::new();
            for (k, c) in chooser.candidates.iter().enumerate() {
                if k == 0 {
                    body.push(var("nearest", Ty::F32, c.distance.clone()));
                    body.push(var("value", Ty::F32, c.value.clone()));
                } else {
                    let (d, v) = (format!("distance{k}"), format!("value{k}"));
                    body.push(let_(&d, Ty::F32, c.distance.clone()));
                    body.push(let_(&v, Ty::F32, c.value.clone()));
                    body.push(Stmt::If {
                        condition: name(&d).lt(name("nearest")),
                        then: vec![assign(name("nearest"), name(&d)), assign(name("value"), name(&v))],
                        otherwise: Vec::new(),
                    });
                }
            }
            body.push(Stmt::Return(name("value")));
            function(&chooser.name, body)
        })
        .collect()
}

/// Choosers of one printed form: how many candidates each is padded to, and which of the read's
/// literals (in [`walk`]'s order) differ between their candidates.
struct Family {
    candidates: usize,
    first_literals: Vec<Expr>,
    varying: Vec<bool>,
}

/// Each chooser padded to its family's count and reading only the nearest candidate; a chooser
/// whose candidates differ in more than their constants reads each.
pub(super) fn padded(choosers: &[Chooser]) -> Vec<Function> {
    let keys: Vec<Option<String>> = choosers.iter().map(family_key).collect();
    let mut families: HashMap<&str, Family> = HashMap::new();
    for (chooser, key) in choosers.iter().zip(&keys) {
        let Some(key) = key else { continue };
        let family = families.entry(key).or_insert_with(|| {
            let first_literals = literals(&chooser.candidates[0].value);
            Family { candidates: 0, varying: vec![false; first_literals.len()], first_literals }
        });
        family.candidates = family.candidates.max(chooser.candidates.len());
        for candidate in &chooser.candidates {
            for (j, literal) in literals(&candidate.value).iter().enumerate() {
                family.varying[j] |= !same(literal, &family.first_literals[j]);
            }
        }
    }
    choosers
        .iter()
        .zip(&keys)
        .map(|(chooser, key)| match key {
            Some(key) => selecting(chooser, &families[key.as_str()]),
            None => reading_each(std::slice::from_ref(chooser)).remove(0),
        })
        .collect()
}

/// The chooser comparing `family.candidates` distances, its own candidates then repeats of its
/// first, and reading the nearest.
fn selecting(chooser: &Chooser, family: &Family) -> Function {
    let first = &chooser.candidates[0];
    if family.candidates == 1 {
        return function(&chooser.name, vec![Stmt::Return(first.value.clone())]);
    }
    let chosen = |j: usize| format!("chosen{j}");
    let mut body = vec![
        Stmt::Comment(
            "The nearest of the chooser's `count` candidates, then its read. A candidate past them\n\
             repeats the first and is skipped."
                .into(),
        ),
        let_(COUNT, Ty::U32, Expr::U32(chooser.candidates.len() as u32)),
        var("nearest", Ty::F32, first.distance.clone()),
    ];
    for (j, literal) in literals(&first.value).into_iter().enumerate().filter(|(j, _)| family.varying[*j]) {
        body.push(var(&chosen(j), literal_type(&literal), literal));
    }
    for k in 1..family.candidates {
        let candidate = chooser.candidates.get(k).unwrap_or(first);
        let d = format!("distance{k}");
        let mut nearer = vec![assign(name("nearest"), name(&d))];
        for (j, literal) in literals(&candidate.value).into_iter().enumerate().filter(|(j, _)| family.varying[*j]) {
            nearer.push(assign(name(&chosen(j)), literal));
        }
        body.push(Stmt::If {
            condition: Expr::U32(k as u32).lt(name(COUNT)),
            then: vec![
                let_(&d, Ty::F32, candidate.distance.clone()),
                Stmt::If { condition: name(&d).lt(name("nearest")), then: nearer, otherwise: Vec::new() },
            ],
            otherwise: Vec::new(),
        });
    }
    let mut value = first.value.clone();
    let mut j = 0;
    walk(&mut value, &mut |e| {
        if is_literal(e) {
            if family.varying[j] {
                *e = name(&chosen(j));
            }
            j += 1;
        }
    });
    body.push(Stmt::Return(value));
    function(&chooser.name, body)
}

/// What the choosers printed alike share: each candidate's distance and read with its literals
/// zeroed, where all of a chooser's candidates have the same.
fn family_key(chooser: &Chooser) -> Option<String> {
    let abstracted = |c: &Candidate| {
        let mut pair = (c.distance.clone(), c.value.clone());
        for e in [&mut pair.0, &mut pair.1] {
            walk(e, &mut |e| match e {
                Expr::F32(v) => *v = 0.0,
                Expr::U32(v) => *v = 0,
                _ => {}
            });
        }
        format!("{pair:?}")
    };
    let first = abstracted(&chooser.candidates[0]);
    chooser.candidates[1..].iter().all(|c| abstracted(c) == first).then_some(first)
}

fn is_literal(e: &Expr) -> bool {
    matches!(e, Expr::F32(_) | Expr::U32(_))
}

/// The literals of `e` in [`walk`]'s order, the order the shape sharing reads them in.
fn literals(e: &Expr) -> Vec<Expr> {
    let mut found = Vec::new();
    walk(&mut e.clone(), &mut |e| {
        if is_literal(e) {
            found.push(e.clone());
        }
    });
    found
}

fn literal_type(e: &Expr) -> Ty {
    match e {
        Expr::U32(_) => Ty::U32,
        _ => Ty::F32,
    }
}

/// The same bits (`-0.0` is not `0.0`).
fn same(a: &Expr, b: &Expr) -> bool {
    match (a, b) {
        (Expr::F32(a), Expr::F32(b)) => a.to_bits() == b.to_bits(),
        (a, b) => a == b,
    }
}
