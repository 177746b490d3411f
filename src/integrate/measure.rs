//! The fast path (`notes/fast-integration.md`): with visible-normal sampling every albedo-type
//! table is `∫ f(c) dM_{mu,alpha}(c)` for one weighted distribution `M` of `c = wi.h` per
//! `(mu, alpha)`. Estimate `M` once, projected onto hat functions of `c`, and every function of
//! `c` — Fresnel for any `(eta, kappa)`, Schlick's weight, a basis curve — is a dot product with
//! its values at the nodes; a whole 4D table is one matrix product.

use rayon::prelude::*;

use super::batch::{CellWarp, for_each_block};
use super::{Estimate, GRAZING_COSINE, combine_replicates};
use crate::physics::{MaskingShadowing, direction_from_cosine, reflect};
use crate::sampling::sequence::PointSet;

/// Hat functions on `intervals + 1` uniform nodes `c_k = k / intervals` over [0, 1].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HatBasis {
    pub intervals: usize,
}

impl HatBasis {
    pub fn node_count(&self) -> usize {
        self.intervals + 1
    }

    pub fn node(&self, k: usize) -> f64 {
        k as f64 / self.intervals as f64
    }

    /// Values of `f` at the nodes.
    pub fn tabulate(&self, f: impl Fn(f64) -> f64) -> Vec<f64> {
        (0..self.node_count()).map(|k| f(self.node(k))).collect()
    }

    /// The coefficients `f~` with `Σ_k f~_k M_k ≈ ∫ f dM` for a measure given by its hat moments
    /// `M_k`: the L2 projection `G^-1 Φ` with `Φ_k = ∫ f hat_k` and `G` the Gram matrix of the hats.
    ///
    /// It is exact when the measure's density is piecewise linear, whatever `f` does between nodes,
    /// where plain node values `f(c_k)` are exact only when `f` is. That matters for Fresnel past
    /// the critical angle, which rises like a square root from its kink: give the kink's location
    /// in `kinks` and the quadrature splits there, substituting `c = c* + s^2` on the side where the
    /// square root starts, so each piece is smooth.
    pub fn project(&self, f: impl Fn(f64) -> f64, kinks: &[f64]) -> Vec<f64> {
        let n = self.intervals;
        let h = 1.0 / n as f64;
        let mut moments = vec![0.0; n + 1];
        for k in 0..n {
            let (a, b) = (self.node(k), self.node(k + 1));
            let mut pieces = vec![a];
            pieces.extend(kinks.iter().copied().filter(|&c| c > a && c < b));
            pieces.push(b);
            for piece in pieces.windows(2) {
                let (lower, upper) = (piece[0], piece[1]);
                let starts_at_kink = kinks.contains(&lower);
                for (x, w) in GAUSS_LEGENDRE_8 {
                    // Map the node x in [-1, 1] to [lower, upper], through c = lower + s^2 when the
                    // piece starts at a kink (dc = 2 s ds).
                    let (c, jacobian) = if starts_at_kink {
                        let span = (upper - lower).sqrt();
                        let s = 0.5 * span * (x + 1.0);
                        (lower + s * s, 0.5 * span * 2.0 * s)
                    } else {
                        (lower + 0.5 * (upper - lower) * (x + 1.0), 0.5 * (upper - lower))
                    };
                    let value = f(c) * w * jacobian;
                    let t = (c - a) / h;
                    moments[k] += value * (1.0 - t);
                    moments[k + 1] += value * t;
                }
            }
        }
        solve_hat_gram(n, moments)
    }

    /// Split weight `w` at `c` between the two nodes around it (linear interpolation weights).
    #[inline]
    pub fn deposit(&self, measure: &mut [f64], c: f32, w: f32) {
        let u = c as f64 * self.intervals as f64;
        let k = (u as usize).min(self.intervals - 1);
        let t = u - k as f64;
        let w = w as f64;
        measure[k] += w * (1.0 - t);
        measure[k + 1] += w * t;
    }
}

