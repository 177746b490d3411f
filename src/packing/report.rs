//! The error a shader really sees, per packing: the emulated shader lookup at random query points
//! (not only nodes) against true 4D multilinear interpolation of the full-precision table, and, at
//! a subset, against the integral itself (per-cell f64 estimates with many samples).

use std::ops::{Add, Mul};

use rayon::prelude::*;

use super::{Filter, PackedFgd, Packing, Program, ProgramBuilder, Texture3D};
use crate::error::Result;
use crate::formats::Precision;
use crate::integrate::Progress;
use crate::recipes::Kernel;
use crate::recipes::fgd::FgdSettings;
use crate::shader::float;
use crate::table::Table;

/// What the report measures.
#[derive(Debug, Clone)]
pub struct ReportSettings {
    /// Random query points, uniform over the table's range.
    pub points: usize,
    /// Of those, how many are also compared with the integral (0: none).
    pub reference_points: usize,
    /// Samples per reference estimate (a power of two).
    pub reference_samples: u64,
    pub seed: u64,
    /// Fractional bits of the hardware filter weight for the "real GPU" column (8 on current GPUs).
    pub weight_bits: u32,
}

impl Default for ReportSettings {
    fn default() -> Self {
        ReportSettings {
            points: 100_000,
            reference_points: 1000,
            reference_samples: 1 << 16,
            seed: 2021,
            weight_bits: 8,
        }
    }
}

/// Mean absolute, RMS and maximum error, and where the maximum is.
#[derive(Debug, Clone, PartialEq)]
pub struct ErrorStats {
    pub count: usize,
    pub mean_abs: f64,
    pub rms: f64,
    pub max: f64,
    /// `(mu, alpha, eta, kappa)` of the largest error.
    pub worst_at: [f64; 4],
}

impl ErrorStats {
    pub fn of(errors: impl IntoIterator<Item = ([f64; 4], f64)>) -> Self {
        let (mut count, mut sum, mut sum2, mut max, mut worst_at) = (0usize, 0.0, 0.0, -1.0f64, [0.0; 4]);
        for (at, e) in errors {
            let e = e.abs();
            count += 1;
            sum += e;
            sum2 += e * e;
            if e > max {
                max = e;
                worst_at = at;
            }
        }
        let n = count.max(1) as f64;
        ErrorStats { count, mean_abs: sum / n, rms: (sum2 / n).sqrt(), max: max.max(0.0), worst_at }
    }
}

/// One packing's figures.
#[derive(Debug, Clone)]
pub struct PackingReport {
    pub name: String,
    pub extent: [usize; 3],
    pub precision: Precision,
    pub bytes: usize,
    pub fetches: usize,
    /// Shader (emulated, exact f32 filter weights) minus 4D multilinear interpolation of the f32 table.
    pub vs_interpolation: ErrorStats,
    /// The same with the filter weights quantised as real hardware does.
    pub vs_interpolation_quantised: ErrorStats,
    /// Shader minus the integral, at the reference subset.
    pub vs_integral: Option<ErrorStats>,
}

/// The report over all requested packings.
#[derive(Debug, Clone)]
pub struct Report {
    pub settings: ReportSettings,
    pub rows: Vec<PackingReport>,
    /// 4D multilinear interpolation of the table minus the integral: the floor no packing beats.
    pub interpolation_vs_integral: Option<ErrorStats>,
    pub table_shape: Vec<usize>,
}

