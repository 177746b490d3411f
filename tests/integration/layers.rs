//! The library's modules form layers, each using only the layers below it: the order a change
//! flows in (physics before the integrals over it, recipes before the configuration that lists
//! them, the pipeline before the scene builds and reports that drive it). This test reads every
//! source file and fails on a `crate::` path that reaches up or sideways, naming the file and the
//! path. `docs/architecture.md` explains the order.
//!
//! A unit is a module or a file path under `src/` (`report/plot`); a file belongs to the unit of
//! its longest matching prefix. Test code (`tests.rs`, `*_tests.rs`, `proptests.rs` and the items
//! under `#[cfg(test)]`, such as a `mod tests { ... }` or a test-only helper) may use any layer;
//! the code around such an item is read.

use std::path::{Path, PathBuf};

/// The layers, lowest first. Units of one layer do not use each other.
const LAYERS: &[&[&str]] = &[
    &["error"],
    // What the process may use of the machine (its memory limits) stands beside them: std alone;
    // and the number type the model is written over.
    &["stats", "table", "memory", "ir/real"],
    // The optics: the Fresnel equations (the loader's) and GGX, Smith, Henyey–Greenstein over
    // the model's number type; a GPU's texture filter, emulated over a table's arithmetic.
    &["physics", "filter"],
    // Files: the loader's readers (`crates/loader/src/formats/`) and this crate's writers beside
    // them (`src/formats/`, whose modules re-export the loader's), one unit.
    &["formats"],
    // The IR crate: the form language, its tape, compiled from a form or recorded from code over
    // the model's number type, the shader description and the tape printed into it.
    &["ir/text"],
    &["ir/tape"],
    &["ir/compile", "ir/record"],
    &["ir/shader", "shader"],
    &["ir/print"],
    // Form files, and a fitted TIR form a scene names: the model evaluates both.
    &["fit/forms/form"],
    &["fit/forms/fitted"],
    // A form printed as a shader: the scene shader prints the forms its materials name.
    &["fit/forms/shader"],
    &["report/plot"],
    &["loader"],
    &["sampling"],
    &["integrate"],
    &["packing"],
    &["model"],
    // Over the model: its ground truth (the walk) and its result tabulated per material (a bake).
    &["random_walk", "bake"],
    // A scene's transfer-matrix shader, over the model and a built folder.
    &["shader/scene"],
    // The read of baked materials, returning the scene shader's result.
    &["shader/baked"],
    &["recipes"],
    &["config"],
    // The build's own steps: the locked output folder, the fit's search, the error maps; the
    // model's lookups answered by quadrature (what the furnace, the bake and the checks compare with);
    // the engine presets, a configuration and the engine file written from its table.
    &["commit", "fit", "report/error_map", "exact", "presets"],
    // Forms written as text: fitted by the fit's search, certified by the recipes' exact
    // integrals, written as one set by the commit; the form the build fits (`fit/forms/build`).
    &["fit/forms"],
    &["pipeline"],
    &["scene"],
    &["furnace"],
    // Reports over everything below; the packing report measures FGD's packings against its recipe.
    &["report", "stability", "packing/report"],
];

fn layer_of(unit: &str) -> Option<usize> {
    LAYERS.iter().position(|layer| layer.contains(&unit))
}

/// The unit of a module path (`fit/forms/form` -> `fit/forms/form`, `fit/least_squares` -> `fit`).
fn unit_of(module_path: &str) -> Option<&'static str> {
    LAYERS
        .iter()
        .flat_map(|layer| layer.iter().copied())
        .filter(|unit| module_path == *unit || module_path.starts_with(&format!("{unit}/")))
        .max_by_key(|unit| unit.len())
}

fn source_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            source_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The code of a file without its comments, the contents of its string and character literals,
/// and its test-only items (those under `#[cfg(test)]` or `#[cfg(all(test, ...))]`); the code after
/// a test-only item is kept.
fn library_code(text: &str) -> String {
    strip_test_items(&strip_comments_and_literals(text))
}

