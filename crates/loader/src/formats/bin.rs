//! The `.bin` layout of the original transfer-matrix code release, read and written
//! bit-for-bit.
//!
//! Its tables are the reference the generator is checked against, and the thesis renderer loads
//! them directly, so this module must read the shipped files and write files those programs
//! accept. The layout, all little-endian, is
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
use crate::formats::{Precision, as_format_error, check_storable_values, read_bytes, write_bytes_atomically};
use crate::table::{Axis, Channel, Mapping, Placement, Table};

/// The original code release handled tables of one to four parameters.
const MAX_AXES: usize = 4;

/// Bytes per axis in the header: one `int32` size and two `float32` range ends.
const HEADER_BYTES_PER_AXIS: usize = 12;

/// Write a one-channel, node-aligned table in the original `.bin` layout.
pub fn write_bin(path: &Path, table: &Table) -> Result<()> {
    let bytes = encode_bin(table)?;
    write_bytes_atomically(path, &bytes)
}

/// The bytes of [`write_bin`]'s file.
pub fn encode_bin(table: &Table) -> Result<Vec<u8>> {
    check_expressible(table)?;
    // The layout stores float32 values, so the f32 storage check applies: no NaN, no infinity.
    check_storable_values(table, Precision::F32)?;

    let mut bytes = Vec::with_capacity(HEADER_BYTES_PER_AXIS * table.dimension() + 4 * table.data.len());
    for axis in &table.axes {
        // `check_expressible` has made sure every count fits an int32.
        bytes.extend_from_slice(&(axis.count as i32).to_le_bytes());
    }
    for axis in &table.axes {
        bytes.extend_from_slice(&(axis.start as f32).to_le_bytes());
        bytes.extend_from_slice(&(axis.end as f32).to_le_bytes());
    }
    for &value in &table.data {
        bytes.extend_from_slice(&value.to_le_bytes());
    }
    Ok(bytes)
}

