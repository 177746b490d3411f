//! FGD: the directional albedo of a GGX interface with exact Fresnel for a complex relative index
//! (`docs/tables.md`, FGD), read by the transfer-matrix model once per colour channel per
//! interface:
//!
//! ```text
//! FGD(mu, alpha, eta, kappa) = ∫ F(wi.h; eta, kappa) D G2 / (4 mu) dwo
//!                            = E_{h ~ D_wi}[ F(wi.h; eta, kappa) G2 / G1(wi) ]
//! ```
//!
//! Fast path (`docs/integration.md`): per `(mu, alpha)` the visible-normal measure of
//! `c = wi.h` on a hat basis ([`cosine_measure`]); per `(eta, kappa)` Fresnel projected on the same
//! basis ([`HatBasis::project`], exact across the kink at the critical angle); the table is one
//! matrix product of the two. Defaults follow the original table: 64^4 node-aligned nodes,
//! `mu`, `alpha` over [0, 1], `eta`, `kappa` over [0, 4], separable Smith, f32 `.bin`.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::driver::one_channel_table;
use super::settings::{
    MuAlphaAxes, OutputConfig, SamplingConfig, SharedSettings, check_cosine_intervals, check_counts,
};
use super::spacing::{ExtinctionAxis, IndexAxis};
use super::{Integrated, Kernel, Metadata, TableRecipe, random_cells};
use crate::error::{Error, Result};
use crate::formats::{FileFormat, Precision};
use crate::integrate::measure::{CosineMeasure, HatBasis, MatrixRef, Projection, cosine_measure, multiply_transposed};
use crate::integrate::quadrature::VisibleNormalQuadrature;
use crate::integrate::{Estimate, Method, Progress, estimate_cells, estimate_per_cell_blocks};
use crate::packing::Packing;
use crate::physics::{MaskingShadowing, critical_cosine, fresnel_reflectance};
use crate::sampling::sequence::PointSet;
use crate::stats::ErrorSummary;
use crate::table::{Axis, Table};

pub const NAME: &str = crate::table::TableKind::Fgd.name();
/// One line for `tmlut list`.
pub const DESCRIPTION: &str = "directional albedo with exact Fresnel, 4D (mu, alpha, eta, kappa)";
/// Channels of the table.
pub const CHANNEL_COUNT: usize = 1;
/// The configuration keys of the node counts, axis 0 first.
pub const COUNT_KEYS: &[&str] = &["mu_count", "alpha_count", "eta_count", "kappa_count"];
/// The interpolation domain of dielectric interfaces onto a rarer medium: `eta < 1`, `kappa = 0`.
pub const DIELECTRIC_ONTO_RARER: &str = "a dielectric onto a rarer medium (eta < 1, kappa = 0)";

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FgdSettings {
    pub mu_count: usize,
    pub alpha_count: usize,
    pub eta_count: usize,
    pub kappa_count: usize,
    #[serde(flatten)]
    pub mu_alpha: MuAlphaAxes,
    pub eta_range: [f64; 2],
    pub kappa_range: [f64; 2],
    /// How the `eta` nodes are spaced.
    pub eta_axis: IndexAxis,
    /// How the `kappa` nodes are spaced.
    pub kappa_axis: ExtinctionAxis,
    pub masking: MaskingShadowing,
    pub method: Method,
    /// Intervals of the hat basis in `c = wi.h` (fast method).
    pub cosine_intervals: usize,
    /// `(eta, kappa)` columns whose replicate spread is computed (all of them costs one matrix
    /// product per replicate).
    pub replicate_error_columns: usize,
    #[serde(flatten)]
    pub shared: SharedSettings,
    /// Volume-texture packings written beside the 4D table (`fgd_<packing>.dds` or `.ktx2`, see
    /// `packing_formats`, with its HLSL and WGSL lookup), in the precision of `output.precision`;
    /// see `docs/packing.md`.
    pub packings: Vec<Packing>,
    /// The files each packing's texture is written to: `fgd_<packing>.dds`, `.ktx2` or both.
    pub packing_formats: Vec<FileFormat>,
}

