//! The Karis split-sum environment-BRDF table (Karis 2013, "Real shading in Unreal Engine 4",
//! pp. 6-7): with Schlick's Fresnel `F = F0 + (1 - F0) Fc`, `Fc = (1 - v.h)^5`, the directional
//! albedo of a GGX BRDF splits into `F0 * scale + bias`, where
//!
//! ```text
//! scale(mu, alpha) = ∫ (1 - Fc(v.h)) D G2 / (4 mu) dl = E_{h ~ D_v}[ (1 - Fc) G2 / G1(v) ]
//! bias(mu, alpha)  = ∫      Fc(v.h)  D G2 / (4 mu) dl = E_{h ~ D_v}[      Fc  G2 / G1(v) ]
//! ```
//!
//! Karis importance-samples D and accumulates `Fc G (v.h) / ((n.h)(n.v))`; drawing from the visible
//! normals instead (Heitz 2018) estimates the same integral with less variance. Defaults follow
//! Unreal Engine 4: 512 x 512 texels, `x = n.v` at texel centres, row 0 = roughness 0 (its shaders
//! sample at `float2(NoV, Roughness)`, and Direct3D, Vulkan, Metal and WebGPU address row 0 at
//! `v = 0`), `alpha = roughness^2`, Schlick–Smith `k = alpha / 2`, stored as R16G16_FLOAT.

use serde::{Deserialize, Serialize};

use super::settings::{OutputConfig, SamplingConfig, SharedSettings};
use super::split_sum::{Orientation, RoughnessAxis, SplitSumSettings};
use super::{Integrated, Kernel, Metadata, TableRecipe};
use crate::error::Result;
use crate::formats::{FileFormat, Precision, SumRounding};
use crate::integrate::quadrature::VisibleNormalQuadrature;
use crate::integrate::{Estimate, Method, Progress, estimate_cosine_functions};
use crate::physics::{MaskingShadowing, schlick_weight};
use crate::sampling::sequence::PointSet;
use crate::table::{Axis, Channel, Table};

pub const NAME: &str = crate::table::TableKind::Karis.name();
/// One line for `tmlut list`.
pub const DESCRIPTION: &str =
    "Karis split-sum environment BRDF (UE4): scale and bias of F0 under Schlick Fresnel, 2D (n.v, roughness)";
/// Channels of the table.
pub const CHANNEL_COUNT: usize = 2;
/// The configuration keys of the node counts, axis 0 first.
pub const COUNT_KEYS: &[&str] = super::split_sum::COUNT_KEYS;

/// The Karis table's settings: the split-sum ones and its own.
pub type KarisSettings = SplitSumSettings<KarisOwn>;

/// What only the Karis table has.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct KarisOwn {
    /// How f16 storage rounds `scale` and `bias`: never above the integrated sum
    /// (`no-energy-gain`), or each to nearest (`nearest`).
    pub storage_rounding: SumRounding,
}

impl Default for KarisOwn {
    fn default() -> Self {
        KarisOwn { storage_rounding: SumRounding::NoEnergyGain }
    }
}

impl Default for KarisSettings {
    fn default() -> Self {
        KarisSettings {
            mu_count: 512,
            roughness_count: 512,
            alpha_range: [0.0, 1.0],
            roughness_axis: RoughnessAxis::Perceptual,
            orientation: Orientation::SmoothFirst,
            masking: MaskingShadowing::SchlickSmith,
            method: Method::Fast,
            shared: SharedSettings {
                sampling: SamplingConfig::replicated(4096),
                output: OutputConfig { formats: vec![FileFormat::Dds, FileFormat::Exr], precision: Precision::F16 },
                ..SharedSettings::default()
            },
            own: KarisOwn::default(),
        }
    }
}

impl KarisSettings {
    pub fn validate(&self) -> Result<()> {
        self.validate_split_sum(NAME, &FileFormat::for_table(2, false))
    }
}

