//! The fast path (`docs/integration.md`): with visible-normal sampling every albedo-type
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
        project_on_nodes(&self.nodes(), f, kinks, None)
    }

    /// [`HatBasis::project`], and how far the projection is from `f` on each interval (the largest
    /// `|f - Σ f~_k hat_k|` at the nodes, the kinks and the quadrature points): where that is not
    /// small, a narrow measure there needs its own basis ([`CosineMeasure::Local`]).
    pub fn project_with_error(&self, f: impl Fn(f64) -> f64, kinks: &[f64]) -> Projection {
        let mut interval_error = vec![0.0; self.intervals];
        let coefficients = project_on_nodes(&self.nodes(), f, kinks, Some(&mut interval_error));
        Projection { coefficients, interval_error }
    }

    fn nodes(&self) -> Vec<f64> {
        (0..self.node_count()).map(|k| self.node(k)).collect()
    }

    /// Split weight `w` at `c` between the two nodes around it (linear interpolation weights).
    #[inline]
    pub fn deposit(&self, measure: &mut [f64], c: f64, w: f64) {
        let u = c * self.intervals as f64;
        let k = (u as usize).min(self.intervals - 1);
        let t = u - k as f64;
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

/// A function of `c` projected on a [`HatBasis`] ([`HatBasis::project_with_error`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Projection {
    pub coefficients: Vec<f64>,
    /// Per interval, the largest `|f - projection|` seen (see [`HatBasis::project_with_error`]).
    pub interval_error: Vec<f64>,
}

/// The L2 projection of `f` on the hats of the sorted `nodes` (see [`HatBasis::project`]); with
/// `interval_error`, also the largest pointwise difference to `f` on each interval.
fn project_on_nodes(
    nodes: &[f64],
    f: impl Fn(f64) -> f64,
    kinks: &[f64],
    interval_error: Option<&mut [f64]>,
) -> Vec<f64> {
    let n = nodes.len() - 1;
    let mut moments = vec![0.0; n + 1];
    let mut pieces = Vec::with_capacity(kinks.len() + 2);
    // (interval, c, f(c)) of every point f was evaluated at, when the error is wanted.
    let keep = interval_error.is_some();
    let mut evaluated = Vec::with_capacity(if keep { n * 8 + kinks.len() } else { 0 });
    for k in 0..n {
        let (a, b) = (nodes[k], nodes[k + 1]);
        let width = b - a;
        pieces.clear();
        pieces.push(a);
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
                let fc = f(c);
                if keep {
                    evaluated.push((k, c, fc));
                }
                let value = fc * w * jacobian;
                let t = (c - a) / width;
                moments[k] += value * (1.0 - t);
                moments[k + 1] += value * t;
            }
            if keep && piece[1] != b {
                evaluated.push((k, upper, f(upper)));
            }
        }
    }
    let coefficients = solve_hat_gram(nodes, moments);
    if let Some(errors) = interval_error {
        let mut record = |k: usize, c: f64, fc: f64| {
            let t = (c - nodes[k]) / (nodes[k + 1] - nodes[k]);
            let projected = coefficients[k] * (1.0 - t) + coefficients[k + 1] * t;
            errors[k] = errors[k].max((fc - projected).abs());
        };
        for (k, c, fc) in evaluated {
            record(k, c, fc);
        }
        for (k, &node) in nodes.iter().enumerate() {
            let fc = f(node);
            if k > 0 {
                record(k - 1, node, fc);
            }
            if k < n {
                record(k, node, fc);
            }
        }
    }
    coefficients
}

