//! DDS textures with the DX10 header extension, the format a real-time renderer uploads without
//! conversion: read back here, written by `tmlut` (its `formats::dds`), both by the header's
//! [`layout`].
//!
//! Laid out by hand rather than through a crate: the fields are few, and the one crate that
//! writes them sets a stray `DDPF_RGB` flag next to the `DX10` fourCC that makes other readers
//! misread the file (Microsoft's `DDS_PIXELFORMAT` reference: with a `DX10` fourCC, `DDPF_FOURCC`
//! is the only flag). The reader accepts exactly what tmlut writes: uncompressed float formats of
//! 1, 2 or 4 channels, 2D textures, arrays of them, or volume textures, one mip level. It exists
//! because no common Linux tool decodes float DDS, so tmlut's own files need a checker.
//!
//! File layout (all little-endian): the magic `"DDS "`, the 124-byte `DDS_HEADER` (which embeds
//! the 32-byte `DDS_PIXELFORMAT`), the 20-byte `DDS_HEADER_DXT10`, then the texels, channels
//! interleaved, x fastest, then y (row 0 first), then z. That is exactly a table's storage order,
//! so axis 0 is the width, axis 1 the height and axis 2 the depth.

use std::path::Path;

use crate::error::{Error, Result};
use crate::formats::{Precision, StoredTexture, read_bytes, texel_values};
use layout::*;

/// The fields and codes of a DDS file's headers, as the reader checks them and tmlut's writer
/// writes them.
pub mod layout {
    use crate::formats::Precision;

    /// The file's first four bytes.
    pub const MAGIC: &[u8; 4] = b"DDS ";
    /// `DDS_HEADER.dwSize`.
    pub const HEADER_SIZE: u32 = 124;
    /// `DDS_PIXELFORMAT.dwSize`.
    pub const PIXEL_FORMAT_SIZE: u32 = 32;
    /// The length of `DDS_HEADER_DXT10`.
    pub const DXT10_HEADER_SIZE: usize = 20;
    /// Magic, `DDS_HEADER` and `DDS_HEADER_DXT10`: where the texels start.
    pub const DATA_OFFSET: usize = 4 + HEADER_SIZE as usize + DXT10_HEADER_SIZE;

    /// `DDS_HEADER.dwFlags`: `dwCaps` is set.
    pub const DDSD_CAPS: u32 = 0x1;
    /// `DDS_HEADER.dwFlags`: `dwHeight` is set.
    pub const DDSD_HEIGHT: u32 = 0x2;
    /// `DDS_HEADER.dwFlags`: `dwWidth` is set.
    pub const DDSD_WIDTH: u32 = 0x4;
    /// `DDS_HEADER.dwFlags`: `dwPitchOrLinearSize` is a row pitch.
    pub const DDSD_PITCH: u32 = 0x8;
    /// `DDS_HEADER.dwFlags`: the pixel format is set.
    pub const DDSD_PIXELFORMAT: u32 = 0x1000;
    /// `DDS_HEADER.dwFlags`: `dwMipMapCount` is set.
    pub const DDSD_MIPMAPCOUNT: u32 = 0x2_0000;
    /// `DDS_HEADER.dwFlags`: `dwDepth` is set (a volume).
    pub const DDSD_DEPTH: u32 = 0x80_0000;

    /// `DDS_HEADER.dwCaps`: more than one surface (a volume).
    pub const DDSCAPS_COMPLEX: u32 = 0x8;
    /// `DDS_HEADER.dwCaps`: always set.
    pub const DDSCAPS_TEXTURE: u32 = 0x1000;
    /// `DDS_HEADER.dwCaps2`: a volume texture.
    pub const DDSCAPS2_VOLUME: u32 = 0x20_0000;

    /// `DDS_PIXELFORMAT.dwFlags`: the fourCC names the format.
    pub const DDPF_FOURCC: u32 = 0x4;
    /// The fourCC of a file whose `DDS_HEADER_DXT10` names its DXGI format.
    pub const FOURCC_DX10: &[u8; 4] = b"DX10";

