//! TIR: the share of the energy transmitted through a smooth interface with relative index
//! `eta < 1` that arrives past the critical angle and is reflected back instead
//! (`docs/tables.md`, TIR; the transfer-matrix model applies it as `r += TIR t, t -= TIR t`):
//!
//! ```text
//! TIR(mu, alpha, eta) = ∫ rho(w) [1 - w.z^2 > eta^2] dw / ∫ rho(w) dw
//! ```
//!
//! where `rho` is a Fresnel-free GGX reflection lobe of roughness `alpha` around the direction of
//! cosine `mu`: `h ~ D_v`, `w = reflect(v, h)`, weight `G1(w)` (separable Smith). Recovered by
//! matching the shipped `tm_TIR.bin`; `alpha` is the roughness of the incoming lobe.
//!
//! Fast path: per `(mu, alpha)` one deterministic integration over the reflected lobe answers every
//! `eta` at once ([`tir_column_by_lobe`]): in the polar angle of `w` each index's indicator is the
//! one cut `theta_w > asin(eta)`, so each value is the lobe's share past that angle, with no random
//! points and no binning error. The per-cell method is Monte Carlo over visible normals in f64
//! ([`tir_cell`]), the independent cross-check.

use serde::{Deserialize, Serialize};

use super::driver::{SamplingRecord, one_channel_table};
use super::settings::{MuAlphaAxes, SamplingConfig, SharedSettings, check_counts};
use super::{Integrated, Kernel, Metadata, TableRecipe, estimate_mu_alpha_columns};
use crate::error::{Error, Result};
use crate::formats::FileFormat;
use crate::integrate::quadrature::{Cut, VisibleNormalQuadrature};
use crate::integrate::{
    Estimate, Method, Progress, combine_replicates, estimate_cells, visible_normal_replicate_means,
};
use crate::physics::{MaskingShadowing, critical_cosine};
use crate::sampling::sequence::PointSet;
use crate::table::{Axis, Mapping, Table, derived};

pub const NAME: &str = crate::table::TableKind::Tir.name();
/// One line for `tmlut list`.
pub const DESCRIPTION: &str = "share of a lobe lost to total internal reflection, 3D (mu, alpha, eta < 1)";
/// Channels of the table.
pub const CHANNEL_COUNT: usize = 1;
/// The configuration keys of the node counts, axis 0 first.
pub const COUNT_KEYS: &[&str] = &["mu_count", "alpha_count", "eta_count"];

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TirSettings {
    pub mu_count: usize,
    pub alpha_count: usize,
    /// Nodes of the third axis: `eta`, or the critical-angle offset that stands for it.
    pub eta_count: usize,
    #[serde(flatten)]
    pub mu_alpha: MuAlphaAxes,
    /// What the third axis samples.
    pub eta_axis: EtaAxis,
    /// The relative index the last `eta` node (eta = 1) is evaluated at. 1 gives the exact value
    /// there, 0 (no critical angle); the original `tm_TIR.bin` behaves as if it were 0.999.
    pub top_eta: f64,
    pub method: Method,
    #[serde(flatten)]
    pub shared: SharedSettings,
    /// Fit an analytic approximation to the built table and write it beside the table.
    pub fit: TirFit,
}

/// What the third axis of the TIR table samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum EtaAxis {
    /// The relative index itself, uniform over [0, 1]: the original `tm_TIR.bin` layout. Its
    /// `(mu, eta)` cells cannot follow the step at the critical cosine of a narrow lobe.
    Eta,
    /// The critical-angle offset `asin(eta) - acos(mu)` over [-pi/2, pi/2], in radians
    /// (`table::derived`), spaced as `asinh(offset / OFFSET_SCALE)`: the step of a narrow lobe
    /// lies at offset 0 for every view and index, where the nodes are densest.
    CriticalAngleOffset,
}

/// The scale of the critical-angle offset axis's `asinh` spacing, in radians: nodes are about
/// evenly spaced within it of 0 and geometrically (ratio 1.13 for 129 nodes) beyond, so that the
/// step of a lobe of roughness `alpha`, about `2 alpha` radians wide, spans several nodes down to
/// the model's smallest lobe roughness (1e-4). An odd node count puts a node at offset 0 itself,
/// the centre of every narrow lobe's step (TIR 1/2 there, and the limit 1 at `mu = 1, eta = 0`).
pub const OFFSET_SCALE: f64 = 1e-3;

