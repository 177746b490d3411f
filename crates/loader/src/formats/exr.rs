//! OpenEXR images of tables, for inspecting them in any image viewer and for renderers that load
//! EXR rather than DDS: read back here, written by `tmlut` (its `formats::exr`), both by the
//! image's [`layout`].
//!
//! An image has two dimensions, so a table of three or four axes is stored as an atlas: one tile
//! per 2D slice over axes 0 and 1, the remaining axes flattened into a slice number (axis 2
//! fastest), tiles laid out row by row in a near-square grid so that the image stays viewable.
//! Row 0 of a tile is axis-1 node 0, as in DDS. A 1-axis table is a one-row image.
//!
//! An EXR file has no place for axes, so the table's description travels in one custom text
//! attribute, `tmlut`, holding JSON: `{"table": name, "axes": [...], "channels": [...],
//! "layout": {...}}` ([`layout::Description`]). [`read_exr`] needs it to rebuild the table and
//! refuses images that lack it. Text attributes are stored as UTF-8 bytes, as OpenEXR itself does.
//!
//! tmlut stores pixels uncompressed in scan lines; the reader takes compressed images too, within
//! [`MAX_COMPRESSION_RATIO`] of the file's length.

use std::collections::HashMap;
use std::io::Cursor;
use std::path::Path;

use ::exr::meta::MetaData;
use ::exr::meta::header::Header;
use ::exr::prelude::{AnyChannel, AttributeValue, Compression, FlatSamples, ReadChannels, ReadLayers, Text};
use serde::Deserialize;

use crate::error::{Error, Result};
use crate::formats::{as_format_error, read_bytes};
use crate::table::Table;
use layout::{AtlasLayout, DESCRIPTION_ATTRIBUTE, Description, to_json, utf8_text};

/// The first four bytes of every OpenEXR file.
const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// What tmlut's writer writes into an image and the reader checks: the attribute describing the
/// table, the placement of its slices, and the text encoding.
pub mod layout {
    use ::exr::prelude::Text;
    use serde::{Deserialize, Serialize};

    use crate::error::{Error, Result};
    use crate::table::{Axis, Channel};

    /// The attribute holding the table's [`Description`].
    pub const DESCRIPTION_ATTRIBUTE: &str = "tmlut";

    /// The longest channel name an EXR header allows.
    pub const MAX_CHANNEL_NAME_BYTES: usize = 255;

    /// What an EXR file must say about its table for the table to be rebuilt.
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    pub struct Description {
        /// The table's name.
        pub table: String,
        /// Its axes.
        pub axes: Vec<Axis>,
        /// Its channels, each an image channel of the same name.
        pub channels: Vec<Channel>,
        /// Where its slices lie in the image.
        pub layout: AtlasLayout,
    }

    /// How a table's 2D slices are placed in the image.
    #[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
    pub struct AtlasLayout {
        /// Nodes of axis 0.
        pub tile_width: usize,
        /// Nodes of axis 1, or 1 for a 1-axis table.
        pub tile_height: usize,
        /// Tiles per row of the image.
        pub columns: usize,
        /// Rows of tiles.
        pub rows: usize,
        /// Product of the node counts of axes 2 and up; 1 for tables of one or two axes.
        pub slices: usize,
    }

    impl AtlasLayout {
        /// The layout for a table of this shape; `None` if the image size would overflow.
        pub fn for_shape(shape: &[usize]) -> Option<AtlasLayout> {
            let tile_width = *shape.first()?;
            let tile_height = shape.get(1).copied().unwrap_or(1);
            let slices = shape.iter().skip(2).try_fold(1usize, |acc, &n| acc.checked_mul(n))?;
            let columns = ceil_sqrt(slices);
            let rows = slices.div_ceil(columns.max(1));
            let layout = AtlasLayout { tile_width, tile_height, columns, rows, slices };
            layout.image_width()?.checked_mul(layout.image_height()?)?;
            Some(layout)
        }

        /// Pixels per row of the image: the tiles of a row side by side; `None` on overflow.
        pub fn image_width(&self) -> Option<usize> {
            self.columns.checked_mul(self.tile_width)
        }

        /// Rows of pixels of the image; `None` on overflow.
        pub fn image_height(&self) -> Option<usize> {
            self.rows.checked_mul(self.tile_height)
        }

        /// Pixel coordinates of the first node of slice `s`.
        pub fn tile_origin(&self, s: usize) -> (usize, usize) {
            ((s % self.columns) * self.tile_width, (s / self.columns) * self.tile_height)
        }
    }

