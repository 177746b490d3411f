//! GD: the albedo of a GGX microfacet surface without Fresnel, which the 6-flux transfer-matrix
//! model uses to normalise its internal lobes (`docs/tables.md`, GD):
//!
//! ```text
//! GD(mu, alpha) = ∫ D G2 / (4 mu) dwo = E_{h ~ D_wi}[ G2 / G1(wi) ] = E_{h ~ D_wi}[ G1(wo) ]
//! ```
//!
//! with separable Smith `G2 = G1(wi) G1(wo)`, the form that reproduces the shipped `tm_GD.bin`
//! (height-correlated Smith does not). Defaults follow that file: 64 x 64 node-aligned nodes,
//! `mu` and `alpha` over [0, 1], f32 `.bin`.

use serde::{Deserialize, Serialize};

use super::driver::one_channel_table;
use super::settings::{SharedSettings, check_counts};
use super::spacing::{CosineAxis, RoughnessAxis, mu_alpha_axes};
use super::{Integrated, Kernel, Metadata, TableRecipe};
use crate::error::Result;
use crate::formats::FileFormat;
use crate::integrate::quadrature::VisibleNormalQuadrature;
use crate::integrate::{Estimate, Method, Progress, cosine_function_replicates, estimate_cosine_functions};
use crate::physics::MaskingShadowing;
use crate::sampling::sequence::PointSet;
use crate::table::{Axis, Table};

pub const NAME: &str = crate::table::TableKind::Gd.name();
/// One line for `tmlut list`.
pub const DESCRIPTION: &str = "microfacet albedo without Fresnel (separable Smith), 2D (mu, alpha)";
/// Channels of the table.
pub const CHANNEL_COUNT: usize = 1;
/// The configuration keys of the node counts, axis 0 first.
pub const COUNT_KEYS: &[&str] = &["mu_count", "alpha_count"];

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GdSettings {
    pub mu_count: usize,
    pub alpha_count: usize,
    /// How the `mu` nodes are spaced.
    pub mu_axis: CosineAxis,
    /// How the `alpha` nodes are spaced.
    pub roughness_axis: RoughnessAxis,
    pub masking: MaskingShadowing,
    pub method: Method,
    #[serde(flatten)]
    pub shared: SharedSettings,
}

impl Default for GdSettings {
    fn default() -> Self {
        GdSettings {
            mu_count: 64,
            alpha_count: 64,
            mu_axis: CosineAxis::SqrtEnds,
            roughness_axis: RoughnessAxis::Perceptual,
            masking: MaskingShadowing::SmithSeparable,
            method: Method::Fast,
            shared: SharedSettings::default(),
        }
    }
}

impl GdSettings {
    pub fn validate(&self) -> Result<()> {
        check_counts(NAME, COUNT_KEYS, &[self.mu_count, self.alpha_count])?;
        self.shared.validate(NAME, &FileFormat::for_table(2, true))
    }

    pub fn axes(&self) -> Result<Vec<Axis>> {
        let counts = [self.mu_count, self.alpha_count];
        Ok(mu_alpha_axes(counts, [[0.0, 1.0]; 2], self.mu_axis, self.roughness_axis)?.into())
    }
}

impl GdSettings {
    /// One node by the fast method (the f32 kernel), as [`Kernel::integrate`] computes it.
    pub fn estimate_node_fast(&self, points: &PointSet, position: &[f64]) -> Estimate {
        albedo(self.masking, Method::Fast, points, position[0], position[1])
    }
}

/// The integrand of GD, of Kulla & Conty's `E` (`ggx_e`: the same integral) and of its average
/// (`ggx_e_avg`): no Fresnel, `f(wi.h) = 1`.
pub(crate) fn without_fresnel(_cos_wi_h: f64) -> [f64; 1] {
    [1.0]
}

/// `E[G2 / G1(wi)]` at one `(mu, alpha)` with `masking`.
pub(crate) fn albedo(masking: MaskingShadowing, method: Method, points: &PointSet, mu: f64, alpha: f64) -> Estimate {
    estimate_cosine_functions(mu, alpha, masking, method, points, without_fresnel)
}

/// [`albedo`] per replicate, for an estimate that adds albedos of several views.
pub(crate) fn albedo_replicates(
    masking: MaskingShadowing,
    method: Method,
    points: &PointSet,
    mu: f64,
    alpha: f64,
) -> Vec<Vec<f64>> {
    cosine_function_replicates(mu, alpha, masking, method, points, without_fresnel)
}