impl Default for FgdSettings {
    fn default() -> Self {
        FgdSettings {
            mu_count: 64,
            alpha_count: 64,
            eta_count: 64,
            kappa_count: 64,
            mu_alpha: MuAlphaAxes::default(),
            eta_range: [0.0, 4.0],
            kappa_range: [0.0, 4.0],
            eta_axis: IndexAxis::DenseNearOne,
            kappa_axis: ExtinctionAxis::DenseNearZero,
            masking: MaskingShadowing::SmithSeparable,
            method: Method::Fast,
            cosine_intervals: 256,
            replicate_error_columns: 256,
            shared: SharedSettings {
                // 2^17: the worst cell's replicate standard error is 5.5e-5, within the 1e-4 target
                // (the manifest's `error.replicate_standard_error`, `docs/benchmark.md`, "The
                // default build's error figures"); 2^16 reaches 1.01e-4 on the default `eta` nodes.
                sampling: SamplingConfig::replicated(1 << 17),
                // Five domains (`interpolation_domains`): half the points of the other tables keeps
                // the check at the cost of theirs.
                interpolation: super::interpolation::InterpolationConfig {
                    points: 1024,
                    nodes: super::interpolation::EXACT_NODES,
                },
                output: OutputConfig { formats: vec![FileFormat::Exr], precision: Precision::F32 },
                ..SharedSettings::default()
            },
            packings: vec![Packing::Lossless],
            packing_formats: vec![FileFormat::Dds],
        }
    }
}

/// An error's message without its key, to be reported under another key.
fn strip_error_key(error: &Error) -> String {
    match error {
        Error::Invalid { key, reason } => format!("{key} {reason}"),
        other => other.to_string(),
    }
}

/// A non-negative `[lo, hi]` range with `lo < hi`.
fn check_index_range(key: &str, [lo, hi]: [f64; 2]) -> Result<()> {
    if !(lo.is_finite() && hi.is_finite() && lo >= 0.0 && lo < hi) {
        return Err(Error::invalid(key, format!("[{lo}, {hi}]; allowed: finite, 0 <= lo < hi")));
    }
    Ok(())
}

impl FgdSettings {
    pub fn validate(&self) -> Result<()> {
        let counts = [self.mu_count, self.alpha_count, self.eta_count, self.kappa_count];
        check_counts(NAME, COUNT_KEYS, &counts)?;
        self.mu_alpha.validate(NAME)?;
        check_index_range("fgd.eta_range", self.eta_range)?;
        check_index_range("fgd.kappa_range", self.kappa_range)?;
        check_cosine_intervals("fgd.cosine_intervals", self.cosine_intervals)?;
        self.shared.validate(NAME, &FileFormat::for_table(4, true))?;
        for (k, packing) in self.packings.iter().enumerate() {
            if self.packings[..k].contains(packing) {
                return Err(Error::invalid("fgd.packings", format!("`{}` is listed twice", packing.name())));
            }
            packing.extent(counts).map_err(|e| Error::invalid("fgd.packings", strip_error_key(&e)))?;
        }
        super::settings::check_packing_formats(
            "fgd.packing_formats",
            &self.packing_formats,
            !self.packings.is_empty(),
        )?;
        Ok(())
    }

    pub fn axes(&self) -> Result<Vec<Axis>> {
        let [mu, alpha] = self.mu_alpha.axes([self.mu_count, self.alpha_count])?;
        Ok(vec![
            mu,
            alpha,
            Axis::node_aligned("eta", self.eta_range[0], self.eta_range[1], self.eta_count)?
                .with_mapping(self.eta_axis.mapping())?,
            Axis::node_aligned("kappa", self.kappa_range[0], self.kappa_range[1], self.kappa_count)?
                .with_mapping(self.kappa_axis.mapping())?,
        ])
    }
}

/// Where the quadrature of Fresnel of `(eta, kappa)` splits: at the critical cosine of `eta < 1`,
/// a kink for a dielectric and, with faint absorption, a bend as sharp as `kappa` is small (F is
/// smooth there, and the split costs nothing in accuracy when it is not needed).
pub fn fresnel_kinks(eta: f64) -> Vec<f64> {
    critical_cosine(eta).into_iter().collect()
}

/// Fresnel of one `(eta, kappa)` projected on the hat basis.
pub fn projected_fresnel(basis: HatBasis, eta: f64, kappa: f64) -> Projection {
    basis.project_with_error(|c| fresnel_reflectance(c, eta, kappa), &fresnel_kinks(eta))
}

