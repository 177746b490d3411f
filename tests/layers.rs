//! The library's modules form layers, each using only the layers below it: the order a change
//! flows in (physics before the integrals over it, recipes before the configuration that lists
//! them, the pipeline before the scene builds and reports that drive it). This test reads every
//! source file and fails on a `crate::` path that reaches up or sideways, naming the file and the
//! path. `docs/architecture.md` explains the order.
//!
//! A unit is a module or a file path under `src/` (`report/plot`); a file belongs to the unit of
//! its longest matching prefix. Test code (`tests.rs`, `*_tests.rs`, `proptests.rs` and everything
//! from `#[cfg(test)]` on) may use any layer.

use std::path::{Path, PathBuf};

/// The layers, lowest first. Units of one layer do not use each other.
const LAYERS: &[&[&str]] = &[
    &["error"],
    // What the process may use of the machine (its memory limits) stands beside them: std alone.
    &["stats", "table", "physics", "machine"],
    // Files and the drawing of PNG plots, which are a file format.
    &["formats"],
    // The form language of `fit/text` (expressions, their compiled tape, a form compiled from a
    // manifest's definition, form files) and a fitted TIR form a scene names: the model
    // evaluates both.
    &["fit/text/expr"],
    &["fit/text/tape"],
    &["fit/text/compile"],
    &["fit/text/form"],
    &["fit/text/fitted"],
    // The emitter that prints one description of a shader as HLSL and WGSL, and the emulator of
    // a GPU's texture filtering, which the loader samples with.
    &["shader", "packing/emulator"],
    // A form printed as a shader: the scene shader prints the forms its materials name.
    &["fit/text/shader"],
    &["report/plot"],
    &["loader"],
    &["sampling"],
    &["integrate"],
    &["packing"],
    &["model"],
    &["random_walk"],
    // A scene's transfer-matrix shader, over the model and a built folder.
    &["shader/scene"],
    &["recipes"],
    &["config"],
    // The build's own steps: the locked output folder, the fit's search, the error maps.
    &["commit", "fit", "report/error_map"],
    // Forms written as text: fitted by the fit's search, certified by the recipes' exact
    // integrals, written as one set by the commit; the form the build fits (`fit/text/build`).
    &["fit/text"],
    &["pipeline"],
    &["scene"],
    &["furnace"],
    // Reports over everything below; the packing report measures FGD's packings against its recipe.
    &["report", "stability", "packing/report"],
];

fn layer_of(unit: &str) -> Option<usize> {
    LAYERS.iter().position(|layer| layer.contains(&unit))
}

/// The unit of a module path (`fit/text/tape` -> `fit/text/tape`, `fit/least_squares` -> `fit`).
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

/// The code of a file without comments and test sections.
fn library_code(text: &str) -> String {
    let text = match text.find("#[cfg(test)]") {
        Some(at) => &text[..at],
        None => text,
    };
    text.lines().map(|line| line.split("//").next().unwrap_or_default()).collect::<Vec<_>>().join("\n")
}

/// The module paths a file names: `crate::a::b::C` gives `a/b/C`; `super::x` is resolved against
/// the file's own module.
fn named_paths(code: &str, module: &str) -> Vec<String> {
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
        paths.push(words(&code[at + "crate::".len()..]).join("/"));
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

#[test]
fn every_module_uses_only_the_layers_below_it() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    source_files(&src, &mut files);
    let mut violations = Vec::new();
    let mut checked = 0;
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
        let module = relative.strip_suffix("/mod").unwrap_or(&relative).to_string();
        let unit = unit_of(&module).unwrap_or_else(|| panic!("src/{relative}.rs is in no layer; add it to LAYERS"));
        let layer = layer_of(unit).unwrap();
        checked += 1;
        let code = library_code(&std::fs::read_to_string(file).unwrap());
        for path in named_paths(&code, &module) {
            let Some(used) = unit_of(&path) else { continue };
            if used == unit {
                continue;
            }
            let used_layer = layer_of(used).unwrap();
            if used_layer >= layer {
                violations.push(format!(
                    "src/{relative}.rs ({unit}, layer {layer}) uses crate::{} ({used}, layer {used_layer})",
                    path.replace('/', "::")
                ));
            }
        }
    }
    assert!(checked > 50, "only {checked} files read from {}", src.display());
    violations.sort();
    violations.dedup();
    assert!(violations.is_empty(), "modules reaching up or sideways:\n{}", violations.join("\n"));
}

#[test]
fn every_top_level_module_has_a_layer() {
    let lib = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("src/lib.rs")).unwrap();
    for line in lib.lines() {
        if let Some(name) = line.trim().strip_prefix("pub mod ").and_then(|rest| rest.strip_suffix(';')) {
            assert!(unit_of(name).is_some(), "module `{name}` of lib.rs is in no layer of tests/layers.rs");
        }
    }
}
