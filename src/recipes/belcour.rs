//! The split-sum table of Belcour, Bati & Barla 2020 with a Fresnel basis (`docs/tables.md`):
//! Fresnel for any `(eta, kappa)` is `F ≈ Σ c_k b_k(c)` with `b0 = 1` and three curves built by
//! singular value decomposition of many Fresnel curves, and the table stores
//!
//! ```text
//! LUT_k(mu, alpha) = ∫ b_k(wi.h) D G2 / (4 mu) dwo = E_{h ~ D_wi}[ b_k(wi.h) G2 / G1(wi) ],   k = 0..3
//! ```
//!
//! so that `FGD ≈ Σ c_k LUT_k` with one RGBA fetch and coefficients from
//! [`FresnelBasis::coefficients`]. The basis and its probe cosines go into the manifest, since a
//! shader needs them. Height-correlated Smith by default, as the thesis says its table used.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::settings::{OutputConfig, SamplingConfig, SharedSettings};
use super::split_sum::{Orientation, RoughnessAxis, SplitSumSettings};
use super::{Integrated, Kernel, Metadata, TableRecipe, fill_mu_alpha_nodes};
use crate::error::Result;
use crate::formats::{FileFormat, Precision};
use crate::integrate::measure::{
    CosineMeasure, HatBasis, MatrixRef, Projection, cosine_measure, dot, multiply_transposed,
};
use crate::integrate::quadrature::VisibleNormalQuadrature;
use crate::integrate::{Estimate, Method, Progress, estimate_cells, estimate_cosine_functions};
use crate::physics::{FresnelBasis, MaskingShadowing, fresnel_reflectance};
use crate::sampling::sequence::PointSet;
use crate::stats::{AccuracyReport, ErrorSummary};
use crate::table::{Axis, Channel, Table};

use super::fgd::{fresnel_kinks, projected_fresnel};

pub const NAME: &str = crate::table::TableKind::Belcour.name();
/// One line for `tmlut list`.
pub const DESCRIPTION: &str = "Belcour-Bati-Barla 2020 split-sum with a Fresnel basis, 2D (n.v, roughness), 4 channels";
/// Channels of the table.
pub const CHANNEL_COUNT: usize = 4;
/// The configuration keys of the node counts, axis 0 first.
pub const COUNT_KEYS: &[&str] = super::split_sum::COUNT_KEYS;

/// The Belcour table's settings: the split-sum ones and its own.
pub type BelcourSettings = SplitSumSettings<BelcourOwn>;

/// What only the Belcour table has.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct BelcourOwn {
    /// Intervals of the hat basis in `c = wi.h` (fast method).
    pub cosine_intervals: usize,
}

impl Default for BelcourOwn {
    fn default() -> Self {
        BelcourOwn { cosine_intervals: 256 }
    }
}

impl Default for BelcourSettings {
    fn default() -> Self {
        BelcourSettings {
            mu_count: 128,
            roughness_count: 128,
            alpha_range: [0.0, 1.0],
            roughness_axis: RoughnessAxis::Perceptual,
            orientation: Orientation::SmoothFirst,
            masking: MaskingShadowing::SmithHeightCorrelated,
            method: Method::Fast,
            shared: SharedSettings {
                sampling: SamplingConfig::replicated(1 << 14),
                // Height-correlated masking at grazing views of rough lobes needs 8 nodes per panel
                // (6 are 1.7e-4 off 16 there; `docs/integration.md`, "Error estimates").
                interpolation: super::interpolation::InterpolationConfig { points: 2048, nodes: 8 },
                output: OutputConfig { formats: vec![FileFormat::Dds, FileFormat::Exr], precision: Precision::F16 },
                ..SharedSettings::default()
            },
            own: BelcourOwn::default(),
        }
    }
}

impl BelcourSettings {
    pub fn validate(&self) -> Result<()> {
        self.validate_split_sum(NAME, &FileFormat::for_table(2, false))?;
        super::settings::check_cosine_intervals("belcour.cosine_intervals", self.own.cosine_intervals)?;
        Ok(())
    }
}

/// Number of cosines and of Fresnel curves of the basis construction.
const BASIS_SAMPLES: usize = 1000;