impl FgdSettings {
    /// One node by the fast method, as [`Kernel::integrate`] computes it (the f32 measure of `(mu, alpha)`
    /// times Fresnel projected on the hat basis, narrow lobes on their own hats where that
    /// projection does not resolve Fresnel), at a position in the axes' quantities: what the
    /// stability checks hold against [`Kernel::estimate_node`].
    pub fn estimate_node_fast(&self, points: &PointSet, position: &[f64]) -> Estimate {
        let (mu, alpha, eta, kappa) = (position[0], position[1], position[2], position[3]);
        let projections = [projected_fresnel(self.cosine_basis(), eta, kappa)];
        fgd_pairs_fast(self.masking, self.cosine_basis(), points, mu, alpha, &[(eta, kappa)], &projections)
    }

    /// The hat basis in `c = wi.h` of the fast method.
    pub fn cosine_basis(&self) -> HatBasis {
        HatBasis { intervals: self.cosine_intervals }
    }
}

/// FGD at one `(mu, alpha)` for several `(eta, kappa)` pairs by the fast method, with `masking` on
/// the hat `basis` (`projections[k]` from [`projected_fresnel`] on `basis` for `pairs[k]`): one
/// visible-normal measure, integrated against each pair's projected Fresnel. One channel per pair.
pub fn fgd_pairs_fast(
    masking: MaskingShadowing,
    basis: HatBasis,
    points: &PointSet,
    mu: f64,
    alpha: f64,
    pairs: &[(f64, f64)],
    projections: &[Projection],
) -> Estimate {
    let measure = cosine_measure(mu, alpha, masking, points, basis);
    fgd_pairs_on_measure(&measure, pairs, projections)
}

/// FGD of each of `pairs` against the visible-normal `measure` of one `(mu, alpha)`: the part of
/// [`fgd_pairs_fast`] after the measure, which slices integrated together share
/// ([`super::slices::integrate_batch`]). Each pair is integrated on its own, so its value does not
/// depend on the other pairs.
pub fn fgd_pairs_on_measure(measure: &CosineMeasure, pairs: &[(f64, f64)], projections: &[Projection]) -> Estimate {
    // One pair at a time: each has its own kinks.
    let per_pair: Vec<Estimate> = pairs
        .iter()
        .zip(projections)
        .map(|(&(eta, kappa), projection)| {
            measure.integrate(&[projection], |_, c| fresnel_reflectance(c, eta, kappa), &fresnel_kinks(eta))
        })
        .collect();
    Estimate::from_channels(&per_pair)
}

/// FGD at one cell on its own, in f64 (the per-cell method, and the references of `bench` and
/// `converge`).
pub fn fgd_cell(masking: MaskingShadowing, points: &PointSet, position: &[f64]) -> Estimate {
    let (mu, alpha, eta, kappa) = (position[0], position[1], position[2], position[3]);
    fgd_cells_at_mu_alpha(masking, points, mu, alpha, &[(eta, kappa)]).remove(0)
}

/// FGD at the cells `(mu, alpha, eta, kappa)` for each of `pairs`, in f64 by the per-cell method,
/// from one pass over the samples: the sampling, the warp and the weight depend on `(mu, alpha)`
/// alone, only Fresnel on the pair. Each estimate has the bits of [`fgd_cell`] at its cell.
pub fn fgd_cells_at_mu_alpha(
    masking: MaskingShadowing,
    points: &PointSet,
    mu: f64,
    alpha: f64,
    pairs: &[(f64, f64)],
) -> Vec<Estimate> {
    estimate_per_cell_blocks(mu, alpha, masking, points, pairs.len(), |cos_wi_h, weight, sums| {
        for (sum, &(eta, kappa)) in sums.iter_mut().zip(pairs) {
            for (&c, &w) in cos_wi_h.iter().zip(weight) {
                *sum += w * fresnel_reflectance(c, eta, kappa);
            }
        }
    })
    .into_channels()
}

/// FGD at one cell `(mu, alpha, eta, kappa)` in f64 by the deterministic visible-normal quadrature
/// ([`VisibleNormalQuadrature`]), cut at the horizon and, below `eta = 1`, where Fresnel turns
/// total ([`fgd_kink`]). The furnace's exact integrals.
pub fn fgd_by_quadrature(
    masking: MaskingShadowing,
    quadrature: &VisibleNormalQuadrature,
    mu: f64,
    alpha: f64,
    pair: (f64, f64),
) -> f64 {
    let [fgd] = fgd_pairs_by_quadrature(masking, quadrature, mu, alpha, [pair]);
    fgd
}

