//! The typed handles against the table they wrap and the GPU emulator, the texture descriptor
//! against the DDS and KTX2 files' own texel bytes, and the errors a renderer meets, on the
//! loader's test folder (`testdata/luts`) and tables made here.

use std::path::Path;

use super::*;
use crate::formats::files::FileKind;
use crate::formats::manifest::MANIFEST_FILE;
use crate::formats::test_folder::{copy_of_test_folder, test_file, test_folder};
use crate::loader::texture::SampledTable;
use crate::table::derived::{critical_angle_fraction, critical_angle_offset};

/// A smooth, non-separable function of a node's position, different per channel.
fn fill(axes: Vec<Axis>, channels: usize, name: &str) -> Table {
    let channel_list = (0..channels).map(|c| Channel::new(format!("c{c}"), "test")).collect();
    let mut table = Table::zeros(name, axes, channel_list).unwrap();
    for n in 0..table.node_count() {
        let position = table.node_position(&table.node_index(n));
        for c in 0..channels {
            let v = position.iter().enumerate().map(|(d, x)| ((d + 1) as f64 * x + c as f64).sin()).sum::<f64>();
            table.data[n * channels + c] = (0.25 + 0.2 * v) as f32;
        }
    }
    table
}

fn karis_table() -> Table {
    let mu = Axis::cell_centred("mu", 0.0, 1.0, 8).unwrap();
    let alpha = Axis::cell_centred("alpha", 0.0, 1.0, 6).unwrap().with_mapping(Mapping::Sqrt).unwrap();
    fill(vec![mu, alpha], 2, "karis")
}

fn gd_table() -> Table {
    let mu = Axis::node_aligned("mu", 0.0, 1.0, 9).unwrap().with_mapping(Mapping::SqrtEnds).unwrap();
    let alpha = Axis::node_aligned("alpha", 0.0, 1.0, 6).unwrap().with_mapping(Mapping::Sqrt).unwrap();
    fill(vec![mu, alpha], 1, "gd")
}

fn fgd_table() -> Table {
    let axes = vec![
        Axis::node_aligned("mu", 0.0, 1.0, 5).unwrap(),
        Axis::node_aligned("alpha", 0.0, 1.0, 4).unwrap(),
        Axis::node_aligned("eta", 0.0, 4.0, 6).unwrap(),
        Axis::node_aligned("kappa", 0.0, 4.0, 3).unwrap(),
    ];
    fill(axes, 1, "fgd")
}

/// The loader's test folder, opened.
fn folder() -> LutFolder {
    LutFolder::open(test_folder()).unwrap()
}

/// Lookup parameters inside, at and past the ends of the unit range.
const PARAMETERS: [f32; 7] = [0.0, 0.013, 0.2, 0.5, 0.77, 1.0, 1.3];

fn assert_same<const N: usize>(handle: [f32; N], table: Vec<f64>, at: &str) {
    let table: Vec<f32> = table.iter().map(|&v| v as f32).collect();
    assert_eq!(&handle[..], &table[..], "at {at}");
}

#[test]
fn each_handle_samples_as_its_table_interpolates() {
    let luts = folder();
    let karis = KarisLut::from_folder(&luts).unwrap();
    let belcour = BelcourLut::open(&luts, "belcour.dds").unwrap();
    let gd = GdLut::from_folder(&luts).unwrap();
    let tir = TirLut::from_folder(&luts).unwrap();
    let fgd = FgdLut::from_folder(&luts).unwrap();
    let rarer = FgdRarerLut::from_folder(&luts).unwrap();
    for &a in &PARAMETERS {
        for &b in &PARAMETERS {
            let at = format!("({a}, {b})");
            let r = b as f64;
            assert_same(karis.sample(a, Roughness(b)), karis.table().interpolate(&[a as f64, r * r]), &at);
            assert_same(belcour.sample(a, Roughness(b)), belcour.table().interpolate(&[a as f64, r * r]), &at);
            assert_same([gd.sample(a, Alpha(b))], gd.table().interpolate(&[a as f64, b as f64]), &at);
            for eta in [0.3f32, 0.9, 1.0] {
                let offset = critical_angle_offset(a as f64, eta as f64);
                let expected = tir.table().interpolate(&[a as f64, b as f64, offset]);
                assert_same([tir.sample(a, Alpha(b), eta)], expected, &format!("{at}, eta {eta}"));
                let fraction = critical_angle_fraction(a as f64, eta as f64);
                let expected = rarer.table().interpolate(&[a as f64, b as f64, fraction]);
                assert_same([rarer.sample(a, Alpha(b), eta)], expected, &format!("{at}, eta {eta}"));
                let eta = eta * 3.0;
                let expected = fgd.table().interpolate(&[a as f64, b as f64, eta as f64, 0.5]);
                assert_same([fgd.sample(a, Alpha(b), eta, 0.5)], expected, &format!("{at}, eta {eta}"));
            }
        }
    }
}