/// Gulbrandsen 2014 ("Artist friendly metallic Fresnel", JCGT 3(4), eqs. 3-4): the complex index
/// with normal reflectivity `r` and edge tint `g`.
pub fn gulbrandsen_index(r: f64, g: f64) -> (f64, f64) {
    let sqrt_r = r.sqrt();
    let n = g * (1.0 - r) / (1.0 + r) + (1.0 - g) * (1.0 + sqrt_r) / (1.0 - sqrt_r);
    let k2 = (r * (1.0 + n).powi(2) - (n - 1.0).powi(2)) / (1.0 - r);
    (n, k2.max(0.0).sqrt())
}

/// The `(eta, kappa)` of curve `index` of the basis construction (Belcour, Bati & Barla 2020, the
/// curves their basis is fitted to; `docs/tables.md`).
/// Gulbrandsen's reflectivity `r' = (r / 0.01) / (1 - 1e-5) + 1e-5` reaches 1.00002 at `r = 0.01`,
/// where the mapping has no real index; it is capped at `1 - 1e-5`.
fn construction_curve(index: usize) -> (f64, f64) {
    if index == 0 {
        return (1.1, 0.0);
    }
    let r = index as f64 / BASIS_SAMPLES as f64;
    if r <= 0.01 {
        let reflectivity = ((r / 0.01) / (1.0 - 1e-5) + 1e-5).min(1.0 - 1e-5);
        gulbrandsen_index(reflectivity, 1.0)
    } else {
        (1.01 + 1.99 * (r - 0.01) / 0.99, 0.0)
    }
}

/// The leading right singular vectors of a row-major `rows x cols` matrix, by orthogonal
/// iteration on `A^T A` with a few more vectors than asked for (which speeds convergence of the
/// leading ones). Only the leading one or two are needed, so a full SVD would be wasted work.
fn leading_right_singular_vectors(a: &[f64], rows: usize, cols: usize, count: usize) -> Vec<Vec<f64>> {
    let block = count + 4;
    // A fixed, full-rank start, so that the result is deterministic.
    let mut v: Vec<Vec<f64>> = (0..block)
        .map(|j| (0..cols).map(|i| ((i * (j + 1)) as f64 * 0.618_034 + j as f64).sin() + 1.5).collect())
        .collect();
    orthonormalise(&mut v);
    // Converges at the rate (sigma_{block+1} / sigma_count)^2 per step; for the construction's
    // matrices (singular values 274, 26, 7.4 and 39, 9.7, 2.0, 0.42, ...) a few dozen steps.
    for _ in 0..1000 {
        let next: Vec<Vec<f64>> = v
            .par_iter()
            .map(|vj| {
                let av: Vec<f64> = (0..rows).map(|r| dot(&a[r * cols..(r + 1) * cols], vj)).collect();
                (0..cols).map(|c| (0..rows).map(|r| a[r * cols + c] * av[r]).sum()).collect()
            })
            .collect();
        let mut next = next;
        orthonormalise(&mut next);
        let change = (0..count).map(|j| 1.0 - dot(&next[j], &v[j]).abs()).fold(0.0, f64::max);
        v = next;
        // 1 - |cos| at rounding level: the direction is fixed to about 1e-7 radians.
        if change < 1e-14 {
            break;
        }
    }
    v.truncate(count);
    v
}

/// Modified Gram–Schmidt, in place.
fn orthonormalise(vectors: &mut [Vec<f64>]) {
    for j in 0..vectors.len() {
        for i in 0..j {
            let projection = dot(&vectors[i], &vectors[j]);
            let (head, tail) = vectors.split_at_mut(j);
            for (x, y) in tail[0].iter_mut().zip(&head[i]) {
                *x -= projection * y;
            }
        }
        let norm = dot(&vectors[j], &vectors[j]).sqrt();
        vectors[j].iter_mut().for_each(|x| *x /= norm);
    }
}

