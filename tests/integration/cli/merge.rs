//! `tmlut merge`: shards of a build merged into the files of one build, a missing or damaged shard
//! refused (and `tmlut cache --verify` over a shard).

use std::path::{Path, PathBuf};

use super::{
    assert_clean_failure, build, scene_path, small_set_written_as, snapshot, stderr, stdout, tmlut, write_config,
};
use crate::common;

use common::SMALL_SET;
use tmlut::formats::manifest::MANIFEST_FILE;

/// A manifest's JSON without its wall times, the one thing two builds of a folder may differ in.
fn manifest_without_wall_times(dir: &Path) -> serde_json::Value {
    fn strip(value: &mut serde_json::Value) {
        match value {
            serde_json::Value::Object(map) => {
                map.remove("wall_time_s");
                map.values_mut().for_each(strip);
            }
            serde_json::Value::Array(items) => items.iter_mut().for_each(strip),
            _ => {}
        }
    }
    let mut value: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join(MANIFEST_FILE)).unwrap()).unwrap();
    strip(&mut value);
    value
}

/// The largest slice entry of a cache folder (a table's values make up most of an entry).
fn largest_entry(dir: &Path) -> PathBuf {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "slice"))
        .max_by_key(|p| (std::fs::metadata(p).unwrap().len(), p.clone()))
        .unwrap()
}

/// Edit a cache entry as someone with write access to the folder can: every value raised by
/// `by`, the marker line's SHA-256 recomputed.
fn reseal_raising_values(entry: &Path, by: f64) {
    let (line, mut body) = common::entry_parts(&std::fs::read(entry).unwrap());
    for v in body["values"].as_array_mut().unwrap() {
        *v = serde_json::json!(v.as_f64().unwrap() + by);
    }
    std::fs::write(entry, common::resealed(&line, &body)).unwrap();
}