/// What the build fits to the TIR table (`crate::fit`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TirFit {
    /// The form file `luts/forms/tir-cauchy-slope.toml` ([`crate::fit::forms::build`]): the most
    /// accurate form measured no costlier than thesis eq. 5.6, written as `tir_fit.hlsl`,
    /// `tir_fit.wgsl` and the table's manifest entry.
    Best,
    Off,
}

impl Default for TirSettings {
    fn default() -> Self {
        TirSettings {
            mu_count: 64,
            alpha_count: 64,
            eta_count: 129,
            mu_alpha: MuAlphaAxes::default(),
            eta_axis: EtaAxis::CriticalAngleOffset,
            top_eta: 1.0,
            method: Method::Fast,
            shared: SharedSettings { sampling: SamplingConfig::replicated(1 << 15), ..SharedSettings::default() },
            fit: TirFit::Best,
        }
    }
}

impl TirSettings {
    pub fn validate(&self) -> Result<()> {
        check_counts(NAME, COUNT_KEYS, &[self.mu_count, self.alpha_count, self.eta_count])?;
        self.mu_alpha.validate(NAME)?;
        match self.eta_axis {
            EtaAxis::Eta => {
                let below_top = Axis::node_aligned("eta", 0.0, 1.0, self.eta_count)?.node_value(self.eta_count - 2);
                if !(self.top_eta > below_top && self.top_eta <= 1.0) {
                    return Err(Error::invalid(
                        "tir.top_eta",
                        format!("{}; allowed: above the next node ({below_top}) and at most 1", self.top_eta),
                    ));
                }
            }
            // Its nodes reach every index up to 1: no node lies a fixed step below the top.
            EtaAxis::CriticalAngleOffset if self.top_eta != 1.0 => {
                return Err(Error::invalid(
                    "tir.top_eta",
                    format!(
                        "{}; allowed: 1 with eta_axis = \"critical-angle-offset\" (other values reproduce the original layout, eta_axis = \"eta\")",
                        self.top_eta
                    ),
                ));
            }
            EtaAxis::CriticalAngleOffset => {}
        }
        self.shared.validate(NAME, &FileFormat::for_table(3, true))
    }

    pub fn axes(&self) -> Result<Vec<Axis>> {
        let third = match self.eta_axis {
            EtaAxis::Eta => Axis::node_aligned("eta", 0.0, 1.0, self.eta_count)?,
            EtaAxis::CriticalAngleOffset => {
                let half_pi = std::f64::consts::FRAC_PI_2;
                Axis::node_aligned(derived::CRITICAL_ANGLE_OFFSET, -half_pi, half_pi, self.eta_count)?
                    .with_mapping(Mapping::Asinh { scale: OFFSET_SCALE, centre: 0.0 })?
            }
        };
        let [mu, alpha] = self.mu_alpha.axes([self.mu_count, self.alpha_count])?;
        Ok(vec![mu, alpha, third])
    }

    /// The relative index a node of the third axis stands for at view cosine `mu`, before
    /// [`TirSettings::evaluated_eta`].
    fn eta_of_node(&self, mu: f64, third: f64) -> f64 {
        match self.eta_axis {
            EtaAxis::Eta => third,
            EtaAxis::CriticalAngleOffset => derived::eta_at_critical_angle_offset(mu, third),
        }
    }

    /// The relative index each node of the third axis is evaluated at, for the view cosine `mu`.
    fn evaluated_etas(&self, mu: f64, third_axis: &Axis) -> Vec<f64> {
        third_axis.node_values().into_iter().map(|x| self.evaluated_eta(self.eta_of_node(mu, x))).collect()
    }
}

/// The `alpha = 0` nodes are the limit `alpha -> 0+`, evaluated at this roughness, as the `mu = 0`
/// nodes are the limit `mu -> 0+`. At `alpha = 0` itself the lobe is the single mirror direction,
/// and where that direction is exactly at the critical angle the value depends on the side it is
/// approached from: at `(mu = 1, alpha = 0, eta = 0)` the mirror direction is the normal, the
/// critical cone of `eta = 0` is the normal alone, and the point value 0 sits between neighbours
/// of 1 along `mu` and `alpha`, so that the table interpolated 0.5 at `alpha = 1/126` where TIR is 1.
/// The limit is 1 there (every direction of a narrow lobe around the normal is past it) and 1/2 at
/// any other critical view; elsewhere the narrowest lobe's value is the mirror step itself.
pub const LIMIT_ROUGHNESS: f64 = 1e-7;

