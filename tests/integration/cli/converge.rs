//! `tmlut converge`: a target error answered, and a bad one refused.

use std::path::Path;

use super::{assert_clean_failure, stderr, stdout, tmlut, write_config};

#[test]
fn converge_answers_a_target_error_and_refuses_a_bad_one() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), "[gd]\nmu_count = 8\nalpha_count = 8\n");
    let out = dir.path().join("reports");
    let (config, out) = (config.to_str().unwrap(), out.to_str().unwrap());
    let sweep = ["converge", "gd", "-q", "--config", config, "--out", out, "--samples-from", "256"];
    let small = ["--samples-to", "1024", "--cells", "4", "--nodes-to", "4", "--reference-nodes", "32"];
    for bad in ["0", "-1e-4", "NaN", "abc"] {
        let output = tmlut(&[&sweep[..], &small, &["--target-error", bad]].concat());
        assert_clean_failure(&output, &["--target-error", "allowed: a positive, finite RMS error"]);
    }
    assert!(!Path::new(out).exists(), "nothing is written for a refused target");
    // Far below what 1024 samples reach: extrapolated, and said so, for both methods.
    let output = tmlut(&[&sweep[..], &small, &["--target-error", "1e-7"]].concat());
    assert!(output.status.success(), "{}", stderr(&output));
    let text = stdout(&output);
    for method in ["fast", "per-cell"] {
        let line = text.lines().find(|l| l.starts_with(&format!("{method}: RMS error <= 1e-7"))).unwrap_or("");
        assert!(line.contains("EXTRAPOLATED") && line.contains("predicted wall time"), "{text}");
    }
    let json = std::fs::read_to_string(Path::new(out).join("converge_gd.json")).unwrap();
    assert!(json.contains("\"status\": \"extrapolated\""), "{json}");
    assert!(Path::new(out).join("converge_gd.png").exists() && Path::new(out).join("converge_gd.csv").exists());
}