/// `text` without its comments (`//` to the end of the line, nested `/* */`) and with its string,
/// raw string and character literals emptied (`"..."` becomes `""`), so that neither a comment
/// nor a literal's `//`, braces, quotes or `crate::` can be taken for code. Lifetimes (`'a`) stay.
fn strip_comments_and_literals(text: &str) -> String {
    let chars: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    let ident = |c: char| c.is_alphanumeric() || c == '_';
    while i < chars.len() {
        let c = chars[i];
        let next = chars.get(i + 1).copied();
        if c == '/' && next == Some('/') {
            while i < chars.len() && chars[i] != '\n' {
                i += 1;
            }
        } else if c == '/' && next == Some('*') {
            let mut depth = 0;
            while i < chars.len() {
                if chars[i] == '/' && chars.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if chars[i] == '*' && chars.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    if chars[i] == '\n' {
                        out.push('\n');
                    }
                    i += 1;
                }
            }
            out.push(' ');
        } else if c == 'r'
            && (i == 0 || !ident(chars[i - 1]) || (chars[i - 1] == 'b' && (i == 1 || !ident(chars[i - 2]))))
            && matches!(next, Some('"' | '#'))
            && chars[i + 1..].iter().find(|&&c| c != '#') == Some(&'"')
        {
            // A raw string: `r"..."`, `r#"..."#`, `br##"..."##`; no escapes.
            let hashes = chars[i + 1..].iter().take_while(|&&c| c == '#').count();
            i += 1 + hashes + 1;
            while i < chars.len() {
                if chars[i] == '"' && chars[i + 1..].iter().take(hashes).filter(|&&c| c == '#').count() == hashes {
                    i += 1 + hashes;
                    break;
                }
                i += 1;
            }
            out.push_str("r\"\"");
        } else if c == '"' {
            i += 1;
            while i < chars.len() && chars[i] != '"' {
                i += if chars[i] == '\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("\"\"");
        } else if c == '\'' && (next == Some('\\') || chars.get(i + 2) == Some(&'\'')) {
            // A character literal (`'x'`, `'\n'`, `'\u{7d}'`); `'a` without a closing quote is a
            // lifetime or a label.
            i += 1;
            while i < chars.len() && chars[i] != '\'' {
                i += if chars[i] == '\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("' '");
        } else {
            out.push(c);
            i += 1;
        }
    }
    out
}

/// Whether an attribute's text (`#[cfg(test)]`, `#[cfg(all(test, feature = "x"))]`) makes the
/// item under it test-only.
fn is_test_only(attribute: &str) -> bool {
    let inner: String = attribute.chars().filter(|c| !c.is_whitespace()).collect();
    let Some(condition) = inner.strip_prefix("#[cfg(").and_then(|rest| rest.strip_suffix(")]")) else {
        return false;
    };
    if condition == "test" {
        return true;
    }
    // `all(...)` with `test` among its own arguments; `any(test, ...)` and `not(test)` are not
    // test-only.
    let Some(arguments) = condition.strip_prefix("all(").and_then(|rest| rest.strip_suffix(')')) else {
        return false;
    };
    let mut depth = 0;
    let mut start = 0;
    let mut parts = Vec::new();
    for (at, c) in arguments.char_indices() {
        match c {
            '(' => depth += 1,
            ')' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(&arguments[start..at]);
                start = at + 1;
            }
            _ => {}
        }
    }
    parts.push(&arguments[start..]);
    parts.contains(&"test")
}

/// The end (exclusive) of the bracketed group opening at `open` (`[`, `(` or `{`), or the end of
/// `code` if it is not closed. `code` has no comments or literal contents.
fn group_end(code: &[char], open: usize) -> usize {
    let mut depth = 0;
    for (at, &c) in code.iter().enumerate().skip(open) {
        match c {
            '(' | '[' | '{' => depth += 1,
            ')' | ']' | '}' => {
                depth -= 1;
                if depth == 0 {
                    return at + 1;
                }
            }
            _ => {}
        }
    }
    code.len()
}