#[test]
fn gpu_sampling_is_the_emulators_bit_for_bit() {
    let luts = folder();
    let karis = KarisLut::from_folder(&luts).unwrap();
    let belcour = BelcourLut::from_folder(&luts).unwrap();
    let gd = GdLut::from_folder(&luts).unwrap();
    let tir = TirLut::from_folder(&luts).unwrap();
    let rarer = FgdRarerLut::from_folder(&luts).unwrap();
    let rarer_gpu = SampledTable::new(rarer.table()).unwrap();
    let emulated = |table: &Table| SampledTable::new(table).unwrap();
    let (karis_gpu, belcour_gpu, gd_gpu, tir_gpu) =
        (emulated(karis.table()), emulated(belcour.table()), emulated(gd.table()), emulated(tir.table()));
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for &a in &PARAMETERS {
        for &b in &PARAMETERS {
            let r = b as f64;
            let point = [a as f64, r * r];
            let expected: Vec<f32> = (0..2).map(|c| karis_gpu.sample(c, &point)).collect();
            assert_eq!(bits(&karis.sample_gpu(a, Roughness(b))), bits(&expected), "karis at ({a}, {b})");
            let expected: Vec<f32> = (0..4).map(|c| belcour_gpu.sample(c, &point)).collect();
            assert_eq!(bits(&belcour.sample_gpu(a, Roughness(b))), bits(&expected), "belcour at ({a}, {b})");
            let point = [a as f64, b as f64];
            assert_eq!(gd.sample_gpu(a, Alpha(b)).to_bits(), gd_gpu.sample(0, &point).to_bits(), "gd at ({a}, {b})");
            for eta in [0.3f32, 0.9, 1.0] {
                let point = [a as f64, b as f64, critical_angle_offset(a as f64, eta as f64)];
                let expected = tir_gpu.sample(0, &point);
                assert_eq!(tir.sample_gpu(a, Alpha(b), eta).to_bits(), expected.to_bits(), "tir at ({a}, {b}, {eta})");
                let point = [a as f64, b as f64, critical_angle_fraction(a as f64, eta as f64)];
                let expected = rarer_gpu.sample(0, &point);
                assert_eq!(
                    rarer.sample_gpu(a, Alpha(b), eta).to_bits(),
                    expected.to_bits(),
                    "fgd_rarer at ({a}, {b}, {eta})"
                );
            }
        }
    }
}

