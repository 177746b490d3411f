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

/// How the nodes of an `eta` axis follow the relative index.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum IndexAxis {
    /// Evenly spaced in `eta` (the original FGD table).
    Uniform,
    /// Evenly spaced in `asinh((eta - 1) / INDEX_AXIS_SCALE)`: dense around `eta = 1`, where
    /// Fresnel turns from nothing to total reflection within a few hundredths of `eta` at grazing
    /// views and the critical cosine `sqrt(1 - eta^2)` sweeps fastest across the views.
    DenseNearOne,
}

/// The scale of [`IndexAxis::DenseNearOne`]: 64 nodes over [0, 4] are 0.018 apart at `eta = 1`,
/// 0.09 at 0 and 0.26 at 4. Chosen by measurement (`docs/tables.md`, "Interpolation error"):
/// 0.1 and 0.5 give a larger maximum error between nodes, 0.3 a larger one at low roughness.
pub const INDEX_AXIS_SCALE: f64 = 0.2;

impl IndexAxis {
    /// The mapping of an `eta` axis spaced this way.
    pub fn mapping(self) -> Mapping {
        match self {
            IndexAxis::Uniform => Mapping::Identity,
            IndexAxis::DenseNearOne => Mapping::Asinh { scale: INDEX_AXIS_SCALE, centre: 1.0 },
        }
    }
}

/// How the nodes of a `kappa` axis follow the extinction coefficient.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ExtinctionAxis {
    /// Evenly spaced in `kappa` (the original FGD table).
    Uniform,
    /// Evenly spaced in `asinh(kappa / EXTINCTION_AXIS_SCALE)`: dense near `kappa = 0`, where a
    /// faint absorption below a denser medium (`eta < 1`) already frustrates total internal
    /// reflection, so that reflectance past the critical angle falls from 1 within a few
    /// hundredths of `kappa`.
    DenseNearZero,
}

/// The scale of [`ExtinctionAxis::DenseNearZero`]: 64 nodes over [0, 4] are 0.007 apart at
/// `kappa = 0` and 0.27 at 4.
pub const EXTINCTION_AXIS_SCALE: f64 = 0.1;

impl ExtinctionAxis {
    /// The mapping of a `kappa` axis spaced this way.
    pub fn mapping(self) -> Mapping {
        match self {
            ExtinctionAxis::Uniform => Mapping::Identity,
            ExtinctionAxis::DenseNearZero => Mapping::Asinh { scale: EXTINCTION_AXIS_SCALE, centre: 0.0 },
        }
    }
}