impl KarisSettings {
    /// One node by the fast method (the f32 kernel), as [`Kernel::integrate`] computes it.
    pub fn estimate_node_fast(&self, points: &PointSet, position: &[f64]) -> Estimate {
        split_sum_terms(self.masking, Method::Fast, points, position[0], position[1])
    }
}

/// Both terms at one `(mu, alpha)`: `E[(1 - Fc) W]` and `E[Fc W]` with `Fc = (1 - wi.h)^5`.
fn split_sum_terms(masking: MaskingShadowing, method: Method, points: &PointSet, mu: f64, alpha: f64) -> Estimate {
    estimate_cosine_functions(mu, alpha, masking, method, points, split_sum_weights)
}

/// The weights of F0 and of 1 in Schlick's Fresnel at `c = wi.h`: `(1 - Fc, Fc)`, `Fc = (1 - c)^5`.
fn split_sum_weights(c: f64) -> [f64; 2] {
    let fc = schlick_weight(c);
    [1.0 - fc, fc]
}

/// The exact `(scale, bias)` at `(mu, alpha)` under `masking`, with the second moment of each
/// channel's integrand over the visible normals, `E[(W f_j)^2]`: the variance of one
/// visible-normal sample, which sets the noise of a Monte Carlo table of N samples
/// (`tmlut audit`). One pass of the quadrature gives both.
pub fn exact_with_second_moments(
    quadrature: &VisibleNormalQuadrature,
    masking: MaskingShadowing,
    mu: f64,
    alpha: f64,
) -> ([f64; CHANNEL_COUNT], [f64; CHANNEL_COUNT]) {
    let horizon = [crate::integrate::quadrature::Cut::MirrorCosine(0.0)];
    let [scale, bias, scale_squared, bias_squared] = quadrature.integrate(mu, alpha, &horizon, |s| {
        let weight = masking.visible_normal_weight(s.wi, s.wo, alpha);
        let [a, b] = split_sum_weights(s.cos_wi_h).map(|v| weight * v);
        [a, b, a * a, b * b]
    });
    ([scale, bias], [scale_squared, bias_squared])
}

/// What the manifest says of Unreal Engine 4's masking, where a split-sum table takes it.
pub(crate) fn schlick_smith_note(masking: MaskingShadowing) -> Option<String> {
    (masking == MaskingShadowing::SchlickSmith).then(|| {
        "Masking `schlick-smith`: G1(w) = w.z / (w.z (1 - k) + k) with k = alpha / 2, as Unreal Engine 4's \
         image-based lighting (Karis 2013, eq. 4); G2 is G1(v) G1(l)."
            .into()
    })
}

impl TableRecipe for KarisSettings {
    table_recipe_accessors!();
}

impl Kernel for KarisSettings {
    kernel_settings!();

    fn empty_table(&self) -> Result<Table> {
        let channels = vec![
            Channel::new("scale", "multiplies F0: ∫ (1 - (1 - v.h)^5) D G2 / (4 n.v) dl"),
            Channel::new("bias", "added: ∫ (1 - v.h)^5 D G2 / (4 n.v) dl"),
        ];
        Table::zeros(NAME, self.axes()?, channels)
    }

    fn metadata(&self) -> Metadata {
        let mut notes = vec!["Runtime: FGD ≈ F0 * scale + bias (Schlick Fresnel).".to_string()];
        notes.extend(schlick_smith_note(self.masking));
        notes.extend(self.layout_notes());
        Metadata {
            integrand: "scale = E_{h~VNDF(v)}[(1 - (1 - v.h)^5) G2(v,l) / G1(v)], bias = E_{h~VNDF(v)}[(1 - v.h)^5 G2(v,l) / G1(v)], l = reflect(v, h)".into(),
            masking: Some(self.masking),
            notes,
            sampler: "visible-normal samples per texel".into(),
            channel_sum: Some(self.own.storage_rounding),
            ..Metadata::default()
        }
    }

    cosine_function_kernel!(split_sum_weights);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recipes::settings::ReferenceConfig;

