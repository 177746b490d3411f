//! FGD onto a rarer medium: the directional albedo of a dielectric interface seen from its denser
//! side (`eta < 1`, `kappa = 0`), which the transfer-matrix model looks up for every dielectric
//! interface whose index falls going down (`docs/scenes.md`, "What the model reads"; `docs/tables.md`):
//!
//! ```text
//! FGD_rarer(mu, alpha, eta) = FGD(mu, alpha, eta, 0) = E_{h ~ D_wi}[ F(wi.h; eta, 0) G2 / G1(wi) ]
//! ```
//!
//! The integral is the 4D FGD table's own at `kappa = 0`; only the grid differs. Without absorption
//! Fresnel reaches 1 at the critical cosine `sqrt(1 - eta^2)` as `1 - c sqrt(cos - cos_c)`, a cusp
//! that runs diagonally through the cells of a `(mu, eta)` grid: there the 4D table interpolates
//! up to 0.29 off (`docs/tables.md`, "Interpolation error"). The third axis here is the
//! [`CRITICAL_ANGLE_FRACTION`](crate::table::derived::CRITICAL_ANGLE_FRACTION), which puts the
//! cusp at 0 for every view and index, spaced as `asinh(fraction / FRACTION_SCALE)` so that the
//! nodes crowd around it. Each node stands for its own index, `eta(mu, fraction)`.
//!
//! Fast path as FGD's: per `(mu, alpha)` one visible-normal measure on the hat basis, integrated
//! against Fresnel projected per `(mu, fraction)` node.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::driver::one_channel_table;
use super::fgd::{
    fgd_by_quadrature, fgd_cells_at_mu_alpha, fgd_pairs_fast, fgd_pairs_on_measure, mu_alpha_measures,
    projected_fresnel,
};
use super::settings::{SamplingConfig, SharedSettings, check_cosine_intervals, check_counts};
use super::spacing::{CosineAxis, RoughnessAxis, mu_alpha_axes};
use super::{Integrated, Kernel, Metadata, TableRecipe, estimate_mu_alpha_columns};
use crate::error::Result;
use crate::formats::FileFormat;
use crate::integrate::measure::{HatBasis, Projection};
use crate::integrate::quadrature::VisibleNormalQuadrature;
use crate::integrate::{Estimate, GRAZING_COSINE, Method, Progress};
use crate::physics::MaskingShadowing;
use crate::sampling::sequence::PointSet;
use crate::table::{Axis, Mapping, Table, derived};

pub const NAME: &str = crate::table::TableKind::FgdRarer.name();
/// One line for `tmlut list`.
pub const DESCRIPTION: &str =
    "FGD of a dielectric onto a rarer medium (eta < 1, kappa = 0), 3D (mu, alpha, critical-angle fraction)";
/// Channels of the table.
pub const CHANNEL_COUNT: usize = 1;
/// The configuration keys of the node counts, axis 0 first.
pub const COUNT_KEYS: &[&str] = &["mu_count", "alpha_count", "fraction_count"];

/// The scale of the fraction axis's `asinh` spacing: 129 nodes over [-1, 1] are 1.2e-3 apart at
/// the cusp and 0.08 at the ends. Chosen by measurement (`docs/tables.md`): 0.1 left the cusp of
/// lobes narrower than 0.01 between nodes (max 9.8e-2 at `alpha 0.002`).
pub const FRACTION_SCALE: f64 = 0.01;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FgdRarerSettings {
    pub mu_count: usize,
    pub alpha_count: usize,
    /// Nodes of the critical-angle fraction over [-1, 1]; an odd count puts a node on the cusp.
    pub fraction_count: usize,
    /// How the `mu` nodes are spaced.
    pub mu_axis: CosineAxis,
    /// How the `alpha` nodes are spaced.
    pub roughness_axis: RoughnessAxis,
    pub masking: MaskingShadowing,
    pub method: Method,
    /// Intervals of the hat basis in `c = wi.h` (fast method).
    pub cosine_intervals: usize,
    #[serde(flatten)]
    pub shared: SharedSettings,
}

