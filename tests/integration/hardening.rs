//! Hostile input, one defect at a time: damaged headers, inputs that never end, outputs that cannot
//! be written. Every run is a separate process under a memory and time limit (`common`), so that a
//! reader that aborts or hangs fails its test instead of the test runner.

use crate::common;

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
    let run = run_limited(&["inspect", built.join("gd.dds").to_str().unwrap()], QUICK);
    assert_clean_error(&run, &["manifest.json", "folder"]);
}

/// `tmlut check DIR` with no budgets: every file against its manifest entry, nothing else.
fn check_consistency(dir: &std::path::Path, no_budgets: &std::path::Path) -> common::Run {
    run_limited(&["check", dir.to_str().unwrap(), "--budgets", no_budgets.to_str().unwrap()], QUICK)
}

/// A build of Karis and GD that takes about a second, so that two of them overlap.
const SLOW_KARIS_AND_GD: &str = "[karis]\nmu_count = 256\nroughness_count = 256\n[karis.sampling]\nsamples = 4096\n\
    replicates = 4\n[gd]\nmu_count = 64\nalpha_count = 64\n[gd.sampling]\nsamples = 1024\nreplicates = 4\n";

#[test]
fn concurrent_builds_into_one_folder_take_turns_and_keep_both_tables() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("slow.toml");
    std::fs::write(&config, SLOW_KARIS_AND_GD).unwrap();
    let out = dir.path().join("luts");
    let start = |only: &str| {
        std::process::Command::new(common::binary())
            .args(["build", "-q", "--config", config.to_str().unwrap(), "--out", out.to_str().unwrap()])
            .args(["--only", only])
            .stderr(std::process::Stdio::piped())
            .stdout(std::process::Stdio::null())
            .spawn()
            .unwrap()
    };
    let first = start("karis");
    std::thread::sleep(Duration::from_millis(100));
    let second = start("gd");
    let (first, second) = (first.wait_with_output().unwrap(), second.wait_with_output().unwrap());
    assert!(first.status.success() && second.status.success());
    let waited = String::from_utf8_lossy(&second.stderr);
    assert!(waited.contains("waiting for the build that holds"), "{waited}");

    let manifest = tmlut::loader::LutFolder::open(&out).unwrap().manifest().clone();
    let files: Vec<&str> = manifest.files.keys().map(String::as_str).collect();
    assert_eq!(files, ["gd.dds", "karis.dds", "karis.exr"]);
    let no_budgets = dir.path().join("none.toml");
    std::fs::write(&no_budgets, "").unwrap();
    let check = check_consistency(&out, &no_budgets);
    assert_eq!(check.ending, Ending::Success, "{}{}", check.stdout, check.stderr);
    let hidden: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(hidden.is_empty(), "{hidden:?}");
}

#[test]
fn a_staging_folder_is_removed_only_when_no_build_holds_the_folder() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("luts");
    // A build elsewhere (another PID namespace or host: its process id means nothing here) holds
    // the folder and stages into it.
    let holder = tmlut::commit::OutputFolder::take(&out, |_| {}).unwrap();
    let foreign = out.join(".tmlut-staging-4000000");
    std::fs::create_dir(&foreign).unwrap();
    std::fs::write(foreign.join("karis.dds"), b"staged").unwrap();

    let config = dir.path().join("small.toml");
    std::fs::write(&config, common::SMALL_SET).unwrap();
    let build = std::process::Command::new(common::binary())
        .args(["build", "-q", "--only", "gd", "--config", config.to_str().unwrap(), "--out", out.to_str().unwrap()])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(500));
    assert!(foreign.join("karis.dds").exists(), "a live build's staging folder was removed");
    assert!(!out.join("manifest.json").exists(), "a second build wrote while the folder was held");
    drop(holder);
    let output = build.wait_with_output().unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    assert!(String::from_utf8_lossy(&output.stderr).contains("waiting"));
    // Once the holder let go, its staging folder was provably abandoned, and removed.
    assert!(!foreign.exists());
}