/// `[sin^2(theta_w) > eta^2]` (that is, `1 - w.z^2 > eta^2`) for `w` above the horizon: `w` is past
/// the critical angle of `eta`. Taking `sin^2 = w.x^2 + w.y^2` avoids the cancellation of `1 - w.z^2`.
fn past_critical_angle(sin2: f64, eta: f64) -> bool {
    sin2 > eta * eta
}

impl TirSettings {
    /// One node by the fast method (the lobe's share past the critical angle, by quadrature), as
    /// [`Kernel::integrate`] computes it, bit for bit; the top node (eta = 1) at `top_eta`. No
    /// random points: its standard error is 0.
    pub fn estimate_node_fast(&self, position: &[f64]) -> Estimate {
        let eta = self.evaluated_eta(self.eta_of_node(position[0], position[2]));
        let lobe = VisibleNormalQuadrature::new(TIR_LOBE_NODES).expect("TIR_LOBE_NODES is a valid rule");
        deterministic(tir_column_by_lobe(&lobe, position[0], position[1], &[eta]))
    }

    /// The relative index a node at `eta` is evaluated at: the top node (eta = 1) at `top_eta`.
    pub(crate) fn evaluated_eta(&self, eta: f64) -> f64 {
        if eta >= 1.0 { self.top_eta } else { eta }
    }
}

/// TIR at one `(mu, alpha, eta)` on its own, in f64: the ratio estimator `Σ G1 [..] / Σ G1`.
pub(crate) fn tir_cell(mu: f64, alpha: f64, eta: f64, points: &PointSet) -> Estimate {
    tir_cells_at_mu_alpha(mu, alpha, &[eta], points).remove(0)
}

/// TIR at `(mu, alpha, eta)` for each of `etas`, in f64 by the per-cell method, from one pass over
/// the samples (the sampling and the weight depend on `(mu, alpha)` alone). Each estimate has the
/// bits of [`tir_cell`] at its cell.
pub(crate) fn tir_cells_at_mu_alpha(mu: f64, alpha: f64, etas: &[f64], points: &PointSet) -> Vec<Estimate> {
    let alpha = alpha.max(LIMIT_ROUGHNESS);
    // sums[k]: weight past the critical angle of etas[k]; sums[etas.len()]: all the weight.
    let total = etas.len();
    let sums = visible_normal_replicate_means(mu, alpha, points, total + 1, |sample, sums| {
        let weight = MaskingShadowing::SmithSeparable.visible_normal_weight(sample.wi, sample.wo, alpha);
        let sin2 = sample.wo.x * sample.wo.x + sample.wo.y * sample.wo.y;
        for (sum, &eta) in sums.iter_mut().zip(etas) {
            if past_critical_angle(sin2, eta) {
                *sum += weight;
            }
        }
        sums[total] += weight;
    });
    let ratios: Vec<Vec<f64>> = sums
        .iter()
        .map(|s| s[..total].iter().map(|&past| if s[total] > 0.0 { past / s[total] } else { 0.0 }).collect())
        .collect();
    combine_replicates(&ratios, total).into_channels()
}

/// TIR at one `(mu, alpha, eta)` in f64 by the deterministic visible-normal quadrature
/// ([`VisibleNormalQuadrature`]): the ratio `∫ G1 [..] / ∫ G1` of [`tir_cell`], cut at the horizon
/// and at the critical cosine `wo.z = sqrt(1 - eta^2)`, so that each piece integrates a smooth
/// function. The furnace's exact integrals.
pub(crate) fn tir_by_quadrature(quadrature: &VisibleNormalQuadrature, mu: f64, alpha: f64, eta: f64) -> f64 {
    let alpha = alpha.max(LIMIT_ROUGHNESS);
    let mut cuts = vec![Cut::MirrorCosine(0.0)];
    cuts.extend(critical_cosine(eta).map(Cut::MirrorCosine));
    let [past, all] = quadrature.integrate(mu, alpha, &cuts, |s| {
        let weight = MaskingShadowing::SmithSeparable.visible_normal_weight(s.wi, s.wo, alpha);
        let sin2 = s.wo.x * s.wo.x + s.wo.y * s.wo.y;
        [if past_critical_angle(sin2, eta) { weight } else { 0.0 }, weight]
    });
    if all > 0.0 { past / all } else { 0.0 }
}

