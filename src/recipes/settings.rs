//! The settings every table shares: its samples, its reference check, its output files, and the
//! checks of node counts and ranges that every table's validation uses.

/// A table's settings struct: its own keys, and where `..shared` stands, the keys every table
/// has (`sampling`, `reference`, `interpolation`, `output`), with the check of those keys
/// (`validate_shared`); where `..mu_alpha_axes` stands (before `..shared`), the sub-ranges and
/// spacings of the `mu` and `alpha` axes of a table whose plan may narrow them. The keys stay in
/// one flat TOML section, in the order written (which the scene cache's keys hash). A macro and
/// not a flattened struct: serde reports a bad value inside a flattened field under the section's
/// name alone (`in `gd``, not `in `gd.output.precision``).
macro_rules! table_settings {
    (
        $(#[$attr:meta])*
        pub struct $name:ident {
            $($(#[$before_attr:meta])* pub $before:ident: $before_ty:ty,)*
            ..mu_alpha_axes,
            $($(#[$between_attr:meta])* pub $between:ident: $between_ty:ty,)*
            ..shared,
            $($(#[$after_attr:meta])* pub $after:ident: $after_ty:ty,)*
        }
    ) => {
        table_settings! {
            $(#[$attr])*
            pub struct $name {
                $($(#[$before_attr])* pub $before: $before_ty,)*
                /// Sub-ranges of the unit axes (a scene's plan narrows them to what its lookups reach).
                pub mu_range: [f64; 2],
                pub alpha_range: [f64; 2],
                /// How the `mu` nodes are spaced.
                pub mu_axis: $crate::recipes::spacing::CosineAxis,
                /// How the `alpha` nodes are spaced.
                pub roughness_axis: $crate::recipes::spacing::RoughnessAxis,
                $($(#[$between_attr])* pub $between: $between_ty,)*
                ..shared,
                $($(#[$after_attr])* pub $after: $after_ty,)*
            }
        }

        impl $name {
            /// Check the sub-ranges of `mu` and `alpha`; `table` names the section in errors.
            pub fn validate_mu_alpha_ranges(&self, table: &str) -> $crate::error::Result<()> {
                $crate::recipes::settings::check_unit_range(&format!("{table}.mu_range"), self.mu_range)?;
                $crate::recipes::settings::check_unit_range(&format!("{table}.alpha_range"), self.alpha_range)
            }

            /// The `mu` and `alpha` axes of `counts` nodes over their sub-ranges, spaced as set.
            pub fn mu_alpha_axes(&self, counts: [usize; 2]) -> $crate::error::Result<[$crate::table::Axis; 2]> {
                let ranges = [self.mu_range, self.alpha_range];
                $crate::recipes::spacing::mu_alpha_axes(counts, ranges, self.mu_axis, self.roughness_axis)
            }
        }
    };
    (
        $(#[$attr:meta])*
        pub struct $name:ident $(<$param:ident>)? {
            $($(#[$before_attr:meta])* pub $before:ident: $before_ty:ty,)*
            ..shared,
            $($(#[$after_attr:meta])* pub $after:ident: $after_ty:ty,)*
        }
    ) => {
        $(#[$attr])*
        #[derive(Debug, Clone, PartialEq, ::serde::Serialize, ::serde::Deserialize)]
        #[serde(deny_unknown_fields, default)]
        pub struct $name $(<$param>)? {
            $($(#[$before_attr])* pub $before: $before_ty,)*
            pub sampling: $crate::recipes::settings::SamplingConfig,
            pub reference: $crate::recipes::settings::ReferenceConfig,
            /// The check between nodes: random points against the exact integral.
            pub interpolation: $crate::recipes::interpolation::InterpolationConfig,
            pub output: $crate::recipes::settings::OutputConfig,
            $($(#[$after_attr])* pub $after: $after_ty,)*
        }

        impl $(<$param>)? $name $(<$param>)? {
            /// Check the keys every table has; `table` names the section in errors, `formats` are
            /// the file formats that can hold the table.
            pub fn validate_shared(&self, table: &str, formats: &[$crate::formats::FileFormat]) -> $crate::error::Result<()> {
                self.sampling.validate(&format!("{table}.sampling"))?;
                self.reference.validate(&format!("{table}.reference"))?;
                self.interpolation.validate(&format!("{table}.interpolation"))?;
                self.output.validate(&format!("{table}.output"), formats)
            }
        }
    };
}

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::formats::{FileFormat, Precision};

/// Nodes per axis above which a table would not fit a GPU texture dimension (Direct3D 12 allows
/// 16384 for 2D textures, 2048 for volumes) nor memory.
pub const MAX_NODES_PER_AXIS: usize = 16384;

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
