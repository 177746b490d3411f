//! Interpolation error: a table as a renderer reads it, against the exact integral at random
//! points of its domain.
//!
//! The two error estimates of a build (the replicate spread and the reference nodes) are taken at
//! the nodes, where interpolation is exact: they say nothing of a table whose integrand turns
//! faster between nodes than linear interpolation follows (a step of total internal reflection at
//! low roughness, the grazing fall-off of a smooth interface). This check draws points uniformly
//! over a domain of lookup parameters, integrates each on its own by the deterministic
//! visible-normal quadrature ([`super::Kernel::exact_value`], [`VisibleNormalQuadrature`]: every
//! jump and kink of the integrand a panel edge, so its error is far below a Monte Carlo
//! estimate's at the same cost), and the pipeline compares every written file, read back and
//! sampled as a renderer samples it, with those values ([`compare`]).
//!
//! The scene build measures its slices the same way, over the ranges their lookups reach.

use serde::{Deserialize, Serialize};

use super::TableRecipe;
use crate::error::{Error, Result};
use crate::integrate::quadrature::VisibleNormalQuadrature;
use crate::integrate::{Progress, estimate_cells};
use crate::physics::henyey_greenstein::MIN_ROUGHNESS;
use crate::sampling::sequence::scramble_seed;
use crate::stats::ErrorSummary;
pub use crate::stats::InterpolationError;

/// How many random points an interpolation check takes per domain, and the quadrature of the
/// exact integral at each.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InterpolationConfig {
    /// Random points per domain (0 skips the check).
    pub points: usize,
    /// Gauss–Legendre nodes per panel of each point's exact integral
    /// ([`crate::integrate::quadrature`]).
    pub nodes: usize,
}

impl Default for InterpolationConfig {
    fn default() -> Self {
        InterpolationConfig { points: 2048, nodes: EXACT_NODES }
    }
}

/// Quadrature nodes per panel of the interpolation check's exact values where a table does not
/// need more: far below the interpolation errors the check measures, at 60 % of the cost of 8
/// nodes (`docs/integration.md`, "Error estimates", measured per table).
pub const EXACT_NODES: usize = 6;

impl InterpolationConfig {
    pub fn validate(&self, key: &str) -> Result<()> {
        if self.points > 0 {
            super::settings::check_quadrature_nodes(&format!("{key}.nodes"), self.nodes)?;
        }
        if self.points > MAX_POINTS {
            return Err(Error::invalid(
                format!("{key}.points"),
                format!("{}; allowed: 0 to {MAX_POINTS}", self.points),
            ));
        }
        Ok(())
    }
}

/// More points than this would make the check cost more than the table.
pub const MAX_POINTS: usize = 1 << 20;

/// The largest roughness of the low-roughness domain: smooth coats and metals, where the tables
/// turn fastest between nodes.
pub const SMOOTH_ALPHA_LIMIT: f64 = 0.05;

/// A box of lookup parameters, one range per parameter, that random points are drawn from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Domain {
    /// What the box is, in words, for the manifest.
    pub name: String,
    /// The lookup parameters, in the order the recipe takes them.
    pub parameters: Vec<String>,
    pub ranges: Vec<[f64; 2]>,
}

impl Domain {
    /// The box in words: `uniform over mu [0, 1], alpha [0.0001, 0.05], ...`.
    pub fn describe(&self) -> String {
        let ranges: Vec<String> =
            self.parameters.iter().zip(&self.ranges).map(|(p, [lo, hi])| format!("{p} [{lo}, {hi}]")).collect();
        format!("uniform over {}", ranges.join(", "))
    }
}