#[test]
fn the_energy_compensation_handles_sample_as_their_tables_interpolate_and_as_the_emulator_filters() {
    let mu = Axis::node_aligned("mu", 0.0, 1.0, 9).unwrap().with_mapping(Mapping::SqrtEnds).unwrap();
    let alpha = Axis::cell_centred("alpha", 0.0, 1.0, 6).unwrap().with_mapping(Mapping::Sqrt).unwrap();
    let e = GgxELut::from_table(fill(vec![mu, alpha.clone()], 1, "ggx_e"), Precision::F32).unwrap();
    let average = GgxEAvgLut::from_table(fill(vec![alpha], 1, "ggx_e_avg"), Precision::F32).unwrap();
    let (e_gpu, average_gpu) = (SampledTable::new(e.table()).unwrap(), SampledTable::new(average.table()).unwrap());
    for &b in &PARAMETERS {
        let at = format!("alpha {b}");
        assert_same([average.sample(Alpha(b))], average.table().interpolate(&[b as f64]), &at);
        assert_eq!(average.sample_gpu(Alpha(b)).to_bits(), average_gpu.sample(0, &[b as f64]).to_bits(), "{at}");
        for &a in &PARAMETERS {
            let at = format!("({a}, {b})");
            assert_same([e.sample(a, Alpha(b))], e.table().interpolate(&[a as f64, b as f64]), &at);
            let expected = e_gpu.sample(0, &[a as f64, b as f64]);
            assert_eq!(e.sample_gpu(a, Alpha(b)).to_bits(), expected.to_bits(), "{at}");
        }
    }
    // One row: a texture of height 1.
    let texture = average.texture().unwrap();
    let descriptor = texture.descriptor();
    assert_eq!((descriptor.width, descriptor.height, descriptor.depth_or_layers), (6, 1, 1));
    // The multiple-scattering split sum, looked up by perceptual roughness as Karis's table.
    let mu = Axis::cell_centred("mu", 0.0, 1.0, 8).unwrap();
    let alpha = Axis::cell_centred("alpha", 0.0, 1.0, 6).unwrap().with_mapping(Mapping::Sqrt).unwrap();
    let table = fill(vec![mu, alpha], 2, "karis_multiscatter");
    let multiscatter = KarisMultiscatterLut::from_table(table, Precision::F16).unwrap();
    for &a in &PARAMETERS {
        for &b in &PARAMETERS {
            let r = b as f64;
            let expected = multiscatter.table().interpolate(&[a as f64, r * r]);
            assert_same(multiscatter.sample(a, Roughness(b)), expected, &format!("({a}, {b})"));
        }
    }
    // E's shape is not E_avg's.
    let err = GgxEAvgLut::from_table(e.into_table(), Precision::F32).unwrap_err().to_string();
    assert!(err.contains("a ggx_e_avg table has the axes (alpha) and 1 channel"), "{err}");
}

#[test]
fn texel_centres_read_their_texel() {
    let luts = folder();
    let karis = KarisLut::from_folder(&luts).unwrap();
    let tir = TirLut::from_folder(&luts).unwrap();
    let centre = |k: usize, n: usize| (k as f32 + 0.5) / n as f32;
    assert_eq!(&karis.sample_uv(centre(3, 8), centre(4, 6))[..], karis.table().node(&[3, 4]));
    assert_eq!(tir.sample_uvw(centre(6, 7), centre(0, 5), centre(2, 6)), tir.table().node(&[6, 0, 2])[0]);
    // Clamp addressing: past the edge reads the edge texel.
    assert_eq!(&karis.sample_uv(-1.0, 2.0)[..], karis.table().node(&[0, 5]));
}

#[test]
fn texture_bytes_are_the_dds_files_texels_with_their_descriptor() {
    let luts = folder();
    let cases = [
        ("karis.dds", KarisLut::from_folder(&luts).unwrap().texture().unwrap(), (8, 6, 1), TextureFormat::Rg16Float),
        (
            "belcour.dds",
            BelcourLut::from_folder(&luts).unwrap().texture().unwrap(),
            (5, 7, 1),
            TextureFormat::Rgba16Float,
        ),
        ("gd.dds", GdLut::from_folder(&luts).unwrap().texture().unwrap(), (9, 6, 1), TextureFormat::R16Float),
        ("tir.dds", TirLut::from_folder(&luts).unwrap().texture().unwrap(), (7, 5, 6), TextureFormat::R32Float),
    ];
    for (file, texture, (w, h, d), format) in cases {
        let desc = texture.descriptor();
        assert_eq!((desc.width, desc.height, desc.depth_or_layers), (w, h, d), "{file}");
        assert_eq!(desc.format, format, "{file}");
        assert_eq!(desc.dimension, if d == 1 { TextureDimension::D2 } else { TextureDimension::D3 }, "{file}");
        assert_eq!(desc.mip_level_count, 1);
        assert_eq!(desc.bytes_per_row, w * format.bytes_per_texel(), "{file}");
        assert_eq!(desc.rows_per_image, h, "{file}");
        let bytes = texture.to_bytes();
        assert_eq!(bytes.len(), (w * h * d * format.bytes_per_texel()) as usize, "{file}");
        assert_eq!(bytes.len(), desc.byte_len(), "{file}");
        let file_bytes = test_file(file);
        assert_eq!(
            &bytes[..],
            &file_bytes[crate::formats::dds::layout::DATA_OFFSET..],
            "{file}: the texels as the DDS file stores them"
        );
        let texel_count = (w * h * d) as usize * format.channels();
        match format.precision() {
            Precision::F16 => assert_eq!(texture.texels_f16().unwrap().len(), texel_count),
            Precision::F32 => assert_eq!(texture.texels_f32().unwrap().len(), texel_count),
        }
        #[cfg(feature = "bytemuck")]
        assert_eq!(texture.bytes(), &bytes[..], "{file}");
    }
    assert_eq!(TextureFormat::Rg16Float.webgpu_name(), "rg16float");
    assert_eq!(TextureFormat::of(3, Precision::F16), None);
}