    /// The smallest `c` with `c * c >= n`, found in integers (squares in u128, so they cannot
    /// overflow) so that perfect squares come out exact whatever the float square root rounds to.
    pub(super) fn ceil_sqrt(n: usize) -> usize {
        let square = |c: usize| c as u128 * c as u128;
        let mut c = (n as f64).sqrt() as usize;
        while c > 0 && square(c - 1) >= n as u128 {
            c -= 1;
        }
        while square(c) < n as u128 {
            c += 1;
        }
        c
    }

    /// OpenEXR stores text as bytes and reads them as UTF-8; the exr crate's own conversion from
    /// `&str` would panic on characters beyond Latin-1, which channel meanings may well contain.
    pub fn utf8_text(s: &str) -> Text {
        Text::from_slice_unchecked(s.as_bytes())
    }

    /// `value` as the JSON of an attribute.
    pub fn to_json<T: Serialize + ?Sized>(value: &T) -> Result<String> {
        serde_json::to_string(value).map_err(|e| Error::invalid("EXR attributes", e.to_string()))
    }
}

/// Read a table as tmlut writes it.
///
/// The header is read and checked before any pixel is decoded: the description's layout must give
/// the image's size, and the pixels that size implies must fit in the file (uncompressed, as tmlut
/// writes them) or, compressed, in [`MAX_COMPRESSION_RATIO`] times it. A damaged size field is
/// refused, never allocated.
pub fn read_exr(path: &Path) -> Result<Table> {
    decode_exr(&read_bytes(path)?, path)
}

/// [`read_exr`] on bytes already in memory; `path` names the file in errors.
pub fn decode_exr(bytes: &[u8], path: &Path) -> Result<Table> {
    // Checked here so that a foreign file is called foreign, not "missing bytes" by the decoder.
    if !bytes.starts_with(&EXR_MAGIC) {
        return Err(Error::format(
            path,
            "not an OpenEXR file: it does not start with the EXR magic number 76 2f 31 01",
        ));
    }
    let refuse = |reason: String| Error::format(path, reason);
    let unreadable = |e: ::exr::error::Error| refuse(format!("unreadable OpenEXR file (truncated or damaged?): {e}"));

    // The header alone: the exr crate reads it in bounded steps, whatever its fields claim.
    let meta = MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(unreadable)?;
    let [header] = meta.headers.as_slice() else {
        return Err(refuse(format!("{} parts; tmlut writes single-part images", meta.headers.len())));
    };
    if header.deep {
        return Err(refuse("a deep image; tmlut writes flat images".into()));
    }
    let description_json = text_attribute(&header.own_attributes.other, DESCRIPTION_ATTRIBUTE, path)?.ok_or_else(|| {
        refuse(format!(
            "the image lacks tmlut's `{DESCRIPTION_ATTRIBUTE}` attribute, so it was not written by tmlut and its axes \
             are unknown; only EXR files written by tmlut can be read back as tables"
        ))
    })?;
    let Description { table: name, axes, channels, layout: stored_layout } =
        from_json(&description_json, DESCRIPTION_ATTRIBUTE, path)?;
    if axes.is_empty() || channels.is_empty() {
        return Err(refuse("the tmlut attributes list no axes or no channels".into()));
    }
    for axis in &axes {
        axis.validate().map_err(|e| as_format_error(e, path))?;
    }

    // The layout follows from the axes; a stored one that disagrees means a damaged or edited file.
    let shape: Vec<usize> = axes.iter().map(|a| a.count).collect();
    let layout = AtlasLayout::for_shape(&shape)
        .ok_or_else(|| refuse(format!("axes of shape {shape:?} are too large for any image")))?;
    if stored_layout != layout {
        return Err(refuse(format!(
            "`{DESCRIPTION_ATTRIBUTE}` gives the layout {} but axes of shape {shape:?} are laid out as {}",
            to_json(&stored_layout)?,
            to_json(&layout)?
        )));
    }
    let (width, height) = (layout.columns * layout.tile_width, layout.rows * layout.tile_height);
    if (header.layer_size.0, header.layer_size.1) != (width, height) {
        return Err(refuse(format!(
            "the image is {} × {} pixels; the layout {} needs {width} × {height}",
            header.layer_size.0,
            header.layer_size.1,
            to_json(&layout)?
        )));
    }
    check_pixel_bytes(header, bytes.len(), path)?;

    let image = ::exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .non_parallel()
        .from_buffered(Cursor::new(bytes))
        .map_err(unreadable)?;
    let layer = image.layer_data;
    if (layer.size.0, layer.size.1) != (width, height) {
        return Err(refuse(format!(
            "the decoded image is {} × {} pixels, its header says {width} × {height}",
            layer.size.0, layer.size.1
        )));
    }

    if let Some(twice) = channels.iter().enumerate().find(|(i, c)| channels[..*i].iter().any(|d| d.name == c.name)) {
        return Err(refuse(format!("`{DESCRIPTION_ATTRIBUTE}` names the channel `{}` twice", twice.1.name)));
    }
    let mut stored = layer.channel_data.list;
    let planes = channels
        .iter()
        .map(|channel| channel_plane(&mut stored, &channel.name, width * height, path))
        .collect::<Result<Vec<_>>>()?;
    let data = untile(&planes, &layout);
    Table::new(name, axes, channels, data).map_err(|e| as_format_error(e, path))
}

