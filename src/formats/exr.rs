//! Writing OpenEXR images of tables; the reader and the image's layout (the `tmlut` attribute
//! describing the table, the atlas of its slices) are the loader's (`tmlut_loader::formats::exr`),
//! re-exported here.
//!
//! The description travels in one custom attribute rather than several because the exr crate
//! writes custom attributes in hash-map order, which changes from run to run: with several, the
//! same table would not give the same bytes twice. Pixels are stored uncompressed in scan lines:
//! the float values of smooth tables barely compress losslessly, while compression would dominate
//! the time to write a large table (uncompressed, a 4096 × 4096 f32 image writes in about a
//! quarter of a second).

pub use tmlut_loader::formats::exr::*;

use std::path::Path;

use ::exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Encoding, FlatSamples, Image, Layer, LayerAttributes, SmallVec,
    WritableImage, f16,
};

use super::{Precision, check_storable_values, write_atomically};
use crate::error::{Error, Result};
use crate::table::Table;
use layout::{AtlasLayout, DESCRIPTION_ATTRIBUTE, Description, MAX_CHANNEL_NAME_BYTES, to_json, utf8_text};

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::{Axis, Channel, Mapping};

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
    fn the_description_is_stored_in_text_attributes() {
        let axes = vec![Axis::node_aligned("mu", 0.0, 1.0, 64).unwrap(); 3];
        let t = Table::zeros("desc", axes, vec![Channel::new("v", "")]).unwrap();
        let image = exr_image(&t, Precision::F16).unwrap();
        let attributes = &image.layer_data.attributes.other;
        assert_eq!(attributes.len(), 1, "one attribute, so that its order cannot vary");
        let Some(AttributeValue::Text(text)) = attributes.get(&utf8_text(DESCRIPTION_ATTRIBUTE)) else {
            panic!("no `{DESCRIPTION_ATTRIBUTE}` text attribute in {attributes:?}")
        };
        let json: serde_json::Value = serde_json::from_slice(text.as_slice()).unwrap();
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
}
