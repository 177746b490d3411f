//! `tmlut audit`: a table an engine ships, measured against exact integrals at the texels of the
//! engine's own layout (`docs/engines.md`, "Audit").
//!
//! The preset says what the file is: its table (three.js's `DFGLUTData.js` holds the Karis split
//! sum), shape, axes (placement, roughness axis, orientation) and masking model. The file is read
//! in the preset's drop-in format, or as a DDS, KTX2 or OpenEXR table of the preset's shape (tmlut's
//! own layout: `n.v` along x). Every texel's exact value comes from the deterministic visible-normal
//! quadrature ([`VisibleNormalQuadrature`]) at the preset's node positions, with the variance of
//! one visible-normal sample beside it ([`causes`] fits noise with it); once per masking model, so
//! that a file integrated with the other one is recognised. Per channel the report gives the RMS,
//! 99th percentile and largest |error| and where, the non-finite values the file holds (a finding,
//! left out of the figures), and the causes [`causes::recognise`] finds.

pub mod causes;

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;

use crate::error::{Error, Result};
use crate::formats::FileFormat;
use crate::integrate::Progress;
use crate::integrate::quadrature::VisibleNormalQuadrature;
use crate::physics::MaskingShadowing;
use crate::presets::Preset;
use crate::recipes::karis;
use crate::table::{Table, TableKind};
use causes::{Evidence, ExactTable, Findings, Grid};

/// The non-finite values listed by place; the count covers them all.
const NON_FINITE_LISTED: usize = 16;

/// The report of one audit: every number a number (never NaN or infinity), so that its JSON reads
/// anywhere.
#[derive(Debug, Clone, Serialize)]
pub struct Audit {
    pub file: String,
    pub preset: String,
    pub engine: String,
    /// What the file was read as: the preset's engine file, or DDS, KTX2 or OpenEXR.
    pub read_as: String,
    pub table: String,
    /// Texels along `n.v` and roughness, and channels.
    pub shape: [usize; 3],
    /// The file's values are all half floats.
    pub half_float: bool,
    /// The conventions the exact values are integrated with.
    pub exact: ExactConventions,
    pub channels: Vec<ChannelError>,
    pub non_finite: NonFinite,
    /// The causes recognised, in words; empty where none is.
    pub causes: Vec<causes::Cause>,
    /// The figures of every test behind the causes.
    pub tests: Findings,
    /// Wall time of the audit (reading, integrating, testing), seconds.
    pub seconds: f64,
    /// |file - exact| per value in the table's order, NaN where the file's value is not finite:
    /// the heat maps' values.
    #[serde(skip)]
    pub errors: Vec<f64>,
    /// The table's axes, for the heat maps.
    #[serde(skip)]
    pub axes: Vec<crate::table::Axis>,
}

/// How the exact values are computed.
#[derive(Debug, Clone, Serialize)]
pub struct ExactConventions {
    pub integral: String,
    pub masking: String,
    pub quadrature_nodes_per_panel: usize,
    /// The preset's layout, as the manifest states it.
    pub layout: Vec<String>,
}

/// One channel's error against the exact table as the preset states it.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelError {
    pub channel: String,
    /// Finite values measured.
    pub values: usize,
    pub rms: f64,
    pub p99: f64,
    pub max: f64,
    /// Where the largest |error| is (none where no value is finite).
    pub max_at: Option<Texel>,
}

/// A texel: its indices along `n.v` and roughness and the values there, with the file's value and
/// the exact one.
#[derive(Debug, Clone, Serialize)]
pub struct Texel {
    pub n_dot_v_index: usize,
    pub roughness_index: usize,
    pub n_dot_v: f64,
    /// Perceptual roughness, `sqrt(alpha)`.
    pub roughness: f64,
    pub alpha: f64,
    pub exact: f64,
    /// The file's value, where finite.
    pub file: Option<f64>,
}

/// NaN and infinity in the file.
#[derive(Debug, Clone, Serialize)]
pub struct NonFinite {
    pub count: usize,
    /// Up to [`NON_FINITE_LISTED`] of them: the texel and channel, and `NaN`, `+inf` or `-inf`.
    pub at: Vec<NonFiniteValue>,
}

#[derive(Debug, Clone, Serialize)]
pub struct NonFiniteValue {
    pub texel: Texel,
    pub channel: String,
    pub value: String,
}

/// The table a shipped file holds, on the preset's axes, and what it was read as.
pub struct Shipped {
    pub table: Table,
    pub read_as: String,
}

