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
//! Unreal Engine 4: 512 x 512 texels, `x = n.v` at texel centres, row 0 = roughness 1,
//! `alpha = roughness^2`, Schlick–Smith `k = alpha / 2`, stored as R16G16_FLOAT.

use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::{ErrorRecord, SamplingRecord, TableBuild, compare_to_reference, replicate_error};
use crate::config::{OutputConfig, ReferenceConfig, SamplingConfig, check_count, check_unit_range};
use crate::error::Result;
use crate::formats::{FileFormat, Precision};
use crate::integrate::{Estimate, MicrofacetSample, Progress, estimate_cells, estimate_visible_normal_integral};
use crate::physics::{MaskingShadowing, schlick_weight};
use crate::sampling::sequence::{PointSet, SamplePlan};
use crate::table::{Axis, Channel, Mapping, Table};

pub const NAME: &str = "karis";

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

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct KarisSettings {
    /// Texels along `x = n.v`.
    pub mu_count: usize,
    /// Texels along roughness.
    pub roughness_count: usize,
    /// Range of GGX alpha covered, before orientation.
    pub alpha_range: [f64; 2],
    pub roughness_axis: RoughnessAxis,
    pub orientation: Orientation,
    pub masking: MaskingShadowing,
    pub sampling: SamplingConfig,
    pub reference: ReferenceConfig,
    pub output: OutputConfig,
}

impl Default for KarisSettings {
    fn default() -> Self {
        KarisSettings {
            mu_count: 512,
            roughness_count: 512,
            alpha_range: [0.0, 1.0],
            roughness_axis: RoughnessAxis::Perceptual,
            orientation: Orientation::RoughFirst,
            masking: MaskingShadowing::SchlickSmith,
            sampling: SamplingConfig { samples: 1024, replicates: 4 },
            reference: ReferenceConfig { cells: 64, samples: 1 << 20 },
            output: OutputConfig { formats: vec![FileFormat::Dds, FileFormat::Exr], precision: Precision::F16 },
        }
    }
}

impl KarisSettings {
    pub fn validate(&self) -> Result<()> {
        check_count("karis.mu_count", self.mu_count)?;
        check_count("karis.roughness_count", self.roughness_count)?;
        check_unit_range("karis.alpha_range", self.alpha_range)?;
        self.sampling.validate("karis.sampling")?;
        self.reference.validate("karis.reference")?;
        self.output.validate("karis.output", &[FileFormat::Dds, FileFormat::Exr])
    }

    /// The table's axes: `mu` cell-centred over [0, 1]; `alpha` cell-centred, spaced and ordered as
    /// configured.
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
}

/// The two split-sum terms at one visible-normal sample: `(1 - Fc) W` and `Fc W`, with
/// `W = G2 / G1(v)`.
fn accumulate_split_sum(masking: MaskingShadowing, alpha: f64) -> impl Fn(&MicrofacetSample, &mut [f64]) {
    move |sample, sums| {
        let weight = masking.visible_normal_weight(sample.wi, sample.wo, alpha);
        let fc = schlick_weight(sample.cos_wi_h);
        sums[0] += (1.0 - fc) * weight;
        sums[1] += fc * weight;
    }
}

/// Both terms at one cell of the table.
fn estimate_cell(table: &Table, masking: MaskingShadowing, points: &PointSet, cell: u64) -> Estimate {
    let position = table.node_position(&table.node_index(cell as usize));
    let (mu, alpha) = (position[0], position[1]);
    estimate_visible_normal_integral(mu, alpha, points, 2, accumulate_split_sum(masking, alpha))
}

