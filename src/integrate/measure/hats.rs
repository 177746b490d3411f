//! Hat functions of `c = wi.h` and the L2 projection of a function onto them: the quadrature
//! that turns `∫ f dM` into a dot product of projected node values with a measure's hat moments.

use super::linalg::solve_symmetric_tridiagonal;

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
    /// small, a narrow measure there needs its own basis ([`super::CosineMeasure::Local`]).
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

/// The hat functions of a [`super::CosineMeasure::Local`] window: sorted nodes from one node of the
/// global [`HatBasis`] to another, uniform at a quarter of the lobe's width over the lobe and
/// doubling outward from it.
#[derive(Debug, Clone, PartialEq)]
pub struct LocalHats {
    pub nodes: Vec<f64>,
    /// The global intervals the window covers, `first..end`.
    pub intervals: std::ops::Range<usize>,
    /// The lobe's centre, the spacing of the nodes over the lobe, and the index of the first node
    /// at or above the centre: the layout [`LocalHats::deposit`] guesses an interval from.
    centre: f64,
    step: f64,
    centre_node: usize,
}

/// Global intervals a window reaches past twice the lobe's width on each side. GGX lobes have
/// heavy tails, and next to a critical angle the global projection misses Fresnel by up to 0.2 in
/// the interval holding the cusp and by a few hundredths in its neighbours: with the window at
/// twice the width, the 5 % of a narrow lobe's weight outside it read Fresnel through that error
/// (2.8e-3 too much at `mu 0.844, alpha 2.5e-4, eta 0.533`). Three intervals more leave outside
/// about 1e-4 of the weight, where the projection's error has decayed.
pub const TAIL_INTERVALS: f64 = 3.0;

impl LocalHats {
    /// The window around a lobe at `mu` of width `width` (both in `c`), in whole intervals of
    /// `basis`, [`TAIL_INTERVALS`] beyond twice the width on each side.
    pub(super) fn around(mu: f64, width: f64, basis: HatBasis) -> LocalHats {
        let n = basis.intervals;
        let reach = 2.0 * width + TAIL_INTERVALS / n as f64;
        let first = (((mu - reach) * n as f64).floor().max(0.0) as usize).min(n - 1);
        let end = (((mu + reach) * n as f64).ceil() as usize).clamp(first + 1, n);
        let (lower, upper) = (basis.node(first), basis.node(end));
        let step = width / LOBE_STEPS_PER_WIDTH;
        let mut nodes = vec![lower, upper];
        let mut offset = 0.0;
        let mut k = 0;
        // Offsets 0, s, 2s, ..., twice the width (the lobe), then doubling to the window's edges.
        let lobe_steps = 2 * LOBE_STEPS_PER_WIDTH as usize;
        while mu - offset > lower || mu + offset < upper {
            for c in [mu - offset, mu + offset] {
                if c > lower && c < upper {
                    nodes.push(c);
                }
            }
            k += 1;
            offset = if k <= lobe_steps { k as f64 * step } else { offset * 2.0 };
        }
        nodes.sort_by(f64::total_cmp);
        // Nodes closer than 1e-3 of a step (mu on the window's edge, say) would make a singular Gram.
        nodes.dedup_by(|b, a| *b - *a < 1e-3 * step);
        if *nodes.last().expect("two nodes") < upper {
            nodes.pop();
            nodes.push(upper);
        }
        let centre_node = nodes.partition_point(|&x| x < mu);
        LocalHats { nodes, intervals: first..end, centre: mu, step, centre_node }
    }

    /// Split weight `w` at `c` (inside the window) between the two ends of the interval it lies
    /// in, kept per interval: `measure[2 k]` and `measure[2 k + 1]` are `∫ (1 - t) dM` and
    /// `∫ t dM` over interval `k` ([`dual_weights`]).
    pub(super) fn deposit(&self, measure: &mut [f64], c: f64, w: f64) {
        let k = self.interval_of(c);
        let t = ((c - self.nodes[k]) / (self.nodes[k + 1] - self.nodes[k])).clamp(0.0, 1.0);
        measure[2 * k] += w * (1.0 - t);
        measure[2 * k + 1] += w * t;
    }

    /// The interval `k` with `nodes[k] <= c < nodes[k + 1]` (the first below the nodes, the last
    /// above them): a guess from the nodes' layout (`k` steps from the centre over the lobe, then
    /// one more per doubling), then a walk to the exact one, which is a step or none. A binary
    /// search over the window's 70-odd nodes waits on seven dependent loads per sample, and the
    /// narrow lobes of a build deposit some 10^8 samples.
    #[inline(always)]
    fn interval_of(&self, c: f64) -> usize {
        let (nodes, last) = (&self.nodes, self.nodes.len() - 2);
        let lobe_steps = 2 * LOBE_STEPS_PER_WIDTH as usize;
        let steps = (c - self.centre).abs() / self.step;
        let from_centre = if steps < lobe_steps as f64 {
            steps as usize
        } else {
            // The binary exponent of steps / lobe_steps: the doublings past the lobe.
            let doublings = ((steps / lobe_steps as f64).to_bits() >> 52).saturating_sub(1023) as usize;
            lobe_steps.saturating_add(doublings)
        };
        let mut k = if c >= self.centre {
            self.centre_node.saturating_add(from_centre)
        } else {
            self.centre_node.saturating_sub(from_centre + 1)
        }
        .min(last);
        while k > 0 && nodes[k] > c {
            k -= 1;
        }
        while k < last && nodes[k + 1] <= c {
            k += 1;
        }
        k
    }

