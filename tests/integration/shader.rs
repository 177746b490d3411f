//! The scene shader run on the CPU ([`super::emulator`]) against the CPU evaluator, as
//! `scripts/gpu-check` runs it on a GPU API: the same values on any machine, Vulkan or not.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use super::common::{SMALL_SET, build_config};
use super::emulator::{Emulator, Value};
use tmlut::formats::manifest::Manifest;
use tmlut::loader::{LutFolder, sample_texture};
use tmlut::model::folder::{FgdSource, FolderTables};
use tmlut::model::{AlbedoPath, TirPath};
use tmlut::scene::library::{merge, read_scene_files};
use tmlut::scene::shader_files::{reference, shader_materials};
use tmlut::shader::scene::{DISPATCH, SceneShader, generate, per_material_module};
use tmlut::shader::{Item, Lang};

/// The largest difference `gpu_check.py` allows: of the albedo, top albedo, lobe energies and
/// cosines, and of the lobes' roughness and GD weighed by their energy.
const TOLERANCE: f64 = 1e-5;

fn scene(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("luts/scenes").join(format!("{name}.toml"))
}

/// How far the scene shader of a folder, run in the emulator, is from the CPU evaluator.
pub struct Comparison {
    /// The largest difference of the albedo, top albedo, lobe energies and cosines, and where.
    pub values: (f64, String),
    /// The largest difference of the lobes' roughness and GD weighed by their energy, and where.
    pub shapes: (f64, String),
    /// What the materials read (`MaterialFunction::reads`).
    pub reads: BTreeSet<String>,
}

impl Comparison {
    /// Both differences within [`TOLERANCE`], and every one of `reads` read by some material.
    pub fn assert_agrees(&self, reads: &[&str]) {
        for read in reads {
            assert!(self.reads.contains(*read), "no material reads {read}: {:?}", self.reads);
        }
        assert!(self.values.0 <= TOLERANCE, "values: {:?}", self.values);
        assert!(self.shapes.0 <= TOLERANCE, "lobe shapes weighed by energy: {:?}", self.shapes);
    }
}

