//! E: the directional albedo of a GGX lobe with `F = 1`, the table an energy-compensating
//! renderer divides by (Kulla & Conty 2017, "Revisiting physically based shading at Imageworks";
//! Turquin 2019):
//!
//! ```text
//! E(mu, alpha) = ∫ D G2 / (4 mu) dwo = E_{h ~ D_wi}[ G2(wi, wo) / G1(wi) ]
//! ```
//!
//! It is GD's integral (`gd.rs`, whose integrand it shares): with separable masking and GD's axes
//! the two tables hold the same values. What differs is what engines need of it: the masking model
//! (height-correlated by default, as Blender Cycles and Filament integrate their E), where the
//! nodes sit (`placement`: node-aligned as Cycles, or at texel centres as Filament and three.js
//! place their tables) and the axes' ranges and spacing. Not part of the default set: built when
//! named (`--only ggx_e`) or with `build = "always"`.

use serde::{Deserialize, Serialize};

use super::driver::one_channel_table;
use super::gd::albedo;
use super::interpolation::InterpolationConfig;
use super::settings::{BuildWhen, MuAlphaAxes, ReferenceConfig, SharedSettings, check_counts};
use super::spacing::placed_mu_alpha_axes;
use super::{Integrated, Kernel, Metadata, TableRecipe};
use crate::error::Result;
use crate::formats::FileFormat;
use crate::integrate::quadrature::VisibleNormalQuadrature;
use crate::integrate::{Estimate, Method, Progress};
use crate::physics::MaskingShadowing;
use crate::sampling::sequence::PointSet;
use crate::table::{Axis, Placement, Table};

pub const NAME: &str = crate::table::TableKind::GgxE.name();
/// One line for `tmlut list`.
pub const DESCRIPTION: &str =
    "GGX albedo with F = 1 for energy compensation (Kulla & Conty 2017), 2D (mu, alpha); built when named";
/// Channels of the table.
pub const CHANNEL_COUNT: usize = 1;
/// The configuration keys of the node counts, axis 0 first.
pub const COUNT_KEYS: &[&str] = &["mu_count", "alpha_count"];

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GgxESettings {
    /// Which builds make the table: only those naming it, or every build of the configuration.
    pub build: BuildWhen,
    pub mu_count: usize,
    pub alpha_count: usize,
    /// Nodes on the range ends (`node-aligned`) or at the centres of equal cells (`cell-centred`).
    pub placement: Placement,
    /// The ranges and spacings of `mu` and `alpha`.
    #[serde(flatten)]
    pub axes: MuAlphaAxes,
    pub masking: MaskingShadowing,
    pub method: Method,
    #[serde(flatten)]
    pub shared: SharedSettings,
}

impl Default for GgxESettings {
    fn default() -> Self {
        GgxESettings {
            build: BuildWhen::Named,
            mu_count: 64,
            alpha_count: 64,
            placement: Placement::NodeAligned,
            axes: MuAlphaAxes::default(),
            masking: MaskingShadowing::SmithHeightCorrelated,
            method: Method::Fast,
            shared: SharedSettings {
                // Height-correlated masking at grazing views of rough lobes: 8 nodes per panel are
                // up to 1.4e-4 off at the mu = 0 nodes, 12 agree with 16 (6 nodes are 1.7e-4 off
                // between nodes, 8 within 2.2e-5).
                reference: ReferenceConfig { cells: 32, nodes: 12 },
                interpolation: InterpolationConfig { points: 2048, nodes: 8 },
                ..SharedSettings::default()
            },
        }
    }
}

impl GgxESettings {
    pub fn validate(&self) -> Result<()> {
        check_counts(NAME, COUNT_KEYS, &[self.mu_count, self.alpha_count])?;
        self.axes.validate(NAME)?;
        self.shared.validate(NAME, &FileFormat::for_table(2, false))
    }

    pub fn axes(&self) -> Result<Vec<Axis>> {
        let axes = &self.axes;
        let counts = [self.mu_count, self.alpha_count];
        let ranges = [axes.mu_range, axes.alpha_range];
        Ok(placed_mu_alpha_axes(self.placement, counts, ranges, axes.mu_axis, axes.roughness_axis)?.into())
    }

    /// One node by the fast method (the f32 kernel), as [`Kernel::integrate`] computes it.
    pub fn estimate_node_fast(&self, points: &PointSet, position: &[f64]) -> Estimate {
        albedo(self.masking, Method::Fast, points, position[0], position[1])
    }
}

impl TableRecipe for GgxESettings {
    table_recipe_accessors!();

    fn built_unnamed(&self) -> bool {
        self.build == BuildWhen::Always
    }
}

impl Kernel for GgxESettings {
    kernel_settings!();

    fn empty_table(&self) -> Result<Table> {
        one_channel_table(NAME, self.axes()?, "e", "∫ D G2 / (4 mu) dwo: the albedo of the GGX lobe with F = 1")
    }

    fn metadata(&self) -> Metadata {
        Metadata {
            integrand: "E = E_{h~VNDF(wi)}[G2(wi,wo) / G1(wi)], wo = reflect(wi, h): GD's integral, F = 1".into(),
            masking: Some(self.masking),
            notes: vec![
                "Energy compensation (Kulla & Conty 2017): a lobe f scaled by 1 + (1 - E(mu)) / E(mu), or with the \
                 multiple-scattering lobe (1 - E(mu_i)) (1 - E(mu_o)) / (pi (1 - E_avg)) of ggx_e_avg added."
                    .into(),
                super::driver::placement_note(self.placement),
                super::driver::grazing_note(),
            ],
            sampler: "visible-normal measure per (mu, alpha)".into(),
            ..Metadata::default()
        }
    }