#[test]
fn a_table_no_texture_holds_is_refused_naming_it() {
    let err = TextureData::from_table(&fgd_table(), Precision::F32).unwrap_err().to_string();
    assert!(err.contains("table `fgd`") && err.contains("4 axes; a texture has 1 to 3"), "{err}");
    let mut three = gd_table();
    three.channels = (0..3).map(|c| Channel::new(format!("c{c}"), "")).collect();
    three.data = vec![0.0; three.node_count() * 3];
    let err = TextureData::from_table(&three, Precision::F16).unwrap_err().to_string();
    assert!(err.contains("3 channels; a texture holds 1, 2 or 4"), "{err}");
}

#[test]
fn a_wrong_number_of_coordinates_is_an_error_not_a_panic() {
    let table = karis_table();
    let mut out = [0.0; 2];
    assert_eq!(table.interpolate_into(&[0.5], &mut out), Err(InterpolationError::AxisCount { axes: 2, given: 1 }));
    assert_eq!(
        table.interpolate_into(&[0.5, 0.5, 0.5], &mut out),
        Err(InterpolationError::AxisCount { axes: 2, given: 3 })
    );
    assert_eq!(
        table.interpolate_into(&[0.5, 0.5], &mut [0.0; 3]),
        Err(InterpolationError::ChannelCount { channels: 2, given: 3 })
    );
    let err = table.interpolate_into(&[0.5], &mut out).unwrap_err().to_string();
    assert!(err.contains("1 coordinates given; the table has 2 axes"), "{err}");
    let mut gpu = [0.0f32; 2];
    assert_eq!(sample_texture(&table, &[0.5], &mut gpu), Err(InterpolationError::AxisCount { axes: 2, given: 1 }));
    let mut one = [0.0f32; 1];
    assert_eq!(sample_texture(&fgd_table(), &[0.5; 4], &mut one), Err(InterpolationError::NotATexture { axes: 4 }));
    // And the allocation-free path is the allocating one.
    table.interpolate_into(&[0.3, 0.6], &mut out).unwrap();
    assert_eq!(out.to_vec(), table.interpolate(&[0.3, 0.6]));
}

#[test]
fn a_file_of_another_kind_is_refused_naming_the_file_and_the_axes_allowed() {
    let luts = folder();
    let err = GdLut::open(&luts, "karis.dds").unwrap_err().to_string();
    assert!(err.contains("karis.dds"), "{err}");
    assert!(err.contains("2 channels; a gd table has the axes (mu, alpha) and 1 channel"), "{err}");
    let err = TirLut::open(&luts, "gd.dds").unwrap_err().to_string();
    assert!(err.contains("a tir table has the axes (mu, alpha, eta or critical_angle_offset)"), "{err}");
    let err = FgdRarerLut::open(&luts, "tir.dds").unwrap_err().to_string();
    assert!(err.contains("a fgd_rarer table has the axes (mu, alpha, critical_angle_fraction)"), "{err}");
    let err = KarisLut::from_table(gd_table(), Precision::F16).unwrap_err().to_string();
    assert!(err.contains("table `gd`"), "{err}");
    // A renderer branches on the kind, not on the words.
    assert!(matches!(GdLut::open(&luts, "karis.dds"), Err(Error::WrongTable { .. })));
    assert!(matches!(KarisLut::from_table(gd_table(), Precision::F16), Err(Error::WrongTable { .. })));
}

