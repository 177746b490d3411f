//! The settings every table shares (its samples, its reference and interpolation checks, its
//! output files), the `mu` and `alpha` axes that a scene's plan may narrow, and the checks of node
//! counts and ranges that every table's validation uses.

use serde::{Deserialize, Serialize};

use super::interpolation::InterpolationConfig;
use super::spacing::{CosineAxis, RoughnessAxis};
use crate::error::{Error, Result};
use crate::formats::{FileFormat, Precision};
use crate::table::Axis;

/// Nodes per axis above which a table would not fit a GPU texture dimension (Direct3D 12 allows
/// 16384 for 2D textures, 2048 for volumes) nor memory.
pub const MAX_NODES_PER_AXIS: usize = 16384;

/// The keys every table has: its samples, its reference check, its interpolation check and its
/// files. Each table's settings flatten it in, so that its keys sit in the table's own section
/// (`[gd.sampling]`, not `[gd.shared.sampling]`) and serialise where the field stands among the
/// table's keys (the scene cache's keys hash that text). serde names neither the whole path of a
/// value refused below a flattened field nor the section of an unknown key; `Config::from_toml`
/// names both.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SharedSettings {
    pub sampling: SamplingConfig,
    pub reference: ReferenceConfig,
    /// The check between nodes: random points against the exact integral.
    pub interpolation: InterpolationConfig,
    pub output: OutputConfig,
}

/// The values each table's defaults start from, stating what differs. Also what a table's settings
/// read on their own take for a shared key they lack; `Config::from_toml` lays a file over the
/// table's own defaults instead.
impl Default for SharedSettings {
    fn default() -> Self {
        SharedSettings {
            sampling: SamplingConfig::replicated(1 << 16),
            reference: ReferenceConfig::default(),
            interpolation: InterpolationConfig::default(),
            output: OutputConfig { formats: vec![FileFormat::Dds], precision: Precision::F32 },
        }
    }
}

impl SharedSettings {
    /// Check the keys every table has; `table` names the section in errors, `formats` are the file
    /// formats that can hold the table.
    pub fn validate(&self, table: &str, formats: &[FileFormat]) -> Result<()> {
        self.sampling.validate(&format!("{table}.sampling"))?;
        self.reference.validate(&format!("{table}.reference"))?;
        self.interpolation.validate(&format!("{table}.interpolation"))?;
        self.output.validate(&format!("{table}.output"), formats)
    }
}

/// The `mu` and `alpha` axes of a table that a scene's plan may narrow to what its lookups reach:
/// their sub-ranges and spacings. Flattened into the table's settings, as [`SharedSettings`] is.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MuAlphaAxes {
    pub mu_range: [f64; 2],
    pub alpha_range: [f64; 2],
    /// How the `mu` nodes are spaced.
    pub mu_axis: CosineAxis,
    /// How the `alpha` nodes are spaced.
    pub roughness_axis: RoughnessAxis,
}

/// The whole unit square, dense at both ends of `mu` and at low roughness.
impl Default for MuAlphaAxes {
    fn default() -> Self {
        MuAlphaAxes {
            mu_range: [0.0, 1.0],
            alpha_range: [0.0, 1.0],
            mu_axis: CosineAxis::SqrtEnds,
            roughness_axis: RoughnessAxis::Perceptual,
        }
    }
}

impl MuAlphaAxes {
    /// Check the sub-ranges of `mu` and `alpha`; `table` names the section in errors.
    pub fn validate(&self, table: &str) -> Result<()> {
        check_unit_range(&format!("{table}.mu_range"), self.mu_range)?;
        check_unit_range(&format!("{table}.alpha_range"), self.alpha_range)
    }

    /// The `mu` and `alpha` axes of `counts` nodes over their sub-ranges, spaced as set.
    pub fn axes(&self, counts: [usize; 2]) -> Result<[Axis; 2]> {
        super::spacing::mu_alpha_axes(counts, [self.mu_range, self.alpha_range], self.mu_axis, self.roughness_axis)
    }
}

/// Which builds make a table that is not part of the default set (an engine's table, which a
/// preset or a user asks for by name): a build that names its tables (`--only`) makes those named,
/// whatever this says; a build that names none makes every table whose `build` is `always`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BuildWhen {
    /// Only when named (`--only ggx_e`).
    Named,
    /// In every build of the configuration, as the default set's tables are.
    Always,
}

/// How many Monte Carlo samples each cell gets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SamplingConfig {
    /// Samples per cell: a power of two.
    pub samples: u64,
    /// Independent scrambles the samples are split into (their spread is the error estimate).
    pub replicates: u32,
}

/// Replicates of every table's default sampling: enough for a spread, few enough to keep each
/// replicate's points many.
pub const REPLICATES: u32 = 4;

impl SamplingConfig {
    /// `samples` per cell in [`REPLICATES`] replicates.
    pub const fn replicated(samples: u64) -> Self {
        SamplingConfig { samples, replicates: REPLICATES }
    }

    pub fn validate(&self, key: &str) -> Result<()> {
        crate::sampling::sequence::SamplePlan::new(self.samples, self.replicates)
            .map_err(|e| Error::invalid(format!("{key}.samples"), strip_key(&e)))?;
        // Replicates split the samples into equal power-of-two prefixes of the Sobol sequence; a
        // count that is not a power of two would silently become the next one.
        if !self.replicates.is_power_of_two() || self.replicates as u64 > self.samples {
            return Err(Error::invalid(
                format!("{key}.replicates"),
                format!(
                    "{}; allowed: a power of two from 1 to the number of samples ({}); more are used where a \
                     replicate would exceed 2^16 points",
                    self.replicates, self.samples
                ),
            ));
        }
        Ok(())
    }
}

