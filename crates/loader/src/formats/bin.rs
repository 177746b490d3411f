//! The `.bin` layout of the original transfer-matrix code release, read bit-for-bit here and
//! written by `tmlut` (its `formats::bin`).
//!
//! Its tables are the reference the generator is checked against, and the thesis renderer loads
//! them directly, so this module must read the shipped files, and tmlut writes files those
//! programs accept. The layout, all little-endian, is
//!
//! ```text
//! int32   size[D]
//! float32 (min, max)[D]      value at the first node, value at the last node
//! float32 data[prod(size)]   axis 0 varying fastest
//! ```
//!
//! with node-aligned, uniformly spaced grids and one value per node. The file carries no magic
//! and no axis count, so a reader recognises the axis count `D` by the only thing that pins it
//! down: the length of the file must be exactly `12 D + 4 prod(size)` bytes.

use std::path::Path;

use crate::error::{Error, Result};
use crate::formats::{as_format_error, read_bytes};
use crate::table::{Axis, Channel, Table};
use layout::{HEADER_BYTES_PER_AXIS, MAX_AXES};

/// The bounds of the layout, which tmlut's writer keeps to and the reader checks.
pub mod layout {
    /// The original code release handled tables of one to four parameters.
    pub const MAX_AXES: usize = 4;

    /// Bytes per axis in the header: one `int32` size and two `float32` range ends.
    pub const HEADER_BYTES_PER_AXIS: usize = 12;
}

/// Read a `.bin` table. `axis_names`, when given, names the axes (axis 0 first) and fixes the
/// axis count; otherwise the axis count is recognised from the file length and the axes are
/// named `x0`, `x1`, ... The table is named after the file stem and its channel `value`.
pub fn read_bin(path: &Path, axis_names: Option<&[&str]>) -> Result<Table> {
    let bytes = read_bytes(path)?;
    decode_bin(&bytes, path, axis_names)
}

/// [`read_bin`] on bytes already in memory; `path` names the file in errors and the table.
pub fn decode_bin(bytes: &[u8], path: &Path, axis_names: Option<&[&str]>) -> Result<Table> {
    if let Some(names) = axis_names
        && !(1..=MAX_AXES).contains(&names.len())
    {
        return Err(Error::invalid(
            "axis names",
            format!("{} names given; a .bin table has 1 to {MAX_AXES} axes", names.len()),
        ));
    }
    let layout = recognise_layout(bytes, path, axis_names.map(<[&str]>::len))?;

    let names: Vec<String> = match axis_names {
        Some(names) => names.iter().map(|n| n.to_string()).collect(),
        None => (0..layout.sizes.len()).map(|d| format!("x{d}")).collect(),
    };
    let axes = layout
        .sizes
        .iter()
        .zip(&layout.ranges)
        .zip(names)
        .map(|((&count, &(min, max)), name)| {
            Axis::node_aligned(name, f64::from(min), f64::from(max), count).map_err(|e| as_format_error(e, path))
        })
        .collect::<Result<Vec<_>>>()?;

    let data_start = HEADER_BYTES_PER_AXIS * layout.sizes.len();
    let data = bytes[data_start..].chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();

    let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "table".into());
    let channel = Channel::new("value", "the single value per node of a transfer-matrix .bin table");
    Table::new(name, axes, vec![channel], data).map_err(|e| as_format_error(e, path))
}

/// Sizes and ranges of a header that agrees with the file length.
#[derive(Debug, Clone, PartialEq)]
struct BinLayout {
    sizes: Vec<usize>,
    ranges: Vec<(f32, f32)>,
}

/// What reading the header as a `D`-axis table gives.
enum Reading {
    /// Sizes and ranges are plausible and the length matches.
    Fits(BinLayout),
    /// Sizes and ranges are plausible but the file is not the length they imply.
    WrongLength { layout: BinLayout, expected: usize },
    /// The header bytes cannot be sizes and ranges of `D` axes.
    Implausible(String),
}