/// The manifest of `dir` replaced by `manifest`, written as a build writes it.
fn rewrite_manifest(dir: &Path, manifest: &Manifest) {
    let text = serde_json::to_string_pretty(manifest).unwrap() + "\n";
    std::fs::write(dir.join(MANIFEST_FILE), text).unwrap();
}

#[test]
fn a_folder_without_the_table_or_with_a_changed_file_is_refused() {
    let dir = copy_of_test_folder();
    let luts = LutFolder::open(dir.path()).unwrap();
    let mut manifest = luts.manifest().clone();
    manifest.files.remove("karis.dds");
    manifest.files.remove("karis.ktx2");
    rewrite_manifest(dir.path(), &manifest);
    let err = KarisLut::from_folder(&LutFolder::open(dir.path()).unwrap()).unwrap_err();
    assert!(matches!(err, Error::Missing { .. }), "{err:?}");
    let err = err.to_string();
    assert!(err.contains(MANIFEST_FILE) && err.contains("lists no `karis` table"), "{err}");
    let err = LutFolder::open(dir.path()).unwrap().load("karis.dds").unwrap_err();
    assert!(matches!(err, Error::Missing { .. }) && err.to_string().contains("lists no file `karis.dds`"), "{err}");
    // A file replaced after the build: the handle opens it verified, as `LutFolder::load`.
    let mut bytes = std::fs::read(dir.path().join("gd.dds")).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 1;
    std::fs::write(dir.path().join("gd.dds"), bytes).unwrap();
    let err = GdLut::open(&luts, "gd.dds").unwrap_err();
    assert!(matches!(err, Error::Mismatch { .. }), "{err:?}");
    let err = err.to_string();
    assert!(err.contains("gd.dds") && err.contains("SHA-256"), "{err}");
}

#[test]
fn a_folder_whose_build_was_interrupted_while_committing_is_refused_as_unfinished() {
    let dir = copy_of_test_folder();
    std::fs::write(dir.path().join(crate::formats::manifest::COMMIT_JOURNAL), b"{}").unwrap();
    let err = LutFolder::open(dir.path()).unwrap_err();
    assert!(matches!(err, Error::Unfinished { .. }), "{err:?}");
    assert!(err.to_string().contains("interrupted"), "{err}");
}

#[test]
fn paths_are_taken_as_any_path_like_value() {
    let dir = test_folder();
    let as_str = dir.to_str().unwrap();
    let as_string = as_str.to_string();
    let as_path_buf = dir.clone();
    for folder in [LutFolder::open(as_str), LutFolder::open(&as_string), LutFolder::open(as_path_buf)] {
        let files = folder.unwrap().files().map(str::to_string).collect::<Vec<_>>();
        assert_eq!(files[..4], ["belcour.dds", "belcour.ktx2", "fgd.bin", "fgd_rarer.dds"]);
    }
    assert_eq!(load_table(dir.join("gd.dds")).unwrap(), load_table(format!("{as_str}/gd.dds")).unwrap());
}

#[test]
fn the_loader_uses_only_tables_formats_errors_and_the_gpu_sampler() {
    // What a renderer links: the model and the generator build on the loader, never the reverse.
    let allowed = ["error", "formats", "table", "filter"];
    let sources = [
        ("mod.rs", include_str!("mod.rs")),
        ("handles.rs", include_str!("handles.rs")),
        ("texture.rs", include_str!("texture.rs")),
        ("source.rs", include_str!("source.rs")),
    ];
    for (file, text) in sources {
        for (at, _) in text.match_indices("crate::") {
            let module = text[at + 7..].split(|c: char| !(c.is_alphanumeric() || c == '_')).next().unwrap_or_default();
            assert!(allowed.contains(&module), "src/loader/{file} uses crate::{module}; allowed: {allowed:?}");
        }
    }
}