#[test]
fn a_build_killed_at_any_moment_leaves_a_folder_that_check_trusts_or_refuses_and_the_next_build_repairs() {
    let dir = tempfile::tempdir().unwrap();
    let out = small_build(dir.path(), &[]);
    let no_budgets = dir.path().join("none.toml");
    std::fs::write(&no_budgets, "").unwrap();
    // The new build flips Karis's orientation and changes every seed: every file differs.
    let flipped = dir.path().join("flipped.toml");
    std::fs::write(
        &flipped,
        format!("seed = 99\n{}", common::SMALL_SET).replace("[karis]\n", "[karis]\norientation = \"smooth-first\"\n"),
    )
    .unwrap();
    let build_args = ["build", "-q", "--config", flipped.to_str().unwrap(), "--out", out.to_str().unwrap()];
    let mut outcomes = std::collections::BTreeMap::new();
    for delay_ms in (0..125).step_by(5) {
        let mut child = std::process::Command::new(common::binary())
            .args(build_args)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(delay_ms));
        let killed = child.try_wait().unwrap().is_none();
        let _ = child.kill(); // SIGKILL: no destructor runs
        child.wait().unwrap();
        let check = check_consistency(&out, &no_budgets);
        let state = match check.ending {
            Ending::Success => "consistent",
            Ending::CleanError if check.stdout.contains("FAIL .tmlut-commit.json: commit") => "journal",
            _ => panic!("killed after {delay_ms} ms: {}{}", check.stdout, check.stderr),
        };
        *outcomes.entry((killed, state)).or_insert(0) += 1;
        // The next build completes or discards what the killed one left.
        let output = std::process::Command::new(common::binary()).args(build_args).output().unwrap();
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        assert_eq!(check_consistency(&out, &no_budgets).ending, Ending::Success);
    }
    assert!(outcomes.keys().any(|(killed, _)| *killed), "{outcomes:?}");
    eprintln!("(killed, folder state) after each kill: {outcomes:?}");
}

#[test]
fn configurations_and_scenes_beyond_any_machine_are_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("luts");
    let out = out.to_str().unwrap();
    let cases: [(&str, &[&str]); 3] = [
        (
            "[fgd]\nmu_count = 16384\nalpha_count = 16384\neta_count = 16384\nkappa_count = 16384\npackings = []\n",
            &["fgd.mu_count, fgd.alpha_count, fgd.eta_count, fgd.kappa_count", "allowed: at most"],
        ),
        ("[gd.sampling]\nsamples = 4294967296\nreplicates = 4\n", &["gd.sampling.samples", "allowed: at most"]),
        ("[gd.sampling]\nsamples = 1024\nreplicates = 3\n", &["gd.sampling.replicates", "power of two"]),
    ];
    for (text, expected) in cases {
        let config = dir.path().join("config.toml");
        std::fs::write(&config, text).unwrap();
        let run =
            run_limited(&["build", "-q", "--only", "gd", "--config", config.to_str().unwrap(), "--out", out], QUICK);
        assert_clean_error(&run, expected);
    }
    let run = run_limited(&["build", "-q", "--only", "gd", "--threads", "100000", "--out", out], QUICK);
    assert_clean_error(&run, &["--threads", "100000", "allowed: 1 to 1024"]);
    assert!(!std::path::Path::new(out).exists(), "nothing is created for a refused build");

    let scene = dir.path().join("glaze.toml");
    std::fs::write(
        &scene,
        "[[material]]\nname = \"glaze\"\n[[material.layer]]\ntype = \"interface\"\nvary = { eta = [1.4, 1e20] }\nalpha = 0.1\n",
    )
    .unwrap();
    let run = run_limited(&["plan", scene.to_str().unwrap()], QUICK);
    assert_clean_error(&run, &["`glaze`", "layer 1: vary.eta", "1e20", "allowed: 0.01 to 100"]);
}

#[test]
fn count_options_beyond_any_machine_are_refused_naming_the_option_and_its_range() {
    // Each aborted (SIGABRT on the allocation, a capacity-overflow panic) or ran for ever before
    // it was bounded; every count option of every command is refused before anything is allocated.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    let scene = format!("{}/luts/scenes/copper-pot.toml", env!("CARGO_MANIFEST_DIR"));
    let huge = "18446744073709551615";
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["shader", &scene, "--luts", out, "--out", out, "--reference-views", "1000000000000"],
            "--reference-views",
        ),
        (vec!["shader", &scene, "--luts", out, "--out", out, "--reference-views", huge], "--reference-views"),
        (vec!["furnace", &scene, "--out", out, "--walk-min-paths", huge, "--walk-max-paths", huge], "--walk-min-paths"),
        (vec!["furnace", &scene, "--out", out, "--walk-max-paths", huge], "--walk-max-paths"),
        (vec!["furnace", &scene, "--out", out, "--views", huge], "--views"),
        (vec!["furnace", &scene, "--out", out, "--picture-size", huge], "--picture-size"),
        (vec!["furnace", &scene, "--out", out, "--exact-nodes", huge], "--exact-nodes"),
        (vec!["bench", "--only", "gd", "--reference-nodes", huge], "--reference-nodes"),
        (vec!["converge", "gd", "--out", out, "--samples-to", "4294967296"], "--samples-to"),
        (vec!["bench", "--only", "gd", "--nodes", huge], "--nodes"),
        (vec!["bench", "--only", "gd", "--repeats", huge], "--repeats"),
        (vec!["bench", "--only", "gd", "--per-cell-nodes", huge], "--per-cell-nodes"),
        (vec!["bench", "walk", "--paths", huge], "--paths"),
        (vec!["bench", "walk", "--repeats", huge], "--repeats"),
        (vec!["bench", "furnace", "--views", huge], "--views"),
        (vec!["bench", "furnace", "--max-paths", huge], "--max-paths"),
        (vec!["bench", "quadrature", "--samples", huge], "--samples"),
        (vec!["converge", "gd", "--out", out, "--cells", huge], "--cells"),
        (vec!["converge", "gd", "--out", out, "--nodes-from", "1"], "--nodes-from"),
        (vec!["converge", "gd", "--out", out, "--nodes-to", huge], "--nodes-to"),
        (vec!["converge", "gd", "--out", out, "--reference-nodes", huge], "--reference-nodes"),
        (vec!["fit", "--form", "luts/forms", "--out", out, "--starts", huge], "--starts"),
        (vec!["pack-report", "--points", huge], "--points"),
        (vec!["pack-report", "--reference-points", huge], "--reference-points"),
    ];
    for (args, option) in cases {
        let run = run_limited(&args, QUICK);
        assert_eq!(run.ending, common::Ending::CleanError, "{args:?}: {}{}", run.stdout, run.stderr);
        assert!(run.stderr.contains(option) && run.stderr.contains("allowed: "), "{args:?}: {}", run.stderr);
    }
    assert!(!std::path::Path::new(out).exists(), "nothing is created for a refused command");
}

