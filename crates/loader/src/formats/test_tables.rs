//! The tables the format tests write and read back.

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