#[test]
fn ktx2_files_open_as_their_dds_twins_with_the_same_texels_and_descriptors() {
    let luts = folder();
    macro_rules! textures {
        ($handle:ident, $file:literal) => {
            (
                $handle::from_folder(&luts).unwrap().texture().unwrap(),
                $handle::open(&luts, $file).unwrap().texture().unwrap(),
                $file,
            )
        };
    }
    let pairs = [
        textures!(KarisLut, "karis.ktx2"),
        textures!(BelcourLut, "belcour.ktx2"),
        textures!(GdLut, "gd.ktx2"),
        textures!(TirLut, "tir.ktx2"),
    ];
    for (from_dds, from_ktx2, file) in pairs {
        assert_eq!(from_ktx2.descriptor(), from_dds.descriptor(), "{file}");
        assert_eq!(from_ktx2.texels(), from_dds.texels(), "{file}");
        // The texel bytes are the file's level 0, where its level index says.
        let bytes = test_file(file);
        let level = u64::from_le_bytes(bytes[80..88].try_into().unwrap()) as usize;
        assert_eq!(&bytes[level..], &from_ktx2.to_bytes()[..], "{file}");
    }
    let (karis_dds, karis_ktx) = (KarisLut::from_folder(&luts).unwrap(), KarisLut::open(&luts, "karis.ktx2").unwrap());
    let (tir_dds, tir_ktx) = (TirLut::from_folder(&luts).unwrap(), TirLut::open(&luts, "tir.ktx2").unwrap());
    assert_eq!(karis_dds.entry().unwrap().format, FileFormat::Dds, "DDS first");
    for &a in &PARAMETERS {
        for &b in &PARAMETERS {
            assert_eq!(karis_ktx.sample(a, Roughness(b)), karis_dds.sample(a, Roughness(b)), "karis at ({a}, {b})");
            assert_eq!(
                karis_ktx.sample_gpu(a, Roughness(b)),
                karis_dds.sample_gpu(a, Roughness(b)),
                "karis at ({a}, {b})"
            );
            assert_eq!(tir_ktx.sample_gpu(a, Alpha(b), 0.9), tir_dds.sample_gpu(a, Alpha(b), 0.9), "tir at ({a}, {b})");
        }
    }
}

#[test]
fn a_ktx2_file_is_verified_against_what_its_entry_states() {
    let luts = folder();
    let verify = |change: &dyn Fn(&mut FileEntry)| {
        let mut entry = luts.entry("tir.ktx2").unwrap().clone();
        change(&mut entry);
        load_verified(test_folder().join("tir.ktx2"), &entry).map(|_| ()).map_err(|e| e.to_string())
    };
    assert_eq!(verify(&|_| {}), Ok(()));
    // The file states its axes and channels: a manifest that disagrees is refuted by the file.
    let err = verify(&|e| e.axes[2].axis.start = -1.0).unwrap_err();
    assert!(err.contains("axis `critical_angle_offset`: the file has 6 nodes over [-1.5, 1.5]"), "{err}");
    let err = verify(&|e| e.channels[0].name = "other".into()).unwrap_err();
    assert!(err.contains("the file has the channels [c0], the manifest states [other]"), "{err}");
    let err = verify(&|e| e.vk_format = Some("R16_SFLOAT".into())).unwrap_err();
    assert!(err.contains("the texture is R32_SFLOAT, the manifest states R16_SFLOAT"), "{err}");
    let err = verify(&|e| e.format = FileFormat::Dds).unwrap_err();
    assert!(err.contains("the file is Ktx2, the manifest states Dds"), "{err}");
    // Without a manifest the file alone describes its table.
    let alone = tempfile::tempdir().unwrap();
    std::fs::write(alone.path().join("tir.ktx2"), test_file("tir.ktx2")).unwrap();
    assert_eq!(load_table(alone.path().join("tir.ktx2")).unwrap(), luts.load("tir.ktx2").unwrap());
}

/// Every file of the folder `dir` held in memory, named `root/file` in errors.
fn held_in_memory(dir: &Path, root: &Path) -> InMemory {
    let mut files = InMemory::new(root);
    for entry in std::fs::read_dir(dir).unwrap() {
        let entry = entry.unwrap();
        files.insert(entry.file_name().to_string_lossy(), std::fs::read(entry.path()).unwrap());
    }
    files
}

