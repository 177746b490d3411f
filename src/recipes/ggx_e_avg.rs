//! E_avg: the hemispherical average of a GGX lobe's albedo with `F = 1` (Kulla & Conty 2017), the
//! energy a lobe keeps of light arriving from every direction alike:
//!
//! ```text
//! E_avg(alpha) = 2 ∫_0^1 E(mu, alpha) mu dmu,   E(mu, alpha) = E_{h ~ D_wi}[ G2(wi, wo) / G1(wi) ]
//! ```
//!
//! with `E` the integral of `ggx_e` (and of GD, whose integrand all three share). The outer
//! integral is a Gauss–Legendre rule in `mu`, `mu_nodes` per panel, the panels growing
//! geometrically from `alpha / 2` at grazing views, where masking reshapes the lobe within
//! `mu ~ alpha`, and none wider than 1/4; `E` at each of its views is estimated on the same points,
//! and each replicate's average is its own, so that their spread is the error of the average.
//! One axis, `alpha`; written as OpenEXR (one row). Not part of the default set: built when named
//! (`--only ggx_e_avg`) or with `build = "always"`.

use serde::{Deserialize, Serialize};

use super::driver::one_channel_table;
use super::gd::{albedo_replicates, exact_albedo};
use super::settings::{BuildWhen, OutputConfig, SamplingConfig, SharedSettings, check_counts, check_unit_range};
use super::spacing::{RoughnessAxis, alpha_axis};
use super::{Integrated, Kernel, Metadata, TableRecipe};
use crate::error::{Error, Result};
use crate::formats::{FileFormat, Precision};
use crate::integrate::quadrature::{VisibleNormalQuadrature, gauss_legendre_unit};
use crate::integrate::{Estimate, Method, Progress, combine_replicates, estimate_cells};
use crate::physics::MaskingShadowing;
use crate::sampling::sequence::PointSet;
use crate::table::{Axis, Placement, Table};

pub const NAME: &str = crate::table::TableKind::GgxEAvg.name();
/// One line for `tmlut list`.
pub const DESCRIPTION: &str = "GGX albedo with F = 1 averaged over the hemisphere, 2 ∫ E mu dmu (Kulla & Conty 2017), 1D (alpha); built when named";
/// Channels of the table.
pub const CHANNEL_COUNT: usize = 1;
/// The configuration keys of the node counts.
pub const COUNT_KEYS: &[&str] = &["alpha_count"];

/// The widest panel of the rule in `mu`.
const MAX_VIEW_PANEL: f64 = 0.25;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GgxEAvgSettings {
    /// Which builds make the table: only those naming it, or every build of the configuration.
    pub build: BuildWhen,
    pub alpha_count: usize,
    /// Nodes on the range ends (`node-aligned`) or at the centres of equal cells (`cell-centred`).
    pub placement: Placement,
    pub alpha_range: [f64; 2],
    /// How the `alpha` nodes are spaced.
    pub roughness_axis: RoughnessAxis,
    pub masking: MaskingShadowing,
    /// Gauss–Legendre nodes per panel of the average over view cosines.
    pub mu_nodes: usize,
    pub method: Method,
    #[serde(flatten)]
    pub shared: SharedSettings,
}

impl Default for GgxEAvgSettings {
    fn default() -> Self {
        GgxEAvgSettings {
            build: BuildWhen::Named,
            alpha_count: 32,
            placement: Placement::NodeAligned,
            alpha_range: [0.0, 1.0],
            roughness_axis: RoughnessAxis::Perceptual,
            masking: MaskingShadowing::SmithHeightCorrelated,
            mu_nodes: 8,
            method: Method::Fast,
            shared: SharedSettings {
                sampling: SamplingConfig::replicated(1 << 16),
                // Each exact value integrates E at 24 to 80 views (1 to 7 ms): a 1D table of 32
                // nodes is read between every pair of them by a few points.
                interpolation: super::interpolation::InterpolationConfig {
                    points: 128,
                    nodes: super::interpolation::EXACT_NODES,
                },
                output: OutputConfig { formats: vec![FileFormat::Exr], precision: Precision::F32 },
                ..SharedSettings::default()
            },
        }
    }
}

impl GgxEAvgSettings {
    pub fn validate(&self) -> Result<()> {
        check_counts(NAME, COUNT_KEYS, &[self.alpha_count])?;
        check_unit_range(&format!("{NAME}.alpha_range"), self.alpha_range)?;
        super::settings::check_quadrature_nodes(&format!("{NAME}.mu_nodes"), self.mu_nodes)?;
        self.shared.validate(NAME, &FileFormat::for_table(1, false))
    }

