use super::*;
use crate::formats::dds;
use crate::formats::test_folder::{test_entry, test_file};

fn decode(bytes: &[u8]) -> Result<Ktx2Texture> {
    decode_ktx2(bytes, Path::new("t.ktx2"))
}

fn error_of(bytes: &[u8]) -> String {
    decode(bytes).unwrap_err().to_string()
}

fn field(bytes: &[u8], offset: usize) -> u32 {
    u32::from_le_bytes(bytes[offset..offset + 4].try_into().unwrap())
}

fn set(bytes: &mut [u8], offset: usize, value: u32) {
    bytes[offset..offset + 4].copy_from_slice(&value.to_le_bytes());
}

/// Where the key/value data and the level data start, from the header.
fn kvd_offset(bytes: &[u8]) -> usize {
    field(bytes, 56) as usize
}

fn data_offset(bytes: &[u8]) -> usize {
    u64::from_le_bytes(bytes[80..88].try_into().unwrap()) as usize
}

/// The test folder's `file` with the bytes `from` (which occur once) replaced by `to` of the same
/// length, and the error reading it gives.
fn edited(file: &str, from: &[u8], to: &[u8]) -> String {
    let mut bytes = test_file(file);
    assert_eq!(from.len(), to.len());
    let at = bytes.windows(from.len()).position(|w| w == from).expect("present");
    assert!(bytes[at + 1..].windows(from.len()).all(|w| w != from), "once");
    bytes[at..at + from.len()].copy_from_slice(to);
    error_of(&bytes)
}

#[test]
fn each_file_reads_as_its_dds_twin_with_the_description_its_manifest_entry_states() {
    for (name, volume) in [("karis", false), ("belcour", false), ("gd", false), ("tir", true), ("slices", false)] {
        let ktx2 = format!("{name}.ktx2");
        let file = decode(&test_file(&ktx2)).unwrap();
        let twin = dds::decode_dds(&test_file(&format!("{name}.dds")), Path::new("t.dds")).unwrap();
        assert_eq!(file.texture, twin, "{ktx2}");
        assert_eq!(file.texture.volume, volume, "{ktx2}");
        let entry = test_entry(&ktx2);
        let description = &file.description;
        assert_eq!(
            (&description.table, &description.axes, &description.channels),
            (&entry.table, &entry.axes, &entry.channels)
        );
        assert_eq!(description.precision, entry.precision, "{ktx2}");
        assert_eq!(description.orientation, if volume { "rdi" } else { "rd" }, "{ktx2}");
        assert!(description.writer.starts_with("tmlut "), "{}", description.writer);
        assert_eq!(stored_format(&test_file(&ktx2)), Some((entry.channels.len(), entry.precision)));
        // The texels are the file's level 0, where its level index says.
        let bytes = test_file(&ktx2);
        assert_eq!(file.texture.data, texel_values(&bytes[data_offset(&bytes)..], entry.precision), "{ktx2}");
        assert_eq!(file.into_table().unwrap().shape(), entry.axes.iter().map(|a| a.axis.count).collect::<Vec<_>>());
    }
}

#[test]
fn an_array_reads_its_layer_count() {
    let file = decode(&test_file("slices.ktx2")).unwrap();
    assert!(file.texture.layered && !file.texture.volume);
    assert_eq!(file.texture.depth, 7);
    assert_eq!(file.description.axes[2].stored_along, "layer");
    // An array of volumes is not something tmlut writes.
    let mut bytes = test_file("slices.ktx2");
    set(&mut bytes, 28, 2);
    assert!(error_of(&bytes).contains("array of 7 volume textures"), "{}", error_of(&bytes));
}

#[test]
fn the_key_value_data_spells_out_each_axis() {
    let karis = test_file("karis.ktx2");
    let kvd = &karis[kvd_offset(&karis)..kvd_offset(&karis) + field(&karis, 60) as usize];
    let text = String::from_utf8_lossy(kvd);
    assert!(text.contains("\"placement\":\"cell-centred\"") && text.contains("\"mapping\":\"sqrt\""), "{text}");
    let tir = decode(&test_file("tir.ktx2")).unwrap();
    // The texture coordinate formula is spelled out per axis, as in the manifest.
    let axis = &tir.description.axes[2];
    assert_eq!(axis.texture_coordinate, axis.axis.texture_coordinate_formula());
}

#[test]
fn foreign_and_truncated_files_are_refused() {
    let good = test_file("karis.ktx2");
    assert!(error_of(b"").contains("not a KTX2 file"));
    assert!(error_of(&test_file("karis.dds")).contains("not a KTX2 file"));
    let mut ktx1 = good.clone();
    ktx1[5..7].copy_from_slice(b"11");
    assert!(error_of(&ktx1).contains("not a KTX2 file"));

    for cut in [12, 80, 103, DFD_OFFSET + 10, kvd_offset(&good) + 10, data_offset(&good), good.len() - 1] {
        let err = error_of(&good[..cut]);
        assert!(err.contains("truncated") || err.contains("stated as"), "cut at {cut}: {err}");
    }
    let err = error_of(&good[..good.len() - 1]);
    assert!(err.contains("need 192 bytes") && err.contains("has 191"), "{err}");
    let mut longer = good.clone();
    longer.push(0);
    assert!(error_of(&longer).contains("1 bytes follow"));
}