#[test]
fn a_library_or_a_table_file_beyond_the_memory_limit_is_refused_before_it_is_allocated() {
    let dir = tempfile::tempdir().unwrap();
    // 5,000 generated materials need about 2.5 GiB of address space to build with their shader:
    // under the tests' 2 GiB the build is refused once planned, naming the limit, where it
    // aborted on an allocation after a minute.
    let library = dir.path().join("lib5000");
    let made = std::process::Command::new("python3")
        .arg(concat!(env!("CARGO_MANIFEST_DIR"), "/scripts/make-library"))
        .args(["5000", "1", library.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(made.status.success(), "{}", String::from_utf8_lossy(&made.stderr));
    let out = dir.path().join("out");
    let run = run_limited(
        &["build", "-q", "--scene", library.to_str().unwrap(), "--out", out.to_str().unwrap()],
        Duration::from_secs(120),
    );
    assert_clean_error(&run, &["5000 materials needs about", "address-space limit (ulimit -v)", "--shard"]);
    assert!(!out.exists(), "nothing is created for a refused build");

    // A table file of 1.5 GiB (sparse: no disk used) read and decoded needs three times that.
    let big = dir.path().join("big.dds");
    let mut file = std::fs::File::create(&big).unwrap();
    std::io::Write::write_all(&mut file, b"DDS ").unwrap();
    file.set_len(1536 << 20).unwrap();
    let run = run_limited(&["inspect", big.to_str().unwrap()], QUICK);
    assert_clean_error(&run, &["big.dds", "reading and decoding it needs about 4.5 GiB"]);
}

#[test]
fn a_link_planted_where_a_command_makes_its_own_folder_is_refused_not_followed() {
    let dir = tempfile::tempdir().unwrap();
    let victim = dir.path().join("victim");
    std::fs::create_dir(&victim).unwrap();
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    // `tmlut furnace` writes each scene into a folder of its name inside --out.
    std::os::unix::fs::symlink(&victim, out.join("copper-pot")).unwrap();
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/luts/scenes/copper-pot.toml");
    let run = run_limited(&["furnace", scene, "--walk", "none", "--out", out.to_str().unwrap()], QUICK);
    assert_clean_error(&run, &["copper-pot", "symbolic link", "never writes through a link"]);
    // `tmlut fit --form DIR` writes each form into a folder of its name.
    let built = small_build(dir.path(), &["--only", "karis"]);
    std::os::unix::fs::symlink(&victim, out.join("karis_env_brdf_approx")).unwrap();
    let form = concat!(env!("CARGO_MANIFEST_DIR"), "/luts/forms/karis-env-brdf-approx.toml");
    let forms = dir.path().join("forms");
    std::fs::create_dir(&forms).unwrap();
    std::fs::copy(form, forms.join("karis-env-brdf-approx.toml")).unwrap();
    let table = built.join("karis.dds");
    let run = run_limited(
        &["fit", "--form", forms.to_str().unwrap(), "--table", table.to_str().unwrap(), "--out", out.to_str().unwrap()],
        QUICK,
    );
    assert_clean_error(&run, &["karis_env_brdf_approx", "symbolic link"]);
    assert_eq!(std::fs::read_dir(&victim).unwrap().count(), 0, "nothing was written through a link");
}
