//! End-to-end tests of the `tmlut` command: what a user runs, what lands on disk, and how bad
//! input is refused.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use crate::common;

use common::SMALL_SET;
use tmlut::formats::manifest::{MANIFEST_FILE, Manifest};
use tmlut::loader::LutFolder;

fn tmlut(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tmlut")).args(args).output().expect("the tmlut binary runs")
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

fn stdout(output: &Output) -> String {
    String::from_utf8_lossy(&output.stdout).into_owned()
}

fn write_config(dir: &Path, text: &str) -> PathBuf {
    let path = dir.join("config.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn build(config: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["build", "--quiet", "--config", config.to_str().unwrap(), "--out", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    tmlut(&args)
}

/// Every file of a folder with its bytes, sorted by name.
fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| (e.file_name().to_string_lossy().into_owned(), std::fs::read(e.path()).unwrap_or_default()))
        .collect();
    files.sort();
    files
}

fn assert_clean_failure(output: &Output, expected: &[&str]) {
    let err = stderr(output);
    assert_eq!(output.status.code(), Some(1), "exit status {:?}; stderr: {err}", output.status);
    assert!(err.starts_with("error: "), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    for e in expected {
        assert!(err.contains(e), "expected `{e}` in: {err}");
    }
}

#[test]
fn build_writes_dds_exr_and_a_manifest_that_a_renderer_can_load() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let out = dir.path().join("luts");
    let output = build(&config, &out, &["--only", "karis"]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(stdout(&output).contains("karis.dds"), "{}", stdout(&output));

    let manifest = Manifest::read(&out.join(MANIFEST_FILE)).unwrap();
    let dds = manifest.entry("karis.dds").expect("karis.dds in the manifest");
    assert_eq!(dds.dxgi_format.as_deref(), Some("R16G16_FLOAT"));
    assert_eq!(dds.masking.as_deref(), Some("schlick-smith"));
    assert_eq!(dds.axes.len(), 2);
    assert_eq!((dds.axes[0].axis.name.as_str(), dds.axes[0].stored_along.as_str()), ("mu", "x"));
    assert_eq!((dds.axes[1].axis.start, dds.axes[1].axis.end), (0.0, 1.0), "row 0 = roughness 0");
    assert_eq!(dds.samples_per_cell, 256);
    assert_eq!(dds.nan_count, 0);
    let reference = dds.error.integration.reference.as_ref().expect("a reference comparison");
    assert_eq!(reference.difference.count, 12, "6 cells x 2 channels");
    let bytes = std::fs::read(out.join("karis.dds")).unwrap();
    assert_eq!(dds.sha256, tmlut::pipeline::sha256_hex(&bytes));
    assert_eq!(dds.bytes, bytes.len() as u64);
    assert!(manifest.entry("karis.exr").is_some());
    assert!(manifest.entry("fgd.exr").is_none(), "--only karis built only karis");

    // The loader reads both files back to the same f16 values, with the manifest's axes.
    let folder = LutFolder::open(&out).unwrap();
    let from_dds = folder.load("karis.dds").unwrap();
    let from_exr = folder.load("karis.exr").unwrap();
    assert_eq!(from_dds.data, from_exr.data);
    assert_eq!(from_dds.axes, from_exr.axes);
    assert_eq!(from_dds.shape(), vec![32, 24]);
    let node = from_dds.node_position(&[5, 7]);
    let interpolated = from_dds.interpolate(&node);
    assert!((interpolated[0] - from_dds.node(&[5, 7])[0] as f64).abs() < 1e-6);
    // And no staging folder is left behind.
    assert!(
        snapshot(&out).iter().all(|(name, _)| !name.starts_with('.')),
        "{:?}",
        snapshot(&out).iter().map(|f| &f.0).collect::<Vec<_>>()
    );
}

#[test]
fn ktx2_is_written_beside_dds_for_tables_and_packings_and_reads_back_the_same() {
    use tmlut::loader::TirLut;
    use tmlut::model::folder::{FgdSource, FolderTables};
    use tmlut::model::{AlbedoPath, Lookup, Tables, TirPath};

    let dir = tempfile::tempdir().unwrap();
    let text = SMALL_SET.replacen("[fgd]\n", "[fgd]\npacking_formats = [\"dds\", \"ktx2\"]\n", 1)
        + "[karis.output]\nformats = [\"dds\", \"ktx2\"]\nprecision = \"f16\"\n"
        + "[tir.output]\nformats = [\"ktx2\"]\nprecision = \"f32\"\n";
    let config = write_config(dir.path(), &text);
    let out = dir.path().join("luts");
    let output = build(&config, &out, &["--only", "fgd,tir,karis"]);
    assert!(output.status.success(), "{}", stderr(&output));

    let manifest = Manifest::read(&out.join(MANIFEST_FILE)).unwrap();
    let karis = manifest.entry("karis.ktx2").expect("karis.ktx2 in the manifest");
    assert_eq!((karis.vk_format.as_deref(), karis.dxgi_format.as_deref()), (Some("R16G16_SFLOAT"), None));
    let binding = karis.binding.as_ref().expect("a binding");
    assert!(binding.texture.contains("VK_FORMAT_R16G16_SFLOAT, WebGPU rg16float"), "{}", binding.texture);
    let (packed_dds, packed_ktx2) =
        (manifest.entry("fgd_lossless.dds").unwrap(), manifest.entry("fgd_lossless.ktx2").unwrap());
    assert_eq!(packed_ktx2.packing, packed_dds.packing, "one packing, its shaders listed by both textures");
    assert_eq!(packed_ktx2.error.interpolation, packed_dds.error.interpolation);
    assert_eq!(packed_ktx2.vk_format.as_deref(), Some("R32_SFLOAT"));
    assert!(manifest.entry("tir.ktx2").is_some() && manifest.entry("tir.dds").is_none());

    // Written, then read back: the same table as its DDS twin (f16 values for Karis).
    let folder = LutFolder::open(&out).unwrap();
    assert_eq!(folder.load("karis.ktx2").unwrap(), folder.load("karis.dds").unwrap());
    assert_eq!(folder.load("fgd_lossless.ktx2").unwrap(), folder.load("fgd_lossless.dds").unwrap());
    assert_eq!(TirLut::from_folder(&folder).unwrap().entry().unwrap().vk_format.as_deref(), Some("R32_SFLOAT"));

    // The model reads the packing from either file alike.
    let lookups: Vec<Lookup> = [(0.1, 0.02, 1.5, 0.0), (0.7, 0.3, 0.4, 2.0), (1.0, 0.9, 3.1, 0.5)]
        .into_iter()
        .map(|(mu, alpha, eta, kappa)| albedo_lookup(mu, alpha, eta, kappa))
        .collect();
    let open =
        |folder: &LutFolder| FolderTables::open(folder, AlbedoPath::Fgd, TirPath::Table, FgdSource::Packing).unwrap();
    let from_dds: Vec<f64> = lookups.iter().map(|l| open(&folder).value(l)).collect();
    let mut without_dds = manifest.clone();
    without_dds.files.remove("fgd_lossless.dds");
    without_dds.write(&out).unwrap();
    std::fs::remove_file(out.join("fgd_lossless.dds")).unwrap();
    let only_ktx2 = LutFolder::open(&out).unwrap();
    let from_ktx2: Vec<f64> = lookups.iter().map(|l| open(&only_ktx2).value(l)).collect();
    assert_eq!(from_ktx2, from_dds);

    let inspected = tmlut(&["inspect", out.join("karis.ktx2").to_str().unwrap()]);
    assert!(inspected.status.success(), "{}", stderr(&inspected));
    let text = stdout(&inspected);
    for expected in
        ["VK_FORMAT_R16G16_SFLOAT, 2D texture 32 x 24", "texture coordinate = sqrt(alpha)", "matches the manifest"]
    {
        assert!(text.contains(expected), "expected `{expected}` in:\n{text}");
    }
    let budgets = dir.path().join("budgets.toml");
    std::fs::write(&budgets, "").unwrap();
    let checked = tmlut(&["check", out.to_str().unwrap(), "--budgets", budgets.to_str().unwrap()]);
    assert!(checked.status.success(), "{}", stdout(&checked));
    assert!(stdout(&checked).contains("ok   fgd_lossless.ktx2: manifest agrees with the file"), "{}", stdout(&checked));
}

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
fn same_seed_gives_identical_files_whatever_the_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let one = dir.path().join("one");
    let two = dir.path().join("two");
    assert!(build(&config, &one, &["--threads", "1"]).status.success());
    assert!(build(&config, &two, &["--threads", "2"]).status.success());
    assert_eq!(
        snapshot(&one).iter().map(|f| f.0.as_str()).collect::<Vec<_>>(),
        [
            "belcour.dds",
            "belcour.exr",
            "fgd.exr",
            "fgd_lossless.dds",
            "fgd_lossless.hlsl",
            "fgd_lossless.wgsl",
            "fgd_rarer.dds",
            "gd.dds",
            "karis.dds",
            "karis.exr",
            "manifest.json",
            "tir.dds",
            // The default build's fit of the TIR table (`[tir] fit = "best"`).
            "tir_fit.hlsl",
            "tir_fit.wgsl"
        ]
    );
    // Every WGSL file of a build is valid WebGPU shader code (naga).
    assert_eq!(common::validate_wgsl_files(&one), 2);
    let (a, b) = (snapshot(&one), snapshot(&two));
    for ((name_a, bytes_a), (name_b, bytes_b)) in a.iter().zip(&b) {
        assert_eq!(name_a, name_b);
        if name_a != MANIFEST_FILE {
            assert!(bytes_a == bytes_b, "{name_a} differs between 1 and 2 threads");
        }
    }
    let three = dir.path().join("three");
    assert!(build(&config, &three, &["--seed", "99", "--only", "karis"]).status.success());
    assert_ne!(std::fs::read(one.join("karis.dds")).unwrap(), std::fs::read(three.join("karis.dds")).unwrap());
}

#[test]
fn list_names_every_table() {
    let output = tmlut(&["list"]);
    assert!(output.status.success());
    for table in ["fgd", "gd", "tir", "belcour", "karis"] {
        assert!(stdout(&output).contains(table), "{}", stdout(&output));
    }
}

