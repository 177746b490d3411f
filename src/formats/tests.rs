//! The writers against the loader's test folder (`crates/loader/testdata/luts`), whose files the
//! loader's reading tests read: every table, written again from what the loader reads of it,
//! gives its file's bytes, and the manifest its own.
//!
//! Where a container's bytes change on purpose, `TMLUT_WRITE_TEST_FOLDER=1 cargo test -p tmlut
//! --lib formats::tests` writes the folder anew: each file from its table, its entry's length and
//! SHA-256, and the manifest.

use std::path::{Path, PathBuf};

use super::manifest::{MANIFEST_FILE, write_manifest};
use super::*;
use crate::loader::LutFolder;

fn test_folder() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("crates/loader/testdata/luts")
}

#[test]
fn the_writers_write_the_loaders_test_folder_byte_for_byte() {
    let folder = LutFolder::open(test_folder()).unwrap();
    let written = tempfile::tempdir().unwrap();
    let mut manifest = folder.manifest().clone();
    for (file, entry) in manifest.files.iter_mut() {
        let table = folder.load(file).unwrap();
        write_table(&written.path().join(file), &table, entry.format, entry.precision).unwrap();
        let bytes = std::fs::read(written.path().join(file)).unwrap();
        (entry.bytes, entry.sha256) = (bytes.len() as u64, sha256_hex(&bytes));
    }
    write_manifest(&manifest, written.path()).unwrap();
    if std::env::var_os("TMLUT_WRITE_TEST_FOLDER").is_some() {
        for file in manifest.files.keys().map(String::as_str).chain([MANIFEST_FILE]) {
            std::fs::copy(written.path().join(file), test_folder().join(file)).unwrap();
        }
    }
    assert!(manifest.files.len() > 10, "{} files", manifest.files.len());
    let differ: Vec<&str> = manifest
        .files
        .keys()
        .map(String::as_str)
        .chain([MANIFEST_FILE])
        .filter(|file| {
            std::fs::read(written.path().join(file)).unwrap() != std::fs::read(test_folder().join(file)).unwrap()
        })
        .collect();
    assert!(differ.is_empty(), "written anew, these differ from the test folder's: {differ:?}");
}