/// Read `path` with `preset`'s conventions: a DDS, KTX2 or OpenEXR file (by its magic number) of
/// the preset's shape, or else the preset's engine file.
pub fn read_shipped(path: &Path, preset: &Preset) -> Result<Shipped> {
    let (kind, _) = preset.audited_table()?;
    let template = preset.config.recipe(kind).empty_table()?;
    let format = match crate::loader::format_of(path) {
        Ok(format) => Some(format),
        Err(Error::Format { .. }) => None,
        Err(e) => return Err(e),
    };
    let Some(format) = format else {
        let table = preset.read_drop_in(path)?;
        let (_, format) = preset.audited_table()?;
        return Ok(Shipped { table, read_as: format!("{}'s {}", preset.section.engine, format.file_name()) });
    };
    let bytes = crate::formats::read_bytes(path)?;
    let (shape, channels, data) = match format {
        FileFormat::Dds => {
            let texture = crate::formats::dds::decode_dds(&bytes, path)?;
            let shape = vec![texture.width as usize, texture.height as usize, texture.depth as usize];
            (shape, texture.channels, texture.data)
        }
        FileFormat::Ktx2 => {
            let texture = crate::formats::ktx2::decode_ktx2(&bytes, path)?.texture;
            let shape = vec![texture.width as usize, texture.height as usize, texture.depth as usize];
            (shape, texture.channels, texture.data)
        }
        FileFormat::Exr => {
            let table = crate::formats::exr::decode_exr(&bytes, path)?;
            (table.shape(), table.channel_count(), table.data)
        }
        FileFormat::Bin => {
            return Err(Error::format(
                path,
                "a `.bin` table is tmlut's transfer-matrix layout, not one an engine ships; audit reads the preset's \
                 engine file, DDS, KTX2 or OpenEXR",
            ));
        }
    };
    let expected: Vec<usize> = template.shape();
    let shape_of_table: Vec<usize> = shape.iter().copied().filter(|&n| n != 1).collect();
    if shape_of_table != expected || channels != template.channel_count() {
        return Err(Error::format(
            path,
            format!(
                "a {} table of {} channel(s); preset `{}` expects {} x {} texels (n.v along x, roughness along y) of {} \
                 channels ({})",
                shape.iter().map(ToString::to_string).collect::<Vec<_>>().join(" x "),
                channels,
                preset.name,
                expected[0],
                expected[1],
                template.channel_count(),
                template.channels.iter().map(|c| c.name.as_str()).collect::<Vec<_>>().join(", ")
            ),
        ));
    }
    let table = Table::new(template.name.clone(), template.axes.clone(), template.channels.clone(), data)?;
    Ok(Shipped { table, read_as: format!("{} in tmlut's layout (n.v along x)", format_name(format)) })
}

/// The exact table of `kind` on `axes` under `masking`, value by value with the variance of one
/// visible-normal sample.
fn exact_table(
    kind: TableKind,
    table: &Table,
    masking: MaskingShadowing,
    quadrature: &VisibleNormalQuadrature,
    progress: &dyn Progress,
) -> Result<ExactTable> {
    if kind != TableKind::Karis {
        return Err(Error::invalid(
            "--preset",
            format!("audit integrates the `karis` table; the preset's engine file holds `{}`", kind.name()),
        ));
    }
    let cells: Vec<u64> = (0..table.node_count() as u64).collect();
    let label = format!("exact, {}", masking.name());
    let moments = crate::integrate::estimate_cells(&cells, &label, progress, |cell| {
        let position = table.node_position(&table.node_index(cell as usize));
        karis::exact_with_second_moments(quadrature, masking, position[0], position[1])
    });
    let mean = moments.iter().flat_map(|(mean, _)| *mean).collect();
    let variance = moments
        .iter()
        .flat_map(|(mean, second)| {
            std::array::from_fn::<f64, { karis::CHANNEL_COUNT }, _>(|c| second[c] - mean[c] * mean[c])
        })
        .collect();
    Ok(ExactTable { masking: masking.name(), mean, variance })
}