#[test]
fn bad_configurations_are_refused_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("luts");
    let cases: &[(&str, &[&str])] = &[
        ("[karis]\nroughness_cuont = 3\n", &["config.toml", "roughness_cuont"]),
        ("[karis]\nalpha_range = [-0.5, 1.0]\n", &["karis.alpha_range", "allowed"]),
        ("[karis]\nalpha_range = [1.0, 0.0]\n", &["karis.alpha_range", "inverted"]),
        ("[karis]\nroughness_count = 1\n", &["karis.roughness_count", "allowed: 2 to"]),
        ("[karis]\nmu_count = 0\n", &["karis.mu_count"]),
        ("[karis.sampling]\nsamples = 100\nreplicates = 4\n", &["karis.sampling.samples", "power of two"]),
        ("seed = -1\n", &["config.toml", "seed"]),
        ("[karis\n", &["config.toml"]),
        ("[fgd]\npacking_formats = [\"exr\"]\n", &["fgd.packing_formats", "allowed: dds, ktx2"]),
        ("[fgd]\npacking_formats = []\n", &["fgd.packing_formats", "is empty"]),
        ("[fgd.output]\nformats = [\"ktx2\"]\nprecision = \"f32\"\n", &["fgd.output.formats", "allowed: bin, exr"]),
    ];
    for (text, expected) in cases {
        let config = write_config(dir.path(), text);
        let output = build(&config, &out, &[]);
        assert_clean_failure(&output, expected);
    }
    assert!(!out.exists(), "a refused configuration must not create the output folder");
    let missing = tmlut(&["build", "--config", dir.path().join("nope.toml").to_str().unwrap()]);
    assert_clean_failure(&missing, &["nope.toml"]);
}

#[test]
fn bad_arguments_are_refused_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let output = build(&config, &dir.path().join("luts"), &["--only", "karis,fgdd"]);
    assert_clean_failure(&output, &["--only", "unknown table `fgdd`", "known tables: fgd, gd, tir, belcour, karis"]);
    let output = build(&config, &dir.path().join("luts"), &["--method", "slow"]);
    assert!(!output.status.success() && stderr(&output).contains("allowed: fast, per-cell"), "{}", stderr(&output));
    let output = build(&config, &dir.path().join("luts"), &["--threads", "0"]);
    assert_clean_failure(&output, &["--threads"]);

    // An output folder that cannot be created: a file stands where a parent folder should be.
    let blocker = dir.path().join("a-file");
    std::fs::write(&blocker, b"x").unwrap();
    let output = build(&config, &blocker.join("luts"), &[]);
    assert_clean_failure(&output, &["a-file"]);
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

#[test]
fn an_interrupted_build_leaves_earlier_outputs_intact() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("luts");
    let small = write_config(dir.path(), SMALL_SET);
    assert!(build(&small, &out, &[]).status.success());
    let before = snapshot(&out);

    // A build that takes several seconds, killed while it integrates.
    let slow = dir.path().join("slow.toml");
    std::fs::write(
        &slow,
        "[karis]\nmu_count = 1024\nroughness_count = 1024\n[karis.sampling]\nsamples = 4096\nreplicates = 4\n",
    )
    .unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_tmlut"))
        .args(["build", "--quiet", "--config", slow.to_str().unwrap(), "--out", out.to_str().unwrap()])
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(600));
    assert!(child.try_wait().unwrap().is_none(), "the slow build finished before it could be interrupted");
    child.kill().unwrap();
    child.wait().unwrap();

    let after: Vec<(String, Vec<u8>)> = snapshot(&out).into_iter().filter(|(name, _)| !name.starts_with('.')).collect();
    assert_eq!(before, after, "files changed under an interrupted build");

    // The next build removes what the killed one left in its staging folder.
    assert!(build(&small, &out, &[]).status.success());
    assert!(snapshot(&out).iter().all(|(name, _)| !name.starts_with('.')));
}

fn scene_path(name: &str) -> String {
    format!("{}/luts/scenes/{name}.toml", env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn plan_prints_the_tables_what_is_left_out_and_the_saving() {
    let output = tmlut(&["plan", &scene_path("profiling")]);
    assert!(output.status.success(), "{}", stderr(&output));
    let text = stdout(&output);
    for expected in [
        "Lookups the transfer-matrix model makes:",
        "coated-conductor, layer 2 from above",
        "fgd_coated-conductor_l1_from-above",
        "tir_coated-conductor_l1_up",
        "Left out:",
        "fgd (4D, 64.0 MiB): every FGD lookup is at fixed (eta, kappa)",
        "against 69.2 MiB (72531968 bytes) for the default set",
    ] {
        assert!(text.contains(expected), "expected `{expected}` in:\n{text}");
    }
}

#[test]
fn build_with_a_scene_writes_its_plan_and_records_it() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let out = dir.path().join("luts");
    let scene = scene_path("copper-pot");
    // Every slice checked on its own and against the full table.
    let output = build(&config, &out, &["--scene", &scene, "--slice-checks", "full"]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(
        stdout(&output).contains("interpolated vs the exact integral, where the slice's lookups are made"),
        "{}",
        stdout(&output)
    );

    let manifest = Manifest::read(&out.join(MANIFEST_FILE)).unwrap();
    let record = manifest.scene.as_ref().expect("the scene is recorded");
    assert_eq!(record.name, "copper-pot");
    assert_eq!(record.text, std::fs::read_to_string(&scene).unwrap());
    let planned: Vec<&str> = record.plan.tables.iter().map(|t| t.name.as_str()).collect();
    assert_eq!(planned.len(), 4, "{planned:?}");
    // Exactly the plan: a DDS per slice and GD in its configured format, nothing of the default set.
    let mut files: Vec<&String> = manifest.files.keys().collect();
    files.sort();
    // Beside the tables, the scene's shader (not a table: listed under `scene_shader`, not among
    // the manifest's files), valid WGSL.
    for shader in ["copper_pot.wgsl", "copper_pot.hlsl", "copper_pot.shader.json"] {
        assert!(out.join(shader).exists(), "{shader}");
    }
    assert_eq!(common::validate_wgsl_files(&out), 1);
    let mut expected: Vec<String> = planned.iter().map(|n| format!("{n}.dds")).collect();
    expected.sort();
    assert_eq!(files, expected.iter().collect::<Vec<_>>());
    assert!(record.plan.left_out.iter().any(|l| l.what.starts_with("fgd (4D")));

    // A renderer loads a slice through the manifest: four channels (three indices and padding).
    let folder = LutFolder::open(&out).unwrap();
    let copper = folder.load("fgd_varnished-copper_l2_from-above.dds").unwrap();
    assert_eq!(copper.channel_count(), 4);
    assert_eq!(copper.channels[3].name, "padding");
    let entry = manifest.entry("fgd_varnished-copper_l2_from-above.dds").unwrap();
    assert_eq!(entry.error.interpolation.len(), 1, "against the exact integral where its lookups are made");
    assert_eq!(entry.accuracy.len(), 1, "the full table at the same points");
    assert_eq!(entry.nan_count, 0);
    let values = copper.interpolate(&[0.8, 0.01]);
    assert!(values[..3].iter().all(|v| (0.0..=1.0).contains(v)) && values[3] == 0.0, "{values:?}");

    // By default the checks are drawn across the slices of the build: the same tables, each with
    // the batch's reference figure and a note saying so.
    let sampled = dir.path().join("sampled");
    let output = build(&config, &sampled, &["--scene", &scene]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(stdout(&output).contains("1 materials: 4 tables (3 slices"), "{}", stdout(&output));
    let sampled_manifest = Manifest::read(&sampled.join(MANIFEST_FILE)).unwrap();
    for (file, entry) in &sampled_manifest.files {
        assert_eq!(entry.sha256, manifest.files[file].sha256, "{file}: the same bytes either way");
        if file.starts_with("fgd_") || file.starts_with("tir_") {
            assert!(entry.error.integration.reference.is_some(), "{file}");
            assert!(entry.notes.iter().any(|n| n.contains("Checked as one of a batch")), "{file}: {:?}", entry.notes);
        }
    }
}

#[test]
fn shader_refuses_a_folder_whose_tables_do_not_match_their_manifest() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let luts = dir.path().join("luts");
    let scene = scene_path("copper-pot");
    assert!(build(&config, &luts, &["--scene", &scene]).status.success());
    let shader = |out: &str| tmlut(&["shader", &scene, "--luts", luts.to_str().unwrap(), "--out", out]);
    let out = dir.path().join("shaders");
    assert!(shader(out.to_str().unwrap()).status.success());
    let slice = luts.join("fgd_varnished-copper_l2_from-above.dds");
    let original = std::fs::read(&slice).unwrap();
    let gd = luts.join("gd.dds");
    let gd_bytes = std::fs::read(&gd).unwrap();
    let mut other = gd_bytes.clone();
    let last = other.len() - 1;
    other[last] ^= 0x40;
    // Truncated, deleted, and a GD of other values: each refused, naming the file.
    for (file, damage, name) in [
        (&slice, Some(original[..original.len() - 8].to_vec()), "fgd_varnished-copper_l2_from-above.dds"),
        (&slice, None, "fgd_varnished-copper_l2_from-above.dds"),
        (&gd, Some(other), "gd.dds"),
    ] {
        match damage {
            Some(bytes) => std::fs::write(file, bytes).unwrap(),
            None => std::fs::remove_file(file).unwrap(),
        }
        let refused = dir.path().join("refused");
        let output = shader(refused.to_str().unwrap());
        assert!(!output.status.success(), "{name}: {}", stdout(&output));
        assert!(stderr(&output).contains(name), "{name}: {}", stderr(&output));
        assert!(!refused.join("copper_pot.wgsl").exists(), "{name}");
        std::fs::write(&slice, &original).unwrap();
        std::fs::write(&gd, &gd_bytes).unwrap();
    }
}

/// Every slice of a folder as its reader finds it, by name: from a file of its own or a region of
/// a texture array.
fn slices_by_name(dir: &Path) -> std::collections::BTreeMap<String, tmlut::table::Table> {
    let folder = LutFolder::open(dir).unwrap();
    folder.scene_slices(|_| true).unwrap().into_iter().map(|s| (s.entry.table.clone(), s.table)).collect()
}

#[test]
fn a_library_in_texture_arrays_reads_exactly_as_its_slice_files_do() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let (files, arrays) = (dir.path().join("files"), dir.path().join("arrays"));
    let scenes = [scene_path("copper-pot"), scene_path("gpu-check/varied-coats"), scene_path("gpu-check/stiff-stacks")];
    for (out, layout) in [(&files, "files"), (&arrays, "arrays")] {
        let mut extra = vec!["--slice-layout", layout];
        for scene in &scenes {
            extra.extend(["--scene", scene.as_str()]);
        }
        let output = build(&config, out, &extra);
        assert!(output.status.success(), "{layout}: {}", stderr(&output));
    }
    // The same slices, value for value, from a handful of arrays instead of a file each.
    let (from_files, from_arrays) = (slices_by_name(&files), slices_by_name(&arrays));
    assert!(from_files.len() > 30, "{} slices", from_files.len());
    assert_eq!(from_files, from_arrays);
    let manifest = Manifest::read(&arrays.join(MANIFEST_FILE)).unwrap();
    // No slice has a file of its own; FGD and TIR of one channel, FGD of three (padded to four).
    let own_files =
        manifest.files.values().filter(|e| e.axes.len() == 2 && e.channels.iter().any(|c| !c.fixed.is_empty()));
    assert_eq!(own_files.count(), 0);
    let arrays_written: Vec<&String> =
        manifest.files.iter().filter(|(_, e)| e.slice_array.is_some()).map(|(f, _)| f).collect();
    assert_eq!(arrays_written, ["fgd_array_r.dds", "fgd_array_rgba.dds", "tir_array_r.dds"]);
    let held: usize = manifest.files.values().filter_map(|e| e.slice_array.as_ref()).map(|a| a.slices.len()).sum();
    assert_eq!(held, from_files.len());

    // One scene's shader over each folder: the CPU evaluator gives the same values, and the
    // shader over the arrays reads texture_2d_array and validates.
    let scene = scene_path("gpu-check/varied-coats");
    let mut references = Vec::new();
    for (name, layout) in [("one-files", "files"), ("one-arrays", "arrays")] {
        let luts = dir.path().join(name);
        assert!(build(&config, &luts, &["--slice-layout", layout, "--scene", &scene]).status.success());
        let out = dir.path().join(format!("{name}-shader"));
        let output = tmlut(&[
            "shader",
            &scene,
            "--luts",
            luts.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--reference-views",
            "16",
        ]);
        assert!(output.status.success(), "{}", stderr(&output));
        assert_eq!(common::validate_wgsl_files(&out), 1);
        let wgsl = std::fs::read_to_string(out.join("varied_coats.wgsl")).unwrap();
        assert_eq!(wgsl.contains("texture_2d_array<f32>"), layout == "arrays");
        // What a renderer creates each texture as, stated beside it.
        let description: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("varied_coats.shader.json")).unwrap()).unwrap();
        for texture in description["textures"].as_array().unwrap() {
            let expected_view = match (texture["layered"] == true, texture["dimension"].as_u64()) {
                (true, _) => "2d-array",
                (false, Some(3)) => "3d",
                _ => "2d",
            };
            assert_eq!(texture["view_dimension"], expected_view, "{texture}");
            assert_eq!(texture["sample_type"], "unfilterable-float", "{texture}");
            assert!(
                ["r32float", "rgba32float", "r16float", "rgba16float"].contains(&texture["format"].as_str().unwrap()),
                "{texture}"
            );
        }
        references.push(std::fs::read(out.join("varied_coats.reference.json")).unwrap());
    }
    assert_eq!(references[0], references[1]);

    // `check` finds every slice inside its array with the value range its entry states...
    let budgets = dir.path().join("no-budgets.toml");
    std::fs::write(&budgets, "").unwrap();
    let check = || tmlut(&["check", arrays.to_str().unwrap(), "--budgets", budgets.to_str().unwrap()]);
    let checked = check();
    assert!(checked.status.success(), "{}", stdout(&checked));
    assert!(stdout(&checked).contains("slices inside the array as placed"), "{}", stdout(&checked));
    // ... and a manifest that places a slice outside its array is refused by the loader and by
    // `check`, naming the slice.
    let mut damaged = manifest.clone();
    let (_, entry) = damaged.files.iter_mut().find(|(_, e)| e.slice_array.is_some()).unwrap();
    let slice = &mut entry.slice_array.as_mut().unwrap().slices[0];
    slice.origin[0] = 100_000;
    let name = slice.table.clone();
    // Sealed again, as a writer that placed it wrong would have: the placement itself is checked.
    entry.seal();
    damaged.write(&arrays).unwrap();
    let error = LutFolder::open(&arrays).unwrap().scene_slices(|_| true).unwrap_err().to_string();
    assert!(error.contains(&name) && error.contains("outside the array"), "{error}");
    let checked = check();
    assert_eq!(checked.status.code(), Some(1), "{}", stdout(&checked));
    assert!(stdout(&checked).contains(&name), "{}", stdout(&checked));
}

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
    let merge = |shards: &[PathBuf], out: &Path| {
        let mut args = vec!["merge", "--quiet", "--config", config.to_str().unwrap(), "--out", out.to_str().unwrap()];
        args.extend(scene_args.iter().copied());
        args.extend(shards.iter().map(|s| s.to_str().unwrap()));
        tmlut(&args)
    };
    let merged = dir.path().join("merged");
    let output = merge(&shard_dirs, &merged);
    assert!(output.status.success(), "{}", stderr(&output));
    // Every file byte for byte, the manifest apart from wall times.
    let (a, b) = (snapshot(&whole), snapshot(&merged));
    let names = |files: &[(String, Vec<u8>)]| files.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    assert_eq!(names(&a), names(&b));
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        if name != MANIFEST_FILE {
            assert!(x == y, "{name} differs");
        }
    }
    assert_eq!(manifest_without_wall_times(&whole), manifest_without_wall_times(&merged));

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