/// [`albedo`] exactly, by the deterministic `quadrature`.
pub(crate) fn exact_albedo(
    quadrature: &VisibleNormalQuadrature,
    masking: MaskingShadowing,
    mu: f64,
    alpha: f64,
) -> f64 {
    let [albedo] = quadrature.cosine_functions(mu, alpha, masking, &[], without_fresnel);
    albedo
}

impl TableRecipe for GdSettings {
    table_recipe_accessors!();
}

impl Kernel for GdSettings {
    kernel_settings!();

    fn empty_table(&self) -> Result<Table> {
        one_channel_table(
            NAME,
            self.axes()?,
            "gd",
            "∫ D G2 / (4 mu) dwo: the albedo of the microfacet lobe without Fresnel",
        )
    }

    fn metadata(&self) -> Metadata {
        Metadata {
            integrand: "GD = E_{h~VNDF(wi)}[G2(wi,wo) / G1(wi)], wo = reflect(wi, h); with separable Smith, E[G1(wo)]"
                .into(),
            masking: Some(self.masking),
            notes: vec![super::driver::NODE_ALIGNED_NOTE.into(), super::driver::grazing_note()],
            sampler: "visible-normal measure per (mu, alpha)".into(),
            ..Metadata::default()
        }
    }

    cosine_function_kernel!(without_fresnel);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::bin::read_bin;
    use crate::recipes::settings::{ReferenceConfig, SamplingConfig};

    /// A table of `counts` nodes (mu, alpha) with 2^12 samples per node, `reference_cells` of them
    /// checked.
    fn small([mu_count, alpha_count]: [usize; 2], reference_cells: usize) -> GdSettings {
        GdSettings {
            mu_count,
            alpha_count,
            shared: SharedSettings {
                sampling: SamplingConfig::replicated(1 << 12),
                reference: ReferenceConfig { cells: reference_cells, nodes: 8 },
                ..GdSettings::default().shared
            },
            ..GdSettings::default()
        }
    }

    fn original() -> Table {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/tmblm/tm_GD.bin");
        read_bin(std::path::Path::new(path), Some(&["mu", "alpha"])).unwrap()
    }

    #[test]
    fn reproduces_the_original_table() {
        // The original layout (luts/original.toml): uniform nodes. Full resolution, fewer samples
        // than the default: the original's own noise is ~1.3e-3.
        let mut settings =
            GdSettings { mu_axis: CosineAxis::Uniform, roughness_axis: RoughnessAxis::Alpha, ..small([64, 64], 0) };
        settings.shared.interpolation = crate::recipes::interpolation::InterpolationConfig { points: 0, nodes: 6 };
        let ours = settings.build(1, &()).unwrap().table;
        let original = original();
        assert_eq!(ours.axes, original.axes);
        let differences = (0..ours.node_count())
            .filter(|&n| n != 0) // the degenerate (mu 0, alpha 0) corner
            .map(|n| (ours.data[n] - original.data[n]) as f64);
        let error = crate::stats::ErrorSummary::of_differences(differences);
        assert!(error.rms <= 2.5e-3, "RMSE {error:?}");
    }

    #[test]
    fn edges_are_finite_and_physical() {
        let settings = small([9, 9], 81);
        let build = settings.build(2, &()).unwrap();
        let table = &build.table;
        let stats = table.stats();
        assert_eq!(stats.nan_count + stats.infinite_count, 0);
        assert!(stats.min > 0.3 && stats.max <= 1.0, "{stats:?}");
        // A smooth surface loses nothing to masking: GD = 1 along alpha = 0, grazing included.
        for i in 0..9 {
            assert!((table.node(&[i, 0])[0] - 1.0).abs() < 1e-6, "mu node {i}: {}", table.node(&[i, 0])[0]);
        }
        // The fast path agrees at every node with the exact integral, within the Monte Carlo error
        // of its own 2^12 samples.
        let reference = build.provenance.error.reference.unwrap();
        let spread = build.provenance.error.replicate_standard_error.max;
        assert!(reference.difference.max < 5.0 * spread && spread < 1e-3, "{reference:?}, spread {spread}");
    }

    #[test]
    fn both_methods_agree() {
        let base = small([6, 5], 0);
        let fast = base.build(3, &()).unwrap().table;
        let per_cell = GdSettings { method: Method::PerCell, ..base }.build(3, &()).unwrap().table;
        for (a, b) in fast.data.iter().zip(&per_cell.data) {
            assert!((a - b).abs() < 1e-5, "{a} vs {b}");
        }
    }
}