    /// `DDS_HEADER_DXT10.resourceDimension` of a 2D texture or an array of them.
    pub const RESOURCE_DIMENSION_TEXTURE2D: u32 = 3;
    /// `DDS_HEADER_DXT10.resourceDimension` of a volume texture.
    pub const RESOURCE_DIMENSION_TEXTURE3D: u32 = 4;
    /// `DDS_HEADER_DXT10.miscFlag` of a cube map.
    pub const RESOURCE_MISC_TEXTURECUBE: u32 = 0x4;

    /// The DXGI formats written and read, as (DXGI_FORMAT, channels, precision).
    pub const FORMATS: [(u32, usize, Precision); 6] = [
        (2, 4, Precision::F32),  // R32G32B32A32_FLOAT
        (10, 4, Precision::F16), // R16G16B16A16_FLOAT
        (16, 2, Precision::F32), // R32G32_FLOAT
        (34, 2, Precision::F16), // R16G16_FLOAT
        (41, 1, Precision::F32), // R32_FLOAT
        (54, 1, Precision::F16), // R16_FLOAT
    ];

    /// The DXGI format holding `channels` channels in `precision`, if it is one of [`FORMATS`].
    pub fn dxgi_format(channels: usize, precision: Precision) -> Option<u32> {
        FORMATS.iter().find(|&&(_, c, p)| c == channels && p == precision).map(|&(f, _, _)| f)
    }
}

/// The DXGI name of the format holding `channels` channels in `precision`, e.g. `R16G16_FLOAT`.
pub fn dxgi_format_name(channels: usize, precision: Precision) -> String {
    format!("{}_FLOAT", super::component_layout(channels, precision))
}

/// A texture as stored in a DDS file.
pub type DdsTexture = StoredTexture;

/// Channels and precision of the DXGI format a DDS file's DX10 header names, if it is one tmlut
/// writes.
pub fn stored_format(bytes: &[u8]) -> Option<(usize, Precision)> {
    let format = u32::from_le_bytes(bytes.get(128..132)?.try_into().ok()?);
    FORMATS.iter().find(|&&(f, _, _)| f == format).map(|&(_, c, p)| (c, p))
}

