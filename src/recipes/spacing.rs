//! How a table spaces its nodes along `mu` and `alpha`: uniformly in the quantity (the original
//! transfer-matrix layout, the only spacing its `.bin` files can state) or through a mapping that
//! puts them where the integrands turn fastest (`table::Mapping`).

use serde::{Deserialize, Serialize};

use crate::table::Mapping;

/// How the nodes of an `alpha` axis follow roughness.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RoughnessAxis {
    /// Evenly spaced in perceptual roughness `r = sqrt(alpha)` (Unreal Engine 4's split-sum
    /// table): nodes at alpha 0, 1/63^2, 4/63^2, ... for 64, dense where smooth lobes change
    /// fastest with roughness.
    Perceptual,
    /// Evenly spaced in GGX alpha.
    Alpha,
}

impl RoughnessAxis {
    /// The mapping of an alpha axis spaced this way.
    pub fn mapping(self) -> Mapping {
        match self {
            RoughnessAxis::Perceptual => Mapping::Sqrt,
            RoughnessAxis::Alpha => Mapping::Identity,
        }
    }
}

/// How the nodes of a `mu` axis follow the view cosine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CosineAxis {
    /// Evenly spaced in `mu`.
    Uniform,
    /// Evenly spaced in `(sqrt(mu) - sqrt(1 - mu) + 1) / 2` ([`Mapping::SqrtEnds`]): dense at
    /// grazing views and near the normal.
    SqrtEnds,
}

impl CosineAxis {
    /// The mapping of a `mu` axis spaced this way.
    pub fn mapping(self) -> Mapping {
        match self {
            CosineAxis::Uniform => Mapping::Identity,
            CosineAxis::SqrtEnds => Mapping::SqrtEnds,
        }
    }
}
