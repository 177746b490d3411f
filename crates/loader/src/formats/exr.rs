//! OpenEXR images of tables, for inspecting them in any image viewer and for renderers that load
//! EXR rather than DDS.
//!
//! An image has two dimensions, so a table of three or four axes is stored as an atlas: one tile
//! per 2D slice over axes 0 and 1, the remaining axes flattened into a slice number (axis 2
//! fastest), tiles laid out row by row in a near-square grid so that the image stays viewable.
//! Row 0 of a tile is axis-1 node 0, as in DDS. A 1-axis table is a one-row image.
//!
//! An EXR file has no place for axes, so the table's description travels in one custom text
//! attribute, `tmlut`, holding JSON: `{"table": name, "axes": [...], "channels": [...],
//! "layout": {...}}`. [`read_exr`] needs it to rebuild the table and refuses images that lack it.
//! One attribute rather than several because the exr crate writes custom attributes in hash-map
//! order, which changes from run to run: with several, the same table would not give the same
//! bytes twice. Text attributes are stored as UTF-8 bytes, as OpenEXR itself does.
//!
//! Pixels are stored uncompressed in scan lines: the float values of smooth tables barely compress
//! losslessly, while compression would dominate the time to write a large table (uncompressed, a
//! 4096 × 4096 f32 image writes in about a quarter of a second).

use std::collections::HashMap;
use std::io::Cursor;
use std::path::Path;

use ::exr::meta::MetaData;
use ::exr::meta::header::Header;
use ::exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Compression, Encoding, FlatSamples, Image, Layer, LayerAttributes,
    ReadChannels, ReadLayers, SmallVec, Text, WritableImage, f16,
};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::formats::{Precision, as_format_error, check_storable_values, read_bytes, write_atomically};
use crate::table::{Axis, Channel, Table};

/// The attribute holding the table's [`Description`].
const DESCRIPTION_ATTRIBUTE: &str = "tmlut";

/// What an EXR file must say about its table for the table to be rebuilt.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Description {
    table: String,
    axes: Vec<Axis>,
    channels: Vec<Channel>,
    layout: AtlasLayout,
}

/// The first four bytes of every OpenEXR file.
const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// The longest channel name an EXR header allows.
const MAX_CHANNEL_NAME_BYTES: usize = 255;

/// How a table's 2D slices are placed in the image.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
struct AtlasLayout {
    /// Nodes of axis 0.
    tile_width: usize,
    /// Nodes of axis 1, or 1 for a 1-axis table.
    tile_height: usize,
    columns: usize,
    rows: usize,
    /// Product of the node counts of axes 2 and up; 1 for tables of one or two axes.
    slices: usize,
}

impl AtlasLayout {
    /// The layout for a table of this shape; `None` if the image size would overflow.
    fn for_shape(shape: &[usize]) -> Option<AtlasLayout> {
        let tile_width = *shape.first()?;
        let tile_height = shape.get(1).copied().unwrap_or(1);
        let slices = shape.iter().skip(2).try_fold(1usize, |acc, &n| acc.checked_mul(n))?;
        let columns = ceil_sqrt(slices);
        let rows = slices.div_ceil(columns.max(1));
        let layout = AtlasLayout { tile_width, tile_height, columns, rows, slices };
        layout.image_width()?.checked_mul(layout.image_height()?)?;
        Some(layout)
    }

    fn image_width(&self) -> Option<usize> {
        self.columns.checked_mul(self.tile_width)
    }

    fn image_height(&self) -> Option<usize> {
        self.rows.checked_mul(self.tile_height)
    }

    /// Pixel coordinates of the first node of slice `s`.
    fn tile_origin(&self, s: usize) -> (usize, usize) {
        ((s % self.columns) * self.tile_width, (s / self.columns) * self.tile_height)
    }
}

