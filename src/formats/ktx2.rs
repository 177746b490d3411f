//! Writing KTX 2.0 textures; the reader and the file's layout are the loader's
//! (`tmlut_loader::formats::ktx2`), re-exported here. The header, the level index and the Basic
//! block of the data format descriptor are the `ktx2` crate's records; the crates that write whole
//! files wrap the C++ KTX-Software (a CMake build), so the file is assembled here.

pub use tmlut_loader::formats::ktx2::*;

use std::collections::BTreeMap;
use std::path::Path;

use ::ktx2::{Header, Index, LevelIndex};

use super::manifest::AxisEntry;
use super::{Precision, TextureShape, put_texels, texture_extents, write_bytes_atomically};
use crate::error::{Error, Result};
use crate::table::Table;
use layout::*;

/// What the key/value data of `table`'s file states, stored in `precision` as a volume or not.
fn description(table: &Table, precision: Precision, volume: bool) -> Description {
    Description {
        table: table.name.clone(),
        axes: table.axes.iter().enumerate().map(|(d, axis)| AxisEntry::new(axis, stored_along(axis, d))).collect(),
        channels: table.channels.clone(),
        precision,
        orientation: orientation(volume).into(),
        writer: format!("tmlut {}", env!("CARGO_PKG_VERSION")),
    }
}

/// The key/value pairs of `description`, sorted by key as KTX 2.0 requires (a `BTreeMap` of UTF-8
/// keys sorts by code point).
fn pairs(description: &Description) -> Result<BTreeMap<&'static str, String>> {
    Ok(BTreeMap::from([
        (KEY_ORIENTATION, description.orientation.clone()),
        (KEY_WRITER, description.writer.clone()),
        (KEY_TABLE, description.table.clone()),
        (KEY_AXES, to_json(&description.axes)?),
        (KEY_CHANNELS, to_json(&description.channels)?),
        (KEY_PRECISION, precision_name(description.precision).into()),
    ]))
}

fn to_json<T: serde::Serialize>(value: &T) -> Result<String> {
    serde_json::to_string(value).map_err(|e| Error::invalid("KTX2 key/value data", e.to_string()))
}

/// Write a 2-axis table as a 2D texture or a 3-axis table as a volume texture.
pub fn write_ktx2(path: &Path, table: &Table, precision: Precision) -> Result<()> {
    let bytes = encode_ktx2(table, precision)?;
    write_bytes_atomically(path, &bytes)
}

/// Key/value data: for each pair, its byte length, the key, NUL, the value, NUL, zero padding to
/// a multiple of 4.
fn key_value_bytes(pairs: &BTreeMap<&str, String>) -> Vec<u8> {
    let mut bytes = Vec::new();
    for (key, value) in pairs {
        let length = key.len() + 1 + value.len() + 1;
        bytes.extend_from_slice(&(length as u32).to_le_bytes());
        bytes.extend_from_slice(key.as_bytes());
        bytes.push(0);
        bytes.extend_from_slice(value.as_bytes());
        bytes.push(0);
        bytes.resize(bytes.len().next_multiple_of(4), 0);
    }
    bytes
}

/// The bytes of [`write_ktx2`]'s file.
pub fn encode_ktx2(table: &Table, precision: Precision) -> Result<Vec<u8>> {
    let key = format!("table `{}`", table.name);
    let ([width, height, depth], shape, format) = texture_extents(table, precision, "KTX2", vk_format)?;
    let volume = shape == TextureShape::Volume;

    let (dfd, type_size) = data_format_descriptor(format)?;
    let kvd = key_value_bytes(&pairs(&description(table, precision, volume))?);
    let kvd_offset = DFD_OFFSET + dfd.len();
    let texel_bytes = table.channel_count() * precision.bytes();
    let data_offset = (kvd_offset + kvd.len()).next_multiple_of(level_alignment(texel_bytes));
    let data_len = table.data.len() * precision.bytes();
    let too_long = || Error::invalid(&key, "its key/value data exceeds the 4 GiB a KTX2 index addresses");
    let header = Header {
        format: Some(format),
        type_size,
        pixel_width: width,
        pixel_height: height,
        // 0 makes a 2D texture; a volume states its depth.
        pixel_depth: if volume { depth } else { 0 },
        // 0 makes a single texture; an array states its layers (KTX 2.0 section 3.4).
        layer_count: if shape == TextureShape::Layers { depth } else { 0 },
        face_count: 1,
        level_count: 1,
        supercompression_scheme: None,
        index: Index {
            dfd_byte_offset: DFD_OFFSET as u32,
            dfd_byte_length: dfd.len() as u32,
            kvd_byte_offset: u32::try_from(kvd_offset).map_err(|_| too_long())?,
            kvd_byte_length: u32::try_from(kvd.len()).map_err(|_| too_long())?,
            sgd_byte_offset: 0,
            sgd_byte_length: 0,
        },
    };
    let level = LevelIndex {
        byte_offset: data_offset as u64,
        byte_length: data_len as u64,
        uncompressed_byte_length: data_len as u64,
    };

    let mut bytes = Vec::with_capacity(data_offset + data_len);
    bytes.extend_from_slice(&header.as_bytes());
    bytes.extend_from_slice(&level.as_bytes());
    bytes.extend_from_slice(&dfd);
    bytes.extend_from_slice(&kvd);
    bytes.resize(data_offset, 0);
    // Table storage order is already texel order.
    put_texels(&mut bytes, &table.data, precision);
    Ok(bytes)
}

#[cfg(test)]
mod tests;