/// The domains a full table is checked over: the whole box of its lookup parameters, and the same
/// box cut to `alpha <= 0.05` (from the model's smallest lobe roughness, 1e-4) where the table has
/// an `alpha` parameter reaching there.
pub fn standard_domains(parameters: &[&str], ranges: &[[f64; 2]]) -> Vec<Domain> {
    let parameters: Vec<String> = parameters.iter().map(|p| p.to_string()).collect();
    let mut domains =
        vec![Domain { name: "whole domain".into(), parameters: parameters.clone(), ranges: ranges.to_vec() }];
    if let Some(a) = parameters.iter().position(|p| p == "alpha") {
        let [lo, hi] = ranges[a];
        let smooth = [lo.max(MIN_ROUGHNESS), hi.min(SMOOTH_ALPHA_LIMIT)];
        if smooth[0] < smooth[1] {
            let mut cut = ranges.to_vec();
            cut[a] = smooth;
            domains.push(Domain { name: "low roughness".into(), parameters, ranges: cut });
        }
    }
    domains
}

/// `count` points drawn uniformly from the box `ranges`, reproducibly from `seed` and `stream`
/// (each coordinate from its own SplitMix64 hash, independent of the Sobol points of estimates).
pub fn random_points(ranges: &[[f64; 2]], count: usize, seed: u64, stream: u64) -> Vec<Vec<f64>> {
    (0..count)
        .map(|k| {
            ranges
                .iter()
                .enumerate()
                .map(|(d, &[lo, hi])| {
                    let u = scramble_seed(seed, stream.wrapping_mul(16).wrapping_add(d as u64), k as u32) as f64
                        / 4_294_967_296.0;
                    lo + u * (hi - lo)
                })
                .collect()
        })
        .collect()
}

/// Random points of one domain with the exact integral at each.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExactValues {
    pub domain: Domain,
    /// Each point's lookup parameters, in the domain's order.
    pub lookups: Vec<Vec<f64>>,
    /// Each point in the table's axes' quantities (what `Table::interpolate` takes).
    pub positions: Vec<Vec<f64>>,
    /// Each point's exact integral, one value per stored channel.
    pub exact: Vec<Vec<f64>>,
    /// Gauss–Legendre nodes per panel of the exact integrals.
    pub nodes: usize,
    /// Points placed where the error peaks ([`peak_lookups`]), the same for every seed: they add to
    /// the maximum, not to the RMS or the percentile, which describe the random points alone.
    #[serde(default)]
    pub peaks: Vec<PeakPoint>,
}

/// A point of [`peak_lookups`] with its exact integral.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PeakPoint {
    pub lookup: Vec<f64>,
    pub position: Vec<f64>,
    pub exact: Vec<f64>,
}

/// Offsets of the view cosine from the critical cosine `sqrt(1 - eta^2)` in [`peak_lookups`]: most
/// below it, where a smooth lobe reflects totally and the table blends in the nodes past the kink.
const CRITICAL_OFFSETS: [f64; 4] = [-0.012, -0.003, -0.0008, 0.002];
/// Relative indices below 1 along the critical angle in [`peak_lookups`].
const CRITICAL_ETAS: usize = 16;
/// Offsets of the view cosine and roughness from their smallest in [`peak_lookups`]: grazing views
/// and the smoothest lobes, where the integrands turn fastest.
const EDGE_OFFSETS: [f64; 2] = [0.0, 0.003];
/// Values of each other parameter in [`peak_lookups`]: the centres of its thirds. Not its ends: at
/// `eta = 1` exactly, `kappa = 0`, an interface reflects nothing, while at grazing views every
/// other `eta` reflects everything, a step no table of `eta` holds and no material looks up (the
/// model leaves an index-matched interface out).
const OTHER_VALUES: usize = 3;

