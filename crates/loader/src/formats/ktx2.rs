//! KTX 2.0 textures (Khronos, <https://registry.khronos.org/KTX/specs/2.0/ktxspec.v2.html>), the
//! container that Bevy, three.js, glTF tool chains and wgpu-based renderers load: read back here,
//! written by `tmlut` (its `formats::ktx2`), both by the file's [`layout`].
//!
//! A table is stored as a DDS file stores it ([`super::dds`]): 2 axes make a 2D texture, 3 a
//! volume texture, with 1, 2 or 4 channels in `VK_FORMAT_R16_SFLOAT`, `R16G16_SFLOAT`,
//! `R16G16B16A16_SFLOAT` or their 32-bit versions, one mip level, no supercompression, the texels
//! in the table's own order (x = axis 0 fastest, row 0 = the first node of axis 1, then z).
//!
//! File layout (little-endian, KTX 2.0 section 3): the 80-byte header, one 24-byte level index
//! entry, the data format descriptor (its total size and one Basic block), the key/value data
//! sorted by key, zero padding to `lcm(texel size, 4)`, the texels. The header, the level index
//! and the Basic block are the `ktx2` crate's records; its descriptor generator follows the Khronos
//! Data Format specification for every `VkFormat`, and only the colour primaries are changed here,
//! to unspecified: the channels are data, not colours in any colour space. The transfer function
//! is linear, as the specification requires of a float format.
//!
//! The key/value data carries what the manifest states about the table, so that the file alone
//! says how to read it (`docs/formats.md`, "KTX2"): `KTXorientation` (`rd` for a 2D texture, `rdi`
//! for a volume: texture coordinate 0 at the first texel, rows and slices in storage order),
//! `KTXwriter` (`tmlut` and its version), and `tmlut.table`, `tmlut.axes` (the manifest's axis
//! entries as JSON: quantity, range, node count, placement, mapping, the texture coordinate
//! formula), `tmlut.channels` (JSON: name and meaning of each) and `tmlut.precision`.
//!
//! The reader accepts what tmlut writes, nothing else, and checks every offset and length
//! the header states against the file's length before reading or allocating. It does not hand the
//! file to the crate's `Reader`: ktx2 0.5.0 parses a descriptor's texel block dimensions with an
//! overflowing `+ 1` that panics on the byte 255; the descriptor is compared byte for byte with
//! the one tmlut writes ([`layout::data_format_descriptor`]) instead.

use std::path::Path;

use ::ktx2::{Format, Header, Index, LevelIndex};

use crate::error::{Error, Result};
use crate::formats::manifest::AxisEntry;
use crate::formats::{Precision, StoredTexture, as_format_error, read_bytes, texel_values};
use crate::table::{Channel, Table};
use layout::*;

/// The 12-byte file identifier `«KTX 20»\r\n\x1A\n`.
const IDENTIFIER: [u8; 12] = ::ktx2::MAGIC;
/// Where the level index starts: right after the header.
const LEVEL_INDEX_OFFSET: usize = Header::LENGTH;

// The keys of the key/value data (`docs/formats.md`, "KTX2"): two standard keys of KTX 2.0, and
// tmlut's own under the prefix `tmlut.` (the prefixes `KTX` and `ktx` are reserved to the
// specification).
/// Standard key: `rd` (2D) or `rdi` (volume).
pub const KEY_ORIENTATION: &str = "KTXorientation";
/// Standard key: `tmlut` and its version.
pub const KEY_WRITER: &str = "KTXwriter";
/// The table's name.
pub const KEY_TABLE: &str = "tmlut.table";
/// JSON: the manifest's axis entries, axis 0 first.
pub const KEY_AXES: &str = "tmlut.axes";
/// JSON: each channel's name and meaning.
pub const KEY_CHANNELS: &str = "tmlut.channels";
/// `f16` or `f32`.
pub const KEY_PRECISION: &str = "tmlut.precision";