impl Default for FgdRarerSettings {
    fn default() -> Self {
        FgdRarerSettings {
            mu_count: 64,
            alpha_count: 64,
            fraction_count: 129,
            mu_axis: CosineAxis::SqrtEnds,
            roughness_axis: RoughnessAxis::Perceptual,
            masking: MaskingShadowing::SmithSeparable,
            method: Method::Fast,
            cosine_intervals: 256,
            shared: SharedSettings {
                // FGD's samples on FGD's (mu, alpha) nodes: a build of both estimates the measures
                // once ([`mu_alpha_measures`]); 2^16 of its own cost more than sharing 2^17.
                sampling: SamplingConfig::replicated(1 << 17),
                ..SharedSettings::default()
            },
        }
    }
}

impl FgdRarerSettings {
    pub fn validate(&self) -> Result<()> {
        check_counts(NAME, COUNT_KEYS, &[self.mu_count, self.alpha_count, self.fraction_count])?;
        check_cosine_intervals("fgd_rarer.cosine_intervals", self.cosine_intervals)?;
        self.shared.validate(NAME, &FileFormat::for_table(3, false))
    }

    pub fn axes(&self) -> Result<Vec<Axis>> {
        let counts = [self.mu_count, self.alpha_count];
        let [mu, alpha] = mu_alpha_axes(counts, [[0.0, 1.0]; 2], self.mu_axis, self.roughness_axis)?;
        Ok(vec![
            mu,
            alpha,
            Axis::node_aligned(derived::CRITICAL_ANGLE_FRACTION, -1.0, 1.0, self.fraction_count)?
                .with_mapping(Mapping::Asinh { scale: FRACTION_SCALE, centre: 0.0 })?,
        ])
    }

    /// The relative index of a node at critical-angle fraction `fraction` seen at cosine `mu`, as
    /// the node is evaluated: `mu = 0` as the limit `mu -> 0+`, like the integral itself.
    fn eta_of_node(mu: f64, fraction: f64) -> f64 {
        derived::eta_at_critical_angle_fraction(mu.max(GRAZING_COSINE), fraction)
    }

    fn cosine_basis(&self) -> HatBasis {
        HatBasis { intervals: self.cosine_intervals }
    }

    /// One node by the fast method, at a position in the axes' quantities: what the stability
    /// checks hold against [`Kernel::estimate_node`].
    pub fn estimate_node_fast(&self, points: &PointSet, position: &[f64]) -> Estimate {
        let pair = (Self::eta_of_node(position[0], position[2]), 0.0);
        let projection = projected_fresnel(self.cosine_basis(), pair.0, pair.1);
        fgd_pairs_fast(self.masking, self.cosine_basis(), points, position[0], position[1], &[pair], &[projection])
    }
}

impl TableRecipe for FgdRarerSettings {
    table_recipe_accessors!();

    fn kept_measure_intervals(&self) -> Option<usize> {
        (self.method == Method::Fast).then_some(self.cosine_intervals)
    }

    /// A lookup passes `(mu, alpha, eta)`, `eta` below 1; the third axis is derived from them.
    fn interpolation_domains(&self) -> Result<Vec<super::interpolation::Domain>> {
        Ok(super::interpolation::standard_domains(&["mu", "alpha", "eta"], &[[0.0, 1.0], [0.0, 1.0], [0.0, 1.0]]))
    }

    fn position_of(&self, lookup: &[f64]) -> Vec<f64> {
        super::position_of_eta_lookup(self, lookup)
    }
}

impl Kernel for FgdRarerSettings {
    kernel_settings!();

    fn empty_table(&self) -> Result<Table> {
        let meaning =
            "∫ F(wi.h; eta, 0) D G2 / (4 mu) dwo: directional albedo of a dielectric interface onto a rarer medium";
        one_channel_table(NAME, self.axes()?, "fgd", meaning)
    }

