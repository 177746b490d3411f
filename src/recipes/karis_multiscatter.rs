//! The Karis split sum arranged for multiple-scattering compensation (Fdez-Agüera 2019; Filament's
//! `DFG` table with `--ibl-dfg-multiscatter`): with Schlick's Fresnel `F = F0 + (F90 - F0) Fc`,
//! `Fc = (1 - v.h)^5`, the same two integrals as Karis's table, kept as
//!
//! ```text
//! bias(mu, alpha)   = ∫ Fc(v.h) D G2 / (4 mu) dl = E_{h ~ D_v}[ Fc G2 / G1(v) ]
//! albedo(mu, alpha) = ∫       D G2 / (4 mu) dl = E_{h ~ D_v}[    G2 / G1(v) ]   (= scale + bias)
//! ```
//!
//! so that one texture gives the single-scattering albedo `mix(bias, albedo, F0)` (`F90 = 1`) and
//! the albedo with `F = 1` an energy compensation divides by (`1 + F0 (1 / albedo - 1)`). Karis's
//! kernel with other channel functions (`karis.rs`); `albedo` is also `ggx_e`'s integral. The
//! layout keys are the split-sum tables' (`split_sum.rs`); by default Filament's: 128 x 128 texel
//! centres over `(n.v, perceptual roughness)`, height-correlated masking, f16. Not part of the
//! default set: built when named (`--only karis_multiscatter`) or with `build = "always"`.

use serde::{Deserialize, Serialize};

use super::settings::{BuildWhen, OutputConfig, ReferenceConfig, SamplingConfig, SharedSettings};
use super::split_sum::{Orientation, RoughnessAxis, SplitSumSettings};
use super::{Integrated, Kernel, Metadata, TableRecipe};
use crate::error::Result;
use crate::formats::{FileFormat, Precision};
use crate::integrate::quadrature::VisibleNormalQuadrature;
use crate::integrate::{Estimate, Method, Progress, estimate_cosine_functions};
use crate::physics::{MaskingShadowing, schlick_weight};
use crate::sampling::sequence::PointSet;
use crate::table::{Axis, Channel, Table};

pub const NAME: &str = crate::table::TableKind::KarisMultiscatter.name();
/// One line for `tmlut list`.
pub const DESCRIPTION: &str = "Karis split sum for multiple scattering (Filament): bias (F90 part) and albedo with \
                               F = 1, 2D (n.v, roughness); built when named";
/// Channels of the table.
pub const CHANNEL_COUNT: usize = 2;
/// The configuration keys of the node counts, axis 0 first.
pub const COUNT_KEYS: &[&str] = super::split_sum::COUNT_KEYS;

/// The multiple-scattering split sum's settings: the split-sum ones and its own.
pub type KarisMultiscatterSettings = SplitSumSettings<MultiscatterOwn>;

/// What only this table has.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MultiscatterOwn {
    /// Which builds make the table: only those naming it, or every build of the configuration.
    pub build: BuildWhen,
}

impl Default for MultiscatterOwn {
    fn default() -> Self {
        MultiscatterOwn { build: BuildWhen::Named }
    }
}

impl Default for KarisMultiscatterSettings {
    fn default() -> Self {
        KarisMultiscatterSettings {
            mu_count: 128,
            roughness_count: 128,
            alpha_range: [0.0, 1.0],
            roughness_axis: RoughnessAxis::Perceptual,
            orientation: Orientation::SmoothFirst,
            masking: MaskingShadowing::SmithHeightCorrelated,
            method: Method::Fast,
            shared: SharedSettings {
                sampling: SamplingConfig::replicated(1 << 14),
                reference: ReferenceConfig { cells: 32, nodes: 8 },
                // Height-correlated masking: 6 nodes are 1.7e-4 off at grazing views of rough lobes.
                interpolation: super::interpolation::InterpolationConfig { points: 2048, nodes: 8 },
                output: OutputConfig { formats: vec![FileFormat::Dds], precision: Precision::F16 },
            },
            own: MultiscatterOwn::default(),
        }
    }
}

impl KarisMultiscatterSettings {
    pub fn validate(&self) -> Result<()> {
        self.validate_split_sum(NAME, &FileFormat::for_table(2, false))
    }

    /// One node by the fast method (the f32 kernel), as [`Kernel::integrate`] computes it.
    pub fn estimate_node_fast(&self, points: &PointSet, position: &[f64]) -> Estimate {
        estimate_cosine_functions(position[0], position[1], self.masking, Method::Fast, points, bias_and_albedo)
    }
}

/// The channel functions of `c = wi.h`: the weight of `F90` in Schlick's Fresnel, `Fc = (1 - c)^5`,
/// and 1.
fn bias_and_albedo(c: f64) -> [f64; 2] {
    [schlick_weight(c), 1.0]
}

impl TableRecipe for KarisMultiscatterSettings {
    table_recipe_accessors!();

    fn built_unnamed(&self) -> bool {
        self.own.build == BuildWhen::Always
    }
}

impl Kernel for KarisMultiscatterSettings {
    kernel_settings!();