/// The independent check of a table at its nodes: random nodes against the exact integral, by
/// the deterministic visible-normal quadrature ([`crate::integrate::quadrature`]), so that the
/// difference is the table's whole integration error there (noise and any bias of the fast path).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReferenceConfig {
    /// Nodes checked (0 skips the check).
    pub cells: usize,
    /// Gauss–Legendre nodes per panel of each exact integral.
    pub nodes: usize,
}

/// Quadrature nodes per panel of a reference node's exact integral: far below the tables' replicate
/// standard errors (`docs/integration.md`, "Error estimates", measured per table).
pub const REFERENCE_NODES: usize = 8;

impl Default for ReferenceConfig {
    fn default() -> Self {
        ReferenceConfig { cells: 32, nodes: REFERENCE_NODES }
    }
}

impl ReferenceConfig {
    pub fn validate(&self, key: &str) -> Result<()> {
        if self.cells > 0 {
            check_quadrature_nodes(&format!("{key}.nodes"), self.nodes)?;
        }
        Ok(())
    }
}

/// Refuse quadrature `nodes` outside [`crate::integrate::quadrature::NODES`], naming `key`.
pub fn check_quadrature_nodes(key: &str, nodes: usize) -> Result<()> {
    let allowed = crate::integrate::quadrature::NODES;
    if !allowed.contains(&nodes) {
        return Err(Error::invalid(key, format!("{nodes}; allowed: {} to {}", allowed.start(), allowed.end())));
    }
    Ok(())
}

/// Which files a table is written to.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputConfig {
    pub formats: Vec<FileFormat>,
    /// Precision of DDS, KTX2 and EXR files (`.bin` is always f32).
    pub precision: Precision,
}

impl OutputConfig {
    pub fn validate(&self, key: &str, allowed: &[FileFormat]) -> Result<()> {
        check_formats(&format!("{key}.formats"), &self.formats, allowed)
    }
}

/// A list of file formats under `key`: each allowed, none twice.
pub fn check_formats(key: &str, formats: &[FileFormat], allowed: &[FileFormat]) -> Result<()> {
    for (k, format) in formats.iter().enumerate() {
        if formats[..k].contains(format) {
            return Err(Error::invalid(
                key,
                format!("`{}` is listed twice; each format is written once", format.extension()),
            ));
        }
        if !allowed.contains(format) {
            let names: Vec<&str> = allowed.iter().map(|f| f.extension()).collect();
            return Err(Error::invalid(
                key,
                format!("`{}` cannot hold this table; allowed: {}", format.extension(), names.join(", ")),
            ));
        }
    }
    Ok(())
}

/// The texture files of a table's packings under `key`: any of the texture formats, at least one
/// where any packing is written (`packed`).
pub fn check_packing_formats(key: &str, formats: &[FileFormat], packed: bool) -> Result<()> {
    check_formats(key, formats, &FileFormat::TEXTURES)?;
    if packed && formats.is_empty() {
        let names: Vec<&str> = FileFormat::TEXTURES.iter().map(|f| f.extension()).collect();
        return Err(Error::invalid(
            key,
            format!("is empty, so the packings asked for would not be written; allowed: {}", names.join(", ")),
        ));
    }
    Ok(())
}

/// Intervals of the hat basis in `c = wi.h` of a fast path: 8 to 4096.
pub fn check_cosine_intervals(key: &str, intervals: usize) -> Result<()> {
    if !(8..=4096).contains(&intervals) {
        return Err(Error::invalid(key, format!("{intervals}; allowed: 8 to 4096")));
    }
    Ok(())
}

/// A node count must be at least 2 (an axis interpolates between nodes) and at most
/// [`MAX_NODES_PER_AXIS`].
pub fn check_count(key: &str, count: usize) -> Result<()> {
    if !(2..=MAX_NODES_PER_AXIS).contains(&count) {
        return Err(Error::invalid(key, format!("{count}; allowed: 2 to {MAX_NODES_PER_AXIS} nodes")));
    }
    Ok(())
}

/// The node counts of `table`, `counts[k]` under `keys[k]` (a recipe's `COUNT_KEYS`), each by
/// [`check_count`].
pub fn check_counts(table: &str, keys: &[&str], counts: &[usize]) -> Result<()> {
    for (key, &count) in keys.iter().zip(counts) {
        check_count(&format!("{table}.{key}"), count)?;
    }
    Ok(())
}

/// A `[lo, hi]` range inside [0, 1] with `lo < hi`.
pub fn check_unit_range(key: &str, [lo, hi]: [f64; 2]) -> Result<()> {
    if !lo.is_finite() || !hi.is_finite() {
        return Err(Error::invalid(key, format!("[{lo}, {hi}] is not finite")));
    }
    if lo < 0.0 || hi > 1.0 {
        return Err(Error::invalid(key, format!("[{lo}, {hi}] leaves [0, 1]; allowed: 0 <= lo < hi <= 1")));
    }
    if lo >= hi {
        return Err(Error::invalid(key, format!("[{lo}, {hi}] is inverted or empty; allowed: lo < hi")));
    }
    Ok(())
}

/// The reason of an error without the key it was raised under, to re-raise it under another.
fn strip_key(error: &Error) -> String {
    match error {
        Error::Invalid { reason, .. } => reason.clone(),
        other => other.to_string(),
    }
}