/// Deterministic uniform numbers in [0, 1) (SplitMix64, Steele et al. 2014).
struct SplitMix(u64);
impl SplitMix {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// `count` query points uniform over the table's range, as the f32 values a shader receives.
pub fn random_points(table: &Table, count: usize, seed: u64) -> Vec<[f32; 4]> {
    let mut rng = SplitMix(seed ^ 0x7061_636B);
    (0..count)
        .map(|_| {
            let mut p = [0.0f32; 4];
            for (v, axis) in p.iter_mut().zip(&table.axes) {
                *v = (axis.start + rng.next() * (axis.end - axis.start)) as f32;
            }
            p
        })
        .collect()
}

fn widen(p: [f32; 4]) -> [f64; 4] {
    p.map(|v| v as f64)
}

/// The thesis renderer's shader as shipped (`docs/packing.md`, `thesis`): one trilinear fetch of the thesis
/// texture at `(mu, alpha, (eta / 4 * 2047 + kappa / 4 * 31) / 2047)`, no half-texel correction.
/// Measured beside the packings to separate the shader's error from the packing's.
pub fn thesis_as_shipped(thesis: &PackedFgd) -> Result<Program> {
    let [_, _, eta_axis, kappa_axis] = [0, 1, 2, 3].map(|d| &thesis.source_axes[d]);
    let depth = thesis.texture.depth as f32;
    let halves = (kappa_axis.count / 2) as f32;
    let mut p = ProgramBuilder::new("fgd_thesis_as_shipped", super::FGD_INPUTS.to_vec());
    let x = p.local("x", p.input("mu"));
    let y = p.local("y", p.input("alpha"));
    let eta = p.input("eta").mul(float(1.0 / eta_axis.end as f32)).mul(float(depth - 1.0));
    let kappa = p.input("kappa").mul(float(1.0 / kappa_axis.end as f32)).mul(float(halves - 1.0));
    let z = p.local("z", eta.add(kappa).mul(float(1.0 / (depth - 1.0))));
    let sampled = p.sample("v0", [&x, &y, &z]);
    p.finish(sampled)
}

/// Measure every packing of `table` (the full-precision FGD table built with `fgd`).
pub fn report(
    table: &Table,
    fgd: &FgdSettings,
    packings: &[Packing],
    precision: Precision,
    include_thesis_as_shipped: bool,
    settings: &ReportSettings,
    progress: &dyn Progress,
) -> Result<Report> {
    let points = random_points(table, settings.points, settings.seed);
    let interpolated: Vec<f64> = points.par_iter().map(|&p| table.interpolate(&widen(p))[0]).collect();
    let references: Option<Vec<f64>> = if settings.reference_points > 0 {
        let reference = crate::recipes::reference_points(settings.reference_samples, settings.seed)?;
        let subset = &points[..settings.reference_points.min(points.len())];
        progress.start("integral", subset.len() as u64);
        let values = subset
            .par_iter()
            .map(|&p| {
                let v = fgd.estimate_node(&reference, &widen(p)).mean[0];
                progress.advance(1);
                v
            })
            .collect();
        progress.finish();
        Some(values)
    } else {
        None
    };
    let measure = |name: String, texture: &Texture3D, program: &Program, bytes: usize, precision: Precision| {
        let run = |filter: Filter| -> Vec<f64> {
            points.par_iter().map(|&p| program.evaluate(&p, texture, filter) as f64).collect()
        };
        let exact = run(Filter::Exact);
        let quantised = run(Filter::QuantisedWeights { bits: settings.weight_bits });
        let against = |values: &[f64]| {
            ErrorStats::of(points.iter().zip(values.iter().zip(&interpolated)).map(|(&p, (v, i))| (widen(p), v - i)))
        };
        let vs_integral = references
            .as_ref()
            .map(|r| ErrorStats::of(points.iter().zip(exact.iter().zip(r)).map(|(&p, (v, i))| (widen(p), v - i))));
        PackingReport {
            name,
            extent: [texture.width, texture.height, texture.depth],
            precision,
            bytes,
            fetches: program.fetch_count(),
            vs_interpolation: against(&exact),
            vs_interpolation_quantised: against(&quantised),
            vs_integral,
        }
    };
    let mut rows = Vec::new();
    for &packing in packings {
        let packed = PackedFgd::pack(table, packing, precision)?;
        rows.push(measure(
            packing.name().to_string(),
            &packed.texture,
            &packed.program,
            packed.texel_bytes(),
            precision,
        ));
        if packing == Packing::Thesis && include_thesis_as_shipped {
            let shipped = thesis_as_shipped(&packed)?;
            rows.push(measure(
                "thesis, shader as shipped".into(),
                &packed.texture,
                &shipped,
                packed.texel_bytes(),
                precision,
            ));
        }
    }
    let interpolation_vs_integral = references
        .as_ref()
        .map(|r| ErrorStats::of(points.iter().zip(interpolated.iter().zip(r)).map(|(&p, (v, i))| (widen(p), v - i))));
    Ok(Report { settings: settings.clone(), rows, interpolation_vs_integral, table_shape: table.shape() })
}

fn at(p: [f64; 4]) -> String {
    format!("mu {:.3}, alpha {:.3}, eta {:.3}, kappa {:.3}", p[0], p[1], p[2], p[3])
}

/// The report as Markdown.
pub fn markdown(report: &Report) -> String {
    let s = &report.settings;
    let mut out = format!(
        "FGD table {:?}; {} random query points (seed {}), uniform over the table's range. Errors are absolute (FGD is in [0, 1]).\n\n",
        report.table_shape, s.points, s.seed
    );
    out.push_str("| packing | texture | precision | bytes | fetches | vs 4D interpolation: mean abs | RMS | max | worst at | max with 8-bit weights |\n");
    out.push_str("|---|---|---|---|---|---|---|---|---|---|\n");
    for r in &report.rows {
        let e = &r.vs_interpolation;
        out.push_str(&format!(
            "| {} | {} x {} x {} | {:?} | {} | {} | {:.2e} | {:.2e} | {:.2e} | {} | {:.2e} |\n",
            r.name,
            r.extent[0],
            r.extent[1],
            r.extent[2],
            r.precision,
            r.bytes,
            r.fetches,
            e.mean_abs,
            e.rms,
            e.max,
            at(e.worst_at),
            r.vs_interpolation_quantised.max,
        ));
    }
    if let Some(base) = &report.interpolation_vs_integral {
        out.push_str(&format!(
            "\nAgainst the integral at the first {} points (per-cell f64 estimates, {} samples each):\n\n",
            base.count, s.reference_samples
        ));
        out.push_str("| lookup | mean abs | RMS | max | worst at |\n|---|---|---|---|---|\n");
        out.push_str(&format!(
            "| 4D multilinear interpolation of the table | {:.2e} | {:.2e} | {:.2e} | {} |\n",
            base.mean_abs,
            base.rms,
            base.max,
            at(base.worst_at)
        ));
        for r in &report.rows {
            if let Some(e) = &r.vs_integral {
                out.push_str(&format!(
                    "| {} | {:.2e} | {:.2e} | {:.2e} | {} |\n",
                    r.name,
                    e.mean_abs,
                    e.rms,
                    e.max,
                    at(e.worst_at)
                ));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::{Axis, Channel};

    /// The thesis packing read with the correct coordinates reproduces a multilinear function
    /// (`tmlut_loader`'s packing tests); the shader as shipped does not.
    #[test]
    fn the_thesis_shader_as_shipped_misses_a_multilinear_function() {
        let f = |p: [f64; 4]| 0.1 + 0.2 * p[0] + 0.1 * p[1] * p[2] + 0.05 * p[2] * p[3] + 0.03 * p[3];
        let axes = vec![
            Axis::node_aligned("mu", 0.0, 1.0, 8).unwrap(),
            Axis::node_aligned("alpha", 0.0, 1.0, 8).unwrap(),
            Axis::node_aligned("eta", 0.0, 4.0, 6).unwrap(),
            Axis::node_aligned("kappa", 0.0, 4.0, 10).unwrap(),
        ];
        let mut t = Table::zeros("fgd", axes, vec![Channel::new("fgd", "test")]).unwrap();
        for n in 0..t.node_count() {
            let p = t.node_position(&t.node_index(n));
            t.data[n] = f([p[0], p[1], p[2], p[3]]) as f32;
        }
        let packed = PackedFgd::pack(&t, Packing::Thesis, Precision::F32).unwrap();
        let shipped = thesis_as_shipped(&packed).unwrap();
        let q = [0.37f32, 0.61, 1.3, 2.2];
        let shipped_error =
            (shipped.evaluate(&q, &packed.texture, Filter::Exact) as f64 - f(q.map(|v| v as f64))).abs();
        assert!(shipped_error > 1e-3, "{shipped_error:e}");
    }
}