/// Where FGD's integrand kinks in `c = wi.h` for the pair `(eta, kappa)`, if it does inside
/// (0, 1): below `eta = 1`, where `t0 = eta^2 - 1 - kappa^2 + c^2` of [`fresnel_reflectance`]
/// changes sign, at `c = sqrt(1 - eta^2 + kappa^2)` (the critical cosine when `kappa = 0`, a
/// rounded kink otherwise).
pub fn fgd_kink((eta, kappa): (f64, f64)) -> Option<f64> {
    let total_reflection_cosine2 = (1.0 - eta) * (1.0 + eta) + kappa * kappa;
    let kink = eta < 1.0 && total_reflection_cosine2 > 0.0 && total_reflection_cosine2 < 1.0;
    kink.then(|| total_reflection_cosine2.sqrt())
}

/// [`fgd_by_quadrature`] of `N` pairs at one `(mu, alpha)` in one pass over the quadrature's
/// nodes (a conductor's three channels): the directions, masking and weights are computed once and
/// only Fresnel per pair. The pairs must share their kink ([`fgd_kink`]); each answer then has the
/// bits of its pair's integral alone, since every pair's sum takes the same terms in the same order.
pub fn fgd_pairs_by_quadrature<const N: usize>(
    masking: MaskingShadowing,
    quadrature: &VisibleNormalQuadrature,
    mu: f64,
    alpha: f64,
    pairs: [(f64, f64); N],
) -> [f64; N] {
    let kink = pairs.first().and_then(|&p| fgd_kink(p));
    debug_assert!(pairs.iter().all(|&p| fgd_kink(p).map(f64::to_bits) == kink.map(f64::to_bits)), "{pairs:?}");
    let kinks: Vec<f64> = kink.into_iter().collect();
    quadrature
        .cosine_functions(mu, alpha, masking, &kinks, |c| pairs.map(|(eta, kappa)| fresnel_reflectance(c, eta, kappa)))
}

impl TableRecipe for FgdSettings {
    table_recipe_accessors!();

    fn companions(&self) -> super::Companions {
        use super::Companions;
        Companions {
            packings: self.packings.clone(),
            packing_formats: self.packing_formats.clone(),
            fitted_form: false,
        }
    }

    fn clear_companions(&mut self) {
        self.packings.clear();
        self.packing_formats.clear();
    }

    fn kept_measure_intervals(&self) -> Option<usize> {
        (self.method == Method::Fast).then_some(self.cosine_intervals)
    }

    /// The whole domain and its low-roughness part, and the domain cut at `eta = 1`: below it a
    /// dielectric (or a faint absorber, `kappa <= 0.1`) has a critical angle, where Fresnel has a
    /// kink whose cosine `sqrt(1 - eta^2)` moves with `eta` across the cells of the `(mu, eta)`
    /// grid, so that no spacing of the separate axes follows it; above it the table has no such
    /// kink. The last domain is the plane `kappa = 0` below `eta = 1`, where the model looks up
    /// every dielectric interface onto a rarer medium (`docs/scenes.md`, "What the model reads"):
    /// random points of a box with `kappa` in a range never land on it, and there the kink is
    /// sharpest (a square-root cusp, no absorption to round it).
    fn interpolation_domains(&self) -> Result<Vec<super::interpolation::Domain>> {
        let names = ["mu", "alpha", "eta", "kappa"];
        let ranges = [self.mu_alpha.mu_range, self.mu_alpha.alpha_range, self.eta_range, self.kappa_range];
        let mut domains = super::interpolation::standard_domains(&names, &ranges);
        let [lo, hi] = self.eta_range;
        for (name, eta, kappa) in [
            ("no critical angle (eta >= 1)", [lo.max(1.0), hi], self.kappa_range),
            (
                "a critical angle (eta < 1, kappa <= 0.1)",
                [lo, hi.min(1.0)],
                [self.kappa_range[0], self.kappa_range[1].min(0.1)],
            ),
            (DIELECTRIC_ONTO_RARER, [lo, hi.min(1.0)], [0.0, 0.0]),
        ] {
            let kappa_reached =
                if kappa[0] == kappa[1] { self.kappa_range[0] == kappa[0] } else { kappa[0] < kappa[1] };
            if eta[0] < eta[1] && kappa_reached && (eta, kappa) != ([lo, hi], self.kappa_range) {
                let mut cut = ranges;
                cut[2] = eta;
                cut[3] = kappa;
                domains.push(super::interpolation::Domain {
                    name: name.into(),
                    parameters: names.iter().map(|n| n.to_string()).collect(),
                    ranges: cut.to_vec(),
                });
            }
        }
        Ok(domains)
    }
}

