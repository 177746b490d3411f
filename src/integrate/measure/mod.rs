//! The fast path (`docs/integration.md`): with visible-normal sampling every albedo-type
//! table is `∫ f(c) dM_{mu,alpha}(c)` for one weighted distribution `M` of `c = wi.h` per
//! `(mu, alpha)`. Estimate `M` once, projected onto hat functions of `c`, and every function of
//! `c` — Fresnel for any `(eta, kappa)`, Schlick's weight, a basis curve — is a dot product with
//! its values at the nodes; a whole 4D table is one matrix product.
//!
//! - [`hats`]: the hat bases (the global uniform one, and a narrow lobe's graded window) and the
//!   projection of a function onto them (the quadrature);
//! - this module: the measures themselves, per cell, estimated from visible-normal samples;
//! - [`linalg`]: dot and matrix products of projected functions with measures, the tridiagonal
//!   solve of the projection, and the symmetric eigensolver (cyclic Jacobi) the form fit's
//!   identifiability uses.

mod hats;
mod linalg;

pub use hats::{HatBasis, LocalHats, Projection};
pub use linalg::{MatrixRef, dot, multiply_transposed, symmetric_eigen};

use super::batch::{CellWarp, for_each_block};
use super::{Estimate, GRAZING_COSINE, combine_replicates};
use crate::physics::{MaskingShadowing, direction_from_cosine, reflect};
use crate::sampling::sequence::PointSet;
use hats::dual_weights;

/// The measure `M_{mu,alpha}` of `c = wi.h` weighted by `W = G2 / G1(wi)`, for one cell.
#[derive(Debug, Clone, PartialEq)]
pub enum CosineMeasure {
    /// A rough surface: the measure on a hat basis, one vector per replicate, entry `k` being
    /// `E[W hat_k(wi.h)]`, so that `E[f(wi.h) W] ≈ Σ_k f~_k M_k` with `f~` from
    /// [`HatBasis::project`].
    Spread { replicates: Vec<Vec<f64>> },
    /// A narrow lobe (small `alpha`, or `mu` near 1): most of its mass lies within a few hat
    /// intervals, where `Σ_k f~_k M_k` sees the projection's pointwise error `f - Σ f~_k hat_k` at
    /// the lobe (of order 1 at a critical angle or in Fresnel's grazing layer near `eta = 1`).
    /// The samples in `window` (whole intervals of the hat basis around the lobe) are also kept
    /// on the window's own intervals (`core`, two moments per interval, intervals graded down to
    /// the lobe's width), with their share of the hat moments (`core_hats`); `replicates` holds
    /// the moments of every sample, as for a spread measure. See [`CosineMeasure::correction`].
    Local { window: LocalHats, core: Vec<Vec<f64>>, core_hats: Vec<Vec<f64>>, replicates: Vec<Vec<f64>> },
    /// A smooth surface (`alpha = 0`): every visible normal is the normal itself, so the measure is
    /// a point mass at `c = mu`. No finite basis represents it exactly, and near a critical angle
    /// the difference is of order 1e-2, so it is kept as what it is.
    PointMass { cosine: f64, weight: f64 },
}

/// A lobe is kept on its own hats when its width is below this many intervals of the global basis.
pub const LOCAL_LOBE_INTERVALS: f64 = 4.0;

/// The global projection is trusted inside a window where it is within this of `f` (pointwise):
/// 20 times below the 2e-4 the stability matrix holds the two paths to.
pub const PROJECTION_TOLERANCE: f64 = 1e-5;

impl CosineMeasure {
    /// Mean hat moments on the global basis; all zero for a point mass (whose contribution is
    /// [`CosineMeasure::correction`]).
    pub fn mean_moments(&self, basis: HatBasis) -> Vec<f64> {
        match self {
            CosineMeasure::Spread { replicates } | CosineMeasure::Local { replicates, .. } => mean_measure(replicates),
            CosineMeasure::PointMass { .. } => vec![0.0; basis.node_count()],
        }
    }