/// The Vulkan name, without its `VK_FORMAT_` prefix, of the format holding `channels` channels in
/// `precision`, e.g. `R16G16_SFLOAT`.
pub fn vk_format_name(channels: usize, precision: Precision) -> String {
    format!("{}_SFLOAT", super::component_layout(channels, precision))
}

/// The facts of a KTX2 file that tmlut's writer writes and the reader checks: where its sections
/// start, its formats, the data format descriptor of each, its alignment and orientation, and how
/// its key/value data names an axis's dimension and a precision.
pub mod layout {
    use ::ktx2::dfd;
    use ::ktx2::{Format, Header, LevelIndex};

    use crate::error::{Error, Result};
    use crate::formats::{LAYER_AXIS, Precision};
    use crate::table::Axis;

    /// Where the data format descriptor starts: after the header and the level index of one level.
    pub const DFD_OFFSET: usize = Header::LENGTH + LevelIndex::LENGTH;

    /// The Vulkan formats written and read, as (VkFormat, channels, precision).
    pub const FORMATS: [(Format, usize, Precision); 6] = [
        (Format::R16_SFLOAT, 1, Precision::F16),
        (Format::R16G16_SFLOAT, 2, Precision::F16),
        (Format::R16G16B16A16_SFLOAT, 4, Precision::F16),
        (Format::R32_SFLOAT, 1, Precision::F32),
        (Format::R32G32_SFLOAT, 2, Precision::F32),
        (Format::R32G32B32A32_SFLOAT, 4, Precision::F32),
    ];

    /// The Vulkan format holding `channels` channels in `precision`, if it is one of [`FORMATS`].
    pub fn vk_format(channels: usize, precision: Precision) -> Option<Format> {
        FORMATS.iter().find(|&&(_, c, p)| c == channels && p == precision).map(|&(f, _, _)| f)
    }

    /// The orientation a texture of `volume` or not is written in: `KTXorientation`'s value.
    pub fn orientation(volume: bool) -> &'static str {
        if volume { "rdi" } else { "rd" }
    }

    /// The texture dimension axis `d` runs along: `x`, `y`, `z`, or the layers of an array.
    pub fn stored_along(axis: &Axis, d: usize) -> &'static str {
        if d == 2 && axis.name == LAYER_AXIS { LAYER_AXIS } else { ["x", "y", "z", "w"].get(d).copied().unwrap_or("w") }
    }

    /// A precision as `tmlut.precision` states it: `f16` or `f32`.
    pub fn precision_name(precision: Precision) -> &'static str {
        match precision {
            Precision::F16 => "f16",
            Precision::F32 => "f32",
        }
    }

    /// The data format descriptor of `format` as tmlut writes it: its total size, then one Basic
    /// block (RGBSDA, linear, straight alpha) with the colour primaries unspecified; and the
    /// format's component size (the header's `typeSize`).
    pub fn data_format_descriptor(format: Format) -> Result<(Vec<u8>, u32)> {
        let (mut basic, type_size) = dfd::Basic::from_format(format)
            .map_err(|e| Error::invalid("KTX2 data format descriptor", format!("{format:?}: {e}")))?;
        basic.color_primaries = None;
        let block = dfd::Block::Basic(basic).to_vec();
        let total = 4 + block.len();
        let mut bytes = Vec::with_capacity(total);
        bytes.extend_from_slice(&(total as u32).to_le_bytes());
        bytes.extend_from_slice(&block);
        Ok((bytes, type_size))
    }

    /// The alignment of the level data: `lcm(texel size, 4)` (KTX 2.0, "mipPadding").
    pub fn level_alignment(texel_bytes: usize) -> usize {
        let gcd = |mut a: usize, mut b: usize| {
            while b != 0 {
                (a, b) = (b, a % b);
            }
            a
        };
        texel_bytes * 4 / gcd(texel_bytes, 4)
    }
}