    fn small_settings() -> KarisSettings {
        KarisSettings {
            mu_count: 16,
            roughness_count: 16,
            shared: SharedSettings {
                sampling: SamplingConfig::replicated(1024),
                reference: ReferenceConfig { cells: 8, nodes: 8 },
                ..KarisSettings::default().shared
            },
            ..KarisSettings::default()
        }
    }

    #[test]
    fn default_axes_follow_unreal_engine_4() {
        let axes = KarisSettings::default().axes().unwrap();
        assert_eq!((axes[0].count, axes[1].count), (512, 512));
        // Row 0 is the smoothest texel centre: roughness 0.5/512, sampled at v = roughness.
        let roughness0 = axes[1].node_value(0).sqrt();
        assert!((roughness0 - 0.5 / 512.0).abs() < 1e-12, "{roughness0}");
        assert!((axes[1].texture_coordinate(0.3f64.powi(2)) - 0.3).abs() < 1e-12);
        assert!((axes[0].node_value(0) - 0.5 / 512.0).abs() < 1e-15);
        // The GL-era image order is the same rows reversed, and an old configuration still names it.
        let bottom_up = KarisSettings { orientation: Orientation::BottomUpImage, ..KarisSettings::default() };
        assert!((bottom_up.axes().unwrap()[1].node_value(0).sqrt() - (1.0 - 0.5 / 512.0)).abs() < 1e-12);
        let config = crate::config::Config::from_toml("[karis]\norientation = \"rough-first\"\n", "t").unwrap();
        assert_eq!(config.karis.orientation, Orientation::BottomUpImage);
    }

    #[test]
    fn smooth_surface_gives_schlick_at_the_view_angle() {
        // alpha -> 0: the lobe is a mirror, so scale = 1 - Fc(mu) and bias = Fc(mu).
        let settings = KarisSettings { alpha_range: [0.0, 1e-8], ..small_settings() };
        let build = settings.build(1, &()).unwrap();
        for i in 0..16 {
            let mu = build.table.axes[0].node_value(i);
            let v = build.table.node(&[i, 15]);
            let fc = schlick_weight(mu);
            assert!((v[0] as f64 - (1.0 - fc)).abs() < 1e-5, "mu {mu}: {v:?}");
            assert!((v[1] as f64 - fc).abs() < 1e-5, "mu {mu}: {v:?}");
        }
    }

    #[test]
    fn agrees_with_karis_own_estimator() {
        let build = small_settings().build(7, &()).unwrap();
        let stats = build.table.stats();
        assert_eq!(stats.nan_count + stats.infinite_count, 0);
        assert!(stats.min >= 0.0 && stats.max <= 1.0, "{stats:?}");
        for index in [[0, 0], [15, 0], [7, 7], [3, 12], [12, 3], [15, 15]] {
            let position = build.table.node_position(&index);
            let expected = crate::recipes::test_estimators::d_importance_sampled(
                MaskingShadowing::SchlickSmith,
                position[0],
                position[1],
                1 << 20,
            );
            let stored = build.table.node(&index);
            for c in 0..2 {
                assert!(
                    (stored[c] as f64 - expected[c]).abs() < 3e-3,
                    "node {index:?} {position:?} channel {c}: table {stored:?}, Karis {expected:?}"
                );
            }
        }
        let reference = build.provenance.error.reference.as_ref().unwrap();
        assert_eq!(reference.difference.count, 16);
        assert!(reference.difference.max < 2e-3, "{reference:?}");
        assert!(build.provenance.error.replicate_standard_error.max < 2e-3, "{:?}", build.provenance.error);
    }

    #[test]
    fn same_seed_same_table_and_different_seed_different_table() {
        let settings = small_settings();
        let a = settings.build(3, &()).unwrap();
        let b = settings.build(3, &()).unwrap();
        let c = settings.build(4, &()).unwrap();
        assert_eq!(a.table.data, b.table.data);
        assert_ne!(a.table.data, c.table.data);
    }
}
