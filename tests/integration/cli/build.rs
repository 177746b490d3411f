//! `tmlut build`: the files, manifest and scene shaders a build writes, the same bytes from the same
//! seed, refused configurations and arguments, slice layouts, and the table cache.

use std::path::{Path, PathBuf};
use std::process::Command;

use super::{
    assert_clean_failure, build, scene_path, shader_functions, small_library_args, small_set_written_as, snapshot,
    stderr, stdout, tmlut, write_config,
};
use crate::common;

use common::SMALL_SET;
use tmlut::formats::manifest::{MANIFEST_FILE, Manifest, write_manifest};
use tmlut::loader::LutFolder;

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

/// The energy-compensation tables at a few nodes and samples.
const ENERGY_COMPENSATION: &str = "
[ggx_e]
mu_count = 8
alpha_count = 6
[ggx_e.sampling]
samples = 1024
replicates = 4
[ggx_e.reference]
cells = 4
nodes = 12
[ggx_e.interpolation]
points = 16
nodes = 8
[ggx_e_avg]
alpha_count = 6
mu_nodes = 4
[ggx_e_avg.sampling]
samples = 1024
replicates = 4
[ggx_e_avg.reference]
cells = 2
nodes = 6
[ggx_e_avg.interpolation]
points = 8
nodes = 6
[karis_multiscatter]
mu_count = 8
roughness_count = 6
[karis_multiscatter.sampling]
samples = 1024
replicates = 4
[karis_multiscatter.reference]
cells = 4
nodes = 8
[karis_multiscatter.interpolation]
points = 16
nodes = 8
";