    /// Entries of a measure deposited by [`LocalHats::deposit`]: two per interval.
    pub(super) fn moment_count(&self) -> usize {
        2 * (self.nodes.len() - 1)
    }

    pub(super) fn contains(&self, c: f64) -> bool {
        c >= self.nodes[0] && c <= self.nodes[self.nodes.len() - 1]
    }
}

/// Intervals of a local window per lobe width, over twice the width on each side of the lobe: a
/// cusp of Fresnel inside the lobe (the critical angle of a dielectric onto a rarer medium) is
/// integrated against a density taken linear over one interval ([`dual_weights`]), which 1/16 of
/// the width makes a few 1e-5 off where 1/4 was a few 1e-3.
const LOBE_STEPS_PER_WIDTH: f64 = 16.0;

/// Per interval of `nodes`, the weights `(phi_left, phi_right)` such that
/// `m0 phi_left + m1 phi_right = ∫ f rho dc` for the density `rho` linear over the interval whose
/// moments are `m0 = ∫ (1 - t) rho dc` and `m1 = ∫ t rho dc` (`t` from 0 to 1 across it). With
/// `J0 = ∫ f dt` and `J1 = ∫ f t dt` over the interval, `phi_left = 4 J0 - 6 J1` and
/// `phi_right = 6 J1 - 2 J0`: `f` at the ends when `f` is linear, and unlike a projection on the
/// hats (whose Gram solve spreads a cusp's error to every node) each interval on its own, so a
/// cusp costs only the samples of its own interval. `J0` and `J1` are taken by [`quadrature`],
/// split at `kinks` and through `c = kink + s^2` after one.
pub(super) fn dual_weights(nodes: &[f64], f: impl Fn(f64) -> f64, kinks: &[f64]) -> Vec<[f64; 2]> {
    nodes
        .windows(2)
        .map(|interval| {
            let (a, b) = (interval[0], interval[1]);
            let width = b - a;
            let (mut j0, mut j1) = (0.0, 0.0);
            // Within two widths of a kink `f` bends like the square root that starts there, which
            // 4 points integrate to 1e-4 on the interval next to it: such intervals take 8. Away
            // from a kink an interval is a small part of the lobe's window over which `f` is smooth,
            // and 2 points (exact for `f` quadratic) are within 4e-6 of 8 over the whole FGD table
            // (`docs/integration.md`, "Narrow lobes").
            let near_kink = kinks.iter().any(|&c| c > a - 2.0 * width && c < b + 2.0 * width);
            let rule: &[(f64, f64)] = if near_kink { &GAUSS_LEGENDRE_8 } else { &GAUSS_LEGENDRE_2 };
            quadrature(a, b, kinks, rule, |c, w, jacobian| {
                let value = f(c) * w * jacobian / width;
                j0 += value;
                j1 += value * (c - a) / width;
            });
            [4.0 * j0 - 6.0 * j1, 6.0 * j1 - 2.0 * j0]
        })
        .collect()
}

/// The points of `rule` over `[a, b]` split at the `kinks` inside it (ascending), each piece mapped
/// from [-1, 1], through `c = kink + s^2` on a piece that starts at a kink (`dc = 2 s ds`), so that
/// a square root starting there is integrated as a polynomial: `visit(c, w, jacobian)` per point.
/// Inlined into its callers, so that their sums stay in registers instead of going through memory
/// at every point (the narrow lobes' corrections of the FGD table call it some 10^7 times).
#[inline(always)]
fn quadrature(a: f64, b: f64, kinks: &[f64], rule: &[(f64, f64)], mut visit: impl FnMut(f64, f64, f64)) {
    let mut lower = a;
    for upper in kinks.iter().copied().filter(|&c| c > a && c < b).chain(std::iter::once(b)) {
        let starts_at_kink = kinks.contains(&lower);
        for &(x, w) in rule {
            let (c, jacobian) = if starts_at_kink {
                let span = (upper - lower).sqrt();
                let s = 0.5 * span * (x + 1.0);
                (lower + s * s, 0.5 * span * 2.0 * s)
            } else {
                (lower + 0.5 * (upper - lower) * (x + 1.0), 0.5 * (upper - lower))
            };
            visit(c, w, jacobian);
        }
        lower = upper;
    }
}