/// The shader of `scenes` (one library) over their build `luts`, run in the emulator, against the
/// CPU evaluator's reference at `views` views and the stiff ones per material. Checks that the
/// module run is the one the build wrote beside its tables; panics on a value that is not finite.
pub fn shader_against_the_cpu(luts: &Path, scenes: &[PathBuf], views: usize) -> Comparison {
    let library = merge(&read_scene_files(scenes).unwrap()).unwrap();
    let materials = shader_materials(&library).unwrap();
    let folder = LutFolder::open(luts).unwrap();
    let shader = generate(&folder, &materials).unwrap();
    let described: Vec<PathBuf> = std::fs::read_dir(luts)
        .unwrap()
        .map(|entry| entry.unwrap().path())
        .filter(|path| path.to_string_lossy().ends_with(".shader.json"))
        .collect();
    let [description] = &described[..] else { panic!("{described:?}: one scene shader") };
    let written = description.to_string_lossy().replace(".shader.json", ".wgsl");
    assert_eq!(std::fs::read_to_string(&written).unwrap(), shader.module.print(Lang::Wgsl), "{written}");
    let constants = description.to_string_lossy().replace(".shader.json", ".constants.bin");
    assert_eq!(std::fs::read(&constants).unwrap(), shader.constants_bytes(), "{constants}");
    let points = reference(&folder, &shader, &materials, views).unwrap();
    let emulator = Emulator::new(&shader, &folder);
    // Each material's own function, its constants literals: what the shared ones must compute.
    let own = per_material_module(&folder, &materials).unwrap();
    let own_emulator = Emulator::of_module(&own, &shader, &folder);
    assert_filters_are_the_cpu_samplers(&shader, &folder, &emulator);
    let mut worst = [(0.0, String::new()), (0.0, String::new())];
    let mut record = |k: usize, got: f32, expected: f64, weight: f64, at: String| {
        assert!(got.is_finite(), "{at}: {got}");
        let difference = weight * (got as f64 - expected).abs();
        if difference > worst[k].0 {
            worst[k] = (difference, at);
        }
    };
    // The count of each material's function bounds what any of its runs reads and computes.
    let costs = shader.costs().unwrap();
    for point in &points {
        let e = &point.evaluation;
        let run = emulator.run(&point.function, vec![Value::F32(e.mu as f32)]);
        let index = shader.materials.iter().position(|m| m.function == point.function).unwrap();
        let counted = costs[index];
        let mu = Value::F32(e.mu as f32);
        let dispatched = emulator.call(DISPATCH, vec![Value::U32(index as u32), mu.clone()]);
        assert_eq!(dispatched, run.value, "{DISPATCH}({index}, {}) against {}", e.mu, point.function);
        let unshared = own_emulator.call(&point.function, vec![mu]);
        assert_eq!(unshared, run.value, "{} at mu {}: its own function against its shape's", point.function, e.mu);
        assert!(
            run.cost.texture_reads <= counted.texture_reads && run.cost.operations <= counted.operations,
            "{} at mu {}: ran {:?}, counted {counted:?}",
            point.material,
            e.mu,
            run.cost
        );
        let result = run.value;
        let at = |what: &str| format!("{} at mu {}: {what}", point.material, e.mu);
        for (name, expected) in [("albedo", e.albedo), ("top_albedo", e.top_albedo)] {
            for (c, got) in result.field(name).and_then(Value::components).unwrap().into_iter().enumerate() {
                record(0, got, expected[c], 1.0, at(&format!("{name}[{c}]")));
            }
        }
        let field = |name: &str, k: usize| {
            result.field(name).and_then(|lobes| lobes.element(k)).unwrap_or_else(|| panic!("{name}[{k}]")).clone()
        };
        for (k, lobe) in e.lobes.iter().enumerate() {
            for (c, got) in field("lobe_energy", k).components().unwrap().into_iter().enumerate() {
                record(0, got, lobe.energy[c], 1.0, at(&format!("lobe {k} energy[{c}]")));
            }
            record(
                0,
                field("lobe_cos", k).f32().unwrap(),
                lobe.mean_direction[2],
                1.0,
                at(&format!("lobe {k} cosine")),
            );
            let energy = lobe.energy.into_iter().fold(0.0, f64::max);
            record(
                1,
                field("lobe_roughness", k).f32().unwrap(),
                lobe.roughness,
                energy,
                at(&format!("lobe {k} roughness")),
            );
            record(1, field("lobe_gd", k).f32().unwrap(), lobe.gd, energy, at(&format!("lobe {k} GD")));
        }
    }
    let [values, shapes] = worst;
    eprintln!(
        "{}: {} points ({} materials of {} stack shapes), largest differences {values:?}, {shapes:?}",
        luts.display(),
        points.len(),
        shader.materials.len(),
        shader.shapes.len()
    );
    for (m, cost) in shader.materials.iter().zip(&costs) {
        eprintln!(
            "  {}: {} lobes, {} texture reads, {} operations",
            m.material, m.lobes, cost.texture_reads, cost.operations
        );
    }
    let reads = shader.materials.iter().flat_map(|m| m.reads.iter().cloned()).collect();
    Comparison { values, shapes, reads }
}

/// The module's filtering helpers (`tmh_bilinear`, `tmh_trilinear`), run in the emulator on every
/// texture bound whole (not a layer of a texture array) at coordinates inside, on and past its
/// edges, give the loader's sampler's values bit for bit: both are the filter of
/// `filter`, one printed, one run in f32.
fn assert_filters_are_the_cpu_samplers(shader: &SceneShader, folder: &LutFolder, emulator: &Emulator) {
    let helpers: BTreeSet<&str> = shader
        .module
        .items
        .iter()
        .filter_map(|item| match item {
            Item::Function(function) => Some(function.name.as_str()),
            _ => None,
        })
        .collect();
    let along = [-0.3f32, 0.0, 0.013, 0.25, 0.5, 0.618034, 0.999, 1.0, 1.7];
    let mut compared = 0;
    for binding in shader.textures.iter().filter(|b| !b.layered) {
        let dimension = binding.dimension as usize;
        let helper = match (dimension, binding.channels) {
            (2, _) => "tmh_bilinear",
            (3, 1) if helpers.contains("tmh_trilinear") => "tmh_trilinear",
            _ => continue,
        };
        let table = folder.load(&binding.file).unwrap();
        let points = (0..along.len().pow(dimension as u32))
            .map(|k| (0..dimension).map(|d| along[k / along.len().pow(d as u32) % along.len()]).collect::<Vec<_>>());
        for point in points {
            let mut expected = vec![0.0; table.channel_count()];
            sample_texture(&table, &point, &mut expected).unwrap();
            let mut arguments = vec![Value::Resource(binding.variable.clone())];
            arguments.extend(point.iter().map(|&x| Value::F32(x)));
            arguments.extend(binding.extent[..dimension].iter().map(|&n| Value::F32(n as f32)));
            let got = emulator.call(helper, arguments).components().unwrap();
            for (c, value) in expected.iter().enumerate() {
                assert_eq!(got[c].to_bits(), value.to_bits(), "{helper} of {} at {point:?}, channel {c}", binding.file);
            }
            compared += 1;
        }
    }
    assert!(compared > 0, "no texture bound whole");
}