/// Refuse a table the `.bin` layout cannot describe: it has no room for channel names,
/// placements or mappings, so anything but one channel on identity-mapped node-aligned axes
/// would be read back as a different table.
fn check_expressible(table: &Table) -> Result<()> {
    let key = format!("table `{}`", table.name);
    if table.channel_count() != 1 {
        return Err(Error::invalid(
            key,
            format!(
                "has {} channels; the .bin layout cannot express that: it holds exactly one value per node",
                table.channel_count()
            ),
        ));
    }
    if !(1..=MAX_AXES).contains(&table.dimension()) {
        return Err(Error::invalid(
            key,
            format!("has {} axes; the .bin layout cannot express that: it holds 1 to {MAX_AXES}", table.dimension()),
        ));
    }
    for axis in &table.axes {
        if axis.placement != Placement::NodeAligned || axis.mapping != Mapping::Identity {
            return Err(Error::invalid(
                key,
                format!(
                    "axis `{}` is {:?} with mapping {}; the .bin layout cannot express that: it holds only \
                     node-aligned axes spaced uniformly in the quantity itself",
                    axis.name,
                    axis.placement,
                    axis.mapping.formula(&axis.name)
                ),
            ));
        }
        if i32::try_from(axis.count).is_err() {
            return Err(Error::invalid(
                key,
                format!("axis `{}` has {} nodes, more than an int32 size can state", axis.name, axis.count),
            ));
        }
        // The range ends are stored as float32: they must stay finite and distinct there.
        let (start, end) = (axis.start as f32, axis.end as f32);
        if !start.is_finite() || !end.is_finite() || start == end {
            return Err(Error::invalid(
                key,
                format!(
                    "axis `{}` range [{}, {}] does not survive float32 storage (it becomes [{start}, {end}])",
                    axis.name, axis.start, axis.end
                ),
            ));
        }
    }
    Ok(())
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

    fn sample_table(shape: &[usize]) -> Table {
        let axes = shape
            .iter()
            .enumerate()
            .map(|(d, &n)| Axis::node_aligned(format!("a{d}"), d as f64 * 0.5, 1.0 + d as f64, n).unwrap())
            .collect::<Vec<_>>();
        let nodes: usize = shape.iter().product();
        let data = (0..nodes).map(|i| (i as f32 * 0.37).sin()).collect();
        Table::new("sample", axes, vec![Channel::new("value", "")], data).unwrap()
    }

    #[test]
    fn encode_decode_encode_is_bit_identical() {
        for shape in [&[7][..], &[5, 3], &[4, 2, 3], &[2, 3, 2, 4]] {
            let table = sample_table(shape);
            let bytes = encode_bin(&table).unwrap();
            assert_eq!(bytes.len(), 12 * shape.len() + 4 * table.data.len());
            let names: Vec<String> = (0..shape.len()).map(|d| format!("a{d}")).collect();
            let names: Vec<&str> = names.iter().map(String::as_str).collect();
            let back = decode_bin(&bytes, Path::new("/tmp/sample.bin"), Some(&names)).unwrap();
            assert_eq!(back.data, table.data);
            assert_eq!(back.axes, table.axes);
            assert_eq!(encode_bin(&back).unwrap(), bytes, "shape {shape:?}");
            // Without names the axis count comes from the file length alone.
            let unnamed = decode_bin(&bytes, Path::new("/tmp/sample.bin"), None).unwrap();
            assert_eq!(unnamed.shape(), shape);
        }
    }

    #[test]
    fn write_and_read_through_a_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("grid.bin");
        let table = sample_table(&[6, 4]);
        write_bin(&path, &table).unwrap();
        let back = read_bin(&path, None).unwrap();
        assert_eq!(back.name, "grid");
        assert_eq!(back.channels, vec![Channel::new("value", back.channels[0].meaning.clone())]);
        assert_eq!(back.axes[0].name, "x0");
        assert_eq!(back.axes[1].name, "x1");
        assert_eq!(back.data, table.data);
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
    fn re_encoding_the_shipped_tables_reproduces_their_bytes() {
        for file in [GD, TIR] {
            let original = std::fs::read(file).unwrap();
            let table = decode_bin(&original, Path::new(file), None).unwrap();
            assert!(encode_bin(&table).unwrap() == original, "{file} changed on re-encoding");
        }
    }

    #[test]
    fn truncated_file_is_refused_with_the_byte_counts() {
        let bytes = encode_bin(&sample_table(&[8, 8])).unwrap();
        let cut = &bytes[..bytes.len() - 10];
        let err = decode_bin(cut, Path::new("cut.bin"), None).unwrap_err().to_string();
        assert!(err.contains("truncated: a table of 8 × 8 nodes"), "{err}");
        assert!(err.contains(&bytes.len().to_string()) && err.contains(&cut.len().to_string()), "{err}");
        // Shorter than any header.
        let err = decode_bin(&bytes[..6], Path::new("cut.bin"), None).unwrap_err().to_string();
        assert!(err.contains("fit no transfer-matrix .bin layout"), "{err}");
    }

    #[test]
    fn wrong_length_file_is_refused() {
        let mut bytes = encode_bin(&sample_table(&[5, 3])).unwrap();
        bytes.extend_from_slice(&[0; 4]);
        let err = decode_bin(&bytes, Path::new("long.bin"), None).unwrap_err().to_string();
        assert!(err.contains("too long: a table of 5 × 3 nodes"), "{err}");
        // The wrong axis count, given by names, is refused too.
        let bytes = encode_bin(&sample_table(&[5, 3])).unwrap();
        let err = decode_bin(&bytes, Path::new("t.bin"), Some(&["a", "b", "c"])).unwrap_err().to_string();
        assert!(err.contains("fit no transfer-matrix .bin layout"), "{err}");
    }

    #[test]
    fn foreign_bytes_are_refused() {
        let text = b"this is plainly not a table, just some text of no special length".to_vec();
        let err = decode_bin(&text, Path::new("notes.bin"), None).unwrap_err();
        assert!(matches!(err, Error::Format { .. }), "{err}");
        assert!(err.to_string().contains("D from 1 to 4"), "{err}");
    }

    #[test]
    fn tables_the_layout_cannot_express_are_refused() {
        let two_channels = Table::zeros(
            "pair",
            vec![Axis::node_aligned("x", 0.0, 1.0, 4).unwrap()],
            vec![Channel::new("a", ""), Channel::new("b", "")],
        )
        .unwrap();
        assert!(encode_bin(&two_channels).unwrap_err().to_string().contains("exactly one value"));

        let centred =
            Table::zeros("centred", vec![Axis::cell_centred("x", 0.0, 1.0, 4).unwrap()], vec![Channel::new("v", "")])
                .unwrap();
        let err = encode_bin(&centred).unwrap_err().to_string();
        assert!(err.contains("cannot express"), "{err}");

        let mapped = Table::zeros(
            "mapped",
            vec![Axis::node_aligned("alpha", 0.0, 1.0, 4).unwrap().with_mapping(Mapping::Sqrt).unwrap()],
            vec![Channel::new("v", "")],
        )
        .unwrap();
        assert!(encode_bin(&mapped).unwrap_err().to_string().contains("sqrt(alpha)"));

        let five = sample_table(&[2, 2, 2, 2, 2]);
        assert!(encode_bin(&five).unwrap_err().to_string().contains("1 to 4"));

        let mut nan = sample_table(&[3, 3]);
        nan.data[4] = f32::NAN;
        assert!(encode_bin(&nan).unwrap_err().to_string().contains("1 NaN"));
    }
}