impl Kernel for FgdSettings {
    kernel_settings!();

    fn empty_table(&self) -> Result<Table> {
        let meaning = "∫ F(wi.h; eta, kappa) D G2 / (4 mu) dwo: directional albedo with exact Fresnel";
        one_channel_table(NAME, self.axes()?, "fgd", meaning)
    }

    fn metadata(&self) -> Metadata {
        Metadata {
            integrand: "FGD = E_{h~VNDF(wi)}[F(wi.h; eta, kappa) G2(wi,wo) / G1(wi)], wo = reflect(wi, h)".into(),
            masking: Some(self.masking),
            notes: vec![
                super::driver::NODE_ALIGNED_NOTE.into(),
                "eta and kappa are relative to the medium above the interface; lookups outside the range clamp (kappa > 4 reads as 4).".into(),
                super::driver::grazing_note(),
            ],
            sampler: format!(
                "visible-normal measure per (mu, alpha) on {} hat intervals in wi.h, times projected Fresnel",
                self.cosine_intervals
            ),
            ..Metadata::default()
        }
    }

    fn integrate(&self, table: &mut Table, points: &PointSet, progress: &dyn Progress) -> Result<Integrated> {
        Ok(match self.method {
            Method::Fast => {
                let (replicate_standard_error, standard_error) = build_fast(self, points, table, progress);
                Integrated { replicate_standard_error, standard_error, accuracy: Vec::new() }
            }
            Method::PerCell => {
                let cells: Vec<u64> = (0..table.node_count() as u64).collect();
                let estimates = estimate_cells(&cells, NAME, progress, |cell| {
                    fgd_cell(self.masking, points, &table.node_position(&table.node_index(cell as usize)))
                });
                for (value, estimate) in table.data.iter_mut().zip(&estimates) {
                    *value = estimate.mean[0] as f32;
                }
                Integrated::of(&estimates)
            }
        })
    }

    fn estimate_node(&self, points: &PointSet, position: &[f64]) -> Estimate {
        fgd_cell(self.masking, points, position)
    }

    fn exact_value(&self, quadrature: &VisibleNormalQuadrature, position: &[f64]) -> Vec<f64> {
        vec![fgd_by_quadrature(self.masking, quadrature, position[0], position[1], (position[2], position[3]))]
    }
}

/// The visible-normal measure of every `(mu, alpha)` node of `mu_axis` x `alpha_axis` (`mu`
/// fastest), on `points` with `masking` on the hat `basis`.
///
/// FGD and `fgd_rarer` integrate the same measures (the same nodes, masking, hats and points by
/// default): the set built last is kept and handed out again when the next table asks for the same
/// one, so that a build of both estimates them once. They depend on nothing but the key.
pub(crate) fn mu_alpha_measures(
    mu_axis: &Axis,
    alpha_axis: &Axis,
    masking: MaskingShadowing,
    points: &PointSet,
    basis: HatBasis,
    progress: &dyn Progress,
) -> std::sync::Arc<Vec<CosineMeasure>> {
    let bits = |axis: &Axis| axis.node_values().iter().map(|v| v.to_bits()).collect::<Vec<u64>>();
    let key: MeasuresKey = (bits(mu_axis), bits(alpha_axis), masking, basis.intervals, points.plan(), points.seed());
    // A panic elsewhere while the lock was held leaves at worst a complete set or none.
    if let Some((_, measures)) =
        LAST.lock().unwrap_or_else(|poisoned| poisoned.into_inner()).as_ref().filter(|(k, _)| *k == key)
    {
        return measures.clone();
    }
    let cells: Vec<u64> = (0..(mu_axis.count * alpha_axis.count) as u64).collect();
    let measures = std::sync::Arc::new(estimate_cells(&cells, "fgd measures", progress, |cell| {
        let (i, j) = (cell as usize % mu_axis.count, cell as usize / mu_axis.count);
        cosine_measure(mu_axis.node_value(i), alpha_axis.node_value(j), masking, points, basis)
    }));
    *LAST.lock().unwrap_or_else(|poisoned| poisoned.into_inner()) = Some((key, measures.clone()));
    measures
}

