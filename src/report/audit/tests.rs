//! Audits of `DFGLUTData.js` files made here from tmlut's own integrals, each perturbed one known
//! way: the cause must be named, and only it.

use std::path::{Path, PathBuf};

use super::*;
use crate::presets::threejs;
use crate::recipes::Kernel;
use crate::recipes::karis::KarisSettings;
use crate::recipes::settings::{ReferenceConfig, SamplingConfig};

fn preset() -> Preset {
    Preset::load("threejs").unwrap()
}

/// The preset's `karis` table integrated with `samples` per texel (one scramble) under `masking`,
/// without the build's checks.
fn integrated(samples: u64, masking: MaskingShadowing) -> Table {
    let mut settings: KarisSettings = preset().config.karis.clone();
    settings.masking = masking;
    settings.shared.sampling = SamplingConfig { samples, replicates: 1 };
    settings.shared.reference = ReferenceConfig { cells: 0, nodes: 8 };
    settings.shared.interpolation.points = 0;
    crate::recipes::driver::build(&settings, 11, &()).unwrap().table
}

/// The preset's table as the exact integrals give it (the audit's own quadrature).
fn exact() -> (Table, ExactTable) {
    let template = preset().config.recipe(TableKind::Karis).empty_table().unwrap();
    let quadrature = VisibleNormalQuadrature::new(8).unwrap();
    let exact = exact_table(TableKind::Karis, &template, MaskingShadowing::SchlickSmith, &quadrature, &()).unwrap();
    let mut table = template;
    table.data = exact.mean.iter().map(|&v| v as f32).collect();
    (table, exact)
}

/// `table` written as three.js's file into `dir`.
fn write_js(dir: &Path, name: &str, table: &Table) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, threejs::dfg_lut_js(table)).unwrap();
    path
}

fn audited(dir: &Path, table: &Table) -> Audit {
    audit(&write_js(dir, "DFGLUTData.js", table), &preset(), &()).unwrap()
}

fn kinds(audit: &Audit) -> Vec<&'static str> {
    audit.causes.iter().map(|c| c.kind).collect()
}

/// `table` with node `(i, j)` taking the value of `source(i, j)`.
fn remapped(table: &Table, source: impl Fn(usize, usize) -> (usize, usize)) -> Table {
    let mut out = table.clone();
    let [nx, ny] = [table.axes[0].count, table.axes[1].count];
    for j in 0..ny {
        for i in 0..nx {
            let (a, b) = source(i, j);
            let start = out.node_number(&[i, j]) * 2;
            out.data[start..start + 2].copy_from_slice(table.node(&[a, b]));
        }
    }
    out
}

#[test]
fn the_exact_table_rounded_to_half_floats_is_recognised_as_rounding() {
    let dir = tempfile::tempdir().unwrap();
    let report = audited(dir.path(), &exact().0);
    assert_eq!(kinds(&report), ["half-float-rounding"], "{}", report.render());
    assert_eq!(report.tests.rounding.equal_to_exact_rounded, 512);
    for channel in &report.channels {
        // Half an f16 ulp below 1 is 2.4e-4.
        assert!(channel.max <= 2.45e-4 && channel.rms < 1.5e-4, "{channel:?}");
    }
    assert_eq!(report.non_finite.count, 0);
}

#[test]
fn tmlut_s_own_threejs_build_is_rounding_and_nothing_else() {
    let dir = tempfile::tempdir().unwrap();
    let (_, files) = crate::pipeline::build_preset(preset(), dir.path(), &()).unwrap();
    let report = audit(&files[0], &preset(), &()).unwrap();
    assert_eq!(kinds(&report), ["half-float-rounding"], "{}", report.render());
    // The DDS beside it holds the same values in tmlut's layout.
    let dds = audit(&dir.path().join("karis.dds"), &preset(), &()).unwrap();
    assert_eq!(dds.read_as, "DDS in tmlut's layout (n.v along x)");
    assert_eq!(dds.errors, report.errors);
}