/// What the key/value data of a tmlut KTX2 file states about its table.
#[derive(Debug, Clone, PartialEq)]
pub struct Description {
    /// The table's name ([`KEY_TABLE`]).
    pub table: String,
    /// The manifest's axis entries, axis 0 (the width) first.
    pub axes: Vec<AxisEntry>,
    /// Each channel's name and meaning ([`KEY_CHANNELS`]).
    pub channels: Vec<Channel>,
    /// The texels' precision ([`KEY_PRECISION`]).
    pub precision: Precision,
    /// `KTXorientation`: `rd` or `rdi`.
    pub orientation: String,
    /// `KTXwriter`: `tmlut` and its version.
    pub writer: String,
}

/// A KTX2 file written by tmlut: its texture and what its key/value data states.
#[derive(Debug, Clone, PartialEq)]
pub struct Ktx2Texture {
    /// The texels and extents of level 0.
    pub texture: StoredTexture,
    /// What the file's key/value data states about the table.
    pub description: Description,
}

impl Ktx2Texture {
    /// The table the file holds, with the axes and channels its key/value data states.
    pub fn into_table(self) -> Result<Table> {
        let axes = self.description.axes.into_iter().map(|entry| entry.axis).collect();
        self.texture.into_table(&self.description.table, axes, self.description.channels)
    }
}

/// Channels and precision of the `VkFormat` a KTX2 file's header names, if it is one tmlut writes.
pub fn stored_format(bytes: &[u8]) -> Option<(usize, Precision)> {
    let format = u32::from_le_bytes(bytes.get(12..16)?.try_into().ok()?);
    FORMATS.iter().find(|&&(f, _, _)| f.value() == format).map(|&(_, c, p)| (c, p))
}

/// Read a KTX2 file as tmlut writes it.
pub fn read_ktx2(path: &Path) -> Result<Ktx2Texture> {
    let bytes = read_bytes(path)?;
    decode_ktx2(&bytes, path)
}

/// What the data format descriptor's byte `k` (from the start of its total size) is.
fn dfd_field(k: usize) -> &'static str {
    match k {
        0..4 => "total size",
        4..12 => "block header",
        12 => "colour model",
        13 => "colour primaries",
        14 => "transfer function",
        15 => "flags",
        16..20 => "texel block dimensions",
        20..28 => "bytes per plane",
        _ => "sample information",
    }
}

/// [`read_ktx2`] on bytes already in memory; `path` names the file in errors.
pub fn decode_ktx2(bytes: &[u8], path: &Path) -> Result<Ktx2Texture> {
    let refuse = |reason: String| Error::format(path, reason);
    let (header, format, channels, precision) = supported_header(bytes, path)?;
    let name = vk_format_name(channels, precision);
    let (width, height) = (header.pixel_width, header.pixel_height);
    if height == 0 {
        return Err(refuse(format!("a 1D texture of {width} texels; only 2D and volume textures are read")));
    }
    let layered = header.layer_count != 0;
    let volume = header.pixel_depth != 0;
    let depth = if layered { header.layer_count } else { header.pixel_depth.max(1) };
    let (dfd_end, kvd_end) = sections(bytes, path, &header.index, format, &name)?;
    let description = read_description(&bytes[dfd_end as usize..kvd_end as usize], path)?;
    let data_offset = level_data(bytes, path, kvd_end, [width, height, depth], channels * precision.bytes(), &name)?;

    if description.precision != precision {
        return Err(refuse(format!(
            "`{KEY_PRECISION}` is {}, the texels are VK_FORMAT_{name}",
            precision_name(description.precision)
        )));
    }
    if description.orientation != orientation(volume) {
        return Err(refuse(format!(
            "`{KEY_ORIENTATION}` is `{}`; tmlut stores a {} texture as `{}` (texture coordinate 0 at the first texel)",
            description.orientation.escape_debug(),
            if volume { "volume" } else { "2D" },
            orientation(volume)
        )));
    }
    let mut texture = StoredTexture { width, height, depth, channels, precision, volume, layered, data: Vec::new() };
    let axes: Vec<_> = description.axes.iter().map(|entry| entry.axis.clone()).collect();
    texture.check_shape(&description.table, &axes, description.channels.len()).map_err(|e| as_format_error(e, path))?;
    texture.data = texel_values(&bytes[data_offset as usize..], precision);
    Ok(Ktx2Texture { texture, description })
}