#[test]
fn the_scene_shader_is_listed_in_the_manifest_and_checked() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let out = dir.path().join("luts");
    let out_arg = out.to_str().unwrap();
    let scene = scene_path("copper-pot");
    assert!(build(&config, &out, &["--scene", &scene]).status.success());
    let no_budgets = write_config(dir.path(), "");
    let check = || tmlut(&["check", out_arg, "--budgets", no_budgets.to_str().unwrap()]);

    // Listed with length and SHA-256, read back by the loader and verified by `check`.
    let listed = |out: &Path| -> Vec<String> {
        let manifest = Manifest::read(&out.join(MANIFEST_FILE)).unwrap();
        let record = manifest.scene_shader.expect("the scene shader is listed");
        assert_eq!(record.scene, "copper-pot");
        for f in &record.files {
            let bytes = std::fs::read(out.join(&f.file)).unwrap();
            assert_eq!(
                (f.bytes, f.sha256.as_str()),
                (bytes.len() as u64, tmlut::pipeline::sha256_hex(&bytes).as_str())
            );
        }
        record.files.into_iter().map(|f| f.file).collect()
    };
    assert_eq!(listed(&out), ["copper_pot.hlsl", "copper_pot.wgsl", "copper_pot.shader.json"]);
    let shader = tmlut::loader::SceneShaderFiles::open(&out).unwrap();
    assert_eq!(shader.wgsl, std::fs::read_to_string(out.join("copper_pot.wgsl")).unwrap());
    assert_eq!(shader.description.materials[0].function, "tm_varnished_copper");
    let output = check();
    assert!(output.status.success(), "{}{}", stdout(&output), stderr(&output));
    for line in ["ok   copper_pot.wgsl: shader length ", "ok   copper_pot.shader.json: shader sha256"] {
        assert!(stdout(&output).contains(line), "expected `{line}` in:\n{}", stdout(&output));
    }

    // A shader file changed after its build is found by both.
    let wgsl = out.join("copper_pot.wgsl");
    let original = std::fs::read(&wgsl).unwrap();
    std::fs::write(&wgsl, [original.as_slice(), b"\n"].concat()).unwrap();
    let output = check();
    assert!(!output.status.success());
    for line in ["FAIL copper_pot.wgsl: shader length", "FAIL copper_pot.wgsl: shader sha256"] {
        assert!(stdout(&output).contains(line), "expected `{line}` in:\n{}", stdout(&output));
    }
    let err = tmlut::loader::SceneShaderFiles::open(&out).unwrap_err().to_string();
    assert!(err.contains("copper_pot.wgsl") && err.contains("bytes, the manifest states"), "{err}");
    std::fs::write(&wgsl, &original).unwrap();

    // `tmlut shader` into the folder of its tables replaces the listing: the reference file is
    // listed while written, and removed with it.
    let shader_into_folder = |views: &str| {
        let output = tmlut(&["shader", &scene, "--luts", out_arg, "--out", out_arg, "--reference-views", views]);
        assert!(output.status.success(), "{}", stderr(&output));
    };
    shader_into_folder("3");
    assert!(listed(&out).contains(&"copper_pot.reference.json".to_string()));
    shader_into_folder("0");
    assert!(!listed(&out).contains(&"copper_pot.reference.json".to_string()));
    assert!(!out.join("copper_pot.reference.json").exists());
    assert!(check().status.success());

    // A build into the folder replaces the tables the shader was specialised to: the shader
    // leaves with them.
    assert!(build(&config, &out, &["--only", "gd"]).status.success());
    assert!(Manifest::read(&out.join(MANIFEST_FILE)).unwrap().scene_shader.is_none());
    assert!(!out.join("copper_pot.wgsl").exists());
}

#[test]
fn a_scene_built_in_ktx2_gives_the_shader_and_the_model_what_its_dds_twin_gives() {
    let dir = tempfile::tempdir().unwrap();
    let dds_config = write_config(dir.path(), SMALL_SET);
    let mut ktx2 = SMALL_SET.replacen("[fgd]\n", "[fgd]\npacking_formats = [\"ktx2\"]\n", 1);
    ktx2.push_str("[gd.output]\nformats = [\"ktx2\"]\n[tir.output]\nformats = [\"ktx2\"]\n");
    let ktx2_dir = dir.path().join("ktx2");
    std::fs::create_dir(&ktx2_dir).unwrap();
    let ktx2_config = write_config(&ktx2_dir, &ktx2);
    let scene = scene_path("copper-pot");
    let built = |config: &Path, name: &str| -> PathBuf {
        let out = dir.path().join(name);
        let output = build(config, &out, &["--scene", &scene]);
        assert!(output.status.success(), "{}", stderr(&output));
        let output = tmlut(&[
            "shader",
            &scene,
            "--luts",
            out.to_str().unwrap(),
            "--out",
            out.join("shader").to_str().unwrap(),
            "--reference-views",
            "7",
        ]);
        assert!(output.status.success(), "{}", stderr(&output));
        out
    };
    let (dds, ktx2) = (built(&dds_config, "dds"), built(&ktx2_config, "ktx2"));

    // Every slice and GD in KTX2 alone, and the shader binds those files.
    let manifest = Manifest::read(&ktx2.join(MANIFEST_FILE)).unwrap();
    assert!(manifest.files.keys().all(|f| f.ends_with(".ktx2")), "{:?}", manifest.files.keys());
    assert_eq!(manifest.files.len(), 4);
    let shader = tmlut::loader::SceneShaderFiles::open(&ktx2).unwrap();
    assert!(shader.description.textures.iter().all(|t| t.file.ends_with(".ktx2")));
    let no_budgets = write_config(dir.path(), "");
    let check = tmlut(&["check", ktx2.to_str().unwrap(), "--budgets", no_budgets.to_str().unwrap()]);
    assert!(check.status.success(), "{}{}", stdout(&check), stderr(&check));

    // The same values, so the same shader text and the same CPU evaluation, bit for bit.
    let read = |dir: &Path, file: &str| std::fs::read(dir.join("shader").join(file)).unwrap();
    assert_eq!(read(&dds, "copper_pot.wgsl"), read(&ktx2, "copper_pot.wgsl"));
    assert_eq!(read(&dds, "copper_pot.reference.json"), read(&ktx2, "copper_pot.reference.json"));
}

