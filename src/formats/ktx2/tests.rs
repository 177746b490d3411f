use super::*;
use crate::formats::test_tables::{check_texture_round_trips, sample_table_over};
use crate::formats::{dds, texel_values};
use crate::table::{Axis, Mapping};

/// Axes of every placement and a mapping, one descending.
fn axes_for(shape: &[usize]) -> Vec<Axis> {
    shape
        .iter()
        .enumerate()
        .map(|(d, &n)| match d {
            0 => Axis::node_aligned("a0", 0.0, 1.0, n).unwrap().with_mapping(Mapping::SqrtEnds).unwrap(),
            1 => Axis::cell_centred("a1", 1.0, 0.25, n).unwrap(),
            _ => Axis::node_aligned(format!("a{d}"), -1.5, 2.0 + d as f64, n).unwrap(),
        })
        .collect()
}

fn sample_table(shape: &[usize], channels: usize) -> Table {
    sample_table_over(axes_for(shape), channels)
}

fn decode(bytes: &[u8]) -> Result<Ktx2Texture> {
    decode_ktx2(bytes, Path::new("t.ktx2"))
}

fn field(bytes: &[u8], offset: usize) -> u32 {
    u32::from_le_bytes(bytes[offset..offset + 4].try_into().unwrap())
}

/// Where the key/value data and the level data start, from the header.
fn kvd_offset(bytes: &[u8]) -> usize {
    field(bytes, 56) as usize
}

fn data_offset(bytes: &[u8]) -> usize {
    u64::from_le_bytes(bytes[80..88].try_into().unwrap()) as usize
}

#[test]
fn an_array_round_trips_with_its_layer_count_and_the_independent_reader_agrees() {
    let mut axes = axes_for(&[5, 3]);
    axes.push(Axis::node_aligned(crate::formats::LAYER_AXIS, 0.0, 5.0, 6).unwrap());
    let table = sample_table_over(axes, 4);
    let bytes = encode_ktx2(&table, Precision::F16).unwrap();
    let reader = ::ktx2::Reader::new(bytes.as_slice()).unwrap();
    let header = reader.header();
    assert_eq!((header.layer_count, header.pixel_depth), (6, 0));
    let file = decode(&bytes).unwrap();
    assert!(file.texture.layered && !file.texture.volume);
    assert_eq!(file.texture.depth, 6);
    assert_eq!(file.description.axes[2].stored_along, "layer");
    let back = file.into_table().unwrap();
    assert_eq!(back.data, table.data.iter().map(|&v| Precision::F16.round(v)).collect::<Vec<_>>());
}

#[test]
fn round_trips_2d_and_volume_textures_in_both_precisions() {
    let dir = tempfile::tempdir().unwrap();
    check_texture_round_trips(sample_table, |table, precision, context| {
        let path = dir.path().join("t.ktx2");
        write_ktx2(&path, table, precision).unwrap();
        let file = read_ktx2(&path).unwrap();
        // The independent reader parses every kind of file too, and finds the same texels.
        let bytes = std::fs::read(&path).unwrap();
        let reader = ::ktx2::Reader::new(bytes.as_slice()).unwrap();
        let level = reader.levels().next().unwrap();
        assert_eq!(texel_values(level.data, precision), file.texture.data, "{context}");
        (file.texture.clone(), file.into_table().unwrap())
    });
}