/// Find the axis count (given, or the only one from 1 to 4) whose header agrees with the file.
fn recognise_layout(bytes: &[u8], path: &Path, given_axes: Option<usize>) -> Result<BinLayout> {
    let candidates: Vec<usize> = match given_axes {
        Some(d) => vec![d],
        None => (1..=MAX_AXES).collect(),
    };
    let readings: Vec<(usize, Reading)> = candidates.iter().map(|&d| (d, read_header(bytes, d))).collect();

    let fitting: Vec<&BinLayout> = readings
        .iter()
        .filter_map(|(_, r)| match r {
            Reading::Fits(layout) => Some(layout),
            _ => None,
        })
        .collect();
    match fitting.as_slice() {
        [layout] => return Ok((*layout).clone()),
        [] => {}
        several => {
            let shapes: Vec<String> = several.iter().map(|l| shape_text(&l.sizes)).collect();
            return Err(Error::format(
                path,
                format!(
                    "ambiguous .bin file: its {} bytes read equally well as tables of {}; pass the axis names \
                     to fix the axis count",
                    bytes.len(),
                    shapes.join(" or ")
                ),
            ));
        }
    }

    // Nothing fits. Readings with a plausible header but the wrong length come first: they are
    // the likely story (a truncated or padded file); the others show why each D was ruled out.
    let mut explanations: Vec<String> = readings
        .iter()
        .filter_map(|(d, r)| match r {
            Reading::WrongLength { layout, expected } => Some(format!(
                "with D = {d} it is {}: a table of {} nodes needs {expected} bytes",
                if bytes.len() < *expected { "truncated" } else { "too long" },
                shape_text(&layout.sizes)
            )),
            _ => None,
        })
        .collect();
    explanations.extend(readings.iter().filter_map(|(d, r)| match r {
        Reading::Implausible(reason) => Some(format!("with D = {d}, {reason}")),
        _ => None,
    }));
    let given = match given_axes {
        Some(d) => format!(" with D = {d} as the axis names given say"),
        None => String::new(),
    };
    Err(Error::format(
        path,
        format!(
            "its {} bytes fit no transfer-matrix .bin layout{given} (int32 size[D], float32 (min, max)[D], float32 \
             data[prod(size)], D from 1 to {MAX_AXES}, every size >= 2, finite distinct ranges): {}",
            bytes.len(),
            explanations.join("; ")
        ),
    ))
}

/// Read the header as that of a `d`-axis table and compare the length it implies with the file.
fn read_header(bytes: &[u8], d: usize) -> Reading {
    let header_len = HEADER_BYTES_PER_AXIS * d;
    if bytes.len() < header_len {
        return Reading::Implausible(format!("the header alone needs {header_len} bytes"));
    }
    let word = |i: usize| [bytes[4 * i], bytes[4 * i + 1], bytes[4 * i + 2], bytes[4 * i + 3]];

    let mut sizes = Vec::with_capacity(d);
    for axis in 0..d {
        let size = i32::from_le_bytes(word(axis));
        if size < 2 {
            return Reading::Implausible(format!("size[{axis}] = {size} is below 2"));
        }
        sizes.push(size as usize);
    }
    let mut ranges = Vec::with_capacity(d);
    for axis in 0..d {
        let min = f32::from_le_bytes(word(d + 2 * axis));
        let max = f32::from_le_bytes(word(d + 2 * axis + 1));
        if !min.is_finite() || !max.is_finite() || min == max {
            return Reading::Implausible(format!("range[{axis}] = [{min}, {max}] is not finite and non-empty"));
        }
        ranges.push((min, max));
    }

    let expected = sizes
        .iter()
        .try_fold(1usize, |acc, &s| acc.checked_mul(s))
        .and_then(|nodes| nodes.checked_mul(4))
        .and_then(|data_len| data_len.checked_add(header_len));
    let layout = BinLayout { sizes, ranges };
    match expected {
        Some(expected) if expected == bytes.len() => Reading::Fits(layout),
        Some(expected) => Reading::WrongLength { layout, expected },
        None => Reading::Implausible(format!("sizes {} overflow the address space", shape_text(&layout.sizes))),
    }
}