type MeasuresKey = (Vec<u64>, Vec<u64>, MaskingShadowing, usize, crate::sampling::sequence::SamplePlan, u64);
/// The measures [`mu_alpha_measures`] built last, with what they depend on.
static LAST: std::sync::Mutex<Option<(MeasuresKey, std::sync::Arc<Vec<CosineMeasure>>)>> = std::sync::Mutex::new(None);

/// Drop the measures [`mu_alpha_measures`] keeps, so that the next build estimates its own (a
/// benchmark times each build from scratch).
pub fn forget_kept_measures() {
    *LAST.lock().unwrap_or_else(|poisoned| poisoned.into_inner()) = None;
}

/// The fast path: measures, projected Fresnel, one matrix product. Returns the replicate spread
/// over `settings.replicate_error_columns` random `(eta, kappa)` columns, and, when that is all of
/// them, the standard error of every node (one more matrix product per replicate).
fn build_fast(
    settings: &FgdSettings,
    points: &PointSet,
    table: &mut Table,
    progress: &dyn Progress,
) -> (ErrorSummary, Option<Vec<f32>>) {
    let basis = HatBasis { intervals: settings.cosine_intervals };
    let k = basis.node_count();
    let (mu_axis, alpha_axis) = (table.axes[0].clone(), table.axes[1].clone());
    let (eta_axis, kappa_axis) = (table.axes[2].clone(), table.axes[3].clone());
    let plane = mu_axis.count * alpha_axis.count;
    let columns = eta_axis.count * kappa_axis.count;

    // Measures, one per (mu, alpha) and replicate.
    let measures = mu_alpha_measures(&mu_axis, &alpha_axis, settings.masking, points, basis, progress);
    let measures: &[CosineMeasure] = &measures;
    let mean: Vec<f64> = measures.iter().flat_map(|m| m.mean_moments(basis)).collect();
    let fresnel_of_column = |column: usize| {
        let (e, q) = (column % eta_axis.count, column / eta_axis.count);
        (eta_axis.node_value(e), kappa_axis.node_value(q))
    };

    // Fresnel, one projection per (eta, kappa).
    let projections: Vec<Projection> = (0..columns)
        .into_par_iter()
        .map(|column| {
            let (eta, kappa) = fresnel_of_column(column);
            projected_fresnel(basis, eta, kappa)
        })
        .collect();
    let fresnel: Vec<f64> = projections.iter().flat_map(|p| p.coefficients.iter().copied()).collect();
    // What the product with the hat moments misses on narrow lobes where the projection does not
    // resolve Fresnel ([`CosineMeasure::correction`]), per replicate; as (column, cell, values).
    // (Point masses, the same in every replicate, are added below.)
    let replicates = points.plan().replicates as usize;
    let off_basis: Vec<usize> =
        (0..plane).filter(|&cell| matches!(measures[cell], CosineMeasure::Local { .. })).collect();
    let corrections: Vec<(usize, usize, Vec<f64>)> = (0..columns)
        .into_par_iter()
        .flat_map_iter(|column| {
            let (eta, kappa) = fresnel_of_column(column);
            let kinks = fresnel_kinks(eta);
            let projection = &projections[column];
            let measures = &measures;
            off_basis.iter().filter_map(move |&cell| {
                measures[cell]
                    .correction(projection, |c| fresnel_reflectance(c, eta, kappa), &kinks, replicates)
                    .map(|values| (column, cell, values))
            })
        })
        .collect();

    // FGD[(eta, kappa)][(mu, alpha)] = Σ_k F[(eta, kappa)][k] M[(mu, alpha)][k]: with (mu, alpha)
    // fastest, the row-major result is the table's own node order.
    let mut product = vec![0.0f64; columns * plane];
    multiply_transposed(MatrixRef::new(&fresnel, columns, k), MatrixRef::new(&mean, plane, k), &mut product);
    // Smooth-surface cells hold a point mass instead (their rows of `mean` are zero).
    product.par_chunks_mut(plane).enumerate().for_each(|(column, row)| {
        let (eta, kappa) = fresnel_of_column(column);
        for (value, measure) in row.iter_mut().zip(measures) {
            if let CosineMeasure::PointMass { cosine, weight } = measure {
                *value += weight * fresnel_reflectance(*cosine, eta, kappa);
            }
        }
    });
    for (column, cell, values) in &corrections {
        product[column * plane + cell] += values.iter().sum::<f64>() / values.len() as f64;
    }
    // Next to a critical angle the projected Fresnel may overshoot its range (an L2 projection of
    // a kink; down to -9.4e-6, `docs/stability.md`); the albedo itself cannot leave [0, 1].
    for (value, p) in table.data.iter_mut().zip(&product) {
        *value = p.clamp(0.0, 1.0) as f32;
    }

    if settings.replicate_error_columns >= columns {
        let map: Vec<f32> = standard_errors(&fresnel, measures, &corrections, basis, replicates, columns)
            .into_iter()
            .map(|s| s as f32)
            .collect();
        return (ErrorSummary::of_differences(map.iter().map(|&s| s as f64)), Some(map));
    }

    // Replicate spread at a random subset of (eta, kappa) columns, every (mu, alpha): the same
    // products on those columns' rows, with the corrections already computed for them.
    let sampled: Vec<usize> = random_cells(columns, settings.replicate_error_columns, points.seed() ^ 0xC011)
        .into_iter()
        .map(|column| column as usize)
        .collect();
    let sampled_fresnel: Vec<f64> =
        sampled.iter().flat_map(|&column| projections[column].coefficients.clone()).collect();
    let sampled_corrections: Vec<(usize, usize, Vec<f64>)> = corrections
        .iter()
        .filter_map(|(column, cell, values)| sampled.binary_search(column).ok().map(|row| (row, *cell, values.clone())))
        .collect();
    let spread = standard_errors(&sampled_fresnel, measures, &sampled_corrections, basis, replicates, sampled.len());
    (ErrorSummary::of_differences(spread), None)
}