#[test]
fn the_energy_compensation_tables_are_built_when_named_and_read_by_their_handles() {
    use tmlut::loader::{Alpha, GgxEAvgLut, GgxELut, KarisMultiscatterLut, Roughness};
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), ENERGY_COMPENSATION);
    let out = dir.path().join("luts");
    let output = build(&config, &out, &["--only", "ggx_e,ggx_e_avg,karis_multiscatter"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let manifest = Manifest::read(&out.join(MANIFEST_FILE)).unwrap();
    for file in ["ggx_e.dds", "ggx_e_avg.exr", "karis_multiscatter.dds"] {
        let entry = manifest.entry(file).unwrap_or_else(|| panic!("{file} in the manifest"));
        assert_eq!(entry.masking.as_deref(), Some("smith-height-correlated"), "{file}");
    }
    for file in ["ggx_e.dds", "ggx_e_avg.exr"] {
        let notes = &manifest.entry(file).unwrap().notes;
        assert!(notes.iter().any(|n| n.starts_with("Node-aligned")), "{file}: {notes:?}");
    }
    let folder = LutFolder::open(&out).unwrap();
    let (e, average) = (GgxELut::from_folder(&folder).unwrap(), GgxEAvgLut::from_folder(&folder).unwrap());
    // A mirror keeps everything, at every view and on average.
    assert_eq!((e.sample(0.3, Alpha(0.0)), average.sample(Alpha(0.0))), (1.0, 1.0));
    // The average over views lies between the views' albedos, at every roughness node.
    let alpha_axis = &average.table().axes[0];
    for k in 1..alpha_axis.count {
        let alpha = alpha_axis.node_value(k) as f32;
        let views: Vec<f32> = (0..=32).map(|j| e.sample(j as f32 / 32.0, Alpha(alpha))).collect();
        let (low, high) = views.iter().fold((f32::MAX, f32::MIN), |(l, h), &v| (l.min(v), h.max(v)));
        let value = average.sample(Alpha(alpha));
        assert!(low <= value && value <= high && value < 1.0, "alpha {alpha}: {value} outside [{low}, {high}]");
    }
    // The multiple-scattering split sum: its F90 part never above its albedo, as stored in f16.
    let multiscatter = KarisMultiscatterLut::from_folder(&folder).unwrap();
    for j in 0..=16 {
        for k in 0..=16 {
            let [bias, albedo] = multiscatter.sample_gpu(j as f32 / 16.0, Roughness(k as f32 / 16.0));
            assert!(0.0 <= bias && bias <= albedo && albedo <= 1.0, "({j}, {k}): bias {bias}, albedo {albedo}");
        }
    }
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
    write_manifest(&without_dds, &out).unwrap();
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
    write_manifest(&damaged, &arrays).unwrap();
    let error = LutFolder::open(&arrays).unwrap().scene_slices(|_| true).unwrap_err().to_string();
    assert!(error.contains(&name) && error.contains("outside the array"), "{error}");
    let checked = check();
    assert_eq!(checked.status.code(), Some(1), "{}", stdout(&checked));
    assert!(stdout(&checked).contains(&name), "{}", stdout(&checked));
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

#[test]
fn scene_shaders_cover_the_6_flux_model_the_split_sum_tables_and_the_3d_tir_table() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    for (scene, stem, expected) in [
        ("scattering", "scattering", &["fn tm_scattering_stack(", "sinh("][..]),
        ("thesis/split-sum", "thesis_split_sum", &["fn tm_varnished_copper_belcour(", "dot(vec4<f32>("]),
        ("gpu-check/varied-coats", "varied_coats", &["tmh_trilinear(", "tmh_acos(", "fn fgd_lossless("]),
        ("gpu-check/stiff-stacks", "stiff_stacks", &["fn tm_bare_conductor_2_flux(", "fn tmh_slices0("]),
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
    write_manifest(&manifest, &out).unwrap();
    std::fs::remove_file(out.join("fgd_rarer.dds")).unwrap();
    let without = open(&LutFolder::open(&out).unwrap());
    for l in &rarer {
        assert_ne!(with_rarer.value(l), without.value(l), "{l:?}");
    }
    for l in &others {
        assert_eq!(with_rarer.value(l), without.value(l), "{l:?}");
    }
}

#[test]
fn the_loader_reads_a_built_folder_from_memory_as_from_disk() {
    use tmlut::error::Error;
    use tmlut::loader::{InMemory, TirLut};

    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), SMALL_SET);
    let out = dir.path().join("luts");
    let output = build(&config, &out, &["--only", "karis,tir"]);
    assert!(output.status.success(), "{}", stderr(&output));
    // Every file of the folder held in memory, named by the folder's path; one byte of `damaged` flipped.
    let held = |damaged: Option<&str>| {
        let mut files = InMemory::new(&out);
        for (name, mut bytes) in snapshot(&out) {
            if Some(name.as_str()) == damaged {
                let last = bytes.len() - 1;
                bytes[last] ^= 1;
            }
            files.insert(name, bytes);
        }
        files
    };
    let on_disk = LutFolder::open(&out).unwrap();
    let in_memory = LutFolder::from_source(held(None)).unwrap();
    assert_eq!(in_memory.manifest(), on_disk.manifest());
    let files: Vec<&str> = on_disk.files().collect();
    assert!(files.contains(&"tir.dds") && files.contains(&"karis.exr"), "{files:?}");
    for file in files {
        assert_eq!(in_memory.load(file).unwrap(), on_disk.load(file).unwrap(), "{file}");
    }
    let fit = on_disk.tir_fit().expect("the build's fitted TIR form");
    for shader in &fit.shaders {
        assert_eq!(in_memory.shader(shader).unwrap(), on_disk.shader(shader).unwrap(), "{}", shader.file);
    }

    // A damaged byte: the same error, whether the file is read from memory or from disk.
    let from_memory = TirLut::from_folder(&LutFolder::from_source(held(Some("tir.dds"))).unwrap()).unwrap_err();
    assert!(matches!(from_memory, Error::Mismatch { .. }), "{from_memory:?}");
    let mut bytes = std::fs::read(out.join("tir.dds")).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 1;
    std::fs::write(out.join("tir.dds"), bytes).unwrap();
    let from_disk = TirLut::from_folder(&LutFolder::open(&out).unwrap()).unwrap_err();
    assert_eq!(from_memory.to_string(), from_disk.to_string());
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
fn a_build_in_another_container_or_precision_reads_every_table_from_the_cache_and_writes_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let scenes = small_library_args();
    let cached_args: Vec<&str> =
        scenes.iter().map(String::as_str).chain(["--cache", cache.to_str().unwrap()]).collect();
    let uncached_args: Vec<&str> = scenes.iter().map(String::as_str).collect();
    let configuration = |name: &str, text: &str| {
        let path = dir.path().join(format!("{name}.toml"));
        std::fs::write(&path, text).unwrap();
        path
    };
    // (slices read from the cache, slices) from the build's summary; (tables read from the cache,
    // tables) from its note on the cache.
    let from_cache = |output: &std::process::Output| {
        let (out, err) = (stdout(output), stderr(output));
        let slices = out.split(" tables (").nth(1).and_then(|rest| rest.split_once(" of them from the cache")).map(
            |(head, _)| {
                let (total, read) = head.split_once(" slices, ").unwrap();
                (read.parse::<usize>().unwrap(), total.parse::<usize>().unwrap())
            },
        );
        let tables = err.lines().find_map(|line| line.strip_suffix(" tables read from it")).map(|head| {
            let (read, total) = head.rsplit_once(": ").unwrap().1.split_once(" of ").unwrap();
            (read.parse::<usize>().unwrap(), total.parse::<usize>().unwrap())
        });
        (slices.unwrap_or_else(|| panic!("no summary in {out}")), tables.unwrap_or_else(|| panic!("no note in {err}")))
    };

    let dds_f32 = configuration("dds-f32", &small_set_written_as("dds", "f32"));
    let output = build(&dds_f32, &dir.path().join("dds-f32"), &cached_args);
    assert!(output.status.success(), "{}", stderr(&output));
    let ((read, slices), (_, tables)) = from_cache(&output);
    assert_eq!(read, 0);
    assert!(slices > 16 && tables > slices, "{slices} slices in arrays and full tables besides: {tables} tables");
    // Another container, then another precision: every slice and table from the cache, and the
    // files (the manifest aside: it says where the tables came from) those of a build without it.
    for (name, container, precision) in [("ktx2-f32", "ktx2", "f32"), ("ktx2-f16", "ktx2", "f16")] {
        let config = configuration(name, &small_set_written_as(container, precision));
        let cached = dir.path().join(format!("{name}-cached"));
        let output = build(&config, &cached, &cached_args);
        assert!(output.status.success(), "{}", stderr(&output));
        assert_eq!(from_cache(&output), ((slices, slices), (tables, tables)), "{name}");
        let uncached = dir.path().join(format!("{name}-uncached"));
        let output = build(&config, &uncached, &uncached_args);
        assert!(output.status.success(), "{}", stderr(&output));
        let (with, without) = (snapshot(&cached), snapshot(&uncached));
        assert_eq!(with.iter().map(|f| &f.0).collect::<Vec<_>>(), without.iter().map(|f| &f.0).collect::<Vec<_>>());
        assert!(
            with.iter().any(|(file, _)| file.ends_with(".ktx2"))
                && !with.iter().any(|(file, _)| file.ends_with(".dds"))
        );
        for ((file, a), (_, b)) in with.iter().zip(&without) {
            assert!(file == MANIFEST_FILE || a == b, "{name}: {file} differs");
        }
    }
    // Each container's build is kept whole under its own key: the first is restored, not rewritten.
    let output = build(&dds_f32, &dir.path().join("dds-f32-again"), &cached_args);
    assert!(stdout(&output).contains("restored whole from the table cache"), "{}", stdout(&output));
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
    write_manifest(&manifest, &out).unwrap();
    assert!(LutFolder::open(&out).unwrap().load(&file).is_ok());
    let refused = verify_restored(&request, &out).unwrap_err();
    assert!(refused.contains(&slice) && refused.contains("exact integral"), "{refused}");
}