#[test]
fn a_table_of_few_samples_is_recognised_as_sample_noise() {
    let dir = tempfile::tempdir().unwrap();
    let report = audited(dir.path(), &integrated(16, MaskingShadowing::SchlickSmith));
    assert_eq!(kinds(&report), ["sample-noise"], "{}", report.render());
}

#[test]
fn gaussian_noise_of_n_samples_gives_back_about_n() {
    // Exact values plus independent Gaussian errors of one visible-normal sample's spread over
    // sqrt(N): the fit must find N within its own sampling error (about 6% for 512 values).
    let (mut table, exact) = exact();
    let samples = 200.0;
    use rand_pcg::rand_core::RngCore;
    let mut rng = rand_pcg::Pcg64Mcg::new(0x5eed);
    let mut uniform = || (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
    for (value, variance) in table.data.iter_mut().zip(&exact.variance) {
        // Box–Muller.
        let (u, v) = (uniform().max(1e-300), uniform());
        let gaussian = (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos();
        *value += (gaussian * (variance.max(0.0) / samples).sqrt()) as f32;
    }
    let dir = tempfile::tempdir().unwrap();
    let report = audited(dir.path(), &table);
    assert_eq!(kinds(&report), ["sample-noise"], "{}", report.render());
    let fitted = report.tests.noise.equivalent_samples.unwrap();
    assert!((fitted / samples - 1.0).abs() < 0.2, "{fitted}");
}

#[test]
fn swapped_axes_are_recognised() {
    let dir = tempfile::tempdir().unwrap();
    let report = audited(dir.path(), &remapped(&exact().0, |i, j| (j, i)));
    assert_eq!(kinds(&report), ["swapped-axes", "half-float-rounding"], "{}", report.render());
}

#[test]
fn the_other_masking_model_is_recognised() {
    let dir = tempfile::tempdir().unwrap();
    let report = audited(dir.path(), &integrated(1 << 16, MaskingShadowing::SmithHeightCorrelated));
    assert_eq!(kinds(&report), ["other-masking", "half-float-rounding"], "{}", report.render());
    assert!(report.causes[0].text.contains("smith-height-correlated"), "{}", report.causes[0].text);
}

#[test]
fn a_table_shifted_by_one_texel_along_n_dot_v_is_recognised() {
    let dir = tempfile::tempdir().unwrap();
    let report = audited(dir.path(), &remapped(&exact().0, |i, j| ((i + 1).min(15), j)));
    assert_eq!(kinds(&report), ["shifted", "half-float-rounding"], "{}", report.render());
    assert!(report.causes[0].text.contains("+1 along n.v"), "{}", report.causes[0].text);
}

#[test]
fn one_row_of_the_file_shifted_along_roughness_is_recognised_and_named() {
    // Row 9 of DFGLUTData.js (n.v index 9): each texel holds its left neighbour's value.
    let dir = tempfile::tempdir().unwrap();
    let report =
        audited(dir.path(), &remapped(&exact().0, |i, j| if i == 9 { (i, j.saturating_sub(1)) } else { (i, j) }));
    assert_eq!(kinds(&report), ["shifted-line"], "{}", report.render());
    assert!(
        report.causes[0].text.contains("n.v index 9 is shifted by one texel along roughness"),
        "{}",
        report.render()
    );
}

#[test]
fn nan_and_infinity_are_findings_and_the_json_holds_numbers_only() {
    let dir = tempfile::tempdir().unwrap();
    let text = threejs::dfg_lut_js(&exact().0);
    // The third word of row 0 (texel (0, 1), scale) NaN, the last word +inf.
    let words: Vec<usize> = text.match_indices("0x").map(|(k, _)| k).collect();
    let mut damaged = text.clone();
    let last = *words.last().unwrap();
    damaged.replace_range(last..last + 6, "0x7c00");
    damaged.replace_range(words[2]..words[2] + 6, "0x7e00");
    let path = dir.path().join("DFGLUTData.js");
    std::fs::write(&path, damaged).unwrap();
    let report = audit(&path, &preset(), &()).unwrap();
    assert_eq!(report.non_finite.count, 2);
    let at: Vec<(usize, usize, &str, &str)> = report
        .non_finite
        .at
        .iter()
        .map(|v| (v.texel.n_dot_v_index, v.texel.roughness_index, v.channel.as_str(), v.value.as_str()))
        .collect();
    assert_eq!(at, [(0, 1, "scale", "NaN"), (15, 15, "bias", "+inf")]);
    assert_eq!(report.largest_error(), f64::INFINITY);
    let json = report.to_json(Some(1e-3));
    assert!(!json.contains("NaN") || json.contains("\"NaN\""), "{json}");
    let parsed: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(parsed["status"], "over-budget");
    assert!(parsed["audit"]["channels"][0]["rms"].is_f64());
    // The other values are still measured.
    assert_eq!(report.channels[0].values + report.channels[1].values, 510);
}

#[test]
fn damaged_files_are_refused_naming_the_expected_shape() {
    let dir = tempfile::tempdir().unwrap();
    let text = threejs::dfg_lut_js(&exact().0);
    let first = text.find("0x").unwrap();
    let short = text.replacen(&text[first..first + 8], "", 1);
    let long = text.replacen("0x", "0x3c00, 0x", 1);
    let word = text.replacen(&text[first..first + 6], "0xzz00", 1);
    let cut = text[..text.len() / 2].to_string();
    for (name, damaged, named) in [
        ("short", short, "DATA holds 511 half floats; expected 16 x 16 x 2 = 512"),
        ("long", long, "DATA holds 513 half floats; expected 16 x 16 x 2 = 512"),
        ("word", word, "`0xzz00` in DATA is not a 16-bit integer literal"),
        ("cut", cut, "the DATA array is not closed"),
        ("empty", String::new(), "no `const DATA = new Uint16Array"),
    ] {
        let path = dir.path().join(format!("{name}.js"));
        std::fs::write(&path, damaged).unwrap();
        let error = audit(&path, &preset(), &()).unwrap_err().to_string();
        assert!(error.contains(named), "{name}: {error}");
    }
    // Bounded: a file larger than any DFG table is refused before it is read.
    let huge = dir.path().join("huge.js");
    let file = std::fs::File::create(&huge).unwrap();
    file.set_len(threejs::MAX_FILE_BYTES + 1).unwrap();
    let error = audit(&huge, &preset(), &()).unwrap_err().to_string();
    assert!(error.contains("huge.js"), "{error}");
    // A DDS of another shape names the preset's.
    let mut settings: KarisSettings = preset().config.karis.clone();
    settings.mu_count = 8;
    let small = settings.empty_table().unwrap();
    let dds = dir.path().join("small.dds");
    crate::formats::dds::write_dds(&dds, &small, crate::formats::Precision::F16).unwrap();
    let error = audit(&dds, &preset(), &()).unwrap_err().to_string();
    assert!(error.contains("expects 16 x 16 texels"), "{error}");
}

#[test]
fn spaces_and_comments_in_the_data_array_are_read() {
    let (table, _) = exact();
    let text = threejs::dfg_lut_js(&table)
        .replace("new Uint16Array( [", "new Uint16Array([ // scale, bias\n")
        .replacen(", 0x", ", /* row */ 0X", 1);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("DFGLUTData.js");
    std::fs::write(&path, text).unwrap();
    let read = preset().read_drop_in(&path).unwrap();
    let rounded: Vec<f32> = table.data.iter().map(|&v| half::f16::from_f32(v).to_f32()).collect();
    assert_eq!(read.data, rounded);
}

#[test]
fn a_preset_without_an_engine_file_says_so() {
    let text = include_str!("../../../luts/presets/threejs.toml")
        .replace("drop_in = { format = \"threejs-dfg-lut\", table = \"karis\" }", "");
    let preset = Preset::from_toml("plain", &text, "plain.toml").unwrap();
    let error = audit(Path::new("DFGLUTData.js"), &preset, &()).unwrap_err().to_string();
    assert!(error.contains("writes no engine file"), "{error}");
}
