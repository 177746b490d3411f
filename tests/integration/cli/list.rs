//! `tmlut list`: the names of the tables and presets.

use super::{stdout, tmlut};

#[test]
fn list_names_every_table() {
    let output = tmlut(&["list"]);
    assert!(output.status.success());
    for table in ["fgd", "gd", "tir", "belcour", "karis", "fgd_rarer", "ggx_e", "ggx_e_avg", "karis_multiscatter"] {
        assert!(stdout(&output).contains(table), "{}", stdout(&output));
    }
}

#[test]
fn list_names_the_presets_and_build_refuses_an_unknown_one_naming_them() {
    let output = tmlut(&["list"]);
    assert!(stdout(&output).contains("threejs"), "{}", stdout(&output));
    let out = tempfile::tempdir().unwrap();
    let output = tmlut(&["build", "--preset", "threejs-r200", "--out", out.path().to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        !output.status.success() && stderr.contains("unknown preset `threejs-r200`; known presets: threejs"),
        "{stderr}"
    );
    assert!(!out.path().join("manifest.json").exists());
}