/// Gauss–Legendre nodes per panel of the lobe quadrature of the fast path ([`tir_column_by_lobe`]):
/// within 1.7e-6 of the 16-node quadrature over the microfacet normals at random cells and indices
/// and at the critical views of narrow lobes (4 nodes: 4.3e-5, 5: 1.2e-5, 8: 3.0e-7;
/// `the_lobe_column_agrees_with_the_quadrature_over_normals`). Monte Carlo at 2^15 samples per
/// `(mu, alpha)` left values up to 1.5e-3 off: an indicator's error falls slowly.
pub const TIR_LOBE_NODES: usize = 6;

/// How the manifest describes the fast path's integration.
pub(crate) fn lobe_quadrature_description() -> String {
    format!(
        "deterministic: Gauss–Legendre quadrature, {TIR_LOBE_NODES} nodes per panel, over the polar angles of w with its density D(h(w)) (panels graded from the mirror direction by alpha), each eta the share past its critical angle asin(eta)"
    )
}

/// Values computed without random points, as an estimate: no replicate spread.
pub(crate) fn deterministic(values: Vec<f64>) -> Estimate {
    Estimate { standard_error: vec![0.0; values.len()], mean: values }
}

/// TIR at `(mu, alpha)` for each of `etas` (any order), deterministic: the share of the lobe
/// past each critical angle `asin(eta)`, from one integration over the lobe in the polar angle of
/// the reflected direction ([`VisibleNormalQuadrature::reflected_lobe`]), where each index's
/// indicator is the one cut `theta_w > asin(eta)`. Each value has the same bits whatever other
/// indices share the call.
pub(crate) fn tir_column_by_lobe(quadrature: &VisibleNormalQuadrature, mu: f64, alpha: f64, etas: &[f64]) -> Vec<f64> {
    let alpha = alpha.max(LIMIT_ROUGHNESS);
    let lobe = quadrature
        .reflected_lobe(mu, alpha, |wi, wo| MaskingShadowing::SmithSeparable.visible_normal_weight(wi, wo, alpha));
    // Past the critical angle where sin(theta_w) > eta, that is theta_w > asin(eta) (none at eta >= 1).
    etas.iter().map(|&eta| lobe.share_beyond(eta.clamp(0.0, 1.0).asin())).collect()
}

impl TableRecipe for TirSettings {
    table_recipe_accessors!();

    fn companions(&self) -> super::Companions {
        use super::Companions;
        Companions { fitted_form: self.fit == TirFit::Best, ..Companions::default() }
    }

    fn clear_companions(&mut self) {
        self.fit = TirFit::Off;
    }

    /// A lookup passes `(mu, alpha, eta)` whatever the third axis samples.
    fn interpolation_domains(&self) -> Result<Vec<super::interpolation::Domain>> {
        Ok(super::interpolation::standard_domains(
            &["mu", "alpha", "eta"],
            &[self.mu_alpha.mu_range, self.mu_alpha.alpha_range, [0.0, 1.0]],
        ))
    }

    fn position_of(&self, lookup: &[f64]) -> Vec<f64> {
        super::position_of_eta_lookup(self, lookup)
    }
}

impl Kernel for TirSettings {
    kernel_settings!();

    fn empty_table(&self) -> Result<Table> {
        let meaning = "share of the energy transmitted through the interface that arrives past the critical angle and is reflected back";
        one_channel_table(NAME, self.axes()?, "tir", meaning)
    }

    fn metadata(&self) -> Metadata {
        Metadata {
            integrand:
                "TIR = Σ G1(w) [1 - w.z^2 > eta^2] / Σ G1(w), h ~ VNDF(v), w = reflect(v, h), w.z > 0 (separable Smith)"
                    .into(),
            masking: Some(MaskingShadowing::SmithSeparable),
            notes: vec![
                super::driver::NODE_ALIGNED_NOTE.into(),
                "alpha is the roughness of the incoming lobe (from hg_to_ggx in the model), not of the interface."
                    .into(),
                format!(
                    "The eta = 1 node is evaluated at eta = {} (1: exact, no total internal reflection; the original behaves as 0.999).",
                    self.top_eta
                ),
                super::driver::grazing_note(),
                format!(
                    "The alpha = 0 nodes are the limit alpha -> 0+, evaluated at alpha = {LIMIT_ROUGHNESS}: the mirror step, 1 at (mu = 1, eta = 0)."
                ),
            ],
            sampler: match self.method {
                Method::Fast => lobe_quadrature_description(),
                Method::PerCell => "visible normals, the ratio of weighted sums per cell".into(),
            },
            ..Metadata::default()
        }
    }