/// `code` (without comments or literal contents) without its test-only items: each attribute
/// that makes an item test-only, the attributes beside it, and the item up to its `;` or `,`, or
/// through the `}` that closes its body (`mod tests { ... }`, a `fn`, an `impl`). The code after
/// the item stays.
fn strip_test_items(code: &str) -> String {
    let chars: Vec<char> = code.chars().collect();
    let mut out = String::with_capacity(code.len());
    let mut i = 0;
    while i < chars.len() {
        if chars[i] == '#' && chars.get(i + 1) == Some(&'[') {
            let end = group_end(&chars, i + 1);
            let attribute: String = chars[i..end].iter().collect();
            if is_test_only(&attribute) {
                i = item_end(&chars, end);
                out.push(' ');
                continue;
            }
        }
        out.push(chars[i]);
        i += 1;
    }
    out
}

/// The end (exclusive) of the item that starts at `start`, after an attribute: further attributes,
/// then everything up to a `;` or `,` outside brackets, or through the first `{ ... }` outside
/// brackets, or up to a closing bracket of the code around the item.
fn item_end(code: &[char], start: usize) -> usize {
    let mut i = start;
    while i < code.len() {
        match code[i] {
            ';' | ',' => return i + 1,
            '{' => return group_end(code, i),
            '(' | '[' => i = group_end(code, i),
            ')' | ']' | '}' => return i,
            _ => i += 1,
        }
    }
    code.len()
}

/// The module paths a file names: `crate::a::b::C` gives `a/b/C` after the crate's `prefix`;
/// `super::x` is resolved against the file's own module.
fn named_paths(code: &str, module: &str, prefix: &str) -> Vec<String> {
    let mut paths = Vec::new();
    // The identifiers of a path up to the first character that ends it (`{`, `;`, `(`, space).
    let words = |rest: &str| -> Vec<String> {
        let mut words = Vec::new();
        for part in rest.split("::") {
            let word: String = part.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
            let ended = word.len() < part.len();
            if !word.is_empty() {
                words.push(word);
            }
            if ended || part.is_empty() {
                break;
            }
        }
        words
    };
    for (at, _) in code.match_indices("crate::") {
        let before = code[..at].chars().last();
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            continue;
        }
        paths.push(format!("{prefix}{}", words(&code[at + "crate::".len()..]).join("/")));
    }
    for (at, _) in code.match_indices("super::") {
        if code[..at].ends_with("super::") {
            continue;
        }
        let mut rest = &code[at..];
        let mut parent: Vec<&str> = module.split('/').collect();
        while let Some(after) = rest.strip_prefix("super::") {
            parent.pop();
            rest = after;
        }
        let mut path: Vec<String> = parent.iter().map(|s| s.to_string()).collect();
        path.extend(words(rest));
        paths.push(path.join("/"));
    }
    paths
}

/// The source folders the layers cover, each with the prefix its modules' units take: the loader
/// crate's, whose modules this crate re-exports under the same names (so its `crate::` paths name
/// the same units), the IR crate's, re-exported as `ir` (its `crate::tape` is this crate's
/// `crate::ir::tape`), and this crate's.
const SOURCE_ROOTS: [(&str, &str); 3] = [("crates/loader/src", ""), ("crates/ir/src", "ir/"), ("src", "")];