/// Build the basis by the SVD construction of Belcour, Bati & Barla 2020 (`docs/tables.md`), with the sign conventions fixed:
/// `b1 = |v0|`, `b2` positive at its largest magnitude, `b3` positive at the first probe cosine.
pub fn build_basis() -> FresnelBasis {
    let n = BASIS_SAMPLES;
    let cosines: Vec<f64> = (0..n).map(|i| i as f64 / (n - 1) as f64).collect();
    // Normalised curves (F(c) - F(1)) / (1 - F(1)), one row per curve.
    let mut curves: Vec<f64> = (0..n)
        .into_par_iter()
        .flat_map_iter(|index| {
            let (eta, kappa) = construction_curve(index);
            let f1 = fresnel_reflectance(1.0, eta, kappa);
            cosines.iter().map(move |&c| (fresnel_reflectance(c, eta, kappa) - f1) / (1.0 - f1)).collect::<Vec<_>>()
        })
        .collect();
    let scale_to_unit_peak = |v: &[f64]| {
        let peak = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        v.iter().map(|x| x / peak).collect::<Vec<f64>>()
    };
    let v0 = &leading_right_singular_vectors(&curves, n, n, 1)[0];
    let b1: Vec<f64> = scale_to_unit_peak(&v0.iter().map(|x| x.abs()).collect::<Vec<_>>());
    for row in curves.chunks_mut(n) {
        for (x, b) in row.iter_mut().zip(&b1) {
            *x -= b;
        }
    }
    let second = leading_right_singular_vectors(&curves, n, n, 2);
    let mut b2 = scale_to_unit_peak(&second[0]);
    if b2.iter().fold(0.0f64, |m, &x| if x.abs() > m.abs() { x } else { m }) < 0.0 {
        b2.iter_mut().for_each(|x| *x = -*x);
    }
    let first_probe = argmax(&b2);
    let mut b3 = scale_to_unit_peak(&second[1]);
    if b3[first_probe] < 0.0 {
        b3.iter_mut().for_each(|x| *x = -*x);
    }
    // The interior extremum of b3 farthest from the first probe.
    let second_probe = (1..n - 1)
        .filter(|&i| (b3[i] - b3[i - 1]) * (b3[i + 1] - b3[i]) <= 0.0 && b3[i] != 0.0)
        .max_by(|&i, &j| {
            let (di, dj) = ((i as f64 - first_probe as f64).abs(), (j as f64 - first_probe as f64).abs());
            di.total_cmp(&dj)
        })
        .unwrap_or(n / 2);
    FresnelBasis::new(b1, b2, b3, [cosines[first_probe], cosines[second_probe]])
}

fn argmax(v: &[f64]) -> usize {
    (0..v.len()).max_by(|&i, &j| v[i].total_cmp(&v[j])).unwrap_or(0)
}

impl BelcourSettings {
    /// One node by the fast method, as [`Kernel::integrate`] computes it: the f32 measure of `(mu, alpha)`
    /// times the basis curves projected on the hat basis.
    pub fn estimate_node_fast(&self, points: &PointSet, position: &[f64]) -> Estimate {
        let basis = basis();
        let hats = HatBasis { intervals: self.own.cosine_intervals };
        let projected = projected_basis(basis, hats);
        let projected: Vec<&Projection> = projected.iter().collect();
        let measure = cosine_measure(position[0], position[1], self.masking, points, hats);
        measure.integrate(&projected, |k, c| basis.evaluate(k, c), &basis_kinks(basis))
    }
}

/// The tabulated curves are piecewise linear: their kinks are at the tabulation cosines.
fn basis_kinks(basis: &FresnelBasis) -> Vec<f64> {
    (0..basis.samples).map(|i| i as f64 / (basis.samples - 1) as f64).collect()
}

/// The four basis curves projected on the hat basis (`b0 = 1` included).
fn projected_basis(basis: &FresnelBasis, hats: HatBasis) -> Vec<Projection> {
    let kinks = basis_kinks(basis);
    (0..4).map(|k| hats.project_with_error(|c| basis.evaluate(k, c), &kinks)).collect()
}

/// The basis, built once per process: it depends on nothing but the construction itself.
pub fn basis() -> &'static FresnelBasis {
    static BASIS: std::sync::OnceLock<FresnelBasis> = std::sync::OnceLock::new();
    BASIS.get_or_init(build_basis)
}

impl TableRecipe for BelcourSettings {
    table_recipe_accessors!();

    fn kept_measure_intervals(&self) -> Option<usize> {
        Some(self.own.cosine_intervals)
    }
}