#[test]
fn the_ktx2_crate_reads_what_is_written() {
    for (shape, channels, precision) in [(&[5, 3][..], 2, Precision::F16), (&[4, 3, 6][..], 4, Precision::F32)] {
        let table = sample_table(shape, channels);
        let bytes = encode_ktx2(&table, precision).unwrap();
        let reader = ::ktx2::Reader::new(bytes.as_slice()).unwrap();
        let header = reader.header();
        let format = vk_format(channels, precision).unwrap();
        assert_eq!(header.format, Some(format));
        assert_eq!(header.type_size as usize, precision.bytes());
        assert_eq!((header.pixel_width, header.pixel_height), (shape[0] as u32, shape[1] as u32));
        assert_eq!(header.pixel_depth, shape.get(2).map_or(0, |&d| d as u32), "0 for a 2D texture");
        assert_eq!((header.layer_count, header.face_count, header.level_count), (0, 1, 1));
        assert_eq!(header.supercompression_scheme, None);

        let basic = reader.basic_dfd().unwrap();
        assert_eq!(reader.dfd_blocks().len(), 1);
        assert_eq!(basic.color_model, Some(::ktx2::ColorModel::RGBSDA));
        assert_eq!(basic.transfer_function, Some(::ktx2::TransferFunction::Linear), "linear data, never sRGB");
        assert_eq!(basic.color_primaries, None, "data, not colours");
        assert_eq!(reader.is_alpha_premultiplied(), Some(false));
        assert_eq!(basic.sample_information.len(), channels);
        assert_eq!(basic.bytes_planes[0] as usize, channels * precision.bytes());

        let pairs: Vec<(&str, &[u8])> = reader.key_value_data().collect();
        let keys: Vec<&str> = pairs.iter().map(|(k, _)| *k).collect();
        assert_eq!(keys, [KEY_ORIENTATION, KEY_WRITER, KEY_AXES, KEY_CHANNELS, KEY_PRECISION, KEY_TABLE]);
        let value = |key: &str| pairs.iter().find(|(k, _)| *k == key).unwrap().1;
        assert_eq!(value(KEY_ORIENTATION), if shape.len() == 3 { &b"rdi\0"[..] } else { b"rd\0" });
        assert_eq!(value(KEY_TABLE), b"sample\0");
        assert_eq!(reader.writer(), Some(format!("tmlut {}\0", env!("CARGO_PKG_VERSION")).as_str()));

        let levels: Vec<_> = reader.levels().collect();
        assert_eq!(levels.len(), 1);
        let mut texels = Vec::new();
        put_texels(&mut texels, &table.data, precision);
        assert_eq!(levels[0].data, texels.as_slice());
        assert_eq!(levels[0].uncompressed_byte_length, texels.len() as u64);
    }
}

#[test]
fn level_data_is_the_dds_twins_texels_aligned_as_the_format_requires() {
    for (channels, precision, alignment) in
        [(1, Precision::F16, 4), (2, Precision::F16, 4), (4, Precision::F16, 8), (4, Precision::F32, 16)]
    {
        let table = sample_table(&[3, 5, 2], channels);
        let ktx = encode_ktx2(&table, precision).unwrap();
        let dds = dds::encode_dds(&table, precision).unwrap();
        let at = data_offset(&ktx);
        assert_eq!(at % alignment, 0, "{channels} channels {precision:?}");
        assert!(
            at >= kvd_offset(&ktx) + field(&ktx, 60) as usize
                && at < kvd_offset(&ktx) + field(&ktx, 60) as usize + alignment
        );
        assert_eq!(&ktx[at..], &dds[148..], "the same texels in the same order");
    }
}

