//! Error maps: the replicate standard error of every node of a table, as an OpenEXR table at full
//! resolution (same axes, readable by `tmlut inspect` and any EXR viewer) and as PNG heatmaps.
//! The heatmaps are drawn in axis coordinates (cell k of N spans `[k/N, (k+1)/N)`), so that the
//! grazing column `mu = 0` and the smooth row `alpha = 0`, where the field's tables are worst, are
//! the edges of every panel.

use std::path::{Path, PathBuf};

use super::plot::{Line, LineStyle, Panel, heatmaps_png, lines_png, viridis};
use crate::error::Result;
use crate::formats::{Precision, exr::write_exr};
use crate::recipes::TableBuild;
use crate::table::{Axis, Channel, Table};

/// The standard-error table of a build, if the build computed one for every node.
pub fn error_table(build: &TableBuild) -> Option<Table> {
    let errors = build.provenance.standard_error.as_ref()?;
    let channels = build
        .table
        .channels
        .iter()
        .map(|c| Channel::new(c.name.clone(), format!("replicate standard error of `{}`", c.name)))
        .collect();
    Table::new(format!("{}_error", build.table.name), build.table.axes.clone(), channels, errors.clone()).ok()
}

/// Write `<table>_error.exr` and `<table>_error.png` into `dir`; nothing when the build has no
/// per-node error.
pub fn write_error_maps(dir: &Path, build: &TableBuild) -> Result<Vec<PathBuf>> {
    let Some(table) = error_table(build) else { return Ok(Vec::new()) };
    let exr = dir.join(format!("{}.exr", table.name));
    write_exr(&exr, &table, Precision::F32)?;
    let png = dir.join(format!("{}.png", table.name));
    let mut title = format!(
        "{}: replicate standard error ({} samples per cell, {} replicates)",
        build.table.name, build.provenance.sampling.samples_per_cell, build.provenance.sampling.replicates
    );
    if table.dimension() == 1 {
        // A table of one axis (an average over the other, as E_avg) has no plane to colour: its
        // error reads as a line per channel.
        error_lines_png(&png, &title, &table)?;
        return Ok(vec![exr, png]);
    }
    let (panels, columns) = panels(&table);
    if panels.len() > 16 {
        let (ax, ay) = (&table.axes[0], &table.axes[1]);
        title.push_str(&format!("; each panel: x = {}, y = {}", axis_label(ax), axis_label(ay)));
    }
    heatmaps_png(&png, &title, "standard error", &panels, columns)?;
    Ok(vec![exr, png])
}

/// The standard error of a one-axis table against its axis, a line per channel.
fn error_lines_png(path: &Path, title: &str, table: &Table) -> Result<()> {
    let axis = &table.axes[0];
    let channels = table.channels.len();
    let lines: Vec<Line> = (0..channels)
        .map(|c| Line {
            name: table.channels[c].name.clone(),
            points: (0..axis.count).map(|k| (axis.node_value(k), table.node(&[k])[c] as f64)).collect(),
            colour: viridis(c as f64 / channels.max(2).saturating_sub(1) as f64),
            style: LineStyle::Solid,
        })
        .collect();
    let largest = table.data.iter().copied().filter(|v| v.is_finite()).fold(0.0f32, f32::max) as f64;
    // A range of some height where every error is 0 (a table whose nodes are exact).
    let top = if largest > 0.0 { largest * 1.1 } else { 1.0 };
    let (low, high) = (axis.start.min(axis.end), axis.start.max(axis.end));
    lines_png(path, title, (&axis_label(axis), low..high), ("standard error", 0.0..top), &lines)
}

/// How an axis reads on a plot: its quantity, direction and spacing.
pub(crate) fn axis_label(axis: &Axis) -> String {
    let spacing = match axis.mapping {
        crate::table::Mapping::Identity => String::new(),
        mapping => format!(", spaced in {}", mapping.formula(&axis.name)),
    };
    format!("{} ({} to {}{spacing})", axis.name, axis.start, axis.end)
}

/// Up to `count` node indices spread evenly over an axis, first and last included.
fn spread_nodes(axis: &Axis, count: usize) -> Vec<usize> {
    let n = axis.count;
    let count = count.min(n).max(1);
    if count == 1 {
        return vec![0];
    }
    let mut nodes: Vec<usize> = (0..count).map(|i| (i * (n - 1) + (count - 1) / 2) / (count - 1)).collect();
    nodes.dedup();
    nodes
}