    cosine_function_kernel!(super::gd::without_fresnel);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recipes::gd::{GdSettings, exact_albedo};
    use crate::recipes::settings::SamplingConfig;

    /// A table of `mu_count x alpha_count` nodes with 2^12 samples per node, every node checked.
    fn small(mu_count: usize, alpha_count: usize, masking: MaskingShadowing) -> GgxESettings {
        GgxESettings {
            mu_count,
            alpha_count,
            masking,
            shared: SharedSettings {
                sampling: SamplingConfig::replicated(1 << 12),
                reference: ReferenceConfig { cells: mu_count * alpha_count, nodes: 12 },
                ..GgxESettings::default().shared
            },
            ..GgxESettings::default()
        }
    }

    #[test]
    fn with_separable_masking_it_is_gd() {
        let e = small(6, 5, MaskingShadowing::SmithSeparable);
        let gd = GdSettings { mu_count: 6, alpha_count: 5, shared: e.shared.clone(), ..GdSettings::default() };
        let (e, gd) = (e.build(4, &()).unwrap().table, gd.build(4, &()).unwrap().table);
        assert_eq!(e.axes, gd.axes);
        assert_eq!(e.data, gd.data);
    }

    #[test]
    fn agrees_with_the_exact_integral_and_with_importance_sampling_of_d() {
        let build = small(8, 8, MaskingShadowing::SmithHeightCorrelated).build(5, &()).unwrap();
        let table = &build.table;
        let stats = table.stats();
        assert_eq!(stats.nan_count + stats.infinite_count, 0);
        assert!(stats.min > 0.3 && stats.max <= 1.0, "{stats:?}");
        // Every node against the quadrature, within the Monte Carlo error of its 2^12 samples.
        let reference = build.provenance.error.reference.unwrap();
        let spread = build.provenance.error.replicate_standard_error.max;
        assert_eq!(reference.difference.count, 64);
        assert!(reference.difference.max < 5.0 * spread && spread < 1e-3, "{reference:?}, spread {spread}");
        // An estimator that shares nothing with the visible normals: D importance sampling with
        // pseudo-random points (Karis's), whose scale + bias is E with F = 1.
        for index in [[1, 1], [7, 2], [3, 5], [7, 7]] {
            let position = table.node_position(&index);
            let [scale, bias] = crate::recipes::test_estimators::d_importance_sampled(
                MaskingShadowing::SmithHeightCorrelated,
                position[0],
                position[1],
                1 << 20,
            );
            let stored = table.node(&index)[0] as f64;
            assert!(
                (stored - (scale + bias)).abs() < 3e-3,
                "node {position:?}: table {stored}, D sampling {}",
                scale + bias
            );
        }
    }

    #[test]
    fn height_correlated_masking_loses_less_than_separable() {
        // 1 / (1 + Λ(wi) + Λ(wo)) >= 1 / ((1 + Λ(wi)) (1 + Λ(wo))) for every pair of directions.
        let quadrature = VisibleNormalQuadrature::new(8).unwrap();
        for (mu, alpha) in [(0.1, 0.5), (0.5, 1.0), (0.9, 0.2)] {
            let correlated = exact_albedo(&quadrature, MaskingShadowing::SmithHeightCorrelated, mu, alpha);
            let separable = exact_albedo(&quadrature, MaskingShadowing::SmithSeparable, mu, alpha);
            assert!(correlated > separable && correlated <= 1.0, "mu {mu} alpha {alpha}: {correlated} vs {separable}");
        }
    }

    #[test]
    fn nodes_sit_where_placement_says() {
        let centred = GgxESettings { mu_count: 16, placement: Placement::CellCentred, ..GgxESettings::default() };
        let axes = centred.axes().unwrap();
        // Texel 0 of 16 sits at 1/32 of the mapped range, texel 15 at 31/32.
        assert!((axes[0].coordinate(axes[0].node_value(0)) - 0.5 / 16.0).abs() < 1e-12);
        assert!((axes[0].coordinate(axes[0].node_value(15)) - 15.5 / 16.0).abs() < 1e-12);
        let aligned = GgxESettings::default().axes().unwrap();
        assert_eq!((aligned[0].node_value(0), aligned[0].node_value(63)), (0.0, 1.0));
    }

    #[test]
    fn it_is_built_only_when_named_unless_asked_always() {
        let config = crate::config::Config::default();
        let unnamed = crate::pipeline::resolve_tables(&config, None).unwrap();
        assert!(!unnamed.contains(&crate::table::TableKind::GgxE), "{unnamed:?}");
        let named = crate::pipeline::resolve_tables(&config, Some(&["ggx_e".into()])).unwrap();
        assert_eq!(named, vec![crate::table::TableKind::GgxE]);
        let always = crate::config::Config::from_toml("[ggx_e]\nbuild = \"always\"\n", "t").unwrap();
        assert!(crate::pipeline::resolve_tables(&always, None).unwrap().contains(&crate::table::TableKind::GgxE));
    }
}