/// Gauss–Legendre nodes and weights on [-1, 1], 2 points (exact for polynomials up to degree 3).
const GAUSS_LEGENDRE_2: [(f64, f64); 2] = [(-0.577_350_269_189_625_8, 1.0), (0.577_350_269_189_625_8, 1.0)];

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
pub(super) fn project_on_nodes(
    nodes: &[f64],
    f: impl Fn(f64) -> f64,
    kinks: &[f64],
    interval_error: Option<&mut [f64]>,
) -> Vec<f64> {
    let n = nodes.len() - 1;
    let mut moments = vec![0.0; n + 1];
    // (interval, c, f(c)) of every point f was evaluated at, when the error is wanted.
    let keep = interval_error.is_some();
    let mut evaluated = Vec::with_capacity(if keep { n * 8 + kinks.len() } else { 0 });
    for k in 0..n {
        let (a, b) = (nodes[k], nodes[k + 1]);
        let width = b - a;
        quadrature(a, b, kinks, &GAUSS_LEGENDRE_8, |c, w, jacobian| {
            let fc = f(c);
            if keep {
                evaluated.push((k, c, fc));
            }
            let value = fc * w * jacobian;
            let t = (c - a) / width;
            moments[k] += value * (1.0 - t);
            moments[k + 1] += value * t;
        });
        if keep {
            evaluated.extend(kinks.iter().filter(|&&c| c > a && c < b).map(|&c| (k, c, f(c))));
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
/// `(h_{k-1} + h_k) / 3` on the diagonal and `h_k / 6` beside it, `h_k` the interval widths.
fn solve_hat_gram(nodes: &[f64], b: Vec<f64>) -> Vec<f64> {
    let n = nodes.len() - 1;
    let width = |k: usize| nodes[k + 1] - nodes[k];
    let diagonal = |k: usize| {
        let left = if k > 0 { width(k - 1) } else { 0.0 };
        let right = if k < n { width(k) } else { 0.0 };
        (left + right) / 3.0
    };
    solve_symmetric_tridiagonal(diagonal, |k| width(k) / 6.0, b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrate::measure::dot;

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
    fn dual_weights_integrate_a_linear_density_exactly_across_a_kink() {
        // Nodes 0, 0.3, 1; density rho(c) = 1 + 2c; f = c, plus sqrt(c - 0.5) past 0.5: a cusp
        // inside the second interval that starts at the kink, as Fresnel's past a critical angle.
        // Moments per interval m0 = ∫ (1 - t) rho, m1 = ∫ t rho.
        let nodes = [0.0, 0.3, 1.0];
        let f = |c: f64| (c - 0.5f64).max(0.0).sqrt() + c;
        let weights = dual_weights(&nodes, f, &[0.5]);
        let rho = |c: f64| 1.0 + 2.0 * c;
        // Both by a fine midpoint rule (the cusp costs it ~1e-9 at 2^20 points).
        let fine = |g: &dyn Fn(f64) -> f64, a: f64, b: f64| {
            let n = 1 << 20;
            let h = (b - a) / n as f64;
            (0..n).map(|i| g(a + (i as f64 + 0.5) * h) * h).sum::<f64>()
        };
        let mut estimate = 0.0;
        for (k, w) in weights.iter().enumerate() {
            let (a, b) = (nodes[k], nodes[k + 1]);
            let m0 = fine(&|c| (1.0 - (c - a) / (b - a)) * rho(c), a, b);
            let m1 = fine(&|c| (c - a) / (b - a) * rho(c), a, b);
            estimate += m0 * w[0] + m1 * w[1];
        }
        let exact = fine(&|c| f(c) * rho(c), 0.0, 1.0);
        assert!((estimate - exact).abs() < 1e-7, "{estimate} vs {exact}");
        // A linear f reads its values at the ends of each interval.
        for (k, w) in dual_weights(&nodes, |c| 0.3 + 2.0 * c, &[]).iter().enumerate() {
            assert!((w[0] - (0.3 + 2.0 * nodes[k])).abs() < 1e-12 && (w[1] - (0.3 + 2.0 * nodes[k + 1])).abs() < 1e-12);
        }
    }

    #[test]
    fn a_window_finds_the_interval_a_binary_search_finds() {
        let basis = HatBasis { intervals: 256 };
        for (mu, width) in [(0.5, 1e-7), (1e-6, 1e-7), (1.0, 1e-8), (0.3, 0.01), (0.999, 2.5e-4), (0.01, 1e-3)] {
            let window = LocalHats::around(mu, width, basis);
            let (nodes, last) = (&window.nodes, window.nodes.len() - 2);
            let searched = |c: f64| nodes.partition_point(|&x| x <= c).saturating_sub(1).min(last);
            // Every node, its neighbours in f64, points between nodes, and beyond both ends.
            let mut probes = vec![-1.0, 2.0, nodes[0] - 1e-9, nodes[last + 1] + 1e-9];
            for pair in nodes.windows(2) {
                for c in
                    [pair[0], pair[0].next_down(), pair[0].next_up(), 0.5 * (pair[0] + pair[1]), pair[1].next_down()]
                {
                    probes.push(c);
                }
            }
            for c in probes {
                assert_eq!(window.interval_of(c), searched(c), "mu {mu} width {width}: c {c}");
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
            assert!(finest <= width / LOBE_STEPS_PER_WIDTH * 1.001, "mu {mu}: finest interval {finest:e}");
            assert!(nodes.len() < 160, "mu {mu}: {} nodes", nodes.len());
        }
    }
}