/// Where a table of `mu` and `alpha` (and `eta`) is hardest to interpolate, the same for every
/// seed: random points land on a narrow peak by chance, so that a maximum over them alone changes
/// several-fold with the seed (FGD onto a rarer medium: 0.041 to 0.174 over four seeds).
/// - grazing views of the smoothest lobes (`mu` and `alpha` at and just above their smallest),
///   with every other parameter at the centres of its thirds;
/// - with an `eta` reaching below 1: along the critical angle, `mu` just below and above
///   `sqrt(1 - eta^2)` at 16 values of `eta`, for the smoothest lobes, with `kappa` (if any) at
///   its smallest, where the kink is sharpest.
///
/// A domain without `mu` and `alpha` has none.
pub fn peak_lookups(domain: &Domain) -> Vec<Vec<f64>> {
    let index = |name: &str| domain.parameters.iter().position(|p| p == name);
    let (Some(m), Some(a)) = (index("mu"), index("alpha")) else {
        return Vec::new();
    };
    let ranges = &domain.ranges;
    let inside = |d: usize, v: f64| v.clamp(ranges[d][0], ranges[d][1]);
    let near_smallest = |d: usize| {
        let mut values: Vec<f64> = EDGE_OFFSETS.iter().map(|o| inside(d, ranges[d][0] + o)).collect();
        values.dedup();
        values
    };
    let alphas = near_smallest(a);
    let mut peaks = Vec::new();
    // Every combination of the other parameters at their ends and middle.
    let others: Vec<usize> = (0..ranges.len()).filter(|&d| d != m && d != a).collect();
    let mut combinations: Vec<Vec<f64>> = vec![ranges.iter().map(|r| r[0]).collect()];
    for &d in &others {
        let [lo, hi] = ranges[d];
        let mut values: Vec<f64> =
            (0..OTHER_VALUES).map(|k| lo + (hi - lo) * (k as f64 + 0.5) / OTHER_VALUES as f64).collect();
        values.dedup();
        combinations = combinations
            .into_iter()
            .flat_map(|c| {
                values.iter().map(move |&v| {
                    let mut c = c.clone();
                    c[d] = v;
                    c
                })
            })
            .collect();
    }
    for base in &combinations {
        for &mu in &near_smallest(m) {
            for &alpha in &alphas {
                let mut point = base.clone();
                point[m] = mu;
                point[a] = alpha;
                peaks.push(point);
            }
        }
    }
    if let Some(e) = index("eta") {
        let [lo, hi] = ranges[e];
        let hi = hi.min(1.0);
        if lo < hi {
            for k in 0..CRITICAL_ETAS {
                // Cell centres of [lo, hi): eta = 1 has no critical angle.
                let eta = lo + (hi - lo) * (k as f64 + 0.5) / CRITICAL_ETAS as f64;
                let critical = (1.0 - eta * eta).sqrt();
                for offset in CRITICAL_OFFSETS {
                    let mu = critical + offset;
                    if mu < ranges[m][0] || mu > ranges[m][1] {
                        continue;
                    }
                    for &alpha in &alphas {
                        let mut point: Vec<f64> = ranges.iter().map(|r| r[0]).collect();
                        point[m] = mu;
                        point[a] = alpha;
                        point[e] = eta;
                        peaks.push(point);
                    }
                }
            }
        }
    }
    peaks
}

/// Draw `config.points` random points in each of `domains`, and add the points `peaks` places in
/// it; map each to the table's axes with `position_of`, and integrate each with `exact(quadrature,
/// position)` (one value per stored channel) by the quadrature of `config.nodes` nodes per panel.
#[allow(clippy::too_many_arguments)]
pub fn exact_values(
    label: &str,
    domains: Vec<Domain>,
    config: &InterpolationConfig,
    seed: u64,
    progress: &dyn Progress,
    peaks: impl Fn(&Domain) -> Vec<Vec<f64>>,
    position_of: impl Fn(&[f64]) -> Vec<f64>,
    exact: impl Fn(&VisibleNormalQuadrature, &[f64]) -> Vec<f64> + Sync,
) -> Result<Vec<ExactValues>> {
    if config.points == 0 {
        return Ok(Vec::new());
    }
    let quadrature = VisibleNormalQuadrature::new(config.nodes)?;
    domains
        .into_iter()
        .enumerate()
        .map(|(d, domain)| {
            let lookups = random_points(&domain.ranges, config.points, seed, 0xD0_0000 + d as u64);
            let peak_lookups = peaks(&domain);
            let random = lookups.len();
            let positions: Vec<Vec<f64>> = lookups.iter().chain(&peak_lookups).map(|l| position_of(l)).collect();
            let cells: Vec<u64> = (0..positions.len() as u64).collect();
            let mut values = estimate_cells(&cells, &format!("{label} interpolation check"), progress, |k| {
                exact(&quadrature, &positions[k as usize])
            });
            let mut positions = positions;
            let peaks = peak_lookups
                .into_iter()
                .zip(positions.split_off(random))
                .zip(values.split_off(random))
                .map(|((lookup, position), exact)| PeakPoint { lookup, position, exact })
                .collect();
            Ok(ExactValues { domain, lookups, positions, exact: values, nodes: config.nodes, peaks })
        })
        .collect()
}