    fn integrate(&self, table: &mut Table, points: &PointSet, progress: &dyn Progress) -> Result<Integrated> {
        let estimates: Vec<Estimate> = match self.method {
            Method::Fast => {
                let third_axis = &table.axes[2];
                let lobe = VisibleNormalQuadrature::new(TIR_LOBE_NODES)?;
                estimate_mu_alpha_columns(table, progress, |_, mu, alpha| {
                    deterministic(tir_column_by_lobe(&lobe, mu, alpha, &self.evaluated_etas(mu, third_axis)))
                })
            }
            Method::PerCell => {
                let cells: Vec<u64> = (0..table.node_count() as u64).collect();
                estimate_cells(&cells, NAME, progress, |cell| {
                    let position = table.node_position(&table.node_index(cell as usize));
                    self.estimate_node(points, &position)
                })
            }
        };
        for (value, estimate) in table.data.iter_mut().zip(&estimates) {
            *value = estimate.mean[0] as f32;
        }
        Ok(match self.method {
            Method::Fast => Integrated::deterministic(),
            Method::PerCell => Integrated::of(&estimates),
        })
    }

    /// The fast path integrates no random points ([`super::driver::quadrature_record`]).
    fn sampling_record(&self, points: &PointSet) -> SamplingRecord {
        match self.method {
            Method::Fast => super::driver::quadrature_record(&self.metadata().sampler, points.seed()),
            Method::PerCell => super::driver::sampling_record(self.method, &self.metadata().sampler, points),
        }
    }

    /// The top node (eta = 1) is evaluated at `top_eta`, as in the table.
    fn estimate_node(&self, points: &PointSet, position: &[f64]) -> Estimate {
        let eta = self.evaluated_eta(self.eta_of_node(position[0], position[2]));
        tir_cell(position[0], position[1], eta, points)
    }