    pub fn axes(&self) -> Result<Vec<Axis>> {
        Ok(vec![alpha_axis(self.placement, self.alpha_count, self.alpha_range, self.roughness_axis)?])
    }

    /// One node by the fast method (the f32 kernel), as [`Kernel::integrate`] computes it.
    pub fn estimate_node_fast(&self, points: &PointSet, position: &[f64]) -> Estimate {
        average_albedo(self, Method::Fast, points, position[0])
    }
}

/// The views `E_avg` averages over, each with its weight, so that `Σ w E(mu)` is the rule for
/// `2 ∫ E(mu) mu dmu` of `nodes` Gauss–Legendre nodes per panel (see the module's comment).
pub fn view_rule(alpha: f64, nodes: usize) -> Result<Vec<(f64, f64)>> {
    if !crate::integrate::quadrature::NODES.contains(&nodes) {
        return Err(Error::invalid("view rule nodes", format!("{nodes}: must be 2 to 64")));
    }
    let mut edges = vec![0.0];
    let mut edge = if alpha > 0.0 { (alpha / 2.0).min(MAX_VIEW_PANEL) } else { MAX_VIEW_PANEL };
    while edge < 1.0 {
        edges.push(edge);
        edge = (2.0 * edge).min(edge + MAX_VIEW_PANEL).min(1.0);
    }
    edges.push(1.0);
    let unit = gauss_legendre_unit(nodes);
    Ok(edges
        .windows(2)
        .flat_map(|panel| {
            let (a, width) = (panel[0], panel[1] - panel[0]);
            unit.iter().map(move |&(u, w)| {
                let mu = a + width * u;
                (mu, 2.0 * mu * w * width)
            })
        })
        .collect())
}

/// `E_avg` at one `alpha` by `method`: `E` at every view of [`view_rule`] on the same points,
/// weighted and added replicate by replicate.
fn average_albedo(settings: &GgxEAvgSettings, method: Method, points: &PointSet, alpha: f64) -> Estimate {
    let rule = view_rule(alpha, settings.mu_nodes).expect("validated settings");
    let mut averages = vec![vec![0.0]; points.plan().replicates as usize];
    for (mu, weight) in rule {
        for (average, albedo) in averages.iter_mut().zip(albedo_replicates(settings.masking, method, points, mu, alpha))
        {
            average[0] += weight * albedo[0];
        }
    }
    combine_replicates(&averages, 1)
}

impl TableRecipe for GgxEAvgSettings {
    table_recipe_accessors!();

    fn built_unnamed(&self) -> bool {
        self.build == BuildWhen::Always
    }
}

impl Kernel for GgxEAvgSettings {
    kernel_settings!();

    fn empty_table(&self) -> Result<Table> {
        one_channel_table(
            NAME,
            self.axes()?,
            "e_avg",
            "2 ∫ E(mu) mu dmu: the albedo of the GGX lobe with F = 1 averaged over the hemisphere",
        )
    }

    fn metadata(&self) -> Metadata {
        Metadata {
            integrand: format!(
                "E_avg = 2 ∫_0^1 E(mu) mu dmu, E = E_{{h~VNDF(wi)}}[G2(wi,wo) / G1(wi)] (ggx_e's integral); the mu \
                 integral by Gauss–Legendre, {} nodes per panel, panels growing from alpha / 2 at grazing views, \
                 none wider than {MAX_VIEW_PANEL}",
                self.mu_nodes
            ),
            masking: Some(self.masking),
            notes: vec![
                "Kulla & Conty 2017: the multiple-scattering lobe (1 - E(mu_i)) (1 - E(mu_o)) / (pi (1 - E_avg)) \
                 restores the energy a GGX lobe with F = 1 loses; E from ggx_e with the same masking."
                    .into(),
                super::driver::placement_note(self.placement),
            ],
            sampler: "visible-normal samples per view of the mu rule, the same points at every view".into(),
            ..Metadata::default()
        }
    }

    fn integrate(&self, table: &mut Table, points: &PointSet, progress: &dyn Progress) -> Result<Integrated> {
        let axis = table.axes[0].clone();
        let nodes: Vec<u64> = (0..axis.count as u64).collect();
        let estimates = estimate_cells(&nodes, &table.name, progress, |k| {
            average_albedo(self, self.method, points, axis.node_value(k as usize))
        });
        super::store_means(table, &estimates);
        Ok(Integrated::of(&estimates))
    }

    fn estimate_node(&self, points: &PointSet, position: &[f64]) -> Estimate {
        average_albedo(self, Method::PerCell, points, position[0])
    }

