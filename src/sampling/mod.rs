//! Sampling: the sequences that drive the Monte Carlo estimates and the warps that turn points of
//! the unit square into microfacet normals. Estimators live in [`crate::integrate`].

#[cfg(feature = "generator")]
pub mod sequence;
pub mod vndf;

pub use vndf::{DiskPoint, VisibleNormalSampler, sample_visible_normal};