/// [`exact_values`] for a full table over its recipe's domains.
pub fn exact_values_of(recipe: &dyn TableRecipe, seed: u64, progress: &dyn Progress) -> Result<Vec<ExactValues>> {
    exact_values(
        recipe.name(),
        recipe.interpolation_domains()?,
        &recipe.interpolation(),
        seed,
        progress,
        peak_lookups,
        |lookup| recipe.position_of(lookup),
        |quadrature, position| recipe.exact_value(quadrature, position),
    )
}

/// Compare values read at the points of `exact` with the exact integral: `read(position)` returns
/// one value per channel of `channels` (which name them).
pub fn compare(
    exact: &ExactValues,
    read_as: &str,
    channels: &[String],
    read: impl Fn(&[f64]) -> Vec<f64>,
) -> InterpolationError {
    let mut differences = Vec::with_capacity(exact.positions.len() * channels.len());
    let mut worst = (-1.0f64, String::new());
    let random = exact.lookups.iter().zip(&exact.positions).zip(&exact.exact);
    let peaks = exact.peaks.iter().map(|p| ((&p.lookup, &p.position), &p.exact));
    let mut random_max = 0.0f64;
    for (k, ((lookup, position), exact_value)) in random.chain(peaks).enumerate() {
        let values = read(position);
        for (c, name) in channels.iter().enumerate() {
            let difference = values[c] - exact_value[c];
            if difference.abs() > worst.0 {
                let at: Vec<String> =
                    exact.domain.parameters.iter().zip(lookup).map(|(p, v)| format!("{p} {v:.6}")).collect();
                worst = (
                    difference.abs(),
                    format!("{}, channel {name}: read {:.6}, exact {:.6}", at.join(", "), values[c], exact_value[c]),
                );
            }
            if k < exact.lookups.len() {
                differences.push(difference);
                random_max = random_max.max(difference.abs());
            }
        }
    }
    let magnitudes: Vec<f64> = differences.iter().map(|d| d.abs()).collect();
    let mut error = ErrorSummary::of_differences(differences);
    error.max = error.max.max(worst.0);
    let mut points = format!("{} points {}", exact.positions.len(), exact.domain.describe());
    if !exact.peaks.is_empty() {
        points += &format!(
            "; the max also over {} points where the error peaks (grazing views of the smoothest lobes, the critical angle)",
            exact.peaks.len()
        );
    }
    let mut compared = InterpolationError::new(&exact.domain.name, points, read_as, exact.nodes, error, worst.1);
    compared.p99 = crate::stats::quantile(&magnitudes, 0.99);
    compared.random_max = random_max;
    compared
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn random_points_fill_their_box_reproducibly() {
        let ranges = [[0.0, 1.0], [0.25, 0.5]];
        let points = random_points(&ranges, 4096, 7, 1);
        assert_eq!(points, random_points(&ranges, 4096, 7, 1));
        assert_ne!(points, random_points(&ranges, 4096, 7, 2));
        for (d, &[lo, hi]) in ranges.iter().enumerate() {
            let values: Vec<f64> = points.iter().map(|p| p[d]).collect();
            assert!(values.iter().all(|&v| v >= lo && v < hi));
            // Uniform: a quarter of the points in each quarter of the range, within 4 sigma.
            for q in 0..4 {
                let (a, b) = (lo + q as f64 * (hi - lo) / 4.0, lo + (q + 1) as f64 * (hi - lo) / 4.0);
                let n = values.iter().filter(|&&v| v >= a && v < b).count() as f64;
                assert!((n - 1024.0).abs() < 4.0 * (4096.0f64 * 0.25 * 0.75).sqrt(), "axis {d}, quarter {q}: {n}");
            }
        }
    }

    #[test]
    fn the_low_roughness_domain_cuts_alpha_only() {
        let domains = standard_domains(&["mu", "alpha", "eta"], &[[0.0, 1.0], [0.0, 1.0], [0.0, 1.0]]);
        assert_eq!(domains.len(), 2);
        assert_eq!(domains[1].ranges, vec![[0.0, 1.0], [MIN_ROUGHNESS, SMOOTH_ALPHA_LIMIT], [0.0, 1.0]]);
        // A table whose alpha range lies above the cut has no low-roughness domain.
        assert_eq!(standard_domains(&["mu", "alpha"], &[[0.0, 1.0], [0.2, 0.4]]).len(), 1);
        assert_eq!(standard_domains(&["x"], &[[0.0, 1.0]]).len(), 1);
    }

    /// Exact values `exact` at the random points 0.1 and 0.7 of the box [0, 1] in `x`, and `peaks`.
    fn two_points(exact: Vec<Vec<f64>>, peaks: Vec<PeakPoint>) -> ExactValues {
        let domain = Domain { name: "box".into(), parameters: vec!["x".into()], ranges: vec![[0.0, 1.0]] };
        let points = vec![vec![0.1], vec![0.7]];
        ExactValues { domain, lookups: points.clone(), positions: points, exact, nodes: 6, peaks }
    }

    #[test]
    fn compare_finds_the_worst_point_and_channel() {
        let exact = two_points(vec![vec![1.0, 2.0], vec![3.0, 4.0]], Vec::new());
        let names = vec!["a".to_string(), "b".to_string()];
        let error = compare(&exact, "test", &names, |p| if p[0] < 0.5 { vec![1.0, 2.5] } else { vec![3.0, 4.0] });
        assert_eq!(error.error.count, 4);
        assert_eq!(error.error.max, 0.5);
        assert!((error.error.rms - 0.25).abs() < 1e-15);
        assert_eq!(error.exact_nodes, 6);
        assert!(error.worst_at.starts_with("x 0.100000, channel b"), "{}", error.worst_at);
    }

    #[test]
    fn a_point_where_the_error_peaks_adds_to_the_max_and_not_to_the_rms_or_percentile() {
        let exact = two_points(
            vec![vec![1.0], vec![2.0]],
            vec![PeakPoint { lookup: vec![0.5], position: vec![0.5], exact: vec![0.0] }],
        );
        // Read 0.1 above exact at the random points, 0.9 at the peak.
        let read = |p: &[f64]| {
            vec![if p[0] == 0.5 {
                0.9
            } else if p[0] < 0.5 {
                1.1
            } else {
                2.1
            }]
        };
        let error = compare(&exact, "test", &["a".into()], read);
        assert_eq!(error.error.count, 2);
        assert_eq!(error.error.max, 0.9);
        assert!((error.random_max - 0.1).abs() < 1e-15, "{}", error.random_max);
        assert!((error.error.rms - 0.1).abs() < 1e-15, "{}", error.error.rms);
        assert!((error.p99 - 0.1).abs() < 1e-15, "{}", error.p99);
        assert!(error.worst_at.starts_with("x 0.500000"), "{}", error.worst_at);
        assert!(error.points.contains("1 points where the error peaks"), "{}", error.points);
    }

    #[test]
    fn peak_points_follow_the_critical_angle_and_the_grazing_smooth_edge_for_every_seed() {
        let domain = Domain {
            name: "onto a rarer medium".into(),
            parameters: ["mu", "alpha", "eta", "kappa"].map(String::from).to_vec(),
            ranges: vec![[0.0, 1.0], [0.0, 1.0], [0.0, 1.0], [0.0, 0.0]],
        };
        let peaks = peak_lookups(&domain);
        // Grazing views of the smoothest lobes: mu and alpha at their smallest.
        assert!(peaks.iter().any(|p| p[0] == 0.0 && p[1] == 0.0), "{peaks:?}");
        // Along the critical angle: mu just below sqrt(1 - eta^2), for 16 values of eta.
        let critical: Vec<&Vec<f64>> =
            peaks.iter().filter(|p| ((1.0 - p[2] * p[2]).sqrt() - p[0] - 0.0008).abs() < 1e-12).collect();
        assert_eq!(critical.len(), 16 * EDGE_OFFSETS.len(), "{peaks:?}");
        // Inside the box, never at eta = 1 (no critical angle, and a step no material looks up).
        for p in &peaks {
            for (v, [lo, hi]) in p.iter().zip(&domain.ranges) {
                assert!(lo <= v && v <= hi, "{p:?}");
            }
            assert!(p[2] < 1.0, "{p:?}");
        }
        // A table without a view cosine and a roughness has none.
        let other = Domain { name: "x".into(), parameters: vec!["x".into()], ranges: vec![[0.0, 1.0]] };
        assert!(peak_lookups(&other).is_empty());
    }

    #[test]
    fn exact_values_are_converged_at_the_default_nodes() {
        // Every table's exact integral at its default nodes per panel (the interpolation check's
        // and the reference nodes') against 16, at random points of each domain and at points
        // where the error peaks (critical angles, grazing views of the smoothest lobes): the
        // checks' figures must not be the quadrature's own error. `--nocapture` prints them.
        let config = crate::config::Config::default();
        let quadrature = |nodes| VisibleNormalQuadrature::new(nodes).unwrap();
        let fine = quadrature(16);
        for recipe in config.recipes() {
            let (check_nodes, reference_nodes) = (recipe.interpolation().nodes, recipe.reference().nodes);
            let (check, reference) = (quadrature(check_nodes), quadrature(reference_nodes));
            let (mut check_max, mut reference_max) = (0.0f64, 0.0f64);
            let domains = recipe.interpolation_domains().unwrap();
            // A table over one axis (`ggx_e_avg`, whose exact value integrates E at some 50 views)
            // is covered by a dozen points per domain.
            let per_domain = if recipe.axes().unwrap().len() == 1 { 12 } else { 200 / domains.len() };
            for (d, domain) in domains.iter().enumerate() {
                let mut lookups = random_points(&domain.ranges, per_domain, 11, d as u64);
                lookups.extend(peak_lookups(domain).into_iter().step_by(4));
                for lookup in &lookups {
                    let position = recipe.position_of(lookup);
                    let exact = recipe.exact_value(&fine, &position);
                    let off = |q: &VisibleNormalQuadrature| {
                        recipe
                            .exact_value(q, &position)
                            .iter()
                            .zip(&exact)
                            .map(|(a, b)| (a - b).abs())
                            .fold(0.0, f64::max)
                    };
                    check_max = check_max.max(off(&check));
                    reference_max = reference_max.max(off(&reference));
                }
            }
            println!(
                "{}: {check_nodes} nodes within {check_max:.2e} of 16, {reference_nodes} within {reference_max:.2e}",
                recipe.name()
            );
            assert!(check_max < 1e-4 && reference_max < 3e-5, "{}: {check_max:e}, {reference_max:e}", recipe.name());
        }
    }
}
