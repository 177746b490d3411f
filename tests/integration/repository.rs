//! The repository stands on its own: every file a test reads and every document a comment cites is
//! inside it, so that `scripts/test` passes in a clone of the repository alone.

use std::path::{Component, Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Every `.rs` file under `src/` and `tests/`.
fn rust_sources() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap().flatten() {
            let path = entry.path();
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                out.push(path);
            }
        }
    }
    let mut sources = Vec::new();
    walk(&root().join("src"), &mut sources);
    walk(&root().join("tests"), &mut sources);
    sources.sort();
    sources
}

/// The string literals that follow `CARGO_MANIFEST_DIR"), ` in `text`: paths relative to the
/// repository that code reads.
fn manifest_relative_paths(text: &str) -> Vec<String> {
    let marker = "env!(\"CARGO_MANIFEST_DIR\"), \"";
    text.match_indices(marker)
        .filter_map(|(at, _)| {
            let rest = &text[at + marker.len()..];
            rest.find('"').map(|end| rest[..end].to_string())
        })
        .collect()
}

/// Repository paths cited in backticks, e.g. `docs/formats.md`, by their top folder.
fn cited_documents(text: &str) -> Vec<String> {
    text.split('`')
        .skip(1)
        .step_by(2)
        .filter(|quoted| {
            quoted.ends_with(".md")
                && !quoted.contains(' ')
                && ["docs/", "notes/", "luts/", "tests/", "../"].iter().any(|top| quoted.starts_with(top))
        })
        .map(str::to_string)
        .collect()
}

#[test]
fn tests_read_only_files_inside_the_repository() {
    let mut outside = Vec::new();
    for source in rust_sources() {
        let text = std::fs::read_to_string(&source).unwrap();
        for relative in manifest_relative_paths(&text) {
            let escapes = Path::new(relative.trim_start_matches('/')).components().any(|c| c == Component::ParentDir);
            let target = root().join(relative.trim_start_matches('/'));
            if escapes || !target.exists() {
                outside.push(format!("{}: {relative}", source.display()));
            }
        }
    }
    assert!(outside.is_empty(), "paths outside the repository or missing:\n{}", outside.join("\n"));
}

#[test]
fn the_reference_tables_are_kept_with_their_provenance() {
    let data = root().join("tests/data/tmblm");
    assert_eq!(std::fs::metadata(data.join("tm_GD.bin")).unwrap().len(), 16_408);
    assert_eq!(std::fs::metadata(data.join("tm_TIR.bin")).unwrap().len(), 1_048_612);
    let readme = std::fs::read_to_string(data.join("README.md")).unwrap();
    assert!(readme.contains("laurent-lu/TMbLM-Rendering"), "{readme}");
}

#[test]
fn comments_cite_only_documents_in_the_repository() {
    let mut missing = Vec::new();
    for source in rust_sources() {
        let text = std::fs::read_to_string(&source).unwrap();
        for cited in cited_documents(&text) {
            if !root().join(&cited).is_file() {
                missing.push(format!("{}: `{cited}`", source.display()));
            }
        }
    }
    assert!(missing.is_empty(), "cited documents not in the repository:\n{}", missing.join("\n"));
}
