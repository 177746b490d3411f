//! The loader's test folder, `testdata/luts`: a table of each kind in the containers and
//! precisions a build writes, their KTX2 twins and a texture array in DDS, KTX2 and OpenEXR, with
//! their manifest, written by tmlut's writers (whose tests hold them to these bytes). The reading
//! tests read them and the bytes cut or edited from them.

use std::path::{Path, PathBuf};

use crate::formats::manifest::{FileEntry, MANIFEST_FILE, Manifest};
use crate::table::Axis;

/// The folder, inside this crate.
pub(crate) fn test_folder() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata/luts")
}

/// The bytes of `file` of the test folder.
pub(crate) fn test_file(file: &str) -> Vec<u8> {
    std::fs::read(test_folder().join(file)).unwrap()
}

/// The test folder's manifest entry of `file`.
pub(crate) fn test_entry(file: &str) -> FileEntry {
    Manifest::read(&test_folder().join(MANIFEST_FILE)).unwrap().files[file].clone()
}

/// The axes the test folder's manifest states for `file`.
pub(crate) fn test_axes(file: &str) -> Vec<Axis> {
    test_entry(file).axes.into_iter().map(|entry| entry.axis).collect()
}

/// A copy of the test folder in a temporary folder, to change.
pub(crate) fn copy_of_test_folder() -> tempfile::TempDir {
    let copy = tempfile::tempdir().unwrap();
    for entry in std::fs::read_dir(test_folder()).unwrap() {
        let entry = entry.unwrap();
        std::fs::copy(entry.path(), copy.path().join(entry.file_name())).unwrap();
    }
    copy
}
