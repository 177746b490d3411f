//! Writing DDS textures with the DX10 header extension; the reader and the headers' layout are
//! the loader's (`tmlut_loader::formats::dds`), re-exported here. The header holds only what
//! the layout needs: with a `DX10` fourCC, `DDPF_FOURCC` is the only pixel-format flag (a stray
//! `DDPF_RGB` beside it, as one DDS crate writes, makes other readers misread the file).

pub use tmlut_loader::formats::dds::*;

use std::path::Path;

use super::{Precision, TextureShape, put_texels, texture_extents, write_bytes_atomically};
use crate::error::{Error, Result};
use crate::table::Table;
use layout::*;

/// Write a 2-axis table as a 2D texture, a 3-axis table as a volume texture, or as an array of 2D
/// textures where its third axis is [`crate::formats::LAYER_AXIS`].
pub fn write_dds(path: &Path, table: &Table, precision: Precision) -> Result<()> {
    let bytes = encode_dds(table, precision)?;
    write_bytes_atomically(path, &bytes)
}

/// The bytes of [`write_dds`]'s file.
pub fn encode_dds(table: &Table, precision: Precision) -> Result<Vec<u8>> {
    let key = format!("table `{}`", table.name);
    let ([width, height, depth], shape, format) = texture_extents(table, precision, "DDS", dxgi_format)?;
    let volume = shape == TextureShape::Volume;

    let bytes_per_texel = table.channel_count() * precision.bytes();
    let pitch = u32::try_from(width as usize * bytes_per_texel)
        .map_err(|_| Error::invalid(&key, format!("a row of {width} texels is too long for a DDS pitch")))?;

    let mut flags = DDSD_CAPS | DDSD_HEIGHT | DDSD_WIDTH | DDSD_PITCH | DDSD_PIXELFORMAT | DDSD_MIPMAPCOUNT;
    let mut caps = DDSCAPS_TEXTURE;
    let mut caps2 = 0;
    if volume {
        flags |= DDSD_DEPTH;
        caps |= DDSCAPS_COMPLEX;
        caps2 |= DDSCAPS2_VOLUME;
    }

    let mut bytes = Vec::with_capacity(DATA_OFFSET + table.data.len() * precision.bytes());
    let mut put = |v: u32| bytes.extend_from_slice(&v.to_le_bytes());
    // DDS_HEADER
    put(u32::from_le_bytes(*MAGIC));
    put(HEADER_SIZE);
    put(flags);
    put(height);
    put(width);
    put(pitch);
    // The depth field is meaningful only with DDSD_DEPTH; a 2D texture leaves it 0.
    put(if volume { depth } else { 0 });
    put(1); // dwMipMapCount: the base level only
    for _ in 0..11 {
        put(0); // dwReserved1
    }
    // DDS_PIXELFORMAT: only the fourCC is meaningful; the DX10 header below names the format.
    put(PIXEL_FORMAT_SIZE);
    put(DDPF_FOURCC);
    put(u32::from_le_bytes(*FOURCC_DX10));
    for _ in 0..5 {
        put(0); // dwRGBBitCount and the four masks
    }
    put(caps);
    put(caps2);
    put(0); // dwCaps3
    put(0); // dwCaps4
    put(0); // dwReserved2
    // DDS_HEADER_DXT10
    put(format);
    put(if volume { RESOURCE_DIMENSION_TEXTURE3D } else { RESOURCE_DIMENSION_TEXTURE2D });
    put(0); // miscFlag
    put(if shape == TextureShape::Layers { depth } else { 1 }); // arraySize
    put(0); // miscFlags2: DDS_ALPHA_MODE_UNKNOWN, the channels are data, not colour and alpha
    debug_assert_eq!(bytes.len(), DATA_OFFSET);

    // Table storage order is already texel order.
    put_texels(&mut bytes, &table.data, precision);
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::test_tables::{channel_list, check_texture_round_trips, sample_table_over};
    use crate::table::Axis;

    fn axes_for(shape: &[usize]) -> Vec<Axis> {
        shape
            .iter()
            .enumerate()
            .map(|(d, &n)| Axis::cell_centred(format!("a{d}"), 0.0, 1.0 + d as f64, n).unwrap())
            .collect()
    }

    fn sample_table(shape: &[usize], channels: usize) -> Table {
        sample_table_over(axes_for(shape), channels)
    }

    fn field(bytes: &[u8], offset: usize) -> u32 {
        u32::from_le_bytes(bytes[offset..offset + 4].try_into().unwrap())
    }

    #[test]
    fn an_array_round_trips_and_states_its_layers_in_the_dx10_header() {
        let mut axes = axes_for(&[5, 3]);
        axes.push(Axis::node_aligned(crate::formats::LAYER_AXIS, 0.0, 6.0, 7).unwrap());
        let table = sample_table_over(axes, 2);
        let bytes = encode_dds(&table, Precision::F32).unwrap();
        // A 2D resource of 7 layers, with no depth and no volume flag.
        assert_eq!((field(&bytes, 132), field(&bytes, 140)), (RESOURCE_DIMENSION_TEXTURE2D, 7));
        assert_eq!((field(&bytes, 8) & DDSD_DEPTH, field(&bytes, 24), field(&bytes, 112)), (0, 0, 0));
        let texture = decode_dds(&bytes, Path::new("a.dds")).unwrap();
        assert!(texture.layered && !texture.volume);
        assert_eq!((texture.width, texture.height, texture.depth), (5, 3, 7));
        assert_eq!(texture.describe(), "array of 7 2D textures 5 x 3");
        assert_eq!(texture.clone().into_table("sample", table.axes.clone(), table.channels.clone()).unwrap(), table);
        // The same texels described as a volume are refused, and an array stated as a volume too.
        let volume_axes = axes_for(&[5, 3, 7]);
        let error = texture.into_table("sample", volume_axes, table.channels.clone()).unwrap_err().to_string();
        assert!(error.contains("is an array"), "{error}");
        let mut bytes = bytes;
        bytes[132..136].copy_from_slice(&RESOURCE_DIMENSION_TEXTURE3D.to_le_bytes());
        let error = decode_dds(&bytes, Path::new("a.dds")).unwrap_err().to_string();
        assert!(error.contains("array size of 7"), "{error}");
    }

    #[test]
    fn round_trips_2d_and_volume_textures_in_both_precisions() {
        let dir = tempfile::tempdir().unwrap();
        check_texture_round_trips(sample_table, |table, precision, _| {
            let path = dir.path().join("t.dds");
            write_dds(&path, table, precision).unwrap();
            let texture = read_dds(&path).unwrap();
            let back = texture.clone().into_table("sample", table.axes.clone(), table.channels.clone()).unwrap();
            (texture, back)
        });
    }

    #[test]
    fn header_fields_sit_at_their_offsets() {
        let bytes = encode_dds(&sample_table(&[5, 3], 2), Precision::F16).unwrap();
        assert_eq!(&bytes[0..4], b"DDS ");
        assert_eq!(field(&bytes, 4), 124);
        assert_eq!(field(&bytes, 8), 0x1 | 0x2 | 0x4 | 0x8 | 0x1000 | 0x2_0000);
        assert_eq!(field(&bytes, 12), 3, "height");
        assert_eq!(field(&bytes, 16), 5, "width");
        assert_eq!(field(&bytes, 20), 5 * 2 * 2, "pitch = width * bytes per texel");
        assert_eq!(field(&bytes, 24), 0, "depth unused in 2D");
        assert_eq!(field(&bytes, 28), 1, "mip count");
        assert!(bytes[32..76].iter().all(|&b| b == 0), "reserved");
        assert_eq!(field(&bytes, 76), 32, "pixel format size");
        assert_eq!(field(&bytes, 80), 0x4, "pixel format flags: DDPF_FOURCC only");
        assert_eq!(&bytes[84..88], b"DX10");
        assert!(bytes[88..108].iter().all(|&b| b == 0), "bit count and masks");
        assert_eq!(field(&bytes, 108), 0x1000, "caps: DDSCAPS_TEXTURE only");
        assert_eq!(field(&bytes, 112), 0, "caps2");
        assert_eq!(field(&bytes, 128), 34, "R16G16_FLOAT");
        assert_eq!(field(&bytes, 132), 3, "TEXTURE2D");
        assert_eq!(field(&bytes, 136), 0, "miscFlag");
        assert_eq!(field(&bytes, 140), 1, "array size");
        assert_eq!(field(&bytes, 144), 0, "alpha mode unknown");
        assert_eq!(bytes.len(), 148 + 5 * 3 * 2 * 2);
    }

    #[test]
    fn volume_flags_are_set_only_for_volumes() {
        let volume = encode_dds(&sample_table(&[4, 3, 6], 4), Precision::F32).unwrap();
        assert_eq!(field(&volume, 8), 0x1 | 0x2 | 0x4 | 0x8 | 0x1000 | 0x2_0000 | 0x80_0000);
        assert_eq!(field(&volume, 20), 4 * 4 * 4, "pitch");
        assert_eq!(field(&volume, 24), 6, "depth");
        assert_eq!(field(&volume, 28), 1, "mip count");
        assert_eq!(field(&volume, 108), 0x1000 | 0x8, "DDSCAPS_TEXTURE | DDSCAPS_COMPLEX");
        assert_eq!(field(&volume, 112), 0x20_0000, "DDSCAPS2_VOLUME");
        assert_eq!(field(&volume, 128), 2, "R32G32B32A32_FLOAT");
        assert_eq!(field(&volume, 132), 4, "TEXTURE3D");
        assert_eq!(field(&volume, 140), 1, "array size");

        let flat = encode_dds(&sample_table(&[4, 3], 4), Precision::F32).unwrap();
        assert_eq!(field(&flat, 8) & 0x80_0000, 0);
        assert_eq!(field(&flat, 108) & 0x8, 0);
        assert_eq!(field(&flat, 112), 0);
    }

    #[test]
    fn every_channel_count_and_precision_names_its_dxgi_format() {
        let expected = [(1, Precision::F32, 41), (1, Precision::F16, 54), (2, Precision::F32, 16)];
        let expected =
            expected.into_iter().chain([(2, Precision::F16, 34), (4, Precision::F32, 2), (4, Precision::F16, 10)]);
        for (channels, precision, format) in expected {
            let bytes = encode_dds(&sample_table(&[2, 2], channels), precision).unwrap();
            assert_eq!(field(&bytes, 128), format, "{channels} channels {precision:?}");
            assert_eq!(field(&bytes, 20), (2 * channels * precision.bytes()) as u32, "pitch");
        }
    }

    #[test]
    fn row_zero_holds_the_first_node_of_axis_one() {
        // f(i, j) = 10 j + i, so each row is recognisable.
        let axes = vec![Axis::node_aligned("x", 0.0, 1.0, 4).unwrap(), Axis::node_aligned("y", 1.0, 0.0, 3).unwrap()];
        let data = (0..3).flat_map(|j| (0..4).map(move |i| (10 * j + i) as f32)).collect();
        let table = Table::new("rows", axes, channel_list(1), data).unwrap();
        let bytes = encode_dds(&table, Precision::F32).unwrap();
        let texel = |x: usize, y: usize| {
            let at = 148 + 4 * (y * 4 + x);
            f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap())
        };
        assert_eq!([texel(0, 0), texel(3, 0)], [0.0, 3.0], "row 0 is y node 0");
        assert_eq!([texel(0, 2), texel(3, 2)], [20.0, 23.0], "the last row is y node 2");
    }

    #[test]
    fn non_finite_values_are_never_written() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.dds");
        let mut table = sample_table(&[4, 4], 1);
        table.data[3] = f32::NAN;
        table.data[7] = f32::INFINITY;
        let err = write_dds(&path, &table, Precision::F32).unwrap_err().to_string();
        assert!(err.contains("`sample`") && err.contains("1 NaN and 1 infinite"), "{err}");
        assert!(!path.exists());

        // Finite in f32 but beyond the f16 range.
        let mut table = sample_table(&[4, 4], 1);
        table.data[0] = 1.0e6;
        let err = encode_dds(&table, Precision::F16).unwrap_err().to_string();
        assert!(err.contains("f16 range"), "{err}");
        assert!(encode_dds(&table, Precision::F32).is_ok());
    }

    #[test]
    fn three_channels_and_other_dimensions_are_refused() {
        let err = encode_dds(&sample_table(&[3, 3], 3), Precision::F16).unwrap_err().to_string();
        assert!(err.contains("3 channels") && err.contains("1, 2 or 4"), "{err}");
        let err = encode_dds(&sample_table(&[3], 1), Precision::F16).unwrap_err().to_string();
        assert!(err.contains("1 axes"), "{err}");
        let err = encode_dds(&sample_table(&[2, 2, 2, 2], 1), Precision::F16).unwrap_err().to_string();
        assert!(err.contains("4 axes"), "{err}");
    }
}
