//! `tmlut audit`: a shipped table measured against exact integrals, with the exit status of
//! `check` and files only inside `--out`.

use std::process::Command;

use super::{snapshot, stderr, stdout, tmlut};

#[test]
fn audit_of_tmlut_s_own_threejs_file_measures_rounding_writes_only_into_out_and_keeps_check_s_statuses() {
    let work = tempfile::tempdir().unwrap();
    let build = work.path().join("build");
    let output = tmlut(&["build", "--quiet", "--preset", "threejs", "--out", build.to_str().unwrap()]);
    assert!(output.status.success(), "{}", stderr(&output));
    let js = build.join("DFGLUTData.js");
    let before = snapshot(&build);

    // Run from a folder of its own: nothing may land in the working directory either.
    let cwd = work.path().join("cwd");
    std::fs::create_dir(&cwd).unwrap();
    let report = work.path().join("report");
    let output = Command::new(env!("CARGO_BIN_EXE_tmlut"))
        .current_dir(&cwd)
        .args(["audit", js.to_str().unwrap(), "--preset", "threejs", "--json", "--quiet"])
        .args(["--out", report.to_str().unwrap(), "--budget", "1e-3"])
        .output()
        .unwrap();
    assert_eq!(output.status.code(), Some(0), "{}", stderr(&output));
    let json: serde_json::Value = serde_json::from_str(&stdout(&output)).expect("--json prints JSON");
    assert_eq!(json["status"], "measured");
    let audit = &json["audit"];
    assert_eq!(audit["causes"][0]["kind"], "half-float-rounding", "{audit}");
    for channel in audit["channels"].as_array().unwrap() {
        let max = channel["max"].as_f64().unwrap();
        assert!(max > 0.0 && max < 2.5e-4, "{channel}");
        assert!(channel["max_at"]["n_dot_v"].is_f64(), "{channel}");
    }
    let mut written: Vec<String> =
        std::fs::read_dir(&report).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    written.sort();
    assert_eq!(written, ["audit.json", "audit_bias.png", "audit_scale.png"]);
    let saved: serde_json::Value = serde_json::from_slice(&std::fs::read(report.join("audit.json")).unwrap()).unwrap();
    assert_eq!(saved["audit"]["channels"], audit["channels"]);
    assert!(std::fs::read_dir(&cwd).unwrap().next().is_none(), "audit wrote into its working directory");
    assert_eq!(snapshot(&build), before, "audit changed the folder it read from");

    // Over the budget: 1; the lines name the cause.
    let output = tmlut(&["audit", js.to_str().unwrap(), "--preset", "threejs", "--quiet", "--budget", "1e-6"]);
    assert_eq!(output.status.code(), Some(1), "{}", stderr(&output));
    assert!(stdout(&output).contains("cause: half-float rounding"), "{}", stdout(&output));
    assert!(stderr(&output).contains("over the budget"), "{}", stderr(&output));
}

#[test]
fn audit_refuses_what_it_cannot_read_with_status_2() {
    let work = tempfile::tempdir().unwrap();
    let short = work.path().join("DFGLUTData.js");
    std::fs::write(&short, "const DATA = new Uint16Array( [ 0x3c00, 0x0000 ] );\n").unwrap();
    let output = tmlut(&["audit", short.to_str().unwrap(), "--preset", "threejs", "--json"]);
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(stderr(&output).contains("DATA holds 2 half floats; expected 16 x 16 x 2 = 512"), "{}", stderr(&output));
    let json: serde_json::Value = serde_json::from_str(&stdout(&output)).unwrap();
    assert_eq!(json["status"], "error");

    let output = tmlut(&["audit", short.to_str().unwrap(), "--preset", "unreal"]);
    assert_eq!(output.status.code(), Some(2));
    assert!(stderr(&output).contains("unknown preset `unreal`; known presets: threejs"), "{}", stderr(&output));

    let missing = work.path().join("missing.js");
    let report = work.path().join("report");
    let output = tmlut(&["audit", missing.to_str().unwrap(), "--preset", "threejs", "--out", report.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(2));
    assert!(stderr(&output).contains("missing.js"), "{}", stderr(&output));
    assert!(!report.exists(), "a failed audit made its --out folder");
}