pub fn build(settings: &KarisSettings, seed: u64, progress: &dyn Progress) -> Result<TableBuild> {
    settings.validate()?;
    let started = Instant::now();
    let plan = SamplePlan::new(settings.sampling.samples, settings.sampling.replicates)?;
    let channels = vec![
        Channel::new("scale", "multiplies F0: ∫ (1 - (1 - v.h)^5) D G2 / (4 n.v) dl"),
        Channel::new("bias", "added: ∫ (1 - v.h)^5 D G2 / (4 n.v) dl"),
    ];
    let mut table = Table::zeros(NAME, settings.axes()?, channels)?;
    let cells: Vec<u64> = (0..table.node_count() as u64).collect();
    let points = PointSet::new(plan, seed);
    let estimates =
        estimate_cells(&cells, "karis", progress, |cell| estimate_cell(&table, settings.masking, &points, cell));
    for (value, estimate) in table.data.chunks_mut(2).zip(&estimates) {
        value[0] = estimate.mean[0] as f32;
        value[1] = estimate.mean[1] as f32;
    }
    let reference = compare_to_reference(&table, &settings.reference, seed, progress, |cell, reference_points| {
        estimate_cell(&table, settings.masking, reference_points, cell)
    })?;
    let wall_time_s = started.elapsed().as_secs_f64();

    let mut notes = vec![
        "Runtime: FGD ≈ F0 * scale + bias (Schlick Fresnel).".to_string(),
        "Texture coordinate x = n.v at texel centres (cell-centred); sample with clamp addressing, linear data (not sRGB).".to_string(),
    ];
    notes.push(match (settings.roughness_axis, settings.orientation) {
        (RoughnessAxis::Perceptual, Orientation::RoughFirst) => {
            "Row 0 = roughness 1: v = 1 - roughness, roughness = sqrt(alpha) (Unreal Engine 4 convention).".into()
        }
        (RoughnessAxis::Perceptual, Orientation::SmoothFirst) => "v = roughness = sqrt(alpha).".into(),
        (RoughnessAxis::Alpha, Orientation::RoughFirst) => "Row 0 = alpha 1: v = 1 - alpha (linear in GGX alpha).".into(),
        (RoughnessAxis::Alpha, Orientation::SmoothFirst) => "v = alpha (linear in GGX alpha).".into(),
    });
    Ok(TableBuild {
        table,
        integrand: "scale = E_{h~VNDF(v)}[(1 - (1 - v.h)^5) G2(v,l) / G1(v)], bias = E_{h~VNDF(v)}[(1 - v.h)^5 G2(v,l) / G1(v)], l = reflect(v, h)".into(),
        masking: Some(settings.masking),
        notes,
        sampling: SamplingRecord {
            method: "visible-normal Monte Carlo, per cell".into(),
            sampler: format!(
                "Owen-scrambled Sobol (sobol_burley), {} replicates x {} points",
                plan.replicates, plan.points
            ),
            samples_per_cell: plan.total(),
            replicates: plan.replicates,
            seed,
        },
        error: ErrorRecord { replicate_standard_error: replicate_error(&estimates), reference },
        wall_time_s,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small_settings() -> KarisSettings {
        KarisSettings {
            mu_count: 16,
            roughness_count: 16,
            sampling: SamplingConfig { samples: 1024, replicates: 4 },
            reference: ReferenceConfig { cells: 8, samples: 1 << 16 },
            ..KarisSettings::default()
        }
    }

    #[test]
    fn default_axes_follow_unreal_engine_4() {
        let axes = KarisSettings::default().axes().unwrap();
        assert_eq!((axes[0].count, axes[1].count), (512, 512));
        // Row 0 is the roughest texel centre: roughness 1 - 0.5/512.
        let roughness0 = axes[1].node_value(0).sqrt();
        assert!((roughness0 - (1.0 - 0.5 / 512.0)).abs() < 1e-12, "{roughness0}");
        assert!((axes[0].node_value(0) - 0.5 / 512.0).abs() < 1e-15);
    }

    #[test]
    fn smooth_surface_gives_schlick_at_the_view_angle() {
        // alpha -> 0: the lobe is a mirror, so scale = 1 - Fc(mu) and bias = Fc(mu).
        let settings = KarisSettings { alpha_range: [0.0, 1e-8], ..small_settings() };
        let build = build(&settings, 1, &()).unwrap();
        for i in 0..16 {
            let mu = build.table.axes[0].node_value(i);
            let v = build.table.node(&[i, 15]);
            let fc = schlick_weight(mu);
            assert!((v[0] as f64 - (1.0 - fc)).abs() < 1e-5, "mu {mu}: {v:?}");
            assert!((v[1] as f64 - fc).abs() < 1e-5, "mu {mu}: {v:?}");
        }
    }

    /// Karis's own estimator (2013, p. 7): normals drawn from `D(h) h.z`, weight
    /// `G (v.h) / ((n.h)(n.v))`, pseudo-random points. Independent of the visible-normal path.
    fn karis_importance_sampled(mu: f64, alpha: f64, samples: u32) -> [f64; 2] {
        use crate::physics::reflect;
        use glam::DVec3;
        let v = crate::physics::direction_from_cosine(mu);
        let mut state = 0x853c_49e6_748f_ea9b_u64;
        let mut uniform = || {
            // xorshift64*: enough for a test, and unrelated to the Sobol points of the table.
            state ^= state >> 12;
            state ^= state << 25;
            state ^= state >> 27;
            (state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut scale, mut bias) = (0.0, 0.0);
        for _ in 0..samples {
            let (u1, u2) = (uniform(), uniform());
            let cos_h = ((1.0 - u1) / (1.0 + (alpha * alpha - 1.0) * u1)).sqrt();
            let sin_h = (1.0 - cos_h * cos_h).max(0.0).sqrt();
            let phi = 2.0 * std::f64::consts::PI * u2;
            let h = DVec3::new(sin_h * phi.cos(), sin_h * phi.sin(), cos_h);
            let l = reflect(v, h);
            let v_h = v.dot(h);
            if l.z <= 0.0 || v_h <= 0.0 {
                continue;
            }
            let g = MaskingShadowing::SchlickSmith.g2(v, l, alpha);
            let weight = g * v_h / (h.z * v.z);
            let fc = schlick_weight(v_h);
            scale += (1.0 - fc) * weight;
            bias += fc * weight;
        }
        [scale / samples as f64, bias / samples as f64]
    }

    #[test]
    fn agrees_with_karis_own_estimator() {
        let build = build(&small_settings(), 7, &()).unwrap();
        let stats = build.table.stats();
        assert_eq!(stats.nan_count + stats.infinite_count, 0);
        assert!(stats.min >= 0.0 && stats.max <= 1.0, "{stats:?}");
        for index in [[0, 0], [15, 0], [7, 7], [3, 12], [12, 3], [15, 15]] {
            let position = build.table.node_position(&index);
            let expected = karis_importance_sampled(position[0], position[1], 1 << 20);
            let stored = build.table.node(&index);
            for c in 0..2 {
                assert!(
                    (stored[c] as f64 - expected[c]).abs() < 3e-3,
                    "node {index:?} {position:?} channel {c}: table {stored:?}, Karis {expected:?}"
                );
            }
        }
        let reference = build.error.reference.as_ref().unwrap();
        assert_eq!(reference.difference.count, 16);
        assert!(reference.difference.max < 2e-3, "{reference:?}");
        assert!(build.error.replicate_standard_error.max < 2e-3, "{:?}", build.error);
    }

    #[test]
    fn same_seed_same_table_and_different_seed_different_table() {
        let settings = small_settings();
        let a = build(&settings, 3, &()).unwrap();
        let b = build(&settings, 3, &()).unwrap();
        let c = build(&settings, 4, &()).unwrap();
        assert_eq!(a.table.data, b.table.data);
        assert_ne!(a.table.data, c.table.data);
    }
}