/// The heatmap panels of a table and the number of columns to lay them out in: a 2D table gives one
/// panel per channel; a 3D table eight slices along axis 2; a 4D table an 8 x 8 grid over axes 2
/// and 3 (first channel).
fn panels(table: &Table) -> (Vec<Panel>, usize) {
    let (ax, ay) = (&table.axes[0], &table.axes[1]);
    let slice = |fixed: &[usize], channel: usize, title: String| {
        let mut values = Vec::with_capacity(ax.count * ay.count);
        for j in 0..ay.count {
            for i in 0..ax.count {
                let mut index = vec![i, j];
                index.extend_from_slice(fixed);
                values.push(table.node(&index)[channel] as f64);
            }
        }
        Panel {
            title,
            x: (axis_label(ax), 0.0, 1.0),
            y: (axis_label(ay), 0.0, 1.0),
            nx: ax.count,
            ny: ay.count,
            values,
        }
    };
    let value_of = |axis: &Axis, k: usize| format!("{} {:.3}", axis.name, axis.node_value(k));
    match table.dimension() {
        2 => {
            let panels: Vec<Panel> =
                table.channels.iter().enumerate().map(|(c, ch)| slice(&[], c, ch.name.clone())).collect();
            let columns = panels.len().min(4);
            (panels, columns)
        }
        3 => {
            let az = &table.axes[2];
            let panels: Vec<Panel> = spread_nodes(az, 8).into_iter().map(|k| slice(&[k], 0, value_of(az, k))).collect();
            (panels, 4)
        }
        _ => {
            let (a2, a3) = (&table.axes[2], &table.axes[3]);
            let (n2, n3) = (spread_nodes(a2, 8), spread_nodes(a3, 8));
            let columns = n2.len();
            let mut panels = Vec::new();
            for &q in n3.iter().rev() {
                for &e in &n2 {
                    panels.push(slice(&[e, q], 0, format!("{}, {}", value_of(a2, e), value_of(a3, q))));
                }
            }
            (panels, columns)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_nodes_include_both_ends() {
        let axis = Axis::node_aligned("eta", 0.0, 4.0, 64).unwrap();
        let nodes = spread_nodes(&axis, 8);
        assert_eq!(nodes.len(), 8);
        assert_eq!((nodes[0], nodes[7]), (0, 63));
        assert_eq!(spread_nodes(&Axis::node_aligned("x", 0.0, 1.0, 3).unwrap(), 8), vec![0, 1, 2]);
    }

    #[test]
    fn maps_of_a_small_build_are_written_and_read_back() {
        use crate::config::{ReferenceConfig, SamplingConfig};
        use crate::recipes::gd::GdSettings;
        use crate::recipes::interpolation::InterpolationConfig;
        use crate::recipes::settings::SharedSettings;
        use crate::recipes::tir::TirSettings;
        let unchecked = |shared: SharedSettings| SharedSettings {
            reference: ReferenceConfig { cells: 0, nodes: 8 },
            interpolation: InterpolationConfig { points: 0, nodes: 6 },
            ..shared
        };
        let settings = GdSettings {
            mu_count: 6,
            alpha_count: 5,
            shared: SharedSettings {
                sampling: SamplingConfig::replicated(1024),
                ..unchecked(GdSettings::default().shared)
            },
            ..GdSettings::default()
        };
        let build = crate::recipes::driver::build(&settings, 1, &()).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let written = write_error_maps(dir.path(), &build).unwrap();
        assert_eq!(written.len(), 2);
        let map = crate::formats::exr::read_exr(&written[0]).unwrap();
        assert_eq!(map.name, "gd_error");
        assert_eq!(map.axes, build.table.axes);
        assert_eq!(&map.data, build.provenance.standard_error.as_ref().unwrap());
        assert!(map.data.iter().any(|&s| s > 0.0) && map.data.iter().all(|s| s.is_finite() && *s >= 0.0));
        assert!(image::open(&written[1]).unwrap().width() > 0);
        // A table integrated without random points has no replicate spread to map.
        let tir = TirSettings {
            mu_count: 6,
            alpha_count: 5,
            eta_count: 9,
            shared: unchecked(TirSettings::default().shared),
            ..TirSettings::default()
        };
        let build = crate::recipes::driver::build(&tir, 1, &()).unwrap();
        assert!(write_error_maps(dir.path(), &build).unwrap().is_empty());
    }

    /// A table of one axis (E_avg over alpha) maps its error as lines, not as a plane.
    #[test]
    fn a_one_axis_table_maps_its_error_as_a_line() {
        use crate::config::{ReferenceConfig, SamplingConfig};
        use crate::recipes::ggx_e_avg::GgxEAvgSettings;
        use crate::recipes::interpolation::InterpolationConfig;
        use crate::recipes::settings::SharedSettings;
        let defaults = GgxEAvgSettings::default();
        let settings = GgxEAvgSettings {
            alpha_count: 6,
            shared: SharedSettings {
                sampling: SamplingConfig::replicated(1024),
                reference: ReferenceConfig { cells: 0, nodes: 8 },
                interpolation: InterpolationConfig { points: 0, nodes: 6 },
                ..defaults.shared.clone()
            },
            ..defaults
        };
        let build = crate::recipes::driver::build(&settings, 1, &()).unwrap();
        assert_eq!(build.table.dimension(), 1);
        let dir = tempfile::tempdir().unwrap();
        let written = write_error_maps(dir.path(), &build).unwrap();
        assert_eq!(written.len(), 2);
        let map = crate::formats::exr::read_exr(&written[0]).unwrap();
        assert_eq!(&map.data, build.provenance.standard_error.as_ref().unwrap());
        assert!(map.data.iter().any(|&s| s > 0.0), "{:?}", map.data);
        assert!(image::open(&written[1]).unwrap().width() > 0);
    }
}