/// Audit `path` with `preset`.
pub fn audit(path: &Path, preset: &Preset, progress: &dyn Progress) -> Result<Audit> {
    let started = Instant::now();
    let (kind, _) = preset.audited_table()?;
    let shipped = read_shipped(path, preset)?;
    let table = &shipped.table;
    let recipe = preset.config.recipe(kind);
    let masking = preset.config.karis.masking;
    let nodes = recipe.reference().nodes;
    let quadrature = VisibleNormalQuadrature::new(nodes)?;
    let exact = exact_table(kind, table, masking, &quadrature, progress)?;
    let other_masking = MaskingShadowing::ALL
        .into_iter()
        .filter(|&m| m != masking)
        .map(|m| exact_table(kind, table, m, &quadrature, progress))
        .collect::<Result<Vec<_>>>()?;

    let file: Vec<f64> = table.data.iter().map(|&v| if v.is_finite() { v as f64 } else { f64::NAN }).collect();
    let half_float = table.data.iter().all(|&v| !v.is_finite() || half::f16::from_f32(v).to_f32() == v);
    let grid = Grid { nx: table.axes[0].count, ny: table.axes[1].count, channels: table.channel_count() };
    let findings = causes::recognise(&Evidence {
        grid,
        file: &file,
        half_float,
        preset: &exact,
        other_masking: &other_masking,
        axis_names: ["n.v", "roughness"],
    });

    let texel = |node: usize, channel: usize| {
        let index = table.node_index(node);
        let position = table.node_position(&index);
        let value = table.data[node * grid.channels + channel];
        Texel {
            n_dot_v_index: index[0],
            roughness_index: index[1],
            n_dot_v: position[0],
            roughness: position[1].sqrt(),
            alpha: position[1],
            exact: exact.mean[node * grid.channels + channel],
            file: value.is_finite().then_some(value as f64),
        }
    };
    let channels = table
        .channels
        .iter()
        .enumerate()
        .map(|(c, channel)| {
            let errors: Vec<(usize, f64)> = (0..table.node_count())
                .filter_map(|node| {
                    let k = node * grid.channels + c;
                    file[k].is_finite().then(|| (node, (file[k] - exact.mean[k]).abs()))
                })
                .collect();
            let magnitudes: Vec<f64> = errors.iter().map(|&(_, e)| e).collect();
            let worst = errors.iter().max_by(|a, b| a.1.total_cmp(&b.1));
            let count = magnitudes.len();
            ChannelError {
                channel: channel.name.clone(),
                values: count,
                rms: if count > 0 {
                    (magnitudes.iter().map(|e| e * e).sum::<f64>() / count as f64).sqrt()
                } else {
                    0.0
                },
                p99: crate::stats::quantile(&magnitudes, 0.99),
                max: worst.map_or(0.0, |w| w.1),
                max_at: worst.map(|&(node, _)| texel(node, c)),
            }
        })
        .collect();
    let non_finite_values: Vec<(usize, usize, f32)> = table
        .data
        .iter()
        .enumerate()
        .filter(|(_, v)| !v.is_finite())
        .map(|(k, &v)| (k / grid.channels, k % grid.channels, v))
        .collect();
    let non_finite = NonFinite {
        count: non_finite_values.len(),
        at: non_finite_values
            .iter()
            .take(NON_FINITE_LISTED)
            .map(|&(node, c, v)| NonFiniteValue {
                texel: texel(node, c),
                channel: table.channels[c].name.clone(),
                value: if v.is_nan() {
                    "NaN".into()
                } else if v > 0.0 {
                    "+inf".into()
                } else {
                    "-inf".into()
                },
            })
            .collect(),
    };
    let layout = recipe.metadata().notes;
    Ok(Audit {
        file: path.display().to_string(),
        preset: preset.name.clone(),
        engine: preset.section.engine.clone(),
        read_as: shipped.read_as,
        table: kind.name().to_string(),
        shape: [grid.nx, grid.ny, grid.channels],
        half_float,
        exact: ExactConventions {
            integral: recipe.metadata().integrand,
            masking: masking.name().to_string(),
            quadrature_nodes_per_panel: nodes,
            layout,
        },
        channels,
        non_finite,
        causes: findings.causes.clone(),
        tests: findings,
        seconds: started.elapsed().as_secs_f64(),
        errors: file.iter().zip(&exact.mean).map(|(f, e)| (f - e).abs()).collect(),
        axes: table.axes.clone(),
    })
}

impl Audit {
    /// The largest |error| of any channel; infinite where the file holds a non-finite value.
    pub fn largest_error(&self) -> f64 {
        if self.non_finite.count > 0 {
            return f64::INFINITY;
        }
        self.channels.iter().map(|c| c.max).fold(0.0, f64::max)
    }

