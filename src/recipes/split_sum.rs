//! What the two split-sum tables (Karis, Belcour) share: 2D textures over `x = n.v` and
//! roughness, with the roughness spacing and orientation as options, because existing renderers
//! disagree on both and users trip over it (the thesis renderer read Unreal's table unflipped and
//! by alpha instead of roughness).

use serde::{Deserialize, Serialize};

use crate::config::{check_count, check_unit_range};
use crate::error::Result;
use crate::table::{Axis, Mapping};

/// How the texture's second coordinate follows roughness.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RoughnessAxis {
    /// Texels evenly spaced in perceptual roughness `r = sqrt(alpha)` (Unreal Engine 4).
    Perceptual,
    /// Texels evenly spaced in GGX alpha.
    Alpha,
}

/// Which end of the roughness axis is row 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Orientation {
    /// Row 0 is the roughest texel (Unreal Engine 4's shipped table: `v = 1 - roughness`).
    RoughFirst,
    /// Row 0 is the smoothest texel (`v = roughness`).
    SmoothFirst,
}

/// The layout of a split-sum texture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SplitSumLayout {
    /// Texels along `x = n.v`.
    pub mu_count: usize,
    /// Texels along roughness.
    pub roughness_count: usize,
    /// Range of GGX alpha covered, before orientation.
    pub alpha_range: [f64; 2],
    pub roughness_axis: RoughnessAxis,
    pub orientation: Orientation,
}

impl SplitSumLayout {
    /// Check the layout; `table` names the configuration section in errors.
    pub fn validate(&self, table: &str) -> Result<()> {
        check_count(&format!("{table}.mu_count"), self.mu_count)?;
        check_count(&format!("{table}.roughness_count"), self.roughness_count)?;
        check_unit_range(&format!("{table}.alpha_range"), self.alpha_range)
    }

    /// The table's axes: `mu` cell-centred over [0, 1]; `alpha` cell-centred, spaced and ordered
    /// as configured.
    pub fn axes(&self) -> Result<Vec<Axis>> {
        let mu = Axis::cell_centred("mu", 0.0, 1.0, self.mu_count)?;
        let [smooth, rough] = self.alpha_range;
        let (start, end) = match self.orientation {
            Orientation::RoughFirst => (rough, smooth),
            Orientation::SmoothFirst => (smooth, rough),
        };
        let mapping = match self.roughness_axis {
            RoughnessAxis::Perceptual => Mapping::Sqrt,
            RoughnessAxis::Alpha => Mapping::Identity,
        };
        let alpha = Axis::cell_centred("alpha", start, end, self.roughness_count)?.with_mapping(mapping)?;
        Ok(vec![mu, alpha])
    }

    /// The conventions a user must know to sample the texture.
    pub fn notes(&self) -> Vec<String> {
        let roughness = match (self.roughness_axis, self.orientation) {
            (RoughnessAxis::Perceptual, Orientation::RoughFirst) => {
                "Row 0 = roughness 1: v = 1 - roughness, roughness = sqrt(alpha) (Unreal Engine 4 convention)."
            }
            (RoughnessAxis::Perceptual, Orientation::SmoothFirst) => {
                "Row 0 = roughness 0: v = roughness = sqrt(alpha)."
            }
            (RoughnessAxis::Alpha, Orientation::RoughFirst) => "Row 0 = alpha 1: v = 1 - alpha (linear in GGX alpha).",
            (RoughnessAxis::Alpha, Orientation::SmoothFirst) => "Row 0 = alpha 0: v = alpha (linear in GGX alpha).",
        };
        vec![
            "Texture coordinate x = n.v at texel centres (cell-centred); sample with clamp addressing, linear data (not sRGB).".into(),
            roughness.into(),
        ]
    }
}
