//! The two pictures of a fit (`tmlut fit --form`): `error_map.png`, the absolute error of the
//! fitted form over the first two axes of the table, and `residuals.png`, the histogram of every
//! residual. Both are drawn with [`crate::report::plot`] (the error map with the heatmap of
//! `tmlut build --error-maps`) into the staging folder of the fit's file set.

use std::path::Path;

use super::data::FormData;
use super::figures::ErrorsByChannel;
use crate::error::Result;
use crate::report::error_map::axis_label;
use crate::report::plot::{Panel, heatmaps_png, histogram_png};
use crate::table::Table;

pub const ERROR_MAP_FILE: &str = "error_map.png";
pub const RESIDUALS_FILE: &str = "residuals.png";
/// Bins of the residual histogram.
pub const HISTOGRAM_BINS: usize = 80;

/// `bins` equal bins over `[min, max]` of `values` (widened when all are equal) and how many
/// values fall in each; the last bin holds the max. Every value is counted once.
pub fn histogram(values: &[f64], bins: usize) -> ((f64, f64), Vec<usize>) {
    let bins = bins.max(1);
    let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (lo, hi) = if !lo.is_finite() || !hi.is_finite() {
        (-1.0, 1.0)
    } else if hi > lo {
        (lo, hi)
    } else {
        let half = (lo.abs() * 1e-3).max(1e-12);
        (lo - half, hi + half)
    };
    let width = (hi - lo) / bins as f64;
    let mut counts = vec![0usize; bins];
    for &v in values {
        let k = ((v - lo) / width).floor();
        let k = if k.is_finite() { (k.max(0.0) as usize).min(bins - 1) } else { 0 };
        counts[k] += 1;
    }
    ((lo, hi), counts)
}

/// The error map's panel: `|form - table|` of `channel` (index into the data's channels) at each
/// node of the table's first two axes, the max over the other axes (a table of one axis gives one
/// row). Where the data is a uniform grid over the form's variables (a table with a derived axis),
/// the map is over the form's first two variables on that grid instead. Cells with no point in the
/// fit's ranges are NaN, drawn apart from exact ones (0, grey): the form was not fitted there.
pub fn error_panel(table: &Table, data: &FormData, residuals: &[f64], channel: usize) -> Panel {
    let channels = data.channels.len().max(1);
    let (x, y, nx, ny) = if data.on_table_nodes {
        let ax = &table.axes[0];
        let y = table.axes.get(1);
        (axis_label(ax), y.map_or_else(|| "(one axis)".to_string(), axis_label), ax.count, y.map_or(1, |a| a.count))
    } else {
        let n = crate::fit::FIT_GRID_NODES;
        let label = |v: &String| {
            let (lo, hi) = super::region::variable_range(table, v);
            format!("{v} ({lo} to {hi}, uniform grid)")
        };
        let y = data.variables.get(1);
        (
            label(&data.variables[0]),
            y.map_or_else(|| "(one variable)".to_string(), label),
            n,
            if y.is_some() { n } else { 1 },
        )
    };
    let mut values = vec![f64::NAN; nx * ny];
    for n in 0..data.len() {
        // The point's place among all the table's nodes (or grid points): a range keeps some.
        let number = data.index[n];
        let (i, j) = if data.on_table_nodes {
            let index = table.node_index(number);
            (index[0], index.get(1).copied().unwrap_or(0))
        } else {
            (number % nx, (number / nx) % ny)
        };
        let e = residuals[n * channels + channel].abs();
        let cell = &mut values[i + nx * j];
        // `max` takes the number over a cell's NaN: the first point of a cell sets it.
        *cell = cell.max(e);
    }
    Panel { title: format!("channel `{}`", data.channels[channel]), x: (x, 0.0, 1.0), y: (y, 0.0, 1.0), nx, ny, values }
}

/// Write both pictures into `dir`: `residuals` point-major, one per channel (form minus table, the
/// form in f32 at the fitted parameters), `figures` their summary.
pub fn write_pictures(
    dir: &Path,
    form: &str,
    table: &Table,
    data: &FormData,
    residuals: &[f64],
    figures: &ErrorsByChannel,
) -> Result<()> {
    // The channel of the largest error.
    let channel =
        figures.together.max_channel.as_ref().and_then(|c| data.channels.iter().position(|d| d == c)).unwrap_or(0);
    let mut panel = error_panel(table, data, residuals, channel);
    let others: Vec<&str> = if data.on_table_nodes {
        table.axes.iter().skip(2).map(|a| a.name.as_str()).collect()
    } else {
        data.variables.iter().skip(2).map(String::as_str).collect()
    };
    panel.title = format!("|form - table| of `{}`", data.channels[channel]);
    if !others.is_empty() {
        panel.title.push_str(&format!(", max over {}", others.join(", ")));
    }
    let title = format!("form `{form}`, table `{}`", table.name);
    heatmaps_png(&dir.join(ERROR_MAP_FILE), &title, "|form - table|", &[panel], 1)?;

    let ((lo, hi), counts) = histogram(residuals, HISTOGRAM_BINS);
    let f = &figures.together;
    // Log counts where the tails would be invisible beside the peak.
    let smallest = counts.iter().copied().filter(|&c| c > 0).min().unwrap_or(1);
    let log_counts = counts.iter().copied().max().unwrap_or(0) > 50 * smallest;
    let title = format!(
        "form `{form}` on table `{}`: {} residuals (form - table); RMS {:.3e}, p99 |r| {:.3e}, max |r| {:.3e}",
        table.name,
        residuals.len(),
        f.rms,
        f.p99,
        f.max
    );
    let marks = [("±RMS".to_string(), [200, 120, 0]), ("±p99 |r|".to_string(), [200, 30, 30])];
    let mut lines = Vec::new();
    for ((name, colour), value) in marks.iter().zip([f.rms, f.p99]) {
        for (k, x) in [value, -value].into_iter().enumerate() {
            if x >= lo && x <= hi {
                // One legend entry per pair.
                lines.push((if k == 0 { name.clone() } else { String::new() }, x, *colour));
            }
        }
    }
    histogram_png(&dir.join(RESIDUALS_FILE), &title, "form - table", (lo, hi), &counts, log_counts, &lines)
}
