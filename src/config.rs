//! The build configuration: a TOML file with one section per table. Every key has a default, so
//! an empty file (or none) builds the default LUT set; an unknown key is an error that names it.
//!
//! ```toml
//! seed = 2021
//!
//! [karis]
//! mu_count = 512
//! roughness_count = 512
//! roughness_axis = "perceptual"   # or "alpha"
//! orientation = "smooth-first"    # row 0 = roughness 0; or "bottom-up-image"
//! masking = "schlick-smith"       # or "smith-separable", "smith-height-correlated"
//! [karis.sampling]
//! samples = 1024                  # per cell, a power of two
//! replicates = 4                  # independent scrambles, for error bars
//! [karis.reference]
//! cells = 64                      # cells checked against a high-sample estimate (0: none)
//! samples = 1048576
//! [karis.output]
//! formats = ["dds", "exr"]
//! precision = "f16"               # or "f32"
//! ```

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::formats::{FileFormat, Precision};
use crate::recipes::{
    belcour::BelcourSettings, fgd::FgdSettings, gd::GdSettings, karis::KarisSettings, tir::TirSettings,
};

/// Nodes per axis above which a table would not fit a GPU texture dimension (Direct3D 12 allows
/// 16384 for 2D textures, 2048 for volumes) nor memory.
pub const MAX_NODES_PER_AXIS: usize = 16384;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Config {
    /// Seed of every Monte Carlo estimate: the same configuration and seed give bit-identical files.
    pub seed: u64,
    pub fgd: FgdSettings,
    pub gd: GdSettings,
    pub tir: TirSettings,
    pub belcour: BelcourSettings,
    pub karis: KarisSettings,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            seed: 2021,
            fgd: FgdSettings::default(),
            gd: GdSettings::default(),
            tir: TirSettings::default(),
            belcour: BelcourSettings::default(),
            karis: KarisSettings::default(),
        }
    }
}

impl Config {
    /// Parse a TOML configuration; `origin` names it in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self> {
        let config: Config = toml::from_str(text).map_err(|e| Error::invalid(origin, clean_toml_error(&e)))?;
        config.validate()?;
        Ok(config)
    }

    pub fn from_file(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|source| Error::io(path, source))?;
        Self::from_toml(&text, &path.display().to_string())
    }

    /// The configuration of `path`, or the built-in defaults without one.
    pub fn load(path: Option<&Path>) -> Result<Self> {
        match path {
            Some(path) => Self::from_file(path),
            None => Ok(Config::default()),
        }
    }

    /// Every table's settings, in build order (the order of [`crate::recipes::TABLES`]).
    pub fn recipes(&self) -> [&dyn crate::recipes::TableRecipe; 5] {
        [&self.fgd, &self.gd, &self.tir, &self.belcour, &self.karis]
    }

    /// The settings of the table called `name`.
    pub fn recipe(&self, name: &str) -> Option<&dyn crate::recipes::TableRecipe> {
        self.recipes().into_iter().find(|r| r.name() == name)
    }

    /// Skip every table's reference and interpolation checks (for timing builds on their own).
    pub fn disable_reference_checks(&mut self) {
        self.fgd.reference.cells = 0;
        self.gd.reference.cells = 0;
        self.tir.reference.cells = 0;
        self.belcour.reference.cells = 0;
        self.karis.reference.cells = 0;
        self.disable_interpolation_checks();
    }

    /// Skip every table's interpolation check (`recipes::interpolation`).
    pub fn disable_interpolation_checks(&mut self) {
        self.fgd.interpolation.points = 0;
        self.gd.interpolation.points = 0;
        self.tir.interpolation.points = 0;
        self.belcour.interpolation.points = 0;
        self.karis.interpolation.points = 0;
    }

    /// Use `method` for every table.
    pub fn set_method(&mut self, method: crate::integrate::Method) {
        self.fgd.method = method;
        self.gd.method = method;
        self.tir.method = method;
        self.belcour.method = method;
        self.karis.method = method;
    }

    pub fn validate(&self) -> Result<()> {
        self.fgd.validate()?;
        self.gd.validate()?;
        self.tir.validate()?;
        self.belcour.validate()?;
        self.karis.validate()
    }
}