#[test]
fn a_scene_with_the_fitted_tir_form_writes_its_shaders_and_no_tir_table() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let scene = dir.path().join("fit.toml");
    let text = std::fs::read_to_string(scene_path("copper-pot")).unwrap().replace("tir = \"table\"", "tir = \"fit\"");
    std::fs::write(&scene, text).unwrap();
    let out = dir.path().join("luts");
    let output = build(&config, &out, &["--scene", scene.to_str().unwrap()]);
    assert!(output.status.success(), "{}", stderr(&output));
    let manifest = Manifest::read(&out.join(MANIFEST_FILE)).unwrap();
    let plan = &manifest.scene.as_ref().expect("the scene is recorded").plan;
    let fit = plan.tir_fit.as_ref().expect("the fit is recorded with the plan");
    assert!(manifest.files.keys().all(|f| !f.starts_with("tir")), "{:?}", manifest.files.keys());
    for shader in &fit.shaders {
        let bytes = std::fs::read(out.join(&shader.file)).unwrap();
        assert_eq!(shader.sha256, tmlut::pipeline::sha256_hex(&bytes));
    }
    assert_eq!(fit.shaders.len(), 2);
    assert!(fit.figures.rmse.is_finite());
    // The fitted form's shader and the scene's shader reading it are valid WGSL.
    assert_eq!(common::validate_wgsl_files(&out), 2);
    assert!(std::fs::read_to_string(out.join("copper_pot.wgsl")).unwrap().contains(" = tmlut_tir("));
}

/// The names of the functions a shader defines: `fn name(` in WGSL, `TYPE name(...) {` in HLSL.
fn shader_functions(text: &str) -> Vec<String> {
    let mut names: Vec<String> = text
        .lines()
        .filter(|line| !line.starts_with([' ', '/', '@', '}']) && line.trim_end().ends_with('{') && line.contains('('))
        .filter_map(|line| line.split('(').next()?.split_whitespace().last().map(str::to_string))
        .collect();
    names.sort();
    names
}

#[test]
fn scene_shaders_cover_the_6_flux_model_the_split_sum_tables_and_the_3d_tir_table() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    for (scene, stem, expected) in [
        ("scattering", "scattering", &["fn tm_scattering_stack(", "sinh("][..]),
        ("thesis/split-sum", "thesis_split_sum", &["fn tm_varnished_copper_belcour(", "dot(vec4<f32>("]),
        ("gpu-check/varied-coats", "varied_coats", &["tmh_trilinear(", "tmh_acos(", "fn fgd_lossless("]),
        ("gpu-check/stiff-stacks", "stiff_stacks", &["fn tm_bare_conductor_2_flux(", "fn tmh_slice0("]),
    ] {
        let out = dir.path().join(stem);
        let output = build(&config, &out, &["--scene", &scene_path(scene)]);
        assert!(output.status.success(), "{scene}: {}", stderr(&output));
        assert!(!stderr(&output).contains("no shader written"), "{scene}: {}", stderr(&output));
        let wgsl = std::fs::read_to_string(out.join(format!("{stem}.wgsl"))).unwrap();
        for text in expected {
            assert!(wgsl.contains(text), "{scene}: no `{text}` in {stem}.wgsl");
        }
        // Valid WebGPU shader code (naga), and HLSL printed from the same description.
        assert!(common::validate_wgsl_files(&out) >= 1);
        let hlsl = std::fs::read_to_string(out.join(format!("{stem}.hlsl"))).unwrap();
        let functions = shader_functions(&wgsl);
        assert!(functions.iter().any(|f| f.starts_with("tm_")), "{functions:?}");
        assert_eq!(functions, shader_functions(&hlsl), "{scene}: the two languages define different functions");
    }
}

#[test]
fn names_that_give_one_file_are_refused_by_plan_and_build_alike() {
    // `plan` passed names that `build` then refused ("a format listed twice", "file name too
    // long"), or that gave one shader function (`glass a`, `glass-a`): both now refuse them.
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let material = |name: &str| {
        format!("[[material]]\nname = \"{name}\"\n[[material.layer]]\ntype = \"interface\"\neta = 1.5\nalpha = 0.1\n")
    };
    let long = "x".repeat(300);
    for (text, expected) in [
        (material("glass a") + &material("glass-a"), &["material 2", "`glass-a`", "(`glass a`)"][..]),
        (material("Copper") + &material("copper"), &["material 2", "`copper`", "(`Copper`)"]),
        (material(&long), &["material 1: name", "300 characters", "allowed: 1 to 64"]),
    ] {
        let scene = dir.path().join("twins.toml");
        std::fs::write(&scene, text).unwrap();
        let output = tmlut(&["plan", scene.to_str().unwrap(), "--config", config.to_str().unwrap()]);
        assert_clean_failure(&output, expected);
        let out = dir.path().join("luts");
        let output = build(&config, &out, &["--scene", scene.to_str().unwrap()]);
        assert_clean_failure(&output, expected);
        assert!(!out.join(MANIFEST_FILE).exists());
    }
}