#[test]
fn every_module_uses_only_the_layers_below_it() {
    let mut violations = Vec::new();
    let mut checked = 0;
    for (root, prefix) in SOURCE_ROOTS {
        let src = Path::new(env!("CARGO_MANIFEST_DIR")).join(root);
        let mut files = Vec::new();
        source_files(&src, &mut files);
        for file in &files {
            let relative = file.strip_prefix(&src).unwrap().with_extension("");
            let relative = relative.to_string_lossy().replace('\\', "/");
            let name = relative.rsplit('/').next().unwrap();
            // The binary and the crate root sit above every layer; tests may use any of them.
            if relative == "main" || relative == "lib" || relative.starts_with("cli/") {
                continue;
            }
            if name == "tests" || name.ends_with("_tests") || name == "proptests" {
                continue;
            }
            // `a/mod.rs` is module `a`.
            let module = format!("{prefix}{}", relative.strip_suffix("/mod").unwrap_or(&relative));
            let unit =
                unit_of(&module).unwrap_or_else(|| panic!("{root}/{relative}.rs is in no layer; add it to LAYERS"));
            let layer = layer_of(unit).unwrap();
            checked += 1;
            let code = library_code(&std::fs::read_to_string(file).unwrap());
            for path in named_paths(&code, &module, prefix) {
                let Some(used) = unit_of(&path) else { continue };
                if used == unit {
                    continue;
                }
                let used_layer = layer_of(used).unwrap();
                if used_layer >= layer {
                    violations.push(format!(
                        "{root}/{relative}.rs ({unit}, layer {layer}) uses crate::{} ({used}, layer {used_layer})",
                        path.replace('/', "::")
                    ));
                }
            }
        }
    }
    assert!(checked > 50, "only {checked} files read from {SOURCE_ROOTS:?}");
    violations.sort();
    violations.dedup();
    assert!(violations.is_empty(), "modules reaching up or sideways:\n{}", violations.join("\n"));
}

#[test]
fn every_top_level_module_has_a_layer() {
    for (root, prefix) in SOURCE_ROOTS {
        let lib = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(root).join("lib.rs")).unwrap();
        for line in lib.lines() {
            if let Some(name) = line.trim().strip_prefix("pub mod ").and_then(|rest| rest.strip_suffix(';')) {
                assert!(
                    unit_of(&format!("{prefix}{name}")).is_some(),
                    "module `{name}` of {root}/lib.rs is in no layer of tests/integration/layers.rs"
                );
            }
        }
    }
}

#[test]
fn library_code_drops_comments_literals_and_test_items_only() {
    let text = r####"//! Docs naming crate::docs.
#[cfg(test)]
mod tests;

use crate::x::Y; // a comment naming crate::comment
/* a block /* nested */ naming crate::block */
const S: &str = "// crate::in_string { \" }";
const C: char = '{';
#[cfg(test)]
#[allow(dead_code)]
fn helper<'a>(s: &'a str) -> [u8; 2] { let _ = "{"; [0; 2] }
pub fn f<'a>(s: &'a str) -> &'a str { let _ = '}'; crate::after_helper::g(s) }
struct P {
    #[cfg(test)]
    probe: crate::probe::Probe,
    kept_field: crate::field::F,
}
#[cfg(test)]
mod tests {
    use crate::test_only;
    fn g() { let s = "}"; let r = r#"}"#; let c = '}'; if true { crate::nested(); } }
}
#[cfg(all(test, feature = "generator"))]
mod more_tests;
#[cfg(any(test, feature = "x"))]
use crate::kept;
#[cfg(not(test))]
use crate::not_test;
pub fn last() { crate::end::h(); }
"####;
    let code = library_code(text);
    assert_eq!(
        named_paths(&code, "m", ""),
        ["x/Y", "after_helper/g", "field/F", "kept", "not_test", "end/h"],
        "the library code read:\n{code}"
    );
    for gone in [
        "mod tests",
        "more_tests",
        "fn helper",
        "probe",
        "test_only",
        "nested",
        "in_string",
        "comment",
        "block",
        "docs",
    ] {
        assert!(!code.contains(gone), "`{gone}` left in:\n{code}");
    }
    for kept in ["struct P {", "kept_field", "pub fn f<'a>(s: &'a str)", "pub fn last()"] {
        assert!(code.contains(kept), "`{kept}` lost from:\n{code}");
    }
}