impl Kernel for BelcourSettings {
    kernel_settings!();

    fn empty_table(&self) -> Result<Table> {
        let channels = (0..4)
            .map(|k| {
                let name = ["b0", "b1", "b2", "b3"][k];
                Channel::new(name, format!("∫ {name}(wi.h) D G2 / (4 mu) dwo; FGD ≈ Σ c_k {name}-channel"))
            })
            .collect();
        Table::zeros(NAME, self.axes()?, channels)
    }

    fn metadata(&self) -> Metadata {
        let mut notes = vec![
            "Runtime: FGD ≈ c0 b0 + c1 b1 + c2 b2 + c3 b3 (RGBA = b0..b3), coefficients from the basis in this manifest: c0 = F(1), c1 = 1 - c0, (c2, c3) from the 2x2 system at the probe cosines.".to_string(),
        ];
        notes.extend(self.layout_notes());
        Metadata {
            integrand: "LUT_k = E_{h~VNDF(wi)}[b_k(wi.h) G2(wi,wo) / G1(wi)], b0 = 1, b1..b3 the tabulated basis"
                .into(),
            masking: Some(self.masking),
            notes,
            sampler: "visible-normal measure per texel, times the projected basis".into(),
            fresnel_basis: Some(basis().clone()),
            channel_sum: None,
        }
    }

    /// The four integrals at every node, and how well `Σ c_k LUT_k` reproduces FGD there.
    fn integrate(&self, table: &mut Table, points: &PointSet, progress: &dyn Progress) -> Result<Integrated> {
        let basis = basis();
        let hats = HatBasis { intervals: self.own.cosine_intervals };
        let projected = projected_basis(basis, hats);
        let projected_refs: Vec<&Projection> = projected.iter().collect();
        let kinks = basis_kinks(basis);

        // The fast path keeps each node's mean measure: the accuracy report needs it too.
        let measures = std::sync::Mutex::new(vec![None; table.node_count()]);
        let estimates = fill_mu_alpha_nodes(table, progress, |node, mu, alpha| match self.method {
            Method::Fast => {
                let measure = cosine_measure(mu, alpha, self.masking, points, hats);
                let estimate = measure.integrate(&projected_refs, |k, c| basis.evaluate(k, c), &kinks);
                measures.lock().expect("measure store")[node] = Some(measure.averaged());
                estimate
            }
            Method::PerCell => basis_integrals(basis, self.masking, Method::PerCell, points, mu, alpha),
        });
        let mut measures: Vec<CosineMeasure> =
            measures.into_inner().expect("measure store").into_iter().flatten().collect();
        if self.method == Method::PerCell {
            let cells: Vec<u64> = (0..table.node_count() as u64).collect();
            measures = estimate_cells(&cells, "belcour accuracy", progress, |cell| {
                let position = table.node_position(&table.node_index(cell as usize));
                cosine_measure(position[0], position[1], self.masking, points, hats).averaged()
            });
        }
        Ok(Integrated { accuracy: split_sum_accuracy(table, basis, &measures, hats), ..Integrated::of(&estimates) })
    }

    fn estimate_node(&self, points: &PointSet, position: &[f64]) -> Estimate {
        basis_integrals(basis(), self.masking, Method::PerCell, points, position[0], position[1])
    }

    /// The curves' kinks are not panel edges: tabulated at 1,000 cosines, each is smooth to the
    /// quadrature's resolution.
    fn exact_value(&self, quadrature: &VisibleNormalQuadrature, position: &[f64]) -> Vec<f64> {
        let basis = basis();
        quadrature
            .cosine_functions(position[0], position[1], self.masking, &[], |c| {
                std::array::from_fn::<f64, 4, _>(|k| basis.evaluate(k, c))
            })
            .to_vec()
    }
}

/// The four integrals at one `(mu, alpha)`, each cell on its own.
fn basis_integrals(
    basis: &FresnelBasis,
    masking: MaskingShadowing,
    method: Method,
    points: &PointSet,
    mu: f64,
    alpha: f64,
) -> Estimate {
    estimate_cosine_functions::<4>(mu, alpha, masking, method, points, |c| {
        std::array::from_fn(|k| basis.evaluate(k, c))
    })
}