    /// Hat moments of replicate `r`; all zero for a point mass (which is the same in every
    /// replicate).
    pub fn replicate_moments(&self, r: usize, basis: HatBasis) -> Vec<f64> {
        match self {
            CosineMeasure::Spread { replicates } | CosineMeasure::Local { replicates, .. } => replicates[r].clone(),
            CosineMeasure::PointMass { .. } => vec![0.0; basis.node_count()],
        }
    }

    /// The same measure with its replicates averaged into one (to keep fewer numbers around).
    pub fn averaged(&self) -> CosineMeasure {
        match self {
            CosineMeasure::Spread { replicates } => {
                CosineMeasure::Spread { replicates: vec![mean_measure(replicates)] }
            }
            CosineMeasure::Local { window, core, core_hats, replicates } => CosineMeasure::Local {
                window: window.clone(),
                core: vec![mean_measure(core)],
                core_hats: vec![mean_measure(core_hats)],
                replicates: vec![mean_measure(replicates)],
            },
            point => point.clone(),
        }
    }

    /// What `∫ f dM` needs beyond `Σ_k f~_k M_k` (the hat moments against `projection`, `f`
    /// projected on the global basis), per replicate (`replicates` of them):
    /// - a point mass: `weight * f(cosine)`;
    /// - a narrow lobe whose window the global projection does not resolve (an error above
    ///   [`PROJECTION_TOLERANCE`]): the window's samples against `f`, interval by interval
    ///   ([`dual_weights`]: exact where the samples' density is linear over an interval, kinks
    ///   included), less their share of `Σ_k f~_k M_k`;
    /// - otherwise nothing (`None`), and the product with the global basis is the whole answer.
    ///
    /// `f` and `kinks` are as for [`HatBasis::project`].
    pub fn correction(
        &self,
        projection: &Projection,
        f: impl Fn(f64) -> f64,
        kinks: &[f64],
        replicates: usize,
    ) -> Option<Vec<f64>> {
        match self {
            CosineMeasure::Spread { .. } => None,
            CosineMeasure::PointMass { cosine, weight } => Some(vec![weight * f(*cosine); replicates]),
            CosineMeasure::Local { window, core, core_hats, .. } => {
                let error = projection.interval_error[window.intervals.clone()].iter().fold(0.0f64, |a, &e| a.max(e));
                if error <= PROJECTION_TOLERANCE {
                    return None;
                }
                let local: Vec<f64> = dual_weights(&window.nodes, f, kinks).into_iter().flatten().collect();
                let global = &projection.coefficients[window.intervals.start..=window.intervals.end];
                Some(
                    core.iter()
                        .zip(core_hats)
                        .map(|(core, hats)| {
                            dot(&local, core) - dot(global, &hats[window.intervals.start..=window.intervals.end])
                        })
                        .collect(),
                )
            }
        }
    }

    /// `∫ f_j dM` for several functions, each given by its projection on the global `basis` and
    /// as a function (`f(j, c)`, with its `kinks`), with replicate error bars.
    pub fn integrate(&self, projections: &[&Projection], f: impl Fn(usize, f64) -> f64, kinks: &[f64]) -> Estimate {
        let replicates: &[Vec<f64>] = match self {
            CosineMeasure::Spread { replicates } | CosineMeasure::Local { replicates, .. } => replicates,
            CosineMeasure::PointMass { .. } => &[],
        };
        let count = replicates.len().max(1);
        let corrections: Vec<Option<Vec<f64>>> =
            (0..projections.len()).map(|j| self.correction(projections[j], |c| f(j, c), kinks, count)).collect();
        let per_replicate: Vec<Vec<f64>> = (0..count)
            .map(|r| {
                (0..projections.len())
                    .map(|j| {
                        let hats = replicates.get(r).map_or(0.0, |m| dot(&projections[j].coefficients, m));
                        hats + corrections[j].as_ref().map_or(0.0, |c| c[r])
                    })
                    .collect()
            })
            .collect();
        combine_replicates(&per_replicate, projections.len())
    }
}

/// The lobe's width in `c = wi.h` for a view cosine `mu` and roughness `alpha`: to first order
/// `wi.h - mu ≈ alpha sin(theta_i) * slope`, and at the normal `1 - wi.h ≈ alpha^2 slope^2 / 2`.
fn lobe_width(mu: f64, alpha: f64) -> f64 {
    alpha * ((1.0 - mu) * (1.0 + mu)).max(0.0).sqrt() + alpha * alpha
}