    fn metadata(&self) -> Metadata {
        Metadata {
            integrand: "FGD = E_{h~VNDF(wi)}[F(wi.h; eta, 0) G2(wi,wo) / G1(wi)], wo = reflect(wi, h), eta < 1".into(),
            masking: Some(self.masking),
            notes: vec![
                super::driver::NODE_ALIGNED_NOTE.into(),
                "The third axis stands for eta: each node is evaluated at eta = sin(v (1 + f)) for f < 0 and sin(v + f (pi/2 - v)) for f >= 0, v = acos(mu); lookups compute f from (mu, eta) by the axis's definition.".into(),
                "eta is relative to the medium above the interface (the denser one); for eta >= 1 or kappa > 0 read the 4D FGD table.".into(),
                super::driver::grazing_note(),
            ],
            sampler: format!(
                "visible-normal measure per (mu, alpha) on {} hat intervals in wi.h, times Fresnel projected per (mu, fraction)",
                self.cosine_intervals
            ),
            ..Metadata::default()
        }
    }

    fn integrate(&self, table: &mut Table, points: &PointSet, progress: &dyn Progress) -> Result<Integrated> {
        let (mu_axis, fractions) = (&table.axes[0], table.axes[2].node_values());
        // Each mu node has its own indices: one Fresnel projection per (mu, fraction) node.
        let pairs: Vec<Vec<(f64, f64)>> = (0..mu_axis.count)
            .map(|i| fractions.iter().map(|&f| (Self::eta_of_node(mu_axis.node_value(i), f), 0.0)).collect())
            .collect();
        let projections: Vec<Vec<Projection>> = match self.method {
            Method::Fast => pairs
                .par_iter()
                .map(|row| row.iter().map(|&(eta, kappa)| projected_fresnel(self.cosine_basis(), eta, kappa)).collect())
                .collect(),
            Method::PerCell => Vec::new(),
        };
        // Every fraction of one (mu, alpha) from one measure (fast) or one pass over the samples
        // (per cell).
        // The measures of FGD's fast path, which a build of both tables estimates once.
        let measures = match self.method {
            Method::Fast => {
                mu_alpha_measures(&table.axes[0], &table.axes[1], self.masking, points, self.cosine_basis(), progress)
            }
            Method::PerCell => Default::default(),
        };
        let nodes = estimate_mu_alpha_columns(table, progress, |cell, mu, alpha| {
            let i = cell % mu_axis.count;
            match self.method {
                Method::Fast => fgd_pairs_on_measure(&measures[cell], &pairs[i], &projections[i]),
                Method::PerCell => {
                    Estimate::from_channels(&fgd_cells_at_mu_alpha(self.masking, points, mu, alpha, &pairs[i]))
                }
            }
        });
        // The global projection of Fresnel misses a cusp by up to 0.2 within its hat interval, and
        // a lobe spread over a few intervals reads a little of that (at most 7.5e-4 in the default
        // table, next to `eta = 1` at grazing views, where Fresnel falls from 1 to 0 within 1e-3 of
        // the critical cosine); the albedo itself cannot leave [0, 1].
        for (value, estimate) in table.data.iter_mut().zip(&nodes) {
            *value = estimate.mean[0].clamp(0.0, 1.0) as f32;
        }
        Ok(Integrated::of(&nodes))
    }

    fn estimate_node(&self, points: &PointSet, position: &[f64]) -> Estimate {
        let pair = (Self::eta_of_node(position[0], position[2]), 0.0);
        fgd_cells_at_mu_alpha(self.masking, points, position[0], position[1], &[pair]).remove(0)
    }