#[test]
fn a_folder_held_in_memory_reads_as_on_disk() {
    let on_disk = folder();
    let in_memory = LutFolder::from_source(held_in_memory(&test_folder(), Path::new("assets/luts"))).unwrap();
    assert_eq!(in_memory.dir(), Path::new("assets/luts"));
    assert_eq!(in_memory.manifest(), on_disk.manifest());
    let files: Vec<&str> = on_disk.files().collect();
    assert!(files.len() > 10, "{files:?}");
    for file in files {
        #[cfg(not(feature = "exr"))]
        if file.ends_with(".exr") {
            continue;
        }
        assert_eq!(in_memory.load(file).unwrap(), on_disk.load(file).unwrap(), "{file}");
    }
    let (karis, karis_on_disk) = (KarisLut::from_folder(&in_memory).unwrap(), KarisLut::from_folder(&on_disk).unwrap());
    assert_eq!(karis.entry(), karis_on_disk.entry());
    assert_eq!(karis.sample_gpu(0.3, Roughness(0.6)), karis_on_disk.sample_gpu(0.3, Roughness(0.6)));
    assert_eq!(in_memory.texture("tir.ktx2").unwrap(), on_disk.texture("tir.ktx2").unwrap());
    // Borrowed for the program's life, as `include_bytes!` gives them.
    let manifest: &'static [u8] = test_file(MANIFEST_FILE).leak();
    let gd: &'static [u8] = test_file("gd.dds").leak();
    let borrowed = LutFolder::from_source(InMemory::new("embedded").with(MANIFEST_FILE, manifest).with("gd.dds", gd));
    assert_eq!(GdLut::from_folder(&borrowed.unwrap()).unwrap().table(), GdLut::from_folder(&on_disk).unwrap().table());
}

#[test]
fn a_damaged_byte_is_refused_in_memory_as_on_disk_with_the_same_error() {
    let dir = copy_of_test_folder();
    let mut bytes = test_file("gd.dds");
    let last = bytes.len() - 1;
    bytes[last] ^= 1;
    std::fs::write(dir.path().join("gd.dds"), &bytes).unwrap();
    // Named by the folder's own path, the files in memory give the very same messages.
    let in_memory = LutFolder::from_source(held_in_memory(dir.path(), dir.path())).unwrap();
    let on_disk = LutFolder::open(dir.path()).unwrap();
    let (from_memory, from_disk) = (in_memory.load("gd.dds").unwrap_err(), on_disk.load("gd.dds").unwrap_err());
    assert!(matches!(from_memory, Error::Mismatch { .. }), "{from_memory:?}");
    assert_eq!(from_memory.to_string(), from_disk.to_string());
    assert!(from_memory.to_string().contains("SHA-256"), "{from_memory}");
    let err = GdLut::from_folder(&in_memory).unwrap_err();
    assert!(matches!(err, Error::Mismatch { .. }), "{err:?}");
}

#[test]
fn files_missing_from_memory_and_an_unfinished_commit_are_refused_as_on_disk() {
    let absent = |err: &Error, file: &Path| matches!(err, Error::Io { path, source } if path == file && source.kind() == std::io::ErrorKind::NotFound);
    let err = LutFolder::from_source(InMemory::new("empty")).unwrap_err();
    assert!(absent(&err, &Path::new("empty").join(MANIFEST_FILE)), "{err:?}");
    let without_gd = InMemory::new("luts").with(MANIFEST_FILE, test_file(MANIFEST_FILE));
    let err = LutFolder::from_source(without_gd).unwrap().load("gd.dds").unwrap_err();
    assert!(absent(&err, &Path::new("luts").join("gd.dds")), "{err:?}");
    let unfinished = held_in_memory(&test_folder(), Path::new("luts"))
        .with(crate::formats::manifest::COMMIT_JOURNAL, b"{}".as_slice());
    let err = LutFolder::from_source(unfinished).unwrap_err();
    assert!(matches!(err, Error::Unfinished { .. }), "{err:?}");
    let err =
        LutFolder::from_source(InMemory::new("luts").with(MANIFEST_FILE, b"{\"hello\": 1}".as_slice())).unwrap_err();
    assert!(err.to_string().contains("not a tmlut manifest"), "{err}");
    // Bytes over a kind's limit are refused whatever their source; checked on the length alone.
    let too_long = FileKind::Manifest.check_length(Path::new("luts/manifest.json"), 1 << 30).unwrap_err();
    assert!(too_long.to_string().contains("a manifest may be at most 268435456 bytes"), "{too_long}");
    assert!(FileKind::Table.check_length(Path::new("t.dds"), 1 << 30).is_ok());
}