    /// The report as JSON, with the status (`measured`, or `over-budget` against `budget`).
    pub fn to_json(&self, budget: Option<f64>) -> String {
        let over = budget.is_some_and(|b| self.largest_error() > b);
        let report = serde_json::json!({
            "status": if over { "over-budget" } else { "measured" },
            "budget": budget,
            "audit": self,
        });
        serde_json::to_string_pretty(&report).expect("an audit's numbers are finite") + "\n"
    }

    /// The report as lines a person reads.
    pub fn render(&self) -> String {
        let mut out = format!(
            "{}: {} ({}), {} x {} texels of {} (n.v x roughness), read as {}; exact: {} masking, {} quadrature nodes per \
             panel\n",
            self.file,
            self.preset,
            self.engine,
            self.shape[0],
            self.shape[1],
            self.table,
            self.read_as,
            self.exact.masking,
            self.exact.quadrature_nodes_per_panel
        );
        for c in &self.channels {
            out.push_str(&format!("  {:<6} rms {:.3e}  p99 {:.3e}  max {:.3e}", c.channel, c.rms, c.p99, c.max));
            if let Some(at) = &c.max_at {
                out.push_str(&format!(
                    " at texel (n.v {}, roughness {}) = (n.v {:.5}, roughness {:.5}): file {}, exact {:.6}",
                    at.n_dot_v_index,
                    at.roughness_index,
                    at.n_dot_v,
                    at.roughness,
                    at.file.map_or("non-finite".to_string(), |v| format!("{v:.6}")),
                    at.exact
                ));
            }
            out.push('\n');
        }
        if self.non_finite.count > 0 {
            let listed: Vec<String> = self
                .non_finite
                .at
                .iter()
                .map(|v| {
                    format!(
                        "{} at (n.v {}, roughness {}) {}",
                        v.value, v.texel.n_dot_v_index, v.texel.roughness_index, v.channel
                    )
                })
                .collect();
            out.push_str(&format!(
                "  finding: {} non-finite value(s), left out of the figures: {}{}\n",
                self.non_finite.count,
                listed.join("; "),
                if self.non_finite.count > listed.len() { "; ..." } else { "" }
            ));
        }
        if self.causes.is_empty() {
            out.push_str("  cause: none recognised\n");
        }
        for cause in &self.causes {
            out.push_str(&format!("  cause: {}\n", cause.text));
        }
        out.push_str(&format!("  audited in {:.2} s\n", self.seconds));
        out
    }

    /// Write `audit.json` and a heat map of |error| per channel (`audit_<channel>.png`) into
    /// `dir` (made if missing), each through a temporary file renamed into place; nothing
    /// elsewhere. Returns the paths written.
    pub fn write(&self, dir: &Path, budget: Option<f64>) -> Result<Vec<PathBuf>> {
        std::fs::create_dir_all(dir).map_err(|source| Error::io(dir, source))?;
        let mut written = Vec::new();
        let json = dir.join("audit.json");
        crate::formats::write_bytes_atomically(&json, self.to_json(budget).as_bytes())?;
        written.push(json);
        let (ax, ay) = (&self.axes[0], &self.axes[1]);
        for (c, channel) in self.channels.iter().enumerate() {
            let values = self.errors.iter().skip(c).step_by(self.shape[2]).copied().collect();
            let panel = crate::report::plot::Panel {
                title: format!("{} (rms {:.2e}, max {:.2e})", channel.channel, channel.rms, channel.max),
                x: (crate::report::error_map::axis_label(ax), 0.0, 1.0),
                y: (crate::report::error_map::axis_label(ay), 0.0, 1.0),
                nx: ax.count,
                ny: ay.count,
                values,
            };
            let png = dir.join(format!("audit_{}.png", channel.channel));
            let title =
                format!("{}: |file - exact| of `{}` ({} preset)", file_name(&self.file), channel.channel, self.preset);
            crate::report::plot::heatmaps_png(&png, &title, "|error|", &[panel], 1)?;
            written.push(png);
        }
        Ok(written)
    }
}

fn format_name(format: FileFormat) -> &'static str {
    match format {
        FileFormat::Dds => "DDS",
        FileFormat::Ktx2 => "KTX2",
        FileFormat::Exr => "OpenEXR",
        FileFormat::Bin => ".bin",
    }
}

fn file_name(path: &str) -> String {
    Path::new(path).file_name().map_or_else(|| path.to_string(), |n| n.to_string_lossy().into_owned())
}

#[cfg(test)]
mod tests;
