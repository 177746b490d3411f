//! Writing the `.bin` layout of the original transfer-matrix code release, bit for bit, so that
//! its programs accept tmlut's files; the reader and the layout's bounds are the loader's
//! (`tmlut_loader::formats::bin`), re-exported here.

pub use tmlut_loader::formats::bin::*;

use std::path::Path;

use super::{Precision, check_storable_values, write_bytes_atomically};
use crate::error::{Error, Result};
use crate::table::{Mapping, Placement, Table};
use layout::{HEADER_BYTES_PER_AXIS, MAX_AXES};

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::{Axis, Channel};

    // The original tables, in the repository's test data.
    const GD: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/tmblm/tm_GD.bin");
    const TIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/tmblm/tm_TIR.bin");

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
    fn re_encoding_the_shipped_tables_reproduces_their_bytes() {
        for file in [GD, TIR] {
            let original = std::fs::read(file).unwrap();
            let table = decode_bin(&original, Path::new(file), None).unwrap();
            assert!(encode_bin(&table).unwrap() == original, "{file} changed on re-encoding");
        }
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