fn shape_text(sizes: &[usize]) -> String {
    sizes.iter().map(|s| s.to_string()).collect::<Vec<_>>().join(" × ")
}

#[cfg(test)]
mod tests {
    use super::*;

    // The original tables, in the repository's test data (two folders up: the workspace root).
    const GD: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/tmblm/tm_GD.bin");
    const TIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/tmblm/tm_TIR.bin");

    fn decode(bytes: &[u8], names: Option<&[&str]>) -> Result<Table> {
        decode_bin(bytes, Path::new("t.bin"), names)
    }

    #[test]
    fn reads_the_shipped_gd_table() {
        let table = read_bin(Path::new(GD), Some(&["mu", "alpha"])).unwrap();
        assert_eq!(table.name, "tm_GD");
        assert_eq!(table.shape(), vec![64, 64]);
        for axis in &table.axes {
            assert_eq!((axis.start, axis.end), (0.0, 1.0));
        }
        let stats = table.stats();
        assert!(stats.min >= 0.30 && stats.max <= 1.0, "{stats:?}");
        assert_eq!(stats.nan_count + stats.infinite_count, 0);
        let corner = table.node(&[0, 0])[0];
        assert!((corner - 0.995).abs() < 1e-3, "{corner}");
        assert_eq!(table.channels, vec![Channel::new("value", table.channels[0].meaning.clone())]);
    }

    #[test]
    fn reads_the_shipped_tir_table() {
        let table = read_bin(Path::new(TIR), None).unwrap();
        assert_eq!(table.shape(), vec![64, 64, 64]);
        assert_eq!(table.axes.iter().map(|a| a.name.as_str()).collect::<Vec<_>>(), ["x0", "x1", "x2"]);
        let stats = table.stats();
        assert!(stats.min >= 0.0 && stats.max <= 1.0, "{stats:?}");
    }

    #[test]
    fn the_axis_count_comes_from_the_length_alone_or_from_the_names() {
        let bytes = std::fs::read(GD).unwrap();
        let unnamed = decode(&bytes, None).unwrap();
        let named = decode(&bytes, Some(&["mu", "alpha"])).unwrap();
        assert_eq!((unnamed.shape(), &unnamed.data), (named.shape(), &named.data));
        assert_eq!(named.axes[1].name, "alpha");
        let err = decode(&bytes, Some(&["a", "b", "c", "d", "e"])).unwrap_err().to_string();
        assert!(err.contains("5 names given"), "{err}");
    }

    #[test]
    fn truncated_file_is_refused_with_the_byte_counts() {
        let bytes = std::fs::read(GD).unwrap();
        let cut = &bytes[..bytes.len() - 10];
        let err = decode(cut, None).unwrap_err().to_string();
        assert!(err.contains("truncated: a table of 64 × 64 nodes"), "{err}");
        assert!(err.contains(&bytes.len().to_string()) && err.contains(&cut.len().to_string()), "{err}");
        // Shorter than any header.
        let err = decode(&bytes[..6], None).unwrap_err().to_string();
        assert!(err.contains("fit no transfer-matrix .bin layout"), "{err}");
    }

    #[test]
    fn wrong_length_file_is_refused() {
        let mut bytes = std::fs::read(GD).unwrap();
        bytes.extend_from_slice(&[0; 4]);
        let err = decode(&bytes, None).unwrap_err().to_string();
        assert!(err.contains("too long: a table of 64 × 64 nodes"), "{err}");
        // The wrong axis count, given by names, is refused too.
        let bytes = std::fs::read(GD).unwrap();
        let err = decode(&bytes, Some(&["a", "b", "c"])).unwrap_err().to_string();
        assert!(err.contains("fit no transfer-matrix .bin layout"), "{err}");
    }

    #[test]
    fn foreign_bytes_are_refused() {
        let text = b"this is plainly not a table, just some text of no special length".to_vec();
        let err = decode(&text, None).unwrap_err();
        assert!(matches!(err, Error::Format { .. }), "{err}");
        assert!(err.to_string().contains("D from 1 to 4"), "{err}");
    }
}