    fn exact_value(&self, quadrature: &VisibleNormalQuadrature, position: &[f64]) -> Vec<f64> {
        let alpha = position[0];
        let rule = view_rule(alpha, quadrature.nodes()).expect("a quadrature's node count");
        vec![rule.iter().map(|&(mu, weight)| weight * exact_albedo(quadrature, self.masking, mu, alpha)).sum()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recipes::settings::ReferenceConfig;

    fn small(alpha_count: usize) -> GgxEAvgSettings {
        GgxEAvgSettings {
            alpha_count,
            shared: SharedSettings {
                sampling: SamplingConfig::replicated(1 << 10),
                reference: ReferenceConfig { cells: alpha_count, nodes: 8 },
                interpolation: super::super::interpolation::InterpolationConfig { points: 0, nodes: 6 },
                ..GgxEAvgSettings::default().shared
            },
            ..GgxEAvgSettings::default()
        }
    }

    #[test]
    fn the_view_rule_integrates_two_mu_times_polynomials_exactly() {
        for alpha in [0.0, 1e-3, 0.3, 1.0] {
            let rule = view_rule(alpha, 4).unwrap();
            // 2 ∫ mu^(k+1) dmu = 2 / (k + 2).
            for k in 0..6 {
                let sum: f64 = rule.iter().map(|&(mu, w)| w * mu.powi(k)).sum();
                assert!((sum - 2.0 / (k as f64 + 2.0)).abs() < 1e-14, "alpha {alpha}, mu^{k}: {sum}");
            }
            assert!(rule.windows(2).all(|p| p[0].0 < p[1].0 && p[0].0 > 0.0 && p[1].0 < 1.0));
        }
        assert!(view_rule(0.5, 1).is_err());
    }

    #[test]
    fn a_mirror_keeps_everything_and_rough_lobes_lose_to_masking() {
        let quadrature = VisibleNormalQuadrature::new(8).unwrap();
        let settings = GgxEAvgSettings::default();
        assert!((settings.exact_value(&quadrature, &[0.0])[0] - 1.0).abs() < 1e-14);
        let values: Vec<f64> =
            [0.1, 0.4, 0.7, 1.0].iter().map(|&alpha| settings.exact_value(&quadrature, &[alpha])[0]).collect();
        assert!(values.windows(2).all(|v| v[1] < v[0]) && values[3] > 0.3, "{values:?}");
    }

    #[test]
    fn the_exact_value_converges_in_its_nodes() {
        let settings = GgxEAvgSettings::default();
        let fine = VisibleNormalQuadrature::new(16).unwrap();
        for (nodes, tolerance) in [(6, 1.5e-6), (8, 3e-7)] {
            let quadrature = VisibleNormalQuadrature::new(nodes).unwrap();
            for alpha in [1e-3, 0.05, 0.5, 1.0] {
                let (coarse, exact) =
                    (settings.exact_value(&quadrature, &[alpha])[0], settings.exact_value(&fine, &[alpha])[0]);
                assert!((coarse - exact).abs() < tolerance, "{nodes} nodes, alpha {alpha}: {coarse} vs {exact}");
            }
        }
    }

    #[test]
    fn agrees_with_the_exact_integral_and_with_views_drawn_by_their_cosine() {
        let build = small(8).build(3, &()).unwrap();
        let reference = build.provenance.error.reference.unwrap();
        let spread = build.provenance.error.replicate_standard_error.max;
        assert_eq!(reference.difference.count, 8);
        assert!(reference.difference.max < 5.0 * spread + 1e-6 && spread < 1e-3, "{reference:?}, spread {spread}");
        // Views drawn with density 2 mu and normals from D h.z: neither the rule in mu nor the
        // visible normals.
        let table = &build.table;
        for k in [3, 5, 7] {
            let alpha = table.axes[0].node_value(k);
            let independent = crate::recipes::test_estimators::average_albedo_d_sampled(
                MaskingShadowing::SmithHeightCorrelated,
                alpha,
                1 << 20,
            );
            let stored = table.data[k] as f64;
            assert!((stored - independent).abs() < 2e-3, "alpha {alpha}: table {stored}, independent {independent}");
        }
    }

    #[test]
    fn both_methods_agree() {
        let base = small(4);
        let fast = base.build(2, &()).unwrap().table;
        let per_cell = GgxEAvgSettings { method: Method::PerCell, ..base }.build(2, &()).unwrap().table;
        for (a, b) in fast.data.iter().zip(&per_cell.data) {
            assert!((a - b).abs() < 1e-5, "{a} vs {b}");
        }
    }
}