/// [`shader_against_the_cpu`] over a build of `scenes` of `luts/scenes` with [`SMALL_SET`], its
/// slices laid out as `layout` says.
fn built_and_emulated(scenes: &[&str], layout: &str, views: usize) -> Comparison {
    let dir = tempfile::tempdir().unwrap();
    let paths: Vec<PathBuf> = scenes.iter().map(|s| scene(s)).collect();
    let mut extra = vec!["--slice-layout", layout];
    for path in &paths {
        extra.extend(["--scene", path.to_str().unwrap()]);
    }
    let luts = build_config(dir.path(), SMALL_SET, &extra);
    shader_against_the_cpu(&luts, &paths, views)
}

/// Every scene of `luts/scenes` as one library with its slices in texture arrays: slices, the FGD
/// packing, the Belcour and Karis split sums, the folder's fitted TIR form and GD, in both flux
/// models and the stiff stacks.
#[test]
fn a_library_shader_run_on_the_cpu_gives_the_cpu_evaluators_values() {
    let scenes = [
        "copper-pot",
        "profiling",
        "scattering",
        "textured",
        "gpu-check/stiff-stacks",
        "gpu-check/varied-coats",
        "thesis/layers",
        "thesis/scattering-variants",
        "thesis/split-sum",
        "thesis/tir",
    ];
    let reads = ["fgd slice", "tir slice", "fgd packing", "belcour", "karis", "tir fit", "gd"];
    built_and_emulated(&scenes, "arrays", 16).assert_agrees(&reads);
}

/// A library whose materials share stack shapes, as a studio's does (coated metals, absorbing and
/// scattering coats of several indices, roughnesses and depths): their functions are one per
/// kind of stack, the constants that differ read from the buffer, and each material's values are those of
/// its own function (`shader_against_the_cpu` compares the two bit for bit, and `tm_material` with
/// both) and of the CPU evaluator.
#[test]
fn materials_of_one_stack_shape_share_a_function_and_keep_their_values() {
    let dir = tempfile::tempdir().unwrap();
    let metals = [([0.27, 0.68, 1.22], [3.61, 2.63, 2.29]), ([1.66, 0.96, 0.62], [8.07, 6.69, 5.25])];
    let mut scene = String::from("name = \"shapes\"\nalbedo = \"fgd\"\ntir = \"table\"\n");
    let interface = |eta: String, kappa: String, alpha: f64| {
        format!("[[material.layer]]\ntype = \"interface\"\neta = {eta}\nkappa = {kappa}\nalpha = {alpha}\n")
    };
    let metal = |k: usize, alpha: f64| {
        let (eta, kappa) = metals[k % 2];
        interface(format!("{eta:?}"), format!("{kappa:?}"), alpha)
    };
    for k in 0..4 {
        let coat = interface(format!("{}", 1.35 + 0.07 * k as f64), "0.0".into(), 0.05 + 0.04 * k as f64);
        scene += &format!("\n[[material]]\nname = \"coated-{k}\"\nmodel = \"2-flux\"\n{coat}{}", metal(k, 0.2));
    }
    for k in 0..3 {
        let coat = interface(format!("{}", 1.4 + 0.1 * k as f64), "0.0".into(), 0.1);
        let medium = format!(
            "[[material.layer]]\ntype = \"medium\"\nsigma_k = [{}, 1.0, 0.3]\ndepth = {}\n",
            0.5 + k as f64,
            0.2 + 0.3 * k as f64
        );
        scene +=
            &format!("\n[[material]]\nname = \"absorbing-{k}\"\nmodel = \"2-flux\"\n{coat}{medium}{}", metal(k, 0.3));
    }
    for k in 0..2 {
        let coat = interface(format!("{}", 1.45 + 0.1 * k as f64), "0.0".into(), 0.15);
        let medium = format!(
            "[[material.layer]]\ntype = \"medium\"\nsigma_s = [{}, 0.8, 0.6]\nsigma_k = [0.1, 0.2, 0.3]\ndepth = 0.5\ng = {}\n",
            1.0 + k as f64,
            0.3 + 0.2 * k as f64
        );
        scene +=
            &format!("\n[[material]]\nname = \"scattering-{k}\"\nmodel = \"6-flux\"\n{coat}{medium}{}", metal(k, 0.25));
    }
    let path = dir.path().join("shapes.toml");
    std::fs::write(&path, scene).unwrap();
    let luts = build_config(dir.path(), SMALL_SET, &["--slice-layout", "arrays", "--scene", path.to_str().unwrap()]);
    let comparison = shader_against_the_cpu(&luts, std::slice::from_ref(&path), 8);
    comparison.assert_agrees(&["fgd slice", "tir slice"]);
    let description: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(luts.join("shapes.shader.json")).unwrap()).unwrap();
    let shapes = description["shapes"].as_array().unwrap();
    assert!(shapes.iter().all(|s| s["constants"].as_u64().unwrap() > 0), "{shapes:?}");
    // One shape per kind of stack, though their slice lookups choose among different numbers of
    // slices (the choosers padded alike).
    let mut shape_of_kind: std::collections::BTreeMap<&str, BTreeSet<u64>> = Default::default();
    for material in description["materials"].as_array().unwrap() {
        let kind = material["material"].as_str().unwrap().split('-').next().unwrap();
        shape_of_kind.entry(kind).or_default().insert(material["shape"].as_u64().unwrap());
    }
    assert_eq!(shapes.len(), 3, "{shape_of_kind:?}");
    assert!(shape_of_kind.values().all(|shapes| shapes.len() == 1), "{shape_of_kind:?}");
}

