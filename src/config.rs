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
use crate::recipes::TableRecipe;
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
        // Parsed to a TOML table first and deserialised from it: that path refuses an array longer
        // than its field (`alpha_range = [0.1, 0.5, 0.9]`), which deserialising from the text
        // directly accepts, dropping the third value.
        let table: toml::Table = text.parse().map_err(|e| Error::invalid(origin, clean_toml_error(&e)))?;
        let config: Config =
            toml::Value::Table(table).try_into().map_err(|e| Error::invalid(origin, clean_toml_error(&e)))?;
        config.validate()?;
        Ok(config)
    }

    pub fn from_file(path: &Path) -> Result<Self> {
        let text = crate::formats::read_text_at_most(path, crate::formats::MAX_TEXT_INPUT_BYTES, "a configuration")?;
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
        self.karis.validate()?;
        for recipe in self.recipes() {
            crate::recipes::check_demand(recipe)?;
        }
        // A table with no format writes nothing, unless it has other outputs: FGD's packed
        // textures, TIR's fitted form.
        let tir_fit = self.tir.fit == crate::recipes::tir::TirFit::Best;
        for (name, output, other_outputs) in [
            (self.fgd.name(), &self.fgd.output, !self.fgd.packings.is_empty()),
            (self.gd.name(), &self.gd.output, false),
            (self.tir.name(), &self.tir.output, tir_fit),
            (self.belcour.name(), &self.belcour.output, false),
            (self.karis.name(), &self.karis.output, false),
        ] {
            if output.formats.is_empty() && !other_outputs {
                return Err(Error::invalid(
                    format!("{name}.output.formats"),
                    "[] writes no file of this table; give at least one format, or leave the table out of the \
                     build with --only",
                ));
            }
        }
        Ok(())
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
        for (k, format) in self.formats.iter().enumerate() {
            if self.formats[..k].contains(format) {
                return Err(Error::invalid(
                    format!("{key}.formats"),
                    format!("`{}` is listed twice; each format is written once", format.extension()),
                ));
            }
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

    #[test]
    fn a_build_that_would_not_fit_in_memory_or_time_is_refused_naming_its_keys() {
        // Every FGD count at its maximum: 2^56 values.
        let e = error_of(
            "[fgd]\nmu_count = 16384\nalpha_count = 16384\neta_count = 16384\nkappa_count = 16384\npackings = []\n",
        );
        assert!(
            e.starts_with("fgd: ") && e.contains("fgd.mu_count, fgd.alpha_count, fgd.eta_count, fgd.kappa_count"),
            "{e}"
        );
        assert!(e.contains("allowed: at most 16.0 GiB"), "{e}");
        // 2^32 samples: 144 GiB of points.
        let e = error_of("[karis.sampling]\nsamples = 4294967296\nreplicates = 4\n");
        assert!(e.starts_with("karis: ") && e.contains("karis.sampling.samples"), "{e}");
        // The per-cell method over the default FGD table with 2^20 samples: 2^44 evaluations and more.
        let e = error_of("[fgd]\nmethod = \"per-cell\"\n[fgd.sampling]\nsamples = 2097152\nreplicates = 4\n");
        assert!(e.contains("fgd.sampling.samples = 2097152") && e.contains("per-cell") && e.contains("2^44"), "{e}");
        // The default set needs far less.
        let config = Config::default();
        for recipe in config.recipes() {
            let demand = crate::recipes::demand(recipe).unwrap();
            assert!(demand.bytes < 1 << 30, "{}: {demand:?}", recipe.name());
        }
    }

    #[test]
    fn a_range_of_three_values_is_refused() {
        let e = error_of("[karis]\nalpha_range = [0.1, 0.5, 0.9]\n");
        assert!(e.contains("invalid length 3") && e.contains("karis.alpha_range"), "{e}");
    }

    #[test]
    fn replicates_that_are_not_a_power_of_two_are_refused() {
        let e = error_of("[karis.sampling]\nsamples = 1024\nreplicates = 3\n");
        assert!(e.contains("karis.sampling.replicates") && e.contains("3; allowed: a power of two"), "{e}");
    }

    #[test]
    fn a_format_listed_twice_or_no_format_at_all_is_refused() {
        let e = error_of("[karis.output]\nformats = [\"dds\", \"exr\", \"dds\"]\nprecision = \"f16\"\n");
        assert!(e.contains("karis.output.formats") && e.contains("`dds` is listed twice"), "{e}");
        let e = error_of("[karis.output]\nformats = []\nprecision = \"f16\"\n");
        assert!(e.contains("karis.output.formats") && e.contains("writes no file") && e.contains("--only"), "{e}");
        // FGD's packed texture and TIR's fitted form are files of their own.
        let packed_only =
            "[fgd.output]\nformats = []\nprecision = \"f32\"\n[tir.output]\nformats = []\nprecision = \"f32\"\n";
        assert!(Config::from_toml(packed_only, "t").is_ok());
        let e = error_of(&format!("{packed_only}[tir]\nfit = \"off\"\n"));
        assert!(e.contains("tir.output.formats"), "{e}");
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