/// How well `Σ c_k LUT_k` reproduces FGD (same masking, same measures, so the difference is the
/// basis's own error), over three parts of the `(eta, kappa)` domain, at every node.
fn split_sum_accuracy(
    table: &Table,
    basis: &FresnelBasis,
    measures: &[CosineMeasure],
    hats: HatBasis,
) -> Vec<AccuracyReport> {
    let domains: [(&str, Vec<(f64, f64)>); 3] = [
        (
            "dielectrics, eta in [1.01, 3], kappa = 0 (the basis's own domain)",
            (0..40).map(|i| (1.01 + 1.99 * i as f64 / 39.0, 0.0)).collect(),
        ),
        (
            "conductors, eta in [0.05, 4], kappa in [0.5, 10]",
            (0..10)
                .flat_map(|i| (0..6).map(move |j| (0.05 + 3.95 * i as f64 / 9.0, 0.5 + 9.5 * j as f64 / 5.0)))
                .collect(),
        ),
        (
            "dielectrics with eta in [0.3, 0.99] (total internal reflection, outside the basis)",
            (0..20).map(|i| (0.3 + 0.69 * i as f64 / 19.0, 0.0)).collect(),
        ),
    ];
    // The measures' mean hat moments, one row per node: `∫ F dM` for every (eta, kappa) of a
    // domain at every node is one matrix product with the projected Fresnel rows, plus each narrow
    // lobe's correction ([`CosineMeasure::correction`]), as the FGD table is built.
    let k = hats.node_count();
    let moments: Vec<f64> = measures.iter().flat_map(|m| m.mean_moments(hats)).collect();
    let approximations: Vec<[f64; 4]> = (0..measures.len())
        .map(|node| {
            let lut = table.node(&table.node_index(node));
            std::array::from_fn(|c| lut[c] as f64)
        })
        .collect();
    domains
        .iter()
        .map(|(what, indices)| {
            let projections: Vec<Projection> =
                indices.par_iter().map(|&(eta, kappa)| projected_fresnel(hats, eta, kappa)).collect();
            let fresnel: Vec<f64> = projections.iter().flat_map(|p| p.coefficients.iter().copied()).collect();
            let mut exact = vec![0.0f64; indices.len() * measures.len()];
            multiply_transposed(
                MatrixRef::new(&fresnel, indices.len(), k),
                MatrixRef::new(&moments, measures.len(), k),
                &mut exact,
            );
            // (difference, eta, kappa, node) for every index and node.
            let differences: Vec<(f64, f64, f64, usize)> = indices
                .par_iter()
                .zip(&projections)
                .zip(exact.par_chunks(measures.len()))
                .flat_map_iter(|((&(eta, kappa), projection), exact)| {
                    let kinks = fresnel_kinks(eta);
                    let coefficients = basis.coefficients(eta, kappa);
                    let approximations = &approximations;
                    measures.iter().zip(exact).enumerate().map(move |(node, (measure, &on_hats))| {
                        let correction = measure
                            .correction(projection, |c| fresnel_reflectance(c, eta, kappa), &kinks, 1)
                            .map_or(0.0, |c| c[0]);
                        let approximate: f64 = (0..4).map(|k| coefficients[k] * approximations[node][k]).sum();
                        (approximate - (on_hats + correction), eta, kappa, node)
                    })
                })
                .collect();
            let worst = differences.iter().max_by(|a, b| a.0.abs().total_cmp(&b.0.abs()));
            let worst_at = worst.map_or(String::new(), |&(_, eta, kappa, node)| {
                let p = table.node_position(&table.node_index(node));
                format!("mu {:.4}, alpha {:.4}, eta {eta:.3}, kappa {kappa:.3}", p[0], p[1])
            });
            AccuracyReport::new(
                format!("Σ c_k LUT_k against FGD with the same masking, {what}"),
                ErrorSummary::of_differences(differences.iter().map(|d| d.0)),
                worst_at,
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recipes::settings::ReferenceConfig;

    #[test]
    fn gulbrandsen_mapping_reproduces_its_reflectivity() {
        for r in [0.1, 0.5, 0.9, 0.99] {
            let (n, k) = gulbrandsen_index(r, 1.0);
            assert!((crate::physics::normal_incidence_reflectance(n, k) - r).abs() < 1e-12, "r {r}: n {n} k {k}");
        }
    }

    #[test]
    fn basis_has_fixed_signs_and_reproduces_dielectrics_and_conductors() {
        let basis = build_basis();
        assert_eq!(basis.b1.len(), BASIS_SAMPLES);
        // b1 is the magnitude of the first singular vector, scaled to a unit peak.
        assert!(
            basis.b1.iter().all(|&x| x >= 0.0) && (basis.b1.iter().cloned().fold(0.0, f64::max) - 1.0).abs() < 1e-12
        );
        let [p, q] = basis.probe_cosines;
        assert!(basis.evaluate(2, p) > 0.0 && basis.evaluate(3, p) > 0.0, "signs at the first probe");
        assert!(p > 0.0 && p < 1.0 && q > 0.0 && q < 1.0 && p != q, "{p} {q}");
        // Inside its domain the four-term form follows exact Fresnel closely at every cosine.
        for (eta, kappa) in [(1.5, 0.0), (2.4, 0.0), (1.05, 0.0), (0.2, 3.0), (1.0, 6.0)] {
            let coefficients = basis.coefficients(eta, kappa);
            let worst = (0..=100)
                .map(|i| {
                    let c = i as f64 / 100.0;
                    (basis.approximate(&coefficients, c) - fresnel_reflectance(c, eta, kappa)).abs()
                })
                .fold(0.0, f64::max);
            assert!(worst < 0.02, "eta {eta} kappa {kappa}: {worst}");
            assert!(coefficients[2] != 0.0 || coefficients[3] != 0.0, "c2, c3 must be fitted");
        }
    }

    #[test]
    fn table_matches_per_cell_estimates_and_reports_its_accuracy() {
        let settings = BelcourSettings {
            mu_count: 8,
            roughness_count: 8,
            shared: SharedSettings {
                sampling: SamplingConfig::replicated(1 << 14),
                reference: ReferenceConfig { cells: 64, nodes: 8 },
                ..BelcourSettings::default().shared
            },
            ..BelcourSettings::default()
        };
        let build = settings.build(4, &()).unwrap();
        let stats = build.table.stats();
        assert_eq!(stats.nan_count + stats.infinite_count, 0);
        // b0 = 1: the channel is the height-correlated albedo, within [0, 1].
        assert!(build.table.channel_values(0).all(|v| (0.0..=1.0).contains(&v)));
        // Every node against 2^18-sample per-cell f64 estimates of all four channels.
        let reference = build.provenance.error.reference.as_ref().unwrap();
        assert_eq!(reference.difference.count, 256);
        assert!(reference.difference.max < 1e-3 && reference.difference.rms < 2e-4, "{reference:?}");
        // The accuracy report covers the three domains, and the basis's own domain does best.
        assert_eq!(build.provenance.accuracy.len(), 3);
        let [dielectrics, conductors, total_internal_reflection] =
            [0, 1, 2].map(|i| build.provenance.accuracy[i].error.rms);
        assert!(dielectrics < 0.01 && conductors < 0.01, "{:?}", build.provenance.accuracy);
        assert!(total_internal_reflection > 10.0 * dielectrics, "{:?}", build.provenance.accuracy);
        assert_eq!(build.provenance.metadata.fresnel_basis.as_ref(), Some(basis()));
    }

    #[test]
    fn basis_matches_an_independent_full_svd() {
        // Values from numpy.linalg.svd of the same construction (notebooks/belcour_basis.py).
        let basis = build_basis();
        assert!((basis.b1[500] - 0.048404048323316316).abs() < 1e-6, "{}", basis.b1[500]);
        assert!((basis.b2[500] - 0.3374159803462637).abs() < 1e-6, "{}", basis.b2[500]);
        assert!((basis.b3[500] - -0.6084733717290459).abs() < 1e-6, "{}", basis.b3[500]);
        assert!((basis.probe_cosines[0] - 0.12812812812812813).abs() < 1e-12);
        assert!((basis.probe_cosines[1] - 0.43243243243243246).abs() < 1e-12);
    }
}