#[test]
fn the_data_format_descriptor_is_the_khronos_one_for_each_float_format() {
    // KTX 2.0 section 3.10 and the Khronos Data Format specification: one Basic block of 24 bytes
    // plus 16 per sample; RGBSDA (1), primaries unspecified (0), linear (1), straight alpha (0);
    // each sample FLOAT | SIGNED, bit length - 1, channel R, G, B, A = 0, 1, 2, 15, with the
    // float bounds -1.0 and 1.0.
    for (channels, precision) in [(1, Precision::F16), (2, Precision::F32), (4, Precision::F16), (4, Precision::F32)] {
        let bytes = encode_ktx2(&sample_table(&[2, 2], channels), precision).unwrap();
        let dfd = &bytes[DFD_OFFSET..kvd_offset(&bytes)];
        let bits = 8 * precision.bytes();
        assert_eq!(field(dfd, 0) as usize, 4 + 24 + 16 * channels, "total size");
        assert_eq!(field(dfd, 4), 0, "vendor Khronos, descriptor type basic");
        assert_eq!(field(dfd, 8), 2 | ((24 + 16 * channels as u32) << 16), "version 2, block size");
        assert_eq!(dfd[12..16], [1, 0, 1, 0]);
        assert_eq!(dfd[16..20], [0, 0, 0, 0], "1 x 1 x 1 x 1 texel blocks");
        assert_eq!(dfd[20] as usize, channels * precision.bytes());
        assert!(dfd[21..28].iter().all(|&b| b == 0));
        let ids: &[u8] = match channels {
            1 => &[0],
            2 => &[0, 1],
            _ => &[0, 1, 2, 15],
        };
        for (k, &id) in ids.iter().enumerate() {
            let sample = &dfd[28 + 16 * k..44 + 16 * k];
            assert_eq!(u16::from_le_bytes([sample[0], sample[1]]) as usize, k * bits, "bit offset");
            assert_eq!(sample[2] as usize, bits - 1, "bit length - 1");
            assert_eq!(sample[3], 0xC0 | id, "FLOAT | SIGNED, channel {id}");
            assert_eq!(sample[4..8], [0, 0, 0, 0], "sample position");
            assert_eq!(field(sample, 8), (-1.0f32).to_bits());
            assert_eq!(field(sample, 12), 1.0f32.to_bits());
        }
    }
}

#[test]
fn the_key_value_data_states_the_manifest_facts() {
    let table = sample_table(&[4, 3, 6], 2);
    let bytes = encode_ktx2(&table, Precision::F16).unwrap();
    let file = decode(&bytes).unwrap();
    let description = &file.description;
    assert_eq!(description.table, "sample");
    assert_eq!(description.precision, Precision::F16);
    assert_eq!(description.orientation, "rdi");
    assert_eq!(description.channels, table.channels);
    let expected: Vec<AxisEntry> =
        table.axes.iter().zip(["x", "y", "z"]).map(|(a, along)| AxisEntry::new(a, along)).collect();
    assert_eq!(description.axes, expected);
    // The texture coordinate formula is spelled out per axis, as in the manifest.
    assert_eq!(description.axes[2].texture_coordinate, table.axes[2].texture_coordinate_formula());
    let kvd = &bytes[kvd_offset(&bytes)..kvd_offset(&bytes) + field(&bytes, 60) as usize];
    let text = String::from_utf8_lossy(kvd);
    assert!(text.contains("\"placement\":\"cell-centred\"") && text.contains("sqrt-ends"), "{text}");
}

#[test]
fn non_finite_values_and_shapes_no_texture_holds_are_refused() {
    let mut table = sample_table(&[4, 4], 1);
    table.data[3] = f32::NAN;
    let err = encode_ktx2(&table, Precision::F32).unwrap_err().to_string();
    assert!(err.contains("`sample`") && err.contains("1 NaN"), "{err}");
    let mut table = sample_table(&[4, 4], 1);
    table.data[0] = 1.0e6;
    assert!(encode_ktx2(&table, Precision::F16).unwrap_err().to_string().contains("f16 range"));

    let err = encode_ktx2(&sample_table(&[3, 3], 3), Precision::F16).unwrap_err().to_string();
    assert!(err.contains("3 channels") && err.contains("KTX2") && err.contains("1, 2 or 4"), "{err}");
    for shape in [&[3][..], &[2, 2, 2, 2]] {
        let err = encode_ktx2(&sample_table(shape, 1), Precision::F16).unwrap_err().to_string();
        assert!(err.contains(&format!("{} axes", shape.len())) && err.contains("KTX2"), "{err}");
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.ktx2");
    assert!(write_ktx2(&path, &sample_table(&[2, 2, 2, 2], 1), Precision::F32).is_err());
    assert!(!path.exists(), "nothing written");
}