/// Gauss–Legendre nodes and weights on [-1, 1], 8 points (exact for polynomials up to degree 15).
const GAUSS_LEGENDRE_8: [(f64, f64); 8] = [
    (-0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
    (-0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (-0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (-0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
];

/// Solve `G x = b` for the Gram matrix of hat functions on `n` uniform intervals of [0, 1]:
/// tridiagonal, `h/6 * [1 4 1]` inside and `h/6 * [2 1]` at the two ends (Thomas algorithm; the
/// matrix is diagonally dominant, so no pivoting is needed).
fn solve_hat_gram(n: usize, mut b: Vec<f64>) -> Vec<f64> {
    let h = 1.0 / n as f64;
    let off = h / 6.0;
    let diagonal = |k: usize| if k == 0 || k == n { h / 3.0 } else { 2.0 * h / 3.0 };
    let mut c_prime = vec![0.0; n + 1];
    c_prime[0] = off / diagonal(0);
    b[0] /= diagonal(0);
    for k in 1..=n {
        let denominator = diagonal(k) - off * c_prime[k - 1];
        c_prime[k] = off / denominator;
        b[k] = (b[k] - off * b[k - 1]) / denominator;
    }
    for k in (0..n).rev() {
        b[k] -= c_prime[k] * b[k + 1];
    }
    b
}

/// The measure `M_{mu,alpha}` of `c = wi.h` weighted by `W = G2 / G1(wi)`, for one cell.
#[derive(Debug, Clone, PartialEq)]
pub enum CosineMeasure {
    /// A rough surface: the measure on a hat basis, one vector per replicate, entry `k` being
    /// `E[W hat_k(wi.h)]`, so that `E[f(wi.h) W] ≈ Σ_k f~_k M_k` with `f~` from
    /// [`HatBasis::project`].
    Spread { replicates: Vec<Vec<f64>> },
    /// A smooth surface (`alpha = 0`): every visible normal is the normal itself, so the measure is
    /// a point mass at `c = mu`. No finite basis represents it exactly, and near a critical angle
    /// the difference is of order 1e-2, so it is kept as what it is.
    PointMass { cosine: f64, weight: f64 },
}

impl CosineMeasure {
    /// Mean hat moments; all zero for a point mass (whose contribution is
    /// [`CosineMeasure::point_mass_integral`]).
    pub fn mean_moments(&self, basis: HatBasis) -> Vec<f64> {
        match self {
            CosineMeasure::Spread { replicates } => mean_measure(replicates),
            CosineMeasure::PointMass { .. } => vec![0.0; basis.node_count()],
        }
    }

    /// Hat moments of replicate `r`; all zero for a point mass (which is the same in every
    /// replicate).
    pub fn replicate_moments(&self, r: usize, basis: HatBasis) -> Vec<f64> {
        match self {
            CosineMeasure::Spread { replicates } => replicates[r].clone(),
            CosineMeasure::PointMass { .. } => vec![0.0; basis.node_count()],
        }
    }

    /// The same measure with its replicates averaged into one (to keep fewer numbers around).
    pub fn averaged(&self) -> CosineMeasure {
        match self {
            CosineMeasure::Spread { replicates } => {
                CosineMeasure::Spread { replicates: vec![mean_measure(replicates)] }
            }
            point => point.clone(),
        }
    }

    /// `∫ f dM` of the point-mass part: `weight * f(cosine)`, or 0 for a spread measure.
    pub fn point_mass_integral(&self, f: impl Fn(f64) -> f64) -> f64 {
        match self {
            CosineMeasure::Spread { .. } => 0.0,
            CosineMeasure::PointMass { cosine, weight } => weight * f(*cosine),
        }
    }

    /// `∫ f_j dM` for several functions, each given both projected on the hat basis (`projected`)
    /// and as a function (`exact`, returning one value per function), with replicate error bars.
    pub fn integrate(&self, projected: &[&[f64]], exact: impl Fn(f64) -> Vec<f64>) -> Estimate {
        match self {
            CosineMeasure::Spread { replicates } => integrate_against(replicates, projected),
            CosineMeasure::PointMass { cosine, weight } => Estimate {
                mean: exact(*cosine).iter().map(|v| weight * v).collect(),
                standard_error: vec![0.0; projected.len()],
            },
        }
    }
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
    let warp = CellWarp::new(mu, alpha);
    let replicates = points
        .replicates_f32()
        .iter()
        .map(|replicate| {
            let mut measure = vec![0.0; basis.node_count()];
            for_each_block(&warp, masking, replicate, |block| {
                for (&c, &w) in block.cos_wi_h.iter().zip(block.weight) {
                    basis.deposit(&mut measure, c, w);
                }
            });
            let n = replicate.len() as f64;
            measure.iter_mut().for_each(|m| *m /= n);
            measure
        })
        .collect();
    CosineMeasure::Spread { replicates }
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

pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// A dense row-major matrix view.
#[derive(Debug, Clone, Copy)]
pub struct MatrixRef<'a> {
    pub data: &'a [f64],
    pub rows: usize,
    pub cols: usize,
}

impl<'a> MatrixRef<'a> {
    pub fn new(data: &'a [f64], rows: usize, cols: usize) -> Self {
        assert_eq!(data.len(), rows * cols, "matrix of {rows} x {cols} needs {} values", rows * cols);
        MatrixRef { data, rows, cols }
    }
}

/// `C = A B^T` for row-major `A` (m x k) and `B` (n x k), into row-major `C` (m x n), with the
/// rows of `C` split across threads. Each element is one dot product over `k` computed by the same
/// kernel whatever the split, so the result does not depend on the thread count.
pub fn multiply_transposed(a: MatrixRef, b: MatrixRef, c: &mut [f64]) {
    assert_eq!(a.cols, b.cols, "inner dimensions differ");
    assert_eq!(c.len(), a.rows * b.rows, "output size");
    let (k, n) = (a.cols, b.rows);
    const ROWS_PER_TASK: usize = 64;
    c.par_chunks_mut(ROWS_PER_TASK * n).enumerate().for_each(|(task, c_rows)| {
        let first = task * ROWS_PER_TASK;
        let m = c_rows.len() / n;
        let a_rows = &a.data[first * k..(first + m) * k];
        // SAFETY: the pointers and strides describe slices whose lengths were checked above:
        // A rows m x k (row stride k), B^T as k x n through B's strides (row stride 1, column
        // stride k), C m x n (row stride n); C does not alias A or B.
        unsafe {
            matrixmultiply::dgemm(
                m,
                k,
                n,
                1.0,
                a_rows.as_ptr(),
                k as isize,
                1,
                b.data.as_ptr(),
                1,
                k as isize,
                0.0,
                c_rows.as_mut_ptr(),
                n as isize,
                1,
            );
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrate::estimate_visible_normal_integral;
    use crate::physics::fresnel_reflectance;
    use crate::sampling::sequence::SamplePlan;

    #[test]
    fn hat_deposits_preserve_mass_and_first_moment() {
        let basis = HatBasis { intervals: 8 };
        let mut m = vec![0.0; 9];
        for (c, w) in [(0.0f32, 1.0f32), (0.3, 2.0), (1.0, 0.5), (0.999, 1.0)] {
            basis.deposit(&mut m, c, w);
        }
        let mass: f64 = m.iter().sum();
        let moment: f64 = m.iter().enumerate().map(|(k, w)| basis.node(k) * w).sum();
        assert!((mass - 4.5).abs() < 1e-12);
        assert!((moment - (0.3f32 as f64 * 2.0 + 0.5 + 0.999f32 as f64)).abs() < 1e-9);
    }

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
                let reference = estimate_visible_normal_integral(mu, alpha, &reference_points, 1, |s, sums| {
                    sums[0] += fresnel_reflectance(s.cos_wi_h, eta, kappa)
                        * MaskingShadowing::SmithSeparable.visible_normal_weight(s.wi, s.wo, alpha);
                })
                .mean[0];
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
        let estimate = measure.integrate(&[&[0.0; 9]], |c| vec![f(c)]);
        assert_eq!(estimate.mean[0], f(0.875));
    }

    #[test]
    fn projection_reproduces_piecewise_linear_functions_and_integrates_smooth_ones() {
        let basis = HatBasis { intervals: 16 };
        let linear = basis.project(|c| 0.3 + 2.0 * c, &[]);
        for (k, v) in linear.iter().enumerate() {
            assert!((v - (0.3 + 2.0 * basis.node(k))).abs() < 1e-12, "node {k}: {v}");
        }
        let kinked = |c: f64| (c - 0.4).abs();
        let projected = basis.project(kinked, &[0.4]);
        // Against a piecewise-linear density the projection integrates exactly. Density 1 + c:
        // its hat moments are h (1 + c_k) inside and h/2 + h^2/6, h - h^2/6 at the ends.
        let h = 1.0 / 16.0;
        let moments: Vec<f64> = (0..=16)
            .map(|k| match k {
                0 => h / 2.0 + h * h / 6.0,
                16 => h - h * h / 6.0,
                _ => h * (1.0 + basis.node(k)),
            })
            .collect();
        let integral = dot(&projected, &moments);
        // ∫0^1 |c - 0.4| (1 + c) dc, split at 0.4.
        let left = |c: f64| 0.4 * c + 0.4 * c * c / 2.0 - c * c / 2.0 - c * c * c / 3.0;
        let right = |c: f64| c * c / 2.0 + c * c * c / 3.0 - 0.4 * c - 0.4 * c * c / 2.0;
        let exact = (left(0.4) - left(0.0)) + (right(1.0) - right(0.4));
        assert!((integral - exact).abs() < 1e-12, "{integral} vs {exact}");
    }

    #[test]
    fn matrix_product_matches_the_definition() {
        let (m, k, n) = (70, 9, 13);
        let a: Vec<f64> = (0..m * k).map(|i| (i as f64 * 0.37).sin()).collect();
        let b: Vec<f64> = (0..n * k).map(|i| (i as f64 * 0.11).cos()).collect();
        let mut c = vec![0.0; m * n];
        multiply_transposed(MatrixRef::new(&a, m, k), MatrixRef::new(&b, n, k), &mut c);
        for i in 0..m {
            for j in 0..n {
                let expected: f64 = (0..k).map(|l| a[i * k + l] * b[j * k + l]).sum();
                assert!((c[i * n + j] - expected).abs() < 1e-12);
            }
        }
    }
}