/// The replicate standard error of every node of the `columns` rows of `fresnel` (projected Fresnel,
/// with `corrections` numbered by those rows), every `(mu, alpha)` fastest: one product per
/// replicate, combined with Welford's running mean and sum of squares (so only one replicate's
/// product is held at a time).
fn standard_errors(
    fresnel: &[f64],
    measures: &[CosineMeasure],
    corrections: &[(usize, usize, Vec<f64>)],
    basis: HatBasis,
    replicates: usize,
    columns: usize,
) -> Vec<f64> {
    let k = basis.node_count();
    let plane = measures.len();
    let mut mean = vec![0.0f64; columns * plane];
    let mut sum_of_squares = vec![0.0f64; columns * plane];
    let mut product = vec![0.0f64; columns * plane];
    for r in 0..replicates {
        let moments: Vec<f64> = measures.iter().flat_map(|m| m.replicate_moments(r, basis)).collect();
        multiply_transposed(MatrixRef::new(fresnel, columns, k), MatrixRef::new(&moments, plane, k), &mut product);
        for (column, cell, values) in corrections {
            product[column * plane + cell] += values[r];
        }
        let count = (r + 1) as f64;
        mean.par_iter_mut().zip(sum_of_squares.par_iter_mut()).zip(&product).for_each(|((m, s), &x)| {
            let delta = x - *m;
            *m += delta / count;
            *s += delta * (x - *m);
        });
    }
    let r = replicates as f64;
    // Point masses are exact: their rows are zero in every replicate, so their spread is 0.
    sum_of_squares.iter().map(|&s| if replicates < 2 { 0.0 } else { (s / (r - 1.0) / r).sqrt() }).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recipes::driver::build;
    use crate::recipes::settings::ReferenceConfig;
    use crate::recipes::{random_cells, reference_points};

    /// A table of `counts` nodes (mu, alpha, eta, kappa), without the reference check.
    fn small([mu_count, alpha_count, eta_count, kappa_count]: [usize; 4]) -> FgdSettings {
        let mut settings = FgdSettings {
            mu_count,
            alpha_count,
            eta_count,
            kappa_count,
            replicate_error_columns: 16,
            ..FgdSettings::default()
        };
        settings.shared.reference = ReferenceConfig { cells: 0, nodes: 8 };
        settings
    }

    #[test]
    fn agrees_with_independent_per_cell_estimates_at_random_nodes() {
        // A reduced grid at the default 2^16 samples, against 2^20-sample per-cell f64 references
        // with independent scrambles, at nodes with mu and alpha away from 0 (the bench runs the
        // full 300-node, 2^22-sample version).
        let settings = small([12, 12, 9, 7]);
        let table = build(&settings, 5, &()).unwrap().table;
        let points = reference_points(1 << 20, 5).unwrap();
        let differences: Vec<f64> = random_cells(table.node_count(), 400, 9)
            .into_iter()
            .map(|n| table.node_position(&table.node_index(n as usize)))
            .filter(|p| p[0] >= 0.05 && p[1] >= 0.05)
            .take(40)
            .map(|p| {
                let n = table.node_number(
                    &p.iter()
                        .zip(&table.axes)
                        .map(|(&x, a)| a.continuous_index(x).round() as usize)
                        .collect::<Vec<_>>(),
                );
                table.data[n] as f64 - settings.estimate_node(&points, &p).mean[0]
            })
            .collect();
        assert_eq!(differences.len(), 40);
        let error = ErrorSummary::of_differences(differences);
        assert!(error.rms <= 1e-5 && error.max <= 1e-4, "{error:?}");
    }

    #[test]
    fn cells_sharing_mu_alpha_get_the_bits_of_each_cell_alone() {
        let points = reference_points(1 << 12, 8).unwrap();
        let pairs = [(1.5, 0.0), (0.6, 0.0), (2.5, 3.0), (1.0, 0.0)];
        for (mu, alpha) in [(0.4, 0.3), (0.0, 0.8), (1.0, 0.0)] {
            for masking in MaskingShadowing::ALL {
                let grouped = fgd_cells_at_mu_alpha(masking, &points, mu, alpha, &pairs);
                assert_eq!(grouped.len(), pairs.len());
                for (estimate, &(eta, kappa)) in grouped.iter().zip(&pairs) {
                    // The cell alone, through the generic per-cell path.
                    let alone = crate::integrate::estimate_cosine_functions(
                        mu,
                        alpha,
                        masking,
                        Method::PerCell,
                        &points,
                        |c| [fresnel_reflectance(c, eta, kappa)],
                    );
                    assert_eq!(estimate.mean[0].to_bits(), alone.mean[0].to_bits(), "{masking:?} {mu} {alpha} {eta}");
                    assert_eq!(estimate.standard_error[0].to_bits(), alone.standard_error[0].to_bits());
                }
            }
        }
    }

    #[test]
    fn edges_match_their_limits() {
        let mut settings = small([9, 5, 9, 5]);
        settings.shared.sampling = SamplingConfig::replicated(1 << 12);
        let table = build(&settings, 6, &()).unwrap().table;
        let stats = table.stats();
        assert_eq!(stats.nan_count + stats.infinite_count, 0);
        assert!(stats.min >= 0.0 && stats.max <= 1.0, "{stats:?}");
        for n in 0..table.node_count() {
            let index = table.node_index(n);
            let p = table.node_position(&index);
            let (mu, alpha, eta, kappa) = (p[0], p[1], p[2], p[3]);
            let value = table.data[n] as f64;
            // No interface, no reflection.
            if eta == 1.0 && kappa == 0.0 {
                assert_eq!(value, 0.0, "{p:?}");
            }
            // A smooth interface is a mirror: exact Fresnel at the view angle.
            if alpha == 0.0 {
                let exact = fresnel_reflectance(mu.max(crate::integrate::GRAZING_COSINE), eta, kappa);
                assert!((value - exact).abs() < 1e-5, "{p:?}: {value} vs {exact}");
            }
        }
    }

    #[test]
    fn both_methods_agree() {
        let mut base = small([4, 3, 4, 3]);
        base.shared.sampling = SamplingConfig::replicated(1 << 12);
        let fast = build(&base, 7, &()).unwrap().table;
        let per_cell = build(&FgdSettings { method: Method::PerCell, ..base }, 7, &()).unwrap().table;
        for (n, (a, b)) in fast.data.iter().zip(&per_cell.data).enumerate() {
            // Same points; they differ by the hat projection and f32 sampling only.
            assert!((a - b).abs() < 2e-4, "node {:?}: {a} vs {b}", fast.node_index(n));
        }
    }

    #[test]
    fn bad_ranges_are_refused() {
        let err = build(&FgdSettings { eta_range: [2.0, 1.0], ..FgdSettings::default() }, 1, &()).unwrap_err();
        assert!(err.to_string().contains("fgd.eta_range"), "{err}");
        let err = build(&FgdSettings { kappa_range: [-1.0, 1.0], ..FgdSettings::default() }, 1, &()).unwrap_err();
        assert!(err.to_string().contains("fgd.kappa_range"), "{err}");
    }
}
