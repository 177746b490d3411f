//! The tables the format tests write and read back.

use crate::formats::{Precision, StoredTexture};
use crate::table::{Axis, Channel, Table};

/// Channels `c0`, `c1`, ... described as `channel 0`, `channel 1`, ...
pub(crate) fn channel_list(n: usize) -> Vec<Channel> {
    (0..n).map(|c| Channel::new(format!("c{c}"), format!("channel {c}"))).collect()
}

/// A table over `axes` with `channels` channels of values that are not exact in f16, with both
/// signs and a range of magnitudes.
pub(crate) fn sample_table_over(axes: Vec<Axis>, channels: usize) -> Table {
    let len = axes.iter().map(|a| a.count).product::<usize>() * channels;
    let data = (0..len).map(|i| (i as f32 * 0.731).sin() * (1.0 + i as f32 * 0.01)).collect();
    Table::new("sample", axes, channel_list(channels), data).unwrap()
}

/// Write `table(shape, channels)` in every shape, channel count and precision a texture format
/// holds by `write_and_read` (the texture read back, and the table it holds), and check both: the
/// texture's layout, the values rounded to the precision, and f32 exactly.
pub(crate) fn check_texture_round_trips(
    table: impl Fn(&[usize], usize) -> Table,
    mut write_and_read: impl FnMut(&Table, Precision, &str) -> (StoredTexture, Table),
) {
    for shape in [&[5, 3][..], &[4, 3, 6]] {
        for channels in [1, 2, 4] {
            for precision in [Precision::F32, Precision::F16] {
                let table = table(shape, channels);
                let context = format!("{shape:?} {channels} channels {precision:?}");
                let (texture, back) = write_and_read(&table, precision, &context);
                assert_eq!((texture.channels, texture.precision), (channels, precision), "{context}");
                assert_eq!(texture.volume, shape.len() == 3, "{context}");
                assert_eq!((texture.width, texture.height), (shape[0] as u32, shape[1] as u32), "{context}");
                assert_eq!(texture.depth, shape.get(2).map_or(1, |&d| d as u32), "{context}");
                let expected: Vec<f32> = table.data.iter().map(|&v| precision.round(v)).collect();
                assert_eq!(back.data, expected, "{context}");
                assert_eq!((&back.name, &back.axes, &back.channels), (&table.name, &table.axes, &table.channels));
                if precision == Precision::F32 {
                    assert_eq!(back, table, "{context}");
                }
            }
        }
    }
}