/// The measure of one cell (see [`CosineMeasure`]).
pub fn cosine_measure(
    mu: f64,
    alpha: f64,
    masking: MaskingShadowing,
    points: &PointSet,
    basis: HatBasis,
) -> CosineMeasure {
    let mu = mu.max(GRAZING_COSINE);
    if alpha == 0.0 {
        let wi = direction_from_cosine(mu);
        let weight = masking.visible_normal_weight(wi, reflect(wi, glam::DVec3::Z), 0.0);
        return CosineMeasure::PointMass { cosine: mu, weight };
    }
    let width = lobe_width(mu, alpha);
    if width >= LOCAL_LOBE_INTERVALS / basis.intervals as f64 {
        let warp = CellWarp::new(mu, alpha);
        let replicates = points
            .replicates_f32()
            .iter()
            .map(|replicate| {
                let mut measure = vec![0.0; basis.node_count()];
                for_each_block(&warp, masking, replicate, |block| {
                    for (&c, &w) in block.cos_wi_h.iter().zip(block.weight) {
                        basis.deposit(&mut measure, c as f64, w as f64);
                    }
                });
                let n = replicate.len() as f64;
                measure.iter_mut().for_each(|m| *m /= n);
                measure
            })
            .collect();
        return CosineMeasure::Spread { replicates };
    }
    // A narrow lobe: the cosine as mu + (wi.h - mu), the offset from the kernel, so that a lobe
    // narrower than the f32 spacing of c keeps its shape.
    let warp = CellWarp::with_offsets(mu, alpha);
    let window = LocalHats::around(mu, width, basis);
    let (mut core, mut core_hats, mut replicates) = (Vec::new(), Vec::new(), Vec::new());
    for replicate in points.replicates_f32() {
        let mut local = vec![0.0; window.moment_count()];
        let mut local_hats = vec![0.0; basis.node_count()];
        let mut all = vec![0.0; basis.node_count()];
        for_each_block(&warp, masking, replicate, |block| {
            for (&offset, &w) in block.cos_offset.iter().zip(block.weight) {
                if w == 0.0 {
                    continue;
                }
                let (c, w) = ((mu + offset as f64).clamp(0.0, 1.0), w as f64);
                basis.deposit(&mut all, c, w);
                if window.contains(c) {
                    window.deposit(&mut local, c, w);
                    basis.deposit(&mut local_hats, c, w);
                }
            }
        });
        let n = replicate.len() as f64;
        for m in [&mut local, &mut local_hats, &mut all] {
            m.iter_mut().for_each(|m| *m /= n);
        }
        core.push(local);
        core_hats.push(local_hats);
        replicates.push(all);
    }
    CosineMeasure::Local { window, core, core_hats, replicates }
}

/// Mean over replicates of per-replicate measures.
pub fn mean_measure(replicates: &[Vec<f64>]) -> Vec<f64> {
    let r = replicates.len() as f64;
    (0..replicates[0].len()).map(|k| replicates.iter().map(|m| m[k]).sum::<f64>() / r).collect()
}