/// The samples of the channel named `name`, as f32, taken out of the list rather than copied
/// (a large table's image is hundreds of megabytes).
fn channel_plane(list: &mut [AnyChannel<FlatSamples>], name: &str, pixels: usize, path: &Path) -> Result<Vec<f32>> {
    let present: Vec<String> = list.iter().map(|c| String::from_utf8_lossy(c.name.as_slice()).into_owned()).collect();
    let channel = list.iter_mut().find(|c| c.name.as_slice() == name.as_bytes()).ok_or_else(|| {
        Error::format(path, format!("the table's channel `{name}` is missing; the image has {}", present.join(", ")))
    })?;
    let values: Vec<f32> = match &mut channel.sample_data {
        FlatSamples::F32(values) => std::mem::take(values),
        FlatSamples::F16(values) => values.iter().map(|v| v.to_f32()).collect(),
        FlatSamples::U32(_) => {
            return Err(Error::format(
                path,
                format!("channel `{name}` holds u32 samples; tmlut tables are stored as f16 or f32"),
            ));
        }
    };
    if values.len() != pixels {
        return Err(Error::format(
            path,
            format!("channel `{name}` holds {} samples, the image needs {pixels} (subsampled?)", values.len()),
        ));
    }
    Ok(values)
}

/// The inverse of the writer's atlas: table data, channels interleaved, from one plane per channel.
fn untile(planes: &[Vec<f32>], layout: &AtlasLayout) -> Vec<f32> {
    let channels = planes.len();
    let width = layout.columns * layout.tile_width;
    let slice_nodes = layout.tile_width * layout.tile_height;
    let mut data = vec![0.0f32; layout.slices * slice_nodes * channels];
    for s in 0..layout.slices {
        let (x0, y0) = layout.tile_origin(s);
        for j in 0..layout.tile_height {
            let node = s * slice_nodes + j * layout.tile_width;
            let pixel = (y0 + j) * width + x0;
            let row = &mut data[node * channels..(node + layout.tile_width) * channels];
            for (c, plane) in planes.iter().enumerate() {
                let source = &plane[pixel..pixel + layout.tile_width];
                for (t, v) in row.iter_mut().skip(c).step_by(channels).zip(source) {
                    *t = *v;
                }
            }
        }
    }
    data
}

/// How many times its compressed size an EXR image's pixels may claim to be. tmlut writes
/// uncompressed images; one re-saved by another tool with lossless compression stays far below
/// this (float data of smooth tables barely compresses), while a damaged size field claims
/// millions of times the file.
pub const MAX_COMPRESSION_RATIO: u64 = 256;

/// Refuse an image whose header claims more pixel bytes than the file can hold: uncompressed, the
/// file's own length; compressed, [`MAX_COMPRESSION_RATIO`] times it (and never more than the
/// largest table file).
fn check_pixel_bytes(header: &Header, file_bytes: usize, path: &Path) -> Result<()> {
    let pixels = header.layer_size.0 as u128 * header.layer_size.1 as u128;
    let claimed = pixels * header.channels.bytes_per_pixel as u128;
    let (limit, why) = if header.compression == Compression::Uncompressed {
        (file_bytes as u128, "the file's length (uncompressed)".to_string())
    } else {
        let limit = (file_bytes as u128 * MAX_COMPRESSION_RATIO as u128).min(super::MAX_TABLE_FILE_BYTES as u128);
        (limit, format!("{MAX_COMPRESSION_RATIO} times the file's length ({:?} compression)", header.compression))
    };
    if claimed > limit {
        return Err(Error::format(
            path,
            format!(
                "truncated or damaged: the header claims {} × {} pixels of {} bytes ({claimed} bytes), more than \
                 {why} allows ({limit} bytes)",
                header.layer_size.0, header.layer_size.1, header.channels.bytes_per_pixel
            ),
        ));
    }
    Ok(())
}