/// Read a DDS texture as tmlut writes it.
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
    use crate::formats::test_folder::{test_axes, test_file};
    use crate::table::{Axis, Channel};

    fn decode(bytes: &[u8]) -> Result<DdsTexture> {
        decode_dds(bytes, Path::new("t.dds"))
    }

    fn error_of(bytes: &[u8]) -> String {
        decode(bytes).unwrap_err().to_string()
    }

    fn channels(n: usize) -> Vec<Channel> {
        (0..n).map(|c| Channel::new(format!("c{c}"), "")).collect()
    }

    #[test]
    fn a_2d_texture_and_a_volume_read_with_their_extents_formats_and_texels() {
        let karis = test_file("karis.dds");
        let texture = decode(&karis).unwrap();
        assert_eq!((texture.width, texture.height, texture.depth), (8, 6, 1));
        assert_eq!(
            (texture.channels, texture.precision, texture.volume, texture.layered),
            (2, Precision::F16, false, false)
        );
        assert_eq!(texture.describe(), "2D texture 8 x 6");
        assert_eq!(texture.data, texel_values(&karis[DATA_OFFSET..], Precision::F16));
        assert_eq!(stored_format(&karis), Some((2, Precision::F16)));

        let tir = test_file("tir.dds");
        let texture = decode(&tir).unwrap();
        assert_eq!((texture.width, texture.height, texture.depth), (7, 5, 6));
        assert_eq!(
            (texture.channels, texture.precision, texture.volume, texture.layered),
            (1, Precision::F32, true, false)
        );
        assert_eq!(texture.describe(), "volume texture 7 x 5 x 6");
        let table = texture.into_table("tir", test_axes("tir.dds"), channels(1)).unwrap();
        assert_eq!(table.shape(), [7, 5, 6]);
        // Row 0 holds the first node of axis 1, x fastest: the table's own storage order.
        assert_eq!(table.data, texel_values(&tir[DATA_OFFSET..], Precision::F32));
    }

    #[test]
    fn an_array_reads_its_layers_from_the_dx10_header() {
        let bytes = test_file("slices.dds");
        let texture = decode(&bytes).unwrap();
        assert!(texture.layered && !texture.volume);
        assert_eq!((texture.width, texture.height, texture.depth), (5, 3, 7));
        assert_eq!(texture.describe(), "array of 7 2D textures 5 x 3");
        let axes = test_axes("slices.dds");
        assert_eq!(axes[2].name, crate::formats::LAYER_AXIS);
        assert_eq!(texture.clone().into_table("slices", axes.clone(), channels(2)).unwrap().shape(), [5, 3, 7]);
        // The same texels described as a volume are refused, and an array stated as a volume too.
        let mut volume_axes = axes;
        volume_axes[2] = Axis::node_aligned("z", 0.0, 1.0, 7).unwrap();
        let error = texture.into_table("slices", volume_axes, channels(2)).unwrap_err().to_string();
        assert!(error.contains("is an array"), "{error}");
        let mut bytes = bytes;
        bytes[132..136].copy_from_slice(&RESOURCE_DIMENSION_TEXTURE3D.to_le_bytes());
        assert!(error_of(&bytes).contains("array size of 7"), "{}", error_of(&bytes));
    }

    #[test]
    fn truncated_file_is_refused_with_the_byte_counts() {
        let bytes = test_file("karis.dds");
        let err = error_of(&bytes[..bytes.len() - 1]);
        assert!(err.contains("truncated") && err.contains("need 192 data bytes") && err.contains("has 191"), "{err}");
        let err = error_of(&bytes[..100]);
        assert!(err.contains("truncated") && err.contains("148"), "{err}");
    }

    #[test]
    fn foreign_files_are_refused() {
        let err = decode(b"\x89PNG\r\n\x1a\n0000").unwrap_err();
        assert!(matches!(err, Error::Format { .. }));
        assert!(err.to_string().contains("not a DDS file"), "{err}");
        assert!(error_of(b"").contains("not a DDS file"));

        let good = test_file("karis.dds");
        let lie = |offset: usize, value: &[u8]| {
            let mut bytes = good.clone();
            bytes[offset..offset + value.len()].copy_from_slice(value);
            error_of(&bytes)
        };
        assert!(lie(28, &3u32.to_le_bytes()).contains("mip maps are not supported"));
        assert!(lie(84, b"DXT1").contains("DX10"));
        let err = lie(128, &28u32.to_le_bytes()); // R8G8B8A8_UNORM
        assert!(err.contains("DXGI_FORMAT 28") && err.contains("R16_FLOAT (54)"), "{err}");
        let mut huge = good.clone();
        for offset in [12, 16] {
            huge[offset..offset + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        }
        assert!(error_of(&huge).contains("truncated"), "{}", error_of(&huge));
        // A 2D texture stated as an array of 6 layers lacks the texels of five of them.
        assert!(lie(140, &6u32.to_le_bytes()).contains("truncated"));
        assert!(lie(140, &0u32.to_le_bytes()).contains("array size of 0"));
        assert!(lie(136, &RESOURCE_MISC_TEXTURECUBE.to_le_bytes()).contains("cube map"));
        assert!(lie(112, &DDSCAPS2_VOLUME.to_le_bytes()).contains("DDSCAPS2_VOLUME"));
    }

    #[test]
    fn into_table_checks_axes_and_channels() {
        let texture = decode(&test_file("karis.dds")).unwrap();
        let axes = test_axes("karis.dds");
        let swapped = vec![axes[1].clone(), axes[0].clone()];
        let err = texture.clone().into_table("t", swapped, channels(2)).unwrap_err().to_string();
        assert!(err.contains("width is 8"), "{err}");
        let three = vec![axes[0].clone(), axes[1].clone(), axes[1].clone()];
        let err = texture.clone().into_table("t", three, channels(2)).unwrap_err().to_string();
        assert!(err.contains("needs 2"), "{err}");
        let err = texture.into_table("t", axes, channels(1)).unwrap_err().to_string();
        assert!(err.contains("holds 2"), "{err}");
    }
}