/// A scene whose lookups its slices do not hold, each slice a file: the 3D TIR table at its
/// critical-angle axis, the `fgd_rarer` stand-in and the FGD packing.
#[test]
fn a_scene_shader_reading_3d_tables_run_on_the_cpu_gives_the_cpu_evaluators_values() {
    let reads = ["tir table", "fgd_rarer table", "fgd packing", "fgd slice"];
    built_and_emulated(&["gpu-check/varied-coats"], "files", 256).assert_agrees(&reads);
}

/// Which file answers a lookup is decided once for both readers (`model::routes`): a table of
/// another shape than its kind's (here a 2D table listed as `tir`) is refused by the CPU evaluator
/// and the scene shader alike, naming the file, and neither reads it as if it were what its kind
/// promises.
#[test]
fn a_table_of_another_shape_than_its_kinds_is_refused_by_both_readers_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let luts = build_config(dir.path(), SMALL_SET, &["--only", "gd"]);
    // The GD table listed as the TIR table, sealed as a build seals it: the folder is consistent
    // (the same bytes, the entry's claims sealed), only the table's shape is wrong for its name.
    let mut manifest = Manifest::read(&luts.join("manifest.json")).unwrap();
    let mut entry = manifest.files.remove("gd.dds").unwrap();
    entry.table = "tir".into();
    entry.seal();
    manifest.files.insert("tir.dds".into(), entry);
    tmlut::formats::manifest::write_manifest(&manifest, &luts).unwrap();
    std::fs::rename(luts.join("gd.dds"), luts.join("tir.dds")).unwrap();
    let folder = LutFolder::open(&luts).unwrap();
    folder.load("tir.dds").unwrap();

    let cpu = FolderTables::open(&folder, AlbedoPath::Fgd, TirPath::Table, FgdSource::Packing).unwrap_err().to_string();
    let materials = shader_materials(&merge(&read_scene_files(&[scene("copper-pot")]).unwrap()).unwrap()).unwrap();
    let shader = generate(&folder, &materials).unwrap_err().to_string();
    for error in [cpu, shader] {
        assert!(error.contains("tir.dds") && error.contains("has axes (mu, alpha)"), "{error}");
        assert!(error.contains("addresses mu, alpha, eta or critical_angle_offset"), "{error}");
    }
    // Read by a path that does not look it up, the folder opens.
    FolderTables::open(&folder, AlbedoPath::Fgd, TirPath::Off, FgdSource::Packing).unwrap();
}
