//! `tmlut inspect`: the conventions of each file printed, and damaged or foreign files refused.

use super::{assert_clean_failure, build, stderr, stdout, tmlut, write_config};

use crate::common::SMALL_SET;

#[test]
fn inspect_prints_the_conventions_of_each_file() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let out = dir.path().join("luts");
    assert!(build(&config, &out, &[]).status.success());
    for file in ["karis.dds", "karis.exr"] {
        let output = tmlut(&["inspect", out.join(file).to_str().unwrap()]);
        assert!(output.status.success(), "{}", stderr(&output));
        let text = stdout(&output);
        for expected in [
            "table:    karis",
            "mu",
            "cell-centred",
            "spaced in sqrt(alpha)",
            "texture coordinate = sqrt(alpha)",
            "Row 0 (the first row in memory) = roughness 0",
            "float2(NoV, roughness)",
            "not sRGB",
            "masking:  schlick-smith",
            "NaN 0",
            "matches the manifest",
        ] {
            assert!(text.contains(expected), "{file}: expected `{expected}` in:\n{text}");
        }
    }
    let dds = stdout(&tmlut(&["inspect", out.join("karis.dds").to_str().unwrap()]));
    assert!(dds.contains("R16G16_FLOAT, 2D texture 32 x 24, 1 mip level"), "{dds}");
}

#[test]
fn the_shipped_original_tables_inspect_cleanly() {
    let gd = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/tmblm/tm_GD.bin");
    let output = tmlut(&["inspect", gd]);
    assert!(output.status.success(), "{}", stderr(&output));
    let text = stdout(&output);
    assert!(text.contains("64 nodes over [0, 1], node-aligned"), "{text}");
    assert!(text.contains("NaN 0"), "{text}");
    assert!(text.contains("(x0) * 63 / 64 + 0.5 / 64"), "{text}");
}

#[test]
fn inspect_refuses_truncated_foreign_and_missing_files() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let out = dir.path().join("luts");
    assert!(build(&config, &out, &[]).status.success());

    let dds = std::fs::read(out.join("karis.dds")).unwrap();
    let truncated = dir.path().join("truncated.dds");
    std::fs::write(&truncated, &dds[..dds.len() / 2]).unwrap();
    assert_clean_failure(&tmlut(&["inspect", truncated.to_str().unwrap()]), &["truncated.dds", "truncated"]);

    let exr = std::fs::read(out.join("karis.exr")).unwrap();
    let truncated = dir.path().join("truncated.exr");
    std::fs::write(&truncated, &exr[..exr.len() / 3]).unwrap();
    assert_clean_failure(&tmlut(&["inspect", truncated.to_str().unwrap()]), &["truncated.exr"]);

    let foreign = dir.path().join("notes.txt");
    std::fs::write(&foreign, b"hello, not a table").unwrap();
    assert_clean_failure(&tmlut(&["inspect", foreign.to_str().unwrap()]), &["notes.txt", "not a table"]);

    let foreign_bin = dir.path().join("random.bin");
    std::fs::write(&foreign_bin, vec![7u8; 1000]).unwrap();
    assert_clean_failure(&tmlut(&["inspect", foreign_bin.to_str().unwrap()]), &["random.bin"]);

    assert_clean_failure(&tmlut(&["inspect", dir.path().join("absent.dds").to_str().unwrap()]), &["absent.dds"]);
}
