//! DDS textures with the DX10 header extension, the format a real-time renderer uploads without
//! conversion.
//!
//! Written by hand rather than through a crate: the fields are few, and the one crate that
//! writes them sets a stray `DDPF_RGB` flag next to the `DX10` fourCC that makes other readers
//! misread the file (Microsoft's `DDS_PIXELFORMAT` reference: with a `DX10` fourCC, `DDPF_FOURCC`
//! is the only flag). The reader accepts exactly what the writer produces:
//! uncompressed float formats of 1, 2 or 4 channels, 2D textures, arrays of them, or volume
//! textures, one mip level. It
//! exists because no common Linux tool decodes float DDS, so our own files need a checker.
//!
//! File layout (all little-endian): the magic `"DDS "`, the 124-byte `DDS_HEADER` (which embeds
//! the 32-byte `DDS_PIXELFORMAT`), the 20-byte `DDS_HEADER_DXT10`, then the texels, channels
//! interleaved, x fastest, then y (row 0 first), then z. That is exactly a table's storage order,
//! so axis 0 is the width, axis 1 the height and axis 2 the depth.

use std::path::Path;

use crate::error::{Error, Result};
use crate::formats::{
    Precision, StoredTexture, TextureShape, put_texels, read_bytes, texel_values, texture_extents,
    write_bytes_atomically,
};
use crate::table::Table;

const MAGIC: &[u8; 4] = b"DDS ";
const HEADER_SIZE: u32 = 124;
const PIXEL_FORMAT_SIZE: u32 = 32;
/// Magic, `DDS_HEADER` and `DDS_HEADER_DXT10`: where the texels start.
const DATA_OFFSET: usize = 4 + HEADER_SIZE as usize + DXT10_HEADER_SIZE;
const DXT10_HEADER_SIZE: usize = 20;

// DDS_HEADER.dwFlags
const DDSD_CAPS: u32 = 0x1;
const DDSD_HEIGHT: u32 = 0x2;
const DDSD_WIDTH: u32 = 0x4;
const DDSD_PITCH: u32 = 0x8;
const DDSD_PIXELFORMAT: u32 = 0x1000;
const DDSD_MIPMAPCOUNT: u32 = 0x2_0000;
const DDSD_DEPTH: u32 = 0x80_0000;

// DDS_HEADER.dwCaps and dwCaps2
const DDSCAPS_COMPLEX: u32 = 0x8;
const DDSCAPS_TEXTURE: u32 = 0x1000;
const DDSCAPS2_VOLUME: u32 = 0x20_0000;

// DDS_PIXELFORMAT.dwFlags
const DDPF_FOURCC: u32 = 0x4;
const FOURCC_DX10: &[u8; 4] = b"DX10";

// DDS_HEADER_DXT10.resourceDimension
const RESOURCE_DIMENSION_TEXTURE2D: u32 = 3;
const RESOURCE_DIMENSION_TEXTURE3D: u32 = 4;
// DDS_HEADER_DXT10.miscFlag
const RESOURCE_MISC_TEXTURECUBE: u32 = 0x4;

/// The DXGI formats written and read, as (DXGI_FORMAT, channels, precision).
const FORMATS: [(u32, usize, Precision); 6] = [
    (2, 4, Precision::F32),  // R32G32B32A32_FLOAT
    (10, 4, Precision::F16), // R16G16B16A16_FLOAT
    (16, 2, Precision::F32), // R32G32_FLOAT
    (34, 2, Precision::F16), // R16G16_FLOAT
    (41, 1, Precision::F32), // R32_FLOAT
    (54, 1, Precision::F16), // R16_FLOAT
];

fn dxgi_format(channels: usize, precision: Precision) -> Option<u32> {
    FORMATS.iter().find(|&&(_, c, p)| c == channels && p == precision).map(|&(f, _, _)| f)
}

/// The DXGI name of the format holding `channels` channels in `precision`, e.g. `R16G16_FLOAT`.
pub fn dxgi_format_name(channels: usize, precision: Precision) -> String {
    format!("{}_FLOAT", super::component_layout(channels, precision))
}

/// A texture as stored in a DDS file.
pub type DdsTexture = StoredTexture;

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

/// Channels and precision of the DXGI format a DDS file's DX10 header names, if it is one tmlut
/// writes.
pub fn stored_format(bytes: &[u8]) -> Option<(usize, Precision)> {
    let format = u32::from_le_bytes(bytes.get(128..132)?.try_into().ok()?);
    FORMATS.iter().find(|&&(f, _, _)| f == format).map(|&(_, c, p)| (c, p))
}