/// toml's messages span several lines with a source excerpt; keep them, but on one line each.
pub(crate) fn clean_toml_error(error: &toml::de::Error) -> String {
    error.to_string().lines().map(str::trim_end).filter(|l| !l.is_empty()).collect::<Vec<_>>().join(" | ")
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

impl SamplingConfig {
    pub fn validate(&self, key: &str) -> Result<()> {
        crate::sampling::sequence::SamplePlan::new(self.samples, self.replicates)
            .map_err(|e| Error::invalid(format!("{key}.samples"), strip_key(&e)))?;
        if self.replicates == 0 || self.replicates as u64 > self.samples {
            return Err(Error::invalid(
                format!("{key}.replicates"),
                format!("{}; allowed: 1 to the number of samples ({})", self.replicates, self.samples),
            ));
        }
        Ok(())
    }
}

/// The independent check of a table: cells re-estimated with many more samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReferenceConfig {
    /// Cells checked (0 skips the check).
    pub cells: usize,
    /// Samples per reference cell: a power of two.
    pub samples: u64,
}

impl ReferenceConfig {
    pub fn validate(&self, key: &str) -> Result<()> {
        if self.cells > 0 {
            crate::sampling::sequence::SamplePlan::new(self.samples, 1)
                .map_err(|e| Error::invalid(format!("{key}.samples"), strip_key(&e)))?;
        }
        Ok(())
    }
}

/// Which files a table is written to.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputConfig {
    pub formats: Vec<FileFormat>,
    /// Precision of DDS and EXR files (`.bin` is always f32).
    pub precision: Precision,
}

impl OutputConfig {
    pub fn validate(&self, key: &str, allowed: &[FileFormat]) -> Result<()> {
        for format in &self.formats {
            if !allowed.contains(format) {
                let names: Vec<&str> = allowed.iter().map(|f| f.extension()).collect();
                return Err(Error::invalid(
                    format!("{key}.formats"),
                    format!("`{}` cannot hold this table; allowed: {}", format.extension(), names.join(", ")),
                ));
            }
        }
        Ok(())
    }
}

/// A node count must be at least 2 (an axis interpolates between nodes) and at most
/// [`MAX_NODES_PER_AXIS`].
pub fn check_count(key: &str, count: usize) -> Result<()> {
    if !(2..=MAX_NODES_PER_AXIS).contains(&count) {
        return Err(Error::invalid(key, format!("{count}; allowed: 2 to {MAX_NODES_PER_AXIS} nodes")));
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

#[cfg(test)]
mod tests {
    use super::*;

    fn error_of(text: &str) -> String {
        Config::from_toml(text, "test.toml").unwrap_err().to_string()
    }

    #[test]
    fn empty_configuration_is_the_default() {
        assert_eq!(Config::from_toml("", "empty").unwrap(), Config::default());
    }

    #[test]
    fn partial_sections_keep_the_other_defaults() {
        let config = Config::from_toml("seed = 5\n[karis]\nmu_count = 32\n", "t").unwrap();
        assert_eq!(config.seed, 5);
        assert_eq!(config.karis.mu_count, 32);
        assert_eq!(config.karis.roughness_count, 512);
    }

    #[test]
    fn unknown_keys_are_named() {
        let e = error_of("[karis]\nmu_cuont = 32\n");
        assert!(e.contains("test.toml") && e.contains("mu_cuont"), "{e}");
        let e = error_of("[fgdd]\n");
        assert!(e.contains("fgdd"), "{e}");
    }

    #[test]
    fn out_of_range_values_are_named_with_what_is_allowed() {
        let e = error_of("[karis]\nalpha_range = [-0.1, 1.0]\n");
        assert!(e.contains("karis.alpha_range") && e.contains("allowed"), "{e}");
        let e = error_of("[karis]\nalpha_range = [0.8, 0.2]\n");
        assert!(e.contains("karis.alpha_range") && e.contains("inverted"), "{e}");
        for n in [0, 1] {
            let e = error_of(&format!("[karis]\nmu_count = {n}\n"));
            assert!(e.contains("karis.mu_count") && e.contains("allowed: 2 to"), "{e}");
        }
        let e = error_of("[karis.sampling]\nsamples = 1000\nreplicates = 4\n");
        assert!(e.contains("karis.sampling.samples") && e.contains("power of two"), "{e}");
        let e = error_of("[karis.output]\nformats = [\"bin\"]\nprecision = \"f16\"\n");
        assert!(e.contains("karis.output.formats") && e.contains("allowed: dds, exr"), "{e}");
        let e = error_of("[tir]\nfit = \"always\"\n");
        assert!(e.contains("always") && e.contains("best") && e.contains("off"), "{e}");
        let e = error_of("[karis]\nmasking = \"beckmann\"\n");
        assert!(e.contains("beckmann") && e.contains("smith-separable"), "{e}");
    }
}

#[cfg(test)]
mod default_file_tests {
    use super::*;

    #[test]
    fn the_committed_default_configuration_is_the_built_in_default() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("luts/default.toml");
        assert_eq!(Config::from_file(&path).unwrap(), Config::default());
    }
}