#[test]
fn shards_merged_give_the_files_of_one_build_and_a_missing_or_damaged_shard_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let scenes = [scene_path("copper-pot"), scene_path("gpu-check/varied-coats"), scene_path("gpu-check/stiff-stacks")];
    let mut scene_args: Vec<&str> = Vec::new();
    for scene in &scenes {
        scene_args.extend(["--scene", scene.as_str()]);
    }
    let whole = dir.path().join("whole");
    let output = build(&config, &whole, &scene_args);
    assert!(output.status.success(), "{}", stderr(&output));
    let shard_dirs: Vec<PathBuf> = (1..=3).map(|i| dir.path().join(format!("shard{i}"))).collect();
    for (i, shard) in shard_dirs.iter().enumerate() {
        let mut args = scene_args.clone();
        let part = format!("{}/3", i + 1);
        args.extend(["--shard", &part, "--cache", shard.to_str().unwrap()]);
        let output = build(&config, &dir.path().join("unused"), &args);
        assert!(output.status.success(), "{}", stderr(&output));
    }
    // A shard writes only into its own folder, and fails where it cannot.
    assert!(!dir.path().join("unused").exists());
    let not_a_folder = dir.path().join("a-file");
    std::fs::write(&not_a_folder, "x").unwrap();
    let mut args = scene_args.clone();
    args.extend(["--shard", "1/3", "--cache", not_a_folder.to_str().unwrap()]);
    assert_clean_failure(
        &build(&config, &dir.path().join("unused"), &args),
        &["--shard", "the shard's folder is incomplete"],
    );
    let merge_as = |config: &Path, shards: &[PathBuf], out: &Path| {
        let mut args = vec!["merge", "--quiet", "--config", config.to_str().unwrap(), "--out", out.to_str().unwrap()];
        args.extend(scene_args.iter().copied());
        args.extend(shards.iter().map(|s| s.to_str().unwrap()));
        tmlut(&args)
    };
    let merge = |shards: &[PathBuf], out: &Path| merge_as(&config, shards, out);
    // Every file byte for byte, the manifest apart from wall times.
    let assert_same_files = |whole: &Path, merged: &Path| {
        let (a, b) = (snapshot(whole), snapshot(merged));
        let names = |files: &[(String, Vec<u8>)]| files.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
        assert_eq!(names(&a), names(&b));
        for ((name, x), (_, y)) in a.iter().zip(&b) {
            if name != MANIFEST_FILE {
                assert!(x == y, "{name} differs");
            }
        }
        assert_eq!(manifest_without_wall_times(whole), manifest_without_wall_times(merged));
    };
    let merged = dir.path().join("merged");
    let output = merge(&shard_dirs, &merged);
    assert!(output.status.success(), "{}", stderr(&output));
    assert_same_files(&whole, &merged);
    // The shards hold what was integrated, not files: merged in another container and precision,
    // they give the files of one build written so.
    let ktx2_f16 = dir.path().join("ktx2-f16.toml");
    std::fs::write(&ktx2_f16, small_set_written_as("ktx2", "f16")).unwrap();
    let whole_ktx2_f16 = dir.path().join("whole-ktx2-f16");
    let output = build(&ktx2_f16, &whole_ktx2_f16, &scene_args);
    assert!(output.status.success(), "{}", stderr(&output));
    let merged_ktx2_f16 = dir.path().join("merged-ktx2-f16");
    let output = merge_as(&ktx2_f16, &shard_dirs, &merged_ktx2_f16);
    assert!(output.status.success(), "{}", stderr(&output));
    assert_same_files(&whole_ktx2_f16, &merged_ktx2_f16);

    // Without one shard, the merge names the missing part and writes nothing.
    let incomplete = dir.path().join("incomplete");
    let output = merge(&shard_dirs[..2], &incomplete);
    assert_clean_failure(&output, &["shard(s) 3/3 of this library", "--shard I/N"]);
    assert!(!incomplete.join(MANIFEST_FILE).exists());
    // Shards of a library of three scenes are not those of one of them, though they hold its tables.
    let mut one_scene = vec!["merge", "--quiet", "--config", config.to_str().unwrap(), "--scene", scenes[0].as_str()];
    let other_library = dir.path().join("other-library");
    one_scene.extend(["--out", other_library.to_str().unwrap()]);
    one_scene.extend(shard_dirs.iter().map(|s| s.to_str().unwrap()));
    assert_clean_failure(&tmlut(&one_scene), &["no shard of this library", "the shards were built with"]);
    assert!(!other_library.exists());
    // An entry re-sealed around other values (its hash line recomputed) is refused by the values
    // themselves, naming it: every value raised, so that whichever nodes are drawn disagree.
    let resealed = dir.path().join("resealed");
    std::fs::create_dir(&resealed).unwrap();
    for shard in &shard_dirs {
        let copy = resealed.join(shard.file_name().unwrap());
        std::fs::create_dir(&copy).unwrap();
        for file in std::fs::read_dir(shard).unwrap().flatten() {
            std::fs::copy(file.path(), copy.join(file.file_name())).unwrap();
        }
    }
    let resealed_dirs: Vec<PathBuf> = shard_dirs.iter().map(|s| resealed.join(s.file_name().unwrap())).collect();
    let entry = largest_entry(&resealed_dirs[0]);
    reseal_raising_values(&entry, 0.25);
    let output = merge(&resealed_dirs, &dir.path().join("poisoned"));
    assert_clean_failure(&output, &[entry.file_name().unwrap().to_str().unwrap(), "exact integral"]);
    assert!(!dir.path().join("poisoned").join(MANIFEST_FILE).exists());
    // The full audit integrates every entry again: an intact folder is the same to the bit, the
    // edited one is named.
    let verify = |folder: &Path| tmlut(&["cache", "--quiet", "--verify", "--dir", folder.to_str().unwrap()]);
    let output = verify(&shard_dirs[1]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(stdout(&output).contains("0 refused"), "{}", stdout(&output));
    let output = verify(&resealed_dirs[0]);
    assert_clean_failure(&output, &["tmlut cache --verify", "1 entries"]);
    assert!(stderr(&output).contains(entry.file_name().unwrap().to_str().unwrap()), "{}", stderr(&output));
    // A damaged entry is refused, naming its file, rather than built again.
    let entry = std::fs::read_dir(&shard_dirs[0])
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .find(|p| p.extension().is_some_and(|e| e == "slice"))
        .unwrap();
    let mut bytes = std::fs::read(&entry).unwrap();
    let last = bytes.len() - 2;
    bytes[last] ^= 1;
    std::fs::write(&entry, bytes).unwrap();
    let output = merge(&shard_dirs, &dir.path().join("damaged"));
    assert_clean_failure(&output, &[entry.file_name().unwrap().to_str().unwrap(), "damaged shard entry"]);
}
