//! Hostile input, one defect at a time: damaged headers, inputs that never end, outputs that cannot
//! be written. Every run is a separate process under a memory and time limit (`common`), so that a
//! reader that aborts or hangs fails its test instead of the test runner.

mod common;

use std::time::Duration;

use common::{Ending, run_limited, small_build};

const QUICK: Duration = Duration::from_secs(20);

/// `run` must end in a clean error naming `names`.
fn assert_clean_error(run: &common::Run, names: &[&str]) {
    assert_eq!(run.ending, Ending::CleanError, "stdout: {}\nstderr: {}", run.stdout, run.stderr);
    for name in names {
        assert!(run.stderr.contains(name), "expected `{name}` in: {}", run.stderr);
    }
}

#[test]
fn a_damaged_exr_size_field_is_refused_before_anything_is_allocated() {
    let dir = tempfile::tempdir().unwrap();
    let out = small_build(dir.path(), &["--only", "karis"]);
    let original = std::fs::read(out.join("karis.exr")).unwrap();
    let marker = b"dataWindow\0box2i\0";
    let window = original.windows(marker.len()).position(|w| w == marker).unwrap() + marker.len() + 4;
    let no_budgets = dir.path().join("none.toml");
    std::fs::write(&no_budgets, "").unwrap();
    // Each byte of the data window's four int32 (x_min, y_min, x_max, y_max), set to values that
    // make the claimed image up to 2^62 bytes; 0x10 in the top byte of x_min was the 12 GiB abort.
    for offset in 0..16 {
        for value in [0x10u8, 0x7f, 0x80, 0xff] {
            let mut bytes = original.clone();
            bytes[window + offset] = value;
            if bytes == original {
                continue;
            }
            std::fs::write(out.join("karis.exr"), &bytes).unwrap();
            let path = out.join("karis.exr");
            let inspect = run_limited(&["inspect", path.to_str().unwrap()], QUICK);
            assert_clean_error(&inspect, &["karis.exr"]);
            let check =
                run_limited(&["check", out.to_str().unwrap(), "--budgets", no_budgets.to_str().unwrap()], QUICK);
            assert_eq!(check.ending, Ending::CleanError, "byte {offset} = {value:#x}: {}", check.stderr);
            assert!(check.stdout.contains("FAIL karis.exr: sha256"), "{}", check.stdout);
            // The rest of the folder is still checked.
            assert!(check.stdout.contains("ok   karis.dds: sha256"), "{}", check.stdout);
        }
    }
}

#[test]
fn inputs_that_never_end_or_are_not_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("luts");
    let out = out.to_str().unwrap();
    let run = run_limited(&["build", "-q", "--config", "/dev/urandom", "--out", out], QUICK);
    assert_clean_error(&run, &["/dev/urandom", "regular file"]);
    let run = run_limited(&["plan", "/dev/zero"], QUICK);
    assert_clean_error(&run, &["/dev/zero", "regular file"]);
    let run = run_limited(&["build", "-q", "--config", dir.path().to_str().unwrap(), "--out", out], QUICK);
    assert_clean_error(&run, &["a folder"]);

    // A budgets file, and a configuration, larger than any honest one.
    let huge = dir.path().join("huge.toml");
    let file = std::fs::File::create(&huge).unwrap();
    file.set_len(64 << 20).unwrap();
    let run = run_limited(&["build", "-q", "--config", huge.to_str().unwrap(), "--out", out], QUICK);
    assert_clean_error(&run, &["huge.toml", "at most"]);

    let built = small_build(dir.path(), &["--only", "gd"]);
    let run = run_limited(&["check", built.to_str().unwrap(), "--budgets", "/dev/urandom"], QUICK);
    assert_clean_error(&run, &["/dev/urandom"]);
    // A manifest that is a folder.
    std::fs::remove_file(built.join("manifest.json")).unwrap();
    std::fs::create_dir(built.join("manifest.json")).unwrap();
    let run = run_limited(&["inspect", built.join("gd.bin").to_str().unwrap()], QUICK);
    assert_clean_error(&run, &["manifest.json", "folder"]);
}