/// The header of a KTX2 file tmlut reads, checked: the identifier, a whole header and level
/// index, a supported format with its component size, no supercompression, one face, one level,
/// no array of volumes. Returns the header and the format's channels and precision.
fn supported_header(bytes: &[u8], path: &Path) -> Result<(Header, Format, usize, Precision)> {
    let refuse = |reason: String| Error::format(path, reason);
    if !bytes.starts_with(&IDENTIFIER) {
        return Err(refuse(
            "not a KTX2 file: it does not start with the KTX 2.0 identifier «KTX 20»\\r\\n\\x1A\\n".into(),
        ));
    }
    if bytes.len() < DFD_OFFSET {
        return Err(refuse(format!(
            "truncated: a KTX2 file of one level needs its {DFD_OFFSET}-byte header and level index, the file has {}",
            bytes.len()
        )));
    }
    let header_bytes: &[u8; Header::LENGTH] = bytes[..Header::LENGTH].try_into().expect("length checked above");
    let header = Header::from_bytes(header_bytes).map_err(|e| refuse(format!("invalid KTX2 header: {e}")))?;

    let allowed = || {
        let names: Vec<String> =
            FORMATS.iter().map(|&(f, c, p)| format!("VK_FORMAT_{} ({})", vk_format_name(c, p), f.value())).collect();
        names.join(", ")
    };
    let stated_format = u32::from_le_bytes(bytes[12..16].try_into().expect("4 bytes"));
    let (format, channels, precision) = *FORMATS
        .iter()
        .find(|&&(f, _, _)| Some(f) == header.format)
        .ok_or_else(|| refuse(format!("vkFormat {stated_format} is not supported; allowed: {}", allowed())))?;
    let name = vk_format_name(channels, precision);
    if header.type_size as usize != precision.bytes() {
        return Err(refuse(format!(
            "typeSize {} for VK_FORMAT_{name}; it must be {}, the bytes of one component",
            header.type_size,
            precision.bytes()
        )));
    }
    if let Some(scheme) = header.supercompression_scheme {
        return Err(refuse(format!(
            "supercompression scheme {}; only uncompressed files (scheme 0) are read",
            scheme.value()
        )));
    }
    let layered = header.layer_count != 0;
    if layered && header.pixel_depth != 0 {
        return Err(refuse(format!(
            "an array of {} volume textures; only single volumes and arrays of 2D textures are read",
            header.layer_count
        )));
    }
    if header.face_count != 1 {
        return Err(refuse(format!("{} faces (a cube map); only 2D and volume textures are read", header.face_count)));
    }
    // 0 and 1 both mean the base level alone (0 asks a loader to generate the others).
    if header.level_count > 1 {
        return Err(refuse(format!(
            "{} mip levels; mip maps are not supported, only a single level is read",
            header.level_count
        )));
    }
    Ok((header, format, channels, precision))
}

