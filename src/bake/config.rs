//! How a scene's materials are baked: the `[bake]` section of a configuration, which the options
//! of `tmlut bake` and `tmlut build --scene --bake` override one by one.
//!
//! ```toml
//! [bake]
//! source = "exact"       # or "tables": the folder's own, as the scene shader reads them
//! nodes = 64             # nodes of mu per material, 9 to 8192
//! tolerance = 2.5e-4     # the interpolation error a kink or curvature may cause before nodes go to it
//! exact_nodes = 8        # Gauss–Legendre nodes per panel of the exact integrals
//! formats = ["dds"]      # dds, ktx2, exr
//! precision = "f32"      # or "f16"
//! ```

use serde::{Deserialize, Serialize};

use super::BakeSettings;
use crate::error::{Error, Result};
use crate::formats::{FileFormat, Precision};

/// What the model reads its integrals from while a material is baked.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BakeSource {
    /// Exact integrals (Gauss–Legendre quadrature): the bake's error replaces the tables'.
    #[default]
    Exact,
    /// The folder's own tables, as the scene shader reads them.
    Tables,
}

impl BakeSource {
    /// Its name as the configuration and the command line spell it.
    pub fn name(self) -> &'static str {
        match self {
            BakeSource::Exact => "exact",
            BakeSource::Tables => "tables",
        }
    }
}

/// The source of a bake from the folder's tables, in the manifest's words (`baked.source`).
pub const TABLES_SOURCE: &str = "the folder's tables, read as the scene shader reads them";

/// What a bake from the folder's tables measures its materials' errors against (the start of
/// `baked.materials[].error.against`): its own source, so that the error is the bake's alone.
pub const TABLES_REFERENCE: &str = "the model with the folder's tables it was baked from (against the model with exact \
                                    integrals: tmlut furnace's errors.baked)";

/// Whether a baked array's errors are measured against the folder's tables it was baked from, not
/// against the model with exact integrals.
pub fn measured_against_its_tables(array: &tmlut_loader::formats::baked::BakedArrayEntry) -> bool {
    array.source == TABLES_SOURCE
}

/// How a scene is baked (the `[bake]` section).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BakeConfig {
    pub source: BakeSource,
    /// Nodes along `mu` per material ([`BakeSettings::nodes`]).
    pub nodes: usize,
    /// [`BakeSettings::tolerance`].
    pub tolerance: f64,
    /// Gauss–Legendre nodes per panel of the exact integrals (the bake's and its errors', where its
    /// source is exact).
    pub exact_nodes: usize,
    /// The files the array is written as.
    pub formats: Vec<FileFormat>,
    pub precision: Precision,
}

impl Default for BakeConfig {
    fn default() -> Self {
        let settings = BakeSettings::default();
        BakeConfig {
            source: BakeSource::Exact,
            nodes: settings.nodes,
            tolerance: settings.tolerance,
            exact_nodes: crate::integrate::quadrature::DEFAULT_NODES,
            formats: vec![FileFormat::Dds],
            precision: Precision::F32,
        }
    }
}

impl BakeConfig {
    /// How each material is baked.
    pub fn settings(&self) -> BakeSettings {
        BakeSettings { nodes: self.nodes, tolerance: self.tolerance }
    }

    /// Refuse settings no bake could use, naming the key: formats other than DDS, KTX2 and EXR
    /// (or none), what [`BakeSettings::check`] refuses, exact integrals on a node count the
    /// quadrature does not take.
    pub fn validate(&self) -> Result<()> {
        if self.formats.is_empty() || self.formats.contains(&FileFormat::Bin) {
            let names: Vec<&str> = self.formats.iter().map(|f| f.extension()).collect();
            return Err(Error::invalid(
                "bake.formats",
                format!(
                    "[{}]; allowed: one or more of dds, ktx2, exr (a baked array is RGBA: .bin holds one channel)",
                    names.join(", ")
                ),
            ));
        }
        self.settings().check()?;
        let quadrature = crate::integrate::quadrature::NODES;
        if !quadrature.contains(&self.exact_nodes) {
            return Err(Error::invalid(
                "bake.exact_nodes",
                format!("{}; allowed: {} to {}", self.exact_nodes, quadrature.start(), quadrature.end()),
            ));
        }
        Ok(())
    }
}
