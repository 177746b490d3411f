//! How a table spaces its nodes along `mu` and `alpha`: uniformly in the quantity (the original
//! transfer-matrix layout, the only spacing its `.bin` files can state) or through a mapping that
//! puts them where the integrands turn fastest (`table::Mapping`).

use serde::{Deserialize, Serialize};

use crate::error::Result;
use crate::table::{Axis, Mapping, Placement};

/// The first two axes of a table over `(mu, alpha, ...)`: `counts` nodes, node-aligned over
/// `ranges`, spaced as `mu_axis` and `roughness_axis` say.
pub fn mu_alpha_axes(
    counts: [usize; 2],
    ranges: [[f64; 2]; 2],
    mu_axis: CosineAxis,
    roughness_axis: RoughnessAxis,
) -> Result<[Axis; 2]> {
    placed_mu_alpha_axes(Placement::NodeAligned, counts, ranges, mu_axis, roughness_axis)
}

/// [`mu_alpha_axes`] with the nodes placed as `placement` says: on the range ends, or at the
/// centres of equal cells (a GPU texture's texels), as engines differ on it.
pub fn placed_mu_alpha_axes(
    placement: Placement,
    counts: [usize; 2],
    [mu_range, alpha_range]: [[f64; 2]; 2],
    mu_axis: CosineAxis,
    roughness_axis: RoughnessAxis,
) -> Result<[Axis; 2]> {
    Ok([
        Axis::new("mu", mu_range[0], mu_range[1], counts[0], placement, mu_axis.mapping())?,
        alpha_axis(placement, counts[1], alpha_range, roughness_axis)?,
    ])
}

/// An `alpha` axis of `count` nodes over `range`, placed and spaced as given.
pub fn alpha_axis(placement: Placement, count: usize, range: [f64; 2], roughness_axis: RoughnessAxis) -> Result<Axis> {
    Axis::new("alpha", range[0], range[1], count, placement, roughness_axis.mapping())
}

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
    /// Evenly spaced in `asinh((eta - 1) / INDEX_AXIS_SCALE) + INDEX_AXIS_SLOPE_BELOW_ONE *
    /// min(eta - 1, 0)`: dense around `eta = 1`, where Fresnel turns from nothing to total
    /// reflection within a few hundredths of `eta` at grazing views and the critical cosine
    /// `sqrt(1 - eta^2)` sweeps fastest across the views, and kept dense below 1, where a
    /// conductor's reflectance climbs to 1 as `eta` falls to 0, with a curvature of `16 / (1 +
    /// kappa^2)^2` at normal incidence.
    DenseNearOne,
}

/// The scale of [`IndexAxis::DenseNearOne`]'s `asinh`.
pub const INDEX_AXIS_SCALE: f64 = 0.25;

/// The slope of [`IndexAxis::DenseNearOne`]'s ramp below `eta = 1`: with the scale, 64 nodes over
/// [0, 4] are 0.039 apart at `eta = 0`, 0.019 below 1 and 0.029 above it, and 0.35 at 4 (scale
/// 0.2 without the ramp: 0.092, 0.018 and 0.27). Both are chosen by measurement
/// (`docs/tables.md`, "Interpolation error"): of the scales 0.1 to 0.3 and slopes 0 to 6 tried,
/// this pair gives the lowest RMS between nodes over the whole domain and at low roughness.
pub const INDEX_AXIS_SLOPE_BELOW_ONE: f64 = 2.0;

impl IndexAxis {
    /// The mapping of an `eta` axis spaced this way.
    pub fn mapping(self) -> Mapping {
        match self {
            IndexAxis::Uniform => Mapping::Identity,
            IndexAxis::DenseNearOne => Mapping::AsinhRampBelow {
                scale: INDEX_AXIS_SCALE,
                centre: 1.0,
                slope_below: INDEX_AXIS_SLOPE_BELOW_ONE,
            },
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