/// The estimate of `∫ f dM` for several functions given by their projected node values, with
/// replicate error bars.
pub fn integrate_against(replicates: &[Vec<f64>], functions: &[&[f64]]) -> Estimate {
    let per_replicate: Vec<Vec<f64>> =
        replicates.iter().map(|m| functions.iter().map(|f| dot(f, m)).collect()).collect();
    combine_replicates(&per_replicate, functions.len())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrate::estimate_visible_normal_integral;
    use crate::physics::fresnel_reflectance;
    use crate::sampling::sequence::SamplePlan;

    #[test]
    fn fresnel_through_the_measure_matches_a_high_sample_reference() {
        // The fast path at 2^14 samples against the f64 per-cell estimator at 2^20 samples with
        // independent scrambles, across the critical angle of eta < 1 and for conductors.
        let points = PointSet::new(SamplePlan::new(1 << 14, 4).unwrap(), 11);
        let reference_points = PointSet::new(SamplePlan::new(1 << 20, 16).unwrap(), 12);
        let basis = HatBasis { intervals: 256 };
        for (mu, alpha) in [(0.8, 0.2), (0.1, 0.6), (0.5, 0.05)] {
            let CosineMeasure::Spread { replicates: measure } =
                cosine_measure(mu, alpha, MaskingShadowing::SmithSeparable, &points, basis)
            else {
                panic!("a rough surface has a spread measure")
            };
            for (eta, kappa) in [(1.5, 0.0), (0.7, 0.0), (0.2, 3.0), (2.5, 1.0)] {
                let kinks: Vec<f64> = crate::physics::critical_cosine(eta).into_iter().collect();
                let fresnel = basis.project(|c| fresnel_reflectance(c, eta, kappa), &kinks);
                let fast = integrate_against(&measure, &[&fresnel]);
                let (fast, standard_error) = (fast.mean[0], fast.standard_error[0]);
                let reference = per_cell_fresnel(mu, alpha, eta, kappa, &reference_points).mean[0];
                // Within four replicate standard errors, plus what the projection may cost.
                assert!(
                    (fast - reference).abs() < 4.0 * standard_error + 1e-5,
                    "mu {mu} alpha {alpha} eta {eta} kappa {kappa}: {fast} ± {standard_error} vs {reference}"
                );
            }
        }
    }

    #[test]
    fn a_smooth_surface_has_a_point_mass_at_the_view_cosine() {
        let points = PointSet::new(SamplePlan::new(64, 2).unwrap(), 1);
        let measure = cosine_measure(0.875, 0.0, MaskingShadowing::SmithSeparable, &points, HatBasis { intervals: 8 });
        assert_eq!(measure, CosineMeasure::PointMass { cosine: 0.875, weight: 1.0 });
        let f = |c: f64| fresnel_reflectance(c, 0.5, 0.0);
        let projection = HatBasis { intervals: 8 }.project_with_error(f, &[]);
        let estimate = measure.integrate(&[&projection], |_, c| f(c), &[]);
        assert_eq!(estimate.mean[0], f(0.875));
    }

    /// The fast path's FGD at one cell, as the recipes compute it.
    fn fast_fresnel(mu: f64, alpha: f64, eta: f64, kappa: f64, points: &PointSet) -> (CosineMeasure, Estimate) {
        let basis = HatBasis { intervals: 256 };
        let measure = cosine_measure(mu, alpha, MaskingShadowing::SmithSeparable, points, basis);
        let kinks: Vec<f64> = crate::physics::critical_cosine(eta).into_iter().collect();
        let projection = basis.project_with_error(|c| fresnel_reflectance(c, eta, kappa), &kinks);
        let estimate = measure.integrate(&[&projection], |_, c| fresnel_reflectance(c, eta, kappa), &kinks);
        (measure, estimate)
    }

    /// The same FGD by the f64 per-cell estimator, the independent cross-check.
    fn per_cell_fresnel(mu: f64, alpha: f64, eta: f64, kappa: f64, points: &PointSet) -> Estimate {
        estimate_visible_normal_integral(mu, alpha, points, 1, |s, sums| {
            sums[0] += fresnel_reflectance(s.cos_wi_h, eta, kappa)
                * MaskingShadowing::SmithSeparable.visible_normal_weight(s.wi, s.wo, alpha);
        })
    }

    #[test]
    fn a_narrow_lobe_gives_the_mirror_value_where_fresnel_is_sharp() {
        // alpha = 1e-7: the lobe is 1e-7 wide, and FGD is F(mu) times E[W] = 1 - O(alpha^2). The
        // cosines sit where F changes within one hat interval of 1/256: just past the critical
        // angle of eta = 0.5 (c* = 0.866), in the grazing layer of eta = 1 + 1e-6 (width 1.4e-3),
        // and 2e-7 from c = 1 past the critical angle of eta = 0.001 (c* = 1 - 5e-7), below the
        // f32 spacing of c. Before the lobes had their own hats these were off by up to 0.7.
        let points = PointSet::new(SamplePlan::new(1 << 10, 2).unwrap(), 5);
        for (mu, eta, kappa) in [
            (0.8661, 0.5, 0.0),
            (0.87, 0.5, 1e-6),
            (1e-3, 1.0 + 1e-6, 0.0),
            (3e-3, 1.0 - 1e-6, 0.0),
            (0.5, 1.5, 0.0),
            (1.0 - 2e-7, 1e-3, 0.0),
            (1.0, 1e-3, 1e-6),
        ] {
            let (measure, fast) = fast_fresnel(mu, 1e-7, eta, kappa, &points);
            assert!(matches!(measure, CosineMeasure::Local { .. }), "mu {mu}: a narrow lobe");
            let mirror = fresnel_reflectance(mu, eta, kappa);
            assert!(
                (fast.mean[0] - mirror).abs() < 2e-5,
                "mu {mu} eta {eta} kappa {kappa}: {} vs {mirror}",
                fast.mean[0]
            );
        }
    }

    /// The two estimates agree within four standard errors of their difference and `floor`.
    fn assert_agree(fast: &Estimate, per_cell: &Estimate, floor: f64, at: &str) {
        let tolerance = 4.0 * fast.standard_error[0].hypot(per_cell.standard_error[0]) + floor;
        assert!(
            (fast.mean[0] - per_cell.mean[0]).abs() < tolerance,
            "{at}: {} vs {} (tolerance {tolerance:.1e})",
            fast.mean[0],
            per_cell.mean[0]
        );
    }

    #[test]
    fn narrow_lobes_at_and_beside_a_critical_angle_match_the_per_cell_estimator() {
        // Fresnel of eta < 1 reaches 1 at the critical cosine as 1 - a sqrt(c - c*): a lobe on the
        // cusp, a lobe 0.002 below it (whose tail reaches into the hat interval of the cusp, where
        // the global projection is 0.07 off), and a lobe at grazing views of eta = 1 - 1e-7. Taken
        // on the window's hats instead of interval by interval these were off by 2.8e-3 to 5e-3.
        let points = PointSet::new(SamplePlan::new(1 << 14, 4).unwrap(), 9);
        let on_cusp = |mu: f64| (1.0 - mu * mu).sqrt();
        for (mu, alpha, eta) in [
            (0.844_046, 2.52e-4, 0.532_866),
            (0.844_046, 2.52e-4, on_cusp(0.844_046)),
            (0.466_347, 2.27e-3, on_cusp(0.466_347)),
            (9.77e-4, 1.01e-3, 1.0 - 9.2e-8),
        ] {
            let (measure, fast) = fast_fresnel(mu, alpha, eta, 0.0, &points);
            assert!(matches!(measure, CosineMeasure::Local { .. }), "mu {mu} alpha {alpha}: a narrow lobe");
            let per_cell = per_cell_fresnel(mu, alpha, eta, 0.0, &points);
            assert_agree(&fast, &per_cell, 5e-5, &format!("mu {mu} alpha {alpha} eta {eta}"));
        }
    }

    #[test]
    fn narrow_lobes_in_the_grazing_layer_match_the_per_cell_estimator() {
        // eta = 1 + 1e-6 at grazing views: Fresnel falls from 1 to 0 over c ~ 1e-3, inside the
        // lobe. Same points for both paths, so they differ by the representation only.
        let points = PointSet::new(SamplePlan::new(1 << 12, 4).unwrap(), 8);
        for (mu, alpha) in [(1e-6, 1e-7), (1e-6, 1e-4), (1e-3, 1e-4), (1e-6, 1e-2), (1e-3, 1e-2)] {
            for (eta, kappa) in [(1.0 + 1e-6, 0.0), (1.0 - 1e-6, 1e-6), (1.0, 1e-6)] {
                let (_, fast) = fast_fresnel(mu, alpha, eta, kappa, &points);
                let per_cell = per_cell_fresnel(mu, alpha, eta, kappa, &points);
                assert_agree(&fast, &per_cell, 2e-4, &format!("mu {mu} alpha {alpha} eta {eta} kappa {kappa}"));
                assert!(fast.mean[0] >= -1e-6, "no Gibbs undershoot: {}", fast.mean[0]);
            }
        }
    }
}