/// Read a DDS texture written by [`write_dds`].
pub fn read_dds(path: &Path) -> Result<DdsTexture> {
    let bytes = read_bytes(path)?;
    decode_dds(&bytes, path)
}

/// [`read_dds`] on bytes already in memory; `path` names the file in errors.
pub fn decode_dds(bytes: &[u8], path: &Path) -> Result<DdsTexture> {
    let refuse = |reason: String| Error::format(path, reason);
    if bytes.len() < 4 || &bytes[..4] != MAGIC {
        return Err(refuse("not a DDS file: it does not start with the magic `DDS `".into()));
    }
    if bytes.len() < DATA_OFFSET {
        return Err(refuse(format!(
            "truncated: a DDS file with a DX10 header needs {DATA_OFFSET} header bytes, the file has {}",
            bytes.len()
        )));
    }
    let field =
        |offset: usize| u32::from_le_bytes([bytes[offset], bytes[offset + 1], bytes[offset + 2], bytes[offset + 3]]);

    let header_size = field(4);
    if header_size != HEADER_SIZE {
        return Err(refuse(format!("DDS_HEADER states size {header_size}; it must be {HEADER_SIZE}")));
    }
    let flags = field(8);
    let (height, width, depth_field, mip_count) = (field(12), field(16), field(24), field(28));
    let pixel_format_size = field(76);
    if pixel_format_size != PIXEL_FORMAT_SIZE {
        return Err(refuse(format!("DDS_PIXELFORMAT states size {pixel_format_size}; it must be {PIXEL_FORMAT_SIZE}")));
    }
    let pixel_format_flags = field(80);
    let four_cc = &bytes[84..88];
    if pixel_format_flags & DDPF_FOURCC == 0 || four_cc != FOURCC_DX10 {
        return Err(refuse(format!(
            "legacy DDS pixel format (flags {pixel_format_flags:#x}, fourCC {}); only files with the DX10 header \
             (DDPF_FOURCC and fourCC `DX10`) are read",
            String::from_utf8_lossy(four_cc).escape_debug()
        )));
    }
    let caps2 = field(112);

    // 0 and 1 both mean the base level alone. A count above 1 is refused even without
    // DDSD_MIPMAPCOUNT: some writers omit the flag, and the file then holds the extra levels.
    if mip_count > 1 {
        return Err(refuse(format!("{mip_count} mip levels; mip maps are not supported, only a single level is read")));
    }

    let format = field(128);
    let (channels, precision) =
        FORMATS.iter().find(|&&(f, _, _)| f == format).map(|&(_, c, p)| (c, p)).ok_or_else(|| {
            let allowed: Vec<String> =
                FORMATS.iter().map(|&(f, c, p)| format!("{} ({f})", dxgi_format_name(c, p))).collect();
            refuse(format!("DXGI_FORMAT {format} is not supported; allowed: {}", allowed.join(", ")))
        })?;
    let resource_dimension = field(132);
    let misc_flag = field(136);
    let array_size = field(140);
    if misc_flag & RESOURCE_MISC_TEXTURECUBE != 0 {
        return Err(refuse("a cube map; only 2D and volume textures are read".into()));
    }
    if array_size == 0 {
        return Err(refuse("an array size of 0; a texture holds at least one layer".into()));
    }
    let layered = array_size > 1;
    let volume = match resource_dimension {
        RESOURCE_DIMENSION_TEXTURE2D => {
            if caps2 & DDSCAPS2_VOLUME != 0 {
                return Err(refuse("TEXTURE2D resource dimension but the DDSCAPS2_VOLUME flag is set".into()));
            }
            false
        }
        RESOURCE_DIMENSION_TEXTURE3D => {
            if layered {
                return Err(refuse(format!("a volume texture with an array size of {array_size}; volumes are single")));
            }
            if flags & DDSD_DEPTH == 0 {
                return Err(refuse("TEXTURE3D resource dimension without the DDSD_DEPTH flag".into()));
            }
            true
        }
        other => {
            return Err(refuse(format!("resource dimension {other}; only 3 (TEXTURE2D) and 4 (TEXTURE3D) are read")));
        }
    };
    let depth = if volume { depth_field } else { array_size };
    if width == 0 || height == 0 || depth == 0 {
        return Err(refuse(format!("empty texture of {width} × {height} × {depth} texels")));
    }

    // In u128, three u32 extents times 16 bytes per texel cannot overflow whatever the header says.
    let data_len = u128::from(width) * u128::from(height) * u128::from(depth) * (channels * precision.bytes()) as u128;
    let present = (bytes.len() - DATA_OFFSET) as u128;
    if present < data_len {
        return Err(refuse(format!(
            "truncated: {width} × {height} × {depth} {} texels need {data_len} data bytes after the {DATA_OFFSET}-byte \
             header, the file has {present}",
            dxgi_format_name(channels, precision)
        )));
    }
    if present > data_len {
        return Err(refuse(format!(
            "{} bytes follow the {data_len} data bytes of a single-level {width} × {height} × {depth} {} texture; \
             only single-level textures are read",
            present - data_len,
            dxgi_format_name(channels, precision)
        )));
    }

    let data = texel_values(&bytes[DATA_OFFSET..], precision);
    Ok(DdsTexture { width, height, depth, channels, precision, volume, layered, data })
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

    #[test]
    fn truncated_file_is_refused_with_the_byte_counts() {
        let bytes = encode_dds(&sample_table(&[5, 3], 1), Precision::F32).unwrap();
        let cut = &bytes[..bytes.len() - 1];
        let err = decode_dds(cut, Path::new("cut.dds")).unwrap_err().to_string();
        assert!(err.contains("truncated") && err.contains("need 60 data bytes") && err.contains("has 59"), "{err}");
        let err = decode_dds(&bytes[..100], Path::new("cut.dds")).unwrap_err().to_string();
        assert!(err.contains("truncated") && err.contains("148"), "{err}");
    }

    #[test]
    fn foreign_files_are_refused() {
        let err = decode_dds(b"\x89PNG\r\n\x1a\n0000", Path::new("image.png")).unwrap_err();
        assert!(matches!(err, Error::Format { .. }));
        assert!(err.to_string().contains("not a DDS file"), "{err}");
        assert!(decode_dds(b"", Path::new("empty.dds")).unwrap_err().to_string().contains("not a DDS file"));

        let good = encode_dds(&sample_table(&[5, 3], 1), Precision::F32).unwrap();
        let mut mipped = good.clone();
        mipped[28..32].copy_from_slice(&3u32.to_le_bytes());
        let err = decode_dds(&mipped, Path::new("m.dds")).unwrap_err().to_string();
        assert!(err.contains("mip maps are not supported"), "{err}");

        let mut legacy = good.clone();
        legacy[84..88].copy_from_slice(b"DXT1");
        let err = decode_dds(&legacy, Path::new("l.dds")).unwrap_err().to_string();
        assert!(err.contains("DX10"), "{err}");

        let mut unsupported = good.clone();
        unsupported[128..132].copy_from_slice(&28u32.to_le_bytes()); // R8G8B8A8_UNORM
        let err = decode_dds(&unsupported, Path::new("u.dds")).unwrap_err().to_string();
        assert!(err.contains("DXGI_FORMAT 28") && err.contains("R16_FLOAT (54)"), "{err}");

        let mut huge = good.clone();
        for offset in [12, 16] {
            huge[offset..offset + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        }
        let err = decode_dds(&huge, Path::new("h.dds")).unwrap_err().to_string();
        assert!(err.contains("truncated"), "{err}");

        let mut array = good;
        array[140..144].copy_from_slice(&6u32.to_le_bytes());
        // A 2D texture stated as an array of 6 layers lacks the texels of five of them.
        let err = decode_dds(&array, Path::new("a.dds")).unwrap_err().to_string();
        assert!(err.contains("truncated"), "{err}");
        array[140..144].copy_from_slice(&0u32.to_le_bytes());
        let err = decode_dds(&array, Path::new("a.dds")).unwrap_err().to_string();
        assert!(err.contains("array size of 0"), "{err}");
    }

    #[test]
    fn into_table_checks_axes_and_channels() {
        let table = sample_table(&[5, 3], 2);
        let bytes = encode_dds(&table, Precision::F32).unwrap();
        let texture = decode_dds(&bytes, Path::new("t.dds")).unwrap();
        let err = texture.clone().into_table("t", axes_for(&[3, 5]), channel_list(2)).unwrap_err().to_string();
        assert!(err.contains("width is 5"), "{err}");
        let err = texture.clone().into_table("t", axes_for(&[5, 3, 2]), channel_list(2)).unwrap_err().to_string();
        assert!(err.contains("needs 2"), "{err}");
        let err = texture.into_table("t", axes_for(&[5, 3]), channel_list(1)).unwrap_err().to_string();
        assert!(err.contains("holds 2"), "{err}");
    }
}