    /// The top node (eta = 1) at `top_eta`, as in the table.
    fn exact_value(&self, quadrature: &VisibleNormalQuadrature, position: &[f64]) -> Vec<f64> {
        let eta = self.evaluated_eta(self.eta_of_node(position[0], position[2]));
        vec![tir_by_quadrature(quadrature, position[0], position[1], eta)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::bin::read_bin;
    use crate::integrate::GRAZING_COSINE;
    use crate::recipes::driver::build;
    use crate::recipes::interpolation::InterpolationConfig;
    use crate::recipes::settings::ReferenceConfig;
    use crate::sampling::sequence::SamplePlan;
    use crate::stats::ErrorSummary;

    #[test]
    fn cells_sharing_mu_alpha_get_the_bits_of_each_cell_alone() {
        let points = crate::recipes::reference_points(1 << 12, 8).unwrap();
        let etas = [0.2, 0.65, 0.9, 0.999];
        for (mu, alpha) in [(0.4, 0.3), (0.0, 0.8), (1.0, 0.0), (0.9, 1.0)] {
            let grouped = tir_cells_at_mu_alpha(mu, alpha, &etas, &points);
            for (estimate, &eta) in grouped.iter().zip(&etas) {
                // The cell alone: the ratio of two sums over its own pass.
                let sums = visible_normal_replicate_means(mu, alpha, &points, 2, |sample, sums| {
                    let weight = MaskingShadowing::SmithSeparable.visible_normal_weight(sample.wi, sample.wo, alpha);
                    if past_critical_angle(sample.wo.x * sample.wo.x + sample.wo.y * sample.wo.y, eta) {
                        sums[0] += weight;
                    }
                    sums[1] += weight;
                });
                let ratios: Vec<Vec<f64>> =
                    sums.iter().map(|s| vec![if s[1] > 0.0 { s[0] / s[1] } else { 0.0 }]).collect();
                let alone = combine_replicates(&ratios, 1);
                assert_eq!(estimate.mean[0].to_bits(), alone.mean[0].to_bits(), "{mu} {alpha} {eta}");
                assert_eq!(estimate.standard_error[0].to_bits(), alone.standard_error[0].to_bits());
            }
        }
    }

    /// How far the lobe quadrature may be from a step's 0 or 1: GGX's tails reach past any angle
    /// (1e-11 of a lobe of `LIMIT_ROUGHNESS` beyond a critical angle far from it), and the rule
    /// is within 1.7e-6 of the quadrature over normals at random cells
    /// (`the_lobe_column_agrees_with_the_quadrature_over_normals`), 2.7e-6 at the grazing views
    /// of the narrowest lobe.
    const LOBE_RULE_ERROR: f64 = 1e-5;

    fn original() -> Table {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/tmblm/tm_TIR.bin");
        read_bin(std::path::Path::new(path), Some(&["mu", "alpha", "eta"])).unwrap()
    }

    fn quick(settings: TirSettings) -> TirSettings {
        let shared = SharedSettings {
            sampling: SamplingConfig::replicated(1 << 12),
            reference: ReferenceConfig { cells: 0, nodes: 8 },
            interpolation: InterpolationConfig { points: 0, nodes: 6 },
            ..settings.shared.clone()
        };
        TirSettings { shared, ..settings }
    }

    /// The original layout, as the committed `luts/original.toml` configures it.
    fn original_layout() -> TirSettings {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/luts/original.toml");
        crate::config::Config::from_file(std::path::Path::new(path)).unwrap().tir
    }

    #[test]
    fn the_original_layout_reproduces_the_original_table() {
        let original = original();
        let as_original = build(&quick(TirSettings { top_eta: 0.999, ..original_layout() }), 1, &()).unwrap().table;
        assert_eq!(as_original.axes, original.axes);
        let rmse = |t: &Table, skip_top: bool| {
            let plane = 64 * 64;
            let limit = if skip_top { 63 * plane } else { 64 * plane };
            ErrorSummary::of_differences((0..limit).map(|n| (t.data[n] - original.data[n]) as f64)).rms
        };
        let with_option = rmse(&as_original, false);
        assert!(with_option <= 4e-3, "RMSE {with_option}");
        // With the exact top node (top_eta = 1) it differs from the original only on its top eta slice.
        let exact = build(&quick(original_layout()), 1, &()).unwrap().table;
        assert!(rmse(&exact, true) <= 4e-3);
        let top_slice = &exact.data[63 * 64 * 64..];
        assert!(top_slice.iter().all(|&v| v == 0.0), "eta = 1 has no critical angle");
    }

    #[test]
    fn the_default_layout_holds_the_original_values_between_its_nodes() {
        // The default table read at the original grid's nodes (the fit grid: the table
        // interpolated there) against tm_TIR.bin, away from its top slice (the original behaves as
        // eta = 0.999 there) and its alpha = 0 nodes at a critical view, which the original holds
        // as a point value and the default as the limit 1/2 (no node of the original grid is at
        // one but a few at mu = 1, eta = 0 and round-off).
        let original = original();
        let ours = crate::fit::fit_grid(&build(&quick(TirSettings::default()), 1, &()).unwrap().table).unwrap();
        assert_eq!(ours.axes, original.axes);
        let plane = 64 * 64;
        let error = ErrorSummary::of_differences((0..63 * plane).map(|n| (ours.data[n] - original.data[n]) as f64));
        assert!(error.rms <= 5e-3, "{error:?}");
    }

    #[test]
    fn smooth_lobe_is_a_step_at_the_critical_cosine() {
        // The original layout's eta axis: the step at the nodes' own critical cosines.
        let table =
            build(&quick(TirSettings { mu_count: 33, alpha_count: 3, eta_count: 17, ..original_layout() }), 2, &())
                .unwrap()
                .table;
        for i in 0..33 {
            for k in 0..17 {
                let position = table.node_position(&[i, 0, k]);
                let (mu, eta) = (position[0].max(GRAZING_COSINE), position[2]);
                // The limit alpha -> 0+: the mirror step, and 1 at the normal for eta = 0, whose
                // critical cone is the normal alone (no other node of this grid is at a critical view).
                let at_the_pole = mu == 1.0 && eta == 0.0;
                let expected = if 1.0 - mu * mu > eta * eta || at_the_pole { 1.0 } else { 0.0 };
                let value = table.node(&[i, 0, k])[0] as f64;
                assert!((value - expected).abs() <= LOBE_RULE_ERROR, "mu {mu} eta {eta}: {value}");
            }
        }
    }

    #[test]
    fn over_the_critical_angle_offset_a_smooth_lobe_steps_at_offset_zero() {
        // Past the critical angle (offset < 0) everything is reflected back, inside it nothing;
        // at offset 0 half the lobe, for every view but the two ends: at the normal (mu = 1,
        // where offset 0 is eta = 0, whose critical cone is the normal alone) all of it, at
        // grazing (mu = 0, where offset 0 is eta = 1: no critical angle) none.
        let settings = quick(TirSettings { mu_count: 17, alpha_count: 3, eta_count: 33, ..TirSettings::default() });
        let table = build(&settings, 2, &()).unwrap().table;
        let reference = VisibleNormalQuadrature::new(16).unwrap();
        assert_eq!(table.axes[2].name, derived::CRITICAL_ANGLE_OFFSET);
        assert_eq!(table.axes[2].node_value(16), 0.0, "an odd count has a node at offset 0");
        for i in 0..17 {
            let mu = table.axes[0].node_value(i);
            for k in 0..33 {
                let offset = table.axes[2].node_value(k);
                let value = table.node(&[i, 0, k])[0] as f64;
                let expected = if offset < 0.0 || mu == 1.0 && offset == 0.0 {
                    1.0
                } else if offset > 0.0 || mu == 0.0 {
                    0.0
                } else {
                    0.5
                };
                // Half a lobe of roughness LIMIT_ROUGHNESS: 1/2 - O(alpha). Off the step, GGX's
                // tails: at grazing views they reach 1.9e-5 of the lobe back over an angle 5e-4
                // away, which both quadratures agree on (Monte Carlo with 2^16 points sees none).
                let tolerance = if expected == 0.5 { 1e-3 } else { 1e-4 };
                assert!((value - expected).abs() <= tolerance, "mu {mu} offset {offset}: {value}");
                let (eta, evaluated_mu) =
                    (settings.evaluated_eta(settings.eta_of_node(mu, offset)), mu.max(GRAZING_COSINE));
                let normals = tir_by_quadrature(&reference, evaluated_mu, LIMIT_ROUGHNESS, eta);
                assert!((value - normals).abs() <= LOBE_RULE_ERROR, "mu {mu} offset {offset}: {value} vs {normals}");
            }
        }
    }

    #[test]
    fn both_methods_agree_and_stay_in_range() {
        let base = quick(TirSettings { mu_count: 5, alpha_count: 4, eta_count: 6, ..TirSettings::default() });
        let fast = base.build(3, &()).unwrap().table;
        let per_cell = build(&TirSettings { method: Method::PerCell, ..base }, 3, &()).unwrap().table;
        for (n, (a, b)) in fast.data.iter().zip(&per_cell.data).enumerate() {
            assert!((0.0..=1.0).contains(a), "{a}");
            // The quadrature against Monte Carlo with 2^12 points (standard error up to 8e-3, a
            // narrow lobe split in half).
            assert!((a - b).abs() < 2e-2, "node {:?}: {a} vs {b}", fast.node_index(n));
        }
    }

    #[test]
    fn a_narrow_lobe_at_a_critical_view_splits_in_half() {
        // Seen exactly at the critical angle, half of a narrow lobe is past it: TIR = 0.5 (1/2 - O(alpha)),
        // on both paths, down to lobes far narrower than the f32 spacing of sin^2 (6e-8).
        let points = PointSet::new(SamplePlan::new(1 << 12, 4).unwrap(), 7);
        let lobe = VisibleNormalQuadrature::new(TIR_LOBE_NODES).unwrap();
        let etas = [0.0, 1e-3, 0.5, 1.0 - 1e-6, 1.0];
        for critical_eta in [0.5f64, 1e-3, 1.0 - 1e-6] {
            let mu = ((1.0 - critical_eta) * (1.0 + critical_eta)).sqrt();
            for alpha in [1e-4, 1e-5, 1e-7] {
                let column = tir_column_by_lobe(&lobe, mu, alpha, &etas);
                for (&fast, &eta) in column.iter().zip(&etas) {
                    let per_cell = tir_cell(mu, alpha, eta, &points);
                    let tolerance = 4.0 * per_cell.standard_error[0] + 2e-4;
                    assert!(
                        (fast - per_cell.mean[0]).abs() <= tolerance,
                        "mu {mu} alpha {alpha} eta {eta}: fast {fast} vs per-cell {} (tolerance {tolerance:.1e})",
                        per_cell.mean[0]
                    );
                    // Half, where the lobe is narrow against sin(theta_v) = eta and cos(theta_v)
                    // (wider, its spread across the plane of incidence adds sin^2: 0.505 at
                    // eta = 1e-3, alpha = 1e-5, 0.55 at alpha = 1e-4; and masking cuts it near the horizon).
                    if eta == critical_eta && alpha <= 1e-2 * critical_eta.min(mu) {
                        assert!((fast - 0.5).abs() < 0.01, "mu {mu} alpha {alpha}: half the lobe is past: {fast}");
                    }
                }
            }
            // alpha = 0 is the limit alpha -> 0+ on both paths: half the lobe past a critical view.
            let column = tir_column_by_lobe(&lobe, mu, 0.0, &etas);
            assert_eq!(column, tir_column_by_lobe(&lobe, mu, LIMIT_ROUGHNESS, &etas));
            let k = etas.iter().position(|&eta| eta == critical_eta).unwrap();
            assert!((column[k] - 0.5).abs() < 1e-3, "mu {mu} alpha 0: {}", column[k]);
            assert!((tir_cell(mu, 0.0, critical_eta, &points).mean[0] - 0.5).abs() < 0.01);
        }
    }

    #[test]
    fn the_alpha_zero_corner_is_the_limit_of_narrow_lobes() {
        // At (mu = 1, alpha = 0, eta = 0) the mirror direction is the normal, which is the whole
        // critical cone of eta = 0: the point value would be 0 between neighbours of 1 along mu
        // and alpha. The limit of narrow lobes is 1: all their directions are off the normal.
        let points = PointSet::new(SamplePlan::new(1 << 10, 4).unwrap(), 5);
        let lobe = VisibleNormalQuadrature::new(TIR_LOBE_NODES).unwrap();
        for alpha in [0.0, LIMIT_ROUGHNESS, 1e-3] {
            // eta = 0.3: GGX's tail past the critical angle, 4.1e-5 of a lobe of alpha = 1e-3.
            let tail = tir_by_quadrature(&VisibleNormalQuadrature::new(16).unwrap(), 1.0, alpha, 0.3);
            let column = tir_column_by_lobe(&lobe, 1.0, alpha, &[0.0, 0.3]);
            assert!((column[0] - 1.0).abs() <= LOBE_RULE_ERROR, "alpha {alpha}: {column:?}");
            assert!((column[1] - tail).abs() <= LOBE_RULE_ERROR, "alpha {alpha}: {column:?} vs {tail}");
            assert_eq!(tir_cell(1.0, alpha, 0.0, &points).mean[0], 1.0, "alpha {alpha}");
        }
    }

    #[test]
    fn the_lobe_column_agrees_with_the_quadrature_over_normals() {
        // Two quadratures of the same integral, over the microfacet normal (cut at the critical
        // cosine) and over the reflected direction's polar angle: random cells, and views at the
        // critical angle of narrow lobes, where TIR steps.
        let lobe_rule = VisibleNormalQuadrature::new(TIR_LOBE_NODES).unwrap();
        let reference = VisibleNormalQuadrature::new(16).unwrap();
        let mut state = 0x1234_5678_9abc_def0u64;
        let mut uniform = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        // Each cell's column: its own index, and four random ones from the same integration.
        let mut cells: Vec<(f64, f64, f64)> = (0..300).map(|_| (uniform(), uniform().powi(2), uniform())).collect();
        for eta in [0.3f64, 0.7, 0.95] {
            let mu = ((1.0 - eta) * (1.0 + eta)).sqrt();
            for alpha in [1e-7, 1e-4, 1e-2, 0.1] {
                cells.push((mu, alpha, eta));
                cells.push(((mu + 0.5 * alpha).min(1.0), alpha, eta));
            }
        }
        let mut worst = (0.0, (0.0, 0.0, 0.0));
        for &(mu, alpha, eta) in &cells {
            let etas = [eta, uniform(), uniform(), uniform(), uniform()];
            let column = tir_column_by_lobe(&lobe_rule, mu, alpha, &etas);
            for (&lobe, &eta) in column.iter().zip(&etas) {
                let normals = tir_by_quadrature(&reference, mu, alpha, eta);
                if (lobe - normals).abs() > worst.0 {
                    worst = ((lobe - normals).abs(), (mu, alpha, eta));
                }
            }
        }
        assert!(worst.0 < 5e-6, "{worst:?}");
    }

    #[test]
    fn top_eta_outside_its_range_is_refused() {
        for bad in [0.5, 1.5, f64::NAN] {
            let err = build(&TirSettings { top_eta: bad, ..TirSettings::default() }, 1, &()).unwrap_err().to_string();
            assert!(err.contains("tir.top_eta") && err.contains("allowed"), "{err}");
        }
    }
}