/// Solve `G x = b` for the Gram matrix of the hat functions on the sorted `nodes`: tridiagonal,
/// `(h_{k-1} + h_k) / 3` on the diagonal and `h_k / 6` beside it, `h_k` the interval widths (Thomas
/// algorithm; the matrix is diagonally dominant, so no pivoting is needed).
fn solve_hat_gram(nodes: &[f64], mut b: Vec<f64>) -> Vec<f64> {
    let n = nodes.len() - 1;
    let width = |k: usize| nodes[k + 1] - nodes[k];
    let off = |k: usize| width(k) / 6.0;
    let diagonal = |k: usize| {
        let left = if k > 0 { width(k - 1) } else { 0.0 };
        let right = if k < n { width(k) } else { 0.0 };
        (left + right) / 3.0
    };
    let mut c_prime = vec![0.0; n + 1];
    c_prime[0] = off(0) / diagonal(0);
    b[0] /= diagonal(0);
    for k in 1..=n {
        let denominator = diagonal(k) - off(k - 1) * c_prime[k - 1];
        c_prime[k] = if k < n { off(k) / denominator } else { 0.0 };
        b[k] = (b[k] - off(k - 1) * b[k - 1]) / denominator;
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
    /// A narrow lobe (small `alpha`, or `mu` near 1): most of its mass lies within a few hat
    /// intervals, where `Σ_k f~_k M_k` sees the projection's pointwise error `f - Σ f~_k hat_k` at
    /// the lobe (of order 1 at a critical angle or in Fresnel's grazing layer near `eta = 1`).
    /// The samples in `window` (whole intervals of the hat basis around the lobe) are also kept
    /// on the window's own hats (`core`, nodes graded down to the lobe's width), with their share
    /// of the hat moments (`core_hats`); `replicates` holds the moments of every sample, as for a
    /// spread measure. See [`CosineMeasure::correction`].
    Local { window: LocalHats, core: Vec<Vec<f64>>, core_hats: Vec<Vec<f64>>, replicates: Vec<Vec<f64>> },
    /// A smooth surface (`alpha = 0`): every visible normal is the normal itself, so the measure is
    /// a point mass at `c = mu`. No finite basis represents it exactly, and near a critical angle
    /// the difference is of order 1e-2, so it is kept as what it is.
    PointMass { cosine: f64, weight: f64 },
}

/// The hat functions of a [`CosineMeasure::Local`] window: sorted nodes from one node of the
/// global [`HatBasis`] to another, uniform at a quarter of the lobe's width over the lobe and
/// doubling outward from it.
#[derive(Debug, Clone, PartialEq)]
pub struct LocalHats {
    pub nodes: Vec<f64>,
    /// The global intervals the window covers, `first..end`.
    pub intervals: std::ops::Range<usize>,
}

/// A lobe is kept on its own hats when its width is below this many intervals of the global basis.
pub const LOCAL_LOBE_INTERVALS: f64 = 4.0;

/// The global projection is trusted inside a window where it is within this of `f` (pointwise):
/// 20 times below the 2e-4 the stability matrix holds the two paths to.
pub const PROJECTION_TOLERANCE: f64 = 1e-5;

impl LocalHats {
    /// The window around a lobe at `mu` of width `width` (both in `c`), in whole intervals of
    /// `basis`.
    fn around(mu: f64, width: f64, basis: HatBasis) -> LocalHats {
        let n = basis.intervals;
        let reach = 2.0 * width;
        let first = (((mu - reach) * n as f64).floor().max(0.0) as usize).min(n - 1);
        let end = (((mu + reach) * n as f64).ceil() as usize).clamp(first + 1, n);
        let (lower, upper) = (basis.node(first), basis.node(end));
        let step = width / 4.0;
        let mut nodes = vec![lower, upper];
        let mut offset = 0.0;
        let mut k = 0;
        // Offsets 0, s, 2s, ..., 8s (the lobe), then 16s, 32s, ... to the window's edges.
        while mu - offset > lower || mu + offset < upper {
            for c in [mu - offset, mu + offset] {
                if c > lower && c < upper {
                    nodes.push(c);
                }
            }
            k += 1;
            offset = if k <= 8 { k as f64 * step } else { offset * 2.0 };
        }
        nodes.sort_by(f64::total_cmp);
        // Nodes closer than 1e-3 of a step (mu on the window's edge, say) would make a singular Gram.
        nodes.dedup_by(|b, a| *b - *a < 1e-3 * step);
        if *nodes.last().expect("two nodes") < upper {
            nodes.pop();
            nodes.push(upper);
        }
        LocalHats { nodes, intervals: first..end }
    }

    /// Split weight `w` at `c` (inside the window) between the two nodes around it.
    fn deposit(&self, measure: &mut [f64], c: f64, w: f64) {
        let last = self.nodes.len() - 2;
        let k = self.nodes.partition_point(|&x| x <= c).saturating_sub(1).min(last);
        let t = ((c - self.nodes[k]) / (self.nodes[k + 1] - self.nodes[k])).clamp(0.0, 1.0);
        measure[k] += w * (1.0 - t);
        measure[k + 1] += w * t;
    }

    fn contains(&self, c: f64) -> bool {
        c >= self.nodes[0] && c <= self.nodes[self.nodes.len() - 1]
    }
}

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
    ///   [`PROJECTION_TOLERANCE`]): the window's samples against `f` projected on the window's own
    ///   hats, less their share of `Σ_k f~_k M_k`;
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
                let local = project_on_nodes(&window.nodes, f, kinks, None);
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
        let mut local = vec![0.0; window.nodes.len()];
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
            basis.deposit(&mut m, c as f64, w as f64);
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

    #[test]
    fn narrow_lobes_in_the_grazing_layer_match_the_per_cell_estimator() {
        // eta = 1 + 1e-6 at grazing views: Fresnel falls from 1 to 0 over c ~ 1e-3, inside the
        // lobe. Same points for both paths, so they differ by the representation only.
        let points = PointSet::new(SamplePlan::new(1 << 12, 4).unwrap(), 8);
        for (mu, alpha) in [(1e-6, 1e-7), (1e-6, 1e-4), (1e-3, 1e-4), (1e-6, 1e-2), (1e-3, 1e-2)] {
            for (eta, kappa) in [(1.0 + 1e-6, 0.0), (1.0 - 1e-6, 1e-6), (1.0, 1e-6)] {
                let (_, fast) = fast_fresnel(mu, alpha, eta, kappa, &points);
                let per_cell = estimate_visible_normal_integral(mu, alpha, &points, 1, |s, sums| {
                    sums[0] += fresnel_reflectance(s.cos_wi_h, eta, kappa)
                        * MaskingShadowing::SmithSeparable.visible_normal_weight(s.wi, s.wo, alpha);
                });
                let tolerance = 4.0 * fast.standard_error[0].hypot(per_cell.standard_error[0]) + 2e-4;
                assert!(
                    (fast.mean[0] - per_cell.mean[0]).abs() < tolerance,
                    "mu {mu} alpha {alpha} eta {eta} kappa {kappa}: {} vs {} (tolerance {tolerance:.1e})",
                    fast.mean[0],
                    per_cell.mean[0]
                );
                assert!(fast.mean[0] >= -1e-6, "no Gibbs undershoot: {}", fast.mean[0]);
            }
        }
    }

    #[test]
    fn a_local_window_is_whole_global_intervals_graded_down_to_the_lobe() {
        let basis = HatBasis { intervals: 256 };
        for (mu, width) in [(0.5, 1e-7), (1e-6, 1e-7), (1.0, 1e-8), (0.3, 0.01)] {
            let window = LocalHats::around(mu, width, basis);
            let nodes = &window.nodes;
            assert_eq!(nodes[0], basis.node(window.intervals.start), "mu {mu}");
            assert_eq!(*nodes.last().unwrap(), basis.node(window.intervals.end), "mu {mu}");
            assert!(nodes.windows(2).all(|w| w[1] > w[0]), "mu {mu}: sorted, distinct");
            assert!(nodes[0] <= mu - 2.0 * width || nodes[0] == 0.0, "mu {mu}: the lobe is inside");
            let finest = nodes.windows(2).map(|w| w[1] - w[0]).fold(f64::INFINITY, f64::min);
            assert!(finest <= width / 4.0 * 1.001, "mu {mu}: finest interval {finest:e}");
            assert!(nodes.len() < 64, "mu {mu}: {} nodes", nodes.len());
        }
    }

    #[test]
    fn projection_on_graded_nodes_is_exact_against_piecewise_linear_densities() {
        let nodes = [0.0, 1e-6, 3e-6, 7e-6, 1.5e-5, 0.5, 1.0];
        let linear = project_on_nodes(&nodes, |c| 0.3 + 2.0 * c, &[], None);
        for (v, c) in linear.iter().zip(nodes) {
            assert!((v - (0.3 + 2.0 * c)).abs() < 1e-12, "{v} at {c}");
        }
        // Density 1 on [0, 1]: hat moments are half the neighbouring widths.
        let moments: Vec<f64> = (0..nodes.len())
            .map(|k| {
                let left = if k > 0 { nodes[k] - nodes[k - 1] } else { 0.0 };
                let right = if k + 1 < nodes.len() { nodes[k + 1] - nodes[k] } else { 0.0 };
                (left + right) / 2.0
            })
            .collect();
        // A kink inside an interval (Fresnel's at a critical angle between two graded nodes).
        let a = 2e-6;
        let projected = project_on_nodes(&nodes, |c| (c - a).abs() + c * c, &[a], None);
        let exact = a * a / 2.0 + (1.0 - a) * (1.0 - a) / 2.0 + 1.0 / 3.0;
        assert!((dot(&projected, &moments) - exact).abs() < 1e-9, "{} vs {exact}", dot(&projected, &moments));
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