    fn empty_table(&self) -> Result<Table> {
        let channels = vec![
            Channel::new("bias", "the F90 part: ∫ (1 - v.h)^5 D G2 / (4 n.v) dl"),
            Channel::new("albedo", "the albedo with F = 1: ∫ D G2 / (4 n.v) dl (scale + bias)"),
        ];
        Table::zeros(NAME, self.axes()?, channels)
    }

    fn metadata(&self) -> Metadata {
        let mut notes = vec![
            "Runtime: single scattering F0 * albedo + (1 - F0) * bias (mix(bias, albedo, F0), F90 = 1); energy \
             compensation 1 + F0 (1 / albedo - 1) (Filament's multiscatter DFG)."
                .to_string(),
            "Stored to nearest: albedo stays at most 1 (1 is a half float) and bias at most albedo (rounding keeps \
             their order)."
                .into(),
        ];
        notes.extend(super::karis::schlick_smith_note(self.masking));
        notes.extend(self.layout_notes());
        Metadata {
            integrand: "bias = E_{h~VNDF(v)}[(1 - v.h)^5 G2(v,l) / G1(v)], albedo = E_{h~VNDF(v)}[G2(v,l) / G1(v)], \
                        l = reflect(v, h)"
                .into(),
            masking: Some(self.masking),
            notes,
            sampler: "visible-normal samples per texel".into(),
            ..Metadata::default()
        }
    }

    cosine_function_kernel!(bias_and_albedo);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recipes::karis::KarisSettings;

    fn small(masking: MaskingShadowing) -> KarisMultiscatterSettings {
        KarisMultiscatterSettings {
            mu_count: 12,
            roughness_count: 10,
            masking,
            shared: SharedSettings {
                sampling: SamplingConfig::replicated(4096),
                reference: ReferenceConfig { cells: 120, nodes: 8 },
                interpolation: super::super::interpolation::InterpolationConfig { points: 0, nodes: 8 },
                ..KarisMultiscatterSettings::default().shared
            },
            ..KarisMultiscatterSettings::default()
        }
    }

    #[test]
    fn holds_karis_bias_and_its_albedo_scale_plus_bias_on_the_same_points() {
        let settings = small(MaskingShadowing::SchlickSmith);
        let karis = KarisSettings {
            mu_count: settings.mu_count,
            roughness_count: settings.roughness_count,
            shared: settings.shared.clone(),
            ..KarisSettings::default()
        };
        let (multiscatter, karis) = (settings.build(6, &()).unwrap().table, karis.build(6, &()).unwrap().table);
        assert_eq!(multiscatter.axes, karis.axes);
        for n in 0..karis.node_count() {
            let index = karis.node_index(n);
            let ([bias, albedo], [scale, karis_bias]) =
                (multiscatter.node(&index).try_into().unwrap(), karis.node(&index).try_into().unwrap());
            assert_eq!(bias, karis_bias, "node {index:?}");
            // Each is a sum of the same samples in f64, stored in f32.
            assert!((albedo as f64 - (scale as f64 + bias as f64)).abs() < 1e-6, "node {index:?}");
        }
    }

    #[test]
    fn its_albedo_is_ggx_e_where_their_layouts_agree() {
        let settings = small(MaskingShadowing::SmithHeightCorrelated);
        let e = crate::recipes::ggx_e::GgxESettings {
            mu_count: settings.mu_count,
            alpha_count: settings.roughness_count,
            placement: crate::table::Placement::CellCentred,
            axes: crate::recipes::settings::MuAlphaAxes {
                mu_axis: crate::recipes::spacing::CosineAxis::Uniform,
                ..Default::default()
            },
            masking: settings.masking,
            shared: settings.shared.clone(),
            ..Default::default()
        };
        let (multiscatter, e) = (settings.build(3, &()).unwrap().table, e.build(3, &()).unwrap().table);
        assert_eq!(multiscatter.axes, e.axes);
        let albedo: Vec<f32> = multiscatter.channel_values(1).collect();
        assert_eq!(albedo, e.data);
    }

    #[test]
    fn agrees_with_the_exact_integral_and_with_importance_sampling_of_d() {
        let build = small(MaskingShadowing::SmithHeightCorrelated).build(2, &()).unwrap();
        let table = &build.table;
        let stats = table.stats();
        assert_eq!(stats.nan_count + stats.infinite_count, 0);
        assert!(stats.min >= 0.0 && stats.max <= 1.0, "{stats:?}");
        let reference = build.provenance.error.reference.unwrap();
        let spread = build.provenance.error.replicate_standard_error.max;
        assert_eq!(reference.difference.count, 240);
        assert!(reference.difference.max < 5.0 * spread && spread < 2e-3, "{reference:?}, spread {spread}");
        for index in [[0, 0], [11, 0], [5, 5], [2, 9], [11, 9]] {
            let position = table.node_position(&index);
            let [scale, bias] = crate::recipes::test_estimators::d_importance_sampled(
                MaskingShadowing::SmithHeightCorrelated,
                position[0],
                position[1],
                1 << 20,
            );
            let stored = table.node(&index);
            for (channel, expected) in [bias, scale + bias].into_iter().enumerate() {
                let value = stored[channel] as f64;
                assert!((value - expected).abs() < 3e-3, "node {position:?} channel {channel}: {value} vs {expected}");
            }
        }
    }
}