/// The sections between the header and the texels, in the order the writer puts them and each
/// inside the file: the data format descriptor of `format` exactly, the key/value data after it,
/// no supercompression global data. Returns where the descriptor and the key/value data end.
fn sections(bytes: &[u8], path: &Path, index: &Index, format: Format, name: &str) -> Result<(u64, u64)> {
    let refuse = |reason: String| Error::format(path, reason);
    if index.dfd_byte_offset as usize != DFD_OFFSET {
        return Err(refuse(format!(
            "its data format descriptor starts at byte {}; after the header and one level index entry it starts at \
             {DFD_OFFSET}",
            index.dfd_byte_offset
        )));
    }
    let (expected_dfd, _) = data_format_descriptor(format)?;
    let dfd_end = DFD_OFFSET as u64 + u64::from(index.dfd_byte_length);
    if u64::from(index.dfd_byte_length) != expected_dfd.len() as u64 || dfd_end > bytes.len() as u64 {
        return Err(refuse(format!(
            "its data format descriptor is stated as {} bytes (file of {} bytes); that of VK_FORMAT_{name} is {}",
            index.dfd_byte_length,
            bytes.len(),
            expected_dfd.len()
        )));
    }
    let stored_dfd = &bytes[DFD_OFFSET..dfd_end as usize];
    if let Some(k) = (0..expected_dfd.len()).find(|&k| stored_dfd[k] != expected_dfd[k]) {
        return Err(refuse(format!(
            "its data format descriptor differs from that of VK_FORMAT_{name} in its {} (byte {k}: {:#04x}, expected \
             {:#04x}); tmlut writes linear, non-premultiplied data with unspecified colour primaries",
            dfd_field(k),
            stored_dfd[k],
            expected_dfd[k]
        )));
    }
    if u64::from(index.kvd_byte_offset) != dfd_end {
        return Err(refuse(format!(
            "its key/value data starts at byte {}; it must follow the data format descriptor at {dfd_end}",
            index.kvd_byte_offset
        )));
    }
    let kvd_end = dfd_end + u64::from(index.kvd_byte_length);
    if kvd_end > bytes.len() as u64 {
        return Err(refuse(format!(
            "truncated: its key/value data ends at byte {kvd_end}, the file has {}",
            bytes.len()
        )));
    }
    if index.sgd_byte_offset != 0 || index.sgd_byte_length != 0 {
        return Err(refuse(format!(
            "supercompression global data at byte {} ({} bytes); an uncompressed file has none",
            index.sgd_byte_offset, index.sgd_byte_length
        )));
    }
    Ok((dfd_end, kvd_end))
}

/// The single level's texels of `extent` texels of `texel_bytes` each: where the level index
/// says, aligned after the key/value data ending at `kvd_end`, whole, nothing after them, zero
/// padding before them. Returns where they start.
fn level_data(
    bytes: &[u8],
    path: &Path,
    kvd_end: u64,
    [width, height, depth]: [u32; 3],
    texel_bytes: usize,
    name: &str,
) -> Result<u64> {
    let refuse = |reason: String| Error::format(path, reason);
    let level_bytes: &[u8; LevelIndex::LENGTH] =
        bytes[LEVEL_INDEX_OFFSET..DFD_OFFSET].try_into().expect("length checked above");
    let level = LevelIndex::from_bytes(level_bytes);
    // In u128, three u32 extents times 16 bytes per texel cannot overflow whatever the header says.
    let data_len = u128::from(width) * u128::from(height) * u128::from(depth) * texel_bytes as u128;
    let data_offset = kvd_end.next_multiple_of(level_alignment(texel_bytes) as u64);
    if level.byte_offset != data_offset {
        return Err(refuse(format!(
            "its level data starts at byte {}; after the key/value data, aligned to {} bytes, it starts at {data_offset}",
            level.byte_offset,
            level_alignment(texel_bytes)
        )));
    }
    if u128::from(level.byte_length) != data_len || level.uncompressed_byte_length != level.byte_length {
        return Err(refuse(format!(
            "its level index states {} bytes ({} uncompressed); {width} × {height} × {depth} VK_FORMAT_{name} texels are \
             {data_len} bytes",
            level.byte_length, level.uncompressed_byte_length
        )));
    }
    let present = (bytes.len() as u64 - data_offset.min(bytes.len() as u64)) as u128;
    if present < data_len {
        return Err(refuse(format!(
            "truncated: {width} × {height} × {depth} VK_FORMAT_{name} texels need {data_len} bytes from byte \
             {data_offset}, the file has {present}"
        )));
    }
    if present > data_len {
        return Err(refuse(format!(
            "{} bytes follow the {data_len} bytes of its single level; only single-level textures are read",
            present - data_len
        )));
    }
    if bytes[kvd_end as usize..data_offset as usize].iter().any(|&b| b != 0) {
        return Err(refuse("the padding before its level data is not zero".into()));
    }

    Ok(data_offset)
}