/// The smallest `c` with `c * c >= n`, found in integers (squares in u128, so they cannot
/// overflow) so that perfect squares come out exact whatever the float square root rounds to.
fn ceil_sqrt(n: usize) -> usize {
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

/// Write a table as an EXR image (an atlas of 2D slices for three or more axes).
pub fn write_exr(path: &Path, table: &Table, precision: Precision) -> Result<()> {
    let image = exr_image(table, precision)?;
    write_atomically(path, |writer| {
        // Uncompressed scan lines leave nothing to do in parallel; threads would only cost.
        image.write().non_parallel().to_buffered(writer).map_err(|e| match e {
            ::exr::error::Error::Io(io) => io,
            other => std::io::Error::other(other.to_string()),
        })
    })
}

/// The image [`write_exr`] writes, checked so that the exr crate has nothing left to refuse.
fn exr_image(table: &Table, precision: Precision) -> Result<Image<Layer<AnyChannels<FlatSamples>>>> {
    let key = format!("table `{}`", table.name);
    check_channel_names(table, &key)?;
    check_storable_values(table, precision)?;
    let too_large = || Error::invalid(&key, format!("shape {:?} is too large for an EXR image", table.shape()));
    let layout = AtlasLayout::for_shape(&table.shape()).ok_or_else(too_large)?;
    let (width, height) = (layout.image_width().ok_or_else(too_large)?, layout.image_height().ok_or_else(too_large)?);
    // EXR stores coordinates as int32.
    if i32::try_from(width).is_err() || i32::try_from(height).is_err() {
        return Err(too_large());
    }

    let planes = atlas_planes(table, &layout);
    let channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = table
        .channels
        .iter()
        .zip(planes)
        .map(|(channel, plane)| {
            let samples = match precision {
                Precision::F32 => FlatSamples::F32(plane),
                Precision::F16 => FlatSamples::F16(plane.into_iter().map(f16::from_f32).collect()),
            };
            AnyChannel::new(utf8_text(&channel.name), samples)
        })
        .collect();

    let mut attributes = LayerAttributes { software_name: Some(utf8_text("tmlut")), ..LayerAttributes::default() };
    let description =
        Description { table: table.name.clone(), axes: table.axes.clone(), channels: table.channels.clone(), layout };
    attributes.other.insert(utf8_text(DESCRIPTION_ATTRIBUTE), AttributeValue::Text(utf8_text(&to_json(&description)?)));

    let layer = Layer::new((width, height), attributes, Encoding::UNCOMPRESSED, AnyChannels::sort(channels));
    Ok(Image::from_layer(layer))
}

/// EXR channel names are null-terminated, at most 255 bytes, and must be unique in a layer.
fn check_channel_names(table: &Table, key: &str) -> Result<()> {
    for (i, channel) in table.channels.iter().enumerate() {
        let name = &channel.name;
        if name.is_empty() || name.contains('\0') || name.len() > MAX_CHANNEL_NAME_BYTES {
            return Err(Error::invalid(
                key,
                format!(
                    "channel name {name:?} cannot name an EXR channel: it must be 1 to {MAX_CHANNEL_NAME_BYTES} \
                     bytes without NUL"
                ),
            ));
        }
        if table.channels[..i].iter().any(|c| c.name == *name) {
            return Err(Error::invalid(
                key,
                format!("two channels are named `{name}`; EXR channels need distinct names"),
            ));
        }
    }
    Ok(())
}

/// One image-sized plane per channel, every slice copied into its tile and unused tiles left 0.
fn atlas_planes(table: &Table, layout: &AtlasLayout) -> Vec<Vec<f32>> {
    let channels = table.channel_count();
    let width = layout.columns * layout.tile_width;
    let mut planes = vec![vec![0.0f32; width * layout.rows * layout.tile_height]; channels];
    // Axes 2 and up vary slowest, so slice s is the contiguous run of nodes starting at
    // s * tile_width * tile_height.
    let slice_nodes = layout.tile_width * layout.tile_height;
    for s in 0..layout.slices {
        let (x0, y0) = layout.tile_origin(s);
        for j in 0..layout.tile_height {
            let node = s * slice_nodes + j * layout.tile_width;
            let pixel = (y0 + j) * width + x0;
            let row = &table.data[node * channels..(node + layout.tile_width) * channels];
            for (c, plane) in planes.iter_mut().enumerate() {
                let target = &mut plane[pixel..pixel + layout.tile_width];
                for (t, v) in target.iter_mut().zip(row.iter().skip(c).step_by(channels)) {
                    *t = *v;
                }
            }
        }
    }
    planes
}

/// Read a table written by [`write_exr`].
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

/// The inverse of [`atlas_planes`]: table data, channels interleaved, from one plane per channel.
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

/// OpenEXR stores text as bytes and reads them as UTF-8; the exr crate's own conversion from
/// `&str` would panic on characters beyond Latin-1, which channel meanings may well contain.
fn utf8_text(s: &str) -> Text {
    Text::from_slice_unchecked(s.as_bytes())
}

fn to_json<T: Serialize + ?Sized>(value: &T) -> Result<String> {
    serde_json::to_string(value).map_err(|e| Error::invalid("EXR attributes", e.to_string()))
}

fn from_json<T: for<'de> Deserialize<'de>>(json: &str, attribute: &str, path: &Path) -> Result<T> {
    serde_json::from_str(json).map_err(|e| Error::format(path, format!("attribute `{attribute}` is not valid: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::Mapping;

    fn table(axes: Vec<Axis>, channel_names: &[&str]) -> Table {
        let channels: Vec<Channel> =
            channel_names.iter().map(|n| Channel::new(*n, format!("meaning of {n}, with µ and α"))).collect();
        let len = axes.iter().map(|a| a.count).product::<usize>() * channels.len();
        // Values not exact in f16, unique per node and channel.
        let data = (0..len).map(|i| 0.1 + i as f32 * 0.013 + (i as f32 * 0.7).sin() * 1e-3).collect();
        Table::new("sample table", axes, channels, data).unwrap()
    }

    fn round_trip(table: &Table, precision: Precision) -> Table {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.exr");
        write_exr(&path, table, precision).unwrap();
        read_exr(&path).unwrap()
    }

    fn assert_round_trip(table: &Table, precision: Precision) {
        let back = round_trip(table, precision);
        assert_eq!(back.name, table.name);
        assert_eq!(back.axes, table.axes);
        assert_eq!(back.channels, table.channels);
        let expected: Vec<f32> = table.data.iter().map(|&v| precision.round(v)).collect();
        assert_eq!(back.data, expected, "{precision:?}");
    }

    #[test]
    fn two_axis_two_channel_table_round_trips_in_f32_and_f16() {
        let axes =
            vec![Axis::cell_centred("mu", 0.0, 1.0, 7).unwrap(), Axis::node_aligned("alpha", 1.0, 0.0, 5).unwrap()];
        // Names that sort in the opposite order, since EXR sorts channels by name.
        let t = table(axes, &["scale", "bias"]);
        assert_round_trip(&t, Precision::F32);
        assert_round_trip(&t, Precision::F16);
        assert_eq!(round_trip(&t, Precision::F32), t);
    }

    #[test]
    fn axis_ranges_come_back_bit_identical() {
        // Shortest-representation decimals that a best-effort JSON float parser gets 1 ulp wrong.
        let axes = vec![
            Axis::node_aligned("mu", 0.1 + 0.2, 2f64.sqrt(), 3).unwrap(),
            Axis::cell_centred("alpha", 1.0 / 3.0, 3.8415492685252453, 2).unwrap(),
        ];
        let t = table(axes, &["v"]);
        assert_eq!(round_trip(&t, Precision::F32).axes, t.axes);
    }

    #[test]
    fn three_axis_table_round_trips_through_the_atlas() {
        let axes = vec![
            Axis::node_aligned("mu", 0.0, 1.0, 5).unwrap(),
            Axis::cell_centred("alpha", 0.0, 1.0, 4).unwrap(),
            Axis::node_aligned("eta", 1.0, 3.0, 7).unwrap(),
        ];
        let t = table(axes, &["value"]);
        assert_round_trip(&t, Precision::F32);
        assert_round_trip(&t, Precision::F16);
    }

    #[test]
    fn four_axis_table_round_trips_with_descending_and_mapped_axes() {
        let axes = vec![
            Axis::node_aligned("mu", 0.0, 1.0, 4).unwrap().with_mapping(Mapping::SqrtOneMinus).unwrap(),
            Axis::cell_centred("alpha", 1.0, 0.0, 3).unwrap().with_mapping(Mapping::Sqrt).unwrap(),
            Axis::node_aligned("eta", 2.5, 1.0, 5).unwrap(),
            Axis::cell_centred("kappa", 0.0, 4.0, 6).unwrap(),
        ];
        let t = table(axes, &["R", "G", "B", "A"]);
        assert_round_trip(&t, Precision::F32);
        assert_round_trip(&t, Precision::F16);
    }

    #[test]
    fn one_axis_table_round_trips_as_a_single_row() {
        let t = table(vec![Axis::node_aligned("x", -1.0, 1.0, 9).unwrap()], &["v"]);
        assert_round_trip(&t, Precision::F32);
        let image = exr_image(&t, Precision::F32).unwrap();
        assert_eq!((image.layer_data.size.0, image.layer_data.size.1), (9, 1));
    }

    #[test]
    fn atlas_places_slices_row_by_row_and_fills_unused_tiles_with_zero() {
        // 5 slices: 3 columns, 2 rows, the last tile unused.
        let axes = vec![
            Axis::node_aligned("x", 0.0, 1.0, 3).unwrap(),
            Axis::node_aligned("y", 0.0, 1.0, 2).unwrap(),
            Axis::node_aligned("z", 0.0, 1.0, 5).unwrap(),
        ];
        let t = table(axes, &["v"]);
        let layout = AtlasLayout::for_shape(&t.shape()).unwrap();
        assert_eq!(layout, AtlasLayout { tile_width: 3, tile_height: 2, columns: 3, rows: 2, slices: 5 });
        let planes = atlas_planes(&t, &layout);
        let width = 9;
        // Slice 4 sits at column 1, row 1: pixel (3 + i, 2 + j) holds node (i, j, 4).
        assert_eq!(planes[0][(2 + 1) * width + 3 + 2], t.node(&[2, 1, 4])[0]);
        // Slice 1, row 0 of the tile, is axis-1 node 0.
        assert_eq!(planes[0][3], t.node(&[0, 0, 1])[0]);
        assert!(planes[0][2 * width + 6..].chunks(width).all(|row| row[..3].iter().all(|&v| v == 0.0)));
        assert!(planes[0].iter().all(|v| v.is_finite()));
    }

    #[test]
    fn layout_uses_a_near_square_grid() {
        for (slices, columns, rows) in
            [(1, 1, 1), (2, 2, 1), (4, 2, 2), (5, 3, 2), (64, 8, 8), (65, 9, 8), (4096, 64, 64)]
        {
            let layout = AtlasLayout::for_shape(&[4, 4, slices]).unwrap();
            assert_eq!((layout.columns, layout.rows), (columns, rows), "{slices} slices");
        }
        assert_eq!(ceil_sqrt(0), 0);
        assert_eq!(ceil_sqrt(usize::MAX), 1 << 32);
    }

    #[test]
    fn the_description_is_stored_in_text_attributes() {
        let axes = vec![Axis::node_aligned("mu", 0.0, 1.0, 64).unwrap(); 3];
        let t = Table::zeros("desc", axes, vec![Channel::new("v", "")]).unwrap();
        let image = exr_image(&t, Precision::F16).unwrap();
        let attributes = &image.layer_data.attributes.other;
        assert_eq!(attributes.len(), 1, "one attribute, so that its order cannot vary");
        let text = text_attribute(attributes, DESCRIPTION_ATTRIBUTE, Path::new("x")).unwrap().unwrap();
        let json: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(json["table"], "desc");
        assert_eq!(json["axes"], serde_json::to_value(&t.axes).unwrap());
        assert_eq!(json["channels"], serde_json::to_value(&t.channels).unwrap());
        assert_eq!(
            json["layout"].to_string(),
            r#"{"columns":8,"rows":8,"slices":64,"tile_height":64,"tile_width":64}"#
        );
    }

    #[test]
    fn non_finite_values_and_bad_channel_names_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.exr");
        let mut t = table(vec![Axis::node_aligned("x", 0.0, 1.0, 4).unwrap(); 2], &["v"]);
        t.data[5] = f32::NAN;
        let err = write_exr(&path, &t, Precision::F32).unwrap_err().to_string();
        assert!(err.contains("`sample table`") && err.contains("1 NaN"), "{err}");
        assert!(!path.exists());

        let t = table(vec![Axis::node_aligned("x", 0.0, 1.0, 4).unwrap()], &["v", "v"]);
        assert!(write_exr(&path, &t, Precision::F32).unwrap_err().to_string().contains("distinct"));
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
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.exr");
        let t = table(vec![Axis::node_aligned("x", 0.0, 1.0, 16).unwrap(); 2], &["a", "b"]);
        write_exr(&path, &t, Precision::F32).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        for cut in [bytes.len() - 7, bytes.len() / 2, 40, 3, 0] {
            std::fs::write(&path, &bytes[..cut]).unwrap();
            let err = read_exr(&path).unwrap_err();
            assert!(matches!(err, Error::Format { .. }), "cut at {cut}: {err}");
        }
        std::fs::write(&path, b"DDS plainly not an EXR file at all").unwrap();
        let err = read_exr(&path).unwrap_err().to_string();
        assert!(err.contains("not an OpenEXR file"), "{err}");
        std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
        let err = read_exr(&path).unwrap_err().to_string();
        assert!(err.contains("truncated or damaged"), "{err}");
    }

    #[test]
    fn edited_layout_is_refused() {
        let t = table(vec![Axis::node_aligned("x", 0.0, 1.0, 3).unwrap(); 3], &["v"]);
        let mut image = exr_image(&t, Precision::F32).unwrap();
        let key = utf8_text(DESCRIPTION_ATTRIBUTE);
        let Some(AttributeValue::Text(text)) = image.layer_data.attributes.other.get(&key) else { panic!() };
        let mut description: serde_json::Value = serde_json::from_slice(text.as_slice()).unwrap();
        description["layout"] = serde_json::json!({"tile_width":3,"tile_height":3,"columns":3,"rows":1,"slices":3});
        image.layer_data.attributes.other.insert(key, AttributeValue::Text(utf8_text(&description.to_string())));
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("edited.exr");
        image.write().to_file(&path).unwrap();
        let err = read_exr(&path).unwrap_err().to_string();
        assert!(err.contains("gives the layout"), "{err}");
    }
}