#[test]
fn header_fields_tmlut_does_not_write_are_refused_naming_them() {
    let good = test_file("karis.ktx2");
    let lie = |offset: usize, value: u32| {
        let mut bytes = good.clone();
        set(&mut bytes, offset, value);
        error_of(&bytes)
    };
    let err = lie(12, 37); // VK_FORMAT_R8G8B8A8_UNORM
    assert!(err.contains("vkFormat 37") && err.contains("VK_FORMAT_R16_SFLOAT (76)"), "{err}");
    assert!(lie(12, 0).contains("vkFormat 0"));
    assert!(lie(16, 4).contains("typeSize 4"));
    assert!(lie(20, 0).contains("zero pixel width"));
    assert!(lie(24, 0).contains("1D texture"));
    // A 2D texture stated as an array of 6 layers lacks the texels of five of them.
    assert!(lie(32, 6).contains("8 × 6 × 6 VK_FORMAT_R16G16_SFLOAT texels are 1152 bytes"), "{}", lie(32, 6));
    assert!(lie(36, 6).contains("cube map"));
    assert!(lie(40, 3).contains("3 mip levels"));
    assert!(lie(44, 2).contains("supercompression scheme 2"));
    assert!(lie(48, 112).contains("starts at byte 112"));
    assert!(lie(52, 1 << 30).contains("stated as 1073741824 bytes"));
    assert!(lie(56, 0).contains("key/value data starts at byte 0"));
    assert!(lie(60, u32::MAX).contains("truncated"));
    assert!(lie(64, 8).contains("supercompression global data"));
    assert!(lie(80, 0).contains("level data starts at byte 0"));
    assert!(lie(88, 7).contains("level index states 7 bytes"));
    assert!(lie(96, 0).contains("(0 uncompressed)"));
    // A size that would overflow any product stays a clean refusal.
    let mut huge = good.clone();
    for offset in [20, 24, 28] {
        set(&mut huge, offset, u32::MAX);
    }
    let err = error_of(&huge);
    assert!(err.contains("level index states"), "{err}");
}

#[test]
fn a_descriptor_other_than_the_writers_is_refused_naming_the_field() {
    let good = test_file("karis.ktx2");
    for (byte, value, field_name) in [(14, 2u8, "transfer function"), (15, 1, "flags"), (13, 1, "colour primaries")] {
        let mut bytes = good.clone();
        bytes[DFD_OFFSET + byte] = value;
        let err = error_of(&bytes);
        assert!(err.contains(field_name) && err.contains("VK_FORMAT_R16G16_SFLOAT"), "{err}");
    }
    // The byte the ktx2 crate's own descriptor parser overflows on: refused without a panic.
    let mut bytes = good.clone();
    bytes[DFD_OFFSET + 16] = 255;
    assert!(error_of(&bytes).contains("texel block dimensions"));
}

#[test]
fn key_value_data_that_disagrees_with_the_texels_or_is_malformed_is_refused() {
    let err = edited("karis.ktx2", b"tmlut.precision\0f16", b"tmlut.precision\0f32");
    assert!(err.contains("`tmlut.precision` is f32") && err.contains("R16G16_SFLOAT"), "{err}");
    let err = edited("karis.ktx2", b"KTXorientation\0rd", b"KTXorientation\0ru");
    assert!(err.contains("`ru`") && err.contains("`rd`"), "{err}");
    let err = edited("karis.ktx2", b"tmlut.axes\0", b"tmlut.axez\0");
    assert!(err.contains("lacks `tmlut.axes`") && err.contains("not written by tmlut"), "{err}");
    let err = edited("karis.ktx2", b"KTXwriter\0", b"zTXwriter\0");
    assert!(err.contains("keys are sorted"), "{err}");
    // A cell-centred axis's formula does not depend on its count: the extents catch it.
    let err = edited("karis.ktx2", b"\"count\":6", b"\"count\":7");
    assert!(err.contains("axis `alpha` has 7 nodes, the texture height is 6"), "{err}");
    // A node-aligned axis's formula does.
    let err = edited("gd.ktx2", b"\"count\":9", b"\"count\":8");
    assert!(err.contains("texture coordinate"), "{err}");
    let err = edited("tir.ktx2", b"\"start\":-1.5", b"\"start\":-1.4");
    assert!(err.contains("texture coordinate"), "{err}");
    let err = edited("karis.ktx2", b"\"name\":\"c0\"", b"\"name\":7777");
    assert!(err.contains("`tmlut.channels` is not valid"), "{err}");
    // A pair claiming more bytes than the key/value data holds.
    let mut bytes = test_file("karis.ktx2");
    let at = kvd_offset(&bytes);
    set(&mut bytes, at, u32::MAX);
    assert!(error_of(&bytes).contains("more than remain"));
}