/// A text attribute as UTF-8; `None` if absent.
fn text_attribute(attributes: &HashMap<Text, AttributeValue>, name: &str, path: &Path) -> Result<Option<String>> {
    match attributes.get(&utf8_text(name)) {
        None => Ok(None),
        Some(AttributeValue::Text(text)) => String::from_utf8(text.as_slice().to_vec())
            .map(Some)
            .map_err(|_| Error::format(path, format!("attribute `{name}` is not UTF-8 text"))),
        Some(other) => Err(Error::format(
            path,
            format!(
                "attribute `{name}` is of type `{}`, tmlut writes it as text",
                String::from_utf8_lossy(other.kind_name())
            ),
        )),
    }
}

fn from_json<T: for<'de> Deserialize<'de>>(json: &str, attribute: &str, path: &Path) -> Result<T> {
    serde_json::from_str(json).map_err(|e| Error::format(path, format!("attribute `{attribute}` is not valid: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::Precision;
    use crate::formats::dds::decode_dds;
    use crate::formats::test_folder::{test_axes, test_file};
    use ::exr::prelude::{AnyChannels, Image, SmallVec, WritableImage};

    fn decode(bytes: &[u8]) -> Result<Table> {
        decode_exr(bytes, Path::new("t.exr"))
    }

    #[test]
    fn an_atlas_reads_as_its_dds_twin_with_the_axes_and_channels_it_states() {
        let table = decode(&test_file("slices.exr")).unwrap();
        let twin = decode_dds(&test_file("slices.dds"), Path::new("slices.dds")).unwrap();
        assert_eq!(table.axes, test_axes("slices.exr"));
        assert_eq!(table.name, "slices");
        assert_eq!(table.channels.iter().map(|c| c.name.as_str()).collect::<Vec<_>>(), ["c0", "c1"]);
        assert_eq!(table.data, twin.data, "the same f16 values, untiled into the table's order");
        assert_eq!(twin.precision, Precision::F16);
    }

    #[test]
    fn layout_uses_a_near_square_grid() {
        for (slices, columns, rows) in
            [(1, 1, 1), (2, 2, 1), (4, 2, 2), (5, 3, 2), (64, 8, 8), (65, 9, 8), (4096, 64, 64)]
        {
            let layout = AtlasLayout::for_shape(&[4, 4, slices]).unwrap();
            assert_eq!((layout.columns, layout.rows), (columns, rows), "{slices} slices");
        }
        assert_eq!(layout::ceil_sqrt(0), 0);
        assert_eq!(layout::ceil_sqrt(usize::MAX), 1 << 32);
    }

    #[test]
    fn foreign_exr_is_refused_for_lacking_the_axes_attribute() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("foreign.exr");
        let channel = AnyChannel::new("Y", FlatSamples::F32(vec![0.5; 6]));
        let image = Image::from_channels((3, 2), AnyChannels::sort(SmallVec::from_vec(vec![channel])));
        image.write().to_file(&path).unwrap();
        let err = read_exr(&path).unwrap_err();
        assert!(matches!(err, Error::Format { .. }));
        assert!(err.to_string().contains("lacks tmlut's `tmlut` attribute"), "{err}");
    }

    #[test]
    fn truncated_and_non_exr_files_are_refused() {
        let bytes = test_file("slices.exr");
        for cut in [bytes.len() - 7, bytes.len() / 2, 40, 3, 0] {
            let err = decode(&bytes[..cut]).unwrap_err();
            assert!(matches!(err, Error::Format { .. }), "cut at {cut}: {err}");
        }
        let err = decode(b"DDS plainly not an EXR file at all").unwrap_err().to_string();
        assert!(err.contains("not an OpenEXR file"), "{err}");
        let err = decode(&bytes[..bytes.len() / 2]).unwrap_err().to_string();
        assert!(err.contains("truncated or damaged"), "{err}");
    }

    #[test]
    fn edited_layout_is_refused() {
        // 7 slices lie in 3 rows of 3 tiles; the same number of bytes states one row of 7.
        let mut bytes = test_file("slices.exr");
        let (from, to) = (b"\"columns\":3,\"rows\":3", b"\"columns\":7,\"rows\":1");
        let at = bytes.windows(from.len()).position(|w| w == from).expect("the layout");
        bytes[at..at + from.len()].copy_from_slice(to);
        let err = decode(&bytes).unwrap_err().to_string();
        assert!(err.contains("gives the layout"), "{err}");
    }
}