    fn exact_value(&self, quadrature: &VisibleNormalQuadrature, position: &[f64]) -> Vec<f64> {
        let pair = (Self::eta_of_node(position[0], position[2]), 0.0);
        vec![fgd_by_quadrature(self.masking, quadrature, position[0], position[1], pair)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recipes::interpolation::InterpolationConfig;
    use crate::recipes::settings::ReferenceConfig;

    fn small(method: Method) -> FgdRarerSettings {
        FgdRarerSettings {
            mu_count: 7,
            alpha_count: 5,
            fraction_count: 9,
            method,
            shared: SharedSettings {
                sampling: SamplingConfig::replicated(1 << 12),
                reference: ReferenceConfig { cells: 0, nodes: 8 },
                interpolation: InterpolationConfig { points: 0, nodes: 6 },
                ..FgdRarerSettings::default().shared
            },
            ..FgdRarerSettings::default()
        }
    }

    #[test]
    fn both_methods_agree() {
        let fast = small(Method::Fast).build(3, &()).unwrap();
        let per_cell = small(Method::PerCell).build(3, &()).unwrap();
        let spread = fast.provenance.error.replicate_standard_error.max;
        for (a, b) in fast.table.data.iter().zip(&per_cell.table.data) {
            assert!((a - b).abs() as f64 <= 4.0 * spread + 2e-4, "{a} vs {b} (spread {spread})");
        }
    }

    #[test]
    fn its_grid_interpolates_the_cusp_better_than_a_grid_of_eta_with_as_many_nodes() {
        // The same integral on 16 x 16 x 33 nodes: over the critical-angle fraction, and over
        // eta (the 4D table's axes at kappa = 0, eta in [0, 1] spaced as its default). Each read
        // where renderers read it, against the exact integral at random points of eta < 1.
        use crate::recipes::fgd::FgdSettings;
        use crate::recipes::interpolation::random_points;
        let quick = |shared: SharedSettings| SharedSettings {
            sampling: SamplingConfig::replicated(1 << 12),
            reference: ReferenceConfig { cells: 0, nodes: 8 },
            interpolation: InterpolationConfig { points: 0, nodes: 6 },
            ..shared
        };
        let rarer = FgdRarerSettings {
            mu_count: 16,
            alpha_count: 16,
            fraction_count: 33,
            shared: quick(FgdRarerSettings::default().shared),
            ..FgdRarerSettings::default()
        };
        let four_d = FgdSettings {
            mu_count: 16,
            alpha_count: 16,
            eta_count: 33,
            kappa_count: 2,
            eta_range: [0.0, 1.0],
            kappa_range: [0.0, 0.1],
            shared: quick(FgdSettings::default().shared),
            packings: Vec::new(),
            ..FgdSettings::default()
        };
        let (rarer_table, four_d_table) = (rarer.build(5, &()).unwrap().table, four_d.build(5, &()).unwrap().table);
        let quadrature = VisibleNormalQuadrature::new(6).unwrap();
        let (mut rarer_max, mut four_d_max) = (0.0f64, 0.0f64);
        for lookup in random_points(&[[0.0, 1.0], [0.0, 1.0], [0.0, 1.0]], 256, 7, 1) {
            let (mu, alpha, eta) = (lookup[0], lookup[1], lookup[2]);
            let exact = fgd_by_quadrature(rarer.masking, &quadrature, mu, alpha, (eta, 0.0));
            rarer_max = rarer_max.max((rarer_table.interpolate(&rarer.position_of(&lookup))[0] - exact).abs());
            four_d_max = four_d_max.max((four_d_table.interpolate(&[mu, alpha, eta, 0.0])[0] - exact).abs());
        }
        // Measured: 1.75e-2 against 0.131.
        assert!(rarer_max < 0.5 * four_d_max, "fraction grid {rarer_max:.2e}, eta grid {four_d_max:.2e}");
    }

    #[test]
    fn a_smooth_interface_reflects_everything_past_the_cusp_and_fresnel_before_it() {
        let table = small(Method::Fast).build(4, &()).unwrap().table;
        // alpha = 0 (the first alpha node): the mirror reflection, F(mu; eta) itself. At fraction
        // f < 0 the index lies below the view's critical one: total internal reflection.
        let fractions = table.axes[2].node_values();
        for i in 1..7 {
            let mu = table.axes[0].node_value(i);
            for (k, &f) in fractions.iter().enumerate() {
                let eta = FgdRarerSettings::eta_of_node(mu, f);
                let value = table.node(&[i, 0, k])[0] as f64;
                let fresnel = crate::physics::fresnel_reflectance(mu, eta, 0.0);
                assert!((value - fresnel).abs() < 1e-3, "mu {mu} fraction {f} eta {eta}: {value} vs F {fresnel}");
                if f < 0.0 {
                    assert!((value - 1.0).abs() < 1e-3, "mu {mu} fraction {f}: {value}");
                }
            }
        }
    }
}