#[test]
fn every_scene_shader_validates_whatever_its_material_names_and_values() {
    // Materials named after the generator's helpers redefined them (`finite-or` gave a second
    // `tm_finite_or`), and extreme media printed `inf`; both shaders failed naga while `tmlut
    // shader` exited 0. The stiff stacks cover every helper and slice chooser; here they carry the
    // helpers' names, beside media at the ends of what a scene admits.
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let hostile = [
        "finite-or",
        "finite-or3",
        "average",
        "ggx-to-hg",
        "transmission-g",
        "then-interface",
        "refracted-cosine",
        "hg-refract",
        "attenuate",
        "asinh",
        "trilinear",
        "acos",
        "slab",
        "safe-ratio",
        "bilinear",
        "hg-to-ggx",
        "normalised",
        "identity",
        "table0",
        "table1",
        "table2",
        "table3",
        "slice0",
        "slice1",
        "slice2",
        "main",
    ];
    let original = std::fs::read_to_string(scene_path("gpu-check/stiff-stacks")).unwrap();
    let mut names = hostile.iter();
    let mut text: String = original
        .lines()
        .map(|line| {
            let material_name = line.starts_with("name = ") && !line.contains("stiff-stacks");
            match if material_name { names.next() } else { None } {
                Some(name) => format!("name = \"{name}\"\n"),
                None => format!("{line}\n"),
            }
        })
        .collect();
    assert!(names.next().is_none(), "every hostile name was given to a material");
    for (k, medium) in [
        "sigma_k = 1e30\ndepth = 1e30",
        "sigma_s = 1e30\nsigma_k = 1e-30\ndepth = 1e-30\ng = 0.999999",
        "sigma_s = 1e-30\nsigma_k = 1e-30\ndepth = 1e30\ng = -1e-30",
    ]
    .iter()
    .enumerate()
    {
        for model in ["2-flux", "6-flux"] {
            text.push_str(&format!(
                "[[material]]\nname = \"extreme-{k}-{model}\"\nmodel = \"{model}\"\n\
                 [[material.layer]]\ntype = \"interface\"\neta = 1.5\nalpha = 0.1\n\
                 [[material.layer]]\ntype = \"medium\"\n{medium}\n\
                 [[material.layer]]\ntype = \"interface\"\neta = [0.2, 0.9, 1.1]\nkappa = [3.0, 2.5, 2.0]\nalpha = 0.3\n"
            ));
        }
    }
    let scene = dir.path().join("stiff-stacks.toml");
    std::fs::write(&scene, text).unwrap();
    let out = dir.path().join("luts");
    let output = build(&config, &out, &["--scene", scene.to_str().unwrap()]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(!stderr(&output).contains("no shader written"), "{}", stderr(&output));
    assert_eq!(common::validate_wgsl_files(&out), 1);
    let wgsl = std::fs::read_to_string(out.join("stiff_stacks.wgsl")).unwrap();
    for name in hostile {
        assert!(wgsl.contains(&format!("fn tm_{}(", name.replace('-', "_"))), "no function of `{name}`");
    }
    let code = wgsl.lines().map(|line| line.split("//").next().unwrap_or("")).collect::<Vec<_>>().join("\n");
    let words: Vec<&str> = code.split(|c: char| !c.is_ascii_alphanumeric()).collect();
    assert!(!words.contains(&"inf") && !words.contains(&"NaN"), "a non-finite literal");
    let hlsl = std::fs::read_to_string(out.join("stiff_stacks.hlsl")).unwrap();
    assert_eq!(shader_functions(&wgsl), shader_functions(&hlsl));
}

#[test]
fn bad_scenes_are_refused_naming_material_and_layer() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("bad.toml");
    std::fs::write(
        &scene,
        "[[material]]\nname = \"pot\"\n[[material.layer]]\ntype = \"interface\"\neta = 1.5\nalpha = 0.1\n\
         [[material.layer]]\ntype = \"medium\"\nsigma_k = 0.2\n",
    )
    .unwrap();
    let output = tmlut(&["plan", scene.to_str().unwrap()]);
    assert_clean_failure(&output, &["material 1 (`pot`), layer 2", "without `depth`"]);
    let out = dir.path().join("out");
    let output = tmlut(&["build", "-q", "--scene", scene.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_clean_failure(&output, &["material 1 (`pot`), layer 2"]);
    assert!(!out.join(MANIFEST_FILE).exists(), "nothing written for a bad scene");
    let output = tmlut(&["plan", dir.path().join("missing.toml").to_str().unwrap()]);
    assert_clean_failure(&output, &["missing.toml"]);
    let output = tmlut(&["build", "--scene", &scene_path("copper-pot"), "--only", "fgd"]);
    assert!(!output.status.success() && stderr(&output).contains("--only"), "{}", stderr(&output));
}

#[test]
fn the_model_reads_a_dielectric_onto_a_rarer_medium_from_fgd_rarer_and_everything_else_as_before() {
    use tmlut::loader::texture::SampledTable;
    use tmlut::model::folder::{FgdSource, FolderTables};
    use tmlut::model::{AlbedoPath, Tables, TirPath};
    use tmlut::table::derived::point_of;

    let dir = tempfile::tempdir().unwrap();
    let out = common::build_config(dir.path(), SMALL_SET, &["--only", "fgd,fgd_rarer"]);
    let rarer = [albedo_lookup(0.72, 0.01, 0.7, 0.0), albedo_lookup(0.3, 0.4, 0.2, 0.0)];
    let others =
        [albedo_lookup(0.72, 0.01, 0.7, 0.05), albedo_lookup(0.5, 0.2, 1.5, 0.0), albedo_lookup(0.9, 0.3, 0.2, 2.0)];
    let open =
        |folder: &LutFolder| FolderTables::open(folder, AlbedoPath::Fgd, TirPath::Off, FgdSource::Packing).unwrap();
    let folder = LutFolder::open(&out).unwrap();
    let with_rarer = open(&folder);
    let texture = SampledTable::new(&folder.load("fgd_rarer.dds").unwrap()).unwrap();
    for l in &rarer {
        let point = point_of(&texture.axes, l.mu, l.alpha, l.eta, 0.0).unwrap();
        assert_eq!(with_rarer.value(l), texture.sample(0, &point) as f64, "{l:?}");
    }
    // Without fgd_rarer the same lookups read the packing; the others read it either way.
    let mut manifest = Manifest::read(&out.join(MANIFEST_FILE)).unwrap();
    manifest.files.remove("fgd_rarer.dds");
    manifest.write(&out).unwrap();
    std::fs::remove_file(out.join("fgd_rarer.dds")).unwrap();
    let without = open(&LutFolder::open(&out).unwrap());
    for l in &rarer {
        assert_ne!(with_rarer.value(l), without.value(l), "{l:?}");
    }
    for l in &others {
        assert_eq!(with_rarer.value(l), without.value(l), "{l:?}");
    }
}

/// An albedo lookup of the first interface from above, as the model makes it.
fn albedo_lookup(mu: f64, alpha: f64, eta: f64, kappa: f64) -> tmlut::model::Lookup {
    use tmlut::model::{Quantity, Site};
    tmlut::model::Lookup {
        quantity: Quantity::Albedo,
        site: Site::FromAbove,
        layer: 1,
        channel: None,
        mu,
        alpha,
        eta,
        kappa,
    }
}

#[test]
fn a_table_larger_than_the_process_may_use_is_refused_before_anything_is_allocated() {
    // 120^4 FGD needs about 10 GiB, under the 16 GiB a table may ask for: allowed on a large
    // machine, but under a 4 GB address-space limit it would abort part way through the build.
    let dir = tempfile::tempdir().unwrap();
    let config =
        write_config(dir.path(), "[fgd]\nmu_count = 120\nalpha_count = 120\neta_count = 120\nkappa_count = 120\n");
    let out = dir.path().join("out");
    let script = format!(
        "ulimit -v 4000000 && exec '{}' build --config '{}' --only fgd --out '{}' -q",
        env!("CARGO_BIN_EXE_tmlut"),
        config.display(),
        out.display()
    );
    let output = Command::new("sh").args(["-c", &script]).output().unwrap();
    assert_clean_failure(&output, &["fgd", "needs about", "at most 3.8 GiB", "ulimit -v", "mu_count"]);
    assert!(!out.exists(), "the refused build created {}", out.display());
}

/// `tmlut fit --form`: the repository's EnvBRDFApprox form (UE4's mobile approximation of the
/// split-sum table) fitted to a small Karis table, against the same form at its published
/// coefficients; the set of files, valid WGSL, and the same bits from the same seed.
#[test]
fn fit_form_refits_the_env_brdf_approx_form_to_a_karis_table() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let luts = dir.path().join("luts");
    let output = build(&config, &luts, &["--only", "karis"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let form = Path::new(env!("CARGO_MANIFEST_DIR")).join("luts/forms/karis-env-brdf-approx.toml");
    let table = luts.join("karis.dds");
    let fit = |out: &Path, extra: &[&str]| {
        let mut args = vec!["fit", "--form", form.to_str().unwrap(), "--table", table.to_str().unwrap()];
        args.extend(["--out", out.to_str().unwrap(), "--starts", "3"]);
        args.extend_from_slice(extra);
        let output = tmlut(&args);
        assert!(output.status.success(), "{}", stderr(&output));
        let json: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("fit.json")).unwrap()).unwrap();
        json
    };
    let published = fit(&dir.path().join("published"), &["--max-evaluations", "0"]);
    let fitted = fit(&dir.path().join("fitted"), &["--certify", "--config", config.to_str().unwrap()]);
    let rms = |json: &serde_json::Value| json["figures"]["together"]["rms"].as_f64().unwrap();
    assert_eq!(published["parameters"]["c"].as_f64(), Some(-0.572));
    assert_eq!(published["start_figures"], fitted["start_figures"]);
    // The least-squares optimum of this form on the 32 x 24 table (docs/fit.md has the figures of
    // the default 512 x 512 table).
    assert!(
        rms(&fitted) <= 0.93 * rms(&published),
        "fitted RMS {} against published {}",
        rms(&fitted),
        rms(&published)
    );
    for name in ["a", "b", "c", "d", "e", "f", "g", "h"] {
        assert!(fitted["parameters"][name].as_f64().unwrap().is_finite(), "{name}");
    }
    // The constant term of `ry` (f) and the two channels' offsets (g, h) only enter as two sums,
    // as do b, c and d along roughness: two directions the data cannot fix.
    let id = &fitted["identifiability"];
    assert_eq!(id["ill_determined"].as_array().unwrap().len(), 2, "{id}");
    assert_eq!(id["ill_determined_parameters"], serde_json::json!(["b", "c", "d", "f", "g", "h"]), "{id}");
    // Certified against exact integrals at the random points of the table's interpolation check
    // (both of Karis's domains), beside the table's own error there.
    let certified = fitted["certified"].as_array().unwrap();
    assert_eq!(certified.len(), 2);
    for c in certified {
        let (form, table) =
            (c["form"]["together"]["rms"].as_f64().unwrap(), c["table"]["together"]["rms"].as_f64().unwrap());
        assert!(table > 0.0 && table < form && form < 0.1, "{c}");
    }
    // Over a region, weighted: each domain's points inside the region, and weighted figures beside
    // the plain ones (the whole domain loses the points of roughness above 0.5; the low-roughness
    // one loses none).
    let config_arg = config.to_str().unwrap();
    let region = fit(
        &dir.path().join("region"),
        &["--range", "roughness=0:0.5", "--weights", "cosine", "--certify", "--config", config_arg],
    );
    let in_region = region["certified"].as_array().unwrap();
    let points = |c: &serde_json::Value| c["points"].as_u64().unwrap();
    assert!(points(&in_region[0]) < points(&certified[0]), "{}", in_region[0]);
    assert_eq!(points(&in_region[1]), points(&certified[1]));
    assert!(in_region.iter().all(|c| c["form_weighted"]["together"]["rms"].is_number()), "{region}");
    assert!(fitted.get("weighted_figures").is_none() && region["weighted_figures"].is_object());
    let out = dir.path().join("fitted");
    let mut files: Vec<String> =
        std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    files.sort();
    let stem = "karis_env_brdf_approx";
    assert_eq!(
        files,
        [
            "error_map.png",
            "fit.json",
            &format!("{stem}.glsl"),
            &format!("{stem}.hlsl"),
            &format!("{stem}.metal"),
            &format!("{stem}.wgsl"),
            "report.md",
            "residuals.png"
        ]
    );
    // The two pictures decode as PNG, at the sizes the plots are drawn.
    for picture in ["error_map.png", "residuals.png"] {
        let image = image::open(out.join(picture)).unwrap_or_else(|e| panic!("{picture}: {e}"));
        assert!((400..=4000).contains(&image.width()) && (300..=4000).contains(&image.height()), "{picture}");
    }
    let wgsl = std::fs::read_to_string(out.join(format!("{stem}.wgsl"))).unwrap();
    let module = naga::front::wgsl::parse_str(&wgsl).unwrap_or_else(|e| panic!("{}", e.emit_to_string(&wgsl)));
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .unwrap();
    assert!(wgsl.contains("fn tmlut_karis_env_brdf_approx(mu: f32, alpha: f32) -> vec2<f32>"), "{wgsl}");
    // The same seed: the same bytes, on one thread as on all.
    let again = dir.path().join("again");
    let output = Command::new(env!("CARGO_BIN_EXE_tmlut"))
        .args(["fit", "--form", form.to_str().unwrap(), "--table", table.to_str().unwrap()])
        .args(["--out", again.to_str().unwrap(), "--starts", "3", "--certify", "--config", config.to_str().unwrap()])
        .env("RAYON_NUM_THREADS", "1")
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", stderr(&output));
    for file in ["fit.json", &format!("{stem}.wgsl"), &format!("{stem}.metal")] {
        let (a, b) =
            (std::fs::read_to_string(out.join(file)).unwrap(), std::fs::read_to_string(again.join(file)).unwrap());
        let (mut a, mut b) = (a.replace(out.to_str().unwrap(), ""), b.replace(again.to_str().unwrap(), ""));
        if file == "fit.json" {
            // The measured times differ from run to run; everything else is the same bytes.
            let untimed = |text: &str| {
                let mut json: serde_json::Value = serde_json::from_str(text).unwrap();
                assert!(json["cost"]["timing"]["form_ns"].is_number(), "{}", json["cost"]);
                json["cost"]["timing"] = serde_json::Value::Null;
                serde_json::to_string_pretty(&json).unwrap()
            };
            (a, b) = (untimed(&a), untimed(&b));
        }
        assert_eq!(a, b, "{file}");
    }
}

/// `tmlut fit --form` on a scene's tables: a form fitted to the scene's FGD slice (2D, one
/// channel per relative index, named as the slice names them), and to its GD table with the
/// scene's weights, a range and a bad range.
#[test]
fn fit_form_fits_a_scene_slice_and_weighs_a_table_by_the_scene() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let luts = dir.path().join("luts");
    let scene = scene_path("copper-pot");
    let output = build(&config, &luts, &["--scene", &scene]);
    assert!(output.status.success(), "{}", stderr(&output));
    let slice = "fgd_varnished-copper_l1_from-above";
    let form = dir.path().join("slice.toml");
    std::fs::write(
        &form,
        format!(
            "table = \"{slice}\"\n[parameters]\nf0 = {{ start = 0.05, min = 0.0, max = 1.0 }}\n\
             p = {{ start = 5.0, min = 0.5, max = 10.0 }}\n[channels]\nfgd0 = \"f0 + (1 - f0) * (1 - mu)^5 * p / 5\"\n"
        ),
    )
    .unwrap();
    let fit = |form: &Path, table: &str, out: &str, extra: &[&str]| {
        let table = luts.join(table);
        let out = dir.path().join(out);
        let mut args = vec!["fit", "--form", form.to_str().unwrap(), "--table", table.to_str().unwrap()];
        args.extend(["--out", out.to_str().unwrap(), "--starts", "2", "--timing-runs", "3"]);
        args.extend_from_slice(extra);
        let output = tmlut(&args);
        let json = std::fs::read(out.join("fit.json"))
            .ok()
            .map(|bytes| serde_json::from_slice::<serde_json::Value>(&bytes).unwrap());
        (output, json)
    };
    let (output, json) = fit(&form, &format!("{slice}.dds"), "slice", &[]);
    assert!(output.status.success(), "{}", stderr(&output));
    let json = json.unwrap();
    let rms = |json: &serde_json::Value, figures: &str| json[figures]["together"]["rms"].as_f64().unwrap();
    assert!(rms(&json, "figures") < 0.5 * rms(&json, "start_figures"), "{json}");
    assert_eq!(json["channels"], serde_json::json!(["fgd0"]));
    assert!(json["cost"]["operations"]["arithmetic"].as_u64().unwrap() > 0, "{}", json["cost"]);
    assert_eq!(json["certified"], serde_json::json!([]), "no certification unless asked");

    // Certified where the scene's lookups of the slice are made: the slice planned again from the
    // scene the folder's manifest records, the form's error beside the slice's own.
    let config_arg = config.to_str().unwrap();
    let (output, certified) =
        fit(&form, &format!("{slice}.dds"), "slice-certified", &["--certify", "--config", config_arg]);
    assert!(output.status.success(), "{}", stderr(&output));
    let certified = certified.unwrap();
    let domains = certified["certified"].as_array().unwrap();
    assert_eq!(domains.len(), 1, "{certified}");
    assert!(domains[0]["domain"].as_str().unwrap().starts_with("uniform over mu ["), "{certified}");
    let together = |set: &str| domains[0][set]["together"]["rms"].as_f64().unwrap();
    // The fitted Schlick-like form is within a few percent; the slice's interpolation far closer.
    assert!(together("form") < 0.1 && together("form") < together("form_at_start"), "{certified}");
    assert!(together("table") < 1e-3 && together("table") < together("form"), "{certified}");

    // One constant `c` for a table whose one channel is named as the table.
    let constant_form = |table: &str| {
        let path = dir.path().join(format!("{table}-constant.toml"));
        let text = format!(
            "table = \"{table}\"\n[parameters]\nc = {{ start = 0.5, min = 0.0, max = 2.0 }}\n[channels]\n{table} = \"c + 0 * mu\"\n"
        );
        std::fs::write(&path, text).unwrap();
        path
    };
    let constant = constant_form("gd");
    let (output, uniform) = fit(&constant, "gd.dds", "gd-uniform", &[]);
    assert!(output.status.success(), "{}", stderr(&output));
    let uniform = uniform.unwrap();
    assert!(uniform.get("weighted_figures").is_none());

    // The pot reads TIR only inside its varnish (eta = 1/1.1), at views above its critical
    // cosine (0.42), where little is lost: a constant weighted by the scene sits far below the
    // table's mean over every eta in [0, 1]. The table is built beside the scene's set, which a
    // build into the same folder would replace.
    let output = build(&config, &dir.path().join("tir-luts"), &["--only", "tir"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let tir_constant = constant_form("tir");
    let (output, tir_uniform) = fit(&tir_constant, "../tir-luts/tir.dds", "tir-uniform", &[]);
    assert!(output.status.success(), "{}", stderr(&output));
    let (output, tir_weighted) = fit(&tir_constant, "../tir-luts/tir.dds", "tir-scene", &["--weights", &scene]);
    assert!(output.status.success(), "{}", stderr(&output));
    let (tir_uniform, tir_weighted) = (tir_uniform.unwrap(), tir_weighted.unwrap());
    let c = |json: &serde_json::Value| json["parameters"]["c"].as_f64().unwrap();
    assert!(
        c(&tir_weighted) < 0.5 * c(&tir_uniform),
        "scene-weighted {} against uniform {}",
        c(&tir_weighted),
        c(&tir_uniform)
    );
    assert!(
        tir_weighted["weights_are"].as_str().unwrap().contains("varnished-copper"),
        "{}",
        tir_weighted["weights_are"]
    );
    assert!(tir_weighted["weighted_figures"]["together"]["rms"].is_number(), "{tir_weighted}");

    // A range is recorded, and shrinks the points.
    let (output, ranged) = fit(&constant, "gd.dds", "gd-range", &["--range", "roughness=0:0.5"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let ranged = ranged.unwrap();
    assert_eq!(ranged["ranges"], serde_json::json!([{ "variable": "roughness", "lo": 0.0, "hi": 0.5 }]));
    assert!(ranged["points"].as_u64() < uniform["points"].as_u64(), "{ranged}");
    let report = std::fs::read_to_string(dir.path().join("gd-range").join("report.md")).unwrap();
    assert!(report.contains("Region: roughness in [0, 0.5]"), "{report}");

    // A variable the table does not have is refused, naming those it has; nothing is written.
    let (output, json) = fit(&constant, "gd.dds", "gd-bad", &["--range", "eta=0:1"]);
    assert!(!output.status.success() && json.is_none());
    assert!(
        stderr(&output).contains("unknown variable `eta`; allowed for table `gd`: mu, alpha, roughness"),
        "{}",
        stderr(&output)
    );
    let (output, _) = fit(&constant, "gd.dds", "gd-bad", &["--weights", "cosines"]);
    assert!(stderr(&output).contains("allowed: uniform, cosine, or a scene file SCENE.toml"), "{}", stderr(&output));

    // A folder of forms: every form fitted over the region with the weights and timed, each
    // form's fit.json and forms.json recording them.
    let forms = dir.path().join("gd-forms");
    std::fs::create_dir(&forms).unwrap();
    std::fs::copy(&constant, forms.join("constant.toml")).unwrap();
    let linear = "table = \"gd\"\n[parameters]\nc = { start = 0.5, min = 0.0, max = 2.0 }\n\
                  d = { start = 0.0, min = -2.0, max = 2.0 }\n[channels]\ngd = \"c + d * mu\"\n";
    std::fs::write(forms.join("linear.toml"), linear).unwrap();
    let (output, _) = fit(&forms, "gd.dds", "gd-folder", &["--range", "roughness=0:0.5", "--weights", "cosine"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let ranking: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("gd-folder/forms.json")).unwrap()).unwrap();
    assert_eq!(ranking["ranges"], ranged["ranges"], "{ranking}");
    assert_eq!((ranking["weights"].as_str(), ranking["timing_runs"].as_u64()), (Some("cosine"), Some(3)), "{ranking}");
    let ranked = ranking["forms"].as_array().unwrap();
    assert_eq!(ranked.len(), 2, "{ranking}");
    for form in ranked {
        let folder = dir.path().join("gd-folder").join(form["folder"].as_str().unwrap());
        let json: serde_json::Value = serde_json::from_slice(&std::fs::read(folder.join("fit.json")).unwrap()).unwrap();
        assert_eq!(
            (&json["ranges"], &json["weights"], &json["points"]),
            (&ranged["ranges"], &ranking["weights"], &ranged["points"])
        );
        assert_eq!(json["weighted_figures"]["together"], form["weighted_figures"], "{json}");
        assert_eq!(json["cost"]["timing"]["runs"].as_u64(), Some(3), "{json}");
    }
}

#[test]
fn fit_form_refuses_a_mistake_naming_file_line_and_column_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let luts = dir.path().join("luts");
    assert!(build(&config, &luts, &["--only", "karis"]).status.success());
    let form = dir.path().join("bad.toml");
    std::fs::write(
        &form,
        "table = \"karis\"\n[parameters]\na = { start = 1.0, min = 0.0, max = 2.0 }\n[channels]\nscale = \"a * rougness\"\n",
    )
    .unwrap();
    let out = dir.path().join("fit");
    let output = tmlut(&[
        "fit",
        "--form",
        form.to_str().unwrap(),
        "--table",
        luts.join("karis.dds").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!output.status.success());
    let message = stderr(&output);
    assert!(
        message.contains("bad.toml:5:14: unknown name `rougness`; allowed here: a, alpha, mu, roughness"),
        "{message}"
    );
    assert!(!out.exists(), "nothing written for a refused form");
    // There is no `tmlut fit tir`: every form is a form file, and the argument parser says so.
    let output = tmlut(&["fit", "tir", "--form", form.to_str().unwrap()]);
    assert!(!output.status.success() && stderr(&output).contains("--form"), "{}", stderr(&output));
}

#[test]
fn a_scene_shader_is_written_as_one_set_or_not_at_all() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene_path("copper-pot");
    // The same scene's tables as a file per slice and as texture arrays: their shaders differ.
    let luts = |layout: &str| {
        let luts = dir.path().join(layout);
        let args = ["build", "-q", "--scene", &scene, "--slice-checks", "none", "--slice-layout", layout, "--out"];
        let built = tmlut(&[&args[..], &[luts.to_str().unwrap()]].concat());
        assert!(built.status.success(), "{}", stderr(&built));
        luts
    };
    let (files, arrays) = (luts("files"), luts("arrays"));
    let out = dir.path().join("shader");
    let shader = |luts: &Path, views: &str| {
        let (luts, out) = (luts.to_str().unwrap(), out.to_str().unwrap());
        tmlut(&["shader", &scene, "--luts", luts, "--out", out, "--reference-views", views])
    };
    let first = shader(&files, "0");
    assert!(first.status.success(), "{}", stderr(&first));
    let before = snapshot(&out);
    assert_eq!(before.len(), 3, "{:?}", before.iter().map(|f| &f.0).collect::<Vec<_>>());
    // A second run whose last file cannot be put in place (a folder holds its name) fails and
    // changes nothing: not the shaders it would have written before that file.
    let reference = before[0].0.replace(".hlsl", ".reference.json");
    std::fs::create_dir(out.join(&reference)).unwrap();
    let failed = shader(&arrays, "3");
    assert_clean_failure(&failed, &[&reference]);
    std::fs::remove_dir(out.join(&reference)).unwrap();
    assert_eq!(snapshot(&out), before);
    // Without the obstacle the set is replaced whole, and no staging folder is left.
    assert!(shader(&arrays, "3").status.success());
    let after = snapshot(&out);
    assert_eq!(after.len(), 4);
    assert_ne!(after.iter().find(|f| f.0.ends_with(".wgsl")), before.iter().find(|f| f.0.ends_with(".wgsl")));
    assert!(std::fs::read_dir(&out).unwrap().flatten().all(|e| e.path().is_file()), "{after:?}");
}

/// Builds the small set's TIR table into `dir/tables` and fits the repository's logistic TIR
/// form to it into `dir/<out>` with `extra` options; returns the fit's folder.
fn fit_tir_logistic(dir: &Path, config: &Path, out: &str, extra: &[&str]) -> PathBuf {
    let tables = dir.join("tables");
    if !tables.join("tir.dds").is_file() {
        let output = build(config, &tables, &["--only", "tir"]);
        assert!(output.status.success(), "{}", stderr(&output));
    }
    let form = Path::new(env!("CARGO_MANIFEST_DIR")).join("luts/forms/tir-logistic.toml");
    fit_form(&form, &tables.join("tir.dds"), &dir.join(out), extra)
}

/// `tmlut fit --form FORM --table TABLE --out OUT --starts 1` with `extra`, which must succeed;
/// returns `OUT`.
fn fit_form(form: &Path, table: &Path, out: &Path, extra: &[&str]) -> PathBuf {
    let mut args = vec!["fit", "--form", form.to_str().unwrap(), "--table", table.to_str().unwrap()];
    args.extend(["--out", out.to_str().unwrap(), "--starts", "1"]);
    args.extend_from_slice(extra);
    let output = tmlut(&args);
    assert!(output.status.success(), "{}", stderr(&output));
    out.to_path_buf()
}

/// The copper pot with `tir = TIR`, written into `dir/name.toml`.
fn copper_pot_with_tir(dir: &Path, name: &str, tir: &str) -> PathBuf {
    let scene = dir.join(format!("{name}.toml"));
    let text = std::fs::read_to_string(scene_path("copper-pot")).unwrap();
    std::fs::write(&scene, text.replace("tir = \"table\"", &format!("tir = \"{tir}\""))).unwrap();
    scene
}

#[test]
fn a_scene_naming_a_fitted_form_is_built_furnaced_and_ranked_with_it() {
    use tmlut::fit::text::FittedForm;
    use tmlut::fit::text::fitted::FittedFormExt;
    use tmlut::furnace::report::FurnaceReport;
    use tmlut::model::folder::{FgdSource, FolderTables};
    use tmlut::model::{AlbedoPath, Lookup, Material, Quantity, Tables, TirPath};

    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    fit_tir_logistic(dir.path(), &config, "logistic", &["--max-evaluations", "300"]);
    let scene = copper_pot_with_tir(dir.path(), "pot", "fit:logistic");
    let luts = dir.path().join("luts");
    let output = build(&config, &luts, &["--scene", scene.to_str().unwrap()]);
    assert!(output.status.success(), "{}", stderr(&output));
    let out = dir.path().join("furnace");
    let (config_arg, out_arg) = (config.to_str().unwrap(), out.to_str().unwrap());
    let small = ["--views", "8", "--exact-nodes", "4"];
    let mut args = vec!["furnace", scene.to_str().unwrap(), "--config", config_arg, "--out", out_arg];
    args.extend(["--luts", luts.to_str().unwrap(), "--walk", "none", "--pictures", "none"]);
    args.extend(small);
    let output = tmlut(&args);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(stdout(&output).contains("fgd / fit:logistic"), "{}", stdout(&output));

    // The furnace's error in the material is the CPU model's with the form: every TIR lookup
    // answered by the form evaluated here, the others by the built folder.
    let report = FurnaceReport::read(&out.join("copper-pot").join("furnace.json")).unwrap();
    let m = &report.materials[0];
    assert!(m.errors.table.max_all.is_finite() && m.errors.table.max_all > 0.0, "{:?}", m.errors.table);
    let form =
        FittedForm::read(&dir.path().join("logistic"), "logistic", tmlut::fit::text::fitted::TIR_TABLES).unwrap();
    assert_eq!(m.tir_form.as_ref(), Some(&form));
    let folder = LutFolder::open(&luts).unwrap();
    let others = FolderTables::open(&folder, AlbedoPath::Fgd, TirPath::Off, FgdSource::Packing).unwrap();
    let evaluator = form.evaluator().unwrap();
    let by_hand = |l: &Lookup| {
        if l.quantity == Quantity::Tir { evaluator.tir(l.mu, l.alpha, l.eta) } else { others.value(l) }
    };
    let model = Material::new(m.model, m.stack.clone());
    let curve: Vec<_> = m.mu.iter().map(|&mu| model.albedo(mu, &by_hand)).collect();
    assert_eq!(curve, m.albedo_tables);

    // The build records the form, writes no TIR table, and its scene shader calls the form.
    let manifest = Manifest::read(&luts.join(MANIFEST_FILE)).unwrap();
    let plan = &manifest.scene.as_ref().expect("the scene is recorded").plan;
    assert_eq!(plan.tir_forms, std::slice::from_ref(&form));
    assert!(manifest.files.keys().all(|f| !f.starts_with("tir")), "{:?}", manifest.files.keys());
    let wgsl = std::fs::read_to_string(luts.join("copper_pot.wgsl")).unwrap();
    assert!(wgsl.contains("fn tmlut_tir_logistic(mu: f32, alpha: f32, eta: f32) -> f32"), "{wgsl}");
    assert!(wgsl.contains(" = tmlut_tir_logistic("), "{wgsl}");
    assert!(common::validate_wgsl_files(&luts) >= 1);
    let hlsl = std::fs::read_to_string(luts.join("copper_pot.hlsl")).unwrap();
    assert!(hlsl.contains(" = tmlut_tir_logistic("), "{hlsl}");
    assert_eq!(shader_functions(&wgsl), shader_functions(&hlsl), "the two languages define different functions");
    // The shader run on the CPU reads the form as the CPU evaluator does.
    super::shader::shader_against_the_cpu(&luts, std::slice::from_ref(&scene), 16).assert_agrees(&["tir form"]);

    // Ranked in the material: the same error for the form, the table's beside it.
    let ranked = dir.path().join("ranked");
    let mut args = vec!["fit", "--scene", scene.to_str().unwrap(), "--form", "logistic"];
    args.extend(["--config", config_arg, "--out", ranked.to_str().unwrap()]);
    args.extend(small);
    let output = Command::new(env!("CARGO_BIN_EXE_tmlut")).current_dir(dir.path()).args(&args).output().unwrap();
    assert!(output.status.success(), "{}", stderr(&output));
    let ranking: tmlut::furnace::forms::FormRanking =
        serde_json::from_slice(&std::fs::read(ranked.join("ranking.json")).unwrap()).unwrap();
    assert_eq!(ranking.forms.len(), 1);
    assert_eq!(ranking.forms[0].max_error, m.errors.table.max_all);
    assert!(ranking.table.max_error.is_finite() && ranking.table.max_error < ranking.forms[0].max_error);
    assert!(stdout(&output).contains("| 1 | `tir_logistic` (fit:logistic) |"), "{}", stdout(&output));
}

#[test]
fn a_scene_naming_an_albedo_form_reads_it_in_place_of_the_karis_table() {
    use tmlut::fit::text::FittedForm;
    use tmlut::fit::text::fitted::FittedFormExt;
    use tmlut::furnace::report::FurnaceReport;
    use tmlut::model::folder::{FgdSource, FolderTables};
    use tmlut::model::{AlbedoPath, Lookup, Material, Quantity, Tables, TirPath};

    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let karis = dir.path().join("karis");
    let output = build(&config, &karis, &["--only", "karis"]);
    assert!(output.status.success(), "{}", stderr(&output));
    // UE4's mobile approximation of the split sum, fitted to the Karis table.
    let form = Path::new(env!("CARGO_MANIFEST_DIR")).join("luts/forms/karis-env-brdf-approx.toml");
    let fitted = dir.path().join("env-brdf");
    fit_form(&form, &karis.join("karis.dds"), &fitted, &["--max-evaluations", "300", "--timing-runs", "0"]);
    let pot = |name: &str, albedo: &str| {
        let scene = dir.path().join(format!("{name}.toml"));
        let text = std::fs::read_to_string(scene_path("copper-pot")).unwrap();
        std::fs::write(&scene, text.replace("albedo = \"fgd\"", &format!("albedo = \"{albedo}\""))).unwrap();
        scene
    };
    let (with_form, with_table) = (pot("form-pot", "fit:env-brdf"), pot("table-pot", "karis"));
    let config_arg = config.to_str().unwrap();
    let furnace = |scene: &Path, name: &str| {
        let luts = dir.path().join(format!("{name}-luts"));
        let output = build(&config, &luts, &["--scene", scene.to_str().unwrap()]);
        assert!(output.status.success(), "{}", stderr(&output));
        let out = dir.path().join(format!("{name}-furnace"));
        let mut args = vec!["furnace", scene.to_str().unwrap(), "--config", config_arg, "--out", out.to_str().unwrap()];
        args.extend(["--luts", luts.to_str().unwrap(), "--walk", "none", "--pictures", "none"]);
        args.extend(["--views", "8", "--exact-nodes", "4"]);
        let output = tmlut(&args);
        assert!(output.status.success(), "{}", stderr(&output));
        (luts, FurnaceReport::read(&out.join("copper-pot").join("furnace.json")).unwrap(), stdout(&output))
    };
    let (luts, report, printed) = furnace(&with_form, "form");
    assert!(printed.contains("fit:env-brdf / table"), "{printed}");
    // The shader run on the CPU reads the form as the CPU evaluator does.
    super::shader::shader_against_the_cpu(&luts, std::slice::from_ref(&with_form), 16).assert_agrees(&["albedo form"]);

    // The furnace reads the form for every albedo lookup (F0 scale + bias, in f32 as the shader
    // computes it) and the folder for the rest.
    let m = &report.materials[0];
    let form = FittedForm::read(&fitted, "env-brdf", tmlut::fit::text::fitted::ALBEDO_TABLES).unwrap();
    assert_eq!((m.albedo_form.as_ref(), m.albedo_path), (Some(&form), AlbedoPath::Karis));
    let folder = LutFolder::open(&luts).unwrap();
    let others = FolderTables::open(&folder, AlbedoPath::Karis, TirPath::Table, FgdSource::Packing).unwrap();
    let evaluator = form.evaluator().unwrap();
    let by_hand = |l: &Lookup| match l.quantity {
        Quantity::Albedo => {
            let v = evaluator.channels(&[l.mu as f32, l.alpha as f32]);
            let f0 = tmlut::physics::normal_incidence_reflectance(l.eta, l.kappa);
            f0 * f64::from(v[0]) + f64::from(v[1])
        }
        _ => others.value(l),
    };
    let model = Material::new(m.model, m.stack.clone());
    let curve: Vec<_> = m.mu.iter().map(|&mu| model.albedo(mu, &by_hand)).collect();
    assert_eq!(curve, m.albedo_tables);
    // Read in place of the table: another curve. Both carry the split sum's own error (Schlick's
    // F0 weighting against the copper's exact FGD), which dominates either's.
    let (_, table_report, _) = furnace(&with_table, "table");
    let table_material = &table_report.materials[0];
    assert_ne!(m.albedo_tables, table_material.albedo_tables);
    let (form_error, table_error) = (m.errors.table.max_all, table_material.errors.table.max_all);
    assert!(form_error.is_finite() && form_error > 0.0 && table_error > 0.0, "form {form_error}, table {table_error}");

    // The build records the form and writes no albedo table; its scene shader calls the form.
    let manifest = Manifest::read(&luts.join(MANIFEST_FILE)).unwrap();
    let plan = &manifest.scene.as_ref().expect("the scene is recorded").plan;
    assert_eq!(plan.albedo_forms, std::slice::from_ref(&form));
    assert!(plan.tir_forms.is_empty());
    assert!(
        manifest.files.keys().all(|f| !f.starts_with("karis") && !f.starts_with("fgd")),
        "{:?}",
        manifest.files.keys()
    );
    let wgsl = std::fs::read_to_string(luts.join("copper_pot.wgsl")).unwrap();
    assert!(wgsl.contains("fn tmlut_karis_env_brdf_approx(mu: f32, alpha: f32) -> vec2<f32>"), "{wgsl}");
    // F0 scale + bias: the form's two channels weighed as the table's are.
    assert!(wgsl.contains("dot(vec2<f32>(0.0022675737, 1.0), tmlut_karis_env_brdf_approx(v"), "{wgsl}");
    assert!(common::validate_wgsl_files(&luts) >= 1);
    let hlsl = std::fs::read_to_string(luts.join("copper_pot.hlsl")).unwrap();
    assert_eq!(shader_functions(&wgsl), shader_functions(&hlsl), "the two languages define different functions");

    // A form fitted to the 4D FGD table reads every albedo lookup at the interface's own indices.
    let fgd = dir.path().join("fgd");
    let output = build(&config, &fgd, &["--only", "fgd"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let schlick = dir.path().join("fgd-schlick.toml");
    std::fs::write(
        &schlick,
        "table = \"fgd\"\n[parameters]\np = { start = 1.0, min = 0.0, max = 2.0 }\n[let]\n\
         f0 = \"((eta - 1)^2 + kappa^2) / ((eta + 1)^2 + kappa^2)\"\n[channels]\nfgd = \"f0 + (1 - f0) * (1 - mu)^5 * p\"\n",
    )
    .unwrap();
    fit_form(&schlick, &fgd.join("fgd.exr"), &dir.path().join("schlick"), &["--timing-runs", "0"]);
    let schlick_pot = pot("schlick-pot", "fit:schlick");
    let (luts, report, printed) = furnace(&schlick_pot, "schlick");
    assert!(printed.contains("fit:schlick / table"), "{printed}");
    super::shader::shader_against_the_cpu(&luts, std::slice::from_ref(&schlick_pot), 16)
        .assert_agrees(&["albedo form"]);
    let m = &report.materials[0];
    assert_eq!(m.albedo_path, AlbedoPath::Fgd);
    assert!(m.errors.table.max_all.is_finite() && m.errors.table.max_all > 0.0, "{:?}", m.errors.table);
    let wgsl = std::fs::read_to_string(luts.join("copper_pot.wgsl")).unwrap();
    assert!(wgsl.contains("fn tmlut_fgd_schlick(mu: f32, alpha: f32, eta: f32, kappa: f32) -> f32"), "{wgsl}");
    // Read at the view-dependent cosine of the top interface (a `let` of the recorded model), at
    // that interface's constant roughness and indices.
    let call = wgsl.split("= tmlut_fgd_schlick(v").nth(1).expect("the form is read").lines().next().unwrap();
    assert!(call.ends_with(", 0.01, 1.1, 0.0);"), "{call}");
    assert!(common::validate_wgsl_files(&luts) >= 1);
    let manifest = Manifest::read(&luts.join(MANIFEST_FILE)).unwrap();
    assert!(manifest.files.keys().all(|f| !f.starts_with("fgd")), "{:?}", manifest.files.keys());

    // A TIR form is no albedo form.
    fit_tir_logistic(dir.path(), &config, "logistic", &["--max-evaluations", "10"]);
    let scene = pot("tir-pot", "fit:logistic");
    let output = tmlut(&["plan", scene.to_str().unwrap(), "--config", config_arg]);
    assert!(!output.status.success());
    let message = stderr(&output);
    assert!(message.contains("fitted to table `tir`") && message.contains("`karis` or `fgd`"), "{message}");
}

#[test]
fn a_scene_naming_a_form_that_cannot_serve_is_refused_with_what_is_allowed() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    fit_tir_logistic(dir.path(), &config, "unfitted", &["--max-evaluations", "0"]);
    let plan = |tir: &str| {
        let scene = copper_pot_with_tir(dir.path(), "pot", tir);
        let output = tmlut(&["plan", scene.to_str().unwrap(), "--config", config.to_str().unwrap()]);
        assert!(!output.status.success(), "{tir}: accepted");
        let message = stderr(&output);
        assert!(!message.contains("panicked"), "{message}");
        assert!(message.contains("pot.toml: tir: "), "{tir}: {message}");
        message
    };
    let missing = plan("fit:nowhere");
    assert!(missing.contains("tir: fit:nowhere (") && missing.contains("no such file"), "{missing}");
    assert!(missing.contains("allowed: \"fit:PATH\""), "{missing}");
    let unfitted = plan("fit:unfitted");
    assert!(unfitted.contains("unfitted") && unfitted.contains("--max-evaluations"), "{unfitted}");
    // A form fitted to another table: its fit.json as written, with the table renamed.
    let other = dir.path().join("other");
    std::fs::create_dir_all(&other).unwrap();
    let json = std::fs::read_to_string(dir.path().join("unfitted").join("fit.json")).unwrap();
    std::fs::write(other.join("fit.json"), json.replace("\"table\": \"tir\"", "\"table\": \"karis\"")).unwrap();
    let wrong = plan("fit:other/fit.json");
    assert!(wrong.contains("fitted to table `karis`") && wrong.contains("table `tir`"), "{wrong}");
    let bare = plan("fit:");
    assert!(bare.contains("names no form"), "{bare}");
    let path_only = plan("form");
    assert!(path_only.contains("names no form") && path_only.contains("\"fit:PATH\""), "{path_only}");
}

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

#[test]
fn an_unchanged_scene_build_is_restored_whole_from_the_cache_and_a_damaged_one_is_built_again() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let cache = dir.path().join("cache");
    let scene = scene_path("copper-pot");
    let args = ["--scene", scene.as_str(), "--cache", cache.to_str().unwrap()];
    let first = dir.path().join("first");
    let output = build(&config, &first, &args);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(!stdout(&output).contains("restored whole"), "{}", stdout(&output));
    // Into a new folder and into the same one: the first build's files, byte for byte.
    for out in [dir.path().join("second"), first.clone()] {
        let output = build(&config, &out, &args);
        assert!(output.status.success(), "{}", stderr(&output));
        assert!(stdout(&output).contains("restored whole from the table cache"), "{}", stdout(&output));
        assert_eq!(snapshot(&first), snapshot(&out));
        assert!(LutFolder::open(&out).is_ok());
    }
    // Another seed is another build.
    let reseeded = dir.path().join("reseeded");
    let mut with_seed = args.to_vec();
    with_seed.extend(["--seed", "7"]);
    let output = build(&config, &reseeded, &with_seed);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(!stdout(&output).contains("restored whole"));
    // A kept file damaged: noticed by its hash, never restored; the build runs and keeps it again.
    // The first build's manifest, as the cache keeps it (by its SHA-256): a file of that build's
    // record, whatever other builds the cache holds.
    let manifest_sha256 = tmlut::loader::sha256_hex(&std::fs::read(first.join(MANIFEST_FILE)).unwrap());
    let object = cache.join(format!("{manifest_sha256}.object"));
    assert!(object.is_file(), "{}", object.display());
    let mut bytes = std::fs::read(&object).unwrap();
    let last = bytes.len() - 2;
    bytes[last] ^= 1;
    std::fs::write(&object, &bytes).unwrap();
    let third = dir.path().join("third");
    let output = build(&config, &third, &args);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(stderr(&output).contains("does not hold the bytes of its name"), "{}", stderr(&output));
    assert_eq!(snapshot(&first).len(), snapshot(&third).len());
    let output = build(&config, &dir.path().join("fourth"), &args);
    assert!(stdout(&output).contains("restored whole"), "{}", stdout(&output));
    // A folder holding a table the build does not write is built into, not restored over.
    let other = dir.path().join("other");
    assert!(build(&config, &other, &["--only", "karis"]).status.success());
    let output = build(&config, &other, &args);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(stderr(&output).contains("which that build did not write"), "{}", stderr(&output));
    // A scene's warnings are its own, not the build's: a restored build states them too.
    let warned = dir.path().join("warned.toml");
    let text = std::fs::read_to_string(&scene).unwrap()
        + "\n[[material.layer]]\ntype = \"interface\"\neta = 1.5\nalpha = 0.1\n";
    std::fs::write(&warned, text).unwrap();
    let warned_args = ["--scene", warned.to_str().unwrap(), "--cache", cache.to_str().unwrap()];
    for (out, restored) in [("warned-first", false), ("warned-second", true)] {
        let output = build(&config, &dir.path().join(out), &warned_args);
        assert!(output.status.success(), "{}", stderr(&output));
        assert_eq!(stdout(&output).contains("restored whole"), restored, "{out}: {}", stdout(&output));
        assert!(stderr(&output).contains("below the opaque conductor"), "{out}: {}", stderr(&output));
    }
}

#[test]
fn a_build_the_cache_keeps_whole_is_restored_only_once_its_tables_agree_with_the_exact_integral() {
    use tmlut::scene::build::{SceneBuildRequest, SliceLayout, build_scene, verify_restored};
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("luts");
    let files = tmlut::scene::library::read_scene_files(&[PathBuf::from(scene_path("copper-pot"))]).unwrap();
    let config = tmlut::config::Config::from_toml(SMALL_SET, "small").unwrap();
    // A file per slice, so that one slice is forged with its entry alone.
    let request = SceneBuildRequest {
        slice_layout: SliceLayout::Files,
        ..tmlut::scene::library::build_request(&files, config, out.clone()).unwrap()
    };
    build_scene(&request, &()).unwrap();
    verify_restored(&request, &out).unwrap();

    // A slice's every value raised by 0.25, its file, entry and seal made consistent again: what
    // an editor of the cache's objects and record can write. The loader and `check` see a
    // consistent folder; the exact integral does not.
    let mut manifest = Manifest::read(&out.join(MANIFEST_FILE)).unwrap();
    let (file, entry) =
        manifest.files.iter_mut().find(|(f, e)| e.table.starts_with("fgd_") && f.ends_with(".dds")).unwrap();
    let (file, slice) = (file.clone(), entry.table.clone());
    let path = out.join(&file);
    let mut table = tmlut::loader::load_table(&path).unwrap();
    table.data.iter_mut().for_each(|v| *v += 0.25);
    tmlut::formats::dds::write_dds(&path, &table, entry.precision).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    entry.sha256 = tmlut::loader::sha256_hex(&bytes);
    entry.value_range = entry.value_range.map(|v| v + 0.25);
    entry.seal();
    manifest.write(&out).unwrap();
    assert!(LutFolder::open(&out).unwrap().load(&file).is_ok());
    let refused = verify_restored(&request, &out).unwrap_err();
    assert!(refused.contains(&slice) && refused.contains("exact integral"), "{refused}");
}