/// The key/value pairs of `kvd`, in file order: each key and value with its terminating NUL
/// removed from the key (values keep theirs).
fn key_value_pairs<'a>(kvd: &'a [u8], path: &Path) -> Result<Vec<(String, &'a [u8])>> {
    let refuse = |reason: String| Error::format(path, format!("key/value data: {reason}"));
    let mut pairs: Vec<(String, &[u8])> = Vec::new();
    let mut at = 0usize;
    while at < kvd.len() {
        let length = kvd
            .get(at..at + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
            .ok_or_else(|| refuse(format!("{} bytes at its end are no length field", kvd.len() - at)))?;
        let pair = kvd
            .get(at + 4..)
            .and_then(|rest| rest.get(..length))
            .ok_or_else(|| refuse(format!("a pair at byte {at} states {length} bytes, more than remain")))?;
        let nul = pair.iter().position(|&b| b == 0).filter(|&n| n > 0).ok_or_else(|| {
            refuse(format!("the pair at byte {at} has no key (a key is at least one byte and ends with NUL)"))
        })?;
        let key = std::str::from_utf8(&pair[..nul])
            .map_err(|_| refuse(format!("the key at byte {at} is not UTF-8")))?
            .to_string();
        if let Some((previous, _)) = pairs.last()
            && previous.as_str() >= key.as_str()
        {
            return Err(refuse(format!(
                "`{}` follows `{}`; keys are sorted and appear once",
                key.escape_debug(),
                previous.escape_debug()
            )));
        }
        pairs.push((key, &pair[nul + 1..]));
        at = (at + 4 + length).next_multiple_of(4);
    }
    Ok(pairs)
}

/// The description the key/value data of a tmlut KTX2 file states.
fn read_description(kvd: &[u8], path: &Path) -> Result<Description> {
    let refuse = |reason: String| Error::format(path, reason);
    let pairs = key_value_pairs(kvd, path)?;
    let text = |key: &str| -> Result<String> {
        let (_, value) = pairs.iter().find(|(k, _)| k == key).ok_or_else(|| {
            refuse(format!(
                "its key/value data lacks `{key}`, so it was not written by tmlut and its table is unknown; only KTX2 \
                 files written by tmlut can be read back as tables"
            ))
        })?;
        let value = value.strip_suffix(&[0]).unwrap_or(value);
        String::from_utf8(value.to_vec()).map_err(|_| refuse(format!("`{key}` is not UTF-8 text")))
    };
    let json = |key: &str| -> Result<serde_json::Value> {
        serde_json::from_str(&text(key)?).map_err(|e| refuse(format!("`{key}` is not valid JSON: {e}")))
    };
    let axes: Vec<AxisEntry> =
        serde_json::from_value(json(KEY_AXES)?).map_err(|e| refuse(format!("`{KEY_AXES}` is not valid: {e}")))?;
    let channels: Vec<Channel> = serde_json::from_value(json(KEY_CHANNELS)?)
        .map_err(|e| refuse(format!("`{KEY_CHANNELS}` is not valid: {e}")))?;
    let precision = match text(KEY_PRECISION)?.as_str() {
        "f16" => Precision::F16,
        "f32" => Precision::F32,
        other => {
            return Err(refuse(format!("`{KEY_PRECISION}` is `{}`; allowed: f16, f32", other.escape_debug())));
        }
    };
    if axes.is_empty() || channels.is_empty() {
        return Err(refuse(format!("`{KEY_AXES}` or `{KEY_CHANNELS}` lists nothing")));
    }
    for (d, entry) in axes.iter().enumerate() {
        let along = stored_along(&entry.axis, d);
        entry.axis.validate().map_err(|e| as_format_error(e, path))?;
        let formula = entry.axis.texture_coordinate_formula();
        if entry.stored_along != along || entry.texture_coordinate != formula {
            return Err(refuse(format!(
                "`{KEY_AXES}`: axis `{}` is stored along `{}` with the texture coordinate `{}`; its position and its \
                 range, count, placement and mapping give `{along}` and `{formula}`",
                entry.axis.name, entry.stored_along, entry.texture_coordinate
            )));
        }
    }
    Ok(Description {
        table: text(KEY_TABLE)?,
        axes,
        channels,
        precision,
        orientation: text(KEY_ORIENTATION)?,
        writer: text(KEY_WRITER)?,
    })
}

#[cfg(test)]
mod tests;
